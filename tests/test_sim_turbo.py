"""Compressor, turbine and the two turbocharger algorithms (thesis 4.3-4.6)."""
import math
import warnings

import pytest

from transgen.errors import SimulationError
from transgen.sim.engine import (AIR, EXHAUST, RPM, TurbochargedDiesel, compression_outlet_temperature,
                                 default_compressor_table, default_turbine_table,
                                 expansion_outlet_temperature)
from transgen.sim.engine.compressor import Compressor
from transgen.sim.engine.turbine import Turbine
from transgen.sim.engine.turbocharger import (BasicTurbo, ChokedFlowError, IterativeTurbo, PortAreas,
                                              TurboConvergenceError, TurboShaft, make_turbo,
                                              mach_from_total_temperature, mach_number, total_pressure,
                                              total_temperature)

P_AMB, T_AMB = 101111.34, 298.46
HIGH_FLOW = (P_AMB, T_AMB, 2.7e5, 2.9e5, 850.0, P_AMB, 90_000 * RPM)   # mid-map (chi ~0.5) near rated
LOW_FLOW = (P_AMB, T_AMB, 1.05e5, 1.08e5, 500.0, P_AMB, 30_000 * RPM)


@pytest.fixture(autouse=True)
def _quiet_maps():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        yield


def test_isentropic_relations():
    assert compression_outlet_temperature(300.0, 2.5, 1.0, AIR) == pytest.approx(
        300.0 * 2.5 ** ((AIR.gamma - 1) / AIR.gamma))
    assert expansion_outlet_temperature(900.0, 2.5, 1.0, EXHAUST) == pytest.approx(
        900.0 * 2.5 ** (-(EXHAUST.gamma - 1) / EXHAUST.gamma))
    assert AIR.gamma == pytest.approx(1.39640884, rel=1e-6)


def test_compressor_energy_sanity():
    c = Compressor(default_compressor_table())
    for pr in (1.3, 2.0, 2.7):
        pt = c.operate(P_AMB, T_AMB, pr * P_AMB, 100_000 * RPM)
        t_isentropic = T_AMB * pr ** AIR.kappa
        assert pt.T_out > t_isentropic > T_AMB           # real compression is hotter
        assert pt.power == pytest.approx(pt.m_dot * AIR.cp * (pt.T_out - T_AMB))
        assert pt.torque * 100_000 * RPM == pytest.approx(pt.power)       # eq. 4.8
        assert pt.eta == pytest.approx((t_isentropic - T_AMB) / (pt.T_out - T_AMB))  # eq. 4.39


def test_turbine_energy_sanity():
    t = Turbine(default_turbine_table())
    pt = t.operate(3.0e5, 850.0, P_AMB, 90_000 * RPM)
    t_isentropic = 850.0 * (P_AMB / 3.0e5) ** EXHAUST.kappa
    assert t_isentropic < pt.T_out < 850.0
    assert 0 < pt.power < pt.m_dot * EXHAUST.cp * (850.0 - t_isentropic)
    assert pt.eta == pytest.approx((850.0 - pt.T_out) / (850.0 - t_isentropic))  # eq. 4.41


def test_mach_relations():
    m, p, T0, area = 0.6, 1.0e5, 700.0, 0.008
    M = mach_from_total_temperature(m, p, T0, area, EXHAUST)
    T = T0 / (1 + 0.5 * (EXHAUST.gamma - 1) * M * M)
    assert mach_number(m, p, T, area, EXHAUST) == pytest.approx(M, rel=1e-12)    # eq. 4.36
    assert total_temperature(T, M, EXHAUST) == pytest.approx(T0)                 # eq. 4.34
    assert total_pressure(p, M, EXHAUST) / p == pytest.approx(
        (T0 / T) ** (EXHAUST.gamma / (EXHAUST.gamma - 1)))                      # eq. 4.35


def test_basic_turbo_outputs_and_torque_balance():
    tp = BasicTurbo().evaluate(*HIGH_FLOW)
    s = tp.signals()
    assert s["PR_c"] == pytest.approx(2.7e5 / P_AMB) and s["ER_t"] == pytest.approx(2.9e5 / P_AMB)
    assert 0 < s["chi"] < 1 and s["m_dot_c"] > 0 and s["m_dot_t"] > 0
    assert tp.omega_dot == pytest.approx((s["torque_t"] - s["torque_c"]) / 2.0e-4)
    assert s["mach_c_in"] == 0.0


def test_iterative_at_the_same_boundary_conditions():
    """Thesis 4.6: lower chi = more corrected flow at a given turbo speed; at low flow the two
    algorithms nearly agree."""
    b, it = BasicTurbo().evaluate(*HIGH_FLOW), IterativeTurbo().evaluate(*HIGH_FLOW)
    assert it.compressor.chi < b.compressor.chi
    assert it.compressor.m_dot > b.compressor.m_dot
    assert it.turbine.expansion_ratio < b.turbine.expansion_ratio     # outlet Mach number
    assert 0.1 < it.mach[3] < 0.5
    bl, il = BasicTurbo().evaluate(*LOW_FLOW), IterativeTurbo().evaluate(*LOW_FLOW)
    assert abs(il.compressor.m_dot / bl.compressor.m_dot - 1) < 1e-2
    assert abs(il.compressor.m_dot / bl.compressor.m_dot - 1) < \
        abs(it.compressor.m_dot / b.compressor.m_dot - 1)


def test_iterative_solution_is_consistent_and_warm_started():
    turbo = IterativeTurbo()
    first = turbo.evaluate(*HIGH_FLOW)
    # both rows of the warm start (m/m_basic, T02/T_basic, slope) hold the last solutions
    assert (turbo._warm != 1.0).all()
    again = turbo.evaluate(*HIGH_FLOW)
    assert again.compressor.m_dot == pytest.approx(first.compressor.m_dot, rel=1e-12)
    # the solution satisfies eq. 4.36 with the static outlet temperature of eq. 4.34
    c, M1, M2 = first.compressor, first.mach[0], first.mach[1]
    assert M1 == pytest.approx(mach_number(c.m_dot, P_AMB, T_AMB, PortAreas().compressor_inlet,
                                           AIR), rel=1e-9)
    assert c.pressure_ratio == pytest.approx(total_pressure(2.7e5, M2, AIR)
                                             / total_pressure(P_AMB, M1, AIR), rel=1e-9)


def test_iterative_failures_raise(monkeypatch):
    with pytest.raises(TurboConvergenceError, match="did not converge"):
        IterativeTurbo(maxiter=1).evaluate(*HIGH_FLOW)
    # the bracketed fallback converges the outlet temperature fully, within its bound
    monkeypatch.setattr(IterativeTurbo, "secant_iterations", 0)
    with pytest.raises(TurboConvergenceError, match="outlet total temperature"):
        IterativeTurbo(inner_maxiter=1).evaluate(*HIGH_FLOW)
    monkeypatch.undo()
    tiny = PortAreas(compressor_inlet=1e-4)
    with pytest.raises(ChokedFlowError, match="compressor.*choked") as err:
        IterativeTurbo(ports=tiny).evaluate(*HIGH_FLOW)
    assert isinstance(err.value, SimulationError)


def test_shaft_damping_and_low_speed_guard():
    shaft = TurboShaft(c1=1e-5, c2=4.9e-9)
    w = 100_000 * RPM
    assert shaft.damping(w) == pytest.approx(1e-5 * w + 4.9e-9 * w * w)
    assert shaft.acceleration(5.0, 4.0, w) < TurboShaft().acceleration(5.0, 4.0, w)
    assert shaft.damping(-w) == -shaft.damping(w)
    # at a standing rotor the torques stay finite and the speed does not go below the floor
    tp = BasicTurbo().evaluate(P_AMB, T_AMB, P_AMB, 1.5e5, 700.0, P_AMB, 0.0)
    assert math.isfinite(tp.turbine.torque) and tp.turbine.torque > 0
    assert TurboShaft().acceleration(0.0, 1.0, 0.0) == 0.0


def test_make_turbo():
    assert isinstance(make_turbo("iterative"), IterativeTurbo)
    assert type(make_turbo("basic")) is BasicTurbo
    with pytest.raises(ValueError, match="unknown turbocharger algorithm"):
        make_turbo("magic")


def test_algorithms_on_engine_steady_states(capsys):
    """Thesis 4.6: virtually the same at low flow, larger differences at high flow, and the
    iterative (kinetic-energy) algorithm predicts a lower turbo speed."""
    basic, iterative = TurbochargedDiesel(turbo="basic"), TurbochargedDiesel(turbo="iterative")
    rows = []
    for rpm, mg in ((800, 40), (1500, 110), (1900, 200)):
        sb = basic.steady_state(rpm * RPM, mg * 1e-6)
        si = iterative.steady_state(rpm * RPM, mg * 1e-6, guess=sb.state)
        rows.append((rpm, mg, sb.signals["m_dot_c"], sb.turbo_speed, si.turbo_speed,
                     sb.signals["chi"], si.signals["chi"]))
    with capsys.disabled():
        print("\n rpm   mg  m_c[kg/s]  n_tc basic/iter [krpm]   d_n_tc   chi basic/iter")
        for rpm, mg, m, nb, ni, cb, ci in rows:
            print(f"{rpm:5d} {mg:4d}  {m:8.3f}   {nb / RPM / 1e3:7.2f} / {ni / RPM / 1e3:7.2f}"
                  f"   {100 * (ni / nb - 1):+6.2f} %   {cb:.3f} / {ci:.3f}")
    rel = [r[4] / r[3] - 1 for r in rows]
    assert all(d < 0 for d in rel)                      # iterative: lower turbo speed
    assert abs(rel[0]) < 0.003                          # low flow: virtually the same
    assert min(abs(rel[1]), abs(rel[2])) > 3 * abs(rel[0])


def test_secant_fast_path_and_bracketed_fallback_agree(monkeypatch):
    fast = IterativeTurbo().evaluate(*HIGH_FLOW)
    monkeypatch.setattr(IterativeTurbo, "secant_iterations", 0)
    slow = IterativeTurbo().evaluate(*HIGH_FLOW)
    for a, b in ((fast.compressor, slow.compressor), (fast.turbine, slow.turbine)):
        assert a.m_dot == pytest.approx(b.m_dot, rel=1e-10) and a.T_out == pytest.approx(b.T_out, rel=1e-10)
    assert fast.mach == pytest.approx(slow.mach, rel=1e-8)
