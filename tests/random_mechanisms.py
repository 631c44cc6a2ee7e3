"""Random mechanisms and scenarios for the simulator's property tests (tests/test_sim_properties.py)
and its long fuzz (benchmarks/fuzz_invariants.py).

A case is a chain of 2-5 links (inertias 0.01-10 kg*m^2) in which consecutive links are joined by
a friction clutch, a one-way clutch or a simple planetary (with a third link of the chain or the
housing as its third member), plus brakes, with random apply signals (constant, step, ramp, table, sine, a sine with offset 0 being
clipped at zero: kinks and rises from zero), a random input torque and output torque, random
initial speeds (some slips start at exactly zero, some links at rest), run for 0.2-0.5 s.

Everything goes through the public API: the ``.mech`` text and a scenario TOML are written to a
folder and read with :func:`transgen.sim.scenario.load.load_scenario`.

:func:`physics_problems` re-checks a completed run's samples independently of the simulator's
own monitor; :func:`solver_differences` compares the runs of one case on several solvers.
"""
from __future__ import annotations

import math
import re
import tomllib
import time as _time
import traceback
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np
from hypothesis import assume
from hypothesis import strategies as st

from transgen.errors import MechError, ScenarioError, TransgenError
from transgen.sim.scenario.load import load_scenario

HOUSING = "housing"
SOLVERS = ("DOP853", "RK45", "LSODA", "Radau", "BDF")

#: Tolerances of the properties (issue 10).
SLIP_RTOL = 1e-6  # sign checks, relative to max(1, max|w|)
TORQUE_RTOL = 1e-6  # holding limit: |t| <= static*apply*(1 + 1e-6) + 1e-6
ENERGY_RTOL = 1e-3  # relative energy residual of the run
ENERGY_FLOOR_ATOLS = 1e3  # ... or its absolute residual in units of the integrator's atol
ATOL = 1e-8  # the scenarios' atol (the default)
MAX_ELEMENTS = 5  # shift elements of a case (the modes are their combinations)
EVENT_ATOL = 1e-3  # s, event times across solvers
SPEED_RTOL = 1e-3  # final link speeds across solvers, relative to max(1, |w|)


@dataclass(frozen=True)
class Case:
    """One random mechanism (``mech``: .mech text) and scenario (``scenario``: TOML text)."""

    mech: str
    scenario: str
    elements: tuple[tuple[str, str, float, int], ...]  # (name, kind, static capacity, free sign)

    def files(self, folder: Path) -> Path:
        (folder / "random.mech").write_text(self.mech)
        path = folder / "random.toml"
        path.write_text(self.scenario)
        return path

    def __str__(self) -> str:
        return f"--- random.mech\n{self.mech}--- random.toml\n{self.scenario}"


def _num(x: float) -> str:
    return repr(float(x))


def _finite(lo, hi):
    return st.floats(lo, hi, allow_nan=False, allow_infinity=False)


@st.composite
def _fraction(draw):
    """An apply level: often exactly 0 or 1, else in between."""
    return draw(st.one_of(st.sampled_from([0.0, 1.0]), _finite(0.0, 1.0)))


@st.composite
def apply_signal(draw, t_end: float) -> str:
    """A TOML apply signal (fraction of full apply) over [0, t_end]."""
    kind = draw(st.sampled_from(["constant", "step", "ramp", "table", "sine", "clipped_sine"]))
    if kind == "constant":
        return _num(draw(_fraction()))
    if kind == "step":
        t = draw(_finite(0.0, t_end))
        return f'{{ type = "step", t = {_num(t)}, before = {_num(draw(_fraction()))}, after = {_num(draw(_fraction()))} }}'
    if kind == "ramp":
        t0 = draw(_finite(0.0, 0.8 * t_end))
        t1 = t0 + draw(_finite(0.01, t_end))
        return (f'{{ type = "ramp", t0 = {_num(t0)}, t1 = {_num(t1)}, v0 = {_num(draw(_fraction()))}, '
                f'v1 = {_num(draw(_fraction()))} }}')
    if kind == "table":
        n = draw(st.integers(2, 5))
        ts = sorted(draw(st.lists(_finite(0.0, t_end), min_size=n, max_size=n, unique=True)))
        if any(b - a < 1e-3 for a, b in zip(ts, ts[1:])):
            ts = [t_end * k / (n - 1) for k in range(n)]
        vs = [draw(_fraction()) for _ in ts]
        return f'{{ type = "table", t = [{", ".join(map(_num, ts))}], value = [{", ".join(map(_num, vs))}] }}'
    offset = 0.0 if kind == "clipped_sine" else draw(_finite(-0.5, 1.0))
    amplitude = draw(_finite(0.05, 1.0))
    frequency = draw(_finite(0.5, 30.0))
    phase = draw(_finite(-math.pi, math.pi))
    return (f'{{ type = "sine", offset = {_num(offset)}, amplitude = {_num(amplitude)}, '
            f'frequency = {_num(frequency)}, phase = {_num(phase)} }}')


@st.composite
def torque_signal(draw, t_end: float, bound: float) -> str:
    """A TOML torque signal [N*m] within +-bound."""
    kind = draw(st.sampled_from(["constant", "constant", "step", "ramp", "sine"]))
    level = _finite(-bound, bound)
    if kind == "constant":
        return _num(draw(st.one_of(st.just(0.0), level)))
    if kind == "step":
        return f'{{ type = "step", t = {_num(draw(_finite(0.0, t_end)))}, before = {_num(draw(level))}, after = {_num(draw(level))} }}'
    if kind == "ramp":
        t0 = draw(_finite(0.0, 0.8 * t_end))
        return (f'{{ type = "ramp", t0 = {_num(t0)}, t1 = {_num(t0 + draw(_finite(0.01, t_end)))}, '
                f'v0 = {_num(draw(level))}, v1 = {_num(draw(level))} }}')
    return (f'{{ type = "sine", offset = {_num(draw(level))}, amplitude = {_num(draw(_finite(0.0, bound)))}, '
            f'frequency = {_num(draw(_finite(0.5, 20.0)))}, phase = {_num(draw(_finite(-math.pi, math.pi)))} }}')


@st.composite
def cases(draw) -> Case:
    """A random chain mechanism with its scenario (see the module docstring)."""
    n = draw(st.integers(2, 5))
    links = [f"L{k + 1}" for k in range(n)]
    inertia = [draw(st.one_of(st.sampled_from([0.01, 0.1, 1.0, 10.0]), _finite(0.01, 10.0))) for _ in links]
    t_end = draw(st.sampled_from([0.2, 0.3, 0.5]))
    lines = ['transmission "random chain"'] + [f"link {k} J={_num(j)}" for k, j in zip(links, inertia)]
    elements: list[tuple[str, str, float, int]] = []
    planetaries: list[tuple[str, str, str, int, int]] = []  # sun, ring, carrier, Ns, Nr
    counts = {"C": 0, "B": 0, "F": 0}
    oneways: list[tuple[str, str | None, int]] = []  # link1, link2 (None: housing), free sign

    def element(kind: str, a: str, b: str | None) -> None:
        prefix = {"clutch": "C", "brake": "B", "oneway": "F"}[kind]
        counts[prefix] += 1
        name = f"{prefix}{counts[prefix]}"
        if kind == "oneway":
            free = draw(st.sampled_from(["positive", "negative"]))
            lines.append(f"oneway {name} {a}{' ' + b if b else ''} free={free}")
            elements.append((name, kind, math.inf, 1 if free == "positive" else -1))
            oneways.append((a, b, elements[-1][3]))
            return
        static = draw(st.one_of(st.sampled_from([1.0, 10.0, 100.0]), _finite(1.0, 500.0)))
        dynamic = static * draw(_finite(0.5, 1.0))
        if kind == "clutch":
            lines.append(f"clutch {name} {a} {b} static={_num(static)} dynamic={_num(dynamic)}")
        else:
            lines.append(f"brake {name} {a} static={_num(static)} dynamic={_num(dynamic)}")
        elements.append((name, kind, static, 0))

    for k in range(n - 1):
        joints = ["clutch", "oneway"] + (["planetary"] if len(planetaries) < 2 else [])
        joint = draw(st.sampled_from(joints))
        a, b = links[k], links[k + 1]
        if joint == "planetary":
            third = draw(st.sampled_from([x for x in links if x not in (a, b)] + [HOUSING]))  # a fixed member
            sun, ring, carrier = draw(st.permutations([a, b, third]))
            if any({sun, ring, carrier} == {p[0], p[1], p[2]} for p in planetaries):
                joint = "clutch"  # two planetaries on the same three links tie them up or duplicate
            else:
                ns = draw(st.integers(15, 60))
                nr = draw(st.integers(ns + 10, ns + 80))
                planetaries.append((sun, ring, carrier, ns, nr))
                lines.append(f"planetary P{len(planetaries)} sun={sun} ring={ring} carrier={carrier} Ns={ns} Nr={nr}")
                continue
        if joint == "oneway" and len(elements) + (n - 1 - k) < MAX_ELEMENTS and draw(st.booleans()):
            element("oneway", b, None)  # a one-way clutch to the housing instead, and a clutch on the joint
            joint = "clutch"
        element(joint, a, b)
    for link in draw(st.lists(st.sampled_from(links), max_size=min(2, MAX_ELEMENTS - len(elements)), unique=True)):
        element("brake", link, None)
    lines += [f"input {links[0]}", f"output {links[-1]}"]
    mech = "\n".join(lines) + "\n"

    # initial speeds: some at rest, some equal to the previous link's (zero slip), one-way clutches
    # in their free direction or at zero slip (a one-way clutch slipping against it is no state
    # a mechanism can be in), then the planetaries' kinematics (each determines one member that
    # is in no other planetary)
    speeds: dict[str, float] = {}
    for k, link in enumerate(links):
        how = draw(st.sampled_from(["rest", "same", "any"]))
        previous = speeds[links[k - 1]] if k else 0.0
        speeds[link] = 0.0 if how == "rest" else (previous if how == "same" else draw(_finite(-100.0, 100.0)))
        for a, b, free in oneways:
            if b == link and free * (speeds[a] - speeds[b]) < 0:  # free * (w_a - w_b) >= 0
                speeds[link] = speeds[a] if how == "same" else speeds[a] - free * abs(speeds[link] - speeds[a])
            elif a == link and b is None and free * speeds[link] < 0:
                speeds[link] = -speeds[link]
    speeds[HOUSING] = 0.0
    for i, (sun, ring, carrier, ns, nr) in enumerate(planetaries):
        others = {x for j, p in enumerate(planetaries) if j != i for x in p[:3]}
        free = [x for x in (carrier, sun, ring) if x not in others and x != HOUSING]
        assume(free)
        x = free[0]
        if x == carrier:
            speeds[carrier] = (ns * speeds[sun] + nr * speeds[ring]) / (ns + nr)
        elif x == sun:
            speeds[sun] = ((ns + nr) * speeds[carrier] - nr * speeds[ring]) / ns
        else:
            speeds[ring] = ((ns + nr) * speeds[carrier] - ns * speeds[sun]) / nr
    speeds.pop(HOUSING, None)
    scale = max(1.0, max(abs(v) for v in speeds.values()))
    assume(all(free * (speeds[a] - (speeds[b] if b else 0.0)) >= -1e-12 * scale for a, b, free in oneways))
    bound = draw(st.sampled_from([10.0, 100.0, 300.0]))
    body = ['mechanism = "random.mech"', "[simulation]", f"t_end = {t_end}", "[initial]",
            "speeds = { " + ", ".join(f"{k} = {_num(v)}" for k, v in speeds.items()) + " }",
            "[input]", 'type = "torque"', f"torque = {draw(torque_signal(t_end, bound))}",
            "[driveline]", f"output_torque = {draw(torque_signal(t_end, bound / 2))}"]
    for name, kind, _, _ in elements:
        if kind != "oneway":
            body += [f"[elements.{name}]", f"apply = {draw(apply_signal(t_end))}"]
    return Case(mech, "\n".join(body) + "\n", tuple(elements))


class NotRunnable(Exception):
    """The case is rejected at load (a tie-up, an undetermined member, ...): not a test failure."""


def load(case: Case, folder: Path, method: str):
    """The scenario of ``case`` on ``method``; :class:`NotRunnable` when the load refuses it with
    the project's error (ScenarioError/MechError), any other exception propagates."""
    try:
        sc = load_scenario(case.files(folder))
    except (ScenarioError, MechError) as exc:
        raise NotRunnable(str(exc)) from None
    sc.options = replace(sc.options, method=method)
    return sc


@dataclass
class Outcome:
    """What became of one case on several solvers."""

    rejected: str | None = None  # the load's message, when the case is not runnable
    results: dict = field(default_factory=dict)  # method -> completed Result
    stopped: dict = field(default_factory=dict)  # method -> message (success False, or a TransgenError raised)
    crashed: dict = field(default_factory=dict)  # method -> traceback of an exception that is not a TransgenError
    physics: dict = field(default_factory=dict)  # method -> physics_problems of its completed run
    differences: list = field(default_factory=list)  # solver_differences (incl. completed on some, stopped on others)
    seconds: dict = field(default_factory=dict)  # method -> wall time of load + run [s]

    def violations(self) -> dict[str, list[str]]:
        """The property violations of this case, one line each, per property (issue 10):
        ``exceptions`` (nothing raises but the project's errors; a stop has a message), ``physics``
        (the re-check of the completed runs' samples), ``solvers`` (the same events and final
        speeds on every solver), ``monitor`` (no valid run is stopped on an invariant),
        ``decision`` (the mode decision is unique)."""
        stops = self.stopped.items()
        return {
            "exceptions": [f"{m}: unexpected exception\n{tb}" for m, tb in self.crashed.items()]
                          + [f"{m}: stopped without a message" for m, msg in stops if not msg.strip()],
            "physics": [f"{m}: {p}" for m, ps in self.physics.items() for p in ps],
            "solvers": list(self.differences),
            "monitor": [f"{m}: {msg}" for m, msg in stops if "invariant '" in msg],
            "decision": [f"{m}: {msg}" for m, msg in stops if wrong_decision(msg)],
        }


def wrong_decision(message: str) -> bool:
    """Whether a stop message shows a wrong mode decision. With rigid links and static >= dynamic
    capacities the accelerations at an instant minimise a strictly convex function (Coulomb
    friction; a one-way clutch is a one-sided limit), so they exist and are unique: "several
    consistent modes" is always wrong, and "no consistent mode" can only come from candidates
    refused for their torque split (elements in parallel, issue 10 section 2)."""
    return "several consistent modes" in message or ("no consistent mode" in message and " 0 candidate mode" in message)


def examine(case: Case, folder: Path, methods=SOLVERS) -> Outcome:
    """Run ``case`` on every method of ``methods`` and check the three properties."""
    out = Outcome()
    for m in methods:
        start = _time.perf_counter()
        try:
            sc = load(case, folder, m)
        except NotRunnable as exc:
            out.rejected = str(exc)
            return out
        try:
            r = sc.run()
        except TransgenError as exc:
            out.stopped[m] = f"{type(exc).__name__}: {exc}"
        except Exception:  # noqa: BLE001 - the property: nothing but the project's errors
            out.crashed[m] = traceback.format_exc()
        else:
            if r.success:
                out.results[m] = r
                out.physics[m] = physics_problems(case, r)
            else:
                out.stopped[m] = r.message
        out.seconds[m] = _time.perf_counter() - start
    if out.results:
        out.differences += [f"completed on {', '.join(out.results)}; stopped on {m}: {msg}" for m, msg in out.stopped.items()]
    if len(out.results) > 1:
        out.differences += solver_differences(out.results)
    return out


def physics_problems(case: Case, r) -> list[str]:
    """What is physically wrong in the completed run ``r`` of ``case``, checked on its samples
    independently of the simulator's monitor (empty: nothing)."""
    problems = []
    monitor = r.stats.get("invariants")
    if monitor is None:
        problems.append("the invariant monitor did not run")
    else:
        for name, v in monitor["invariants"].items():
            if not v["worst"] <= 1.0:
                problems.append(f"monitor invariant {name}: worst {v['worst']:.3g} > 1 on a completed run")
    for name, values in r.signals.items():
        if np.issubdtype(np.asarray(values).dtype, np.number) and not np.all(np.isfinite(values)):
            problems.append(f"signal {name} is not finite")
    speeds = [np.abs(v) for k, v in r.signals.items() if k.startswith("w_")]
    scale = max(1.0, max(float(np.max(v)) for v in speeds))
    time = r.time
    for name, kind, static, free in case.elements:
        slip, torque = r.signals[f"slip_{name}"], r.signals[f"t_{name}"]
        locked = r.signals[f"locked_{name}"] != 0
        if kind == "oneway":
            bad = ~locked & (free * slip < -SLIP_RTOL * scale)
            what = "a free one-way clutch slips in its locking direction"
        else:
            bad_slip = ~locked & (torque * slip < -SLIP_RTOL * np.abs(torque) * scale)
            capacity = static * r.signals[f"apply_{name}"]
            bad_hold = locked & (np.abs(torque) > capacity * (1 + TORQUE_RTOL) + TORQUE_RTOL)
            if bad_hold.any():
                k = int(np.argmax(bad_hold))
                problems.append(f"{name} locked holds |t| = {abs(torque[k]):.6g} > static*apply = {capacity[k]:.6g} "
                                f"at t={time[k]:.6g}")
            bad = bad_slip
            what = "a slipping friction element creates energy (t*slip < 0)"
        if bad.any():
            k = int(np.argmax(bad))
            problems.append(f"{name}: {what} at t={time[k]:.6g} (slip {slip[k]:.6g}, t {torque[k]:.6g})")
    residual = r.energy.get("relative_residual", math.nan)
    # the monitor's criterion: relative to the run's energies, or within what the integrator's
    # absolute tolerance leaves in the energy integrals (1000 x atol) when they are tiny
    if not (residual <= ENERGY_RTOL or abs(r.energy.get("residual", math.nan)) <= ENERGY_FLOOR_ATOLS * ATOL):
        problems.append(f"energy relative residual {residual:.3g} > {ENERGY_RTOL:g} "
                        f"(residual {r.energy.get('residual', math.nan):.3g} J)")
    return problems


def signal_breakpoints(case: Case) -> set[float]:
    """The times [s] where a signal of the case's scenario jumps or kinks (steps, ramp ends, table
    knots)."""
    data = tomllib.loads(case.scenario)
    specs = [data["input"]["torque"], data["driveline"]["output_torque"]]
    specs += [e["apply"] for e in data.get("elements", {}).values()]
    out = set()
    for spec in specs:
        if isinstance(spec, dict):
            kind = spec["type"]
            out.update([spec["t"]] if kind == "step" else [spec["t0"], spec["t1"]] if kind == "ramp"
                       else spec["t"] if kind == "table" else [])
    return out


def _stop_time(problem: str) -> float | None:
    m = re.search(r"\bt=([0-9.e+-]+) s: invariant", problem)
    return float(m.group(1)) if m else None


def _over_the_limit(problem: str) -> bool:
    return bool(re.search(r"invariant 'holding_limit' violated by \w+ .*(the locked torque exceeds the holding limit"
                          r"|a locked one-way clutch transmits against its locking direction)", problem)
                or re.search(r"\w+ locked holds \|t\| = .* > static\*apply", problem))


def _at_a_breakpoint(problem: str, case: Case) -> bool:
    t = _stop_time(problem)
    # the monitor names the first violating sample, printed to 6 digits
    return t is not None and any(abs(t - b) <= 5e-6 * max(1.0, b) for b in signal_breakpoints(case))


def _burst_at_a_step(problem: str, case: Case) -> bool:
    """A solver difference in which some run has two or more events within 10 us at a step of a
    signal: one decision at the step should settle the mode, but an event function that saw the
    value after the step forces an unlock just before it, and the mode is then corrected in one or
    more further events (unlock and re-lock, 'switch') in an order that depends on the solver."""
    if not problem.startswith("event"):
        return False
    steps = signal_breakpoints(case)
    for run in re.findall(r"\[start[^\]]*\]", problem):
        times = [float(t) for t in re.findall(r"@([0-9.e+-]+)", run)[1:]]
        for t1, t2 in zip(times, times[1:]):
            if 0 <= t2 - t1 < 1e-5 and any(abs(t1 - b) <= 5e-6 * max(1.0, b) for b in steps):
                return True
    return False


#: Known simulator bugs that random cases hit: name -> (does a violation's text show it, reason).
#: Each has a minimal reproducer in tests/test_sim_properties.py (xfail until the core is fixed), or
#: names the bundled case that shows it.
KNOWN_BUGS = {
    "slip crossing missed between integrator steps": (
        lambda p, case: bool(re.search(r"invariant 'oneway_free_sign' violated|invariant 'dissipation' violated by \w+ "
                                       r".*the slipping element creates energy|a slip dip one solver resolved", p)),
        "solve_ivp finds an event only where its function changes sign between two steps; the dense "
        "output of every step is scanned at 16 interior points for a slip dipping through zero and "
        "back (integration.missed_crossing; test_reproducer_oneway_grazing_under_an_alternating_load_locks "
        "passes on every solver), but a dip narrower than the scan is still missed and the monitor "
        "then stops the run"),
    "no combination passes the sticking test": (
        lambda p, case: bool(re.search(r"no consistent mode for the elements at zero slip \([^)]*\); 0 candidate", p)),
        "several elements at zero slip where every lock is too weak and every slip, tested at its "
        "static capacity (thesis 3.2.6), is braked back: the complementarity problem can have no "
        "solution when static > dynamic capacity, and the run stops with 'no consistent mode' "
        "(refused, not wrong). Elements that broke loose already (forced, sliding) are tested at "
        "their dynamic capacity and redundant locks try every reduction, which removed the cases "
        "seen so far; kept for what the larger fuzz (benchmarks/fuzz_invariants.py) may find"),
    "ambiguous decision at round-off torques": (
        lambda p, case: "several consistent modes" in p,
        "the lock test accepts a one-way torque of up to 1e-9 N*m in the free direction "
        "(ElementConfig.holding_margin) while the slip test accepts any slip acceleration > 0, so where "
        "torques are below 1e-9 N*m - a tiny apply, or torques reversing through zero, where the unlock "
        "event itself fires at |t| = 1e-9 N*m - locking and overrunning are both consistent and the run "
        "stops (test_reproducer_decision_with_a_tiny_clutch_torque_is_unique, "
        "test_reproducer_two_oneway_clutches_overrun_together)"),
}


def known_bug(problem: str, case: Case, outcome: "Outcome | None" = None) -> str | None:
    """The name of the known bug that ``problem`` (a violation's text) shows, or None. A solver
    difference in a case where some solver showed a known bug is put down to that bug."""
    for name, (shows, _) in KNOWN_BUGS.items():
        if shows(problem, case):
            return name
    if outcome is not None and problem in outcome.differences:
        for other in list(outcome.stopped.values()) + [p for ps in outcome.physics.values() for p in ps]:
            for name, (shows, _) in KNOWN_BUGS.items():
                if shows(other, case):
                    return name
    return None


#: [s] a lock and an unlock of the same element closer than this are one slip dip through zero
DIP_WINDOW = 1e-3


def _without_dips(events) -> list[tuple[str, tuple[str, ...]]]:
    """The event signature with every lock that the same elements' unlock follows within
    :data:`DIP_WINDOW` left out, with that unlock: a slip dipping through zero and back, which a
    solver whose steps straddle it misses (the known bug "slip crossing missed between integrator
    steps"); the rest of the two runs must still agree."""
    out, k = [], 0
    events = list(events)
    while k < len(events):
        e = events[k]
        if (e.kind == "lock" and k + 1 < len(events) and events[k + 1].kind == "unlock"
                and events[k + 1].elements == e.elements and events[k + 1].t - e.t < DIP_WINDOW):
            k += 2
            continue
        out.append((e.kind, e.elements))
        k += 1
    return out


def event_signature(r) -> list[tuple[str, tuple[str, ...]]]:
    return [(e.kind, e.elements) for e in r.events]


def solver_differences(results: dict) -> list[str]:
    """How the completed runs ``results`` (method -> Result) of one case differ beyond the
    properties' tolerances: event sequence (kinds and elements, times within 1 ms), final link
    speeds within 0.1 % of max(1, |w|). Compared with the first method's run."""
    methods = list(results)
    ref = results[methods[0]]
    problems = []
    links = [k for k in ref.signals if k.startswith("w_")]
    for m in methods[1:]:
        r = results[m]
        if event_signature(r) != event_signature(ref):
            dip = _without_dips(ref.events) == _without_dips(r.events)
            problems.append(("events differ only by a lock and unlock of one element within "
                             f"{DIP_WINDOW * 1e3:g} ms (a slip dip one solver resolved and the other missed): "
                             if dip else "events differ: ") + f"{methods[0]} {describe_events(ref)} vs {m} {describe_events(r)}")
        else:
            dt = max((abs(a.t - b.t) for a, b in zip(ref.events, r.events)), default=0.0)
            if dt > EVENT_ATOL:
                problems.append(f"event times differ by {dt * 1e3:.3g} ms: {methods[0]} {describe_events(ref)} "
                                f"vs {m} {describe_events(r)}")
        for k in links:
            a, b = float(ref.signals[k][-1]), float(r.signals[k][-1])
            if abs(a - b) > SPEED_RTOL * max(1.0, abs(a)):
                problems.append(f"final {k}: {methods[0]} {a:.9g} vs {m} {b:.9g}")
    return problems


def describe_events(r) -> str:
    return "[" + ", ".join(f"{e.kind} {'+'.join(e.elements) or '-'} @{e.t:.6g}" for e in r.events) + "]"


__all__ = ["SOLVERS", "Case", "cases", "apply_signal", "torque_signal", "NotRunnable", "load", "Outcome", "examine",
           "physics_problems", "solver_differences", "describe_events", "event_signature", "KNOWN_BUGS", "known_bug", "wrong_decision",
           "signal_breakpoints"]
