"""Scenario files (TOML): what to simulate, read into a :class:`Scenario` ready to run.

A scenario names the ``.mech`` file and gives the initial state, the input torque source, loads,
the driveline and vehicle, the apply signals of the shift elements (or a shift schedule) and the
solver settings; see the README section "Scenario files" for every key. ``include = [...]``
lists shared parameter files (a vehicle, an engine) whose tables are merged in first, so that the
including file's own values win (the thesis' hierarchical initialization files, 2.3.4). Paths are
relative to the file that names them.

Reading the file (includes, positions, typed values, signals) is :mod:`.scenario.file`'s job;
this module builds the :class:`Scenario` from what it reads. Errors are
:class:`~transgen.errors.ScenarioError` with ``FILE:LINE:COL: error: message``, the
line and a caret, located at the key or list entry that is wrong (positions from
:mod:`~transgen.sim.scenario.tomlpos`), in the included file when the value comes from one; a TOML syntax
error keeps tomllib's line and column. Everything is checked before a run: NaN and infinity
anywhere, types, names (with suggestions), ``[output]`` signals, shift times. Parsing never
evaluates code.

:func:`load_scenario` takes ``overrides`` (dotted keys -> values, :mod:`.overrides`), set in
the merged data before the build so that the same checks apply (errors ``--set KEY: error:``),
and ``files`` (texts by absolute path, :mod:`.file_access`) to build a scenario without the
disk; :func:`scenario_files` collects those texts and :func:`scenario_keys` lists the keys.
"""
from __future__ import annotations

import difflib
import functools
import math
from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from transgen.errors import MechError, ModeError, ScenarioError
from transgen.kinematics import constraint_matrix, numeric_rank
from transgen.language import load_mechanism, parse_mechanism
from transgen.limits import LIMITS, limit
from transgen.model import Mechanism

from ..model.components import Driveline, EngineMap, EngineOnLink, EngineWithConverter, InputTorque, LinkLoad
from ..model.losses import loss_component
from ..model.mesh import MeshModel
from .loss_table import read_losses
from . import schema as S
from ..control.schedule import AutoShift, ShiftEvent, ShiftTemplate, shift_trajectories
from ..core.signals import Constant
from ..solve.simulate import Powertrain, SolverOptions
from .file_access import FileAccess
from .library import bundled_scenarios
from .file import MAX_STEPS, Reader, Source, as_float, bounded, read_source, shown
from ..model.transmission import Transmission

__all__ = ["Scenario", "load_scenario", "scenario_files", "scenario_keys", "scenario_path", "parse_scenario", "bundled_scenarios", "output_signals", "RPM"]

RPM = 2 * math.pi / 60



@dataclass
class Scenario:
    """A scenario ready to run: the powertrain, the solver options and what to report."""

    path: Path
    title: str
    mechanism: Mechanism
    powertrain: Powertrain
    options: SolverOptions
    shifts: list = field(default_factory=list)  # report.Shift, when known from the schedule
    outputs: list[str] = field(default_factory=list)
    data: dict = field(default_factory=dict)
    lockup: list[str] = field(default_factory=list)  # converter lock-up clutches (not gear shifts)
    #: the periodic signals the file gives, ``(key path, signal)``, and a function giving an error
    #: located at a key path (:mod:`.run_limits` checks the run's size with them)
    periodic: list = field(default_factory=list, repr=False, compare=False)
    locate: object = field(default=None, repr=False, compare=False)

    @property
    def gearbox_input(self) -> str:
        """The link the gearbox is driven at: the turbine of a ``[converter]`` between two links of
        the mechanism (the pump, the mechanism's input, is the engine side), else the input."""
        turbine = (self.data.get("converter") or {}).get("turbine")
        return turbine if isinstance(turbine, str) and turbine in {k.name for k in self.mechanism.links} \
            else self.mechanism.input

    def run(self, progress=None, start=None, t_end: float | None = None):
        """Simulate; returns a :class:`~transgen.sim.core.result.Result`. ``start``: a saved state
        (:mod:`.restart`) to run from, at its time; ``t_end``: stop there instead of at the
        scenario's end [s] (the result's ``state`` then starts a later run)."""
        from ..solve.simulate import simulate

        options = self.options
        if start is not None:
            options = replace(options, t_start=start.t)
        if t_end is not None:
            options = replace(options, t_end=t_end)
        result = simulate(self.powertrain, options, progress, start)
        result.meta.update({"scenario": str(self.path), "title": self.title, "lockup": list(self.lockup),
                            "input_link": self.mechanism.input, "output_link": self.mechanism.output,
                            "gearbox_input": self.gearbox_input})
        return result


# ----------------------------------------------------------------------------- reading TOML


# --------------------------------------------------------------------------------- building


def load_scenario(path: str | Path, overrides: Mapping[str, object] | None = None,
                  files: Mapping[str, str] | None = None) -> Scenario:
    """Read a scenario file (or the name of a bundled scenario) into a runnable :class:`Scenario`.

    ``overrides`` maps dotted keys to values (``{"driveline.vehicle_mass": 20000}``, see
    :mod:`transgen.sim.scenario.overrides`): each is set in the merged file data before the scenario is
    built, so every check applies to it. ``files`` maps absolute resolved paths to file texts:
    every file the scenario reads (the TOML file and its includes, the ``.mech`` file, converter
    tables, compressor and turbine maps) is taken from it instead of the disk when it is there
    (see :func:`scenario_files`)."""
    return _load(path, overrides, FileAccess(files))


def scenario_files(path: str | Path, overrides: Mapping[str, object] | None = None,
                   check=None) -> dict[str, str]:
    """Every file that loading the scenario reads (with ``overrides``), keyed as ``files`` of
    :func:`load_scenario` is: ``load_scenario(path, o, files=scenario_files(path, o))`` equals
    ``load_scenario(path, o)`` without the disk. The keys are absolute resolved paths, so on
    another machine (or in another folder) name the scenario by its key,
    ``str(scenario_path(path).resolve())``, not by a relative path. ``check``: a function called
    with the loaded scenario (a sweep checks the size of each run: :func:`.run_limits.check_run`)."""
    access = FileAccess()
    scenario = _load(path, overrides, access)
    if check is not None:
        check(scenario)
    return dict(access.read)


def scenario_keys(path: str | Path, overrides: Mapping[str, object] | None = None,
                  files: Mapping[str, str] | None = None) -> dict[str, object]:
    """Every settable dotted key of a scenario -> its current value (None where the file does not
    set it and the default applies); the mechanism's parameters as ``mech.NAME.PARAM``."""
    from .overrides import settable_keys

    scenario = load_scenario(path, overrides, files)
    return settable_keys(scenario.data, scenario.mechanism)


def scenario_path(path: str | Path, access: FileAccess | None = None) -> Path:
    """The scenario file ``path`` names: the file, or the bundled scenario of that name."""
    path, access = Path(path), access or FileAccess()
    if access.is_file(path):
        return path
    bundled = bundled_scenarios()
    if path.stem in bundled and path.suffix in ("", ".toml"):
        path = bundled[path.stem]
    if not access.is_file(path):
        close = difflib.get_close_matches(path.stem, list(bundled), n=1)
        hint = f"; did you mean '{close[0]}'?" if close else f" (bundled: {', '.join(bundled)})"
        raise ScenarioError(f"{path}:1:1: error: no such scenario file{hint}")
    return path


def _load(path: str | Path, overrides, access: FileAccess) -> Scenario:
    path = scenario_path(path, access)
    return _build(*read_source(path, None, (), access), path, overrides, access)


def parse_scenario(text: str, path: str | Path = "scenario.toml",
                   overrides: Mapping[str, object] | None = None) -> Scenario:
    """A :class:`Scenario` from the TOML text of a scenario file; ``path`` names it in messages,
    and includes and the mechanism are looked for relative to its folder."""
    path = Path(path)
    access = FileAccess()
    return _build(*read_source(path, text, (), access), path, overrides, access)


def _mechanism(r: Reader, path: Path, ref: str) -> Mechanism:
    """The mechanism ``ref`` names: a file relative to the scenario, or to the current folder, or
    a bundled name (as :func:`~transgen.language.load_mechanism` finds it), read through the
    scenario's file access."""
    from transgen.library import bundled_path

    def candidates():  # lazily: the bundled mechanisms are listed (a folder's glob) only when needed
        yield path.parent / ref
        yield Path(ref)
        yield bundled_path(Path(ref).name)

    for candidate in candidates():
        if candidate is not None and r.access.is_file(candidate):
            try:
                text = r.access.read_text(candidate)
            except (OSError, UnicodeDecodeError):
                break  # load_mechanism says why
            return _parsed(text, str(candidate))
    return load_mechanism(ref)


@functools.lru_cache(maxsize=16)
def _parsed(text: str, name: str) -> Mechanism:
    """:func:`~transgen.language.parse_mechanism`, remembered for the last texts: the runs of a
    sweep and an optimizer's candidates read the same mechanism (the model is immutable)."""
    return parse_mechanism(text, name)


def _build(data: dict, source: Source, path: Path, overrides=None, access: FileAccess | None = None) -> Scenario:
    from .overrides import apply_overrides, check_keys, mech_overrides

    apply_overrides(data, source, overrides)
    r = Reader(source, access)
    r.table({"": data}, ("",), None)
    for k in data:
        if k not in S.TOP_KEYS:
            close = difflib.get_close_matches(k, sorted(S.TOP_KEYS), n=1)
            raise r.error((k,), f"unknown key '{k}'" + (f"; did you mean '{close[0]}'?" if close else ""))
    if "mechanism" not in data:
        raise r.error(("mechanism",), "missing 'mechanism = \"FILE.mech\"' (a path relative to the scenario, or a bundled name)")
    mech_ref = r.text(data, (), "mechanism")
    try:
        mech = _mechanism(r, path, mech_ref)
    except (MechError, OSError) as exc:
        raise r.error(("mechanism",), f"mechanism '{mech_ref}' has errors:\n{exc}") from None
    mech = mech_overrides(mech, overrides)
    check_keys(overrides, data, mech)

    sim_t = r.table(data, ("simulation",), S.SIMULATION_KEYS)
    comp_t = r.table(data, ("compliant",), S.COMPLIANT_KEYS)
    model = r.text(sim_t, ("simulation",), "model", "switching")
    if model not in ("switching", "compliant"):
        raise r.error(("simulation", "model"), f"model must be 'switching' or 'compliant', not {shown(model)}")
    options = SolverOptions(
        t_start=r.number(sim_t, ("simulation",), "t_start", 0.0),
        t_end=r.number(sim_t, ("simulation",), "t_end"),
        model=model,
        method=r.text(sim_t, ("simulation",), "method", "DOP853" if model == "switching" else "Radau"),
        rtol=r.number(sim_t, ("simulation",), "rtol", 1e-8, positive=True),
        atol=r.number(sim_t, ("simulation",), "atol", 1e-8, positive=True),
        max_step=r.number(sim_t, ("simulation",), "max_step", math.inf, positive=True),
        output_dt=r.number(sim_t, ("simulation",), "output_dt", 1e-3, positive=True),
        slip_tol=r.number(sim_t, ("simulation",), "slip_tol", 1e-7, positive=True),
        energy_tol=r.number(sim_t, ("simulation",), "energy_tol", 1e-3, positive=True),
        stiffness=r.number(comp_t, ("compliant",), "stiffness", 1e5, positive=True),
        damping=r.number(comp_t, ("compliant",), "damping", 100.0, minimum=0.0),
    )
    if options.t_end <= options.t_start:
        raise r.error(("simulation", "t_end"), f"t_end ({options.t_end:g}) must be after t_start ({options.t_start:g})")
    if options.method not in ("RK45", "RK23", "DOP853", "Radau", "BDF", "LSODA"):
        raise r.error(("simulation", "method"), f"unknown integration method {shown(options.method)}")
    duration = options.t_end - options.t_start
    for key in ("rtol", "atol"):  # a tolerance below the floor never converges (transgen.limits)
        if getattr(options, key) < limit(key):
            raise r.error(("simulation", key), f"{key} = {getattr(options, key):g} is below the limit of "
                                               f"{limit(key):g}: {LIMITS[key].why}")
    for key, step in (("output_dt", options.output_dt), ("max_step", options.max_step)):
        if duration / step > MAX_STEPS:
            raise r.error(("simulation", key), f"{key} = {step:g} s gives {duration / step:.3g} steps in the simulated "
                                               f"{duration:g} s (at most {MAX_STEPS})")
    r.window = (options.t_start, options.t_end)

    gears = {g.name: g.engaged for g in mech.gears}
    from transgen.own_converter import own_converter

    own = own_converter(mech)
    lockup_set = frozenset({own.lockup}) if own else frozenset()  # no shift element (gear_swap)
    element_names = list(mech.element_names)
    elements_t = r.table(data, ("elements",), set(element_names))
    element_extra: dict[str, dict] = {}
    for name, spec in elements_t.items():
        keys = ("elements", name)
        spec = r.table(data, keys, S.ELEMENT_KEYS)
        extra: dict = {}
        if "apply" in spec:
            extra["apply"] = r.signal(spec["apply"], keys + ("apply",))
        if "friction" in spec:
            fkeys = keys + ("friction",)
            f = r.table(data, fkeys, S.FRICTION_KEYS)
            slip = r.numbers(f, fkeys, "slip")
            factor = r.numbers(f, fkeys, "factor", len(slip))
            if slip[0] < 0 or any(b <= a for a, b in zip(slip, slip[1:])):
                raise r.error(fkeys + ("slip",), "friction 'slip' must be increasing speeds >= 0 [rad/s]")
            if min(factor) < 0:
                raise r.error(fkeys + ("factor",), "friction 'factor' must be >= 0")
            extra["friction"] = (tuple(slip), tuple(factor))
        if "energizing" in spec and "gain" not in spec:
            raise r.error(keys + ("energizing",), "energizing goes with a self-energising 'gain'")
        if "gain" in spec:
            extra["gain"] = r.number(spec, keys, "gain", positive=True)
            direction = spec.get("energizing", "positive")
            if direction not in ("positive", "negative"):
                raise r.error(keys + ("energizing",), f"energizing must be 'positive' or 'negative', not {shown(direction)}")
            extra["energizing"] = 1 if direction == "positive" else -1
        element_extra[name] = extra

    init_t = r.table(data, ("initial",), S.INITIAL_KEYS)
    if "gear" in init_t:
        init_gear = _gear(r, init_t["gear"], ("initial", "gear"), gears)
        init_locked = list(gears[init_gear])
    else:
        init_locked = r.names(init_t, ("initial",), "locked")
        for k, x in enumerate(init_locked):
            if x not in element_names:
                close = difflib.get_close_matches(x, element_names, n=1)
                raise r.error(("initial", "locked", k), f"unknown element {shown(x)}"
                                                         + (f"; did you mean '{close[0]}'?" if close else ""))

    # shift events (template) or automatic schedule -> apply signals
    shifts_report = []
    requests: list = []  # (signal, keys) of the engine torque-request factors, multiplied (schedule docstring)
    shifts_t = r.table(data, ("shifts",), S.SHIFTS_KEYS)
    if shifts_t:
        if "gear" not in init_t:
            raise r.error(("shifts",), "shift events need [initial] gear = ... (the gear they start from)")
        template = _template(r, data, ("shifts", "template"), closed_loop=False)
        events = []
        event_list = shifts_t.get("events", [])
        if not event_list and "template" in shifts_t:
            raise r.error(("shifts", "template"), "a shift template shapes the shift events: give [shifts] events = "
                                                  f"[{_EVENT}, ...] (or use [auto_shift] template)")
        if not isinstance(event_list, list):
            raise r.error(("shifts", "events"), f"events must be a list of {_EVENT}, not {shown(event_list)}")
        for k, ev in enumerate(event_list):
            keys = ("shifts", "events", k)
            if not isinstance(ev, dict) or not {"t", "from", "to"} <= set(ev):
                raise r.error(keys, f"each shift event is {_EVENT}, not {shown(ev)}")
            ev = r.table(data, keys, S.EVENT_KEYS)
            source, target = (_gear(r, ev[x], keys + (x,), gears) for x in ("from", "to"))
            t = r.number(ev, keys, "t")
            if not options.t_start <= t < options.t_end:
                raise r.error(keys + ("t",), f"shift event {k + 1} at t = {t:g} s is outside the simulated interval "
                                             f"[{options.t_start:g}, {options.t_end:g}) s")
            tmpl = _template(r, data, keys + ("template",), closed_loop=False) if "template" in ev else template
            events.append(ShiftEvent(t, source, target, tmpl))
        try:
            signals = shift_trajectories(gears, init_gear, events, element_names, lockup_set)
        except ValueError as exc:
            raise r.error(("shifts", "events"), str(exc)) from None
        from ..analysis.report import Shift
        from ..control.schedule import gear_elements

        for ev in events:
            on, off = gear_elements(gears, ev.source, ev.target, lockup_set)
            shifts_report.append(Shift(on, off, ev.t, f"{ev.source}-{ev.target}"))
        for name, sig in signals.items():
            if mech.element(name).kind != "oneway" and "apply" not in element_extra.get(name, {}):
                element_extra.setdefault(name, {})["apply"] = sig
        from ..control.schedule import torque_request_signal

        request = torque_request_signal(events)
        if request is not None:
            first = next(k for k, ev in enumerate(events) if ev.template.torque_intervention)
            where = ("shifts", "events", first) + (("template",) if "template" in event_list[first] else ())
            requests.append((request, where if "template" in event_list[first] else ("shifts", "template")))

    for name in init_locked:  # elements of the initial gear default to full apply
        element_extra.setdefault(name, {}).setdefault("apply", Constant(1.0))

    sim_coords = r.names(sim_t, ("simulation",), "coordinates") if "coordinates" in sim_t else None
    losses = read_losses(r, data, mech, model)
    try:
        tr = Transmission(losses.mechanism(mech) if losses else mech, element_extra, sim_coords,
                          r.text(sim_t, ("simulation",), "modes", "auto"))
    except MechError as exc:  # a mode the simulator cannot run (as `transgen check` says)
        raise r.error(("mechanism",), f"mechanism '{mech_ref}' has errors:\n{exc}") from None
    except (ModeError, ValueError) as exc:
        where = ("simulation", "modes") if "modes" in sim_t else ("simulation",) if sim_t else ("mechanism",)
        raise r.error(where, f"cannot model the transmission: {exc}") from None

    w0 = _initial_speeds(r, mech, tr, init_t, init_locked)
    components = _components(r, data, mech, tr)
    if losses:
        components.append(loss_component(tr, losses.model, losses.kinds, losses.pump_link))
        if "mesh" in losses.kinds:
            tr.mesh = MeshModel(tr.mech, tr.graph, losses.eta0, losses.eta_pair)
    controllers = []
    auto_t = r.table(data, ("auto_shift",), S.AUTO_SHIFT_KEYS)
    if auto_t:
        keys = ("auto_shift",)
        order = r.names(auto_t, keys, "order")
        if len(order) < 2:
            raise r.error(keys + ("order",), "order needs at least two gears, e.g. [\"1\", \"2\"]")
        for k, g in enumerate(order):
            _gear(r, g, keys + ("order", k), gears)
        thr = r.numbers(auto_t, keys, "throttle")
        up, down = ([[v * RPM for v in row] for row in _grid(r, auto_t, keys, key, len(order) - 1, len(thr),
                                                              "output speeds [rpm] (a row per upshift, a column per throttle)")]
                    for key in ("upshift_rpm", "downshift_rpm"))
        throttle = r.signal(auto_t.get("throttle_signal", 1.0), keys + ("throttle_signal",))
        template = _template(r, data, keys + ("template",))
        shifts_of_order = {f"{a}-{b}" for a, b in zip(order, order[1:])} | {f"{b}-{a}" for a, b in zip(order, order[1:])}
        templates, speed_first = {}, {}
        for table_key, out in (("templates", templates), ("speed_first_templates", speed_first)):
            for name in r.table(data, keys + (table_key,), None):
                if name not in shifts_of_order:
                    close = difflib.get_close_matches(name, sorted(shifts_of_order), n=1)
                    raise r.error(keys + (table_key, name), f"{table_key}: {shown(name)} is no shift of the order "
                                  f"(\"SOURCE-TARGET\" of neighbouring gears" + (f"; did you mean '{close[0]}'?)" if close else ")"))
                where = keys + (table_key, name)
                out[name] = _template(r, data, where, template)  # over the schedule's template
        min_interval = r.number(auto_t, keys, "min_interval", 2.0, minimum=0.0)
        try:
            controllers.append(AutoShift(order, thr, up, down, throttle, tr.link_index[mech.output], gears,
                                         template, min_interval, gear=init_gear if "gear" in init_t else order[0],
                                         templates=templates, speed_first=speed_first, lockup=lockup_set,
                                         slips={e.name: tuple(float(c) for c in tr.P[i]) for i, e in enumerate(tr.elements)}))
        except ValueError as exc:
            raise r.error(keys, str(exc)) from None
        intervening = [name for name, tm in templates.items() if tm.torque_intervention]
        if template.torque_intervention or intervening:
            from ..control.schedule import ControllerRequest

            requests.append((ControllerRequest(controllers[-1]),
                             keys + (("template",) if template.torque_intervention else ("templates", intervening[0]))))
    if "driver" in data:  # a drive cycle's driver: it commands the throttle and the brakes
        from ..control.driver import attach_driver

        attach_driver(r, data, components, controllers, mech, tr, float(options.t_start))
    if "torque_request" in r.table(data, ("input",), S.INPUT_KEYS):
        requests.insert(0, (_request_signal(r, data, options), ("input", "torque_request")))
    if requests:
        _attach_request(r, components, requests)
    out_t = r.table(data, ("output",), S.OUTPUT_KEYS)
    outputs = r.names(out_t, ("output",), "signals")
    pt = Powertrain(tr, components, w0, controllers)
    _settle_driveshaft(r, init_t, pt, init_locked, float(options.t_start))
    from ..model.assembly import check_scenario_causality

    check_scenario_causality(r, pt)  # thesis 2.4: an algebraic loop in the assembly is refused before the run
    known = output_signals(pt)
    for k, name in enumerate(outputs):
        if name not in known:
            close = difflib.get_close_matches(name, known, n=1)
            raise r.error(("output", "signals", k), f"unknown output signal {shown(name)}"
                                                    + (f"; did you mean '{close[0]}'?" if close else
                                                       f" (signals: {bounded(', '.join(known), 400)})"))
    from transgen.own_converter import lockup_clutches

    conv = data.get("converter", {})
    lockup = list(lockup_clutches(mech, conv.get("pump"), conv.get("turbine"))) if conv else []
    title = data.get("title", path.stem)
    if not isinstance(title, str):
        raise r.error(("title",), f"title must be a string, not {shown(title)}")
    return Scenario(path, title, mech, pt, options, shifts_report, outputs, data, lockup, list(r.periodic), r.error)


_EVENT = '{ t = ..., from = "1", to = "2" }'


def _request_signal(r: Reader, data: dict, options: SolverOptions):
    """``[input] torque_request``: an engine torque-request factor [-] given as a signal (>= 0)."""
    keys = ("input", "torque_request")
    signal = r.signal(data["input"]["torque_request"], keys)
    times = np.linspace(options.t_start, options.t_end, 2001)
    times = np.union1d(times, [b for b in signal.breakpoints(options.t_start, options.t_end)])
    low = float(np.min(signal.sample(times)))
    if low < 0.0:
        raise r.error(keys, f"the torque-request factor must be >= 0 (1: the engine's own torque), it reaches {low:g}")
    return signal


def _attach_request(r: Reader, components: list, requests: list) -> None:
    """Give the scenario's engine its torque-request factor: the product of ``requests``
    ((signal, keys) pairs, the keys where each is asked for, for the error when the input has no
    engine). A map engine scales its torque (:meth:`EngineMap.requested`); the turbodiesel its
    fuel command (bounded by the full-load fuel at the current speed)."""
    from ..model.turbodiesel import TurbodieselSource
    from ..core.signals import Product

    signal = requests[0][0] if len(requests) == 1 else Product(tuple(s for s, _ in requests))
    engines = [c for c in components if isinstance(c, (EngineOnLink, EngineWithConverter, TurbodieselSource))]
    if not engines:
        raise r.error(requests[0][1], "an engine torque intervention needs an engine at the input ([input] type = "
                                      "\"engine_map\", \"engine_converter\" or \"turbodiesel\"; a prescribed torque has no engine "
                                      "to ask)")
    for c in engines:
        c.request = signal
        if isinstance(c, TurbodieselSource):  # the torque request acts on the fuel command
            c.fuel = Product((c.fuel, signal)) if c.fuel is not None else signal
            c.engine.rack = c.fuel.value


def output_signals(pt: Powertrain) -> list[str]:
    """Names of the signals a run of ``pt`` gives (the columns ``[output] signals`` may choose):
    link speeds, element slips, torques, applies, powers and states, the input and output torques,
    the mode, the energy integrals and the components' own signals."""
    tr = pt.transmission
    names = ["T_in", "T_out", "mode", "E_in", "E_dissipated", "E_load", "E_stored"] + [f"w_{k}" for k in tr.links]
    for e in tr.elements:
        names += [f"{p}_{e.name}" for p in ("slip", "t", "apply", "P", "locked")]
    w = np.asarray(pt.initial_speeds if pt.initial_speeds is not None else np.zeros(len(tr.links)), dtype=float)
    for c in pt.components:
        x = np.asarray(c.initial_state(w), dtype=float)
        _, signals, _ = c.sample(np.zeros(1), x.reshape(-1, 1), w.reshape(-1, 1))
        names += list(signals)
    return list(dict.fromkeys(names))


def _settle_driveshaft(r: Reader, init_t: dict, pt: Powertrain, locked: list[str], t0: float) -> None:
    """``[initial] driveshaft``: ``"unwound"`` (the default, no twist at the start) or
    ``"settled"`` (wound to the torque of steady acceleration, :mod:`transgen.sim.model.settle`)."""
    keys = ("initial", "driveshaft")
    start = r.text(init_t, ("initial",), "driveshaft", "unwound")
    if start not in ("unwound", "settled"):
        raise r.error(keys, f"driveshaft must be 'unwound' or 'settled', not {shown(start)}")
    if start == "unwound":
        return
    from ..model.settle import settled_driveshaft_torque

    driveline = next((c for c in pt.components if isinstance(c, Driveline)), None)
    if driveline is None:
        raise r.error(keys, "a settled driveshaft needs a [driveline] with a stiffness")
    tr = pt.transmission
    try:
        torque = settled_driveshaft_torque(pt, frozenset(tr.element_index[x] for x in locked), t0)
    except (ModeError, ValueError) as exc:
        raise r.error(keys, f"cannot settle the driveshaft: {exc}") from None
    driveline.initial_twist = torque / driveline.stiffness


def _gear(r: Reader, value, keys, gears: dict) -> str:
    """A gear name of the gear table (given as a string or a number)."""
    name = str(value) if isinstance(value, (str, int)) and not isinstance(value, bool) else None
    if name not in gears:
        close = difflib.get_close_matches(name, list(gears), n=1) if name else []
        raise r.error(keys, f"unknown gear {shown(value)}" + (f"; did you mean '{close[0]}'?" if close else
                                                             f" (gears: {', '.join(gears) or 'none'})"))
    return name


def _grid(r: Reader, table: dict, keys, name: str, rows: int, columns: int, what: str) -> list[list[float]]:
    """A table ``name`` of ``rows`` rows of ``columns`` finite numbers (``what`` says what they are)."""
    v = table.get(name)
    if not isinstance(v, list) or len(v) != rows or not all(isinstance(row, list) and len(row) == columns for row in v):
        raise r.error(keys + (name,), f"{name} must be {rows} rows of {columns} {what}")
    out = []
    for k, row in enumerate(v):
        values = [as_float(x) for x in row]
        if None in values:
            j = values.index(None)
            raise r.error(keys + (name, k, j), f"{name}: row {k + 1}, entry {j + 1} is {shown(row[j])}, not a finite number")
        out.append(values)
    return out


def _template(r: Reader, data: dict, keys, base: ShiftTemplate | None = None, closed_loop: bool = True) -> ShiftTemplate:
    """The shift template at ``keys`` (its keys over ``base``, default the ShiftTemplate defaults);
    ``closed_loop`` False: an open-loop shift (``[shifts]`` events) that cannot ease."""
    from ..control.schedule import EASE_BOUNDS

    fields = ShiftTemplate.__dataclass_fields__
    spec = r.table(data, keys, set(fields))
    values = {}
    for k in spec:
        values[k] = v = r.number(spec, keys, k, minimum=0.0)
        if k in EASE_BOUNDS and v > EASE_BOUNDS[k][1]:
            raise r.error(keys + (k,), f"'{k}' must be <= {EASE_BOUNDS[k][1]:g}, not {v:g}")
    if not closed_loop and values.get("ease_slip", 0.0) > 0:
        raise r.error(keys + ("ease_slip",), "easing acts on the measured oncoming slip: only an [auto_shift] "
                                             "template eases, not a [shifts] event's (set ease_slip = 0)")
    return replace(base, **values) if base is not None else ShiftTemplate(**values)


def _initial_speeds(r: Reader, mech: Mechanism, tr: Transmission, init_t: dict, locked: list[str]) -> np.ndarray:
    """All link speeds from the given ones and the kinematics of the initially locked elements."""
    given = {}
    for key, scale in (("speeds", 1.0), ("speeds_rpm", RPM)):
        table = init_t.get(key, {})
        if not isinstance(table, dict):
            raise r.error(("initial", key), f"{key} must be a table like {{ L1 = 100.0 }}, not {shown(table)}")
        for link in table:
            if link not in tr.link_index:
                close = difflib.get_close_matches(link, tr.links, n=1)
                raise r.error(("initial", key, link), f"unknown link {shown(link)}"
                                                      + (f"; did you mean '{close[0]}'?" if close else ""))
            given[link] = r.number(table, ("initial", key), link) * scale
    a = constraint_matrix(tr.graph, locked)
    n = len(tr.links)
    rows = [np.eye(n)[tr.link_index[k]] for k in given]
    m = np.vstack([a] + rows) if rows else a
    rhs = np.concatenate([np.zeros(a.shape[0]), list(given.values())])
    if numeric_rank(m) < n:
        free = n - numeric_rank(m)
        raise r.error(("initial",), f"the initial speeds leave {free} degree(s) of freedom undetermined: "
                                    f"give more link speeds in [initial] speeds (links: {', '.join(tr.links)})")
    w, *_ = np.linalg.lstsq(m, rhs, rcond=None)
    if np.linalg.norm(m @ w - rhs) > 1e-8 * max(1.0, np.linalg.norm(rhs)):
        raise r.error(("initial",), "the initial speeds contradict the kinematics of the initially locked elements")
    return w


def _components(r: Reader, data: dict, mech: Mechanism, tr: Transmission) -> list:
    comps = []
    li = tr.link_index
    inp = r.table(data, ("input",), S.INPUT_KEYS)
    keys = ("input",)
    kind = r.text(inp, keys, "type", "torque")
    if kind == "torque":
        comps.append(InputTorque(r.signal(inp.get("torque", 0.0), keys + ("torque",)), li[mech.input]))
    elif kind in ("engine_map", "engine_converter"):
        speeds = [x * RPM for x in r.numbers(inp, keys, "speed_rpm")]
        throttle = r.numbers(inp, keys, "throttle")
        if any(b <= a for a, b in zip(speeds, speeds[1:])) or any(b <= a for a, b in zip(throttle, throttle[1:])):
            raise r.error(keys + ("speed_rpm",), "speed_rpm and throttle must be increasing")
        table = _grid(r, inp, keys, "torque_table", len(throttle), len(speeds),
                      "torques [N*m] (a row per throttle, a column per speed)")
        engine = EngineMap(tuple(speeds), tuple(throttle), tuple(tuple(row) for row in table))
        thr_signal = r.signal(inp.get("throttle_signal", 1.0), keys + ("throttle_signal",))
        fuel = None
        if "fuel_map" in inp:
            from .fuel_file import read_fuel_map

            fuel = read_fuel_map(r, inp["fuel_map"], keys + ("fuel_map",), engine)
        if kind == "engine_map":
            comps.append(EngineOnLink(engine, thr_signal, li[mech.input], fuel=fuel,
                                      idle=r.number(inp, keys, "idle_rpm", 0.0, minimum=0.0) * RPM))
        else:
            from ..model.powertrain import read_converter

            converter = read_converter(r, inp, keys, "converter")
            comps.append(EngineWithConverter(engine, thr_signal, converter,
                                             r.number(inp, keys, "J_engine", positive=True), li[mech.input],
                                             omega_start=r.number(inp, keys, "engine_speed_rpm", 700.0) * RPM,
                                             idle=r.number(inp, keys, "idle_rpm", 0.0) * RPM, fuel=fuel))
    elif kind == "turbodiesel":
        from ..model.turbodiesel import turbodiesel_component

        comps.append(turbodiesel_component(r, inp, keys, mech, tr))
    else:
        raise r.error(keys + ("type",), f"input type must be torque, engine_map, engine_converter or turbodiesel, not {shown(kind)}")

    loads = data.get("load", [])
    if not isinstance(loads, list):
        raise r.error(("load",), "loads are an array of tables: [[load]]")
    for k, spec in enumerate(loads):
        keys = ("load", k)
        if not isinstance(spec, dict):
            raise r.error(keys, f"each [[load]] is a table, not {shown(spec)}")
        spec = r.table(data, keys, S.LOAD_KEYS)
        name = r.text(spec, keys, "torque")
        if name not in {t.name for t in mech.loads}:
            raise r.error(keys, f"[[load]] {k + 1}: torque {name!r} is not a 'torque NAME LINK' of the mechanism "
                                f"(declared: {', '.join(t.name for t in mech.loads) or 'none'})")
        link = next(t.link for t in mech.loads if t.name == name)
        comps.append(LinkLoad(name, li[link], r.signal(spec.get("signal", 0.0), keys + ("signal",)),
                              r.number(spec, keys, "c0", 0.0), r.number(spec, keys, "c1", 0.0), r.number(spec, keys, "c2", 0.0)))

    conv = r.table(data, ("converter",), S.CONVERTER_KEYS)
    if conv:
        from ..model.powertrain import converter_component

        comps.append(converter_component(r, conv, ("converter",), mech, tr))

    dl = r.table(data, ("driveline",), S.DRIVELINE_KEYS)
    keys = ("driveline",)
    if "stiffness" in dl:
        grade = r.number(dl, keys, "grade", 0.0)
        if "grade_percent" in dl:
            grade = math.atan(r.number(dl, keys, "grade_percent") / 100.0)
        params = (r.number(dl, keys, "stiffness", positive=True), r.number(dl, keys, "damping", 0.0, minimum=0.0),
                  r.number(dl, keys, "output_inertia", 0.0, minimum=0.0),
                  r.number(dl, keys, "final_drive", 1.0, positive=True),
                  r.number(dl, keys, "wheel_radius", 0.5, positive=True),
                  r.number(dl, keys, "vehicle_mass", 0.0, minimum=0.0),
                  r.number(dl, keys, "rolling_resistance", 0.0, minimum=0.0), r.number(dl, keys, "cd_a", 0.0, minimum=0.0),
                  r.number(dl, keys, "air_density", 1.2, positive=True), grade)
        try:
            if "brake" in dl or "driver" in data:  # wheel brakes (transgen.sim.model.brake): a torque [N*m] >= 0
                from ..model.brake import BrakedDriveline

                comps.append(BrakedDriveline(li[mech.output], *params,
                                             brake=r.signal(dl.get("brake", 0.0), keys + ("brake",))))
            else:
                comps.append(Driveline(li[mech.output], *params))
        except ValueError as exc:
            raise r.error(keys, str(exc)) from None
    elif "output_torque" in dl:
        sig = r.signal(dl["output_torque"], keys + ("output_torque",))
        comps.append(_OutputTorque(sig, li[mech.output]))
    return comps


class _OutputTorque(LinkLoad):
    """A prescribed output torque (no driveline): ``T_out = signal(t)``."""

    def __init__(self, signal, link):
        super().__init__("T_out", link, signal)

    def torques(self, t, x, w):
        return {"T_out": self.signal.value(t)}

    def power_in(self, t, x, w):
        return 0.0

    def load_power(self, t, x, w):
        return self.signal.value(t) * w[self.link]

    def signals(self, t, x, w):
        return {"T_out": self.signal.value(t)}
