"""Runde's mode-switching method (thesis 3.2) with located events.

The states are the generalized coordinates of the current mode, the states of the components
(engine, driveline, ...) and three energy integrals. Between events the mode and the slip
direction of every slipping element are fixed, so the right-hand side is smooth. The integrator
(``scipy.integrate.solve_ivp``, through :func:`.integration.integrate`) locates, by root finding
on its dense output:

* a slipping element's slip crossing zero (it may lock, or slip the other way);
* a locked friction element's torque reaching its static capacity ``T_static * apply(t)``;
* a locked one-way clutch's torque reversing;
* a locked group of elements in parallel leaving its combined holding range
  (:meth:`Transmission.holding_margin` gives all three);
* an apply signal rising from zero or falling to zero (a kink of the element's torque, and an
  element at zero slip may lock).

A slip within the decision's tolerance is at zero slip: the speeds are projected so that it is
exactly zero, and its slip event fires when the slip, moving off in its direction, comes back a
thousandth of the tolerance past zero, so that a slip that accelerates the wrong way is caught at
once, never run away from (:func:`.integration.slip_event`).

At each event, and at each breakpoint of an input signal, the new mode is decided by
:meth:`Transmission.decide` (every element at zero slip may lock or slip either way; the unique
consistent combination is taken, otherwise the run stops naming the elements). The new mode's
states are the link speeds at the event, so no link speed jumps.

Between events the right-hand side and the torque events' holding margins are evaluated by the
compiled kernel of :mod:`.kernel` (the same formulas, compiled with numba; the components without a
compiled form are evaluated in Python and passed in), or, without numba or with
``TRANSGEN_JIT=0``, by the Python functions ``point`` and ``locked_torques`` below.
"""
from __future__ import annotations

import math
import time as _time

import numpy as np

from transgen.errors import ModeError, SimulationError

from .integration import (ComponentEvaluator, Powertrain, Recorder, Segment, SolverOptions, StateLayout, apply_events,
                          collect, left_of, memo_last, next_stop, sample_block, signal_time,
                          slip_event)
from .kernel import compiled_powertrain
from .restart import SimState, check_compatible, controller_state, restore_controllers
from ..core.result import Event, Result

__all__ = ["simulate_switching"]


def simulate_switching(pt: Powertrain, options: SolverOptions, progress=None, start: SimState | None = None) -> Result:
    """Simulate ``pt`` with Runde's mode-switching method (see the module docstring); from the
    saved state ``start`` (:mod:`.restart`, at ``options.t_start``) when given. The result's
    ``state`` is the run's state at its end."""
    tr = pt.transmission
    model = ComponentEvaluator(pt)
    wall = _time.perf_counter()
    t = options.t_start
    recorder = Recorder(pt, options, _sample)
    events: list[Event] = []
    message, success = "completed", True
    zeno_time, zeno_count = -math.inf, 0
    n_events = 0
    if start is None:
        w = np.asarray(pt.initial_speeds, dtype=float).copy()
        comp_states = [c.initial_state(w) for c in pt.components]
        locked: frozenset | None = None
        directions = np.sign(tr.P @ w).astype(int)
        energy = np.zeros(3)
        forced: dict[int, int] = {}
    else:
        check_compatible(pt, start, t)
        restore_controllers(pt, start)
        w, locked, directions = start.w.copy(), start.locked, start.directions.copy()
        comp_states = [np.array(x, dtype=float) for x in start.components]
        energy, forced = start.energy.copy(), dict(start.forced)
        if locked is not None:  # else the first decision is still to come, as in a fresh run
            events.append(Event(t, "start", tuple(tr.elements[i].name for i in sorted(locked)), "",
                                tr.mode_name(locked), "from a saved state"))
    own_applies = {e.name: e.apply for e in tr.elements}  # what the controllers command differs
    quiet = False
    compiled = compiled_powertrain(pt) if tr.mesh is None else None  # mesh losses: the Python path only
    mesh_slot = _mesh_slot(pt)

    def slip_tol(w):
        return max(1e-9, options.slip_tol * max(1.0, float(np.max(np.abs(w)))))

    while t < options.t_end - 1e-12:
        # the consistent mode at t
        dummy_layout = StateLayout(pt.components, 0)
        y_ext = np.concatenate(comp_states + [energy]) if comp_states else energy.copy()
        t_sig = signal_time(pt, t)
        u_ext, *_ = model.external(t_sig, y_ext, w, dummy_layout)
        previous = locked
        try:
            if not (quiet and _mode_holds(tr, t_sig, w, locked, slip_tol(w))):
                locked, directions = tr.decide(t_sig, w, u_ext, slip_tol(w), forced, previous or frozenset(),
                                               None if previous is None else directions)
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
        # project onto the new mode, and the slips at zero (within the tolerance) onto exactly zero, so
        # that an element moving off from zero slip starts there and not at round-off on either side
        # (no jump: these slips are below the tolerance)
        q = w[mode.coords]
        tol = slip_tol(w)
        at_zero = [i for i in range(len(tr.elements)) if i not in locked and abs(tr.P[i] @ w) <= tol]
        a = tr.P[at_zero] @ mode.C
        if a.size:  # rows not held at zero by the mode already (round-off rows would zero a coordinate)
            a = a[np.linalg.norm(a, axis=1) > 1e-9 * max(1.0, float(np.max(np.abs(mode.C))))]
        if a.size:
            q = q - np.linalg.lstsq(a, a @ q, rcond=1e-9)[0]
        w = mode.C @ q
        layout = StateLayout(pt.components, mode.dof)
        y0 = np.concatenate([q] + comp_states + [energy])
        slipping = [i for i in range(len(tr.elements)) if i not in locked]
        t_stop = next_stop(pt, t, options.t_end, slipping)
        seg_dirs = directions.copy()

        def point(tt, y, C=mode.C, PC=tr.P @ mode.C, dof=mode.dof, layout=layout,
                  active=tr.slipping_set(locked, seg_dirs, t, t_stop)):
            q = y[:dof]
            ww = C @ q
            u, derivs, p_in, diss, p_load = model.external(tt, y, ww, layout)
            slips = PC @ q
            if active:
                diss = _add_slipping(u, tt, slips.tolist(), active, diss)
            qd, _, mesh = tr.response(mode, u, ww)
            return ww, u, derivs, p_in, diss + mesh, p_load, slips, qd, mesh

        evaluate = memo_last(model, point, t_stop, t_sig)

        def locked_torques(tt, y, C=mode.C, PC=tr.P @ mode.C, D=mode.D, dof=mode.dof, layout=layout,
                           active=tr.slipping_set(locked, seg_dirs, t, t_stop)):
            # the torques of the locked rows from the input vector of ``point`` alone: what the torque
            # events need at every step end
            q = y[:dof]
            u = model.inputs(tt, y, C @ q, layout)
            if active:
                _add_slipping(u, tt, (PC @ q).tolist(), active)
            return (D @ u if tr.mesh is None else tr.response(mode, u, C @ q)[1]).tolist()

        event_torques = memo_last(model, locked_torques, t_stop, t_sig, "input_calls")

        def rhs(tt, y, mode=mode, layout=layout):
            ww, u, derivs, p_in, diss, p_load, _, qd, mesh = evaluate(tt, y)
            out = layout.derivative(qd, derivs, p_in, diss, p_load)
            if mesh_slot is not None:
                out[mode.dof + mesh_slot] += mesh  # the mesh energy by kind (:mod:`..model.losses`)
            return out

        def margin(tt, y, row, mode=mode):
            return tr.holding_margin(mode, row, tt, event_torques(tt, y)[row])

        inputs = lambda tt, y: evaluate(tt, y)[1]  # noqa: E731
        PC = tr.P @ mode.C
        applies = apply_events(tr, slipping, t_sig, t_stop)
        slip_events = [slip_event(lambda tt, y, PC=PC, dof=mode.dof: PC @ y[:dof], i, int(seg_dirs[i]), tol, PC[i])
                       for i in slipping if seg_dirs[i] != 0]
        step_events = None
        if compiled is not None:  # the same functions, compiled (see the module docstring)
            compiled = compiled.current()
            kernel = compiled.segment(mode, layout, tr.slipping_set(locked, seg_dirs, t, t_stop),
                                      [f.info[1] for f in applies], [f.linear for f in slip_events])
            rhs = memo_last(model, kernel.rhs, t_stop, t_sig)
            inputs = memo_last(model, kernel.inputs, t_stop, t_sig)
            if kernel.jacobian is not None:
                rhs.partial_jacobian = _jacobian(model, kernel.jacobian, t_stop, t_sig)
            # every event's value at a step end from one evaluation (ode_solvers: ``batch``)
            step_events = memo_last(model, kernel.events, t_stop, t_sig, "input_calls")
            # in the order of event_funcs: the slips, the applies, the locked rows
            for k, f in enumerate(slip_events):  # the event itself stays linear (for the root and the scan)
                f.batch = (step_events, k)
            applies = [_from_batch(step_events, len(slip_events) + k, f) for k, f in enumerate(applies)]
            first_row = len(slip_events) + len(applies)

            def margin(tt, y, row, step_events=step_events, first_row=first_row):
                return step_events(tt, y)[first_row + row]
        event_funcs = slip_events + applies
        for row, i in enumerate(mode.locked_order):  # one row per locked element or group in parallel

            def torque_event(tt, y, row=row, margin=margin):
                return margin(tt, y, row)

            if step_events is not None:
                torque_event.batch = (step_events, first_row + row)

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
            sol = recorder.integrate(rhs, t, t_stop, y0, event_funcs, layout.energy.start,
                                     lambda t1, dense: Segment(t, t1, locked, seg_dirs, mode, dense),
                                     f"mode {tr.mode_name(locked)}")
        except SimulationError as exc:
            success, message = False, str(exc)
            break
        t_end = float(sol.t[-1])
        y_end = sol.y[:, -1]
        w = mode.C @ y_end[: mode.dof]
        comp_states = [y_end[sl] for sl in layout.slices]
        energy = y_end[layout.energy]
        forced = {}
        # a segment ended by a sampling controller alone (a driver, whose commands continue from
        # their values) changed nothing at its end: the mode goes on (see _mode_holds)
        quiet = sol.status == 1 and all(f.info[0] == "control" and getattr(f.info[1][0], "keeps_mode", False)
                                        for f, te in zip(event_funcs, sol.t_events) if len(te))
        if sol.status == 1:
            n_events += 1
            u_end = inputs(t_end, y_end)
            for f, te in zip(event_funcs, sol.t_events):
                kind, i = f.info
                if len(te) and kind == "control":
                    controller, what = i
                    description = controller.fire(what, t_end, {e.name: e for e in tr.elements}, w)
                    if description:
                        kind_of = getattr(controller, "event_kinds", {}).get(what, "command")  # e.g. "ease"
                        events.append(Event(t_end, kind_of, (), tr.mode_name(locked), tr.mode_name(locked), description))
                if len(te) and kind == "torque":
                    row = mode.locked_order.index(i)
                    torque = mode.D[row] @ u_end if tr.mesh is None else tr.response(mode, u_end, w)[1][row]
                    forced.update(tr.unlock_directions(mode, row, t_end, torque))
            if n_events > options.max_events:
                success, message = False, f"t={t_end:.6g} s: more than {options.max_events} events"
                break
        t = t_end
        if progress is not None:
            progress(t)

    result = collect(pt, options, recorder, events, success, message, model, wall)
    commanded = {e.name: e.apply for e in tr.elements if e.apply is not own_applies[e.name]}
    if start is not None:
        commanded = {**start.commanded, **commanded}
    result.state = SimState(t, w.copy(), locked, directions.copy(),
                            dict(forced), tuple(np.array(x, dtype=float) for x in comp_states), np.array(energy),
                            tuple(controller_state(c) for c in pt.controllers), commanded, SimState.shape_of(pt))
    return result


def _mode_holds(tr, t: float, w: np.ndarray, locked, tol: float) -> bool:
    """Whether the mode ``locked`` goes on at ``t`` without a decision, after a segment that a
    sampling controller alone ended (a driver: its commands are continuous there, so the speeds,
    the torques and the holding margins are those the last segment ended with, inside their
    limits, or a torque event would have ended it): no element outside the mode that could
    transmit torque is at zero slip (it might lock) and no apply signal has a breakpoint at ``t``."""
    if locked is None:
        return False
    slips = tr.P @ w
    after = t + 1e-12 * max(1.0, abs(t))
    for i, e in enumerate(tr.elements):
        if e.kind != "oneway" and any(t <= b <= after for b in e.apply.breakpoints(t, after)):
            return False
        if i not in locked and abs(slips[i]) <= tol and e.applied_after(t):
            return False
    return True


def _jacobian(model, jacobian, t_stop: float, t_from: float):
    """``partial_jacobian(n_dynamic)`` for :func:`.integration.integrate`: the compiled
    forward-difference Jacobian, with the signals' times as :func:`.integration.memo_last` takes
    them, its right-hand-side evaluations counted."""
    t_left = left_of(t_stop)

    def partial_jacobian(n_dynamic):
        def jac(t, y):
            model.calls += n_dynamic + 1
            return jacobian(min(max(t, t_from), t_left), y, n_dynamic)
        return jac

    return partial_jacobian


def _from_batch(values, index: int, like):
    """The event ``like`` (its attributes) as entry ``index`` of the vector ``values(t, y)``."""
    def event(tt, y):
        return values(tt, y)[index]

    event.terminal, event.direction, event.info = like.terminal, like.direction, like.info
    event.batch = (values, index)
    return event


def _add_slipping(u: np.ndarray, t: float, slips: list, active: tuple, dissipated: float = 0.0) -> float:
    """Add the torques of the slipping elements ``active`` (:meth:`Transmission.slipping_set`) at
    the slips ``slips`` [rad/s] to the input vector ``u``; returns ``dissipated`` [W] plus their
    dissipation."""
    for i, col, e, scale in active:
        torque = e.torque_at(t, slips[i], scale)
        u[col] += torque
        dissipated += torque * slips[i]
    return dissipated


def _sample(pt: Powertrain, seg: Segment, ts: np.ndarray, ys: np.ndarray) -> dict[str, np.ndarray]:
    tr = pt.transmission
    mode = seg.mode
    slipping = np.array([i not in seg.locked for i in range(len(tr.elements))])
    mesh = np.zeros(len(ts))

    def element_state(W, slips, U):
        te = tr.slipping_torques_at(ts, W, seg.locked, seg.directions)
        torques = te.copy()
        if mode.locked_order or tr.mesh is not None:
            full = U.copy()
            full[tr.element_input] += te
            if tr.mesh is None:
                rows = mode.D @ full
            else:  # the lossy equations at each time (:meth:`Transmission.response`)
                rows = np.zeros((len(mode.locked_order), len(ts)))
                for k in range(len(ts)):
                    _, rows[:, k], mesh[k] = tr.response(mode, full[:, k], W[:, k])
            if mode.locked_order:
                torques += tr.split_locked_torques(mode, ts, rows)  # per element, by the split rule
        power = np.where(slipping[:, None], np.abs(torques * slips), 0.0)
        return te, torques, power, 0.0

    out = sample_block(pt, seg, ts, ys, 0, element_state)
    if tr.mesh is not None:
        out["P_mesh"] = mesh
    return out


def _mesh_slot(pt: Powertrain):
    """Where the loss component's ``E_mesh`` state is among the component states (None: no mesh
    losses)."""
    from ..model.losses import LossComponent

    pos = 0
    for c in pt.components:
        if isinstance(c, LossComponent) and "E_mesh" in c.state_names:
            return pos + c.state_names.index("E_mesh")
        pos += len(c.state_names)
    return None
