"""Shift-table synthesis: a gear table for a mechanism that has gearsets and shift elements.

1. **Candidates**: every combination of engaged elements that is a gear (a determined ratio, so
   no tie-up; a gear with idle members, :mod:`transgen.idle`, is one: an A340E's 1st leaves the
   hub between B2 and F1 idle), in which every engaged element is needed: an element that only
   repeats another's constraint, or only holds an idle hub (a link no gearset touches:
   :func:`transgen.idle.holds_only_idle`), is left out. Positive ratios are forward candidates, negative ones
   reverse candidates. A combination with a one-way clutch counts only where the clutch holds
   in drive: the quasi-static torque balance (input torque positive, inertias neglected) must
   load it against its free direction, else it would overrun and the gear would not exist.
2. **Forward sequences**: paths of ``N`` candidates with strictly falling ratios in which each
   shift changes one element (one released, one applied: a *single swap*) or, counted
   separately, two (a *double swap*); a depth-first search over this graph (a DAG ordered by
   ratio), every path scored.
3. **Reverse**: for each forward table the ``R`` reverse candidates with the best reverse term.

Score (larger is better), with the steps ``phi_i = i_i / i_(i+1)`` of the forward ratios::

    score = ln(spread)
            - 2.0 * sum_i out(phi_i)             out(phi) = max(0, ln(1.1/phi), ln(phi/1.8))
            - 1.0 * sum_i max(0, ln(phi_(i+1)/phi_i))   (a step larger than the one before it)
            - 0.5 * double swaps
            - 0.5 * upshifts that engage a dog element
            - 0.25 * gears whose number of engaged elements differs from the most common one
            + 0.05 * upshifts in which a one-way clutch releases (by itself: no clutch-to-clutch timing)
            + 0.01 * one-way clutches holding in the forward gears (no apply pressure: a tie-break)
            - for each reverse gear: 0.5 * (elements changed from 1st gear - 2)/2
                                     + 0.5 * |ln(|i_R| / i_1)|

A large spread is rewarded, steps outside about 1.1-1.8 and steps that grow toward the top gears
are penalised (a geometric or progressive table has none), double swaps cost half a unit each.

Dog clutches and brakes (``dog``) are shift elements like the others, but they engage only at
synchronous speed and carry no torque while slipping. In a power-on downshift the engine speeds up
while the offgoing element slips, and an oncoming dog locks when it reaches synchronism (the 9HP's
4th-to-5th and 7th-to-8th gears release its dogs on the upshift and engage them on the downshift);
in a power-on upshift the oncoming element must carry the torque while it slips to pull the engine
down, which a dog cannot: such a shift needs a torque interruption, and it costs as much as a double
swap. Every table lists the shifts in which a dog engages (``dog_shifts``: ``"4-5"`` an upshift,
``"5-4"`` a downshift, with the dog's name).
"""
from __future__ import annotations

import heapq
import itertools
import math
from collections import Counter
from dataclasses import dataclass

from ..errors import TransgenError
import numpy as np

from ..graph import TRANSFORMER_KINDS, bond_graph, coefficient, element_nodes, link_nodes, transformer_ports
from ..idle import gear_check, holds_only_idle
from ..kinematics import _values, analyze
from ..model import Mechanism

__all__ = ["ShiftTable", "TableSynthesis", "gear_candidates", "synthesize_table", "table_score", "STEP_RANGE"]

STEP_RANGE = (1.1, 1.8)
"""Comfortable range of the step between neighbouring forward gears."""

DOG_UPSHIFT_PENALTY = 0.5
"""Score per upshift whose oncoming elements include a dog (it cannot carry torque while slipping)."""

ONEWAY_BONUS = 0.05
"""Score per upshift in which a one-way clutch releases (by itself: no clutch-to-clutch timing)."""

HOLD_BONUS = 0.01
"""Score per one-way clutch holding in a forward gear: it needs no apply pressure, so of a one-way
clutch and a friction element in parallel the one-way clutch is preferred (a tie-break)."""

MAX_VISITS = 2_000_000
"""Most search nodes visited before the search stops (and says so)."""


class TableInputError(TransgenError, ValueError):
    """The request cannot be met: too few candidates, a gear table already given, ..."""


@dataclass(frozen=True)
class Candidate:
    engaged: frozenset
    ratio: float
    oneways: frozenset = frozenset()  # the engaged one-way clutches (each holding in drive)
    positions: frozenset = frozenset()  # the (link1, link2) pairs the engaged elements join
    where: tuple = ()  # (element, (link1, link2)) of each engaged element
    dogs: frozenset = frozenset()  # the engaged dog elements

    @property
    def names(self) -> tuple[str, ...]:
        """The engaged elements in the file's order."""
        return tuple(e for e, _ in self.where) if self.where else tuple(sorted(self.engaged))


@dataclass(frozen=True)
class ShiftTable:
    """One synthesised gear table: forward gears in order of falling ratio, then reverse gears."""

    forward: tuple[Candidate, ...]
    reverse: tuple[Candidate, ...]
    score: float
    double_swaps: tuple[tuple[str, str], ...]
    dog_shifts: tuple[tuple[str, str], ...] = ()
    """``(shift, dog)`` for every shift between neighbouring forward gears in which a dog engages:
    ``("4-5", "A")`` on the upshift, ``("5-4", "F")`` on the downshift."""

    @property
    def spread(self) -> float:
        return self.forward[0].ratio / self.forward[-1].ratio if len(self.forward) > 1 else 1.0

    @property
    def steps(self) -> tuple[float, ...]:
        return tuple(a.ratio / b.ratio for a, b in zip(self.forward, self.forward[1:]))

    @property
    def gears(self) -> dict[str, tuple[str, ...]]:
        """Gear names (1..N, then R, R2, ...) and their engaged elements, in element order."""
        out = {str(i + 1): c.names for i, c in enumerate(self.forward)}
        out.update({("R" if i == 0 else f"R{i + 1}"): c.names for i, c in enumerate(self.reverse)})
        return out

    @property
    def ratios(self) -> dict[str, float]:
        out = {str(i + 1): c.ratio for i, c in enumerate(self.forward)}
        out.update({("R" if i == 0 else f"R{i + 1}"): c.ratio for i, c in enumerate(self.reverse)})
        return out

    def mech_lines(self, order: tuple[str, ...] = ()) -> list[str]:
        """``gear NAME = ELEMENTS ratio=...`` lines (elements in ``order``, the file's order)."""
        rank = {name: i for i, name in enumerate(order)}
        lines = []
        for name, engaged in self.gears.items():
            elements = sorted(engaged, key=lambda e: rank.get(e, len(rank)))
            lines.append(f"gear {name} = {' '.join(elements)} ratio={self.ratios[name]:.4f}")
        return lines

    def to_dict(self) -> dict:
        return {"gears": {k: list(v) for k, v in self.gears.items()}, "ratios": self.ratios,
                "steps": list(self.steps), "spread": self.spread, "score": self.score,
                "double_swaps": [list(p) for p in self.double_swaps],
                "dog_shifts": [list(p) for p in self.dog_shifts]}


@dataclass(frozen=True)
class TableSynthesis:
    """The result of :func:`synthesize_table`: the best ``tables``, the candidates, notes."""

    mechanism: Mechanism
    tables: tuple[ShiftTable, ...]
    forward_candidates: int
    reverse_candidates: int
    searched: int
    complete: bool
    notes: tuple[str, ...] = ()

    UNITS = {"ratios": "1", "steps": "1", "spread": "1", "score": "1", "forward_candidates": "1",
             "reverse_candidates": "1", "sequences_scored": "1"}
    """Units of the numeric fields of :meth:`to_dict` (ratios: input speed / output speed)."""

    def to_dict(self) -> dict:
        return {"mechanism": self.mechanism.name, "score_formula": SCORE_FORMULA,
                "forward_candidates": self.forward_candidates, "reverse_candidates": self.reverse_candidates,
                "sequences_scored": self.searched, "complete": self.complete, "notes": list(self.notes),
                "tables": [t.to_dict() for t in self.tables]}


SCORE_FORMULA = ("ln(spread) - 2*sum out(step) - 1*sum max(0, ln(step[i+1]/step[i])) - 0.5*double swaps "
                 "- 0.5*upshifts that engage a dog "
                 "- 0.25*gears with an unusual element count + 0.05*upshifts released by a one-way clutch + 0.01*one-way clutches holding in forward gears - per reverse gear (0.5*(changes from 1st - 2)/2 "
                 "+ 0.5*|ln(|i_R|/i_1)|); out(step) = max(0, ln(1.1/step), ln(step/1.8))")


def gear_candidates(mech: Mechanism) -> list[Candidate]:
    """Every combination of engaged elements that is a gear (a determined, finite ratio; idle
    members allowed: :mod:`transgen.idle`) with no superfluous element (see the module
    docstring): no element only repeats another's constraint or only holds an idle hub
    (:func:`transgen.idle.holds_only_idle`)."""
    g = bond_graph(mech)
    names = element_nodes(g)
    free = analyze(mech, (), g).dof
    out = []
    if free < 1:
        return []  # locked without any element engaged
    checks: dict[tuple[str, ...], object] = {}

    def check(combo):
        if combo not in checks:
            checks[combo] = gear_check(mech, combo, g)
        return checks[combo]

    # each engaged element removes one DOF: a gear engages at most free - 1 (fewer with idle members)
    for combo in (c for r in range(1, free) for c in itertools.combinations(names, r)):
        c = check(combo)
        if not (c.is_gear and c.ratio is not None and math.isfinite(c.ratio)):
            continue
        if any(holds_only_idle(c, check(tuple(x for x in combo if x != e))) for e in combo):
            continue  # an element that only repeats another's constraint or holds an idle hub
        if _oneways_hold(mech, combo, g) is not False:
            oneways = frozenset(e for e in combo if g.nodes[e]["kind"] == "oneway")
            where = tuple((e, (g.nodes[e]["link1"], g.nodes[e]["link2"])) for e in combo)
            dogs = frozenset(e for e in combo if g.nodes[e]["kind"] == "dog")
            out.append(Candidate(frozenset(combo), c.ratio, oneways, frozenset(p for _, p in where), where, dogs))
    return out


def oneway_torques(mech: Mechanism, engaged, g=None) -> dict[str, float] | None:
    """Torques of the engaged one-way clutches in a quasi-static drive (input torque 1 N*m,
    inertias neglected), by the sign convention of :mod:`transgen.model`; ``None`` when the
    static torques are not unique.

    Unknowns: the tooth force of each transformer (its port torques proportional to the port
    coefficients ``c_k``), the torque of each engaged element and the output torque; one torque
    balance per link.
    """
    g = bond_graph(mech) if g is None else g
    links = link_nodes(g)
    row = {name: i for i, name in enumerate(links)}
    transformers = [n for n, d in g.nodes(data=True) if d["kind"] in TRANSFORMER_KINDS]
    values = _values(g)
    engaged = list(engaged)
    m = np.zeros((len(links), len(transformers) + len(engaged) + 1))
    b = np.zeros(len(links))
    for j, node in enumerate(transformers):
        for link, _, terms in transformer_ports(g, node):
            if link in row:
                m[row[link], j] -= float(coefficient(terms, values))
    for j, name in enumerate(engaged):
        data = g.nodes[name]
        m[row[data["link1"]], len(transformers) + j] -= 1.0
        if data["link2"] in row:
            m[row[data["link2"]], len(transformers) + j] += 1.0
    m[row[mech.output], -1] = -1.0
    b[row[mech.input]] = -1.0
    if np.linalg.matrix_rank(m) < m.shape[1]:
        return None
    x = np.linalg.lstsq(m, b, rcond=None)[0]
    return {name: float(x[len(transformers) + j]) for j, name in enumerate(engaged)
            if g.nodes[name]["kind"] == "oneway"}


def _oneways_hold(mech: Mechanism, engaged, g) -> bool | None:
    """Whether every engaged one-way clutch carries its drive torque in its locking direction
    (``None``: no one-way clutch engaged)."""
    if not any(g.nodes[e]["kind"] == "oneway" for e in engaged):
        return None
    torques = oneway_torques(mech, engaged, g)
    if torques is None:
        return False
    for name, t in torques.items():
        free = g.nodes[name]["free"]
        if (free == "positive" and t > 1e-9) or (free == "negative" and t < -1e-9):
            return False  # it would overrun: the gear does not hold in drive
    return True


def _changes(a: Candidate, b: Candidate) -> int:
    """Elements changed in a shift from ``a`` to ``b``: 2 is a single swap, 4 a double swap.

    Elements that join the same two links (a brake and a one-way clutch in parallel) count as
    one: handing the torque from one to the other changes no constraint."""
    return len(a.positions ^ b.positions)


def _out(step: float) -> float:
    low, high = STEP_RANGE
    return max(0.0, math.log(low / step), math.log(step / high))


def _oneway_releases(a: Candidate, b: Candidate) -> int:
    """One-way clutches of ``a`` whose constraint is gone in ``b``: they release by themselves in
    the shift from ``a`` to ``b`` (no clutch-to-clutch timing)."""
    return sum(1 for e, position in a.where if e in a.oneways and position not in b.positions)


def _dog_engagements(a: Candidate, b: Candidate) -> frozenset:
    """The dogs that engage in the shift from ``a`` to ``b``."""
    return b.dogs - a.dogs


def table_score(ratios: list[float], counts: list[int], doubles: int, releases: int = 0, holding: int = 0,
                dog_upshifts: int = 0) -> float:
    """The forward part of the score (see the module docstring)."""
    steps = [a / b for a, b in zip(ratios, ratios[1:])]
    score = math.log(ratios[0] / ratios[-1]) if len(ratios) > 1 else 0.0
    score -= 2.0 * sum(_out(s) for s in steps)
    score -= 1.0 * sum(max(0.0, math.log(b / a)) for a, b in zip(steps, steps[1:]))
    score -= 0.5 * doubles
    score -= DOG_UPSHIFT_PENALTY * dog_upshifts
    usual = Counter(counts).most_common(1)[0][0]
    score -= 0.25 * sum(1 for c in counts if c != usual)
    return score + ONEWAY_BONUS * releases + HOLD_BONUS * holding


def _reverse_term(first: Candidate, rev: Candidate) -> float:
    return 0.5 * max(0, _changes(first, rev) - 2) / 2 + 0.5 * abs(math.log(abs(rev.ratio) / first.ratio))


def synthesize_table(mech: Mechanism, forward: int, reverse: int = 1, top: int = 5,
                     allow_double: bool = True, progress=None) -> TableSynthesis:
    """The ``top`` best gear tables of ``forward`` forward and ``reverse`` reverse gears.

    Raises :class:`TableInputError` when there are fewer candidates than gears asked for.
    """
    if forward < 1 or reverse < 0 or top < 1:
        raise TableInputError(f"need --forward >= 1, --reverse >= 0 and --top >= 1 (got {forward}, {reverse}, {top})")
    candidates = gear_candidates(mech)
    fwd = sorted((c for c in candidates if c.ratio > 0), key=lambda c: -c.ratio)
    rev = sorted((c for c in candidates if c.ratio < 0), key=lambda c: c.ratio)
    distinct = len({round(c.ratio, 9) for c in fwd})
    if distinct < forward:
        raise TableInputError(f"{mech.source}: only {distinct} distinct forward ratios among the {len(fwd)} "
                              f"combinations that are gears; {forward} forward gears asked for")
    if len(rev) < reverse:
        raise TableInputError(f"{mech.source}: only {len(rev)} reverse combinations; {reverse} reverse gears asked for")
    limit = 4 if allow_double else 2
    succ = [[j for j in range(i + 1, len(fwd))
             if fwd[i].ratio > fwd[j].ratio * (1 + 1e-9) and _changes(fwd[i], fwd[j]) <= limit]
            for i in range(len(fwd))]
    keep = max(50, 10 * top)
    heap: list[tuple[float, int, tuple[int, ...]]] = []
    visits = 0
    tick = 0
    path: list[int] = []

    def visit(i: int) -> bool:
        nonlocal visits, tick
        visits += 1
        if visits > MAX_VISITS:
            return False
        path.append(i)
        if len(path) == forward:
            ratios = [fwd[k].ratio for k in path]
            counts = [len(fwd[k].engaged) for k in path]
            doubles = sum(1 for a, b in zip(path, path[1:]) if _changes(fwd[a], fwd[b]) > 2)
            releases = sum(_oneway_releases(fwd[a], fwd[b]) for a, b in zip(path, path[1:]))
            holding = sum(len(fwd[k].oneways) for k in path)
            dog_up = sum(1 for a, b in zip(path, path[1:]) if _dog_engagements(fwd[a], fwd[b]))
            score = table_score(ratios, counts, doubles, releases, holding, dog_up)
            tick += 1
            item = (score, -tick, tuple(path))
            if len(heap) < keep:
                heapq.heappush(heap, item)
            elif item > heap[0]:
                heapq.heapreplace(heap, item)
        else:
            for j in succ[i]:
                if len(fwd) - j < forward - len(path):
                    break
                if not visit(j):
                    path.pop()
                    return False
        path.pop()
        return True

    complete = True
    for i in range(len(fwd) - forward + 1):
        if progress:
            progress(f"forward sequences from candidate {i + 1}/{len(fwd) - forward + 1}")
        if not visit(i):
            complete = False
            break
    tables = []
    for score, _, seq in heap:
        first = fwd[seq[0]]
        chosen, total = [], score
        for c in sorted(rev, key=lambda c: _reverse_term(first, c)):
            if len(chosen) == reverse:
                break
            if all(abs(c.ratio - o.ratio) > 1e-9 * abs(c.ratio) for o in chosen):
                chosen.append(c)
                total -= _reverse_term(first, c)
        doubles = tuple((str(k + 1), str(k + 2)) for k, (a, b) in enumerate(zip(seq, seq[1:]))
                        if _changes(fwd[a], fwd[b]) > 2)
        dog_shifts = []
        for k, (a, b) in enumerate(zip(seq, seq[1:])):
            up, down = f"{k + 1}-{k + 2}", f"{k + 2}-{k + 1}"
            dog_shifts += [(up, d) for d in sorted(_dog_engagements(fwd[a], fwd[b]))]
            dog_shifts += [(down, d) for d in sorted(_dog_engagements(fwd[b], fwd[a]))]
        tables.append(ShiftTable(tuple(fwd[k] for k in seq), tuple(chosen), total, doubles, tuple(dog_shifts)))
    tables.sort(key=lambda t: -t.score)
    notes = []
    if not complete:
        notes.append(f"search stopped after {MAX_VISITS} nodes: the tables are the best of those seen, not "
                     f"certainly the best")
    if not tables:
        notes.append("no sequence of forward gears with single or double swaps exists")
    return TableSynthesis(mech, tuple(tables[:top]), len(fwd), len(rev), tick, complete, tuple(notes))
