"""The simulator's ODE solvers: scipy's integrators with less Python per step.

:class:`LeanBDF` and :class:`LeanRadau` (scipy's BDF and Radau with a lean dense LU) live in
:mod:`.ode_stiff`, imported at their first use (they need scipy.linalg; the default LSODA path
does not, and imports only the parts of scipy it uses: :mod:`.scipy_parts`).

:class:`LeanLSODA` is scipy's LSODA with the Python between two calls of the compiled lsoda
routine cut down: the same call with the same arguments and work arrays, one step at a time,
without the ``scipy.integrate.ode`` wrapper's argument shuffling, and a dense output that keeps a
copy of the step's Nordsieck columns and builds scipy's polynomial only when it is evaluated.
:class:`LeanOdeSolution` evaluates a segment's steps at many times without scipy's walk over them.

:func:`solve_segment` is ``solve_ivp``'s driver loop for the simulator's segments (dense output,
terminal events), the same steps, event roots and solution, without its per-step array
conversions.
"""
from __future__ import annotations

import warnings
from types import SimpleNamespace

import numpy as np

from ...blas import limit_loaded
from .scipy_parts import brentq, is_bdf, lsoda_classes, lsoda_routine

LSODA, LsodaDenseOutput, ConstantDenseOutput, OdeSolution = lsoda_classes()

__all__ = ["LeanBDF", "LeanLSODA", "LeanRadau", "SOLVERS", "solve_segment"]


def __getattr__(name: str):
    """:class:`LeanBDF`, :class:`LeanRadau` (and ``change_D``) from :mod:`.ode_stiff`, imported here
    at their first use."""
    if name in ("LeanBDF", "LeanRadau", "change_D"):
        from . import ode_stiff

        return getattr(ode_stiff, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


class _LsodaDense(LsodaDenseOutput):
    """:class:`~scipy.integrate._ivp.lsoda.LsodaDenseOutput` (the Nordsieck polynomial of one
    step) built lazily: a step keeps its Nordsieck columns as the flat copy of LSODA's work array;
    the ``(n, order + 1)`` array ``yh`` (scipy's reshape and copy of that array) is made on the
    first evaluation, and the power array ``p = arange(order + 1)`` is shared between steps of
    the same order. It evaluates with the inherited ``_call_impl``: the same values, bit for bit."""

    _powers: dict = {}

    def __init__(self, t_old, t, h, order: int, n: int, flat: np.ndarray):
        self.t_old, self.t, self.h = t_old, t, h
        self._order, self._n, self._flat, self._yh = order, n, flat, None

    @property
    def t_min(self):
        return min(self.t, self.t_old)

    @property
    def t_max(self):
        return max(self.t, self.t_old)

    @property
    def yh(self) -> np.ndarray:
        if self._yh is None:
            self._yh = self._flat.reshape((self._n, self._order + 1), order="F").copy()
        return self._yh

    @property
    def p(self) -> np.ndarray:
        p = self._powers.get(self._order)
        if p is None:
            p = self._powers[self._order] = np.arange(np.int32(self._order) + 1)  # LSODA's iwork is int32
            p.flags.writeable = False
        return p


class LeanLSODA(LSODA):
    """:class:`scipy.integrate.LSODA` (version 1.17: a C lsoda called one step at a time, ``itask
    = 5``) with the step and the dense output written out: each step is the same call of
    ``scipy.integrate._odepack.lsoda`` with the same arguments, work arrays and internal-state
    arrays that scipy's ``_step_impl`` passes through ``scipy.integrate.ode``, so the same steps,
    states and dense output, bit for bit. The solver is set up by scipy's own ``__init__``; a
    scipy whose LSODA keeps other state runs scipy's step.

    The right-hand side is called as scipy calls it (``asarray(fun(t, y), dtype=float)``, counted
    in ``nfev``) with one Python frame less."""

    _INTEGRATOR_STATE = ("call_args", "rwork", "iwork", "state_doubles", "state_ints", "messages")

    def __init__(self, fun, t0, y0, t_bound, **options):
        super().__init__(fun, t0, y0, t_bound, **options)
        routine = lsoda_routine()
        if routine is None:  # the public API only (scipy_parts): scipy's own step
            self._lean = False
            return
        solver = self._lsoda_solver
        integrator = solver._integrator
        self._lean = (all(hasattr(integrator, a) for a in self._INTEGRATOR_STATE) and len(integrator.call_args) == 7
                      and integrator.call_args[4] is integrator.rwork and integrator.call_args[5] is integrator.iwork
                      and not solver.f_params and not solver.jac_params and routine is integrator.runner)
        if not self._lean:
            return
        self._run = integrator.runner
        self._integrator = integrator
        rtol, atol, _, self._istate, rwork, iwork, jt = integrator.call_args
        self._tolerances = (rtol, atol, 5)  # itask 5: one step, not past rwork[0] = t_bound
        self._work = (rwork, iwork, solver.jac or (lambda: None), jt, (), 1, (), integrator.state_doubles,
                      integrator.state_ints)
        self._rwork, self._iwork = rwork, iwork
        # the step's order and sizes read as Python numbers (no numpy scalars per step)
        self._iwork_ints, self._rwork_floats = memoryview(iwork), memoryview(rwork)
        self._y_c = solver._y  # the array the C code steps (in place); ``y`` is a copy of it
        self._forward = self.direction > 0  # the end test on Python floats (``direction`` is +-1.0)

        def f(t, y):
            self.nfev += 1
            return np.asarray(fun(t, y), dtype=float)

        self._f = f

    def step(self):
        """:meth:`OdeSolver.step` with scipy's ``LSODA._step_impl`` inline."""
        if not self._lean:
            return super().step()
        if self.status != "running":
            raise RuntimeError("Attempt to step on a failed or finished solver.")
        t = self.t
        if self.n == 0 or t == self.t_bound:
            self.t_old = t
            self.t = self.t_bound
            self.status = "finished"
            return None
        y, t_new, istate = self._run(self._f, self._y_c, t, self.t_bound, *self._tolerances, self._istate, *self._work)
        self._y_c = y
        if istate < 0:
            integrator = self._integrator
            warnings.warn(f"lsoda: {integrator.messages.get(istate, f'Unexpected istate={istate:d}')}", stacklevel=2)
            self.status = "failed"
            return "Unexpected istate in LSODA."
        self._istate = 2
        self.t = t_new
        self.y = y.copy()
        self.njev = self.nlu = self._iwork_ints[12]  # LSODA's Jacobian evaluations = LU decompositions
        self.t_old = t
        past = t_new - self.t_bound
        if (past >= 0) if self._forward else (past <= 0):  # direction * (t - t_bound) >= 0
            self.status = "finished"
        return None

    def dense_output(self):
        """scipy's ``LSODA._dense_output_impl`` (the Nordsieck array of the last step, its last
        column rescaled to the step when the order is to drop) as a lazy :class:`_LsodaDense`."""
        if not self._lean:
            return super().dense_output()
        if self.t_old is None:
            raise RuntimeError("Dense output is available after a successful step was made.")
        if self.n == 0 or self.t == self.t_old:
            return ConstantDenseOutput(self.t_old, self.t, self.y)
        ints, n = self._iwork_ints, self.n
        order = ints[13]
        flat = self._rwork[20:20 + (order + 1) * n].copy()  # yh in Fortran order: column j at j*n
        if ints[14] < order:
            iwork, rwork = self._iwork, self._rwork
            flat[order * n:] *= (rwork[11] / rwork[10]) ** iwork[13]  # scipy's yh[:, -1], numpy scalars
        return _LsodaDense(self.t_old, self.t, self._rwork_floats[11], order, n, flat)


class LeanOdeSolution(OdeSolution):
    """:class:`scipy.integrate.OdeSolution` whose evaluation at many times finds the runs of
    times in one step with one array operation (scipy walks them one by one with
    ``itertools.groupby``) and evaluates an LSODA step's polynomial inline: the same
    interpolant on the same times with the same operations, so the same values, bit for bit."""

    def __call__(self, t):
        t = np.asarray(t)
        if t.ndim != 1 or not t.size or not hasattr(self, "side"):  # scipy < 1.11 has no side: its own walk
            return super().__call__(t)
        if t.size == 1 or bool(np.all(t[1:] >= t[:-1])):  # sorted already (the output grid): no permutation
            reverse, t_sorted = None, t
        else:
            order = np.argsort(t)
            reverse = np.empty_like(order)
            reverse[order] = np.arange(order.shape[0])
            t_sorted = t[order]
        segments = np.searchsorted(self.ts_sorted, t_sorted, side=self.side)
        segments -= 1
        segments[segments < 0] = 0
        segments[segments > self.n_segments - 1] = self.n_segments - 1
        if not self.ascending:
            segments = self.n_segments - 1 - segments
        bounds = [0, *(np.flatnonzero(segments[1:] != segments[:-1]) + 1).tolist(), len(segments)]
        interpolants = self.interpolants
        ys = []
        for segment, start, end in zip(segments[bounds[:-1]].tolist(), bounds, bounds[1:]):
            interpolant, group = interpolants[segment], t_sorted[start:end]
            if type(interpolant) is _LsodaDense:  # LsodaDenseOutput._call_impl on a 1-d array
                ys.append(np.dot(interpolant.yh, ((group - interpolant.t) / interpolant.h) ** interpolant.p[:, None]))
            else:
                ys.append(interpolant(group))
        ys = np.concatenate(ys, axis=1) if all(y.ndim == 2 for y in ys) else np.hstack(ys)
        return ys if reverse is None else ys[:, reverse]


class _SolverTable(dict):
    """:data:`SOLVERS`: ``"BDF"`` and ``"Radau"`` are added at their first look-up (:mod:`.ode_stiff`)."""

    def __missing__(self, method):
        if method not in ("BDF", "Radau"):
            raise KeyError(method)
        from .ode_stiff import LeanBDF, LeanRadau

        self.setdefault("BDF", LeanBDF)
        self.setdefault("Radau", LeanRadau)
        return self[method]

    def get(self, method, default=None):
        try:
            return self[method]
        except (KeyError, TypeError):
            return default

    def __contains__(self, method) -> bool:
        return method in ("BDF", "Radau") or dict.__contains__(self, method)


SOLVERS = _SolverTable(LSODA=LeanLSODA)
"""Solver classes used for these method names (the others are passed to ``solve_ivp`` by name)."""

#: the result messages of solve_ivp (its module imports scipy.optimize; tests/test_scipy_parts.py
#: checks they are solve_ivp's)
_MESSAGES = {0: "The solver successfully reached the end of the integration interval.",
             1: "A termination event occurred."}


_EPS = np.finfo(float).eps


def solve_segment(fun, t0: float, t1: float, y0: np.ndarray, method, events: list, **options) -> SimpleNamespace:
    """``solve_ivp(fun, (t0, t1), y0, method=method, events=events, dense_output=True, **options)``
    for events that are all terminal (each stops the integration at its first root): the same
    solver steps, event detection (a sign change between step ends in the event's direction),
    roots (Brent's method on the step's dense output, ``xtol = rtol = 4 eps``) and result fields
    (``t``, ``y``, ``sol``, ``t_events``, ``y_events``, ``status``, ``message``, ``success``, ``nfev``).

    An event with the attribute ``linear = (row, offset)`` is the linear function ``row @
    y[:len(row)] + offset`` of the state: at the step ends those are evaluated together, in one
    matrix product (the roots are found with the event functions themselves). Events with the
    attribute ``batch = (values, index)`` are entry ``index`` of the vector ``values(t, y)``: at
    the step ends one call of ``values`` gives them all (the simulator's compiled events).

    Why not ``solve_ivp`` itself: on the simulator's small systems its per-step bookkeeping (event
    values through arrays, the active-event search, the event counts) cost as much as a
    right-hand-side evaluation; here the event values stay Python floats.
    """
    if any(getattr(e, "terminal", None) != 1 and getattr(e, "terminal", None) is not True for e in events):
        raise ValueError("solve_segment takes terminal events only")
    if isinstance(method, str):  # solve_ivp's other methods, by their public names
        import scipy.integrate

        if method not in ("RK23", "RK45", "DOP853", "Radau", "BDF", "LSODA"):
            raise ValueError(f"unknown solve_ivp method {method!r}")
        method = getattr(scipy.integrate, method)
    t0, t1 = float(t0), float(t1)
    limit_loaded()  # a BLAS the solver's import brought (scipy.linalg): one thread as well
    solver = method(fun, t0, y0, t1, vectorized=False, **options)
    ts, ys, interpolants = [t0], [y0], []
    directions = [getattr(e, "direction", 0) for e in events]
    values = _event_values(events)
    g = values(t0, y0)
    hit, root, y_root = None, None, None
    status, message = None, None
    step, dense_output, keep = solver.step, solver.dense_output, interpolants.append
    while status is None:
        message = step()
        state = solver.status
        if state == "finished":
            status = 0
        elif state == "failed":
            status = -1
            break
        t_old, t, y = solver.t_old, solver.t, solver.y
        sol = dense_output()
        keep(sol)
        if events:
            g_new = values(t, y)
            for a, b in zip(g, g_new):
                if a * b <= 0 or a != a or b != b:  # a sign change or a zero (or NaN): the full test
                    active = [k for k, (a, b, d) in enumerate(zip(g, g_new, directions))
                              if (d > 0 and a <= 0 <= b) or (d < 0 and a >= 0 >= b)
                              or (d == 0 and (a <= 0 <= b or a >= 0 >= b))]
                    break
            else:
                active = None  # every value kept its strict sign: no event in any direction
            if active:
                roots = [brentq(lambda tt, e=events[k]: e(tt, sol(tt)), t_old, t, xtol=4 * _EPS, rtol=4 * _EPS)
                         for k in active]
                # the first root in the direction of integration (ties: the first event, as a stable sort)
                first = min(range(len(active)), key=(roots.__getitem__ if t > t_old else lambda j: -roots[j]))
                hit, root = active[first], roots[first]
                status = 1
                t = root
                y = y_root = sol(t)
            g = g_new
        if len(ts) > 1 and ts[-1] == t:
            interpolants.pop()
        else:
            ts.append(t)
            ys.append(y)
    t_events = [np.array([root]) if k == hit else np.zeros(0) for k in range(len(events))]
    y_events = [np.array([y_root]) if k == hit else np.zeros(0) for k in range(len(events))]
    ts_arr = np.array(ts)
    alt = {"alt_segment": _alt_segment(method)} if _HAS_ALT_SEGMENT else {}
    return SimpleNamespace(t=ts_arr, y=np.array(ys).T, sol=LeanOdeSolution(ts_arr, interpolants, **alt),
                           t_events=t_events, y_events=y_events, nfev=solver.nfev, njev=solver.njev,
                           nlu=solver.nlu, status=status, message=_MESSAGES.get(status, message),
                           success=status >= 0)


#: OdeSolution takes ``alt_segment`` (solve_ivp's choice of segment at a step end) from scipy 1.11 on
_HAS_ALT_SEGMENT = "alt_segment" in OdeSolution.__init__.__code__.co_varnames


def _alt_segment(method) -> bool:
    """solve_ivp's ``alt_segment`` of the dense output: ``method in (BDF, LSODA)`` (scipy's BDF
    is loaded where it is the method)."""
    return method in (LSODA, LeanLSODA) or is_bdf(method)


def _event_values(events: list):
    """``values(t, y)``: the list of the events' values at a step end, the linear ones
    (:func:`solve_segment`) from one matrix product, those with the attribute ``batch = (values,
    index)`` (entry ``index`` of the vector ``values(t, y)``) from one call of ``values``."""
    batches: dict[int, tuple] = {}
    for k, e in enumerate(events):
        if getattr(e, "batch", None) is not None:
            batches.setdefault(id(e.batch[0]), (e.batch[0], []))[1].append((k, e.batch[1]))
    batched = {k for _, members in batches.values() for k, _ in members}
    batches = list(batches.values())
    if len(batches) == 1 and batches[0][1] == [(k, k) for k in range(len(events))]:
        func = batches[0][0]  # one vector of all the values, in order
        return lambda t, y: func(t, y).tolist()
    linear = [k for k, e in enumerate(events) if getattr(e, "linear", None) is not None and k not in batched]
    if len({len(events[k].linear[0]) for k in linear}) > 1:
        return lambda t, y: [e(t, y) for e in events]
    others = [(k, events[k]) for k in range(len(events)) if k not in linear and k not in batched]
    if linear:
        rows = np.array([events[k].linear[0] for k in linear], dtype=float)
        offsets = np.array([events[k].linear[1] for k in linear], dtype=float)
        width = rows.shape[1]
    if linear and not batches and linear == list(range(len(linear))):  # the linear events first (the simulator's order)
        rest = [e for _, e in others]

        def values(t, y):
            g = (rows @ y[:width] + offsets).tolist()
            for e in rest:
                g.append(e(t, y))
            return g

        return values

    def values(t, y):
        g = [0.0] * len(events)
        if linear:
            for k, v in zip(linear, (rows @ y[:width] + offsets).tolist()):
                g[k] = v
        for k, e in others:
            g[k] = e(t, y)
        for func, members in batches:
            vector = func(t, y).tolist()
            for k, j in members:
                g[k] = vector[j]
        return g

    return values
