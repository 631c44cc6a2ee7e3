"""Basic-ratio fitting for ``transgen synthesize topology``: the sets' ``k = Nr/Ns`` and the gear
table of a concept that reproduce target ratios.

A concept's ``K``-element combinations that are gears have ratios ``r_j(k)`` (input speed /
output speed), rational functions of the sets' basic ratios. Fitting assigns each target gear
``g`` (ratio ``t_g``) to a distinct combination ``a(g)`` and chooses ``k`` within the ring/sun
bounds to minimise the log errors ``ln(r_a(g)(k) / t_g)``:

1. **Screen**: :mod:`transgen.synthesis.screen` (exact, per grid cell, distinct gears).
2. **Fit** (:func:`fit_concept`): from the best sample points, the assignment by the Hungarian
   method on the squared log errors (scipy ``linear_sum_assignment``), then bounded least
   squares (scipy ``least_squares``) in ``k``, re-assigned at the optimum and refitted once.
   The result's ``max_error`` is the largest relative error ``|r/t - 1|``.
"""
from __future__ import annotations

import itertools
from dataclasses import dataclass

import numpy as np

from .topology import Train, _null_vectors, speed_basis

__all__ = ["Fit", "grid", "concept_ratios", "batch_ratios", "refine", "fit_concept", "sample_points"]

BIG = 1e6


def sample_points(n_sets: int, k_low: float, k_high: float, count: int, seed: int = 0) -> np.ndarray:
    """``(generic, sample)``: a generic point (deterministic, off any lattice) and ``count``
    Sobol points of the box ``[k_low, k_high]^n_sets``."""
    from scipy.stats import qmc

    rng = np.random.default_rng(seed + 12345)
    generic = k_low + (0.2 + 0.6 * rng.random(n_sets)) * (k_high - k_low)
    if not count:
        return generic[None], np.zeros((0, n_sets))
    sobol = qmc.Sobol(n_sets, scramble=True, seed=seed).random(count)
    return generic[None], k_low + sobol * (k_high - k_low)


def _log_errors(r: np.ndarray, t: float) -> np.ndarray:
    with np.errstate(all="ignore"):
        q = r / t
        return np.where(q > 0, np.abs(np.log(np.where(q > 0, q, 1.0))), np.inf)


def grid(n_sets: int, k_low: float, k_high: float, points: int = 256) -> tuple[np.ndarray, np.ndarray]:
    """``(vertices, boxes)``: a regular grid of about ``points`` vertices over the box (``g`` per
    axis, at least 3) and, per sub-box, the indices of its ``2^n`` corners."""
    g = max(3, int(round(points ** (1.0 / n_sets))))
    axis = np.linspace(k_low, k_high, g)
    vertices = np.array(list(itertools.product(axis, repeat=n_sets)))
    strides = g ** np.arange(n_sets - 1, -1, -1)
    lower = np.array(list(itertools.product(range(g - 1), repeat=n_sets)))
    offsets = np.array(list(itertools.product((0, 1), repeat=n_sets)))
    boxes = (lower[:, None, :] + offsets[None]) @ strides
    return vertices, boxes


def concept_ratios(train: Train, i: int, o: int, candidates, combos: np.ndarray, k: np.ndarray) -> np.ndarray:
    """Ratios (P x S) of the combinations ``combos`` (S x K indices into ``candidates``, each
    ``(link,)`` or ``(l1, l2)``) at the points ``k`` (P x N); NaN where not a gear."""
    basis = speed_basis(train, k)
    n_links = len(train.links)
    vec = np.zeros((len(candidates), n_links))
    for e, c in enumerate(candidates):
        vec[e, c[0]] = 1.0
        if len(c) == 2:
            vec[e, c[1]] = -1.0
    ev = np.einsum("el,pld->ped", vec, basis)
    rows = ev[:, combos, :]
    q = _null_vectors(rows)  # P x S x D
    s = np.einsum("pld,psd->psl", basis, q)
    return _ratio(rows, q, s[..., i], s[..., o])


def _ratio(rows: np.ndarray, q: np.ndarray, s_in: np.ndarray, s_out: np.ndarray) -> np.ndarray:
    """``s_in / s_out``, NaN where the element rows are dependent (the same threshold as the
    pruning: the minors against Hadamard's bound) or the output stands."""
    with np.errstate(all="ignore"):
        norm = np.linalg.norm(q, axis=-1)
        scale = np.prod(np.linalg.norm(rows, axis=-1), axis=-1)
        good = (np.abs(s_out) > 1e-12 * norm) & (norm > 1e-9 * np.maximum(scale, 1e-300))
        return np.where(good, s_in / np.where(good, s_out, 1.0), np.nan)


@dataclass(frozen=True)
class Fit:
    """A fitted concept: ``k`` (one per set), ``assignment[g]`` the combination (row of the
    concept's combinations) of target gear ``g``, the ratios and relative errors per gear."""

    k: tuple[float, ...]
    assignment: tuple[int, ...]
    ratios: tuple[float, ...]
    errors: tuple[float, ...]

    @property
    def max_error(self) -> float:
        return max(abs(e) for e in self.errors)


def _assign(r: np.ndarray, targets: np.ndarray) -> np.ndarray | None:
    from scipy.optimize import linear_sum_assignment

    cost = np.array([[_log_errors(np.array([x]), t)[0] for x in r] for t in targets])
    cost = np.where(np.isfinite(cost), cost ** 2, BIG)
    if cost.shape[1] < cost.shape[0]:
        return None
    rows, cols = linear_sum_assignment(cost)
    if np.any(cost[rows, cols] >= BIG):
        return None
    out = np.empty(len(targets), dtype=np.int64)
    out[rows] = cols
    return out


def fit_concept(train: Train, i: int, o: int, candidates, combos: np.ndarray, targets: np.ndarray,
                k_low: float, k_high: float, starts: np.ndarray) -> Fit | None:
    """The best fit from the points ``starts`` (rows of k), ``None`` when no assignment of the
    targets to distinct gears of the right sign exists there."""
    from scipy.optimize import least_squares

    n = train.sets
    lo, hi = np.full(n, k_low), np.full(n, k_high)
    best: Fit | None = None
    for start in np.atleast_2d(starts):
        k = np.clip(start, lo, hi)
        assignment = None
        for _ in range(2):
            r = concept_ratios(train, i, o, candidates, combos, k[None])[0]
            assignment = _assign(r, targets)
            if assignment is None:
                break
            chosen = combos[assignment]

            def residuals(x, chosen=chosen):
                rr = concept_ratios(train, i, o, candidates, chosen, x[None])[0]
                q = rr / targets
                return np.where(q > 0, np.log(np.where(q > 0, q, 1.0)), 10.0)

            sol = least_squares(residuals, k, bounds=(lo, hi + 1e-12), method="trf", xtol=1e-10, ftol=1e-10,
                                gtol=1e-10, max_nfev=60 * n, loss="soft_l1", f_scale=0.02)
            k = sol.x
        if assignment is None:
            continue
        r = concept_ratios(train, i, o, candidates, combos, k[None])[0]
        assignment = _assign(r, targets)
        if assignment is None:
            continue
        ratios = r[assignment]
        fit = Fit(tuple(float(x) for x in k), tuple(int(a) for a in assignment),
                  tuple(float(x) for x in ratios), tuple(float(x) for x in ratios / targets - 1))
        if best is None or fit.max_error < best.max_error:
            best = fit
    return best


def batch_ratios(train: Train, io: np.ndarray, vectors: np.ndarray, combos: np.ndarray, k: np.ndarray) -> np.ndarray:
    """Ratios (R x S) of many placements on ``train`` at once: row ``r`` has input/output
    ``io[r]``, element constraint vectors ``vectors[r]`` (E x L: +1/-1 on the links each element
    joins) and is evaluated at ``k[r]``; ``combos`` (S x K) the element subsets (positions)."""
    basis = speed_basis(train, k)  # R x L x D
    ev = np.einsum("rel,rld->red", vectors, basis)  # R x E x D
    rows = ev[:, combos, :]
    q = _null_vectors(rows)  # R x S x D
    s = np.einsum("rld,rsd->rsl", basis, q)
    r = np.arange(len(k))
    return _ratio(rows, q, s[r, :, io[:, 0]], s[r, :, io[:, 1]])


def _relaxed(r: np.ndarray, targets: np.ndarray, pick: np.ndarray | None = None):
    """Relaxed residuals (R x G): each target to its nearest ratio of the right sign (or the
    combination ``pick`` chosen before), and the choice."""
    with np.errstate(all="ignore"):
        q = r[:, None, :] / targets[None, :, None]  # R x G x S
        e = np.where(q > 0, np.log(np.where(q > 0, q, 1.0)), np.inf)
        e = np.where(np.isnan(e), np.inf, e)
    if pick is None:
        pick = np.argmin(np.abs(e), axis=2)
    res = np.take_along_axis(e, pick[..., None], axis=2)[..., 0]
    return res, pick


def refine(train: Train, io: np.ndarray, vectors: np.ndarray, combos: np.ndarray, targets: np.ndarray,
           k0: np.ndarray, k_low: float, k_high: float, iterations: int = 14) -> tuple[np.ndarray, np.ndarray]:
    """Batched Levenberg-Marquardt on the relaxed residuals (each target to its nearest ratio),
    from ``k0`` (R x N) inside the bounds: ``(k, relaxed max |ln error|)`` per row. The relaxed
    error at ``k`` never exceeds the error of any assignment there, so a row above the
    tolerance here cannot meet it at this ``k``."""
    k = np.clip(np.array(k0, dtype=float), k_low, k_high)
    n = k.shape[1]
    lam = np.full(len(k), 1e-2)
    res, pick = _relaxed(batch_ratios(train, io, vectors, combos, k), targets)
    cost = np.sum(np.where(np.isfinite(res), res, 1e3) ** 2, axis=1)
    h = 1e-6
    for _ in range(iterations):
        finite = np.all(np.isfinite(res), axis=1)
        if not finite.any():
            break
        jac = np.empty(res.shape + (n,))
        for p in range(n):
            kp = k.copy()
            kp[:, p] += h
            rp, _ = _relaxed(batch_ratios(train, io, vectors, combos, kp), targets, pick)
            with np.errstate(all="ignore"):
                jac[..., p] = (rp - res) / h
        jac = np.where(np.isfinite(jac), jac, 0.0)
        r0 = np.where(np.isfinite(res), res, 0.0)
        jtj = np.einsum("rgp,rgq->rpq", jac, jac)
        jtr = np.einsum("rgp,rg->rp", jac, r0)
        damp = lam[:, None, None] * (np.eye(n)[None] * (1.0 + np.einsum("rpp->rp", jtj)[:, :, None]))
        try:
            step = -np.linalg.solve(jtj + damp, jtr[..., None])[..., 0]
        except np.linalg.LinAlgError:
            break
        trial = np.clip(k + step, k_low, k_high)
        tres, tpick = _relaxed(batch_ratios(train, io, vectors, combos, trial), targets)
        tcost = np.sum(np.where(np.isfinite(tres), tres, 1e3) ** 2, axis=1)
        better = tcost < cost
        k = np.where(better[:, None], trial, k)
        res = np.where(better[:, None], tres, res)
        pick = np.where(better[:, None], tpick, pick)
        cost = np.where(better, tcost, cost)
        lam = np.where(better, lam / 3, lam * 4)
    worst = np.max(np.abs(res), axis=1)
    return k, np.where(np.isfinite(worst), worst, np.inf)
