"""Ravigneaux compounds in ``transgen synthesize topology --ravigneaux K``: gear trains, ``.mech``
statements and tooth counts.

A Ravigneaux compound has four members (small sun, large sun, carrier, ring) and two degrees of
freedom. It is searched as two planetary sets that share the ring and the carrier: set ``a``
simple (the large sun on the long pinion, ``w_s + k_a w_r - (1 + k_a) w_c = 0``) and set ``b``
double-pinion (the small sun on the short pinion, which meshes the long one: ``w_s - k_b w_r +
(k_b - 1) w_c = 0``), each basic ratio ``k = Nr/Ns`` within the ring/sun bounds. Its ring and
carrier are each one link from the start; the rest of the enumeration, the pruning, the screen
(both rows are affine in their ``k``) and the fit are those of simple sets.

Of ``N`` sets, ``K`` are compounds: ``N - K`` simple sets (internal sets ``0 .. N - K - 1``),
then the compounds as internal pairs ``(N - K + 2q, N - K + 2q + 1)``, ``N + K`` planetary
statements in all. The symmetries are the permutations of the simple sets and of the compounds
as wholes (:func:`transgen.synthesis.topology.set_permutations`): the two suns of a compound
mesh different pinions and are never swapped.

A candidate's ``.mech`` states the compound as the file language does
(``mechanisms/hsw_ravigneaux4.mech``): the two planetary statements, ``share A.ring B.ring``,
``share A.carrier B.carrier`` and ``share B.outer_pinion A.pinion`` (the long pinion), so that
``transgen synthesize teeth`` (:func:`transgen.synthesis.teeth.synthesize_teeth`, which honours
shares: one ring, one long pinion at one centre distance, a short pinion that fits) finds
buildable teeth. The search uses that same function for its candidates' compounds, with the
simple sets outside compounds fixed in turn to their admissible ``Nr/Ns`` closest to the fitted
``k`` (:func:`ravigneaux_teeth`).
"""
from __future__ import annotations

import itertools
from fractions import Fraction

import numpy as np

from .topology import (Train, _canonical_codes, _partitions, _train_code, link_count, locked_pair, set_permutations,
                       trains)

__all__ = ["compound_pairs", "ravigneaux_trains", "spec_trains", "share_lines", "ravigneaux_teeth"]


def compound_pairs(n_simple: int, n_compounds: int) -> tuple[tuple[int, int], ...]:
    """The internal set pairs ``(simple half, double-pinion half)`` of the compounds."""
    return tuple((n_simple + 2 * q, n_simple + 2 * q + 1) for q in range(n_compounds))


def ravigneaux_trains(n_simple: int, n_compounds: int, n_links: int, bare_input: bool = True,
                      max_grounded: int = 0) -> list[Train]:
    """Every gear train of ``n_simple`` simple sets and ``n_compounds`` Ravigneaux compounds with
    ``n_links`` links (the bare input shaft counted), at most ``max_grounded`` members fixed to
    the housing (a compound's ring or carrier counted once), one per class of kind-keeping set
    permutations, in a fixed order."""
    pairs = compound_pairs(n_simple, n_compounds)
    n_sets = n_simple + 2 * n_compounds
    glued = {3 * b + j: 3 * a + j for a, b in pairs for j in (1, 2)}  # ring and carrier of b -> of a
    members = list(range(3 * n_sets))
    reduced = [m for m in members if m not in glued]
    perms = set_permutations(Train(n_sets, (), (), pairs))
    out: list[Train] = []
    seen = set()
    for count in range(max_grounded + 1):
        for fixed in itertools.combinations(reduced, count):
            grounded = tuple(sorted(set(fixed) | {m for m, g in glued.items() if g in fixed}))
            if len({m // 3 for m in grounded}) < len(grounded):
                continue  # two members of one set held: the set is locked
            for train in _trains_grounded(n_sets, pairs, glued, members, reduced, grounded, n_links, bare_input, perms):
                if grounded:  # one representative across the grounded choices too
                    code = min(_train_code(train.links, train.grounded, p) for p in perms)
                    if code in seen:
                        continue
                    seen.add(code)
                out.append(train)
    return out


def _trains_grounded(n_sets, pairs, glued, members, reduced, grounded, n_links, bare_input, perms) -> list[Train]:
    """The trains of :func:`ravigneaux_trains` with the members ``grounded`` held."""
    out = []
    free = [m for m in members if m not in grounded]
    for bare in ((0, 1) if bare_input else (0,)):
        target = n_links - bare
        rows = []
        for blocks in _partitions([m for m in reduced if m not in grounded], target):
            block_of = {m: i for i, b in enumerate(blocks) for m in b}
            # a compound's small sun never on its own ring's or carrier's link (it would lock b)
            if any(3 * b in block_of and block_of[3 * b] in (block_of.get(3 * a + 1), block_of.get(3 * a + 2))
                   for a, b in pairs):
                continue
            rows.append([block_of[glued.get(m, m)] for m in free])
        if not rows:
            continue
        labels = np.array(rows, dtype=np.int64)
        codes = _canonical_codes(labels, free, grounded, perms)
        _, first = np.unique(codes, return_index=True)
        for row in sorted(first, key=lambda r: codes[r]):
            blocks = [tuple(m for c, m in enumerate(free) if labels[row, c] == b) for b in range(target)]
            train = Train(n_sets, tuple(sorted(blocks)) + (((),) if bare else ()), grounded, pairs)
            if not locked_pair(train):
                out.append(train)
    return out


def spec_trains(spec) -> list[Train]:
    """The gear trains of a :class:`transgen.synthesis.search.SearchSpec` (simple or compound)."""
    n_links = link_count(spec.planetaries, spec.engaged)
    if not spec.ravigneaux:
        return trains(spec.sets, n_links, max_grounded=spec.grounded)
    return ravigneaux_trains(spec.sets - spec.ravigneaux, spec.ravigneaux, n_links, max_grounded=spec.grounded)


def share_lines(train: Train) -> list[str]:
    """The ``share`` statements of the compounds (sets named ``P1 ..`` as in the ``.mech``)."""
    out = []
    for a, b in train.ravigneaux:
        pa, pb = f"P{a + 1}", f"P{b + 1}"
        out += [f"share {pa}.ring {pb}.ring            # one ring gear",
                f"share {pa}.carrier {pb}.carrier      # one carrier",
                f"share {pb}.outer_pinion {pa}.pinion  # the long pinion"]
    return out


def ravigneaux_teeth(fc, spec, rules, set_options, concept_text, per_set: int = 4):
    """Tooth counts of a fitted compound concept ``fc``: the simple sets outside compounds take
    each of their ``per_set`` admissible ``Nr/Ns`` closest to the fitted ``k``
    (``set_options(k, count)``), and for every such choice the compounds' teeth come from
    :func:`transgen.synthesis.teeth.synthesize_teeth` under ``rules`` and the shares, each target
    within ``spec.tolerance`` (relative). ``(teeth, ratios)``: ``(name, Ns, Nr, planets)`` of every
    set and the exact ratios of the best (largest error, then size), or ``(None, None)``."""
    from ..language import parse_mechanism
    from .teeth import RatioTarget, synthesize_teeth

    train = fc.concept.train
    paired = {s for pair in train.ravigneaux for s in pair}
    simple = [p for p in range(train.sets) if p not in paired]
    gears = dict(zip(spec.gears, fc.gears))
    targets = tuple(RatioTarget(g, repr(t), Fraction(spec.tolerance * abs(t)).limit_denominator(10 ** 9))
                    for g, t in zip(spec.gears, spec.targets))
    best = None
    for choice in itertools.product(*(set_options(fc.fit.k[p], per_set) for p in simple)):
        known = tuple((f"P{p + 1}", ns, nr, n) for p, (ns, nr, n) in zip(simple, choice))
        mech = parse_mechanism(concept_text(fc.concept, gears, None, known), "<candidate>", unknown_teeth=True)
        found = synthesize_teeth(mech, targets, rules, top=1)
        if not found.solutions:
            continue
        sol = found.solutions[0]
        every = {name: (name, ns, nr, n) for name, ns, nr, n in known}
        every.update({t.name: (t.name, t.n_sun, t.n_ring, t.planets) for t in sol.teeth})
        teeth = tuple(every.values())
        key = (sol.max_error, sum(ns + nr for _, ns, nr, _ in teeth))
        if best is None or key < best[0]:
            best = (key, tuple(sorted(teeth, key=lambda t: int(t[0][1:]))),
                    {g: float(r) for g, r in sol.ratios.items()})
    return (None, None) if best is None else best[1:]
