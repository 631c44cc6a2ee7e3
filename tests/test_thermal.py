"""The lumped clutch thermal model (transgen.losses.thermal): closed forms and the shift report."""
from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from transgen.losses.thermal import (ClutchPack, class_packs, clutch_temperatures, default_packs,
                                     pack_from_geometry, shift_temperatures, temperature_response)

OIL = 80.0


def test_adiabatic_rise_is_the_energy_over_m_c_for_any_sampling():
    pack = ClutchPack(2.0, 470.0, 0.0)
    rng = np.random.default_rng(3)
    t = np.sort(np.concatenate([[0.0, 1.0], rng.uniform(0, 1, 7)]))
    p = rng.uniform(0, 5e4, len(t))
    temp, peak, _ = temperature_response(t, p, pack, OIL)
    energy = float(np.sum(0.5 * (p[1:] + p[:-1]) * np.diff(t)))  # exact for piecewise-linear power
    assert temp[-1] - OIL == pytest.approx(energy / (2.0 * 470.0), rel=1e-13)
    assert peak == pytest.approx(temp[-1]) and np.all(np.diff(temp) >= 0)


def test_cooling_decays_with_the_time_constant_m_c_over_h_a():
    pack = ClutchPack(1.5, 470.0, 90.0)
    tau = 1.5 * 470.0 / 90.0
    assert pack.time_constant == pytest.approx(tau)
    # constant power to 0.5 s, then nothing; sampled coarsely: still exact
    t = np.array([0.0, 0.5, 0.5, 2.0, 7.0, 20.0])
    p = np.array([2e4, 2e4, 0.0, 0.0, 0.0, 0.0])
    temp, peak, peak_t = temperature_response(t, p, pack, OIL)
    theta_end = 2e4 / 90.0 * (1 - math.exp(-0.5 / tau))
    assert temp[1] - OIL == pytest.approx(theta_end, rel=1e-13)
    for k in (3, 4, 5):
        assert temp[k] - OIL == pytest.approx(theta_end * math.exp(-(t[k] - 0.5) / tau), rel=1e-12)
    assert peak == pytest.approx(temp[1]) and peak_t == 0.5


def test_a_ramp_matches_a_fine_ode_solution():
    pack = ClutchPack(0.8, 480.0, 60.0)
    t = np.array([0.0, 0.3, 1.1, 2.0])
    p = np.array([0.0, 3e4, 1e4, 0.0])

    def rhs(s, y):
        return [(np.interp(s, t, p) - pack.conductance * y[0]) / pack.heat_capacity]

    ref = solve_ivp(rhs, (0, 2.0), [0.0], t_eval=t, rtol=1e-12, atol=1e-12, max_step=1e-3)
    temp, _, _ = temperature_response(t, p, pack, OIL)
    assert np.allclose(temp - OIL, ref.y[0], rtol=1e-8, atol=1e-8)


def test_a_peak_between_samples_is_found():
    pack = ClutchPack(0.5, 470.0, 200.0)  # tau 1.2 s
    t = np.array([0.0, 0.2, 10.0])
    p = np.array([0.0, 5e4, 0.0])  # the rise goes on after the power's peak, until P = G theta
    temp, peak, peak_t = temperature_response(t, p, pack, OIL)
    fine = np.linspace(0, 10, 200001)
    temp_f, _, _ = temperature_response(fine, np.interp(fine, t, p), pack, OIL)
    assert peak > temp.max() + 1.0
    assert peak == pytest.approx(temp_f.max(), abs=1e-6)
    assert peak_t == pytest.approx(fine[np.argmax(temp_f)], abs=1e-3)


def test_pack_from_geometry_and_the_class_packs():
    pack = pack_from_geometry(4, 0.0022, 0.064, 0.085, 7850.0, 470.0, 1000.0)
    area = math.pi * (0.085 ** 2 - 0.064 ** 2)
    assert pack.mass == pytest.approx(4 * area * 0.0022 * 7850)
    assert pack.conductance == pytest.approx(1000.0 * 8 * area)
    classes = class_packs()
    assert set(classes) >= {"car", "truck"}
    car, truck = classes["car"][0], classes["truck"][0]
    assert car.heat_capacity == pytest.approx(pack.heat_capacity)
    assert truck.heat_capacity > 3 * car.heat_capacity
    assert 1.0 < car.time_constant < 20.0 and 1.0 < truck.time_constant < 20.0
    packs = default_packs({"C1": 700.0, "C5": 8400.0, "F1": math.inf})
    assert packs["C1"] == car.scaled(1.0, packs["C1"].name)
    assert packs["C5"].heat_capacity == pytest.approx(2 * truck.heat_capacity)
    assert packs["F1"] == car


def test_the_shift_report_gives_each_shifts_rise_and_the_run_its_peaks():
    from transgen.sim import load_scenario
    from transgen.sim.analysis.report import report_dict, report_text
    from transgen.sim.analysis.shift_quality import shift_report

    r = load_scenario("simple2_upshift").run()
    (q,) = shift_report(r)
    on = q.oncoming
    thermal = clutch_temperatures(r)
    pack = thermal.packs[on]
    assert 0 < q.temperature_rise[on] <= q.energy[on] / pack.heat_capacity
    # adiabatic packs: the rise is the shift energy over m c (the energy from t_start to the end)
    adiabatic = {e: ClutchPack(p.mass, p.specific_heat, 0.0) for e, p in thermal.packs.items()}
    th = clutch_temperatures(r, adiabatic)
    start, peak, rise = shift_temperatures(th, q.t_start, q.dissipation_end)[on]
    assert rise == pytest.approx(q.energy[on] / pack.heat_capacity, rel=1e-9)
    summary = report_dict(r, [q])["clutch_temperature"]
    assert summary["elements"][on]["peak"] == pytest.approx(thermal.peaks[on])
    assert "Clutch temperatures" in report_text(r, [q])


def test_optimize_max_temperature_is_a_constraint():
    from transgen.sim.study.optimize import Constraints, Objective, score

    ref = {"success": True, "completed": True, "energy": 1000.0, "duration": 0.5, "hole": 40.0, "flare": 0.0,
           "bindup": False, "bindup_torque": 0.0, "offgoing_torque": 100.0, "chatter": False, "locks": 1, "jerk": None,
           "temperature": 150.0}
    c = Constraints(max_temperature=140.0)
    s, _, violations = score(ref, ref, Objective({"energy": 1.0}), c)
    assert s > 1e3 and violations == {"max temperature": pytest.approx(10.0 / 140.0)}
    s, _, violations = score({**ref, "temperature": 130.0}, ref, Objective({"energy": 1.0}), c)
    assert s == pytest.approx(1.0) and not violations
    assert "pack temperature <= 140 degC" in c.text()


def test_a_long_run_over_many_time_constants_reaches_the_steady_state():
    pack = ClutchPack(0.5, 470.0, 100.0)  # tau 2.35 s; 2000 s is some 850 tau: several blocks
    t = np.linspace(0.0, 2000.0, 5001)
    temp, peak, _ = temperature_response(t, np.full(len(t), 3000.0), pack, OIL)
    exact = OIL + 3000.0 / 100.0 * (1 - np.exp(-t / pack.time_constant))
    assert np.allclose(temp, exact, rtol=1e-12, atol=1e-9)
    assert peak == pytest.approx(OIL + 30.0)


def test_sweep_columns_of_the_pack_temperatures_have_units():
    from transgen.sim.study.table import column_unit

    assert column_unit("shift.1-2.temperature_peak.C4") == "degC"
    assert column_unit("shift.1-2.temperature_start.C4") == "degC"
    assert column_unit("shift.2-3#2.temperature_rise.C3") == "K"


def test_two_node_model_conserves_energy_and_matches_an_ode_solution():
    from transgen.losses.thermal import TwoNodePack, two_node_response

    t = np.array([0.0, 0.2, 0.5, 3.0])
    p = np.array([0.0, 4e4, 1e4, 0.0])
    adiabatic = TwoNodePack(steel=400.0, lining=60.0, partition=0.7, between=30.0, steel_oil=0.0)
    temp = two_node_response(t, p, adiabatic, OIL)
    energy = float(np.sum(0.5 * (p[1:] + p[:-1]) * np.diff(t)))
    assert (temp[-1] - OIL) @ np.array([400.0, 60.0]) == pytest.approx(energy, rel=1e-12)
    pack = TwoNodePack(steel=400.0, lining=60.0, partition=0.7, between=30.0, steel_oil=80.0, lining_oil=5.0)
    a_mat, b_vec = pack.system()
    ref = solve_ivp(lambda s, y: a_mat @ y + b_vec * np.interp(s, t, p), (0, 3.0), [0.0, 0.0], t_eval=t,
                    rtol=1e-12, atol=1e-12, max_step=1e-3)
    assert np.allclose(two_node_response(t, p, pack, OIL) - OIL, ref.y.T, rtol=1e-8, atol=1e-8)
