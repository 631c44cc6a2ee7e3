"""The compiled right-hand side (transgen.sim.solve.kernel) gives the numbers of the Python one: the state
derivative, the input vector and the torque events' holding margins of every bundled scenario's
powertrain at random states, times, modes and slip directions; every signal kind (hypothesis over
random signals and tables); a powertrain mixing compiled and Python-only components and signals
runs to the same events and speeds as the Python path."""
from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from transgen.sim.solve import kernel as K
from transgen.sim.model.components import Component, Driveline, EngineMap, EngineWithConverter, InputTorque, LinkLoad
from transgen.sim.solve.integration import ComponentEvaluator, StateLayout, _partial_jacobian
from transgen.sim.core.interp import interp2
from transgen.sim.core.jit import compiled
from transgen.sim.scenario.library import bundled_scenarios
from transgen.sim.scenario.load import load_scenario
from transgen.sim.core.signals import Constant, Periodic, Pulse, Ramp, Signal, Sine, Spliced, Step, Sum, Table
from transgen.sim.solve.simulate import simulate
from transgen.sim.solve.switching import _add_slipping
from transgen.sim.model.transmission import APPLY_THRESHOLD

def _compiled_available() -> bool:
    """Whether compiled forms can be had here (numba installed, TRANSGEN_JIT not 0). Not
    :func:`~transgen.sim.core.jit.jit_enabled`: a process of single runs takes the Python path until the kernels are
    built, and these tests compare the two paths whatever this process chose."""
    import importlib.util
    import os

    return os.environ.get("TRANSGEN_JIT", "1") != "0" and importlib.util.find_spec("numba") is not None


pytestmark = pytest.mark.skipif(not _compiled_available(), reason="numba not installed or TRANSGEN_JIT=0")


def _python(pt, mode, layout, active, t, y):
    """The Python path of transgen.sim.solve.switching: derivative, input vector, holding margins."""
    tr = pt.transmission
    model = ComponentEvaluator(pt)
    q = y[:mode.dof]
    w = mode.C @ q
    u, derivs, p_in, diss, p_load = model.external(t, y, w, layout)
    slips = (tr.P @ mode.C @ q).tolist()
    diss = _add_slipping(u, t, slips, active, diss)
    dy = layout.derivative(mode.B @ u, derivs, p_in, diss, p_load)
    u_in = model.inputs(t, y, w, layout)
    _add_slipping(u_in, t, slips, active)
    margins = [tr.holding_margin(mode, row, t, (mode.D @ u_in)[row]) for row in range(len(mode.locked_order))]
    return dy, u, np.array(margins)


def _close(a, b, what):
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    scale = 1.0 + np.max(np.abs(b), initial=0.0)
    assert a.shape == b.shape and np.allclose(a, b, rtol=1e-11, atol=1e-11 * scale), (what, a, b)


@pytest.mark.parametrize("name", sorted(bundled_scenarios()))
def test_compiled_rhs_equals_the_python_one(name):
    _compare_compiled_with_python(name)


#: a shifts' torque request (issue 12) spanning a cut, no change and a boost up to full load
_REQUEST = {"type": "table", "t": [0.0, 5.0, 10.0, 15.0, 20.0], "value": [0.3, 1.0, 1.6, 0.8, 1.2]}


@pytest.mark.parametrize("kind", ["engine_converter", "engine_map"])
def test_the_engine_torque_request_compiles_to_the_python_numbers(kind):
    overrides = {"input.torque_request": _REQUEST}
    if kind == "engine_map":  # the engine map on the input link (no converter)
        overrides["input.type"] = "engine_map"
    _compare_compiled_with_python("ht740_original", overrides)


def test_the_idle_governor_of_an_engine_map_compiles_to_the_python_numbers():
    """An engine map on the input link with an idle governor (the engine of a mechanism with its
    own converter, transgen.own_converter): idle far above the random states' speeds, so the
    governed throttle is what both paths compute."""
    _compare_compiled_with_python("ht740_original", {"input.type": "engine_map", "input.idle_rpm": 3000.0})
    pt = load_scenario("ht740_original", {"input.type": "engine_map", "input.idle_rpm": 3000.0}).powertrain
    engine = next(c for c in pt.components if hasattr(c, "idle"))
    w = np.zeros(len(pt.transmission.links))
    w[engine.link] = 0.5 * engine.idle  # half idle: the governor opens the throttle fully
    assert engine.signals(0.0, None, w)["throttle"] == 1.0


def test_an_engine_under_a_torque_request_samples_its_right_hand_side_numbers():
    """The output sampling of an engine behind a converter under a shift's torque request (one loop
    over the output times, compiled where the simulator is) gives the per-point numbers of its
    right-hand side bit for bit: the engine torque with the request, the governed throttle (speeds
    below idle included), the converter's torques."""
    import numba  # noqa: F401 - compiled_loop compiles where numba is loaded, as in a simulation

    pt = load_scenario("ht740_original", {"input.torque_request": _REQUEST}).powertrain
    [engine] = [c for c in pt.components if isinstance(c, EngineWithConverter)]
    rng = np.random.default_rng(12)
    n = 64
    ts = np.sort(rng.uniform(0.0, 20.0, n))
    omega_e = rng.uniform(0.2, 1.5, n) * max(engine.idle, 50.0)
    W = np.zeros((len(pt.transmission.links), n))
    W[engine.link] = rng.uniform(0.0, 1.0, n) * omega_e
    _, signals, _ = engine.sample(ts, omega_e[None, :], W)
    assert np.array_equal(signals["T_engine"], [engine._engine_torque(t, w) for t, w in zip(ts, omega_e)])
    assert np.array_equal(signals["throttle"], [engine._throttle(t, w) for t, w in zip(ts, omega_e)])
    pump, turbine = zip(*(engine.converter.torques(a, b) for a, b in zip(omega_e, W[engine.link])))
    assert np.array_equal(signals["T_pump"], pump) and np.array_equal(signals["T_in"], turbine)
    assert len(set(signals["torque_request"])) > 3  # the request varies over the times sampled


def _compare_compiled_with_python(name, overrides=None):
    pt = load_scenario(name, overrides or {}).powertrain
    tr = pt.transmission
    rng = np.random.default_rng(sum(map(ord, name)))
    cp = K.CompiledPowertrain(pt)
    w0 = np.asarray(pt.initial_speeds, dtype=float)
    comp0 = [np.asarray(c.initial_state(w0), dtype=float) for c in pt.components]
    modes = list(tr.std_modes)
    checked = 0
    for mode in modes:
        layout = StateLayout(pt.components, mode.dof)
        for _ in range(6):
            directions = rng.choice([-1, 1], len(tr.elements))
            active = tr.slipping_set(mode.locked, directions)
            watched = [i for i, e in enumerate(tr.elements) if e.kind != "oneway"]
            slips = [(d * (tr.P[i] @ mode.C), 1e-6 * i) for i, d in enumerate(directions)]
            seg = cp.segment(mode, layout, active, watched, slips)
            t = float(rng.uniform(0.0, 20.0))
            q = rng.uniform(-1.0, 1.0, mode.dof) * 150.0
            states = [x * (1.0 + 0.05 * rng.uniform(-1, 1, len(x))) + (rng.uniform(-1, 1, len(x)) if len(x) and
                      c.state_names and "omega" in c.state_names[-1] else 0.0) for c, x in zip(pt.components, comp0)]
            y = np.concatenate([q] + states + [rng.uniform(0, 1, 3)])
            dy, u, margins = _python(pt, mode, layout, active, t, y)
            _close(seg.rhs(t, y), dy, ("rhs", name, mode.name, t))
            _close(seg.inputs(t, y), u, ("inputs", name, mode.name, t))
            applies = [tr.elements[i].apply.value(t) - APPLY_THRESHOLD for i in watched]
            slip_values = [float(row @ y[:mode.dof]) + offset for row, offset in slips]
            _close(seg.events(t, y), np.concatenate([slip_values, applies, margins]), ("events", name, mode.name, t))
            if seg.jacobian is not None:  # the compiled Jacobian: integrate's differences of the compiled rhs
                n_dynamic = layout.energy.start
                assert np.array_equal(seg.jacobian(t, y, n_dynamic), _partial_jacobian(seg.rhs, len(y), n_dynamic)(t, y))
            checked += 1
    assert checked >= 6


def _signals():
    numbers = st.floats(-50.0, 50.0, allow_nan=False)
    positive = st.floats(0.05, 5.0)

    @st.composite
    def table(draw):
        n = draw(st.integers(1, 6))
        steps = draw(st.lists(st.sampled_from([0.0, 0.3, 1.0, 2.5]), min_size=n, max_size=n))
        times = list(np.cumsum(steps) + draw(st.floats(-2.0, 2.0)))
        return Table(tuple(times), tuple(draw(st.lists(numbers, min_size=n, max_size=n))))

    leaves = st.one_of(
        st.builds(Constant, numbers),
        st.builds(Step, numbers.map(lambda x: x / 10), numbers, numbers),
        st.builds(lambda a, d, v0, v1: Ramp(a, a + d, v0, v1), numbers.map(lambda x: x / 10), positive, numbers, numbers),
        table(),
        st.builds(Sine, numbers, numbers, positive, st.floats(-3.0, 3.0)),
        st.builds(lambda t0, w, lo, hi, p: Pulse(t0, w, lo, hi, None if p is None else w + p), numbers.map(lambda x: x / 10),
                  positive, numbers, numbers, st.none() | positive),
        st.builds(lambda tab, extra: Periodic(tab, max(tab.times[-1] - tab.times[0], 0.0) + extra), table(), positive),
    )
    return st.recursive(leaves, lambda inner: st.one_of(
        st.builds(lambda parts: Sum(tuple(parts)), st.lists(inner, min_size=1, max_size=3)),
        st.builds(Spliced, numbers.map(lambda x: x / 10), inner, inner)), max_leaves=6)


@settings(max_examples=60, deadline=None)
@given(_signals(), st.lists(st.floats(-8.0, 8.0, allow_nan=False), min_size=1, max_size=8))
def test_every_signal_kind_compiles_to_its_value(signal, times):
    enc = K._Encoder()
    start, end = enc.signal(signal)
    P, F = np.array(enc.P, dtype=np.int64), np.array(enc.F + [0.0])
    value = compiled(K.signal_value)
    for t in times + list(signal.breakpoints(-8.0, 8.0) if not isinstance(signal, (Periodic,)) else []):
        assert value(t, start, end, P, F, np.zeros(1)) == pytest.approx(signal.value(t), rel=1e-13, abs=1e-12), t


@settings(max_examples=40, deadline=None)
@given(st.integers(2, 5), st.integers(1, 4), st.data())
def test_compiled_table_lookups_equal_the_python_ones(n_x, n_y, data):
    xs = tuple(np.cumsum(data.draw(st.lists(st.floats(0.1, 100.0), min_size=n_x, max_size=n_x))))
    ys = tuple(np.cumsum(data.draw(st.lists(st.floats(0.01, 1.0), min_size=n_y, max_size=n_y))))
    table = tuple(tuple(data.draw(st.lists(st.floats(-500, 500), min_size=n_x, max_size=n_x))) for _ in ys)
    x = data.draw(st.floats(-10.0, xs[-1] + 10.0))
    y = data.draw(st.floats(-1.0, ys[-1] + 1.0))
    got = compiled(interp2)(x, y, np.array(xs), np.array(ys), np.array(table))
    assert got == interp2(x, y, xs, ys, table) == EngineMap(xs, ys, table)(x, y)


class _PythonDrag(Component):
    """A component without a compiled form, with a state: a first-order lagging drag torque on a link."""

    name = "drag"
    state_names = ("lagged",)

    def __init__(self, link, gain, tau):
        self.link, self.gain, self.tau = link, gain, tau

    def evaluate(self, t, x, w):
        return self.torques(t, x, w), [(self.gain * float(w[self.link]) - x[0]) / self.tau], 0.0, \
            x[0] * float(w[self.link]), 0.0

    def torques(self, t, x, w):
        return {"T_in": -float(x[0])}


@dataclasses.dataclass(frozen=True)
class _Chirp(Signal):
    """A signal of its own class (no compiled form): evaluated in Python."""

    base: Signal

    def value(self, t):
        return self.base.value(t) * (1.0 + 0.1 * math.sin(3.0 * t))

    def breakpoints(self, t0=-math.inf, t1=math.inf):
        return self.base.breakpoints(t0, t1)


def test_a_powertrain_mixing_compiled_and_python_parts_runs_as_the_python_path(monkeypatch):
    base = load_scenario("simple2_upshift")
    pt = base.powertrain
    tr = pt.transmission
    inp = next(c for c in pt.components if isinstance(c, InputTorque))
    mixed = [InputTorque(_Chirp(inp.signal), inp.link), _PythonDrag(inp.link, 0.2, 0.05)]
    mixed += [c for c in pt.components if not isinstance(c, InputTorque)]
    pt2 = dataclasses.replace(pt, components=mixed)
    cp = K.CompiledPowertrain(pt2)
    assert cp.external and cp.python  # the chirp and the drag run in Python, the rest compiled
    options = dataclasses.replace(base.options, t_end=min(base.options.t_end, 8.0))
    fast = simulate(pt2, options)
    monkeypatch.setenv("TRANSGEN_JIT", "0")
    slow = simulate(pt2, options)
    assert fast.success and slow.success, (fast.message, slow.message)
    assert [(e.kind, e.elements) for e in fast.events] == [(e.kind, e.elements) for e in slow.events]
    assert np.allclose([e.t for e in fast.events], [e.t for e in slow.events], rtol=0, atol=1e-9)
    out = fast.meta["links"][-1]
    grid = np.linspace(0.0, options.t_end, 801)
    a = np.interp(grid, fast.time, fast[f"w_{out}"])
    b = np.interp(grid, slow.time, slow[f"w_{out}"])
    assert np.max(np.abs(a - b)) < 1e-6 * max(1.0, np.max(np.abs(b)))
    assert fast.energy["relative_residual"] < 1e-6


def test_a_subclass_that_changes_the_physics_runs_in_python():
    class Stiffer(Driveline):
        def evaluate(self, t, x, w):
            return super().evaluate(t, x, w)

    class Louder(LinkLoad):
        def kernel_form(self):
            return super().kernel_form()

    pt = load_scenario("ht740_improved").powertrain
    drive = next(c for c in pt.components if isinstance(c, Driveline))
    stiff = Stiffer(**{f.name: getattr(drive, f.name) for f in dataclasses.fields(Driveline) if f.init})
    pt2 = dataclasses.replace(pt, components=[stiff if c is drive else c for c in pt.components])
    cp = K.CompiledPowertrain(pt2)
    assert [c for c, *_ in cp.python] == [stiff]
    assert Louder("T_in", 0).kernel_form()[0] == "link_load"  # a subclass that says it compiles does


def test_reading_a_scenario_does_not_load_numba(tmp_path):
    import subprocess
    import sys

    code = ("import sys; from transgen.sim.scenario.load import load_scenario; load_scenario('ht740_improved'); "
            "assert 'numba' not in sys.modules, 'numba loaded'")
    subprocess.run([sys.executable, "-c", code], check=True, cwd=tmp_path)  # not the checkout: the installed package


@pytest.mark.parametrize("method", ["LSODA", "BDF"])
def test_dense_output_in_one_call_equals_scipys(method):
    import numba  # noqa: F401  (the compiled loop runs once numba is loaded, as in a simulation)

    from transgen.sim.solve.dense import dense_values
    from transgen.sim.solve.ode_solvers import SOLVERS, solve_segment

    def rhs(t, y):
        return np.array([y[1], -4.0 * y[0] - 0.3 * y[1] + np.sin(3.0 * t), y[1] * y[1]])

    sol = solve_segment(rhs, 0.0, 12.0, np.array([1.0, 0.5, 0.0]), SOLVERS.get(method, method), [],
                        rtol=1e-7, atol=1e-9)
    ts = np.concatenate([np.linspace(0.0, 12.0, 997), sol.t, [6.0, 0.0, 12.0]])  # step ends too, unsorted
    expected = sol.sol(ts)
    got = dense_values(sol.sol, ts)
    assert got.shape == expected.shape
    assert np.allclose(got, expected, rtol=1e-14, atol=1e-14)


@settings(max_examples=30, deadline=None)
@given(st.lists(st.sampled_from([0.0, 0.25, 1.0]), min_size=1, max_size=7), st.data())
def test_a_tables_samples_are_its_values(steps, data):
    import numba  # noqa: F401  (the compiled loop runs once numba is loaded, as in a simulation)

    times = tuple(np.cumsum(steps))
    table = Table(times, tuple(data.draw(st.lists(st.floats(-9.0, 9.0), min_size=len(times), max_size=len(times)))))
    ts = np.concatenate([np.linspace(times[0] - 1.0, times[-1] + 1.0, 40), times])
    assert np.allclose(table.sample(ts), [table.value(t) for t in ts], rtol=1e-14, atol=1e-14)
