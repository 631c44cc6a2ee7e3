"""Standard drive cycles: the speed traces shipped as data and the WLTP tolerance rule (the
``scenario new --maneuver cycle`` text is :func:`~.maneuver.cycle_scenario`'s).

Bundled traces (``sim/data/cycles/*.csv``, ``time_s,speed_kmh`` at 1 Hz, each with a header
naming its regulation and where the numbers were extracted from)::

    ``wltc_class3b``  WLTC class 3b, 0-1800 s, 23.27 km (UN GTR No. 15, UN ECE R154);
    ``ftp75``         FTP-75, 0-1874 s, 17.77 km: the UDDS (40 CFR Part 86 Appendix I) 0-1369 s and its
                      first 505 s again (hot start), the 10 min soak between them left out.

A trace is piecewise linear between its points (the regulations give 1 Hz values; the driver
follows the line between them). :func:`tracking` applies the WLTP speed-trace tolerance (UN GTR
No. 15 Annex 6 / R154: +-2 km/h, +-1 s): at each time the actual speed must lie between the
lowest trace speed within +-1 s minus 2 km/h and the highest within +-1 s plus 2 km/h (the
band the trace sweeps when shifted by up to 1 s either way, widened by 2 km/h).
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from transgen.errors import ScenarioError

__all__ = ["SpeedTrace", "load_trace", "bundled_cycles", "tracking", "Tracking", "TOLERANCE_KMH",
           "TOLERANCE_S", "CYCLE_DIR", "MAX_TRACE_POINTS", "DEFAULT_CYCLE", "band"]

CYCLE_DIR = Path(__file__).resolve().parent.parent / "data" / "cycles"
TOLERANCE_KMH = 2.0
"""WLTP's speed tolerance [km/h]."""
TOLERANCE_S = 1.0
"""WLTP's time tolerance [s]."""
MAX_TRACE_POINTS = 100_000
"""Most points a speed trace may have."""
DEFAULT_CYCLE = "wltc_class3b"


@dataclass(frozen=True)
class SpeedTrace:
    """A speed trace: ``times`` [s] increasing, ``speeds`` [m/s] >= 0; ``name`` and ``source`` (its
    header comment)."""

    name: str
    times: tuple[float, ...]
    speeds: tuple[float, ...]
    source: str = ""

    def speed(self, t):
        """The trace speed [m/s] at ``t`` (a number or an array), linear between the points,
        constant beyond the ends."""
        return np.interp(t, self.times, self.speeds)

    def slope(self, t: float) -> float:
        """The trace's acceleration [m/s^2] at ``t``: the slope of the piece it lies in (0 outside)."""
        k = int(np.searchsorted(self.times, t, side="right")) - 1
        if k < 0 or k + 1 >= len(self.times):
            return 0.0
        return (self.speeds[k + 1] - self.speeds[k]) / (self.times[k + 1] - self.times[k])

    @property
    def duration(self) -> float:
        return self.times[-1] - self.times[0]

    @property
    def distance(self) -> float:
        """Distance [m] of the trace (its integral)."""
        return float(np.trapezoid(self.speeds, self.times))


def bundled_cycles() -> dict[str, Path]:
    """The bundled traces by name."""
    return {p.stem: p for p in sorted(CYCLE_DIR.glob("*.csv"))}


def load_trace(ref: str, base: Path | None = None) -> SpeedTrace:
    """The trace ``ref``: a bundled name or a CSV file (relative to ``base``) of ``time_s,speed_kmh``
    rows, ``#`` comment lines and one header row. Errors name the file, line and column."""
    bundled = bundled_cycles()
    path = bundled.get(ref)
    if path is None:
        path = Path(ref) if base is None or Path(ref).is_absolute() else base / ref
        if not path.is_file():
            raise ScenarioError(f"{ref}:1:1: error: no such speed trace (a CSV file of time_s,speed_kmh, or a bundled "
                                f"cycle: {', '.join(bundled)})")
    try:
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise ScenarioError(f"{path}:1:1: error: cannot read the speed trace: {exc}") from None
    comments, times, speeds = [], [], []
    header = False
    for n, line in enumerate(text.splitlines(), 1):
        s = line.strip()
        if not s:
            continue
        if s.startswith("#"):
            comments.append(s.lstrip("# "))
            continue
        cells = [c.strip() for c in s.split(",")]
        if not header and cells[:2] == ["time_s", "speed_kmh"]:
            header = True
            continue
        if len(cells) != 2:
            raise ScenarioError(f"{path}:{n}:1: error: a row of a speed trace is 'time_s,speed_kmh', not {s[:60]!r}")
        values = []
        for c, cell in enumerate(cells):
            try:
                v = float(cell)
            except ValueError:
                v = math.nan
            if not math.isfinite(v) or (c == 1 and v < 0):
                col = line.index(cell) + 1 if cell in line else 1
                raise ScenarioError(f"{path}:{n}:{col}: error: {cell[:30]!r} is not a finite "
                                    + ("time [s]" if c == 0 else "speed >= 0 [km/h]"))
            values.append(v)
        if times and values[0] <= times[-1]:
            raise ScenarioError(f"{path}:{n}:1: error: the times of a speed trace must increase ({values[0]:g} after "
                                f"{times[-1]:g})")
        times.append(values[0])
        speeds.append(values[1] / 3.6)
        if len(times) > MAX_TRACE_POINTS:
            raise ScenarioError(f"{path}:{n}:1: error: a speed trace has at most {MAX_TRACE_POINTS} points")
    if len(times) < 2:
        raise ScenarioError(f"{path}:1:1: error: a speed trace needs at least two rows of time_s,speed_kmh")
    return SpeedTrace(path.stem, tuple(times), tuple(speeds), " ".join(comments))


@dataclass(frozen=True)
class Tracking:
    """How a run followed a trace by the WLTP rule: ``inside`` fraction of the samples in the band,
    ``outside_time`` [s] outside it, ``violations`` (intervals outside), ``worst`` [km/h] the
    largest distance outside the band (0 inside), ``rms_error`` / ``max_error`` [km/h] of the
    speed against the trace at the same time."""

    t0: float
    t1: float
    samples: int
    inside: float
    outside_time: float
    violations: int
    worst: float
    worst_time: float | None
    rms_error: float
    max_error: float

    def to_dict(self) -> dict:
        from dataclasses import asdict

        return asdict(self)


def band(trace: SpeedTrace, t: np.ndarray, tol_v: float = TOLERANCE_KMH / 3.6,
         tol_t: float = TOLERANCE_S) -> tuple[np.ndarray, np.ndarray]:
    """The lower and upper limits [m/s] of the tolerance band at the times ``t`` (module docstring)."""
    t = np.asarray(t, dtype=float)
    knots_t, knots_v = np.asarray(trace.times), np.asarray(trace.speeds)
    lo = np.minimum(trace.speed(t - tol_t), trace.speed(t + tol_t))
    hi = np.maximum(trace.speed(t - tol_t), trace.speed(t + tol_t))
    first = np.searchsorted(knots_t, t - tol_t, side="left")
    last = np.searchsorted(knots_t, t + tol_t, side="right")
    for j in range(int(np.max(last - first, initial=0))):  # the trace's corners inside the window
        k = first + j
        ok = k < last
        kk = np.minimum(k, len(knots_t) - 1)
        lo = np.where(ok, np.minimum(lo, knots_v[kk]), lo)
        hi = np.where(ok, np.maximum(hi, knots_v[kk]), hi)
    return lo - tol_v, hi + tol_v


def tracking(trace: SpeedTrace, t: np.ndarray, v: np.ndarray) -> Tracking:
    """:class:`Tracking` of the vehicle speed ``v`` [m/s] at the times ``t`` [s] against ``trace``."""
    t, v = np.asarray(t, dtype=float), np.asarray(v, dtype=float)
    lo, hi = band(trace, t)
    out = np.maximum(lo - v, v - hi)  # > 0 outside the band [m/s]
    bad = out > 1e-9
    dt = np.diff(t, append=t[-1]) if len(t) else t
    starts = int(np.count_nonzero(bad[1:] & ~bad[:-1]) + (1 if len(bad) and bad[0] else 0))
    err = (v - trace.speed(t)) * 3.6
    k = int(np.argmax(out)) if len(out) else 0
    return Tracking(float(t[0]), float(t[-1]), len(t), float(np.mean(~bad)) if len(t) else 1.0,
                    float(np.sum(dt[bad])), starts, float(max(0.0, out[k]) * 3.6) if len(out) else 0.0,
                    float(t[k]) if len(out) and bad[k] else None,
                    float(np.sqrt(np.mean(err ** 2))) if len(t) else 0.0,
                    float(np.max(np.abs(err))) if len(t) else 0.0)
