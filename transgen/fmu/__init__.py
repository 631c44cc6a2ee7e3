"""FMU export (FMI 2.0 / 3.0, Model Exchange and Co-Simulation) of a transgen transmission or
scenario: :func:`export_fmu`. See docs/fmu.md.

Modules: :mod:`.data` (the tables, from the simulator's own transmission), :mod:`.codegen` (the
generated C), :mod:`.description` (``modelDescription.xml``), :mod:`.build` (compiler, archive),
:mod:`.export` (the sources: ``.mech`` or scenario), :mod:`.cli` (``transgen fmu``); the C runtime
is in ``c/``.
"""
__all__ = ["export_fmu", "FmuError"]


def __getattr__(name: str):
    """The package's names, imported on first use: ``transgen --help`` builds the ``fmu``
    command's parser from :mod:`.cli` without loading numpy."""
    if name == "FmuError":
        from .data import FmuError
        return FmuError
    if name == "export_fmu":
        from .export import export_fmu
        return export_fmu
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
