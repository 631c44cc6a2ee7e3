"""The compiled right-hand side of the mode-switching model (:mod:`.switching`).

The Python right-hand side is a tree of small calls (components, signals, table look-ups, element
torques); on the simulator's few-state systems those calls, not the arithmetic, cost the time. Here
the powertrain is described as data — two arrays of integers and numbers
(:class:`CompiledPowertrain`: the components' ``kernel_form()``, the signals' ``kernel_form()``,
the shift elements) plus two per mode (:meth:`CompiledPowertrain.segment`: the mode matrices, the
slipping elements, the locked rows) — and one function, compiled with numba, evaluates it:
the state derivative (:func:`rhs_kernel`), the input vector (:func:`inputs_kernel`) and the
values of the torque and apply events, the holding margins and the apply signals
(:func:`events_kernel`). It calls the very functions the Python
classes call (the :func:`~.jit.compilable` formulas of :mod:`.components`, :mod:`.signals`,
:mod:`.transmission`, :mod:`.interp` and the torque converter): there is one implementation of
the physics, and the two paths agree to round-off (the sums of the matrix products are taken in
another order than numpy's).

A component or a signal without a compiled form (``kernel_form()`` None, e.g. the turbocharged
diesel) is evaluated in Python at every call and its values are passed in (the array ``ext``):
such a powertrain runs compiled apart from it.

Layout of the powertrain arrays ``P`` (int64) and ``F`` (float64)::

    P[0:4]   number of components, offset of their records, number of elements, offset of theirs
    component record (8 integers): kind (:data:`COMPONENT_KINDS`, 0 for Python), position of its
             states after the mode's coordinates, number of states, offset of its numbers in F,
             of its integers in P, of its input columns in P, of its signal references in P,
             and (Python) of its block in ``ext``: [power in, dissipation, load power,
             derivatives..., input vector...]
    element record (8 integers): kind code (:data:`~.transmission.FRICTION` ...), free direction,
             apply signal (start, end), friction table (offset in F, length), offset of T_static
             in F, 0
    signal: a run of nodes of 4 integers (kind, offset of its numbers in F, their count, count
             of parts or index in ``ext``), parts before the whole: a reference is the (start,
             end) offsets of the run in P, evaluated as a stack machine (:func:`signal_value`)

The integers and numbers of each component kind, as its ``kernel_form()`` gives them::

    ``input_torque``      (link), ()
    ``engine_on_link``    (link, n_speeds, n_throttles, has_request), speeds + throttles + torque rows
                          + (idle,);
                          signals: the throttle and, where ``has_request``, the shifts' torque request
    ``engine_converter``  (link, n_speeds, n_throttles, n_drive, n_coast, has_request), (J_engine, idle)
                          + the engine map as above + the converter's tables (``kernel_numbers``)
    ``link_load``         (link), (c0, c1, c2)
    ``driveline``         (output link), (stiffness, damping, J_v, mass, rolling, grade, air density,
                          cd_a, wheel radius, final drive)
    ``converter``         (pump link, turbine link, n_drive, n_coast), the converter's tables
    ``braked_driveline``  as ``driveline``; signal: the wheel brake torque (:mod:`.brake`)

Size: about 530 lines, over the project's 500: the kernel and the description it reads are one
concept, kept together so that the layout written and the layout read cannot drift apart.
"""
from __future__ import annotations

import math

import numpy as np

from ..model.brake import braked_driveline_rates
from ..model.components import (driveline_rates, engine_converter_rates, governed_throttle, link_load_torque, requested_torque,
                         converter_loss, own_kernel_form)
from ..engine.torque_converter import converter_torques
from ..core.interp import interp2
from ..core.jit import compilable, compiled, jit_enabled, settle_after_loading
from ..core.signals import periodic_value, pulse_value, ramp_value, sine_value, step_value, table_value
from ..model.transmission import APPLY_THRESHOLD, ONEWAY, add_holding_range, element_margin, group_margin, slipping_torque, static_capacity

__all__ = ["CompiledPowertrain", "CompiledSegment", "compiled_powertrain", "rhs_kernel", "inputs_kernel",
           "events_kernel", "jacobian_kernel", "SIGNAL_KINDS", "COMPONENT_KINDS"]

SIGNAL_KINDS = {"constant": 1, "step": 2, "ramp": 3, "table": 4, "sine": 5, "pulse": 6, "periodic": 7, "sum": 8,
                "spliced": 9}
_SUM, _SPLICED, _EXTERNAL = 8, 9, 10
COMPONENT_KINDS = {"input_torque": 1, "engine_on_link": 2, "engine_converter": 3, "link_load": 4, "driveline": 5,
                   "converter": 6, "braked_driveline": 7}
_RECORD = 8
_SQRT_EPS = math.sqrt(np.finfo(float).eps)


# --------------------------------------------------------------------------- the kernel


@compilable
def _leaf(t, kind, foff, nf, aux, F, ext):
    """The value at ``t`` of a signal node without parts."""
    if kind == 1:
        return F[foff]
    if kind == 2:
        return step_value(t, F[foff], F[foff + 1], F[foff + 2])
    if kind == 3:
        return ramp_value(t, F[foff], F[foff + 1], F[foff + 2], F[foff + 3])
    if kind == 4:
        n = nf // 2
        return table_value(t, F[foff:foff + n], F[foff + n:foff + nf])
    if kind == 5:
        return sine_value(t, F[foff], F[foff + 1], F[foff + 2], F[foff + 3])
    if kind == 6:
        return pulse_value(t, F[foff], F[foff + 1], F[foff + 2], F[foff + 3], F[foff + 4])
    if kind == 7:
        n = (nf - 1) // 2
        return periodic_value(t, F[foff + 1:foff + 1 + n], F[foff + 1 + n:foff + nf], F[foff])
    return ext[aux]


@compilable
def signal_value(t, start, end, P, F, ext):
    """The value at ``t`` of the signal whose nodes are ``P[start:end]`` (module docstring)."""
    if end - start == 4:
        return _leaf(t, P[start], P[start + 1], P[start + 2], P[start + 3], F, ext)
    stack = np.empty((end - start) // 4)
    sp = 0
    for k in range(start, end, 4):
        kind = P[k]
        if kind == 8:  # sum of the last parts, in order
            n = P[k + 3]
            total = 0.0
            for j in range(sp - n, sp):
                total += stack[j]
            sp -= n
            stack[sp] = total
        elif kind == 9:  # spliced: before, after
            value = stack[sp - 1] if t >= F[P[k + 1]] else stack[sp - 2]
            sp -= 2
            stack[sp] = value
        else:
            stack[sp] = _leaf(t, kind, P[k + 1], P[k + 2], P[k + 3], F, ext)
        sp += 1
    return stack[0]


@compilable
def _apply(t, rec, P, F, ext):
    """``ElementConfig.apply_at``: 1 for a one-way clutch, the apply signal clipped at 0 otherwise."""
    if P[rec] == ONEWAY:
        return 1.0
    return max(0.0, signal_value(t, P[rec + 2], P[rec + 3], P, F, ext))


@compilable
def _matvec(G, off, rows, cols, x, out):
    for r in range(rows):
        acc = 0.0
        for j in range(cols):
            acc += G[off + r * cols + j] * x[j]
        out[r] = acc


@compilable
def _evaluate(t, y, P, F, S, G, ext, u, out):
    """The input vector ``u`` (components and slipping elements) at ``(t, y)``; the components'
    derivatives into ``out`` (after the mode's coordinates); returns the power in, dissipated and
    to the load [W]."""
    dof, n_links, n_u = S[0], S[1], S[2]
    w = np.empty(n_links)
    _matvec(G, S[8], n_links, dof, y, w)
    p_in = 0.0
    diss = 0.0
    p_load = 0.0
    for c in range(P[0]):
        rec = P[1] + _RECORD * c
        kind, pos, foff, ioff, coff, soff = P[rec], dof + P[rec + 1], P[rec + 3], P[rec + 4], P[rec + 5], P[rec + 6]
        if kind == 0:  # evaluated in Python
            e, ns = P[rec + 7], P[rec + 2]
            p_in += ext[e]
            diss += ext[e + 1]
            p_load += ext[e + 2]
            for k in range(ns):
                out[pos + k] = ext[e + 3 + k]
            for k in range(n_u):
                u[k] += ext[e + 3 + ns + k]
        elif kind == 1:  # input torque
            torque = signal_value(t, P[soff], P[soff + 1], P, F, ext)
            u[P[coff]] += torque
            p_in += torque * w[P[ioff]]
        elif kind == 2:  # engine map on a link
            ns, nt = P[ioff + 1], P[ioff + 2]
            speed = w[P[ioff]]
            speeds, throttles = F[foff:foff + ns], F[foff + ns:foff + ns + nt]
            table = F[foff + ns + nt:foff + ns + nt + ns * nt].reshape(nt, ns)
            throttle = governed_throttle(signal_value(t, P[soff], P[soff + 1], P, F, ext), speed,
                                         F[foff + ns + nt + ns * nt])
            torque = interp2(speed, throttle, speeds, throttles, table)
            if P[ioff + 3]:  # a torque request of the shifts
                torque = requested_torque(torque, signal_value(t, P[soff + 2], P[soff + 3], P, F, ext), speed, speeds,
                                          throttles, table)
            u[P[coff]] += torque
            p_in += torque * speed
        elif kind == 3:  # engine behind a torque converter
            ns, nt, n1, n2 = P[ioff + 1], P[ioff + 2], P[ioff + 3], P[ioff + 4]
            omega_e, omega_t = y[pos], w[P[ioff]]
            m = foff + 2
            speeds, throttles = F[m:m + ns], F[m + ns:m + ns + nt]
            table = F[m + ns + nt:m + ns + nt + ns * nt].reshape(nt, ns)
            m += ns + nt + ns * nt
            pump, turbine = converter_torques(omega_e, omega_t, F[m:m + n1], F[m + n1:m + 2 * n1],
                                              F[m + 2 * n1:m + 3 * n1], F[m + 3 * n1:m + 3 * n1 + n2],
                                              F[m + 3 * n1 + n2:m + 3 * n1 + 2 * n2])
            throttle = governed_throttle(signal_value(t, P[soff], P[soff + 1], P, F, ext), omega_e, F[foff + 1])
            t_engine = interp2(omega_e, throttle, speeds, throttles, table)
            if P[ioff + 5]:  # a torque request of the shifts
                t_engine = requested_torque(t_engine, signal_value(t, P[soff + 2], P[soff + 3], P, F, ext), omega_e,
                                            speeds, throttles, table)
            rate, power, loss = engine_converter_rates(t_engine, pump, turbine, omega_e, omega_t, F[foff])
            u[P[coff]] += turbine
            out[pos] = rate
            p_in += power
            diss += loss
        elif kind == 4:  # load on a link
            speed = w[P[ioff]]
            torque = link_load_torque(signal_value(t, P[soff], P[soff + 1], P, F, ext), speed, F[foff], F[foff + 1],
                                      F[foff + 2])
            u[P[coff]] += torque
            p_in += torque * speed
        elif kind == 5:  # driveline and vehicle
            shaft, d_theta, d_omega, loss, power = driveline_rates(
                y[pos], y[pos + 1], w[P[ioff]], F[foff], F[foff + 1], F[foff + 2], F[foff + 3], F[foff + 4],
                F[foff + 5], F[foff + 6], F[foff + 7], F[foff + 8], F[foff + 9])
            u[P[coff]] += shaft
            out[pos] = d_theta
            out[pos + 1] = d_omega
            diss += loss
            p_load += power
        elif kind == 6:  # torque converter between two links
            n1, n2 = P[ioff + 2], P[ioff + 3]
            wp, wt = w[P[ioff]], w[P[ioff + 1]]
            m = foff
            pump, turbine = converter_torques(wp, wt, F[m:m + n1], F[m + n1:m + 2 * n1], F[m + 2 * n1:m + 3 * n1],
                                              F[m + 3 * n1:m + 3 * n1 + n2], F[m + 3 * n1 + n2:m + 3 * n1 + 2 * n2])
            u[P[coff]] += -pump
            u[P[coff + 1]] += turbine
            diss += converter_loss(pump, turbine, wp, wt)
        elif kind == 7:  # driveline and vehicle with wheel brakes
            shaft, d_theta, d_omega, loss, power = braked_driveline_rates(
                y[pos], y[pos + 1], w[P[ioff]], signal_value(t, P[soff], P[soff + 1], P, F, ext), F[foff], F[foff + 1],
                F[foff + 2], F[foff + 3], F[foff + 4], F[foff + 5], F[foff + 6], F[foff + 7], F[foff + 8], F[foff + 9])
            u[P[coff]] += shaft
            out[pos] = d_theta
            out[pos + 1] = d_omega
            diss += loss
            p_load += power
    # the slipping elements (Transmission.slipping_set): (element, input column), signed capacity
    dof_pc = S[10]
    for k in range(S[4]):
        i, col, scale = S[S[5] + 2 * k], S[S[5] + 2 * k + 1], G[S[13] + k]
        slip = 0.0
        for j in range(dof):
            slip += G[dof_pc + i * dof + j] * y[j]
        if scale == 0.0:
            continue
        rec = P[3] + _RECORD * i
        fo, fn = P[rec + 4], P[rec + 5]
        torque = slipping_torque(_apply(t, rec, P, F, ext), slip, scale, F[fo:fo + fn], F[fo + fn:fo + 2 * fn])
        u[col] += torque
        diss += torque * slip
    return p_in, diss, p_load


@compilable
def rhs_kernel(t, y, P, F, S, G, ext, out):
    """The state derivative at ``(t, y)`` into ``out``: the mode's ``B u``, the components'
    derivatives, the three energy rates (power in, dissipated, to the load). (Filling an array
    the caller made, rather than returning a new one, saves numba the boxing of a result.)"""
    out[:] = 0.0
    u = np.zeros(S[2])
    p_in, diss, p_load = _evaluate(t, y, P, F, S, G, ext, u, out)
    _matvec(G, S[9], S[0], S[2], u, out)
    n = len(y)
    out[n - 3] = p_in
    out[n - 2] = diss
    out[n - 1] = p_load


@compilable
def jacobian_kernel(t, y, P, F, S, G, ext, n_dynamic, sqrt_eps, out):
    """The forward-difference Jacobian of :func:`rhs_kernel` into ``out`` (zeros past the first
    ``n_dynamic`` columns): the arithmetic of ``integration._partial_jacobian``, one call."""
    n = len(y)
    f0 = np.empty(n)
    fj = np.empty(n)
    rhs_kernel(t, y, P, F, S, G, ext, f0)
    yj = y.copy()
    out[:, :] = 0.0
    for j in range(n_dynamic):
        h = sqrt_eps * max(abs(y[j]), 1e-3)
        yj[:] = y
        yj[j] += h
        rhs_kernel(t, yj, P, F, S, G, ext, fj)
        step = yj[j] - y[j]
        for i in range(n):
            out[i, j] = (fj[i] - f0[i]) / step


@compilable
def inputs_kernel(t, y, P, F, S, G, ext):
    """The input vector ``u`` at ``(t, y)`` (component and slipping element torques)."""
    u = np.zeros(S[2])
    _evaluate(t, y, P, F, S, G, ext, u, np.zeros(len(y)))
    return u


@compilable
def events_kernel(t, y, P, F, S, G, ext, margins):
    """The values of the segment's events into ``margins``, in the order the simulator lists the
    events: the slip events' linear functions ``row @ y + offset`` (:func:`~.integration.slip_event`),
    the apply signal minus :data:`~.transmission.APPLY_THRESHOLD` of every watched element
    (:func:`~.integration.apply_events`), the holding margin of every locked row of the mode
    (``Transmission.holding_margin`` of its torque ``D u``)."""
    n_rows, n_u, dof = S[6], S[2], S[0]
    for k in range(S[16]):
        off = S[17] + k * (dof + 1)
        acc = 0.0
        for j in range(dof):
            acc += G[off + j] * y[j]
        margins[k] = acc + G[off + dof]
    for k in range(S[14]):
        rec = P[3] + _RECORD * S[S[15] + k]
        margins[S[16] + k] = signal_value(t, P[rec + 2], P[rec + 3], P, F, ext) - APPLY_THRESHOLD
    first = S[16] + S[14]
    if n_rows == 0:
        return
    u = inputs_kernel(t, y, P, F, S, G, ext)
    torques = np.empty(n_rows)
    _matvec(G, S[11], n_rows, n_u, u, torques)
    for r in range(n_rows):
        m = S[S[7] + r]
        n = S[m]
        if n == 1:
            rec = P[3] + _RECORD * S[m + 1]
            cap = static_capacity(P[rec], F[P[rec + 6]], _apply(t, rec, P, F, ext))
            margins[first + r] = element_margin(P[rec], cap, P[rec + 1], torques[r])
            continue
        lo = 0.0
        hi = 0.0
        friction = 0.0
        for k in range(n):
            rec = P[3] + _RECORD * S[m + 1 + 2 * k]
            cap = 0.0
            if P[rec] != ONEWAY:
                cap = static_capacity(P[rec], F[P[rec + 6]], _apply(t, rec, P, F, ext))
                friction += cap
            lo, hi = add_holding_range(lo, hi, P[rec], P[rec + 1], S[m + 2 + 2 * k], cap)
        margins[first + r] = group_margin(lo, hi, friction, torques[r])


# --------------------------------------------------------------------------- the description


class _Encoder:
    """Builds the arrays ``P`` and ``F`` (module docstring)."""

    def __init__(self):
        self.P: list[int] = [0, 0, 0, 0]  # the header, filled last
        self.F: list[float] = []
        self.external: list = []  # signals evaluated in Python, by their index in ext
        self._signals: dict[int, tuple[int, int]] = {}

    def numbers(self, values) -> int:
        off = len(self.F)
        self.F.extend(float(v) for v in values)
        return off

    def signal(self, sig) -> tuple[int, int]:
        """The reference (start, end) of ``sig``'s nodes in P (encoded once per object)."""
        key = id(sig)
        if key not in self._signals:
            start = len(self.P)
            self._nodes(sig)
            self._signals[key] = (start, len(self.P))
        return self._signals[key]

    def _nodes(self, sig) -> None:
        form = sig.kernel_form() if own_kernel_form(sig) else None
        if form is None:
            self.external.append(sig)
            self.P.extend((_EXTERNAL, 0, 0, len(self.external) - 1))
            return
        kind, numbers, parts = form
        for part in parts:
            self._nodes(part)
        self.P.extend((SIGNAL_KINDS[kind], self.numbers(numbers), len(numbers), len(parts)))


class CompiledPowertrain:
    """A powertrain (:class:`~.integration.Powertrain`) as data for the compiled kernels, built once
    per run (again when a controller replaces an apply signal: :meth:`current`).

    ``jit``: call the numba-compiled kernels (False: the same functions in Python, slow, for tests
    of the description itself).
    """

    def __init__(self, pt, jit: bool = True):
        tr = pt.transmission
        self.pt, self.jit = pt, jit
        self.applies = tuple(e.apply for e in tr.elements)
        enc = _Encoder()
        records, python = [], []
        pos = n_ext = 0
        n_u = len(tr.inputs)
        for c in pt.components:
            n_states = len(c.state_names)
            form = c.kernel_form() if own_kernel_form(c) else None
            if form is None:
                python.append((c, slice(pos, pos + n_states), n_ext, n_states))
                records.append((0, pos, n_states, 0, 0, 0, 0, n_ext))
                n_ext += 3 + n_states + n_u
            else:
                kind, ints, numbers, signals, inputs = form
                foff = enc.numbers(numbers)
                refs = [x for s in signals for x in enc.signal(s)]
                ioff = len(enc.P)
                enc.P.extend(int(x) for x in ints)
                coff = len(enc.P)
                enc.P.extend(tr.input_index[name] for name in inputs)
                soff = len(enc.P)
                enc.P.extend(refs)
                records.append((COMPONENT_KINDS[kind], pos, n_states, foff, ioff, coff, soff, 0))
            pos += n_states
        elements = []
        for e in tr.elements:
            start, end = enc.signal(e.apply)
            fr = e.friction or ((), ())
            fo = enc.numbers(tuple(fr[0]) + tuple(fr[1]))
            elements.append((e.code, int(e.free), start, end, fo, len(fr[0]), enc.numbers((e.static,)), 0))
        comp_off = len(enc.P)
        enc.P[0:4] = [len(records), comp_off, len(elements), comp_off + _RECORD * len(records)]
        enc.P.extend(x for r in records for x in r)
        enc.P.extend(x for r in elements for x in r)
        self.P = np.array(enc.P, dtype=np.int64)
        self.F = np.array(enc.F if enc.F else [0.0], dtype=float)
        self.external = list(enc.external)
        n_sig = len(self.external)  # the external signals first in ext, then the Python blocks
        self.python = [(c, sl, off + n_sig, n) for c, sl, off, n in python]
        for c, rec in enumerate(records):
            if rec[0] == 0:
                self.P[comp_off + _RECORD * c + 7] += n_sig
        self.ext = np.zeros(n_sig + n_ext)
        self.input_index = tr.input_index
        self.n_u = n_u
        self._kernels = tuple(compiled(f) if jit else f for f in (rhs_kernel, inputs_kernel, events_kernel,
                                                                      jacobian_kernel))
        if jit:
            settle_after_loading()

    def current(self) -> "CompiledPowertrain":
        """This description, or a new one when an apply signal was replaced since (a controller's
        command)."""
        applies = tuple(e.apply for e in self.pt.transmission.elements)
        if all(a is b for a, b in zip(applies, self.applies)):
            return self
        return CompiledPowertrain(self.pt, self.jit)

    def segment(self, mode, layout, active, watched=(), slips=()) -> "CompiledSegment":
        """The kernels of one segment in ``mode`` (:class:`~.transmission.ModeData`) with the state
        layout ``layout``, the slipping elements ``active`` (:meth:`Transmission.slipping_set`),
        the elements ``watched`` by apply events (indices) and the slip events' linear functions
        ``slips`` (``(row, offset)`` pairs: :func:`~.integration.slip_event`'s ``linear``)."""
        tr = self.pt.transmission
        dof, n_links, n_el = mode.dof, len(tr.links), len(tr.elements)
        G: list[float] = []

        def block(a) -> int:
            off = len(G)
            G.extend(np.asarray(a, dtype=float).ravel().tolist())
            return off

        c_off, b_off = block(mode.C), block(mode.B)
        pc_off, d_off = block(tr.P @ mode.C), block(mode.D)
        scale_off = block([scale for _, _, _, scale in active])
        slip_off = block([x for row, offset in slips for x in (*np.asarray(row, dtype=float)[:dof], offset)])
        S = [dof, n_links, self.n_u, n_el, len(active), 0, len(mode.locked_order), 0, c_off, b_off, pc_off, d_off,
             layout.size, scale_off, len(watched), 0, len(slips), slip_off]
        S[15] = len(S)
        S.extend(int(i) for i in watched)
        S[5] = len(S)
        S.extend(x for i, col, _, _ in active for x in (i, col))
        S[7] = len(S)
        S.extend([0] * len(mode.locked_order))
        for r in range(len(mode.locked_order)):
            S[S[7] + r] = len(S)
            S.append(len(mode.groups[r]))
            S.extend(x for i, sign in zip(mode.groups[r], mode.signs[r]) for x in (i, sign))
        return CompiledSegment(self, np.array(S, dtype=np.int64), np.array(G if G else [0.0]), mode, layout)


class CompiledSegment:
    """The kernels of one segment: ``rhs(t, y)``, ``inputs(t, y)`` and ``events(t, y)``
    (:func:`rhs_kernel`, :func:`inputs_kernel`, :func:`events_kernel`), with the Python-evaluated
    parts filled into ``ext`` first."""

    def __init__(self, pt: CompiledPowertrain, S: np.ndarray, G: np.ndarray, mode, layout):
        rhs_into, inputs, events_into, jacobian_into = pt._kernels
        P, F, ext = pt.P, pt.F, pt.ext
        n_y, n_events, empty = layout.size, int(S[6] + S[14] + S[16]), np.empty
        fill = self._filler(pt, mode, layout, ext) if pt.external or pt.python else None

        def into(kernel, size: int, derivatives: bool):
            """``f(t, y)``: a new array of ``size`` filled by ``kernel`` (the Python-evaluated parts
            first, with their derivatives where ``derivatives``)."""
            def call(t, y):
                if fill is not None:
                    fill(t, y, derivatives)
                out = empty(size)
                kernel(t, y, P, F, S, G, ext, out)
                return out

            return call

        rhs = into(rhs_into, n_y, True)
        events = into(events_into, n_events, False)

        def inputs_at(t, y):
            if fill is not None:
                fill(t, y, False)
            return inputs(t, y, P, F, S, G, ext)

        def jacobian(t, y, n_dynamic):
            out = empty((n_y, n_y))
            jacobian_into(t, y, P, F, S, G, ext, n_dynamic, _SQRT_EPS, out)
            return out

        self.rhs, self.events, self.inputs = rhs, events, inputs_at
        #: ``jacobian(t, y, n_dynamic)``: :func:`jacobian_kernel` (None with Python-evaluated parts,
        #: which would have to be evaluated at every column's state)
        self.jacobian = jacobian if fill is None else None

    @staticmethod
    def _filler(pt: CompiledPowertrain, mode, layout, ext):
        """``fill(t, y, derivatives)``: the Python-evaluated signals and components into ``ext``
        (with their derivatives and powers when ``derivatives``, their torques alone otherwise)."""
        C, dof, offset = mode.C, mode.dof, layout.offset
        index, n_u = pt.input_index, pt.n_u
        python = [(c, slice(offset + sl.start, offset + sl.stop), off, n) for c, sl, off, n in pt.python]

        def fill(t, y, derivatives: bool):
            for j, sig in enumerate(pt.external):
                ext[j] = sig.value(t)
            if not python:
                return
            w = C @ y[:dof]
            for c, sl, off, n in python:
                if derivatives:
                    torques, dx, p_in, diss, p_load = c.evaluate(t, y[sl], w)
                    if len(dx) != n:
                        raise ValueError(f"component derivatives of {len(dx)} states, expected {n}")
                    ext[off:off + 3] = (p_in, diss, p_load)
                    ext[off + 3:off + 3 + n] = dx
                else:
                    torques = c.torques(t, y[sl], w)
                block = ext[off + 3 + n:off + 3 + n + n_u]
                block[:] = 0.0
                for name, value in torques.items():
                    block[index[name]] += value

        return fill


def compiled_powertrain(pt) -> CompiledPowertrain | None:
    """The compiled description of ``pt`` for a run, or None when the simulator runs its Python
    right-hand side (numba missing, or ``TRANSGEN_JIT=0``: :func:`~.jit.jit_enabled`)."""
    return CompiledPowertrain(pt) if jit_enabled() else None
