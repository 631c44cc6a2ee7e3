"""Shared gears: the ``share`` statement (transgen.language_share), its round trip through
transgen.mech_format, and the rules ``synthesize teeth`` draws from it (transgen.synthesis.shares).

Checked against: located diagnostics for every rule of the statement; the kinematics of the
bundled Ravigneaux mechanisms with and without their shares; the HowStuffWorks Ravigneaux's
published teeth (30/36/72, HSW_9 in mechanisms/hsw_ravigneaux4.mech); and the search with shares
against the search without them filtered by the rules written out here by hand.
"""
from __future__ import annotations

import math
import re

import pytest

from transgen import load_mechanism, parse_mechanism
from transgen.cli import main
from transgen.errors import MechValidationError
from transgen.kinematics import gear_ratios
from transgen.mech_format import format_mechanism
from transgen.model import Share, share_groups
from transgen.synthesis.shares import double_pinions_fit, share_rules
from transgen.synthesis.teeth import AssemblyRules, planet_counts, ratio_targets, synthesize_teeth

RAVIGNEAUX = ("hsw_ravigneaux4", "mb7g_tronic")
"""The bundled mechanisms with a Ravigneaux set."""


def _bare(name: str) -> str:
    """The bundled text without its share statements."""
    return "\n".join(line for line in load_mechanism(name).text.split("\n") if not line.startswith("share "))


HSW = _bare("hsw_ravigneaux4")


def _error(extra: str) -> str:
    with pytest.raises(MechValidationError) as exc:
        parse_mechanism(HSW + "\n" + extra + "\n", "x.mech")
    return str(exc.value)


# ------------------------------------------------------------------------------ the language


def test_the_bundled_ravigneaux_sets_declare_their_shares():
    hsw = load_mechanism("hsw_ravigneaux4")
    assert hsw.shares == (Share("PG_small", "ring", "PG_large", "ring"), Share("PG_small", "carrier", "PG_large", "carrier"),
                          Share("PG_small", "outer_pinion", "PG_large", "pinion"))
    mb7 = load_mechanism("mb7g_tronic")
    assert {(g[0][1], g[1][1]) for g in share_groups(mb7.shares)} == {("sun", "sun"), ("carrier", "carrier"),
                                                                        ("pinion", "inner_pinion")}


@pytest.mark.parametrize("name", RAVIGNEAUX)
def test_shares_leave_the_ratios_unchanged(name):
    with_shares, without = load_mechanism(name), parse_mechanism(_bare(name))
    assert with_shares.shares and not without.shares
    assert gear_ratios(with_shares) == gear_ratios(without)


@pytest.mark.parametrize("name", RAVIGNEAUX)
def test_shares_are_written_back(name):
    m = load_mechanism(name)
    text = format_mechanism(m)
    assert [line for line in text.split("\n") if line.startswith("share ")] == [
        f"share {s.set1}.{s.member1} {s.set2}.{s.member2}" for s in m.shares]
    assert parse_mechanism(text) == m
    assert parse_mechanism(_bare(name)) != m  # the shares are part of the model


def test_a_share_may_come_before_the_sets_it_names():
    lines = HSW.split("\n")
    at = next(i for i, line in enumerate(lines) if line.startswith("planetary "))
    m = parse_mechanism("\n".join(lines[:at] + ["share PG_large.ring PG_small.ring"] + lines[at:]))
    assert m.shares == (Share("PG_large", "ring", "PG_small", "ring"),)


LINE = len(HSW.split("\n")) + 1
"""The line of a statement appended to HSW."""


@pytest.mark.parametrize("extra, column, message", [
    ("share PG_x.ring PG_large.ring", 7, "unknown planetary 'PG_x'; did you mean 'PG_small'?"),
    ("share PG_small.rng PG_large.ring", 16, "planetary PG_small has no member 'rng'; did you mean 'ring'? (members: "
                                             "sun, ring, carrier, inner_pinion, outer_pinion)"),
    ("share PG_small.ring PG_large.outer_pinion", 30, "planetary PG_large has no member 'outer_pinion'"),
    ("share IN.ring PG_large.ring", 7, "'IN' is a link, not a planetary"),
    ("share PG_small.ring PG_small.ring", 21, "a set cannot share a gear with itself"),
    ("share PG_small.sun PG_small.ring", 20, "a set cannot share a gear with itself"),
    ("share PG_small.ring PG_large.sun", 21, "a ring and a sun cannot be one gear"),
    ("share PG_small.sun PG_large.sun", 20, "a shared sun is one link, but PG_small.sun is 'Ss' and PG_large.sun "
                                            "is 'Sl'"),
    ("share PG_small.ring PG_large.ring\nshare PG_large.ring PG_small.ring", 1,
     "PG_large.ring and PG_small.ring are already one gear (share at line {line})"),
    ("share PG_small.inner_pinion PG_large.pinion\nshare PG_large.pinion PG_small.outer_pinion", 1,
     "conflicting shares: with this one PG_small.inner_pinion and PG_small.outer_pinion would be one gear"),
    ("share PG_small ring", 7, "unexpected 'PG_small'; expected a planetary member SET.MEMBER"),
])
def test_bad_shares_are_located_errors(extra, column, message):
    text = _error(extra) if "SET.MEMBER" not in message else _syntax(extra)
    line = LINE + extra.count("\n")
    assert any(row.startswith(f"x.mech:{line}:{column}: error: ") and message.format(line=LINE) in row
               for row in text.split("\n")), text


def _syntax(extra: str) -> str:
    from transgen.errors import MechSyntaxError

    with pytest.raises(MechSyntaxError) as exc:
        parse_mechanism(HSW + "\n" + extra + "\n", "x.mech")
    return str(exc.value)


def test_a_shared_pinion_needs_a_shared_gear_it_meshes():
    """The kinematics know nothing of shares: a pinion is one only if a gear it meshes in both
    sets is one too (with the carrier, that fixes its one speed)."""
    message = "a pinion turns with the gears it meshes, and PG_small and PG_large share none of them"
    assert message in _error("share PG_small.outer_pinion PG_large.pinion")
    assert message in _error("share PG_small.inner_pinion PG_large.pinion\nshare PG_small.ring PG_large.ring")
    parse_mechanism(HSW + "\nshare PG_large.pinion PG_small.outer_pinion\nshare PG_large.ring PG_small.ring\n")


def test_shared_gears_must_agree_on_links_and_known_teeth():
    other = HSW.replace("ring=OUT_R carrier=C Ns=36", "ring=C carrier=OUT_R Ns=36")
    with pytest.raises(MechValidationError, match="a shared pinion turns on one carrier, but PG_small.carrier is 'C'"):
        parse_mechanism(other + "\nshare PG_small.outer_pinion PG_large.pinion\n")
    unequal = HSW.replace("Ns=36 Nr=72", "Ns=36 Nr=74")
    with pytest.raises(MechValidationError, match="one gear has one tooth count, but PG_small has Nr=72 and PG_large "
                                                  "has Nr=74"):
        parse_mechanism(unequal + "\nshare PG_small.ring PG_large.ring\n")


def test_bad_share_exits_2_on_the_command_line(tmp_path, capsys):
    path = tmp_path / "bad.mech"
    path.write_text(HSW + "\nshare PG_small.ring PG_large.sun\n")
    assert main(["check", str(path)]) == 2
    assert f"bad.mech:{LINE}:21: error: share PG_small.ring PG_large.sun" in capsys.readouterr().err


def test_share_is_a_reserved_word():
    with pytest.raises(MechValidationError, match="'share' is a reserved word"):
        parse_mechanism(HSW.replace("link IN ", "link share J=1\nlink IN "))


# ------------------------------------------------------------------------------ tooth counts


def test_double_pinion_fit_by_hand():
    """HSW: small sun 30, ring 72, long (outer) pinion (72 - 36)/2 = 18. The short pinion Ni must
    clear the ring (30 + 2 Ni + 4 < 72: Ni <= 18) and reach the long one (|72 - 18 - 30 - Ni| <=
    Ni + 18: Ni >= 3), so 17 and 18 teeth fit at 17 minimum; the long pinion clears the small sun
    (72 - 36 > 34)."""
    assert [ni for ni in range(1, 40) if double_pinions_fit(30, 72, ni, 18, 17)] == [17, 18]
    assert [ni for ni in range(1, 40) if double_pinions_fit(30, 72, ni, 18, 1)] == list(range(3, 19))
    assert not double_pinions_fit(33, 72, 17, 18, 17)  # large sun 36 only 3 teeth above the small sun


def test_bundled_teeth_obey_their_shares():
    rules = AssemblyRules(k_min=1.2)

    def counts(ns, nr, pinions):
        return planet_counts(ns, nr, pinions, rules)
    hsw = load_mechanism("hsw_ravigneaux4")
    teeth = {p.name: (p.n_sun, p.n_ring) for p in hsw.planetaries}
    assert share_rules(hsw).planets(teeth, rules, counts) == {"PG_small": 3, "PG_large": 3}  # 42/3, 108/3
    mb7 = load_mechanism("mb7g_tronic")
    teeth = {p.name: (p.n_sun, p.n_ring) for p in mb7.planetaries}
    # long pinion (86 - 42)/2 = 22 at (42 + 86)/4 = 32 = (42 + 22)/2; 128/4 and 68/4 whole
    assert share_rules(mb7).planets(teeth, rules, counts) == {"rav_long": 4, "rav_short": 4}
    assert share_rules(mb7).planets(teeth | {"rav_short": (44, 110)}, rules, counts) is None  # two suns
    assert share_rules(parse_mechanism(_bare("mb7g_tronic"))) is None


def _hand_rules(teeth: dict, rules: AssemblyRules) -> bool:
    """The HSW Ravigneaux's shares written out: one ring; the long pinion (Nr - Nsl)/2 is PG_small's
    outer pinion, so a short pinion must fit; one planet count."""
    (ns, nr), (nl, nr2) = teeth["PG_small"], teeth["PG_large"]
    if nr != nr2:
        return False
    long_pinion = (nr - nl) // 2
    short = [ni for ni in range(rules.min_teeth, nr) if ns + 2 * ni + 4 < nr and nr - 2 * long_pinion > ns + 4
             and abs(nr - long_pinion - ns - ni) <= ni + long_pinion]
    common = set(planet_counts(ns, nr, 2, rules)) & set(planet_counts(nl, nr, 1, rules))
    return bool(short and common)


def test_hsw_ravigneaux_teeth_with_shares_are_buildable_and_the_published_first():
    """Measured: without the shares 1806 answers, 19 with equal rings; with them 13, all
    buildable, the published 30/36/72 first; the same 13 as the answers without shares that obey
    the rules by hand."""
    rules = AssemblyRules()
    unknown = lambda text: parse_mechanism(re.sub(r"Ns=\d+ Nr=\d+", "Ns=? Nr=?", text), "u.mech", unknown_teeth=True)
    shared = unknown(load_mechanism("hsw_ravigneaux4").text)
    result = synthesize_teeth(shared, ratio_targets(shared), rules, top=0)
    bare = unknown(HSW)
    before = synthesize_teeth(bare, ratio_targets(bare), rules, top=0)
    teeth = [{t.name: (t.n_sun, t.n_ring) for t in s.teeth} for s in result.solutions]
    old = [{t.name: (t.n_sun, t.n_ring) for t in s.teeth} for s in before.solutions]
    print(f"hsw_ravigneaux4: {before.count} answers without shares, "
          f"{sum(t['PG_small'][1] == t['PG_large'][1] for t in old)} with equal rings; {result.count} with shares")
    assert before.count == 1806 and result.count == len(result.solutions) == 13
    assert teeth[0] == {"PG_small": (30, 72), "PG_large": (36, 72)}
    assert [t for t in old if _hand_rules(t, rules)] == teeth
    for s in result.solutions:  # both sets report the one planet count of the long pinions
        assert s.teeth[0].planets == s.teeth[1].planets


def test_a_known_set_constrains_its_unknown_partner():
    text = re.sub(r"(planetary PG_small .*?)Ns=\d+ Nr=\d+", r"\1Ns=? Nr=?", load_mechanism("hsw_ravigneaux4").text)
    m = parse_mechanism(text, "u.mech", unknown_teeth=True)
    result = synthesize_teeth(m, ratio_targets(m), top=0)
    assert result.count >= 1 and all(s.teeth[0].n_ring == 72 for s in result.solutions)
    assert (result.solutions[0].teeth[0].n_sun, result.solutions[0].teeth[0].planets) == (30, 3)


def test_the_completed_file_keeps_its_shares(tmp_path, capsys):
    path = tmp_path / "u.mech"
    path.write_text(re.sub(r"Ns=\d+ Nr=\d+", "Ns=? Nr=?", load_mechanism("hsw_ravigneaux4").text))
    done = tmp_path / "done.mech"
    assert main(["synthesize", "teeth", str(path), "-o", str(done)]) == 0
    m = load_mechanism(done)
    assert m.shares == load_mechanism("hsw_ravigneaux4").shares
    assert math.isclose(gear_ratios(m)["1"], 2.4)


def test_no_solution_with_shares_lists_only_candidates_that_obey_them(tmp_path, capsys):
    path = tmp_path / "u.mech"
    path.write_text(re.sub(r"Ns=\d+ Nr=\d+", "Ns=? Nr=?", load_mechanism("hsw_ravigneaux4").text))
    assert main(["synthesize", "teeth", str(path), "--ratios", "1=2.4,2=1.47,3=1,OD=0.67,R=-2.5"]) == 1
    out = capsys.readouterr().out
    assert "note: shared gears (PG_small.ring = PG_large.ring" in out
    assert "none of them obeys the shares" in out


# ------------------------------------------------------------------------------ lever


@pytest.mark.parametrize("name", RAVIGNEAUX)
def test_a_ravigneaux_set_is_one_four_node_lever(name):
    """The sets on one pinion share its carrier and a gear it meshes (the language requires it),
    so the lever layout, combining levers on two common nodes, draws them as one lever."""
    from transgen.drawing.lever import lever_layout

    m = load_mechanism(name)
    levers = lever_layout(m)
    for group in share_groups(m.shares):
        sets = {s for s, _ in group}
        lever = next(lv for lv in levers if sets <= set(lv.sets))
        assert len(lever.nodes) == 4 and len(lever.sets) == 2
    if name == "hsw_ravigneaux4":
        # Benford-Leising in PG_small's units: S-R = Nr - Ns = 42, R-C = Ns = 30; PG_large's C-S
        # is Nr = 72 where its R-C is Ns = 36, so 72 * 30/36 = 60 beyond C
        assert [(n.link, n.position) for n in lever.nodes] == [("Ss", 0), ("OUT_R", 42), ("C", 72), ("Sl", 132)]
