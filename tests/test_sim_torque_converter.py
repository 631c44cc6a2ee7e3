"""Torque converter characteristics: drive, coupling point, coast, symmetry, data checks."""
import math

import numpy as np
import pytest

from transgen.sim.engine import RPM
from transgen.sim.engine.torque_converter import TorqueConverter, TorqueConverterError

TC = TorqueConverter.load()
WP = 1500 * RPM


def test_stall_and_capacity_factor():
    tp, tt = TC.torques(WP, 0.0)
    assert tp == pytest.approx((WP / 4.25) ** 2)              # T_pump = (omega/K)^2
    assert tt / tp == pytest.approx(2.2)                      # stall torque ratio
    for sr in TC.speed_ratio[:-1]:
        tp, tt = TC.torques(WP, sr * WP)
        assert tp == pytest.approx((WP / TC.capacity_factor_at(sr)) ** 2)
        assert tt == pytest.approx(TC.torque_ratio_at(sr) * tp)


def test_drive_curve_shape():
    sr = np.linspace(0.0, 0.99, 100)
    tq = np.array([TC.torques(WP, s * WP) for s in sr])
    assert np.all(np.diff(tq[:, 1]) < 0)                       # turbine torque falls with SR
    assert np.all(tq[:, 1] >= tq[:, 0] - 1e-9)                 # TR >= 1
    eff = [TC.efficiency(s) for s in sr]
    assert 0.85 < max(eff) < 1.0
    assert TC.capacity_factor_at(1.0) == math.inf


def test_coupling_point_and_coast_are_continuous():
    assert TC.torques(WP, WP) == (0.0, 0.0)
    below, above = TC.torques(WP, 0.999 * WP), TC.torques(WP, 1.001 * WP)
    assert below[0] > 0 and above[0] < 0 and above[1] < 0          # coast: pump driven
    assert abs(below[0]) < 10 and abs(above[0]) < 10
    tp, tt = TC.torques(WP, 1.25 * WP)                                # reverse flow, TR = 1
    assert tp == tt == pytest.approx(-(1.25 * WP / np.interp(0.8, TC.coast_speed_ratio,
                                                               TC.coast_capacity_factor)) ** 2)


def test_odd_symmetry_and_standstill():
    assert TC.torques(-WP, -0.5 * WP) == pytest.approx(tuple(-v for v in TC.torques(WP, 0.5 * WP)))
    assert TC.torques(0.0, 0.0) == (0.0, 0.0)
    tp, tt = TC.torques(0.0, 100.0)                                   # turbine drives pump
    assert tp < 0 and tt < 0
    assert TC.torques(WP, -50.0) == TC.torques(WP, 0.0)               # SR < 0: stall values


def test_invalid_tables_raise():
    with pytest.raises(TorqueConverterError, match="speed ratios"):
        TorqueConverter((0.0, 0.5), (4.0, 5.0), (2.0, 1.0), (0.0, 1.0), (5.0, math.inf))
    with pytest.raises(TorqueConverterError, match="capacity"):
        TorqueConverter((0.0, 1.0), (-4.0, math.inf), (2.0, 1.0), (0.0, 1.0), (5.0, math.inf))


def test_shipped_table_has_provenance():
    assert dict(TC.provenance)["source"].startswith("synthetic")
    assert TC.causality["pump"].gives == "torque"
