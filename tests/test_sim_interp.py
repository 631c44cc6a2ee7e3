"""The one scalar table look-up (transgen.sim.core.interp): cell search, clamping, bilinear values."""
import math
import random
from bisect import bisect_right

import pytest

from transgen.sim.core.interp import bilinear, interp1, interp1_pair, interp2, interp_like_numpy, locate

GRID = (0.0, 1.0, 2.5, 4.0)


@pytest.mark.parametrize("v, cell, weight, outside", [
    (-1.0, 0, 0.0, True), (0.0, 0, 0.0, False), (0.5, 0, 0.5, False), (1.0, 1, 0.0, False),
    (3.25, 2, 0.5, False), (4.0, 2, 1.0, False), (9.0, 2, 1.0, True), (math.inf, 2, 1.0, True),
])
def test_locate_finds_the_cell_and_clamps(v, cell, weight, outside):
    assert locate(GRID, v) == (cell, weight, outside)


def test_locate_of_nan_gives_a_nan_weight_not_an_index_error():
    i, w, _ = locate(GRID, math.nan)
    assert i == len(GRID) - 2 and math.isnan(w)


def test_bilinear_is_exact_at_the_corners_and_linear_along_edges():
    z = [[1.0, 2.0], [3.0, 5.0]]  # z[i_x][i_y]
    assert [bilinear(z, 0, wx, 0, wy) for wx, wy in ((0, 0), (0, 1), (1, 0), (1, 1))] == [1.0, 2.0, 3.0, 5.0]
    assert bilinear(z, 0, 0.5, 0, 0.5) == pytest.approx(2.75)
    assert bilinear(z, 0, 0.25, 0, 0.0) == pytest.approx(1.5)


def _interp2_reference(x, y, xs, ys, table):
    """The engine-map look-up as it was before the grid search was shared (bit for bit)."""
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


def test_interp2_is_bit_identical_to_the_former_engine_map_look_up():
    rnd = random.Random(7)
    xs = (60.0, 100.0, 150.0, 210.0, 250.0)
    ys = (0.0, 0.3, 0.7, 1.0)
    table = tuple(tuple(rnd.uniform(-200.0, 1800.0) for _ in xs) for _ in ys)
    points = [(rnd.uniform(0.0, 300.0), rnd.uniform(-0.2, 1.2)) for _ in range(2000)]
    points += [(x, y) for x in xs for y in ys]
    for x, y in points:
        assert interp2(x, y, xs, ys, table) == _interp2_reference(x, y, xs, ys, table)
        assert interp2(x, y, xs, ys[:1], table[:1]) == _interp2_reference(x, y, xs, ys[:1], table[:1])


def test_interp1_clamps_and_interpolates():
    assert interp1(-5.0, GRID, (1.0, 2.0, 3.0, 4.0)) == 1.0
    assert interp1(5.0, GRID, (1.0, 2.0, 3.0, 4.0)) == 4.0
    assert interp1(1.75, GRID, (1.0, 2.0, 3.0, 4.0)) == pytest.approx(2.5)


def test_interp_like_numpy_is_numpy_interp_bit_for_bit():
    import numpy as np

    rng = random.Random(7)
    for _ in range(200):
        xs = tuple(sorted({rng.uniform(-5, 5) for _ in range(rng.randint(2, 9))}))
        if len(xs) < 2:
            continue
        ys = tuple(rng.uniform(-1e3, 1e3) for _ in xs)
        probes = [rng.uniform(-7, 7) for _ in range(30)] + list(xs) + [math.inf, -math.inf, math.nan]
        for x in probes:
            got, want = interp_like_numpy(x, xs, ys), float(np.interp(x, xs, ys))
            assert got == want or (math.isnan(got) and math.isnan(want)), (x, xs, ys)


def test_interp1_pair_is_two_interp1_bit_for_bit():
    rng = random.Random(11)
    for _ in range(100):
        xs = tuple(sorted({rng.uniform(0, 1) for _ in range(rng.randint(2, 12))}))
        if len(xs) < 2:
            continue
        ys, zs = (tuple(rng.uniform(-5, 5) for _ in xs) for _ in range(2))
        for x in [rng.uniform(-0.2, 1.2) for _ in range(40)] + list(xs):
            assert interp1_pair(x, xs, ys, zs) == (interp1(x, xs, ys), interp1(x, xs, zs))
