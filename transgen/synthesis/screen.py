"""The cell screen of ``transgen synthesize topology``: which concepts can meet the target ratios
with distinct gears somewhere in the ring/sun box, decided exactly on grid cells before any fit.

A gear's ratio is ``P(k)/Q(k)`` with ``P`` and ``Q`` cofactors of the constraint matrix, in which
each ``k_p`` appears in one row only, so both are *multi-affine*. On a cell (a sub-box) ``Q``
keeps one sign iff it has that sign at all ``2^N`` corners (a multi-affine function takes its
extremes at the corners); then the ratio is linear-fractional, hence monotone, in each ``k_p``
and its range over the cell is the hull of its corner values (else it is unbounded).

In a cell, gear ``c`` *covers* target ``g`` when its range meets ``[t_g (1 - tol), t_g (1 + tol)]``.
A concept that meets every target at some ``k`` of the cell has a *distinct assignment* there:
each target covered by its own gear. With the targets sorted, both ends of their tolerance
intervals increase, so the targets a gear covers are a contiguous run: the bipartite graph is
convex and Glover's greedy (targets in order, each to the free covering gear whose run ends
first) finds a complete matching iff one exists (Hall's condition holds). A cell without one is
dropped; a concept without any cell is dropped. Cells that pass are split in ``2^N`` halves and
screened again (``levels``): every point of a cell is in one of its children, so the screen stays
exact, and tighter ranges drop more.
"""
from __future__ import annotations

import itertools

import numpy as np

from .topology import TrainKinematics, sample_speeds

__all__ = ["distinct_cover", "cover_runs", "cell_screen", "vertex_starts", "VertexSpeeds", "SLACK"]

SLACK = 1e-9
"""Relative widening of the target intervals: rounding in the corner values never drops a cell."""


def distinct_cover(a: np.ndarray, b: np.ndarray, n_targets: int) -> np.ndarray:
    """Whether targets ``0 .. n_targets - 1`` can each get their own gear, per row: gear ``s`` of
    row ``m`` covers the targets ``a[m, s] .. b[m, s]`` (none when ``a > b``). Glover's greedy,
    exact for such interval (convex) bipartite graphs."""
    m = a.shape[0]
    rows = np.arange(m)
    used = np.zeros(a.shape, dtype=bool)
    ok = np.ones(m, dtype=bool)
    big = int(b.max(initial=0)) + 1
    for g in range(n_targets):
        avail = ~used & (a <= g) & (b >= g)
        j = np.where(avail, b, big).argmin(axis=1)
        has = avail[rows, j]
        ok &= has
        used[rows, j] |= has
    return ok


def cover_runs(lo: np.ndarray, hi: np.ndarray, targets: np.ndarray, tolerance: float) -> tuple[np.ndarray, np.ndarray]:
    """``(a, b)``: the run of sorted targets (indices into ``np.sort(targets)``) whose tolerance
    intervals meet ``[lo, hi]`` (any shape; NaN ranges cover nothing: ``a > b``)."""
    t = np.sort(targets)
    t0 = np.minimum(t * (1 - tolerance), t * (1 + tolerance))
    t1 = np.maximum(t * (1 - tolerance), t * (1 + tolerance))
    t0 = t0 - SLACK * np.abs(t)
    t1 = t1 + SLACK * np.abs(t)
    bad = np.isnan(lo) | np.isnan(hi)
    a = np.searchsorted(t1, np.where(bad, np.inf, lo), side="left")
    b = np.searchsorted(t0, np.where(bad, -np.inf, hi), side="right") - 1
    return a.astype(np.int16), b.astype(np.int16)


def _ranges(s_in: np.ndarray, s_out: np.ndarray, norm: np.ndarray, corners: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Ratio ranges (U x B) over cells from the input and output speeds (U x P) at the points,
    ``corners`` (B x 2^N) the point indices of each cell's corners; unbounded where the output
    speed changes sign or vanishes at a corner."""
    qs = np.where(np.abs(s_out) > 1e-12 * np.maximum(norm, 1e-300), np.sign(s_out), 0.0)
    qc = qs[:, corners]
    pole = ~((qc > 0).all(axis=2) | (qc < 0).all(axis=2))
    with np.errstate(all="ignore"):
        r = np.where(qs != 0, s_in / np.where(qs != 0, s_out, 1.0), 0.0)
    rc = r[:, corners]
    lo = np.where(pole, -np.inf, rc.min(axis=2))
    hi = np.where(pole, np.inf, rc.max(axis=2))
    return lo, hi


class VertexSpeeds:
    """Gear speeds of a train's combinations at the vertices of its fixed grid, computed once
    per train and shared by the screen's first level and the start points (``combos`` sorted
    rows of ``kin.combos``; ``speeds`` combos x V x L)."""

    def __init__(self, kin: TrainKinematics, combos: np.ndarray, vertices: np.ndarray):
        self.combos = combos
        self.vertices = vertices
        self.speeds = sample_speeds(kin, combos, vertices)
        self.norms = np.linalg.norm(self.speeds, axis=2)

    def of(self, combos: np.ndarray) -> np.ndarray:
        """Speeds (len(combos) x V x L) of the rows ``combos`` (each among ``self.combos``)."""
        return self.speeds[np.searchsorted(self.combos, combos)]


def cell_screen(kin: TrainKinematics, i: int, o: int, ids: np.ndarray, valid: np.ndarray, targets: np.ndarray,
                tolerance: float, k_low: float, k_high: float, cells: int, levels: int,
                first: VertexSpeeds | None = None) -> np.ndarray:
    """Which placements (rows: ``ids`` their combinations, ``valid`` which of them are gears with
    input ``i`` and output ``o`` turning at the generic point) keep a cell with a distinct
    assignment after ``levels`` subdivisions of a grid of ``cells`` per axis. Exact (see the
    module docstring): no placement that meets the targets anywhere in the box is dropped.
    ``first``: the speeds at the grid's vertices (the first level's corners), when computed."""
    n = kin.train.sets
    g = len(targets)
    offsets = np.array(list(itertools.product((0, 1), repeat=n)), dtype=np.int64)
    # active (row, cell) pairs; cells by their lower corner on the lattice of the current level
    lower = np.array(list(itertools.product(range(cells), repeat=n)), dtype=np.int64)
    pair_row = np.repeat(np.arange(len(ids)), len(lower))
    pair_cell = np.tile(lower, (len(ids), 1))
    per_axis = cells
    for level in range(levels + 1):
        if not len(pair_row):
            break
        if level:
            pair_row = np.repeat(pair_row, len(offsets))
            pair_cell = (2 * pair_cell[:, None, :] + offsets[None]).reshape(-1, n)
            per_axis *= 2
        base = per_axis + 1
        cell_code = pair_cell @ (base ** np.arange(n - 1, -1, -1))
        ucells, cell_inv = np.unique(cell_code, return_inverse=True)
        ulower = np.stack(np.unravel_index(ucells, (base,) * n), axis=1)
        corner_code = (ulower[:, None, :] + offsets[None]) @ (base ** np.arange(n - 1, -1, -1))
        upoints, corner_inv = np.unique(corner_code, return_inverse=True)
        corner_inv = corner_inv.reshape(len(ucells), len(offsets))
        k = k_low + np.stack(np.unravel_index(upoints, (base,) * n), axis=1) * ((k_high - k_low) / per_axis)
        active_rows = np.unique(pair_row)
        ucombos, combo_inv = np.unique(ids[active_rows], return_inverse=True)
        if level == 0 and first is not None and len(upoints) == len(first.vertices):
            # every vertex is a corner: the lattice is the fixed grid
            rows = np.searchsorted(first.combos, ucombos)
            s_in, s_out, norm = first.speeds[rows, :, i], first.speeds[rows, :, o], first.norms[rows]
        else:
            s = sample_speeds(kin, ucombos, k)  # U x P x L
            s_in, s_out, norm = s[..., i], s[..., o], np.linalg.norm(s, axis=2)
        lo, hi = _ranges(s_in, s_out, norm, corner_inv)
        a, b = cover_runs(lo, hi, targets, tolerance)  # U x B
        row_pos = np.searchsorted(active_rows, pair_row)
        cinv = combo_inv.reshape(len(active_rows), -1)[row_pos]  # pairs x S
        pa, pb = a[cinv, cell_inv[:, None]], b[cinv, cell_inv[:, None]]
        v = valid[pair_row]
        pa = np.where(v, pa, g)
        pb = np.where(v, pb, -1)
        ok = distinct_cover(pa, pb, g)
        pair_row, pair_cell = pair_row[ok], pair_cell[ok]
    keep = np.zeros(len(ids), dtype=bool)
    keep[pair_row] = True
    return keep


def vertex_starts(kin: TrainKinematics, i: int, o: int, ids: np.ndarray, targets: np.ndarray,
                  first: VertexSpeeds) -> np.ndarray:
    """The start of each placement's refinement: the vertex of the fixed grid (``first``)
    with the smallest relaxed error (every target to its nearest gear ratio of the right sign).
    Independent of the screen, so the fit of a placement does not depend on what was pruned."""
    ucombos, inv = np.unique(ids, return_inverse=True)
    inv = inv.reshape(ids.shape)
    s = first.of(ucombos)
    vertices = first.vertices
    with np.errstate(all="ignore"):
        r = s[..., i] / s[..., o]  # U x V
        worst = np.zeros((len(ids), len(vertices)))
        for t in targets:
            q = r / t
            e = np.where(q > 0, np.abs(np.log(np.where(q > 0, q, 1.0))), np.inf)
            e = np.where(np.isnan(e), np.inf, e)
            worst = np.maximum(worst, e[inv].min(axis=1))
    return vertices[np.argmin(worst, axis=1)]
