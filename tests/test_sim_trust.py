"""A run is physically right on every solver, or it stops naming the invariant, element and time.

Regression tests for the silent wrong results of issue 10 (each checked against its closed form),
and tests that the invariant monitor stops a run that breaks physics.
"""
from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from transgen.sim.solve.monitor import INVARIANTS, InvariantMonitor, InvariantViolation
from transgen.sim.scenario.load import load_scenario

SOLVERS = ["DOP853", "RK45", "LSODA", "Radau", "BDF"]

TWO = """transmission "two inertias and a clutch"
link A J=1
link B J=1
clutch C A B static=10 dynamic=10
input A
output B
"""


def scenario(tmp_path, body: str, mech: str | None = TWO, method: str = "DOP853", **options):
    if mech is not None:
        (tmp_path / "two.mech").write_text(mech)
    path = tmp_path / "s.toml"
    path.write_text(body)
    sc = load_scenario(path)
    sc.options = replace(sc.options, method=method, **options)
    return sc


def clutch_body(apply: str, t_end: float, speeds="{ A = 0.0, B = 0.0 }", torque=5.0, extra=""):
    return f"""mechanism = "two.mech"
[simulation]
t_end = {t_end}
[initial]
speeds = {speeds}
{extra}
[input]
type = "torque"
torque = {torque}
[elements.C]
apply = {apply}
"""


def lock_times(result, kind="lock"):
    return [e.t for e in result.events if e.kind == kind]


def sine_lock_time() -> float:
    """Two unit inertias, 5 N*m on A, clutch 10*sin(2 pi t): the slip 5t - (10/pi)(1 - cos 2 pi t)
    returns to zero (the clutch locks) at the root of this function."""
    from scipy.optimize import brentq

    return brentq(lambda t: 5 * t - 10 / math.pi * (1 - math.cos(2 * math.pi * t)), 0.02, 0.2)


@pytest.mark.parametrize("method", SOLVERS)
def test_apply_rising_from_zero_at_rest_locks(tmp_path, method):
    sine = '{ type = "sine", offset = 0.0, amplitude = 1.0, frequency = 1.0 }'
    r = scenario(tmp_path, clutch_body(sine, 0.3), method=method).run()
    assert r.success, r.message
    assert lock_times(r) == pytest.approx([sine_lock_time()], abs=1e-4)
    assert r.energy["dissipated"] > 0


@pytest.mark.parametrize("method", SOLVERS)
def test_started_locked_with_zero_apply_slips_then_locks_without_creating_energy(tmp_path, method):
    sine = '{ type = "sine", offset = 0.0, amplitude = 1.0, frequency = 1.0 }'
    body = clutch_body(sine, 0.3, speeds="{ A = 10.0, B = 10.0 }", extra='locked = ["C"]')
    r = scenario(tmp_path, body, method=method).run()
    assert r.success, r.message
    assert lock_times(r) == pytest.approx([sine_lock_time()], abs=1e-4)
    assert r.energy["dissipated"] >= 0
    slipping = r.signals["locked_C"] == 0
    t_c, slip = r.signals["t_C"][slipping], r.signals["slip_C"][slipping]
    assert np.all(t_c * slip >= -1e-6 * np.abs(t_c))  # the slip tolerance: 1e-7 x 10 rad/s


@pytest.mark.parametrize("method", SOLVERS)
def test_ramp_from_zero_locks_at_the_closed_form_time(tmp_path, method):
    # slip = 5t - 2 * integral of 40 t: zero again at t = 0.125 s
    ramp = '{ type = "ramp", t0 = 0.0, t1 = 0.25, v0 = 0.0, v1 = 1.0 }'
    r = scenario(tmp_path, clutch_body(ramp, 0.3), method=method).run()
    assert r.success, r.message
    assert lock_times(r) == pytest.approx([0.125], abs=1e-6)


@pytest.mark.parametrize("frequency", [50.0, 500.0])
@pytest.mark.parametrize("method", SOLVERS)
def test_clipped_sine_apply_is_integrated_exactly_on_every_solver(tmp_path, method, frequency):
    # apply max(0, sin): the mean torque is 10/pi on a clutch slipping all along, so B gains
    # 10/pi * T / J over T = 0.2 s whatever the frequency
    sine = f'{{ type = "sine", offset = 0.0, amplitude = 1.0, frequency = {frequency} }}'
    r = scenario(tmp_path, clutch_body(sine, 0.2, speeds="{ A = 100.0, B = 0.0 }", torque=0.0), method=method).run()
    assert r.success, r.message
    assert r.signals["w_B"][-1] == pytest.approx(10 / math.pi * 0.2, rel=1e-5)


OWC = """mechanism = "zf3hp22_small"
[simulation]
t_end = 0.3
[initial]
gear = "1"
speeds = { IN = 100.0 }
[input]
type = "torque"
torque = 200.0
[driveline]
output_inertia = 50.0
stiffness = 12000.0
damping = 200.0
"""


@pytest.mark.parametrize("method", SOLVERS)
def test_oneway_clutch_starting_at_round_off_engages(tmp_path, method):
    r = scenario(tmp_path, OWC, mech=None, method=method).run()
    assert r.success, r.message
    locks = [e for e in r.events if e.kind == "lock"]
    assert locks and locks[0].elements == ("OWC",) and locks[0].t == pytest.approx(7.6e-5, abs=2e-5)
    assert np.all(r.signals["slip_OWC"] >= -1e-6)  # never runs away in its locking direction
    assert r.signals["w_IN"][-1] < 200


def test_every_run_reports_the_invariants_it_checked(tmp_path):
    r = scenario(tmp_path, clutch_body('{ type = "ramp", t0 = 0.0, t1 = 0.25, v0 = 0.0, v1 = 1.0 }', 0.3)).run()
    checked = r.stats["invariants"]
    assert set(checked["invariants"]) == set(INVARIANTS)
    assert all(v["checks"] > 0 for k, v in checked["invariants"].items() if k not in ("oneway_free_sign", "idle_speed"))
    assert all(v["worst"] <= 1.0 for v in checked["invariants"].values())


def test_monitor_can_be_switched_off(tmp_path):
    sc = scenario(tmp_path, clutch_body("1.0", 0.1), monitor=False)
    assert "invariants" not in sc.run().stats


@pytest.mark.parametrize("patched", ["torque_at", "signed_capacity"])
def test_a_friction_torque_of_the_wrong_sign_stops_the_run(tmp_path, monkeypatch, patched):
    from transgen.sim.model.transmission import ElementConfig

    if patched == "torque_at":  # the Python right-hand side's element torque (the compiled one calls the formula)
        monkeypatch.setenv("TRANSGEN_JIT", "0")
        original = ElementConfig.torque_at
        monkeypatch.setattr(ElementConfig, "torque_at", lambda self, t, slip, scale, friction=True:
                            -original(self, t, slip, scale, friction))
    else:  # the signed capacity both right-hand sides take
        original = ElementConfig.signed_capacity
        monkeypatch.setattr(ElementConfig, "signed_capacity", lambda self, direction, capacity="dynamic":
                            -original(self, direction, capacity))
    sc = scenario(tmp_path, clutch_body("0.5", 0.3, speeds="{ A = 10.0, B = 0.0 }"))
    r = sc.run()
    assert not r.success
    assert "invariant" in r.message and "C" in r.message and "t=" in r.message


def _block(n=3, **signals):
    base = {"w_A": np.ones(n), "E_in": np.zeros(n), "E_dissipated": np.zeros(n), "E_load": np.zeros(n),
            "E_stored": np.ones(n)}
    base.update(signals)
    return base


class _Element:
    def __init__(self, name, kind, static=10.0, free=0):
        self.name, self.kind, self.static, self.free = name, kind, static, free


class _Tr:
    def __init__(self, *elements):
        self.elements = list(elements)


@pytest.mark.parametrize("case, invariant", [
    ({"slip_F": np.array([1.0, 0.0, -1e-3]), "t_F": np.zeros(3), "apply_F": np.ones(3)}, "oneway_free_sign"),
    ({"slip_F": np.array([1.0, 1.0, 1.0]), "t_F": np.array([0.0, 0.0, 0.0]), "apply_F": np.ones(3),
      "w_A": np.array([1.0, np.nan, 1.0])}, "finite"),
])
def test_monitor_flags_a_free_oneway_clutch_in_its_locking_direction(case, invariant):
    monitor = InvariantMonitor(_Tr(_Element("F", "oneway", free=1)), 1e-7, 1e-3)
    with pytest.raises(InvariantViolation) as info:
        monitor.check(np.array([0.0, 0.5, 1.0]), _block(**case), frozenset(), "M1")
    assert info.value.invariant == invariant


def test_monitor_flags_a_locked_torque_beyond_capacity_and_an_open_energy_balance():
    monitor = InvariantMonitor(_Tr(_Element("C", "clutch")), 1e-7, 1e-3)
    over = _block(slip_C=np.zeros(3), t_C=np.array([5.0, 9.0, 11.0]), apply_C=np.ones(3))
    with pytest.raises(InvariantViolation) as info:
        monitor.check(np.array([0.0, 0.5, 1.0]), over, frozenset({0}), "M1")
    assert (info.value.invariant, info.value.element, info.value.t) == ("holding_limit", "C", 1.0)
    leak = _block(slip_C=np.zeros(3), t_C=np.zeros(3), apply_C=np.ones(3), E_in=np.array([0.0, 1.0, 2.0]))
    with pytest.raises(InvariantViolation) as info:
        monitor.check(np.array([0.0, 0.5, 1.0]), leak, frozenset({0}), "M1")
    assert info.value.invariant == "energy_balance"
