"""Scenario files (TOML): what to simulate, read into a :class:`Scenario` ready to run.

A scenario names the ``.mech`` file and gives the initial state, the input torque source, loads,
the driveline and vehicle, the apply signals of the shift elements (or a shift schedule) and the
solver settings; see the README section "Scenario files" for every key. ``include = [...]``
lists shared parameter files (a vehicle, an engine) whose tables are merged in first, so that the
including file's own values win (the thesis' hierarchical initialization files, 2.3.4). Paths are
relative to the file that names them.

Errors are :class:`~transgen.errors.ScenarioError` with ``FILE:LINE:COL: error: message``, the
line and a caret, located at the key or list entry that is wrong (positions from
:mod:`~transgen.sim.tomlpos`), in the included file when the value comes from one; a TOML syntax
error keeps tomllib's line and column. Everything is checked before a run: NaN and infinity
anywhere, types, names (with suggestions), ``[output]`` signals, shift times. Parsing never
evaluates code.
"""
from __future__ import annotations

import difflib
import math
import re
import sys
import tomllib
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from transgen.errors import Diagnostic, MechError, ModeError, ScenarioError
from transgen.kinematics import constraint_matrix, numeric_rank
from transgen.language import load_mechanism
from transgen.model import Mechanism

from .components import Driveline, EngineMap, EngineOnLink, EngineWithConverter, InputTorque, LinkLoad
from .schedule import AutoShift, ShiftEvent, ShiftTemplate, shift_trajectories
from .signals import Constant, Periodic, Pulse, Ramp, Signal, Sine, Step, Table
from .simulate import Powertrain, SolverOptions
from .tomlpos import key_positions
from .transmission import Transmission

__all__ = ["Scenario", "load_scenario", "parse_scenario", "bundled_scenarios", "output_signals", "RPM"]

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
    """A scenario file's text and the files it includes, for locating keys in error messages.

    ``includes`` are the sources of the included files in the order they are merged; a key's
    value comes from the last file that gives it, so errors about it are located there."""

    def __init__(self, path: Path, text: str):
        self.path = path
        self.lines = text.splitlines()
        self.positions = key_positions(text)
        self.includes: list[_Source] = []

    def _chain(self) -> list[_Source]:
        """Sources in the order of precedence: this file, then its includes, last one first."""
        return [self] + [s for inc in reversed(self.includes) for s in inc._chain()]

    def _depth(self, keys: tuple) -> int:
        return next((d for d in range(len(keys), 0, -1) if keys[:d] in self.positions), 0)

    def locate(self, keys: tuple) -> tuple[_Source, int, int]:
        """``(source, line, column)`` of the longest prefix of the key path ``keys`` that a file
        writes (this file or an included one); line 1, column 1 of this file if none does."""
        best, depth = self, 0
        for source in self._chain():
            d = source._depth(keys)
            if d > depth:
                best, depth = source, d
        if depth == 0:
            return self, 1, 1
        return (best, *best.positions[keys[:depth]])

    def error(self, keys, message: str) -> ScenarioError:
        source, line, col = self.locate(tuple(keys))
        return source.error_at(line, col, message)

    def error_at(self, line: int, col: int, message: str) -> ScenarioError:
        return _located(self.path, self.lines, line, col, message)


def _located(path: Path, lines: list[str], line: int, col: int, message: str) -> ScenarioError:
    """``FILE:LINE:COL: error: message``, the line and a caret (message and line bounded)."""
    text = lines[line - 1] if 0 < line <= len(lines) else ""
    return ScenarioError(Diagnostic(str(path), line, col, _bounded(message), text[:_SHOWN]).format())


_SHOWN = 200  # characters of a source line or value shown in a message


def _bounded(text: str, limit: int = 2000) -> str:
    return text if len(text) <= limit else text[:limit] + f"... ({len(text) - limit} more characters)"


def _shown(value) -> str:
    """``repr`` of a value for a message, bounded."""
    return _bounded(repr(value), _SHOWN)


def _non_finite(node, path: tuple = ()):
    """The key path of the first NaN or infinite number in parsed TOML data, else None."""
    if isinstance(node, float) and not math.isfinite(node) or isinstance(node, int) and abs(node) > sys.float_info.max:
        return path
    items = node.items() if isinstance(node, dict) else enumerate(node) if isinstance(node, list) else ()
    for k, v in items:
        found = _non_finite(v, path + (k,))
        if found is not None:
            return found
    return None


def _read(path: Path, text: str | None = None, seen: tuple[Path, ...] = ()) -> tuple[dict, _Source]:
    """The data of a scenario file merged over its includes, and its source (with the includes')."""
    if text is None:
        try:
            text = path.read_text(encoding="utf-8")
        except (OSError, UnicodeDecodeError) as exc:
            raise ScenarioError(f"{path}:1:1: error: cannot read scenario file ({exc})") from None
    try:
        data = tomllib.loads(text)
        source = _Source(path, text)
        bad = _non_finite(data)
    except RecursionError:
        raise _located(path, text.splitlines(), 1, 1, "arrays or tables nested too deeply") from None
    except tomllib.TOMLDecodeError as exc:
        m = re.search(r"\(at line (\d+), column (\d+)\)", str(exc))
        line, col = (int(m.group(1)), int(m.group(2))) if m else (1, 1)
        msg = re.sub(r"\s*\(at line \d+, column \d+\)", "", str(exc))
        raise _located(path, text.splitlines(), line, col, f"TOML syntax: {msg}") from None
    if bad is not None:
        name = ".".join(str(k) for k in bad)
        raise source.error(bad, f"'{name}' is not a finite number (NaN and infinity are refused; "
                                f"a number too large for a float, such as 1e400, reads as infinity)")
    includes = data.pop("include", [])
    if isinstance(includes, str):
        includes = [includes]
    if not isinstance(includes, list) or not all(isinstance(x, str) for x in includes):
        raise source.error(("include",), "include must be a file name or a list of file names")
    merged: dict = {}
    for k, inc in enumerate(includes):
        inc_path = path.parent / inc
        if not _is_file(inc_path):
            raise source.error(("include", k), f"included file '{inc}' not found (looked in {path.parent})")
        inc_path = inc_path.resolve()
        chain = seen + (path.resolve(),)
        if inc_path in chain:
            raise source.error(("include", k), f"include cycle: {' -> '.join(str(p) for p in chain + (inc_path,))}")
        inc_data, inc_source = _read(inc_path, None, chain)
        mech = inc_data.get("mechanism")
        if isinstance(mech, str) and _is_file(inc_path.parent / mech):
            inc_data["mechanism"] = str((inc_path.parent / mech).resolve())
        source.includes.append(inc_source)
        _merge(merged, inc_data)
    _merge(merged, data)
    return merged, source


def _is_file(path: Path) -> bool:
    """Whether ``path`` is a file (False, not an error, for a name the system refuses, e.g. too long)."""
    try:
        return path.is_file()
    except (OSError, ValueError):
        return False


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
        self.window: tuple[float, float] | None = None  # the simulated interval, once known

    def error(self, keys, message):
        return self.source.error(keys, message)

    def table(self, data, keys, allowed: set[str] | None = None) -> dict:
        node = data
        for k in keys:
            if isinstance(node, list) and isinstance(k, int) and k < len(node):
                node = node[k]
            else:
                node = node.get(k, {}) if isinstance(node, dict) else {}
        if not isinstance(node, dict):
            raise self.error(keys, f"[{'.'.join(map(str, keys))}] must be a table, not {_shown(node)}")
        if allowed is not None:
            for k in node:
                if k not in allowed:
                    close = difflib.get_close_matches(k, sorted(allowed), n=1)
                    hint = f"; did you mean '{close[0]}'?" if close else f" (known: {', '.join(sorted(allowed))})"
                    raise self.error(keys + (k,), f"unknown key '{k}' in [{'.'.join(map(str, keys)) or 'top level'}]{hint}")
        return node

    def number(self, table: dict, keys, name: str, default=None, minimum=None, positive=False) -> float:
        if name not in table:
            if default is None:
                raise self.error(keys, f"missing '{name}' in [{'.'.join(map(str, keys))}]")
            return default
        v = _as_float(table[name])
        if v is None:
            raise self.error(keys + (name,), f"'{name}' must be a finite number, not {_shown(table[name])}")
        if positive and v <= 0:
            raise self.error(keys + (name,), f"'{name}' must be positive, not {v:g}")
        if minimum is not None and v < minimum:
            raise self.error(keys + (name,), f"'{name}' must be >= {minimum:g}, not {v:g}")
        return v

    def numbers(self, table, keys, name, length=None) -> list[float]:
        v = table.get(name)
        if not isinstance(v, list) or not v:
            raise self.error(keys + (name,), f"'{name}' must be a non-empty list of numbers, not {_shown(v)}")
        out = []
        for k, x in enumerate(v):
            f = _as_float(x)
            if f is None:
                raise self.error(keys + (name, k), f"'{name}' must be a list of finite numbers: entry {k + 1} is {_shown(x)}")
            out.append(f)
        if length is not None and len(v) != length:
            raise self.error(keys + (name,), f"'{name}' must have {length} entries, not {len(v)}")
        return out

    def text(self, table: dict, keys, name: str, default: str | None = None) -> str:
        """A string value (``default`` when absent; required when ``default`` is None)."""
        if name not in table:
            if default is None:
                raise self.error(keys, f"missing '{name}' in [{'.'.join(map(str, keys))}]")
            return default
        v = table[name]
        if not isinstance(v, str):
            raise self.error(keys + (name,), f"'{name}' must be a string, not {_shown(v)}")
        return v

    def names(self, table: dict, keys, name: str) -> list[str]:
        """A list of names (strings or numbers, as gear names often are); empty when absent."""
        v = table.get(name, [])
        if not isinstance(v, list) or not all(isinstance(x, (str, int)) and not isinstance(x, bool) for x in v):
            raise self.error(keys + (name,), f"'{name}' must be a list of names, not {_shown(v)}")
        return [str(x) for x in v]

    def signal(self, spec, keys) -> Signal:
        """A signal from a number (constant) or a table ``{type = ..., ...}``."""
        if _as_float(spec) is not None:
            return Constant(_as_float(spec))
        if not isinstance(spec, dict):
            raise self.error(keys, "a signal is a finite number or a table like "
                                   "{ type = \"ramp\", t0 = 1, t1 = 2, v0 = 0, v1 = 1 }, not " + _shown(spec))
        kind = spec.get("type")
        if not isinstance(kind, str) or kind not in _SIGNAL_KEYS:
            raise self.error(keys, f"signal type must be one of {', '.join(_SIGNAL_KEYS)}, not {_shown(kind)}")
        known = _SIGNAL_KEYS[kind]
        for k in spec:
            if k != "type" and k not in known:
                close = difflib.get_close_matches(k, sorted(known), n=1)
                hint = f"; did you mean '{close[0]}'?" if close else f" (known: {', '.join(sorted(known))})"
                raise self.error(keys + (k,), f"unknown key '{k}' for a {kind} signal{hint}")
        num = lambda name, default=None, **kw: self.number(spec, keys, name, default, **kw)  # noqa: E731
        if kind == "constant":
            return Constant(num("value"))
        if kind == "step":
            return Step(num("t"), num("before"), num("after"))
        if kind == "ramp":
            t0, t1 = num("t0"), num("t1")
            if t1 <= t0:
                raise self.error(keys, f"ramp needs t1 > t0 (t0={t0:g}, t1={t1:g})")
            return Ramp(t0, t1, num("v0"), num("v1"))
        if kind == "sine":
            return Sine(num("offset", 0.0), num("amplitude"), num("frequency", positive=True), num("phase", 0.0))
        if kind in ("pulse", "square"):
            if kind == "square":
                period = num("period", positive=True)
                duty = num("duty", 0.5)
                if not 0 < duty < 1:
                    raise self.error(keys + ("duty",), f"duty must be between 0 and 1 (exclusive), not {duty:g}")
                t0, width = num("t0", 0.0), duty * period
            else:
                t0, width = num("t0"), num("width", positive=True)
                period = num("period", positive=True) if "period" in spec else None
                if period is not None and period <= width:
                    raise self.error(keys + ("period",), f"a pulse train needs period > width ({period:g} <= {width:g})")
            self._check_edges(keys, period, 2)
            return Pulse(t0, width, num("low", 0.0), num("high", 1.0), period)
        table = self._table(spec, keys)
        if kind == "table":
            return table
        span = table.times[-1] - table.times[0]
        period = num("period", span if span > 0 else None, positive=True)
        if period < span:
            raise self.error(keys + ("period",), f"period {period:g} s is shorter than the table's span {span:g} s")
        self._check_edges(keys, period, len(table.times) + 1)
        return Periodic(table, period)

    def _table(self, spec: dict, keys) -> Table:
        ts = self.numbers(spec, keys, "t")
        vs = self.numbers(spec, keys, "value", len(ts))
        for k in range(1, len(ts)):
            if ts[k] < ts[k - 1]:
                raise self.error(keys + ("t", k), f"table times 't' must not decrease ({ts[k]:g} after {ts[k - 1]:g}); "
                                                  f"two equal times are a jump")
        return Table(tuple(ts), tuple(vs))

    def _check_edges(self, keys, period: float | None, per_period: int) -> None:
        """Refuse a periodic signal with more than :data:`MAX_BREAKPOINTS` breakpoints in the
        simulated interval (each one restarts the integrator)."""
        if period is None or self.window is None:
            return
        count = (self.window[1] - self.window[0]) / period * per_period
        if count > MAX_BREAKPOINTS:
            raise self.error(keys + ("period",), f"period {period:g} s gives about {count:.3g} breakpoints in the "
                                                 f"simulated {self.window[1] - self.window[0]:g} s (at most {MAX_BREAKPOINTS})")


MAX_BREAKPOINTS = 100_000
"""Most breakpoints a periodic signal may have in a scenario's simulated interval."""

MAX_STEPS = 10_000_000
"""Most output samples (``output_dt``) and smallest steps (``max_step``) in the simulated interval."""

_SIGNAL_KEYS = {"constant": {"value"}, "step": {"t", "before", "after"}, "ramp": {"t0", "t1", "v0", "v1"},
                "table": {"t", "value"}, "sine": {"offset", "amplitude", "frequency", "phase"},
                "pulse": {"t0", "width", "period", "low", "high"}, "square": {"period", "duty", "t0", "low", "high"},
                "periodic": {"t", "value", "period"}}


def _as_float(v) -> float | None:
    """``v`` as a finite float, or None if it is not a finite number (bools are not numbers)."""
    if isinstance(v, bool) or not isinstance(v, (int, float)):
        return None
    try:
        f = float(v)
    except OverflowError:  # an integer beyond the float range
        return None
    return f if math.isfinite(f) else None


# --------------------------------------------------------------------------------- building


def load_scenario(path: str | Path) -> Scenario:
    """Read a scenario file (or the name of a bundled scenario) into a runnable :class:`Scenario`."""
    path = Path(path)
    if not _is_file(path) and path.stem in bundled_scenarios() and path.suffix in ("", ".toml"):
        path = bundled_scenarios()[path.stem]
    if not _is_file(path):
        close = difflib.get_close_matches(path.stem, list(bundled_scenarios()), n=1)
        hint = f"; did you mean '{close[0]}'?" if close else f" (bundled: {', '.join(bundled_scenarios())})"
        raise ScenarioError(f"{path}:1:1: error: no such scenario file{hint}")
    return _build(*_read(path), path)


def parse_scenario(text: str, path: str | Path = "scenario.toml") -> Scenario:
    """A :class:`Scenario` from the TOML text of a scenario file; ``path`` names it in messages,
    and includes and the mechanism are looked for relative to its folder."""
    path = Path(path)
    return _build(*_read(path, text), path)


def _build(data: dict, source: _Source, path: Path) -> Scenario:
    r = _Reader(source)
    r.table({"": data}, ("",), None)
    for k in data:
        if k not in _TOP_KEYS:
            close = difflib.get_close_matches(k, sorted(_TOP_KEYS), n=1)
            raise r.error((k,), f"unknown key '{k}'" + (f"; did you mean '{close[0]}'?" if close else ""))
    if "mechanism" not in data:
        raise r.error(("mechanism",), "missing 'mechanism = \"FILE.mech\"' (a path relative to the scenario, or a bundled name)")
    mech_ref = r.text(data, (), "mechanism")
    mech_path = path.parent / mech_ref
    try:
        mech = load_mechanism(mech_path if _is_file(mech_path) else mech_ref)
    except (MechError, OSError) as exc:
        raise r.error(("mechanism",), f"mechanism '{mech_ref}' has errors:\n{exc}") from None

    sim_t = r.table(data, ("simulation",), {"t_start", "t_end", "model", "method", "rtol", "atol", "max_step",
                                             "output_dt", "slip_tol", "coordinates", "modes"})
    comp_t = r.table(data, ("compliant",), {"stiffness", "damping"})
    model = r.text(sim_t, ("simulation",), "model", "switching")
    if model not in ("switching", "compliant"):
        raise r.error(("simulation", "model"), f"model must be 'switching' or 'compliant', not {_shown(model)}")
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
        stiffness=r.number(comp_t, ("compliant",), "stiffness", 1e5, positive=True),
        damping=r.number(comp_t, ("compliant",), "damping", 100.0, minimum=0.0),
    )
    if options.t_end <= options.t_start:
        raise r.error(("simulation", "t_end"), f"t_end ({options.t_end:g}) must be after t_start ({options.t_start:g})")
    if options.method not in ("RK45", "RK23", "DOP853", "Radau", "BDF", "LSODA"):
        raise r.error(("simulation", "method"), f"unknown integration method {_shown(options.method)}")
    duration = options.t_end - options.t_start
    for key, step in (("output_dt", options.output_dt), ("max_step", options.max_step)):
        if duration / step > MAX_STEPS:
            raise r.error(("simulation", key), f"{key} = {step:g} s gives {duration / step:.3g} steps in the simulated "
                                               f"{duration:g} s (at most {MAX_STEPS})")
    r.window = (options.t_start, options.t_end)

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
            fkeys = keys + ("friction",)
            f = r.table(data, fkeys, {"slip", "factor"})
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
                raise r.error(keys + ("energizing",), f"energizing must be 'positive' or 'negative', not {_shown(direction)}")
            extra["energizing"] = 1 if direction == "positive" else -1
        element_extra[name] = extra

    init_t = r.table(data, ("initial",), {"gear", "locked", "speeds", "speeds_rpm"})
    if "gear" in init_t:
        init_gear = _gear(r, init_t["gear"], ("initial", "gear"), gears)
        init_locked = list(gears[init_gear])
    else:
        init_locked = r.names(init_t, ("initial",), "locked")
        for k, x in enumerate(init_locked):
            if x not in element_names:
                close = difflib.get_close_matches(x, element_names, n=1)
                raise r.error(("initial", "locked", k), f"unknown element {_shown(x)}"
                                                         + (f"; did you mean '{close[0]}'?" if close else ""))

    # shift events (template) or automatic schedule -> apply signals
    shifts_report = []
    shifts_t = r.table(data, ("shifts",), {"template", "events"})
    if shifts_t:
        if "gear" not in init_t:
            raise r.error(("shifts",), "shift events need [initial] gear = ... (the gear they start from)")
        template = _template(r, data, ("shifts", "template"))
        events = []
        event_list = shifts_t.get("events", [])
        if not isinstance(event_list, list):
            raise r.error(("shifts", "events"), f"events must be a list of {_EVENT}, not {_shown(event_list)}")
        for k, ev in enumerate(event_list):
            keys = ("shifts", "events", k)
            if not isinstance(ev, dict) or not {"t", "from", "to"} <= set(ev):
                raise r.error(keys, f"each shift event is {_EVENT}, not {_shown(ev)}")
            ev = r.table(data, keys, {"t", "from", "to", "template"})
            source, target = (_gear(r, ev[x], keys + (x,), gears) for x in ("from", "to"))
            t = r.number(ev, keys, "t")
            if not options.t_start <= t < options.t_end:
                raise r.error(keys + ("t",), f"shift event {k + 1} at t = {t:g} s is outside the simulated interval "
                                             f"[{options.t_start:g}, {options.t_end:g}) s")
            tmpl = _template(r, data, keys + ("template",)) if "template" in ev else template
            events.append(ShiftEvent(t, source, target, tmpl))
        try:
            signals = shift_trajectories(gears, init_gear, events, element_names)
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

    sim_coords = r.names(sim_t, ("simulation",), "coordinates") if "coordinates" in sim_t else None
    try:
        tr = Transmission(mech, element_extra, sim_coords, r.text(sim_t, ("simulation",), "modes", "auto"))
    except (ModeError, ValueError) as exc:
        raise r.error(("simulation",), f"cannot model the transmission: {exc}") from None

    w0 = _initial_speeds(r, mech, tr, init_t, init_locked)
    components = _components(r, data, mech, tr)
    controllers = []
    auto_t = r.table(data, ("auto_shift",), {"order", "throttle", "upshift_rpm", "downshift_rpm", "template",
                                             "min_interval", "throttle_signal"})
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
        min_interval = r.number(auto_t, keys, "min_interval", 2.0, minimum=0.0)
        try:
            controllers.append(AutoShift(order, thr, up, down, throttle, tr.link_index[mech.output], gears,
                                         template, min_interval, gear=init_gear if "gear" in init_t else order[0]))
        except ValueError as exc:
            raise r.error(keys, str(exc)) from None
    out_t = r.table(data, ("output",), {"signals", "dt"})
    outputs = r.names(out_t, ("output",), "signals")
    pt = Powertrain(tr, components, w0, controllers)
    from .assembly import check_scenario_causality

    check_scenario_causality(r, pt)  # thesis 2.4: an algebraic loop in the assembly is refused before the run
    known = output_signals(pt)
    for k, name in enumerate(outputs):
        if name not in known:
            close = difflib.get_close_matches(name, known, n=1)
            raise r.error(("output", "signals", k), f"unknown output signal {_shown(name)}"
                                                    + (f"; did you mean '{close[0]}'?" if close else
                                                       f" (signals: {_bounded(', '.join(known), 400)})"))
    conv = data.get("converter", {})
    lockup = [e.name for e in mech.elements if conv and {e.link1, e.link2} == {conv.get("pump"), conv.get("turbine")}]
    title = data.get("title", path.stem)
    if not isinstance(title, str):
        raise r.error(("title",), f"title must be a string, not {_shown(title)}")
    return Scenario(path, title, mech, pt, options, shifts_report, outputs, data, lockup)


_EVENT = '{ t = ..., from = "1", to = "2" }'


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


def _gear(r: _Reader, value, keys, gears: dict) -> str:
    """A gear name of the gear table (given as a string or a number)."""
    name = str(value) if isinstance(value, (str, int)) and not isinstance(value, bool) else None
    if name not in gears:
        close = difflib.get_close_matches(name, list(gears), n=1) if name else []
        raise r.error(keys, f"unknown gear {_shown(value)}" + (f"; did you mean '{close[0]}'?" if close else
                                                             f" (gears: {', '.join(gears) or 'none'})"))
    return name


def _grid(r: _Reader, table: dict, keys, name: str, rows: int, columns: int, what: str) -> list[list[float]]:
    """A table ``name`` of ``rows`` rows of ``columns`` finite numbers (``what`` says what they are)."""
    v = table.get(name)
    if not isinstance(v, list) or len(v) != rows or not all(isinstance(row, list) and len(row) == columns for row in v):
        raise r.error(keys + (name,), f"{name} must be {rows} rows of {columns} {what}")
    out = []
    for k, row in enumerate(v):
        values = [_as_float(x) for x in row]
        if None in values:
            j = values.index(None)
            raise r.error(keys + (name, k, j), f"{name}: row {k + 1}, entry {j + 1} is {_shown(row[j])}, not a finite number")
        out.append(values)
    return out


def _template(r: _Reader, data: dict, keys) -> ShiftTemplate:
    fields = ShiftTemplate.__dataclass_fields__
    spec = r.table(data, keys, set(fields))
    return ShiftTemplate(**{k: r.number(spec, keys, k, minimum=0.0) for k in spec})


def _initial_speeds(r: _Reader, mech: Mechanism, tr: Transmission, init_t: dict, locked: list[str]) -> np.ndarray:
    """All link speeds from the given ones and the kinematics of the initially locked elements."""
    given = {}
    for key, scale in (("speeds", 1.0), ("speeds_rpm", RPM)):
        table = init_t.get(key, {})
        if not isinstance(table, dict):
            raise r.error(("initial", key), f"{key} must be a table like {{ L1 = 100.0 }}, not {_shown(table)}")
        for link in table:
            if link not in tr.link_index:
                close = difflib.get_close_matches(link, tr.links, n=1)
                raise r.error(("initial", key, link), f"unknown link {_shown(link)}"
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


def _components(r: _Reader, data: dict, mech: Mechanism, tr: Transmission) -> list:
    comps = []
    li = tr.link_index
    inp = r.table(data, ("input",), {"type", "torque", "speed_rpm", "throttle", "torque_table", "throttle_signal",
                                      "converter", "J_engine", "engine_speed_rpm", "idle_rpm", "engine", "turbo",
                                      "fuel_signal", "governor", "crank_model"})
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
        if kind == "engine_map":
            comps.append(EngineOnLink(engine, thr_signal, li[mech.input]))
        else:
            from .engine.torque_converter import TorqueConverter

            conv_ref = r.text(inp, keys, "converter", "") or None
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
        raise r.error(keys + ("type",), f"input type must be torque, engine_map, engine_converter or turbodiesel, not {_shown(kind)}")

    loads = data.get("load", [])
    if not isinstance(loads, list):
        raise r.error(("load",), "loads are an array of tables: [[load]]")
    for k, spec in enumerate(loads):
        keys = ("load", k)
        if not isinstance(spec, dict):
            raise r.error(keys, f"each [[load]] is a table, not {_shown(spec)}")
        spec = r.table(data, keys, {"torque", "signal", "c0", "c1", "c2"})
        name = r.text(spec, keys, "torque")
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
        params = (r.number(dl, keys, "stiffness", positive=True), r.number(dl, keys, "damping", 0.0, minimum=0.0),
                  r.number(dl, keys, "output_inertia", 0.0, minimum=0.0),
                  r.number(dl, keys, "final_drive", 1.0, positive=True),
                  r.number(dl, keys, "wheel_radius", 0.5, positive=True),
                  r.number(dl, keys, "vehicle_mass", 0.0, minimum=0.0),
                  r.number(dl, keys, "rolling_resistance", 0.0, minimum=0.0), r.number(dl, keys, "cd_a", 0.0, minimum=0.0),
                  r.number(dl, keys, "air_density", 1.2, positive=True), grade)
        try:
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
