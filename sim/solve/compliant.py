"""The compliant clutch model (Haessig et al., thesis 3.2.1-3.2.2), for comparison with Runde's
mode-switching method.

The transmission keeps one state per independent inertia (the generalized coordinates of the
mode with nothing locked) and every shift element is a submodel of its own: while it sticks it
is a stiff torsional spring ``k`` with damper ``c`` (its twist ``phi`` is a state), while it slips
it transmits ``T_dyn * apply * sign(slip)``. It starts to stick when its slip crosses zero (with
``phi = 0``) and slips again when the spring-damper torque exceeds the static capacity (a
one-way clutch: when its torque reverses), in the direction of that torque, its spring's twist
and twist rate going into the damper (:func:`_absorb_twist_rate`). The stiff springs make the equations stiff: the
default integrator is Radau. The same scenario files run with either model.
"""
from __future__ import annotations

import math
import time as _time

import numpy as np

from transgen.errors import ModeError, SimulationError

from ..core.result import Event
from .integration import (ComponentEvaluator, Powertrain, Recorder, Segment, SolverOptions, StateLayout, apply_events,
                          collect, memo_last, next_stop, sample_block, signal_time,
                          slip_event)

__all__ = ["simulate_compliant"]


def simulate_compliant(pt: Powertrain, options: SolverOptions, progress=None):
    """Simulate with the compliant clutch model (see the module docstring)."""
    tr = pt.transmission
    dogs = [e.name for e in tr.elements if e.kind == "dog"]
    if dogs:
        raise SimulationError(f"the compliant clutch model has no dog elements ({', '.join(dogs)}: a dog has no "
                              f"slipping torque for a spring to load); use the default switching model")
    model = ComponentEvaluator(pt)
    wall = _time.perf_counter()
    try:
        mode = tr.mode(frozenset())
    except ModeError as exc:
        raise SimulationError(f"the compliant model needs the mode with nothing locked: {exc}") from None
    n_e = len(tr.elements)
    k, c = options.stiffness, options.damping
    w = np.asarray(pt.initial_speeds, dtype=float)
    comp_states = [cmp.initial_state(w) for cmp in pt.components]
    energy = np.zeros(3)
    phi = np.zeros(n_e)
    slips0 = tr.P @ w
    tol = max(1e-9, options.slip_tol * max(1.0, float(np.max(np.abs(w)))))
    stuck = np.array([abs(slips0[i]) <= tol and e.applied_after(options.t_start) for i, e in enumerate(tr.elements)])
    directions = np.sign(slips0).astype(int)
    directions[np.abs(slips0) <= tol] = 0  # round-off is no direction; set from the slip acceleration below
    t = options.t_start
    recorder = Recorder(pt, options, lambda p, seg, ts, ys: _sample(p, seg, ts, ys, k, c))
    events = [Event(t, "start", tuple(e.name for e, s in zip(tr.elements, stuck) if s), "", _name(tr, stuck))]
    success, message = True, "completed"
    layout = StateLayout(pt.components, mode.dof + n_e)
    spring = slice(mode.dof, mode.dof + n_e)
    zeno_time, zeno_count = -math.inf, 0
    while t < options.t_end - 1e-12:
        y0 = np.concatenate([w[mode.coords], phi] + comp_states + [energy])
        seg_stuck = stuck.copy()
        seg_locked = frozenset(np.flatnonzero(seg_stuck))
        t_stop = next_stop(pt, t, options.t_end, np.flatnonzero(~seg_stuck))

        def point(tt, y, seg_stuck=seg_stuck, PC=tr.P @ mode.C, active=()):
            q = y[: mode.dof]
            ww = mode.C @ q
            u, derivs, p_in, diss, p_load = model.external(tt, y, ww, layout)
            slips = PC @ q
            te = np.where(seg_stuck, k * y[spring] + c * slips, 0.0)  # stuck: spring-damper
            diss += c * float(np.sum(np.where(seg_stuck, slips * slips, 0.0)))
            s = slips.tolist()
            for i, _, e, scale in active:  # slipping: as in the mode-switching model
                te[i] = e.torque_at(tt, s[i], scale)
                diss += te[i] * s[i]
            u[tr.element_input] += te
            return ww, u, derivs, p_in, diss, p_load, slips, te

        # elements at zero slip that are not sticking move off the way their slip accelerates under
        # the torques of everything else, the slipping elements' friction included
        at_zero = ~seg_stuck & (directions == 0)
        if at_zero.any():
            u0 = point(signal_time(pt, t), y0, seg_stuck, tr.P @ mode.C,
                       tr.slipping_set(seg_locked, directions, t, t_stop))[1]
            acc = tr.P @ (mode.C @ (mode.B @ u0))
            directions = np.where(at_zero, np.sign(acc).astype(int), directions)
        seg_dirs = directions.copy()
        point.__defaults__ = (seg_stuck, tr.P @ mode.C, tr.slipping_set(seg_locked, seg_dirs, t, t_stop))
        evaluate = memo_last(model, point, t_stop, signal_time(pt, t))

        def rhs(tt, y, seg_stuck=seg_stuck):
            ww, u, derivs, p_in, diss, p_load, slips, _ = evaluate(tt, y)
            return layout.derivative(np.concatenate([mode.B @ u, np.where(seg_stuck, slips, 0.0)]), derivs, p_in, diss, p_load)

        event_funcs = []
        PC = tr.P @ mode.C
        for i, e in enumerate(tr.elements):
            if seg_stuck[i]:
                def unstick(tt, y, i=i, e=e):
                    return e.holding_margin(tt, evaluate(tt, y)[7][i])
                unstick.terminal, unstick.direction, unstick.info = True, -1, ("unstick", i)
                event_funcs.append(unstick)
            elif seg_dirs[i] != 0:
                event_funcs.append(slip_event(lambda tt, y: evaluate(tt, y)[6], i, int(seg_dirs[i]), tol, PC[i]))
        event_funcs += apply_events(tr, np.flatnonzero(~seg_stuck), t, t_stop)
        try:
            sol = recorder.integrate(rhs, t, t_stop, y0, event_funcs, layout.energy.start,
                                     lambda t1, dense: Segment(t, t1, seg_locked, seg_dirs, mode, dense, seg_stuck),
                                     f"compliant model, sticking {_name(tr, seg_stuck)}")
        except SimulationError as exc:
            success, message = False, str(exc)
            break
        t_end = float(sol.t[-1])
        y_end = sol.y[:, -1]
        w = mode.C @ y_end[: mode.dof]
        phi = y_end[spring].copy()
        comp_states = [y_end[sl] for sl in layout.slices]
        energy = y_end[layout.energy]
        slips = tr.P @ w
        if sol.status == 1:
            for f, te in zip(event_funcs, sol.t_events):
                if not len(te):
                    continue
                kind, i = f.info
                e = tr.elements[i]
                before = _name(tr, stuck)
                if kind == "unstick":
                    t_e = evaluate(t_end, y_end)[7][i]
                    stuck[i] = False
                    directions[i] = e.free if e.kind == "oneway" else (1 if t_e > 0 else -1)
                    # the spring energy is released into the damper: account it as dissipated
                    energy[1] += 0.5 * k * phi[i] ** 2
                    if directions[i] * slips[i] < 0:
                        w, lost = _absorb_twist_rate(tr, mode, w, i)
                        energy[1] += lost
                        slips = tr.P @ w
                    phi[i] = 0.0
                    events.append(Event(t_end, "unlock", (e.name,), before, _name(tr, stuck)))
                elif abs(slips[i]) <= tol and e.applied_after(t_end):  # a slip back at zero, or an apply rising at it
                    stuck[i] = True
                    phi[i] = 0.0
                    events.append(Event(t_end, "lock", (e.name,), before, _name(tr, stuck)))
                elif kind == "slip":
                    directions[i] = 0  # through zero, released: the next segment takes the slip acceleration
            if t_end - zeno_time < 1e-9 * max(1.0, t_end):
                zeno_count += 1
                if zeno_count > 50:
                    success, message = False, f"t={t_end:.9g} s: chattering in the compliant model"
                    break
            else:
                zeno_time, zeno_count = t_end, 0
        else:
            directions = np.where(stuck, directions, np.where(np.abs(slips) <= tol, 0, np.sign(slips)).astype(int))
        t = t_end
        if progress is not None:
            progress(t)
    return collect(pt, options, recorder, events, success, message, model, wall)


def _absorb_twist_rate(tr, mode, w: np.ndarray, i: int):
    """The link speeds ``w`` [rad/s] after the breakaway of element ``i`` against its slip, and the
    kinetic energy [J] that took (>= 0, dissipated).

    A stuck element's slip is its spring's twist rate (``phi' = slip``): it has the sign of the
    spring torque while the torque grows, the other sign while the spring unwinds, as an
    off-going element does when its capacity falls below its torque faster than the torque falls
    (an upshift's release). The element breaks away in the direction of its torque (a one-way
    clutch: its free direction), as in the mode-switching model, and its spring goes with its
    twist and its twist rate: the twist's energy into the damper (accounted by the caller) and
    the twist rate taken up by the damper as a plastic angular impulse along the element
    (momentum kept, the slip brought to zero). Left in the links, that slip would make the
    element slide against its own friction torque (create energy) until the slip turns, and
    sliding the slip's way instead reverses the element's torque for an instant. Both the slip,
    ``(dT/dt) / k``, and the impulse vanish with the stiffness."""
    column = mode.B[:, int(tr.element_input[i])]  # state acceleration per unit element torque
    row = tr.P[i] @ mode.C                        # slip per state
    q = w[mode.coords] - column * (float(tr.P[i] @ w) / float(row @ column))
    after = mode.C @ q
    return after, 0.5 * float(tr.inertia @ (w * w - after * after))


def _name(tr, stuck) -> str:
    return tr.mode_name(i for i, s in enumerate(stuck) if s)


def _sample(pt, seg, ts, ys, k, c):
    tr = pt.transmission
    n_e = len(tr.elements)
    phi = ys[seg.mode.dof: seg.mode.dof + n_e]
    stuck = seg.stuck[:, None]

    def element_state(W, slips, U):
        te = tr.slipping_torques_at(ts, W, seg.locked, seg.directions)
        te = np.where(stuck, k * phi + c * slips, te)
        power = np.where(stuck, c * slips ** 2, np.abs(te * slips))
        return te, te, power, 0.5 * k * np.sum(np.where(stuck, phi ** 2, 0.0), axis=0)

    return sample_block(pt, seg, ts, ys, n_e, element_state)
