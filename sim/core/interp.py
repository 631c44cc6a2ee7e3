"""Fast scalar table look-up for the simulator's right-hand side: the one home of it.

``numpy.interp`` costs microseconds of overhead per scalar call; these plain-Python versions
(``bisect`` on tuples or lists) are several times faster for the scalar look-ups done at every
right-hand-side evaluation. All clamp outside the table (constant extrapolation). All are
:func:`~.jit.compilable`: the compiled right-hand side (:mod:`.kernel`) calls the same functions
on float64 arrays.

* :func:`interp1` - piecewise-linear ``y(x)`` (signals, torque-converter curves);
* :func:`interp1_pair` - two tables over one grid at one point, one cell search (a converter's
  capacity and torque-ratio curves);
* :func:`interp_like_numpy` - the same with ``numpy.interp``'s arithmetic, bit for bit (where a
  result must not change when a ``numpy.interp`` call is replaced, e.g. the engine's fuel curve);
* :func:`locate` - the cell and weight of a value in a grid, and whether it was outside: the
  one grid search of every 2-D look-up;
* :func:`bilinear` - the value in a cell of ``z[i_x][i_y]`` (the compressor and turbine causal
  tables of :mod:`transgen.sim.engine.preprocessor`, which use ``locate``'s out-of-grid flag to
  warn);
* :func:`interp2` - the engine torque map ``table[i_y][i_x]``.
"""
from __future__ import annotations

from bisect import bisect_right

from .jit import compilable

__all__ = ["interp1", "interp1_pair", "interp_like_numpy", "interp2", "locate", "bilinear"]


@compilable
def interp1(x: float, xs: tuple, ys: tuple) -> float:
    """Piecewise-linear ``y(x)`` through the points ``(xs, ys)``; ``xs`` increasing."""
    if x <= xs[0]:
        return ys[0]
    if x >= xs[-1]:
        return ys[-1]
    i = bisect_right(xs, x) - 1
    x0 = xs[i]
    return ys[i] + (ys[i + 1] - ys[i]) * (x - x0) / (xs[i + 1] - x0)


@compilable
def interp1_pair(x: float, xs: tuple, ys: tuple, zs: tuple) -> tuple[float, float]:
    """``(interp1(x, xs, ys), interp1(x, xs, zs))`` with one search of the cell (the same
    arithmetic: the same numbers, bit for bit)."""
    if x <= xs[0]:
        return ys[0], zs[0]
    if x >= xs[-1]:
        return ys[-1], zs[-1]
    i = bisect_right(xs, x) - 1
    x0 = xs[i]
    dx, span = x - x0, xs[i + 1] - x0
    return ys[i] + (ys[i + 1] - ys[i]) * dx / span, zs[i] + (zs[i + 1] - zs[i]) * dx / span


@compilable
def interp_like_numpy(x: float, xs, ys) -> float:
    """``float(numpy.interp(x, xs, ys))`` for one value, bit for bit (numpy's slope form
    ``slope*(x - xs[i]) + ys[i]``, an end value at or beyond the ends and at a grid point, NaN for
    NaN) without its array conversions; ``xs`` increasing, at least two points."""
    if x != x:
        return x
    if x < xs[0]:
        return float(ys[0])
    if x >= xs[-1]:
        return float(ys[-1])
    i = bisect_right(xs, x) - 1
    if xs[i] == x:
        return float(ys[i])
    slope = (ys[i + 1] - ys[i]) / (xs[i + 1] - xs[i])
    y = slope * (x - xs[i]) + ys[i]
    if y != y:  # numpy's second try from the other end of the cell
        y = slope * (x - xs[i + 1]) + ys[i + 1]
        if y != y and ys[i] == ys[i + 1]:
            y = ys[i]
    return float(y)


@compilable
def locate(grid, v: float) -> tuple[int, float, bool]:
    """Cell index ``i`` (``grid[i] <= v <= grid[i+1]``), weight ``(v - grid[i])/(grid[i+1] -
    grid[i])`` in [0, 1], and whether ``v`` was outside the grid (then clamped to its edge).

    ``grid`` is strictly increasing with at least two points; a NaN ``v`` gives a NaN weight.
    """
    if v <= grid[0]:
        return 0, 0.0, v < grid[0]
    if v >= grid[-1]:
        return len(grid) - 2, 1.0, v > grid[-1]
    i = min(bisect_right(grid, v) - 1, len(grid) - 2)  # the min only acts on NaN
    return i, (v - grid[i]) / (grid[i + 1] - grid[i]), False


@compilable
def bilinear(z, i: int, wx: float, j: int, wy: float) -> float:
    """Bilinear value in the cell ``(i, j)`` of ``z[i_x][i_y]`` at the weights from :func:`locate`."""
    r0, r1 = z[i], z[i + 1]
    return ((1.0 - wx) * ((1.0 - wy) * r0[j] + wy * r0[j + 1])
            + wx * ((1.0 - wy) * r1[j] + wy * r1[j + 1]))


@compilable
def interp2(x: float, y: float, xs: tuple, ys: tuple, table: tuple) -> float:
    """Bilinear ``z(x, y)`` in ``table[i_y][i_x]``, clamped at the edges; a single row
    (``len(ys) == 1``) is linear in ``x``.

    The cell is found by :func:`locate`; the value is interpolated along ``x`` on the two rows,
    then along ``y``.  That is :func:`bilinear`'s value up to rounding; the two orders of the
    arithmetic are kept so that the simulator's results stay bit-identical.
    """
    i, fx, _ = locate(xs, x)
    if len(ys) == 1:
        row = table[0]
        return row[i] + (row[i + 1] - row[i]) * fx
    j, fy, _ = locate(ys, y)
    r0, r1 = table[j], table[j + 1]
    lo = r0[i] + (r0[i + 1] - r0[i]) * fx
    hi = r1[i] + (r1[i + 1] - r1[i]) * fx
    return lo + (hi - lo) * fy
