"""Running a powertrain: Runde's mode-switching method (thesis 3.2) with located events, and the
compliant (Haessig) clutch model for comparison.

Mode switching: the states are the generalized coordinates of the current mode, the states of
the components (engine, driveline, ...) and three energy integrals. Between events the mode and
the slip direction of every slipping element are fixed, so the right-hand side is smooth. The
integrator (``scipy.integrate.solve_ivp``) locates, by root finding on its dense output:

* a slipping element's slip crossing zero (it may lock, or slip the other way);
* a locked friction element's torque reaching its static capacity ``T_static * apply(t)``;
* a locked one-way clutch's torque reversing;
* a locked group of elements in parallel leaving its combined holding range
  (:meth:`Transmission.holding_margin`, which also gives the two cases above).

At each event, and at each breakpoint of an input signal, the new mode is decided by
:meth:`Transmission.decide` (every element at zero slip may lock or slip either way; the unique
consistent combination is taken, otherwise the run stops naming the elements). The new mode's
states are the link speeds at the event, so no link speed jumps.
"""
from __future__ import annotations

import math
import time as _time
from dataclasses import dataclass, field

import numpy as np
from scipy.integrate import solve_ivp

from transgen.errors import ModeError, SimulationError

from .components import Component
from .result import Event, ModeSpan, Result
from .transmission import ModeData, Transmission

__all__ = ["SolverOptions", "Powertrain", "simulate"]


@dataclass(frozen=True)
class SolverOptions:
    """Integration settings.

    ``model``: ``"switching"`` (Runde's method) or ``"compliant"`` (Haessig's: a locked
    element is a spring ``stiffness`` [N*m/rad] with damper ``damping`` [N*m*s/rad]).
    ``output_dt``: spacing of the output samples [s]. ``slip_tol``: slip speed [rad/s] below
    which an element counts as at zero slip in the mode decision (relative to the largest link
    speed, at least 1e-9).
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
class _Segment:
    t0: float
    t1: float
    locked: frozenset
    directions: np.ndarray
    mode: ModeData | None
    sol: object
    stuck: np.ndarray | None = None  # compliant model: which elements act as springs


class _Layout:
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
        out = np.empty(self.size)
        out[: self.offset] = head
        for sl, dx in zip(self.slices, derivs):
            out[sl] = dx
        out[self.energy] = (p_in, dissipated, p_load)
        return out


def _breakpoints(pt: Powertrain, t0: float, t1: float) -> list[float]:
    points = set()
    for e in pt.transmission.elements:
        points.update(e.breakpoints())
    for c in pt.components:
        points.update(c.breakpoints())
    return sorted(p for p in points if t0 < p < t1)


class _Model:
    """Shared evaluation for both clutch models: component torques and energy rates."""

    def __init__(self, pt: Powertrain):
        self.pt = pt
        self.tr = pt.transmission
        self.components = pt.components
        self.n_u = len(self.tr.inputs)
        self.calls = 0

    def external(self, t: float, y: np.ndarray, w: np.ndarray, layout: _Layout):
        """External input vector (component torques), component derivatives (in the order of
        ``layout.slices``) and the power in, dissipated and passed to the load [W]."""
        u = np.zeros(self.n_u)
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
        return u, derivs, p_in, dissipated, p_load


def memo_last(model: "_Model", func):
    """``func(t, y)`` remembered for the last ``(t, y)``: the integrator calls the right-hand side
    and every event function with the same point, which then costs one evaluation
    (counted in ``model.calls``)."""
    last = {}

    def wrapper(t, y):
        key = (t, y.tobytes())
        if key not in last:
            model.calls += 1
            last.clear()
            last[key] = func(t, y)
        return last[key]

    return wrapper


def _check_finite(t, y, where: str):
    if not np.all(np.isfinite(y)):
        raise SimulationError(f"t={t:.6g} s: non-finite state in {where}")


def simulate(pt: Powertrain, options: SolverOptions = SolverOptions(), progress=None) -> Result:
    """Simulate ``pt`` from ``options.t_start`` to ``options.t_end``.

    ``progress``: optional callable ``progress(t)`` called after every integration segment.
    Returns a :class:`Result`; on failure ``success`` is False and ``message`` says when, in which
    mode and why (the samples up to the failure are kept).
    """
    if options.model == "compliant":
        from .compliant import simulate_compliant

        return simulate_compliant(pt, options, progress)
    if options.model != "switching":
        raise ValueError(f"unknown clutch model {options.model!r}: choose 'switching' or 'compliant'")
    return _simulate_switching(pt, options, progress)


def _simulate_switching(pt: Powertrain, options: SolverOptions, progress) -> Result:
    tr = pt.transmission
    model = _Model(pt)
    wall = _time.perf_counter()
    w0 = np.asarray(pt.initial_speeds, dtype=float)
    comp_states = [c.initial_state(w0) for c in pt.components]
    t = options.t_start
    segments: list[_Segment] = []
    events: list[Event] = []
    message, success = "completed", True
    locked: frozenset | None = None
    directions = np.sign(tr.P @ w0).astype(int)
    energy = np.zeros(3)
    zeno_time, zeno_count = -math.inf, 0
    n_events = 0
    w = w0.copy()
    forced: dict[int, int] = {}

    def slip_tol(w):
        return max(1e-9, options.slip_tol * max(1.0, float(np.max(np.abs(w)))))

    while t < options.t_end - 1e-12:
        # the consistent mode at t
        dummy_layout = _Layout(pt.components, 0)
        y_ext = np.concatenate(comp_states + [energy]) if comp_states else energy.copy()
        u_ext, *_ = model.external(t, y_ext, w, dummy_layout)
        previous = locked
        try:
            locked, directions = tr.decide(t, w, u_ext, slip_tol(w), forced)
            mode = tr.mode(locked)
        except (SimulationError, ModeError) as exc:
            success, message = False, f"{exc} (mode {tr.mode_name(previous) if previous is not None else 'none'})"
            break
        if previous is None:
            events.append(Event(t, "start", tuple(tr.elements[i].name for i in sorted(locked)), "", tr.mode_name(locked)))
        elif locked != previous:
            gained = sorted(locked - previous)
            lost = sorted(previous - locked)
            kind = "lock" if gained and not lost else ("unlock" if lost and not gained else "switch")
            events.append(Event(t, kind, tuple(tr.elements[i].name for i in gained + lost),
                                tr.mode_name(previous), tr.mode_name(locked)))
        # zeno / chattering guard: many decisions at (nearly) the same instant
        if t - zeno_time < 1e-9 * max(1.0, abs(t)):
            zeno_count += 1
            if zeno_count > 50:
                names = sorted({x for ev in events[-10:] for x in ev.elements})
                success, message = False, (f"t={t:.9g} s: mode chattering (Zeno behaviour) between "
                                           f"{', '.join(names)} in mode {tr.mode_name(locked)}")
                break
        else:
            zeno_time, zeno_count = t, 0
        w = mode.C @ w[mode.coords]  # project onto the new mode (no jump: slips of locking elements ~0)
        layout = _Layout(pt.components, mode.dof)
        y0 = np.concatenate([w[mode.coords]] + comp_states + [energy])
        breaks = _breakpoints(pt, t, options.t_end)
        t_stop = min([b for b in breaks if b > t + 1e-12] + [options.t_end])
        seg_dirs = directions.copy()
        slipping = [i for i in range(len(tr.elements)) if i not in locked]

        def point(tt, y, C=mode.C, PC=tr.P @ mode.C, dof=mode.dof, layout=layout,
                  active=tr.slipping_set(locked, seg_dirs, t, t_stop)):
            q = y[:dof]
            ww = C @ q
            u, derivs, p_in, diss, p_load = model.external(tt, y, ww, layout)
            slips = PC @ q
            if active:
                s = slips.tolist()
                for i, col, e, scale in active:
                    torque = e.torque_at(tt, s[i], scale)
                    u[col] += torque
                    diss += torque * s[i]
            return ww, u, derivs, p_in, diss, p_load, slips

        evaluate = memo_last(model, point)

        def rhs(tt, y, mode=mode, layout=layout):
            ww, u, derivs, p_in, diss, p_load, _ = evaluate(tt, y)
            return layout.derivative(mode.B @ u, derivs, p_in, diss, p_load)

        event_funcs = []
        # an element starting at zero slip (open, or a one-way clutch) moves off in the direction
        # of its slip acceleration; the event must only catch it coming back through zero
        _, u0, *_ = evaluate(t, y0)
        start_acc = tr.P @ (mode.C @ (mode.B @ u0))
        start_slip = tr.P @ w
        for i in slipping:
            e = tr.elements[i]
            moving = seg_dirs[i] if abs(start_slip[i]) > slip_tol(w) else int(np.sign(start_acc[i]))

            def slip_event(tt, y, i=i):
                return evaluate(tt, y)[6][i]

            slip_event.terminal = True
            slip_event.direction = -moving
            if moving == 0:
                continue
            slip_event.info = ("slip", i)
            event_funcs.append(slip_event)
        for row, i in enumerate(mode.locked_order):

            def torque_event(tt, y, row=row, mode=mode):
                return tr.holding_margin(mode, row, tt, mode.D[row] @ evaluate(tt, y)[1])

            torque_event.terminal = True
            torque_event.direction = -1
            torque_event.info = ("torque", i)
            event_funcs.append(torque_event)

        for controller in pt.controllers:
            for func, kind in controller.event_functions():

                def control_event(tt, y, func=func, mode=mode):
                    return func(tt, mode.C @ y[: mode.dof])

                control_event.terminal = True
                control_event.direction = -1
                control_event.info = ("control", (controller, kind))
                event_funcs.append(control_event)

        try:
            sol = integrate(rhs, t, t_stop, y0, options, event_funcs, layout.energy.start)
        except SimulationError as exc:
            success, message = False, f"{exc} (mode {tr.mode_name(locked)})"
            break
        t_end = float(sol.t[-1])
        segments.append(_Segment(t, t_end, locked, seg_dirs, mode, sol.sol))
        y_end = sol.y[:, -1]
        _check_finite(t_end, y_end, f"mode {tr.mode_name(locked)}")
        w = mode.C @ y_end[: mode.dof]
        comp_states = [y_end[sl] for sl in layout.slices]
        energy = y_end[layout.energy]
        forced = {}
        if sol.status == 1:
            n_events += 1
            u_end = evaluate(t_end, y_end)[1]
            for f, te in zip(event_funcs, sol.t_events):
                kind, i = f.info
                if len(te) and kind == "control":
                    controller, what = i
                    description = controller.fire(what, t_end, {e.name: e for e in tr.elements})
                    if description:
                        events.append(Event(t_end, "command", (), tr.mode_name(locked), tr.mode_name(locked), description))
                if len(te) and kind == "torque":
                    row = mode.locked_order.index(i)
                    forced.update(tr.unlock_directions(mode, row, t_end, mode.D[row] @ u_end))
            if n_events > options.max_events:
                success, message = False, f"t={t_end:.6g} s: more than {options.max_events} events"
                break
        t = t_end
        if progress is not None:
            progress(t)

    return _collect(pt, options, segments, events, success, message, model, wall)


def _collect(pt: Powertrain, options: SolverOptions, segments: list[_Segment], events: list[Event], success: bool,
             message: str, model: _Model, wall: float, sampler=None) -> Result:
    """Sample every segment on the output grid and compute the named signals.

    ``sampler(pt, seg, ts, ys)`` gives the signals of one segment at the times ``ts`` from its
    states ``ys`` (one column per time) as a dict of arrays (default: the mode-switching
    model's :func:`_sample`)."""
    tr = pt.transmission
    e_names = [e.name for e in tr.elements]
    blocks: list[dict[str, np.ndarray]] = []
    times: list[np.ndarray] = []
    mode_names = []
    order: list[str] = []
    for seg in segments:
        grid = np.arange(math.ceil((seg.t0 + 1e-12) / options.output_dt) * options.output_dt, seg.t1, options.output_dt)
        grid = grid[(grid > seg.t0 + 1e-12) & (grid < seg.t1 - 1e-12)]
        ts = np.concatenate([[seg.t0], grid, [seg.t1]])
        blocks.append((sampler or _sample)(pt, seg, ts, seg.sol(ts)))  # the dense output at all samples at once
        times.append(ts)
        name = tr.mode_name(seg.locked)
        if name not in order:
            order.append(name)
        mode_names.append(np.full(len(ts), order.index(name) + 1.0))
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
    for seg in segments:
        name = tr.mode_name(seg.locked)
        locked = tuple(tr.elements[i].name for i in sorted(seg.locked))
        if spans and spans[-1].name == name and abs(spans[-1].t1 - seg.t0) < 1e-12:
            spans[-1] = ModeSpan(spans[-1].t0, seg.t1, name, locked)
        else:
            spans.append(ModeSpan(seg.t0, seg.t1, name, locked))
    energy = {}
    if len(time_arr):
        e_in, e_diss, e_load, e_st = (arrays[k] for k in ("E_in", "E_dissipated", "E_load", "E_stored"))
        d_stored = e_st[-1] - e_st[0]
        residual = e_in[-1] - (d_stored + e_diss[-1] + e_load[-1])
        energy = {"work_in": float(e_in[-1]), "stored_change": float(d_stored), "dissipated": float(e_diss[-1]),
                  "work_to_load": float(e_load[-1]), "residual": float(residual),
                  "relative_residual": float(abs(residual) / max(abs(e_in[-1]), 1e-12))}
    stats = {"wall_time": _time.perf_counter() - wall, "rhs_evaluations": model.calls,
             "events": sum(1 for e in events if e.kind != "start"), "segments": len(segments)}
    meta = {"mechanism": tr.mech.name, "model": options.model, "links": list(tr.links), "elements": e_names,
            "mode_names": order, "coordinates": list(tr.coordinates)}
    return Result(time_arr, arrays, units, spans, events, success, message, energy, stats, meta)


def sample_block(pt: Powertrain, seg: _Segment, ts: np.ndarray, ys: np.ndarray, n_extra: int,
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
    layout = _Layout(pt.components, dof + n_extra)
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


def _sample(pt: Powertrain, seg: _Segment, ts: np.ndarray, ys: np.ndarray) -> dict[str, np.ndarray]:
    tr = pt.transmission
    mode = seg.mode
    slipping = np.array([i not in seg.locked for i in range(len(tr.elements))])

    def element_state(W, slips, U):
        te = tr.slipping_torques_at(ts, W, seg.locked, seg.directions)
        torques = te.copy()
        if mode.locked_order:
            full = U.copy()
            full[tr.element_input] += te
            torques += tr.split_locked_torques(mode, ts, mode.D @ full)
        power = np.where(slipping[:, None], np.abs(torques * slips), 0.0)
        return te, torques, power, 0.0

    return sample_block(pt, seg, ts, ys, 0, element_state)


def integrate(rhs, t0: float, t1: float, y0: np.ndarray, options: SolverOptions, events: list,
              n_dynamic: int | None = None):
    """One integration segment with ``solve_ivp`` (dense output, terminal events); raises
    :class:`SimulationError` when the integrator fails.

    ``n_dynamic``: the right-hand side depends on the first ``n_dynamic`` states only (the rest
    are quadratures, the energy integrals); the implicit methods then get a finite-difference
    Jacobian over those columns, the others being zero, instead of differencing every state.
    """
    extra = {}
    if n_dynamic is not None and options.method in ("LSODA", "BDF", "Radau"):
        extra["jac"] = _partial_jacobian(rhs, len(y0), n_dynamic)
    sol = solve_ivp(rhs, (t0, t1), y0, method=options.method, rtol=options.rtol, atol=options.atol,
                    max_step=options.max_step, events=events, dense_output=True, **extra)
    if sol.status == -1:
        raise SimulationError(f"t={sol.t[-1]:.6g} s: integrator failed: {sol.message}")
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
