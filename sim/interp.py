"""Fast scalar table look-up for the simulator's right-hand side.

``numpy.interp`` costs microseconds of overhead per scalar call; these plain-Python versions
(``bisect`` on tuples) are several times faster for the scalar look-ups done at every
right-hand-side evaluation. Both clamp outside the table (constant extrapolation).
"""
from __future__ import annotations

from bisect import bisect_right

__all__ = ["interp1", "interp2"]


def interp1(x: float, xs: tuple, ys: tuple) -> float:
    """Piecewise-linear ``y(x)`` through the points ``(xs, ys)``; ``xs`` increasing."""
    if x <= xs[0]:
        return ys[0]
    if x >= xs[-1]:
        return ys[-1]
    i = bisect_right(xs, x) - 1
    x0 = xs[i]
    return ys[i] + (ys[i + 1] - ys[i]) * (x - x0) / (xs[i + 1] - x0)


def interp2(x: float, y: float, xs: tuple, ys: tuple, table: tuple) -> float:
    """Bilinear ``z(x, y)`` in ``table[i_y][i_x]``, clamped at the edges."""
    x = xs[0] if x < xs[0] else (xs[-1] if x > xs[-1] else x)
    y = ys[0] if y < ys[0] else (ys[-1] if y > ys[-1] else y)
    i = min(max(bisect_right(xs, x) - 1, 0), len(xs) - 2)
    fx = (x - xs[i]) / (xs[i + 1] - xs[i])
    if len(ys) == 1:
        row = table[0]
        return row[i] + (row[i + 1] - row[i]) * fx
    j = min(max(bisect_right(ys, y) - 1, 0), len(ys) - 2)
    fy = (y - ys[j]) / (ys[j + 1] - ys[j])
    lo = table[j][i] + (table[j][i + 1] - table[j][i]) * fx
    hi = table[j + 1][i] + (table[j + 1][i + 1] - table[j + 1][i]) * fx
    return lo + (hi - lo) * fy
