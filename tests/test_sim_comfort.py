"""Comfort arithmetic (transgen.sim.analysis.comfort): the ISO 2631-1 weightings against the standard's
tabulated factors, jerk, VDV and settling time on signals with closed-form answers."""
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from transgen.sim.analysis.comfort import jerk, settling_time, unique_samples, vdv, weighted, weighting_response

# ISO 2631-1:1997 Table 3 (principal weightings, factors x 1000), Wk (z) and Wd (x, y)
TABLE = {
    "Wk": {0.1: 31.2, 0.2: 121, 0.5: 418, 1.0: 482, 2.0: 531, 4.0: 967, 6.3: 1054, 8.0: 1036, 12.5: 902,
           16.0: 768, 31.5: 405, 63.0: 186, 80.0: 132},
    "Wd": {0.1: 62.4, 0.2: 243, 0.5: 853, 1.0: 1011, 2.0: 890, 4.0: 512, 6.3: 323, 8.0: 253, 12.5: 161,
           16.0: 125, 31.5: 63.2, 63.0: 29.5, 80.0: 21.1},
}


@pytest.mark.parametrize("name", ["Wk", "Wd"])
def test_weighting_matches_iso_2631_table(name):
    f = np.array(sorted(TABLE[name]))
    table = np.array([TABLE[name][x] for x in f]) / 1000.0
    # the transfer function within the table's rounding (3 significant digits)
    assert np.allclose(weighting_response(f, name), table, rtol=4e-3)


@pytest.mark.parametrize("name", ["Wk", "Wd"])
@pytest.mark.parametrize("f", [0.5, 1.0, 2.0, 4.0, 8.0, 16.0, 31.5, 63.0])
def test_weighting_filter_passes_sines_at_the_table_factors(name, f):
    # a sine through the filter (as the report applies it) comes out at the tabulated factor
    t = np.linspace(0.0, 12.0, 48001)
    tw, aw = weighted(t, np.sin(2 * math.pi * f * t), name)
    steady = aw[tw > 8.0]
    assert 0.5 * np.ptp(steady) == pytest.approx(TABLE[name][f] / 1000.0, rel=6e-3)


def test_unknown_weighting_is_refused():
    with pytest.raises(ValueError, match="unknown frequency weighting 'Wz'"):
        weighted(np.arange(3.0), np.zeros(3), "Wz")


def test_unique_samples_keeps_the_value_after_an_event():
    t = np.array([0.0, 0.1, 0.2, 0.2, 0.3])
    y = np.array([0.0, 1.0, 2.0, 5.0, 6.0])
    tu, yu = unique_samples(t, y)
    assert tu.tolist() == [0.0, 0.1, 0.2, 0.3] and yu.tolist() == [0.0, 1.0, 5.0, 6.0]
    tu, yu = unique_samples(np.array([0.0, 0.1, 0.1 + 1e-9, 0.2]), np.array([0.0, 1.0, 1.0, 2.0]), 1e-3)
    assert tu.tolist() == [0.0, 0.1, 0.2]


def test_jerk_of_a_ramp_is_its_slope_across_events_and_near_duplicates():
    # a = 2 + 3 t sampled every 5 ms, with an event (repeated time) and a sample 1 ns after a grid point
    t = np.concatenate([np.arange(0.0, 1.0, 0.005), [0.5, 0.7 + 1e-9]])
    t.sort()
    a = 2.0 + 3.0 * t + 1e-7 * np.random.default_rng(1).standard_normal(len(t))  # solver-level noise
    tj, j = jerk(t, a)
    assert np.all(np.diff(tj) > 0)
    assert np.allclose(j, 3.0, atol=1e-3)  # no 1e-7/1e-9 = 100 m/s^3 spike at the near-duplicate


def test_jerk_of_a_sine():
    # a = A sin(w t): jerk A w cos(w t), max |jerk| = A w (secants of a fine sampling)
    A, w = 0.7, 2 * math.pi * 2.0
    t = np.linspace(0.0, 2.0, 4001)
    tj, j = jerk(t, A * np.sin(w * t))
    assert np.allclose(j, A * w * np.cos(w * tj), atol=1e-4 * A * w)
    assert np.max(np.abs(j)) == pytest.approx(A * w, rel=1e-5)


def test_vdv_of_an_unweighted_sine_is_closed_form():
    # integral of (A sin(w t))^4 over whole periods T is 3 A^4 T / 8
    A, f, T = 1.3, 5.0, 2.0
    t = np.linspace(0.0, T, 20001)
    tu, au = weighted(t, A * np.sin(2 * math.pi * f * t), "none")
    assert vdv(tu, au, 0.0, T) == pytest.approx(A * (3 * T / 8) ** 0.25, rel=1e-6)
    assert vdv(tu, au, 1.0, 1.0) == 0.0


@pytest.mark.parametrize("name,f", [("Wd", 1.0), ("Wd", 8.0), ("Wk", 6.3), ("Wk", 1.0)])
def test_vdv_of_a_weighted_sine_in_steady_state(name, f):
    # after the filter's transient the weighted sine has amplitude |W(f)| A
    A, T0, T = 2.0, 10.0, 4.0
    t = np.linspace(0.0, T0 + T, int((T0 + T) * 400) + 1)
    tw, aw = weighted(t, A * np.sin(2 * math.pi * f * t), name)
    amp = A * float(weighting_response([f], name)[0])
    assert vdv(tw, aw, T0, T0 + T) == pytest.approx(amp * (3 * T / 8) ** 0.25, rel=5e-3)


def test_a_constant_acceleration_is_not_vibration():
    # the weighting filter starts in the steady state of the first sample: a steady 0.8 m/s^2
    # (a vehicle accelerating) gives no weighted acceleration
    t = np.linspace(0.0, 3.0, 601)
    for name in ("Wk", "Wd"):
        _, aw = weighted(t, np.full(len(t), 0.8), name)
        assert np.max(np.abs(aw)) < 1e-9


def test_settling_time_of_an_exponential():
    # y = 100 + 50 exp(-t/tau) enters the 5 % band (+-5) at tau ln(10)
    tau = 0.3
    t = np.linspace(0.0, 3.0, 30001)
    y = 100.0 + 50.0 * np.exp(-t / tau)
    assert settling_time(t, y, 0.0, 3.0, 100.0, 5.0) == pytest.approx(tau * math.log(10.0), abs=1e-4)
    assert settling_time(t, y, 2.0, 3.0, 100.0, 5.0) == 0.0
    assert settling_time(t, y, 5.0, 6.0, 100.0, 5.0) is None


@settings(max_examples=30, deadline=None)
@given(st.floats(0.1, 5.0), st.floats(0.5, 20.0), st.floats(0.0, 6.28))
def test_vdv_scales_with_amplitude_and_is_shift_invariant(amplitude, f, phase):
    # VDV is homogeneous of degree 1 in the acceleration and ignores its sign
    t = np.linspace(0.0, 2.0, 8001)
    a = np.sin(2 * math.pi * f * t + phase)
    tw, aw = weighted(t, a, "Wd")
    _, aw2 = weighted(t, -amplitude * a, "Wd")
    assert vdv(tw, aw2, 0.5, 2.0) == pytest.approx(amplitude * vdv(tw, aw, 0.5, 2.0), rel=1e-9)


def test_filtered_jerk_is_the_derivative_of_the_10_hz_low_pass():
    from transgen.sim.analysis.comfort import JERK_FILTER_HZ, filtered_jerk

    t = np.linspace(0.0, 4.0, 4001)
    # a constant jerk of 3 m/s^3 (a ramp of acceleration): the filter passes it once settled
    tg, j = filtered_jerk(t, 3.0 * t)
    late = tg > 0.5
    assert np.allclose(j[late & (tg < 3.9)], 3.0, rtol=1e-3)
    # a 2 Hz sine: jerk amplitude 2 pi f A |H(2 Hz)| (2nd-order Butterworth at 10 Hz)
    f, amp = 2.0, 0.5
    tg, j = filtered_jerk(t, amp * np.sin(2 * np.pi * f * t))
    gain = 1.0 / np.sqrt(1.0 + (f / JERK_FILTER_HZ) ** 4)
    assert np.max(np.abs(j[(tg > 1.0) & (tg < 3.9)])) == pytest.approx(2 * np.pi * f * amp * gain, rel=2e-3)
    # a 100 Hz ripple on top is cut ~100 times (the exact jerk would show 2 pi 100 x 0.05 = 31 m/s^3)
    tg, j2 = filtered_jerk(t, amp * np.sin(2 * np.pi * f * t) + 0.05 * np.sin(2 * np.pi * 100.0 * t))
    ripple = np.max(np.abs((j2 - j)[(tg > 1.0) & (tg < 3.9)]))
    assert ripple < 0.5
