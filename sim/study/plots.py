"""Plots of a study: a metric over one parameter, heat maps over two.

Matplotlib's object API only (no ``pyplot``); figures are written through the project's figure
writer (:func:`transgen.drawing.save_figure`: atomic, format from the suffix). Failed runs and
missing values are left out of line plots and blank in heat maps.

* :func:`plot_metric` - a metric over one parameter, one line per value of the other grid
  parameters (a sample with several parameters: points);
* :func:`plot_heatmap` - a metric over two parameters of a full grid (the mean where other
  parameters vary);
* :func:`plot_sweep` - :data:`METRICS` of every shift and the energy dissipated, written into a
  folder: heat maps for a two-parameter grid, otherwise over each parameter.
"""
from __future__ import annotations

import itertools
import math
from pathlib import Path

from .table import SweepTable, column_shift, column_unit

__all__ = ["plot_metric", "plot_heatmap", "plot_sweep", "sweep_metrics", "METRICS"]

#: the shift-report figures plotted by :func:`plot_sweep` (``shift.1-2.NAME`` for every shift)
METRICS = ("torque_hole", "bindup_torque", "flare_max_rpm", "energy_total", "shift_duration")


def _number(value) -> float | None:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        return None
    return float(value) if math.isfinite(value) else None


def _label(column: str) -> str:
    unit = column_unit(column)
    return f"{column} [{unit}]" if unit else column


def _sortable(values) -> list:
    unique = list(dict.fromkeys(values))
    try:
        return sorted(unique)
    except TypeError:
        return unique


def _figure(ax):
    if ax is not None:
        return ax.figure, ax
    from matplotlib.figure import Figure

    fig = Figure(figsize=(7.0, 4.5), layout="constrained")
    return fig, fig.add_subplot()


def plot_metric(table: SweepTable, metric: str, parameter: str, ax=None):
    """``metric`` (a column) over ``parameter``; one line per combination of the other
    parameters when they take few values, else points. Returns the figure."""
    fig, ax = _figure(ax)
    others = [p for p in table.parameters if p != parameter and len(set(map(repr, table[p]))) > 1]
    groups: dict[tuple, list] = {}
    for row in table.rows:
        groups.setdefault(tuple(repr(row.get(p)) for p in others), []).append(row)
    as_points = len(groups) > 12 or any(len(g) < 2 for g in groups.values()) and len(groups) > 1
    for group, rows in groups.items():
        pts = sorted((x, y) for r in rows if r.get("success")
                     and (x := _number(r.get(parameter))) is not None and (y := _number(r.get(metric))) is not None)
        if not pts:
            continue
        label = ", ".join(f"{p} = {v}" for p, v in zip(others, group)) if others and not as_points else None
        xs, ys = zip(*pts)
        ax.plot(xs, ys, "o" if as_points else "o-", ms=4, label=label, color="C0" if as_points else None)
    ax.set_xlabel(_label(parameter))
    ax.set_ylabel(_label(metric))
    ax.set_title(f"{metric} over {parameter}")
    ax.grid(True, alpha=0.3)
    if ax.get_legend_handles_labels()[1]:
        ax.legend(fontsize=8)
    return fig


def plot_heatmap(table: SweepTable, metric: str, x: str, y: str, ax=None):
    """``metric`` over the grid of parameters ``x`` and ``y`` as a heat map (the mean of the
    successful runs in each cell; blank where none). Returns the figure."""
    import numpy as np

    fig, ax = _figure(ax)
    xs, ys = _sortable(table[x]), _sortable(table[y])
    sums = np.zeros((len(ys), len(xs)))
    counts = np.zeros((len(ys), len(xs)))
    for row in table.rows:
        value = _number(row.get(metric)) if row.get("success") else None
        if value is not None and row.get(x) in xs and row.get(y) in ys:
            i, j = ys.index(row.get(y)), xs.index(row.get(x))
            sums[i, j] += value
            counts[i, j] += 1
    with np.errstate(invalid="ignore", divide="ignore"):
        grid = np.where(counts > 0, sums / np.maximum(counts, 1), np.nan)
    image = ax.imshow(np.ma.masked_invalid(grid), origin="lower", aspect="auto", cmap="viridis")
    ax.set_xticks(range(len(xs)), [str(v) for v in xs], rotation=45 if len(xs) > 6 else 0)
    ax.set_yticks(range(len(ys)), [str(v) for v in ys])
    for (i, j), value in np.ndenumerate(grid):
        if np.isfinite(value) and len(xs) * len(ys) <= 100:  # dark text on the bright cells of viridis
            ax.text(j, i, f"{value:.4g}", ha="center", va="center", fontsize=7,
                    color="k" if image.norm(value) > 0.6 else "w")
    ax.set_xlabel(_label(x))
    ax.set_ylabel(_label(y))
    ax.set_title(metric)
    fig.colorbar(image, ax=ax, label=_label(metric))
    return fig


def sweep_metrics(table: SweepTable) -> list[str]:
    """The columns :func:`plot_sweep` draws: :data:`METRICS` of every shift, the energy
    dissipated and the turbocharger's time to 90 % boost, where the table has them."""
    columns = table.columns
    prefixes = list(dict.fromkeys(c.rsplit(".", 1)[0] for c in columns
                                  if (s := column_shift(c)) is not None and len(s[1]) == 1))
    wanted = [f"{p}.{m}" for p, m in itertools.product(prefixes, METRICS)]
    wanted += ["energy.dissipated", "turbo.time_to_90_boost"]
    return [c for c in wanted if c in columns]


def plot_sweep(table: SweepTable, directory: str | Path, formats=("png",)) -> list[Path]:
    """Write the plots of a study into ``directory``: for each of :func:`sweep_metrics`, a heat
    map when exactly two parameters vary on a full grid, else the metric over each varying
    parameter. Returns the files written."""
    from transgen.drawing import save_figure

    directory = Path(directory)
    varying = [p for p in table.parameters if len(set(map(repr, table[p]))) > 1]
    full = len(varying) == 2 and len({(repr(r.get(varying[0])), repr(r.get(varying[1]))) for r in table.rows}) == \
        len(set(map(repr, table[varying[0]]))) * len(set(map(repr, table[varying[1]])))
    written = []
    for metric in sweep_metrics(table):
        stem = metric.replace(".", "_")
        if full:
            figures = [(f"{stem}_map", plot_heatmap(table, metric, varying[0], varying[1]))]
        else:
            figures = [(f"{stem}_over_{p.replace('.', '_')}", plot_metric(table, metric, p)) for p in varying]
        for name, fig in figures:
            for fmt in formats:
                written.append(save_figure(fig, directory / f"{name}.{fmt}"))
    return written
