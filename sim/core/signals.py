"""Time signals: apply fractions, torques and other inputs as functions of time.

Every signal is a frozen object with ``value(t)`` and ``breakpoints(t0, t1)`` — the times in
``[t0, t1]`` where it is not smooth (jumps and kinks), at which the simulator restarts its
integrator so that no jump or kink is stepped over. Finite signals have finitely many and may be
asked for all of them (``breakpoints()``); a periodic signal has infinitely many and raises
``ValueError`` unless the window is finite. Signals are right-continuous: at a jump the value is
the one after it.

Kinds (as written in a scenario file, see docs/reference/scenario_files.md)::

    ``constant``  ``value``
    ``step``      ``t``, ``before``, ``after``
    ``ramp``      ``t0``, ``t1``, ``v0``, ``v1`` (constant outside ``[t0, t1]``)
    ``table``     ``t = [...]``, ``value = [...]``: piecewise linear, constant beyond the ends; two
                  equal consecutive times are a jump (``t = [0, 1, 1, 2]``, ``value = [0, 0, 1, 1]``
                  steps from 0 to 1 at 1 s)
    ``sine``      ``offset``, ``amplitude``, ``frequency`` [Hz], ``phase`` [rad]
    ``pulse``     ``t0``, ``width``, ``low`` (default 0), ``high`` (default 1), ``period`` (optional):
                  ``high`` on ``[t0, t0 + width)``, repeated every ``period`` from ``t0`` on when given
    ``square``    ``period``, ``low`` (default 0), ``high`` (default 1), ``duty`` (fraction of the
                  period at ``high``, default 0.5), ``t0`` (a rising edge, default 0): a pulse train
    ``periodic``  ``t = [...]``, ``value = [...]`` (a table, jumps allowed), ``period`` (default
                  ``t[-1] - t[0]``, at least that): the table over ``[t[0], t[0] + period)`` repeated
                  for all times, holding its last value to the end of each period

The values are :func:`~.jit.compilable` functions of the signal's numbers, and every kind has a
``kernel_form()``: ``(kind, numbers, parts)``, its description as data, with which the compiled
right-hand side (:mod:`.kernel`) evaluates it by the same functions. A signal of another class
(without its own ``kernel_form``) is evaluated in Python and passed to the compiled one.
"""
from __future__ import annotations

import math
from bisect import bisect_left, bisect_right
from dataclasses import dataclass
from math import ulp

import numpy as np

from .jit import compilable, compiled_loop

__all__ = ["Signal", "Constant", "Step", "Ramp", "Table", "Sine", "Pulse", "Periodic", "Sum", "Product", "Spliced"]


def _window(points, t0: float, t1: float) -> tuple[float, ...]:
    """The sorted distinct ``points`` in ``[t0, t1]``."""
    return tuple(sorted({p for p in points if t0 <= p <= t1}))


class Signal:
    """Base class: a scalar function of time [s]."""

    def value(self, t: float) -> float:  # pragma: no cover - abstract
        raise NotImplementedError

    def breakpoints(self, t0: float = -math.inf, t1: float = math.inf) -> tuple[float, ...]:
        """The times in ``[t0, t1]`` where the signal jumps or has a kink, sorted."""
        return ()

    def __call__(self, t: float) -> float:
        return self.value(t)

    def kernel_form(self) -> tuple[str, tuple[float, ...], tuple["Signal", ...]] | None:
        """``(kind, numbers, parts)``: the signal as data for the compiled right-hand side
        (:mod:`.kernel`), or None when it has none (it is then evaluated in Python)."""
        return None

    def sample(self, ts: np.ndarray) -> np.ndarray:
        """The signal at every time of ``ts`` (for output sampling)."""
        return np.array([self.value(t) for t in ts], dtype=float)

    def upper_bound(self, t0: float, t1: float) -> float:
        """An upper bound of the signal on ``[t0, t1]`` (``inf`` when unknown): the simulator
        leaves out of a segment's right-hand side the shift elements whose apply signal cannot
        rise above zero in it."""
        return math.inf

    #: linear between its breakpoints (jumps at breakpoints): its crossings are computed exactly
    piecewise_linear = False

    def next_crossing(self, level: float, t0: float, t1: float) -> float | None:
        """The first time in ``(t0, t1)`` [s] at which the signal crosses ``level`` strictly inside
        one of its smooth pieces (crossings at breakpoints are breakpoints already); ``inf`` when
        there is none, ``None`` when the signal cannot tell (the simulator then relies on its event
        function alone). An apply signal crossing zero is a kink of the element torque: the
        simulator restarts its integrator there, so that no solver steps over a short pulse."""
        return _piecewise_linear_crossing(self, level, t0, t1) if self.piecewise_linear else None

    def next_minimum(self, t0: float, t1: float) -> float | None:
        """The first local minimum in ``(t0, t1)`` [s] strictly inside a smooth piece; ``inf`` when
        there is none, ``None`` when the signal cannot tell. A locked element's holding limit
        ``T_static * apply`` is smallest there, and the simulator ends a segment at it so that the
        unlock event cannot be stepped over (a locked mode's dynamics do not see the apply)."""
        return _next_minimum(self, t0, t1)


def _next_minimum(signal: "Signal", t0: float, t1: float) -> float | None:
    """:meth:`Signal.next_minimum` of a signal without its own: a piecewise-linear one has its
    minima at breakpoints (``inf``), any other cannot tell (``None``)."""
    return math.inf if signal.piecewise_linear else None


def _piecewise_linear_crossing(signal: "Signal", level: float, t0: float, t1: float) -> float:
    """:meth:`Signal.next_crossing` of a signal that is linear between its breakpoints (jumps are
    breakpoints): the pieces between the breakpoints in the window, each tested at its ends."""
    times = sorted({t0, t1, *signal.breakpoints(t0, t1)})
    for a, b in zip(times, times[1:]):
        if b > a:
            eps = 1e-12 * max(1.0, abs(a), abs(b))
            tc = _linear_crossing(level, t0, t1, ((a, signal.value(a + eps)), (b, signal.value(b - eps))))
            if tc < math.inf:
                return tc
    return math.inf


def _linear_crossing(level: float, t0: float, t1: float, knots) -> float:
    """:meth:`Signal.next_crossing` of the piecewise-linear function through ``knots``
    ``[(t, value), ...]`` (times increasing)."""
    for (ta, va), (tb, vb) in zip(knots, knots[1:]):
        if tb <= t0 or ta >= t1:
            continue
        if (va - level) * (vb - level) < 0.0:
            tc = ta + (level - va) / (vb - va) * (tb - ta)
            if t0 < tc < t1:
                return tc
    return math.inf


@dataclass(frozen=True)
class Constant(Signal):
    piecewise_linear = True

    v: float

    def value(self, t: float) -> float:
        return self.v

    def kernel_form(self):
        return "constant", (float(self.v),), ()

    def sample(self, ts: np.ndarray) -> np.ndarray:
        return np.full(len(ts), float(self.v))

    def upper_bound(self, t0: float, t1: float) -> float:
        return self.v



@dataclass(frozen=True)
class Step(Signal):
    piecewise_linear = True

    t: float
    before: float
    after: float

    def value(self, t: float) -> float:
        return step_value(t, self.t, self.before, self.after)

    def kernel_form(self):
        return "step", (float(self.t), float(self.before), float(self.after)), ()

    def breakpoints(self, t0: float = -math.inf, t1: float = math.inf) -> tuple[float, ...]:
        return _window((self.t,), t0, t1)

    def upper_bound(self, t0: float, t1: float) -> float:
        return max(self.value(t0), self.value(t1))



@dataclass(frozen=True)
class Ramp(Signal):
    piecewise_linear = True

    t0: float
    t1: float
    v0: float
    v1: float

    def value(self, t: float) -> float:
        return ramp_value(t, self.t0, self.t1, self.v0, self.v1)

    def kernel_form(self):
        return "ramp", (float(self.t0), float(self.t1), float(self.v0), float(self.v1)), ()

    def breakpoints(self, t0: float = -math.inf, t1: float = math.inf) -> tuple[float, ...]:
        return _window((self.t0, self.t1), t0, t1)

    def upper_bound(self, t0: float, t1: float) -> float:
        return max(self.value(t0), self.value(t1))  # monotonic



@dataclass(frozen=True)
class Table(Signal):
    """Piecewise-linear table; ``times`` non-decreasing, two equal consecutive times are a jump
    (right-continuous: at the jump time the value after it). Of more than two equal times only the
    first and the last are kept (the values between are never taken)."""

    piecewise_linear = True

    times: tuple[float, ...]
    values: tuple[float, ...]

    def __post_init__(self):
        ts = [float(x) for x in self.times]
        vs = [float(x) for x in self.values]
        if not ts or len(ts) != len(vs):
            raise ValueError("a table needs as many values as times, at least one")
        if any(not math.isfinite(x) for x in ts + vs):
            raise ValueError("table times and values must be finite")
        if any(b < a for a, b in zip(ts, ts[1:])):
            raise ValueError("table times must not decrease")
        keep = [k for k in range(len(ts)) if not (0 < k < len(ts) - 1 and ts[k - 1] == ts[k] == ts[k + 1])]
        object.__setattr__(self, "times", tuple(ts[k] for k in keep))
        object.__setattr__(self, "values", tuple(vs[k] for k in keep))

    def value(self, t: float) -> float:
        return table_value(t, self.times, self.values)

    def kernel_form(self):
        return "table", self.times + self.values, ()

    def sample(self, ts: np.ndarray) -> np.ndarray:
        xs, ys = np.asarray(self.times, dtype=float), np.asarray(self.values, dtype=float)
        ts = np.asarray(ts, dtype=float)
        loop = compiled_loop(table_values, len(ts)) if ts.ndim == 1 else None
        if loop is not None:  # the values of :meth:`value`, in one compiled loop
            out = np.empty(len(ts))
            loop(np.ascontiguousarray(ts), xs, ys, out)
            return out
        if len(xs) == 1:
            return np.full(len(ts), ys[0])
        i = np.clip(np.searchsorted(xs, ts, side="right") - 1, 0, len(xs) - 2)
        span = xs[i + 1] - xs[i]
        frac = np.divide(ts - xs[i], span, out=np.zeros(len(ts)), where=span > 0)
        out = ys[i] + (ys[i + 1] - ys[i]) * frac
        out[ts < xs[0]] = ys[0]
        out[ts >= xs[-1]] = ys[-1]
        return out

    def upper_bound(self, t0: float, t1: float) -> float:
        inside = [v for t, v in zip(self.times, self.values) if t0 <= t <= t1]  # piecewise linear
        return max([self.value(t0), self.value(t1)] + inside)

    def breakpoints(self, t0: float = -math.inf, t1: float = math.inf) -> tuple[float, ...]:
        return _window(self.times, t0, t1)



@dataclass(frozen=True)
class Sine(Signal):
    offset: float
    amplitude: float
    frequency: float
    phase: float = 0.0

    def value(self, t: float) -> float:
        return sine_value(t, self.offset, self.amplitude, self.frequency, self.phase)

    def kernel_form(self):
        return "sine", (float(self.offset), float(self.amplitude), float(self.frequency), float(self.phase)), ()

    def upper_bound(self, t0: float, t1: float) -> float:
        return self.offset + abs(self.amplitude)

    def next_minimum(self, t0, t1):
        if self.amplitude == 0.0 or self.frequency == 0.0:
            return math.inf
        omega = 2 * math.pi * self.frequency
        root = 1.5 * math.pi if self.amplitude > 0 else 0.5 * math.pi  # where the sine is lowest
        k = math.floor((omega * t0 + self.phase - root) / (2 * math.pi)) + 1
        t = (root + 2 * math.pi * k - self.phase) / omega
        if t <= t0:
            t += 2 * math.pi / omega
        return t if t < t1 else math.inf

    def next_crossing(self, level, t0, t1):
        if self.amplitude == 0.0 or self.frequency == 0.0:
            return math.inf
        r = (level - self.offset) / self.amplitude
        if not -1.0 < r < 1.0:
            return math.inf  # never crosses (at most touches)
        omega = 2 * math.pi * self.frequency
        base = math.asin(r)
        theta0 = omega * t0 + self.phase
        best = math.inf
        for root in (base, math.pi - base):  # sin(theta) = r at root + 2 pi k
            k = math.floor((theta0 - root) / (2 * math.pi)) + 1
            t = (root + 2 * math.pi * k - self.phase) / omega
            if t <= t0:  # round-off at the window's start
                t += 2 * math.pi / omega
            best = min(best, t)
        return best if best < t1 else math.inf


@compilable
def _period_start(t: float, first: float, period: float) -> float:
    """The start ``first + k*period`` of the period holding ``t`` (``k`` corrected for round-off
    in the division, so that ``start <= t < start + period`` with the same arithmetic as the
    breakpoints)."""
    k = math.floor((t - first) / period)
    while first + k * period > t:
        k -= 1
    while first + (k + 1) * period <= t:
        k += 1
    return first + k * period


def _period_indices(first: float, period: float, a: float, b: float) -> range:
    """The ``k`` of the periods ``[first + k*period, first + (k+1)*period)`` that may meet ``[a, b]``."""
    return range(math.floor((a - first) / period) - 1, math.floor((b - first) / period) + 2)


def _finite_window(signal: Signal, t0: float, t1: float) -> None:
    if not (math.isfinite(t0) and math.isfinite(t1)):
        raise ValueError(f"a periodic {type(signal).__name__} has infinitely many breakpoints: "
                         f"ask for those of a finite window, breakpoints(t0, t1)")


@dataclass(frozen=True)
class Pulse(Signal):
    """``high`` on ``[t0, t0 + width)`` and ``low`` elsewhere; with a ``period``, that pulse
    repeated every ``period`` from ``t0`` on (a pulse train or square wave; ``low`` before
    ``t0``). Jumps at every edge; ``0 < width < period``."""

    piecewise_linear = True

    t0: float
    width: float
    low: float = 0.0
    high: float = 1.0
    period: float | None = None

    def __post_init__(self):
        if not self.width > 0:
            raise ValueError(f"a pulse needs width > 0, not {self.width:g}")
        if self.period is not None and not self.period > self.width:
            raise ValueError(f"a pulse train needs period > width (width {self.width:g}, period {self.period:g})")

    def value(self, t: float) -> float:
        return pulse_value(t, self.t0, self.width, self.low, self.high, 0.0 if self.period is None else self.period)

    def kernel_form(self):
        return "pulse", (float(self.t0), float(self.width), float(self.low), float(self.high),
                         0.0 if self.period is None else float(self.period)), ()

    def breakpoints(self, t0: float = -math.inf, t1: float = math.inf) -> tuple[float, ...]:
        if self.period is None:
            return _window((self.t0, self.t0 + self.width), t0, t1)
        _finite_window(self, t0, t1)
        starts = [self.t0 + k * self.period for k in _period_indices(self.t0, self.period, t0, t1) if k >= 0]
        return _window([x for s in starts for x in (s, s + self.width)], t0, t1)

    def _next_edge(self, t: float) -> float:
        """The first edge after ``t`` (``inf`` after a single pulse)."""
        if t < self.t0:
            return self.t0
        start = self.t0 if self.period is None else _period_start(t, self.t0, self.period)
        if t < start + self.width:
            return start + self.width
        return math.inf if self.period is None else start + self.period

    def upper_bound(self, t0: float, t1: float) -> float:
        if self._next_edge(t0) <= t1:  # both levels are taken
            return max(self.low, self.high)
        return self.value(t0)


@dataclass(frozen=True)
class Periodic(Signal):
    """The table ``table`` over ``[t_first, t_first + period)`` repeated for all times (before
    the table's first time too); ``period`` at least the table's span, the last value holding
    from the table's last time to the end of the period. Breakpoints: the table's times and the
    start of every period (where one period's end meets the next one's start)."""

    piecewise_linear = True

    table: Table
    period: float

    def __post_init__(self):
        span = self.table.times[-1] - self.table.times[0]
        if not (self.period > 0 and self.period >= span):
            raise ValueError(f"a periodic table needs a period > 0 and >= its span {span:g} s, not {self.period:g}")

    def _phase(self, t: float) -> float:
        return periodic_phase(t, self.table.times, self.period)

    def value(self, t: float) -> float:
        return periodic_value(t, self.table.times, self.table.values, self.period)

    def kernel_form(self):
        return "periodic", (float(self.period),) + self.table.times + self.table.values, ()

    def breakpoints(self, t0: float = -math.inf, t1: float = math.inf) -> tuple[float, ...]:
        _finite_window(self, t0, t1)
        first = self.table.times[0]
        offsets = sorted({x - first for x in self.table.times if x - first < self.period} | {0.0})
        points = [first + k * self.period + d for k in _period_indices(first, self.period, t0, t1) for d in offsets]
        return _window(points, t0, t1)

    def upper_bound(self, t0: float, t1: float) -> float:
        if t1 - t0 >= self.period:
            return max(self.table.values)
        first = self.table.times[0]
        u0 = self._phase(t0)
        u1 = u0 + (t1 - t0)
        if u1 <= first + self.period:
            return self.table.upper_bound(u0, u1)
        return max(self.table.upper_bound(u0, first + self.period), self.table.upper_bound(first, u1 - self.period))


@dataclass(frozen=True)
class Sum(Signal):
    """The sum of several signals (e.g. a base table and a shift-template contribution)."""

    parts: tuple[Signal, ...]

    def value(self, t: float) -> float:
        return sum(p.value(t) for p in self.parts)

    def kernel_form(self):
        return "sum", (), tuple(self.parts)

    def upper_bound(self, t0: float, t1: float) -> float:
        return sum(p.upper_bound(t0, t1) for p in self.parts)

    def breakpoints(self, t0: float = -math.inf, t1: float = math.inf) -> tuple[float, ...]:
        return _window([b for p in self.parts for b in p.breakpoints(t0, t1)], t0, t1)

    @property
    def piecewise_linear(self) -> bool:
        return all(p.piecewise_linear for p in self.parts)


@dataclass(frozen=True)
class Product(Signal):
    """The product of several signals (e.g. a fuel command times a shift's torque-request factor)."""

    parts: tuple[Signal, ...]

    def value(self, t: float) -> float:
        return math.prod(p.value(t) for p in self.parts)

    def breakpoints(self, t0: float = -math.inf, t1: float = math.inf) -> tuple[float, ...]:
        return _window([b for p in self.parts for b in p.breakpoints(t0, t1)], t0, t1)


@dataclass(frozen=True)
class Spliced(Signal):
    """``before`` up to time ``t``, ``after`` from ``t`` on (a controller's new command)."""

    t: float
    before: Signal
    after: Signal

    def value(self, t: float) -> float:
        return self.after.value(t) if t >= self.t else self.before.value(t)

    def kernel_form(self):
        return "spliced", (float(self.t),), (self.before, self.after)

    def upper_bound(self, t0: float, t1: float) -> float:
        bounds = []
        if t0 < self.t:
            bounds.append(self.before.upper_bound(t0, min(t1, self.t)))
        if t1 >= self.t:
            bounds.append(self.after.upper_bound(max(t0, self.t), t1))
        return max(bounds)

    def breakpoints(self, t0: float = -math.inf, t1: float = math.inf) -> tuple[float, ...]:
        before = [b for b in self.before.breakpoints(t0, min(t1, self.t)) if b < self.t] if t0 < self.t else []
        after = [b for b in self.after.breakpoints(max(t0, self.t), t1) if b > self.t] if t1 > self.t else []
        return _window([self.t] + before + after, t0, t1)

    @property
    def piecewise_linear(self) -> bool:
        return self.before.piecewise_linear and self.after.piecewise_linear

    def next_minimum(self, t0, t1):
        first = self.before.next_minimum(t0, min(t1, self.t)) if t0 < self.t else math.inf
        if first is None or first < math.inf:
            return first
        return self.after.next_minimum(max(t0, self.t), t1) if t1 > self.t else math.inf

    def next_crossing(self, level, t0, t1):
        if t0 < self.t:
            first = self.before.next_crossing(level, t0, min(t1, self.t))
            if first is None or first < math.inf:
                return first
        if t1 > self.t:
            return self.after.next_crossing(level, max(t0, self.t), t1)
        return math.inf


# ------------------------------------------------------------------ values (one implementation)


@compilable
def step_value(t: float, at: float, before: float, after: float) -> float:
    """A step from ``before`` to ``after`` at ``at`` (right-continuous)."""
    return after if t >= at else before


@compilable
def ramp_value(t: float, t0: float, t1: float, v0: float, v1: float) -> float:
    """``v0`` up to ``t0``, linear to ``v1`` at ``t1``, ``v1`` after."""
    if t <= t0:
        return v0
    if t >= t1:
        return v1
    return v0 + (v1 - v0) * (t - t0) / (t1 - t0)


@compilable
def table_value(t: float, ts, vs) -> float:
    """The piecewise-linear table ``(ts, vs)`` at ``t`` (a jump at two equal times, right-continuous)."""
    if t < ts[0]:
        return vs[0]
    if t >= ts[-1]:
        return vs[-1]
    i = bisect_right(ts, t) - 1  # ts[i] <= t < ts[i + 1], so ts[i + 1] > ts[i]
    return vs[i] + (vs[i + 1] - vs[i]) * (t - ts[i]) / (ts[i + 1] - ts[i])


@compilable
def table_values(ts, times, values, out) -> None:
    """:func:`table_value` at every time of ``ts``, into ``out``."""
    for k in range(len(ts)):
        out[k] = table_value(ts[k], times, values)


@compilable
def sine_value(t: float, offset: float, amplitude: float, frequency: float, phase: float) -> float:
    return offset + amplitude * math.sin(2 * math.pi * frequency * t + phase)


@compilable
def pulse_value(t: float, t0: float, width: float, low: float, high: float, period: float) -> float:
    """:class:`Pulse` at ``t``; ``period`` 0 for a single pulse."""
    start = t0 if period == 0.0 or t < t0 else _period_start(t, t0, period)
    return high if start <= t < start + width else low


@compilable
def periodic_phase(t: float, times, period: float) -> float:
    """``t`` carried into the first period of a :class:`Periodic` table with the times ``times``,
    snapped onto a table time that round-off misses by a few ulps (so that a jump at a period's
    start stays right-continuous)."""
    first = times[0]
    u = first + (t - _period_start(t, first, period))
    tol = 8 * ulp(max(abs(t), abs(first) + period))
    j = bisect_left(times, u - tol)
    if j < len(times) and abs(times[j] - u) <= tol:
        u = times[j]
    return u


@compilable
def periodic_value(t: float, times, values, period: float) -> float:
    return table_value(periodic_phase(t, times, period), times, values)
