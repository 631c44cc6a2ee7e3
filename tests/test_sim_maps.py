"""Maps: file round trip, the chi pre-processor (thesis eqs 4.23-4.25), guards and warnings."""
import math
import warnings

import numpy as np
import pytest

from transgen.sim.engine import (
    DATA_DIR, RPM, CompressorMap, CompressorSpeedLine, MapError, MapLine, MapRangeWarning,
    TurbineMap, TurbineSpeedLine, WECompressorFit, WETurbineFit, chi_coordinate, LiUCompressorFit, DEFAULT_FLOW_SCALE,
    CHOKE_EFFICIENCY, DEFAULT_SPEED_SCALE, generate_we_compressor_map,
    default_compressor_table, default_turbine_table, generate_compressor_map,
    generate_turbine_map, load_map, preprocess_compressor, preprocess_turbine, save_map)


def _hand_map(surge_pr_low=1.2):
    """Two speed lines whose chi values are easy to check by hand."""
    lines = (CompressorSpeedLine(1000.0, (0.3, 0.2, 0.1), (1.0, 1.1, surge_pr_low),
                                 (0.6, 0.7, 0.65)),
             CompressorSpeedLine(2000.0, (0.6, 0.45, 0.3), (1.0, 1.4, 1.8), (0.5, 0.75, 0.7)))
    return CompressorMap("hand", lines, MapLine((1000.0, 2000.0), (0.1, 0.3), (surge_pr_low, 1.8)),
                         MapLine((1000.0, 2000.0), (0.3, 0.6), (1.0, 1.0)), 298.0, 1e5,
                         (("source", "hand-made test data"),))


def test_chi_coordinate_eq_4_25():
    assert chi_coordinate(1.5, 1.0, 2.0) == 0.5
    assert chi_coordinate(1.0, 1.0, 2.0) == 0.0          # stall line
    assert chi_coordinate(2.0, 1.0, 2.0) == 1.0          # surge line
    assert chi_coordinate(2.2, 1.0, 2.0) == pytest.approx(1.2)   # > 1: surge side


def test_chi_guard_where_surge_and_stall_lines_meet():
    with pytest.raises(MapError, match="0/0"):
        chi_coordinate(1.0, 1.0, 1.0)
    with pytest.raises(MapError, match=r"speed line .* rpm.*0/0"):
        preprocess_compressor(_hand_map(surge_pr_low=1.0))


def test_preprocessor_chi_tables_by_hand():
    tab = preprocess_compressor(_hand_map(), n_chi=3)
    np.testing.assert_allclose(tab.chi, [0.0, 0.5, 1.0])
    np.testing.assert_allclose(tab.mass_flow, [[0.3, 0.2, 0.1], [0.6, 0.45, 0.3]])
    np.testing.assert_allclose(tab.efficiency, [[0.6, 0.7, 0.65], [0.5, 0.75, 0.7]])
    # N = 1500: PR_stall = 1, span = (0.2 + 0.8)/2 = 0.5, so PR = 1.3 gives chi = 0.6;
    # flow: 0.18 on the 1000 line, 0.42 on the 2000 line -> 0.30.
    m, eta, chi = tab.lookup(1500.0, 1.3)
    assert chi == pytest.approx(0.6)
    assert m == pytest.approx(0.30)
    assert eta == pytest.approx(0.5 * (0.7 - 0.2 * 0.05) + 0.5 * (0.75 - 0.2 * 0.05))


def test_out_of_data_warns_once_and_clamps():
    tab = preprocess_compressor(_hand_map(), n_chi=3)
    with warnings.catch_warnings(record=True) as rec:
        warnings.simplefilter("always")
        m, _, chi = tab.lookup(2500.0, 2.5)                # above the top line, surge side
        tab.lookup(500.0, 0.9)                             # below the lowest line, stalled
    assert [w.category for w in rec] == [MapRangeWarning]
    assert "N_corr" in str(rec[0].message) and "PR = 2.5000" in str(rec[0].message)
    assert m == pytest.approx(0.3)                         # clamped to the surge flow
    assert chi == pytest.approx((2.5 - 1.0) / 0.8)         # chi itself is reported unclamped


def test_below_the_lowest_speed_line_fan_laws():
    tab = default_compressor_table()
    n0 = tab.speed[0]
    with pytest.warns(MapRangeWarning, match="below the lowest speed line"):
        half = tab.lookup(0.5 * n0, 1.0 + 0.25 * 0.005)
    assert half[0] == pytest.approx(0.5 * tab.lookup(n0, 1.005)[0])      # similar point
    assert tab.lookup(0.0, 1.0)[0] == 0.0                                  # standstill
    assert tab.lookup(n0 * (1 - 1e-9), 1.002)[0] == pytest.approx(tab.lookup(n0, 1.002)[0])


def test_round_trip(tmp_path):
    for m in (generate_compressor_map(), generate_turbine_map(), _hand_map()):
        back = load_map(save_map(m, tmp_path / "map.toml"))
        assert back == m


def test_shipped_maps_are_the_generator_output():
    assert load_map(DATA_DIR / "we_compressor.toml") == generate_compressor_map()
    assert load_map(DATA_DIR / "we_turbine.toml") == generate_turbine_map()
    text = (DATA_DIR / "we_compressor.toml").read_text()
    assert text.startswith("# Compressor map") and "Sivertsson" in text and "Moore" in text


def test_load_map_reports_all_problems(tmp_path):
    path = tmp_path / "bad.toml"
    path.write_text('format = "transgen-turbine-map"\nversion = 1\n[reference]\n'
                    'temperature = 873.0\n[[speed_line]]\nspeed = 1.0\n'
                    'expansion_ratio = [1.0, 2.0]\nmass_flow = [0.0]\nefficiency = [0.5, 0.6]\n')
    with pytest.raises(MapError) as err:
        load_map(path)
    msg = str(err.value)
    assert str(path) in msg and "pressure" in msg


def test_map_validation():
    with pytest.raises(MapError, match="efficiency"):
        TurbineMap("t", (TurbineSpeedLine(1.0, (1.0, 2.0), (0.0, 0.1), (0.5, 1.5)),
                         TurbineSpeedLine(2.0, (1.0, 2.0), (0.0, 0.1), (0.5, 0.5))), 873.0, 1e5)


def test_generated_tables_reproduce_the_fit():
    fit, tab = LiUCompressorFit(flow_scale=DEFAULT_FLOW_SCALE, speed_scale=DEFAULT_SPEED_SCALE), default_compressor_table()
    # On a speed line, at the map's own points (PR equally spaced from surge to choke = chi
    # equally spaced, chi = 1 at surge and 0 at choke, by the fit's own equations).
    for n in (30_000, 60_000, 105_000):
        w = n * RPM
        i = list(tab.speed).index(w)
        m_s, pr_s = fit.surge_point(w)
        m_c, pr_c = fit.choke_point(w, CHOKE_EFFICIENCY)
        assert (tab.pr_surge[i], tab.pr_stall[i]) == (pytest.approx(pr_s), pytest.approx(pr_c))
        assert tab.mass_flow[i, -1] == pytest.approx(m_s) and tab.mass_flow[i, 0] == pytest.approx(m_c)
        for chi in (0.0, 0.25, 0.5, 0.75, 1.0):
            pr = pr_c + chi * (pr_s - pr_c)
            m, eta, c = tab.lookup(w, pr)
            assert c == pytest.approx(chi)
            assert m == pytest.approx(fit.mass_flow(w, pr), rel=2e-3)
            assert eta == pytest.approx(fit.efficiency(w, fit.mass_flow(w, pr)), abs=5e-3)
    # Between speed lines, within a few per cent.
    w, pr = 70_000 * RPM, 1.5
    assert tab.lookup(w, pr)[0] == pytest.approx(fit.mass_flow(w, pr), rel=0.03)
    tfit, ttab = WETurbineFit(vgt_position=55.0), default_turbine_table()
    for er in (1.0, 1.5, 2.5, 4.0):
        m, _ = ttab.lookup(80_000 * RPM, er)
        assert m == pytest.approx(tfit.mass_flow(ttab.p_ref, ttab.T_ref, er), rel=1e-9)


def test_turbine_table_flow_rises_from_zero_with_expansion_ratio():
    tab = preprocess_turbine(generate_turbine_map())
    flows = [tab.lookup(60_000 * RPM, er)[0] for er in (1.0, 1.01, 1.5, 3.0, 5.0)]
    assert flows[0] == 0.0
    assert all(b > a for a, b in zip(flows, flows[1:]))


def test_reference_magnitudes_of_the_we_compressor():
    """Zero-flow PR and flow at PR = 1 against the research note's table (section 2.1)."""
    fit = WECompressorFit()
    for krpm, pr0, w1 in ((40, 1.25, 0.21), (60, 1.75, 0.34), (100, 3.75, 0.72)):
        w = krpm * 1000 * RPM
        assert fit.pressure_ratio(w, fit.zero_flow_head(w)) == pytest.approx(pr0, abs=0.01)
        assert fit.mass_flow(w, 1.0) == pytest.approx(w1, abs=0.01)
    assert math.isclose(preprocess_compressor(generate_we_compressor_map()).T_ref, fit.T_amb)
