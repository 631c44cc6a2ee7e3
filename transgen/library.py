"""The bundled library of real transmissions (the ``mechanisms/`` folder)."""
from __future__ import annotations

import importlib.util
from pathlib import Path

__all__ = ["bundled_mechanisms", "bundled_path", "package_folder"]


def package_folder(package: str) -> Path:
    """The folder of the data package ``package`` (``"transgen.mechanisms"``) as installed (the
    package's own path, found without importing ``importlib.resources``, whose import costs
    start-up time)."""
    return Path(importlib.util.find_spec(package).submodule_search_locations[0])


def _folder() -> Path:
    return package_folder("transgen.mechanisms")


def bundled_mechanisms() -> dict[str, Path]:
    """Name (file stem) -> path of every bundled ``.mech`` file, sorted by name."""
    return {p.stem: p for p in sorted(_folder().glob("*.mech"))}


def bundled_path(name: str) -> Path | None:
    """Path of the bundled mechanism ``name`` (with or without ``.mech``), or ``None``."""
    stem = name[:-5] if name.endswith(".mech") else name
    return bundled_mechanisms().get(stem)
