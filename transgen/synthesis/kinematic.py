"""Gear ratios as functions of the planetary basic ratios ``k = Nr/Ns`` (numeric and exact).

A planetary's constraint is homogeneous in its tooth counts (thesis eq. 3.37: simple set
``Ns*w_s + Nr*w_r = (Ns + Nr)*w_c``; double-pinion set ``Nr*w_r - Ns*w_s = (Nr - Ns)*w_c``),
so every speed ratio depends on a set only through ``k = Nr/Ns``. Only planetaries can have
unknown teeth; gear pairs and stepped-pinion sets (``stepped``: the language refuses ``?`` there)
enter with their own tooth counts. With the shift elements of a
gear engaged, the constraint matrix of the links is affine in ``k``::

    A(k) = A0 + sum_p k_p * A_p

and the input/output ratio follows from ``A(k) w = 0`` with the input speed set to 1 (in a gear
with idle members, :mod:`transgen.idle`, their speeds pinned to zero: they do not move the ratio). This
module builds ``A0`` and ``A_p`` once per gear from :func:`transgen.kinematics.constraints`
(the same constraints as every other analysis) and evaluates the ratio for many ``k`` at once
(numpy, batched) or exactly for rational ``k`` (:class:`fractions.Fraction`).
"""
from __future__ import annotations

from dataclasses import dataclass
from fractions import Fraction

import numpy as np

from ..graph import bond_graph, link_nodes
from ..idle import idle_pins
from ..kinematics import _values, constraints
from ..model import Mechanism

__all__ = ["GearKinematics", "gear_kinematics"]


@dataclass(frozen=True)
class GearKinematics:
    """The ratio of one gear as a function of the unknown sets' ``k``.

    ``a0`` (rows x links) and ``ak`` (sets x rows x links) give ``A(k)``; ``rows`` are the
    independent rows used; ``depends`` the indices of the sets the ratio depends on.
    """

    gear: str
    engaged: tuple[str, ...]
    a0: np.ndarray
    ak: np.ndarray
    i_in: int
    i_out: int
    rows: tuple[int, ...]
    depends: tuple[int, ...]

    def ratios(self, k: np.ndarray) -> np.ndarray:
        """Input/output speed ratios for the rows of ``k`` (shape (N, sets)); NaN where singular."""
        k = np.atleast_2d(np.asarray(k, dtype=float))
        a = self.a0[None] + np.einsum("np,pij->nij", k, self.ak) if self.ak.shape[0] else np.repeat(
            self.a0[None], k.shape[0], axis=0)
        a = a[:, list(self.rows), :]
        keep = [j for j in range(a.shape[2]) if j != self.i_in]
        lhs, rhs = a[:, :, keep], -a[:, :, self.i_in]
        out = keep.index(self.i_out)
        with np.errstate(all="ignore"):
            hadamard = np.prod(np.linalg.norm(lhs, axis=2), axis=1)  # bound of |det|
            good = np.abs(np.linalg.det(lhs)) > 1e-12 * hadamard
            result = np.full(k.shape[0], np.nan)
            if good.any():
                w = np.linalg.solve(lhs[good], rhs[good][..., None])[..., 0]
                result[good] = 1.0 / w[:, out]
        return result

    def exact_ratio(self, k: tuple[Fraction, ...]) -> Fraction | None:
        """The ratio for rational ``k``, exactly (``None`` where not determined)."""
        n = self.a0.shape[1]
        rows = []
        for r in range(self.a0.shape[0]):
            row = [Fraction(self.a0[r, j]).limit_denominator(10**9) for j in range(n)]
            for p, kp in enumerate(k):
                for j in range(n):
                    if self.ak[p, r, j]:
                        row[j] += kp * Fraction(self.ak[p, r, j]).limit_denominator(10**9)
            rows.append(row)
        # w_in = 1: unknowns are the other speeds
        keep = [j for j in range(n) if j != self.i_in]
        aug = [[row[j] for j in keep] + [-row[self.i_in]] for row in rows]
        solution = _solve_exact(aug, len(keep))
        if solution is None:
            return None
        w_out = solution[keep.index(self.i_out)]
        return None if w_out == 0 else 1 / w_out


def _solve_exact(aug: list[list[Fraction]], n: int) -> list[Fraction] | None:
    """Solve an augmented system (rows may be redundant) exactly; ``None`` when it has no unique
    solution."""
    rows = [r[:] for r in aug]
    pivots = []
    r = 0
    for c in range(n):
        pivot = next((i for i in range(r, len(rows)) if rows[i][c] != 0), None)
        if pivot is None:
            return None
        rows[r], rows[pivot] = rows[pivot], rows[r]
        inv = 1 / rows[r][c]
        rows[r] = [x * inv for x in rows[r]]
        for i in range(len(rows)):
            if i != r and rows[i][c] != 0:
                f = rows[i][c]
                rows[i] = [x - f * y for x, y in zip(rows[i], rows[r])]
        pivots.append(c)
        r += 1
    if any(row[n] != 0 for row in rows[r:]):
        return None  # inconsistent
    return [rows[i][n] for i in range(n)]


def gear_kinematics(mech: Mechanism, engaged, name: str, unknown: tuple[str, ...],
                    k_low: np.ndarray, k_high: np.ndarray, rng: np.random.Generator) -> GearKinematics:
    """The kinematics of the gear ``name`` (elements ``engaged``) in the sets ``unknown``.

    Known sets keep their tooth counts; an unknown set gets ``Ns = 1, Nr = k``. The independent
    rows are chosen at a random ``k`` inside ``[k_low, k_high]`` (a generic point).
    """
    g = bond_graph(mech)
    links = link_nodes(g)
    index = {link: j for j, link in enumerate(links)}
    # every transformer's own parameters (gear pairs, stepped-pinion sets, known planetaries);
    # an unknown planetary Ns = 1, Nr = 0 (its k enters through ak)
    values: dict = _values(g)
    for p in mech.planetaries:
        values[f"Ns_{p.name}"] = p.n_sun if p.n_sun is not None else 1
        values[f"Nr_{p.name}"] = p.n_ring if p.n_ring is not None else 0

    def matrix(vals) -> np.ndarray:
        rows = constraints(g, tuple(engaged), vals)
        a = np.zeros((len(rows), len(links)))
        for r, c in enumerate(rows):
            for link, v in c.coeffs.items():
                a[r, index[link]] = float(v)
        return a

    a0 = matrix(values)
    ak = np.zeros((len(unknown),) + a0.shape)
    for p, set_name in enumerate(unknown):
        ak[p] = matrix({**values, f"Nr_{set_name}": 1}) - a0
    i_in, i_out = index[mech.input], index[mech.output]
    k = k_low + rng.random(len(unknown)) * (k_high - k_low)
    a = a0 + np.tensordot(k, ak, axes=1)
    # a gear with idle members (transgen.idle): their speeds, pinned to zero, leave the ratio as it
    # is and the system one degree of freedom (the idle links at the generic point: structural)
    pins = idle_pins(a, i_in, i_out)
    if pins:
        extra = np.eye(len(links))[list(pins)]
        a0 = np.vstack([a0, extra])
        ak = np.concatenate([ak, np.zeros((len(unknown), len(pins), len(links)))], axis=1)
        a = np.vstack([a, extra])
    # independent rows at a generic point, greedily
    chosen: list[int] = []
    for r in range(a.shape[0]):
        trial = a[chosen + [r]]
        if np.linalg.matrix_rank(trial, tol=1e-9 * max(1.0, np.abs(a).max())) == len(chosen) + 1:
            chosen.append(r)
    gk = GearKinematics(name, tuple(engaged), a0, ak, i_in, i_out, tuple(chosen), ())
    if len(chosen) != len(links) - 1:  # not one degree of freedom: no determined ratio
        return gk
    # which sets the ratio depends on: finite differences at a few generic points
    points = k_low + rng.random((3, len(unknown))) * (k_high - k_low)
    base = gk.ratios(points)
    depends = []
    for p in range(len(unknown)):
        shifted = points.copy()
        shifted[:, p] += 1e-4 * (k_high[p] - k_low[p] + 1)
        if np.any(np.abs(gk.ratios(shifted) - base) > 1e-9 * (1 + np.abs(base))):
            depends.append(p)
    return GearKinematics(name, tuple(engaged), a0, ak, i_in, i_out, tuple(chosen), tuple(depends))
