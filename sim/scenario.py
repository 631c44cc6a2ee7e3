"""Scenario files (TOML): what to simulate, read into a :class:`Scenario` ready to run.

A scenario names the ``.mech`` file and gives the initial state, the input torque source, loads,
the driveline and vehicle, the apply signals of the shift elements (or a shift schedule) and the
solver settings; see the README section "Scenario files" for every key. ``include = [...]``
lists shared parameter files (a vehicle, an engine) whose tables are merged in first, so that the
including file's own values win (the thesis' hierarchical initialization files, 2.3.4). Paths are
relative to the file that names them.

Errors are :class:`~transgen.errors.ScenarioError` with ``FILE:LINE: error: message``; a TOML
syntax error keeps tomllib's line and column. Parsing never evaluates code.
"""
from __future__ import annotations

import difflib
import math
import re
import tomllib
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from transgen.errors import MechError, ModeError, ScenarioError
from transgen.kinematics import constraint_matrix, numeric_rank
from transgen.language import load_mechanism
from transgen.model import Mechanism

from .components import Driveline, EngineMap, EngineOnLink, EngineWithConverter, InputTorque, LinkLoad
from .schedule import AutoShift, ShiftEvent, ShiftTemplate, shift_trajectories
from .signals import Constant, Ramp, Signal, Sine, Step, Table
from .simulate import Powertrain, SolverOptions
from .transmission import Transmission

__all__ = ["Scenario", "load_scenario", "bundled_scenarios", "RPM"]

RPM = 2 * math.pi / 60

_TOP_KEYS = {"mechanism", "include", "title", "description", "simulation", "compliant", "initial", "input", "load",
             "driveline", "elements", "shifts", "auto_shift", "output", "report", "converter"}


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

    def run(self, progress=None):
        """Simulate; returns a :class:`~transgen.sim.result.Result`."""
        from .simulate import simulate

        result = simulate(self.powertrain, self.options, progress)
        result.meta.update({"scenario": str(self.path), "title": self.title, "lockup": list(self.lockup),
                            "input_link": self.mechanism.input, "output_link": self.mechanism.output})
        return result


def bundled_scenarios() -> dict[str, Path]:
    """Name -> path of the scenarios shipped in ``sim/scenarios``."""
    folder = Path(__file__).parent / "scenarios"
    return {p.stem: p for p in sorted(folder.glob("*.toml"))}


# ----------------------------------------------------------------------------- reading TOML


class _Source:
    """A scenario file's text, for locating keys in error messages."""

    def __init__(self, path: Path, text: str):
        self.path = path
        self.lines = text.splitlines()

    def locate(self, keys: tuple[str, ...]) -> int:
        """Best-effort line of a dotted key (table header and key), 1-based; 1 if not found."""
        line_no = 0
        section = None
        for depth in range(len(keys), 0, -1):
            header = re.compile(r"^\s*\[\[?\s*" + r"\s*\.\s*".join(re.escape(k) for k in keys[:depth]) + r"\s*\]\]?\s*(#.*)?$")
            for i, line in enumerate(self.lines):
                if header.match(line):
                    section = i
                    break
            if section is not None:
                rest = keys[depth:]
                if not rest:
                    return section + 1
                key_re = re.compile(r"^\s*" + re.escape(rest[0]) + r"\s*=")
                for i in range(section + 1, len(self.lines)):
                    if self.lines[i].lstrip().startswith("["):
                        break
                    if key_re.match(self.lines[i]) or re.search(r"[{,]\s*" + re.escape(rest[0]) + r"\s*=", self.lines[i]):
                        return i + 1
                return section + 1
        key_re = re.compile(r"^\s*" + re.escape(keys[0]) + r"\s*=") if keys else None
        for i, line in enumerate(self.lines):
            if key_re and key_re.match(line):
                return i + 1
            if keys and re.search(r"[{,\s]" + re.escape(keys[-1]) + r"\s*=", line):
                line_no = line_no or i + 1
        return line_no or 1

    def error(self, keys, message: str) -> ScenarioError:
        line = self.locate(tuple(str(k) for k in keys))
        text = self.lines[line - 1] if 0 < line <= len(self.lines) else ""
        return ScenarioError(f"{self.path}:{line}: error: {message}\n    {text}")


def _read(path: Path, seen: tuple[Path, ...] = ()) -> tuple[dict, _Source]:
    path = path.resolve()
    if path in seen:
        raise ScenarioError(f"{path}:1: error: include cycle: {' -> '.join(str(p) for p in seen + (path,))}")
    try:
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise ScenarioError(f"{path}:1: error: cannot read scenario file ({exc})") from None
    source = _Source(path, text)
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        m = re.search(r"\(at line (\d+), column (\d+)\)", str(exc))
        line, col = (int(m.group(1)), int(m.group(2))) if m else (1, 1)
        msg = re.sub(r"\s*\(at line \d+, column \d+\)", "", str(exc))
        shown = source.lines[line - 1] if 0 < line <= len(source.lines) else ""
        raise ScenarioError(f"{path}:{line}:{col}: error: TOML syntax: {msg}\n    {shown}\n    {' ' * (col - 1)}^") from None
    includes = data.pop("include", [])
    if isinstance(includes, str):
        includes = [includes]
    if not isinstance(includes, list):
        raise source.error(("include",), "include must be a list of file names")
    merged: dict = {}
    for inc in includes:
        inc_path = (path.parent / str(inc))
        if not inc_path.exists():
            raise source.error(("include",), f"included file '{inc}' not found (looked in {path.parent})")
        inc_data, _ = _read(inc_path, seen + (path,))
        if "mechanism" in inc_data:
            inc_data["mechanism"] = str((inc_path.parent / inc_data["mechanism"]).resolve()) \
                if (inc_path.parent / inc_data["mechanism"]).exists() else inc_data["mechanism"]
        _merge(merged, inc_data)
    _merge(merged, data)
    return merged, source


def _merge(base: dict, extra: dict) -> None:
    for k, v in extra.items():
        if isinstance(v, dict) and isinstance(base.get(k), dict):
            _merge(base[k], v)
        else:
            base[k] = v


class _Reader:
    """Typed access to the scenario data with located errors."""

    def __init__(self, source: _Source):
        self.source = source

    def error(self, keys, message):
        return self.source.error(keys, message)

    def table(self, data, keys, allowed: set[str] | None = None) -> dict:
        node = data
        for k in keys:
            node = node.get(k, {}) if isinstance(node, dict) else {}
        if not isinstance(node, dict):
            raise self.error(keys, f"[{'.'.join(keys)}] must be a table")
        if allowed is not None:
            for k in node:
                if k not in allowed:
                    close = difflib.get_close_matches(k, sorted(allowed), n=1)
                    hint = f"; did you mean '{close[0]}'?" if close else f" (known: {', '.join(sorted(allowed))})"
                    raise self.error(keys + (k,), f"unknown key '{k}' in [{'.'.join(keys) or 'top level'}]{hint}")
        return node

    def number(self, table: dict, keys, name: str, default=None, minimum=None, positive=False) -> float:
        if name not in table:
            if default is None:
                raise self.error(keys, f"missing '{name}' in [{'.'.join(keys)}]")
            return default
        v = table[name]
        if isinstance(v, bool) or not isinstance(v, (int, float)):
            raise self.error(keys + (name,), f"'{name}' must be a number, not {v!r}")
        v = float(v)
        if not math.isfinite(v):
            raise self.error(keys + (name,), f"'{name}' must be finite")
        if positive and v <= 0:
            raise self.error(keys + (name,), f"'{name}' must be positive, not {v:g}")
        if minimum is not None and v < minimum:
            raise self.error(keys + (name,), f"'{name}' must be >= {minimum:g}, not {v:g}")
        return v

    def numbers(self, table, keys, name, length=None) -> list[float]:
        v = table.get(name)
        if not isinstance(v, list) or not v or not all(isinstance(x, (int, float)) and not isinstance(x, bool) for x in v):
            raise self.error(keys + (name,), f"'{name}' must be a non-empty list of numbers")
        if length is not None and len(v) != length:
            raise self.error(keys + (name,), f"'{name}' must have {length} entries, not {len(v)}")
        return [float(x) for x in v]

    def signal(self, spec, keys) -> Signal:
        """A signal from a number (constant) or a table ``{type = ..., ...}``."""
        if isinstance(spec, (int, float)) and not isinstance(spec, bool):
            return Constant(float(spec))
        if not isinstance(spec, dict):
            raise self.error(keys, "a signal is a number or a table like { type = \"ramp\", t0 = 1, t1 = 2, v0 = 0, v1 = 1 }")
        kind = spec.get("type")
        kinds = {"constant": {"value"}, "step": {"t", "before", "after"}, "ramp": {"t0", "t1", "v0", "v1"},
                 "table": {"t", "value"}, "sine": {"offset", "amplitude", "frequency", "phase"}}
        if kind not in kinds:
            raise self.error(keys, f"signal type must be one of {', '.join(kinds)}, not {kind!r}")
        for k in spec:
            if k != "type" and k not in kinds[kind]:
                raise self.error(keys, f"unknown key '{k}' for a {kind} signal (known: {', '.join(sorted(kinds[kind]))})")
        if kind == "constant":
            return Constant(self.number(spec, keys, "value"))
        if kind == "step":
            return Step(self.number(spec, keys, "t"), self.number(spec, keys, "before"), self.number(spec, keys, "after"))
        if kind == "ramp":
            t0, t1 = self.number(spec, keys, "t0"), self.number(spec, keys, "t1")
            if t1 <= t0:
                raise self.error(keys, f"ramp needs t1 > t0 (t0={t0:g}, t1={t1:g})")
            return Ramp(t0, t1, self.number(spec, keys, "v0"), self.number(spec, keys, "v1"))
        if kind == "sine":
            return Sine(self.number(spec, keys, "offset", 0.0), self.number(spec, keys, "amplitude"),
                        self.number(spec, keys, "frequency", positive=True), self.number(spec, keys, "phase", 0.0))
        ts = self.numbers(spec, keys, "t")
        vs = self.numbers(spec, keys, "value", len(ts))
        if any(b <= a for a, b in zip(ts, ts[1:])):
            raise self.error(keys, "table times 't' must be strictly increasing")
        return Table(tuple(ts), tuple(vs))


# --------------------------------------------------------------------------------- building


def load_scenario(path: str | Path) -> Scenario:
    """Read a scenario file (or the name of a bundled scenario) into a runnable :class:`Scenario`."""
    path = Path(path)
    if not path.exists() and path.stem in bundled_scenarios() and path.suffix in ("", ".toml"):
        path = bundled_scenarios()[path.stem]
    if not path.exists():
        raise ScenarioError(f"{path}:1: error: no such scenario file (bundled: {', '.join(bundled_scenarios())})")
    data, source = _read(path)
    r = _Reader(source)
    r.table({"": data}, ("",), None)
    for k in data:
        if k not in _TOP_KEYS:
            close = difflib.get_close_matches(k, sorted(_TOP_KEYS), n=1)
            raise r.error((k,), f"unknown key '{k}'" + (f"; did you mean '{close[0]}'?" if close else ""))
    if "mechanism" not in data:
        raise r.error(("mechanism",), "missing 'mechanism = \"FILE.mech\"' (a path relative to the scenario, or a bundled name)")
    mech_ref = str(data["mechanism"])
    mech_path = path.parent / mech_ref
    try:
        mech = load_mechanism(mech_path if mech_path.exists() else mech_ref)
    except MechError as exc:
        raise ScenarioError(f"{source.path}:{source.locate(('mechanism',))}: error: mechanism '{mech_ref}' has errors:\n{exc}") from None

    sim_t = r.table(data, ("simulation",), {"t_start", "t_end", "model", "method", "rtol", "atol", "max_step",
                                             "output_dt", "slip_tol", "coordinates", "modes"})
    comp_t = r.table(data, ("compliant",), {"stiffness", "damping"})
    model = sim_t.get("model", "switching")
    if model not in ("switching", "compliant"):
        raise r.error(("simulation", "model"), f"model must be 'switching' or 'compliant', not {model!r}")
    options = SolverOptions(
        t_start=r.number(sim_t, ("simulation",), "t_start", 0.0),
        t_end=r.number(sim_t, ("simulation",), "t_end"),
        model=model,
        method=str(sim_t.get("method", "DOP853" if model == "switching" else "Radau")),
        rtol=r.number(sim_t, ("simulation",), "rtol", 1e-8, positive=True),
        atol=r.number(sim_t, ("simulation",), "atol", 1e-8, positive=True),
        max_step=r.number(sim_t, ("simulation",), "max_step", math.inf, positive=True),
        output_dt=r.number(sim_t, ("simulation",), "output_dt", 1e-3, positive=True),
        slip_tol=r.number(sim_t, ("simulation",), "slip_tol", 1e-7, positive=True),
        stiffness=r.number(comp_t, ("compliant",), "stiffness", 1e5, positive=True),
        damping=r.number(comp_t, ("compliant",), "damping", 100.0, minimum=0.0),
    )
    if options.t_end <= options.t_start:
        raise r.error(("simulation", "t_end"), f"t_end ({options.t_end:g}) must be after t_start ({options.t_start:g})")
    if options.method not in ("RK45", "RK23", "DOP853", "Radau", "BDF", "LSODA"):
        raise r.error(("simulation", "method"), f"unknown integration method {options.method!r}")

    gears = {g.name: g.engaged for g in mech.gears}
    element_names = list(mech.element_names)
    elements_t = r.table(data, ("elements",), set(element_names))
    element_extra: dict[str, dict] = {}
    for name, spec in elements_t.items():
        keys = ("elements", name)
        spec = r.table(data, keys, {"apply", "friction", "gain", "energizing"})
        extra: dict = {}
        if "apply" in spec:
            extra["apply"] = r.signal(spec["apply"], keys + ("apply",))
        if "friction" in spec:
            f = r.table(spec, ("friction",), {"slip", "factor"})
            slip = r.numbers(f, keys + ("friction",), "slip")
            extra["friction"] = (tuple(slip), tuple(r.numbers(f, keys + ("friction",), "factor", len(slip))))
        if "gain" in spec:
            extra["gain"] = r.number(spec, keys, "gain", positive=True)
            direction = spec.get("energizing", "positive")
            if direction not in ("positive", "negative"):
                raise r.error(keys + ("energizing",), "energizing must be 'positive' or 'negative'")
            extra["energizing"] = 1 if direction == "positive" else -1
        element_extra[name] = extra

    init_t = r.table(data, ("initial",), {"gear", "locked", "speeds", "speeds_rpm"})
    if "gear" in init_t:
        if str(init_t["gear"]) not in gears:
            raise r.error(("initial", "gear"), f"unknown gear {init_t['gear']!r} (gears: {', '.join(gears)})")
        init_locked = list(gears[str(init_t["gear"])])
    else:
        init_locked = [str(x) for x in init_t.get("locked", [])]
        for x in init_locked:
            if x not in element_names:
                raise r.error(("initial", "locked"), f"unknown element {x!r}")

    # shift events (template) or automatic schedule -> apply signals
    shifts_report = []
    shifts_t = r.table(data, ("shifts",), {"template", "events"})
    if shifts_t:
        if "gear" not in init_t:
            raise r.error(("shifts",), "shift events need [initial] gear = ... (the gear they start from)")
        template = _template(r, shifts_t.get("template", {}), ("shifts", "template"))
        events = []
        for k, ev in enumerate(shifts_t.get("events", [])):
            keys = ("shifts", "events")
            if not isinstance(ev, dict) or not {"t", "from", "to"} <= set(ev):
                raise r.error(keys, "each shift event is { t = ..., from = \"1\", to = \"2\" }")
            for g in (str(ev["from"]), str(ev["to"])):
                if g not in gears:
                    raise r.error(keys, f"unknown gear {g!r} in shift event {k + 1} (gears: {', '.join(gears)})")
            tmpl = _template(r, ev.get("template", {}), keys) if "template" in ev else template
            events.append(ShiftEvent(r.number(ev, keys, "t"), str(ev["from"]), str(ev["to"]), tmpl))
        try:
            signals = shift_trajectories(gears, str(init_t["gear"]), events, element_names)
        except ValueError as exc:
            raise r.error(("shifts", "events"), str(exc)) from None
        from .report import Shift
        from .schedule import gear_elements

        for ev in events:
            on, off = gear_elements(gears, ev.source, ev.target)
            shifts_report.append(Shift(on, off, ev.t, f"{ev.source}-{ev.target}"))
        for name, sig in signals.items():
            if mech.element(name).kind != "oneway" and "apply" not in element_extra.get(name, {}):
                element_extra.setdefault(name, {})["apply"] = sig

    for name in init_locked:  # elements of the initial gear default to full apply
        element_extra.setdefault(name, {}).setdefault("apply", Constant(1.0))

    sim_coords = sim_t.get("coordinates")
    try:
        tr = Transmission(mech, element_extra, sim_coords, str(sim_t.get("modes", "auto")))
    except (ModeError, ValueError) as exc:
        raise r.error(("simulation",), f"cannot model the transmission: {exc}") from None

    w0 = _initial_speeds(r, mech, tr, init_t, init_locked)
    components = _components(r, data, mech, tr)
    controllers = []
    auto_t = r.table(data, ("auto_shift",), {"order", "throttle", "upshift_rpm", "downshift_rpm", "template",
                                             "min_interval", "throttle_signal"})
    if auto_t:
        keys = ("auto_shift",)
        order = [str(x) for x in auto_t.get("order", [])]
        for g in order:
            if g not in gears:
                raise r.error(keys + ("order",), f"unknown gear {g!r}")
        thr = r.numbers(auto_t, keys, "throttle")
        up = [[v * RPM for v in row] for row in auto_t.get("upshift_rpm", [])]
        down = [[v * RPM for v in row] for row in auto_t.get("downshift_rpm", [])]
        if len(up) != len(order) - 1 or len(down) != len(order) - 1 or any(len(x) != len(thr) for x in up + down):
            raise r.error(keys, f"upshift_rpm and downshift_rpm need {len(order) - 1} rows of {len(thr)} output speeds")
        throttle = r.signal(auto_t.get("throttle_signal", 1.0), keys + ("throttle_signal",))
        try:
            controllers.append(AutoShift(order, thr, up, down, throttle, tr.link_index[mech.output], gears,
                                         _template(r, auto_t.get("template", {}), keys + ("template",)),
                                         r.number(auto_t, keys, "min_interval", 2.0, minimum=0.0),
                                         gear=str(init_t.get("gear", order[0]))))
        except ValueError as exc:
            raise r.error(keys, str(exc)) from None
    out_t = r.table(data, ("output",), {"signals", "dt"})
    outputs = [str(x) for x in out_t.get("signals", [])]
    pt = Powertrain(tr, components, w0, controllers)
    from .assembly import check_scenario_causality

    check_scenario_causality(r, pt)  # thesis 2.4: an algebraic loop in the assembly is refused before the run
    conv = data.get("converter", {})
    lockup = [e.name for e in mech.elements if conv and {e.link1, e.link2} == {conv.get("pump"), conv.get("turbine")}]
    return Scenario(path, str(data.get("title", path.stem)), mech, pt, options, shifts_report, outputs, data, lockup)


def _template(r: _Reader, spec: dict, keys) -> ShiftTemplate:
    fields = ShiftTemplate.__dataclass_fields__
    for k in spec:
        if k not in fields:
            raise r.error(keys, f"unknown shift template key '{k}' (known: {', '.join(fields)})")
    return ShiftTemplate(**{k: r.number(spec, keys, k, minimum=0.0) for k in spec})


def _initial_speeds(r: _Reader, mech: Mechanism, tr: Transmission, init_t: dict, locked: list[str]) -> np.ndarray:
    """All link speeds from the given ones and the kinematics of the initially locked elements."""
    given = {}
    for key, scale in (("speeds", 1.0), ("speeds_rpm", RPM)):
        table = init_t.get(key, {})
        if not isinstance(table, dict):
            raise r.error(("initial", key), f"{key} must be a table like {{ L1 = 100.0 }}")
        for link, v in table.items():
            if link not in tr.link_index:
                close = difflib.get_close_matches(link, tr.links, n=1)
                raise r.error(("initial", key), f"unknown link {link!r}" + (f"; did you mean '{close[0]}'?" if close else ""))
            given[link] = float(v) * scale
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


def _components(r: _Reader, data: dict, mech: Mechanism, tr: Transmission) -> list:
    comps = []
    li = tr.link_index
    inp = r.table(data, ("input",), {"type", "torque", "speed_rpm", "throttle", "torque_table", "throttle_signal",
                                      "converter", "J_engine", "engine_speed_rpm", "idle_rpm", "engine", "turbo",
                                      "fuel_signal", "governor", "crank_model"})
    kind = inp.get("type", "torque")
    keys = ("input",)
    if kind == "torque":
        comps.append(InputTorque(r.signal(inp.get("torque", 0.0), keys + ("torque",)), li[mech.input]))
    elif kind in ("engine_map", "engine_converter"):
        speeds = [x * RPM for x in r.numbers(inp, keys, "speed_rpm")]
        throttle = r.numbers(inp, keys, "throttle")
        table = inp.get("torque_table")
        if not isinstance(table, list) or len(table) != len(throttle) or any(
                not isinstance(row, list) or len(row) != len(speeds) for row in table):
            raise r.error(keys + ("torque_table",), f"torque_table must be {len(throttle)} rows (throttles) of {len(speeds)} torques (speeds)")
        engine = EngineMap(tuple(speeds), tuple(throttle), tuple(tuple(float(x) for x in row) for row in table))
        thr_signal = r.signal(inp.get("throttle_signal", 1.0), keys + ("throttle_signal",))
        if kind == "engine_map":
            comps.append(EngineOnLink(engine, thr_signal, li[mech.input]))
        else:
            from .engine.torque_converter import TorqueConverter

            conv_ref = inp.get("converter")
            try:
                converter = TorqueConverter.load(r.source.path.parent / conv_ref) if conv_ref else TorqueConverter.load()
            except (OSError, ValueError) as exc:
                raise r.error(keys + ("converter",), f"cannot load the torque converter: {exc}") from None
            comps.append(EngineWithConverter(engine, thr_signal, converter,
                                             r.number(inp, keys, "J_engine", positive=True), li[mech.input],
                                             omega_start=r.number(inp, keys, "engine_speed_rpm", 700.0) * RPM,
                                             idle=r.number(inp, keys, "idle_rpm", 0.0) * RPM))
    elif kind == "turbodiesel":
        from .powertrain import turbodiesel_component

        comps.append(turbodiesel_component(r, inp, keys, mech, tr))
    else:
        raise r.error(keys + ("type",), f"input type must be torque, engine_map, engine_converter or turbodiesel, not {kind!r}")

    loads = data.get("load", [])
    if not isinstance(loads, list):
        raise r.error(("load",), "loads are an array of tables: [[load]]")
    for k, spec in enumerate(loads):
        keys = ("load",)
        if not isinstance(spec, dict):
            raise r.error(keys, "each [[load]] is a table")
        for key in spec:
            if key not in {"torque", "signal", "c0", "c1", "c2"}:
                raise r.error(keys, f"unknown key '{key}' in [[load]] {k + 1} (known: torque, signal, c0, c1, c2)")
        name = str(spec.get("torque", ""))
        if name not in {t.name for t in mech.loads}:
            raise r.error(keys, f"[[load]] {k + 1}: torque {name!r} is not a 'torque NAME LINK' of the mechanism "
                                f"(declared: {', '.join(t.name for t in mech.loads) or 'none'})")
        link = next(t.link for t in mech.loads if t.name == name)
        comps.append(LinkLoad(name, li[link], r.signal(spec.get("signal", 0.0), keys + ("signal",)),
                              r.number(spec, keys, "c0", 0.0), r.number(spec, keys, "c1", 0.0), r.number(spec, keys, "c2", 0.0)))

    conv = r.table(data, ("converter",), {"pump", "turbine", "pump_torque", "turbine_torque", "file"})
    if conv:
        from .powertrain import converter_component

        comps.append(converter_component(r, conv, ("converter",), mech, tr))

    dl = r.table(data, ("driveline",), {"output_inertia", "stiffness", "damping", "final_drive", "wheel_radius",
                                         "vehicle_mass", "rolling_resistance", "cd_a", "air_density", "grade",
                                         "grade_percent", "output_torque"})
    keys = ("driveline",)
    if "stiffness" in dl:
        grade = r.number(dl, keys, "grade", 0.0)
        if "grade_percent" in dl:
            grade = math.atan(r.number(dl, keys, "grade_percent") / 100.0)
        try:
            comps.append(Driveline(li[mech.output], r.number(dl, keys, "stiffness", positive=True),
                                   r.number(dl, keys, "damping", 0.0, minimum=0.0),
                                   r.number(dl, keys, "output_inertia", 0.0, minimum=0.0),
                                   r.number(dl, keys, "final_drive", 1.0, positive=True),
                                   r.number(dl, keys, "wheel_radius", 0.5, positive=True),
                                   r.number(dl, keys, "vehicle_mass", 0.0, minimum=0.0),
                                   r.number(dl, keys, "rolling_resistance", 0.0, minimum=0.0),
                                   r.number(dl, keys, "cd_a", 0.0, minimum=0.0),
                                   r.number(dl, keys, "air_density", 1.2, positive=True), grade))
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
