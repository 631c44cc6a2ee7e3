"""Scenario fuzzer: mutated scenario files through the API, expecting located errors or clean runs.

Every case starts from a bundled scenario (``sim/scenarios``, the shared include files among them)
or from a small synthetic one, mutates its data — a NaN or infinity anywhere, a number too large
for a float, a value of the wrong type (strings, tables, lists of lists, booleans), a missing or
unknown key, a signal of a random kind with random parameters, shift events inside and outside
the run, ``[output]`` signals known and unknown, includes that are missing, cyclic, not TOML or
faulty themselves — and sometimes the text (a character deleted or inserted, a line doubled, the
file cut short). The case is read with :func:`~transgen.sim.scenario.load.parse_scenario` (from text)
or :func:`~transgen.sim.scenario.load.load_scenario` (from a file next to its includes); a scenario
that loads is run over a short interval (``t_end`` capped ``0.2``-``0.5`` s after its start) under
a time limit (CPU seconds, and a wall-time bound of :data:`WALL_FACTOR` times as long).

Outcomes: ``refused`` (a :class:`~transgen.errors.TransgenError` at load, which must read
``FILE:LINE:COL: error:``), ``failed`` (the run stopped with a message), ``completed`` (every
result signal finite), and the failures of the fuzz: ``crash`` (any other exception: a
traceback), ``unlocated`` (a load error without its location), ``hang`` (over the time limit),
``nan`` (a completed run with a NaN in its result; an infinite value is counted apart, as
``completed with infinite values``: the engine's air-fuel ratio is infinite with the fuel cut off).

    from fuzz.fuzz_scenario import fuzz_scenarios
    report = fuzz_scenarios(seed=1, count=100)
    assert not report.failures, report.text()
"""
from __future__ import annotations

import contextlib
import dataclasses
import json
import math
import re
import shutil
import signal
import tempfile
import time
import tomllib
import traceback
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from transgen.errors import TransgenError
from transgen.sim.scenario.load import bundled_scenarios, load_scenario, parse_scenario

__all__ = ["FuzzReport", "fuzz_scenarios"]

LOCATED = re.compile(r"^[^\n]+:\d+:\d+: error: ", re.S)
FAILURES = ("crash", "unlocated", "hang", "nan")



class _Raw(str):
    """Text written into the TOML as it is (e.g. ``1e400``, which reads as infinity)."""


@dataclass
class FuzzReport:
    """Counts of the outcomes and the failing cases (their text and what happened)."""

    seed: int
    count: int
    outcomes: dict[str, int] = field(default_factory=dict)
    failures: list[dict] = field(default_factory=list)
    wall: float = 0.0
    slowest: float = 0.0

    def text(self) -> str:
        lines = [f"scenario fuzz: seed {self.seed}, {self.count} cases in {self.wall:.1f} s "
                 f"(slowest {self.slowest:.2f} s): "
                 + ", ".join(f"{k} {v}" for k, v in sorted(self.outcomes.items()))]
        for f in self.failures[:10]:
            lines.append(f"--- case {f['case']} ({f['outcome']}, from {f['origin']}):\n{f['detail']}\n{f['text'][:3000]}")
        return "\n".join(lines)


# ----------------------------------------------------------------------------- TOML writing


def _value(v) -> str:
    if isinstance(v, _Raw):
        return str(v)
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, float):
        return "nan" if math.isnan(v) else ("inf" if v > 0 else "-inf") if math.isinf(v) else repr(v)
    if isinstance(v, int):
        return str(v)
    if isinstance(v, str):
        return json.dumps(v)
    if isinstance(v, list):
        return "[" + ", ".join(_value(x) for x in v) + "]"
    if isinstance(v, dict):
        return "{ " + ", ".join(f"{_key(k)} = {_value(x)}" for k, x in v.items()) + " }"
    raise TypeError(type(v))


def _key(k: str) -> str:
    return k if re.fullmatch(r"[A-Za-z0-9_-]+", k) else json.dumps(k)


def dumps(data: dict) -> str:
    """TOML text of ``data``: top-level tables as ``[name]`` sections, everything else inline."""
    head = [f"{_key(k)} = {_value(v)}" for k, v in data.items() if not isinstance(v, dict)]
    body = []
    for k, v in data.items():
        if isinstance(v, dict):
            body.append(f"\n[{_key(k)}]")
            body += [f"{_key(a)} = {_value(b)}" for a, b in v.items()]
    return "\n".join(head + body) + "\n"


SYNTHETIC = dumps({"mechanism": "simple2", "simulation": {"t_end": 0.3}, "initial": {"gear": "1", "speeds": {"Li": 100.0}},
                   "input": {"torque": 100.0}, "driveline": {"output_inertia": 100.0, "stiffness": 1.2e4, "damping": 200.0}})
"""A small scenario of the thesis' simple transmission, mutated like the bundled ones."""

# ----------------------------------------------------------------------------- mutations


def _leaves(node, path=()):
    """Every key path of a nested dict/list structure (tables and lists included)."""
    items = node.items() if isinstance(node, dict) else enumerate(node) if isinstance(node, list) else ()
    for k, v in items:
        yield path + (k,)
        yield from _leaves(v, path + (k,))


def _get(node, path):
    for k in path:
        node = node[k]
    return node


def _random_signal(rng) -> dict:
    kind = rng.choice(["constant", "step", "ramp", "table", "sine", "pulse", "square", "periodic"])
    r = lambda lo=-1.0, hi=1.0: float(np.round(rng.uniform(lo, hi), 3))  # noqa: E731
    if kind == "constant":
        return {"type": kind, "value": r(0, 1)}
    if kind == "step":
        return {"type": kind, "t": r(0, 0.4), "before": r(0, 1), "after": r(0, 1)}
    if kind == "ramp":
        t0 = r(0, 0.3)
        return {"type": kind, "t0": t0, "t1": t0 + r(-0.05, 0.3), "v0": r(0, 1), "v1": r(0, 1)}
    if kind == "sine":
        return {"type": kind, "offset": r(), "amplitude": r(), "frequency": r(0.5, 50.0)}
    if kind == "pulse":
        spec = {"type": kind, "t0": r(0, 0.3), "width": r(0.0, 0.1), "low": r(0, 1), "high": r(0, 1)}
        if rng.random() < 0.6:
            spec["period"] = r(0.0, 0.2)
        return spec
    if kind == "square":
        return {"type": kind, "period": r(0.005, 0.2), "duty": r(0, 1), "low": r(0, 1), "high": r(0, 1)}
    n = int(rng.integers(1, 6))
    ts = sorted(r(0, 0.4) for _ in range(n))
    if n > 2 and rng.random() < 0.5:
        ts[1] = ts[2]  # a jump
    spec = {"type": kind, "t": ts, "value": [r(0, 1) for _ in range(n)]}
    if kind == "periodic" and rng.random() < 0.5:
        spec["period"] = r(0.0, 0.5)
    return spec


_BAD_VALUES = [math.nan, math.inf, -math.inf, _Raw("1e400"), _Raw("-1e999"), 10 ** 400, 0, -1, 1e-300, 1e300, 0.0,
               "abc", "", True, [], [1, 2], [[1, 2], [3]], ["a", "b"], {}, {"a": 1}, {"type": "table"},
               {"type": "table", "t": ["a"], "value": ["b"]}, {"type": "table", "t": [[0]], "value": [[1]]},
               [{"t": 1}], 1979]


def _mutate_data(data: dict, rng, folder: Path) -> None:
    """One random change of ``data`` in place."""
    paths = list(_leaves(data))
    choice = rng.random()
    if choice < 0.3 and paths:  # a leaf or table replaced by a bad value
        path = paths[int(rng.integers(len(paths)))]
        bad = _BAD_VALUES[int(rng.integers(len(_BAD_VALUES)))]
        _get(data, path[:-1])[path[-1]] = bad
    elif choice < 0.38 and paths:  # a key removed
        path = paths[int(rng.integers(len(paths)))]
        parent = _get(data, path[:-1])
        del parent[path[-1]]
    elif choice < 0.42:  # an unknown key
        tables = [p for p in paths if isinstance(_get(data, p), dict)]
        target = _get(data, tables[int(rng.integers(len(tables)))]) if tables else data
        target[str(rng.choice(["stiffnes", "t_ned", "aply", "zzz", "type2"]))] = 1.0
    elif choice < 0.72:  # a random signal somewhere a signal goes (or not)
        spot = rng.choice(["elements", "input", "load", "driveline", "anywhere"])
        sig = _random_signal(rng)
        if rng.random() < 0.3:  # with one parameter broken
            k = str(rng.choice([k for k in sig if k != "type"] or ["type"]))
            sig[k] = _BAD_VALUES[int(rng.integers(len(_BAD_VALUES)))]
        if spot == "elements":
            elements = data.setdefault("elements", {})
            if isinstance(elements, dict):
                names = list(elements) or ["C1", "C2"]
                entry = elements.setdefault(str(rng.choice(names)), {})
                if isinstance(entry, dict):
                    entry["apply"] = sig
        elif spot == "input" and isinstance(data.get("input"), dict):
            data["input"]["torque" if data["input"].get("type", "torque") == "torque" else "throttle_signal"] = sig
        elif spot == "load":
            data["load"] = [{"torque": "Tload", "signal": sig}]
        elif spot == "driveline":
            data["driveline"] = {"output_torque": sig}
        elif paths:
            path = paths[int(rng.integers(len(paths)))]
            _get(data, path[:-1])[path[-1]] = sig
    elif choice < 0.82:  # shift events, inside and outside the run
        t_end = data.get("simulation", {}).get("t_end", 0.3) if isinstance(data.get("simulation"), dict) else 0.3
        t = float(rng.choice([0.1, 0.05, t_end, t_end + 1.0, -1.0])) if isinstance(t_end, (int, float)) else 0.1
        data["shifts"] = {"events": [{"t": t, "from": str(rng.choice(["1", "2", "9"])), "to": str(rng.choice(["2", "1"]))}]}
        if rng.random() < 0.5:
            data["shifts"]["template"] = {"fill_time": float(rng.choice([0.0, 0.01, 0.05])), "ramp_time": 0.05}
    elif choice < 0.9:  # output signals
        data["output"] = {"signals": [str(rng.choice(["T_out", "w_L1", "w_Li", "T_ot", "slip_C1", "mode", "E_in", "x"]))
                                      for _ in range(int(rng.integers(1, 4)))]}
    else:  # includes
        kind = rng.choice(["missing", "self", "number", "not_toml", "faulty", "nested_list", "long", "mechanism",
                           "converter"])
        if kind == "missing":
            data["include"] = ["nowhere.toml"]
        elif kind == "long":  # a name the file system refuses
            data["include"] = ["x" * 5000 + ".toml"]
        elif kind == "mechanism":  # a scenario, a folder, a missing file, an over-long name as the mechanism
            data["mechanism"] = str(rng.choice(["case.toml", ".", "nowhere.mech", "m" * 5000, ""]))
        elif kind == "converter":
            data["converter"] = {"file": str(rng.choice(["case.toml", "nowhere.toml", ".", "c" * 5000]))}
        elif kind == "self":
            data["include"] = [str(rng.choice(["case.toml", "./shared/../case.toml", "../scenarios/case.toml"]))]
        elif kind == "number":
            data["include"] = 5
        elif kind == "nested_list":
            data["include"] = [["a.toml"]]
        elif kind == "not_toml":
            (folder / "junk.toml").write_text("this is [not toml\n", encoding="utf-8")
            data["include"] = ["junk.toml"]
        else:
            (folder / "faulty.toml").write_text("[driveline]\nstiffness = nan\n[input]\ntorque = \"x\"\n",
                                                encoding="utf-8")
            data["include"] = ["faulty.toml"]


def _mutate_text(text: str, rng) -> str:
    lines = text.splitlines(keepends=True)
    choice = rng.random()
    if choice < 0.3 and text:
        i = int(rng.integers(len(text)))
        return text[:i] + text[i + 1:]
    if choice < 0.6:
        i = int(rng.integers(len(text) + 1))
        return text[:i] + str(rng.choice(list("[]{}=\",#\n.'"))) + text[i:]
    if choice < 0.75 and lines:
        i = int(rng.integers(len(lines)))
        return "".join(lines[:i + 1] + lines[i:])
    if choice < 0.8:  # nested deeper than any parser's recursion
        n = int(rng.choice([10, 400, 3000]))
        return text + "deep = " + "[" * n + "]" * n + "\n"
    return text[:int(rng.integers(len(text) + 1))]


# ----------------------------------------------------------------------------- running


class _Timeout(Exception):
    pass


WALL_FACTOR = 6
"""A case is a hang after ``time_limit`` CPU seconds, or this many times ``time_limit`` seconds of
wall time (a case that blocks without computing): the machine may be shared, so the wall clock
alone would count a starved case as hung."""


@contextlib.contextmanager
def _time_limit(seconds: float):
    """Raise :class:`_Timeout` in the block after ``seconds`` of this process's CPU time or
    :data:`WALL_FACTOR` times as many seconds of wall time."""
    def handler(signum, frame):
        raise _Timeout("CPU" if signum == signal.SIGPROF else "wall")

    old = signal.signal(signal.SIGALRM, handler), signal.signal(signal.SIGPROF, handler)
    signal.setitimer(signal.ITIMER_PROF, seconds)
    signal.setitimer(signal.ITIMER_REAL, WALL_FACTOR * seconds)
    try:
        yield
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.setitimer(signal.ITIMER_PROF, 0)
        signal.signal(signal.SIGALRM, old[0])
        signal.signal(signal.SIGPROF, old[1])


def _limit_text(exc: _Timeout, time_limit: float) -> str:
    return (f"more than {time_limit:g} s of CPU" if str(exc) == "CPU"
            else f"more than {WALL_FACTOR * time_limit:g} s of wall time")


def warm_up(sources: dict[str, tuple[Path, str]]) -> None:
    """Run every source once over 0.2 s, untimed: the first run of a powertrain compiles its
    right-hand side (numba, 5-15 s of CPU once, cached on disk for later processes), a cost of
    the checkout, not of the case that happens to come first."""
    for path, text in sources.values():
        try:
            scenario = parse_scenario(text, path)
            o = scenario.options
            scenario.options = dataclasses.replace(o, t_end=o.t_start + min(0.2, o.t_end - o.t_start))
            scenario.run()
        except Exception:  # noqa: BLE001 - a source that does not run is fuzzed all the same
            pass


def _case(rng, sources: dict[str, tuple[Path, str]]):
    """(origin, folder, text, how) of a case: ``how`` is "text" or "file"; ``folder`` is the
    origin's (the case is read as ``folder/case.toml``, next to the files it includes)."""
    origin = str(rng.choice(list(sources)))
    path, text = sources[origin]
    folder = path.parent
    data = tomllib.loads(text)
    sim = data.setdefault("simulation", {}) if "mechanism" in data else None
    if isinstance(sim, dict):
        sim["t_end"] = float(sim.get("t_start", 0.0)) + float(np.round(rng.uniform(0.2, 0.5), 3))
    for _ in range(int(rng.integers(0, 3))):
        _mutate_data(data, rng, folder)
    text = dumps(data)
    if rng.random() < 0.15:
        text = _mutate_text(text, rng)
    return origin, folder, text, "text" if rng.random() < 0.5 else "file"


def _run_one(text: str, how: str, folder: Path, rng, time_limit: float) -> tuple[str, str]:
    """(outcome, detail) of one case."""
    try:
        with _time_limit(time_limit):
            start = time.perf_counter()
            path = folder / "case.toml"
            if how == "file":
                path.write_text(text, encoding="utf-8")
                scenario = load_scenario(path)
            else:
                scenario = parse_scenario(text, path)
            opts = scenario.options
            if opts.t_end - opts.t_start > 0.5:
                scenario.options = dataclasses.replace(opts, t_end=opts.t_start + float(rng.uniform(0.2, 0.5)))
    except _Timeout as exc:
        return "hang", f"load took {_limit_text(exc, time_limit)}"
    except TransgenError as exc:
        message = str(exc)
        return ("refused", message) if LOCATED.match(message) else ("unlocated", message)
    except Exception:
        return "crash", "at load:\n" + traceback.format_exc(limit=-8)
    try:
        with _time_limit(max(time_limit - (time.perf_counter() - start), 0.1)):
            result = scenario.run()
    except _Timeout as exc:
        return "hang", f"load and run took {_limit_text(exc, time_limit)}"
    except TransgenError as exc:
        return "failed", str(exc)
    except Exception:
        return "crash", "in the run:\n" + traceback.format_exc(limit=-8)
    if not result.success:
        return "failed", result.message
    values = {k: np.asarray(v, dtype=float) for k, v in result.signals.items()}
    nan = [k for k, v in values.items() if np.isnan(v).any()]
    if nan or not np.all(np.isfinite(result.time)):
        return "nan", f"NaN in {', '.join(nan[:5]) or 'time'}"
    infinite = [k for k, v in values.items() if np.isinf(v).any()]
    if infinite:  # e.g. the engine's air-fuel ratio lambda with the fuel cut off: a value, not an error
        return "completed with infinite values", ", ".join(infinite[:5])
    return "completed", ""


def fuzz_scenarios(seed: int, count: int, time_limit: float = 10.0, progress=None, warm: bool = False) -> FuzzReport:
    """Run ``count`` fuzzed scenario cases from ``seed``; see the module docstring. ``warm``:
    run every source once first (:func:`warm_up`), untimed."""
    rng = np.random.default_rng(seed)
    report = FuzzReport(seed, count)
    start = time.perf_counter()
    with tempfile.TemporaryDirectory(prefix="fuzz_scenario_") as tmp:
        folder = Path(tmp) / "scenarios"
        shutil.copytree(Path(next(iter(bundled_scenarios().values()))).parent, folder)
        sources = {p.relative_to(folder).as_posix(): (p, p.read_text(encoding="utf-8")) for p in sorted(folder.rglob("*.toml"))}
        sources["synthetic"] = (folder / "synthetic.toml", SYNTHETIC)
        if warm:
            warm_up(sources)
        for k in range(count):
            origin, case_folder, text, how = _case(rng, sources)
            t0 = time.perf_counter()
            outcome, detail = _run_one(text, how, case_folder, rng, time_limit)
            report.slowest = max(report.slowest, time.perf_counter() - t0)
            report.outcomes[outcome] = report.outcomes.get(outcome, 0) + 1
            if outcome in FAILURES:
                report.failures.append({"case": k, "origin": origin, "outcome": outcome, "detail": detail, "text": text})
            if progress is not None:
                progress(k, outcome)
    report.wall = time.perf_counter() - start
    return report
