"""Shift schedules: apply trajectories of the oncoming and offgoing elements generated from a
template, for shift events at given times or for an automatic schedule.

The template's phases and parameters and the automatic schedule: docs/explanation/shift-schedules.md.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ..core.interp import interp_like_numpy
from ..core.signals import Signal, Spliced, Table

__all__ = ["ShiftTemplate", "ShiftEvent", "shift_trajectories", "gear_elements", "gear_swap", "AutoShift",
           "TORQUE_FIELDS", "torque_request_signal", "request_table", "ControllerRequest", "POWER_ON_THROTTLE",
           "SYNC_FRACTION", "SYNC_MIN", "speed_phase_first", "EASE_FIELDS", "EASE_BOUNDS"]

POWER_ON_THROTTLE = 0.1
"""Throttle [0-1] at and above which a shift is power-on (module docstring)."""
SYNC_FRACTION = 0.1
"""Fraction of the oncoming element's slip at the command at which a speed-phase-first shift applies it."""
SYNC_MIN = 1.0
"""Smallest slip [rad/s] at which a speed-phase-first shift applies its oncoming element."""
SYNC_RELEASE = 0.02
"""Time [s] in which a speed-phase-first shift releases what is left of its offgoing element at synchronism."""


def speed_phase_first(direction: str, throttle: float) -> bool:
    """Whether a shift (``direction`` 'up'/'down') at ``throttle`` [0-1] has its speed phase first:
    a power-on downshift or a power-off upshift (module docstring)."""
    return (direction == "down") == (throttle >= POWER_ON_THROTTLE)

#: the template's engine torque intervention parameters (factors [-] and times [s]); their defaults
#: leave the engine alone
TORQUE_FIELDS = ("torque_boost", "boost_delay", "boost_time", "torque_cut", "cut_delay", "cut_time", "torque_ramp")

#: the template's easing of the inertia phase's end (``ease_slip`` 0: off; module docstring of the
#: automatic schedule, :meth:`AutoShift.fire`)
EASE_FIELDS = ("ease_slip", "ease_time", "ease_level")
EASE_BOUNDS = {"ease_slip": (0.0, 0.99), "ease_time": (0.0, 10.0), "ease_level": (0.0, 1.0)}
"""Inclusive bounds of the easing fields: a fraction of the initial slip [-], a time [s], an apply level [-]."""


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
    torque_boost: float = 1.0
    boost_delay: float = 0.0
    boost_time: float = 0.0
    torque_cut: float = 1.0
    cut_delay: float = 0.0
    cut_time: float = 0.0
    torque_ramp: float = 0.05
    ease_slip: float = 0.0
    ease_time: float = 0.0
    ease_level: float = 0.0

    def __post_init__(self):
        for name in self.__dataclass_fields__:
            v = getattr(self, name)
            if not (isinstance(v, (int, float)) and math.isfinite(v) and v >= 0):
                raise ValueError(f"shift template: {name} must be a finite number >= 0, not {v!r}")
            lo, hi = EASE_BOUNDS.get(name, (0.0, math.inf))
            if not lo <= v <= hi:
                raise ValueError(f"shift template: {name} must lie in [{lo:g}, {hi:g}], not {v!r}")

    def as_data(self) -> dict:
        """The template as plain data for a scenario file or a JSON document: every field, but the
        engine torque intervention's only where it intervenes (a clutch-only template writes its
        nine apply fields), the easing's only where it eases."""
        data = {k: getattr(self, k) for k in self.__dataclass_fields__}
        for fields, used in ((TORQUE_FIELDS, self.torque_intervention), (EASE_FIELDS, self.eases)):
            if not used:
                for k in fields:
                    del data[k]
        return data

    @property
    def eases(self) -> bool:
        """Whether an automatic schedule eases the oncoming element near the lock (``ease_slip`` > 0)."""
        return self.ease_slip > 0.0

    def eased(self, t0: float, t: float, now: float) -> list[tuple[float, float]]:
        """The oncoming apply of a shift commanded at ``t0`` [s] from its ease event at ``t`` on,
        from its value ``now``: a ramp to ``ease_level`` over ``ease_time``, that level held until
        the template's hold ends (at least as long again as the ramp: the lock is expected by the
        ramp's end, the hold covers an error of that estimate), then full apply over
        ``final_time`` (a slip that did not close is closed then)."""
        ramp = max(self.ease_time, 1e-6)
        t_hold = max(t0 + self.fill_time + self.ramp_time + self.hold_time, t + 2.0 * ramp)
        return [(t, now), (t + ramp, self.ease_level), (t_hold, self.ease_level),
                (t_hold + max(self.final_time, 1e-6), 1.0)]

    @property
    def torque_intervention(self) -> bool:
        """Whether the template asks the engine for another torque than its own at some time."""
        return ((self.torque_boost != 1.0 and self.boost_time + self.torque_ramp > 0)
                or (self.torque_cut != 1.0 and self.cut_time + self.torque_ramp > 0))

    def torque_request(self, t0: float) -> list[tuple[float, float]]:
        """Corner points ``(t [s], factor [-])`` of the engine torque-request factor of a shift
        commanded at ``t0`` (1 before the first and after the last point); ``[]`` without an
        intervention. See the module docstring."""
        if not self.torque_intervention:
            return []
        ramp = max(self.torque_ramp, 1e-6)  # 0: a step, as the apply jumps (1 us)
        t_r = t0 + self.fill_time + self.offgoing_delay
        t_e = t_r + self.offgoing_ramp
        trapezoids = [(t_r + self.boost_delay, self.boost_time, self.torque_boost - 1.0),
                      (t_e + self.cut_delay, self.cut_time, self.torque_cut - 1.0)]
        trapezoids = [tp for tp in trapezoids if tp[2] != 0.0]
        corners = []
        for c in sorted({c for a, hold, _ in trapezoids for c in (a, a + ramp, a + ramp + hold, a + 2 * ramp + hold)}):
            if not corners or c - corners[-1] > 1e-9:  # one corner where two meet but for round-off
                corners.append(c)

        def shape(t, a, hold):
            return float(np.clip(min((t - a) / ramp, (a + 2 * ramp + hold - t) / ramp), 0.0, 1.0))

        return [(t, max(0.0, 1.0 + sum(d * shape(t, a, hold) for a, hold, d in trapezoids))) for t in corners]

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
              oneway: frozenset[str] = frozenset(),
              lockup: frozenset[str] = frozenset()) -> tuple[tuple[str, ...], tuple[str, ...]]:
    """(oncoming, offgoing) elements a shift from ``source`` to ``target`` commands, each sorted.

    Elements in ``oneway`` (one-way clutches) are left out: they need no command. A converter
    lock-up clutch in ``lockup`` (:func:`transgen.own_converter.own_converter`) is no shift element:
    it is left out of both gears before the swap is counted. Raises
    ``ValueError`` naming the gears when the shift is not schedulable: more than
    :data:`MAX_SWAP` elements change on either side, or nothing is left to command.
    """
    a, b = set(gears[source]) - lockup, set(gears[target]) - lockup
    on, off = b - a, a - b
    engaged = f"(engaged {' '.join(sorted(a))} -> {' '.join(sorted(b))})"
    if len(on) > MAX_SWAP or len(off) > MAX_SWAP:
        raise ValueError(f"shift {source}-{target} is not schedulable: it swaps {len(off)} element(s) for "
                         f"{len(on)}, at most a double swap (2 off, 2 on) is supported {engaged}")
    on, off = tuple(sorted(on - oneway)), tuple(sorted(off - oneway))
    if not on and not off:
        raise ValueError(f"shift {source}-{target} is not schedulable: no clutch or brake to command {engaged}")
    return on, off


def gear_elements(gears: dict[str, tuple[str, ...]], source: str, target: str,
                  lockup: frozenset[str] = frozenset()) -> tuple[str, str]:
    """(oncoming, offgoing) element of a single-swap shift between two gears of the gear table
    (``lockup``: as :func:`gear_swap`)."""
    a, b = set(gears[source]) - lockup, set(gears[target]) - lockup
    if len(b - a) != 1 or len(a - b) != 1:
        raise ValueError(f"shift {source}-{target} is not a single swap of one element "
                         f"(engaged {' '.join(sorted(a))} -> {' '.join(sorted(b))})")
    (on,), (off,) = gear_swap(gears, source, target, lockup=lockup)
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
                       elements: list[str], lockup: frozenset[str] = frozenset()) -> dict[str, Table]:
    """Apply signals of every element for a sequence of shift events starting in ``initial_gear``
    (``lockup``: as :func:`gear_swap`)."""
    points = {e: [(0.0, 1.0 if e in gears[initial_gear] else 0.0)] for e in elements}
    current = initial_gear
    for ev in sorted(events, key=lambda e: e.t):
        if ev.source != current:
            raise ValueError(f"shift at t={ev.t:g} s starts from gear {ev.source} but gear {current} is engaged")
        on, off = gear_elements(gears, ev.source, ev.target, lockup)
        points[on] += ev.template.oncoming(ev.t)
        points[off] += ev.template.offgoing(ev.t)
        current = ev.target
    return {e: _merge(p) for e, p in points.items()}


def request_table(profiles: list[list[tuple[float, float]]]) -> Table | None:
    """The torque-request factor of several shifts' profiles (``(t, factor)`` corners, 1 outside
    each) as one table: their product at every corner (profiles that overlap multiply); None when
    there is none."""
    profiles = [p for p in profiles if p]
    if not profiles:
        return None
    tables = [_merge([(p[0][0] - 1.0, 1.0)] + p) for p in profiles]
    times = sorted({t for tb in tables for t in tb.times})
    return Table(tuple(times), tuple(float(np.prod([tb.value(t) for tb in tables])) for t in times))


def torque_request_signal(events: list[ShiftEvent]) -> Table | None:
    """The engine torque-request factor [-] of a sequence of shift events (None: no event's
    template intervenes, the engine runs on its own)."""
    return request_table([ev.template.torque_request(ev.t) for ev in events])


class ControllerRequest(Signal):
    """The torque-request factor that a controller (:class:`AutoShift`) commands: its current
    ``torque_request`` signal, read at every evaluation (the controller splices each shift's
    profile into it when it commands the shift; its saved state restores it)."""

    piecewise_linear = True

    def __init__(self, controller=None):
        self.controller = controller

    def value(self, t: float) -> float:
        return self.controller.torque_request.value(t)

    def breakpoints(self, t0: float = -math.inf, t1: float = math.inf) -> tuple[float, ...]:
        return self.controller.torque_request.breakpoints(t0, t1)

    def upper_bound(self, t0: float, t1: float) -> float:
        return self.controller.torque_request.upper_bound(t0, t1)


@dataclass
class AutoShift:
    """An automatic shift schedule: shift lines over output speed and throttle.

    ``upshift[k]``: output-link speeds [rad/s] at ``throttle_points`` above which gear ``order[k]``
    shifts up to ``order[k+1]``; ``downshift[k]``: speeds below which ``order[k+1]`` shifts down
    (must lie below the upshift line: hysteresis). ``min_interval``: no new shift within this time
    after one starts [s]. Commands shifts with :class:`ShiftTemplate` trajectories by replacing the
    apply signals of the elements concerned from the command time on: ``templates["1-2"]`` for the
    shift from gear 1 to 2 where given (a calibration per shift), else ``template``. A
    torque-phase-first shift whose template eases (``ease_slip`` > 0) raises an ``ease`` event when
    its oncoming slip falls to ``ease_slip`` times the slip at the command (a root-found event, as
    the shift lines) and from then on follows :meth:`ShiftTemplate.eased`.
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
    torque_request: Signal = field(default_factory=lambda: Table((0.0,), (1.0,)))  # engine torque-request factor
    slips: dict = field(default_factory=dict)  # element -> coefficients of its slip over the link speeds
    speed_first: dict = field(default_factory=dict)  # "SOURCE-TARGET" -> template of a speed-phase-first shift
    pending: dict = field(default_factory=dict)  # a speed-phase-first shift waiting for synchronism
    lockup: frozenset = frozenset()  # converter lock-up clutches: no shift element (gear_swap)
    easing: dict = field(default_factory=dict)  # a shift whose oncoming element waits for its ease slip

    event_kinds = {"ease": "ease"}  # the kind of the Result's event of a fired event function (else "command")

    def __post_init__(self):
        for up, down in zip(self.upshift, self.downshift):
            if np.any(np.asarray(down) >= np.asarray(up)):
                raise ValueError("every downshift speed must lie below the upshift speed (hysteresis)")
        for source, target in zip(self.order, self.order[1:]):
            gear_swap(self.gears, source, target, lockup=self.lockup)  # refuses a sequence with an unschedulable shift
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
        if self.pending:
            funcs.append((self._sync_margin, "sync"))
        if self.easing:
            funcs.append((self._ease_margin, "ease"))
        return funcs

    def _ease_margin(self, t: float, w) -> float:
        """Falls through zero when the easing shift's oncoming slip is down to its ease slip."""
        return max(abs(self._slip(n, w)) for n in self.easing["elements"]) - self.easing["band"]

    def _ease(self, t: float, elements: dict) -> str:
        """Ease the oncoming element(s) of the shift waiting for it (:meth:`ShiftTemplate.eased`)."""
        p, self.easing = self.easing, {}
        template = p["template"]
        for name in p["elements"]:
            e = elements[name]
            e.apply = Spliced(t, e.apply, _merge(template.eased(p["t0"], t, e.apply.value(t))))
        return (f"ease: {' '.join(p['elements'])} to {template.ease_level:g} over {template.ease_time:g} s "
                f"at {template.ease_slip:g} of the slip ({p['shift']})")

    def _slip(self, name: str, w) -> float:
        return float(sum(c * x for c, x in zip(self.slips[name], w)))

    def _sync_margin(self, t: float, w) -> float:
        """Falls through zero when the waiting oncoming element nears synchronism or its deadline passes."""
        p = self.pending
        return min(max(abs(self._slip(n, w)) for n in p["elements"]) - p["band"], p["deadline"] - t)

    def _synchronise(self, t: float, elements: dict) -> str:
        """Apply the oncoming element(s) of the waiting shift: from their level to full over its ramp."""
        p, self.pending = self.pending, {}
        for names, level, ramp in ((p["elements"], 1.0, max(p["ramp"], 1e-6)), (p["offgoing"], 0.0, SYNC_RELEASE)):
            for name in names:
                e = elements[name]
                now = e.apply.value(t)
                if level > 0 or now > 0:
                    e.apply = Spliced(t, e.apply, _merge([(t, now), (t + ramp, level)]))
        return (f"synchronism: apply {' '.join(p['elements'])}" + (f", release {' '.join(p['offgoing'])}"
                                                                   if p["offgoing"] else "") + f" ({p['shift']})")

    def fire(self, kind: str, t: float, elements: dict, w=None) -> str | None:
        """Command the shift ``kind`` ('up'/'down') at ``t``, or ('sync') apply a waiting oncoming
        element; returns a description or None when blocked by ``min_interval``. ``elements``:
        name -> ElementConfig (apply replaced); ``w``: the link speeds [rad/s] at ``t`` (a
        speed-phase-first shift and easing need them, module docstring); ('ease') ease a shift's
        oncoming element at its ease slip."""
        if kind == "sync":
            return self._synchronise(t, elements) if self.pending else None
        if kind == "ease":
            return self._ease(t, elements) if self.easing else None
        if self._wait(t) > 1e-9 * max(1.0, abs(t)):
            return None
        k = self.order.index(self.gear)
        target = self.order[k + 1] if kind == "up" else self.order[k - 1]
        oneway = frozenset(name for name, e in elements.items() if e.kind == "oneway")
        on, off = gear_swap(self.gears, self.gear, target, oneway, self.lockup)
        template = self.templates.get(f"{self.gear}-{target}", self.template)
        oncoming = template.oncoming(t)
        if self.pending:  # a shift still waiting for synchronism: its oncoming element is applied now
            self._synchronise(t, elements)
        self.easing = {}  # a shift still waiting for its ease slip is not eased (this one's trajectories follow)
        power = "on" if float(self.throttle.value(t)) >= POWER_ON_THROTTLE else "off"
        if (on and w is not None and all(n in self.slips for n in on)
                and speed_phase_first(kind, float(self.throttle.value(t)))):
            template = self.speed_first.get(f"{self.gear}-{target}", template)
            oncoming = template.oncoming(t)[:3]  # the fill alone, held until synchronism
            slip = max(abs(self._slip(n, w)) for n in on)
            self.pending = {"elements": on, "offgoing": off, "band": max(SYNC_FRACTION * slip, SYNC_MIN),
                            "ramp": template.final_time,
                            "deadline": t + template.fill_time + template.ramp_time + template.hold_time,
                            "shift": f"{self.gear}-{target}"}
        elif on and w is not None and template.eases and all(n in self.slips for n in on):
            slip = max(abs(self._slip(n, w)) for n in on)
            if slip > 0.0:  # the ease event on the measured slip, a fraction of this one
                self.easing = {"elements": on, "band": template.ease_slip * slip, "template": template, "t0": t,
                               "shift": f"{self.gear}-{target}"}
        for names, pts in ((on, oncoming), (off, template.offgoing(t))):
            for name in names:
                e = elements[name]
                e.apply = Spliced(t, e.apply, _merge([(t, e.apply.value(t))] + pts[1:]))
        profile = template.torque_request(t)
        if profile:  # the profile from the command on (an earlier shift's leftover is dropped)
            self.torque_request = Spliced(t, self.torque_request, _merge([(t, 1.0)] + profile))
        self.history.append((t, self.gear, target))
        description = (f"{kind}shift {self.gear}-{target} (on {' '.join(on) or 'none: one-way clutch locks'}, "
                       f"off {' '.join(off) or 'none: one-way clutch overruns'}; power-{power})")
        self.gear, self.last_shift = target, t
        return description
