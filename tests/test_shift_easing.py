"""Easing the end of the inertia phase (ShiftTemplate ease_slip / ease_time / ease_level, the
``ease`` event of AutoShift): where it fires, what it does to the lock, the refusals."""
from __future__ import annotations

import math
import textwrap

import numpy as np
import pytest

from transgen.errors import ScenarioError
from transgen.sim import load_scenario
from transgen.sim.control.schedule import ShiftTemplate

# simple2 (input 2.9 kg*m^2) in a heavy vehicle at 300 N*m: the 1-2 locks during its hold at
# ramp_end 0.45 (C2 765 N*m against its static share 600 N*m: 0.35 of 1700)
SCENARIO = """
mechanism = "simple2"
[simulation]
t_end = 2.5
[initial]
gear = "1"
speeds = { Li = 50.0 }
[input]
torque = 300.0
[driveline]
output_inertia = 5.0
stiffness = 5000.0
damping = 300.0
final_drive = 3.0
wheel_radius = 0.3
vehicle_mass = 20000.0
[auto_shift]
order = ["1", "2"]
throttle = [0.0, 1.0]
upshift_rpm = [[100, 100]]
downshift_rpm = [[50, 50]]
throttle_signal = 1.0
[auto_shift.template]
fill_time = 0.05
fill_level = 0.0
ramp_time = 0.2
ramp_end = 0.45
hold_time = 1.0
final_time = 0.2
offgoing_delay = 0.0
offgoing_level = 1.0
offgoing_ramp = 0.12
"""
EASE = "ease_slip = 0.5\nease_time = 0.3\nease_level = 0.36\n"


def _file(tmp_path, text):
    p = tmp_path / "s.toml"
    p.write_text(textwrap.dedent(text))
    return p


def _run(tmp_path, extra=""):
    r = load_scenario(_file(tmp_path, SCENARIO + extra)).run()
    assert r.success, r.message
    return r


def _at(r, name, t):
    return float(np.interp(t, r.time, r[name]))


def test_the_ease_event_fires_at_its_fraction_of_the_commanded_slip(tmp_path):
    r = _run(tmp_path, EASE)
    [command] = [e for e in r.events if e.kind == "command"]
    [ease] = [e for e in r.events if e.kind == "ease"]
    assert "C2" in ease.detail and "(1-2)" in ease.detail
    # the event is root-found on the measured slip: |slip| = 0.5 x |slip at the command|
    assert abs(_at(r, "slip_C2", ease.t)) == pytest.approx(0.5 * abs(_at(r, "slip_C2", command.t)), rel=1e-3)
    # from there the apply ramps from the held level to ease_level over ease_time
    assert _at(r, "apply_C2", ease.t) == pytest.approx(0.45, abs=1e-6)
    assert _at(r, "apply_C2", ease.t + 0.15) == pytest.approx(0.405, abs=1e-6)
    assert _at(r, "apply_C2", ease.t + 0.3) == pytest.approx(0.36, abs=1e-6)


def _lock(r):
    """The slip rate [rad/s^2] just before the oncoming element's lock and the largest |jerk|
    [m/s^3] in the 0.2 s from it."""
    t_lock = next(e.t for e in r.events if e.kind == "lock" and "C2" in e.elements)
    i = np.searchsorted(r.time, t_lock) - 1
    rate = (r["slip_C2"][i] - r["slip_C2"][i - 2]) / (r.time[i] - r.time[i - 2])
    window = (r.time >= t_lock - 1e-3) & (r.time <= t_lock + 0.2)
    return abs(rate), float(np.max(np.abs(r["vehicle_jerk"][window])))


def test_easing_lowers_the_slip_rate_and_the_jerk_at_the_lock(tmp_path):
    rate0, jerk0 = _lock(_run(tmp_path))
    rate1, jerk1 = _lock(_run(tmp_path, EASE))
    # the lock jerk follows the slip deceleration at lock-up: easing to just above the static
    # share (0.36 against 0.35) cuts both
    assert rate1 < 0.5 * rate0
    assert jerk1 < 0.5 * jerk0


def test_easing_off_by_default_and_written_only_where_used():
    assert not ShiftTemplate().eases
    assert "ease_slip" not in ShiftTemplate().as_data()
    assert ShiftTemplate(ease_slip=0.5, ease_time=0.1, ease_level=0.3).as_data()["ease_level"] == 0.3


@pytest.mark.parametrize("key, value", [("ease_slip", 1.5), ("ease_slip", math.nan), ("ease_level", 1.2),
                                        ("ease_time", -0.1), ("ease_time", 11.0)])
def test_bad_easing_values_are_refused(key, value):
    with pytest.raises(ValueError, match=key):
        ShiftTemplate(**{key: value})


@pytest.mark.parametrize("line, words", [("ease_slip = 1.5", "'ease_slip' must be <= 0.99"),
                                         ("ease_level = nan", "ease_level' is"),
                                         ("ease_time = 20.0", "'ease_time' must be <= 10"),
                                         ("ease_time = -1.0", "'ease_time' must be >= 0")])
def test_bad_easing_keys_are_located(tmp_path, line, words):
    p = _file(tmp_path, SCENARIO + line + "\n")
    with pytest.raises(ScenarioError) as exc:
        load_scenario(p)
    n = SCENARIO.count("\n") + 1
    assert str(exc.value).startswith(f"{p}:{n}:"), str(exc.value)
    assert words in str(exc.value)


def test_an_open_loop_shift_event_cannot_ease(tmp_path):
    text = SCENARIO.split("[auto_shift]")[0] + """
[shifts]
events = [ { t = 0.5, from = "1", to = "2", template = { ease_slip = 0.5, ease_time = 0.1, ease_level = 0.3 } } ]
"""
    with pytest.raises(ScenarioError, match="only an \\[auto_shift\\] template eases"):
        load_scenario(_file(tmp_path, text))


#: the shift report starts a shift where its oncoming apply leaves zero: a fill level makes that the command
TUNE = {"simulation.t_end": 4.0, "auto_shift.template.fill_level": 0.02}


def test_optimize_tunes_the_easing_of_an_automatic_schedule(tmp_path):
    from transgen.sim.study.optimize import EASE_PARAMETERS, optimize

    path = _file(tmp_path, SCENARIO + EASE)
    result = optimize(str(path), max_evaluations=10, population=9, seed=2, overrides=TUNE)
    assert set(EASE_PARAMETERS) <= set(result.parameters)
    rows = result.history
    assert rows[0]["ease_slip"] == 0.5 and rows[0]["ease_level"] == 0.36  # the start: the scenario's own
    assert len({r["ease_level"] for r in rows}) > 1  # the candidates vary it
    tuned = result.shifts[0].best_template
    template = result.overrides["auto_shift.template" + "s.1-2"]
    assert {k: template[k] for k in EASE_PARAMETERS if k in template} == (
        {k: getattr(tuned, k) for k in EASE_PARAMETERS} if tuned.eases else {})
    assert load_scenario(path, {**TUNE, **result.overrides}).run().success


def test_the_default_easing_is_the_static_share_plus_a_tenth_of_the_inertia_torque():
    from transgen.sim.derive.calibration import EASE_RESIDUAL, EASE_SLIP, ease

    # inertia-phase level 0.5 over a static share of 0.3 (mean torque), 0.35 at the phase's end
    level, ramp, longer = ease(0.5, 0.3, 0.35, 0.4)
    assert level == pytest.approx(0.35 + EASE_RESIDUAL * 0.2)
    # the slip rate falls linearly from a = s0/t_ip to 0.1 a over the ramp: the slip it covers
    # is the half left at the ease event
    s0, t_ip = 1.0, 0.4
    a = s0 / t_ip
    assert 0.5 * (a + EASE_RESIDUAL * a) * ramp == pytest.approx(EASE_SLIP * s0)
    assert longer == pytest.approx(ramp - EASE_SLIP * t_ip)
    assert ease(0.3, 0.3, 0.3, 0.4) == (0.0, 0.0, 0.0)  # no inertia torque: nothing to ease
    assert ease(0.5, 0.3, 0.9, 0.4)[0] == 0.5  # never above the inertia-phase level


def test_scenario_new_eases_every_upshift_of_the_8hp70_car():
    from transgen import load_mechanism
    from transgen.sim.derive.launch import derive_launch

    launch = derive_launch(load_mechanism("zf8hp70"), "car")
    for c in launch.calibrations:
        t = c.template
        assert t.ease_slip == 0.5 and 0 < t.ease_level < t.ramp_end and t.ease_time > 0, c.source
