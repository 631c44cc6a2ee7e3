"""Shift calibration (:mod:`transgen.sim.study.optimize`, ``transgen optimize``): template fitting
of raw apply tables, the overrides that carry a calibration, a small optimization on simple2 in
this process (a seeded run is repeatable and never worse than its start), an infeasible constraint
said with the binding constraint, command-line errors (exit 2)."""
from __future__ import annotations

import csv
import json
import math
from pathlib import Path

import numpy as np
import pytest

from transgen.cli import main
from transgen.sim import load_scenario
from transgen.sim.analysis.report import shift_report
from transgen.sim.control.schedule import ShiftTemplate
from transgen.sim.core.signals import Table
from transgen.sim.study.optimize import (EASE_PARAMETERS, TORQUE_PARAMETERS, Constraints, Objective, fit_template, optimize,
                                         parse_objective, plan_calibration, score, trade_off)

SMALL = {"max_evaluations": 10, "population": 9}  # the start and one generation of nine candidates


def _signal(points, before):
    from transgen.sim.control.schedule import _merge

    return _merge([(0.0, before)] + list(points))


def test_fit_template_recovers_a_template_from_its_tables():
    true = ShiftTemplate(fill_time=0.08, fill_level=0.15, ramp_time=0.4, ramp_end=0.5, hold_time=0.3,
                         final_time=0.15, offgoing_delay=0.1, offgoing_level=0.35, offgoing_ramp=0.25)
    on, off = _signal(true.oncoming(2.0), 0.0), _signal(true.offgoing(2.0), 1.0)
    fitted, residual = fit_template(on, off, 2.0, 3.2)
    assert residual < 0.02
    ts = np.linspace(2.0, 3.2, 500)
    for a, b in ((_signal(fitted.oncoming(2.0), 0.0), on), (_signal(fitted.offgoing(2.0), 1.0), off)):
        assert np.max(np.abs(a.sample(ts) - b.sample(ts))) < 0.02


def test_fit_of_a_linear_ramp_and_a_late_release():
    """The raw tables of ht740_original: a one-second linear ramp, the release at its end."""
    on = Table((0.0, 4.0, 5.0), (0.0, 0.0, 1.0))
    off = Table((0.0, 5.0, 5.1), (1.0, 1.0, 0.0))
    fitted, residual = fit_template(on, off, 4.0, 5.2)
    assert residual < 1e-3
    assert fitted.fill_time + fitted.offgoing_delay == pytest.approx(1.0, abs=5e-3)


@pytest.fixture(scope="module")
def ht740_plans():
    scenario = load_scenario("ht740_original")
    result = scenario.run()
    return scenario, result, *plan_calibration(scenario.path, {}, result, scenario)


def test_raw_tables_fitted_reproduce_the_run(ht740_plans):
    scenario, result, calibration, plans = ht740_plans
    assert calibration.kind == "tables"
    assert [(p.name, p.oncoming, p.offgoing) for p in plans] == [("1-2", "C4", "C5"), ("2-3", "C3", "C4"),
                                                                  ("3-4", "C2", "C3")]
    assert all(p.fit_residual < 1e-3 for p in plans)
    overrides = calibration.overrides(plans, {p.number: p.template for p in plans})
    assert set(overrides) == {f"elements.{e}.apply" for e in ("C2", "C3", "C4", "C5")}
    again = load_scenario("ht740_original", overrides).run()
    for a, b in zip(shift_report(result), shift_report(again)):
        assert b.energy_total == pytest.approx(a.energy_total, rel=2e-3)
        assert b.bindup == a.bindup


def test_one_shift_changed_leaves_the_others(ht740_plans):
    scenario, result, calibration, plans = ht740_plans
    tmpl = ShiftTemplate(fill_time=0.1, fill_level=0.1, ramp_time=0.5, ramp_end=0.6, hold_time=0.3, final_time=0.2,
                         offgoing_delay=0.1, offgoing_level=0.3, offgoing_ramp=0.2)
    overrides = calibration.overrides(plans, {2: tmpl})
    c4 = overrides["elements.C4.apply"]
    table = Table(tuple(c4["t"]), tuple(c4["value"]))
    raw = scenario.powertrain.transmission.elements[[e.name for e in scenario.powertrain.transmission.elements].index("C4")].apply
    for t in (3.0, 4.5, 5.5, 8.9):  # its 1-2 apply is the raw one
        assert table.value(t) == pytest.approx(raw.value(t))
    assert table.value(9.0 + 0.1 + 0.1 + 0.2 + 0.01) == 0.0  # released by the new template


def test_score_puts_every_feasible_candidate_first():
    ref = {"success": True, "completed": True, "energy": 1000.0, "duration": 0.5, "hole": 40.0, "flare": 0.0,
           "bindup": False, "bindup_torque": 0.0, "offgoing_torque": 100.0, "chatter": False, "locks": 1, "jerk": None}
    objective, constraints = Objective({"energy": 1.0}), Constraints()
    good, terms, violations = score({**ref, "energy": 500.0}, ref, objective, constraints)
    assert good == pytest.approx(0.5) and not violations and terms == {"energy": pytest.approx(0.5)}
    bad, _, violations = score({**ref, "energy": 10.0, "bindup": True, "bindup_torque": 50.0}, ref, objective,
                               constraints)
    assert bad > 1e3 and set(violations) == {"no bindup"}
    worse, _, _ = score({**ref, "bindup": True, "bindup_torque": 90.0}, ref, objective, constraints)
    assert worse > bad
    failed, _, _ = score({"success": False, "message": "x"}, ref, objective, constraints)
    assert failed > worse


def test_max_energy_and_a_reference_calibration_limit_each_shift():
    ref = {"success": True, "completed": True, "energy": 1000.0, "duration": 0.5, "hole": 40.0, "flare": 0.0,
           "bindup": False, "bindup_torque": 0.0, "offgoing_torque": 100.0, "chatter": False, "locks": 1, "jerk": None}
    s, _, violations = score({**ref, "energy": 900.0}, ref, Objective({"energy": 1.0}), Constraints(max_energy=800.0))
    assert s > 1e3 and violations == {"max energy": pytest.approx(100.0 / 800.0)}
    s, _, violations = score({**ref, "energy": 700.0}, ref, Objective({"energy": 1.0}), Constraints(max_energy=800.0))
    assert s == pytest.approx(0.7) and not violations
    own = Constraints(max_hole_pct=30.0).for_shift(40.0, 500.0)  # the tighter of the run's and the reference's
    assert (own.max_hole_pct, own.max_energy) == (30.0, 500.0)
    own = Constraints(max_energy=400.0).for_shift(None, 500.0)  # a reference shift without a hole leaves it free
    assert (own.max_hole_pct, own.max_energy) == (None, 400.0)


def test_no_worse_than_limits_each_shift_by_the_reference_calibration(tmp_path, capsys):
    """--no-worse-than: each shift's torque hole and clutch energy at most the reference's at the
    same gears (here the scenario itself: its own whole-run report), in the JSON and the header."""
    out = tmp_path / "tuned.toml"
    code = main(["optimize", "simple2_upshift", "--workers", "1", "--evaluations", "10", "--population", "9",
                 "--no-worse-than", "simple2_upshift", "--allow-bindup", "--max-flare", "1000", "-o", str(out),
                 "--quiet", "--json"])
    doc = json.loads(capsys.readouterr().out)
    assert code in (0, 1) and doc["constraints"]["no_worse_than"] == "simple2_upshift"
    [before], [shift] = doc["report_before"], doc["shifts"]
    assert shift["constraints"]["max_hole_pct"] == pytest.approx(before["torque_hole_pct"])
    assert shift["constraints"]["max_energy"] == pytest.approx(before["energy_total"])
    if shift["feasible"]:
        assert shift["metrics_after"]["hole"] <= before["torque_hole_pct"]
        assert shift["metrics_after"]["energy"] <= before["energy_total"]
    else:
        assert shift["binding"] in ("max hole", "max energy")
    assert "limits (no worse than simple2_upshift): torque hole <=" in out.read_text()


def test_max_jerk_limits_each_shift_where_the_scenario_measures_it():
    ref = {"success": True, "completed": True, "energy": 1000.0, "duration": 0.5, "hole": 40.0, "flare": 0.0,
           "bindup": False, "bindup_torque": 0.0, "offgoing_torque": 100.0, "chatter": False, "locks": 1, "jerk": 30.0}
    limit = Constraints(max_jerk=10.0)
    s, _, violations = score({**ref, "jerk": 15.0}, ref, Objective({"energy": 1.0}), limit)
    assert s > 1e3 and violations == {"max jerk": pytest.approx(0.5)}
    s, _, violations = score({**ref, "jerk": 9.0, "energy": 600.0}, ref, Objective({"energy": 1.0}), limit)
    assert s == pytest.approx(0.6) and not violations
    s, _, violations = score({**ref, "jerk": None}, {**ref, "jerk": None}, Objective({"energy": 1.0}), limit)
    assert not violations                                  # no vehicle: nothing to limit
    assert "jerk <= 10 m/s^3" in limit.text()


def test_trade_off_keeps_the_feasible_candidates_no_other_beats_on_both():
    rows = [{"hole": 20.0, "energy": 5.0, "feasible": True}, {"hole": 10.0, "energy": 9.0, "feasible": True},
            {"hole": 15.0, "energy": 9.5, "feasible": True},  # beaten on both by 10 % / 9 kJ
            {"hole": 5.0, "energy": 1.0, "feasible": False},  # infeasible: not a choice
            {"hole": 10.0, "energy": 9.0, "feasible": True},  # the same point again
            {"hole": 30.0, "energy": 5.0, "feasible": True},  # as cool as 20 % / 5, deeper
            {"hole": None, "energy": 2.0, "feasible": True}, {"hole": 25.0, "energy": 4.0, "feasible": True}]
    assert [(r["hole"], r["energy"]) for r in trade_off(rows)] == [(10.0, 9.0), (20.0, 5.0), (25.0, 4.0)]
    assert trade_off([r for r in rows if not r["feasible"]]) == []


def test_the_default_objective_leaves_out_a_term_the_scenario_cannot_measure():
    """Jerk without a vehicle (None in the candidate and the start) is no term at all (not a
    constant added to every score); with a vehicle it counts, relative to the start's jerk."""
    ref = {"success": True, "completed": True, "energy": 1000.0, "duration": 0.5, "hole": 40.0, "flare": 0.0,
           "bindup": False, "bindup_torque": 0.0, "offgoing_torque": 100.0, "chatter": False, "locks": 1, "jerk": None}
    candidate = {**ref, "energy": 500.0, "hole": 20.0, "duration": 0.25}
    s, terms, _ = score(candidate, ref, Objective(), Constraints())
    assert "jerk" in Objective().weights and "jerk" not in terms
    assert s == pytest.approx(0.5 + 0.5 + 0.1 * 0.5)
    s, terms, _ = score({**candidate, "jerk": 5.0}, {**ref, "jerk": 10.0}, Objective(), Constraints())
    assert terms["jerk"] == pytest.approx(Objective().weights["jerk"] * 0.5)


def test_parse_objective():
    assert parse_objective("energy=1,jerk=0.2,duration=0.1").weights == {"energy": 1.0, "jerk": 0.2, "duration": 0.1}
    for bad, what in (("energy=1,comfort=2", "unknown term"), ("energy=x", "not a number"),
                      ("energy=-1", ">= 0"), ("energy=0", "at least one")):
        with pytest.raises(ValueError, match=what):
            parse_objective(bad)


def test_small_optimization_on_simple2_is_repeatable_and_no_worse():
    runs = [optimize("simple2_upshift", seed=3, **SMALL) for _ in range(2)]
    a, b = runs
    [s] = a.shifts
    assert s.plan.oncoming == "C2" and s.plan.offgoing == "C1"
    assert s.evaluations == 10 and len(a.history) == 10
    assert s.best_score <= s.start_score
    assert [r["score"] for r in a.history] == [r["score"] for r in b.history]  # the same seed, the same search
    assert a.overrides == b.overrides
    assert set(a.overrides) == {"elements.C1.apply", "elements.C2.apply"}
    tuned = load_scenario("simple2_upshift", a.overrides).run()
    assert tuned.success


def test_cli_writes_a_scenario_that_simulate_runs(tmp_path, capsys):
    out = tmp_path / "tuned.toml"
    code = main(["optimize", "simple2_upshift", "--workers", "1", "--evaluations", "10", "--population", "9",
                 "--allow-bindup", "--max-flare", "1000", "-o", str(out), "--report", "--quiet"])
    text = capsys.readouterr().out
    assert code == 0, text
    assert "evaluations/s" in text and "before" in text and "after" in text
    assert "The trade between torque hole and clutch energy" in text
    head = out.read_text()
    assert head.startswith("# Shift calibration by 'transgen optimize' of simple2_upshift\n") and "# objective:" in head
    assert 'include = ["simple2_upshift"]' in head and "# shift 1-2 (C2 on, C1 off)" in head
    import transgen

    assert str(Path(transgen.__file__).resolve().parent.parent) not in head  # no path of this machine
    assert "# constraints:" in head and "[elements.C2]" in head
    rows = list(csv.DictReader(open(tmp_path / "tuned.history.csv")))
    assert len(rows) == 10 and {"fill_time", "energy", "score", "feasible"} <= set(rows[0])
    assert main(["simulate", str(out), "--report", "--quiet"]) == 0


def test_infeasible_constraints_name_the_binding_one(tmp_path, capsys):
    out = tmp_path / "tuned.toml"
    code = main(["optimize", "simple2_upshift", "--workers", "1", "--evaluations", "10", "--population", "9",
                 "--max-duration", "0.001", "-o", str(out), "--quiet"])
    err = capsys.readouterr().err
    assert code == 1
    assert "no candidate met the constraints" in err and "binding: max duration" in err
    assert out.exists()  # the best candidate found is kept


@pytest.mark.parametrize("argv, message", [
    (["--objective", "comfort=1"], "--objective: error: unknown term 'comfort'"),
    (["--max-flare", "-5"], "--max-flare: error"),
    (["--max-hole", "nan"], "--max-hole: error"),
    (["--shift", "5-6"], "--shift 5-6: error: no such shift"),
    (["--set", "driveline.mass=3"], "--set driveline.mass: error"),
    (["--evaluations", "1"], "--evaluations: error"),
    (["--seed", "-1"], "--seed: error"),
    (["--max-energy", "0"], "--max-energy: error"),
    (["--max-jerk", "-1"], "--max-jerk: error"),
    (["--no-worse-than", "no_such_scenario"], "no such scenario file"),
    (["--no-worse-than", "zf3hp22_manual_first_coast"], "--no-worse-than zf3hp22_manual_first_coast: error: its run "
                                                        "has no shift 1-2 to compare with"),
])
def test_cli_errors_exit_2(argv, message, tmp_path, capsys):
    out = tmp_path / "tuned.toml"
    assert main(["optimize", "simple2_upshift", "--workers", "1", "-o", str(out), "--quiet"] + argv) == 2
    err = capsys.readouterr().err
    assert message in err and "Traceback" not in err
    assert not out.exists()


def test_cli_refuses_another_output_kind_and_a_missing_scenario(tmp_path, capsys):
    assert main(["optimize", "simple2_upshift", "-o", str(tmp_path / "x.csv")]) == 2
    assert main(["optimize", "no_such_scenario", "--workers", "1", "-o", str(tmp_path / "x.toml")]) == 2
    err = capsys.readouterr().err
    assert "-o" in err and "no such scenario" in err


def test_events_and_automatic_schedules_carry_their_templates(tmp_path):
    """A scenario with shift events tunes each event's template; a launch tunes the automatic
    schedule's template of each shift (``[auto_shift] templates."1-2"``)."""
    path = tmp_path / "launch.toml"
    assert main(["scenario", "new", "simple2", "-o", str(path)]) == 0
    scenario = load_scenario(path)
    result = scenario.run()
    calibration, plans = plan_calibration(path, {}, result, scenario)
    assert calibration.kind == "auto" and plans and plans[0].name == "1-2"
    from dataclasses import replace

    from transgen.errors import ScenarioError
    from transgen.sim.study.optimize import _refresh

    moved = replace(plans[0], t_start=plans[0].t_start + 1.5)  # found again by its place in the run
    assert _refresh(moved, result).t_start == pytest.approx(plans[0].t_start)
    with pytest.raises(ScenarioError, match="no longer commands it"):
        _refresh(replace(plans[0], number=len(plans) + 1), result)
    tmpl = ShiftTemplate(fill_time=0.05)
    overrides = calibration.overrides(plans, {1: tmpl})
    clutch = {k: v for k, v in ShiftTemplate().__dict__.items()  # no intervention, no easing
              if k not in TORQUE_PARAMETERS + EASE_PARAMETERS}
    assert overrides == {"auto_shift.templates.1-2": {**clutch, "fill_time": 0.05}}
    tuned = load_scenario(path, overrides)
    assert tuned.powertrain.controllers[0].templates["1-2"] == tmpl
    assert not math.isnan(tuned.run().time[-1])


EVENTS = """
mechanism = "simple2"
[simulation]
t_start = 4.0
t_end = 7.0
[initial]
gear = "1"
speeds_rpm = { Li = 1500 }
[input]
type = "torque"
torque = 400.0
[driveline]
output_inertia = 100.0
stiffness = 12000.0
damping = 200.0
[shifts]
template = { ramp_end = 0.8 }
events = [{ t = 5.0, from = "1", to = "2" }]
"""


def test_shift_events_carry_a_template_each(tmp_path):
    path = tmp_path / "events.toml"
    path.write_text(EVENTS)
    scenario = load_scenario(path)
    calibration, plans = plan_calibration(path, {}, scenario.run(), scenario)
    assert calibration.kind == "events" and [(p.name, p.oncoming, p.offgoing) for p in plans] == [("1-2", "C2", "C1")]
    assert plans[0].template == ShiftTemplate(ramp_end=0.8)
    tmpl = ShiftTemplate(ramp_time=0.3)
    overrides = calibration.overrides(plans, {1: tmpl})
    # no engine torque intervention, no easing (a timed event has no measured slip to ease on)
    clutch = {k: v for k, v in tmpl.__dict__.items() if k not in TORQUE_PARAMETERS + EASE_PARAMETERS}
    assert overrides == {"shifts.events": [{"t": 5.0, "from": "1", "to": "2", "template": clutch}]}
    assert load_scenario(path, overrides).run().success


def test_local_processes_and_dask_give_the_same_calibration():
    """The same seed gives the same search on every executor (the batches are put back in order)."""
    distributed = pytest.importorskip("distributed")
    from transgen.sim.study import DaskExecutor, LocalExecutor

    serial = optimize("simple2_upshift", seed=1, **SMALL)
    local = optimize("simple2_upshift", seed=1, executor=LocalExecutor(2), **SMALL)
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1",
                                  dashboard_address=None) as cluster:
        on_dask = optimize("simple2_upshift", seed=1, executor=DaskExecutor(cluster.scheduler_address), **SMALL)
    scores = [r["score"] for r in serial.history]
    assert [r["score"] for r in local.history] == scores
    assert [r["score"] for r in on_dask.history] == scores
    assert local.overrides == serial.overrides == on_dask.overrides


def _quadratic(dim: int, calls: list):
    """A batch evaluator for :func:`_search` on a bowl in the unit box with its minimum at
    ``0.2 .. 0.8`` and a penalty wall as the score's (feasible first: ``x0 + x1 <= 1.2``), and
    the best point kept as :func:`optimize` keeps it."""
    target = np.linspace(0.2, 0.8, dim)
    best = {"x": np.full(dim, 0.95), "score": math.inf}

    def batch_map(func, xs):
        scores = []
        for x in xs:
            x = np.asarray(x, dtype=float)
            violation = max(x[0] + x[1] - 1.2, 0.0)
            s = 1e3 * (1.0 + violation) if violation else float(np.sum((x - target) ** 2))
            calls.append(x.copy())
            scores.append(s)
            if s < best["score"]:
                best.update(x=x, score=s)
        return scores

    return batch_map, best, target


@pytest.mark.parametrize("dim, budget, reached", [(9, 600, 1e-3), (16, 1000, 1e-2)])
def test_search_converges_within_its_budget_repeatably(dim, budget, reached):
    from transgen.sim.study.optimize import _search

    before = np.random.get_state()[1].copy()
    runs = []
    for _ in range(2):
        calls: list = []
        batch_map, best, target = _quadratic(dim, calls)
        counter = {"evaluations": 1}
        wrapped = lambda f, xs: (counter.__setitem__("evaluations", counter["evaluations"] + len(xs)), batch_map(f, xs))[1]  # noqa: E731
        _search(wrapped, best, counter, [(0.0, 1.0)] * dim, budget, 12, seed=5)
        assert len(calls) <= budget
        assert all(np.all((0.0 <= x) & (x <= 1.0)) for x in calls)  # never outside the box
        assert best["score"] < reached and np.allclose(best["x"], target, atol=math.sqrt(reached))
        runs.append(np.array(calls))
    assert np.array_equal(runs[0], runs[1])  # the same seed, the same candidates
    assert np.array_equal(np.random.get_state()[1], before)  # numpy's global random state untouched
