"""``transgen synthesize topology``: the whole search, tooth counts, ranking and the candidates' files.

Stages (counts reported for each, see :class:`TopologySynthesis`):

1. **enumerated** - the concepts of the search space with the sets told apart (every gear train
   counted once per labelling of its sets), :mod:`transgen.synthesis.topology`;
2. **distinct** - one per isomorphism class (set permutations, links, element order, clutch ends);
3. **feasible** - the distinct concepts that pass the early pruning (enough one-DOF gears with
   different ratios, no superfluous element, no dead link), before any ratio is fitted;
4. **screened** / **refined** / **fitted** - the exact cell screen with distinct gears
   (:mod:`transgen.synthesis.screen`), the batched refinement and the
   exact fit of the basic ratios and the gear table (:mod:`transgen.synthesis.fit`): *fitted*
   concepts meet every target within ``tolerance`` (relative) with ``k`` in the ring/sun bounds;
5. **ranked** - the best fitted concepts by ratio error get tooth counts near their fitted
   ``k`` under the assembly rules of ``synthesize teeth``
   (:func:`transgen.synthesis.teeth.planet_count`) and the designer's
   figures from :func:`transgen.powerflow.power_flow` and
   :func:`transgen.synthesis.table.table_score`, and are ranked (see :data:`RANKING`).

The work is split by gear train (:func:`transgen.synthesis.search.train_task`): tasks are
independent, run on any executor with ``run(fn, shared, tasks)`` (the sweep's local processes or
Dask), and are merged in the trains' order, so the result does not depend on the executor.
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass, replace
from fractions import Fraction

from ..errors import TransgenError
from .search import FittedConcept, SearchSpec, TrainResult, train_task
from .ravigneaux import ravigneaux_teeth, share_lines, spec_trains
from .topology import Concept, link_count

__all__ = ["TopologyInputError", "Candidate", "TopologySynthesis", "synthesize_topology", "concept_text",
           "estimate_seconds", "rank_fitted", "RANKING", "MAX_SETS", "MAX_ELEMENTS"]

MAX_SETS = 4
"""Most planetary statements searched, a Ravigneaux compound counting two (4 simple sets: 8721
gear trains of 8 links)."""

MAX_ELEMENTS = 7
"""Most shift elements (brakes + clutches)."""

MAX_SECONDS = 6 * 3600
"""Estimated single-core run time above which a search is refused (say ``--max-hours``)."""

SECONDS_PER_PLACEMENT = 7.5e-8
"""Measured single-core cost per placement of a train (early pruning, screen and refinement of the
survivors; N = 4 with 2 brakes and 3 clutches, whose largest trains have 2.75 million
placements: the whole search of the 8721 trains took about 1870 s, docs/topology.md)."""

SECONDS_PER_TRAIN = 0.01
"""Measured single-core overhead per gear train (its kinematics)."""

RANKING = ("candidates with tooth counts first; then the largest relative ratio error in bins of a fifth of "
           "the tolerance; then the designer's cost = 10*(1 - mean forward efficiency) + 0.1*largest "
           "circulating power + 0.05*largest open-element slip + 0.02*largest element torque - 0.5*shift-table "
           "score (per unit input power, speed, torque; efficiency at eta0 = 0.98)")


class TopologyInputError(TransgenError, ValueError):
    """The request cannot be searched: sizes out of bounds, targets that make no sense (exit 2)."""


@dataclass(frozen=True)
class Candidate:
    """One ranked concept: the fit, the gear table, tooth counts (``None``: none found under the
    assembly rules), the ratios and errors (from the teeth when found, else the fit's) and the
    ranking figures; ``mech`` the complete ``.mech`` text."""

    rank: int
    concept: Concept
    k: tuple[float, ...]
    gears: dict
    ratios: dict
    errors: dict
    teeth: tuple | None
    figures: dict
    mech: str

    @property
    def max_ratio_error(self) -> float:
        return max(abs(e) for e in self.errors.values())

    def to_dict(self) -> dict:
        c = self.concept
        t = c.train
        return {
            "rank": self.rank, "max_ratio_error": self.max_ratio_error, "ratios": dict(self.ratios),
            "errors": dict(self.errors), "table": {g: list(e) for g, e in self.gears.items()},
            "k": {f"P{p + 1}": v for p, v in enumerate(self.k)},
            "teeth": ({name: {"Ns": ns, "Nr": nr, "planets": n} for name, ns, nr, n in self.teeth}
                      if self.teeth else None),
            "links": [t.link_name(i) for i in range(len(t.links))], "input": t.link_name(c.input),
            "output": t.link_name(c.output),
            "elements": {name: [t.link_name(l) for l in links] for name, links in c.elements},
            "figures": dict(self.figures), "mech": self.mech,
        }


@dataclass(frozen=True)
class TopologySynthesis:
    """The result: the request, the counts of every stage, the run time and the candidates."""

    spec: SearchSpec
    trains: int
    counts: dict
    seconds: float
    candidates: tuple[Candidate, ...]
    notes: tuple[str, ...] = ()

    UNITS = {"max_ratio_error": "1", "ratios": "1", "errors": "1", "k": "1", "seconds": "s", "counts": "1",
             "tolerance": "1", "targets": "1", "figures": "1 (per unit input speed, torque, power)", "Ns": "1",
             "Nr": "1", "planets": "1", "rank": "1"}

    def to_dict(self) -> dict:
        s = self.spec
        return {"request": {"sets": s.sets, "ravigneaux": s.ravigneaux, "grounded": s.grounded,
                            "brakes": s.brakes, "clutches": s.clutches, "engaged": s.engaged,
                            "targets": dict(zip(s.gears, s.targets)), "tolerance": s.tolerance,
                            "ring_sun": [s.k_low, s.k_high]},
                "trains": self.trains, "counts": dict(self.counts), "seconds": self.seconds, "ranking": RANKING,
                "notes": list(self.notes), "candidates": [c.to_dict() for c in self.candidates]}


def estimate_seconds(spec: SearchSpec, n_trains: int | None = None) -> float:
    """Estimated single-core run time [s] of the search (the early pruning's placements times its
    measured cost, plus a per-train overhead)."""
    n = link_count(spec.planetaries, spec.engaged)
    pairs = n * (n - 1) // 2
    inner = math.comb(n - 2, spec.brakes) * math.comb(pairs, spec.clutches) * n * (n - 1)
    count = n_trains if n_trains is not None else _train_estimate(spec.planetaries, n)
    if n_trains is None and spec.grounded:  # each choice of held members: a bound, not a count
        count *= sum(math.comb(3 * spec.planetaries, g) for g in range(spec.grounded + 1))
    return count * (inner * SECONDS_PER_PLACEMENT + SECONDS_PER_TRAIN)


def _train_estimate(sets: int, links: int) -> int:
    """Gear trains up to set permutations (counted by :func:`transgen.synthesis.topology.trains`)."""
    known = {(2, 4): 12, (2, 5): 18, (3, 6): 345, (3, 7): 204, (4, 8): 8721}
    return known.get((sets, links), int(10 ** (sets + 0.5)))


def validate_spec(spec: SearchSpec, max_seconds: float = MAX_SECONDS) -> None:
    """Refuse what cannot be searched, before any work (bounded sizes, a time estimate)."""
    if not 1 <= spec.sets <= MAX_SETS:
        raise TopologyInputError(f"--sets must be 1..{MAX_SETS}, not {spec.sets}")
    if not 0 <= spec.ravigneaux <= spec.sets or spec.planetaries > MAX_SETS:
        raise TopologyInputError(f"--ravigneaux must be 0..--sets with at most {MAX_SETS} planetary statements "
                                 f"(a compound counts two), not {spec.ravigneaux} of {spec.sets} sets")
    if not 0 <= spec.grounded <= min(2, spec.planetaries):
        raise TopologyInputError(f"--grounded must be 0..{min(2, spec.planetaries)} (members fixed to the housing), "
                                 f"not {spec.grounded}")
    if spec.brakes < 0 or spec.clutches < 0 or not 1 <= spec.brakes + spec.clutches <= MAX_ELEMENTS:
        raise TopologyInputError(f"--brakes and --clutches: 1..{MAX_ELEMENTS} elements in all, not "
                                 f"{spec.brakes} + {spec.clutches}")
    if not 1 <= spec.engaged <= spec.brakes + spec.clutches:
        raise TopologyInputError(f"--engaged must be 1..{spec.brakes + spec.clutches} (the elements), not {spec.engaged}")
    possible = math.comb(spec.brakes + spec.clutches, spec.engaged)
    if len(spec.targets) > possible:
        raise TopologyInputError(f"{len(spec.targets)} target gears, but {spec.brakes + spec.clutches} elements "
                                 f"engaged {spec.engaged} at a time give at most {possible} combinations")
    if not (1 < spec.k_low < spec.k_high <= 20):
        raise TopologyInputError(f"--ring-sun must satisfy 1 < MIN < MAX <= 20, not {spec.k_low:g},{spec.k_high:g}")
    if not (0 < spec.tolerance <= 0.2):
        raise TopologyInputError(f"--tolerance must be in (0, 0.2] (relative), not {spec.tolerance:g}")
    if len(set(spec.targets)) < len(spec.targets):
        raise TopologyInputError("two target gears have the same ratio")
    seconds = estimate_seconds(spec)
    if seconds > max_seconds:
        raise TopologyInputError(f"this search would take about {seconds / 3600:.1f} h on one core (limit "
                                 f"{max_seconds / 3600:.1f} h): fewer sets or elements, or a larger --max-hours")


# ------------------------------------------------------------------------------ the .mech text


def concept_text(concept: Concept, gears: dict, ratios: dict | None = None, teeth=None, title: str = "",
                 comments: tuple[str, ...] = ()) -> str:
    """The ``.mech`` of a concept: links named by their members, sets ``P1..PN`` (``Ns=? Nr=?``
    when ``teeth`` is ``None``), brakes and clutches (named A, B, ... with placeholder capacities),
    input, output and the gear table (``ratios`` written as ``ratio=``)."""
    t = concept.train
    names = [t.link_name(i) for i in range(len(t.links))]
    link_of = t.link_of()
    lines = [f"# {line}" for line in comments]
    lines.append(f'transmission "{title or "synthesized concept"}"')
    lines.append("")
    lines.append("# inertias: placeholders (0.01 kg*m^2); capacities: placeholders, size them with "
                 "'transgen powerflow --design-torque'")
    for name in names:
        lines.append(f"link {name} J=0.01")
    lines.append("")
    by_set = {name: (ns, nr) for name, ns, nr, _ in teeth} if teeth else {}
    for p in range(t.sets):
        members = []
        for j, word in enumerate(("sun", "ring", "carrier")):
            m = 3 * p + j
            members.append(f"{word}={names[link_of[m]] if m in link_of else 'housing'}")
        ns, nr = by_set.get(f"P{p + 1}", ("?", "?"))
        pinions = " pinions=2" if p in t.double_pinion else ""
        lines.append(f"planetary P{p + 1} {' '.join(members)} Ns={ns} Nr={nr}{pinions}")
    lines += share_lines(t)
    lines.append("")
    for name, links in concept.elements:
        if len(links) == 1:
            lines.append(f"brake {name} {names[links[0]]} static=1000 dynamic=850")
        else:
            lines.append(f"clutch {name} {names[links[0]]} {names[links[1]]} static=1000 dynamic=850")
    lines.append("")
    lines.append(f"input {names[concept.input]}")
    lines.append(f"output {names[concept.output]}")
    lines.append("")
    for gear, engaged in gears.items():
        ratio = f" ratio={ratios[gear]}" if ratios and gear in ratios else ""
        lines.append(f"gear {gear} = {' '.join(engaged)}{ratio}")
    return "\n".join(lines) + "\n"


# ------------------------------------------------------------------------------ the search


def _task(spec: SearchSpec, train) -> TrainResult:
    return train_task(train, spec)


def set_options(k: float, rules, count: int) -> list[tuple[int, int, int]]:
    """The ``count`` admissible ``(Ns, Nr, planets)`` of a simple set with ``Nr/Ns`` closest to
    ``k`` (smallest sets first among equal fractions) under ``rules``."""
    from .teeth import planet_count

    found: dict = {}
    top_sun = int(rules.max_teeth / rules.k_min)
    for ns in range(rules.min_teeth, top_sun + 1):
        for nr in range(max(ns + 1, int(k * ns) - 2), min(rules.max_teeth, int(k * ns) + 3) + 1):
            n = planet_count(ns, nr, 1, rules)
            if n is not None:
                f = Fraction(nr, ns)
                if f not in found:
                    found[f] = (ns, nr, n)
    ranked = sorted(found.items(), key=lambda item: (abs(float(item[0]) - k), item[1][0] + item[1][1]))
    return [v for _, v in ranked[:count]]


def _teeth(fc: FittedConcept, spec: SearchSpec, rules, per_set: int = 8):
    """Tooth counts near the fitted ``k`` under ``rules`` (the assembly rules of ``synthesize
    teeth``, :func:`transgen.synthesis.teeth.planet_count`): for each set the ``per_set``
    admissible ``Nr/Ns`` closest to its ``k`` (smallest sets first among equal fractions), every
    combination of them, the best by largest relative ratio error then size; ``(teeth, ratios)``
    with ``teeth`` as ``(name, Ns, Nr, planets)``, or ``(None, None)`` when none is within the
    tolerance. The ratios are recomputed by :func:`transgen.kinematics.analyze` on the file."""
    import itertools

    import numpy as np

    from ..kinematics import analyze
    from ..language import parse_mechanism
    from .fit import batch_ratios

    c = fc.concept
    if c.train.ravigneaux:  # shared gears: synthesize teeth's own search, which honours them
        return ravigneaux_teeth(fc, spec, rules, lambda k, count: set_options(k, rules, count), concept_text)
    options = []
    for k in fc.fit.k:
        options.append(set_options(k, rules, per_set))
        if not options[-1]:
            return None, None
    choices = list(itertools.product(*options))
    ks = np.array([[nr / ns for ns, nr, _ in choice] for choice in choices])
    n_el = len(c.elements)
    n_links = len(c.train.links)
    vectors = np.zeros((len(choices), n_el, n_links))
    for j, (_, links) in enumerate(c.elements):
        vectors[:, j, links[0]] = 1.0
        if len(links) == 2:
            vectors[:, j, links[1]] = -1.0
    names = [name for name, _ in c.elements]
    combos = np.array([[names.index(e) for e in engaged] for engaged in fc.gears], dtype=np.int64)
    io = np.tile([c.input, c.output], (len(choices), 1))
    r = batch_ratios(c.train, io, vectors, combos, ks)
    err = np.max(np.abs(r / np.array(spec.targets) - 1), axis=1)
    err = np.where(np.isfinite(err), err, np.inf)
    size = np.array([sum(ns + nr for ns, nr, _ in choice) for choice in choices])
    best = min(range(len(choices)), key=lambda j: (err[j], size[j]))
    if not err[best] <= spec.tolerance * (1 + 1e-9):
        return None, None
    teeth = tuple((f"P{p + 1}", ns, nr, n) for p, (ns, nr, n) in enumerate(choices[best]))
    gears = dict(zip(spec.gears, fc.gears))
    mech = parse_mechanism(concept_text(c, gears, None, teeth), "<candidate>")
    ratios = {g: analyze(mech, gears[g]).ratio for g in spec.gears}
    return teeth, ratios


def _text(x: float) -> str:
    return f"{x:.6g}"


def _figures(mech_text: str, gears: dict, spec: SearchSpec) -> dict:
    """The designer's figures of a completed concept (see :data:`RANKING`)."""
    from ..language import parse_mechanism
    from ..powerflow import power_flow
    from .table import table_score

    from ..powerflow import PowerFlowError

    mech = parse_mechanism(mech_text, "<candidate>")
    try:
        flow = power_flow(mech, eta0=0.98)
    except (PowerFlowError, RuntimeError) as exc:  # no unique static torques: ranked last
        return {"powerflow_error": str(exc), "designer_cost": None}
    forward = [g for g, t in zip(spec.gears, spec.targets) if t > 0]
    eff = {gf.name: gf.efficiency for gf in flow.gears}
    slips = [abs(v) for gf in flow.gears for v in gf.element_slips.values() if v is not None]
    torques = [abs(v) for gf in flow.gears for v in gf.element_torques.values() if v is not None]
    circ = [abs(gf.circulating_power) for gf in flow.gears]
    ratios = [gf.ratio for gf in flow.gears if gf.name in forward]
    order = sorted(forward, key=lambda g: -dict(zip(spec.gears, spec.targets))[g])
    sets = [frozenset(gears[g]) for g in order]
    doubles = sum(1 for a, b in zip(sets, sets[1:]) if len(a ^ b) > 2)
    score = table_score(sorted(ratios, reverse=True), [len(s) for s in sets], doubles) if len(ratios) > 1 else 0.0
    n_elements = spec.brakes + spec.clutches
    figures = {
        "open_elements_per_gear": n_elements - spec.engaged,
        "mean_forward_efficiency": sum(eff[g] for g in forward) / max(1, len(forward)),
        "min_efficiency": min(eff.values()),
        "efficiency": eff,
        "max_circulating_power": max(circ, default=0.0),
        "max_open_slip": max(slips, default=0.0),
        "max_element_torque": max(torques, default=0.0),
        "table_score": score,
        "double_swaps": doubles,
    }
    figures["designer_cost"] = (10 * (1 - figures["mean_forward_efficiency"]) + 0.1 * figures["max_circulating_power"]
                                + 0.05 * figures["max_open_slip"] + 0.02 * figures["max_element_torque"]
                                - 0.5 * score)
    return figures


def synthesize_topology(spec: SearchSpec, top: int = 20, executor=None, progress=None, rules=None,
                        teeth_candidates: int | None = None, max_seconds: float = MAX_SECONDS,
                        train_list=None, checkpoint=None) -> TopologySynthesis:
    """Search every concept of ``spec`` (see the module docstring) and return the ``top`` best.

    ``executor``: anything with ``run(fn, shared, tasks)`` (default: in this process);
    ``teeth_candidates``: how many of the best fitted concepts get a tooth-count search (default
    ``3 * top``); ``train_list``: the gear trains to search (default: all of the search space;
    for measurements and tests); ``checkpoint``: a folder to keep the finished trains in and
    resume from (:mod:`transgen.synthesis.checkpoint`; the result is the same with or without).
    """
    from .teeth import AssemblyRules

    validate_spec(spec, max_seconds)
    if top < 1 or top > 1000:
        raise TopologyInputError(f"--top must be 1..1000, not {top}")
    rules = rules or AssemblyRules(k_min=spec.k_low, k_max=spec.k_high)
    start = time.perf_counter()
    all_trains = spec_trains(spec) if train_list is None else list(train_list)
    total = TrainResult()
    results: dict[int, TrainResult] = {}
    if executor is None:
        from types import SimpleNamespace

        executor = SimpleNamespace(run=lambda fn, shared, tasks: (fn(shared, t) for t in tasks))
    saved = None
    if checkpoint is not None:
        from .checkpoint import Checkpoint

        saved = Checkpoint(checkpoint, spec, all_trains)
        results.update(saved.done)
    tasks = [(i, t) for i, t in enumerate(all_trains) if i not in results]
    try:
        for done, (index, result) in enumerate(executor.run(_indexed_task, spec, tasks), start=len(results) + 1):
            results[index] = result
            if saved is not None:
                saved.add(index, result)
            if progress:
                progress(f"gear trains {done}/{len(all_trains)}")
    finally:  # also when stopped (Ctrl-C, SIGTERM): the trains finished so far are kept
        if saved is not None:
            saved.save()
    for index in sorted(results):
        total.merge(results[index])
    return rank_fitted(spec, total, len(all_trains), top, rules, teeth_candidates, progress,
                       time.perf_counter() - start)


def rank_fitted(spec: SearchSpec, total: TrainResult, n_trains: int, top: int = 20, rules=None,
                teeth_candidates: int | None = None, progress=None, seconds: float = 0.0) -> TopologySynthesis:
    """Tooth counts, figures and ranking of the fitted concepts of ``total`` (the merged train
    results, in the trains' order): the last stage of :func:`synthesize_topology`, also for the
    trains finished so far (a checkpoint)."""
    from .teeth import AssemblyRules

    rules = rules or AssemblyRules(k_min=spec.k_low, k_max=spec.k_high)
    start = time.perf_counter()
    fitted = sorted(total.concepts, key=lambda f: (f.fit.max_error, f.concept.key()))
    chosen = fitted[: (teeth_candidates if teeth_candidates is not None else 3 * top)]
    candidates = []
    for n, fc in enumerate(chosen, start=1):
        if progress:
            progress(f"tooth counts and figures {n}/{len(chosen)}")
        gears = dict(zip(spec.gears, fc.gears))
        teeth, exact = _teeth(fc, spec, rules)
        ratios = exact if exact else dict(zip(spec.gears, fc.fit.ratios))
        errors = {g: ratios[g] / t - 1 for g, t in zip(spec.gears, spec.targets)}
        shown = {g: f"{ratios[g]:.4f}" for g in spec.gears} if teeth else None
        text = concept_text(fc.concept, gears, shown, teeth, "synthesized concept",
                            _comments(spec, fc, teeth))
        figures = _figures(text, gears, spec) if teeth else {}
        candidates.append(Candidate(0, fc.concept, fc.fit.k, gears, ratios, errors, teeth, figures, text))
    bin_width = spec.tolerance / 5

    def key(c: Candidate):
        cost = c.figures.get("designer_cost")
        return (c.teeth is None, math.floor(c.max_ratio_error / bin_width), math.inf if cost is None else cost,
                c.concept.key())

    ranked = sorted(candidates, key=key)[:top]
    ranked = tuple(replace(c, rank=i) for i, c in enumerate(ranked, start=1))
    counts = {"enumerated": total.enumerated, "distinct": total.distinct, "feasible": total.feasible,
              "screened": total.screened, "refined": total.refined, "fitted": total.fitted,
              "teeth_searched": len(chosen), "with_teeth": sum(1 for c in candidates if c.teeth),
              "ranked": len(ranked)}
    notes = []
    if not fitted:
        notes.append("no concept meets every target within the tolerance")
    return TopologySynthesis(spec, n_trains, counts, seconds + time.perf_counter() - start, ranked, tuple(notes))




def _indexed_task(spec: SearchSpec, task):
    index, train = task
    return index, train_task(train, spec)


def _comments(spec: SearchSpec, fc: FittedConcept, teeth) -> tuple[str, ...]:
    targets = ", ".join(f"{g}={t:g}" for g, t in zip(spec.gears, spec.targets))
    k = ", ".join(f"P{p + 1} {v:.4f}" for p, v in enumerate(fc.fit.k))
    return (f"generated by transgen synthesize topology from the target ratios {targets}",
            f"fitted ring/sun ratios k = Nr/Ns: {k}",
            "tooth counts: " + ("transgen synthesize teeth's assembly rules" if teeth else
                                "none found under the assembly rules (Ns=? Nr=? left open)"))
