"""Every scenario value addressable (issue 11, section 1): ``--set KEY=VALUE`` overrides, the
mechanism's parameters, the files a scenario reads, ``transgen scenario keys`` and ``copy``."""
from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from transgen.errors import ScenarioError
from transgen.sim import load_scenario, parse_override, scenario_files, scenario_keys
from transgen.sim.scenario import bundled_scenarios

SHORT = {"simulation.t_end": 2.0}  # the HT-740 launch in first gear, fast enough for tests


def _final(scenario, name="w_L6"):
    result = scenario.run()
    assert result.success, result.message
    return float(result[name][-1])


def _same(a, b) -> None:
    assert a.time.shape == b.time.shape
    assert np.array_equal(a.time, b.time)
    for name in a.signals:
        assert np.array_equal(a.signals[name], b.signals[name]), name


# ------------------------------------------------------------------------------ values


def test_parse_override_reads_toml_values_and_bare_words():
    assert parse_override("driveline.vehicle_mass=20000") == ("driveline.vehicle_mass", 20000)
    assert parse_override("input.type=\"turbodiesel\"") == ("input.type", "turbodiesel")
    assert parse_override("input.type=turbodiesel") == ("input.type", "turbodiesel")
    assert parse_override("elements.C4.apply={type=\"ramp\", t0=1, t1=2, v0=0, v1=1}")[1] == \
        {"type": "ramp", "t0": 1, "t1": 2, "v0": 0, "v1": 1}
    assert parse_override(" shifts.events.0.t = 4.5 ") == ("shifts.events.0.t", 4.5)


@pytest.mark.parametrize("text, words", [
    ("driveline.vehicle_mass", "expected KEY=VALUE"),
    ("=3", "expected KEY=VALUE"),
    ("driveline.vehicle_mass=", "no value"),
    ("driveline..mass=1", "names joined by dots"),
    ("driveline.vehicle_mass=nan", "not a finite number"),
    ("driveline.vehicle_mass=inf", "not a finite number"),
    ("driveline.vehicle_mass=1e400", "not a finite number"),
    ("simulation.rtol=[1, nan]", "not a finite number"),
    ("elements.C4.apply={type=\"ramp\"", "not a TOML value"),
    ("x=1\ny=2", "not a TOML value"),
])
def test_parse_override_refuses_malformed_text(text, words):
    with pytest.raises(ScenarioError, match=words) as err:
        parse_override(text)
    assert "--set" in str(err.value)


# --------------------------------------------------------------------------- overrides


def test_vehicle_mass_override_changes_the_final_speed_and_the_file_value_changes_nothing():
    base = load_scenario("ht740_improved", SHORT).run()
    same = load_scenario("ht740_improved", {**SHORT, "driveline.vehicle_mass": 36000.0}).run()
    _same(base, same)
    light = load_scenario("ht740_improved", {**SHORT, "driveline.vehicle_mass": 20000}).run()
    assert light.success
    assert light["w_L6"][-1] > 1.2 * base["w_L6"][-1]   # the lighter truck is faster after 2 s


def test_override_matches_an_edited_file(tmp_path):
    text = bundled_scenarios()["simple2_upshift"].read_text(encoding="utf-8")
    edited = tmp_path / "s.toml"
    edited.write_text(text.replace('mechanism = "simple2"', 'mechanism = "simple2"\n[compliant]\n', 1)
                      + "\n", encoding="utf-8")
    a = load_scenario(bundled_scenarios()["simple2_upshift"], {"simulation.rtol": 1e-6}).run()
    edited.write_text(text.replace("[simulation]", "[simulation]\nrtol = 1e-6", 1), encoding="utf-8")
    b = load_scenario(edited).run()
    _same(a, b)


def test_overrides_reach_every_table():
    s = load_scenario("ht740_improved", {"input.throttle_signal": 0.6, "simulation.rtol": 1e-6,
                                         "elements.C4.apply.t": [0.0, 4.0, 5.5, 9.0, 9.02, 9.3],
                                         "initial.speeds.L1": 10.0})
    assert s.options.rtol == 1e-6
    assert s.data["input"]["throttle_signal"] == 0.6
    assert s.powertrain.initial_speeds[s.powertrain.transmission.link_index["L1"]] == pytest.approx(10.0)
    assert s.data["elements"]["C4"]["apply"]["t"][2] == 5.5


def test_a_key_absent_from_the_file_but_known_is_set():
    s = load_scenario("ht740_improved", {"driveline.grade_percent": 2.0})
    assert s.data["driveline"]["grade_percent"] == 2.0
    # a table the file lacks: its other required keys are asked for, naming the override
    with pytest.raises(ScenarioError, match=r"^--set auto_shift.upshift_rpm: error: .*order"):
        load_scenario("ht740_improved", {"auto_shift.upshift_rpm": [[1500]]})


@pytest.mark.parametrize("key, value, words", [
    ("driveline.vehicle_mas", 1.0, r"unknown key 'vehicle_mas' in \[driveline\]; did you mean 'driveline.vehicle_mass'"),
    ("vehicle_mass", 1.0, r"did you mean 'driveline.vehicle_mass'"),
    ("drivline.vehicle_mass", 1.0, r"did you mean 'driveline.vehicle_mass'"),
    ("elements.C9.apply", 1.0, r"unknown key 'C9' in \[elements\]"),
    ("initial.speeds.L99", 1.0, r"unknown key 'L99'"),
    ("simulation.rtol.x", 1.0, r"'simulation.rtol' is a value, not a table"),
    ("elements.C4.apply.t9", 1.0, r"unknown key 't9' of the signal 'elements.C4.apply'"),
    ("shifts.events.0.t", 1.0, r"array of tables with 0 entries|has no entries"),
    ("driveline.vehicle_mass", "heavy", r"'vehicle_mass' must be a finite number, not 'heavy'"),
    ("driveline.vehicle_mass", -5.0, r"'vehicle_mass' must be >= 0"),
    ("elements.C4.apply", {"type": "ramp", "t0": 2.0, "t1": 1.0, "v0": 0, "v1": 1}, r"ramp needs t1 > t0"),
    ("input.type", "steam", r"input type must be"),
    ("simulation.method", "Euler", r"unknown integration method"),
    ("mech.L1.J", -1.0, r"J must not be negative"),
    ("mech.L1.j", 1.0, r"has no parameter 'j'; did you mean 'J'"),
    ("mech.L9.J", 1.0, r"no link, planetary, gear pair or shift element 'L9' in the mechanism; did you mean 'L\d'"),
    ("mech.P2.Nr", 40, r"ring teeth Nr=40 must exceed sun teeth Ns=52"),
    ("mech.P2.Nr", 100.5, r"tooth count"),
    ("mech.C4.dynamic", 5000.0, r"dynamic capacity 5000 N\*m exceeds static capacity 2900 N\*m"),
    ("mech.C4", 5.0, r"mech.NAME.PARAM"),
    ("driveline.vehicle_mass", float("nan"), r"not a finite number"),
])
def test_bad_overrides_are_refused_naming_the_key(key, value, words):
    with pytest.raises(ScenarioError, match=words) as err:
        load_scenario("ht740_improved", {key: value})
    message = str(err.value)
    assert message.startswith(f"--set {key}: error: "), message
    assert "m915" not in message and ".toml:" not in message  # not located in a file


def test_mechanism_parameters_change_the_matrices_and_the_result():
    base = load_scenario("ht740_improved", SHORT)
    heavy = load_scenario("ht740_improved", {**SHORT, "mech.L1.J": 2.5})
    tr_a, tr_b = base.powertrain.transmission, heavy.powertrain.transmission
    assert tr_b.inertia[tr_b.link_index["L1"]] == 2.5 and tr_a.inertia[tr_a.link_index["L1"]] == 0.25
    assert heavy.mechanism.link("L1").inertia == 2.5
    ratio = load_scenario("ht740_improved", {**SHORT, "mech.P3.Nr": 80})
    assert ratio.mechanism.planetaries[2].n_ring == 80
    a, b = _final(base), _final(ratio)
    assert abs(a - b) > 1e-3 * abs(a)   # another first-gear ratio, another output speed
    same = load_scenario("ht740_improved", {**SHORT, "mech.C4.static": 2900.0}).run()
    _same(base.run(), same)


# -------------------------------------------------------------------------------- files


@pytest.mark.parametrize("name", ["ht740_improved", "ht740_turbo_iterative"])
def test_scenario_files_hold_every_file_read(name):
    files = scenario_files(name)
    names = {Path(k).name for k in files}
    assert {f"{name}.toml", "m915_driveline.toml"} <= names
    assert any(k.endswith(".mech") for k in files)
    if "turbo" in name:
        assert {"we_compressor.toml", "we_turbine.toml", "ht740_turbo.toml"} <= names
    assert all(Path(k).is_absolute() for k in files)


def test_load_from_files_equals_load_from_disk_and_uses_the_texts(tmp_path):
    overrides = {**SHORT, "driveline.vehicle_mass": 25000.0}
    files = scenario_files("ht740_improved", overrides)
    a = load_scenario("ht740_improved", overrides).run()
    b = load_scenario("ht740_improved", overrides, files=files).run()
    _same(a, b)
    # the texts are used, not the disk: a changed text changes the scenario
    driveline = next(k for k in files if k.endswith("m915_driveline.toml"))
    changed = dict(files)
    changed[driveline] = files[driveline].replace("final_drive = 5.57", "final_drive = 4.0")
    s = load_scenario("ht740_improved", SHORT, files=changed)
    assert s.data["driveline"]["final_drive"] == 4.0
    mech = next(k for k in files if k.endswith(".mech"))
    changed[mech] = files[mech].replace("J=0.25", "J=0.5", 1)
    assert load_scenario("ht740_improved", SHORT, files=changed).mechanism.link("L1").inertia == 0.5


def test_a_scenario_loads_from_texts_alone(tmp_path):
    """A scenario whose files exist nowhere on the disk (a sweep worker on another machine)."""
    folder = tmp_path / "nowhere"
    files = {str((folder / "s.toml").resolve()): 'mechanism = "m.mech"\ninclude = ["inc.toml"]\n'
                                                 '[simulation]\nt_end = 1.0\n[input]\ntorque = 10.0\n',
             str((folder / "inc.toml").resolve()): '[initial]\nlocked = ["C"]\nspeeds = { A = 1.0 }\n',
             str((folder / "m.mech").resolve()): "link A J=1\nlink B J=2\nclutch C A B static=100 dynamic=80\n"
                                                  "input A\noutput B\n"}
    s = load_scenario(folder / "s.toml", {"input.torque": 20.0}, files=files)
    assert s.mechanism.link("B").inertia == 2.0
    result = s.run()
    assert result.success
    assert result["w_B"][-1] == pytest.approx(1.0 + 20.0 / 3.0, rel=1e-6)


# --------------------------------------------------------------------------------- keys


def test_scenario_keys_list_values_known_keys_and_mechanism_parameters():
    keys = scenario_keys("ht740_improved")
    assert keys["driveline.vehicle_mass"] == 36000.0
    assert keys["input.throttle_signal"] == 0.72
    assert keys["elements.C4.apply"]["type"] == "table"
    assert keys["mech.L1.J"] == 0.25 and keys["mech.P2.Nr"] == 136 and keys["mech.C4.static"] == 2900.0
    assert "auto_shift.upshift_rpm" in keys and keys["auto_shift.upshift_rpm"] is None
    assert "shifts.template.ramp_time" in keys
    assert "include" not in keys
    turbo = scenario_keys("ht740_turbo")
    for key in ("input.engine.V_im", "input.engine.V_d", "input.shaft.inertia", "input.shaft.c1",
                "input.ports.turbine_inlet", "input.compressor_map", "input.turbine_map"):
        assert key in turbo
    current = {k: v for k, v in keys.items() if v is not None}
    assert load_scenario("ht740_improved", current).data == load_scenario("ht740_improved").data
