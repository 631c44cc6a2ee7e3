"""Time signals: apply fractions, torques and other inputs as functions of time.

Every signal is a frozen object with ``value(t)`` and ``breakpoints()`` — the times where it is
not smooth, at which the simulator restarts its integrator so that no kink is stepped over.

Kinds (as written in a scenario file, see README "Scenario files"):

``constant``  ``value``
``step``      ``t``, ``before``, ``after``
``ramp``      ``t0``, ``t1``, ``v0``, ``v1`` (constant outside ``[t0, t1]``)
``table``     ``t = [...]``, ``value = [...]``: piecewise linear, constant beyond the ends
``sine``      ``offset``, ``amplitude``, ``frequency`` [Hz], ``phase`` [rad]
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .interp import interp1

__all__ = ["Signal", "Constant", "Step", "Ramp", "Table", "Sine", "Sum", "Spliced"]


class Signal:
    """Base class: a scalar function of time [s]."""

    def value(self, t: float) -> float:  # pragma: no cover - abstract
        raise NotImplementedError

    def breakpoints(self) -> tuple[float, ...]:
        return ()

    def __call__(self, t: float) -> float:
        return self.value(t)

    def sample(self, ts: np.ndarray) -> np.ndarray:
        """The signal at every time of ``ts`` (for output sampling)."""
        return np.array([self.value(t) for t in ts], dtype=float)

    def upper_bound(self, t0: float, t1: float) -> float:
        """An upper bound of the signal on ``[t0, t1]`` (``inf`` when unknown): the simulator
        leaves out of a segment's right-hand side the shift elements whose apply signal cannot
        rise above zero in it."""
        return math.inf

    def next_crossing(self, level: float, t0: float, t1: float) -> float | None:
        """The first time in ``(t0, t1)`` [s] at which the signal crosses ``level`` strictly inside
        one of its smooth pieces (crossings at breakpoints are breakpoints already); ``inf`` when
        there is none, ``None`` when the signal cannot tell (the simulator then relies on its event
        function alone). An apply signal crossing zero is a kink of the element torque: the
        simulator restarts its integrator there, so that no solver steps over a short pulse."""
        return None


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
    v: float

    def value(self, t: float) -> float:
        return self.v

    def sample(self, ts: np.ndarray) -> np.ndarray:
        return np.full(len(ts), float(self.v))

    def upper_bound(self, t0: float, t1: float) -> float:
        return self.v

    def knots(self) -> tuple:
        return ((-math.inf, self.v), (math.inf, self.v))

    def next_crossing(self, level, t0, t1):
        return math.inf


@dataclass(frozen=True)
class Step(Signal):
    t: float
    before: float
    after: float

    def value(self, t: float) -> float:
        return self.after if t >= self.t else self.before

    def breakpoints(self) -> tuple[float, ...]:
        return (self.t,)

    def upper_bound(self, t0: float, t1: float) -> float:
        return max(self.value(t0), self.value(t1))

    def knots(self) -> tuple:
        return ((-math.inf, self.before), (self.t, self.before), (self.t, self.after), (math.inf, self.after))

    def next_crossing(self, level, t0, t1):
        return math.inf  # constant pieces; the jump is a breakpoint


@dataclass(frozen=True)
class Ramp(Signal):
    t0: float
    t1: float
    v0: float
    v1: float

    def value(self, t: float) -> float:
        if t <= self.t0:
            return self.v0
        if t >= self.t1:
            return self.v1
        return self.v0 + (self.v1 - self.v0) * (t - self.t0) / (self.t1 - self.t0)

    def breakpoints(self) -> tuple[float, ...]:
        return (self.t0, self.t1)

    def upper_bound(self, t0: float, t1: float) -> float:
        return max(self.value(t0), self.value(t1))  # monotonic

    def knots(self) -> tuple:
        return ((-math.inf, self.v0), (self.t0, self.v0), (self.t1, self.v1), (math.inf, self.v1))

    def next_crossing(self, level, t0, t1):
        return _linear_crossing(level, t0, t1, self.knots())


@dataclass(frozen=True)
class Table(Signal):
    """Piecewise-linear table; ``times`` strictly increasing."""

    times: tuple[float, ...]
    values: tuple[float, ...]

    def __post_init__(self):
        object.__setattr__(self, "times", tuple(float(x) for x in self.times))
        object.__setattr__(self, "values", tuple(float(x) for x in self.values))

    def value(self, t: float) -> float:
        return interp1(t, self.times, self.values)

    def sample(self, ts: np.ndarray) -> np.ndarray:
        return np.interp(ts, self.times, self.values)

    def upper_bound(self, t0: float, t1: float) -> float:
        inside = [v for t, v in zip(self.times, self.values) if t0 < t < t1]  # piecewise linear
        return max([self.value(t0), self.value(t1)] + inside)

    def breakpoints(self) -> tuple[float, ...]:
        return tuple(self.times)

    def knots(self) -> tuple:
        return tuple(zip(self.times, self.values))

    def next_crossing(self, level, t0, t1):
        return _linear_crossing(level, t0, t1, self.knots())


@dataclass(frozen=True)
class Sine(Signal):
    offset: float
    amplitude: float
    frequency: float
    phase: float = 0.0

    def value(self, t: float) -> float:
        return self.offset + self.amplitude * math.sin(2 * math.pi * self.frequency * t + self.phase)

    def upper_bound(self, t0: float, t1: float) -> float:
        return self.offset + abs(self.amplitude)

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


@dataclass(frozen=True)
class Sum(Signal):
    """The sum of several signals (e.g. a base table and a shift-template contribution)."""

    parts: tuple[Signal, ...]

    def value(self, t: float) -> float:
        return sum(p.value(t) for p in self.parts)

    def upper_bound(self, t0: float, t1: float) -> float:
        return sum(p.upper_bound(t0, t1) for p in self.parts)

    def breakpoints(self) -> tuple[float, ...]:
        return tuple(sorted({b for p in self.parts for b in p.breakpoints()}))

    def next_crossing(self, level, t0, t1):
        if not all(hasattr(p, "knots") for p in self.parts):
            return None
        # piecewise linear between the union of the parts' knots (jumps are breakpoints)
        times = sorted({t for p in self.parts for t, _ in p.knots() if math.isfinite(t)} | {t0, t1})
        times = [t for t in times if t0 <= t <= t1]
        knots = []
        for a, b in zip(times, times[1:]):
            if b > a:
                eps = 1e-12 * max(1.0, abs(a), abs(b))
                knots.append(((a, self.value(a + eps)), (b, self.value(b - eps))))
        for (ta, va), (tb, vb) in knots:
            tc = _linear_crossing(level, t0, t1, ((ta, va), (tb, vb)))
            if tc < math.inf:
                return tc
        return math.inf


@dataclass(frozen=True)
class Spliced(Signal):
    """``before`` up to time ``t``, ``after`` from ``t`` on (a controller's new command)."""

    t: float
    before: Signal
    after: Signal

    def value(self, t: float) -> float:
        return self.after.value(t) if t >= self.t else self.before.value(t)

    def upper_bound(self, t0: float, t1: float) -> float:
        bounds = []
        if t0 < self.t:
            bounds.append(self.before.upper_bound(t0, min(t1, self.t)))
        if t1 >= self.t:
            bounds.append(self.after.upper_bound(max(t0, self.t), t1))
        return max(bounds)

    def breakpoints(self) -> tuple[float, ...]:
        return tuple(sorted({self.t} | {b for b in self.before.breakpoints() if b < self.t}
                            | {b for b in self.after.breakpoints() if b > self.t}))

    def next_crossing(self, level, t0, t1):
        if t0 < self.t:
            first = self.before.next_crossing(level, t0, min(t1, self.t))
            if first is None or first < math.inf:
                return first
        if t1 > self.t:
            return self.after.next_crossing(level, max(t0, self.t), t1)
        return math.inf
