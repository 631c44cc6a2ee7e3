"""Modes of operation (thesis 3.3.2, 3.4.2) and generalized coordinates (3.2.3, eq. 3.12)."""
from __future__ import annotations

import functools
import itertools

import numpy as np
import pytest

import independent as ind
from transgen import ModeError, bundled_mechanisms, load_mechanism, parse_mechanism
from transgen.equations import complete_locked, input_names
from transgen.graph import build_graph, link_nodes
from transgen.modes import (
    check_coordinates,
    coordinate_subset,
    default_coordinates,
    mode_models,
    select_modes,
    valid_coordinate_sets,
)
from transgen.statespace import state_space

BUNDLED = bundled_mechanisms()


@functools.lru_cache(maxsize=None)
def _models(name, which="auto"):
    mech = load_mechanism(name)
    return mech, mode_models(mech, which), link_nodes(build_graph(mech))


# ---------------------------------------------------------------------------------------------
# which modes


def test_ht740_default_modes_are_the_thesis_seven():
    mech, models, _ = _models("ht740")
    assert [(m.name, m.locked) for m in models] == [
        ("M1", ("C1", "C5")),  # 1st gear
        ("M2", ("C1", "C4")),  # 2nd gear
        ("M3", ("C1", "C3")),  # 3rd gear
        ("M4", ("C1", "C2")),  # 4th gear
        ("M5", ("C1",)),  # forward speed phase
        ("M6", ("C5",)),  # neutral
        ("M7", ("C2", "C5")),  # reverse
    ]
    assert [m.dof for m in models] == [1, 1, 1, 1, 2, 2, 1]
    assert [m.kinematic_dof for m in models] == [1, 1, 1, 1, 2, 2, 1]
    assert [m.mode.label for m in models] == ["gear 1", "gear 2", "gear 3", "gear 4", "speed phase 1-2, 2-3, 3-4",
                                              "neutral N", "reverse R"]
    assert [m.kind for m in models] == ["gear"] * 4 + ["neutral"] * 2 + ["gear"]
    assert all(m.problem == "" and m.equations is not None for m in models)


def test_simple2_default_modes():
    mech, models, _ = _models("simple2")
    assert [(m.name, m.locked, m.dof) for m in models] == [("M1", ("C1",), 1), ("M2", ("C2",), 1), ("M3", (), 2)]


def test_ht740_mode_dof_is_rank_of_g_accel_and_matches_the_null_space_method():
    mech, models, _ = _models("ht740")
    u = input_names(build_graph(mech))
    for m in models:
        ref = ind.dynamics(mech, m.locked, u)
        assert m.dof == ref.dof == np.linalg.matrix_rank(ref.alpha) == np.linalg.matrix_rank(m.equations.G_accel)


def test_neutral_from_first_and_reverse_gear_when_none_declared():
    text = BUNDLED["ht740"].read_text(encoding="utf-8").replace("neutral N = C5", "")
    mech = parse_mechanism(text)
    modes = select_modes(mech)
    # C1 C5 (1st) and C2 C5 (R) share C5: the neutral is C5 alone
    assert [m.locked for m in modes] == [("C1", "C5"), ("C1", "C4"), ("C1", "C3"), ("C1", "C2"), ("C1",), ("C5",),
                                         ("C2", "C5")]
    assert modes[5].label == "neutral 1-R"


def test_declared_modes_replace_the_default():
    text = BUNDLED["ht740"].read_text(encoding="utf-8") + "mode first = C1 C5\nmode coast = none\nmode Rev = C5 C2\n"
    mech = parse_mechanism(text)
    declared = select_modes(mech)
    assert [(m.name, m.locked, m.label) for m in declared] == [
        ("first", ("C1", "C5"), "declared"), ("coast", (), "declared"), ("Rev", ("C5", "C2"), "declared")]
    assert select_modes(mech, "declared") == declared
    assert len(select_modes(mech, "default")) == 7
    models = mode_models(mech)
    assert [(m.name, m.dof) for m in models] == [("first", 1), ("coast", 3), ("Rev", 1)]
    ss = state_space(mech)
    assert [m.name for m in ss.modes] == ["first", "coast", "Rev"]
    assert len(ss.coordinates) == 3


def test_all_modes_and_unknown_selection():
    mech = load_mechanism("ht740")
    modes = select_modes(mech, "all")
    assert [m.locked for m in modes] == ind.all_combinations(mech)
    assert [m.name for m in modes] == [f"M{i + 1}" for i in range(32)]
    with pytest.raises(ValueError, match="unknown mode selection"):
        select_modes(mech, "some")


@pytest.mark.parametrize("name", sorted(BUNDLED))
def test_default_modes_of_every_bundled_mechanism_are_distinct_and_solvable(name):
    mech, models, _ = _models(name)
    keys = [frozenset(m.locked) for m in models]
    assert len(set(keys)) == len(keys)
    assert [m.name for m in models] == [f"M{i + 1}" for i in range(len(models))] or mech.modes
    for m in models:
        assert m.equations is not None, (m.name, m.problem)
        ref = ind.kinematics(mech, m.locked)
        assert m.kinematic_dof == ref.dof and m.kind == ref.kind
    # every declared forward gear is a mode (with the one-way clutches beside its elements)
    if not mech.modes:
        g = build_graph(mech)
        for gear in mech.gears:
            assert frozenset(complete_locked(g, gear.engaged)) in keys, gear


# ---------------------------------------------------------------------------------------------
# generalized coordinates


def test_ht740_l1_l6_are_valid_coordinates():
    mech, models, links = _models("ht740")
    check_coordinates(models, links, ("L1", "L6"))
    check_coordinates(models, links, ("L6", "L1"))
    subsets = [coordinate_subset(m, links, ("L1", "L6")) for m in models]
    assert subsets == [("L1",)] * 4 + [("L1", "L6")] * 2 + [("L1",)]
    # with the output first, the 1-DOF modes use the output (nested subsets, thesis 3.2.3)
    assert [coordinate_subset(m, links, ("L6", "L1")) for m in models][0] == ("L6",)


def test_invalid_coordinates_name_the_mode_and_why():
    mech, models, links = _models("ht740")
    with pytest.raises(ModeError) as info:
        check_coordinates(models, links, ("L1", "L2"))
    msg = str(info.value)
    assert "mode M5 (C1 locked)" in msg
    assert "L1 and L2 move in a fixed ratio in this mode" in msg
    assert "rank 1" in msg and "2 degree(s) of freedom" in msg
    with pytest.raises(ModeError, match="1 coordinate\\(s\\) given but the modelled modes need 2"):
        check_coordinates(models, links, ("L1",))
    with pytest.raises(ModeError, match="unknown link\\(s\\) L7"):
        check_coordinates(models, links, ("L1", "L7"))


def test_coordinates_none_of_which_moves_are_explained():
    mech = parse_mechanism("""\
link A J=1
link B J=1
link C J=1
link D J=1
planetary P sun=A ring=B carrier=C Ns=30 Nr=60
gears G A D N1=10 N2=30
brake BA A static=1 dynamic=1
input A
output C
mode one = BA
mode free = none
""")
    models = mode_models(mech)
    links = link_nodes(build_graph(mech))
    assert [m.dof for m in models] == [1, 2]
    with pytest.raises(ModeError, match="mode one \\(BA locked\\).*none of them moves in this mode"):
        check_coordinates(models, links, ("A", "D"))
    with pytest.raises(ModeError, match="mode free \\(nothing locked\\).*A and D move in a fixed ratio"):
        check_coordinates(models[1:], links, ("A", "D"))
    check_coordinates(models, links, ("A", "C"))
    assert valid_coordinate_sets(models, links) == [("A", "B"), ("A", "C"), ("B", "C"), ("B", "D"), ("C", "D")]


def _valid_by_null_space(mech, models, links, coords):
    """Independent eq. 3.12 test: the coordinates span every mode's motions (rank of N's rows)."""
    u = input_names(build_graph(mech))
    for m in models:
        ref = ind.dynamics(mech, m.locked, u)
        rows = ref.N[[links.index(c) for c in coords]]
        if (np.linalg.matrix_rank(rows, tol=1e-9) if rows.size else 0) != ref.dof:
            return False
    return True


@pytest.mark.parametrize("name, expected", [
    ("simple2", None),
    ("ht740", [("L1", "L3"), ("L1", "L4"), ("L1", "L6")]),
])
def test_valid_coordinate_sets_exhaustively(name, expected):
    mech, models, links = _models(name)
    valid = valid_coordinate_sets(models, links)
    if expected is not None:
        assert valid == expected
    needed = max(m.dof for m in models)
    for combo in itertools.combinations(links, needed):
        by_null_space = _valid_by_null_space(mech, models, links, combo)
        assert (combo in valid) == by_null_space, combo
        if combo in valid:
            check_coordinates(models, links, combo)
            check_coordinates(models, links, tuple(reversed(combo)))
        else:
            with pytest.raises(ModeError, match="not valid for mode"):
                check_coordinates(models, links, combo)
    # every valid set is a combination in link order, without repeats
    assert valid == sorted(set(valid), key=lambda s: [links.index(x) for x in s])


def test_simple2_valid_sets_pair_an_input_side_and_an_output_side_shaft():
    mech, models, links = _models("simple2")
    valid = set(valid_coordinate_sets(models, links))
    # in the 2-DOF mode the input side (Li, La, Lb) and the output side (Lc, Ld, Lo) turn independently
    assert valid == {(a, b) for a in ("Li", "La", "Lb") for b in ("Lc", "Ld", "Lo")}


@pytest.mark.parametrize("name", sorted(BUNDLED))
def test_default_coordinates_contain_input_and_output(name):
    mech, models, links = _models(name)
    coords = default_coordinates(models, links, mech.input, mech.output)
    check_coordinates(models, links, coords)
    assert coords[0] == mech.input
    valid = valid_coordinate_sets(models, links)
    if any(mech.input in s and mech.output in s for s in valid):
        assert mech.output in coords
    if len(coords) >= 2 and mech.output in coords:
        assert coords[1] == mech.output
    assert state_space(mech).coordinates == (mech.coordinates or coords)


def test_simple2_and_ht740_default_coordinates_are_input_output():
    for name, expected in (("simple2", ("Li", "Lo")), ("ht740", ("L1", "L6"))):
        mech, models, links = _models(name)
        assert default_coordinates(models, links, mech.input, mech.output) == expected


def test_coordinates_statement_is_used_and_checked():
    text = BUNDLED["ht740"].read_text(encoding="utf-8")
    mech = parse_mechanism(text + "coordinates L1 L4\n")
    assert state_space(mech).coordinates == ("L1", "L4")
    bad = parse_mechanism(text + "coordinates L1 L2\n")
    with pytest.raises(ModeError, match="M5"):
        state_space(bad)


def test_no_valid_coordinates():
    from dataclasses import replace

    mech, models, links = _models("ht740")
    impossible = [replace(models[0], dof=len(links) + 1)]  # more DOF than links
    assert valid_coordinate_sets(impossible, links) == []
    with pytest.raises(ModeError, match="no valid set"):
        default_coordinates(impossible, links, "L1", "L6")


def test_all_modes_of_ht740_need_three_coordinates():
    mech, models, links = _models("ht740", "all")
    solvable = [m for m in models if m.equations is not None]
    assert max(m.dof for m in solvable) == 3
    sets = valid_coordinate_sets(solvable, links)
    assert sets
    for combo in itertools.combinations(links, 3):
        assert (combo in sets) == _valid_by_null_space(mech, solvable, links, combo), combo


@pytest.mark.parametrize("name", sorted(BUNDLED))
def test_valid_coordinate_sets_of_every_bundled_mechanism(name):
    """valid_coordinate_sets is exactly the set of link combinations whose null-space rows span
    every modelled mode (eq. 3.12, computed independently)."""
    mech, models, links = _models(name)
    valid = set(valid_coordinate_sets(models, links))
    needed = max(m.dof for m in models)
    assert valid
    for combo in itertools.combinations(links, needed):
        assert (combo in valid) == _valid_by_null_space(mech, models, links, combo), combo
