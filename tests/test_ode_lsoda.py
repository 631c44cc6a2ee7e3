"""The lean LSODA stepper (transgen.sim.solve.ode_solvers.LeanLSODA) gives scipy's LSODA, bit for bit:
the same steps, states, event roots, dense output and counters on random linear and nonlinear
systems with terminal events, the same failure (status, message, warning), and the same runs of
every bundled scenario integrated with LSODA."""
from __future__ import annotations

import dataclasses
import warnings

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from scipy.integrate import LSODA, solve_ivp

from transgen.sim.solve import ode_solvers
from transgen.sim.solve.ode_solvers import SOLVERS, LeanLSODA, solve_segment
from transgen.sim.scenario.library import bundled_scenarios
from transgen.sim.scenario.load import load_scenario


def _terminal(func, direction=0, linear=None):
    func.terminal, func.direction = True, direction
    if linear is not None:
        func.linear = linear
    return func


def _same_segment(got, ref, n: int):
    assert (got.status, got.message, got.success) == (ref.status, ref.message, ref.success)
    assert np.array_equal(got.t, ref.t) and np.array_equal(got.y, ref.y)
    assert len(got.t_events) == len(ref.t_events)
    for a, b in zip(got.t_events, ref.t_events):
        assert np.array_equal(a, b)
    for a, b in zip(got.y_events, ref.y_events):
        assert np.array_equal(np.reshape(a, (-1, n)), np.reshape(b, (-1, n)))
    assert got.nfev == ref.nfev
    if len(ref.t) > 1:
        # inside the steps, and at the step ends themselves (which step's polynomial is taken)
        ts = np.concatenate([np.linspace(ref.t[0], ref.t[-1], 41), ref.t])
        assert np.array_equal(got.sol(ts), ref.sol(ts))
        for tt in ts[::7]:
            assert np.array_equal(got.sol(tt), ref.sol(tt))


@st.composite
def _systems(draw):
    """A random system ``y' = A y + c * sin(y) + b cos(w t)`` (``c`` zero: linear) with terminal
    events (linear ones on the state, a nonlinear one, a time), tolerances and step bound."""
    n = draw(st.integers(1, 6))
    seed = draw(st.integers(0, 2**32 - 1))
    rng = np.random.default_rng(seed)
    t1 = draw(st.sampled_from([0.3, 2.0, 6.0, -0.3]))  # -0.3: backwards in time
    stiff = t1 > 0 and draw(st.booleans())
    A = rng.normal(size=(n, n)) - np.diag(rng.uniform(0.1, 500.0 if stiff else 3.0, n))
    c = draw(st.sampled_from([0.0, 0.5, 2.0]))
    b, w = rng.normal(size=n), rng.uniform(0.5, 20.0)
    y0 = rng.normal(size=n)
    rtol = draw(st.sampled_from([1e-3, 1e-5, 1e-7, 1e-9]))
    atol = draw(st.sampled_from([1e-6, 1e-8, rtol]))
    max_step = draw(st.sampled_from([np.inf, 0.05, 0.7]))
    with_jac = draw(st.booleans())
    n_linear = draw(st.integers(0, 3))
    rows = [rng.normal(size=draw(st.integers(1, n))) if draw(st.booleans()) else rng.normal(size=n)
            for _ in range(n_linear)]
    offsets = rng.normal(size=n_linear)
    directions = [draw(st.sampled_from([-1, 0, 1])) for _ in range(n_linear + 2)]
    level = rng.uniform(0.5, 3.0)
    t_event = draw(st.sampled_from([None, 0.25, 1.5])) if t1 > 0 else draw(st.sampled_from([None, -0.2]))
    return dict(n=n, A=A, c=c, b=b, w=w, y0=y0, rtol=rtol, atol=atol, max_step=max_step, t1=t1,
                with_jac=with_jac, rows=rows, offsets=offsets, directions=directions, level=level, t_event=t_event)


def _problem(p):
    A, c, b, w = p["A"], p["c"], p["b"], p["w"]

    def fun(t, y):
        return A @ y + c * np.sin(y) + b * np.cos(w * t)

    def jac(t, y):
        return A + np.diag(c * np.cos(y))

    def events():
        out = []
        for row, offset, d in zip(p["rows"], p["offsets"], p["directions"]):
            out.append(_terminal(lambda t, y, row=row, off=offset: float(row @ y[:len(row)]) + off, d, (row, offset)))
        out.append(_terminal(lambda t, y: float(y @ y) - p["level"] ** 2, p["directions"][-2]))
        if p["t_event"] is not None:
            out.append(_terminal(lambda t, y: t - p["t_event"], p["directions"][-1]))
        return out

    options = dict(rtol=p["rtol"], atol=p["atol"], max_step=p["max_step"])
    if p["with_jac"]:
        options["jac"] = jac
    return fun, events, options


@settings(max_examples=60, deadline=None, derandomize=True, suppress_health_check=[HealthCheck.too_slow])
@given(_systems())
def test_lean_lsoda_is_scipy_lsoda_bit_for_bit(p):
    fun, events, options = _problem(p)
    y0 = p["y0"]
    got = solve_segment(fun, 0.0, p["t1"], y0, LeanLSODA, events(), **options)
    ref = solve_segment(fun, 0.0, p["t1"], y0, LSODA, events(), **options)
    _same_segment(got, ref, p["n"])
    assert (got.njev, got.nlu) == (ref.njev, ref.nlu)
    # and scipy's own driver with the solver by name
    ivp = solve_ivp(fun, (0.0, p["t1"]), y0, method="LSODA", events=events(), dense_output=True, **options)
    _same_segment(got, ivp, p["n"])


@pytest.mark.parametrize("t_bound", [3.0, -3.0])
def test_lean_lsoda_steps_like_scipy_one_by_one(t_bound):
    """The solver objects themselves, step by step, forwards and backwards in time: time, state,
    counters, dense output."""
    A = np.array([[0.0, 7.0, 0.0], [-7.0, -0.1, 1.0], [0.0, 0.0, -40.0]]) * np.sign(t_bound)

    def fun(t, y):
        return A @ y + np.array([0.0, np.sin(t), 0.0])

    lean = LeanLSODA(fun, 0.0, np.array([1.0, 0.0, 2.0]), t_bound, rtol=1e-8, atol=1e-10, max_step=0.2)
    ref = LSODA(fun, 0.0, np.array([1.0, 0.0, 2.0]), t_bound, rtol=1e-8, atol=1e-10, max_step=0.2)
    if not lean._lean:
        pytest.skip("this scipy's LSODA keeps other state: LeanLSODA runs scipy's own step (tested below)")
    while ref.status == "running":
        assert lean.step() == ref.step()
        assert (lean.status, lean.t, lean.t_old, lean.nfev, lean.njev, lean.nlu) == \
               (ref.status, ref.t, ref.t_old, ref.nfev, ref.njev, ref.nlu)
        assert np.array_equal(lean.y, ref.y) and lean.y is not lean._y_c
        a, b = lean.dense_output(), ref.dense_output()
        ts = np.linspace(ref.t_old, ref.t, 5)
        assert np.array_equal(a(ts), b(ts)) and np.array_equal(a(ts[2]), b(ts[2]))
        assert (a.t_min, a.t_max) == (b.t_min, b.t_max)
    with pytest.raises(RuntimeError):
        lean.step()


def test_lean_lsoda_fails_as_scipy_does():
    """A state component with a zero error weight (``atol = 0`` and a zero state): the same
    refused call, status, message and warning."""
    def fun(t, y):
        return np.array([-y[0], 0.0])

    results, caught = [], []
    for method in (LeanLSODA, LSODA):
        with warnings.catch_warnings(record=True) as w:
            warnings.simplefilter("always")
            results.append(solve_segment(fun, 0.0, 2.0, np.array([1.0, 0.0]), method, [], rtol=1e-6, atol=0.0))
        caught.append([str(x.message) for x in w])
    got, ref = results
    assert ref.status == -1
    _same_segment(got, ref, 2)
    assert caught[0] == caught[1] and caught[0]


def test_zero_length_segment_and_empty_state():
    for y0, t1 in ((np.array([1.0, 2.0]), 0.0), (np.zeros(0), 1.0)):
        got = solve_segment(lambda t, y: -y, 0.0, t1, y0, LeanLSODA, [])
        ref = solve_segment(lambda t, y: -y, 0.0, t1, y0, LSODA, [])
        assert got.status == ref.status == 0 and np.array_equal(got.t, ref.t) and np.array_equal(got.y, ref.y)


def test_lsoda_by_name_is_the_lean_stepper():
    assert SOLVERS["LSODA"] is LeanLSODA


def _run(name: str, method: str):
    s = load_scenario(name)
    s.options = dataclasses.replace(s.options, method=method)
    return s.run()


@pytest.mark.parametrize("name", sorted(bundled_scenarios()))
def test_bundled_scenarios_with_lsoda_are_scipy_lsoda_bit_for_bit(name, monkeypatch):
    """Every bundled scenario integrated with LSODA (whatever its own method): event times, all
    output arrays, spans and counters the same with the lean stepper as with scipy's class."""
    got = _run(name, "LSODA")
    monkeypatch.setitem(ode_solvers.SOLVERS, "LSODA", LSODA)
    ref = _run(name, "LSODA")
    assert got.success == ref.success and got.message == ref.message
    assert [(e.t, e.kind) for e in got.events] == [(e.t, e.kind) for e in ref.events]
    assert np.array_equal(got.time, ref.time)
    assert set(got.signals) == set(ref.signals)
    for k in ref.signals:
        assert np.array_equal(got.signals[k], ref.signals[k], equal_nan=True), k
    assert got.modes == ref.modes
    assert got.stats["rhs_evaluations"] == ref.stats["rhs_evaluations"]
    assert got.stats["segments"] == ref.stats["segments"]


@settings(max_examples=40, deadline=None, derandomize=True)
@given(st.sampled_from(["LSODA", "BDF", "RK45"]), st.booleans(), st.integers(0, 2**32 - 1))
def test_lean_ode_solution_is_scipys(method, backwards, seed):
    """The segment's solution (:class:`LeanOdeSolution`) at unsorted times with repeats, step
    ends, times outside the segment: scipy's :class:`OdeSolution` on the same steps, bit for bit."""
    from scipy.integrate import OdeSolution

    rng = np.random.default_rng(seed)
    A = np.array([[-0.2, 6.0], [-6.0, -0.2]])
    t1 = -2.0 if backwards else 2.0
    got = solve_segment(lambda t, y: A @ y, 0.0, t1, np.array([1.0, 0.5]), method, [], rtol=1e-6, atol=1e-9)
    sol = got.sol
    if not hasattr(sol, "side"):
        pytest.skip("scipy < 1.11: OdeSolution has no alt_segment; LeanOdeSolution calls scipy's own")
    ref = OdeSolution(sol.ts, sol.interpolants, alt_segment=sol.side == ("right" if not backwards else "left"))
    assert ref.side == sol.side
    ts = np.concatenate([rng.uniform(-0.1, 2.1, 30) * np.sign(t1), rng.choice(got.t, 8), got.t[:3]])
    rng.shuffle(ts)
    assert np.array_equal(sol(ts), ref(ts))
    assert np.array_equal(sol(np.sort(ts)), ref(np.sort(ts)))  # sorted: no permutation
    assert np.array_equal(sol(ts[:1]), ref(ts[:1])) and np.array_equal(sol(ts[0]), ref(ts[0]))


def test_lean_lsoda_falls_back_to_scipys_step(monkeypatch):
    """A scipy whose LSODA keeps other state (here: another compiled routine) runs scipy's own
    step and dense output."""
    monkeypatch.setattr(ode_solvers, "lsoda_routine", lambda: None)
    A = np.array([[-0.2, 6.0], [-6.0, -0.2]])
    got = solve_segment(lambda t, y: A @ y, 0.0, 2.0, np.array([1.0, 0.5]), LeanLSODA, [], rtol=1e-7, atol=1e-9)
    ref = solve_segment(lambda t, y: A @ y, 0.0, 2.0, np.array([1.0, 0.5]), LSODA, [], rtol=1e-7, atol=1e-9)
    assert not any(getattr(ip, "_flat", None) is not None for ip in got.sol.interpolants)
    _same_segment(got, ref, 2)
