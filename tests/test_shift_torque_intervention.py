"""Engine torque intervention in shift calibration (:mod:`transgen.sim.control.schedule`, the engines of
:mod:`transgen.sim.model.components`, ``[input] torque_request``, ``transgen optimize``): the factor
signal's shape, no intervention leaves a run bit for bit as it was, the engine torque is scaled
(limited to full load) and the torque hole of the torque phase shrinks, the optimizer tunes and
reports the parameters, the tuned file runs from another folder, bad values are refused at the door."""
from __future__ import annotations

import math
import os

import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

from transgen.errors import ScenarioError
from transgen.sim import load_scenario
from transgen.sim.scenario.load import parse_scenario
from transgen.sim.model.components import EngineMap
from transgen.sim.analysis.report import shift_report
from transgen.sim.control.schedule import ShiftEvent, ShiftTemplate, request_table, torque_request_signal

TRUCK = os.path.join(os.path.dirname(__file__), "..", "sim", "scenarios", "shared", "m915_truck.toml")

# the HT-740 truck's 1-2 upshift as a shift event (engine, converter, driveline), 1.5 s around it
EVENT = """
mechanism = "ht740"
include = ["{truck}"]
[simulation]
t_end = 5.6
method = "LSODA"
rtol = 1e-7
atol = 1e-7
output_dt = 0.005
[initial]
gear = "1"
speeds = {{ L1 = 0.0 }}
[shifts]
events = [{{ t = 4.0, from = "1", to = "2", template = {{ fill_time = 0.1, ramp_time = 0.4, offgoing_delay = 0.1, offgoing_level = 0.2, offgoing_ramp = 0.3{extra} }} }}]
"""


def _event(tmp_path, extra="", name="ev.toml"):
    path = tmp_path / name
    path.write_text(EVENT.format(truck=os.path.abspath(TRUCK).replace("\\", "/"), extra=extra))
    return path


# ------------------------------------------------------------------------------ the factor signal


def test_no_intervention_by_default():
    t = ShiftTemplate()
    assert not t.torque_intervention and t.torque_request(3.0) == []
    # a factor of 1, or a trapezoid of no length, asks for nothing
    assert not ShiftTemplate(torque_boost=1.0, boost_time=0.5).torque_intervention
    assert not ShiftTemplate(torque_cut=0.5, cut_time=0.0, torque_ramp=0.0).torque_intervention
    assert torque_request_signal([ShiftEvent(1.0, "1", "2")]) is None


def test_profile_corners_follow_the_template_phases():
    t = ShiftTemplate(fill_time=0.1, offgoing_delay=0.2, offgoing_ramp=0.3, torque_boost=1.3, boost_delay=0.05,
                      boost_time=0.2, torque_cut=0.6, cut_delay=0.1, cut_time=0.25, torque_ramp=0.04)
    corners = t.torque_request(10.0)

    def at(time):
        [f] = [f for tc, f in corners if abs(tc - time) < 1e-9]
        return f

    t_r = 10.0 + 0.1 + 0.2  # the offgoing release starts
    t_e = t_r + 0.3  # ... and ends
    a = t_r + 0.05
    assert at(a) == pytest.approx(1.0)
    assert at(a + 0.04) == pytest.approx(1.3)
    assert at(a + 0.24) == pytest.approx(1.3)
    assert at(a + 0.28) == pytest.approx(1.0)
    c = t_e + 0.1
    assert at(c + 0.04) == pytest.approx(0.6)
    assert at(c + 0.29) == pytest.approx(0.6)
    assert at(c + 0.33) == pytest.approx(1.0)
    sig = torque_request_signal([ShiftEvent(10.0, "1", "2", t)])
    assert sig.value(9.0) == 1.0 and sig.value(20.0) == 1.0
    assert sig.value(a + 0.14) == pytest.approx(1.3) and sig.value(c + 0.2) == pytest.approx(0.6)


@settings(max_examples=60, deadline=None)
@given(boost=st.floats(0.0, 3.0), cut=st.floats(0.0, 1.5), ramp=st.floats(0.005, 0.3),
       times=st.lists(st.floats(0.0, 0.6), min_size=4, max_size=4))
@example(boost=0.0, cut=0.90625, ramp=0.2, times=[0.6, 0.0, 0.0, 0.2])  # two corners 5e-16 s apart
def test_profile_is_continuous_bounded_and_ends_at_one(boost, cut, ramp, times):
    """Between the levels the factor moves no faster than the ramps allow (no step unless the ramp is
    0), stays >= 0 and within the levels asked for (overlapping changes add), and is 1 outside."""
    t = ShiftTemplate(torque_boost=boost, boost_delay=times[0], boost_time=times[1], torque_cut=cut,
                      cut_delay=times[2], cut_time=times[3], torque_ramp=ramp)
    pts = t.torque_request(2.0)
    if not t.torque_intervention:
        assert pts == []
        return
    ts, fs = np.array([p[0] for p in pts]), np.array([p[1] for p in pts])
    assert fs[0] == pytest.approx(1.0) and fs[-1] == pytest.approx(1.0)
    assert np.all(fs >= 0.0)
    assert np.all(fs <= 1.0 + max(0.0, boost - 1.0) + max(0.0, cut - 1.0) + 1e-12)
    assert np.all(fs >= max(0.0, 1.0 + min(0.0, boost - 1.0) + min(0.0, cut - 1.0)) - 1e-12)
    slope = np.abs(np.diff(fs)) / np.maximum(np.diff(ts), 1e-300)
    assert np.all(slope <= (abs(boost - 1.0) + abs(cut - 1.0)) / ramp * (1 + 1e-9) + 1e-9)


def test_overlapping_shift_profiles_multiply():
    a = [(1.0, 1.0), (1.1, 0.5), (1.3, 0.5), (1.4, 1.0)]
    b = [(1.2, 1.0), (1.25, 2.0), (1.5, 2.0), (1.6, 1.0)]
    table = request_table([a, b, []])
    assert table.value(1.27) == pytest.approx(0.5 * 2.0)
    assert table.value(0.0) == 1.0 and table.value(2.0) == 1.0
    assert request_table([[], []]) is None


@pytest.mark.parametrize("bad", [-0.1, math.nan, math.inf])
def test_template_refuses_negative_and_non_finite_values(bad):
    with pytest.raises(ValueError, match="torque_cut must be a finite number >= 0"):
        ShiftTemplate(torque_cut=bad)


def test_map_engine_request_scales_driving_torque_up_to_full_load():
    engine = EngineMap((0.0, 200.0), (0.0, 0.5, 1.0), ((-50.0, -80.0), (400.0, 600.0), (900.0, 1100.0)))
    w = 100.0
    part = engine(w, 0.5)  # 500
    assert engine.requested(part, w, 1.0) == part
    assert engine.requested(part, w, 0.6) == pytest.approx(0.6 * part)
    assert engine.requested(part, w, 1.5) == pytest.approx(1.5 * part)  # 750 < full load 1000
    assert engine.requested(part, w, 3.0) == pytest.approx(engine(w, 1.0))  # no more than full load
    assert engine.requested(engine(w, 0.0), w, 0.5) == engine(w, 0.0)  # motoring drag is left alone
    full = engine(w, 1.0)
    assert engine.requested(full, w, 1.2) == full


# ------------------------------------------------------------------------------------- in a run


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("torque")
    plain = load_scenario(_event(tmp, "", "plain.toml"))
    ones = load_scenario(_event(tmp, ", torque_boost = 1.0, boost_time = 0.3, torque_cut = 1.0, cut_time = 0.2",
                                "ones.toml"))
    boost = load_scenario(_event(tmp, ", torque_boost = 1.3, boost_time = 0.3", "boost.toml"))
    return {"plain": (plain, plain.run()), "ones": (ones, ones.run()), "boost": (boost, boost.run())}


def test_no_intervention_leaves_the_run_bit_for_bit(runs):
    (_, a), (_, b) = runs["plain"], runs["ones"]
    assert a.success and b.success
    assert np.array_equal(a.time, b.time)
    for name in ("T_out", "T_in", "T_engine", "omega_engine", "w_L1"):
        assert np.array_equal(a.signals[name], b.signals[name]), name
    assert "torque_request" not in a.signals and "torque_request" not in b.signals


def test_explicit_factor_one_leaves_ht740_bit_for_bit():
    a = load_scenario("ht740_original", {"simulation.t_end": 5.5}).run()
    b = load_scenario("ht740_original", {"simulation.t_end": 5.5, "input.torque_request": 1.0}).run()
    assert np.array_equal(a.time, b.time)
    assert np.array_equal(a.signals["T_out"], b.signals["T_out"])
    assert np.all(b.signals["torque_request"] == 1.0)


def test_torque_phase_increase_raises_engine_and_output_torque(runs):
    (scenario, base), (_, boosted) = runs["plain"], runs["boost"]
    f = boosted.signals["torque_request"]
    assert f.max() == pytest.approx(1.3) and f.min() == pytest.approx(1.0)
    # where the factor is 1.3 the engine gives 1.3 times its map torque, or its full-load torque
    engine = scenario.powertrain.components[0].engine
    k = np.nonzero(f > 1.3 - 1e-9)[0]
    assert len(k) > 10
    w, thr = boosted.signals["omega_engine"][k], boosted.signals["throttle"][k]
    own = np.array([engine(a, b) for a, b in zip(w, thr)])
    full = np.array([engine(a, 1.0) for a, b in zip(w, thr)])
    assert np.allclose(boosted.signals["T_engine"][k], np.minimum(1.3 * own, full), rtol=1e-12)
    # and the output torque in the torque phase holds up better: a shallower torque hole
    [q0] = shift_report(base, scenario.shifts)
    [q1] = shift_report(boosted, scenario.shifts)
    assert q1.torque_hole_pct < q0.torque_hole_pct - 1.0
    assert q1.torque_request_max == pytest.approx(1.3) and q1.torque_increase_duration > 0.3
    assert q0.torque_request_max is None


def test_energy_balance_holds_with_the_intervention(runs):
    from transgen.sim.analysis.report import energy_balance

    _, result = runs["boost"]
    summary = energy_balance(result)
    assert summary["passed"], summary


def test_input_torque_request_signal_and_turbodiesel_fuel():
    scenario = load_scenario("ht740_turbo", {"input.torque_request": {"type": "table", "t": [0.0, 1.0, 2.0],
                                                                      "value": [1.0, 0.5, 1.0]}})
    engine = next(c for c in scenario.powertrain.components if hasattr(c, "crank_model"))
    fuel = scenario.data["input"].get("fuel_signal", 1.0)
    assert engine.request.value(1.0) == 0.5
    assert engine.engine.rack(1.0) == pytest.approx(0.5 * engine.fuel.parts[0].value(1.0))
    assert engine.engine.rack(3.0) == pytest.approx(engine.fuel.parts[0].value(3.0))
    assert fuel is not None


def test_automatic_schedule_splices_the_request_when_it_shifts(tmp_path):
    from transgen.cli import main

    path = tmp_path / "launch.toml"
    assert main(["scenario", "new", "simple2", "-o", str(path)]) == 0
    tmpl = {"torque_cut": 0.5, "cut_time": 0.3, "torque_boost": 1.2, "boost_time": 0.2}
    scenario = load_scenario(path, {"auto_shift.templates.1-2": tmpl})
    result = scenario.run()
    assert result.success
    f = result.signals["torque_request"]
    [t_shift] = [h[0] for h in scenario.powertrain.controllers[0].history if h[1:] == ("1", "2")]
    assert np.all(f[result.time < t_shift] == 1.0)
    assert f.min() == pytest.approx(0.5) and f.max() == pytest.approx(1.2)
    assert f[-1] == 1.0


# --------------------------------------------------------------------------------- bad input


@pytest.mark.parametrize("extra, message", [
    (", torque_cut = -0.5, cut_time = 0.2", "'torque_cut' must be >= 0"),
    (", torque_boost = nan", "not a finite number"),
    (", torque_boost = inf", "not a finite number"),
])
def test_bad_template_values_are_refused_with_their_place(tmp_path, extra, message):
    path = _event(tmp_path, extra)
    with pytest.raises(ScenarioError) as exc:
        load_scenario(path)
    text = str(exc.value)
    assert message in text and f"{path}:" in text and ": error: " in text
    line = int(text.split(f"{path}:", 1)[1].split(":")[0])
    assert "torque_" in path.read_text().splitlines()[line - 1]


def test_negative_torque_request_signal_is_refused(tmp_path):
    path = tmp_path / "neg.toml"
    path.write_text('include = ["ht740_original"]\n[input]\ntorque_request = { type = "table", t = [0.0, 1.0], '
                    'value = [1.0, -0.2] }\n')
    with pytest.raises(ScenarioError, match=r"neg\.toml:3:\d+: error: the torque-request factor must be >= 0"):
        load_scenario(path)


def test_intervention_without_an_engine_is_refused(tmp_path):
    from test_optimize import EVENTS

    path = tmp_path / "torque.toml"
    path.write_text(EVENTS.replace('events = [{ t = 5.0, from = "1", to = "2" }]',
                                   'events = [{ t = 5.0, from = "1", to = "2", template = { torque_cut = 0.5, '
                                   'cut_time = 0.1 } }]'))
    with pytest.raises(ScenarioError, match="torque.toml:\\d+:\\d+: error: an engine torque intervention needs an "
                                            "engine"):
        load_scenario(path)


# ------------------------------------------------------------------------------------ optimizer


def test_optimizer_tunes_and_reports_the_intervention(tmp_path):
    from transgen.sim.study.optimize import PARAMETERS, TORQUE_PARAMETERS, optimize, tuned_scenario_text

    path = _event(tmp_path)
    result = optimize(path, max_evaluations=20, population=16, seed=1)
    assert result.engine_torque and result.parameters == PARAMETERS + TORQUE_PARAMETERS
    assert all(k in result.history[-1] for k in TORQUE_PARAMETERS)
    [s] = result.shifts
    text = tuned_scenario_text(result, tmp_path / "tuned.toml")
    assert "# tuned: fill_time" in text and "torque_ramp" in text
    assert "engine torque intervention:" in text
    tuned = parse_scenario(text, tmp_path / "tuned.toml")
    events = tuned.data["shifts"]["events"]
    if s.best_template.torque_intervention:
        assert events[0]["template"]["torque_boost"] == s.best_template.torque_boost
    assert tuned.run().success
    clutches = optimize(path, max_evaluations=10, population=9, seed=1, engine_torque=False)
    assert clutches.parameters == PARAMETERS and not clutches.engine_torque
    assert not any(k in clutches.history[-1] for k in TORQUE_PARAMETERS)
    assert not clutches.shifts[0].best_template.torque_intervention


def test_tables_calibration_writes_the_request_as_input_signal(tmp_path):
    from transgen.sim.study.optimize import plan_calibration

    scenario = load_scenario("ht740_original", {"simulation.t_end": 6.0})
    result = scenario.run()
    calibration, plans = plan_calibration(scenario.path, {}, result, scenario)
    tmpl = ShiftTemplate(**{**plans[0].template.__dict__, "torque_boost": 1.2, "boost_time": 0.3})
    overrides = calibration.overrides(plans, {1: tmpl})
    table = overrides["input.torque_request"]
    assert table["type"] == "table" and max(table["value"]) == pytest.approx(1.2)
    run = load_scenario("ht740_original", {"simulation.t_end": 6.0, **overrides}).run()
    assert run.signals["torque_request"].max() == pytest.approx(1.2)
    assert calibration.overrides(plans, {1: plans[0].template}).get("input.torque_request") is None


def test_optimizer_refuses_engine_torque_without_an_engine(tmp_path):
    from test_optimize import EVENTS

    from transgen.sim.study.optimize import optimize

    path = tmp_path / "events.toml"
    path.write_text(EVENTS)
    with pytest.raises(ScenarioError, match="needs an engine"):
        optimize(path, max_evaluations=10, population=9, engine_torque=True)
    assert not optimize(path, max_evaluations=10, population=9).engine_torque  # off by default without an engine


def test_tuned_file_of_a_bundled_scenario_runs_from_another_folder(tmp_path, monkeypatch):
    from transgen.sim.study.optimize import (Calibration, Constraints, Objective, OptimizeResult,
                                             tuned_scenario_text)
    from transgen.sim.scenario.load import scenario_path

    original = str(scenario_path("ht740_original").resolve())
    result = OptimizeResult(original, "HT", Objective(), Constraints(), Calibration("tables", 0.0), [], [],
                            {"simulation.t_end": 1.0}, [], 0)
    out = tmp_path / "a" / "tuned.toml"
    out.parent.mkdir()
    out.write_text(tuned_scenario_text(result, out))
    assert 'include = ["ht740_original"]' in out.read_text()
    elsewhere = tmp_path / "b"
    elsewhere.mkdir()
    monkeypatch.chdir(elsewhere)
    moved = tmp_path / "c" / "tuned.toml"
    moved.parent.mkdir()
    moved.write_text(out.read_text())
    for path in (out, moved):
        run = load_scenario(path).run()
        assert run.success and run.time[-1] == pytest.approx(1.0)


def test_a_file_next_to_the_including_one_wins_over_the_bundled_name(tmp_path):
    (tmp_path / "ht740_original").write_text('include = ["shared_missing.toml"]\n')
    path = tmp_path / "s.toml"
    path.write_text('include = ["ht740_original"]\n')
    with pytest.raises(ScenarioError, match="shared_missing.toml"):
        load_scenario(path)
    with pytest.raises(ScenarioError, match="included file 'no_such_scenario' not found"):
        (tmp_path / "t.toml").write_text('include = ["no_such_scenario"]\n')
        load_scenario(tmp_path / "t.toml")


def test_optimize_json_with_engine_torque_is_a_valid_document(tmp_path, capsys, monkeypatch):
    import json

    from transgen.cli import main
    from transgen.schemas import validate

    path = _event(tmp_path)
    monkeypatch.chdir(tmp_path)
    code = main(["optimize", str(path), "--workers", "1", "--evaluations", "10", "--population", "9",
                 "--allow-bindup", "--max-flare", "1000", "-o", "tuned.toml", "--json"])
    assert code == 0
    doc = json.loads(capsys.readouterr().out)
    validate(doc)
    assert doc["engine_torque"] is True and "torque_boost" in doc["parameters"]
    assert doc["units"]["torque_boost"] == "1" and doc["units"]["cut_time"] == "s"
    assert "torque_request_min" in doc["report_after"][0]


def test_second_pass_keeps_the_files_own_request_outside_the_retuned_shift():
    """A tuned raw-table file carries its intervention as [input] torque_request: re-tuning a shift
    replaces that shift's span only where the new template intervenes, the rest stays."""
    from transgen.sim.study.optimize import plan_calibration

    own = {"type": "table", "t": [0.0, 1.0, 1.1, 1.3, 1.4, 4.4, 4.5, 4.7, 4.8], "value": [1.0, 1.0, 0.9, 0.9, 1.0,
                                                                                        1.0, 0.7, 0.7, 1.0]}
    base = {"simulation.t_end": 6.0, "input.torque_request": own}
    scenario = load_scenario("ht740_original", base)
    result = scenario.run()
    calibration, plans = plan_calibration(scenario.path, {}, result, scenario)
    assert calibration.request is not None
    assert "input.torque_request" not in calibration.overrides(plans, {1: plans[0].template})  # kept as it is
    tmpl = ShiftTemplate(**{**plans[0].template.__dict__, "torque_boost": 1.2, "boost_time": 0.3})
    table = calibration.overrides(plans, {1: tmpl})["input.torque_request"]
    from transgen.sim.core.signals import Table

    new = Table(tuple(table["t"]), tuple(table["value"]))
    assert new.value(1.2) == pytest.approx(0.9)  # before the shift: the file's own
    assert max(new.sample(np.linspace(plans[0].t_start, 6.0, 2000))) == pytest.approx(1.2)
    assert min(new.sample(np.linspace(plans[0].t_start, 6.0, 2000))) == pytest.approx(1.0)  # its own cut replaced


def test_restart_inside_a_shift_keeps_the_commanded_torque_request(tmp_path):
    """The automatic schedule's torque request is controller state: a run restarted inside the shift
    (as each optimizer candidate is) goes on with the request the schedule commanded before."""
    import pickle

    from transgen.cli import main

    path = tmp_path / "launch.toml"
    assert main(["scenario", "new", "simple2", "-o", str(path)]) == 0
    over = {"auto_shift.templates.1-2": {"torque_cut": 0.5, "cut_time": 0.3, "torque_boost": 1.2, "boost_time": 0.2}}
    full = load_scenario(path, over).run()
    t_cut = next(e.t for e in full.events if e.kind == "command") + 0.05
    state = pickle.loads(pickle.dumps(load_scenario(path, over).run(t_end=t_cut).state))
    restarted = load_scenario(path, over).run(start=state)
    assert restarted.success, restarted.message
    ts = np.linspace(t_cut + 0.01, t_cut + 1.5, 300)
    for name in ("torque_request", "T_out"):
        a = np.interp(ts, full.time, full.signals[name])
        b = np.interp(ts, restarted.time, restarted.signals[name])
        assert np.allclose(a, b, rtol=1e-4, atol=1e-3 * np.max(np.abs(a))), name
    assert restarted.signals["torque_request"].min() == pytest.approx(0.5)
