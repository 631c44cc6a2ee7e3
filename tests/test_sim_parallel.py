"""Elements in parallel: shift elements that lock the same relative motion (the same two links) are
one constraint with a combined holding range, decided as one, and their torques are split by
the documented rule (friction first, in proportion to capacity; the one-way clutches take the
rest in their locking direction). `modes`, `std` and the simulator agree on which modes exist."""
from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from transgen import bundled_mechanisms, load_mechanism, parse_mechanism
from transgen.describe import modes_report
from transgen.errors import ModeError
from transgen.modes import select_modes
from transgen.sim.model.components import InputTorque
from transgen.sim.scenario.load import load_scenario
from transgen.sim.core.signals import Constant, Ramp
from transgen.sim.solve.simulate import Powertrain, SolverOptions, simulate
from transgen.sim.model.transmission import Transmission
from transgen.std import state_transition_diagram

TOL = 1e-6


def _check_element_limits(tr: Transmission, r, rtol=1e-6):
    """Every element's reported torque within its own limit: a locked friction element within
    +-static*apply, a slipping one at most dynamic*apply, a one-way clutch only in its locking
    direction (free=+1 transmits t <= 0)."""
    s = r.signals
    for e in tr.elements:
        t = s[f"t_{e.name}"]
        scale = 1.0 + np.abs(t).max()
        if e.kind == "oneway":
            assert np.all(e.free * t <= rtol * scale), e.name
        else:
            limit = np.where(s[f"locked_{e.name}"] > 0, e.static, e.dynamic) * s[f"apply_{e.name}"]
            assert np.all(np.abs(t) <= limit + rtol * scale), e.name


# ------------------------------------------------------------------------- two friction clutches
PAIR = """
link A J=1
link B J=2
clutch C A B static=10 dynamic=8
clutch D B A static=30 dynamic=24
input A
output B
"""


def _pair(torque, t_end):
    mech = parse_mechanism(PAIR)
    tr = Transmission(mech, {"C": {"apply": Constant(1.0)}, "D": {"apply": Constant(1.0)}}, modes="all")
    pt = Powertrain(tr, [InputTorque(torque, tr.link_index["A"])], np.zeros(2))
    return tr, simulate(pt, SolverOptions(t_end=t_end, output_dt=0.01))


def test_two_friction_clutches_in_parallel_lock_as_one_and_share_by_capacity():
    tr, r = _pair(Constant(6.0), 1.0)
    assert r.success, r.message
    assert r.stats["events"] == 0 and set(r.modes[0].locked) == {"C", "D"}
    s = r.signals
    need = 2.0 / 3.0 * 6.0  # the torque B needs to follow A: J_B/(J_A+J_B) * T_in
    # D is declared the other way round (B to A): its torque counts with the opposite sign
    np.testing.assert_allclose(s["t_C"] - s["t_D"], need, rtol=1e-9)
    # in proportion to their capacities: 10 : 30
    np.testing.assert_allclose(s["t_C"], need * 10 / 40, rtol=1e-9)
    np.testing.assert_allclose(s["t_D"], -need * 30 / 40, rtol=1e-9)
    _check_element_limits(tr, r)


def test_two_friction_clutches_unlock_at_their_combined_capacity():
    # needed torque 2/3 * 10 t reaches the combined 10 + 30 N*m at t = 6 s (not at 10 N*m = 1.5 s)
    tr, r = _pair(Ramp(0.0, 10.0, 0.0, 100.0), 7.0)
    assert r.success, r.message
    unlocks = [e for e in r.events if e.kind == "unlock"]
    assert len(unlocks) == 1 and set(unlocks[0].elements) == {"C", "D"}
    assert unlocks[0].t == pytest.approx(6.0, abs=1e-6)
    s = r.signals
    after = r.time > 6.0 + 1e-6
    # both slip forward (w_A > w_B), each at its dynamic capacity, D in its own (reversed) sense
    assert np.all(s["slip_C"][after] > 0) and np.all(s["slip_D"][after] < 0)
    np.testing.assert_allclose(s["t_C"][after], 8.0)
    np.testing.assert_allclose(s["t_D"][after], -24.0)
    _check_element_limits(tr, r)


# --------------------------------------------------------- a freewheel beside a friction clutch


def test_freewheel_beside_a_clutch_locks_overruns_relocks_and_brakes():
    sc = load_scenario("freewheel_clutch")
    r = sc.run()
    assert r.success, r.message
    ev = [(e.kind, tuple(sorted(e.elements)), e.t) for e in r.events if e.kind != "start"]
    assert [(k, el) for k, el, _ in ev] == [("unlock", ("F",)), ("lock", ("F",)), ("lock", ("C",)),
                                            ("unlock", ("C", "F"))]
    # overrun as the drive torque ramps below the freewheel's torque (0.8 T_in + 0.4 = 0 at T_in
    # = -0.5 on the 1 ms ramp from 20 to -2); re-lock when A (alpha 40) catches B (alpha -1);
    # the clutch's capacity 100 (1 - (t-4)/0.1) falls to the 3.6 N*m it carries at 4.0964 s
    assert ev[0][2] == pytest.approx(1.0 + 0.001 * 20.5 / 22, abs=1e-6)
    # at 2 s A runs at 7.2 - 4 and B at 7.2 - 1 rad/s (drag -2 N*m on A, load 2 N*m on B); then A
    # gains 40 and B loses 1 rad/s^2: the 3 rad/s gap closes in 3/41 s (to the 1 ms ramps)
    assert ev[1][2] == pytest.approx(2.0 + 3.0 / 41.0, abs=1e-3)
    assert ev[2][2] == pytest.approx(2.5, abs=1e-9)  # the clutch joins as its apply rises from zero
    assert ev[3][2] == pytest.approx(4.0 + 0.1 * (1 - 3.6 / 100), abs=1e-5)
    s = r.signals
    tr = sc.powertrain.transmission
    _check_element_limits(tr, r)
    # locked: the group's torques sum to what B needs, J_B alpha + T_out with alpha from the
    # torque balance of both inertias (independent of the mode matrices)
    locked = s["locked_F"] > 0
    alpha = (s["T_in"] - 2.0) / 2.5
    np.testing.assert_allclose((s["t_F"] + s["t_C"])[locked], (2.0 * alpha + 2.0)[locked], atol=1e-6)
    # engine braking through the clutch (3-4 s): the freewheel carries nothing, the clutch -3.6
    braking = (r.time > 3.01) & (r.time < 4.0)
    np.testing.assert_allclose(s["t_C"][braking], -3.6, atol=1e-9)
    np.testing.assert_allclose(s["t_F"][braking], 0.0, atol=1e-12)
    # while the clutch and the freewheel both hold a drive torque, the clutch carries it first
    both = (r.time > 2.51) & (r.time < 3.0)
    np.testing.assert_allclose(s["t_C"][both], 16.4, atol=1e-9)
    assert r.energy["relative_residual"] < 1e-9
    assert r.stats["invariants"]["invariants"]["holding_limit"]["checks"] > 0  # the run-time monitor agreed


# -------------------------------------------------------------- the ZF 3HP22's manual first


def test_zf3hp22_manual_first_coast_down_brakes_with_the_engine():
    sc = load_scenario("zf3hp22_manual_first_coast")
    r = sc.run()
    assert r.success, r.message
    tr = sc.powertrain.transmission
    s = r.signals
    ev = [(e.kind, tuple(sorted(e.elements))) for e in r.events if e.kind != "start"]
    assert ev == [("unlock", ("BLR", "OWC")), ("lock", ("BLR", "OWC"))]
    t_unlock, t_lock = (e.t for e in r.events if e.kind != "start")
    assert 2.0 < t_unlock < 2.1 and 3.0 < t_lock < 3.3
    first = r.time < t_unlock - 1e-6
    again = r.time > t_lock + 1e-6
    free = (r.time > t_unlock + 1e-6) & (r.time < t_lock - 1e-6)
    ratio = 6983 / 2555  # first gear of zf3hp22_small
    for phase in (first, again):
        # manual first: input tied to the output in first gear, and the output drives the input
        # (T_out < 0: engine braking), the brake carrying the coast torque and the one-way clutch
        # nothing (the coast torque is in its free direction)
        np.testing.assert_allclose(s["w_IN"][phase], ratio * s["w_OUT_Cf_Rr"][phase], rtol=1e-9)
        # (means: the driveshaft starts untwisted and rings at first)
        assert s["T_out"][phase].mean() < -30.0
        assert s["t_BLR"][phase].mean() > 20.0
        np.testing.assert_allclose(s["t_OWC"][phase], 0.0, atol=1e-9)
    # released: the one-way clutch overruns and the car coasts without engine braking (until
    # BLR is re-applied at 3 s and slips, pulling the input back up)
    assert np.all(s["slip_OWC"][free][5:] > 0)
    coasting = free & (r.time > t_unlock + 0.1) & (r.time < 3.0)
    assert np.all(np.abs(s["T_out"][coasting]) < 5.0)
    dv = np.diff(s["vehicle_speed"])
    assert dv[first[1:]].mean() < 2 * dv[coasting[1:]].mean() < 0  # decelerates faster when braking
    _check_element_limits(tr, r)
    assert r.energy["relative_residual"] < 1e-6


def test_zf3hp22_drive_first_has_no_engine_braking():
    """The same coast-down in D (BLR never applied): the one-way clutch overruns at once."""
    sc = load_scenario("zf3hp22_manual_first_coast")
    tr = sc.powertrain.transmission
    tr.elements[tr.element_index["BLR"]].apply = Constant(0.0)
    r = simulate(sc.powertrain, dataclasses.replace(sc.options, t_end=1.0))
    assert r.success, r.message
    # (the driveshaft starts untwisted: the one-way clutch holds until the car pulls back)
    unlocks = [e for e in r.events if e.kind == "unlock"]
    assert len(unlocks) == 1 and unlocks[0].elements == ("OWC",) and unlocks[0].t < 0.05
    assert r.modes[-1].locked == ("FWD",)
    later = r.time > unlocks[0].t + 1e-3
    assert np.all(r.signals["slip_OWC"][later] > 0)


def test_decide_locks_the_pair_for_drive_and_coast_torque():
    """At zero slip with BLR applied the group locks whichever way the torque goes: unique."""
    mech = load_mechanism("zf3hp22_small")
    tr = Transmission(mech, {"FWD": {"apply": Constant(1.0)}, "BLR": {"apply": Constant(1.0)}})
    data = tr.mode([tr.element_index[x] for x in ("FWD", "OWC")])
    w = data.C @ np.array([100.0])
    u = np.zeros(len(tr.inputs))
    for t_in, t_out in ((200.0, 300.0), (-20.0, -500.0)):  # drive; coast (the car drives the output)
        u[tr.input_index["T_in"]], u[tr.input_index["T_out"]] = t_in, t_out
        locked, _ = tr.decide(0.0, w, u, 1e-9)
        assert {tr.elements[i].name for i in locked} == {"FWD", "BLR", "OWC"}
    # without BLR the coast torque makes the one-way clutch overrun
    tr.elements[tr.element_index["BLR"]].apply = Constant(0.0)
    locked, directions = tr.decide(0.0, w, u, 1e-9)
    assert {tr.elements[i].name for i in locked} == {"FWD"}
    assert directions[tr.element_index["OWC"]] == 1


def test_split_rule_invariants_on_random_torques():
    """For random inputs and apply levels: each member within its own limit, the one-way clutch
    only in its locking direction, the members summing to the constraint torque; the combined
    range is the sum of the members'."""
    mech = parse_mechanism("""
link A J=1
link B J=2
clutch C A B static=10 dynamic=8
oneway F B A free=positive
clutch D B A static=30 dynamic=24
input A
output B
""")
    rng = np.random.default_rng(3)
    tr = Transmission(mech, modes="all")
    c, f, d = (tr.element_index[x] for x in "CFD")
    data = tr.mode([c, f, d])
    assert len(data.locked_order) == 1 and set(data.groups[0]) == {c, f, d}
    for _ in range(50):
        a_c, a_d = rng.uniform(0, 1, 2)
        tr.elements[c].apply = Constant(a_c)
        tr.elements[d].apply = Constant(a_d)
        tau = rng.normal(scale=60.0, size=7)
        ts = np.zeros(7)
        lo, hi = tr.holding_limits(data, 0, 0.0)
        rep = data.locked_order[0]
        signs = dict(zip(data.groups[0], data.signs[0]))
        # F (B to A, free=positive) overruns when B runs ahead of A, i.e. it can carry torque
        # only from A to B: without limit in the positive direction of C (A to B)
        assert (lo, hi) == (pytest.approx(-10 * a_c - 30 * a_d), np.inf) if rep == c else True
        out = tr.split_locked_torques(data, ts, tau[None, :])
        np.testing.assert_allclose(sum(signs[i] * out[i] for i in (c, f, d)), tau, atol=1e-9)
        inside = (tau >= lo) & (tau <= hi)
        assert np.all(np.abs(out[c][inside]) <= 10 * a_c + 1e-9)
        assert np.all(np.abs(out[d][inside]) <= 30 * a_d + 1e-9)
        assert np.all(tr.elements[f].free * out[f] <= 1e-9)
        # friction first: the one-way clutch carries only what exceeds the friction elements in
        # its locking direction (beyond the range the other way it carries nothing)
        excess = np.maximum(tau - (10 * a_c + 30 * a_d), 0.0)
        np.testing.assert_allclose(np.abs(out[f]), excess, atol=1e-9)


def test_lone_elements_keep_their_holding_margins():
    mech = load_mechanism("zf3hp22_small")
    tr = Transmission(mech, {"B2": {"apply": Constant(0.5)}})
    data = tr.mode([tr.element_index["FWD"], tr.element_index["B2"]])
    row = data.locked_order.index(tr.element_index["B2"])
    assert tr.holding_margin(data, row, 0.0, 100.0) == pytest.approx(260 * 0.5 - 100.0, abs=1e-6)
    assert tr.unlock_directions(data, row, 0.0, -130.0) == {tr.element_index["B2"]: -1}
    data = tr.mode([tr.element_index["FWD"], tr.element_index["OWC"]])
    row = data.locked_order.index(tr.element_index["OWC"])
    assert tr.holding_margin(data, row, 0.0, -50.0) == pytest.approx(50.0, abs=1e-6)  # -free * t
    assert tr.unlock_directions(data, row, 0.0, 0.0) == {tr.element_index["OWC"]: 1}


# ------------------------------------------------------- modes, std and the simulator agree
BUNDLED = bundled_mechanisms()


@pytest.mark.parametrize("name", sorted(BUNDLED))
def test_modes_std_and_simulator_agree(name):
    mech = load_mechanism(BUNDLED[name])
    tr = Transmission(mech)
    # every mode the STD lists (default selection) is one the simulator builds
    for mode in state_transition_diagram(mech).modes:
        tr.mode([tr.element_index[x] for x in mode.locked])
    if len(mech.elements) > 7 and name != "mb722_6_w5a330_1996":  # (one 8-element gearbox: 256 modes)
        return
    every = select_modes(mech, "all")
    std = state_transition_diagram(mech, every)
    report = modes_report(mech, "all")
    flagged = {frozenset(m["locked"]) for m in report["modes"] if "not unique" in m["problem"]
               or "massless" in m["problem"]}
    refused = set()
    for mode in every:
        try:
            tr.mode([tr.element_index[x] for x in mode.locked])
        except ModeError:
            refused.add(mode.key)
    assert refused == flagged == {m.key for m, _ in std.unmodellable}
    assert {m.key for m in std.modes} == {m.key for m in every} - refused
    # the static diagnosis over all combinations says the same for the modelled ones
    diag = {frozenset(x) for x in report["diagnosis"]["non_unique_torques"] + report["diagnosis"]["undetermined_massless"]}
    assert {m.key for m in every} & diag == refused
    # elements in parallel are reported, never as non-unique torques
    for grp in report["diagnosis"]["parallel"]:
        assert frozenset(grp) not in diag


def test_zf3hp22_std_knows_manual_first():
    mech = load_mechanism("zf3hp22_small")
    std = state_transition_diagram(mech, select_modes(mech, "all"))
    name = {m.key: m.name for m in std.modes}
    manual, drive = name[frozenset({"FWD", "BLR", "OWC"})], name[frozenset({"FWD", "OWC"})]
    edges = {(t.source, t.target, t.element, t.event) for t in std.internal}
    assert (drive, manual, "BLR", "apply") in edges and (manual, drive, "BLR", "release") in edges
    speed_phase = name[frozenset({"FWD"})]
    assert (speed_phase, manual, "BLR+OWC", "lock") in edges
    unlock = next(t for t in std.internal if (t.source, t.element, t.event) == (manual, "BLR+OWC", "unlock"))
    assert unlock.target == speed_phase
    assert "[-inf, static_BLR]" in unlock.condition
    report = modes_report(mech, "all")
    assert report["diagnosis"]["parallel"] == [["BLR", "OWC"]]
    assert ["FWD", "BLR", "OWC"] not in report["diagnosis"]["non_unique_torques"]


def test_cli_names_the_groups_and_the_modes_it_cannot_model(capsys):
    from transgen.cli import main

    assert main(["modes", "zf3hp22_small"]) == 0
    out = capsys.readouterr().out
    assert "reverse R; BLR+OWC in parallel" in out
    assert "elements in parallel (same motion; locked together they are one constraint): BLR OWC" in out
    assert main(["std", "zf3hp22_small", "--all"]) == 0
    out = capsys.readouterr().out
    assert ": apply BLR: BLR is applied while OWC holds the motion (slip 0)" in out
    assert "(FWD DIR B2 BLR OWC) cannot be modelled: " in out and "BLR+OWC are not unique" in out


@pytest.mark.parametrize("name", ["freewheel_clutch", "zf3hp22_manual_first_coast"])
def test_parallel_scenarios_do_not_depend_on_the_solver(name):
    """The same event sequence (times within 1 ms) and final speeds within 0.1 % on all five
    solvers."""
    sc = load_scenario(name)
    runs = {m: simulate(sc.powertrain, dataclasses.replace(sc.options, method=m))
            for m in ("DOP853", "RK45", "LSODA", "Radau", "BDF")}
    ref = runs["DOP853"]
    for method, r in runs.items():
        assert r.success, (method, r.message)
        assert [(e.kind, e.elements) for e in r.events] == [(e.kind, e.elements) for e in ref.events], method
        assert max(abs(a.t - b.t) for a, b in zip(r.events, ref.events)) < 1e-3, method
        for link in sc.powertrain.transmission.links:
            a, b = r.signals[f"w_{link}"][-1], ref.signals[f"w_{link}"][-1]
            assert abs(a - b) <= 1e-3 * max(1.0, abs(b)), (method, link)
