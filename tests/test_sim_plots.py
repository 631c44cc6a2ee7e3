"""Result plots: every plot returns a labelled Figure with the shift phases shaded, plot_all writes
its files atomically, compare overlays runs."""
import numpy as np
import pytest

pytest.importorskip("matplotlib")

from matplotlib.figure import Figure  # noqa: E402

from transgen.sim.analysis.plots import (PLOTS, compare, plot_all, plot_apply, plot_io_torques, plot_mode,  # noqa: E402
                                plot_power, plot_shift, plot_slips, plot_speeds, plot_torques, shift_window)
from transgen.sim.analysis.report import shift_report  # noqa: E402


def _cases():
    """The simple2 run and the synthetic result of test_sim_report.py (tests/ is no package)."""
    import importlib.util
    from pathlib import Path

    spec = importlib.util.spec_from_file_location("_sim_report_cases", Path(__file__).with_name("test_sim_report.py"))
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module.run_simple2, module.synthetic


run_simple2, synthetic = _cases()

FUNCS = [plot_speeds, plot_slips, plot_torques, plot_io_torques, plot_power, plot_mode, plot_apply]
NAMES = ["speeds", "slips", "torques", "io_torques", "power", "mode", "apply"]
ALL = NAMES + ["drive"]  # plot_all's whole-run figures (plot_drive: panels of its own)


@pytest.fixture(scope="module")
def s2():
    r = run_simple2()
    return r, shift_report(r)


@pytest.mark.parametrize("func", FUNCS, ids=NAMES)
def test_plot_returns_labelled_figure(s2, func):
    r, qs = s2
    fig = func(r, qs)
    assert isinstance(fig, Figure)
    ax = fig.axes[0]
    assert ax.get_xlabel() == "time [s]"
    assert "[" in ax.get_ylabel() and "]" in ax.get_ylabel()  # units
    assert ax.get_title()
    assert ax.get_lines()
    # torque and inertia phase shaded
    assert len(ax.patches) >= 2
    # the legend sits outside the axes in a figure of our own (it hides no curve)
    assert ax.get_legend() is None and len(fig.legends) == 1
    labels = [t.get_text() for t in fig.legends[0].get_texts()]
    assert "torque phase" in labels and "inertia phase" in labels


@pytest.mark.parametrize("func", FUNCS, ids=NAMES)
def test_plot_into_given_axes_and_window(s2, func):
    r, qs = s2
    fig = Figure()
    ax = fig.add_subplot()
    assert func(r, qs, ax=ax, time_window=(4.9, 6.0)) is fig
    assert ax.get_xlim() == pytest.approx((4.9, 6.0))
    assert ax.get_legend() is not None and not fig.legends  # inside the caller's axes
    for line in ax.get_lines():
        x = line.get_xdata()
        if len(x) > 2:  # data lines (not axhline)
            assert min(x) >= 4.9 and max(x) <= 6.0


def test_plot_without_qualities(s2):
    r, _ = s2
    for func in FUNCS:
        fig = func(r)
        assert isinstance(fig, Figure) and not fig.axes[0].patches


def test_speeds_secondary_rpm_and_links(s2):
    r, qs = s2
    fig = plot_speeds(r, qs)
    ax = fig.axes[0]
    labels = [line.get_label() for line in ax.get_lines()]
    assert "Li (input)" in labels and "Lo (output)" in labels and "La" in labels
    rpm_axes = [c for c in ax.get_children() if c.__class__.__name__ == "SecondaryAxis"]
    assert rpm_axes and "rpm" in rpm_axes[0].get_ylabel()


def test_mode_tick_labels(s2):
    r, qs = s2
    ax = plot_mode(r, qs).axes[0]
    ticks = [t.get_text() for t in ax.get_yticklabels()]
    assert ticks == ["1 [C1]", "none", "2 [C2]"]  # the gears by name (transgen.names), the speed phase by its locked set


def test_power_in_kw(s2):
    r, qs = s2
    ax = plot_power(r, qs).axes[0]
    assert "kW" in ax.get_ylabel()
    peak = max(max(line.get_ydata()) for line in ax.get_lines())
    assert peak == pytest.approx(qs[0].peak_power["C2"] / 1e3, rel=1e-9)


def test_plot_all_writes_files_atomically(s2, tmp_path):
    r, qs = s2
    out = tmp_path / "plots"
    paths = plot_all(r, qs, out, formats=("png", "svg"))
    assert sorted(p.name for p in paths) == sorted(f"{n}.{f}" for n in ALL + ["shift_1-2"] for f in ("png", "svg"))
    assert sorted(p.name for p in out.iterdir()) == sorted(p.name for p in paths)  # no temp files left
    for p in paths:
        assert p.stat().st_size > 1000
    assert (out / "speeds.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    zoom = plot_all(r, qs, out, time_window=(4.9, 6.0), prefix="zoom_")
    assert [p.name for p in zoom] == [f"zoom_{n}.png" for n in ALL]
    assert not [p for p in out.iterdir() if p.name.startswith(".")]
    assert set(PLOTS) == set(ALL)


def test_plot_all_failure_leaves_no_temp(s2, tmp_path):
    r, qs = s2
    with pytest.raises(ValueError):
        plot_all(r, qs, tmp_path, formats=("nosuchformat",))
    assert not list(tmp_path.iterdir())


def test_compare(s2):
    r, qs = s2
    r2 = run_simple2(c1=((0, 5.1, 5.2), (1, 1, 0)))
    fig = compare({"original": r, "improved": r2}, "T_out", qualities={"original": qs}, time_window=(4.8, 6.2))
    ax = fig.axes[0]
    assert [line.get_label() for line in ax.get_lines()] == ["original", "improved"]
    assert ax.get_xlabel() == "time [s]" and ax.get_ylabel() == "T_out [N*m]"
    assert len(ax.patches) == 2
    assert [t.get_text() for t in fig.legends[0].get_texts()] == ["original", "improved", "torque phase",
                                                                  "inertia phase"]
    with pytest.raises(KeyError):
        compare({"a": r}, "nope")


def test_synthetic_plots():
    r = synthetic()
    qs = shift_report(r)
    for func in FUNCS:
        assert isinstance(func(r, qs), Figure)


def test_shift_figure_zooms_on_the_shift(s2):
    """simple2 has no vehicle mass: speeds, element torques and output torque only."""
    r, (q,) = s2
    t0, t1 = shift_window(r, q)
    assert t0 < q.t_start and t1 > q.shift_end and t1 - t0 < 2.0  # not the whole 4 s run
    fig = plot_shift(r, q)
    assert len(fig.axes) == 3
    assert fig.axes[-1].get_xlim() == pytest.approx((t0, t1)) and fig.axes[-1].get_xlabel() == "time [s]"
    for ax in fig.axes:
        assert len(ax.patches) >= 2 and "[" in ax.get_ylabel()  # phases shaded, units
    labels = [line.get_label() for line in fig.axes[1].get_lines()]
    assert [x for x in labels if not x.startswith("_")] == ["C2 (on)", "+-C2 static x apply", "C1 (off)",
                                                            "+-C1 static x apply"]
    # the envelope is static capacity x apply (C2: 2000 N*m, thesis Table 3.1)
    env = fig.axes[1].get_lines()[1]
    x, y = env.get_xdata(), env.get_ydata()
    assert y == pytest.approx(2000.0 * np.interp(x, r.time, r["apply_C2"]), rel=1e-9)
    assert "torque hole" in fig.axes[0].get_title()


def test_shift_figure_with_vehicle_has_acceleration_and_jerk(tmp_path):
    from transgen.sim.scenario.load import load_scenario

    sc = load_scenario("ht740_improved", {"simulation.t_end": 5.5})
    r = sc.run()
    (q,) = shift_report(r, sc.shifts or None)
    fig = plot_shift(r, q)
    assert [ax.get_ylabel() for ax in fig.axes] == ["speed [rpm]", "element torque [N*m]", "torque [N*m]",
                                                    "acceleration [m/s^2]", "jerk [m/s^3]"]
    assert [line.get_label() for line in fig.axes[3].get_lines()][:2] == ["vehicle acceleration",
                                                                         "ISO 2631-1 Wd-weighted"]
    jerk_line = fig.axes[4].get_lines()[0]
    assert max(abs(jerk_line.get_ydata())) == pytest.approx(q.jerk_max, rel=1e-9)
    paths = plot_all(r, [q], tmp_path)
    assert (tmp_path / "shift_1-2.png").stat().st_size > 10000 and len(paths) == len(ALL) + 1
