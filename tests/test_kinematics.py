"""Kinematics (DOF, ratios, classification, gear table checks) against an independent exact method
(tests/independent.py: constraints written from the Mechanism, exact rational elimination)."""
from __future__ import annotations

import random
from fractions import Fraction

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from sympy import Rational

import independent as ind
from transgen import bundled_mechanisms, load_mechanism, parse_mechanism
from transgen.graph import build_graph
from transgen.kinematics import analyze, check_gears, combinations, gear_ratios, gear_table

BUNDLED = bundled_mechanisms()


@pytest.fixture(scope="module")
def ht740():
    return load_mechanism("ht740")


def _same(combo, ref, where=""):
    """transgen's Combination equals the exact independent result."""
    msg = f"{where} engaged={combo.engaged}: transgen {combo} vs independent {ref}"
    assert combo.dof == ref.dof, msg
    assert combo.kind == ref.kind, msg
    if ref.ratio is None:
        assert combo.ratio is None, msg
    else:
        assert combo.ratio is not None, msg
        assert abs(combo.ratio - float(ref.ratio)) <= 1e-9 * max(1.0, abs(float(ref.ratio))), msg
    if ref.kind == "gear":
        assert combo.floating == ref.floating, msg
    if ref.kind == "other":
        assert combo.detail == ref.detail, msg


# ---------------------------------------------------------------------------------------------
# the independent method itself, on hand-checked cases


def test_independent_method_on_hand_checked_cases():
    m = parse_mechanism("""
link A J=1
link B J=1
link C J=1
gears G A B N1=20 N2=60
gears H B C N1=30 N2=15 mesh=internal
clutch K A C static=1 dynamic=1
brake Q B static=1 dynamic=1
input A
output C
""")
    assert ind.constraint_matrix(m).tolist() == [[20, 60, 0], [0, 30, -15]]
    free = ind.kinematics(m)
    # w_B = -w_A/3, w_C = 2 w_B = -2/3 w_A: ratio A/C = -3/2, one DOF
    assert (free.dof, free.kind, free.ratio, free.floating) == (1, "gear", Rational(-3, 2), ())
    assert ind.kinematics(m, ("K",)).kind == "tie-up"
    held = ind.kinematics(m, ("Q",))
    assert (held.dof, held.kind) == (0, "tie-up")
    p = parse_mechanism("""
link S J=1
link R J=1
link C J=1
planetary P sun=S ring=R carrier=C Ns=30 Nr=90 pinions=2
brake B R static=1 dynamic=1
input S
output C
""")
    # double pinion, ring held: -Ns ws = (Nr - Ns) wc -> ws/wc = -(90-30)/30 = -2
    assert ind.kinematics(p, ("B",)).ratio == -2
    other = ind.kinematics(p, ())
    assert (other.dof, other.kind) == (2, "neutral")


# ---------------------------------------------------------------------------------------------
# every combination of every bundled mechanism


@pytest.mark.parametrize("name", sorted(BUNDLED))
def test_every_combination_matches_the_exact_method(name):
    mech = load_mechanism(BUNDLED[name])
    g = build_graph(mech)
    combos = ind.all_combinations(mech)
    assert len(combos) == 2 ** len(mech.elements)
    for engaged in combos:
        _same(analyze(mech, engaged, g), ind.kinematics(mech, engaged), name)


@pytest.mark.parametrize("name", ["ht740", "simple2", "hsw_ravigneaux4", "zf3hp22_big"])
def test_combinations_lists_all_2_to_the_k_in_order(name):
    mech = load_mechanism(name)
    got = combinations(mech)
    expected = ind.all_combinations(mech)
    assert [c.engaged for c in got] == expected
    for c in got:
        _same(c, ind.kinematics(mech, c.engaged), name)
    assert [c.engaged for c in combinations(mech, max_engaged=1)] == [e for e in expected if len(e) <= 1]


@pytest.mark.parametrize("name", sorted(BUNDLED))
def test_declared_gears_reproduce_their_published_ratio(name):
    mech = load_mechanism(BUNDLED[name])
    for gear in mech.gears:
        ref = ind.kinematics(mech, gear.engaged)
        if gear.kind == "neutral":
            assert ref.kind == "neutral", gear
            continue
        assert ref.kind == "gear", gear
        if gear.ratio is not None:
            written = Fraction(gear.ratio)
            decimals = len(gear.ratio.split(".")[1]) if "." in gear.ratio else 0
            exact = Fraction(int(ref.ratio.p), int(ref.ratio.q))
            # the printed precision, or the file's explicit tol= where the source's digits disagree
            bound = Fraction(gear.tolerance) if gear.tolerance is not None else Fraction(1, 2 * 10 ** decimals)
            assert abs(exact - written) <= bound, (gear, exact)
    assert check_gears(mech) == []


# ---------------------------------------------------------------------------------------------
# HT-740 (thesis 3.4.2) and the other worked examples


def test_ht740_degrees_of_freedom(ht740):
    g = build_graph(ht740)
    assert analyze(ht740, (), g).dof == 3
    for e in ht740.element_names:
        assert analyze(ht740, (e,), g).dof == 2, e
    for gear in ht740.gears:
        if gear.kind == "gear":
            assert len(gear.engaged) == 2
            assert analyze(ht740, gear.engaged, g).dof == 1, gear


def test_ht740_ratios(ht740):
    ratios = gear_ratios(ht740)
    assert list(ratios) == ["1", "2", "3", "4", "R"]
    assert {k: round(v, 2) for k, v in ratios.items()} == {"1": 3.69, "2": 2.02, "3": 1.38, "4": 1.00, "R": -6.04}
    # the exact values given in ht740.mech's comments, by the independent method
    exact = {g.name: ind.kinematics(ht740, g.engaged).ratio for g in ht740.gears if g.kind == "gear"}
    assert exact == {"1": Rational(48, 13), "2": Rational(103, 51), "3": Rational(47, 34), "4": 1, "R": Rational(-1021, 169)}
    for name, r in exact.items():
        assert ratios[name] == pytest.approx(float(r), rel=1e-12)


def test_ht740_gear_table(ht740):
    table = gear_table(ht740)
    rows = {r.name: r for r in table.gears}
    assert [r.name for r in table.gears] == ["1", "2", "3", "4", "R", "N"]
    assert rows["N"].kind == "neutral" and rows["N"].combination.kind == "neutral" and rows["N"].dof == 2
    assert all(rows[n].matches_published for n in "1234R")
    assert rows["1"].step == pytest.approx((48 / 13) / (103 / 51))
    assert rows["3"].step == pytest.approx(47 / 34)
    assert rows["4"].step is None and rows["R"].step is None and rows["N"].step is None
    assert table.spread == pytest.approx(48 / 13)
    assert len(table.combinations) == 32
    assert gear_table(ht740, all_combinations=False).combinations == ()
    d = table.to_dict()
    assert d["gears"][0]["ratio"] == pytest.approx(48 / 13) and d["gears"][0]["engaged"] == ["C1", "C5"]
    assert len(d["combinations"]) == 32


def test_simple2_ratios_are_exact():
    m = load_mechanism("simple2")
    assert {g.name: ind.kinematics(m, g.engaged).ratio for g in m.gears} == {"1": Rational(20, 3), "2": Rational(40, 11)}
    assert gear_ratios(m) == pytest.approx({"1": 20 / 3, "2": 40 / 11}, rel=1e-12)
    none = analyze(m, ())
    assert (none.dof, none.kind) == (2, "neutral")
    both = analyze(m, ("C1", "C2"))
    assert (both.dof, both.kind, both.ratio) == (0, "tie-up", None)


def test_ravigneaux_ratios_are_exact():
    m = load_mechanism("hsw_ravigneaux4")
    exact = {g.name: ind.kinematics(m, g.engaged).ratio for g in m.gears}
    assert exact == {"1": Rational(12, 5), "2": Rational(22, 15), "3": 1, "OD": Rational(2, 3), "R": -2}
    assert gear_ratios(m) == pytest.approx({k: float(v) for k, v in exact.items()}, rel=1e-12)


# ---------------------------------------------------------------------------------------------
# classification and check_gears on small inline mechanisms

SMALL = """\
link A J=1
link B J=2
link X J=0.5
link Y J=0.5
gears G A B N1=20 N2=40
clutch K A B static=10 dynamic=8
clutch KX X Y static=10 dynamic=8
brake BY Y static=10 dynamic=8
brake BA A static=10 dynamic=8
input A
output B
"""


def test_classification_on_a_small_mechanism():
    m = parse_mechanism(SMALL)
    free = analyze(m, ())
    assert (free.dof, free.kind, free.floating) == (3, "gear", ("X", "Y"))
    assert free.ratio == pytest.approx(-2.0)
    k = analyze(m, ("K",))  # A = B and 20 A = -40 B: both held, X and Y still turn
    assert (k.kind, k.dof, k.detail) == ("other", 2, "input and output held")
    assert (analyze(m, ("K", "BY", "KX")).kind, analyze(m, ("K", "BY", "KX")).dof) == ("tie-up", 0)
    held = analyze(m, ("BA",))
    assert (held.kind, held.detail, held.ratio) == ("other", "input and output held", None)
    y = analyze(m, ("BY",))
    assert (y.kind, y.floating, y.dof) == ("gear", ("X",), 2)
    xy = analyze(m, ("BY", "KX"))
    assert (xy.kind, xy.floating, xy.dof) == ("gear", (), 1)
    for c in ind.all_combinations(m):
        _same(analyze(m, c), ind.kinematics(m, c), "SMALL")


def test_neutral_and_held_output_are_told_apart():
    m = parse_mechanism("""\
link A J=1
link B J=1
link C J=1
planetary P sun=A ring=B carrier=C Ns=30 Nr=60
brake BA A static=1 dynamic=1
brake BC C static=1 dynamic=1
brake BB B static=1 dynamic=1
input A
output C
""")
    assert analyze(m, ()).kind == "neutral"
    assert (analyze(m, ("BC",)).kind, analyze(m, ("BC",)).detail) == ("other", "output held")
    assert (analyze(m, ("BA",)).kind, analyze(m, ("BA",)).detail) == ("other", "input held")
    assert analyze(m, ("BB",)).ratio == pytest.approx(3.0)  # (Ns + Nr)/Ns
    assert analyze(m, ("BA", "BB")).kind == "tie-up"


GEARS_BASE = SMALL.rstrip("\n")


def _check(extra: str):
    m = parse_mechanism(GEARS_BASE + "\n" + extra, "g.mech")
    return m, check_gears(m)


def test_check_gears_accepts_a_gear_with_a_floating_member():
    m, problems = _check("gear 1 = BY ratio=-2.0")
    assert problems == []
    row = gear_table(m, all_combinations=False).gears[0]
    assert row.combination.floating == ("X",)
    assert row.matches_published is True
    assert gear_table(m, all_combinations=False).to_dict()["gears"][0]["floating"] == ["X"]


def test_check_gears_flags_a_tie_up():
    text_extra = "gear 1 = BY\ngear 2 = K BY KX ratio=1\n"
    m, problems = _check(text_extra)
    assert len(problems) == 1
    d = problems[0]
    assert "ties up" in d.message and "gear 2" in d.message
    line = GEARS_BASE.count("\n") + 3
    assert (d.filename, d.line, d.column) == ("g.mech", line, len("gear ") + 1)
    assert d.source_line == "gear 2 = K BY KX ratio=1"
    assert f"g.mech:{line}:6: error: " in d.format()


def test_check_gears_flags_an_undetermined_ratio():
    m = parse_mechanism("""\
link A J=1
link B J=1
link C J=1
planetary P sun=A ring=B carrier=C Ns=30 Nr=60
clutch K A B static=1 dynamic=1
brake BC C static=1 dynamic=1
input A
output C
gear 1 = BC
gear 2 = K
""", "u.mech")
    problems = check_gears(m)
    assert [(d.line, d.column) for d in problems] == [(9, 6)]
    assert "does not determine the input/output ratio" in problems[0].message
    assert "output held" in problems[0].message
    assert gear_ratios(m) == {"1": None, "2": pytest.approx(1.0)}


def test_check_gears_flags_a_mismatched_published_ratio():
    m, problems = _check("gear 1 = BY ratio=-2.1\ngear 2 = BY ratio=-2.0\ngear 3 = BY ratio=-2\ngear 4 = BY ratio=2.0\n")
    first = GEARS_BASE.count("\n") + 2
    assert [(d.line, d.column) for d in problems] == [(first, 6), (first + 3, 6)]
    assert "computed ratio -2 does not match the declared ratio=-2.1" in problems[0].message
    assert "ratio=2.0" in problems[1].message


def test_published_ratio_tolerance_is_half_a_unit_of_the_last_digit():
    # -2 exactly: "-2.004" misses (half unit 5e-4), "-2.0004" misses, "-2.00" and "-20e-1" match
    m, problems = _check("gear 1 = BY ratio=-2.004\ngear 2 = BY ratio=-2.00\ngear 3 = BY ratio=-20e-1\ngear 4 = BY ratio=-2.0004\n")
    first = GEARS_BASE.count("\n") + 2
    assert [d.line for d in problems] == [first, first + 3]
    rows = gear_table(m, all_combinations=False).gears
    assert [r.matches_published for r in rows] == [False, True, True, False]


def test_check_gears_flags_a_neutral_that_is_not_neutral():
    m, problems = _check("neutral N = BY\nneutral N2 = KX\n")
    # BY leaves the gear pair turning: a gear (ratio -2), not a neutral; KX likewise
    assert len(problems) == 2
    assert "neutral N (BY) is not a neutral: it is gear with ratio -2" in problems[0].message


# ---------------------------------------------------------------------------------------------
# property: random mechanisms


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.integers(0, 2**32 - 1))
def test_random_mechanisms_match_the_exact_method(seed):
    text = ind.random_mechanism_text(random.Random(seed))
    mech = parse_mechanism(text)
    g = build_graph(mech)
    for engaged in ind.all_combinations(mech):
        _same(analyze(mech, engaged, g), ind.kinematics(mech, engaged), text)
