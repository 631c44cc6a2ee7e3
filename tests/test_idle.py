"""Idle members (issue 21): one rule (:mod:`transgen.idle`) and every command agreeing on it.

Two bundled cases: ``a340e_like`` (a brake B2 holding the outer race H of a one-way clutch F1:
elements in series; H idles in 1st, reverse and the coast gear 2C) and ``idle_hub3`` (the hub H of
clutches C, D, F that only open elements touch in 1st, as in a Ford 10R80). For each, ratios,
modes, matrices, std, check, scenario new, synthesize teeth / table and the simulator must name
the same gears with the same idle members.
"""
from __future__ import annotations

import networkx as nx
import numpy as np
import pytest

from transgen import load_mechanism
from transgen.equations import complete_locked
from transgen.graph import bond_graph
from transgen.idle import gear_check, holds_only_idle, idle_text
from transgen.kinematics import gear_table
from transgen.language import parse_mechanism
from transgen.modes import mode_models
from transgen.statespace import state_space
from transgen.statics import check_oneways, drive_torques
from transgen.std import state_transition_diagram

CASES = {"a340e_like": {"1": ("H",), "R": ("H",), "2C": ("H",)}, "idle_hub3": {"1": ("H",)}}
"""The gears with idle members of each case, and their idle members."""


def _declared(mech):
    return [g for g in mech.gears if g.kind == "gear"]


@pytest.mark.parametrize("name", sorted(CASES))
def test_the_rule_finds_the_idle_hubs(name):
    mech = load_mechanism(name)
    for gear in _declared(mech):
        c = gear_check(mech, gear.engaged)
        assert c.is_gear and c.problem == "", gear.name
        assert c.idle == CASES[name].get(gear.name, ()), gear.name
        assert c.hubs == c.idle  # bare hubs: no gearset touches them
        assert c.dof == 1 + len(c.idle)
    assert idle_text(2, ("H",)) == "2 DOF: 1 + 1 idle (H)" and idle_text(1, ()) == "1 DOF"


def test_a_massless_idle_hub_is_no_usable_gear():
    text = load_mechanism("idle_hub3").text.replace("link H   J=0.006", "link H   J=0")
    mech = parse_mechanism(text)
    c = gear_check(mech, mech.gear("1").engaged)
    assert c.kind == "gear" and not c.is_gear and "massless" in c.problem and "H" in c.problem


@pytest.mark.parametrize("name", sorted(CASES))
def test_ratios_modes_matrices_and_statics_agree(name):
    mech = load_mechanism(name)
    expected = {g.name: CASES[name].get(g.name, ()) for g in _declared(mech)}
    # ratios / check: the floating column is the idle members
    table = gear_table(mech, all_combinations=False)
    assert {r.name: r.combination.floating for r in table.gears if r.kind == "gear"} == expected
    # modes: each declared gear is a mode with its idle members
    g = bond_graph(mech)
    models = {m.mode.key: m for m in mode_models(mech)}
    for gear in _declared(mech):
        m = models[frozenset(complete_locked(g, gear.engaged))]
        assert m.idle == expected[gear.name] and m.dof == 1 + len(m.idle) and m.equations is not None
    # matrices: the idle member's own speed is a state of its gear
    ss = state_space(mech)
    for m in ss.modes:
        if m.idle:
            assert set(m.idle) <= set(m.states) and len(m.states) == m.dof
    idle_modes = {frozenset(m.locked): m.idle for m in ss.modes if m.idle}
    for gear in _declared(mech):
        assert idle_modes.get(frozenset(complete_locked(g, gear.engaged)), ()) == expected[gear.name]
    # statics: the one-way clutches of idle gears are checked too (1st's F2 / OWC holds drive)
    for gear in _declared(mech):
        assert drive_torques(mech, gear.engaged, g) is not None, gear.name
    assert check_oneways(mech) == []


@pytest.mark.parametrize("name", sorted(CASES))
def test_std_connects_every_declared_gear_to_the_next(name):
    mech = load_mechanism(name)
    g = bond_graph(mech)
    std = state_transition_diagram(mech)
    graph = nx.DiGraph()
    graph.add_nodes_from(m.name for m in std.modes)
    graph.add_edges_from((t.source, t.target) for t in std.internal)
    by_key = {m.key: m.name for m in std.modes}
    gears = [by_key[frozenset(complete_locked(g, x.engaged))] for x in _declared(mech) if not x.alternative]
    for a, b in zip(gears, gears[1:]):
        assert nx.has_path(graph, a, b), (a, b)
    assert not std.unmodellable


def test_std_holds_the_modes_the_a340e_shifts_pass_through():
    """The 1-2 with F1 locked beside 1st (H turning with the sun), the 1-2 speed phase with F1
    holding and B2 slipping, and the 3-4's C1+C2+B2 (C0 released, F0 overrunning, B0 slipping):
    the modes a simulated launch enters (measured: events of ``scenario new`` + ``simulate``)."""
    mech = load_mechanism("a340e_like")
    keys = {m.key for m in state_transition_diagram(mech).modes}
    for locked in (("C0", "F0", "C1", "F1", "F2"), ("C0", "F0", "C1", "F1"), ("C1", "C2", "B2"),
                   ("F0", "C1", "C2", "B2")):
        assert frozenset(locked) in keys, locked


@pytest.mark.parametrize("name", sorted(CASES))
def test_scenario_new_launches_through_every_forward_gear(name):
    from transgen.sim.derive.launch import derive_launch

    mech = load_mechanism(name)
    launch = derive_launch(mech, "car")
    forward = [x.name for x in _declared(mech) if not x.alternative and gear_check(mech, x.engaged).ratio > 0]
    assert list(launch.order) == forward
    assert not launch.skipped
    assert not [w for w in launch.warnings if "left out" in w]
    assert {x.name: x.idle for x in launch.gears} == {x: CASES[name].get(x, ()) for x in forward}


def test_scenario_new_warns_about_a_gear_it_cannot_use():
    from transgen.sim.derive.launch import derive_launch

    text = load_mechanism("a340e_like").text.replace("link H   J=0.004", "link H   J=0")
    launch = derive_launch(parse_mechanism(text), "car")
    assert launch.order[0] == "2"
    assert any(w.startswith("gear 1 cannot be used") and "massless" in w for w in launch.warnings)


def test_scenario_new_says_so_on_stderr_and_in_json(tmp_path, capsys):
    import json

    from transgen.cli import main

    path = tmp_path / "massless_hub.mech"
    path.write_text(load_mechanism("a340e_like").text.replace("link H   J=0.004", "link H   J=0"))
    assert main(["scenario", "new", str(path), "--json"]) == 0
    out = capsys.readouterr()
    assert "warning: gear 1 cannot be used and is left out" in out.err
    doc = json.loads(out.out)
    assert doc["order"] == ["2", "3", "4"] and any("gear 1 cannot be used" in w for w in doc["warnings"])


@pytest.mark.parametrize("name", sorted(CASES))
def test_synthesize_teeth_matches_the_idle_gears(name):
    from transgen.synthesis.teeth import AssemblyRules, ratio_targets, synthesize_teeth

    mech = load_mechanism(name)
    sets = ["front", "rear"]
    known = {p.name: (p.n_sun, p.n_ring) for p in mech.planetaries}
    text = mech.text
    for p in sets:
        text = text.replace(f"Ns={known[p][0]} Nr={known[p][1]}", "Ns=? Nr=?")
    open_mech = parse_mechanism(text, f"{name}_unknown.mech", unknown_teeth=True)
    assert [p.n_sun for p in open_mech.planetaries if p.name in sets] == [None, None]
    result = synthesize_teeth(open_mech, ratio_targets(open_mech), AssemblyRules(profile_shift=True), top=0)
    assert result.solutions, "no teeth found"
    found = [{t.name: (t.n_sun, t.n_ring) for t in s.teeth} for s in result.solutions]
    for s in result.solutions:  # every target met, the idle gears' included
        for gear in CASES[name]:
            if mech.gear(gear).ratio is not None:
                assert abs(s.errors[gear]) <= float(mech.gear(gear).tolerance or 0.0005) + 1e-12
    # the file's own sets (their basic ratio Nr/Ns: the default rules want planets of 17 teeth and
    # more, so the A340E-like front set 34/64 comes out as 51/96)
    assert any(all(f[p][1] * known[p][0] == known[p][1] * f[p][0] for p in sets) for f in found), found[:5]


def _bare(mech):
    """The mechanism's text without its gear lines (as tests/test_synthesis.py strips them)."""
    lines = [x for x in mech.text.splitlines() if not x.lstrip().startswith(("gear ", "neutral "))]
    return parse_mechanism("\n".join(lines) + "\n")


@pytest.mark.parametrize("name", sorted(CASES))
def test_synthesize_table_never_adds_an_element_to_hold_an_idle_hub(name):
    from transgen.synthesis.table import gear_candidates, synthesize_table

    mech = load_mechanism(name)
    bare = _bare(mech)
    g = bond_graph(bare)
    candidates = gear_candidates(bare)
    for c in candidates:
        full = gear_check(bare, tuple(c.engaged), g)
        for e in c.engaged:
            assert not holds_only_idle(full, gear_check(bare, tuple(x for x in c.engaged if x != e), g)), c.engaged
    # the published first gear (up to the friction member of a group in parallel) is a candidate,
    # and no candidate is it plus an element that would only hold its idle hub
    first = frozenset(mech.gear("1").engaged)
    engaged = {c.engaged for c in candidates}
    assert any(c <= first and gear_check(bare, tuple(c), g).idle == ("H",) for c in engaged)
    held = [first | {e} for e in bare.element_names if e not in first]
    held = [x for x in held if gear_check(bare, tuple(x), g).is_gear and gear_check(bare, tuple(x), g).idle == ()]
    assert held and not [x for x in held if x in engaged]
    best = synthesize_table(bare, 3, 1, top=1).tables[0]
    for c in best.forward:
        assert c.engaged not in held


IDLE_RUN = """mechanism = "idle_hub3"
[simulation]
t_end = 0.3
[initial]
gear = "1"
speeds = { IN = 100.0, H = 30.0 }
[input]
type = "torque"
torque = 200.0
[driveline]
output_inertia = 50.0
stiffness = 12000.0
damping = 200.0
"""


def test_the_simulator_runs_an_idle_gear_and_bounds_the_hub(tmp_path):
    from transgen.sim.scenario.load import load_scenario

    path = tmp_path / "s.toml"
    path.write_text(IDLE_RUN)
    r = load_scenario(path).run()
    assert r.success, r.message
    w_h = r.signals["w_H"]  # reported; no drag on an open element: the hub keeps its speed
    assert np.allclose(w_h, 30.0, rtol=1e-9, atol=1e-9)
    assert r.signals["w_IN"][-1] != pytest.approx(100.0)  # the gear itself moved
    checked = r.stats["invariants"]["invariants"]["idle_speed"]
    assert checked["checks"] > 0 and checked["worst"] <= 1.0


def test_the_monitor_flags_an_idle_hub_running_away():
    from transgen.idle import idle_hubs
    from transgen.sim.solve.monitor import InvariantMonitor, InvariantViolation
    from transgen.sim.model.transmission import Transmission

    mech = load_mechanism("idle_hub3")
    assert idle_hubs(mech, mech.gear("1").engaged) == (("H", ("IN", "S", "Rf")),)
    tr = Transmission(mech)
    first = frozenset(tr.element_index[x] for x in mech.gear("1").engaged)
    n, zero = 3, np.zeros(3)
    block = {f"w_{k}": np.full(n, 10.0) for k in tr.links}
    block.update({"E_in": zero, "E_dissipated": zero, "E_load": zero, "E_stored": np.ones(n)})
    for e in tr.elements:
        block.update({f"slip_{e.name}": zero, f"t_{e.name}": zero, f"apply_{e.name}": zero})
    block["w_H"] = np.array([1.0, 5.0, 12.0])  # faster than its start (1) and IN, S, Rf (10)
    with pytest.raises(InvariantViolation) as info:
        InvariantMonitor(tr, 1e-7, 1e-3).check(np.array([0.0, 0.5, 1.0]), block, first, "M1")
    assert (info.value.invariant, info.value.element, info.value.t) == ("idle_speed", "H", 1.0)
    block["w_H"] = np.array([1.0, 5.0, 9.0])  # pulled toward its neighbours: within the bound
    InvariantMonitor(tr, 1e-7, 1e-3).check(np.array([0.0, 0.5, 1.0]), block, first, "M1")


def test_the_readme_series_example_has_its_idle_hub():
    """The language reference (docs/reference/language.md), 'Elements in series and idle members':
    the worked Simpson example with its band B2 replaced by a brake on F1's outer race H."""
    import re
    from pathlib import Path

    readme = (Path(__file__).resolve().parent.parent / "docs" / "reference" / "language.md").read_text(encoding="utf-8")
    simpson = re.search(r"^```\n(# Simpson.*?)^```", readme, flags=re.S | re.M).group(1)
    series = re.search(r"^```\n(# B2 holds the hub H.*?)^```", readme, flags=re.S | re.M).group(1)
    lines = [x for x in simpson.splitlines() if not x.startswith(("brake  B2", "gear 2 ="))]
    extra = [x for x in series.splitlines() if not x.startswith("#")]
    links = [x for x in extra if x.startswith("link")]
    text = "\n".join(lines[:2] + links + lines[2:] + [x for x in extra if x not in links]) + "\n"
    mech = parse_mechanism(text, "README.md")
    assert gear_check(mech, mech.gear("1").engaged).idle == ("H",)
    assert gear_check(mech, mech.gear("R").engaged).idle == ("H",)
    two = gear_check(mech, mech.gear("2").engaged)
    assert two.idle == () and two.ratio == pytest.approx(1 + 35 / 73)
