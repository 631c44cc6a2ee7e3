"""FMU export (FMI 2.0 / 3.0, Model Exchange and Co-Simulation) of a transgen transmission or
scenario: :func:`export_fmu`. See docs/fmu.md.

Modules: :mod:`.data` (the tables, from the simulator's own transmission), :mod:`.codegen` (the
generated C), :mod:`.description` (``modelDescription.xml``), :mod:`.build` (compiler, archive),
:mod:`.export` (the sources: ``.mech`` or scenario), :mod:`.cli` (``transgen fmu``); the C runtime
is in ``c/``.
"""
from .data import FmuError
from .export import export_fmu

__all__ = ["export_fmu", "FmuError"]
