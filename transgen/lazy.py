"""Names of a package loaded from their modules on first access (PEP 562 ``__getattr__``).

The packages ``transgen``, ``transgen.synthesis``, ``transgen.sim`` and ``transgen.sim.study`` export
their API this way, so that ``transgen --help`` and the commands that need no numeric library do not
import one.
"""
from __future__ import annotations

import importlib
import sys
from typing import Callable, Mapping

__all__ = ["lazy_module_attributes"]


def lazy_module_attributes(package: str, where: Mapping[str, str]) -> tuple[Callable, Callable]:
    """``__getattr__`` and ``__dir__`` for the module ``package``: each name of ``where`` comes from
    the submodule it maps to, imported on first access; the value is then kept in the package, so
    later accesses are plain look-ups."""

    def __getattr__(name: str):
        module = where.get(name)
        if module is None:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        value = getattr(importlib.import_module(f"{package}.{module}"), name)
        setattr(sys.modules[package], name, value)
        return value

    def __dir__() -> list[str]:
        return sorted(set(vars(sys.modules[package])) | set(where))

    return __getattr__, __dir__
