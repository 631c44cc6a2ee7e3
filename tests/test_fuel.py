"""Fuel flow of an engine torque map (transgen.sim.engine.fuel): a measured table (fuel rate or BSFC)
interpolated bilinearly, the Willans-line estimate from the map's own motored torque with the
overrun cut-off, the m_dot_fuel signal of a run, and located errors for a bad [input] fuel_map."""
from __future__ import annotations

import math

import numpy as np
import pytest

from transgen.errors import ScenarioError
from transgen.sim.model.components import EngineMap
from transgen.sim.engine.fuel import FuelMap, WillansFuel

RPM = 2 * math.pi / 60


def test_table_is_bilinear_and_clamped():
    fm = FuelMap((100.0, 300.0), (0.0, 200.0), ((0.1, 0.3), (1.1, 2.3)))
    assert fm.flow(100.0, 0.0) == pytest.approx(0.1)
    assert fm.flow(300.0, 200.0) == pytest.approx(2.3)
    # the middle: the mean of the four corners
    assert fm.flow(200.0, 100.0) == pytest.approx((0.1 + 0.3 + 1.1 + 2.3) / 4)
    # bilinear along an edge, clamped outside
    assert fm.flow(150.0, 200.0) == pytest.approx(1.1 + 0.25 * 1.2)
    assert fm.flow(1000.0, -50.0) == pytest.approx(0.3)
    assert np.allclose(fm.flow(np.array([100.0, 300.0]), np.array([0.0, 0.0])), [0.1, 0.3])


def test_willans_line_uses_the_motored_torque_and_cuts_off_closed_throttle():
    engine = EngineMap((100.0, 500.0), (0.0, 1.0), ((-10.0, -30.0), (200.0, 250.0)))
    w = WillansFuel(engine, efficiency=0.4, heating_value=42e6)
    # at 300 rad/s the motored torque is -20 N*m: 100 N*m of brake torque burns (100 + 20) * 300 / 0.4 W
    assert w.flow(300.0, 100.0, 0.5) == pytest.approx(120.0 * 300.0 / 0.4 / 42e6)
    assert w.flow(300.0, -20.0, 0.5) == pytest.approx(0.0)       # only the friction: nothing burnt beyond it
    assert w.flow(300.0, -20.0, 0.0) == 0.0                      # closed throttle above idle: fuel cut-off
    assert w.flow(300.0, 50.0, 0.0) == 0.0
    # doubling the brake power over the friction doubles the flow (the line)
    assert w.flow(300.0, 220.0, 1.0) == pytest.approx(2 * w.flow(300.0, 100.0, 1.0))


def _scenario(fuel, **more):
    from transgen.sim.scenario.load import load_scenario

    return load_scenario("ht740_original", {"input.fuel_map": fuel, "simulation.t_end": 0.3, **more})


@pytest.mark.parametrize("kind", ["engine_converter", "engine_map"])
def test_a_run_gives_the_fuel_flow_of_its_map(kind):
    # BSFC 250 g/kWh everywhere: the flow is 250 g/kWh times the brake power (none at zero torque);
    # bilinear between the zero row and the top row is exact for bsfc * T * w
    fuel = {"type": "table", "speed_rpm": [0, 3000], "torque": [0, 3000], "bsfc": [[250, 250], [250, 250]]}
    scenario = _scenario(fuel, **({"input.type": "engine_map"} if kind == "engine_map" else {}))
    result = scenario.run()
    assert result.success, result.message
    sig = result.signals
    if kind == "engine_map":
        torque, speed = sig["T_in"], sig[f"w_{scenario.mechanism.input}"]
    else:
        torque, speed = sig["T_engine"], sig["omega_engine"]
    assert np.max(torque) > 100.0
    assert np.allclose(sig["m_dot_fuel"], 250.0 * np.maximum(torque, 0.0) * np.maximum(speed, 0.0) / 3.6e9, rtol=1e-9, atol=1e-12)
    from transgen.sim.engine.fuel import fuel_of

    assert fuel_of(scenario.powertrain) == (745.0, "fuel map")


def test_bad_fuel_maps_are_located_errors():
    cases = [
        ("diesel", r"fuel_map type must be \"table\" or \"willans\""),
        ({"type": "willans", "eficiency": 0.4}, r"unknown key 'eficiency'.*did you mean 'efficiency'"),
        ({"type": "willans", "efficiency": -1}, r"'efficiency' must be positive"),
        ({"speed_rpm": [1000, 900], "torque": [0, 1], "fuel_rate": [[1, 1], [1, 1]]},
         r"fuel_map speed_rpm must be increasing"),
        ({"speed_rpm": [1000, 2000], "torque": [0, 1], "fuel_rate": [[1, 1]]},
         r"fuel_rate must be 2 rows \(one per torque\) of 2 numbers"),
        ({"speed_rpm": [1000, 2000], "torque": [0, 1], "fuel_rate": [[1, 1], [1, -2]]},
         r"fuel_rate: row 2, entry 2 is -2"),
        ({"speed_rpm": [1000, 2000], "torque": [0, 1]}, r"gives one of 'fuel_rate' \[g/s\] or 'bsfc'"),
        (3, r"fuel_map must be \"willans\" or a table"),
    ]
    for spec, message in cases:
        with pytest.raises(ScenarioError, match=message):
            _scenario(spec)
