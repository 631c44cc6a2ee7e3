"""Design synthesis: planetary tooth counts from target ratios (:mod:`.teeth`) and gear tables
from a mechanism's gearsets and shift elements (:mod:`.table`).

The names below load their module on first use, so that ``transgen --help`` stays fast.
"""
from __future__ import annotations

_LAZY = {
    "AssemblyRules": "teeth", "RatioTarget": "teeth", "TeethSynthesis": "teeth", "TeethSolution": "teeth",
    "parse_ratio_targets": "teeth", "ratio_targets": "teeth", "planet_count": "teeth",
    "synthesize_teeth": "teeth", "completed_text": "teeth",
    "ShiftTable": "table", "TableSynthesis": "table", "gear_candidates": "table", "synthesize_table": "table",
    "table_score": "table",
}

__all__ = sorted(_LAZY)


def __getattr__(name: str):
    module = _LAZY.get(name)
    if module is None:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    import importlib

    value = getattr(importlib.import_module(f".{module}", __name__), name)
    globals()[name] = value
    return value
