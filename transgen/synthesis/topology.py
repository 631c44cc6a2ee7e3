"""Concept enumeration for ``transgen synthesize topology``: gear trains, shift elements, canonical forms.

A **concept** is ``N`` simple planetary sets (members sun, ring, carrier; set ``p``'s basic
ratio ``k_p = Nr/Ns``) whose ``3N`` members are joined into *links* by permanent connections,
plus at most one *bare input shaft* (a link with no member, reached only through clutches, as
the Simpson's input), the input link, the output link, ``B`` brakes (link to housing) and ``C``
clutches (link to link). A gear engages ``K`` elements; with ``L`` links the gear train has
``L - N`` degrees of freedom, so a gear is one degree of freedom iff ``L = N + K + 1``: the
number of links is fixed by ``N`` and ``K``.

The search space (what :func:`enumerate_concepts` walks) and why each rule loses no design:

* a link holds at most one member of each set (two members of one set in one link lock the set:
  it turns as a block and is no gearset);
* the output is a member link (an output shaft reached only through clutches has no gear with
  the clutch open: it is the same mechanism with the clutch's other link as output in every gear
  that uses it); the input is a member link or the bare shaft;
* no brake on the input or the output (a gear with it engaged holds the input or the output);
* no two sets on the same three links (they lock each other, or one is redundant:
  :func:`locked_pair`);
* no member is fixed to the housing (``grounded``: a fixed member makes a simple set a fixed
  reduction; allowed on request with ``max_grounded``).

Ravigneaux compounds (``Train.ravigneaux``, :mod:`transgen.synthesis.ravigneaux`) are a simple
and a double-pinion set whose ring and carrier are one link each; their symmetries are those of
:func:`set_permutations` (kinds kept, the two suns never swapped).

Symmetries removed (:func:`canonical_key`): the ``N!`` permutations of the sets, the order of
the links (a link is named by the members it joins, so relabelling links changes nothing), the
order of the brakes and clutches and the two ends of each clutch. The sun/ring reflection of a
set maps ``k`` to ``1/k``, outside the ring/sun bounds (``1 < k_min``), so it is no symmetry of
the bounded problem. A concept's key is the smallest encoding over the set permutations; two
concepts are isomorphic iff their keys are equal.

Early pruning (:func:`feasible_mask`, before any ratio is fitted), at a generic point ``k``
(deterministic, inside the bounds): a concept is *feasible* when at least ``G`` (the number of
target gears) of its ``K``-element combinations are gears (one degree of freedom, input and
output turning) with pairwise different ratios, every element takes part in at least one such
gear (else it is superfluous: the same concept without it is smaller), and every link is the
input or the output, or joins two or more members, or carries an element (a single member with
nothing on it leaves its set without any effect: a smaller concept). A property that holds at a
generic point holds for almost every ``k`` (the conditions are polynomial in ``k``), so nothing
that could meet the targets is dropped.
"""
from __future__ import annotations

import itertools
import math
from dataclasses import dataclass

import numpy as np

__all__ = [
    "MEMBERS", "Train", "set_permutations", "Concept", "trains", "train_automorphisms", "canonical_key", "link_count",
    "placements", "count_orbits", "locked_pair", "TrainKinematics", "train_kinematics", "sample_speeds", "feasible_mask", "rank_mask", "row_masks",
]

MEMBERS = ("S", "R", "C")
"""Member letters: sun, ring, carrier (member ``3p + j`` is letter ``j`` of set ``p``)."""

BARE = -1
"""Member code of the bare input shaft in the encodings."""


def link_count(n_sets: int, engaged: int) -> int:
    """Links of a concept whose gears engage ``engaged`` elements with one degree of freedom."""
    return n_sets + engaged + 1


@dataclass(frozen=True)
class Train:
    """The sets' members joined into links: ``links[i]`` the member indices of link ``i``
    (``()``: the bare input shaft); ``grounded`` the members fixed to the housing."""

    sets: int
    links: tuple[tuple[int, ...], ...]
    grounded: tuple[int, ...] = ()
    ravigneaux: tuple[tuple[int, int], ...] = ()
    """The Ravigneaux compounds ``(a, b)``: set ``a`` simple (large sun, long pinion), set ``b``
    double-pinion (small sun), one ring and one carrier (:mod:`transgen.synthesis.ravigneaux`)."""

    @property
    def double_pinion(self) -> frozenset[int]:
        """The double-pinion sets (``w_s - k w_r + (k - 1) w_c = 0``)."""
        return frozenset(b for _, b in self.ravigneaux)

    @property
    def bare(self) -> int | None:
        """Index of the bare input shaft, ``None`` when there is none."""
        return next((i for i, m in enumerate(self.links) if not m), None)

    def link_of(self) -> dict[int, int]:
        """Member index -> link index (grounded members absent)."""
        return {m: i for i, members in enumerate(self.links) for m in members}

    def link_name(self, i: int) -> str:
        """``S1_S2``, ``C3``, ``IN`` (the bare shaft): the members a link joins, set numbers from 1."""
        members = self.links[i]
        if not members:
            return "IN"
        return "_".join(f"{MEMBERS[m % 3]}{m // 3 + 1}" for m in members)


def set_permutations(train: Train) -> list[tuple[int, ...]]:
    """The set permutations that keep each set's kind: any permutation of the simple sets outside
    compounds times any permutation of the Ravigneaux compounds as wholes (a compound's two sets
    are not interchangeable: their suns mesh different pinions); the identity first."""
    if not train.ravigneaux:
        return list(itertools.permutations(range(train.sets)))
    paired = {s for pair in train.ravigneaux for s in pair}
    simple = [p for p in range(train.sets) if p not in paired]
    out = []
    for ps in itertools.permutations(simple):
        for pr in itertools.permutations(range(len(train.ravigneaux))):
            perm = list(range(train.sets))
            for a, b in zip(simple, ps):
                perm[a] = b
            for q, r in enumerate(pr):
                for x, y in zip(train.ravigneaux[q], train.ravigneaux[r]):
                    perm[x] = y
            out.append(tuple(perm))
    return out


def _perm_members(members, perm) -> tuple[int, ...]:
    return tuple(sorted(3 * perm[m // 3] + m % 3 for m in members))


def _train_code(links, grounded, perm) -> tuple:
    mapped = sorted(_perm_members(m, perm) if m else (BARE,) for m in links)
    return tuple(mapped), _perm_members(grounded, perm)


def trains(n_sets: int, n_links: int, bare_input: bool = True, max_grounded: int = 0) -> list[Train]:
    """Every gear train of ``n_sets`` simple sets with ``n_links`` links (the bare input shaft
    counted when there is one), one per class of set permutations, in a fixed order (links
    sorted by their member tuples; trains by their canonical code)."""
    n_members = 3 * n_sets
    perms = list(itertools.permutations(range(n_sets)))
    out: list[Train] = []
    for bare in ((0, 1) if bare_input else (0,)):
        target = n_links - bare
        for grounded_count in range(max_grounded + 1):
            for grounded in itertools.combinations(range(n_members), grounded_count):
                if len({m // 3 for m in grounded}) < grounded_count:
                    continue  # two members of one set grounded: the set is locked
                rest = [m for m in range(n_members) if m not in grounded]
                labels = np.array([[next(b for b, block in enumerate(blocks) if m in block) for m in rest]
                                   for blocks in _partitions(rest, target)], dtype=np.int64).reshape(-1, len(rest))
                if not len(labels):
                    continue
                codes = _canonical_codes(labels, rest, grounded, perms)
                _, first = np.unique(codes, return_index=True)
                for row in sorted(first, key=lambda r: codes[r]):
                    blocks = [tuple(m for m, lab in zip(rest, labels[row]) if lab == b) for b in range(target)]
                    links = tuple(sorted(blocks)) + (((),) if bare else ())
                    train = Train(n_sets, links, tuple(grounded))
                    if not locked_pair(train):
                        out.append(train)
    # one representative per class across the grounded choices too (a set permutation may map
    # one grounded choice onto another)
    seen, unique = set(), []
    for t in out:
        code = min(_train_code(t.links, t.grounded, p) for p in perms) if t.grounded else None
        if code is not None and code in seen:
            continue
        if code is not None:
            seen.add(code)
        unique.append(t)
    return unique


def locked_pair(train: Train) -> bool:
    """Whether two sets have their three members on the same three links (in any order): two
    independent constraints on three speeds leave only the block rotation, so the pair is locked
    (in the same order with equal ``k``, one set is redundant): a concept of fewer sets."""
    link_of = train.link_of()
    on = [frozenset(link_of.get(3 * p + j, -1 - 3 * p - j) for j in range(3)) for p in range(train.sets)]
    return len(set(on)) < len(on)


def _canonical_codes(labels: np.ndarray, members: list[int], grounded, perms) -> np.ndarray:
    """Smallest code over the set permutations of each partition (rows: the block of each of
    ``members``), vectorised: the members are reordered by the permutation, the block labels
    renumbered by first occurrence, and the label vector read as a base-``b`` integer."""
    n_blocks = int(labels.max()) + 1
    position = {m: j for j, m in enumerate(members)}
    best = None
    for perm in perms:
        image = [3 * perm[m // 3] + m % 3 for m in members]
        if sorted(3 * perm[m // 3] + m % 3 for m in grounded) != sorted(grounded):
            continue  # this permutation moves the grounded members: another class
        # column j of the permuted partition is the member that the permutation sends to members[j]
        inverse = {img: m for m, img in zip(members, image)}
        cols = [position[inverse[m]] for m in members]
        lab = labels[:, cols]
        first = np.stack([np.where(lab == b, np.arange(lab.shape[1]), lab.shape[1]).min(axis=1)
                          for b in range(n_blocks)], axis=1)
        rank = np.argsort(np.argsort(first, axis=1), axis=1)
        renamed = np.take_along_axis(rank, lab, axis=1)
        code = np.zeros(len(lab), dtype=np.int64)
        for j in range(lab.shape[1]):
            code = code * n_blocks + renamed[:, j]
        best = code if best is None else np.minimum(best, code)
    return best


def _partitions(members: list[int], blocks: int):
    """Set partitions of ``members`` into exactly ``blocks`` blocks, no block with two members of
    one set (members in increasing order; blocks in order of their smallest member)."""
    n = len(members)
    current: list[list[int]] = []

    def rec(i: int):
        if len(current) + (n - i) < blocks:
            return
        if i == n:
            if len(current) == blocks:
                yield [list(b) for b in current]
            return
        m = members[i]
        for b in current:
            if all(x // 3 != m // 3 for x in b):
                b.append(m)
                yield from rec(i + 1)
                b.pop()
        if len(current) < blocks:
            current.append([m])
            yield from rec(i + 1)
            current.pop()

    yield from rec(0)


def train_automorphisms(train: Train) -> list[tuple[tuple[int, ...], tuple[int, ...]]]:
    """``(set permutation, link permutation)`` of every set permutation that maps ``train`` onto
    itself (the identity first); the link permutation sends link ``i`` to link ``pi[i]``."""
    index = {m if m else (BARE,): i for i, m in enumerate(train.links)}
    out = []
    for perm in set_permutations(train):
        images = [(_perm_members(m, perm) if m else (BARE,)) for m in train.links]
        if all(img in index for img in images) and _perm_members(train.grounded, perm) == train.grounded:
            out.append((perm, tuple(index[img] for img in images)))
    out.sort(key=lambda a: a[0] != tuple(range(train.sets)))
    return out


@dataclass(frozen=True)
class Concept:
    """A gear train with its input, output, brakes (link indices) and clutches (link pairs, the
    smaller index first), all in the train's link indices."""

    train: Train
    input: int
    output: int
    brakes: tuple[int, ...]
    clutches: tuple[tuple[int, int], ...]

    @property
    def elements(self) -> tuple[tuple[str, tuple[int, ...]], ...]:
        """``(name, links)`` of every element: brakes first (A, B, ...), then clutches."""
        out = [(chr(ord("A") + i), (b,)) for i, b in enumerate(self.brakes)]
        out += [(chr(ord("A") + len(self.brakes) + i), c) for i, c in enumerate(self.clutches)]
        return tuple(out)

    def key(self) -> tuple:
        """The canonical key (see :func:`canonical_key`)."""
        return canonical_key(self)


def _concept_code(c: Concept, perm) -> tuple:
    def enc(i):
        m = c.train.links[i]
        return _perm_members(m, perm) if m else (BARE,)

    train_code = _train_code(c.train.links, c.train.grounded, perm)
    return (train_code, enc(c.input), enc(c.output), tuple(sorted(enc(b) for b in c.brakes)),
            tuple(sorted(tuple(sorted((enc(a), enc(b)))) for a, b in c.clutches)))


def canonical_key(c: Concept) -> tuple:
    """The smallest label-free encoding of ``c`` over all permutations of its sets: links named
    by their members, clutch ends and element order sorted (kind-keeping permutations only,
    :func:`set_permutations`; the compounds are part of the key). Equal keys = isomorphic concepts."""
    return min(_concept_code(c, p) for p in set_permutations(c.train)) + (c.train.ravigneaux,)


def placements(train: Train, n_brakes: int, n_clutches: int):
    """Every ``(input, output, brakes, clutches)`` of the search space on ``train`` (see the module
    docstring), in a fixed order."""
    n = len(train.links)
    bare = train.bare
    pairs = list(itertools.combinations(range(n), 2))
    for i in ([bare] if bare is not None else range(n)):
        for o in range(n):
            if o == i or o == bare:
                continue
            brake_links = [l for l in range(n) if l not in (i, o) and l != bare]
            for bs in itertools.combinations(brake_links, n_brakes):
                for cs in itertools.combinations(pairs, n_clutches):
                    yield i, o, bs, cs


def _subset_count(cycles: list[int], size: int) -> int:
    """Subsets of ``size`` items that are unions of whole cycles (lengths ``cycles``)."""
    ways = [1] + [0] * size
    for length in cycles:
        for s in range(size, length - 1, -1):
            ways[s] += ways[s - length]
    return ways[size]


def _cycles(perm: dict) -> list[int]:
    seen, out = set(), []
    for start in perm:
        if start in seen:
            continue
        length, x = 0, start
        while x not in seen:
            seen.add(x)
            x = perm[x]
            length += 1
        out.append(length)
    return out


def count_orbits(train: Train, n_brakes: int, n_clutches: int, automorphisms=None) -> tuple[int, int]:
    """``(placements, distinct)``: the number of placements on ``train`` and of their classes
    under the train's automorphisms (Burnside's lemma: the mean number of fixed placements)."""
    autos = train_automorphisms(train) if automorphisms is None else automorphisms
    n = len(train.links)
    bare = train.bare
    pairs = list(itertools.combinations(range(n), 2))
    total_fixed = 0
    raw = 0
    for a, (_, pi) in enumerate(autos):
        fixed = 0
        for i in ([bare] if bare is not None else range(n)):
            for o in range(n):
                if o == i or o == bare:
                    continue
                brake_links = [l for l in range(n) if l not in (i, o) and l != bare]
                nb = math.comb(len(brake_links), n_brakes)
                nc = math.comb(len(pairs), n_clutches)
                if a == 0:
                    raw += nb * nc
                if pi[i] != i or pi[o] != o:
                    continue
                fb = _subset_count(_cycles({l: pi[l] for l in brake_links}), n_brakes)
                pair_perm = {p: tuple(sorted((pi[p[0]], pi[p[1]]))) for p in pairs}
                fc = _subset_count(_cycles(pair_perm), n_clutches)
                fixed += fb * fc
        total_fixed += fixed
    return raw, total_fixed // len(autos)


# ------------------------------------------------------------------------------ kinematics


@dataclass(frozen=True)
class TrainKinematics:
    """Every ``K``-combination of candidate elements of a train, evaluated at sample points.

    ``candidates[e]`` = ``(link,)`` (a brake) or ``(l1, l2)`` (a clutch); ``combos`` (T x K) the
    candidate indices of each combination; ``lookup`` maps a sorted K-tuple of candidate indices
    (flattened, base ``len(candidates)``) to its row in ``combos``. ``speeds`` (T x 1 x L): the
    link speeds of the gear (the null vector of the engaged elements' constraints, scaled to unit
    norm in the train's speed space) at the generic point ``k``; ``moves`` (T x L) whether a link
    turns in that gear there; ``rank_ok`` (T) one degree of freedom there.
    """

    train: Train
    engaged: int
    candidates: tuple[tuple[int, ...], ...]
    combos: np.ndarray
    lookup: np.ndarray
    k: np.ndarray
    speeds: np.ndarray
    rank_ok: np.ndarray
    moves: np.ndarray

    def combo_ids(self, elements: np.ndarray) -> np.ndarray:
        """Rows of ``combos`` of every K-subset of each row of ``elements`` (candidate indices,
        sorted ascending per row): shape (rows, C(E, K))."""
        n = len(self.candidates)
        cols = []
        for sub in itertools.combinations(range(elements.shape[1]), self.engaged):
            code = np.zeros(elements.shape[0], dtype=np.int64)
            for j in sub:
                code = code * n + elements[:, j]
            cols.append(self.lookup[code])
        return np.stack(cols, axis=1)


def speed_basis(train: Train, k: np.ndarray) -> np.ndarray:
    """Orthonormal bases (P x L x D) of the link speeds allowed by the sets at each row of ``k``
    (P x N): the null space of ``A(k)``, row ``p``: ``w_s + k_p w_r - (1 + k_p) w_c = 0`` (a
    double-pinion set: ``w_s - k_p w_r + (k_p - 1) w_c = 0``; both affine in ``k_p``)."""
    k = np.atleast_2d(k)
    link_of = train.link_of()
    n_links = len(train.links)
    a = np.zeros((k.shape[0], train.sets, n_links))
    double = train.double_pinion
    for p in range(train.sets):
        coeffs = ((np.ones(k.shape[0]), -k[:, p], k[:, p] - 1) if p in double else
                  (np.ones(k.shape[0]), k[:, p], -(1 + k[:, p])))
        for j, coeff in enumerate(coeffs):
            m = 3 * p + j
            if m in link_of:
                a[:, p, link_of[m]] += coeff
    _, _, vt = np.linalg.svd(a)
    basis = np.transpose(vt[:, train.sets:, :], (0, 2, 1)).copy()
    # orientation: det([A; V^T]) > 0, so that the gear speeds V q (q the cofactors of the element
    # rows in the basis) are the cofactors of [A; E] times a positive factor: their signs are
    # those of polynomials in k (what the interval screen of transgen.synthesis.fit relies on)
    flip = np.linalg.det(np.concatenate([a, np.transpose(basis, (0, 2, 1))], axis=1)) < 0
    basis[flip, :, -1] *= -1
    return basis


def _null_vectors(e: np.ndarray) -> np.ndarray:
    """Generalised cross product of the rows of ``e`` (..., K, K+1): ``q_j = (-1)^j det(e without
    column j)``, orthogonal to the rows, zero when they are dependent (closed forms for K <= 3)."""
    k, d = e.shape[-2], e.shape[-1]
    if k == 1:
        return np.stack([e[..., 0, 1], -e[..., 0, 0]], axis=-1)
    if k == 2:
        return np.cross(e[..., 0, :], e[..., 1, :])
    if k == 3:
        a, b, c = e[..., 0, :], e[..., 1, :], e[..., 2, :]

        def m(i, j):
            return b[..., i] * c[..., j] - b[..., j] * c[..., i]

        m01, m02, m03, m12, m13, m23 = m(0, 1), m(0, 2), m(0, 3), m(1, 2), m(1, 3), m(2, 3)
        return np.stack([a[..., 1] * m23 - a[..., 2] * m13 + a[..., 3] * m12,
                         -(a[..., 0] * m23 - a[..., 2] * m03 + a[..., 3] * m02),
                         a[..., 0] * m13 - a[..., 1] * m03 + a[..., 3] * m01,
                         -(a[..., 0] * m12 - a[..., 1] * m02 + a[..., 2] * m01)], axis=-1)
    out = np.empty(e.shape[:-2] + (d,))
    for j in range(d):
        out[..., j] = (-1) ** j * np.linalg.det(np.delete(e, j, axis=-1))
    return out


def _gear_speeds(train: Train, cands, combos: np.ndarray, k: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Link speeds (T x P x L, unit norm in the speed space; zero where not one degree of
    freedom) of the combinations ``combos`` of candidate elements at the points ``k``, and
    whether each has one degree of freedom (T x P)."""
    n_links = len(train.links)
    basis = speed_basis(train, k)  # P x L x D
    vec = np.zeros((len(cands), n_links))
    for e, c in enumerate(cands):
        vec[e, c[0]] = 1.0
        if len(c) == 2:
            vec[e, c[1]] = -1.0
    ev = np.einsum("el,pld->ped", vec, basis)  # P x n x D
    rows = ev[:, combos, :]  # P x T x K x D
    q = _null_vectors(rows)  # P x T x D
    norm = np.linalg.norm(q, axis=-1, keepdims=True)
    scale = np.prod(np.linalg.norm(rows, axis=-1), axis=-1)[..., None]  # Hadamard's bound of the minors
    ok = norm > 1e-9 * np.maximum(scale, 1e-300)
    q = np.where(ok, q / np.where(norm > 0, norm, 1.0), 0.0)
    return np.einsum("pld,ptd->tpl", basis, q), ok[..., 0].T


def train_kinematics(train: Train, engaged: int, k: np.ndarray) -> TrainKinematics:
    """:class:`TrainKinematics` of ``train`` at the generic point ``k`` (one row)."""
    n_links = len(train.links)
    cands = [(l,) for l in range(n_links) if train.links[l]] + list(itertools.combinations(range(n_links), 2))
    n = len(cands)
    combos = np.array(list(itertools.combinations(range(n), engaged)), dtype=np.int64).reshape(-1, engaged)
    lookup = np.full(n ** engaged, -1, dtype=np.int64)
    codes = np.zeros(len(combos), dtype=np.int64)
    for j in range(engaged):
        codes = codes * n + combos[:, j]
    lookup[codes] = np.arange(len(combos))
    speeds, ok = _gear_speeds(train, cands, combos, np.atleast_2d(k))
    moves = np.abs(speeds[:, 0, :]) > 1e-9
    return TrainKinematics(train, engaged, tuple(cands), combos, lookup, np.atleast_2d(k), speeds, ok[:, 0], moves)


def sample_speeds(kin: TrainKinematics, rows: np.ndarray, k: np.ndarray) -> np.ndarray:
    """Link speeds (len(rows) x P x L) of the combinations ``rows`` (indices into
    ``kin.combos``) at the points ``k``."""
    return _gear_speeds(kin.train, kin.candidates, kin.combos[rows], k)[0]


def rank_mask(kin: TrainKinematics, elements: np.ndarray, gears: int) -> tuple[np.ndarray, np.ndarray]:
    """``(keep, ids)``: the placements (rows of sorted candidate indices) with at least ``gears``
    combinations of one degree of freedom at the generic point (a condition that does not depend
    on the input and output, checked once per train), and their combination rows."""
    ids = kin.combo_ids(elements)
    return kin.rank_ok[ids].sum(axis=1) >= gears, ids


def pack_bits(flags: np.ndarray) -> np.ndarray:
    """Boolean flags along the last axis (at most 64) as one unsigned integer each (bit ``s`` =
    ``flags[..., s]``), of the narrowest width that holds them."""
    n = flags.shape[-1]
    width = next(w for w in (1, 2, 4, 8) if 8 * w >= n)
    packed = np.packbits(flags, axis=-1, bitorder="little")
    pad = width - packed.shape[-1]
    if pad:
        packed = np.concatenate([packed, np.zeros(packed.shape[:-1] + (pad,), dtype=np.uint8)], axis=-1)
    return np.ascontiguousarray(packed).view(f"<u{width}")[..., 0]


def row_masks(kin: TrainKinematics, elements: np.ndarray, ids: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Bit masks of placements (rows of ``elements``, ``ids`` their combinations), computed once
    per train for :func:`feasible_mask`: ``(gear, turns, touched)``: which combinations (bit
    ``s``) have one degree of freedom at the generic point, which of those turn link ``l``
    (rows x L), which links (bit ``l``) carry an element."""
    gear = pack_bits(kin.rank_ok[ids])
    turns = pack_bits(np.transpose(kin.moves[ids], (0, 2, 1)))
    n_links = len(kin.train.links)
    touch = np.zeros((len(kin.candidates), n_links), dtype=bool)
    for e, c in enumerate(kin.candidates):
        touch[e, list(c)] = True
    touched = pack_bits(touch[elements].any(axis=1))
    return gear, turns, touched


def feasible_mask(kin: TrainKinematics, i: int, o: int, elements: np.ndarray, gears: int,
                  ids: np.ndarray | None = None, necessary: bool = True, distinct: bool = True,
                  masks=None) -> np.ndarray:
    """Which placements (rows of ``elements``: sorted candidate indices, input ``i``, output
    ``o``) pass the early pruning of the module docstring for ``gears`` target gears.

    The rules of the search space (every element in some gear, no dead link) always apply; the
    necessary conditions of meeting ``gears`` targets (that many gears, ``distinct`` ones: pass
    ``False`` when two targets are within twice the tolerance) only with ``necessary``.
    ``masks``: :func:`row_masks` of the rows (computed here when not given)."""
    ids = kin.combo_ids(elements) if ids is None else ids
    gear, turns, touched = row_masks(kin, elements, ids) if masks is None else masks
    valid = gear & turns[:, i] & turns[:, o]  # bit s: a gear with input and output turning
    keep = np.bitwise_count(valid) >= (gears if necessary else 1)
    # no dead link: a single member with nothing on it (not input/output)
    single = touched.dtype.type(sum(1 << l for l, m in enumerate(kin.train.links) if len(m) == 1 and l not in (i, o)))
    keep &= (touched & single) == single
    # every element in some gear
    for j in range(elements.shape[1]):
        having = sum(1 << s_ for s_, subset in enumerate(itertools.combinations(range(elements.shape[1]),
                                                                               kin.engaged)) if j in subset)
        keep &= (valid & valid.dtype.type(having)) != 0
    if not (necessary and distinct and keep.any()):
        return keep
    # distinct ratios among the gears at the generic point
    rows = np.flatnonzero(keep)
    valid_combo = kin.rank_ok & kin.moves[:, i] & kin.moves[:, o]
    s = kin.speeds[:, 0, :]
    with np.errstate(all="ignore"):
        ratio = np.where(valid_combo, s[:, i] / np.where(valid_combo, s[:, o], 1.0), np.nan)
    r = np.sort(ratio[ids[rows]], axis=1)  # NaN last
    gaps = np.abs(np.diff(r, axis=1)) > 1e-7 * (1 + np.abs(r[:, 1:]))
    count = np.isfinite(r[:, 0]) + np.sum(gaps & np.isfinite(r[:, 1:]), axis=1)
    keep[rows] = count >= gears
    return keep
