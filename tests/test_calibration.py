"""The default calibration of 'transgen scenario new' (transgen.sim.derive.calibration, docs/calibration.md):
its pieces against closed forms and the statics, the driveline of the vehicle classes from its
parts, and untuned launches of bundled gearboxes judged by issue 21's acceptance rule."""
from __future__ import annotations

import math

import pytest

from transgen import load_mechanism
from transgen.sim.derive.acceptance import FLARE_LIMIT_RPM, UpshiftVerdict, hole_limit, judge_upshift, launch_acceptance
from transgen.sim.derive.calibration import (FLARE_RAMP, SYNC_FILL, ShiftTiming, coast_downshift_calibration, handover,
                                      kickdown_calibration, synchronised_inertia, upshift_calibration)
from transgen.sim.derive.driveline_class import DrivelineParts
from transgen.sim.derive.launch import VEHICLES, derive_launch, launch_scenario, static_element_torques


def test_synchronised_inertia_of_the_two_speed_is_its_input_inertia():
    # simple2: only the input (2.9 kg*m^2) and the output (held) have inertia
    mech = load_mechanism("simple2")
    assert synchronised_inertia(mech, ("C1",), ("C2",)) == pytest.approx(2.9, rel=1e-12)


@pytest.mark.parametrize("name", ["zf8hp70", "ht740", "hsw_ravigneaux4"])
def test_the_handover_at_rest_is_the_statics_of_the_two_gears(name):
    """At zero acceleration the offgoing torque of the torque-phase mode starts at its gear-A
    static torque and vanishes when the oncoming carries its gear-B static torque (lam = 1): the
    torque-phase mode and static_element_torques agree."""
    launch = derive_launch(load_mechanism(name), "car")
    mech = launch.mechanism
    for s in launch.shifts:
        a, b = launch.gear(s.source), launch.gear(s.target)
        lam, before = handover(mech, a.engaged, {e: b.torque_factors[e] for e in s.oncoming}, s.offgoing, 100.0)
        if len(s.oncoming) == 1 and len(s.offgoing) == 1:
            assert lam == pytest.approx(1.0, rel=1e-9), (name, s)
        for e, t in before.items():
            assert t == pytest.approx(100.0 * static_element_torques(mech, a.engaged)[e], rel=1e-9)


def test_a_kickdown_holds_what_the_flare_does_not_need():
    """simple2 2-1 (the input's 2.9 kg*m^2 raised by w_in (r1/r2 - 1) in t_ip): the offgoing C2,
    slipping, holds T_in - J dw / t_ip through its static share; its release over FLARE_RAMP t_ip
    has that mean over t_ip."""
    launch = derive_launch(load_mechanism("simple2"), "car")
    mech, first, second = launch.mechanism, launch.gear("1"), launch.gear("2")
    timing = ShiftTiming(inertia_phase=0.4)
    w_in, t_in = 20.0, 300.0
    cal = kickdown_calibration(mech, second, first, ("C1",), ("C2",), t_in, w_in, timing)
    dw = w_in * (first.ratio / second.ratio - 1.0)
    assert cal.speed_change == pytest.approx(dw) and cal.inertia == pytest.approx(2.9)
    held = t_in - 2.9 * dw / 0.4
    mean = 1.0 - 0.4 / (2 * FLARE_RAMP * 0.4)
    level = abs(second.torque_factors["C2"]) * held / mech.element("C2").dynamic / mean
    assert 0.0 < level < 1.0 and cal.offgoing_level == pytest.approx(level, rel=1e-9)
    tpl = cal.template
    assert tpl.fill_level == SYNC_FILL and tpl.offgoing_delay == 0.0 and tpl.offgoing_ramp == pytest.approx(0.8)
    # more inertia to raise, less to hold; a flare the engine cannot make releases at once
    assert kickdown_calibration(mech, second, first, ("C1",), ("C2",), t_in, 2 * w_in, timing).offgoing_level < level
    assert kickdown_calibration(mech, second, first, ("C1",), ("C2",), 10.0, w_in, timing).offgoing_level == 0.0


def test_a_coast_downshift_is_sized_as_an_upshift_with_the_drag():
    launch = derive_launch(load_mechanism("simple2"), "car")
    mech, first, second = launch.mechanism, launch.gear("1"), launch.gear("2")
    timing = ShiftTiming()
    cal = coast_downshift_calibration(mech, second, first, ("C1",), ("C2",), -40.0, 150.0, timing)
    own = upshift_calibration(mech, second, first, ("C1",), ("C2",), 40.0, 150.0, timing)
    # the input rises by w_in (r1/r2 - 1); the levels are the upshift method's with |drag|
    assert cal.speed_change == pytest.approx(150.0 * (first.ratio / second.ratio - 1.0))
    assert cal.inertia_level == own.inertia_level and cal.handover_level == own.handover_level
    assert cal.template.ramp_time <= timing.torque_phase
    # almost no drag (the engine idles): the ramp still reaches its level in t_tp
    tiny = coast_downshift_calibration(mech, second, first, ("C1",), ("C2",), 0.0, 150.0, timing)
    assert tiny.template.ramp_time == pytest.approx(timing.torque_phase)


def test_the_scenario_holds_each_upshifts_derived_template():
    mech = load_mechanism("zf3hp22_small")
    launch = derive_launch(mech, "car")
    text = launch_scenario(mech, "car", "zf3hp22_small", launch)
    for c in launch.calibrations:
        assert f'[auto_shift.templates."{c.source}-{c.target}"]' in text
        t = c.template
        # the oncoming passes the handover level after the torque phase; the offgoing is out before it
        assert t.ramp_end * VEHICLES["car"].shift_timing.torque_phase / t.ramp_time == pytest.approx(
            c.handover_level, rel=1e-3)
        assert t.offgoing_ramp < VEHICLES["car"].shift_timing.torque_phase
        assert c.handover_level < c.inertia_level <= 0.95
    doc = launch.to_dict()
    assert [c["from"] + "-" + c["to"] for c in doc["calibration"]] == [f"{s.source}-{s.target}" for s in launch.shifts]
    assert doc["driveline"]["stiffness"] > 0


def test_the_driveline_is_its_parts_in_series_through_the_final_drive():
    parts = DrivelineParts(propshaft=36000.0, halfshaft=5000.0, halfshafts=2, tyre_slip_stiffness=20.0,
                           relaxation_length=0.15, driven_axle_load=0.5, damping_ratio=0.1)
    eq = parts.equivalent(final_drive=3.0, wheel_radius=0.3, mass=1500.0, output_inertia=0.0, gearbox_inertia=1.0)
    tyres = 0.3 ** 2 * 20.0 * 0.5 * 1500.0 * 9.81 / 0.15 / 9.0
    assert eq.parts == pytest.approx({"propshaft": 36000.0, "halfshafts": 10000.0 / 9.0, "tyres": tyres})
    k = 1.0 / (1 / 36000.0 + 9.0 / 10000.0 + 1.0 / tyres)
    assert eq.stiffness == pytest.approx(k)
    j2 = 1500.0 * 0.09 / 9.0
    j = j2 / (1.0 + j2)
    assert eq.damping == pytest.approx(2 * 0.1 * math.sqrt(k * j))
    assert eq.frequency == pytest.approx(math.sqrt(k / j) / (2 * math.pi))
    with pytest.raises(ValueError, match="halfshafts"):
        DrivelineParts(36000.0, 5000.0, 0, 20.0, 0.15, 0.5, 0.1)


def test_the_acceptance_rule():
    assert hole_limit(1.5) == pytest.approx(100 * (1 - 1 / 1.5) + 20)
    ok = UpshiftVerdict("1-2", 1.5, 0.0, FLARE_LIMIT_RPM, 53.0, hole_limit(1.5), 10.0, True)
    assert ok.acceptable
    assert not UpshiftVerdict("1-2", 1.5, 2.0, 0.0, 40.0, hole_limit(1.5), 10.0, True).acceptable  # bindup
    assert not UpshiftVerdict("1-2", 1.5, 0.0, 50.5, 40.0, hole_limit(1.5), 10.0, True).acceptable  # flare
    assert not UpshiftVerdict("1-2", 1.5, 0.0, 0.0, 54.0, hole_limit(1.5), 10.0, True).acceptable  # hole
    assert not UpshiftVerdict("1-2", 1.5, 0.0, 0.0, 40.0, hole_limit(1.5), 10.0, False).acceptable  # not locked
    assert not judge_upshift("1-2", 1.5, []).acceptable
    with pytest.raises(ValueError):
        hole_limit(float("nan"))


# the fast acceptance check: gearboxes with a one-way clutch, clutch-to-clutch single swaps and a
# double swap, in both vehicle classes (benchmarks/bench_launch_acceptance.py runs every gearbox)
@pytest.mark.parametrize("name", ["zf3hp22_small", "ht740", "hsw_ravigneaux4"])
@pytest.mark.parametrize("vehicle", ["car", "truck"])
def test_untuned_launch_upshifts_are_acceptable(name, vehicle):
    launch, verdicts, _ = launch_acceptance(load_mechanism(name), vehicle, name)
    assert [v.name for v in verdicts] == [f"{a}-{b}" for a, b in zip(launch.order, launch.order[1:])]
    bad = [v for v in verdicts if not v.acceptable]
    assert not bad, bad
    if vehicle == "car":  # a few times the passenger-car comfort limit of about 10 m/s^3
        assert max(v.jerk for v in verdicts) < 60.0
