"""The per-train work of ``transgen synthesize topology``: enumerate, deduplicate, prune, screen, fit.

One task is one gear train (:func:`train_task`): its placements (input, output, brakes,
clutches; :func:`transgen.synthesis.topology.placements` in the same order, vectorised here),
the early pruning (:func:`transgen.synthesis.topology.feasible_mask`), one representative per
class of the train's automorphisms, the exact cell screen and the fit
(:mod:`transgen.synthesis.fit`). Tasks are independent and deterministic, so they run on the
sweep executors (``sim.study.executors``) in any order and the merged result is the same.
"""
from __future__ import annotations

import itertools
from dataclasses import dataclass, field

import numpy as np

from .fit import Fit, fit_concept, grid, refine, sample_points
from .screen import VertexSpeeds, cell_screen, vertex_starts
from .topology import (Concept, Train, count_orbits, feasible_mask, rank_mask, row_masks, set_permutations,
                       train_automorphisms, train_kinematics)

__all__ = ["SearchSpec", "TrainResult", "FittedConcept", "train_task", "feasible_placements", "placement_concept"]


@dataclass(frozen=True)
class SearchSpec:
    """What is searched: sizes, targets (gear names and ratios), bounds and thresholds."""

    sets: int
    brakes: int
    clutches: int
    engaged: int
    gears: tuple[str, ...]
    targets: tuple[float, ...]
    tolerance: float = 0.01
    k_low: float = 1.5
    k_high: float = 4.5
    samples: int = 256
    seed: int = 0
    levels: int | None = None
    """Subdivisions of the screen's grid cells (each halves the cells' edges); default 2 up to
    three sets, 0 for four (measured: at N = 4 the refinement of the few survivors costs less
    than subdividing, docs/topology.md)."""
    ravigneaux: int = 0
    """How many of the ``sets`` are Ravigneaux compounds (two planetary statements each,
    :mod:`transgen.synthesis.ravigneaux`)."""
    grounded: int = 0
    """Most members fixed to the housing (a fixed member makes its set a fixed reduction, as the
    front set of a Lepelletier design); default none."""
    prune: bool = True
    """Apply the necessary conditions (gear count, distinct ratios, cell screen); ``False`` only
    for the brute-force comparison in the tests."""

    @property
    def planetaries(self) -> int:
        """Planetary statements (basic ratios): a compound counts two."""
        return self.sets + self.ravigneaux


@dataclass(frozen=True)
class FittedConcept:
    """A concept whose fitted ratios meet every target within the tolerance."""

    concept: Concept
    fit: Fit
    gears: tuple[tuple[str, ...], ...]
    """The engaged elements (names) of each target gear, in the targets' order."""


@dataclass
class TrainResult:
    """Counts of one train and its fitted concepts."""

    enumerated: int = 0
    distinct: int = 0
    feasible: int = 0
    screened: int = 0
    refined: int = 0
    fitted: int = 0
    concepts: list = field(default_factory=list)

    def merge(self, other: "TrainResult") -> None:
        self.enumerated += other.enumerated
        self.distinct += other.distinct
        self.feasible += other.feasible
        self.screened += other.screened
        self.refined += other.refined
        self.fitted += other.fitted
        self.concepts.extend(other.concepts)


def _is_representative(i, o, bs, cs, autos) -> bool:
    own = (i, o, tuple(bs), tuple(cs))
    for _, pi in autos[1:]:
        img = (pi[i], pi[o], tuple(sorted(pi[b] for b in bs)),
               tuple(sorted(tuple(sorted((pi[a], pi[b]))) for a, b in cs)))
        if img < own:
            return False
    return True


def feasible_placements(train: Train, spec: SearchSpec):
    """``(counts, kinematics, feasible)`` of ``train``: ``feasible`` lists ``(input, output,
    rows)`` with one row of sorted candidate-element indices (brakes, then clutches) per distinct
    feasible concept (one representative per class of the train's automorphisms)."""
    out = TrainResult()
    autos = train_automorphisms(train)
    factor = len(set_permutations(train)) // len(autos)  # labelled copies of this train
    raw, distinct = count_orbits(train, spec.brakes, spec.clutches, autos)
    out.enumerated = raw * factor
    out.distinct = distinct
    generic, _ = sample_points(train.sets, spec.k_low, spec.k_high, 0, spec.seed)
    kin = train_kinematics(train, spec.engaged, generic)
    gears = len(spec.targets)
    n = len(train.links)
    bare = train.bare
    index = {c: e for e, c in enumerate(kin.candidates)}
    clutch_ids = [index[p] for p in itertools.combinations(range(n), 2)]
    clutch_sets = np.array(list(itertools.combinations(clutch_ids, spec.clutches)), dtype=np.int64).reshape(
        -1, spec.clutches)
    member_links = [l for l in range(n) if l != bare]
    brake_sets = np.array(list(itertools.combinations([index[(l,)] for l in member_links], spec.brakes)),
                          dtype=np.int64).reshape(-1, spec.brakes)
    feasible: list[tuple[int, int, np.ndarray]] = []
    if not len(brake_sets) or not len(clutch_sets):
        return out, kin, feasible
    # placements up to the input and output; the rank condition does not depend on them
    elements = np.hstack([np.repeat(brake_sets, len(clutch_sets), axis=0),
                          np.tile(clutch_sets, (len(brake_sets), 1))])
    necessary = spec.prune
    distinct = _separated(spec)
    if necessary:  # the rank condition does not depend on the input and output
        keep, ids = rank_mask(kin, elements, gears)
        elements, ids = elements[keep], ids[keep]
    else:
        ids = kin.combo_ids(elements)
    brake_link = np.array([c[0] for c in kin.candidates])
    braked = np.zeros((len(elements), n), dtype=bool)
    for j in range(spec.brakes):
        braked[np.arange(len(elements)), brake_link[elements[:, j]]] = True
    # links that can be the input or output of a row: not braked, and (a necessary condition)
    # turning in at least one gear per target; rows without an input and an output are dropped
    usable = ~braked
    if necessary:
        usable &= (kin.rank_ok[:, None] & kin.moves)[ids].sum(axis=1) >= gears
        enough = usable.sum(axis=1) >= 2  # an input and an output
        if bare is not None:
            enough &= usable[:, bare]
        elements, ids, usable = elements[enough], ids[enough], usable[enough]
    gear, turns, touched = row_masks(kin, elements, ids)
    for i in ([bare] if bare is not None else range(n)):
        with_i = np.flatnonzero(usable[:, i])
        for o in range(n):
            if o == i or o == bare:
                continue
            here = with_i[usable[with_i, o]]
            if not len(here):
                continue
            sub = (gear[here], turns[here], touched[here])
            rows_here, ids_here = elements[here], ids[here]
            rows = rows_here[feasible_mask(kin, i, o, rows_here, gears, ids_here, necessary, distinct, sub)]
            if len(autos) > 1 and len(rows):
                reps = [r for r in range(len(rows)) if _is_representative(
                    i, o, [kin.candidates[e][0] for e in rows[r, :spec.brakes]],
                    [kin.candidates[e] for e in rows[r, spec.brakes:]], autos)]
                rows = rows[reps]
            out.feasible += len(rows)
            if len(rows):
                feasible.append((i, o, rows))
    return out, kin, feasible


def _separated(spec: SearchSpec) -> bool:
    """Whether no two targets can be met by one ratio (then the gears must differ)."""
    t = np.sort(np.array(spec.targets))
    return bool(np.all(t[1:] * (1 - spec.tolerance) > t[:-1] * (1 + spec.tolerance) + 1e-12 * np.abs(t[1:])))


def placement_concept(kin, spec: SearchSpec, i: int, o: int, row) -> Concept:
    """The :class:`Concept` of one row of :func:`feasible_placements`."""
    cands = [kin.candidates[e] for e in row]
    return Concept(kin.train, i, o, tuple(c[0] for c in cands[:spec.brakes]), tuple(cands[spec.brakes:]))


def train_task(train: Train, spec: SearchSpec) -> TrainResult:
    """Every fitted concept on ``train`` and the counts of each stage (see the module docstring)."""
    out, kin, feasible = feasible_placements(train, spec)
    vertices, _ = grid(train.sets, spec.k_low, spec.k_high, spec.samples)
    cells = max(1, round(len(vertices) ** (1 / train.sets)) - 1)
    targets = np.array(spec.targets)
    n = len(train.links)
    found = []
    groups = [(i, o, rows, kin.combo_ids(rows)) for i, o, rows in feasible]
    first = VertexSpeeds(kin, np.unique(np.concatenate([ids.ravel() for *_, ids in groups])), vertices) \
        if groups else None
    for i, o, rows, ids in groups:
        if spec.prune:
            valid = (kin.rank_ok & kin.moves[:, i] & kin.moves[:, o])[ids]
            ok = cell_screen(kin, i, o, ids, valid, targets, spec.tolerance, spec.k_low, spec.k_high, cells,
                             (2 if train.sets <= 3 else 0) if spec.levels is None else spec.levels, first)
            rows, ids = rows[ok], ids[ok]
        if not len(rows):
            continue
        starts = vertex_starts(kin, i, o, ids, targets, first)
        found += [(i, o, r, k0) for r, k0 in zip(rows, starts)]
    out.screened = len(found)
    if not found:
        return out
    combos = np.array(list(itertools.combinations(range(spec.brakes + spec.clutches), spec.engaged)),
                      dtype=np.int64)
    io = np.array([(i, o) for i, o, _, _ in found])
    vectors = np.zeros((len(found), spec.brakes + spec.clutches, n))
    for r, (_, _, els, _) in enumerate(found):
        for j, e in enumerate(els):
            c = kin.candidates[e]
            vectors[r, j, c[0]] = 1.0
            if len(c) == 2:
                vectors[r, j, c[1]] = -1.0
    k, worst = refine(train, io, vectors, combos, targets, np.array([k0 for *_, k0 in found]), spec.k_low,
                      spec.k_high)
    out.refined = int(np.sum(worst <= 2 * spec.tolerance))
    for r in np.flatnonzero(worst <= 2 * spec.tolerance):
        i, o, els, _ = found[r]
        cands = [kin.candidates[e] for e in els]
        fit = fit_concept(train, i, o, cands, combos, targets, spec.k_low, spec.k_high, k[r][None])
        if fit is None or fit.max_error > spec.tolerance:
            continue
        concept = placement_concept(kin, spec, i, o, els)
        names = [name for name, _ in concept.elements]
        gear_elements = tuple(tuple(names[j] for j in combos[a]) for a in fit.assignment)
        out.fitted += 1
        out.concepts.append(FittedConcept(concept, fit, gear_elements))
    return out
