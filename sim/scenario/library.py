"""The bundled scenarios (the ``scenarios/`` folder) and data files (the ``data/`` folder: torque
converters, compressor and turbine maps), found without importing the simulator (``transgen
simulate --list`` needs no numeric library)."""
from __future__ import annotations

from pathlib import Path

__all__ = ["bundled_scenarios", "bundled_data", "DATA_FOLDER"]

DATA_FOLDER = Path(__file__).resolve().parent.parent / "data"


def bundled_scenarios() -> dict[str, Path]:
    """Name -> path of the scenarios shipped in ``sim/scenarios``."""
    folder = Path(__file__).parent.parent / "scenarios"
    return {p.stem: p for p in sorted(folder.glob("*.toml"))}


def bundled_data(name: str) -> Path | None:
    """The data file shipped in ``sim/data`` that ``name`` names by its bare name
    (``torque_converter_car``, or with its ``.toml`` suffix), else None. A scenario refers to
    bundled data so (``converter = "torque_converter_car"``), never by the install's path, so
    that the file runs on any machine."""
    p = Path(name)
    if p.name != name or p.suffix not in ("", ".toml"):
        return None
    path = DATA_FOLDER / f"{p.stem}.toml"
    try:
        return path if path.is_file() else None
    except OSError:  # a name the file system cannot hold (longer than 255 bytes): no bundled file
        return None
