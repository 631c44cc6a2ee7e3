"""``transgen synthesize topology``: enumeration against a brute force, the pruning against
:func:`transgen.kinematics.analyze`, and the Simpson three-speed found from its ratios alone."""
from __future__ import annotations

import itertools
import json

import numpy as np
import pytest

from transgen.kinematics import analyze
from transgen.language import parse_mechanism
from transgen.synthesis.fit import sample_points
from transgen.synthesis.rank import concept_text, synthesize_topology, validate_spec, TopologyInputError
from transgen.synthesis.search import SearchSpec, feasible_placements, placement_concept
from transgen.synthesis.topology import (Concept, Train, canonical_key, count_orbits, link_count, placements,
                                         speed_basis, trains)


# ------------------------------------------------------------------ brute force, no symmetry breaking


def _labelled_trains(n_sets: int, n_links: int, max_grounded: int = 0):
    """Every train with the sets told apart: each member gets a block label (first occurrence
    order) or the housing (at most ``max_grounded`` members), no two members of one set in a
    block or on the housing; with and without a bare input shaft."""
    n = 3 * n_sets
    for bare in (0, 1):
        blocks = n_links - bare
        housing = blocks
        seen = set()
        for labels in itertools.product(range(blocks + (1 if max_grounded else 0)), repeat=n):
            if labels.count(housing) > max_grounded:
                continue
            order = {}
            norm = tuple(x if x == housing else order.setdefault(x, len(order)) for x in labels)
            if norm in seen or len(order) != blocks:
                continue
            seen.add(norm)
            links = [tuple(m for m in range(n) if norm[m] == b) for b in range(blocks)]
            grounded = tuple(m for m in range(n) if norm[m] == housing)
            if any(len({m // 3 for m in link}) < len(link) for link in links + [grounded]):
                continue
            train = Train(n_sets, tuple(links) + (((),) if bare else ()), grounded)
            link_sets = [frozenset(l for l, link in enumerate(links) for m in link if m // 3 == p)
                         | {-1 - m for m in grounded if m // 3 == p} for p in range(n_sets)]
            if len(set(link_sets)) < n_sets:  # two sets on the same three links: locked
                continue
            yield train


@pytest.mark.parametrize("n_sets,brakes,clutches,engaged,gears,grounded",
                         [(2, 1, 1, 1, 2, 0), (2, 1, 2, 2, 3, 0), (2, 1, 1, 1, 2, 1)])
def test_the_enumeration_finds_the_brute_forces_distinct_concepts(n_sets, brakes, clutches, engaged, gears,
                                                                  grounded):
    spec = SearchSpec(n_sets, brakes, clutches, engaged, tuple(str(g) for g in range(gears)),
                      tuple(float(g + 2) for g in range(gears)), grounded=grounded)
    k = sample_points(n_sets, spec.k_low, spec.k_high, 0, spec.seed)[0][0]
    n_links = link_count(n_sets, engaged)
    _assert_the_search_finds_the_brute_force(spec, _labelled_trains(n_sets, n_links, grounded),
                                             trains(n_sets, n_links, max_grounded=grounded), k)


def _assert_the_search_finds_the_brute_force(spec, labelled_trains, search_trains, k):
    """Every labelled placement reduced by its canonical key and pruned plainly
    (:func:`_plain_feasible`) gives the search's feasible representatives and counts."""
    brute_keys, brute_feasible, labelled = set(), set(), 0
    for train in labelled_trains:
        for i, o, bs, cs in placements(train, spec.brakes, spec.clutches):
            labelled += 1
            c = Concept(train, i, o, bs, cs)
            key = canonical_key(c)
            if key not in brute_keys:
                brute_keys.add(key)
                if _plain_feasible(c, len(spec.gears), spec.engaged, k):
                    brute_feasible.add(key)
    fast_keys, enumerated, distinct = [], 0, 0
    for train in search_trains:
        counts, kin, feasible = feasible_placements(train, spec)
        enumerated += counts.enumerated
        distinct += counts.distinct
        for i, o, rows in feasible:
            fast_keys += [canonical_key(placement_concept(kin, spec, i, o, r)) for r in rows]
    assert len(fast_keys) == len(set(fast_keys)), "one representative per class"
    assert set(fast_keys) == brute_feasible
    assert distinct == len(brute_keys)
    assert enumerated == labelled
    assert brute_feasible, "the case prunes something and keeps something"
    assert len(brute_feasible) < len(brute_keys)


def test_the_canonical_key_ignores_set_order_link_order_and_clutch_ends():
    a = Train(2, ((0,), (1, 5), (2, 3), (4,), ()))
    # the same train with the sets swapped (member m of set p -> set 1 - p) and links reordered
    swap = {0: 3, 1: 4, 2: 5, 3: 0, 4: 1, 5: 2}
    b_links = [tuple(sorted(swap[m] for m in link)) for link in a.links]
    order = [4, 2, 0, 3, 1]
    b = Train(2, tuple(b_links[j] for j in order))
    pos = {j: n for n, j in enumerate(order)}
    ca = Concept(a, 4, 2, (0,), ((0, 4), (3, 4)))
    cb = Concept(b, pos[4], pos[2], (pos[0],), tuple(sorted((tuple(sorted((pos[x], pos[y]))) for x, y in ((4, 0), (4, 3))))))
    assert canonical_key(ca) == canonical_key(cb)
    assert canonical_key(ca) != canonical_key(Concept(a, 4, 2, (3,), ((0, 4), (3, 4))))


def test_orbit_counts_match_explicit_classes():
    spec_trains = trains(2, 5)
    for train in spec_trains[:8]:
        keys = {canonical_key(Concept(train, *p)) for p in placements(train, 1, 2)}
        assert count_orbits(train, 1, 2)[1] == len(keys)


def test_the_gear_rule_agrees_with_kinematics_analyze():
    """The vectorised pruning and transgen.kinematics.analyze classify the same combinations as
    one-DOF gears, with the same ratio (one rule: a K-element combination of one DOF)."""
    spec = SearchSpec(2, 2, 2, 2, ("1", "2", "3", "R"), (2.5, 1.5, 1.0, -2.0))
    k = sample_points(2, 1.5, 4.5, 0, 0)[0]
    checked = 0
    for train in trains(2, 5)[:6]:
        _, kin, feasible = feasible_placements(train, spec)
        for i, o, rows in feasible[:2]:
            c = placement_concept(kin, spec, i, o, rows[0])
            teeth = tuple((f"P{p + 1}", 1000, int(round(1000 * k[0][p])), 3) for p in range(2))
            names = [n for n, _ in c.elements]
            gears = {f"g{j}": combo for j, combo in enumerate(itertools.combinations(names, 2))}
            mech = parse_mechanism(concept_text(c, gears, None, teeth), "<test>")
            basis = speed_basis(train, np.array([[t[2] / 1000 for t in teeth]]))[0]
            for combo in gears.values():
                got = analyze(mech, combo)
                rows_ = [basis[c.elements[names.index(e)][1][0]] - (basis[c.elements[names.index(e)][1][1]]
                         if len(c.elements[names.index(e)][1]) == 2 else 0) for e in combo]
                null = np.linalg.svd(np.array(rows_))[2][-1]
                w = basis @ null
                ours = abs(w[i]) > 1e-9 and abs(w[o]) > 1e-9
                assert ours == (got.kind == "gear" and got.dof == 1)
                if ours:
                    assert w[i] / w[o] == pytest.approx(got.ratio, rel=1e-9)
                checked += 1
    assert checked > 20


def test_sizes_are_bounded_before_any_work():
    with pytest.raises(TopologyInputError, match="would take about"):
        validate_spec(SearchSpec(4, 3, 4, 3, tuple("12345678R"), tuple(range(1, 10))), max_seconds=60)
    with pytest.raises(TopologyInputError, match="at most"):
        validate_spec(SearchSpec(2, 1, 1, 1, ("1", "2", "3"), (3.0, 2.0, 1.0)))
    with pytest.raises(TopologyInputError, match="--sets"):
        validate_spec(SearchSpec(7, 1, 1, 1, ("1",), (3.0,)))


SIMPSON = "1=2.479,2=1.479,3=1.000,R=-2.086"  # ZF 3HP22 (published ratios)


def _simpson_key():
    # bare input IN; sun S1_S2; front ring R1; output front carrier + rear ring; rear carrier C2
    t = Train(2, ((0, 3), (1,), (2, 4), (5,), ()))
    # brakes: sun (2nd), rear carrier (low/reverse); clutches: IN-R1 (forward), IN-sun (direct/reverse)
    return canonical_key(Concept(t, 4, 2, (0, 3), ((1, 4), (0, 4))))


def test_the_simpson_three_speed_is_found_from_its_ratios(tmp_path):
    gears, targets = zip(*[(g, float(r)) for g, r in (item.split("=") for item in SIMPSON.split(","))])
    spec = SearchSpec(2, 2, 2, 2, gears, targets, tolerance=0.01)
    result = synthesize_topology(spec, top=10, teeth_candidates=10)
    keys = [c.concept.key() for c in result.candidates]
    assert _simpson_key() in keys
    simpson = result.candidates[keys.index(_simpson_key())]
    assert simpson.teeth and simpson.max_ratio_error <= 0.01
    assert {g: set(e) for g, e in simpson.gears.items()} == {"1": {"B", "D"}, "2": {"A", "D"}, "3": {"C", "D"},
                                                             "R": {"B", "C"}}
    c = result.counts
    assert c["enumerated"] >= c["distinct"] >= c["feasible"] >= c["screened"] >= c["fitted"] >= c["ranked"] > 0
    # the candidate's .mech is complete: every gear's ratio checks against its file
    mech = parse_mechanism(simpson.mech, "<simpson>")
    for gear in mech.gears:
        assert analyze(mech, gear.engaged).ratio == pytest.approx(float(gear.ratio), abs=6e-5)


def test_the_command_writes_files_and_a_valid_document(tmp_path, capsys):
    from transgen.cli import main
    from transgen.schemas import validate

    out = tmp_path / "cands"
    code = main(["synthesize", "topology", "--sets", "2", "--brakes", "2", "--clutches", "2", "--ratios", SIMPSON,
                 "--top", "2", "-o", str(out), "--json"])
    assert code == 0
    doc = json.loads(capsys.readouterr().out)
    validate(doc)
    assert doc["schema"] == "transgen.synthesize.topology/1"
    assert [c["rank"] for c in doc["candidates"]] == [1, 2]
    assert (out / "summary.csv").read_text().count("\n") == 3
    assert (out / "candidate_01.mech").read_text() == doc["candidates"][0]["mech"]


def test_bad_input_is_an_error_not_a_traceback(capsys):
    from transgen.cli import main

    assert main(["synthesize", "topology", "--sets", "2", "--brakes", "2", "--clutches", "2",
                 "--ratios", "1=abc"]) == 2
    assert "error" in capsys.readouterr().err
    assert main(["synthesize", "topology", "--sets", "9", "--brakes", "2", "--clutches", "2",
                 "--ratios", "1=2,2=1"]) == 2


class _Reversed:
    """An executor that runs the tasks in reverse order (as a pool may finish them)."""

    def run(self, fn, shared, tasks):
        return (fn(shared, t) for t in reversed(list(tasks)))


def test_the_result_does_not_depend_on_the_executor_or_task_order():
    from transgen.sim.study.executors import LocalExecutor

    gears, targets = zip(*[(g, float(r)) for g, r in (item.split("=") for item in SIMPSON.split(","))])
    spec = SearchSpec(2, 2, 2, 2, gears, targets)
    subset = trains(2, 5)[:1] + [Train(2, ((0, 3), (1,), (2, 4), (5,), ()))]
    runs = [synthesize_topology(spec, top=3, train_list=subset, executor=e)
            for e in (None, _Reversed(), LocalExecutor(1))]
    for other in runs[1:]:
        assert other.counts == runs[0].counts
        assert [c.mech for c in other.candidates] == [c.mech for c in runs[0].candidates]
    assert runs[0].candidates


# ------------------------------------------------------------------ pruning against no pruning


def test_glovers_greedy_finds_a_distinct_assignment_iff_one_exists():
    from transgen.synthesis.screen import distinct_cover

    rng = np.random.default_rng(3)
    n_targets, n_gears = 5, 6
    a = rng.integers(0, n_targets + 1, size=(400, n_gears))
    b = a + rng.integers(-1, 3, size=(400, n_gears))
    got = distinct_cover(a, b, n_targets)
    for row in range(len(a)):
        covers = [[a[row, s] <= g <= b[row, s] for s in range(n_gears)] for g in range(n_targets)]
        brute = any(all(covers[g][p[g]] for g in range(n_targets))
                    for p in itertools.permutations(range(n_gears), n_targets))
        assert got[row] == brute
    assert 0 < got.sum() < len(got)


def test_the_cell_screen_contains_every_ratio_it_may_meet():
    """Corner hulls of a cell contain the ratio at points inside it (the monotonicity the screen
    relies on), checked at random points of random cells of a three-set train."""
    from transgen.synthesis.fit import concept_ratios
    from transgen.synthesis.screen import _ranges
    from transgen.synthesis.topology import sample_speeds, train_kinematics

    train = trains(3, 6)[40]
    kin = train_kinematics(train, 2, sample_points(3, 1.5, 4.5, 0, 0)[0])
    i, o = 0, len(train.links) - 1
    rows = np.flatnonzero(kin.rank_ok & kin.moves[:, i] & kin.moves[:, o])[:30]
    rng = np.random.default_rng(1)
    for _ in range(5):
        low = 1.5 + 2.5 * rng.random(3)
        corners = low + 0.5 * np.array(list(itertools.product((0, 1), repeat=3)))
        s = sample_speeds(kin, rows, corners)
        lo, hi = _ranges(s[..., i], s[..., o], np.linalg.norm(s, axis=2), np.arange(8)[None])
        inside = low + 0.5 * rng.random((20, 3))
        r = concept_ratios(train, i, o, kin.candidates, kin.combos[rows], inside).T  # rows x points
        ok = np.isnan(r) | ((r >= lo - 1e-9 * np.abs(lo)) & (r <= hi + 1e-9 * np.abs(hi)))
        assert ok.all()


def _fitted(spec):
    from transgen.synthesis.search import TrainResult, train_task

    total = TrainResult()
    for train in trains(spec.sets, link_count(spec.sets, spec.engaged)):
        total.merge(train_task(train, spec))
    return total, {(f.concept.key(), f.fit.k, f.fit.assignment) for f in total.concepts}


def test_the_pruning_drops_no_concept_the_fit_finds():
    """Every distinct concept fitted without the necessary conditions (gear count, distinct
    ratios, cell screen) against the pruned search: the same concepts, the same fits."""
    from dataclasses import replace

    gears, targets = zip(*[(g, float(r)) for g, r in (item.split("=") for item in SIMPSON.split(","))])
    spec = SearchSpec(2, 2, 2, 2, gears, targets, tolerance=0.01)
    pruned, with_pruning = _fitted(spec)
    brute, without = _fitted(replace(spec, prune=False))
    assert with_pruning == without
    assert len(with_pruning) == pruned.fitted > 10
    assert pruned.screened < pruned.feasible < brute.feasible
    assert brute.screened == brute.feasible


# ------------------------------------------------------------------ the checkpoint


def test_a_resumed_search_gives_the_same_result(tmp_path):
    import json as json_

    from transgen.synthesis.checkpoint import CHECKPOINT, CheckpointError

    gears, targets = zip(*[(g, float(r)) for g, r in (item.split("=") for item in SIMPSON.split(","))])
    spec = SearchSpec(2, 2, 2, 2, gears, targets)
    plain = synthesize_topology(spec, top=3, teeth_candidates=3)
    first = synthesize_topology(spec, top=3, teeth_candidates=3, checkpoint=tmp_path)
    path = tmp_path / CHECKPOINT
    doc = json_.loads(path.read_text())
    assert len(doc["done"]) == plain.trains
    # an interrupted run: half the trains done
    doc["done"] = {i: r for i, r in doc["done"].items() if int(i) % 2}
    path.write_text(json_.dumps(doc))
    ran = []

    class Counting:
        def run(self, fn, shared, tasks):
            for t in tasks:
                ran.append(t[0])
                yield fn(shared, t)

    resumed = synthesize_topology(spec, top=3, teeth_candidates=3, checkpoint=tmp_path, executor=Counting())
    assert sorted(ran) == [i for i in range(plain.trains) if i % 2 == 0]
    for other in (first, resumed):
        assert other.counts == plain.counts
        assert [c.mech for c in other.candidates] == [c.mech for c in plain.candidates]
    with pytest.raises(CheckpointError, match=f"{CHECKPOINT}:1:1: error: written for another search"):
        synthesize_topology(SearchSpec(2, 2, 2, 2, gears, targets, tolerance=0.02), checkpoint=tmp_path)


def test_a_stopped_search_keeps_the_trains_it_finished(tmp_path):
    import json as json_

    from transgen.synthesis.checkpoint import CHECKPOINT

    gears, targets = zip(*[(g, float(r)) for g, r in (item.split("=") for item in SIMPSON.split(","))])
    spec = SearchSpec(2, 2, 2, 2, gears, targets)

    class Stopping:
        def run(self, fn, shared, tasks):
            for n, t in enumerate(tasks):
                if n == 3:
                    raise KeyboardInterrupt
                yield fn(shared, t)

    with pytest.raises(KeyboardInterrupt):
        synthesize_topology(spec, checkpoint=tmp_path, executor=Stopping())
    assert sorted(json_.loads((tmp_path / CHECKPOINT).read_text())["done"], key=int) == ["0", "1", "2"]


# ------------------------------------------------------------------ Ravigneaux compounds


def _labelled_compound_trains(n_simple: int, n_links: int, max_grounded: int = 0):
    """Every train of ``n_simple`` simple sets and one Ravigneaux compound (sets told apart): a
    block label (or the housing, at most ``max_grounded`` times) for each member, the compound's
    two rings and two carriers together, no two members of one set in a block or on the housing,
    no two sets on the same three links."""
    from transgen.synthesis.ravigneaux import compound_pairs

    pairs = compound_pairs(n_simple, 1)
    n_sets = n_simple + 2
    (a, b), = pairs
    n = 3 * n_sets
    glued = {3 * b + 1: 3 * a + 1, 3 * b + 2: 3 * a + 2}
    free = [m for m in range(n) if m not in glued]
    for bare in (0, 1):
        blocks = n_links - bare
        seen = set()
        housing = blocks  # the label of a grounded member
        for labels in itertools.product(range(blocks + (1 if max_grounded else 0)), repeat=len(free)):
            if labels.count(housing) > max_grounded:
                continue
            order = {}
            norm = tuple(x if x == housing else order.setdefault(x, len(order)) for x in labels)
            if norm in seen or len(order) != blocks:
                continue
            seen.add(norm)
            label = dict(zip(free, norm))
            label.update({m: label[g] for m, g in glued.items()})
            grounded = tuple(m for m in range(n) if label[m] == housing)
            links = [tuple(m for m in range(n) if label[m] == x) for x in range(blocks)]
            if any(len({m // 3 for m in group}) < len(group) for group in links + [grounded]):
                continue
            train = Train(n_sets, tuple(links) + (((),) if bare else ()), grounded, pairs)
            on = [frozenset(label[3 * p + j] if label[3 * p + j] != housing else -1 - 3 * p - j for j in range(3))
                  for p in range(n_sets)]
            if len(set(on)) < n_sets:
                continue
            yield train


def _plain_feasible(c: Concept, gears: int, engaged: int, k: np.ndarray) -> bool:
    """The early pruning written plainly for simple and double-pinion sets (matrix rank)."""
    t = c.train
    n = len(t.links)
    link_of = t.link_of()
    rows = []
    for p in range(t.sets):
        row = np.zeros(n)
        coeffs = (1.0, -k[p], k[p] - 1) if p in t.double_pinion else (1.0, k[p], -(1 + k[p]))
        for j, coeff in enumerate(coeffs):
            if 3 * p + j in link_of:  # else held: speed zero
                row[link_of[3 * p + j]] += coeff
        rows.append(row)
    elements = [(b,) for b in c.brakes] + list(c.clutches)
    ratios, used = [], set()
    for combo in itertools.combinations(range(len(elements)), engaged):
        a = list(rows)
        for e in combo:
            row = np.zeros(n)
            row[elements[e][0]] = 1
            if len(elements[e]) == 2:
                row[elements[e][1]] = -1
            a.append(row)
        a = np.array(a)
        if n - np.linalg.matrix_rank(a, tol=1e-9) != 1:
            continue
        w = np.linalg.svd(a)[2][-1]
        if abs(w[c.input]) < 1e-9 or abs(w[c.output]) < 1e-9:
            continue
        ratios.append(w[c.input] / w[c.output])
        used.update(combo)
    distinct = len({round(r, 7) for r in ratios})
    touched = {l for e in elements for l in e} | {c.input, c.output}
    dead = any(len(t.links[l]) == 1 and l not in touched for l in range(n))
    return len(ratios) >= gears and distinct >= gears and len(used) == len(elements) and not dead


@pytest.mark.parametrize("n_simple,brakes,clutches,engaged,gears,grounded",
                         [(0, 2, 2, 2, 3, 0), (1, 1, 1, 1, 2, 0), (0, 1, 2, 1, 2, 1)])
def test_the_compound_enumeration_finds_the_brute_forces_distinct_concepts(n_simple, brakes, clutches, engaged,
                                                                           gears, grounded):
    from transgen.synthesis.ravigneaux import spec_trains

    spec = SearchSpec(n_simple + 1, brakes, clutches, engaged, tuple(str(g) for g in range(gears)),
                      tuple(float(g + 2) for g in range(gears)), ravigneaux=1, grounded=grounded)
    k = sample_points(spec.planetaries, spec.k_low, spec.k_high, 0, spec.seed)[0][0]
    n_links = link_count(spec.planetaries, engaged)
    _assert_the_search_finds_the_brute_force(spec, _labelled_compound_trains(n_simple, n_links, grounded),
                                             spec_trains(spec), k)


def test_a_compounds_two_suns_are_not_interchangeable():
    """Swapping the small and the large sun is another mechanism: other ratios, another key."""
    from transgen.synthesis.fit import concept_ratios

    pairs = ((0, 1),)
    # links: S1, S2, ring, carrier, bare input; brake on S1, clutches IN-S2 and IN-carrier
    one = Train(2, ((0,), (3,), (1, 4), (2, 5), ()), (), pairs)
    two = Train(2, ((3,), (0,), (1, 4), (2, 5), ()), (), pairs)  # the suns' places swapped
    c1, c2 = (Concept(t, 4, 2, (0,), ((1, 4), (3, 4))) for t in (one, two))
    assert canonical_key(c1) != canonical_key(c2)
    k = np.array([[2.0, 2.4]])
    cands = [(0,), (1, 4), (3, 4)]
    combos = np.array([[0, 1], [0, 2], [1, 2]])
    r1 = concept_ratios(one, 4, 2, cands, combos, k)[0]
    r2 = concept_ratios(two, 4, 2, cands, combos, k)[0]
    # each against transgen.kinematics.analyze on the written file (teeth of k = 2 and 2.4)
    for train, r in ((one, r1), (two, r2)):
        text = concept_text(Concept(train, 4, 2, (0,), ((1, 4), (3, 4))), {"a": ("A", "B"), "b": ("A", "C")},
                            teeth=(("P1", 36, 72, 3), ("P2", 30, 72, 3)))
        mech = parse_mechanism(text)
        assert analyze(mech, ("A", "B")).ratio == pytest.approx(r[0], rel=1e-9)
        assert analyze(mech, ("A", "C")).ratio == pytest.approx(r[1], rel=1e-9)
    assert not np.allclose(r1, r2)


def _concept_of(mech) -> Concept:
    """A parsed mechanism with one Ravigneaux compound (a simple and a double-pinion set on one
    ring and one carrier) and simple sets, as a :class:`Concept` (for comparing keys)."""
    double = [p for p in mech.planetaries if p.pinions == 2]
    (b,) = double
    (a,) = [p for p in mech.planetaries if p.pinions == 1 and (p.ring, p.carrier) == (b.ring, b.carrier)]
    order = [p for p in mech.planetaries if p not in (a, b)] + [a, b]
    names = [l.name for l in mech.links]
    members = {n: tuple(3 * s + j for s, p in enumerate(order) for j, m in enumerate((p.sun, p.ring, p.carrier))
                        if m == n) for n in names}
    train = Train(len(order), tuple(members[n] for n in names), (), ((len(order) - 2, len(order) - 1),))
    idx = {n: i for i, n in enumerate(names)}
    brakes = tuple(idx[e.link1] for e in mech.elements if e.kind == "brake")
    clutches = tuple(tuple(sorted((idx[e.link1], idx[e.link2]))) for e in mech.elements if e.kind == "clutch")
    return Concept(train, idx[mech.input], idx[mech.output], brakes, clutches)


def test_the_ravigneaux_four_speed_is_found_from_its_ratios(tmp_path):
    """HowStuffWorks' Ravigneaux 4-speed from its ratios alone (as ``transgen ratios`` prints
    them; its file is read only after the search, to compare the keys)."""
    from pathlib import Path

    from transgen.language import load_mechanism
    from transgen.synthesis.teeth import AssemblyRules

    spec = SearchSpec(1, 2, 3, 2, ("1", "2", "3", "OD", "R"), (2.4, 1.4667, 1.0, 0.6667, -2.0), ravigneaux=1)
    result = synthesize_topology(spec, top=5)
    assert result.candidates
    known = load_mechanism(Path(__file__).parent.parent / "mechanisms" / "hsw_ravigneaux4.mech")
    want = canonical_key(_concept_of(known))
    same = [c for c in result.candidates if canonical_key(c.concept) == want]
    assert same, "the published kinematics are among the candidates"
    c = same[0]
    assert c.teeth and c.max_ratio_error <= 0.01
    mech = parse_mechanism(c.mech)
    assert len(mech.shares) == 3
    for gear, engaged in c.gears.items():
        assert analyze(mech, engaged).ratio == pytest.approx(c.ratios[gear], rel=1e-9)
    teeth = {name: (ns, nr) for name, ns, nr, _ in c.teeth}
    assert teeth["P1"][1] == teeth["P2"][1], "one ring"
    from transgen.synthesis.shares import share_rules
    from transgen.synthesis.teeth import planet_counts

    rules = AssemblyRules(k_min=spec.k_low, k_max=spec.k_high)
    pinions = {p.name: p.pinions for p in mech.planetaries}
    planets = share_rules(mech).planets(teeth, rules, lambda ns, nr, n: planet_counts(ns, nr, n, rules))
    assert planets is not None, "the shares hold: one long pinion at one centre distance"
    assert set(pinions.values()) == {1, 2}
    assert result.counts["fitted"] >= 1 and result.counts["feasible"] < result.counts["distinct"]


def test_ravigneaux_counts_are_checked(capsys):
    from transgen.cli import main

    for args, word in ((["--sets", "1", "--ravigneaux", "2"], "--ravigneaux"),
                       (["--sets", "3", "--ravigneaux", "2"], "--ravigneaux"),
                       (["--sets", "1", "--ravigneaux", "-1"], "--ravigneaux"),
                       (["--sets", "1", "--ravigneaux", "1", "--grounded", "3"], "--grounded"),
                       (["--sets", "2", "--grounded", "-1"], "--grounded")):
        assert main(["synthesize", "topology", *args, "--brakes", "2", "--clutches", "2",
                     "--ratios", "1=2,2=1"]) == 2
        assert word in capsys.readouterr().err


def test_the_compound_command_writes_a_valid_document_and_drawable_files(tmp_path, capsys):
    from transgen.cli import main
    from transgen.schemas import validate

    out = tmp_path / "rav"
    code = main(["synthesize", "topology", "--sets", "1", "--ravigneaux", "1", "--brakes", "2", "--clutches", "3",
                 "--ratios", "1=2.4,2=1.4667,3=1.0,OD=0.6667,R=-2.0", "--top", "2", "-o", str(out), "--json"])
    assert code == 0
    doc = json.loads(capsys.readouterr().out)
    validate(doc)
    assert doc["request"]["ravigneaux"] == 1 and doc["request"]["grounded"] == 0
    text = (out / "candidate_01.mech").read_text()
    assert "pinions=2" in text and text.count("\nshare ") == 3
    assert (out / "candidate_01_levers.svg").exists()
