"""Shift-quality report: exact numbers on a hand-built result, and the physics of the simple
two-speed 1-2 upshift of thesis 3.3.1 (Figs. 3.2-3.7)."""
import json
import math

import numpy as np
import pytest

from transgen import load_mechanism
from transgen.kinematics import constraint_matrix, null_space
from transgen.sim.model.components import Driveline, InputTorque
from transgen.sim.analysis.report import (RPM_PER_RAD_S, Shift, ShiftQuality, energy_balance, infer_shifts, report_dict,
                                 report_text, shift_report)
from transgen.sim.core.result import Event, ModeSpan, Result
from transgen.sim.analysis.samples import integrate
from transgen.sim.core.signals import Constant, Table
from transgen.sim.solve.simulate import Powertrain, SolverOptions, simulate


# --------------------------------------------------------------------------- synthetic result
def _tri(t, t0, tp, t1, peak):
    """Triangle: 0 at t0, ``peak`` at tp, 0 at t1."""
    up = peak * (t - t0) / (tp - t0)
    down = peak * (t1 - t) / (t1 - tp)
    return np.where((t >= t0) & (t <= tp), up, np.where((t > tp) & (t <= t1), down, 0.0))


def synthetic(events=True, meta_links=True) -> Result:
    """A 1-2 upshift built by hand, offgoing A, oncoming B, command at 1.0 s:

    * B apply ramps 0 -> 1 over 1.0-1.4 s, its torque is -1000*apply while it slips (sign must
      not matter), it locks at 1.6 s; A apply 1 until 1.1 s, ramps to 0 at 1.3 s;
    * A holds +200 N*m before the shift, falls as 200 - 1000*(t-1) in the torque phase (zero at
      1.2 s, -50 N*m at its unlock at 1.25 s): bindup of 50 N*m for 0.05 s;
    * T_out 1000 N*m before, falls linearly to 600 N*m at 1.25 s (hole 400 N*m = 40 %), 1500 in
      the speed phase (+50 %), 1000 after;
    * input speed 100 + 10 t, plus a 5 rad/s triangular flare peaking at 1.30 s, then falling
      40 rad/s to the new ratio; ratio 5 before, 2.5 after;
    * P_B = 20000*apply_B while B slips (8000 J), P_A a 2000 W triangle over 1.25-1.28 s (30 J):
      both above 1 % of 20 kW from 1.251 to 1.278 s.
    """
    segs = [np.linspace(0.0, 1.25, 1251), np.linspace(1.25, 1.6, 351), np.linspace(1.6, 2.0, 401)]
    sig = {}

    def add(name, parts):
        sig[name] = np.concatenate(parts)

    t1, t2, t3 = segs
    apply_a = lambda t: np.clip(1.0 - (t - 1.1) / 0.2, 0.0, 1.0)  # noqa: E731
    apply_b = lambda t: np.clip((t - 1.0) / 0.4, 0.0, 1.0)  # noqa: E731
    base = lambda t: 100.0 + 10.0 * t  # noqa: E731
    add("apply_A", [apply_a(t) for t in segs])
    add("apply_B", [apply_b(t) for t in segs])
    add("t_B", [-1000.0 * apply_b(t1), -1000.0 * apply_b(t2), np.full(len(t3), -800.0)])
    add("t_A", [np.where(t1 < 1.0, 200.0, 200.0 - 1000.0 * (t1 - 1.0)),
                -50.0 * np.clip(1.0 - (t2 - 1.25) / 0.05, 0.0, 1.0), np.zeros(len(t3))])
    add("locked_A", [np.ones(len(t1)), np.zeros(len(t2)), np.zeros(len(t3))])
    add("locked_B", [np.zeros(len(t1)), np.zeros(len(t2)), np.ones(len(t3))])
    bump = _tri(t2, 1.25, 1.30, 1.35, 5.0)
    drop = np.where(t2 > 1.35, 160.0 * (t2 - 1.35), 0.0)
    add("w_Li", [base(t1), base(t2) + bump - drop, base(t3) - 40.0])
    w_lo_a, w_lo_b = base(1.25) / 5.0, (base(1.6) - 40.0) / 2.5
    add("w_Lo", [base(t1) / 5.0, w_lo_a + (w_lo_b - w_lo_a) * (t2 - 1.25) / 0.35, (base(t3) - 40.0) / 2.5])
    add("T_out", [np.where(t1 < 1.0, 1000.0, 1000.0 - 1600.0 * (t1 - 1.0)), np.full(len(t2), 1500.0),
                  np.full(len(t3), 1000.0)])
    add("T_in", [np.full(len(t), 300.0) for t in segs])
    add("P_B", [20000.0 * apply_b(t1), 20000.0 * apply_b(t2), np.zeros(len(t3))])
    add("P_A", [np.zeros(len(t1)), _tri(t2, 1.25, 1.26, 1.28, 2000.0), np.zeros(len(t3))])
    add("slip_A", [np.zeros(len(t1)), 20.0 * (t2 - 1.25), 7.0 + 0 * t3])
    add("slip_B", [np.full(len(t1), -50.0), -50.0 + 50.0 * (t2 - 1.25) / 0.35, np.zeros(len(t3))])
    add("mode", [np.full(len(t1), 1.0), np.full(len(t2), 2.0), np.full(len(t3), 3.0)])
    time = np.concatenate(segs)
    p_in = sig["T_in"] * sig["w_Li"]
    diss = sig["P_A"] + sig["P_B"]

    def cum(y):
        return np.concatenate([[0.0], np.cumsum(0.5 * (y[1:] + y[:-1]) * np.diff(time))])

    sig["E_in"] = cum(p_in)
    sig["E_dissipated"] = cum(diss)
    sig["E_load"] = np.zeros(len(time))
    sig["E_stored"] = sig["E_in"] - sig["E_dissipated"]
    energy = {"work_in": float(sig["E_in"][-1]), "stored_change": float(sig["E_stored"][-1]),
              "dissipated": float(sig["E_dissipated"][-1]), "work_to_load": 0.0, "residual": 0.0,
              "relative_residual": 0.0}
    units = {k: "" for k in sig}
    modes = [ModeSpan(0.0, 1.25, "M1", ("A",)), ModeSpan(1.25, 1.6, "M3", ()), ModeSpan(1.6, 2.0, "M2", ("B",))]
    evs = [Event(0.0, "start", ("A",), "", "M1")]
    if events:
        evs += [Event(1.25, "unlock", ("A",), "M1", "M3"), Event(1.6, "lock", ("B",), "M3", "M2")]
    meta = {"mechanism": "synthetic", "model": "switching", "links": ["Li", "Lo"], "elements": ["A", "B"],
            "mode_names": ["M1", "M3", "M2"], "coordinates": ["Li", "Lo"]}
    if meta_links:
        meta.update(input_link="Li", output_link="Lo")
    return Result(time, sig, units, modes, evs, True, "completed", energy,
                  {"wall_time": 0.1, "rhs_evaluations": 10, "events": 2, "segments": 3}, meta)


@pytest.fixture(scope="module")
def syn():
    r = synthetic()
    (q,) = shift_report(r)
    return r, q


def test_synthetic_inferred_shift():
    r = synthetic()
    assert infer_shifts(r) == [Shift("B", "A", 1.0, "M1-M2")]


def test_synthetic_phases(syn):
    _, q = syn
    assert isinstance(q, ShiftQuality)
    assert (q.oncoming, q.offgoing, q.name, q.completed, q.direction) == ("B", "A", "M1-M2", True, "upshift")
    assert q.torque_phase_start == pytest.approx(1.0, abs=1e-12)
    assert q.torque_phase_end == pytest.approx(1.25, abs=1e-12)
    assert q.torque_phase_duration == pytest.approx(0.25, abs=1e-12)
    assert q.inertia_phase_start == pytest.approx(1.25, abs=1e-12)
    assert q.inertia_phase_end == pytest.approx(1.6, abs=1e-12)
    assert q.inertia_phase_duration == pytest.approx(0.35, abs=1e-12)
    assert q.shift_end == pytest.approx(1.6) and q.shift_duration == pytest.approx(0.6)
    assert q.dissipation_end == pytest.approx(1.6) and q.offgoing_drag_after_lock == 0.0
    assert q.offgoing_unlock == pytest.approx(1.25) and q.oncoming_lock == pytest.approx(1.6)
    assert q.ratio_before == pytest.approx(5.0) and q.ratio_after == pytest.approx(2.5)


def test_synthetic_torque_hole(syn):
    _, q = syn
    assert q.output_torque_before == pytest.approx(1000.0)
    assert q.output_torque_min == pytest.approx(600.0)
    assert q.output_torque_min_time == pytest.approx(1.25)
    assert q.torque_hole == pytest.approx(400.0)
    assert q.torque_hole_pct == pytest.approx(40.0)
    assert q.output_torque_max == pytest.approx(1500.0)
    assert q.output_torque_overshoot_pct == pytest.approx(50.0)


def test_synthetic_bindup(syn):
    _, q = syn
    assert q.bindup
    assert q.offgoing_torque_before == pytest.approx(200.0)
    assert q.bindup_torque == pytest.approx(50.0)
    assert q.bindup_duration == pytest.approx(0.05, abs=1e-9)
    assert q.offgoing_torque_at_unlock == pytest.approx(-50.0)


def test_synthetic_flare(syn):
    _, q = syn
    assert q.flare
    assert q.flare_max == pytest.approx(5.0, abs=1e-9)
    assert q.flare_max_rpm == pytest.approx(5.0 * 60 / (2 * math.pi))
    assert q.flare_time == pytest.approx(1.30)


def test_synthetic_energy_and_overlap(syn):
    _, q = syn
    assert q.energy["B"] == pytest.approx(8000.0, rel=1e-9)
    assert q.energy["A"] == pytest.approx(30.0, rel=1e-9)
    assert q.energy_total == pytest.approx(8030.0, rel=1e-9)
    assert q.peak_power == {"A": pytest.approx(2000.0), "B": pytest.approx(20000.0)}
    # both above 200 W (1 % of 20 kW) from 1.251 to 1.278 s
    assert q.both_dissipating_duration == pytest.approx(0.027, abs=1e-9)
    # A's torque is reversed (-50 -> 0 N*m against +200 before) the whole time, but A unlocks at
    # apply 0.25, its release under way: a late release (bindup), not a forced unlock
    assert q.forced_duration == pytest.approx(0.027, abs=1e-9)
    assert not q.forced_unlock and q.forced_unlock_element is None
    assert q.offgoing_energy_share == pytest.approx(100 * 30 / 8030)


def test_synthetic_ramp_overrun(syn):
    _, q = syn
    assert q.oncoming_apply_final == pytest.approx(1.0)
    assert q.oncoming_ramp_end == pytest.approx(1.4)
    assert q.speed_phase_past_ramp
    assert q.speed_phase_overrun == pytest.approx(0.2)


def test_synthetic_without_events_uses_locked_signals(syn):
    _, q = syn
    (q2,) = shift_report(synthetic(events=False))
    for k in ("torque_phase_start", "torque_phase_end", "inertia_phase_end", "torque_hole", "bindup_torque",
              "flare_max", "energy_total", "both_dissipating_duration", "forced_duration",
              "speed_phase_overrun"):
        assert getattr(q2, k) == pytest.approx(getattr(q, k)), k


def test_synthetic_offgoing_drag_after_lock():
    # A goes on slipping after B locked at 1.6 s, its torque reversed (-30 N*m against +200):
    # 1000 W falling to 0 at 1.7 s (50 J more), above 200 W until 1.68 s
    r = synthetic()
    t = r.time
    k = np.nonzero(t >= 1.6)[0][1:]  # seg3, after the duplicate sample of the lock
    r.signals["P_A"][k] = np.clip(1000.0 * (1.7 - t[k]) / 0.1, 0.0, None)
    r.signals["t_A"][k] = np.where(t[k] < 1.7, -30.0, 0.0)
    (q,) = shift_report(r)
    assert q.shift_end == pytest.approx(1.6) and q.dissipation_end == pytest.approx(1.7)
    assert q.energy["A"] == pytest.approx(80.0, rel=1e-9)
    assert q.offgoing_energy_after_lock == pytest.approx(50.0, rel=1e-9)
    assert q.offgoing_drag_after_lock == pytest.approx(0.08, abs=1e-9)
    assert q.forced_duration == pytest.approx(0.027 + 0.08, abs=1e-9)
    assert any("after B locked" in n for n in q.notes)


def test_synthetic_explicit_shift_and_links():
    r = synthetic(meta_links=False)
    (q,) = shift_report(r, [Shift("B", "A", 1.0, "1-2")])
    assert q.name == "1-2" and q.input_link == "Li" and q.output_link == "Lo"
    assert any("input link not recorded" in n for n in q.notes)
    (q,) = shift_report(r, [Shift("B", "A", 1.0)], input_link="Li", output_link="Lo")
    assert not any("not recorded" in n for n in q.notes)
    assert q.name == "M1-M2" and q.flare_max == pytest.approx(5.0)
    with pytest.raises(KeyError):
        shift_report(r, [Shift("X", "A", 1.0)])


def test_synthetic_no_lock():
    r = synthetic()
    r.signals["locked_B"] = np.zeros(len(r.time))
    r.events = r.events[:2]
    (q,) = shift_report(r, [Shift("B", "A", 1.0)])
    assert not q.completed and q.inertia_phase_end is None and q.shift_duration is None
    assert q.shift_end == pytest.approx(2.0)
    assert any("never locked" in n for n in q.notes)


def test_integrate_repeated_times():
    t = np.array([0.0, 1.0, 1.0, 2.0, 3.0])
    y = np.array([1.0, 1.0, 5.0, 5.0, 5.0])  # a step at a mode change (repeated time 1.0)
    assert integrate(t, y, 0.0, 3.0) == pytest.approx(11.0)
    assert integrate(t, y, 0.5, 1.0) == pytest.approx(0.5)
    assert integrate(t, y, 1.0, 1.5) == pytest.approx(2.5)
    assert integrate(t, y, 0.5, 2.5) == pytest.approx(0.5 + 7.5)
    assert integrate(t, y, 2.0, 1.0) == 0.0


def test_energy_balance_pass_fail():
    r = synthetic()
    eb = energy_balance(r)
    assert eb["passed"] and eb["tolerance"] == pytest.approx(1e-3 * r.energy["work_in"])
    r.energy = dict(r.energy, residual=0.002 * r.energy["work_in"])
    assert not energy_balance(r)["passed"]
    r.energy = {}
    assert energy_balance(r)["passed"] is False


def test_report_text_and_dict(syn):
    r, q = syn
    text = report_text(r, [q])
    for s in ("Shift M1-M2", "torque phase", "inertia (speed) phase", "N*m", "rad/s", "rpm", "bindup",
              "YES", "flare", "energy [J]", "peak power [W]", "Energy balance", "PASS", "Run statistics"):
        assert s in text, s
    d = report_dict(r, [q])
    json.dumps(d, allow_nan=False)
    assert d["shifts"][0]["torque_hole"] == pytest.approx(400.0)
    assert d["shifts"][0]["energy"]["B"] == pytest.approx(8000.0)
    assert d["energy_balance"]["passed"] is True
    assert report_dict(r)["shifts"][0]["name"] == "M1-M2"  # qualities computed when not given


# --------------------------------------------------------------------------- comfort figures
def _with_vehicle(r: Result) -> Result:
    """The synthetic result with a vehicle acceleration: 1 m/s^2 until 1.1 s, down to 0.5 at
    1.3 s (jerk -2.5 m/s^3), up to 0.8 at 1.4 s (jerk +3 m/s^3), 0.8 after."""
    a = np.interp(r.time, [0.0, 1.1, 1.3, 1.4, 2.0], [1.0, 1.0, 0.5, 0.8, 0.8])
    return Result(r.time, {**r.signals, "vehicle_accel": a}, r.units, r.modes, r.events, r.success, r.message,
                  r.energy, r.stats, r.meta)


def test_synthetic_comfort_closed_form():
    (q,) = shift_report(_with_vehicle(synthetic()), weighting="none")
    assert q.window_end == 2.0  # 2 s after the lock at 1.6 s, cut at the end of the run
    assert q.accel_before == pytest.approx(1.0, rel=1e-12)
    assert q.accel_after == pytest.approx(0.8, rel=1e-12)
    assert q.jerk_max == pytest.approx(3.0, rel=1e-6) and 1.3 < q.jerk_max_time < 1.4
    assert q.jerk_peak_to_peak == pytest.approx(5.5, rel=1e-6)
    # (integral of a^4 over 1-2 s)^(1/4), piecewise exact: a^4 of a linear piece integrates to
    # dt * (a1^5 - a0^5) / (5 (a1 - a0))
    pieces = 0.1 + 0.2 * (1 - 0.5 ** 5) / 2.5 + 0.1 * (0.8 ** 5 - 0.5 ** 5) / 1.5 + 0.6 * 0.8 ** 4
    assert q.vdv_weighting == "none" and q.vdv == pytest.approx(pieces ** 0.25, rel=1e-6)
    # T_out: 1500 N*m in the speed phase, 1000 after the lock: final 1000, overshoot 50 %, settled
    # at the lock (the event's repeated time stamp)
    assert q.output_torque_final == pytest.approx(1000.0)
    assert q.torque_overshoot == pytest.approx(50.0)
    assert q.settling_time == pytest.approx(0.0, abs=1e-12)
    assert q.lock_counts == {"A": 0, "B": 1} and q.unlock_counts == {"A": 1, "B": 0} and not q.chatter
    d = q.to_dict()
    assert d["lock_counts"] == {"A": 0, "B": 1} and d["vdv"] == pytest.approx(pieces ** 0.25, rel=1e-6)
    # the default weighting is ISO 2631-1 Wd (fore-aft), which attenuates the sub-Hz content
    (w,) = shift_report(_with_vehicle(synthetic()))
    assert w.vdv_weighting == "Wd" and 0 < w.vdv < q.vdv


def test_synthetic_without_vehicle_has_no_comfort_figures(syn):
    _, q = syn
    assert q.accel_before is q.accel_after is q.jerk_max is q.vdv is None
    assert any("no vehicle" in n for n in q.notes)
    assert q.torque_overshoot == pytest.approx(50.0)  # the output torque figures need no vehicle
    with pytest.raises(ValueError, match="unknown frequency weighting"):
        shift_report(synthetic(), weighting="Wq")


def test_synthetic_forced_unlock_while_fully_applied():
    r = synthetic()
    sig = dict(r.signals, apply_A=np.ones(len(r.time)))  # A never released: B drives it over its capacity
    r = Result(r.time, sig, r.units, r.modes, r.events, True, "completed", r.energy, r.stats, r.meta)
    (q,) = shift_report(r)
    assert q.forced_unlock and q.forced_unlock_element == "A"
    assert any("forced to unlock at 1.2500 s while fully applied" in n for n in q.notes)
    assert "YES - A unlocked while fully applied" in report_text(r, [q])


def test_synthetic_chatter_counts():
    r = synthetic()
    evs = [r.events[0], Event(1.25, "unlock", ("A",), "M1", "M3"), Event(1.3, "lock", ("A",), "M3", "M1"),
           Event(1.35, "unlock", ("A",), "M1", "M3"), Event(1.6, "lock", ("B",), "M3", "M2")]
    r = Result(r.time, r.signals, r.units, r.modes, evs, True, "completed", r.energy, r.stats, r.meta)
    (q,) = shift_report(r)
    assert q.lock_counts == {"A": 1, "B": 1} and q.unlock_counts == {"A": 2, "B": 0}
    assert q.chatter and any("chatter: A locked 1 and unlocked 2 times" in n for n in q.notes)
    assert q.offgoing_unlock == 1.35


def test_vehicle_acceleration_is_the_force_balance():
    """The driveline's vehicle_accel integrates to the vehicle speed (it is the exact derivative of
    the speed state, not a differenced signal); a driveline without a vehicle mass has none."""
    from transgen.sim.scenario.load import load_scenario

    r = load_scenario("ht740_improved", {"simulation.t_end": 3.0}).run()
    t, a, v = r.time, r["vehicle_accel"], r["vehicle_speed"]
    assert r.units["vehicle_accel"] == "m/s^2" and r.units["vehicle_jerk"] == "m/s^3"
    for t0, t1 in ((0.5, 1.0), (1.0, 3.0)):
        assert integrate(t, a, t0, t1) == pytest.approx(np.interp(t1, t, v) - np.interp(t0, t, v), rel=1e-4)
    assert not {"vehicle_accel", "vehicle_jerk"} & set(load_scenario("simple2_upshift", {"simulation.t_end": 4.1})
                                                       .run().signals)


def test_vehicle_jerk_is_the_exact_derivative():
    """vehicle_jerk integrates to the change of vehicle_accel across the C5 unlock and the C4 lock
    of the original 1-2 (finely sampled: the jerk jumps at the unlock and decays within
    milliseconds); the differenced jerk of coarse samples misses that peak, the exact one does not
    depend on the sampling."""
    from transgen.sim.analysis.comfort import jerk
    from transgen.sim.scenario.load import load_scenario

    fine = load_scenario("ht740_original", {"simulation.t_end": 5.6, "simulation.output_dt": 2e-4}).run()
    t, a, j = fine.time, fine["vehicle_accel"], fine["vehicle_jerk"]
    for t0, t1 in ((1.0, 3.0), (4.0, 5.1), (5.07, 5.3)):
        assert integrate(t, j, t0, t1) == pytest.approx(np.interp(t1, t, a) - np.interp(t0, t, a), rel=1e-3)
    coarse = load_scenario("ht740_original", {"simulation.t_end": 5.6}).run()  # output_dt 5 ms
    (qf,), (qc,) = shift_report(fine), shift_report(coarse)
    assert qc.jerk_max == pytest.approx(qf.jerk_max, rel=1e-6) and qc.jerk_max_time == qf.jerk_max_time
    _, differenced = jerk(coarse.time, coarse["vehicle_accel"])
    assert np.max(np.abs(differenced)) < 0.95 * qc.jerk_max


def test_sweep_rows_carry_the_comfort_scalars():
    from transgen.sim.scenario.load import load_scenario
    from transgen.sim.study.table import column_unit
    from transgen.sim.study.task import result_scalars

    sc = load_scenario("ht740_improved", {"simulation.t_end": 5.5})
    row = result_scalars(sc, sc.run())
    for k in ("accel_before", "accel_after", "jerk_max", "jerk_peak_to_peak", "vdv", "torque_overshoot",
              "settling_time", "shift_duration", "lock_counts.C4", "unlock_counts.C5", "peak_power.C4"):
        assert isinstance(row[f"shift.1-2.{k}"], float | int), k
    assert row["shift.1-2.vdv_weighting"] == "Wd" and row["shift.1-2.chatter"] is False
    assert row["shift.1-2.forced_unlock"] is False and row["shift.1-2.forced_unlock_element"] is None
    assert row["shift.1-2.lock_counts.C4"] == 1 and row["shift.1-2.unlock_counts.C5"] == 1
    for prefix in ("shift.1-2", "shift1"):  # a table written before shifts were named by gear
        assert [column_unit(f"{prefix}.{k}") for k in ("jerk_max", "vdv", "accel_after", "lock_counts.C4")] == [
            "m/s^3", "m/s^1.75", "m/s^2", "1"]


# --------------------------------------------------------------------------- simple2 1-2 upshift
def run_simple2(c1=((0, 5.2, 5.3), (1, 1, 0)), c2=((0, 5.0, 5.5), (0, 0, 1))) -> Result:
    """Thesis 3.3.1 simple transmission, 400 N*m input, driveshaft 12000 N*m/rad, 200 N*m*s/rad,
    100 kg*m^2 output inertia; C2 ramps on over 5.0-5.5 s, C1 off over 5.2-5.3 s."""
    m = load_mechanism("simple2")
    from transgen.sim.model.transmission import Transmission

    tr = Transmission(m, {"C1": {"apply": Table(*c1)}, "C2": {"apply": Table(*c2)}})
    n = null_space(constraint_matrix(tr.graph, ["C1"]), len(tr.links))
    w0 = n[:, 0] / n[0, 0] * 150.0
    comps = [InputTorque(Constant(400.0), tr.link_index["Li"]),
             Driveline(tr.link_index["Lo"], 12000, 200, J_out=100.0)]
    r = simulate(Powertrain(tr, comps, w0), SolverOptions(t_end=8.0, t_start=4.0))
    assert r.success, r.message
    r.meta.update(input_link="Li", output_link="Lo")
    return r


@pytest.fixture(scope="module")
def s2():
    r = run_simple2()
    return r, shift_report(r)


def test_simple2_phases(s2):
    r, qs = s2
    assert len(qs) == 1
    q = qs[0]
    unlock = [e.t for e in r.events if e.kind == "unlock"][0]
    lock = [e.t for e in r.events if e.kind == "lock"][0]
    assert (q.oncoming, q.offgoing, q.name, q.t_start, q.direction) == ("C2", "C1", "1-2", 5.0, "upshift")
    assert q.torque_phase_start == pytest.approx(5.0, abs=1e-9)
    assert q.torque_phase_end == unlock == q.inertia_phase_start
    assert unlock == pytest.approx(5.25, abs=0.01)
    assert q.inertia_phase_end == lock == q.shift_end
    assert lock == pytest.approx(5.76, abs=0.01)
    assert q.torque_phase_start < q.torque_phase_end < q.inertia_phase_end
    assert q.shift_duration == pytest.approx(lock - 5.0)
    assert q.ratio_before == pytest.approx(20 / 3, rel=1e-6)
    assert q.ratio_after == pytest.approx(40 / 11, rel=1e-6)


def test_simple2_torque_phase_physics(s2):
    r, (q,) = s2
    # the speeds hardly change in the torque phase, the ratio holds exactly (C1 locked)
    t = r.time
    i = (t >= q.torque_phase_start) & (t < q.torque_phase_end)
    ratio = r["w_Li"][i] / r["w_Lo"][i]
    assert np.allclose(ratio, 20 / 3, rtol=1e-9)
    # torque hole: output torque falls to its minimum at the C1 unlock
    assert q.torque_hole > 0 and q.torque_hole_pct > 0
    assert q.output_torque_min_time == pytest.approx(q.torque_phase_end, abs=2e-3)
    # the speed phase carries the inertia torque: the output torque peaks above the pre-shift value
    assert q.output_torque_max > q.output_torque_before
    assert q.inertia_phase_start <= q.output_torque_max_time <= q.inertia_phase_end


def test_simple2_bindup_and_release(s2):
    r, (q,) = s2
    # C1 stays fully applied until 5.2 s: it is released late, its torque reverses (bindup) and it
    # unlocks when that reversed torque reaches its static capacity 1000 N*m * apply
    assert q.bindup
    assert q.offgoing_torque_before < 0 < q.offgoing_torque_at_unlock
    apply_at_unlock = 1.0 - (q.offgoing_unlock - 5.2) / 0.1
    assert q.offgoing_torque_at_unlock == pytest.approx(1000.0 * apply_at_unlock, rel=1e-6)
    assert q.bindup_torque == pytest.approx(q.offgoing_torque_at_unlock, rel=1e-3)
    assert 0.0 < q.bindup_duration < q.torque_phase_duration
    # late release: C1 slips (and dissipates) in the reversed direction until its apply is 0; it
    # unlocked because its apply fell (half released), so it was not forced to unlock
    assert not q.forced_unlock and 0.0 < q.both_dissipating_duration < 0.05
    assert q.forced_duration == pytest.approx(q.both_dissipating_duration, rel=1e-6)
    assert q.energy["C1"] < 0.01 * q.energy["C2"]
    # no flare: the input only slows down
    assert not q.flare and q.flare_max < 0.1


def test_simple2_ramp_and_energy(s2):
    r, (q,) = s2
    assert q.oncoming_ramp_end == pytest.approx(5.5, abs=1e-9)
    assert q.speed_phase_past_ramp
    assert q.speed_phase_overrun == pytest.approx(q.oncoming_lock - 5.5)
    # element energies + driveshaft damping = the dissipated-energy integral of the run
    t = r.time
    damper = 200.0 * (r["w_Lo"] - r["omega_v"]) ** 2
    whole = sum(integrate(t, r[f"P_{e}"], t[0], t[-1]) for e in ("C1", "C2")) + integrate(t, damper, t[0], t[-1])
    assert whole == pytest.approx(r.energy["dissipated"], rel=1e-5)
    e_diss = r["E_dissipated"]
    window = np.interp(q.shift_end, t, e_diss) - np.interp(q.t_start, t, e_diss) - integrate(
        t, damper, q.t_start, q.shift_end)
    assert q.energy_total == pytest.approx(window, rel=1e-4)
    assert q.peak_power["C2"] > 0
    eb = energy_balance(r)
    assert eb["passed"] and eb["relative_residual"] < 1e-6


def test_simple2_report_text(s2):
    r, qs = s2
    text = report_text(r, qs)
    assert "Shift 1-2 (upshift): oncoming C2, offgoing C1" in text and "PASS" in text
    json.dumps(report_dict(r, qs), allow_nan=False)


def test_simple2_variants():
    base = shift_report(run_simple2())[0]
    # releasing C1 at its torque reversal (5.1-5.2 s) shrinks the bindup and the torque hole
    timed = shift_report(run_simple2(c1=((0, 5.1, 5.2), (1, 1, 0))))[0]
    assert timed.bindup_torque < 0.5 * base.bindup_torque
    assert timed.torque_hole < 0.5 * base.torque_hole
    assert timed.energy_total < base.energy_total
    # releasing C1 before C2 takes torque (4.9-5.0 s): flare, no torque phase, no bindup
    r = run_simple2(c1=((0, 4.9, 5.0), (1, 1, 0)))
    (early,) = shift_report(r)
    assert early.t_start == pytest.approx(4.9)  # inferred from the start of the release ramp
    assert early.offgoing_unlock < 5.0 and early.torque_phase_duration == 0.0
    assert early.flare and early.flare_max > 1.0
    assert early.flare_max_rpm == pytest.approx(early.flare_max * RPM_PER_RAD_S)
    assert not early.bindup
    assert any("early release" in n for n in early.notes)


def test_simple2_release_while_applied_is_not_forced():
    # C1 drops to 30 % at 5.0 s (below the torque it carries) and decays to 0 at 5.4 s: it slips its
    # normal way, re-locks, and is finally released with a small reversed torque
    r = run_simple2(c1=((0, 4.99, 5.0, 5.4), (1, 1, 0.3, 0)))
    (q,) = shift_report(r)
    unlocks = [e.t for e in r.events if e.kind == "unlock"]
    assert len(unlocks) == 2 and q.t_start == pytest.approx(4.99)
    assert q.offgoing_unlock == unlocks[-1] == q.inertia_phase_start  # the final release
    assert q.torque_phase_start == pytest.approx(5.0) and q.torque_phase_duration > 0.1
    assert any("re-locked" in n for n in q.notes)
    assert q.both_dissipating_duration > 0.005 and q.forced_duration < 0.005 and not q.forced_unlock
    assert any("its normal way" in n for n in q.notes)


def test_ht740_thesis_findings():
    """Thesis 3.4.4 on the bundled HT-740 scenarios: the original trajectories bind up at every
    shift, their first two speed phases run past the oncoming ramp, and at the 3-4 shift the
    oncoming element forces the offgoing one to unlock (the largest offgoing dissipation); the
    improved trajectories shrink the torque holes and the dissipated energy of every shift."""
    from transgen.sim.scenario.load import load_scenario

    def run(name):
        sc = load_scenario(name)
        r = sc.run()
        assert r.success, r.message
        qs = shift_report(r, sc.shifts or None)
        assert [(q.oncoming, q.offgoing) for q in qs] == [("C4", "C5"), ("C3", "C4"), ("C2", "C3")]
        assert all(q.completed for q in qs) and energy_balance(r)["passed"]
        # "All shifts were made when the engine speed reached approximately 1800 revolutions per
        # minute"; "accelerated from zero speed to approximately 27 miles per hour over twenty seconds"
        engine = [np.interp(q.t_start, r.time, r["omega_engine"]) * RPM_PER_RAD_S for q in qs]
        assert all(abs(x - 1800.0) < 0.03 * 1800.0 for x in engine), engine
        assert abs(r["vehicle_speed_mph"][-1] - 27.0) < 1.5
        return qs

    orig, impr = run("ht740_original"), run("ht740_improved")
    assert all(q.bindup for q in orig)
    assert [q.speed_phase_past_ramp for q in orig] == [True, True, False]
    assert orig[2].forced_unlock
    assert orig[2].offgoing_energy_share > max(orig[0].offgoing_energy_share, orig[1].offgoing_energy_share)
    # C3 (static capacity 1100 N*m) keeps slipping against the locked C2 after the lock
    assert orig[2].offgoing_drag_after_lock > 0.1 and orig[2].dissipation_end > orig[2].shift_end
    assert orig[2].offgoing_energy_share > 10.0
    assert all(q.offgoing_energy_share < 5.0 and q.offgoing_drag_after_lock == 0.0 for q in impr)
    for a, b in zip(orig, impr):
        assert b.torque_hole < a.torque_hole
        assert b.energy_total < a.energy_total
        assert b.bindup_torque < a.bindup_torque
        # the improved shifts give a smaller vibration dose (in the flaring improved 2-3, C4 dropped
        # to its holding pressure lets go abruptly at 9.02 s, so its peak jerk is hardly lower,
        # 32 against 33 m/s^3: compared below for the 1-2 and 3-4 only)
        assert b.vdv < a.vdv
    assert impr[0].jerk_max < 0.5 * orig[0].jerk_max and impr[2].jerk_max < orig[2].jerk_max
    # the 3-4 anomaly: only there is the offgoing C3 forced to unlock while fully applied; the
    # late releases of the first two shifts (bindup) and every improved shift are ordinary
    assert [(q.forced_unlock, q.forced_unlock_element) for q in orig] == [(False, None), (False, None), (True, "C3")]
    assert not any(q.forced_unlock for q in impr)
    assert not any(q.chatter for q in orig + impr)
    for q in orig + impr:
        assert q.vdv_weighting == "Wd" and q.vdv > 0 and q.jerk_peak_to_peak >= q.jerk_max > 0
        assert q.accel_before > q.accel_after > 0  # an upshift: less tractive force in the higher gear
        assert q.shift_duration == pytest.approx(q.shift_end - q.t_start)


def test_ht740_improved_chatter_at_constant_throttle():
    """At the constant throttle 0.72 the scenarios had before their shifts were put at 1800 rpm,
    the improved 3-4 chatters: C3, dropped to its 30 % holding pressure, slips, re-locks and slips
    again before C2 locks (issue 12: 'C3 locks and unlocks repeatedly in the 3-4'). The bundled
    file now holds C4 and C3 at 53 % (issue 27); the earlier holding levels and release times are
    set back here, and with the bundled ones the same throttle gives no chatter."""
    from transgen.sim.scenario.load import load_scenario

    new = load_scenario("ht740_improved", {"input.throttle_signal": 0.72})
    rn = new.run()
    assert not any(q.chatter or q.flare for q in shift_report(rn, new.shifts or None))
    sc = load_scenario("ht740_improved", {"input.throttle_signal": 0.72,
                                          "elements.C4.apply.value.4": 0.35, "elements.C4.apply.t.5": 9.3,
                                          "elements.C3.apply.value.4": 0.3, "elements.C3.apply.t.5": 17.15})
    r = sc.run()
    qs = shift_report(r, sc.shifts or None)
    assert [q.chatter for q in qs] == [False, False, True]
    q = qs[2]
    assert (q.unlock_counts["C3"], q.lock_counts["C3"], q.lock_counts["C2"], q.unlock_counts["C2"]) == (2, 1, 1, 0)
    unlocks = [e.t for e in r.events if e.kind == "unlock" and e.elements == ("C3",)]
    assert len(unlocks) == 2 and q.offgoing_unlock == unlocks[-1] and not q.forced_unlock
    assert qs[1].flare_max_rpm == pytest.approx(165.5, abs=1.0)  # the 2-3 flare the issue quotes


def test_oneway_release_downshift_is_inferred():
    """A release to a one-way clutch (bundled oneway_overrun scenario): the C2 upshift off the
    freewheel is a perfect shift (no bindup, small torque hole); the release of C2 at 2.5 s hands
    back to the one-way clutch F1 - a downshift with its speed phase first and no apply ramp."""
    from transgen.sim.scenario.load import load_scenario

    r = load_scenario("oneway_overrun").run()
    assert r.success, r.message
    up, down = shift_report(r)
    assert (up.oncoming, up.offgoing, up.direction) == ("C2", "F1", "upshift")
    assert not up.bindup and up.offgoing_torque_at_unlock == pytest.approx(0.0, abs=1e-6)
    assert 0 < up.torque_hole_pct < 10.0
    assert (down.oncoming, down.offgoing, down.direction, down.t_start) == ("F1", "C2", "downshift", 2.5)
    assert down.completed and down.inertia_phase_start < down.inertia_phase_end == down.shift_end
    assert down.torque_phase_duration == 0.0 and down.oncoming_ramp_end is None
    assert not down.speed_phase_past_ramp and not down.flare
    assert any("downshift" in n for n in down.notes)
