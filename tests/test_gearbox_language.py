"""Language features met while writing real gearboxes (issue 13, section 5): floating members in
the ratios table, truncated and toleranced published ratios, alternative gears, the one-way
clutch direction check, neutrals with more than two DOF, stepped-pinion planetaries and dog
elements."""
from __future__ import annotations

import json

import pytest

from transgen.cli import main
from transgen.kinematics import check_gears, gear_table
from transgen.language import format_mechanism, parse_mechanism

FLOAT = """\
link A J=1
link B J=2
link X J=0.5
link Y J=0.5
gears G A B N1=20 N2=40
clutch KX X Y static=10 dynamic=8
brake BY Y static=10 dynamic=8
input A
output B
"""


def _write(tmp_path, text, name="m.mech"):
    path = tmp_path / name
    path.write_text(text)
    return str(path)


def test_ratios_table_names_the_floating_members(tmp_path, capsys):
    path = _write(tmp_path, FLOAT + "gear 1 = BY ratio=-2\n")
    assert main(["ratios", path, "--gears-only"]) == 0
    out = capsys.readouterr().out
    assert "floating" in out.splitlines()[2]
    row = [line for line in out.splitlines() if line.strip().startswith("1 ")][0]
    assert row.rstrip().endswith("X")


# --- published ratios: truncated, toleranced; a mismatch is a finding of `ratios` -------------

TRUNC = FLOAT + "brake BA A static=10 dynamic=8\n"


def _rows(extra: str):
    m = parse_mechanism(TRUNC + extra, "t.mech")
    return m, gear_table(m, all_combinations=False).gears


def test_truncated_published_ratio_is_cut_toward_zero():
    # computed -2 exactly; a truncated 3-decimal print of 1.49781 is 1.497
    m, rows = _rows("gear 1 = BY ratio=-2.000 rounding=truncated\ngear 2 = BY ratio=-1.998 rounding=truncated\n"
                    "gear 3 = BY ratio=-2.001 rounding=truncated\ngear 4 = BY ratio=-2.0000\n")
    assert [r.matches_published for r in rows] == [True, False, False, True]
    assert rows[0].published_range == pytest.approx((-2.001, -2.0))
    assert [d.line for d in check_gears(m)] == [TRUNC.count("\n") + 2, TRUNC.count("\n") + 3]


def test_truncation_of_a_positive_ratio():
    text = FLOAT.replace("N1=20 N2=40", "N1=20000 N2=29956") + "gear 1 = BY ratio=-1.497 rounding=truncated\n"
    row = gear_table(parse_mechanism(text), all_combinations=False).gears[0]
    assert row.ratio == pytest.approx(-1.4978) and row.matches_published is True
    rounded = text.replace(" rounding=truncated", "")
    assert gear_table(parse_mechanism(rounded), all_combinations=False).gears[0].matches_published is False


def test_explicit_tolerance():
    m, rows = _rows("gear 1 = BY ratio=-2.01 tol=0.01\ngear 2 = BY ratio=-2.01 tol=0.009\n")
    assert [r.matches_published for r in rows] == [True, False]
    assert "tol=0.009" in check_gears(m)[0].message


@pytest.mark.parametrize("extra, message", [
    ("gear 1 = BY tol=0.1", "give ratio=... too"),
    ("gear 1 = BY ratio=2 tol=0.1 rounding=truncated", "not both"),
    ("gear 1 = BY ratio=2 rounding=down", "rounding must be one of nearest, truncated"),
    ("gear 1 = BY ratio=2 tol=-0.1", "tol must be positive"),
    ("gear 1 = BY ratio=2 tol=nan", "NaN"),
])
def test_bad_tolerances_are_located_errors(extra, message):
    from transgen.errors import MechValidationError

    with pytest.raises(MechValidationError) as exc:
        parse_mechanism(TRUNC + extra + "\n")
    assert message in str(exc.value)


def test_tolerances_round_trip_through_format():
    m = parse_mechanism(TRUNC + "gear 1 = BY ratio=-2.000 rounding=truncated\ngear 2 = BY ratio=-2.01 tol=0.01\n")
    assert parse_mechanism(format_mechanism(m)) == m


def test_ratios_reports_a_mismatch_with_the_table_and_exit_1(tmp_path, capsys):
    path = _write(tmp_path, TRUNC + "gear 1 = BY ratio=-2.1\ngear 2 = BY ratio=-2\n")
    assert main(["ratios", path]) == 1
    out = capsys.readouterr().out
    assert "MISMATCH" in out and "-2 ok" in out and "all " in out  # table and combinations printed
    assert f"{path}:{TRUNC.count(chr(10)) + 1}:6: warning: gear 1: computed ratio -2" in out
    assert main(["ratios", path, "--json"]) == 1
    data = json.loads(capsys.readouterr().out)
    assert [g["matches_published"] for g in data["gears"]] == [False, True]
    assert len(data["findings"]) == 1 and data["findings"][0]["line"] == TRUNC.count("\n") + 1
    from transgen.schemas import validate
    validate(data)
    # check still refuses the file (exit 2): a published ratio that does not hold is an error there
    assert main(["check", path]) == 2
    assert "error: gear 1: computed ratio -2 does not match the declared ratio=-2.1" in capsys.readouterr().err


def test_ratios_exit_0_without_mismatch(tmp_path, capsys):
    assert main(["ratios", _write(tmp_path, TRUNC + "gear 1 = BY ratio=-2\n"), "--gears-only"]) == 0
    assert "published ratio" not in capsys.readouterr().out


# --- alternative gears -------------------------------------------------------------------------

SIMPSON = """\
link IN  J=0.10
link S   J=0.02
link Rf  J=0.03
link OUT J=0.20
link Cr  J=0.04
planetary front sun=S ring=Rf  carrier=OUT Ns=35 Nr=73
planetary rear  sun=S ring=OUT carrier=Cr  Ns=35 Nr=73
clutch FWD IN Rf static=900 dynamic=760
clutch DIR IN S  static=900 dynamic=760
brake  B2  S  static=700 dynamic=600 type=band
brake  BLR Cr static=1500 dynamic=1300
input IN
output OUT
gear 1 = FWD BLR
gear 2 = FWD B2
gear 3 = FWD DIR
gear R = DIR BLR
"""


def test_an_alternative_gear_after_top_gets_no_step_and_no_speed_phase():
    from transgen.modes import select_modes

    # first gear declared only as the alternative (manual) low, after top gear
    text = SIMPSON.replace("gear 1 = FWD BLR\n", "") + "gear L = FWD BLR alternative\n"
    m = parse_mechanism(text)
    assert [g.alternative for g in m.gears] == [False, False, False, True]
    table = gear_table(m, all_combinations=False)
    steps = {r.name: r.step for r in table.gears}
    assert steps["L"] is None and steps["3"] is None and steps["2"] == pytest.approx(table.gears[0].ratio)
    assert table.spread == pytest.approx(table.gears[0].ratio)  # 2 over 3 (= 1): L is left out
    labels = [mode.label for mode in select_modes(m, "default")]
    assert not any("L" in label.split("speed phase")[-1] for label in labels if "speed phase" in label)
    assert "alternative gear L" in labels
    # without the mark, the gear declared after top gear gets a step and a spurious speed phase
    unmarked = parse_mechanism(text.replace(" alternative", ""))
    labels = [mode.label for mode in select_modes(unmarked, "default")]
    assert any("3-L" in label for label in labels)


def test_alternative_is_shown_and_round_trips(tmp_path, capsys):
    text = SIMPSON + "gear L = FWD BLR alternative ratio=2.479\n"
    m = parse_mechanism(text)
    assert parse_mechanism(format_mechanism(m)) == m
    assert main(["ratios", _write(tmp_path, text), "--gears-only"]) == 0
    out = capsys.readouterr().out
    assert "L (alt)" in out and "alternative gear" in out
    assert main(["ratios", _write(tmp_path, text), "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert [g["alternative"] for g in data["gears"]] == [False, False, False, False, True]


@pytest.mark.parametrize("extra, message", [
    ("gear L = FWD alternative alternative", "'alternative' is given twice"),
    ("neutral N = FWD alternative", "marks a gear row"),
    ("gear L = alternative", "engages no element"),
    ("clutch alternative IN OUT static=1 dynamic=1", "reserved word"),
])
def test_alternative_misuse(extra, message):
    from transgen.errors import MechValidationError

    with pytest.raises(MechValidationError) as exc:
        parse_mechanism(SIMPSON + extra + "\n")
    assert message in str(exc.value)


# --- one-way clutch direction under drive ------------------------------------------------------

ZF3HP22 = SIMPSON.replace("input IN", "oneway OWC Cr free=positive\ninput IN").replace(
    "gear 1 = FWD BLR", "gear 1 = FWD OWC").replace("gear R = DIR BLR", "gear R = DIR BLR")


def test_drive_torques_of_a_simpson_first_gear():
    from transgen.kinematics import gear_ratios
    from transgen.statics import drive_torques

    m = parse_mechanism(ZF3HP22)
    ratio = gear_ratios(m)["1"]
    t = drive_torques(m, ("FWD", "OWC"))
    # the held rear carrier reacts ratio - 1 input torques; FWD carries the whole input torque
    assert t["FWD"] == pytest.approx(1.0) and t["OWC"] == pytest.approx(-(ratio - 1.0))
    assert drive_torques(m, ("FWD",)) is None  # not a one-DOF gear


@pytest.mark.parametrize("name", ["zf3hp22_big", "mb722_6_w5a580_2004", "simple2_oneway", "ht740"])
def test_drive_torques_agree_with_the_simulators_static_balance(name):
    from transgen.language import load_mechanism
    from transgen.sim.derive.launch import static_element_torques
    from transgen.statics import drive_torques

    m = load_mechanism(name)
    for gear in m.gears:
        ours = drive_torques(m, gear.engaged)
        if ours is None:
            continue
        theirs = static_element_torques(m, gear.engaged)
        for label, t in ours.items():
            assert theirs[label.split("+")[0]] == pytest.approx(t, abs=1e-9), (gear.name, label)


def test_a_flipped_oneway_is_an_error_at_its_line(tmp_path, capsys):
    from transgen.statics import check_oneways

    assert check_oneways(parse_mechanism(ZF3HP22)) == []
    flipped = ZF3HP22.replace("free=positive", "free=negative")
    problems = check_oneways(parse_mechanism(flipped, "f.mech"))
    line = flipped.splitlines().index("oneway OWC Cr free=negative") + 1
    assert [(d.line, d.column) for d in problems] == [(line, 8)]
    assert "would overrun" in problems[0].message and "gear 1" in problems[0].message
    path = _write(tmp_path, flipped)
    assert main(["check", path]) == 2
    assert f"{path}:{line}:8: error: one-way clutch OWC (free=negative" in capsys.readouterr().err
    assert main(["ratios", path]) == 2


def test_oneway_beside_an_applied_brake_is_not_flagged():
    from transgen.statics import check_oneways

    # reverse DIR BLR: the group BLR+OWC holds torque in the one-way clutch's free direction,
    # which the brake takes
    m = parse_mechanism(ZF3HP22)
    assert check_oneways(m) == []


def test_every_bundled_mechanism_passes_the_oneway_check():
    from transgen.language import load_mechanism
    from transgen.library import bundled_mechanisms
    from transgen.statics import check_oneways

    for name in bundled_mechanisms():
        assert check_oneways(load_mechanism(name)) == [], name


# --- the default neutral with more than two DOF ------------------------------------------------

def test_neutral_with_three_dof_is_modelled():
    from transgen.language import load_mechanism
    from transgen.modes import mode_models, neutral_note

    for name, locked, dof in (("zf3hp22_big", (), 3), ("mb722_6_w5a580_2004", ("F1",), 3)):
        m = load_mechanism(name)
        models = {mm.mode.label: mm for mm in mode_models(m)}
        neutral = [mm for label, mm in models.items() if label.startswith("neutral")]
        assert len(neutral) == 1, name
        assert neutral[0].locked == locked and neutral[0].dof == dof and neutral[0].kind == "neutral"
        assert neutral[0].equations is not None and neutral[0].problem == ""
        assert neutral_note(m) == ""


def test_state_space_grows_to_the_neutrals_dof():
    from transgen.language import load_mechanism
    from transgen.statespace import state_space

    ss = state_space(load_mechanism("zf3hp22_big"))
    assert len(ss.coordinates) == 3


def test_no_default_neutral_is_explained(tmp_path, capsys):
    from transgen.modes import neutral_note

    no_reverse = SIMPSON.replace("gear R = DIR BLR\n", "")
    assert "no reverse gear" in neutral_note(parse_mechanism(no_reverse))
    massless = SIMPSON.replace("link IN  J=0.10", "link IN  J=0")  # with FWD and DIR open, IN is loose
    note = neutral_note(parse_mechanism(massless))
    assert "share BLR" in note and "massless" in note and "neutral N = " in note
    path = _write(tmp_path, massless)
    assert main(["modes", path]) == 0
    assert "note: no neutral is modelled" in capsys.readouterr().out
    assert main(["modes", path, "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert data["notes"] == [note]
    from transgen.schemas import validate
    validate(data)
    declared = parse_mechanism(massless + "neutral N = BLR FWD\n")
    assert neutral_note(declared) == ""


# --- stepped-pinion planetary --------------------------------------------------------------------

STEP_BASE = """\
link S  J=0.1
link S2 J=0.05
link R  J=0.2
link R1 J=0.15
link C  J=0.3
brake BR R static=1 dynamic=1
brake BS S static=1 dynamic=1
brake BS2 S2 static=1 dynamic=1
clutch K S C static=1 dynamic=1
input S
output C
"""


def _stepped(line: str):
    return parse_mechanism(STEP_BASE + line + "\n")


def test_stepped_sun_and_ring_ratio_from_the_pinion_relation():
    from fractions import Fraction

    from transgen.kinematics import analyze

    ns, nr, np1, np2 = 30, 70, 20, 25
    m = _stepped(f"stepped P carrier=C sun1=S Ns1={ns} ring2=R Nr2={nr} Np1={np1} Np2={np2}")
    # ring held: (w_s - w_c)*Ns/Np1 = -(w_p - w_c) and -w_c*Nr/Np2 = w_p - w_c
    assert analyze(m, ("BR",)).ratio == pytest.approx(float(1 + Fraction(nr * np1, ns * np2)), rel=1e-12)
    assert analyze(m, ("K",)).ratio == pytest.approx(1.0)
    # equal steps: the simple planetary
    simple = parse_mechanism(STEP_BASE + f"planetary P sun=S ring=R carrier=C Ns={ns} Nr={nr}\n")
    same = _stepped(f"stepped P carrier=C sun1=S Ns1={ns} ring2=R Nr2={nr} Np1=20 Np2=20")
    assert analyze(same, ("BR",)).ratio == pytest.approx(analyze(simple, ("BR",)).ratio, rel=1e-12)


def test_stepped_two_suns_and_one_sun_two_rings():
    from transgen.kinematics import analyze

    # two suns on a stepped pinion (a stepped Ravigneaux-like set): sun2 held, sun1 input
    m = _stepped("stepped P carrier=C sun1=S Ns1=24 sun2=S2 Ns2=36 Np1=30 Np2=18")
    # (w1 - wc)*24/30 = (0 - wc)*36/18  ->  w1/wc = 1 - 2.5 = -1.5
    assert analyze(m, ("BS2",)).ratio == pytest.approx(-1.5, rel=1e-12)
    # one sun, two rings on the two steps: three members, two constraints, one DOF left with a brake
    m3 = _stepped("stepped P carrier=C sun1=S Ns1=30 ring1=R1 Nr1=80 ring2=R Nr2=70 Np1=25 Np2=20")
    assert len([n for n, d in __import__("transgen.graph", fromlist=["x"]).build_graph(m3).nodes(data=True)
                if d["kind"] == "stepped"]) == 2
    assert analyze(m3, ("BR",)).ratio == pytest.approx(1 + 70 * 25 / (30 * 20), rel=1e-12)
    assert analyze(m3, ()).dof == 3  # S, R1, R, C with two constraints, and the unconnected S2


def test_stepped_torques_conserve_power_and_match_the_lever():
    from transgen.statics import drive_torques

    text = STEP_BASE.replace("link S2 J=0.05\n", "").replace("link R1 J=0.15\n", "").replace(
        "brake BS2 S2 static=1 dynamic=1\n", "")
    m = parse_mechanism(text + "stepped P carrier=C sun1=S Ns1=30 ring2=R Nr2=70 Np1=20 Np2=25\n")
    ratio = 1 + 70 * 20 / (30 * 25)
    t = drive_torques(m, ("BR",))
    # the brake holds the output torque less the input torque (static, massless)
    assert abs(t["BR"]) == pytest.approx(ratio - 1.0, rel=1e-9)


def test_stepped_symbolic_matrices_evaluate_to_the_numeric_ones():
    import numpy as np
    import sympy

    from transgen.equations import assemble, solve, symbols_of
    from transgen.graph import build_graph

    m = _stepped("stepped P carrier=C sun1=S Ns1=30 ring2=R Nr2=70 Np1=20 Np2=25")
    g = build_graph(m)
    for locked in ((), ("BR",)):
        num = solve(assemble(g, locked), g)
        sym = solve(assemble(g, locked, symbolic=True), g)
        values = {sympy.Symbol(k, positive=True): v for k, v in
                  {**{k: v for _, d in g.nodes(data=True) for k, v in d.get("params", {}).items()},
                   **{f"J_{n}": d["J"] for n, d in g.nodes(data=True) if d["kind"] == "link"}}.items()}
        assert set(map(str, symbols_of(g))) >= {"Np1_P", "Np2_P", "Ns1_P", "Nr2_P"}
        evaluated = np.array(sym.G.xreplace(values).evalf(), dtype=float)
        assert np.allclose(evaluated, num.G, atol=1e-9)


def test_stepped_round_trip_check_json_and_drawing(tmp_path, capsys):
    m = _stepped("stepped P carrier=C sun1=S Ns1=30 ring2=R Nr2=70 Np1=20 Np2=25")
    assert parse_mechanism(format_mechanism(m)) == m
    path = _write(tmp_path, format_mechanism(m) + "gear 1 = BR\n")
    assert main(["check", path, "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert data["stepped"][0]["members"][1] == {"role": "ring2", "link": "R", "teeth": 70}
    from transgen.schemas import validate
    validate(data)
    assert main(["check", path]) == 0
    assert "(and 1 stepped-pinion)" in capsys.readouterr().out
    assert main(["graph", path, "-o", str(tmp_path / "g.dot")]) == 0
    assert "stepped pinion" in (tmp_path / "g.dot").read_text()
    assert main(["graph", path, "-o", str(tmp_path / "g.png")]) == 0


@pytest.mark.parametrize("line, message", [
    ("stepped P carrier=C sun1=S Ns1=30 Np1=20", "needs two to four central gears"),
    ("stepped P carrier=C sun1=S ring2=R Nr2=70 Np1=20 Np2=25", "sun1= needs its tooth count Ns1="),
    ("stepped P carrier=C sun1=S Ns1=30 ring2=R Nr2=70 Np1=20", "needs Np2="),
    ("stepped P carrier=C sun1=S Ns1=30 ring1=R Nr1=70 Np1=20 Np2=25", "no sun or ring meshes step 2"),
    ("stepped P carrier=C sun1=S Ns1=30 ring2=R Nr2=20 Np1=20 Np2=25", "must exceed the teeth of pinion step 2"),
    ("stepped P carrier=S sun1=S Ns1=30 ring2=R Nr2=70 Np1=20 Np2=25", "used twice"),
    ("stepped P carrier=C sun1=S Ns1=30 sun2=S2 Ns2=45 Np1=20 Np2=30", "would turn together"),
    ("stepped P sun1=S Ns1=30 ring2=R Nr2=70 Np1=20 Np2=25", "needs carrier="),
    ("stepped P carrier=C sun1=Q Ns1=30 ring2=R Nr2=70 Np1=20 Np2=25", "unknown link 'Q'"),
    ("stepped P carrier=C sun1=S Ns1=30 ring2=R Nr2=70 Np1=20 Np2=25 Ns3=4", "unknown parameter 'Ns3'"),
    ("stepped P carrier=C sun1=S Nr1=30 ring2=R Nr2=70 Np1=20 Np2=25", "give ring1=LINK too"),
])
def test_stepped_errors(line, message):
    from transgen.errors import MechValidationError

    with pytest.raises(MechValidationError) as exc:
        _stepped(line)
    assert message in str(exc.value)


def test_mb7g_tronic_reproduces_the_published_ratios():
    from transgen.language import load_mechanism

    m = load_mechanism("mb7g_tronic")
    table = gear_table(m, all_combinations=False)
    published = {"1": 4.377, "2": 2.859, "3": 1.921, "4": 1.368, "5": 1.0, "6": 0.820, "7": 0.728,
                 "R1": -3.416, "R2": -2.231}
    assert {r.name: round(r.ratio, 3) for r in table.gears} == published
    assert all(r.matches_published for r in table.gears)
    assert check_gears(m) == []
    # R2 (comfort reverse) is an alternative gear; the spread is 1st over 7th
    assert [r.name for r in table.gears if r.alternative] == ["R2"]
    assert table.spread == pytest.approx(table.gears[0].ratio / table.gears[6].ratio)


def test_stepped_teeth_are_settable_parameters():
    from transgen.kinematics import analyze
    from transgen.parameters import ParameterError, mechanism_parameters, with_parameter

    m = _stepped("stepped P carrier=C sun1=S Ns1=30 ring2=R Nr2=70 Np1=20 Np2=25")
    params = mechanism_parameters(m)
    assert {k: v for k, v in params.items() if k.startswith("P.")} == {"P.Ns1": 30, "P.Nr2": 70, "P.Np1": 20,
                                                                      "P.Np2": 25}
    changed = with_parameter(m, "P", "Np2", 20)
    assert analyze(changed, ("BR",)).ratio == pytest.approx(1 + 70 / 30)
    assert with_parameter(m, "P", "Nr2", 80).stepped[0].members[1] == ("ring2", "R", 80)
    with pytest.raises(ParameterError, match="has no parameter 'Ns2'"):
        with_parameter(m, "P", "Ns2", 30)
    with pytest.raises(ParameterError, match="must exceed the teeth of pinion step 2"):
        with_parameter(m, "P", "Np2", 90)
