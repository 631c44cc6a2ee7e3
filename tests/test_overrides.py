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
from transgen.sim.scenario.load import bundled_scenarios

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


def test_an_entry_of_a_list_is_a_key():
    s = load_scenario("ht740_improved", {"elements.C4.apply.t.2": 5.5, "input.torque_table.2.3": 1650})
    assert s.data["elements"]["C4"]["apply"]["t"] == [0.0, 4.0, 5.5, 9.0, 9.02, 9.508]
    assert s.data["input"]["torque_table"][2][3] == 1650
    with pytest.raises(ScenarioError, match=r"^--set elements.C4.apply.t.9: error: 'elements.C4.apply.t' is a list of "
                                            r"6 entries: give an index 0..5"):
        load_scenario("ht740_improved", {"elements.C4.apply.t.9": 1.0})
    with pytest.raises(ScenarioError, match=r"^--set elements.C4.apply.t.2: error: table times 't' must not decrease"):
        load_scenario("ht740_improved", {"elements.C4.apply.t.2": 3.0})


def test_a_key_absent_from_the_file_but_known_is_set():
    s = load_scenario("ht740_improved", {"driveline.grade_percent": 2.0})
    assert s.data["driveline"]["grade_percent"] == 2.0
    # a table the file lacks: its other required keys are asked for, naming the override
    with pytest.raises(ScenarioError, match=r"^--set auto_shift.upshift_rpm: error: .*order"):
        load_scenario("ht740_improved", {"auto_shift.upshift_rpm": [[1500]]})
    # a shift template without shift events would change nothing: refused
    with pytest.raises(ScenarioError, match=r"^--set shifts.template.ramp_time: error: a shift template shapes the "
                                            r"shift events"):
        load_scenario("ht740_improved", {"shifts.template.ramp_time": 0.4})


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


def test_an_error_about_a_file_value_beside_an_override_names_the_override():
    with pytest.raises(ScenarioError, match=r"ht740_improved.toml:\d+:\d+: error: unknown key 't' for a ramp signal"
                                            r".*\(with --set elements.C4.apply.type\)"):
        load_scenario("ht740_improved", {"elements.C4.apply.type": "ramp"})
    with pytest.raises(ScenarioError, match=r"^--set elements.C4.apply: error: ramp needs t1 > t0"):  # all of it from --set
        load_scenario("ht740_improved", {"elements.C4.apply": {"type": "ramp", "t0": 4.0, "t1": 5.0, "v0": 0, "v1": 1}}
                      | {"elements.C4.apply.t1": 3.0})


def test_mechanism_parameters_change_the_matrices_and_the_result():
    base = load_scenario("ht740_improved", SHORT)
    heavy = load_scenario("ht740_improved", {**SHORT, "mech.L1.J": 2.5})
    tr_a, tr_b = base.powertrain.transmission, heavy.powertrain.transmission
    assert tr_b.inertia[tr_b.link_index["L1"]] == 2.5 and tr_a.inertia[tr_a.link_index["L1"]] == 0.25
    assert heavy.mechanism.link("L1").inertia == 2.5
    ratio = load_scenario("ht740_improved", {**SHORT, "mech.P3.Nr": 80})
    assert ratio.mechanism.planetaries[2].n_ring == 80
    from transgen.statespace import state_space

    for changed in (heavy, ratio):   # the mode matrices follow the parameter
        m_a, m_b = (state_space(s.mechanism, coordinates=["L1", "L6"]).mode("M1") for s in (base, changed))
        assert m_a.B.shape == m_b.B.shape and not np.allclose(m_a.B, m_b.B)
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
    assert keys["input.throttle_signal"] == {"type": "table", "t": [0.0, 5.5, 7.0], "value": [0.61, 0.61, 0.83]}
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


# --------------------------------------------------------------------------- turbodiesel

TURBO_SHORT = {"simulation.t_end": 1.5}


def test_turbodiesel_defaults_written_out_give_the_same_run_number_for_number():
    keys = scenario_keys("ht740_turbo_iterative")
    explicit = {k: v for k, v in keys.items()
                if k.startswith(("input.engine.", "input.shaft.", "input.ports.", "input.air.", "input.exhaust.",
                                 "input.turbo_solver."))}
    assert len(explicit) > 40 and keys["input.shaft.inertia"] == 2.0e-4 and keys["input.engine.V_im"] == 0.022
    a = load_scenario("ht740_turbo_iterative", TURBO_SHORT).run()
    b = load_scenario("ht740_turbo_iterative", {**TURBO_SHORT, **explicit}).run()
    _same(a, b)
    current = {k: v for k, v in scenario_keys("ht740_turbo").items() if v is not None}
    _same(load_scenario("ht740_turbo", TURBO_SHORT).run(), load_scenario("ht740_turbo", {**current, **TURBO_SHORT}).run())


@pytest.mark.filterwarnings("ignore:.*operating point outside the data")  # low ambient pressure
@pytest.mark.parametrize("key, value", [("input.engine.V_im", 0.044), ("input.shaft.inertia", 4e-4),
                                        ("input.shaft.c1", 1e-4), ("input.engine.p_amb", 90000.0),
                                        ("input.ports.turbine_inlet", 0.003), ("input.air.cp", 1005.0),
                                        ("input.exhaust.R", 290.0), ("input.turbo_solver.xtol", 1e-6)])
def test_turbodiesel_parameters_change_the_turbocharger(key, value):
    a = load_scenario("ht740_turbo_iterative", TURBO_SHORT).run()
    b = load_scenario("ht740_turbo_iterative", {**TURBO_SHORT, key: value}).run()
    assert a.success and b.success
    assert not np.array_equal(a["omega_tc"], b["omega_tc"]) or not np.array_equal(a["p_im"], b["p_im"])
    engine = load_scenario("ht740_turbo_iterative", {key: value}).powertrain.components[0].engine
    table, name = key.split(".")[1:]
    obj = {"engine": engine.params, "shaft": engine.turbo.shaft, "ports": getattr(engine.turbo, "ports", None),
           "air": engine.turbo.compressor.gas, "exhaust": engine.turbo.turbine.gas, "turbo_solver": engine.turbo}[table]
    assert getattr(obj, name) == value


def test_turbodiesel_map_files_are_read_relative_to_the_file_and_from_files(tmp_path):
    from transgen.sim.engine import DATA_DIR

    (tmp_path / "maps").mkdir()
    comp = (DATA_DIR / "we_compressor.toml").read_text(encoding="utf-8")
    (tmp_path / "maps" / "c.toml").write_text(comp, encoding="utf-8")
    turbo = bundled_scenarios()["ht740_turbo"]
    scenario = tmp_path / "s.toml"
    scenario.write_text(f'include = ["{turbo.as_posix()}"]\n[input]\ncompressor_map = "maps/c.toml"\n'
                        '[simulation]\nt_end = 1.5\n', encoding="utf-8")
    a, b = load_scenario(scenario).run(), load_scenario("ht740_turbo", TURBO_SHORT).run()
    _same(a, b)  # the same map from another file
    files = scenario_files(scenario)
    assert str((tmp_path / "maps" / "c.toml").resolve()) in files
    scenario.write_text(scenario.read_text().replace("compressor_map", "turbine_map"), encoding="utf-8")
    with pytest.raises(ScenarioError, match=r"s.toml:3:1: error: bad turbine_map: .* is a compressor map"):
        load_scenario(scenario)


@pytest.mark.parametrize("key, value, words", [
    ("input.engine.V_imm", 1.0, r"unknown key 'V_imm' in \[input.engine\]; did you mean 'input.engine.V_im'"),
    ("input.engine.V_im", 0.0, r"'V_im' must be positive"),
    ("input.engine.n_cyl", 6.5, r"'n_cyl' must be a whole number >= 1"),
    ("input.engine.c_vol", [1.0, 2.0], r"'c_vol' must have 3 entries"),
    ("input.engine.full_load_fuel", [1e-4, 2e-4], r"full_load_speed and full_load_fuel must have as many entries"),
    ("input.shaft.inertia", -1.0, r"'inertia' must be positive"),
    ("input.ports.turbine_inlet", 0.003, r"ports is used by the iterative turbo algorithm only"),
    ("input.turbo_solver.maxiter", 10, r"turbo_solver is used by the iterative turbo algorithm only"),
    ("input.air.cp", 280.0, r"air: cp \(280\) must exceed R \(287\)"),
    ("input.compressor_map", "no_such_map.toml", r"cannot read the map file"),
    ("input.turbine_map", "we_compressor", r"is a compressor map, not a turbine map"),  # the bundled map by name
])
def test_bad_turbodiesel_values_are_refused(key, value, words):
    with pytest.raises(ScenarioError, match=words) as err:
        load_scenario("ht740_turbo", {key: value})
    assert str(err.value).startswith(f"--set {key}: error: ")


# ------------------------------------------------------------------------ command line


def _transgen(tmp_path, *argv):
    """``python -m transgen ARGV`` in ``tmp_path`` (not the checkout): (exit code, stdout, stderr)."""
    run = subprocess.run([sys.executable, "-m", "transgen", *argv], capture_output=True, text=True, timeout=300,
                         env=dict(os.environ, MPLBACKEND="Agg"), cwd=tmp_path)
    return run.returncode, run.stdout, run.stderr


def test_simulate_set_changes_the_run_and_bad_keys_exit_2_before_it(tmp_path):
    code, out, err = _transgen(tmp_path, "simulate", "ht740_improved", "--set", "simulation.t_end=1.0",
                               "--set", "driveline.vehicle_mass=20000", "--json", "-o", "r.csv")
    assert code == 0, err
    assert json.loads(out)["success"] is True
    header, *rows = (tmp_path / "r.csv").read_text().splitlines()
    assert float(rows[-1].split(",")[0]) == pytest.approx(1.0)
    for argv, words in [(["--set", "driveline.vehicle_mas=1"], "did you mean 'driveline.vehicle_mass'?"),
                        (["--set", "vehicle_mass=1"], "did you mean 'driveline.vehicle_mass'?"),
                        (["--set", "driveline.vehicle_mass=heavy"], "must be a finite number"),
                        (["--set", "driveline.vehicle_mass"], "expected KEY=VALUE"),
                        (["--set", "mech.P2.Nr=10"], "must exceed sun teeth"),
                        (["--set", "simulation.rtol=nan"], "not a finite number")]:
        code, out, err = _transgen(tmp_path, "simulate", "ht740_improved", "-o", "bad.csv", *argv)
        key = argv[1].split("=")[0]
        assert code == 2, (argv, err)
        assert err.startswith(f"--set {key}: error: ") and words in err and "Traceback" not in err, err
        assert not (tmp_path / "bad.csv").exists() and out == ""


def test_scenario_keys_command_lists_keys_and_values(tmp_path):
    code, out, err = _transgen(tmp_path, "scenario", "keys", "ht740_improved", "--set", "driveline.grade_percent=1.5")
    assert code == 0, err
    lines = dict(line.split(" = ", 1) for line in out.splitlines())
    assert {k.strip(): v for k, v in lines.items()}["driveline.vehicle_mass"] == "36000.0"
    assert {k.strip(): v for k, v in lines.items()}["driveline.grade_percent"] == "1.5"
    assert {k.strip(): v for k, v in lines.items()}["auto_shift.upshift_rpm"] == "(default)"
    code, out, err = _transgen(tmp_path, "scenario", "keys", "ht740_improved", "--json")
    assert code == 0, err
    keys = json.loads(out)["keys"]
    assert keys == json.loads(json.dumps(scenario_keys("ht740_improved")))
    for key, text in [(k.strip(), v) for k, v in lines.items()]:   # every value reads back as --set reads it
        if text != "(default)":
            assert parse_override(f"{key}={text}")[1] == (1.5 if key == "driveline.grade_percent" else keys[key]), key
    code, _, err = _transgen(tmp_path, "scenario", "keys", "ht740_improvd")
    assert code == 2 and "did you mean 'ht740_improved'" in err


def test_scenario_copy_writes_the_includes_and_the_copy_runs_from_its_folder(tmp_path):
    code, out, err = _transgen(tmp_path, "scenario", "copy", "ht740_improved", "mine")
    assert code == 0, err
    written = sorted(p.relative_to(tmp_path / "mine").as_posix() for p in (tmp_path / "mine").rglob("*.toml"))
    assert written == ["ht740_improved.toml", "shared/m915_driveline.toml", "shared/m915_truck.toml"]
    copy = tmp_path / "mine" / "ht740_improved.toml"
    assert copy.read_text() == bundled_scenarios()["ht740_improved"].read_text()
    a = load_scenario(copy, SHORT)
    assert all(str(tmp_path) in k or k.endswith((".mech", "torque_converter_heavy_truck.toml"))
               for k in scenario_files(copy))   # the includes are the copies
    _same(a.run(), load_scenario("ht740_improved", SHORT).run())
    # run from the copy's folder, by its relative name
    code, out, err = _transgen(tmp_path / "mine", "simulate", "ht740_improved.toml", "--set", "simulation.t_end=0.5",
                               "--quiet")
    assert code == 0, err
    # existing files are kept, all of them: nothing is written
    (tmp_path / "mine" / "shared" / "m915_truck.toml").write_text("# edited\n")
    code, out, err = _transgen(tmp_path, "scenario", "copy", "ht740_improved", "mine")
    assert code == 2 and "m915_truck.toml" in err and "--force" in err
    assert (tmp_path / "mine" / "shared" / "m915_truck.toml").read_text() == "# edited\n"
    code, out, err = _transgen(tmp_path, "scenario", "copy", "ht740_improved", "mine", "--force")
    assert code == 0, err
    assert "m915_truck.toml" in out
    assert (tmp_path / "mine" / "shared" / "m915_truck.toml").read_text().startswith("# M915")


def test_scenario_copy_writes_all_files_or_none(tmp_path, monkeypatch):
    from transgen.sim.scenario.copy import copy_scenario

    calls = []
    import transgen.export as export

    real = export.write_text

    def failing(path, text):
        calls.append(path)
        if len(calls) == 2:
            raise OSError("disk full")
        real(path, text)

    monkeypatch.setattr(export, "write_text", failing)
    with pytest.raises(OSError):
        copy_scenario("ht740_turbo_iterative", tmp_path / "out")
    assert not [p for p in (tmp_path / "out").rglob("*") if p.is_file()]
    monkeypatch.setattr(export, "write_text", real)
    written = copy_scenario("ht740_turbo_iterative", tmp_path / "out")
    assert sorted(p.name for p in written) == ["ht740_turbo.toml", "ht740_turbo_iterative.toml", "m915_driveline.toml"]


def test_gear_pair_radii_and_one_way_direction_are_parameters():
    base = load_scenario("oneway_overrun")
    bigger = load_scenario("oneway_overrun", {"mech.Gi1.r2": 0.09})
    assert bigger.mechanism.gear_pairs[0].n2 == 0.09 and base.mechanism.gear_pairs[0].n2 == 0.08
    a, b = base.run(), bigger.run()
    assert a.success and b.success
    assert abs(a["w_Lo"][-1] - b["w_Lo"][-1]) > 1e-3 * abs(a["w_Lo"][-1])   # another first-gear ratio
    turned = load_scenario("oneway_overrun", {"mech.F1.free": "negative"})
    assert turned.mechanism.element("F1").free == "negative"
    with pytest.raises(ScenarioError, match=r"--set mech.Gi1.N1: error: gears Gi1 has no parameter 'N1'"):
        load_scenario("oneway_overrun", {"mech.Gi1.N1": 20})
    with pytest.raises(ScenarioError, match=r"free must be one of positive, negative"):
        load_scenario("oneway_overrun", {"mech.F1.free": "both"})


def test_a_worker_elsewhere_loads_the_scenario_by_its_key(tmp_path, monkeypatch):
    from transgen.sim.scenario.load import scenario_path

    key = str(scenario_path("ht740_improved").resolve())
    files = scenario_files("ht740_improved", SHORT)
    assert key in files
    monkeypatch.chdir(tmp_path)
    _same(load_scenario(key, SHORT, files=files).run(), load_scenario("ht740_improved", SHORT).run())
