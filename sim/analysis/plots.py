"""Plots of a simulation result in the style of thesis Figs. 3.2-3.7 and 3.14-3.25.

Every time plot shades the shift phases from
:class:`~transgen.sim.analysis.shift_quality.ShiftQuality`: the torque phase and the inertia (speed)
phase in two colours. Functions take ``ax=None`` (a new figure) or an axes to draw into, and
return the :class:`matplotlib.figure.Figure`.
``time_window=(t0, t1)`` zooms on a part of the run (the y limits follow the data shown). In a
figure of their own the legend sits outside the axes, right of the plot, so it hides no curve;
drawn into a given axes it goes inside at the best place.

Matplotlib is imported only inside the functions and only its object API is used (no
``pyplot``), so plotting is safe in any thread and with any backend.

* :func:`plot_speeds` - link speeds [rad/s], secondary axis in rpm (input link drawn bold);
* :func:`plot_slips` - slip speeds of the shift elements [rad/s];
* :func:`plot_torques` - torques transmitted by the shift elements [N*m];
* :func:`plot_io_torques` - input and output torques [N*m] (engine torque when present);
* :func:`plot_power` - power dissipated per element [kW];
* :func:`plot_mode` - mode of operation (step plot, mode names and locked elements as ticks);
* :func:`plot_apply` - apply fractions of the shift elements [-];
* :func:`plot_drive` - the whole run: vehicle speed [km/h], engine speed [rpm] and the gear
  (named as the gear table names it) over time;
* :func:`plot_shift` - one shift zoomed on its own time window (phases shaded, events marked):
  input speed with the old and new gears' synchronous speeds, the torques of the elements that
  take part with their holding-capacity envelopes ``+-T_static*apply``, the output torque, the
  vehicle acceleration (raw and frequency-weighted) and the jerk;
* :func:`plot_all` - all of the above written to files (one ``shift_<name>`` figure per shift,
  ``shift_1-2``);
  :func:`compare` - one signal of several runs overlaid.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from transgen.names import locked_text

from ..core.result import Result

__all__ = [
    "plot_speeds",
    "plot_slips",
    "plot_torques",
    "plot_io_torques",
    "plot_power",
    "plot_mode",
    "plot_apply",
    "plot_shift",
    "plot_drive",
    "gear_track",
    "shift_window",
    "shift_files",
    "plot_all",
    "compare",
    "PLOTS",
]

RPM_PER_RAD_S = 60.0 / (2.0 * np.pi)
TORQUE_PHASE_COLOR = "#f4a259"
INERTIA_PHASE_COLOR = "#5b8def"
PHASE_ALPHA = 0.18
FIGSIZE = (10.0, 5.0)
DPI = 120


# ----------------------------------------------------------------------------- helpers
def _axes(ax, figsize=FIGSIZE):
    if ax is not None:
        return ax.figure, ax
    from matplotlib.figure import Figure

    fig = Figure(figsize=figsize, dpi=DPI, layout="constrained")
    ax = fig.add_subplot()
    ax._transgen_own = True  # a figure of our own: the legend goes outside the axes
    return fig, ax


def _mask(result: Result, time_window):
    t = result.time
    if time_window is None:
        return np.ones(len(t), dtype=bool)
    t0, t1 = time_window
    return (t >= t0) & (t <= t1)


def _elements(result: Result, elements=None) -> list[str]:
    if elements is not None:
        return list(elements)
    names = result.meta.get("elements") if result.meta else None
    return list(names or [k[6:] for k in result.signals if k.startswith("apply_")])


def _links(result: Result, links=None) -> list[str]:
    if links is not None:
        return list(links)
    names = result.meta.get("links") if result.meta else None
    return list(names or [k[2:] for k in result.signals if k.startswith("w_")])


def _input_link(result: Result, input_link=None):
    meta = result.meta or {}
    if input_link or meta.get("input_link"):
        return input_link or meta.get("input_link")
    coords = meta.get("coordinates") or []
    return coords[0] if coords else None


def _output_link(result: Result, output_link=None):
    meta = result.meta or {}
    if output_link or meta.get("output_link"):
        return output_link or meta.get("output_link")
    coords = meta.get("coordinates") or []
    return coords[1] if len(coords) > 1 else None


def _colors(n: int):
    from matplotlib import colormaps

    cmap = colormaps["tab10" if n <= 10 else "tab20"]
    return [cmap(i % cmap.N) for i in range(n)]


def _shade(ax, qualities, time_window=None) -> list:
    """Shade the torque and inertia phases; returns legend proxies (once per kind)."""
    from matplotlib.patches import Patch

    handles = []
    kinds = set()
    for q in qualities or ():
        spans = [("torque phase", q.torque_phase_start, q.torque_phase_end, TORQUE_PHASE_COLOR),
                 ("inertia phase", q.inertia_phase_start, q.inertia_phase_end, INERTIA_PHASE_COLOR)]
        for label, a, b, color in spans:
            if a is None or b is None or b <= a:
                continue
            if time_window is not None and (b < time_window[0] or a > time_window[1]):
                continue
            ax.axvspan(a, b, color=color, alpha=PHASE_ALPHA, lw=0, zorder=0)
            kinds.add((label, color))
    for label, color in sorted(kinds, reverse=True):
        handles.append(Patch(facecolor=color, alpha=PHASE_ALPHA * 2, label=label))
    return handles


def _finish(ax, ylabel: str, title: str, handles, time_window, result: Result, legend: bool = True):
    ax.set_xlabel("time [s]")
    ax.set_ylabel(ylabel)
    ax.set_title(title)
    ax.grid(True, alpha=0.4)
    if time_window is not None:
        ax.set_xlim(*time_window)
    elif len(result.time):
        ax.set_xlim(float(result.time[0]), float(result.time[-1]))
    if legend:
        lines, _ = ax.get_legend_handles_labels()
        _legend(ax, lines + list(handles))


def _legend(ax, items):
    """Outside the axes, right of the plot, in a figure of our own (it never hides a curve);
    inside at the best place when drawing into a caller's axes."""
    if not items:
        return
    if getattr(ax, "_transgen_own", False):
        ax.figure.legend(handles=items, loc="outside right upper", fontsize="small",
                         ncol=1 if len(items) <= 16 else 2)
    else:
        ax.legend(handles=items, loc="best", fontsize="small", ncol=1 if len(items) <= 6 else 2, framealpha=0.85)


def _title(result: Result, what: str) -> str:
    mech = (result.meta or {}).get("mechanism", "")
    short = mech.split(" (")[0] if mech else ""
    return f"{what} - {short}" if short else what


_STYLES = ("-", "--", "-.", ":")


def _lines(ax, result: Result, names, labels, mask, scale=1.0, widths=None, colors=None):
    """One line per signal. Signals often coincide (elements locked together): the lines cycle
    through solid, dashed, dash-dotted and dotted so that a line drawn over another still shows
    it; bold lines (``widths``) are drawn solid underneath the others."""
    t = result.time[mask]
    colors = colors or _colors(len(names))
    for k, (n, lab) in enumerate(zip(names, labels)):
        if n not in result.signals:
            continue
        bold = n in (widths or {})
        if bold:
            style, z = "-", 2
        else:
            style, z = _STYLES[k % len(_STYLES)], 3
        ax.plot(t, result.signals[n][mask] * scale, label=lab, color=colors[k], lw=widths[n] if bold else 1.5,
                ls=style, zorder=z)


def _time_plot(result: Result, qualities, ax, time_window, signals, labels, ylabel: str, what: str,
               zero_line: bool = False, **line_options):
    """One line per signal (see :func:`_lines`; ``line_options``: ``scale``, ``widths``,
    ``colors``), a thin line at zero when ``zero_line``, the shift phases shaded, axes labelled
    and titled ``what``. Returns the figure and the axes."""
    fig, ax = _axes(ax)
    _lines(ax, result, signals, labels, _mask(result, time_window), **line_options)
    if zero_line:
        ax.axhline(0.0, color="0.3", lw=0.8)
    handles = _shade(ax, qualities, time_window)
    _finish(ax, ylabel, _title(result, what), handles, time_window, result)
    return fig, ax


# ----------------------------------------------------------------------------- time plots
def plot_speeds(result: Result, qualities=None, ax=None, links=None, time_window=None, input_link=None,
                output_link=None):
    """Link speeds [rad/s] (thesis Figs. 3.2, 3.14, 3.20), with a secondary axis in rpm; the
    input and output links are drawn bold and named."""
    names = _links(result, links)
    inp, out = _input_link(result, input_link), _output_link(result, output_link)
    labels = [f"{k} (input)" if k == inp else (f"{k} (output)" if k == out else k) for k in names]
    widths = {f"w_{k}": 2.6 for k in (inp, out) if k}
    fig, ax = _time_plot(result, qualities, ax, time_window, [f"w_{k}" for k in names], labels, "speed [rad/s]",
                         "Link speeds", widths=widths)
    sec = ax.secondary_yaxis("right", functions=(lambda x: x * RPM_PER_RAD_S, lambda x: x / RPM_PER_RAD_S))
    sec.set_ylabel(f"speed [rpm]{' (input: ' + inp + ')' if inp else ''}")
    return fig


def plot_slips(result: Result, qualities=None, ax=None, elements=None, time_window=None):
    """Slip speeds of the shift elements [rad/s] (thesis Figs. 3.7, 3.15, 3.21)."""
    names = _elements(result, elements)
    return _time_plot(result, qualities, ax, time_window, [f"slip_{e}" for e in names], names, "slip speed [rad/s]",
                      "Shift element slip speeds", zero_line=True)[0]


def plot_torques(result: Result, qualities=None, ax=None, elements=None, time_window=None):
    """Torque transmitted by each shift element, from its link1 to its link2 [N*m] (thesis
    Figs. 3.4, 3.16, 3.22)."""
    names = _elements(result, elements)
    return _time_plot(result, qualities, ax, time_window, [f"t_{e}" for e in names], names,
                      "transmitted torque [N*m]", "Shift element torques", zero_line=True)[0]


def plot_io_torques(result: Result, qualities=None, ax=None, time_window=None):
    """Input torque ``T_in`` and output (driveshaft) torque ``T_out`` [N*m], and the engine
    torque when the run has one (thesis Figs. 3.5, 3.17, 3.23)."""
    names = [n for n in ("T_in", "T_out", "T_engine") if n in result.signals]
    labels = {"T_in": "input torque T_in", "T_out": "output torque T_out", "T_engine": "engine torque"}
    return _time_plot(result, qualities, ax, time_window, names, [labels[n] for n in names], "torque [N*m]",
                      "Input and output torques", zero_line=True,
                      colors=["tab:blue", "tab:red", "tab:gray"][: len(names)])[0]


def plot_power(result: Result, qualities=None, ax=None, elements=None, time_window=None):
    """Power dissipated in each shift element [kW] (thesis Figs. 3.18, 3.24)."""
    names = _elements(result, elements)
    fig, ax = _time_plot(result, qualities, ax, time_window, [f"P_{e}" for e in names], names,
                         "dissipated power [kW]", "Shift element power dissipation", scale=1e-3)
    lo, hi = ax.get_ylim()
    ax.set_ylim(min(lo, 0.0), hi if hi > 0 else 1.0)
    return fig


def plot_mode(result: Result, qualities=None, ax=None, time_window=None):
    """Mode of operation over time (thesis Figs. 3.6, 3.19, 3.25): a step plot with the mode
    names (and their locked elements) as y tick labels."""
    fig, ax = _axes(ax, (10.0, 3.8))
    m = _mask(result, time_window)
    names = list((result.meta or {}).get("mode_names") or [])
    mode = result.signals["mode"]
    ax.plot(result.time[m], mode[m], drawstyle="steps-post", color="tab:purple", lw=2.0, label="mode")
    locked = {s.name: s.locked for s in result.modes}
    if not names:
        names = [str(int(v)) for v in sorted(set(mode.astype(int)))]
    ticks = list(range(1, len(names) + 1))
    ax.set_yticks(ticks)
    shown = {n: locked_text(v) for n, v in locked.items()}
    ax.set_yticklabels([f"{n} [{shown[n]}]" if n in shown and shown[n] != n else n for n in names])
    ax.set_ylim(0.5, len(names) + 0.5)
    handles = _shade(ax, qualities, time_window)
    _finish(ax, "mode [locked elements]", _title(result, "Mode of operation"), handles, time_window, result,
            legend=False)
    _legend(ax, handles)
    return fig


def gear_track(result: Result) -> tuple[np.ndarray, np.ndarray, list[str]]:
    """The gear over the run as a step line: (times [s], level, gear names), level ``k`` the
    ``k``-th gear of the ticks (the run's gears in the gear-table order, ``meta["gears"]``). A
    span in no gear (a shift's speed phase, a freewheel) lies half-way between the gears before
    and after it (at the gear before when none follows)."""
    spans = list(result.modes)
    order = list((result.meta or {}).get("gears") or [])
    seen = [m.gear for m in spans if m.gear is not None]
    ticks = [g for g in order if g in seen] + [g for g in dict.fromkeys(seen) if g not in order]
    level = {g: float(k) for k, g in enumerate(ticks, start=1)}
    times, values = [], []
    for k, m in enumerate(spans):
        if m.gear is not None:
            y = level[m.gear]
        else:
            before = next((level[x.gear] for x in reversed(spans[:k]) if x.gear is not None), None)
            after = next((level[x.gear] for x in spans[k + 1:] if x.gear is not None), None)
            known = [v for v in (before, after) if v is not None]
            y = sum(known) / len(known) if known else np.nan
        times += [m.t0, m.t1]
        values += [y, y]
    return np.array(times, dtype=float), np.array(values, dtype=float), ticks


def plot_drive(result: Result, qualities=None, ax=None, time_window=None):
    """The whole run as a driver sees it, three panels sharing the time axis: the vehicle speed
    [km/h] (when the run has a vehicle), the engine speed [rpm] (the engine's, else the input
    link's) and the gear (:func:`gear_track`, the gear names on the axis); the shift phases
    shaded. ``ax`` is not used (a figure of its own)."""
    from matplotlib.figure import Figure

    sig, meta = result.signals, result.meta or {}
    panels = (["vehicle"] if "vehicle_speed" in sig else []) + ["engine", "gear"]
    fig = Figure(figsize=(10.0, 2.4 * len(panels) + 0.8), dpi=DPI, layout="constrained")
    axes = fig.subplots(len(panels), 1, sharex=True, squeeze=False)[:, 0]
    m = _mask(result, time_window)
    t = result.time[m]
    for ax_, panel in zip(axes, panels):
        if panel == "vehicle":
            ax_.plot(t, sig["vehicle_speed"][m] * 3.6, color="tab:blue", lw=1.8, label="vehicle speed")
            ax_.set_ylabel("vehicle speed [km/h]")
        elif panel == "engine":
            inp = _input_link(result)
            name, label = ("omega_engine", "engine") if "omega_engine" in sig else (f"w_{inp}", f"input {inp}")
            if name in sig:
                ax_.plot(t, sig[name][m] * RPM_PER_RAD_S, color="tab:red", lw=1.6, label=f"{label} speed")
            ax_.set_ylabel("engine speed [rpm]")
        else:
            tg, level, ticks = gear_track(result)
            ax_.plot(tg, level, color="tab:purple", lw=2.0, label="gear")
            ax_.set_yticks(range(1, len(ticks) + 1))
            ax_.set_yticklabels(ticks)
            ax_.set_ylim(0.5, max(len(ticks), 1) + 0.5)
            ax_.set_ylabel("gear")
        handles = _shade(ax_, qualities, time_window)
        ax_.grid(True, alpha=0.4)
        if panel != "gear":
            lines, _ = ax_.get_legend_handles_labels()
            ax_.legend(handles=lines + handles, loc="upper left", fontsize="small")
    axes[-1].set_xlabel("time [s]")
    if time_window is not None:
        axes[-1].set_xlim(*time_window)
    elif len(result.time):
        axes[-1].set_xlim(float(result.time[0]), float(result.time[-1]))
    axes[0].set_title(_title(result, "Vehicle speed, engine speed and gear"))
    return fig


def plot_apply(result: Result, qualities=None, ax=None, elements=None, time_window=None):
    """Apply fraction of each shift element (the clutch pressure profiles, thesis Fig. 3.3)."""
    names = _elements(result, elements)
    fig, ax = _time_plot(result, qualities, ax, time_window, [f"apply_{e}" for e in names], names,
                         "apply fraction [-]", "Shift element apply (pressure) profiles")
    ax.set_ylim(-0.05, 1.1)
    return fig


def shift_window(result: Result, quality) -> tuple[float, float]:
    """The time window [s] of :func:`plot_shift`: from a little before the shift command to a
    while after the shift (and the offgoing element's dissipation) ends - a margin of 15 % of
    the shift's span (at least 0.1 s) before and of 50 % (at least 0.5 s) after, within the run."""
    t = result.time
    end = max(quality.shift_end, quality.dissipation_end)
    span = max(end - quality.t_start, 1e-3)
    return (max(float(t[0]), quality.t_start - max(0.15 * span, 0.1)),
            min(float(t[-1]), end + max(0.5 * span, 0.5)))


def _events_in(ax, result: Result, time_window, label: bool):
    """Thin vertical lines at the lock/unlock events in the window (labelled on top when ``label``)."""
    for e in result.events:
        if e.kind == "start" or not (time_window[0] <= e.t <= time_window[1]):
            continue
        ax.axvline(e.t, color="0.35", lw=0.7, ls=(0, (4, 3)), zorder=1)
        if label:
            ax.annotate(f"{'+'.join(e.elements)} {e.kind}", (e.t, 1.0), xycoords=("data", "axes fraction"),
                        rotation=90, va="top", ha="right", fontsize="x-small", color="0.25")


def plot_shift(result: Result, quality, time_window=None, elements=None, weighting: str | None = None):
    """One shift zoomed on its own time window (:func:`shift_window` unless ``time_window``): a
    figure of stacked panels sharing the time axis, the torque and inertia phases shaded and the
    lock/unlock events marked in each.

    1. input link speed [rpm] (and the engine speed when the run has one), with the synchronous
       speeds of the old and the new gear (output speed x the speed ratio before / after);
    2. the torques of the shift's elements [N*m] - the oncoming and offgoing elements and any other
       that locks or unlocks in the window, or ``elements`` - each with its holding-capacity
       envelope ``+-T_static*apply`` (dotted, from ``meta["static_capacity"]``);
    3. the output torque [N*m] with its pre-shift mean and its final value after the shift;
    4. the vehicle acceleration [m/s^2] and its frequency-weighted form (``weighting``, default
       that of the quality's VDV) - only when the run has a vehicle (``vehicle_accel``);
    5. the jerk [m/s^3] (the driveline's exact ``vehicle_jerk``; differenced,
       :func:`transgen.sim.analysis.comfort.jerk`, for a result without it).

    ``quality``: the :class:`~transgen.sim.analysis.shift_quality.ShiftQuality` of the shift."""
    from matplotlib.figure import Figure

    from .comfort import jerk, weighted

    q = quality
    tw = tuple(time_window) if time_window is not None else shift_window(result, q)
    t, sig, meta = result.time, result.signals, result.meta or {}
    vehicle = "vehicle_accel" in sig
    n = 5 if vehicle else 3
    fig = Figure(figsize=(10.0, 2.3 * n + 0.8), dpi=DPI, layout="constrained")
    axes = fig.subplots(n, 1, sharex=True)
    m = _mask(result, tw)
    tm = t[m]

    # 1 speeds
    ax = axes[0]
    inp, out = q.input_link, q.output_link
    ax.plot(tm, sig[f"w_{inp}"][m] * RPM_PER_RAD_S, color="tab:blue", lw=2.0, label=f"{inp} (input)")
    if "omega_engine" in sig:
        ax.plot(tm, sig["omega_engine"][m] * RPM_PER_RAD_S, color="tab:gray", lw=1.4, label="engine")
    for r_, lab, ls in ((q.ratio_before, "old gear", "--"), (q.ratio_after, "new gear", ":")):
        if r_ is not None and f"w_{out}" in sig:
            ax.plot(tm, sig[f"w_{out}"][m] * r_ * RPM_PER_RAD_S, color="tab:green", lw=1.2, ls=ls,
                    label=f"{lab} synchronous ({out} x {r_:.3g})")
    ax.set_ylabel("speed [rpm]")

    # 2 element torques and capacity envelopes
    ax = axes[1]
    if elements is None:
        moving = [e for e in q.lock_counts if q.lock_counts.get(e, 0) or q.unlock_counts.get(e, 0)]
        elements = list(dict.fromkeys([q.oncoming, q.offgoing] + moving))
    caps = meta.get("static_capacity") or {}
    biggest = 0.0
    for e, color in zip(elements, _colors(len(elements))):
        if f"t_{e}" not in sig:
            continue
        biggest = max(biggest, float(np.max(np.abs(sig[f"t_{e}"][m]), initial=0.0)))
        role = " (on)" if e == q.oncoming else (" (off)" if e == q.offgoing else "")
        ax.plot(tm, sig[f"t_{e}"][m], color=color, lw=1.8, label=f"{e}{role}")
        if e in caps and f"apply_{e}" in sig:
            env = caps[e] * np.maximum(sig[f"apply_{e}"][m], 0.0)
            ax.plot(tm, env, color=color, lw=1.0, ls=":", label=f"+-{e} static x apply")
            ax.plot(tm, -env, color=color, lw=1.0, ls=":")
    ax.axhline(0.0, color="0.3", lw=0.8)
    if biggest > 0:  # the torques fill the panel; an envelope far above them is cut off
        ax.set_ylim(-1.5 * biggest, 1.5 * biggest)
    ax.set_ylabel("element torque [N*m]")

    # 3 output torque
    ax = axes[2]
    ax.plot(tm, sig["T_out"][m], color="tab:red", lw=1.8, label="output torque T_out")
    ax.axhline(q.output_torque_before, color="tab:red", lw=0.9, ls="--", label="before (pre-shift mean)")
    if q.output_torque_final is not None:
        ax.axhline(q.output_torque_final, color="tab:purple", lw=0.9, ls=":", label="final (after the shift)")
    ax.set_ylabel("torque [N*m]")

    # 4, 5 acceleration and jerk
    if vehicle:
        ax = axes[3]
        ax.plot(tm, sig["vehicle_accel"][m], color="tab:orange", lw=1.8, label="vehicle acceleration")
        wname = weighting or (q.vdv_weighting if q.vdv_weighting != "none" else None)
        if wname:
            tu, aw = weighted(t, sig["vehicle_accel"], wname)
            k = (tu >= tw[0]) & (tu <= tw[1])
            ax.plot(tu[k], aw[k], color="tab:brown", lw=1.0, label=f"ISO 2631-1 {wname}-weighted")
        ax.axhline(0.0, color="0.3", lw=0.8)
        ax.set_ylabel("acceleration [m/s^2]")
        ax = axes[4]
        tj, j = (t, sig["vehicle_jerk"]) if "vehicle_jerk" in sig else jerk(t, sig["vehicle_accel"])
        k = (tj >= tw[0]) & (tj <= tw[1])
        ax.plot(tj[k], j[k], color="tab:olive", lw=1.4, label="jerk")
        ax.axhline(0.0, color="0.3", lw=0.8)
        ax.set_ylabel("jerk [m/s^3]")

    for k, ax in enumerate(axes):
        handles = _shade(ax, [q], tw)
        _events_in(ax, result, tw, label=k == 0)
        ax.grid(True, alpha=0.4)
        lines, _ = ax.get_legend_handles_labels()
        ax.legend(handles=lines + (handles if k == 0 else []), loc="center left", bbox_to_anchor=(1.01, 0.5),
                  fontsize="small")
    axes[-1].set_xlabel("time [s]")
    axes[-1].set_xlim(*tw)
    figs = [f"torque hole {q.torque_hole_pct:.1f} %" if q.torque_hole_pct is not None else "",
            f"flare {q.flare_max_rpm:.0f} rpm" if q.flare else "",
            "bindup" if q.bindup else "", f"forced unlock {q.forced_unlock_element}" if q.forced_unlock else "",
            "chatter" if q.chatter else "",
            f"max |jerk| {q.jerk_max:.1f} m/s^3" if q.jerk_max is not None else "",
            f"VDV {q.vdv:.3f} m/s^1.75 ({q.vdv_weighting})" if q.vdv is not None else ""]
    axes[0].set_title(_title(result, f"Shift {q.name}: {q.oncoming} on, {q.offgoing} off") + "\n"
                      + ", ".join(x for x in figs if x), fontsize="medium")
    return fig


PLOTS = {
    "speeds": plot_speeds,
    "slips": plot_slips,
    "torques": plot_torques,
    "io_torques": plot_io_torques,
    "power": plot_power,
    "mode": plot_mode,
    "apply": plot_apply,
    "drive": plot_drive,
}


def plot_all(result: Result, qualities=None, directory=".", formats=("png",), time_window=None,
             prefix: str = "") -> list[Path]:
    """Write every plot of :data:`PLOTS` to ``directory`` as ``<prefix><name>.<format>``
    (``speeds.png``, ``slips.png``, ``torques.png``, ``io_torques.png``, ``power.png``,
    ``mode.png``, ``apply.png``, ``drive.png``) and, without a ``time_window``, the :func:`plot_shift`
    figure of each shift of ``qualities`` named by the shift (:func:`shift_files`: ``shift_1-2.png``,
    ``shift_2-3.png``, a second 2-3 ``shift_2-3#2.png``), atomically: each file is
    written to a temporary file in the same directory and renamed over the target
    (:func:`transgen.export.atomic_path`). Returns the paths written."""
    from transgen.export import atomic_path

    directory = Path(directory)
    paths = []
    figures = [(name, func(result, qualities, time_window=time_window)) for name, func in PLOTS.items()]
    if time_window is None:
        figures += [(name, plot_shift(result, q)) for name, q in zip(shift_files(qualities or ()), qualities or ())]
    for name, fig in figures:
        for fmt in formats:
            path = directory / f"{prefix}{name}.{fmt}"
            with atomic_path(path, suffix=f".{fmt}") as tmp:
                fig.savefig(tmp, format=fmt)
            paths.append(path)
    return paths


def shift_files(qualities) -> list[str]:
    """The file name (without suffix) of each shift's :func:`plot_shift` figure: ``shift_`` and
    the shift's name, numbered where a name repeats (:func:`transgen.names.numbered`)."""
    from transgen.names import numbered

    return [f"shift_{name}".replace(" ", "_").replace("/", "_") for name in numbered(q.name for q in qualities)]


def compare(results: dict, signal: str, ax=None, time_window=None, qualities=None, scale: float = 1.0,
            ylabel: str | None = None):
    """Overlay ``signal`` from several runs (``{label: Result}``), e.g. the original against the
    improved pressure trajectories, or the switching against the compliant clutch model.
    ``qualities``: optional ``{label: [ShiftQuality]}``; the phases of the first label that has
    them are shaded."""
    fig, ax = _axes(ax)
    colors = _colors(len(results))
    unit = ""
    styles = ["-", "--", "-.", ":"]
    for k, (label, r) in enumerate(results.items()):
        if signal not in r.signals:
            raise KeyError(f"run {label!r} has no signal {signal!r}")
        m = _mask(r, time_window)
        ax.plot(r.time[m], r.signals[signal][m] * scale, label=label, color=colors[k],
                ls=styles[k % len(styles)], lw=1.8)
        unit = unit or r.units.get(signal, "")
    handles = []
    for label in results:
        if qualities and qualities.get(label):
            handles = _shade(ax, qualities[label], time_window)
            break
    first = next(iter(results.values())) if results else None
    ax.set_xlabel("time [s]")
    ax.set_ylabel(ylabel or (f"{signal} [{unit}]" if unit else signal))
    ax.set_title(f"{signal}: " + " vs ".join(str(x) for x in results))
    ax.grid(True, alpha=0.4)
    if time_window is not None:
        ax.set_xlim(*time_window)
    elif first is not None and len(first.time):
        ax.set_xlim(min(float(r.time[0]) for r in results.values()), max(float(r.time[-1]) for r in results.values()))
    lines, _ = ax.get_legend_handles_labels()
    _legend(ax, lines + handles)
    return fig
