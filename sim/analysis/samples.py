"""Arithmetic on the sampled signals of a simulation result.

A :class:`~transgen.sim.core.result.Result` samples its signals at increasing times; a mode change
repeats its time stamp (the value before the event, then the value after it). These helpers
interpolate, integrate and measure durations over such samples so that a repeated time stamp
adds nothing and the value on either side of an event can be asked for. Times in s; the units of
the values are those of the signal.
"""
from __future__ import annotations

import numpy as np

__all__ = ["value_at", "window", "integrate", "duration_above"]


def value_at(t: np.ndarray, y: np.ndarray, x: float, side: str = "left") -> float:
    """``y`` at time ``x``, linearly interpolated (held constant outside the samples); at a
    repeated time (a mode change) ``side="left"`` gives the value before the event, ``"right"``
    the value after it."""
    i = int(np.searchsorted(t, x, side=side))
    if side == "left":  # t[i] is the first sample >= x
        if i >= len(t):
            return float(y[-1])
        if t[i] == x or i == 0:
            return float(y[i])
    else:  # t[i - 1] is the last sample <= x
        if i == 0:
            return float(y[0])
        if t[i - 1] == x or i >= len(t):
            return float(y[i - 1])
    t0, t1 = t[i - 1], t[i]
    f = (x - t0) / (t1 - t0) if t1 > t0 else 1.0
    return float(y[i - 1] + f * (y[i] - y[i - 1]))


def window(t: np.ndarray, t0: float, t1: float) -> np.ndarray:
    """Indices of the samples in ``[t0, t1]``."""
    return np.nonzero((t >= t0) & (t <= t1))[0]


def _cumtrapz(t: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Cumulative trapezoidal integral; a repeated time stamp (dt = 0) adds nothing, so the
    result is continuous across mode changes."""
    out = np.zeros(len(t))
    if len(t) > 1:
        out[1:] = np.cumsum(0.5 * (y[1:] + y[:-1]) * np.diff(t))
    return out


def integrate(t: np.ndarray, y: np.ndarray, t0: float, t1: float) -> float:
    """Trapezoidal integral of ``y`` over ``[t0, t1]`` (interpolated at the ends; repeated time
    stamps at mode changes are handled: a zero-length interval adds nothing)."""
    if t1 <= t0 or len(t) < 2:
        return 0.0
    c = _cumtrapz(t, y)
    return value_at(t, c, t1) - value_at(t, c, t0)


def duration_above(t: np.ndarray, z: np.ndarray) -> float:
    """Total time where ``z > 0``, crossings located by linear interpolation between samples."""
    if len(t) < 2:
        return 0.0
    dt = np.diff(t)
    a, b = z[:-1], z[1:]
    total = float(np.sum(dt[(a > 0) & (b > 0)]))
    cross = (a > 0) != (b > 0)
    for k in np.nonzero(cross & (dt > 0))[0]:
        pos, neg = (a[k], b[k]) if a[k] > 0 else (b[k], a[k])
        total += dt[k] * pos / (pos - neg)
    return total
