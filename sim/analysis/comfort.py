"""Ride-comfort arithmetic on a sampled vehicle acceleration: jerk, ISO 2631-1 frequency
weighting, vibration dose value (VDV) and settling time.

The shift analysis (:mod:`transgen.sim.analysis.shift_quality`) takes the vehicle's longitudinal
acceleration from the driveline's force balance (the ``vehicle_accel`` signal of
:class:`~transgen.sim.model.components.Driveline`: exact at every sample, no differentiation noise) and
uses these functions on it. Times in s, accelerations in m/s^2, jerk in m/s^3, VDV in m/s^1.75.

* **Jerk** - the acceleration differenced between successive samples on *unique* times: a
  mode change repeats its time stamp (the value before, then after the event), the value after
  the event is kept; samples closer than ``MIN_DT_FRACTION`` of the median spacing to the
  previous one kept are skipped (an event a few nanoseconds after an output sample would turn
  the solver's round-off into a huge jerk). The jerk of an interval is its secant slope,
  reported at its mid-time.
* **Frequency weighting** - ISO 2631-1:1997 Annex A: band limiting (2nd-order Butterworth
  high-pass at f1 = 0.4 Hz and low-pass at f2 = 100 Hz), the acceleration-velocity transition
  ``(1 + s/w3) / (1 + s/(Q4 w4) + s^2/w4^2)`` and the upward step
  ``(s^2 + s w5/Q5 + w5^2) / (s^2 + s w6/Q6 + w6^2)`` (its gain rises from (f5/f6)^2 to 1).
  ``Wk`` (vertical z, f3 = f4 = 12.5 Hz, Q4 = 0.63, f5 = 2.37 Hz, Q5 = 0.91, f6 = 3.35 Hz,
  Q6 = 0.91) and ``Wd`` (horizontal x and y, f3 = f4 = 2 Hz, Q4 = 0.63, no step). A vehicle's
  longitudinal (fore-aft, x) acceleration on a seated person is weighted with **Wd** (ISO 2631-1
  Table 1), the default here; ``Wk`` is the vertical weighting, ``none`` leaves it unweighted.
  The filter is applied exactly, in the frequency domain: the acceleration, resampled (linearly)
  on a uniform grid at ``FS_WEIGHTING`` and less its first value, is zero-padded by
  ``PAD_WEIGHTING`` seconds (the 0.4 Hz high-pass has long died out by then, so the FFT's
  circular convolution is the linear one) and multiplied by the analog transfer function
  ``H(j 2 pi f)``: no bilinear-transform warping, and no import of :mod:`scipy.signal` (0.35 s
  of CPU, as much as a whole HT-740 run). Subtracting the first value starts the filter in its
  steady state (the weighting has no DC gain: a constant acceleration gives no weighted output).
* **Filtered jerk** - the jerk as an accelerometer measurement gives it: the acceleration,
  resampled like the weighting's, through a 2nd-order Butterworth low-pass at
  :data:`JERK_FILTER_HZ` (10 Hz; exactly, in the frequency domain, like the weighting) and
  differentiated by central differences on the 1 kHz grid. Measured shift jerk is the derivative of a low-pass
  filtered acceleration (SAE 2016-01-1681: a Butterworth low-pass on the vehicle's acceleration
  before differentiating); 10 Hz passes the driveline's shuffle modes (2-8 Hz) and the shift's
  own transient and removes what a model's instantaneous lock puts above them (the exact jerk,
  unfiltered, is kept beside it: ``jerk_max``).
* **VDV** - ``(integral of a_w^4 dt)^(1/4)`` over a window (ISO 2631-1 6.3.2), trapezoidal on
  the uniform grid.
"""
from __future__ import annotations

import math

import numpy as np

__all__ = [
    "WEIGHTINGS",
    "FS_WEIGHTING",
    "check_weighting",
    "transfer_function",
    "weighting_response",
    "weighted",
    "vdv",
    "unique_samples",
    "jerk",
    "filtered_jerk",
    "JERK_FILTER_HZ",
    "settling_time",
]

FS_WEIGHTING = 1000.0  # Hz, uniform resampling rate of the weighting filter
PAD_WEIGHTING = 10.0  # s of zero padding after the signal (the weighting filter's memory)
JERK_FILTER_HZ = 10.0  # Hz, cut-off of the low-pass before differentiating (filtered jerk)
MIN_DT_FRACTION = 0.05  # of the median sample spacing: closer samples are skipped when differencing

#: ISO 2631-1 Annex A (Table A.1) parameters: frequencies [Hz], quality factors [-]; ``None``
#: where a weighting has no such section. Band limiting f1 = 0.4 Hz, f2 = 100 Hz, Q1 = Q2 = 1/sqrt(2).
WEIGHTINGS = {
    "Wk": {"f1": 0.4, "f2": 100.0, "f3": 12.5, "f4": 12.5, "Q4": 0.63, "f5": 2.37, "Q5": 0.91, "f6": 3.35, "Q6": 0.91},
    "Wd": {"f1": 0.4, "f2": 100.0, "f3": 2.0, "f4": 2.0, "Q4": 0.63, "f5": None, "Q5": None, "f6": None, "Q6": None},
}
_Q_BAND = 1.0 / math.sqrt(2.0)


def check_weighting(weighting: str) -> str:
    """``weighting`` if it is one of :data:`WEIGHTINGS` or ``"none"``, else ValueError."""
    if weighting != "none" and weighting not in WEIGHTINGS:
        raise ValueError(f"unknown frequency weighting {weighting!r} (known: {', '.join(WEIGHTINGS)}, none)")
    return weighting


def _check(weighting: str) -> dict:
    if check_weighting(weighting) == "none":
        raise ValueError("the weighting 'none' has no filter")
    return WEIGHTINGS[weighting]


def _sections(weighting: str) -> list[tuple[list[float], list[float]]]:
    """Analog second-order sections ``(b, a)`` (descending powers of s) of ``weighting``."""
    p = _check(weighting)
    w1, w2, w3, w4 = (2 * math.pi * p[k] for k in ("f1", "f2", "f3", "f4"))
    secs = [([1.0, 0.0, 0.0], [1.0, w1 / _Q_BAND, w1 ** 2]),  # high-pass (band limit)
            ([0.0, 0.0, w2 ** 2], [1.0, w2 / _Q_BAND, w2 ** 2]),  # low-pass (band limit)
            ([0.0, 1.0 / w3, 1.0], [1.0 / w4 ** 2, 1.0 / (p["Q4"] * w4), 1.0])]  # a-v transition
    if p["f5"] is not None:
        w5, w6 = 2 * math.pi * p["f5"], 2 * math.pi * p["f6"]
        secs.append(([1.0, w5 / p["Q5"], w5 ** 2], [1.0, w6 / p["Q6"], w6 ** 2]))  # upward step
    return secs


def transfer_function(f, weighting: str) -> np.ndarray:
    """The analog weighting ``weighting`` ("Wk", "Wd"): complex ``H(j 2 pi f)`` at the
    frequencies ``f`` [Hz]."""
    s = 2j * math.pi * np.asarray(f, dtype=float)
    h = np.ones_like(s)
    for b, a in _sections(weighting):
        h = h * np.polyval(b, s) / np.polyval(a, s)
    return h


def weighting_response(f, weighting: str) -> np.ndarray:
    """Modulus of the weighting ``weighting`` ("Wk", "Wd") at the frequencies ``f`` [Hz]: the
    weighting factors of ISO 2631-1 Table 3."""
    return np.abs(transfer_function(f, weighting))


def unique_samples(t: np.ndarray, y: np.ndarray, min_dt: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """``(t, y)`` with one sample per time: at a repeated time stamp (a mode change) the value
    after the event; a sample less than ``min_dt`` after the previous one kept is skipped (the
    last sample is always kept, replacing a kept one closer than ``min_dt`` before it)."""
    t = np.asarray(t, dtype=float)
    y = np.asarray(y, dtype=float)
    if len(t) == 0:
        return t, y
    last = np.ones(len(t), dtype=bool)
    last[:-1] = t[1:] > t[:-1]  # the last sample of each time stamp
    t, y = t[last], y[last]
    if min_dt <= 0 or len(t) < 3:
        return t, y
    keep = [0]
    for k in range(1, len(t)):
        if t[k] - t[keep[-1]] >= min_dt:
            keep.append(k)
    if keep[-1] != len(t) - 1:
        if len(keep) > 1 and t[-1] - t[keep[-1]] < min_dt:
            keep[-1] = len(t) - 1
        else:
            keep.append(len(t) - 1)
    return t[keep], y[keep]


def jerk(t: np.ndarray, a: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Jerk [m/s^3] of the acceleration samples ``a`` [m/s^2] over ``t`` [s]: the secant slope of
    each interval between unique samples (see the module doc), at the interval's mid-time.
    Returns ``(t_mid, jerk)`` (empty with fewer than two distinct times)."""
    tu, au = unique_samples(t, a)
    if len(tu) < 2:
        return np.zeros(0), np.zeros(0)
    tu, au = unique_samples(tu, au, MIN_DT_FRACTION * float(np.median(np.diff(tu))))
    dt = np.diff(tu)
    return 0.5 * (tu[1:] + tu[:-1]), np.diff(au) / dt


def weighted(t: np.ndarray, a: np.ndarray, weighting: str = "Wd", fs: float = FS_WEIGHTING
             ) -> tuple[np.ndarray, np.ndarray]:
    """The acceleration ``a`` [m/s^2] over ``t`` [s] resampled on a uniform grid at ``fs`` [Hz]
    and frequency-weighted (``"Wk"``, ``"Wd"``; ``"none"``: only resampled), the filter in its
    steady state at the first sample (see the module doc). Returns ``(t_uniform, a_weighted)``."""
    check_weighting(weighting)
    tu, au = unique_samples(t, a)
    if len(tu) < 2:
        return tu, au
    n = int(math.floor((tu[-1] - tu[0]) * fs)) + 1
    grid = tu[0] + np.arange(n) / fs
    x = np.interp(grid, tu, au)
    if weighting == "none":
        return grid, x
    size = 1 << int(math.ceil(math.log2(n + PAD_WEIGHTING * fs)))
    spectrum = np.fft.rfft(x - x[0], size) * transfer_function(np.fft.rfftfreq(size, 1.0 / fs), weighting)
    return grid, np.fft.irfft(spectrum, size)[:n]


def filtered_jerk(t: np.ndarray, a: np.ndarray, cutoff: float = JERK_FILTER_HZ, fs: float = FS_WEIGHTING
                  ) -> tuple[np.ndarray, np.ndarray]:
    """The jerk [m/s^3] of the acceleration ``a`` [m/s^2] over ``t`` [s] low-pass filtered (2nd-order
    Butterworth at ``cutoff`` [Hz], causal, at rest in its steady state at the first sample) on a
    uniform grid at ``fs`` [Hz]; see the module doc. Returns ``(t_uniform, jerk)``."""
    tu, au = unique_samples(t, a)
    if len(tu) < 2:
        return np.zeros(0), np.zeros(0)
    n = int(math.floor((tu[-1] - tu[0]) * fs)) + 1
    grid = tu[0] + np.arange(n) / fs
    x = np.interp(grid, tu, au)
    size = 1 << int(math.ceil(math.log2(n + PAD_WEIGHTING * fs)))
    s = 2j * math.pi * np.fft.rfftfreq(size, 1.0 / fs)
    wc = 2.0 * math.pi * cutoff
    h = wc ** 2 / (s ** 2 + math.sqrt(2.0) * wc * s + wc ** 2)
    filtered = np.fft.irfft(np.fft.rfft(x - x[0], size) * h, size)[:n]
    if n < 2:
        return grid, np.zeros(n)
    return grid, np.gradient(filtered, 1.0 / fs)  # central differences: the filter left no noise to amplify


def vdv(t: np.ndarray, a: np.ndarray, t0: float, t1: float) -> float:
    """Vibration dose value [m/s^1.75 for a in m/s^2]: ``(integral of a^4 dt over [t0, t1])^(1/4)``,
    trapezoidal over the samples in the window (``a`` already weighted, see :func:`weighted`)."""
    from .samples import integrate

    if t1 <= t0 or len(t) < 2:
        return 0.0
    return max(integrate(t, np.asarray(a, dtype=float) ** 4, t0, t1), 0.0) ** 0.25


def settling_time(t: np.ndarray, y: np.ndarray, t0: float, t1: float, final: float, band: float) -> float | None:
    """Time after ``t0`` [s] from which ``y`` stays within ``final +- band`` up to ``t1`` (the last
    exit from the band, located by linear interpolation between samples); 0 if it never leaves
    the band in ``[t0, t1]``; None without samples in the window."""
    from .samples import window

    idx = window(t, t0, t1)
    if len(idx) == 0:
        return None
    out = np.abs(y[idx] - final) - band
    above = np.nonzero(out > 0)[0]
    if len(above) == 0:
        return 0.0
    k = int(above[-1])
    if k == len(idx) - 1:
        return float(t[idx[k]]) - t0
    ta, tb = float(t[idx[k]]), float(t[idx[k + 1]])
    oa, ob = float(out[k]), float(out[k + 1])
    tx = ta + (tb - ta) * oa / (oa - ob) if oa != ob else tb
    return tx - t0
