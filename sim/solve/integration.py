"""The integration core shared by both clutch models (:mod:`.switching`, Runde's mode switching,
and :mod:`.compliant`, Haessig's compliant clutches): the solver settings, the powertrain being
run, the layout of the state vector, the components' evaluation, the breakpoints of the input
signals, one integration segment with ``scipy.integrate.solve_ivp`` and the sampling of the
segments into a :class:`~.result.Result`.

Neither clutch model owns this module; both import it, and :func:`.simulate.simulate` chooses
between them. A run is a sequence of :class:`Segment` s: between two segment ends the right-hand
side is smooth (the mode, the slip directions and the signals' pieces are fixed), and each segment
keeps its dense output for sampling.
"""
from __future__ import annotations

import math
import time as _time
from dataclasses import dataclass, field

import numpy as np

from transgen.errors import SimulationError, StateOutOfDomain

from ..model.components import Component
from ..model.losses import loss_energy
from .dense import dense_values
from .monitor import InvariantMonitor
from ..core.result import Event, ModeSpan, Result
from ..core.signals import Constant
from ..model.transmission import APPLY_THRESHOLD, ModeData, Transmission

__all__ = ["SolverOptions", "Powertrain", "Segment", "StateLayout", "ComponentEvaluator", "next_stop", "memo_last",
           "slip_event", "apply_events", "signal_time",
           "check_finite", "integrate", "output_times", "Recorder", "collect", "energy_scale",
           "sample_block"]


@dataclass(frozen=True)
class SolverOptions:
    """Integration settings.

    ``model``: ``"switching"`` (Runde's method) or ``"compliant"`` (Haessig's: a locked
    element is a spring ``stiffness`` [N*m/rad] with damper ``damping`` [N*m*s/rad]).
    ``output_dt``: spacing of the output samples [s]. ``slip_tol``: slip speed [rad/s] below
    which an element counts as at zero slip in the mode decision (relative to the largest link
    speed, at least 1e-9). ``monitor``: check the physical invariants of :mod:`.monitor` on every
    segment (on by default); ``energy_tol``: the largest energy residual of one segment, relative
    to the run's energy scale.
    """

    t_end: float = 10.0
    t_start: float = 0.0
    model: str = "switching"
    method: str = "DOP853"
    rtol: float = 1e-8
    atol: float = 1e-8
    max_step: float = math.inf
    output_dt: float = 1e-3
    slip_tol: float = 1e-7
    max_events: int = 100000
    monitor: bool = True
    energy_tol: float = 1e-3
    stiffness: float = 1e5
    damping: float = 100.0


@dataclass
class Powertrain:
    """A transmission with the components that drive and load it, and its initial link speeds."""

    transmission: Transmission
    components: list[Component] = field(default_factory=list)
    initial_speeds: np.ndarray | None = None
    controllers: list = field(default_factory=list)  # e.g. schedule.AutoShift


@dataclass
class Segment:
    t0: float
    t1: float
    locked: frozenset
    directions: np.ndarray
    mode: ModeData | None
    sol: object
    stuck: np.ndarray | None = None  # compliant model: which elements act as springs


class StateLayout:
    """Where the component states and the energy integrals sit in the state vector."""

    def __init__(self, components: list[Component], offset: int):
        self.slices = []
        pos = offset
        for c in components:
            n = len(c.state_names)
            self.slices.append(slice(pos, pos + n))
            pos += n
        self.energy = slice(pos, pos + 3)  # work in, dissipated, work into the load
        self.size = pos + 3
        self.offset = offset

    def derivative(self, head: np.ndarray, derivs: list, p_in: float, dissipated: float, p_load: float) -> np.ndarray:
        """The state derivative: ``head`` (the transmission's states), the components'
        derivatives, the three energy rates."""
        # the slices are consecutive: one list, one array (cheaper than item assignments)
        out = head.tolist()
        for dx in derivs:
            out.extend(dx)
        out += (p_in, dissipated, p_load)
        if len(out) != self.size:
            raise ValueError(f"component derivatives of {len(out) - self.offset - 3} states, expected "
                             f"{self.size - self.offset - 3}")
        return np.array(out, dtype=float)


def signal_time(pt: Powertrain, t: float) -> float:
    """Where a segment starting at ``t`` evaluates its signals at its start: ``t``, or the last
    breakpoint closer after it than a segment can be long (1e-12 relative): a jump that close is
    taken as passed, not stepped over with the value before it."""
    after = t + 1e-12 * max(1.0, abs(t))
    points = [p for o in (*pt.transmission.elements, *pt.components) for p in o.breakpoints(t, after) if t < p <= after]
    return max(points, default=t)


def next_stop(pt: Powertrain, t: float, t_end: float, released=()) -> float:
    """Where the segment starting at ``t`` must end at the latest: the next breakpoint of an input
    signal (a kink or jump of an apply, a torque, a throttle, ...), the next crossing of
    :data:`~.transmission.APPLY_THRESHOLD` by the apply of an element of ``released`` (indices of
    the elements not locked; a rise from zero may lock one, both directions are kinks of its
    torque), the next local minimum of the apply of a locked friction element (where its holding
    limit is lowest: the unlock event cannot be stepped over), or ``t_end``."""
    after = t + 1e-12 * max(1.0, abs(t))
    stop = t_end
    # the next breakpoint, looked for in growing windows (a periodic signal has one every period)
    window = min(t_end - after, 1e-3 * max(1.0, t_end - t))
    owners = [*pt.transmission.elements, *pt.components]
    while window > 0:
        t1 = min(t_end, after + window)
        points = [p for o in owners for p in o.breakpoints(after, t1) if after < p < t_end]
        if points or t1 >= t_end:
            stop = min(points + [t_end])
            break
        window *= 8
    released = set(released)
    for i, e in enumerate(pt.transmission.elements):
        if e.kind == "oneway":
            continue
        # a released element: its apply crossing zero; a locked one: its apply's lowest point
        point = e.apply.next_crossing(APPLY_THRESHOLD, after, stop) if i in released else e.apply.next_minimum(after, stop)
        if point is not None and point < stop:
            stop = point
    return stop


class ComponentEvaluator:
    """Shared evaluation for both clutch models: component torques and energy rates."""

    def __init__(self, pt: Powertrain):
        self.pt = pt
        self.tr = pt.transmission
        self.components = pt.components
        self.n_u = len(self.tr.inputs)
        self.calls = 0
        self.input_calls = 0  # evaluations of the input vector alone (:meth:`inputs`)

    def external(self, t: float, y: np.ndarray, w: np.ndarray, layout: StateLayout):
        """External input vector (component torques), component derivatives (in the order of
        ``layout.slices``) and the power in, dissipated and passed to the load [W]."""
        u = [0.0] * self.n_u  # a list while summing: item updates of an array cost more
        derivs = []
        p_in = dissipated = p_load = 0.0
        index = self.tr.input_index
        for c, sl in zip(self.components, layout.slices):
            torques, dx, pi, di, pl = c.evaluate(t, y[sl], w)
            for name, value in torques.items():
                u[index[name]] += value
            derivs.append(dx)
            p_in += pi
            dissipated += di
            p_load += pl
        return np.array(u), derivs, p_in, dissipated, p_load

    def inputs(self, t: float, y: np.ndarray, w: np.ndarray, layout: StateLayout) -> np.ndarray:
        """The external input vector of :meth:`external` alone (each component's ``torques``):
        what an event function on the locked torques needs at every step, without the components'
        derivatives and powers (an engine's air path, a road load)."""
        u = [0.0] * self.n_u
        index = self.tr.input_index
        for c, sl in zip(self.components, layout.slices):
            for name, value in c.torques(t, y[sl], w).items():
                u[index[name]] += value
        return np.array(u)


def memo_last(model: "ComponentEvaluator", func, t_stop: float = math.inf, t_from: float = -math.inf,
              counter: str = "calls"):
    """``func(t, y)`` remembered for the last ``(t, y)``: the integrator calls the right-hand side
    and every event function with the same point, which then costs one evaluation
    (counted in ``model.calls``, or the attribute ``counter`` of ``model``).

    ``t_stop``: the segment's end. Signals are right-continuous (a step takes its new value at its
    time), but a segment ending at a breakpoint integrates the piece before it: at ``t_stop`` the
    signals are evaluated at :func:`left_of` it, so that its last step and its events see the value
    the segment integrated, not the one after the jump; before ``t_from`` (:func:`signal_time`)
    they are evaluated at it."""
    last_t = last_y = last_value = None
    t_left = left_of(t_stop)

    def wrapper(t, y):
        nonlocal last_t, last_y, last_value
        key = y.tobytes()
        if t != last_t or key != last_y:
            setattr(model, counter, getattr(model, counter) + 1)
            last_value = func(min(max(t, t_from), t_left), y)
            last_t, last_y = t, key
        return last_value

    return wrapper


def left_of(t: float) -> float:
    """The last float before ``t``: where a segment ending at ``t`` evaluates its signals."""
    return math.nextafter(t, -math.inf) if math.isfinite(t) else t


def slip_event(slips_of, i: int, moving: int, tol: float, row: np.ndarray | None = None):
    """Terminal event of element ``i`` slipping in direction ``moving`` (+1/-1): its slip
    (``slips_of(t, y)[i]`` [rad/s]) comes back through zero. It fires at ``moving * slip =
    -tol/1000``, a little past zero but well inside the mode decision's slip tolerance ``tol``, so
    that the decision finds the element at zero slip, and a slip that starts at zero or within
    round-off of it on the wrong side (an element whose slip accelerates against the direction it
    was given) is caught at once instead of running away without a crossing.

    ``row``: the slip as a linear function of the first states (``slip = row @ y[:len(row)]``):
    the event is then that product, with no evaluation of the right-hand side at the end of every
    step, and :func:`integrate` can look for a crossing inside a step (:func:`missed_crossing`)."""
    half = 1e-3 * tol
    if row is None:
        def event(tt, y):
            return moving * slips_of(tt, y)[i] + half
    else:
        coef = moving * np.asarray(row, dtype=float)
        n = len(coef)

        def event(tt, y):
            return float(coef @ y[:n]) + half

    event.terminal, event.direction, event.info = True, -1, ("slip", i)
    event.linear = None if row is None else (moving * np.asarray(row, dtype=float), half)
    return event


#: Points inside each integrator step at which :func:`missed_crossing` evaluates the slips.
CROSSING_SCAN = 16


def missed_crossing(sol, events: list):
    """The first crossing of a slip event (:func:`slip_event` with a ``row``) *inside* an
    integrator step, which ``solve_ivp`` cannot see: it looks for sign changes between step ends
    only, so a slip that dips through zero and back within one step (a one-way clutch grazing its
    locking direction under an alternating load) would be stepped over. The dense output of each
    step is scanned at :data:`CROSSING_SCAN` interior points (a linear function of the state:
    cheap) and the first dip below zero is located by root finding. Returns ``(t, index)`` of the
    crossing and the event's index, or None."""
    linear = [(k, f.linear) for k, f in enumerate(events) if getattr(f, "linear", None) is not None]
    if not linear or len(sol.t) < 2:
        return None
    steps = np.asarray(sol.t)
    rows = np.array([r for _, (r, _) in linear])
    halves = np.array([h for _, (_, h) in linear])[:, None]
    # only the steps where a dip is possible: the value at an end is within twice the change over
    # the step or its neighbours (elsewhere the slip is far from zero for its rate of change)
    ends = rows @ np.asarray(sol.y)[: rows.shape[1]] + halves
    change = np.abs(np.diff(ends, axis=1))
    # the change over the step before and after (zero past the ends; concatenation: np.pad is slow)
    edge = np.zeros((len(change), 1))
    near = np.maximum(change, np.maximum(np.concatenate([edge, change[:, :-1]], axis=1),
                                         np.concatenate([change[:, 1:], edge], axis=1)))
    steps_in = np.flatnonzero(np.any(np.minimum(ends[:, :-1], ends[:, 1:]) <= 2.0 * near, axis=0))
    if not len(steps_in):
        return None
    frac = np.arange(1, CROSSING_SCAN + 1) / (CROSSING_SCAN + 1)
    ts = (steps[steps_in, None] + (steps[steps_in + 1] - steps[steps_in])[:, None] * frac[None, :]).ravel()
    ys = dense_values(sol.sol, ts)
    values = rows @ ys[: rows.shape[1]] + halves
    below = values < 0.0
    if not below.any():
        return None
    first = np.argmax(below, axis=1)  # first sample below zero of each event (0 where none)
    best = None
    for j in np.flatnonzero(below.any(axis=1)):
        m = int(first[j])
        t_hi = ts[m]
        step = steps_in[m // CROSSING_SCAN]
        t_lo = ts[m - 1] if m % CROSSING_SCAN else float(steps[step])
        if best is None or t_hi < best[1]:
            best = (j, t_hi, t_lo)
    j, t_hi, t_lo = best
    row, half = linear[j][1]

    def value(tt):
        return float(row @ sol.sol(tt)[: len(row)] + half)

    if value(t_lo) <= 0.0:
        return None  # below zero from the step's start: the event itself has seen it
    from scipy.optimize import brentq  # here, not at import: reading a scenario needs no scipy

    return brentq(value, t_lo, t_hi, xtol=1e-14, rtol=4 * np.finfo(float).eps), linear[j][0]


def cut_at(sol, t_cut: float, event_index: int, n_events: int):
    """``sol`` ended at ``t_cut`` by the terminal event ``event_index`` (as if ``solve_ivp`` had
    found it): status 1, the state there from the dense output; the dense output is kept (it is
    valid up to ``t_cut``)."""
    y_cut = sol.sol(t_cut)
    keep = sol.t < t_cut
    sol.t = np.append(sol.t[keep], t_cut)
    sol.y = np.column_stack([sol.y[:, keep], y_cut])
    sol.t_events = [np.array([t_cut]) if k == event_index else np.zeros(0) for k in range(n_events)]
    sol.y_events = [y_cut[None, :] if k == event_index else np.zeros((0, len(y_cut))) for k in range(n_events)]
    sol.status = 1
    return sol


def apply_events(tr: Transmission, indices, t0: float, t_stop: float = math.inf) -> list:
    """Terminal events of the friction elements ``indices`` whose apply signal varies: the apply
    crossing :data:`~.transmission.APPLY_THRESHOLD` (a rise from zero, where an element at zero
    slip may lock, or a fall to zero; both are kinks of the element torque, which must not be
    stepped over). Each event watches the crossing away from the state just after ``t0``."""
    out = []
    for i in indices:
        e = tr.elements[i]
        if e.kind == "oneway" or isinstance(e.apply, Constant):
            continue

        def event(tt, y, signal=e.apply, t_left=left_of(t_stop)):
            return signal.value(tt if tt < t_left else t_left) - APPLY_THRESHOLD

        event.terminal, event.info = True, ("apply", i)
        event.direction = -1 if e.applied_just_after(t0) else 1
        out.append(event)
    return out


def check_finite(t, y, where: str):
    if not np.all(np.isfinite(y)):
        raise SimulationError(f"t={t:.6g} s: non-finite state in {where}")


def output_times(t0: float, t1: float, dt: float) -> np.ndarray:
    """The sample times of a segment ``[t0, t1]``: its ends and the output grid (spacing ``dt``)
    strictly inside."""
    grid = np.arange(math.ceil((t0 + 1e-12) / dt) * dt, t1, dt)
    grid = grid[(grid > t0 + 1e-12) & (grid < t1 - 1e-12)]
    return np.concatenate([[t0], grid, [t1]])


class Recorder:
    """The sampled output of a run, segment by segment, checked by the invariant monitor.

    ``sampler(pt, seg, ts, ys)`` gives the signals of one segment at the times ``ts`` from its
    states ``ys`` (one column per time) as a dict of arrays (each clutch model has its own, built
    on :func:`sample_block`). :meth:`add` samples a finished segment at once, so that a violated
    invariant stops the run where it happens (:class:`~.monitor.InvariantViolation`); the
    violating segment's samples are kept for the plots.
    """

    def __init__(self, pt: Powertrain, options: SolverOptions, sampler):
        self.pt, self.options, self.sampler = pt, options, sampler
        self.segments: list[Segment] = []
        self.blocks: list[dict[str, np.ndarray]] = []
        self.times: list[np.ndarray] = []
        self.monitor = (InvariantMonitor(pt.transmission, options.slip_tol, options.energy_tol, 1e3 * options.atol)
                        if options.monitor else None)

    def integrate(self, rhs, t0: float, t1: float, y0: np.ndarray, events: list, n_dynamic: int, segment,
                  where: str):
        """Integrate one segment (:func:`integrate`), check its end state and record it (:meth:`add`);
        ``segment(t_end, dense_output)`` builds its :class:`Segment`. Returns the solver's solution.
        A failure raises :class:`SimulationError` naming ``where`` (the mode); a violated
        invariant names its own."""
        try:
            sol = integrate(rhs, t0, t1, y0, self.options, events, n_dynamic)
            check_finite(float(sol.t[-1]), sol.y[:, -1], where)
        except SimulationError as exc:
            raise SimulationError(f"{exc} ({where})") from None
        self.add(segment(float(sol.t[-1]), sol.sol))
        return sol

    def add(self, seg: Segment) -> None:
        ts = output_times(seg.t0, seg.t1, self.options.output_dt)
        # the dense output at all samples at once; the segment's end sampled with the signals' values
        # before any jump there (:func:`left_of`), the next segment's start gives those after it; the
        # start with the values the segment was decided and integrated with (:func:`signal_time`)
        at = np.maximum(np.minimum(ts, left_of(seg.t1)), signal_time(self.pt, seg.t0))
        block = self.sampler(self.pt, seg, at, dense_values(seg.sol, ts))
        self.segments.append(seg)
        self.blocks.append(block)
        self.times.append(ts)
        if self.monitor is not None:
            self.monitor.check(ts, block, seg.locked, self.pt.transmission.mode_name(seg.locked))


def collect(pt: Powertrain, options: SolverOptions, recorder: Recorder, events: list[Event], success: bool,
            message: str, model: ComponentEvaluator, wall: float) -> Result:
    """The :class:`Result` of a run from its recorded segments."""
    tr = pt.transmission
    e_names = [e.name for e in tr.elements]
    mode_names = []
    order: list[str] = []
    for seg, ts in zip(recorder.segments, recorder.times):
        name = tr.mode_name(seg.locked)
        if name not in order:
            order.append(name)
        mode_names.append(np.full(len(ts), order.index(name) + 1.0))
    blocks, times = recorder.blocks, recorder.times
    units = {f"w_{k}": "rad/s" for k in tr.links}
    for n in e_names:
        units.update({f"slip_{n}": "rad/s", f"t_{n}": "N*m", f"apply_{n}": "1", f"P_{n}": "W", f"locked_{n}": "1"})
    units.update({"T_in": "N*m", "T_out": "N*m", "mode": "1", "E_in": "J", "E_dissipated": "J", "E_load": "J",
                  "E_stored": "J", "theta_ds": "rad", "omega_v": "rad/s", "vehicle_speed": "m/s",
                  "vehicle_speed_mph": "mph", "road_torque": "N*m", "omega_engine": "rad/s", "T_engine": "N*m",
                  "T_pump": "N*m", "throttle": "1", "converter_speed_ratio": "1"})
    for c in pt.components:
        units.update(getattr(c, "signal_units", {}))
    arrays = {k: np.concatenate([blk[k] for blk in blocks]) for k in (blocks[0] if blocks else {})}
    arrays["mode"] = np.concatenate(mode_names) if mode_names else np.zeros(0)
    time_arr = np.concatenate(times) if times else np.zeros(0)
    spans = []
    for seg in recorder.segments:
        name = tr.mode_name(seg.locked)
        locked = tuple(tr.elements[i].name for i in sorted(seg.locked))
        if spans and spans[-1].name == name and abs(spans[-1].t1 - seg.t0) < 1e-12:
            spans[-1] = ModeSpan(spans[-1].t0, seg.t1, name, locked, spans[-1].gear)
        else:
            spans.append(ModeSpan(seg.t0, seg.t1, name, locked, tr.names.gear(locked)))
    energy = {}
    if len(time_arr):
        e_in, e_diss, e_load, e_st = (arrays[k] for k in ("E_in", "E_dissipated", "E_load", "E_stored"))
        d_stored = e_st[-1] - e_st[0]
        residual = e_in[-1] - (d_stored + e_diss[-1] + e_load[-1])
        energy = {"work_in": float(e_in[-1]), "stored_change": float(d_stored), "dissipated": float(e_diss[-1]),
                  "work_to_load": float(e_load[-1]), "residual": float(residual),
                  "relative_residual": float(abs(residual) / energy_scale(arrays))}
        losses = loss_energy(time_arr, arrays)
        if losses is not None:  # by kind, within "dissipated" (:mod:`..model.losses`)
            energy["losses"] = losses
    stats = {"wall_time": _time.perf_counter() - wall, "rhs_evaluations": model.calls,
             "input_evaluations": model.input_calls,
             "events": sum(1 for e in events if e.kind != "start"), "segments": len(recorder.segments)}
    if recorder.monitor is not None:
        stats["invariants"] = recorder.monitor.summary()
    meta = {"mechanism": tr.mech.name, "model": options.model, "links": list(tr.links), "elements": e_names,
            "mode_names": order, "gears": [g.name for g in tr.mech.gears], "naming": tr.names.to_dict(),
            "coordinates": list(tr.coordinates),
            "static_capacity": {e.name: e.static for e in tr.elements if e.kind != "oneway"}}
    return Result(time_arr, arrays, units, spans, events, success, message, energy, stats, meta)


def energy_scale(arrays: dict[str, np.ndarray]) -> float:
    """The energy [J] a run's energy residual is measured against: the largest of the work in,
    the dissipated energy, the work to the load and the stored energy over the run (never near
    zero while anything moves, also when no work goes in, e.g. a coast-down), at least 1e-9 J (so
    that the round-off of a run in which nothing moves is no residual)."""
    return max([float(np.max(np.abs(arrays[k]))) for k in ("E_in", "E_dissipated", "E_load", "E_stored")] + [1e-9])


def sample_block(pt: Powertrain, seg: Segment, ts: np.ndarray, ys: np.ndarray, n_extra: int,
                 element_state) -> dict[str, np.ndarray]:
    """The named signals at the output times ``ts`` of one segment (states ``ys``, one column per
    time), shared by both clutch models.

    ``n_extra`` states follow the mode's coordinates before the component states (the spring
    twists of the compliant model); ``element_state(W, slips, U)`` returns, for the link speeds
    ``W``, slips and input vectors ``U`` without element torques (one column per time), the
    element torques as inputs, the transmitted torques, the dissipated powers and any extra
    stored energy (rows: elements; columns: times).
    """
    tr = pt.transmission
    dof = seg.mode.dof
    n = len(ts)
    W = seg.mode.C @ ys[:dof]
    layout = StateLayout(pt.components, dof + n_extra)
    out: dict[str, np.ndarray] = {}
    U = np.zeros((len(tr.inputs), n))
    stored = 0.5 * (tr.inertia @ (W * W))
    for c, sl in zip(pt.components, layout.slices):
        torques, signals, energy = c.sample(ts, ys[sl], W)
        for name, values in torques.items():
            U[tr.input_index[name]] += values
        out.update(signals)
        stored += energy
    slips = tr.P @ W
    te, torques, power, extra = element_state(W, slips, U)
    U[tr.element_input] += te
    if tr.mesh is None:  # link accelerations [rad/s^2], for the components that need them
        A = seg.mode.C @ (seg.mode.B @ U)
    else:  # the lossy equations' (:meth:`Transmission.response`)
        A = seg.mode.C @ np.column_stack([tr.response(seg.mode, U[:, k], W[:, k])[0] for k in range(n)]) if n \
            else np.zeros((len(tr.links), 0))
    for c, sl in zip(pt.components, layout.slices):
        out.update(c.sample_rates(ts, ys[sl], W, A))
    for k, name in enumerate(tr.links):
        out[f"w_{name}"] = W[k]
    for i, e in enumerate(tr.elements):
        out[f"slip_{e.name}"] = slips[i]
        out[f"t_{e.name}"] = torques[i]
        out[f"apply_{e.name}"] = e.apply_over(ts)
        out[f"P_{e.name}"] = power[i]
        out[f"locked_{e.name}"] = np.full(n, 1.0 if i in seg.locked else 0.0)
    out.setdefault("T_in", U[tr.input_index["T_in"]])
    out.setdefault("T_out", U[tr.input_index["T_out"]])
    e_in, e_diss, e_load = ys[layout.energy]
    out.update({"E_in": e_in, "E_dissipated": e_diss, "E_load": e_load, "E_stored": stored + extra})
    return out


def integrate(rhs, t0: float, t1: float, y0: np.ndarray, options: SolverOptions, events: list,
              n_dynamic: int | None = None):
    """One integration segment with ``solve_ivp``'s method (:func:`.ode_solvers.solve_segment`: dense
    output, terminal events); raises
    :class:`SimulationError` when the integrator fails.

    ``n_dynamic``: the right-hand side depends on the first ``n_dynamic`` states only (the rest
    are quadratures, the energy integrals); the implicit methods then get a finite-difference
    Jacobian over those columns, the others being zero, instead of differencing every state
    (``rhs.partial_jacobian(n_dynamic)`` when ``rhs`` has one: the same differences, computed by
    the compiled right-hand side in one call).
    """
    from .ode_solvers import SOLVERS, solve_segment  # here, not at import: reading a scenario needs no scipy

    outside: list[StateOutOfDomain] = []

    def guarded(t, y):
        # a trial state outside a component's domain: NaN makes the solver reject the step and retry
        # a shorter one (an accepted state is checked again by the events and the monitor)
        try:
            return rhs(t, y)
        except StateOutOfDomain as exc:
            outside.append(exc)
            return np.full(len(y), np.nan)

    extra = {}
    # at most an eighth of the segment per step: a segment starts and ends at kinks, often where a
    # forcing is zero (an apply between two zero crossings), and a solver whose first step is chosen
    # from a zero derivative would otherwise step over the whole pulse with no error to see (BDF does)
    max_step = min(options.max_step, (t1 - t0) / 8.0) if t1 > t0 else options.max_step
    if n_dynamic is not None and options.method in ("LSODA", "BDF", "Radau"):
        # the Jacobian is taken at accepted states: a state outside the domain there stops the run
        jacobian = getattr(rhs, "partial_jacobian", None)  # a compiled right-hand side's own, one call
        extra["jac"] = jacobian(n_dynamic) if jacobian is not None else _partial_jacobian(rhs, len(y0), n_dynamic)
    try:
        sol = solve_segment(guarded, t0, t1, y0, SOLVERS.get(options.method, options.method), events,
                            rtol=options.rtol, atol=options.atol, max_step=max_step, **extra)
    except ValueError as exc:  # a solver's linear algebra refusing the NaN of a rejected trial state
        if outside:
            raise outside[-1] from None
        raise SimulationError(f"t={t0:.6g} s: integrator failed: {exc}") from None
    if sol.status == -1:
        why = f" (last trial state outside its domain: {outside[-1]})" if outside else ""
        raise SimulationError(f"t={sol.t[-1]:.6g} s: integrator failed: {sol.message}{why}")
    if not np.all(np.isfinite(sol.y[:, -1])) and outside:
        raise outside[-1]
    missed = missed_crossing(sol, events)
    if missed is not None:
        sol = cut_at(sol, missed[0], missed[1], len(events))
    return sol


def _partial_jacobian(rhs, n: int, n_dynamic: int):
    """Forward-difference Jacobian of ``rhs`` whose columns past ``n_dynamic`` are zero."""
    sqrt_eps = math.sqrt(np.finfo(float).eps)

    def jac(t, y):
        f0 = rhs(t, y)
        out = np.zeros((n, n))
        for j in range(n_dynamic):
            h = sqrt_eps * max(abs(y[j]), 1e-3)
            yj = y.copy()
            yj[j] += h
            out[:, j] = (rhs(t, yj) - f0) / (yj[j] - y[j])
        return out

    return jac
