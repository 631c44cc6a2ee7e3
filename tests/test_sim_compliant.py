"""Haessig's compliant clutch model (sim/compliant.py): a stuck element is a spring-damper whose
twist rate is its slip, a slipping one transmits ``T_dyn * apply * sign(slip)``. Its breakaway
and zero-slip decisions keep every slipping element dissipative (the invariant monitor stops a
run otherwise), and it converges to the mode-switching model as the stiffness grows."""
from __future__ import annotations

import numpy as np
import pytest

from transgen import parse_mechanism
from transgen.sim.components import InputTorque
from transgen.sim.scenario import load_scenario
from transgen.sim.signals import Constant, Table
from transgen.sim.simulate import Powertrain, SolverOptions, simulate
from transgen.sim.transmission import Transmission

PAIR = parse_mechanism("""
link A J=1
link B J=2
clutch C A B static=300 dynamic=250
input A
output B
""")


def _pair(apply, torque, t_end=0.6, **options):
    """Two inertias (A 1, B 2 kg*m^2) joined by clutch C, stuck at the start, driven on A."""
    tr = Transmission(PAIR, {"C": {"apply": apply}}, modes="all")
    pt = Powertrain(tr, [InputTorque(torque, tr.link_index["A"])], np.array([10.0, 10.0]))
    settings = dict(model="compliant", method="Radau", rtol=1e-8, atol=1e-8, stiffness=1e5, damping=1000.0)
    settings.update(options)
    return simulate(pt, SolverOptions(t_end=t_end, output_dt=0.01, **settings))


# the held torque T_in * J_B / (J_A + J_B) = 200 (1 - t) falls, the capacity 300 (1 - 2 t) falls
# faster: C breaks away at t = 0.25 s with 150 N*m while its spring unwinds (slip = dT/dt / k < 0
# against a positive torque), as an off-going clutch released faster than it unloads does
RELEASE = dict(apply=Table((0.0, 0.5), (1.0, 0.0)), torque=Table((0.0, 1.0), (300.0, 0.0)))


def _times(result, kind):
    return [e.t for e in result.events if e.kind == kind]


def _dissipates(result, name):
    # t * slip >= 0 up to the zero-slip band a slip event stops in (the monitor's tolerance)
    slipping = result[f"locked_{name}"] == 0
    t, slip = result[f"t_{name}"][slipping], result[f"slip_{name}"][slipping]
    return np.all(t * slip >= -1e-6 * np.abs(t))


def test_a_clutch_released_faster_than_it_unloads_breaks_away_dissipating():
    # the breakaway's friction torque took the spring torque's sign while the slip had the other:
    # the monitor stopped the run ("the slipping element creates energy") at the unlock
    r = _pair(**RELEASE)
    assert r.success, r.message
    assert _times(r, "unlock")[0] == pytest.approx(0.25, abs=1e-6)  # where the switching model unlocks
    assert _dissipates(r, "C")
    assert r["slip_C"][-1] > 0  # slipping on in the torque's direction
    assert r.energy["relative_residual"] < 1e-6


def test_the_breakaway_lag_of_the_compliance_vanishes_with_the_stiffness():
    # the reversed slip turns within the spring's time scale; the element sticks at the crossing
    # and slips on once its spring has wound up again: a lag that shrinks as the stiffness grows
    lags = []
    for k, c in ((1e5, 1e3), (1e7, 6e3)):
        r = _pair(**RELEASE, stiffness=k, damping=c)
        assert r.success, r.message
        assert _dissipates(r, "C")
        lags.append(_times(r, "unlock")[-1] - 0.25)
    assert 0 <= lags[1] < lags[0] / 4 and lags[0] < 3e-3
    # stiff enough that the spring's twist rate stays inside the zero-slip tolerance: no lag at all
    r = _pair(**RELEASE, stiffness=1e9, damping=6e4)
    assert r.success and [e.kind for e in r.events[1:]] == ["unlock"]


def test_a_clutch_overloaded_by_a_growing_torque_breaks_away_once():
    # held torque 600 t grows through the capacity 300 at 0.5 s: spring torque and slip agree
    r = _pair(apply=Constant(1.0), torque=Table((0.0, 1.0), (0.0, 900.0)), t_end=0.7)
    assert r.success, r.message
    assert [(e.kind, e.elements) for e in r.events[1:]] == [("unlock", ("C",))]
    assert r.events[1].t == pytest.approx(0.5, abs=1e-3)
    assert _dissipates(r, "C") and r["slip_C"][-1] > 0


@pytest.mark.parametrize("name, t_end, unlock, lock", [
    ("ht740_original", 5.3, 5.0786, 5.1814),   # the switching model's C5 unlock and C4 lock
    ("ht740_improved", 4.9, 4.2321, 4.7424),
])
def test_ht740_upshift_runs_with_the_compliant_model(name, t_end, unlock, lock):
    # both stopped at C5's release (the energy-creating breakaway); once past it, the improved
    # trajectories chattered where C5, released, came back through zero slip: the direction it
    # then moves in was taken without the slipping on-coming C4's torque
    s = load_scenario(name, {"simulation.model": "compliant", "simulation.t_end": t_end})
    r = s.run()
    assert r.success, r.message
    assert _times(r, "unlock")[0] == pytest.approx(unlock, abs=1e-3)  # k = 1e5: lags by up to ms
    c4 = [e.t for e in r.events if e.kind == "lock" and e.elements == ("C4",)]
    assert len(c4) == 1 and c4[0] == pytest.approx(lock, abs=3e-3)
    assert _dissipates(r, "C5") and _dissipates(r, "C4")
