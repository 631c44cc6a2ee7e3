"""The turbodiesel's compiled kernels (sim/engine/kernels.py, sim/engine/compiled.py) against the
same functions run by the interpreter, against the look-up and root finder they replace
(transgen.sim.core.interp, scipy's brentq), and against the engine's equations written out here."""
import math
import re
import warnings

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from transgen.sim.engine import (RPM, MapRangeWarning, TurbochargedDiesel, default_compressor_table,
                                 default_turbine_table, exhaust_temperature)
from transgen.sim.engine import kernels as K
from transgen.sim.engine.compiled import kernels
from transgen.sim.engine.turbocharger import ChokedFlowError, IterativeTurbo, PortAreas
from transgen.sim.core.interp import bilinear, locate
from transgen.errors import SimulationError

ENGINES = {kind: TurbochargedDiesel(turbo=kind, rack=0.7) for kind in ("basic", "iterative")}
STATE = ENGINES["basic"].initial_state(1500 * RPM)


@pytest.fixture(autouse=True)
def _quiet_maps():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", MapRangeWarning)
        yield


def _both(kind, p_im, p_em, w_tc, omega_e, u_f):
    """``(status, out)`` of the compiled and of the interpreted evaluation (own warm starts)."""
    eng = ENGINES[kind]
    ev, P, c, t, TB, warm = eng._kernel_inputs
    results = []
    for f in (ev, K.engine_evaluate):
        out, work = np.full(K.N_OUT, -1.0), np.empty(K.N_SOLVE)
        with np.errstate(all="ignore"):  # the interpreter's numpy scalars warn where the compiled code is silent
            status = f(P, c, t, TB, np.ones((2, 3)), p_im, p_em, w_tc, omega_e, u_f, out, work)
        results.append((int(status), out))
    return results


@settings(max_examples=60, deadline=None)
@given(kind=st.sampled_from(["basic", "iterative"]), p_im=st.floats(0.9e5, 3.2e5), ratio=st.floats(0.8, 1.6),
       w_tc=st.floats(0.0, 130_000 * RPM), rpm=st.floats(0.0, 2400.0), mg=st.floats(0.0, 220.0))
def test_compiled_evaluation_equals_the_interpreted_one(kind, p_im, ratio, w_tc, rpm, mg):
    (s_fast, fast), (s_ref, ref) = _both(kind, p_im, p_im * ratio, w_tc, rpm * RPM, mg * 1e-6)
    assert s_fast == s_ref
    if s_fast == K.OK:
        np.testing.assert_allclose(fast, ref, rtol=1e-12, atol=0.0)
    else:  # what the error message reads
        np.testing.assert_allclose(fast[K.O_INFO0:K.O_INFO1 + 1], ref[K.O_INFO0:K.O_INFO1 + 1], rtol=1e-12)


def _old_compressor_lookup(tab, N_corr, PR):
    """The compressor look-up as it was written before the kernels (transgen.sim.core.interp on lists)."""
    speed, chi_grid = tab.speed.tolist(), tab.chi.tolist()
    stall_l, span_l = tab.pr_stall.tolist(), (tab.pr_surge - tab.pr_stall).tolist()
    m_l, e_l = tab.mass_flow.tolist(), tab.efficiency.tolist()

    def in_range(N, pr):
        i, wx, _ = locate(speed, N)
        stall = stall_l[i] + wx * (stall_l[i + 1] - stall_l[i])
        span = span_l[i] + wx * (span_l[i + 1] - span_l[i])
        chi = (pr - stall) / span
        j, wy, _ = locate(chi_grid, chi)
        return bilinear(m_l, i, wx, j, wy), bilinear(e_l, i, wx, j, wy), chi

    if N_corr < speed[0]:
        r = max(N_corr, 0.0) / speed[0]
        m, eta, chi = in_range(speed[0], 1.0 + (PR - 1.0) / max(r * r, 1e-12))
        return r * m, eta, chi
    return in_range(N_corr, PR)


@settings(max_examples=200, deadline=None)
@given(n=st.floats(-1000.0, 16000.0), pr=st.floats(0.5, 4.0), er=st.floats(0.5, 5.0))
def test_table_lookups_equal_the_interpolation_they_replace(n, pr, er):
    ctab, ttab = default_compressor_table(), default_turbine_table()
    assert ctab.lookup(n, pr) == _old_compressor_lookup(ctab, n, pr)
    i, wx, _ = locate(ttab.speed.tolist(), n)
    j, wy, _ = locate(ttab.expansion_ratio.tolist(), er)
    assert ttab.lookup(n, er) == (bilinear(ttab.mass_flow.tolist(), i, wx, j, wy),
                                  bilinear(ttab.efficiency.tolist(), i, wx, j, wy))


def test_locate_on_arrays_is_interp_locate():
    grid = np.array([0.0, 0.5, 1.5, 4.0])
    for v in (-1.0, 0.0, 0.2, 0.5, 1.0, 1.5, 3.9, 4.0, 5.0, math.inf, -math.inf):
        assert kernels().locate(grid, v) == locate(grid.tolist(), v) == K.locate(grid, v)
    i, w, out = kernels().locate(grid, math.nan)
    assert (i, out) == locate(grid.tolist(), math.nan)[::2] and math.isnan(w)


@pytest.mark.parametrize("device", ["compressor", "turbine"])
def test_brent_fallback_is_scipy_brentq_step_for_step(device):
    """With the secant path off the solve is Brent's method on a bracket: the same root as
    scipy's brentq on the same residual and bracket."""
    from scipy.optimize import brentq

    turbo = IterativeTurbo()
    dev = (turbo.compressor if device == "compressor" else turbo.turbine).kernel_device
    a = PortAreas()
    args = ((1.0e5, 298.0, 2.2e5, 90_000 * RPM, a.compressor_inlet, a.compressor_outlet) if device == "compressor"
            else (2.6e5, 900.0, 1.0e5, 90_000 * RPM, a.turbine_inlet, a.turbine_outlet))
    st_ = np.empty(K.N_SOLVE)
    status = K.solve_device(dev, *args, np.ones(3), 1e-13, 60, 1e-12, 50, 0, st_)
    assert status == K.OK
    m = st_[K.S_M]
    unpacked = K.unpack_device(dev)
    work = np.empty(K.N_SOLVE)
    basic = K.machine_flow(unpacked, *args[:4])
    m_star = min(args[0] * args[4] * math.sqrt(unpacked[11] / (unpacked[12] * args[1])),
                 args[2] * args[5] * math.sqrt(unpacked[11] * (unpacked[11] + 1) / (2 * unpacked[12] * basic[1])))
    work[:] = 0.0
    work[K.S_T02] = basic[1]
    status, lo, hi = K._bracket(unpacked, *args, 50, 1e-12, work, basic[0], 0.999 * m_star, basic[0])
    assert status == K.OK

    def residual(x):
        return K.device_residual(unpacked, *args, x, 50, 1e-12, work)

    assert m == brentq(residual, lo, hi, xtol=1e-13, maxiter=60)
    compiled = np.empty(K.N_SOLVE)
    assert kernels().solve_device(dev, *args, np.ones(3), 1e-13, 60, 1e-12, 50, 0, compiled) == K.OK
    assert compiled[K.S_M] == pytest.approx(m, rel=1e-14)


@pytest.mark.parametrize("kind", ["basic", "iterative"])
def test_engine_derivatives_are_the_manifold_and_shaft_equations(kind):
    """The evaluation composed by hand from the public pieces (cylinder flow, exhaust temperature,
    turbocharger, shaft) and the manifold equations of the diesel module's docstring."""
    eng = TurbochargedDiesel(turbo=kind, rack=0.7)
    p, w = eng.params, 1400 * RPM
    x = eng.initial_state(w) * np.array([1.03, 0.98, 1.05])
    u_f = eng.fuel(0.3, w)
    dx, torque = eng.derivatives(0.3, x, w), eng.torque(0.3, x, w)
    sig = eng.signals(0.3, x, w)
    n_e = w / RPM
    eta_vol = p.c_vol[0] * math.sqrt(x[0]) + p.c_vol[1] * math.sqrt(n_e) + p.c_vol[2]
    W_ei = eta_vol * x[0] * n_e * p.V_d / (120 * p.air.R * p.T_im)
    W_f = u_f * n_e * p.n_cyl / 120
    T_em, *_ = exhaust_temperature(p, x[0], x[1], W_f / W_ei, W_ei + W_f)
    eng.turbo.reset()
    tp = eng.turbo.evaluate(p.p_amb, p.T_amb, x[0], x[1], T_em, p.p_amb, x[2])
    expected = (p.air.R * p.T_im * (tp.compressor.m_dot - W_ei) / p.V_im,
                p.exhaust.R * T_em * (W_ei + W_f - tp.turbine.m_dot) / p.V_em,
                (tp.turbine.torque - tp.compressor.torque) / p.shaft.inertia)
    np.testing.assert_allclose(dx, expected, rtol=1e-9, atol=1e-6 * np.abs(expected).max())
    assert sig["eta_vol"] == pytest.approx(eta_vol, rel=1e-12) and sig["T_em"] == pytest.approx(T_em, rel=1e-9)
    assert sig["torque_engine"] == torque == eng.crank_torque(0.3, x, w)
    assert sig["m_dot_c"] == pytest.approx(tp.compressor.m_dot, rel=1e-9)
    assert sig["chi"] == pytest.approx(tp.compressor.chi, rel=1e-9)


def test_engine_errors_name_the_device_time_and_reason():
    tiny = IterativeTurbo(ports=PortAreas(turbine_inlet=1e-5))
    eng = TurbochargedDiesel(turbo=tiny)
    with pytest.raises(ChokedFlowError, match=r"engine at t = 1.25 s: turbine \(p_in = .*choked flow"):
        eng.derivatives(1.25, STATE, 1500 * RPM)
    with pytest.raises(SimulationError, match="residual-gas fixed point did not converge in 1 iterations"):
        exhaust_temperature(eng.params, 2e5, 2.2e5, 0.03, 0.4, maxiter=1)


def test_out_of_map_warning_from_the_compiled_evaluation_names_the_map_once():
    eng = TurbochargedDiesel(turbo="iterative")
    x = np.array([1.2e5, 1.3e5, 250_000 * RPM])  # far above the top speed line
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        eng.derivatives(0.0, x, 1500 * RPM)
        eng.derivatives(0.1, x, 1500 * RPM)
    texts = [str(w.message) for w in caught if issubclass(w.category, MapRangeWarning)]
    assert len([t for t in texts if t.startswith("compressor map")]) == 1
    assert any("rpm" in t and "outside the data" in t for t in texts)


def test_a_turbo_solve_failure_stops_the_run_naming_device_time_and_reason():
    from transgen.sim.scenario.load import load_scenario

    r = load_scenario("ht740_turbo_iterative", {"input.ports.turbine_inlet": 0.0011}).run()
    assert not r.success
    assert re.search(r"engine at t = [0-9.]+ s: turbine \(p_in = .*\): no subsonic solution", r.message), r.message


def test_without_numba_the_engine_runs_interpreted_with_a_warning(monkeypatch):
    import builtins
    import sys

    import transgen.sim.engine.compiled as compiled

    real_import = builtins.__import__

    def no_numba(name, *args, **kwargs):
        if name == "numba" or name.startswith("numba."):
            raise ImportError("no numba here")
        return real_import(name, *args, **kwargs)

    monkeypatch.setattr(builtins, "__import__", no_numba)
    monkeypatch.delitem(sys.modules, "numba", raising=False)
    monkeypatch.setattr(compiled, "_COMPILED", None)
    with pytest.warns(RuntimeWarning, match="numba is not installed"):
        plain = compiled.kernels()
    assert plain.engine_evaluate is K.engine_evaluate
    monkeypatch.undo()  # the engine below compiled, and this one through the interpreter, agree
    eng = TurbochargedDiesel(turbo="iterative", rack=0.7)
    eng._kernels = plain
    ref = TurbochargedDiesel(turbo="iterative", rack=0.7)
    x = STATE * np.array([1.02, 0.99, 1.01])
    np.testing.assert_allclose(eng.derivatives(0.2, x, 1500 * RPM), ref.derivatives(0.2, x, 1500 * RPM), rtol=1e-12)


@settings(max_examples=25, deadline=None)
@given(n_chi=st.integers(3, 41), every=st.integers(1, 4), p_im=st.floats(0.95e5, 3.0e5), ratio=st.floats(0.9, 1.5),
       w_tc=st.floats(5_000 * RPM, 140_000 * RPM), rpm=st.floats(600.0, 2200.0))
def test_other_table_sizes_compile_to_the_same_numbers(n_chi, every, p_im, ratio, w_tc, rpm):
    """Any grid the pre-processor makes (here: other chi resolutions, a thinned expansion-ratio
    grid) goes through the same compiled code: compiled = interpreted, both algorithms."""
    from transgen.sim.engine import DATA_DIR, load_map, preprocess_compressor, preprocess_turbine
    from transgen.sim.engine.compressor import Compressor
    from transgen.sim.engine.turbine import Turbine
    from transgen.sim.engine.turbocharger import BasicTurbo

    tmap = load_map(DATA_DIR / "we_turbine.toml")
    er = preprocess_turbine(tmap).expansion_ratio
    devices = (Compressor(preprocess_compressor(load_map(DATA_DIR / "we_compressor.toml"), n_chi=n_chi)),
               Turbine(preprocess_turbine(tmap, er[::every] if er[::every][-1] == er[-1] else np.r_[er[::every], er[-1]])))
    for turbo in (BasicTurbo(*devices), IterativeTurbo(*devices)):
        eng = TurbochargedDiesel(turbo=turbo)
        ev, P, c, t, TB, _ = eng._kernel_inputs
        results = []
        for f in (ev, K.engine_evaluate):
            out, work = np.full(K.N_OUT, -1.0), np.empty(K.N_SOLVE)
            with np.errstate(all="ignore"):
                status = f(P, c, t, TB, np.ones((2, 3)), p_im, p_im * ratio, w_tc, rpm * RPM, 1.2e-4, out, work)
            results.append((int(status), out))
        (s_fast, fast), (s_ref, ref) = results
        assert s_fast == s_ref
        if s_fast == K.OK:
            np.testing.assert_allclose(fast, ref, rtol=1e-12, atol=0.0)
