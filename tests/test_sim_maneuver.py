"""Maneuvers derived from a .mech (scenario new --maneuver): power-on downshifts (kickdown) and
power-off downshifts (coast-down) of the 8HP70 car and the HT-740 truck run and give sensible
reports; the wheel brakes keep the energy balance; a speed-phase-first shift applies its oncoming
element at synchronism."""
from __future__ import annotations

import math
import tomllib

import numpy as np
import pytest

from transgen import load_mechanism
from transgen.cli import main
from transgen.sim.model.brake import BrakedDriveline, braked_driveline_rates
from transgen.sim.analysis.downshift_quality import downshift_figures
from transgen.sim.derive.launch import derive_launch
from transgen.sim.derive.maneuver import derive_maneuver, maneuver_scenario
from transgen.sim.analysis.report import energy_balance, shift_report
from transgen.sim.scenario.load import parse_scenario
from transgen.sim.control.schedule import POWER_ON_THROTTLE, SYNC_FRACTION, speed_phase_first
from transgen.sim.core.signals import Constant, Ramp


def _run(name, vehicle, kind, tmp_path):
    mech = load_mechanism(name)
    launch = derive_launch(mech, vehicle)
    text = maneuver_scenario(mech, vehicle, kind, name, launch)
    scenario = parse_scenario(text, tmp_path / f"{kind}.toml")
    result = scenario.run()
    assert result.success, result.message
    assert energy_balance(result)["passed"]
    return mech, launch, derive_maneuver(mech, launch, kind), result, shift_report(result)


def test_speed_phase_first_is_a_power_on_downshift_or_a_power_off_upshift():
    assert speed_phase_first("down", 1.0) and speed_phase_first("up", 0.0)
    assert not speed_phase_first("up", POWER_ON_THROTTLE) and not speed_phase_first("down", 0.0)


@pytest.mark.parametrize("name, vehicle", [("zf8hp70", "car"), ("ht740", "truck")])
def test_kickdown_gives_power_on_downshifts_that_flare_to_synchronism(name, vehicle, tmp_path):
    mech, launch, m, result, report = _run(name, vehicle, "kickdown", tmp_path)
    assert m.gear == launch.order[-1] and m.throttle_after == 1.0 and m.expected
    downs = [q for q in report if q.direction == "downshift"]
    assert downs and all(q.completed for q in downs)
    commands = [e.detail for e in result.events if e.kind == "command"]
    assert commands[0].startswith(f"downshift {m.expected[0]} ") and commands[0].endswith("; power-on)")
    assert any(c.startswith("synchronism: apply") for c in commands)
    for q in downs:
        d = downshift_figures(result, q)
        assert d["power"] == "on"
        assert 0.0 < d["time_to_sync"] < 1.0          # the flare: well within a second
        assert d["overshoot_rpm"] < 150.0               # the oncoming element locks near synchronism
        assert d["tie_up_energy"] >= 0.0 and d["offgoing_after_sync"] >= 0.0
        assert not q.bindup
        # the oncoming element only filled until the sync command, then applied
        sync = next(e.t for e in result.events if e.kind == "command" and e.t > q.t_start
                    and e.detail.startswith("synchronism"))
        a_on = result.signals[f"apply_{q.oncoming}"]
        k = np.searchsorted(result.time, sync) - 1
        assert a_on[k] == pytest.approx(0.02, abs=1e-9)
        # the input reaches the new gear's speed at the sync command (within its band) or after
        assert sync <= d["sync_time"] + 1e-6
    # the vehicle accelerates after the kickdown
    v = result.signals["vehicle_speed"]
    assert v[-1] > v[np.searchsorted(result.time, 3.0)] + 0.5


@pytest.mark.parametrize("name, vehicle", [("zf8hp70", "car"), ("ht740", "truck")])
def test_coastdown_brakes_down_through_the_gears_with_power_off_downshifts(name, vehicle, tmp_path):
    mech, launch, m, result, report = _run(name, vehicle, "coastdown", tmp_path)
    assert m.brake > 0 and m.throttle_after == 0.0
    downs = [q for q in report if q.direction == "downshift"]
    commanded = [e.detail.split(" (")[0] for e in result.events if e.kind == "command"]
    assert commanded == [f"downshift {s}" for s in m.expected]     # every throttle-0 line, in order
    assert len(downs) == len(m.expected) and all(q.completed for q in downs)
    for q in downs:
        d = downshift_figures(result, q)
        assert d["power"] == "off" and 0.0 < d["time_to_sync"] < 1.0 and d["overshoot_rpm"] < 150.0
    # the brakes took energy out at the wheels, the vehicle slowed
    p_brake = result.signals["P_brake"]
    assert np.all(p_brake >= -1e-9) and np.trapezoid(p_brake, result.time) > 0
    assert result.signals["vehicle_speed"][-1] < 0.5 * m.speed


def test_braked_driveline_opposes_motion_fades_at_rest_and_compiles_alike():
    numbers = (8000.0, 150.0, 10.0, 1700.0, 0.0, 0.0, 1.2, 0.0, 0.33, 3.0)
    _, _, free, _, p_free = braked_driveline_rates(0.0, 30.0, 30.0, 0.0, *numbers)
    _, _, braked, _, p_braked = braked_driveline_rates(0.0, 30.0, 30.0, 900.0, *numbers)
    assert braked - free == pytest.approx(-900.0 / 3.0 / 10.0 * math.tanh(30.0 * 0.11 / 0.02))
    assert p_braked - p_free == pytest.approx(900.0 / 3.0 * math.tanh(165.0) * 30.0)
    _, _, rest, _, _ = braked_driveline_rates(0.0, 0.0, 0.0, 900.0, *numbers)
    assert rest == 0.0                                   # no torque at rest: a stopped vehicle stays
    assert braked_driveline_rates(0.0, 30.0, 30.0, -5.0, *numbers) == braked_driveline_rates(0.0, 30.0, 30.0, 0.0,
                                                                                                *numbers)
    d = BrakedDriveline(0, 8000.0, 150.0, 0.05, 3.0, 0.33, 1700.0, 0.011, 0.7, brake=Ramp(0.0, 1.0, 0.0, 900.0))
    kind, ints, nums, signals, inputs = d.kernel_form()
    assert kind == "braked_driveline" and signals == (d.brake,) and inputs == ("T_out",)
    assert d.breakpoints(-1, 2) == (0.0, 1.0)


def test_scenario_brake_key_and_cli_maneuvers(tmp_path, capsys):
    out = tmp_path / "kd.toml"
    assert main(["scenario", "new", "ht740", "--vehicle", "truck", "--maneuver", "coastdown", "-o", str(out)]) == 0
    data = tomllib.loads(out.read_text())
    assert data["driveline"]["brake"]["type"] == "ramp"
    assert set(data["auto_shift"]["speed_first_templates"]) == {"2-1", "3-2", "4-3", "1-2", "2-3", "3-4"}
    assert data["initial"]["driveshaft"] == "settled" and data["initial"]["gear"] == "4"
    assert main(["scenario", "new", "ht740", "--maneuver", "kickdown", "--cycle", "ftp75"]) == 2
    assert "--cycle goes with --maneuver cycle" in capsys.readouterr().err
    bad = out.read_text().replace("brake = {", "brake = { nope = 1,", 1)
    with pytest.raises(Exception, match="brake"):
        parse_scenario(bad, tmp_path / "bad.toml")


def test_sync_band_is_a_fraction_of_the_slip_at_the_command():
    from transgen.sim.control.schedule import AutoShift
    from transgen.sim.model.transmission import ElementConfig

    mech = load_mechanism("ht740")
    gears = {g.name: g.engaged for g in mech.gears}
    shift = AutoShift(["3", "4"], [0.0, 1.0], [[100.0, 100.0]], [[50.0, 50.0]], Constant(1.0), 0, gears, gear="4",
                      slips={e.name: (1.0,) + (0.0,) * 9 for e in mech.elements})
    elements = {e.name: ElementConfig(e.name, e.kind, Constant(1.0 if e.name in gears["4"] else 0.0), None,
                                      e.static, e.dynamic) for e in mech.elements}
    text = shift.fire("down", 1.0, elements, np.full(10, 200.0))
    assert text.endswith("; power-on)") and shift.pending["band"] == pytest.approx(SYNC_FRACTION * 200.0)
    (name,) = shift.pending["elements"]
    assert elements[name].apply_at(1.5) == pytest.approx(shift.speed_first.get("4-3", shift.template).fill_level)
    assert shift.fire("sync", 1.6, elements).startswith("synchronism: apply")
    assert elements[name].apply_at(1.6 + shift.template.final_time) == 1.0 and not shift.pending


def test_tipout_upshifts_power_off_speed_phase_first_and_tipin_does_not_shift(tmp_path):
    mech, launch, m, result, report = _run("zf8hp70", "car", "tipout", tmp_path)
    commands = [e.detail for e in result.events if e.kind == "command"]
    assert commands[0].startswith(f"upshift {m.expected[0]} ") and commands[0].endswith("; power-off)")
    assert commands[1].startswith("synchronism: apply")
    (q,) = report
    assert q.direction == "upshift" and q.completed   # (the lift-off reverses the torque: no bindup test)
    assert q.flare_max_rpm < 150.0
    _, _, m, result, report = _run("zf8hp70", "car", "tipin", tmp_path)
    assert m.throttle < m.throttle_after < 1.0 and report == []
    assert not [e for e in result.events if e.kind == "command"]
