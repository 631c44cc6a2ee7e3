"""State-transition diagrams (thesis 3.2.6-3.2.7, 3.3.2 Fig. 3.8, 3.4.2 Fig. 3.12)."""
from __future__ import annotations

import pytest

from transgen import bundled_mechanisms, load_mechanism, parse_mechanism
from transgen.equations import locking_groups
from transgen.graph import build_graph
from transgen.modes import Mode, select_modes
from transgen.std import lock_condition, state_transition_diagram, unlock_condition

BUNDLED = bundled_mechanisms()


def _edges(std):
    return {(t.source, t.target, t.element, t.event) for t in std.internal}


def _check_structure(mech, std):
    """Invariants of every STD: one transition per (mode, element) when no elements are in
    parallel; each changes exactly its elements; the target, when modelled, is the mode whose
    locked set is reached."""
    by_name = {m.name: m for m in std.modes}
    by_key = {m.key: m for m in std.modes}
    if all(len(grp.members) == 1 for grp in locking_groups(build_graph(mech))):
        assert len(std.transitions) == len(std.modes) * len(mech.elements)
    assert set(std.internal) | set(std.external) == set(std.transitions)
    assert not set(std.internal) & set(std.external)
    for t in std.transitions:
        src = by_name[t.source]
        assert t.adds == (not set(t.elements) & set(src.locked))
        assert t.adds or set(t.elements) <= set(src.locked)
        assert set(src.locked) ^ set(t.reaches) == set(t.elements)
        target = by_key.get(frozenset(t.reaches))
        assert t.target == (target.name if target else None)
        assert t.leaves_model == (t.target is None)
        assert len(set(t.reaches)) == len(t.reaches)


def test_simple2_std_is_thesis_figure_3_8():
    mech = load_mechanism("simple2")
    std = state_transition_diagram(mech)
    assert [(m.name, m.locked) for m in std.modes] == [("M1", ("C1",)), ("M2", ("C2",)), ("M3", ())]
    # thesis 3.3.2: Mode 1 -C1 unlocks-> Mode 3; Mode 2 -C2 unlocks-> Mode 3;
    # Mode 3 -C1 locks-> Mode 1; Mode 3 -C2 locks-> Mode 2
    assert _edges(std) == {("M1", "M3", "C1", "unlock"), ("M2", "M3", "C2", "unlock"),
                           ("M3", "M1", "C1", "lock"), ("M3", "M2", "C2", "lock")}
    assert len(std.internal) == 4
    # locking the other clutch in a gear ties the gearbox up: not modelled, but listed
    assert {(t.source, t.element, t.event, frozenset(t.reaches)) for t in std.external} == {
        ("M1", "C2", "lock", frozenset({"C1", "C2"})), ("M2", "C1", "lock", frozenset({"C1", "C2"}))}
    assert all(t.target is None for t in std.external)
    _check_structure(mech, std)
    c = {(t.source, t.element): t.condition for t in std.transitions}
    assert c[("M1", "C1")] == "|t_C1| > static capacity"
    assert c[("M3", "C2")] == "slip of C2 crosses 0 and |t_C2| <= static capacity"


def test_ht740_std_is_thesis_figure_3_12():
    mech = load_mechanism("ht740")
    std = state_transition_diagram(mech)
    assert len(std.modes) == 7
    assert _edges(std) == {
        ("M1", "M6", "C1", "unlock"), ("M1", "M5", "C5", "unlock"), ("M2", "M5", "C4", "unlock"),
        ("M3", "M5", "C3", "unlock"), ("M4", "M5", "C2", "unlock"), ("M5", "M1", "C5", "lock"),
        ("M5", "M2", "C4", "lock"), ("M5", "M3", "C3", "lock"), ("M5", "M4", "C2", "lock"),
        ("M6", "M1", "C1", "lock"), ("M6", "M7", "C2", "lock"), ("M7", "M6", "C2", "unlock"),
    }
    _check_structure(mech, std)
    assert len(std.external) == 7 * 5 - 12


@pytest.mark.parametrize("name", sorted(BUNDLED))
def test_internal_transitions_pair_up(name):
    """Every internal lock has the reverse unlock (and vice versa), on the same elements; a
    friction element applied to a held group can be released again."""
    mech = load_mechanism(BUNDLED[name])
    std = state_transition_diagram(mech, select_modes(mech, "all") if len(mech.elements) <= 5 else None)
    _check_structure(mech, std)
    edges = _edges(std)
    reverse = {"lock": "unlock", "unlock": "lock", "apply": "release", "release": "apply"}
    for s, t, e, ev in edges:
        if ev == "apply" and mech.element(e).kind == "oneway":
            continue  # a one-way clutch engages a held motion at once and never leaves it alone
        assert (t, s, e, reverse[ev]) in edges, (s, t, e, ev)


def test_std_with_explicit_modes_and_to_dict():
    mech = load_mechanism("ht740")
    modes = [Mode("first", ("C1", "C5")), Mode("phase", ("C1",))]
    std = state_transition_diagram(mech, modes)
    assert _edges(std) == {("first", "phase", "C5", "unlock"), ("phase", "first", "C5", "lock")}
    d = std.to_dict()
    assert d["modes"] == [{"name": "first", "gear": "1", "locked": ["C1", "C5"], "label": ""},
                          {"name": "phase", "gear": None, "locked": ["C1"], "label": ""}]
    assert {(t["from"], t["to"], t["element"], t["event"]) for t in d["transitions"]} == _edges(std)
    assert len(d["leaving"]) == 2 * 5 - 2
    for t in d["leaving"]:
        assert set(t) == {"from", "element", "event", "condition", "reaches"}
    unlock_c1 = next(t for t in d["leaving"] if t["from"] == "first" and t["element"] == "C1")
    assert unlock_c1["event"] == "unlock" and unlock_c1["reaches"] == ["C5"]


def test_declared_modes_drive_the_std():
    text = BUNDLED["simple2"].read_text(encoding="utf-8") + "mode low = C1\nmode both = C1 C2\n"
    std = state_transition_diagram(parse_mechanism(text))
    assert [m.name for m in std.modes] == ["low", "both"]
    assert _edges(std) == {("low", "both", "C2", "lock"), ("both", "low", "C2", "unlock")}


ONEWAY = """\
link A J=1
link B J=1
link C J=1
planetary P sun=A ring=B carrier=C Ns=30 Nr=60
oneway Fpos B free=positive
oneway Fneg A C free=negative
clutch K A B static=10 dynamic=8
input A
output C
mode none = none
mode pos = Fpos
mode neg = Fneg
"""


def test_one_way_clutch_conditions_name_the_right_direction():
    mech = parse_mechanism(ONEWAY)
    std = state_transition_diagram(mech)
    c = {(t.source, t.element, t.event): t.condition for t in std.transitions}
    # free=positive overruns while w1 - w2 > 0: it locks when the slip would turn negative, and
    # while locked it can only push link1 forward (t < 0, it acts -t on link1): it unlocks when
    # the torque it would have to carry turns positive
    assert c[("none", "Fpos", "lock")] == "slip of Fpos reaches 0 and would turn negative"
    assert c[("pos", "Fpos", "unlock")] == "t_Fpos reverses (t_Fpos > 0)"
    assert c[("none", "Fneg", "lock")] == "slip of Fneg reaches 0 and would turn positive"
    assert c[("neg", "Fneg", "unlock")] == "t_Fneg reverses (t_Fneg < 0)"
    # friction elements keep the capacity conditions
    assert c[("none", "K", "lock")] == "slip of K crosses 0 and |t_K| <= static capacity"
    assert c[("pos", "Fneg", "lock")] == "slip of Fneg reaches 0 and would turn positive"
    assert _edges(std) == {("none", "pos", "Fpos", "lock"), ("pos", "none", "Fpos", "unlock"),
                           ("none", "neg", "Fneg", "lock"), ("neg", "none", "Fneg", "unlock")}


def test_condition_helpers():
    assert lock_condition("oneway", "F", "positive").endswith("would turn negative")
    assert lock_condition("oneway", "F", "negative").endswith("would turn positive")
    assert unlock_condition("oneway", "F", "positive") == "t_F reverses (t_F > 0)"
    assert unlock_condition("oneway", "F", "negative") == "t_F reverses (t_F < 0)"
    assert lock_condition("brake", "B") == "slip of B crosses 0 and |t_B| <= static capacity"
    assert unlock_condition("clutch", "C") == "|t_C| > static capacity"


@pytest.mark.parametrize("name", ["mb722_6_w5a330_1996", "zf3hp22_big"])
def test_bundled_one_way_clutches(name):
    mech = load_mechanism(name)
    std = state_transition_diagram(mech)
    oneways = [e for e in mech.elements if e.kind == "oneway"]
    assert oneways and all(e.free == "positive" for e in oneways)
    for t in std.transitions:
        if len(t.elements) > 1 or t.event in ("apply", "release"):  # elements in parallel
            assert "combined holding range" in t.condition or t.event in ("apply", "release"), t
            continue
        e = mech.element(t.element)
        if e.kind != "oneway":
            assert "static capacity" in t.condition
        elif t.event == "lock":
            assert t.condition == f"slip of {e.name} reaches 0 and would turn negative"
        else:
            assert t.condition == f"t_{e.name} reverses (t_{e.name} > 0)"
    # the 1-2 upshift: the one-way clutch of 1st overruns (unlocks) into the speed phase
    first = select_modes(mech)[0]
    owc_in_first = [e.name for e in oneways if e.name in first.locked]
    assert owc_in_first
    targets = {t.element: t.target for t in std.transitions if t.source == first.name}
    assert any(targets[e] is not None for e in owc_in_first)


def test_one_way_conditions_agree_with_the_equations_sign_convention():
    """Drive the sun of ONEWAY with T_in > 0 while Fpos (free=positive) holds the ring: unlocked, the
    ring would accelerate backwards (its slip would turn negative, so the clutch is right to lock),
    and locked it carries a torque t_Fpos < 0 (so its unlock condition t_Fpos > 0 is not met)."""
    import numpy as np

    from transgen.graph import build_graph
    from transgen.equations import assemble, solve

    mech = parse_mechanism(ONEWAY)
    g = build_graph(mech)
    free = solve(assemble(g, ()), g)
    u = np.zeros(len(free.u))
    u[free.u.index("T_in")] = 100.0
    u[free.u.index("T_out")] = 0.0
    links = list(mech.link_names)
    assert (free.G_accel @ u)[links.index("B")] < 0
    held = solve(assemble(g, ("Fpos",)), g)
    t = (held.G_clutches @ u)[0]
    assert t < 0
    # reversing the drive reverses the torque: now the unlock condition holds
    assert (held.G_clutches @ -u)[0] > 0
