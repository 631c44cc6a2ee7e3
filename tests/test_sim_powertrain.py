"""Turbocharged powertrain: converter component, lock-up through the mechanism clutch, the
turbodiesel source, the causality check of a scenario, the maps command and the turbo report.

The full 20 s runs of ht740_turbo / ht740_turbo_iterative are in benchmarks/bench_powertrain.py;
here the turbo scenario runs shortened (3 s)."""
import dataclasses
import json
import math
import warnings
from pathlib import Path

import numpy as np
import pytest

from transgen.errors import ScenarioError
from transgen.sim.model.assembly import causal_assembly, check_powertrain
from transgen.sim.core.causality import AlgebraicLoopError, Causality
from transgen.sim.engine import RPM
from transgen.sim.engine.torque_converter import TorqueConverter
from transgen.sim.engine.turbo_report import turbo_report
from transgen.sim.model.powertrain import ConverterComponent
from transgen.sim.model.turbodiesel import TurbodieselSource
from transgen.sim.scenario.load import bundled_scenarios, load_scenario

SCENARIOS = Path(__file__).resolve().parent.parent / "sim" / "scenarios"
TURBO = SCENARIOS / "ht740_turbo.toml"


@pytest.fixture(autouse=True)
def _quiet_maps():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        yield


def _short(name: str, t_end: float = 3.0):
    sc = load_scenario(name)
    sc.options = dataclasses.replace(sc.options, t_end=t_end)
    return sc, sc.run()


@pytest.fixture(scope="module")
def turbo_runs():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return {kind: _short(name) for kind, name in (("basic", "ht740_turbo"),
                                                      ("iterative", "ht740_turbo_iterative"))}


# ----------------------------------------------------------------------------- converter


def test_converter_component_torques_and_dissipation_are_consistent():
    tc = TorqueConverter.load()
    comp = ConverterComponent(tc, pump=0, turbine=1, pump_torque="Tp", turbine_torque="Tt")
    speeds = np.linspace(-250.0, 250.0, 41)
    for wp in speeds:
        for wt in speeds:
            w = np.array([wp, wt])
            tp, tt = tc.torques(wp, wt)
            assert comp.torques(0.0, (), w) == {"Tp": -tp, "Tt": tt}
            d = comp.dissipation(0.0, (), w)
            assert d >= -1e-9 * (1 + abs(tp * wp)), (wp, wt, d)
            assert d == pytest.approx(tp * wp - tt * wt)
    sig = comp.signals(0.0, (), np.array([150.0, 75.0]))
    assert sig["converter_speed_ratio"] == pytest.approx(0.5)
    assert sig["converter_torque_ratio"] == pytest.approx(tc.torque_ratio_at(0.5))
    assert sig["T_pump"] > 0 and sig["T_turbine"] > sig["T_pump"]
    assert comp.torques(0.0, (), np.array([150.0, 150.0])) == {"Tp": 0.0, "Tt": 0.0}   # locked: no torque


_LOCKUP = """
mechanism = "ht740_tc"
[simulation]
t_end = {t_end}
method = "LSODA"
rtol = 1e-7
atol = 1e-7
output_dt = 0.005
[initial]
locked = ["C1", "C5"]
speeds_rpm = {{ E = 1500.0, L1 = 600.0 }}
[input]
type = "torque"
torque = 900.0
[converter]
pump = "E"
turbine = "L1"
pump_torque = "Tp"
turbine_torque = "Tt"
[elements.C1]
apply = 1.0
[elements.C5]
apply = 1.0
[elements.LU]
apply = {{ type = "ramp", t0 = 0.2, t1 = 0.5, v0 = 0.0, v1 = {lu} }}
[driveline]
output_inertia = 0.5
stiffness = 20000.0
damping = 300.0
final_drive = 5.57
wheel_radius = 0.52
vehicle_mass = 36000.0
rolling_resistance = 0.008
"""


def _lockup_run(tmp_path, lu: float, t_end: float = 1.5):
    path = tmp_path / f"lockup_{lu}.toml"
    path.write_text(_LOCKUP.format(t_end=t_end, lu=lu), encoding="utf-8")
    return load_scenario(path).run()


def test_lockup_clutch_locks_at_zero_slip_like_every_element(tmp_path):
    r = _lockup_run(tmp_path, 1.0)
    assert r.success, r.message
    locks = [e for e in r.events if e.kind == "lock" and e.elements == ("LU",)]
    assert len(locks) == 1, r.events
    t_lock = locks[0].t
    assert 0.2 < t_lock < 1.0 and locks[0].source == "1" and locks[0].target == "1L"
    t, w_e, w_l1 = r.time, r["w_E"], r["w_L1"]
    before = t < t_lock - 1e-9
    after = t > t_lock + 1e-9
    assert np.all(w_e[before] > w_l1[before])                           # slipping, pump ahead
    assert np.allclose(w_e[after], w_l1[after], rtol=0, atol=1e-9)      # locked together
    # speeds of E and L1 continuous at the lock (both samples at t_lock agree)
    at = np.flatnonzero(np.abs(t - t_lock) < 1e-12)
    assert len(at) == 2
    assert abs(w_e[at[0]] - w_e[at[1]]) < 1e-6 and abs(w_l1[at[0]] - w_l1[at[1]]) < 1e-6
    assert abs(w_e[at[0]] - w_l1[at[0]]) < 1e-3
    # locked: the converter carries nothing, LU carries the torque within its capacity
    assert np.all(np.abs(r["T_pump"][after]) < 1e-6)
    assert np.all(np.abs(r["t_LU"][after]) <= 2300.0)
    assert np.all(r["P_converter"] >= -1e-6)
    assert r.energy["relative_residual"] < 1e-5


def test_lockup_without_enough_capacity_keeps_slipping(tmp_path):
    """A weakly applied LU (7 % of 1955 N*m dynamic) cannot pull the pump down to the turbine
    speed against 900 N*m: no lock event, the converter keeps driving."""
    r = _lockup_run(tmp_path, 0.07, t_end=1.0)
    assert r.success, r.message
    assert not any("LU" in e.elements for e in r.events)
    assert np.all(r["slip_LU"][r.time > 0.01] > 0)


# ----------------------------------------------------------------------------- turbo scenario


def test_turbo_scenarios_are_bundled_and_differ_only_in_the_algorithm():
    names = bundled_scenarios()
    assert {"ht740_turbo", "ht740_turbo_iterative"} <= set(names)
    a, b = load_scenario("ht740_turbo"), load_scenario("ht740_turbo_iterative")
    ea, eb = (next(c for c in s.powertrain.components if isinstance(c, TurbodieselSource)) for s in (a, b))
    assert (ea.engine.turbo.kind, eb.engine.turbo.kind) == ("basic", "iterative")
    assert {k: v for k, v in a.data.items() if k not in ("title", "input")} == \
        {k: v for k, v in b.data.items() if k not in ("title", "input")}
    assert {k: v for k, v in a.data["input"].items() if k != "turbo"} == \
        {k: v for k, v in b.data["input"].items() if k != "turbo"}
    assert a.options.method in ("BDF", "LSODA") and a.options.output_dt == 0.01


def test_turbo_scenario_runs_short_without_nan(turbo_runs):
    for kind, (sc, r) in turbo_runs.items():
        assert r.success, (kind, r.message)
        for name in ("w_E", "omega_tc", "p_im", "p_em", "chi", "m_dot_c", "T_in", "T_pump", "dT_c", "dT_t"):
            assert np.all(np.isfinite(r[name])), (kind, name)
        rpm = r["w_E"] / RPM
        assert rpm[0] == pytest.approx(800.0)
        assert rpm[-1] > 1700.0                              # accelerating towards ~2000 rpm
        assert r["boost_pressure_ratio"][-1] > 1.8 > 1.1 > r["boost_pressure_ratio"][0]
        assert r.energy["relative_residual"] < 1e-4, (kind, r.energy)
        assert r.energy["dissipated"] > 0 and r.energy["work_in"] > r.energy["dissipated"]
        assert np.all(r["P_converter"] >= -1e-6)


def test_turbo_report_and_comparison(turbo_runs, capsys):
    (_, a), (_, b) = turbo_runs["basic"], turbo_runs["iterative"]
    rep = turbo_report(a, b)
    with capsys.disabled():
        print("\n" + rep.text())
    assert rep.fuel_step == pytest.approx(0.5)
    assert rep.time_to_90_boost is not None and 0.5 < rep.time_to_90_boost < rep.window_end
    assert 50.0 < rep.peak_turbo_speed_krpm < 150.0
    assert 0.0 <= rep.chi_min < rep.chi_max <= 1.2
    c = rep.comparison
    assert c["bins"] and c["second_lower"] in (True, False)
    assert c["high"]["d_turbo_krpm"] < 0                  # iterative: lower turbo speed at high flow
    json.dumps(rep.to_dict())
    with pytest.raises(ValueError, match="omega_tc"):
        turbo_report(_lockup_like_result(a))


def test_algorithm_difference_on_the_same_states_reproduces_the_thesis(turbo_runs):
    """Thesis 4.6: the iterative algorithm gives a lower chi (more corrected flow at a given turbo
    speed); virtually the same at low flow, larger differences at high flow. Evaluated on the
    same states, without the engine's feedback."""
    sc, a = turbo_runs["basic"]
    engine = next(c.engine for c in sc.powertrain.components if isinstance(c, TurbodieselSource))
    rep = turbo_report(a, engine=engine, bins=4)
    d = rep.decoupled
    assert d["points"] > 100 and d["skipped"] == 0
    assert d["chi_lower"] and d["grows_with_flow"]
    lo, hi = d["bins"][0], d["bins"][-1]
    assert abs(lo["d_chi"]) < 0.002 and hi["d_chi"] < -0.003
    assert 0.0 <= lo["d_flow_c_percent"] < hi["d_flow_c_percent"]      # more compressor flow
    assert all(b["mach_c_out"] < b["mach_c_in"] for b in d["bins"])
    assert "decoupled" in rep.text() and json.dumps(rep.to_dict())


def test_chi_shift_follows_the_port_mach_numbers():
    """The iterative chi shift has the sign of M_out^2 - M_in^2 (total vs static pressure ratio):
    equal ducts give a lower chi at every pressure ratio; an outlet duct much smaller than the
    inlet a higher chi at low pressure ratio."""
    from transgen.sim.engine.turbocharger import BasicTurbo, IterativeTurbo, PortAreas

    basic = BasicTurbo()
    omega = 60e3 * RPM
    for p_out in (1.15e5, 1.3e5):
        a = basic.compressor.operate(1e5, 298.0, p_out, omega)
        for d_out, sign in ((0.100, -1), (0.060, +1)):
            ports = dataclasses.replace(PortAreas(), compressor_outlet=math.pi / 4 * d_out ** 2)
            b, (m_in, m_out) = IterativeTurbo(ports=ports)._solve("compressor", basic.compressor, 1e5, 298.0, p_out, omega,
                                                                  ports.compressor_inlet, ports.compressor_outlet)
            assert np.sign(m_out - m_in) == sign and np.sign(b.chi - a.chi) == sign, (p_out, d_out)


def _lockup_like_result(r):
    return dataclasses.replace(r, signals={k: v for k, v in r.signals.items() if k != "omega_tc"})


def test_non_finite_engine_state_stops_the_run_naming_it():
    sc = load_scenario(TURBO)
    sc.options = dataclasses.replace(sc.options, t_end=1.0)
    src = next(c for c in sc.powertrain.components if isinstance(c, TurbodieselSource))
    rack = src.engine.rack
    src.engine.rack = lambda t: math.nan if t > 0.3 else rack(t)
    r = sc.run()
    assert not r.success
    assert "engine" in r.message and "non-finite" in r.message
    assert "t = 0.3" in r.message and "p_im" in r.message and "omega_tc" in r.message


# ----------------------------------------------------------------------------- causality


def test_assembly_of_the_turbo_scenario_is_causal():
    sc = load_scenario(TURBO)
    asm = check_powertrain(sc.powertrain)
    kinds = {b.name: dict(b.ports) for b in asm.blocks}
    assert kinds["engine"]["crank"] is Causality.RESISTIVE
    assert kinds["link E"]["shaft"] is Causality.INERTIAL
    assert kinds["converter"] == {"pump": Causality.RESISTIVE, "turbine": Causality.RESISTIVE}
    assert kinds["intake_manifold"]["port_a"] is Causality.CONTROL_VOLUME
    assert kinds["compressor"]["inlet"] is Causality.FLOW
    assert kinds["driveshaft"]["a"] is Causality.COMPLIANT and kinds["vehicle"]["shaft"] is Causality.INERTIAL
    joints = set(asm.joints)
    assert ("engine.crank", "link E") in joints
    assert ("converter.pump", "link E") in joints and ("converter.turbine", "link L1") in joints
    assert ("driveshaft.a", "link L6") in joints


def test_every_bundled_scenario_passes_the_causality_check():
    for name in bundled_scenarios():
        check_powertrain(load_scenario(name).powertrain)


def test_inertial_engine_on_the_inertial_input_link_is_refused(tmp_path):
    path = tmp_path / "inertial_crank.toml"
    path.write_text(f'include = ["{TURBO.as_posix()}"]\n\n[input]\ncrank_model = "inertial"\n', encoding="utf-8")
    with pytest.raises(ScenarioError) as err:
        load_scenario(path)
    msg = str(err.value)
    assert f"{path}:4:1: error:" in msg                      # located at the crank_model line
    assert "algebraic loop between 'engine'" in msg and "'link E'" in msg
    assert "refused before the run" in msg and 'crank_model = "torque"' in msg
    # the same assembly checked directly names both blocks
    sc = load_scenario(TURBO)
    src = next(c for c in sc.powertrain.components if isinstance(c, TurbodieselSource))
    src.crank_model = "inertial"
    with pytest.raises(AlgebraicLoopError) as err2:
        check_powertrain(sc.powertrain)
    assert err2.value.pairs == [("engine", "link E")]
    assert causal_assembly(sc.powertrain).origin["engine"] == ("input", "crank_model")


@pytest.mark.parametrize("extra, words", [
    ('[converter]\npump = "X"\n', "pump link 'X' is not a link"),
    ('[converter]\npump_torque = "Tt"\n', "acts on link L1, not on the pump link E"),
    ('[converter]\nturbine_torque = "Tq"\n', "not a 'torque NAME LINK'"),
    ('[converter]\nfile = "missing.toml"\n', "cannot load the torque converter"),
    ('[input]\nturbo = "fancy"\n', "turbo must be 'basic' or 'iterative'"),
    ('[input]\ncrank_model = "rigid"\n', "crank_model must be"),
    ('[input]\ngovernor = { idle = 600 }\n', r"unknown key 'idle' in \[input.governor\]; did you mean 'idle_rpm'"),
])
def test_scenario_errors_of_the_turbo_keys_are_located(tmp_path, extra, words):
    path = tmp_path / "bad.toml"
    path.write_text(f'include = ["{TURBO.as_posix()}"]\n\n' + extra, encoding="utf-8")
    with pytest.raises(ScenarioError, match=words) as err:
        load_scenario(path)
    assert f"{path}:" in str(err.value)


# ----------------------------------------------------------------------------- maps command


def test_maps_command_json_in_process(capsys):
    from transgen.cli import main

    assert main(["maps", "we_compressor", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["kind"] == "compressor" and len(out["speed_lines"]) >= 5
    assert out["table"]["chi"]["range"] == [0.0, 1.0] and out["table"]["chi"]["points"] >= 11
    assert all(a < b for a, b in zip(out["table"]["speed_rpm"], out["table"]["speed_rpm"][1:]))
    assert all(su > st for su, st in zip(out["table"]["pr_surge"], out["table"]["pr_stall"]))
    assert main(["maps", "we_turbine"]) == 0
    text = capsys.readouterr().out
    assert "turbine map" in text and "m_corr(N_corr, ER)" in text
    assert main(["maps", "no_such_map"]) == 2  # bad input
    assert "bundled: we_compressor, we_turbine" in capsys.readouterr().err


def test_maps_command_writes_the_plots(tmp_path, capsys):
    from transgen.cli import main

    assert main(["maps", "we_compressor", "--plot", str(tmp_path), "--json"]) == 0
    written = json.loads(capsys.readouterr().out)["written"]
    names = sorted(Path(p).name for p in written)
    assert names == ["fig4_04_compressor_map.png", "fig4_06_compressor_flow_table.png",
                     "fig4_07_compressor_efficiency_table.png"]
    for p in written:
        assert Path(p).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".")]      # no temporary leftovers


def test_turbo_comparison_plots(turbo_runs, tmp_path):
    from transgen.sim.engine.plots import THESIS_SIGNALS, plot_turbo_comparison

    runs = {"basic": turbo_runs["basic"][1], "iterative": turbo_runs["iterative"][1]}
    paths = plot_turbo_comparison(runs, tmp_path, formats=("svg",))
    assert {p.stem for p in paths} >= {stem for stem, *_ in THESIS_SIGNALS} | {"engine_overview"}
    assert all(p.stat().st_size > 1000 for p in paths)


@pytest.mark.parametrize("name", ["ht740_turbo", "ht740_turbo_iterative"])
def test_engine_sampled_over_times_is_its_signals_at_each_time_bit_for_bit(name):
    # TurbodieselSource.sample computes the named signals over all output times at once; they must
    # be those of signals() at each time, the same numbers (the iterative turbocharger's warm start
    # follows the evaluations: both engines see the same sequence)
    def component():
        return next(c for c in load_scenario(name).powertrain.components if isinstance(c, TurbodieselSource))

    a, b = component(), component()
    n = 400
    ts = np.linspace(0.0, 6.0, n)
    X = np.array([np.linspace(1.1e5, 2.6e5, n), np.linspace(1.2e5, 2.9e5, n), np.linspace(2e3, 9e3, n)])
    W = np.zeros((a.link + 1, n))
    W[a.link] = np.linspace(70.0, 230.0, n)
    _, signals, stored = a.sample(ts, X, W)
    rows = [b.signals(ts[k], X[:, k], W[:, k]) for k in range(n)]
    assert list(signals) == list(rows[0]) and not stored.any()
    for key, values in signals.items():
        assert values.tobytes() == np.array([r[key] for r in rows], dtype=float).tobytes(), key
    assert np.any(signals["mach_c_in"] != 0.0) == (name == "ht740_turbo_iterative")
