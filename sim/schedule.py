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

Elements engaged in both gears stay at their level. A double swap (two elements off, two on, as
in a clutch-to-clutch shift between non-adjacent planetary states) applies the oncoming profile to
both oncoming elements and the offgoing profile to both offgoing ones (:func:`gear_swap`); a
one-way clutch is never commanded: leaving the gear it overruns by itself, entering it locks by
itself when the offgoing element lets go. :func:`shift_trajectories` turns a list of
shift events into apply :class:`~transgen.sim.signals.Table` signals; :class:`AutoShift` is a
controller that commands shifts when the output speed crosses throttle-dependent upshift or
downshift lines (with hysteresis: the downshift line lies below the upshift line).
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .interp import interp_like_numpy
from .signals import Signal, Spliced, Table

__all__ = ["ShiftTemplate", "ShiftEvent", "shift_trajectories", "gear_elements", "gear_swap", "AutoShift"]


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


MAX_SWAP = 2
"""Most elements a shift applies (and releases) at once: single and double swaps."""


def gear_swap(gears: dict[str, tuple[str, ...]], source: str, target: str,
              oneway: frozenset[str] = frozenset()) -> tuple[tuple[str, ...], tuple[str, ...]]:
    """(oncoming, offgoing) elements a shift from ``source`` to ``target`` commands, each sorted.

    Elements in ``oneway`` (one-way clutches) are left out: they need no command. Raises
    ``ValueError`` naming the gears when the shift is not schedulable: more than
    :data:`MAX_SWAP` elements change on either side, or nothing is left to command.
    """
    a, b = set(gears[source]), set(gears[target])
    on, off = b - a, a - b
    engaged = f"(engaged {' '.join(sorted(a))} -> {' '.join(sorted(b))})"
    if len(on) > MAX_SWAP or len(off) > MAX_SWAP:
        raise ValueError(f"shift {source}-{target} is not schedulable: it swaps {len(off)} element(s) for "
                         f"{len(on)}, at most a double swap (2 off, 2 on) is supported {engaged}")
    on, off = tuple(sorted(on - oneway)), tuple(sorted(off - oneway))
    if not on and not off:
        raise ValueError(f"shift {source}-{target} is not schedulable: no clutch or brake to command {engaged}")
    return on, off


def gear_elements(gears: dict[str, tuple[str, ...]], source: str, target: str) -> tuple[str, str]:
    """(oncoming, offgoing) element of a single-swap shift between two gears of the gear table."""
    a, b = set(gears[source]), set(gears[target])
    if len(b - a) != 1 or len(a - b) != 1:
        raise ValueError(f"shift {source}-{target} is not a single swap of one element "
                         f"(engaged {' '.join(sorted(a))} -> {' '.join(sorted(b))})")
    (on,), (off,) = gear_swap(gears, source, target)
    return on, off


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
    apply signals of the elements concerned from the command time on: ``templates["1-2"]`` for the
    shift from gear 1 to 2 where given (a calibration per shift), else ``template``.
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
    templates: dict = field(default_factory=dict)  # "SOURCE-TARGET" -> the template of that shift

    def __post_init__(self):
        for up, down in zip(self.upshift, self.downshift):
            if np.any(np.asarray(down) >= np.asarray(up)):
                raise ValueError("every downshift speed must lie below the upshift speed (hysteresis)")
        for source, target in zip(self.order, self.order[1:]):
            gear_swap(self.gears, source, target)  # refuses a sequence with an unschedulable shift
        self.gear = self.gear or self.order[0]

    def _line(self, table, k, t):
        return interp_like_numpy(float(self.throttle.value(t)), self.throttle_points, table[k])

    def _wait(self, t: float) -> float:
        """Time [s] left before ``min_interval`` allows the next shift (<= 0: allowed)."""
        return self.last_shift + self.min_interval - t

    def event_functions(self):
        """(function of (t, w), name) pairs; a zero crossing from above commands a shift. A line
        crossed while ``min_interval`` still blocks shifts commands the shift when the interval
        ends (the function is the later of the two conditions), so no shift is lost."""
        k = self.order.index(self.gear)
        funcs = []
        if k + 1 < len(self.order):
            funcs.append((lambda t, w, k=k: max(self._line(self.upshift, k, t) - w[self.output], self._wait(t)), "up"))
        if k > 0:
            funcs.append((lambda t, w, k=k: max(w[self.output] - self._line(self.downshift, k - 1, t), self._wait(t)),
                          "down"))
        return funcs

    def fire(self, kind: str, t: float, elements: dict) -> str | None:
        """Command the shift ``kind`` ('up'/'down') at ``t``; returns a description or None when
        blocked by ``min_interval``. ``elements``: name -> ElementConfig (apply replaced)."""
        if self._wait(t) > 1e-9 * max(1.0, abs(t)):
            return None
        k = self.order.index(self.gear)
        target = self.order[k + 1] if kind == "up" else self.order[k - 1]
        oneway = frozenset(name for name, e in elements.items() if e.kind == "oneway")
        on, off = gear_swap(self.gears, self.gear, target, oneway)
        template = self.templates.get(f"{self.gear}-{target}", self.template)
        for names, pts in ((on, template.oncoming(t)), (off, template.offgoing(t))):
            for name in names:
                e = elements[name]
                e.apply = Spliced(t, e.apply, _merge([(t, e.apply.value(t))] + pts[1:]))
        self.history.append((t, self.gear, target))
        description = (f"{kind}shift {self.gear}-{target} (on {' '.join(on) or 'none: one-way clutch locks'}, "
                       f"off {' '.join(off) or 'none: one-way clutch overruns'})")
        self.gear, self.last_shift = target, t
        return description
