"""Shift schedules: apply trajectories of the oncoming and offgoing elements generated from a
template, for shift events at given times or for an automatic schedule.

The template (all times in s, apply levels as fractions of full apply), for a shift commanded at
``t0``:

oncoming element
    ``0`` until ``t0``; fill: ``fill_level`` from ``t0`` to ``t0 + fill_time`` (the piston
    strokes, the clutch carries little torque); torque-phase ramp: linear from ``fill_level`` to
    ``ramp_end`` over ``ramp_time``; inertia phase: held at ``ramp_end`` for ``hold_time``; then
    a ramp to full apply ``1`` over ``final_time`` (locks the element firmly).
offgoing element
    ``1`` until ``t0 + fill_time + offgoing_delay``; then a drop to ``offgoing_level`` and a
    linear release to ``0`` over ``offgoing_ramp`` — released as the oncoming element takes
    over the torque (too late: bindup; too early: flare).

Elements engaged in both gears stay at their level. :func:`shift_trajectories` turns a list of
shift events into apply :class:`~transgen.sim.signals.Table` signals; :class:`AutoShift` is a
controller that commands shifts when the output speed crosses throttle-dependent upshift or
downshift lines (with hysteresis: the downshift line lies below the upshift line).
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .signals import Signal, Spliced, Table

__all__ = ["ShiftTemplate", "ShiftEvent", "shift_trajectories", "gear_elements", "AutoShift"]


@dataclass(frozen=True)
class ShiftTemplate:
    fill_time: float = 0.1
    fill_level: float = 0.1
    ramp_time: float = 0.5
    ramp_end: float = 0.6
    hold_time: float = 0.6
    final_time: float = 0.2
    offgoing_delay: float = 0.15
    offgoing_level: float = 0.3
    offgoing_ramp: float = 0.2

    def oncoming(self, t0: float) -> list[tuple[float, float]]:
        t1 = t0 + self.fill_time
        t2 = t1 + self.ramp_time
        t3 = t2 + self.hold_time
        return [(t0, 0.0), (t0 + 1e-6, self.fill_level), (t1, self.fill_level), (t2, self.ramp_end),
                (t3, self.ramp_end), (t3 + self.final_time, 1.0)]

    def offgoing(self, t0: float) -> list[tuple[float, float]]:
        t1 = t0 + self.fill_time + self.offgoing_delay
        return [(t1, 1.0), (t1 + 1e-6, self.offgoing_level), (t1 + self.offgoing_ramp, 0.0)]


@dataclass(frozen=True)
class ShiftEvent:
    """Shift from gear ``source`` to gear ``target`` commanded at ``t`` [s]."""

    t: float
    source: str
    target: str
    template: ShiftTemplate = ShiftTemplate()


def gear_elements(gears: dict[str, tuple[str, ...]], source: str, target: str) -> tuple[str, str]:
    """(oncoming, offgoing) element of a single-swap shift between two gears of the gear table."""
    a, b = set(gears[source]), set(gears[target])
    on, off = b - a, a - b
    if len(on) != 1 or len(off) != 1:
        raise ValueError(f"shift {source}-{target} is not a single swap of one element "
                         f"(engaged {' '.join(sorted(a))} -> {' '.join(sorted(b))})")
    return next(iter(on)), next(iter(off))


def _merge(points: list[tuple[float, float]]) -> Table:
    points = sorted(points)
    times, values = [], []
    for t, v in points:
        if times and t <= times[-1]:
            t = times[-1] + 1e-9
        times.append(t)
        values.append(v)
    return Table(tuple(times), tuple(values))


def shift_trajectories(gears: dict[str, tuple[str, ...]], initial_gear: str, events: list[ShiftEvent],
                       elements: list[str]) -> dict[str, Table]:
    """Apply signals of every element for a sequence of shift events starting in ``initial_gear``."""
    points = {e: [(0.0, 1.0 if e in gears[initial_gear] else 0.0)] for e in elements}
    current = initial_gear
    for ev in sorted(events, key=lambda e: e.t):
        if ev.source != current:
            raise ValueError(f"shift at t={ev.t:g} s starts from gear {ev.source} but gear {current} is engaged")
        on, off = gear_elements(gears, ev.source, ev.target)
        points[on] += ev.template.oncoming(ev.t)
        points[off] += ev.template.offgoing(ev.t)
        current = ev.target
    return {e: _merge(p) for e, p in points.items()}


@dataclass
class AutoShift:
    """An automatic shift schedule: shift lines over output speed and throttle.

    ``upshift[k]``: output-link speeds [rad/s] at ``throttle_points`` above which gear ``order[k]``
    shifts up to ``order[k+1]``; ``downshift[k]``: speeds below which ``order[k+1]`` shifts down
    (must lie below the upshift line: hysteresis). ``min_interval``: no new shift within this time
    after one starts [s]. Commands shifts with :class:`ShiftTemplate` trajectories by replacing the
    apply signals of the elements concerned from the command time on.
    """

    order: list[str]
    throttle_points: list[float]
    upshift: list[list[float]]
    downshift: list[list[float]]
    throttle: Signal
    output: int
    gears: dict[str, tuple[str, ...]]
    template: ShiftTemplate = ShiftTemplate()
    min_interval: float = 2.0
    gear: str = ""
    last_shift: float = -1e9
    history: list = field(default_factory=list)

    def __post_init__(self):
        for up, down in zip(self.upshift, self.downshift):
            if np.any(np.asarray(down) >= np.asarray(up)):
                raise ValueError("every downshift speed must lie below the upshift speed (hysteresis)")
        self.gear = self.gear or self.order[0]

    def _line(self, table, k, t):
        return float(np.interp(self.throttle.value(t), self.throttle_points, table[k]))

    def event_functions(self):
        """(function of (t, w), name) pairs; a zero crossing from above commands a shift."""
        k = self.order.index(self.gear)
        funcs = []
        if k + 1 < len(self.order):
            funcs.append((lambda t, w, k=k: self._line(self.upshift, k, t) - w[self.output], "up"))
        if k > 0:
            funcs.append((lambda t, w, k=k: w[self.output] - self._line(self.downshift, k - 1, t), "down"))
        return funcs

    def fire(self, kind: str, t: float, elements: dict) -> str | None:
        """Command the shift ``kind`` ('up'/'down') at ``t``; returns a description or None when
        blocked by ``min_interval``. ``elements``: name -> ElementConfig (apply replaced)."""
        if t - self.last_shift < self.min_interval:
            return None
        k = self.order.index(self.gear)
        target = self.order[k + 1] if kind == "up" else self.order[k - 1]
        on, off = gear_elements(self.gears, self.gear, target)
        for name, pts in ((on, self.template.oncoming(t)), (off, self.template.offgoing(t))):
            e = elements[name]
            e.apply = Spliced(t, e.apply, _merge([(t, e.apply.value(t))] + pts[1:]))
        self.history.append((t, self.gear, target))
        description = f"{kind}shift {self.gear}-{target} (on {on}, off {off})"
        self.gear, self.last_shift = target, t
        return description
