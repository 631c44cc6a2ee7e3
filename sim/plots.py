"""Plots of a simulation result in the style of thesis Figs. 3.2-3.7 and 3.14-3.25.

Every time plot shades the shift phases from
:class:`~transgen.sim.shift_quality.ShiftQuality`: the torque phase and the inertia (speed)
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
* :func:`plot_all` - all of the above written to files; :func:`compare` - one signal of several
  runs overlaid.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from .result import Result

__all__ = [
    "plot_speeds",
    "plot_slips",
    "plot_torques",
    "plot_io_torques",
    "plot_power",
    "plot_mode",
    "plot_apply",
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
    ax.set_yticklabels([f"{n} [{'+'.join(locked[n]) or 'none'}]" if n in locked else n for n in names])
    ax.set_ylim(0.5, len(names) + 0.5)
    handles = _shade(ax, qualities, time_window)
    _finish(ax, "mode [locked elements]", _title(result, "Mode of operation"), handles, time_window, result,
            legend=False)
    _legend(ax, handles)
    return fig


def plot_apply(result: Result, qualities=None, ax=None, elements=None, time_window=None):
    """Apply fraction of each shift element (the clutch pressure profiles, thesis Fig. 3.3)."""
    names = _elements(result, elements)
    fig, ax = _time_plot(result, qualities, ax, time_window, [f"apply_{e}" for e in names], names,
                         "apply fraction [-]", "Shift element apply (pressure) profiles")
    ax.set_ylim(-0.05, 1.1)
    return fig


PLOTS = {
    "speeds": plot_speeds,
    "slips": plot_slips,
    "torques": plot_torques,
    "io_torques": plot_io_torques,
    "power": plot_power,
    "mode": plot_mode,
    "apply": plot_apply,
}


def plot_all(result: Result, qualities=None, directory=".", formats=("png",), time_window=None,
             prefix: str = "") -> list[Path]:
    """Write every plot of :data:`PLOTS` to ``directory`` as ``<prefix><name>.<format>``
    (``speeds.png``, ``slips.png``, ``torques.png``, ``io_torques.png``, ``power.png``,
    ``mode.png``, ``apply.png``), atomically: each file is written to a temporary file in the
    same directory and renamed over the target (:func:`transgen.export.atomic_path`). Returns the
    paths written."""
    from transgen.export import atomic_path

    directory = Path(directory)
    paths = []
    for name, func in PLOTS.items():
        fig = func(result, qualities, time_window=time_window)
        for fmt in formats:
            path = directory / f"{prefix}{name}.{fmt}"
            with atomic_path(path, suffix=f".{fmt}") as tmp:
                fig.savefig(tmp, format=fmt)
            paths.append(path)
    return paths


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
