"""The bundled compressor map as thesis Fig. 4.4 draws it (issue 27): a surge line with the
falling branch left of it, a choke line where the flow stops growing, chi (eq. 4.25) 1 on surge
and 0 on choke, no efficiency floor; an operating point left of surge is counted, not hidden."""
import warnings

import numpy as np
import pytest

from transgen.sim.engine import (CHOKE_EFFICIENCY, DATA_DIR, DEFAULT_FLOW_SCALE, DEFAULT_SPEED_SCALE, RPM, LiUCompressorFit,
                                 MapRangeWarning, default_compressor_table, load_map)
from transgen.sim.engine.turbo_report import _time_where


@pytest.fixture(scope="module")
def cmap():
    return load_map(DATA_DIR / "we_compressor.toml")


def test_every_speed_line_has_surge_choke_and_a_branch_left_of_surge(cmap):
    for s in cmap.speed_lines:
        m, pr = np.asarray(s.mass_flow), np.asarray(s.pressure_ratio)
        pr_su = cmap.surge_line.pressure_ratio_at(s.speed)
        pr_ch = cmap.stall_line.pressure_ratio_at(s.speed)
        m_su = float(np.interp(s.speed, cmap.surge_line.speed, cmap.surge_line.mass_flow))
        m_ch = float(np.interp(s.speed, cmap.stall_line.speed, cmap.stall_line.mass_flow))
        assert pr_su > pr_ch >= 1.0 and m_ch > m_su > 0.0
        assert pr.max() == pytest.approx(pr_su)            # the line peaks on the surge line
        # the published surge line, flow scaled: PR = 12.353*m/f + 0.6861
        assert pr_su == pytest.approx(12.3530 * m_su / DEFAULT_FLOW_SCALE + 0.6861, rel=1e-9)
        left = m < m_su * (1 - 1e-9)
        assert left.sum() >= 3
        # left of surge the PR falls with falling flow ...
        assert np.all(np.diff(pr[left]) > 0) and pr[left][-1] < pr_su
        # ... so a PR there is reached twice: also on the stable branch (two flows per PR)
        stable = m >= m_su
        p = pr[left][-1]
        assert pr[stable].min() < p < pr[stable].max()
        # nearly flat at surge: the slope next to surge is small on both sides
        k = int(np.argmax(pr))
        assert abs(pr[k] - pr[k - 1]) / (pr_su - pr_ch) < 0.05
        # choke: below the choke PR the flow stops growing
        below = stable & (pr < pr_ch * (1 - 1e-12))
        if pr_ch > 1.001:
            assert below.sum() >= 2 and np.allclose(m[below], m_ch, rtol=1e-12)
        assert m.max() == pytest.approx(m_ch)


def test_chi_is_one_on_surge_and_zero_on_choke(cmap):
    tab = default_compressor_table()
    fit = LiUCompressorFit(flow_scale=DEFAULT_FLOW_SCALE, speed_scale=DEFAULT_SPEED_SCALE)
    # on the table
    assert tab.chi[0] == 0.0 and tab.chi[-1] == 1.0
    for i, w in enumerate(tab.speed):
        assert tab.mass_flow[i, -1] == pytest.approx(np.interp(w, cmap.surge_line.speed, cmap.surge_line.mass_flow))
        assert tab.mass_flow[i, 0] == pytest.approx(np.interp(w, cmap.stall_line.speed, cmap.stall_line.mass_flow))
        assert np.all(np.diff(tab.mass_flow[i]) < 0)      # flow falls from choke to surge
    # by the map's own equations: exact on the tabulated speed lines; between them the surge and
    # choke lines are interpolated linearly in speed (a few per cent in chi at mid speeds)
    for n, tol in ((30_000, 1e-9), (75_000, 1e-9), (105_000, 1e-9), (50_000, 0.05), (80_000, 0.05), (100_000, 0.05)):
        w = n * RPM
        m_s, pr_s = fit.surge_point(w)
        m_c, pr_c = fit.choke_point(w, CHOKE_EFFICIENCY)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", MapRangeWarning)   # chi a hair outside [0, 1]
            assert tab.lookup(w, pr_s)[2] == pytest.approx(1.0, abs=tol)
            assert tab.lookup(w, pr_c)[2] == pytest.approx(0.0, abs=tol)
            assert tab.lookup(w, pr_s)[0] == pytest.approx(m_s, rel=max(tol, 1e-9) * 2)
            assert tab.lookup(w, pr_c)[0] == pytest.approx(m_c, rel=max(tol, 1e-9) * 2)


def test_no_efficiency_floor_inside_the_map(cmap):
    """The compressor efficiency stays physical over the whole table: no value sits on a floor
    (every speed line has one minimum, at an end of the drawn region) and all lie in (0.4, 0.8)."""
    tab = default_compressor_table()
    assert 0.4 < tab.efficiency.min() and tab.efficiency.max() < 0.8
    for row in tab.efficiency:
        assert np.sum(np.isclose(row, row.min(), rtol=0, atol=1e-9)) == 1
    for s in cmap.speed_lines:     # the drawn lines, left branch and choke segment included
        e = np.asarray(s.efficiency)
        assert e.min() > 0.2 and np.sum(np.isclose(e, e.min(), atol=1e-9)) == 1


def test_surge_is_reported_not_clamped_silently():
    tab = default_compressor_table()
    w = 75_000 * RPM
    pr = tab.pr_surge[list(tab.speed).index(w)] * 1.02
    with pytest.warns(MapRangeWarning, match="chi = 1.0"):
        m, _, chi = tab.lookup(w, pr)
    assert chi > 1.0 and m == pytest.approx(tab.mass_flow[list(tab.speed).index(w), -1])
    t = np.array([0.0, 0.1, 0.2, 0.3, 0.4])
    chi = np.array([0.5, 1.1, 1.2, 0.9, 0.5])
    assert _time_where(t, chi > 1.0) == (pytest.approx(0.2), 0.1)


def test_turbine_efficiency_has_no_floor_or_wall():
    """Figs. 4.10-4.11 (issue 27): the turbine efficiency table has no floor (W&E's 0.2) and no
    wall between speed lines (their c_m(omega) step at 26.4 krpm); it is the published parabola
    near the optimum blade-speed ratio, C1 continued to 0 at BSR = 0 and towards 0 at ER = 1."""
    from transgen.sim.engine import WETurbineFit, default_turbine_table

    tab = default_turbine_table()
    eta = tab.efficiency
    assert np.all(eta[:, 0] == 0.0) and np.all(eta[:, 1:] > 0.0) and eta.max() <= 0.8180028
    for row in eta:                         # one peak per speed line, no plateau on either side
        k = int(np.argmax(row))
        assert np.all(np.diff(row[:k + 1]) > 0) and np.all(np.diff(row[k:]) < 0)
    # neighbouring speed lines at the same ER differ smoothly (no wall): the peak efficiency of
    # every line is the fit's maximum within a few per cent
    assert np.all(eta.max(axis=1) > 0.78)
    # the published parabola holds near the optimum
    fit = WETurbineFit(vgt_position=55.0)
    w = 80_000 * 2 * np.pi / 60
    for er in (1.3, 1.65, 2.0):
        bsr = fit.blade_speed_ratio(w, tab.T_ref, er)
        if abs(bsr - fit.BSR_opt) < 0.3:
            assert fit.smooth_efficiency(w, tab.T_ref, er) == pytest.approx(fit.efficiency(w, tab.T_ref, er), abs=1e-9)
    # C1 at the tangent points
    c, b0, e = fit.c_m_at(w), fit.BSR_opt, fit.eta_max
    b_lo = np.sqrt(b0 * b0 - e / c)
    assert (e - c * (b_lo - b0) ** 2) / b_lo == pytest.approx(-2 * c * (b_lo - b0))
