"""The simulator's fast paths give the numbers of the plain ones: its integration driver
(transgen.sim.solve.ode_solvers.solve_segment) against scipy's solve_ivp (the same steps, event roots,
end state and dense output, bit for bit), the torque events' input vector against the full
evaluation's, the mechanism-derived caches shared between transmissions."""
from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from transgen.sim.solve.ode_solvers import LeanBDF, LeanRadau, solve_segment

METHODS = ["RK45", "DOP853", "LSODA", "BDF", "Radau", LeanBDF, LeanRadau]


def _oscillator(t, y):
    """Damped, forced oscillator with an energy integral as a third state."""
    return np.array([y[1], -4.0 * y[0] - 0.3 * y[1] + np.sin(3.0 * t), y[1] * y[1]])


def _terminal(func, direction=0, linear=None):
    func.terminal, func.direction = True, direction
    if linear is not None:
        func.linear = linear
    return func


def _events(level: float):
    row = np.array([1.0, 0.0])
    return [
        _terminal(lambda t, y: y[2] - level, 1),                                        # energy reaches a level
        _terminal(lambda t, y: float(row @ y[:2]) + 0.7, -1, (row, 0.7)),               # y0 falls through -0.7
        _terminal(lambda t, y: float(np.array([0.0, 1.0]) @ y[:2]) - 2.5, 0,            # y1 through 2.5
                  (np.array([0.0, 1.0]), -2.5)),
        _terminal(lambda t, y: t - 7.25, 1),                                            # a time
    ]


def _compare(method, level, t1=10.0):
    y0 = np.array([1.0, 0.5, 0.0])
    options = dict(rtol=1e-6, atol=1e-8, max_step=0.5)
    ref = solve_ivp(_oscillator, (0.0, t1), y0, method=method, events=_events(level), dense_output=True, **options)
    got = solve_segment(_oscillator, 0.0, t1, y0, method, _events(level), **options)
    assert got.status == ref.status and got.message == ref.message and got.success == ref.success
    assert np.array_equal(got.t, ref.t) and np.array_equal(got.y, ref.y)
    for a, b in zip(got.t_events, ref.t_events):
        assert np.array_equal(a, b)
    for a, b in zip(got.y_events, ref.y_events):
        assert np.array_equal(np.reshape(a, (-1, 3)), np.reshape(b, (-1, 3)))
    ts = np.linspace(0.0, float(ref.t[-1]), 97)
    assert np.array_equal(got.sol(ts), ref.sol(ts))
    assert got.nfev == ref.nfev
    return got


@pytest.mark.parametrize("method", METHODS, ids=lambda m: m if isinstance(m, str) else m.__name__)
@pytest.mark.parametrize("level", [0.4, 3.0, 1e9])  # the energy event first, another one first, none
def test_solve_segment_is_solve_ivp_bit_for_bit(method, level):
    got = _compare(method, level)
    if level == 1e9:
        assert got.status == 1 and got.t[-1] < 7.25 + 1e-9  # some other event or the time event stops it


def test_solve_segment_without_events_runs_to_the_end():
    y0 = np.array([1.0, 0.0, 0.0])
    ref = solve_ivp(_oscillator, (0.0, 2.0), y0, method="LSODA", dense_output=True, rtol=1e-7, atol=1e-9)
    got = solve_segment(_oscillator, 0.0, 2.0, y0, "LSODA", [], rtol=1e-7, atol=1e-9)
    assert got.status == 0 and got.t[-1] == 2.0
    assert np.array_equal(got.y, ref.y) and got.t_events == [] and got.y_events == []


def test_simultaneous_roots_stop_at_the_first_event_as_solve_ivp_does():
    same = [_terminal(lambda t, y: t - 0.5, 1), _terminal(lambda t, y: t - 0.5, 1)]
    got = solve_segment(_oscillator, 0.0, 1.0, np.array([1.0, 0.0, 0.0]), "RK45", same)
    ref = solve_ivp(_oscillator, (0.0, 1.0), np.array([1.0, 0.0, 0.0]), method="RK45", events=same,
                    dense_output=True)
    assert [len(te) for te in got.t_events] == [len(te) for te in ref.t_events] == [1, 0]
    assert got.t[-1] == ref.t[-1] == 0.5


def test_solve_segment_refuses_an_event_that_does_not_stop():
    event = lambda t, y: y[0]  # noqa: E731
    with pytest.raises(ValueError, match="terminal"):
        solve_segment(_oscillator, 0.0, 1.0, np.array([1.0, 0.0, 0.0]), "RK45", [event])


# ----------------------------------------------------------------------------- the events' inputs
@pytest.mark.filterwarnings("ignore:.*outside the data")  # random states off the map: clamped, warned
@pytest.mark.parametrize("name", ["ht740_turbo", "ht740_turbo_iterative", "ht740_improved", "coupled_clutches"])
def test_input_vector_alone_is_the_right_hand_sides(name):
    """What the torque events read at every step end (ComponentEvaluator.inputs: the components'
    torques alone; the turbodiesel's from its cylinders) is the input vector of the full
    evaluation, bit for bit, at states off the steady state."""
    from transgen.sim.solve.integration import ComponentEvaluator, StateLayout
    from transgen.sim.scenario.load import load_scenario

    pt = load_scenario(name).powertrain
    model = ComponentEvaluator(pt)
    w0 = np.asarray(pt.initial_speeds, dtype=float)
    layout = StateLayout(pt.components, 0)
    base = np.concatenate([c.initial_state(w0) for c in pt.components] + [np.zeros(3)])
    rng = np.random.default_rng(3)
    for k in range(25):
        y = base * (1.0 + 0.02 * rng.standard_normal(len(base)))
        w = w0 + rng.uniform(0.0, 150.0, len(w0))
        t = 0.8 * k
        alone = model.inputs(t, y, w, layout)
        # the other order too: after a full evaluation at the same point (the engine's cache)
        full = model.external(t, y, w, layout)[0]
        assert np.array_equal(alone, full)
        assert np.array_equal(model.inputs(t, y, w, layout), full)


def test_crank_torque_is_the_engines_torque():
    from transgen.sim.engine.diesel import TurbochargedDiesel
    from transgen.sim.engine.gas import RPM

    for turbo in ("basic", "iterative"):
        eng = TurbochargedDiesel(turbo=turbo, rack=0.7)
        x0 = eng.initial_state(1500 * RPM)
        for k, n in enumerate((200.0, 650.0, 1200.0, 1900.0, 2250.0)):
            x = x0 * (1.0 + 0.03 * np.array([np.sin(k), np.cos(k), np.sin(2 * k)]))
            cheap = eng.crank_torque(0.1 * k, x, n * RPM)
            assert cheap == eng.torque(0.1 * k, x, n * RPM) == eng.crank_torque(0.1 * k, x, n * RPM)


# ----------------------------------------------------------------------------- shared caches
def test_transmissions_of_one_mechanism_share_what_the_gearing_decides():
    from transgen.errors import ModeError
    from transgen.sim.scenario.load import load_scenario

    a, b = load_scenario("ht740_improved").powertrain.transmission, load_scenario("ht740_improved").powertrain.transmission
    assert a is not b and a._on_demand is b._on_demand and a._implied is b._implied
    names = [e.name for e in a.elements]
    odd = frozenset(range(len(names)))  # every element locked: no mode (the gearing is overconstrained)
    with pytest.raises(ModeError) as first:
        a.mode(odd)
    with pytest.raises(ModeError) as again:  # from the cache, the same message
        b.mode(odd)
    assert str(first.value) == str(again.value)
    on_demand = next(k for k in map(frozenset, ([0], [1], [0, 1], [2], [0, 2])) if k not in {m.locked for m in a.std_modes})
    try:
        data = a.mode(on_demand)
    except ModeError:
        return
    assert b.mode(on_demand) is data and not data.in_std


def _stiff(t, y):
    """A stiff chain (rates 1 to 1e4) driven by a kinked forcing, with a quadratic coupling."""
    k = np.array([1.0, 30.0, 900.0, 1e4])
    return np.concatenate([[np.sin(5 * t) + abs(np.cos(2 * t)) - k[0] * y[0]],
                           k[:-1] * y[:-1] - k[1:] * y[1:] + 0.1 * y[:-1] ** 2])


@pytest.mark.parametrize("options", [dict(rtol=1e-5, atol=1e-5), dict(rtol=1e-8, atol=1e-10, max_step=0.05),
                                     dict(rtol=1e-3, atol=1e-6, first_step=1e-5)])
def test_lean_bdf_steps_as_scipys_bdf_bit_for_bit(options):
    from scipy.integrate import BDF

    y0 = np.array([0.5, 0.0, 0.2, 0.0])
    ref = solve_ivp(_stiff, (0.0, 6.0), y0, method=BDF, dense_output=True, **options)
    got = solve_ivp(_stiff, (0.0, 6.0), y0, method=LeanBDF, dense_output=True, **options)
    assert got.status == ref.status == 0
    assert np.array_equal(got.t, ref.t) and np.array_equal(got.y, ref.y)
    assert (got.nfev, got.njev, got.nlu) == (ref.nfev, ref.njev, ref.nlu)
    ts = np.linspace(0.0, 6.0, 301)
    assert np.array_equal(got.sol(ts), ref.sol(ts))


@pytest.mark.parametrize("method", ["RK45", "DOP853", LeanBDF])  # (LSODA: its Fortran loops on an infinite derivative)
def test_solve_segment_fails_as_solve_ivp_does(method):
    """A right-hand side that blows up: the same status, message and last state."""
    def blow_up(t, y):
        return np.array([1.0 / np.float64(0.5 - t), y[0]])

    y0 = np.array([0.0, 0.0])
    with np.errstate(all="ignore"):
        try:
            ref = solve_ivp(blow_up, (0.0, 1.0), y0, method=method, dense_output=True, rtol=1e-6, atol=1e-9)
        except ValueError as exc:  # a LAPACK refusal of the non-finite Jacobian: the same for both
            with pytest.raises(ValueError, match=str(exc)[:20]):
                solve_segment(blow_up, 0.0, 1.0, y0, method, [], rtol=1e-6, atol=1e-9)
            return
        got = solve_segment(blow_up, 0.0, 1.0, y0, method, [], rtol=1e-6, atol=1e-9)
    assert (got.status, got.message, got.success) == (ref.status, ref.message, ref.success)
    assert np.array_equal(got.t, ref.t) and np.array_equal(got.y, ref.y, equal_nan=True)
