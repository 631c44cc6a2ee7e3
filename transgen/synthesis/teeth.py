"""Tooth-count synthesis: planetary tooth counts that reproduce target gear ratios.

Planetaries whose tooth counts are written ``Ns=? Nr=?`` (or ranges ``Ns=20..60``) are unknown.
Every speed ratio depends on a set only through its basic ratio ``k = Nr/Ns`` (see
:mod:`transgen.synthesis.kinematic`), so the search runs in three steps:

1. **Continuous**: find every ``k`` vector inside the bounds where each target ratio is met
   within its tolerance: least squares (scipy ``least_squares``) from the best points of a Sobol
   sample of the box, residuals ``(R_g(k) - target_g) / tolerance_g``.
2. **Bands**: around each continuous solution, the box of ``k`` where the linearised ratios stay
   within *twice* their tolerance (one linear program per bound, scipy ``linprog``), widened by
   half: a superset of the true region, so no integer solution is lost to linearisation.
3. **Integers**: every admissible ``(Ns, Nr)`` with ``Nr/Ns`` in a band, grouped by the exact
   fraction ``k``; a depth-first search assigns the sets one by one and drops a branch as soon as
   a gear whose ratio depends only on the assigned sets misses its target (pruning per gear);
   the survivors are checked exactly with fractions.

Assembly rules (:class:`AssemblyRules`, for each set, checked on every solution):

* simple set, standard centre distance: ``Nr - Ns`` even, planet teeth ``Np = (Nr - Ns)/2``
  (with ``profile_shift``, ``Nr - Ns`` may be odd and ``Np = floor((Nr - Ns)/2)``);
* at least ``min_teeth`` teeth on the sun and on the planets (double-pinion sets: the sun; the
  pinion sizes are not determined by ``Ns`` and ``Nr``);
* ring/sun ratio ``k_min <= Nr/Ns <= k_max``;
* ``n`` equally spaced planets, ``n`` from ``planets``: ``(Ns + Nr)/n`` a whole number for a
  simple set, ``(Nr - Ns)/n`` for a double-pinion set (positive basic ratio: the ring and sun
  turn the same way with the carrier held, so the mesh-phase condition takes the difference);
  for a simple set the neighbouring planets must clear each other, ``(Ns + Np) sin(pi/n) > Np + 2``
  (tip diameters at a standard addendum of one module; KHK gear handbook, eqs. 13-5, 13-7, 13-9).
  The planet count reported is the largest admissible one.
* the sets named by ``share`` statements are chosen together: equal teeth on a shared sun or ring,
  a shared pinion at one centre distance with one planet count (:mod:`transgen.synthesis.shares`).

Solutions are ranked by their largest absolute ratio error, then by size ``sum(Ns + Nr)``.
"""
from __future__ import annotations

import itertools
import math
import re
from dataclasses import dataclass, field
from fractions import Fraction

import numpy as np

from ..errors import TransgenError
from ..kinematics import _half_unit
from ..model import Mechanism
from .kinematic import GearKinematics, gear_kinematics
from .shares import share_rules, shared_choices

__all__ = [
    "AssemblyRules",
    "RatioTarget",
    "SetTeeth",
    "TeethSolution",
    "TeethSynthesis",
    "parse_ratio_targets",
    "ratio_targets",
    "planet_count",
    "planet_counts",
    "synthesize_teeth",
    "completed_text",
]


class SynthesisInputError(TransgenError, ValueError):
    """The targets or rules of a synthesis do not make sense (exit 2)."""


@dataclass(frozen=True)
class AssemblyRules:
    """The rules every synthesised set obeys (see the module docstring).

    ``max_teeth`` bounds the ring of a set written ``Nr=?`` (and its sun at ``max_teeth/k_min``).
    """

    planets: tuple[int, ...] = (3, 4, 5)
    min_teeth: int = 17
    k_min: float = 1.5
    k_max: float = 4.5
    max_teeth: int = 150
    profile_shift: bool = False

    def describe(self) -> list[str]:
        """The rules in words, for the output."""
        counts = ",".join(str(n) for n in self.planets)
        return [
            f"planets equally spaced, n in {{{counts}}}: (Ns + Nr)/n whole for a simple set, (Nr - Ns)/n whole "
            f"for a double-pinion set; neighbouring planets clear: (Ns + Np) sin(pi/n) > Np + 2",
            ("profile shift allowed: Nr - Ns may be odd, Np = floor((Nr - Ns)/2)" if self.profile_shift else
             "standard centre distance: Nr - Ns even, planet teeth Np = (Nr - Ns)/2 (simple set)"),
            f"at least {self.min_teeth} teeth on sun and planets (double-pinion: sun only)",
            f"ring/sun ratio {self.k_min:g} <= Nr/Ns <= {self.k_max:g}; unknown rings at most {self.max_teeth} teeth",
        ]


def planet_count(n_sun: int, n_ring: int, pinions: int, rules: AssemblyRules) -> int | None:
    """The largest admissible number of equally spaced planets, ``None`` when the set cannot be
    assembled under ``rules``."""
    fits = planet_counts(n_sun, n_ring, pinions, rules)
    return max(fits) if fits else None


def planet_counts(n_sun: int, n_ring: int, pinions: int, rules: AssemblyRules) -> tuple[int, ...]:
    """Every admissible number of equally spaced planets (none: the set cannot be assembled)."""
    if n_sun < rules.min_teeth or n_ring <= n_sun:
        return ()
    if not rules.k_min <= n_ring / n_sun <= rules.k_max:
        return ()
    if pinions == 2:
        return tuple(n for n in rules.planets if (n_ring - n_sun) % n == 0)
    if (n_ring - n_sun) % 2 and not rules.profile_shift:
        return ()
    n_planet = (n_ring - n_sun) // 2
    if n_planet < rules.min_teeth:
        return ()
    return tuple(n for n in rules.planets
                 if (n_sun + n_ring) % n == 0 and (n_sun + n_planet) * math.sin(math.pi / n) > n_planet + 2)


@dataclass(frozen=True)
class RatioTarget:
    """A target ratio (input speed / output speed) of a gear: ``text`` as written, met when the
    computed ratio lies within ``tolerance`` of it."""

    gear: str
    text: str
    tolerance: Fraction

    @property
    def value(self) -> Fraction:
        return Fraction(self.text)


_TARGET = re.compile(r"^\s*([A-Za-z0-9_]+)\s*=\s*([+-]?(\d+(\.\d*)?|\.\d+)([eE][+-]?\d+)?)\s*$")


def parse_ratio_targets(text: str) -> dict[str, str]:
    """``"1=4.70,2=3.13,R=-3.30"`` -> ``{"1": "4.70", ...}`` (the numbers kept as written)."""
    out: dict[str, str] = {}
    for item in text.split(","):
        if not item.strip():
            continue
        match = _TARGET.match(item)
        if not match:
            raise SynthesisInputError(f"--ratios: cannot read {item.strip()!r}: write GEAR=RATIO, e.g. 1=4.70")
        if match.group(1) in out:
            raise SynthesisInputError(f"--ratios: gear {match.group(1)} is given twice")
        out[match.group(1)] = match.group(2)
    return out


def ratio_targets(mech: Mechanism, ratios: dict[str, str] | None = None,
                  tolerance: float | None = None) -> tuple[RatioTarget, ...]:
    """The targets: ``ratios`` (gear -> ratio text) or else the gear lines' ``ratio=``.

    The tolerance of each is half a unit of its last written digit (the gear line's ``tol=`` where
    it gives one), or ``tolerance`` for all (published ratios are sometimes truncated rather than
    rounded: widen it then).
    """
    gears = {g.name: g for g in mech.gears if g.kind == "gear"}
    if ratios is None:
        ratios = {g.name: g.ratio for g in gears.values() if g.ratio is not None}
        if not ratios:
            raise SynthesisInputError(f"{mech.source}: no target ratios: give --ratios GEAR=RATIO,... or ratio= on "
                                      f"the gear lines")
    targets = []
    for name, text in ratios.items():
        if name not in gears:
            known = ", ".join(gears) or "none"
            raise SynthesisInputError(f"target ratio for gear {name!r}, which the gear table of {mech.source} does "
                                      f"not declare (gears: {known})")
        if not math.isfinite(float(text)) or float(text) == 0:
            raise SynthesisInputError(f"target ratio of gear {name} must be a finite, nonzero number, not {text}")
        own = gears[name].tolerance if gears[name].ratio == text else None  # the gear line's tol=
        tol = (Fraction(tolerance) if tolerance is not None else Fraction(own) if own is not None
               else Fraction(_half_unit(text)).limit_denominator(10**12))
        targets.append(RatioTarget(name, text, tol))
    if tolerance is not None and not (math.isfinite(tolerance) and tolerance > 0):
        raise SynthesisInputError(f"--tolerance must be a positive number, not {tolerance}")
    return tuple(targets)


@dataclass(frozen=True)
class SetTeeth:
    """The tooth counts of one set in a solution and its planet count."""

    name: str
    n_sun: int
    n_ring: int
    planets: int
    pinions: int = 1


@dataclass(frozen=True)
class TeethSolution:
    """Tooth counts of every set, with the exact ratios and their errors (ratio - target)."""

    teeth: tuple[SetTeeth, ...]
    ratios: dict = field(compare=False)
    errors: dict = field(compare=False)
    max_error: float = 0.0
    feasible: bool = True

    @property
    def size(self) -> int:
        """Total teeth of suns and rings: the ranking's measure of size."""
        return sum(t.n_sun + t.n_ring for t in self.teeth)

    def to_dict(self) -> dict:
        return {"teeth": {t.name: {"Ns": t.n_sun, "Nr": t.n_ring, "planets": t.planets} for t in self.teeth},
                "max_error": self.max_error, "errors": dict(self.errors),
                "ratios": {g: float(r) for g, r in self.ratios.items()}, "size": self.size}


@dataclass(frozen=True)
class TeethSynthesis:
    """The result of :func:`synthesize_teeth`.

    ``solutions`` are the best ``top`` of ``count`` solutions; ``closest`` the best candidates
    that miss a target when there is none; ``continuous`` the ``k`` vectors of step 1.
    """

    mechanism: Mechanism
    targets: tuple[RatioTarget, ...]
    rules: AssemblyRules
    unknown: tuple[str, ...]
    solutions: tuple[TeethSolution, ...]
    count: int
    closest: tuple[TeethSolution, ...] = ()
    continuous: tuple[dict, ...] = ()
    notes: tuple[str, ...] = ()

    UNITS = {"max_error": "1", "errors": "1", "ratios": "1", "target": "1", "tolerance": "1", "k": "1",
             "worst_residual": "1", "Ns": "1", "Nr": "1", "planets": "1", "size": "1", "count": "1"}
    """Units of the numeric fields of :meth:`to_dict` (ratios and their errors: input speed / output
    speed; tooth and planet counts; ``worst_residual``: largest error over its tolerance)."""

    def to_dict(self) -> dict:
        return {
            "mechanism": self.mechanism.name,
            "unknown": list(self.unknown),
            "targets": [{"gear": t.gear, "target": float(t.value), "tolerance": float(t.tolerance)}
                        for t in self.targets],
            "rules": self.rules.describe(),
            "ranking": "largest absolute ratio error, then size sum(Ns + Nr)",
            "count": self.count,
            "solutions": [s.to_dict() for s in self.solutions],
            "closest": [s.to_dict() for s in self.closest],
            "continuous": [dict(c) for c in self.continuous],
            "notes": list(self.notes),
        }


def completed_text(mech: Mechanism, solution: TeethSolution) -> str:
    """The ``.mech`` text of ``mech`` with the unknown tooth counts filled in from ``solution``
    (comments and layout kept)."""
    lines = mech.text.split("\n")
    by_name = {t.name: t for t in solution.teeth}
    for p in mech.planetaries:
        if p.teeth_known or p.name not in by_name:
            continue
        t = by_name[p.name]
        i = p.span.line - 1
        line = lines[i]
        line = re.sub(r"\bNs\s*=\s*(\?|\d+\s*\.\.\s*\d+)", f"Ns={t.n_sun}", line)
        line = re.sub(r"\bNr\s*=\s*(\?|\d+\s*\.\.\s*\d+)", f"Nr={t.n_ring}", line)
        lines[i] = line
    return "\n".join(lines)


# --------------------------------------------------------------------------------- the search


@dataclass
class _Problem:
    mech: Mechanism
    targets: tuple[RatioTarget, ...]
    rules: AssemblyRules
    unknown: tuple[str, ...]
    pinions: tuple[int, ...]
    sun_range: list[tuple[int, int]]
    ring_range: list[tuple[int, int]]
    k_low: np.ndarray
    k_high: np.ndarray
    gears: list[GearKinematics]
    target: np.ndarray
    tol: np.ndarray

    def residuals(self, k: np.ndarray) -> np.ndarray:
        """Normalised residuals (ratio - target)/tolerance, shape (N, gears)."""
        k = np.atleast_2d(k)
        r = np.column_stack([g.ratios(k) for g in self.gears]) if self.gears else np.zeros((len(k), 0))
        return np.where(np.isfinite(r), (r - self.target) / self.tol, 1e12)

    def pairs(self, p: int, low: float, high: float) -> dict[Fraction, list[tuple[int, int, int]]]:
        """Admissible (Ns, Nr, planets) of set ``p`` with ``low <= Nr/Ns <= high``, by exact ``k``."""
        out: dict[Fraction, list[tuple[int, int, int]]] = {}
        (s0, s1), (r0, r1) = self.sun_range[p], self.ring_range[p]
        for ns in range(s0, s1 + 1):
            lo, hi = max(r0, math.ceil(low * ns - 1e-9)), min(r1, math.floor(high * ns + 1e-9))
            for nr in range(lo, hi + 1):
                n = planet_count(ns, nr, self.pinions[p], self.rules)
                if n is not None:
                    out.setdefault(Fraction(nr, ns), []).append((ns, nr, n))
        for v in out.values():
            v.sort(key=lambda t: t[0] + t[1])
        return out


def _problem(mech: Mechanism, targets, rules: AssemblyRules, rng) -> _Problem:
    unknown, pinions, suns, rings, lows, highs = [], [], [], [], [], []
    for p in mech.planetaries:
        if p.teeth_known:
            continue
        unknown.append(p.name)
        pinions.append(p.pinions)
        if p.n_sun is not None:
            sun = (p.n_sun, p.n_sun)
        else:
            sun = p.sun_bounds or (rules.min_teeth, max(rules.min_teeth, int(rules.max_teeth / rules.k_min)))
        if p.n_ring is not None:
            ring = (p.n_ring, p.n_ring)
        else:
            ring = p.ring_bounds or (math.ceil(rules.min_teeth * rules.k_min), rules.max_teeth)
        suns.append(sun)
        rings.append(ring)
        low, high = max(rules.k_min, ring[0] / sun[1]), min(rules.k_max, ring[1] / sun[0])
        if low > high:
            raise SynthesisInputError(f"{mech.source}:{p.span.line}:{p.span.column}: error: planetary {p.name}: the "
                                      f"tooth ranges allow no ring/sun ratio within {rules.k_min:g}..{rules.k_max:g}")
        lows.append(low)
        highs.append(high)
    k_low, k_high = np.array(lows, dtype=float), np.array(highs, dtype=float)
    gears = []
    for t in targets:
        gk = gear_kinematics(mech, mech.gear(t.gear).engaged, t.gear, tuple(unknown), k_low, k_high, rng)
        if len(gk.rows) != len(mech.links) - 1:
            raise SynthesisInputError(f"{mech.source}:{mech.gear(t.gear).span.line}:{mech.gear(t.gear).span.column}: "
                                      f"error: gear {t.gear} ({' '.join(gk.engaged)}) does not fix the input/output "
                                      f"ratio (idle members aside, more than one degree of freedom is left), so it "
                                      f"has no ratio to match")
        gears.append(gk)
    target = np.array([float(t.value) for t in targets])
    tol = np.array([float(t.tolerance) for t in targets])
    return _Problem(mech, tuple(targets), rules, tuple(unknown), tuple(pinions), suns, rings, k_low, k_high,
                    gears, target, tol)


def _continuous(pb: _Problem, starts: int, rng, progress) -> list[tuple[np.ndarray, float]]:
    """Local minima of the normalised residuals: (k, largest |residual|), best first."""
    from scipy.optimize import least_squares
    from scipy.stats import qmc

    dim = len(pb.unknown)
    sample = qmc.Sobol(dim, seed=rng).random(4096)
    points = pb.k_low + sample * (pb.k_high - pb.k_low)
    worst = np.max(np.abs(pb.residuals(points)), axis=1)
    order = np.argsort(worst)
    picks = list(order[:starts]) + list(rng.choice(len(points), size=starts // 4, replace=False))
    found: list[tuple[np.ndarray, float]] = []
    span = pb.k_high - pb.k_low
    lo, hi = pb.k_low, pb.k_high + 1e-12 * (1 + pb.k_high)
    for i, start in enumerate(picks):
        if progress:
            progress(f"continuous solve {i + 1}/{len(picks)}")
        fit = least_squares(lambda k: pb.residuals(k)[0], points[start], bounds=(lo, hi), method="trf",
                            x_scale="jac", xtol=1e-12, ftol=1e-12, gtol=1e-12, max_nfev=200)
        k = fit.x
        value = float(np.max(np.abs(pb.residuals(k)[0])))
        if all(np.max(np.abs(k - other) / (span + 1e-300)) > 1e-6 for other, _ in found):
            found.append((k, value))
    found.sort(key=lambda f: f[1])
    return found


def _band(pb: _Problem, k: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
    """A box of ``k`` around ``k`` containing every point where the linearised ratios are within
    twice their tolerance (``None`` when the linearised targets cannot be met there)."""
    from scipy.optimize import linprog

    dim = len(k)
    r0 = pb.residuals(k)[0]
    h = 1e-7 * (1 + np.abs(k))
    shifted = k + np.diag(h)
    jac = ((pb.residuals(shifted) - r0) / h[:, None]).T  # gears x sets
    a_ub = np.vstack([jac, -jac])
    b_ub = np.concatenate([2 - r0, 2 + r0])
    bounds = list(zip(pb.k_low - k, pb.k_high - k))
    low, high = pb.k_low.copy(), pb.k_high.copy()
    for p in range(dim):
        c = np.zeros(dim)
        for sign in (1.0, -1.0):
            c[p] = sign
            res = linprog(c, A_ub=a_ub, b_ub=b_ub, bounds=bounds, method="highs")
            if res.status == 2:  # infeasible
                return None
            if res.status != 0:
                continue  # unbounded or failed: keep the bound of the box
            if sign > 0:
                low[p] = max(pb.k_low[p], k[p] + 1.5 * res.x[p] - 1e-9)
            else:
                high[p] = min(pb.k_high[p], k[p] + 1.5 * res.x[p] + 1e-9)
    return low, high


def _exact_errors(pb: _Problem, ks: tuple[Fraction, ...]) -> tuple[dict, dict, bool] | None:
    ratios, errors, ok = {}, {}, True
    for gk, t in zip(pb.gears, pb.targets):
        r = gk.exact_ratio(ks)
        if r is None:
            return None
        ratios[t.gear] = r
        err = r - t.value
        errors[t.gear] = float(err)
        ok = ok and abs(err) <= t.tolerance
    return ratios, errors, ok


def _search(pb: _Problem, candidates: list[list[Fraction]], progress) -> list[tuple[Fraction, ...]]:
    """Depth-first search over the candidate ``k`` of each set, pruned per gear (float check with
    a relative slack of 1e-9), then checked exactly."""
    dim = len(candidates)
    order = sorted(range(dim), key=lambda p: len(candidates[p]))
    depth_of = {p: d for d, p in enumerate(order)}
    ready: dict[int, list[int]] = {}
    for g, gk in enumerate(pb.gears):
        d = max((depth_of[p] for p in gk.depends), default=-1)
        ready.setdefault(d, []).append(g)
    slack = pb.tol * (1 + 1e-9) + 1e-12 * np.abs(pb.target)
    mid = (pb.k_low + pb.k_high) / 2
    if ready.get(-1):
        r = np.array([pb.gears[g].ratios(mid[None])[0] for g in ready[-1]])
        if np.any(~(np.abs(r - pb.target[ready[-1]]) <= slack[ready[-1]])):
            return []
    results: list[tuple[Fraction, ...]] = []
    assigned = [None] * dim

    def visit(d: int, point: np.ndarray) -> None:
        p = order[d]
        values = candidates[p]
        batch = np.repeat(point[None], len(values), axis=0)
        batch[:, p] = [float(v) for v in values]
        keep = np.ones(len(values), dtype=bool)
        for g in ready.get(d, []):
            r = pb.gears[g].ratios(batch)
            keep &= np.abs(r - pb.target[g]) <= slack[g]
        for i in np.flatnonzero(keep):
            assigned[p] = values[i]
            if d + 1 == dim:
                results.append(tuple(assigned))
            else:
                visit(d + 1, batch[i])

    if dim:
        visit(0, mid.copy())
    else:
        results.append(())
    return results


def _expand(pb: _Problem, combos: list[tuple[tuple[Fraction, ...], dict, dict]],
            pairs: list[dict], top: int) -> tuple[list[TeethSolution], int]:
    """The tooth counts of each exact solution in ``k``: ``top`` best (0: all) and the count.
    The sets named by a ``share`` are chosen jointly (:func:`~transgen.synthesis.shares.shared_choices`),
    the others independently."""
    count = 0
    out: list[TeethSolution] = []
    shares = share_rules(pb.mech)
    known_sets = [p for p in pb.mech.planetaries if p.teeth_known]
    joint = [i for i, name in enumerate(pb.unknown) if shares is not None and name in shares.sets]
    free = [i for i in range(len(pb.unknown)) if i not in joint]
    for ks, ratios, errors in combos:
        lists = [pairs[p][kp] for p, kp in enumerate(ks)]
        together = [({}, ())] if shares is None else _shared(pb, shares, joint, [lists[i] for i in joint])
        count += len(together) * math.prod(len(lists[i]) for i in free)
        if top:
            lists = [v[:top] for v in lists]
            together = together[:top]
        max_error = max((abs(e) for e in errors.values()), default=0.0)
        for (planets, shared), *rest in itertools.product(together, *(lists[i] for i in free)):
            choice = dict(zip(joint, shared)) | dict(zip(free, rest))
            teeth = tuple(SetTeeth(pb.unknown[i], *choice[i], pb.pinions[i]) for i in range(len(pb.unknown)))
            known = tuple(SetTeeth(p.name, p.n_sun, p.n_ring, planets.get(p.name) or
                                   planet_count(p.n_sun, p.n_ring, p.pinions, pb.rules) or 0, p.pinions)
                          for p in known_sets)
            out.append(TeethSolution(_in_file_order(pb.mech, teeth + known), ratios, errors, max_error))
        if top:
            out.sort(key=lambda s: (s.max_error, s.size))
            del out[top:]
    out.sort(key=lambda s: (s.max_error, s.size))
    return out, count


def _shared(pb: _Problem, shares, joint: list[int], lists: list) -> list[tuple[dict, tuple]]:
    """:func:`~transgen.synthesis.shares.shared_choices` for the unknown sets ``joint``."""
    known = {p.name: (p.n_sun, p.n_ring) for p in pb.mech.planetaries if p.teeth_known}
    return shared_choices(shares, [pb.unknown[i] for i in joint], lists, known, pb.rules,
                          lambda ns, nr, pinions: planet_counts(ns, nr, pinions, pb.rules))


def _in_file_order(mech: Mechanism, teeth: tuple[SetTeeth, ...]) -> tuple[SetTeeth, ...]:
    order = {p.name: i for i, p in enumerate(mech.planetaries)}
    return tuple(sorted(teeth, key=lambda t: order[t.name]))


def _closest(pb: _Problem, minima, top: int) -> list[TeethSolution]:
    """Candidates near the best continuous minima that miss a target: the admissible fractions
    next to each set's ``k`` (two on each side), ranked by their largest error."""
    seen, combos = set(), []
    for k, _ in minima[:3]:
        near = []
        for p in range(len(k)):
            pairs = pb.pairs(p, max(pb.k_low[p], k[p] - 0.1), min(pb.k_high[p], k[p] + 0.1))
            below = sorted((f for f in pairs if f <= k[p]), reverse=True)[:2]
            above = sorted(f for f in pairs if f > k[p])[:2]
            near.append([(f, pairs[f]) for f in below + above])
        for choice in itertools.product(*near):
            ks = tuple(f for f, _ in choice)
            if ks in seen:
                continue
            seen.add(ks)
            exact = _exact_errors(pb, ks)
            if exact is not None:
                combos.append((ks, exact[0], exact[1], {p: lst for p, (_, lst) in enumerate(choice)}))
    out = []
    shares = share_rules(pb.mech)
    for ks, ratios, errors, lists in combos:
        first = {p: lst[0] for p, lst in lists.items()}
        if shares is not None:  # the smallest choice that obeys the shares, if any
            joint = [p for p, name in enumerate(pb.unknown) if name in shares.sets]
            found = _shared(pb, shares, joint, [lists[p] for p in joint])
            if not found:
                continue
            first.update(zip(joint, found[0][1]))
        teeth = tuple(SetTeeth(name, *first[p], pin) for p, (name, pin) in enumerate(zip(pb.unknown, pb.pinions)))
        out.append(TeethSolution(_in_file_order(pb.mech, teeth), ratios, errors,
                                 max(abs(e) for e in errors.values()), feasible=False))
    out.sort(key=lambda s: (s.max_error, s.size))
    return out[:top]


def _check_teeth_range(rules: AssemblyRules) -> None:
    """The tooth counts of the rules within :mod:`transgen.limits` (``min_teeth``, ``max_teeth``):
    whole numbers, checked before the search allocates its tables of candidate pairs."""
    from ..limits import LimitExceeded, check_limit

    for value, option in ((rules.min_teeth, "--min-teeth"), (rules.max_teeth, "--max-teeth")):
        if isinstance(value, bool) or not isinstance(value, int):
            raise SynthesisInputError(f"{option}: a whole number of teeth, not {value!r}")
    try:
        check_limit("min_teeth", rules.min_teeth, f"--min-teeth {rules.min_teeth}")
        check_limit("max_teeth", rules.max_teeth, f"--max-teeth {rules.max_teeth}")
    except LimitExceeded as exc:
        raise SynthesisInputError(str(exc)) from None


PAIR_SECONDS = 4e-4
"""Search time per candidate (Ns, Nr) pair of the unknown sets [s]: the HT-740 with its three
sets unknown took 13 s for 44,000 pairs (--max-teeth 150) and 74 s for 179,000 (300)."""


def candidate_pairs(pb: _Problem) -> int:
    """The number of (Ns, Nr) pairs within the ranges and ring/sun bounds of every unknown set,
    counted (one loop over the sun range) before any is made."""
    total = 0
    for (s0, s1), (r0, r1) in zip(pb.sun_range, pb.ring_range):
        for ns in range(max(s0, 1), s1 + 1):
            high, low = min(float(r1), pb.rules.k_max * ns), max(float(r0), pb.rules.k_min * ns)
            total += max(0, math.floor(high) - math.ceil(low) + 1)
    return total


def _check_search_size(pb: _Problem, force: bool | None) -> None:
    from ..limits import LimitExceeded, check_limit, human_time

    pairs = candidate_pairs(pb)
    try:
        check_limit("teeth_pairs", pairs, f"--max-teeth {pb.rules.max_teeth} (the tooth ranges of {', '.join(pb.unknown)})",
                    f"about {human_time(pairs * PAIR_SECONDS)} to search", force,
                    hint="give a smaller --max-teeth, a larger --min-teeth or narrower ranges Ns=A..B")
    except LimitExceeded as exc:
        raise SynthesisInputError(str(exc)) from None


def synthesize_teeth(mech: Mechanism, targets: tuple[RatioTarget, ...], rules: AssemblyRules = AssemblyRules(),
                     top: int = 10, starts: int = 64, seed: int = 0, progress=None,
                     force: bool | None = None) -> TeethSynthesis:
    """Every admissible set of tooth counts for the unknown sets of ``mech`` that meets every
    target ratio within its tolerance (see the module docstring for the method and the rules).

    ``top`` limits the solutions returned (0: all; ``count`` is always the total); ``starts`` is
    the number of least-squares starts; ``progress(text)`` is called on long runs; ``force``
    searches beyond the limit ``teeth_pairs`` of :mod:`transgen.limits` (None: refused without
    offering ``--force``).
    """
    if top < 0:
        raise SynthesisInputError(f"--top must be 0 (all) or a positive number, not {top}")
    if not rules.planets or min(rules.planets) < 1:
        raise SynthesisInputError("--planets needs positive planet counts, e.g. 3,4,5")
    if not 1 < rules.k_min < rules.k_max:
        raise SynthesisInputError(f"ring/sun ratio bounds must satisfy 1 < min < max, not {rules.k_min:g}..{rules.k_max:g}")
    _check_teeth_range(rules)
    rng = np.random.default_rng(seed)
    pb = _problem(mech, targets, rules, rng)
    _check_search_size(pb, force)
    notes = []
    free = {p for p in range(len(pb.unknown)) if not any(p in gk.depends for gk in pb.gears)}
    if mech.shares:
        notes.append("shared gears (" + ", ".join(f"{s.set1}.{s.member1} = {s.set2}.{s.member2}" for s in mech.shares)
                     + "): equal teeth on a shared sun or ring; a shared pinion has one tooth count at one centre "
                       "distance, a double-pinion set on it a partner pinion that fits, and one planet count")
    for p, name in enumerate(pb.unknown):
        if p in free:
            notes.append(f"no target ratio depends on set {name}: any admissible teeth fit, the smallest are listed")
    minima = _continuous(pb, starts, rng, progress) if pb.unknown else [(np.zeros(0), 0.0)]
    pairs: list[dict] = [{} for _ in pb.unknown]
    combos: set[tuple[Fraction, ...]] = set()
    for k, value in minima:
        if value > 3:  # the band's linear programme would be infeasible anyway
            continue
        band = _band(pb, k) if pb.unknown else (np.zeros(0), np.zeros(0))
        if band is None:
            continue
        low, high = band
        local = []
        for p in range(len(pb.unknown)):
            found = pb.pairs(p, low[p], high[p])
            if p in free and found:  # no ratio depends on it: one representative k carries every pair
                merged = sorted((t for v in found.values() for t in v), key=lambda t: t[0] + t[1])
                found = {min(found): merged}
            pairs[p].update(found)
            local.append(sorted(found))
        combos.update(_search(pb, local, progress))
    exact = []
    for ks in sorted(combos):
        result = _exact_errors(pb, ks)
        if result is not None and result[2]:
            exact.append((ks, result[0], result[1]))
    solutions, count = _expand(pb, exact, pairs, top)
    closest = () if solutions else tuple(_closest(pb, minima, top or 10))
    continuous = tuple({"k": {n: float(v) for n, v in zip(pb.unknown, k)}, "worst_residual": value}
                       for k, value in minima[:5])
    return TeethSynthesis(mech, tuple(targets), rules, pb.unknown, tuple(solutions), count, closest, continuous,
                          tuple(notes))
