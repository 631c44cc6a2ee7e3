"""Turbo lag grows with the rotor inertia and the manifold volumes (thesis 4.4.3; the worked
example docs/turbo_lag.md): two runs of the bundled ht740_turbo up to the first shift."""
import pytest


def _report(**keys):
    from transgen.sim.engine.turbo_report import turbo_report
    from transgen.sim.scenario.load import load_scenario

    r = load_scenario("ht740_turbo", {"simulation.t_end": 3.9, **keys}).run()
    assert r.success, r.message
    return turbo_report(r)


def test_lag_grows_with_inertia_and_volumes():
    small = _report(**{"input.shaft.inertia": 1e-4, "input.engine.V_im": 0.011, "input.engine.V_em": 0.010})
    large = _report(**{"input.shaft.inertia": 4e-4, "input.engine.V_im": 0.044, "input.engine.V_em": 0.040})
    assert large.time_to_90_boost > small.time_to_90_boost + 0.1
    assert large.boost_peak < small.boost_peak - 0.1
    for rep in (small, large):     # the launch stays between the surge and choke lines
        assert rep.surge_time == 0.0 and rep.surge_first is None and rep.choke_time == 0.0
        assert 0.0 < rep.chi_min <= rep.chi_max < 1.0
        assert "surge (chi > 1" in rep.text()


def test_temperature_changes_are_total_to_total():
    """Figs. 4.21-4.22 compare like with like: with the iterative algorithm the devices' power is
    m*cp*(total temperature change), so dT_c and dT_t (signals of the run) are totals."""
    import numpy as np

    from transgen.sim.engine import AIR, EXHAUST
    from transgen.sim.scenario.load import load_scenario

    r = load_scenario("ht740_turbo_iterative", {"simulation.t_end": 2.0}).run()
    assert r.success, r.message
    k = np.nonzero(r["m_dot_t"] > 0.2)[0]
    assert len(k) and np.max(r["mach_t_in"][k]) > 0.05
    np.testing.assert_allclose(r["m_dot_c"][k] * AIR.cp * r["dT_c"][k], r["power_c"][k], rtol=1e-6)
    np.testing.assert_allclose(r["m_dot_t"][k] * EXHAUST.cp * r["dT_t"][k], r["power_t"][k], rtol=1e-6)


def test_chi_port_area_figure_shows_both_port_choices():
    from transgen.sim.cli import _engine_of
    from transgen.sim.engine.plots import plot_chi_port_areas
    from transgen.sim.scenario.load import load_scenario

    sc = load_scenario("ht740_turbo", {"simulation.t_end": 3.0})
    r = sc.run()
    fig = plot_chi_port_areas(r, _engine_of(sc))
    labels = [line.get_label() for line in fig.axes[0].get_lines() if not line.get_label().startswith("_")]
    assert labels == ["compressor ports 100 mm in / 100 mm out", "compressor ports 100 mm in / 76 mm out"]
    assert "port areas" in fig.axes[0].get_title()
