"""Design synthesis: planetary tooth counts from target ratios (:mod:`.teeth`) and gear tables
from a mechanism's gearsets and shift elements (:mod:`~.synthesis.table`).

The names below load their module on first use, so that ``transgen --help`` stays fast.
"""
from __future__ import annotations

from ..lazy import lazy_module_attributes

_LAZY = {
    "AssemblyRules": "teeth", "RatioTarget": "teeth", "TeethSynthesis": "teeth", "TeethSolution": "teeth",
    "parse_ratio_targets": "teeth", "ratio_targets": "teeth", "planet_count": "teeth",
    "synthesize_teeth": "teeth", "completed_text": "teeth",
    "ShiftTable": "table", "TableSynthesis": "table", "gear_candidates": "table", "synthesize_table": "table",
    "table_score": "table",
}

__all__ = sorted(_LAZY)


__getattr__, __dir__ = lazy_module_attributes(__name__, _LAZY)
