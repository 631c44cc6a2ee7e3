"""Export a transmission or a scenario as an FMU (FMI 2.0 or 3.0, Model Exchange and/or
Co-Simulation): :func:`export_fmu`.

From a ``.mech`` file: the transmission alone; inputs ``T_in`` (input torque), ``T_out``
(output load torque), ``apply_<element>`` (apply fractions, capacity = apply x capacity).
From a scenario: its mechanism with the scenario's element data and initial speeds, and its
time signals built in as the inputs' defaults (an input the importer never sets follows the
scenario's signal, so the FMU alone reproduces ``transgen simulate``) and its driveline
(driveshaft spring-damper and vehicle) and its engine map (on the input link or behind the torque
converter) where it has them. Scenarios with other components (the turbodiesel, an automatic
schedule) are refused with a message naming what is not supported yet.
"""
from __future__ import annotations

import re
from pathlib import Path

from .build import RUNTIME, compile_library, platform_folder, write_fmu
from .codegen import model_data_h, model_signals_h
from .data import FmuData, FmuError, fmu_data
from .description import model_description

__all__ = ["export_fmu", "load_source", "fmu_files", "INTERFACES"]

INTERFACES = {"me": ("me",), "cs": ("cs",), "both": ("me", "cs")}
#: the model-independent runtime (``c/``): the FMI glue file of the version includes tg_model.c,
#: which includes the other two
RUNTIME_FILES = ("tg_model.c", "tg_matrices.c", "tg_values.c", "tg_decide.c", "tg_components.c", "tg_schedule.c")


def model_identifier(name: str) -> str:
    """A C identifier from a file name (the FMU's modelIdentifier and library name)."""
    ident = re.sub(r"[^A-Za-z0-9_]", "_", name) or "model"
    return ident if not ident[0].isdigit() else "m_" + ident


def load_source(source: str | Path, model_name: str, overrides=None) -> FmuData:
    """The FMU tables of ``source``: a ``.mech`` file (or bundled mechanism ``NAME.mech``), a
    scenario ``.toml`` file, or a bare name (a bundled scenario, else a bundled mechanism)."""
    from transgen.language import load_mechanism
    from transgen.library import bundled_path
    from transgen.sim.scenario.library import bundled_scenarios
    from transgen.sim.model.transmission import Transmission

    text = str(source)
    is_mech = text.endswith(".mech") or (not text.endswith(".toml") and not Path(text).is_file()
                                         and text not in bundled_scenarios() and bundled_path(text) is not None)
    if is_mech:
        if overrides:
            raise FmuError("--set applies to scenarios only, not to a .mech file")
        mech = load_mechanism(text)
        return fmu_data(Transmission(mech), model_name, mech.name, source=Path(text).name)
    return _scenario_data(text, model_name, overrides)


def _scenario_data(source: str, model_name: str, overrides) -> FmuData:
    from transgen.sim.model.components import Driveline, EngineOnLink, EngineWithConverter, InputTorque, LinkLoad
    from transgen.sim.scenario.load import load_scenario

    sc = load_scenario(source, overrides)
    pt = sc.powertrain
    tr = pt.transmission
    where = f"scenario {sc.path.name}"
    if sc.options.model != "switching":
        raise FmuError(f"{where}: the FMU export follows the switching model; this scenario uses the "
                       f"{sc.options.model} model")
    from transgen.sim.control.schedule import AutoShift

    if len(pt.controllers) > 1 or any(not isinstance(c, AutoShift) for c in pt.controllers):
        raise FmuError(f"{where}: only one automatic shift schedule ([auto_shift]) can be exported")
    signals, driveline, engine = {}, None, None
    for c in pt.components:
        form = c.kernel_form()
        if isinstance(c, InputTorque):
            signals["T_in"] = c.signal
        elif isinstance(c, LinkLoad) and form[2] == (0.0, 0.0, 0.0) and c.input_name == "T_out":
            signals["T_out"] = c.signal
        elif isinstance(c, Driveline):
            driveline = c
        elif isinstance(c, (EngineOnLink, EngineWithConverter)) and form is not None:
            engine = c
        else:
            kind = type(c).__name__
            what = {"TurbodieselSource": "the turbodiesel engine (its air path and turbocharger)",
                    "ConverterComponent": "a torque converter",
                    "EngineOnLink": "an engine map", "EngineWithConverter": "an engine map with a torque converter"}.get(kind, f"the component {form[0] if form else kind}")
            raise FmuError(f"{where}: {what} cannot be exported to an FMU by this version; supported: an input "
                           f"torque signal or an engine map (with a converter), an output torque signal or a driveline (export the mechanism NAME.mech and "
                           f"connect the rest in the importing tool)")
    for e in tr.elements:
        if e.kind != "oneway":
            signals[f"apply_{e.name}"] = e.apply
    return fmu_data(tr, model_name, sc.title, signals, pt.initial_speeds, sc.options.slip_tol, sc.options.t_end,
                    source=sc.path.name, driveline=driveline, engine=engine,
                    schedule=pt.controllers[0] if pt.controllers else None, rtol=sc.options.rtol)


def fmu_files(d: FmuData, fmi: int = 2, interface: str = "both") -> dict[str, bytes]:
    """The archive entries of the FMU of ``d``: model description, library, sources."""
    if fmi not in (2, 3):
        raise FmuError(f"--fmi must be 2 or 3, not {fmi}")
    if interface not in INTERFACES:
        raise FmuError(f"--interface must be me, cs or both, not {interface}")
    guid = d.guid(f"fmi{fmi}")
    glue = f"tg_fmi{fmi}.c"
    sources = {"model_data.h": model_data_h(d, guid), "model_signals.h": model_signals_h(d)}
    sources.update({name: (RUNTIME / name).read_text() for name in RUNTIME_FILES + (glue,)})
    folder, suffix = platform_folder(fmi)
    import tempfile

    with tempfile.TemporaryDirectory(prefix="transgen-fmu-lib-") as tmp:
        lib = Path(tmp, d.model_name + suffix)
        compile_library(sources, glue, fmi, lib)
        binary = lib.read_bytes()
    files = {"modelDescription.xml": model_description(d, fmi, INTERFACES[interface], guid).encode(),
             f"binaries/{folder}/{d.model_name}{suffix}": binary}
    files.update({f"sources/{name}": text.encode() for name, text in sources.items()})
    return files


def export_fmu(source: str | Path, output: str | Path, fmi: int = 2, interface: str = "both",
               overrides=None) -> Path:
    """Write the FMU of ``source`` (see :func:`load_source`) to ``output`` (``NAME.fmu``; ``NAME``
    becomes the model identifier) for FMI ``fmi`` (2 or 3) with ``interface`` ``"me"``, ``"cs"``
    or ``"both"``. Returns the path. The same input gives the same bytes."""
    output = Path(output)
    if output.suffix != ".fmu":
        raise FmuError(f"{output}: the output file must end in .fmu")
    d = load_source(source, model_identifier(output.stem), overrides)
    write_fmu(output, fmu_files(d, fmi, interface))
    return output
