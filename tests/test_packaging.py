"""pyproject.toml lists its packages by name, so a package folder it forgets is silently left out of
a non-editable wheel (an editable install still finds it, so no other test would notice)."""
from __future__ import annotations

import tomllib
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def test_every_package_folder_is_listed():
    setuptools = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))["tool"]["setuptools"]
    listed = set(setuptools["packages"])
    found = set()
    for package, folder in setuptools["package-dir"].items():
        for init in (ROOT / folder).rglob("__init__.py"):
            parts = init.parent.relative_to(ROOT / folder).parts
            found.add(".".join([package, *parts]))
    assert "transgen.drawing" in found
    assert found <= listed, f"package folders missing from pyproject.toml packages: {sorted(found - listed)}"
