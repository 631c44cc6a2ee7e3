"""Launch scenarios derived from a .mech alone (transgen scenario new): the derivation checked
against the numbers the mechanism files state, the schedule's double swaps and one-way clutches,
and every bundled gearbox launched from rest through every forward gear in a car and a truck."""
from __future__ import annotations

import json
import tomllib
import warnings

import numpy as np
import pytest

from transgen import bundled_mechanisms, load_mechanism, parse_mechanism
from transgen.own_converter import converter_drive, own_converter
from transgen.cli import main
from transgen.errors import ScenarioError
from transgen.kinematics import gear_ratios
from transgen.sim.derive.launch import (HOLD_FACTOR, RAMP_END_RANGE, derive_launch, launch_scenario, output_inertia,
                                 static_element_torques)
from transgen.sim.scenario.load import load_scenario
from transgen.sim.control.schedule import AutoShift, ShiftTemplate, gear_swap
from transgen.sim.core.signals import Constant
from transgen.sim.model.transmission import ElementConfig


# ------------------------------------------------------------------------------ derivation


@pytest.mark.parametrize("name, gear, expected", [
    ("ht740", "1", {"C1": 1.0, "C5": 1.0 - 3.6923}),        # C5 reacts ratio - 1 (thesis: 5385 N*m at 2000)
    ("zf3hp22_small", "2", {"FWD": 1.0, "B2": -0.562}),      # the file's comments: 1.000 and 0.562 x Tin
    ("hsw_ravigneaux4", "2", {"CL_small_sun": 1.0, "BAND_large_sun": -0.467}),
    ("mb722_6_w5a330_1996", "2", {"K1": -0.633}),   # magnitudes from the comments; sign: w1 - w2 convention
])
def test_static_element_torques_match_the_mechanism_files(name, gear, expected):
    mech = load_mechanism(name)
    k = static_element_torques(mech, mech.gear(gear).engaged)
    for element, value in expected.items():
        assert k[element] == pytest.approx(value, abs=2e-3), (element, k)


def test_static_element_torques_balance_the_gear():
    """Input, output and housing torques balance: the brakes react 1 - ratio (here a gear whose
    only housing element is one brake)."""
    mech = load_mechanism("zf3hp22_small")
    k = static_element_torques(mech, mech.gear("2").engaged)
    assert k["B2"] == pytest.approx(1.0 - 1.5616, abs=1e-3)


def test_output_inertia_reflects_the_input_inertia_with_the_ratio_squared():
    mech = load_mechanism("simple2")  # Li 2.9 kg*m^2 on the input, Lo 1.0 on the output, massless between
    assert output_inertia(mech, mech.gear("1").engaged) == pytest.approx(1.0 + 2.9 * (20 / 3) ** 2, rel=1e-9)
    assert output_inertia(mech, mech.gear("2").engaged) == pytest.approx(1.0 + 2.9 * (40 / 11) ** 2, rel=1e-9)


def test_forward_gears_sorted_and_shifts_with_double_swap_and_one_way_clutches():
    hsw = derive_launch(load_mechanism("hsw_ravigneaux4"))
    assert hsw.order == ("1", "2", "3", "OD")          # R (negative ratio) left out
    last = hsw.shifts[-1]
    assert (last.source, last.target, last.kind) == ("3", "OD", "double swap")
    assert last.oncoming == ("BAND_large_sun", "CL_carrier") and last.offgoing == ("CL_large_sun", "CL_small_sun")
    mb = derive_launch(load_mechanism("mb722_6_w5a330_1996"))
    first = mb.shifts[0]
    assert first.oncoming == ("K1",) and first.offgoing == () and first.overrunning == ("F1",)
    assert mb.shifts[1].overrunning == ("F2",) and mb.shifts[1].oncoming == ("K2",)


def test_a_swap_of_more_than_two_elements_is_refused_naming_the_gears():
    mech = load_mechanism("mb722_6_w5a330_1996")
    table = {g.name: g.engaged for g in mech.gears}
    with pytest.raises(ValueError, match=r"shift 1-5 is not schedulable: it swaps 3 element\(s\) for 3"):
        gear_swap(table, "1", "5")
    # a gear table whose only upshifts are triple swaps: refused with the file and gear line
    text = mech.text
    for g in ("2", "3", "4"):
        text = "\n".join(line for line in text.splitlines() if not line.startswith(f"gear {g} "))
    with pytest.raises(ScenarioError, match=r"mb722.*:\d+:\d+: error: no forward gear can be shifted to from gear 1"):
        derive_launch(parse_mechanism(text, mech.source))


def test_an_unreachable_gear_is_named_and_left_out():
    mech = load_mechanism("mb722_6_w5a330_1996")
    text = "\n".join(line for line in mech.text.splitlines() if not line.startswith(("gear 3 ", "gear 4 ")))
    launch = derive_launch(parse_mechanism(text, mech.source))
    assert launch.order == ("1", "2")  # 2 -> 5 swaps K1 B2 F2 for K2 K3 B1
    assert launch.skipped[0][0] == "5" and "not schedulable" in launch.skipped[0][1]
    assert any("gear 5 is not schedulable" in w for w in launch.warnings)
    assert "NOT SCHEDULABLE" in launch_scenario(parse_mechanism(text, mech.source))


def test_too_small_capacities_limit_the_engine_torque_and_are_then_sufficient():
    mech = load_mechanism("zf3hp22_small")
    text = mech.text.replace("clutch FWD IN Rf  static=470 dynamic=400", "clutch FWD IN Rf  static=120 dynamic=100")
    assert text != mech.text
    weak = parse_mechanism(text, mech.source)
    launch = derive_launch(weak, "car")
    assert launch.torque_scale < 1.0
    assert any(w.startswith("FWD: declared static capacity 120 N*m") for w in launch.warnings)
    # the limited input torque is what FWD (|k| = 1 in every forward gear) can hold with the margin
    assert HOLD_FACTOR * launch.input_torque_max == pytest.approx(120.0, rel=1e-3)
    assert launch.vehicle.mass == pytest.approx(1700.0 * launch.torque_scale)
    assert RAMP_END_RANGE[0] <= launch.template.ramp_end <= RAMP_END_RANGE[1]
    assert derive_launch(mech, "car").torque_scale == 1.0


def test_schedule_lines_rise_and_downshift_lines_lie_below():
    for name in ("zf8hp70", "ht740"):
        for vehicle in ("car", "truck"):
            launch = derive_launch(load_mechanism(name), vehicle)
            up = np.array(launch.upshift_rpm)
            assert np.all(np.diff(up, axis=0) > 0)
            assert np.all(np.array(launch.downshift_rpm) < up)
            assert launch.t_end > launch.shift_times[-1]


def test_a_mechanism_without_forward_gears_is_refused():
    with pytest.raises(ScenarioError, match=r"coupled_clutches\.mech:1:1: error: a launch scenario needs a gear "
                                            r"table with at least two forward gears"):
        derive_launch(load_mechanism("coupled_clutches"))
    with pytest.raises(ValueError, match="unknown vehicle class 'bus'"):
        derive_launch(load_mechanism("ht740"), "bus")


# ------------------------------------------------------------------------------- schedule


def _elements(mech):
    return {e.name: ElementConfig(e.name, e.kind, None, None, e.static, e.dynamic,
                                  apply=Constant(1.0 if e.name in mech.gear("3").engaged else 0.0))
            for e in mech.elements}


def test_auto_shift_double_swap_applies_both_oncoming_and_releases_both_offgoing():
    mech = load_mechanism("hsw_ravigneaux4")
    gears = {g.name: g.engaged for g in mech.gears}
    tmpl = ShiftTemplate()
    shift = AutoShift(["3", "OD"], [0.0, 1.0], [[100.0, 100.0]], [[50.0, 50.0]], Constant(0.5), 0, gears, tmpl,
                      gear="3")
    elements = _elements(mech)
    text = shift.fire("up", 1.0, elements)
    assert text == "upshift 3-OD (on BAND_large_sun CL_carrier, off CL_large_sun CL_small_sun; power-on)"
    t_hold = 1.0 + tmpl.fill_time + tmpl.ramp_time + 0.5 * tmpl.hold_time
    t_done = 1.0 + tmpl.fill_time + tmpl.ramp_time + tmpl.hold_time + tmpl.final_time + 0.1
    for name in ("BAND_large_sun", "CL_carrier"):
        assert elements[name].apply_at(t_hold) == pytest.approx(tmpl.ramp_end)
        assert elements[name].apply_at(t_done) == pytest.approx(1.0)
    for name in ("CL_large_sun", "CL_small_sun"):
        assert elements[name].apply_at(0.99) == 1.0 and elements[name].apply_at(t_done) == 0.0
    assert elements["REVERSE_BAND"].apply_at(t_done) == 0.0


def test_auto_shift_leaves_one_way_clutches_alone_and_refuses_a_triple_swap():
    mech = load_mechanism("mb722_6_w5a330_1996")
    gears = {g.name: g.engaged for g in mech.gears}
    shift = AutoShift(["1", "2"], [0.0, 1.0], [[100.0, 100.0]], [[50.0, 50.0]], Constant(0.5), 0, gears, gear="1")
    elements = _elements(mech)
    assert shift.fire("up", 2.0, elements) == "upshift 1-2 (on K1, off none: one-way clutch overruns; power-on)"
    with pytest.raises(ValueError, match="shift 1-5 is not schedulable"):
        AutoShift(["1", "5"], [0.0, 1.0], [[100.0, 100.0]], [[50.0, 50.0]], Constant(0.5), 0, gears)


def test_a_line_crossed_within_min_interval_shifts_when_the_interval_ends():
    mech = load_mechanism("ht740")
    gears = {g.name: g.engaged for g in mech.gears}
    shift = AutoShift(["1", "2", "3"], [0.0, 1.0], [[100.0, 100.0], [120.0, 120.0]], [[50.0, 50.0], [60.0, 60.0]],
                      Constant(0.5), 0, gears, min_interval=2.0)
    shift.fire("up", 1.0, {e.name: ElementConfig(e.name, e.kind, None, None, e.static, e.dynamic) for e in mech.elements})
    (up, kind), _ = shift.event_functions()
    w = np.array([200.0])          # far above the 2-3 line already
    assert kind == "up" and up(2.0, w) == pytest.approx(1.0) and up(3.5, w) < 0  # zero crossing at t = 3.0
    assert up(3.0, w) == pytest.approx(0.0, abs=1e-12)


# ------------------------------------------------------------------ launches of every gearbox

def _with_gear_table(name):
    """At least two forward gears (positive ratio) in the gear table."""
    return sum(1 for r in gear_ratios(load_mechanism(name)).values() if r is not None and r > 0) >= 2


LAUNCH_CASES = [
    (name, vehicle)
    for name in bundled_mechanisms() if _with_gear_table(name) for vehicle in ("car", "truck")
]


@pytest.mark.parametrize("name, vehicle", LAUNCH_CASES)
def test_generated_launch_runs_from_rest_through_every_forward_gear(name, vehicle, tmp_path):
    mech = load_mechanism(name)
    launch = derive_launch(mech, vehicle)
    path = tmp_path / "launch.toml"
    path.write_text(launch_scenario(mech, vehicle, name, launch), encoding="utf-8")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        scenario = load_scenario(path)
        result = scenario.run()
    assert result.success, result.message
    commands = [e.detail for e in result.events if e.kind == "command"]
    assert [c.split(" (")[0] for c in commands] == [f"upshift {a}-{b}" for a, b in zip(launch.order, launch.order[1:])]
    # the mode spans visit every gear of the sequence, in order, and the run ends in the top gear
    # (one-way clutches engage by themselves: a mode may hold one beside the gear's elements)
    # (a mechanism with its own converter runs them in converter drive: the lock-up open, the
    # ratio is the turbine's, transgen.own_converter)
    own = own_converter(mech)
    oneways = {e.name for e in mech.elements if e.kind == "oneway"}
    spans = [set(m.locked) - oneways for m in result.modes]
    i = 0
    for gear in launch.order:
        engaged = set(converter_drive(launch.gear(gear).engaged, own)) - oneways
        i = next((j for j in range(i, len(spans)) if spans[j] == engaged), None)
        assert i is not None, f"gear {gear} ({' '.join(sorted(engaged))}) never engaged"
    assert spans[-1] == set(converter_drive(launch.gear(launch.order[-1]).engaged, own)) - oneways
    w_in, w_out = result[f"w_{result.meta['gearbox_input']}"][-1], result[f"w_{mech.output}"][-1]
    assert w_in / w_out == pytest.approx(launch.gear(launch.order[-1]).ratio, rel=1e-4)
    assert result["vehicle_speed"][0] == 0.0 if "vehicle_speed" in result.signals else True


# -------------------------------------------------------------------------------------- CLI


def test_cli_scenario_new_writes_prints_and_summarises(tmp_path, capsys, monkeypatch):
    out = tmp_path / "sub" / "launch.toml"
    assert main(["scenario", "new", "ht740", "--vehicle", "truck", "-o", str(out)]) == 0
    assert "wrote" in capsys.readouterr().out
    data = tomllib.loads(out.read_text())
    assert data["mechanism"] == "ht740" and data["auto_shift"]["order"] == ["1", "2", "3", "4"]
    assert load_scenario(out).mechanism.name == load_mechanism("ht740").name

    assert main(["scenario", "new", "zf3hp22_small"]) == 0
    printed = capsys.readouterr().out
    assert tomllib.loads(printed)["initial"] == {"gear": "1", "speeds": {"OUT_Cf_Rr": 0.0}}

    assert main(["scenario", "new", "hsw_ravigneaux4", "--json"]) == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary["schema"] == "transgen.scenario-new/1" and "transgen_version" in summary
    assert summary["shifts"][-1]["kind"] == "double swap" and summary["written"] == []

    # a path FILE is written relative to the scenario's folder
    mech_file = tmp_path / "my.mech"
    mech_file.write_text(load_mechanism("simple2").text)
    monkeypatch.chdir(tmp_path)
    assert main(["scenario", "new", "my.mech", "-o", "sub/s2.toml"]) == 0
    assert tomllib.loads((tmp_path / "sub" / "s2.toml").read_text())["mechanism"] == "../my.mech"
    assert load_scenario(tmp_path / "sub" / "s2.toml").mechanism.gears[0].name == "1"


def test_cli_scenario_new_bad_input_exits_2_and_writes_nothing(tmp_path, capsys):
    out = tmp_path / "x.toml"
    assert main(["scenario", "new", "coupled_clutches", "-o", str(out)]) == 2
    err = capsys.readouterr().err
    assert "coupled_clutches.mech:1:1: error: a launch scenario needs" in err and "Traceback" not in err
    assert not out.exists() and list(tmp_path.iterdir()) == []
    with pytest.raises(SystemExit) as exc:
        main(["scenario", "new", "ht740", "--vehicle", "bus"])
    assert exc.value.code == 2
    with pytest.raises(SystemExit) as exc:
        main(["scenario", "--help"])
    assert exc.value.code == 0 and "new" in capsys.readouterr().out


def test_a_second_gear_with_the_same_ratio_is_left_out():
    mech = load_mechanism("ht740")
    text = mech.text.replace("gear 3 = C1 C3", "gear 2b = C4 C1 ratio=2.02\ngear 3 = C1 C3")
    launch = derive_launch(parse_mechanism(text, mech.source))
    assert launch.order == ("1", "2", "3", "4")
    assert launch.skipped == (("2b", "same ratio as gear 2 (2.0196)"),)
