"""Drive cycles: the shipped traces match the regulations' figures, the WLTP tolerance rule, and
the driver following the first 120 s of the WLTC in the 8HP70 car inside the tolerance with its
shifts, energies and energy balance (the whole cycle: benchmarks/bench_cycle.py)."""
from __future__ import annotations

import json

import numpy as np
import pytest

from transgen import load_mechanism
from transgen.cli import main
from transgen.errors import ScenarioError
from transgen.sim.analysis.cycle_report import SHIFT_KINDS, cycle_report
from transgen.sim.control.cycles import SpeedTrace, band, bundled_cycles, load_trace, tracking
from transgen.sim.control.driver import Driver
from transgen.sim.engine.fuel import fuel_of
from transgen.sim.derive.launch import derive_launch
from transgen.sim.derive.maneuver import maneuver_scenario
from transgen.sim.analysis.report import energy_balance
from transgen.sim.scenario.load import parse_scenario


def test_bundled_traces_match_the_regulations():
    assert set(bundled_cycles()) >= {"wltc_class3b", "ftp75"}
    wltc = load_trace("wltc_class3b")
    assert len(wltc.times) == 1801 and wltc.duration == 1800.0
    assert sum(wltc.speeds) * 3.6 == pytest.approx(83758.6, abs=0.05)       # the GTR's checksum
    assert wltc.distance == pytest.approx(23266, rel=1e-3)                   # 23.27 km
    assert max(wltc.speeds) * 3.6 == pytest.approx(131.3)
    assert "GTR No. 15" in wltc.source
    ftp = load_trace("ftp75")
    assert ftp.duration == 1874.0 and ftp.distance / 1609.344 == pytest.approx(11.04, abs=0.01)   # 11.04 mi
    assert max(ftp.speeds) / 0.44704 == pytest.approx(56.7, abs=0.01)                              # mph
    # the hot start repeats the first 505 s of the UDDS
    assert np.allclose(ftp.speeds[1370:1875], ftp.speeds[1:506])


def test_bad_trace_files_are_located_errors(tmp_path):
    f = tmp_path / "t.csv"
    f.write_text("# a trace\ntime_s,speed_kmh\n0,0\n1,nan\n")
    with pytest.raises(ScenarioError, match=r"t.csv:4:3: error: 'nan' is not a finite speed"):
        load_trace(str(f))
    f.write_text("0,0\n0,5\n")
    with pytest.raises(ScenarioError, match=r":2:1: error: the times of a speed trace must increase"):
        load_trace(str(f))
    with pytest.raises(ScenarioError, match="no such speed trace"):
        load_trace("wltc_class9")


def test_tolerance_band_is_the_trace_shifted_one_second_and_two_kmh():
    trace = SpeedTrace("ramp", (0.0, 10.0, 20.0), (0.0, 10.0, 10.0))      # 1 m/s^2, then constant
    lo, hi = band(trace, np.array([5.0, 10.0, 15.0]))
    tol = 2 / 3.6
    assert lo == pytest.approx([4.0 - tol, 9.0 - tol, 10.0 - tol]) and hi == pytest.approx([6.0 + tol, 10 + tol, 10 + tol])
    t = np.linspace(0.0, 20.0, 201)
    late = trace.speed(t - 0.99)                         # a second late: inside
    assert tracking(trace, t, late).inside == 1.0
    off = trace.speed(t) + 2.1 / 3.6                     # 2.1 km/h too fast: outside where the speed is constant
    tk = tracking(trace, t, off)
    assert tk.violations >= 1 and tk.worst == pytest.approx(0.1, abs=1e-6) and tk.inside < 1.0
    assert tk.rms_error == pytest.approx(2.1)


@pytest.fixture(scope="module")
def wltc_start(tmp_path_factory):
    mech = load_mechanism("zf8hp70")
    text = maneuver_scenario(mech, "car", "cycle", "zf8hp70", derive_launch(mech, "car"))
    scenario = parse_scenario(text, tmp_path_factory.mktemp("cycle") / "cycle.toml", {"simulation.t_end": 120.0})
    result = scenario.run()
    driver = next(c for c in scenario.powertrain.controllers if isinstance(c, Driver))
    return scenario, result, driver


def test_the_driver_follows_the_wltc_start_inside_the_tolerance(wltc_start):
    scenario, result, driver = wltc_start
    assert result.success, result.message
    assert energy_balance(result)["passed"]
    c = cycle_report(result, driver.trace)
    assert c.tracking.inside == 1.0 and c.tracking.violations == 0 and c.tracking.rms_error < 1.0
    assert c.distance == pytest.approx(c.trace_distance, rel=0.02)
    # stop-and-go: up- and power-off downshifts, the brakes used, the vehicle held at the stops
    assert c.shifts["upshift power-on"] >= 3 and c.shifts["downshift power-off"] >= 3
    assert set(c.shifts) == set(SHIFT_KINDS) and c.shift_total == sum(c.shifts.values())
    e = c.energy
    assert e["brakes"] > 0 and e["clutches"] > 0 and e["converter"] > 0 and e["wheels_positive"] > e["road"] > 0
    assert all(e[k] >= 0 for k in e if k.startswith("element_"))
    assert e["engine"] > e["wheels_positive"] + e["clutches"]            # the losses come out of the engine's work
    stand = (result.time > 1.0) & (result.time < 10.4)   # the trace stands until 11 s (the driver sees 0.5 s ahead)
    assert np.max(result.signals["vehicle_speed"][stand]) < 0.1 / 3.6     # held by the brakes
    # the car class's fuel map: the Willans-line estimate over its torque map (transgen.sim.engine.fuel)
    fuel = fuel_of(scenario.powertrain)
    assert fuel is not None and fuel[1] == "Willans-line estimate"
    c = cycle_report(result, driver.trace, fuel=fuel)
    sig = result.signals
    engine = next(x for x in scenario.powertrain.components if getattr(x, "fuel", None) is not None).engine
    t0 = np.interp(sig["omega_engine"], engine.speeds, engine.torque[0])
    own = np.where(sig["throttle"] > 1e-9, np.maximum(sig["T_engine"] - t0, 0.0) * sig["omega_engine"], 0.0)
    assert c.fuel == pytest.approx(np.trapezoid(own, result.time) / (0.38 * 42.7e6), rel=1e-9)
    assert c.fuel_volume == pytest.approx(1000 * c.fuel / 745.0)
    assert 4.0 < c.fuel_per_100km < 20.0                               # a 1700 kg petrol car in town
    # brake efficiency of the engine over the run: below the Willans slope, above zero
    assert 0.05 < e["engine"] / (c.fuel * 42.7e6) < 0.38
    brake = result.signals["brake_torque"]
    assert np.all(brake >= 0) and np.all(result.signals["throttle"] <= 1.0)


def test_driver_keys_are_checked(tmp_path):
    mech = load_mechanism("zf8hp70")
    text = maneuver_scenario(mech, "car", "cycle", "zf8hp70", derive_launch(mech, "car"))
    with pytest.raises(ScenarioError, match="no such speed trace"):
        parse_scenario(text.replace('trace = "wltc_class3b"', 'trace = "nope.csv"'), tmp_path / "a.toml")
    with pytest.raises(ScenarioError, match=r"the \[driver\] commands input.throttle_signal"):
        parse_scenario(text.replace("[input]", "[input]\nthrottle_signal = 0.3", 1), tmp_path / "b.toml")
    with pytest.raises(ScenarioError, match="unknown key|not a key|kp_typo"):
        parse_scenario(text.replace('trace = "wltc_class3b"', 'trace = "wltc_class3b"\nkp_typo = 1'), tmp_path / "c.toml")


def test_cli_cycle_scenario_and_json_report(tmp_path, capsys):
    out = tmp_path / "ftp.toml"
    assert main(["scenario", "new", "zf8hp70", "--maneuver", "cycle", "--cycle", "ftp75", "-o", str(out)]) == 0
    capsys.readouterr()
    assert main(["simulate", str(out), "--set", "simulation.t_end=25", "--json", "--quiet"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["cycle"]["trace"] == "ftp75" and doc["cycle"]["tracking"]["inside"] == 1.0
    assert doc["units"]["fuel"] == "kg" and doc["units"]["fuel_per_100km"] == "L/100 km"
    assert doc["cycle"]["fuel"] > 0 and doc["cycle"]["fuel_source"] == "Willans-line estimate"
