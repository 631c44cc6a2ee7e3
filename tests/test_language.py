"""The .mech language: every statement of the README's language reference, located diagnostics, the
canonical writer (round trip) and robustness against arbitrary input."""
from __future__ import annotations

import math
import re
import string

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import transgen
from transgen import (
    HOUSING,
    Diagnostic,
    MechError,
    MechSyntaxError,
    MechValidationError,
    bundled_mechanisms,
    format_mechanism,
    load_mechanism,
    parse_mechanism,
)
from transgen.model import ExternalTorque, Gear, GearPair, Link, ModeDecl, Planetary, ShiftElement

BUNDLED = bundled_mechanisms()


def test_every_bundled_mechanism_is_bundled():
    # guards the parametrizations below against an empty or partial library
    assert {"simple2", "ht740", "hsw_ravigneaux4", "zf8hp45"} <= set(BUNDLED)
    assert len(BUNDLED) >= 12


# ---------------------------------------------------------------------------------------------
# helpers


def where(text: str, line: int, needle: str, occurrence: int = 1) -> tuple[int, int]:
    """(line, column) of the ``occurrence``-th ``needle`` in 1-based line ``line`` of ``text``."""
    src = text.split("\n")[line - 1]
    col = -1
    for _ in range(occurrence):
        col = src.index(needle, col + 1)
    return line, col + 1


def errors(text: str, filename: str = "f.mech", kind=MechError) -> list[Diagnostic]:
    with pytest.raises(kind) as info:
        parse_mechanism(text, filename)
    exc = info.value
    assert isinstance(exc, MechError)
    assert all(isinstance(d, Diagnostic) for d in exc.diagnostics)
    # every diagnostic of the exception is printed, in file order, located and with a caret
    assert exc.diagnostics == sorted(exc.diagnostics, key=lambda d: (d.line, d.column))
    lines = re.split(r"\r?\n", text)
    for d in exc.diagnostics:
        assert d.filename == filename
        assert d.severity == "error"
        head = f"{filename}:{d.line}:{d.column}: error: {d.message}"
        assert head in str(exc)
        if 0 < d.line <= len(lines) and lines[d.line - 1]:
            assert d.source_line == lines[d.line - 1]
            assert f"{head}\n    {d.source_line}\n    {' ' * (d.column - 1)}^" in str(exc)
    return exc.diagnostics


def value_at(text: str, line: int, key: str, occurrence: int = 1) -> tuple[int, int]:
    """(line, column) of the value of ``key=value`` in line ``line``."""
    line, col = where(text, line, f"{key}=", occurrence)
    return line, col + len(key) + 1


def only(diags: list[Diagnostic], pattern: str) -> Diagnostic:
    found = [d for d in diags if re.search(pattern, d.message)]
    assert len(found) == 1, f"expected one diagnostic matching {pattern!r}, got {[d.message for d in diags]}"
    return found[0]


def at(d: Diagnostic) -> tuple[int, int]:
    return d.line, d.column


BASE = """\
link A J=1
link B J=2
gears G A B N1=20 N2=40
input A
output B
"""


# ---------------------------------------------------------------------------------------------
# every statement of the reference


FULL = """\
# a comment line
transmission "Every statement"   # trailing comment

link IN J=0.25
link S1 J=0
link R1 J=1.5e-2
link C1 J=3
link OUT J=.5
link X J=2
planetary P1 sun=S1 ring=R1 carrier=C1 Ns=30 Nr=72
planetary P2 sun=S1 ring=housing carrier=OUT Ns=20 Nr=50 pinions=2
planetary P3 sun=X ring=R1 carrier=C1 Ns=20 Nr=50 pinions=1
gears G1 IN S1 N1=20 N2=40
gears G2 C1 X N1=17 N2=51 mesh=internal
gears G3 IN OUT r1=0.03 r2=0.08 mesh=external

clutch K1 IN R1 static=400 dynamic=340
clutch K2 X housing static=10 dynamic=10
brake B1 C1 static=500 dynamic=425 type=band
brake B2 X static=50 dynamic=0 type=plate
brake B3 S1 static=5 dynamic=4
oneway F1 C1 free=positive
oneway F2 X OUT free=negative
input IN
output OUT
torque Tpto X
torque Taux C1
gear 1 = K1 B1 ratio=3.5
gear 2 = K1 ratio=-2.25 B2
gear OD = K2 B3
gear 3R = F1 F2 ratio=1e1
neutral N = B1
neutral N2 = B1 F1
mode M1 = K1 B1
mode Mfree = none
coordinates IN OUT
"""


def test_every_statement_of_the_reference_parses_to_its_meaning():
    m = parse_mechanism(FULL, "full.mech")
    assert m.name == "Every statement"
    assert m.source == "full.mech"
    assert m.links == (
        Link("IN", 0.25), Link("S1", 0.0), Link("R1", 0.015), Link("C1", 3.0), Link("OUT", 0.5), Link("X", 2.0))
    assert m.planetaries == (
        Planetary("P1", "S1", "R1", "C1", 30, 72, 1),
        Planetary("P2", "S1", HOUSING, "OUT", 20, 50, 2),
        Planetary("P3", "X", "R1", "C1", 20, 50, 1),
    )
    assert all(isinstance(p.n_sun, int) and isinstance(p.n_ring, int) for p in m.planetaries)
    assert m.gear_pairs == (
        GearPair("G1", "IN", "S1", 20, 40, "teeth", "external"),
        GearPair("G2", "C1", "X", 17, 51, "teeth", "internal"),
        GearPair("G3", "IN", "OUT", 0.03, 0.08, "radius", "external"),
    )
    assert [g.sign for g in m.gear_pairs] == [-1, 1, -1]
    assert m.elements == (
        ShiftElement("K1", "clutch", "IN", "R1", 400.0, 340.0),
        ShiftElement("K2", "clutch", "X", HOUSING, 10.0, 10.0),
        ShiftElement("B1", "brake", "C1", HOUSING, 500.0, 425.0, brake_type="band"),
        ShiftElement("B2", "brake", "X", HOUSING, 50.0, 0.0, brake_type="plate"),
        ShiftElement("B3", "brake", "S1", HOUSING, 5.0, 4.0),
        ShiftElement("F1", "oneway", "C1", HOUSING, math.inf, 0.0, free="positive"),
        ShiftElement("F2", "oneway", "X", "OUT", math.inf, 0.0, free="negative"),
    )
    assert (m.input, m.output) == ("IN", "OUT")
    assert m.loads == (ExternalTorque("Tpto", "X", "load"), ExternalTorque("Taux", "C1", "load"))
    assert [t.name for t in m.torques] == ["T_in", "T_out", "Tpto", "Taux"]
    assert [t.sign for t in m.torques] == [1, -1, 1, 1]
    assert m.gears == (
        Gear("1", ("K1", "B1"), "gear", "3.5"),
        Gear("2", ("K1", "B2"), "gear", "-2.25"),
        Gear("OD", ("K2", "B3"), "gear", None),
        Gear("3R", ("F1", "F2"), "gear", "1e1"),
        Gear("N", ("B1",), "neutral", None),
        Gear("N2", ("B1", "F1"), "neutral", None),
    )
    assert [g.name for g in m.neutrals] == ["N", "N2"]
    assert m.modes == (ModeDecl("M1", ("K1", "B1")), ModeDecl("Mfree", ()))
    assert m.coordinates == ("IN", "OUT")
    # positions are kept for messages (1-based line and column of the name)
    assert (m.link("R1").span.line, m.link("R1").span.column) == where(FULL, 6, "R1")
    line_3r = FULL.split("\n").index("gear 3R = F1 F2 ratio=1e1") + 1
    assert (m.gear("3R").span.line, m.gear("3R").span.column) == where(FULL, line_3r, "3R")
    assert m.source_line(6) == "link R1 J=1.5e-2"


def test_title_defaults_to_the_file_stem_and_load_mechanism_reads_files(tmp_path):
    path = tmp_path / "my_box.mech"
    path.write_text(BASE, encoding="utf-8")
    m = load_mechanism(path)
    assert m.name == "my_box"
    assert m.source == str(path)
    # a bare name that is no file is looked up in the bundled library, with or without .mech
    assert load_mechanism("ht740").name == load_mechanism("ht740.mech").name == load_mechanism(BUNDLED["ht740"]).name


def test_load_mechanism_errors_are_mech_errors(tmp_path):
    with pytest.raises(MechSyntaxError, match="cannot read file"):
        load_mechanism(tmp_path / "missing.mech")
    binary = tmp_path / "bin.mech"
    binary.write_bytes(b"\xff\xfe\x00link")
    with pytest.raises(MechSyntaxError, match="not a text file"):
        load_mechanism(binary)
    bad = tmp_path / "bad.mech"
    bad.write_text(BASE.replace("J=2", "J=-2"), encoding="utf-8")
    with pytest.raises(MechValidationError) as info:
        load_mechanism(bad)
    assert str(info.value).startswith(f"{bad}:2:10: error: ")


def test_crlf_line_endings_and_missing_final_newline():
    m = parse_mechanism(BASE.replace("\n", "\r\n").rstrip("\r\n"))
    assert m == parse_mechanism(BASE)
    d = only(errors(BASE.replace("J=2", "J=-2").replace("\n", "\r\n")), "negative")
    assert at(d) == where(BASE.replace("J=2", "J=-2"), 2, "-2")


def test_error_classes():
    assert issubclass(MechSyntaxError, MechError) and issubclass(MechValidationError, MechError)
    assert issubclass(MechError, transgen.TransgenError) and issubclass(MechError, ValueError)


# ---------------------------------------------------------------------------------------------
# located diagnostics, one kind of bad input at a time


def test_unknown_link_with_did_you_mean():
    text = BASE.replace("gears G A B", "gears G A Bx")
    d = only(errors(text, kind=MechValidationError), "unknown link")
    assert at(d) == where(text, 3, "Bx")
    assert d.message == "unknown link 'Bx'; did you mean 'B'?"


def test_unknown_name_without_a_close_match_has_no_suggestion():
    text = BASE.replace("output B", "output Zzzzzz")
    d = only(errors(text), "unknown link")
    assert at(d) == where(text, 5, "Zzzzzz")
    assert "did you mean" not in d.message


def test_gear_naming_an_unknown_element_with_did_you_mean():
    text = BASE + "clutch C1 A B static=10 dynamic=5\ngear 1 = C1\ngear 2 = C2 ratio=1\n"
    d = only(errors(text), "unknown shift element")
    assert at(d) == where(text, 8, "C2")
    assert d.message == "unknown shift element 'C2'; did you mean 'C1'?"


def test_gear_naming_a_link_is_an_unknown_element():
    text = BASE + "clutch C1 A B static=10 dynamic=5\ngear 1 = A\n"
    d = only(errors(text), "unknown shift element")
    assert at(d) == where(text, 7, "A")


def test_duplicate_names():
    text = BASE + "link A J=3\nclutch G A B static=1 dynamic=1\n"
    diags = errors(text)
    d1 = only(diags, "duplicate name 'A'")
    assert at(d1) == where(text, 6, "A")
    assert "line 1" in d1.message
    d2 = only(diags, "duplicate name 'G'")
    assert at(d2) == where(text, 7, "G")
    assert "gear pair" in d2.message and "line 3" in d2.message


def test_duplicate_gear_and_mode_names():
    text = BASE + "clutch C A B static=1 dynamic=1\ngear 1 = C\ngear 1 = C\nmode M = C\nmode M = none\n"
    diags = errors(text)
    assert at(only(diags, "duplicate gear name '1'")) == where(text, 8, "1")
    assert at(only(diags, "duplicate mode name 'M'")) == where(text, 10, "M")


def test_element_listed_twice_in_a_gear():
    text = BASE + "clutch C A B static=1 dynamic=1\ngear 1 = C C\n"
    assert at(only(errors(text), "lists 'C' twice")) == where(text, 7, "C")


@pytest.mark.parametrize(
    "statement, needle, occurrence",
    [
        ("clutch K A A static=1 dynamic=1", "A", 2),
        ("oneway F B B free=positive", "B", 2),
        ("gears H B B N1=10 N2=20", "B", 2),
    ],
)
def test_element_connecting_a_link_to_itself(statement, needle, occurrence):
    text = BASE + statement + "\n"
    d = only(errors(text), "to itself")
    assert at(d) == where(text, 6, needle, occurrence)


def test_clutch_from_the_housing_is_rejected_at_the_housing():
    text = BASE + "clutch K housing A static=1 dynamic=1\nbrake Q housing static=1 dynamic=1\n"
    diags = errors(text)
    positions = [at(d) for d in diags if "housing cannot be used here" in d.message]
    assert positions == [where(text, 6, "housing"), where(text, 7, "housing")]


@pytest.mark.parametrize("ns, nr", [(50, 50), (60, 40)])
@pytest.mark.parametrize("pinions", ["", " pinions=2"])
def test_planetary_ring_must_exceed_sun(ns, nr, pinions):
    text = BASE + f"link C J=1\nplanetary P sun=A ring=B carrier=C Ns={ns} Nr={nr}{pinions}\n"
    d = only(errors(text), "ring teeth")
    assert at(d) == value_at(text, 7, "Nr")
    assert f"Nr={nr}" in d.message and f"Ns={ns}" in d.message


def test_planetary_with_repeated_members():
    text = BASE + "planetary P sun=A ring=B carrier=A Ns=20 Nr=50\nplanetary Q sun=housing ring=B carrier=housing Ns=20 Nr=50\n"
    diags = errors(text)
    d1 = only(diags, "planetary P: member 'A' is used twice")
    assert at(d1) == where(text, 6, "A")  # reported at the first use of the repeated member
    d2 = only(diags, "planetary Q: member 'housing' is used twice")
    assert at(d2) == where(text, 7, "housing")


def test_negative_inertia_and_capacities():
    text = BASE.replace("J=2", "J=-2") + "clutch C A B static=-1 dynamic=0\nbrake K A static=10 dynamic=-0.5\n"
    diags = errors(text)
    assert at(only(diags, r"^J must not be negative")) == where(text, 2, "-2")
    assert at(only(diags, r"^static must not be negative")) == where(text, 6, "-1")
    assert at(only(diags, r"^dynamic must not be negative")) == where(text, 7, "-0.5")


def test_dynamic_capacity_above_static():
    text = BASE + "clutch C A B static=100 dynamic=150\n"
    assert at(only(errors(text), "exceeds static capacity")) == where(text, 6, "150")


@pytest.mark.parametrize("value", ["0", "-3", "20.5", "1e-1", "+0"])
@pytest.mark.parametrize("key", ["N1", "N2"])
def test_tooth_counts_must_be_positive_whole_numbers(key, value):
    original = {"N1": "20", "N2": "40"}[key]
    text = BASE.replace(f"{key}={original}", f"{key}={value}")
    d = only(errors(text), "tooth count")
    assert at(d) == value_at(text, 3, key)
    assert d.message == f"{key} is a tooth count: a positive whole number, not {value}"


def test_planetary_tooth_counts_must_be_positive_whole_numbers():
    text = BASE + "link C J=1\nplanetary P sun=A ring=B carrier=C Ns=0 Nr=7.5\n"
    diags = errors(text)
    assert at(only(diags, "^Ns is a tooth count")) == where(text, 7, "0")
    assert at(only(diags, "^Nr is a tooth count")) == where(text, 7, "7.5")


def test_whole_tooth_count_written_with_a_decimal_point_is_accepted():
    m = parse_mechanism(BASE.replace("N1=20", "N1=20.0").replace("N2=40", "N2=4e1"))
    assert (m.gear_pairs[0].n1, m.gear_pairs[0].n2) == (20, 40)


def test_radii_must_be_positive_and_not_mixed_with_teeth():
    text = BASE + "gears H A B r1=0 r2=0.1\ngears K A B N1=10 r2=0.1\ngears L A B mesh=internal\n"
    diags = errors(text)
    assert at(only(diags, "^r1 must be positive")) == where(text, 6, "0")
    assert at(only(diags, "not both")) == (7, 1)
    assert at(only(diags, "gear pair L needs N1=")) == (8, 1)


@pytest.mark.parametrize("role", ["input", "output"])
def test_missing_input_or_output(role):
    text = "\n".join(line for line in BASE.splitlines() if not line.startswith(role)) + "\n"
    d = only(errors(text), f"missing '{role}'")
    assert at(d) == (4, 1)  # located at the last line


def test_missing_input_and_output_are_both_reported():
    text = "link A J=1\nlink B J=1\n"
    diags = errors(text)
    assert at(only(diags, "missing 'input'")) == (2, 1)
    assert at(only(diags, "missing 'output'")) == (2, 1)


def test_input_twice_and_input_equal_to_output():
    text = BASE + "input B\n"
    assert at(only(errors(text), "input is given twice")) == where(text, 6, "B")
    text = BASE.replace("output B", "output A")
    assert at(only(errors(text), "same link")) == where(text, 5, "A")


def test_unknown_parameter_with_did_you_mean():
    text = BASE.replace("link B J=2", "link B J=2 mass=3") + "link C J=1\nplanetary P sun=A ring=B carrier=C Nss=20 Nr=50\n"
    diags = errors(text)
    d1 = only(diags, "unknown parameter 'mass'")
    assert at(d1) == where(text, 2, "mass")
    assert "(known: J)" in d1.message
    d2 = only(diags, "unknown parameter 'Nss'")
    assert at(d2) == where(text, 7, "Nss")
    assert "did you mean 'Ns'?" in d2.message
    # the required Ns is then missing, reported at the statement
    assert at(only(diags, "needs Ns=")) == (7, 1)


def test_parameter_given_twice_and_bad_choice():
    text = BASE.replace("J=1", "J=1 J=2") + "oneway F A free=sideways\nbrake K B static=1 dynamic=1 type=disc\n"
    diags = errors(text)
    assert at(only(diags, "given twice")) == where(text, 1, "J", 2)
    assert at(only(diags, "free must be one of")) == where(text, 6, "sideways")
    assert at(only(diags, "type must be one of")) == where(text, 7, "disc")


def test_number_where_name_expected_and_name_where_number_expected():
    text = BASE + "link C J=heavy\nplanetary P sun=1 ring=B carrier=C Ns=20 Nr=50\n"
    diags = errors(text)
    assert at(only(diags, "J must be a number, not 'heavy'")) == where(text, 6, "heavy")
    assert at(only(diags, "sun must name a link")) == where(text, 7, "1")


def test_a_non_link_where_a_link_is_expected():
    text = BASE + "clutch K A G static=1 dynamic=1\n"
    d = only(errors(text), "not a link")
    assert d.message == "'G' is a gear pair, not a link"
    assert at(d) == where(text, 6, "G")


def test_reserved_words_cannot_name_things():
    text = BASE + "link housing J=1\nclutch gear A B static=1 dynamic=1\n"
    diags = errors(text)
    assert at(only(diags, "'housing' is a reserved word")) == where(text, 6, "housing")
    assert at(only(diags, "'gear' is a reserved word")) == where(text, 7, "gear")


def test_coordinates_checked():
    text = BASE + "coordinates A A Q\n"
    diags = errors(text)
    assert at(only(diags, "coordinate 'A' is given twice")) == where(text, 6, "A")
    assert at(only(diags, "unknown link 'Q'")) == where(text, 6, "Q")


def test_syntax_errors_on_several_lines_are_reported_together():
    text = (
        "link A J=1\n"
        "link B J==2\n"  # line 2: second '='
        "gears G A B N1=20 N2=40\n"
        "clutch C1 A B static=10 dynamic=5 extra\n"  # line 4: dangling name
        "input A\n"
        "output B B\n"  # line 6: extra name
        "gear 1 C1\n"  # line 7: missing '='
        'transmission "unterminated\n'  # line 8: bad string
    )
    with pytest.raises(MechSyntaxError) as info:
        parse_mechanism(text, "syn.mech")
    diags = info.value.diagnostics
    assert [d.line for d in diags] == [2, 4, 6, 7, 8]
    assert at(diags[0]) == where(text, 2, "=", 2)
    assert at(diags[1]) == (4, len("clutch C1 A B static=10 dynamic=5 extra") + 1)  # at the end of line
    assert at(diags[2]) == where(text, 6, "B", 2)
    assert at(diags[3]) == where(text, 7, "C1")
    assert diags[4].line == 8 and diags[4].column in (14, 15)
    assert "expected" in diags[3].message and "'='" in diags[3].message
    s = str(info.value)
    for d in diags:
        assert f"syn.mech:{d.line}:{d.column}: error: " in s
    assert s.count("^") == 5


def test_unknown_statement_keyword():
    text = BASE + "shaft S J=1\n"
    d = errors(text, kind=MechSyntaxError)[0]
    assert at(d) == (6, 1)
    assert "statement keyword" in d.message or "expected" in d.message


def test_all_problems_of_a_file_are_reported_at_once():
    text = (
        "link A J=-1\n"  # 1 negative inertia
        "link A J=1\n"  # 2 duplicate
        "link B J=1\n"
        "gears G A Bb N1=0 N2=40\n"  # 4 unknown link + bad teeth
        "clutch K B B static=1 dynamic=1\n"  # 5 to itself
        "planetary P sun=A ring=B carrier=housing Ns=60 Nr=40 pinions=3\n"  # 6 Nr<=Ns + pinions
        "input A\n"
        "gear 1 = K Q ratio=x\n"  # 8 unknown element + ratio not a number
    )
    diags = errors(text, kind=MechValidationError)
    got = sorted((d.line, d.column, d.message.split(" ")[0]) for d in diags)
    expected_lines = {1, 2, 4, 5, 6, 8}
    assert {d.line for d in diags} == expected_lines | {8}
    assert at(only(diags, "J must not be negative")) == where(text, 1, "-1")
    assert at(only(diags, "duplicate name 'A'")) == where(text, 2, "A")
    assert at(only(diags, "unknown link 'Bb'")) == where(text, 4, "Bb")
    assert at(only(diags, "N1 is a tooth count")) == where(text, 4, "0")
    assert at(only(diags, "connects 'B' to itself")) == where(text, 5, "B", 2)
    assert at(only(diags, "ring teeth")) == where(text, 6, "40")
    assert at(only(diags, "pinions must be one of")) == where(text, 6, "3")
    assert at(only(diags, "unknown shift element 'Q'")) == where(text, 8, "Q")
    assert at(only(diags, "ratio must be a number")) == where(text, 8, "x")
    assert at(only(diags, "missing 'output'")) == (8, 1)
    assert len(got) == 10


def test_diagnostic_format():
    d = Diagnostic("a.mech", 3, 5, "something is wrong", "\tlink X")
    assert d.format() == "a.mech:3:5: error: something is wrong\n     link X\n        ^"
    assert str(Diagnostic("a.mech", 1, 1, "m")) == "a.mech:1:1: error: m"


# ---------------------------------------------------------------------------------------------
# parsing never evaluates code


@pytest.mark.parametrize(
    "value",
    [
        "__import__('os').system('touch PWNED')",
        '__import__("os")',
        "1+1",
        "2*3",
        "(1)",
        "[1]",
        "float('inf')",
        "1_000",
        "0x10",
    ],
)
def test_values_are_never_evaluated(value, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)

    def boom(*args, **kwargs):  # pragma: no cover - only runs if the parser evaluates
        raise AssertionError("the parser evaluated code")

    monkeypatch.setattr("builtins.eval", boom)
    monkeypatch.setattr("builtins.exec", boom)
    text = BASE.replace("J=2", f"J={value}")
    with pytest.raises(MechSyntaxError) as info:
        parse_mechanism(text)
    assert info.value.diagnostics[0].line == 2
    assert not (tmp_path / "PWNED").exists()


def test_a_name_value_is_not_looked_up_as_code():
    d = only(errors(BASE.replace("J=2", "J=inf")), "J must be a number")
    assert "'inf'" in d.message


# ---------------------------------------------------------------------------------------------
# canonical writer


@pytest.mark.parametrize("name", sorted(BUNDLED))
def test_format_round_trip_of_every_bundled_mechanism(name):
    m = load_mechanism(BUNDLED[name])
    text = format_mechanism(m)
    again = parse_mechanism(text, m.source)
    assert again == m
    # canonical: formatting is a fixed point
    assert format_mechanism(again) == text


def test_format_round_trip_of_every_statement():
    m = parse_mechanism(FULL)
    again = parse_mechanism(format_mechanism(m))
    assert again == m
    assert again.modes == m.modes and again.coordinates == m.coordinates and again.loads == m.loads


def test_equality_detects_a_changed_mechanism():
    # the round-trip tests rely on Mechanism equality: it must see a changed number
    m = load_mechanism("ht740")
    assert parse_mechanism(format_mechanism(m).replace("Ns=45", "Ns=44")) != m


def test_format_round_trip_keeps_full_float_precision():
    m = parse_mechanism(BASE.replace("J=1", "J=0.12345678901234567").replace(
        "gears G A B N1=20 N2=40", "gears G A B r1=0.0300000000000001 r2=0.08"))
    assert parse_mechanism(format_mechanism(m)) == m


# ---------------------------------------------------------------------------------------------
# robustness: arbitrary text is parsed or rejected with a MechError, never another exception


@pytest.mark.parametrize("statement", ["gears H A B N1=1e400 N2=20",
                                       "link C J=1\nplanetary P sun=A ring=B carrier=C Ns=20 Nr=1e999"])
def test_overflowing_tooth_count_is_a_located_error(statement):
    text = BASE + statement + "\n"
    d = only(errors(text), "tooth count")
    assert d.line >= 6


def test_non_finite_numbers_are_rejected():
    text = BASE.replace("J=2", "J=1e400") + "clutch K A B static=1e999 dynamic=1\nbrake Q A static=5 dynamic=-1e400\n" \
        + "gears H A B r1=1e309 r2=0.1\ngear 1 = K ratio=1e400\n"
    diags = errors(text)
    assert at(only(diags, "^J ")) == value_at(text, 2, "J")
    assert at(only(diags, "^static ")) == value_at(text, 6, "static")
    assert at(only(diags, "^dynamic ")) == value_at(text, 7, "dynamic")
    assert at(only(diags, "^r1 ")) == value_at(text, 8, "r1")
    assert at(only(diags, "^ratio ")) == value_at(text, 9, "ratio")


def test_form_feed_does_not_shift_line_numbers():
    text = "link A J=1 \f\nlink B J=@\n"
    with pytest.raises(MechSyntaxError) as info:
        parse_mechanism(text)
    assert at(info.value.diagnostics[0]) == (2, 10)
    text = BASE.replace("link A J=1", "link A J=1\f").replace("J=2", "J=-2")
    d = only(errors(text), "negative")
    assert d.source_line == "link B J=-2"


def _parse_or_mech_error(text: str) -> None:
    try:
        m = parse_mechanism(text, "fuzz.mech")
    except MechError as exc:
        assert exc.diagnostics
        for d in exc.diagnostics:
            assert d.line >= 1 and d.column >= 1 and d.message
        str(exc)
        return
    # whatever parses, formats and parses back to the same mechanism
    assert parse_mechanism(format_mechanism(m), "fuzz.mech") == m


@settings(max_examples=80, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.text(alphabet=string.printable, max_size=300))
def test_random_printable_text_parses_or_raises_mech_error(text):
    _parse_or_mech_error(text)


_INTERESTING = ["=", '"', "#", "\n", " ", "\t", "-", ".", "e", "0", "1", "9", "_", "A", "x", "\r", "\f", "(", "'"]
_TOKENS = ["link", "planetary", "gears", "clutch", "brake", "oneway", "input", "output", "torque", "gear",
           "neutral", "mode", "coordinates", "none", "housing", "=", "J=0", "J=-1", "Ns=0", "Nr=10", "pinions=2",
           "mesh=internal", "free=negative", "ratio=1.5", "static=1", "dynamic=2", "r1=0.1", "N1=3.5", '"t"',
           "0", "-1", "1e3", "X", "T_in", "#"]
_VALUES = ["1e400", "-1e999", "0.12345678901234567", "1e-400", "0", "-1", "1.5", "+2", ".5", "2.", "1e3", "1e-3", "x", "housing", "none", "L1", "C1", "positive",
           "negative", "internal", "band", "2", "3", "Ns", "="]
_TEXTS = {name: path.read_text(encoding="utf-8") for name, path in BUNDLED.items()}
# the same files without comments and blank lines, so that most mutations hit statements
_TEXTS.update({f"{name}-bare": "\n".join(line for line in (re.sub(r"#.*", "", raw).rstrip() for raw in text.split("\n")) if line) + "\n"
               for name, text in list(_TEXTS.items())})


@st.composite
def mutated_mech(draw):
    text = _TEXTS[draw(st.sampled_from(sorted(_TEXTS)))]
    for _ in range(draw(st.integers(1, 4))):
        op = draw(st.sampled_from(["del_char", "ins_char", "rep_char", "del_tok", "ins_tok", "rep_tok", "swap_lines",
                                   "dup_line", "rep_value", "rep_value"]))
        if op == "rep_value":
            spans = [m.span(1) for m in re.finditer(r"=[ \t]*([^\s#]+)", text)]
            if not spans:
                continue
            a, b = draw(st.sampled_from(spans))
            new = draw(st.sampled_from(_VALUES) | st.integers(-5, 200).map(str)
                       | st.builds("{}.{}e{}".format, st.integers(-99, 999), st.integers(0, 999), st.integers(-20, 20)))
            text = text[:a] + new + text[b:]
        elif op in ("del_char", "ins_char", "rep_char"):
            i = draw(st.integers(0, max(len(text) - 1, 0)))
            c = draw(st.sampled_from(_INTERESTING) | st.characters(min_codepoint=32, max_codepoint=126))
            if op == "del_char":
                text = text[:i] + text[i + 1:]
            elif op == "ins_char":
                text = text[:i] + c + text[i:]
            else:
                text = text[:i] + c + text[i + 1:]
        elif op in ("del_tok", "ins_tok", "rep_tok"):
            parts = re.split(r"(\s+)", text)
            idx = [k for k, p in enumerate(parts) if p and not p.isspace()]
            if not idx:
                continue
            k = draw(st.sampled_from(idx))
            tok = draw(st.sampled_from(_TOKENS) | st.sampled_from([parts[j] for j in idx[:200]]))
            if op == "del_tok":
                parts[k] = ""
            elif op == "ins_tok":
                parts[k] = tok + " " + parts[k]
            else:
                parts[k] = tok
            text = "".join(parts)
        else:
            lines = text.split("\n")
            i = draw(st.integers(0, len(lines) - 1))
            j = draw(st.integers(0, len(lines) - 1))
            if op == "swap_lines":
                lines[i], lines[j] = lines[j], lines[i]
            else:
                lines.insert(j, lines[i])
            text = "\n".join(lines)
    return text


@settings(max_examples=200, deadline=None, suppress_health_check=[HealthCheck.too_slow, HealthCheck.filter_too_much])
@given(mutated_mech())
def test_mutated_bundled_files_parse_or_raise_mech_error(text):
    _parse_or_mech_error(text)
