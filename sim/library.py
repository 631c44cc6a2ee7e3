"""The bundled scenarios (the ``scenarios/`` folder), found without importing the simulator
(``transgen simulate --list`` needs no numeric library)."""
from __future__ import annotations

from pathlib import Path

__all__ = ["bundled_scenarios"]


def bundled_scenarios() -> dict[str, Path]:
    """Name -> path of the scenarios shipped in ``sim/scenarios``."""
    folder = Path(__file__).parent / "scenarios"
    return {p.stem: p for p in sorted(folder.glob("*.toml"))}
