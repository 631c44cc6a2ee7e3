"""The bundled library of real transmissions (the ``mechanisms/`` folder)."""
from __future__ import annotations

from importlib import resources
from pathlib import Path

__all__ = ["bundled_mechanisms", "bundled_path"]


def _folder() -> Path:
    return Path(str(resources.files("transgen.mechanisms")))


def bundled_mechanisms() -> dict[str, Path]:
    """Name (file stem) -> path of every bundled ``.mech`` file, sorted by name."""
    return {p.stem: p for p in sorted(_folder().glob("*.mech"))}


def bundled_path(name: str) -> Path | None:
    """Path of the bundled mechanism ``name`` (with or without ``.mech``), or ``None``."""
    stem = name[:-5] if name.endswith(".mech") else name
    return bundled_mechanisms().get(stem)
