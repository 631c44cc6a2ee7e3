"""Plots of the turbocharged engine (thesis chapter 4) and of turbocharger maps.

Run comparison, both turbo algorithms overlaid (thesis Figs. 4.17-4.24), each figure with the
difference (second run minus first) underneath, shift phases shaded:

* :func:`plot_turbo_signal` - one signal of several runs (turbo speed, chi, mass flows,
  temperature rise and drop, PR, ER: :data:`THESIS_SIGNALS`);
* :func:`plot_engine_overview` - engine and turbine speeds, engine torque, boost, vehicle speed;
* :func:`plot_operating_points` - the runs' compressor operating points on the compressor map;
* :func:`plot_turbo_comparison` - all of the above written to files.

Maps (``transgen maps``), thesis Figs. 4.4, 4.6, 4.7, 4.10, 4.11:

* :func:`plot_compressor_map` - the manufacturer-format map: speed lines of pressure ratio over
  corrected flow, surge and stall lines, efficiency contours;
* :func:`plot_compressor_tables` - the transformed causal tables ``m_corr(N_corr, chi)`` and
  ``eta(N_corr, chi)`` (surfaces);
* :func:`plot_turbine_map` - turbine speed lines (flow and efficiency over expansion ratio);
* :func:`plot_turbine_tables` - ``m_corr(N_corr, ER)`` and ``eta(N_corr, ER)`` (surfaces);
* :func:`plot_map_file` - the plots of one map file written to files.

The text and JSON summary of a map (``transgen maps``) is :mod:`transgen.sim.engine.map_summary`.

Only matplotlib's object API is used (``matplotlib.figure.Figure``, no ``pyplot``); files are
written atomically with :func:`transgen.drawing.save_figure`.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from .diesel import EngineParams
from .gas import RPM
from .map_file import DATA_DIR, CompressorMap, TurbineMap, load_map
from .preprocessor import CompressorTable, TurbineTable, preprocess_compressor, preprocess_turbine
from .turbo_report import unique_times

__all__ = [
    "THESIS_SIGNALS",
    "plot_turbo_signal",
    "plot_engine_overview",
    "plot_operating_points",
    "plot_turbo_comparison",
    "plot_chi_port_areas",
    "plot_compressor_map",
    "plot_compressor_tables",
    "plot_turbine_map",
    "plot_turbine_tables",
    "plot_map_file",
]

KRPM = 1.0 / (RPM * 1e3)
RUN_COLORS = ("#1f5fa8", "#d1495b", "#2a9d3f", "#8e6bbf")
RUN_STYLES = ("-", "--", "-.", ":")
SHIFT_COLOR = "#9aa5b1"
DPI = 150

THESIS_SIGNALS = (
    # file name, signal, scale, y label, title
    ("fig4_17_turbo_speed", "omega_tc", KRPM, "turbo speed [krpm]", "Turbocharger speed (thesis Fig. 4.17)"),
    ("fig4_18_chi", "chi", 1.0, "chi [-]", "Normalized pressure coordinate chi (thesis Fig. 4.18)"),
    ("fig4_19_compressor_flow", "m_dot_c", 1.0, "mass flow [kg/s]", "Compressor mass flow (thesis Fig. 4.19)"),
    ("fig4_20_turbine_flow", "m_dot_t", 1.0, "mass flow [kg/s]", "Turbine mass flow (thesis Fig. 4.20)"),
    ("fig4_21_compressor_temperature_rise", "dT_c", 1.0, "T0_out - T0_in, total to total [K]",
     "Compressor gas temperature increase (thesis Fig. 4.21)"),
    ("fig4_22_turbine_temperature_drop", "dT_t", 1.0, "T0_in - T0_out, total to total [K]",
     "Turbine gas temperature decrease (thesis Fig. 4.22)"),
    ("fig4_23_compressor_pressure_ratio", "PR_c", 1.0, "pressure ratio p_out/p_in [-]",
     "Compressor pressure ratio (thesis Fig. 4.23)"),
    ("fig4_24_turbine_expansion_ratio", "ER_t", 1.0, "expansion ratio p_in/p_out [-]",
     "Turbine expansion ratio (thesis Fig. 4.24)"),
)
"""The signals of thesis Figs. 4.17-4.24: (file stem, signal, scale, y label, title)."""


# ----------------------------------------------------------------------------- helpers
def _figure(figsize=(9.0, 5.0)):
    from matplotlib.figure import Figure

    return Figure(figsize=figsize, dpi=110, layout="constrained")


def _runs(results) -> list[tuple[str, object]]:
    """``{label: Result}`` or a sequence of results -> [(label, result)]."""
    if isinstance(results, dict):
        return list(results.items())
    out = []
    for r in results:
        meta = r.meta or {}
        out.append((str(meta.get("title") or meta.get("scenario") or f"run {len(out) + 1}"), r))
    return out


def _shift_spans(result) -> list[tuple[float, float, str]]:
    """Shifts of a run from its events: from an element other than a lock-up clutch unlocking to
    the next such element locking, labelled with the modes (e.g. ``1 -> 2``)."""
    spans = []
    start = None
    for e in result.events:
        if e.kind == "start" or all(n.startswith("LU") for n in e.elements):
            continue
        if e.kind in ("unlock", "switch") and start is None:
            start = e
        elif e.kind == "lock" and start is not None:
            spans.append((start.t, e.t, f"{start.source} -> {e.target}"))
            start = None
    return spans


def _shade_shifts(ax, result, label: bool = True):
    for a, b, text in _shift_spans(result):
        ax.axvspan(a, b, color=SHIFT_COLOR, alpha=0.25, lw=0, zorder=0)
        if label:
            ax.annotate(text.replace(" -> ", "-"), xy=((a + b) / 2, 1.0), xycoords=("data", "axes fraction"),
                        xytext=(0, 2), textcoords="offset points", ha="center", va="bottom", fontsize="x-small",
                        color="#44505c")


def _label_for(label: str) -> str:
    """Short legend label: the algorithm name when the title names one."""
    low = label.lower()
    for key, text in (("iterative", "iterative (thesis 'improved')"), ("basic", "basic (thesis 'original')")):
        if key in low:
            return text
    return label


# ----------------------------------------------------------------------------- run comparison
def plot_turbo_signal(results, signal: str, scale: float = 1.0, ylabel: str = "", title: str = "",
                      difference: bool = True):
    """One signal of several runs overlaid over time; with two runs and ``difference``, a lower
    panel shows the second minus the first (time-aligned). Shift phases of the first run are
    shaded and labelled. Returns the Figure."""
    runs = _runs(results)
    two = difference and len(runs) == 2
    fig = _figure((9.0, 5.6 if two else 4.6))
    if two:
        gs = fig.add_gridspec(2, 1, height_ratios=(3.0, 1.25))
        ax = fig.add_subplot(gs[0])
        axd = fig.add_subplot(gs[1], sharex=ax)
    else:
        ax, axd = fig.add_subplot(), None
    for k, (label, r) in enumerate(runs):
        if signal not in r.signals:
            raise ValueError(f"run '{label}' has no signal '{signal}' (not a turbodiesel run?)")
        ax.plot(r.time, r.signals[signal] * scale, color=RUN_COLORS[k % 4], ls=RUN_STYLES[k % 4], lw=1.6,
                label=_label_for(label))
    _shade_shifts(ax, runs[0][1])
    ax.set_ylabel(ylabel or signal)
    ax.set_title(title or signal, pad=14)
    ax.grid(True, alpha=0.35)
    ax.legend(loc="best", fontsize="small", framealpha=0.9)
    t0, t1 = float(runs[0][1].time[0]), float(runs[0][1].time[-1])
    ax.set_xlim(t0, t1)
    if axd is None:
        ax.set_xlabel("time [s]")
        return fig
    ax.tick_params(labelbottom=False)
    (la, ra), (lb, rb) = runs
    ta, ya = unique_times(ra.time, ra.signals[signal] * scale)
    tb, yb = unique_times(rb.time, rb.signals[signal] * scale)
    d = np.interp(ta, tb, yb) - ya
    axd.axhline(0.0, color="#555555", lw=0.8)
    axd.plot(ta, d, color="#6b4c9a", lw=1.3)
    _shade_shifts(axd, ra, label=False)
    unit = ylabel[ylabel.rfind("["):] if "[" in ylabel else ""
    axd.set_ylabel(f"difference {unit}".strip(), fontsize="small")
    axd.set_xlabel("time [s]")
    axd.grid(True, alpha=0.35)
    axd.set_title(f"{_label_for(lb).split(' (')[0]} - {_label_for(la).split(' (')[0]}", fontsize="small", loc="left")
    return fig


def plot_engine_overview(results):
    """Engine (input link) and turbine speeds, engine torque, boost pressure ratio and vehicle
    speed of the runs, with the shift phases and lock-up spans of the first run."""
    runs = _runs(results)
    fig = _figure((9.0, 8.0))
    axes = fig.subplots(4, 1, sharex=True)
    first = runs[0][1]
    inp = (first.meta or {}).get("input_link", "E")
    for k, (label, r) in enumerate(runs):
        c, ls = RUN_COLORS[k % 4], RUN_STYLES[k % 4]
        lab = _label_for(label)
        axes[0].plot(r.time, r.signals[f"w_{inp}"] / RPM, color=c, ls=ls, lw=1.6, label=f"engine ({inp}), {lab}")
        if "w_L1" in r.signals and k == 0:
            axes[0].plot(r.time, r.signals["w_L1"] / RPM, color="#888888", lw=1.2, label="turbine (L1)")
        axes[1].plot(r.time, r.signals["torque_engine"], color=c, ls=ls, lw=1.6, label=lab)
        axes[2].plot(r.time, r.signals["boost_pressure_ratio"], color=c, ls=ls, lw=1.6, label=lab)
        if "vehicle_speed_mph" in r.signals:
            axes[3].plot(r.time, r.signals["vehicle_speed_mph"], color=c, ls=ls, lw=1.6, label=lab)
    if "locked_LU" in first.signals:
        t, lu = first.time, first.signals["locked_LU"] > 0.5
        edges = np.flatnonzero(np.diff(lu.astype(int))) + 1
        bounds = np.concatenate([[0], edges, [len(t)]])
        for a, b in zip(bounds[:-1], bounds[1:]):
            if lu[a]:
                axes[0].axvspan(t[a], t[b - 1], color="#f4d35e", alpha=0.3, lw=0, zorder=0)
        from matplotlib.patches import Patch

        handles, _ = axes[0].get_legend_handles_labels()
        handles.append(Patch(facecolor="#f4d35e", alpha=0.5, label="lock-up LU locked"))
        axes[0].legend(handles=handles, loc="lower right", fontsize="x-small", framealpha=0.9)
    else:
        axes[0].legend(loc="lower right", fontsize="x-small")
    for ax, ylabel in zip(axes, ("speed [rpm]", "engine torque [N*m]", "boost PR [-]", "vehicle speed [mph]")):
        _shade_shifts(ax, first, label=ax is axes[0])
        ax.set_ylabel(ylabel)
        ax.grid(True, alpha=0.35)
    axes[1].legend(loc="lower right", fontsize="x-small")
    axes[-1].set_xlabel("time [s]")
    axes[0].set_xlim(float(first.time[0]), float(first.time[-1]))
    axes[0].set_title("Engine, converter and vehicle", pad=14)
    return fig


def plot_operating_points(results, cmap: CompressorMap | None = None):
    """The compressor operating points of the runs (corrected flow, pressure ratio) on the
    compressor map (default: the bundled one)."""
    cmap = cmap or load_map(DATA_DIR / "we_compressor.toml")
    fig = plot_compressor_map(cmap)
    ax = fig.axes[0]
    for k, (label, r) in enumerate(_runs(results)):
        if "N_corr_c" not in r.signals:
            continue
        # corrected at the ambient (static) inlet state: the bundled map's reference state is the
        # engine's ambient, so this is the actual flow (the iterative algorithm reads the map
        # with the inlet total state, a fraction of a percent away)
        p = EngineParams()
        m_corr = r.signals["m_dot_c"] * (cmap.p_ref / p.p_amb) * np.sqrt(p.T_amb / cmap.T_ref)
        ax.plot(m_corr, r.signals["PR_c"], color=RUN_COLORS[k % 4], ls=RUN_STYLES[k % 4], lw=1.4,
                label=f"operating points, {_label_for(label)}", zorder=5)
    flows = [np.max(r.signals["m_dot_c"]) for _, r in _runs(results) if "m_dot_c" in r.signals]
    prs = [np.max(r.signals["PR_c"]) for _, r in _runs(results) if "PR_c" in r.signals]
    if flows:  # zoom on the region the runs use
        ax.set_xlim(0.0, 1.35 * max(flows))
        ax.set_ylim(0.85, 1.0 + 1.3 * (max(prs) - 1.0))
    ax.legend(loc="upper left", fontsize="x-small", framealpha=0.9)
    ax.set_title("Compressor operating points of the runs on the map", pad=8)
    return fig


def plot_chi_port_areas(result, engine):
    """Thesis Fig. 4.18's finding and its dependence on the port areas: the chi shift of the
    iterative algorithm against the basic one on the same states of ``result`` (no engine
    feedback), per compressor-flow bin, with the engine's ports and with a 76 mm compressor
    outlet (:func:`~transgen.sim.engine.turbo_report.algorithm_difference`)."""
    from .turbo_report import algorithm_difference

    d = algorithm_difference(result, engine)
    fig = _figure((8.0, 4.6))
    ax = fig.add_subplot()
    for k, (run, style) in enumerate(((d, "-o"), (d.get("alternative"), "--s"))):
        if not run or not run["bins"]:
            continue
        x = [0.5 * (b["flow_lo"] + b["flow_hi"]) for b in run["bins"]]
        mm = run["ports_mm"]
        ax.plot(x, [b["d_chi"] for b in run["bins"]], style, color=RUN_COLORS[k],
                label=f"compressor ports {mm['compressor_inlet']:g} mm in / {mm['compressor_outlet']:g} mm out")
    ax.axhline(0.0, color="#555555", lw=0.8)
    ax.set_xlabel("compressor mass flow of the basic algorithm [kg/s]")
    ax.set_ylabel("chi(iterative) - chi(basic) [-]")
    ax.set_title("Chi shift of the iterative algorithm on the same states (thesis Fig. 4.18):\n"
                 "its sign depends on the compressor's outlet/inlet port areas", fontsize="medium")
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize="small")
    return fig


def plot_turbo_comparison(results, directory=".", formats=("png",), prefix: str = "",
                          engine=None) -> list[Path]:
    """Write the thesis Fig. 4.17-4.24 comparisons, the engine overview and the operating points
    of ``results`` (``{label: Result}`` or a list) to ``directory`` as
    ``<prefix><name>.<format>``; with ``engine`` (the first run's TurbochargedDiesel) also the
    chi shift for two compressor port areas (:func:`plot_chi_port_areas`). Returns the paths."""
    from transgen.drawing import save_figure

    directory = Path(directory)
    jobs = [(stem, lambda s=signal, sc=scale, yl=ylabel, ti=title: plot_turbo_signal(results, s, sc, yl, ti))
            for stem, signal, scale, ylabel, title in THESIS_SIGNALS]
    if engine is not None:
        first = _runs(results)[0][1]
        jobs.append(("fig4_18_chi_port_areas", lambda: plot_chi_port_areas(first, engine)))
    jobs.append(("engine_overview", lambda: plot_engine_overview(results)))
    jobs.append(("compressor_operating_points", lambda: plot_operating_points(results)))
    paths = []
    for stem, make in jobs:
        fig = make()
        for fmt in formats:
            paths.append(save_figure(fig, directory / f"{prefix}{stem}.{fmt}", dpi=DPI))
    return paths


# ----------------------------------------------------------------------------- maps
def _speed_colors(n: int):
    from matplotlib import colormaps

    cm = colormaps["viridis"]
    return [cm(0.05 + 0.85 * i / max(n - 1, 1)) for i in range(n)]


def plot_compressor_map(cmap: CompressorMap, table: CompressorTable | None = None):
    """Manufacturer-format compressor map (thesis Fig. 4.4): pressure ratio over corrected mass
    flow for each speed line (labelled in krpm), the surge and stall lines, and efficiency
    contours between them (from the causal tables, i.e. on the chi grid of each speed line)."""
    table = table or preprocess_compressor(cmap)
    fig = _figure((9.0, 6.2))
    ax = fig.add_subplot()
    # efficiency contours on the (N, chi) grid mapped to (flow, PR)
    pr = table.pr_stall[:, None] + table.chi[None, :] * (table.pr_surge - table.pr_stall)[:, None]
    levels = np.arange(0.40, 0.76, 0.05)
    cs = ax.contourf(table.mass_flow, pr, table.efficiency, levels=levels, extend="both", cmap="YlOrRd", alpha=0.55,
                     zorder=0)
    cl = ax.contour(table.mass_flow, pr, table.efficiency, levels=levels, colors="#7a3b10", linewidths=0.6, zorder=1)
    ax.clabel(cl, fmt="%.2f", fontsize="x-small")
    cb = fig.colorbar(cs, ax=ax, pad=0.01)
    cb.set_label("isentropic efficiency [-]")
    colors = _speed_colors(len(cmap.speed_lines))
    x_max = max(max(s.mass_flow) for s in cmap.speed_lines)
    last = -np.inf
    for c, s in zip(colors, cmap.speed_lines):
        ax.plot(s.mass_flow, s.pressure_ratio, color=c, lw=1.3, zorder=3)
        k = int(np.argmax(s.mass_flow))  # label at the stall end, where the lines are apart
        if s.mass_flow[k] - last > 0.04 * x_max:
            ax.annotate(f"{s.speed / RPM / 1e3:.0f}k", (s.mass_flow[k], s.pressure_ratio[k]), xytext=(0, -4),
                        textcoords="offset points", fontsize="x-small", ha="center", va="top", color=c, zorder=4,
                        fontweight="bold")
            last = s.mass_flow[k]
    ax.plot(cmap.surge_line.mass_flow, cmap.surge_line.pressure_ratio, color="#c0392b", lw=2.4, label="surge line",
            zorder=4)
    ax.plot(cmap.stall_line.mass_flow, cmap.stall_line.pressure_ratio, color="#222222", lw=2.0, ls="--",
            label="stall (choke) line", zorder=4)
    ax.plot([], [], color=colors[len(colors) // 2], lw=1.3, label="speed lines (corrected, krpm)")
    ax.set_xlabel(f"corrected mass flow [kg/s] (p_ref = {cmap.p_ref / 1e3:.2f} kPa, T_ref = {cmap.T_ref:.2f} K)")
    ax.set_ylabel("total pressure ratio p02/p01 [-]")
    ax.set_title(f"Compressor map (thesis Fig. 4.4 format)\n{cmap.name}", fontsize="medium")
    ax.grid(True, alpha=0.3)
    ax.set_xlim(0.0, 1.08 * x_max)
    ax.set_ylim(bottom=0.85)
    ax.legend(loc="upper right", fontsize="small", framealpha=0.9)
    return fig


def _surface(x, y, z, xlabel, ylabel, zlabel, title, cmap_name, azim=-128.0):
    """A 3-D surface plot of a table over two inputs, with a labelled colour bar."""
    from matplotlib.figure import Figure

    fig = Figure(figsize=(8.0, 6.2), dpi=110)
    ax = fig.add_axes((0.0, 0.02, 0.86, 0.9), projection="3d")
    X, Y = np.meshgrid(x, y, indexing="ij")
    surf = ax.plot_surface(X, Y, z, cmap=cmap_name, edgecolor="#333333", linewidth=0.25, antialiased=True)
    ax.set_xlabel(xlabel, labelpad=8)
    ax.set_ylabel(ylabel, labelpad=8)
    ax.set_zlabel(zlabel, labelpad=8)
    ax.view_init(elev=26, azim=azim)
    ax.set_box_aspect(None, zoom=0.88)
    cax = fig.add_axes((0.86, 0.18, 0.025, 0.6))
    cb = fig.colorbar(surf, cax=cax)
    cb.set_label(zlabel)
    fig.suptitle(title, fontsize="medium", y=0.97)
    return fig


def plot_compressor_tables(table: CompressorTable):
    """The compressor's causal tables as surfaces over corrected speed [krpm] and chi: corrected
    mass flow (thesis Fig. 4.6) and isentropic efficiency (Fig. 4.7). Returns two Figures."""
    n = table.speed / RPM / 1e3
    return (_surface(n, table.chi, table.mass_flow, "N_corr [krpm]", "chi [-]", "m_corr [kg/s]",
                     f"Compressor mass flow table m_corr(N_corr, chi) (thesis Fig. 4.6)\n{table.name}", "viridis"),
            _surface(n, table.chi, table.efficiency, "N_corr [krpm]", "chi [-]", "efficiency [-]",
                     f"Compressor efficiency table eta(N_corr, chi) (thesis Fig. 4.7)\n{table.name}", "plasma"))


def plot_turbine_map(tmap: TurbineMap):
    """Turbine speed lines in manufacturer format: corrected mass flow and efficiency over the
    expansion ratio."""
    fig = _figure((12.0, 5.0))
    ax1, ax2 = fig.subplots(1, 2)
    colors = _speed_colors(len(tmap.speed_lines))
    for c, s in zip(colors, tmap.speed_lines):
        lab = f"{s.speed / RPM / 1e3:.0f} krpm"
        ax1.plot(s.expansion_ratio, s.mass_flow, color=c, lw=1.3, label=lab)
        ax2.plot(s.expansion_ratio, s.efficiency, color=c, lw=1.3, label=lab)
    ax1.set_ylabel("corrected mass flow [kg/s]")
    ax2.set_ylabel("efficiency [-]")
    for ax, t in ((ax1, "Turbine flow characteristic"), (ax2, "Turbine efficiency")):
        ax.set_xlabel("expansion ratio p01/p02 [-]")
        ax.set_title(t, fontsize="medium")
        ax.grid(True, alpha=0.3)
    fig.legend(*ax2.get_legend_handles_labels(), loc="outside right upper", fontsize="x-small", title="N_corr",
               title_fontsize="x-small")
    fig.suptitle(f"Turbine map: {tmap.name}", fontsize="medium")
    return fig


def plot_turbine_tables(table: TurbineTable):
    """The turbine's causal tables as surfaces over corrected speed [krpm] and expansion ratio:
    corrected mass flow (thesis Fig. 4.10) and efficiency (Fig. 4.11). Returns two Figures."""
    n = table.speed / RPM / 1e3
    return (_surface(n, table.expansion_ratio, table.mass_flow, "N_corr [krpm]", "ER [-]", "m_corr [kg/s]",
                     f"Turbine mass flow table m_corr(N_corr, ER) (thesis Fig. 4.10)\n{table.name}", "viridis", 40.0),
            _surface(n, table.expansion_ratio, table.efficiency, "N_corr [krpm]", "ER [-]", "efficiency [-]",
                     f"Turbine efficiency table eta(N_corr, ER) (thesis Fig. 4.11)\n{table.name}", "plasma", 40.0))


def plot_map_file(m: CompressorMap | TurbineMap, directory=".", formats=("png",), prefix: str = "") -> list[Path]:
    """Write the plots of a map as ``<prefix><name>.<format>``: a compressor gives
    ``fig4_04_compressor_map``, ``fig4_06_compressor_flow_table`` and
    ``fig4_07_compressor_efficiency_table``; a turbine ``turbine_map``,
    ``fig4_10_turbine_flow_table`` and ``fig4_11_turbine_efficiency_table``. Returns the paths
    written."""
    from transgen.drawing import save_figure

    directory = Path(directory)
    if isinstance(m, CompressorMap):
        table = preprocess_compressor(m)
        flow, eta = plot_compressor_tables(table)
        figs = [("fig4_04_compressor_map", plot_compressor_map(m, table)), ("fig4_06_compressor_flow_table", flow),
                ("fig4_07_compressor_efficiency_table", eta)]
    else:
        table = preprocess_turbine(m)
        flow, eta = plot_turbine_tables(table)
        figs = [("turbine_map", plot_turbine_map(m)), ("fig4_10_turbine_flow_table", flow),
                ("fig4_11_turbine_efficiency_table", eta)]
    paths = []
    for stem, fig in figs:
        for fmt in formats:
            paths.append(save_figure(fig, directory / f"{prefix}{stem}.{fmt}", dpi=DPI))
    return paths
