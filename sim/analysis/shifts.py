"""The shifts in a simulation result: :class:`Shift`, :func:`infer_shifts`, and the times at
which a shift element locks or unlocks.

A shift hands the torque from an *offgoing* shift element to an *oncoming* one. When the
scenario does not list its shifts, :func:`infer_shifts` finds them from the elements' apply
signals and the run's lock/unlock events. The lock and unlock times come from the events (mode
changes), else from an element's ``locked_<e>`` signal. Times in s. The shift-quality analysis of
each shift is :func:`transgen.sim.analysis.shift_quality.shift_report`.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from transgen.names import ModeNames
from transgen.names import shift_name as _joined

from ..core.result import Result

__all__ = ["Shift", "infer_shifts", "lock_time", "lock_times", "shift_name", "APPLY_ZERO"]

APPLY_ZERO = 1e-9  # an apply at or below this is "off"


@dataclass(frozen=True)
class Shift:
    """A shift to analyse: ``oncoming`` element applied, ``offgoing`` released, commanded at
    ``t_start`` [s] (the start of the pre-shift reference and of every shift window)."""

    oncoming: str
    offgoing: str
    t_start: float
    name: str = ""


def _mode_locked(result: Result) -> dict[str, set]:
    return {m.name: set(m.locked) for m in result.modes}


def _event_times(result: Result, element: str, after: float, before: float, locks: bool) -> list[float]:
    """Times of the events in ``[after, before]`` where ``element`` locks (``locks``) or unlocks."""
    locked = _mode_locked(result)
    out = []
    for e in result.events:
        if e.kind == "start" or element not in e.elements or not (after <= e.t <= before):
            continue
        src, tgt = locked.get(e.source), locked.get(e.target)
        if src is None or tgt is None:
            if e.kind == ("lock" if locks else "unlock"):
                out.append(float(e.t))
        elif (element in tgt and element not in src) if locks else (element in src and element not in tgt):
            out.append(float(e.t))
    return out


def _signal_edges(t: np.ndarray, y: np.ndarray, after: float, before: float, rising: bool) -> list[float]:
    """Times in ``[after, before]`` where a 0/1 signal rises (or falls)."""
    s = y > 0.5
    k = np.nonzero((~s[:-1] & s[1:]) if rising else (s[:-1] & ~s[1:]))[0] + 1
    return [float(x) for x in t[k] if after <= x <= before]


def lock_times(result: Result, element: str, after: float, before: float, locks: bool) -> list[float]:
    """When ``element`` locks (``locks``) or unlocks in ``[after, before]``: from the events, else
    from its ``locked_`` signal."""
    times = _event_times(result, element, after, before, locks)
    key = f"locked_{element}"
    if not times and key in result.signals:
        times = _signal_edges(result.time, result.signals[key], after, before, rising=locks)
    return times


def lock_time(result: Result, element: str, after: float, before: float, locks: bool) -> float | None:
    """The first of :func:`lock_times`, or None."""
    times = lock_times(result, element, after, before, locks)
    return times[0] if times else None


def _rise_onsets(t: np.ndarray, a: np.ndarray) -> list[float]:
    """Times where an apply signal leaves zero (the last zero sample before it rises)."""
    on = a > APPLY_ZERO
    return [float(t[i]) for i in range(len(t) - 1) if not on[i] and on[i + 1]]


def _fall_zeros(t: np.ndarray, a: np.ndarray) -> list[tuple[float, float]]:
    """(release start, time it reaches zero) for every fall of an apply signal to zero."""
    on = a > APPLY_ZERO
    out = []
    for i in range(len(t) - 1):
        if on[i] and not on[i + 1]:
            j = i
            # back over the decreasing ramp (and over repeated or nearly repeated time stamps)
            while j > 0 and (a[j - 1] > a[j] + 1e-12 or (t[j] - t[j - 1] < 1e-9 and a[j - 1] >= a[j] - 1e-9)):
                j -= 1
            out.append((float(t[j]), float(t[i + 1])))
    return out


def infer_shifts(result: Result, max_early_release: float = 1.0) -> list[Shift]:
    """Shifts from the apply signals and the events.

    Every rise of an element's apply from zero is an oncoming apply. The offgoing element is the
    one whose apply falls to zero nearest after that rise (its release starting before the
    oncoming element locks); failing that, one that fell to zero at most ``max_early_release`` s
    before it (an early release). ``t_start`` is the start of the oncoming apply, or the start
    of the offgoing release ramp when that comes first. Failing both, the offgoing element is the
    first other element that unlocks after the rise (a one-way clutch, or an element whose apply
    stays on).

    A release to zero that belongs to no such shift, followed by another element locking (a
    one-way clutch taking over, e.g. a release-to-freewheel downshift), is a shift too, with the
    element that locks as the oncoming one and ``t_start`` at the start of the release.

    The name is ``source-target`` (``2-3``) from the modes before the shift and after the oncoming
    element locks (:func:`shift_name`).
    """
    t = result.time
    t_end = float(t[-1])
    elements = list(result.meta.get("elements") or [k[6:] for k in result.signals if k.startswith("apply_")])
    locked = _mode_locked(result)
    rises = []
    falls = {}
    for e in elements:
        a = result.signals.get(f"apply_{e}")
        if a is None:
            continue
        rises += [(x, e) for x in _rise_onsets(t, a)]
        falls[e] = _fall_zeros(t, a)
    rises.sort()
    shifts = []
    used = set()
    for t_on, on in rises:
        best = None
        t_lock = lock_time(result, on, t_on, t_end, locks=True)
        limit = t_lock if t_lock is not None else t_end
        after = [(tz, e, ts) for e, fl in falls.items() if e != on for ts, tz in fl
                 if tz >= t_on and ts <= limit and (e, tz) not in used]
        if after:
            tz, best, ts = min(after)
        else:
            before = [(tz, e, ts) for e, fl in falls.items() if e != on for ts, tz in fl
                      if t_on - max_early_release <= tz < t_on and (e, tz) not in used]
            if before:
                tz, best, ts = max(before)
        if best is not None:
            used.add((best, tz))
            t_start = min(t_on, ts)  # a release that starts before the oncoming apply
        else:
            t_start = t_on
            for ev in result.events:
                if ev.t < t_on or ev.kind == "start":
                    continue
                src, tgt = locked.get(ev.source, set()), locked.get(ev.target, set())
                lost = [x for x in ev.elements if x != on and x in src and x not in tgt]
                if lost:
                    best = lost[0]
                    break
        if best is None:
            continue
        shifts.append(Shift(on, best, t_start, shift_name(result, on, t_start, best)))
    # releases handed over to an element that locks by itself (one-way clutch)
    starts = sorted([x for x, _ in rises] + [ts for fl in falls.values() for ts, _ in fl])
    for off, fl in falls.items():
        for ts, tz in fl:
            if (off, tz) in used or any(abs(s.t_start - ts) < 1e-9 and s.offgoing == off for s in shifts):
                continue
            nxt = min([x for x in starts if x > ts + 1e-9], default=t_end)
            for ev in result.events:
                if ev.kind == "start" or not (ts <= ev.t <= nxt):
                    continue
                src, tgt = locked.get(ev.source, set()), locked.get(ev.target, set())
                gained = [x for x in ev.elements if x != off and x in tgt and x not in src]
                if gained:
                    shifts.append(Shift(gained[0], off, ts, shift_name(result, gained[0], ts, off)))
                    break
    shifts.sort(key=lambda s: s.t_start)
    return shifts


def _mode_at(result: Result, x: float, side: str) -> str | None:
    for m in result.modes:
        if (m.t0 <= x < m.t1) if side == "right" else (m.t0 < x <= m.t1):
            return m.name
    if result.modes:
        return result.modes[0].name if x <= result.modes[0].t0 else result.modes[-1].name
    return None


def shift_name(result: Result, on: str, t_start: float, off: str | None = None) -> str:
    """``source-target`` (:func:`transgen.names.shift_name`: ``2-3``): the modes, named as the
    result names them (by gear, :class:`transgen.names.ModeNames`), before ``t_start`` and after
    ``on`` locks. A shift whose ``on`` never locks (a run that ends in it) is named by the mode it
    was heading for, the one before with ``off`` released and ``on`` locked, where the result
    carries its mechanism's names (``meta["naming"]``); else ``"<on> on"``."""
    t_end = float(result.time[-1]) if len(result.time) else t_start
    t_lock = lock_time(result, on, t_start, t_end, locks=True)
    a = _mode_at(result, t_start, "left")
    b = _mode_at(result, t_lock, "right") if t_lock is not None else None
    naming = (result.meta or {}).get("naming")
    if a and b is None and off is not None and naming:
        before = next((m.locked for m in result.modes if m.name == a), None)
        if before is not None:
            b = ModeNames.from_dict(naming).name((set(before) - {off}) | {on})
    return _joined(a, b) if a and b else f"{on} on"
