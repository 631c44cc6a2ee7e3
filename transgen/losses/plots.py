"""Figures of the loss budget: per-gear breakdown, efficiency maps, neutral parasitic loss,
clutch temperatures. Each takes ``ax=None`` (or a figure size), returns the figure and never
shows it; matplotlib is imported here only."""
from __future__ import annotations

import numpy as np

__all__ = ["plot_breakdown", "plot_efficiency_map", "plot_neutral", "plot_clutch_temperatures"]

_COLORS = {"mesh": "#4c72b0", "drag": "#dd8452", "spin": "#55a868", "pump": "#c44e52"}


def plot_breakdown(losses, title: str = "", ax=None):
    """Stacked bars of the loss by kind [W] per gear, the efficiency written above each bar."""
    import matplotlib.pyplot as plt

    fig, ax = (ax.figure, ax) if ax is not None else plt.subplots(figsize=(8, 4.5))
    names = [g.gear for g in losses]
    x = np.arange(len(losses))
    bottom = np.zeros(len(losses))
    for kind in ("mesh", "drag", "spin", "pump"):
        values = np.array([{"mesh": g.mesh, "drag": g.drag_total, "spin": g.spin_total, "pump": g.pump}[kind]
                           for g in losses])
        ax.bar(x, values, bottom=bottom, color=_COLORS[kind], label=kind)
        bottom += values
    for xi, g, top in zip(x, losses, bottom):
        ax.text(xi, top, f"{100 * g.efficiency:.1f} %", ha="center", va="bottom", fontsize=8)
    ax.set_xticks(x, names)
    ax.set_xlabel("gear")
    ax.set_ylabel("loss [W]")
    ax.set_ylim(0, 1.12 * max(bottom.max(), 1.0))
    ax.set_title(title, fontsize=10)
    ax.legend(loc="upper left", fontsize=8)
    fig.tight_layout()
    return fig


def plot_efficiency_map(emap, title: str = "", columns: int = 3):
    """One contour map of the efficiency [%] over input speed x input torque per gear."""
    import matplotlib.pyplot as plt

    gears = list(emap.efficiency)
    rows = -(-len(gears) // columns)
    fig, axes = plt.subplots(rows, columns, figsize=(4.2 * columns, 3.3 * rows), squeeze=False,
                             sharex=True, sharey=True)
    levels = [50, 60, 70, 75, 80, 85, 88, 90, 92, 94, 95, 96, 97, 98, 99]
    for ax, g in zip(axes.flat, gears):
        eff = 100.0 * emap.efficiency[g]
        cs = ax.contourf(emap.speeds_rpm, emap.torques, np.clip(eff, 0, 100), levels=[0] + levels + [100],
                         cmap="viridis")
        lines = ax.contour(emap.speeds_rpm, emap.torques, eff, levels=levels, colors="k", linewidths=0.5)
        ax.clabel(lines, fontsize=6, fmt="%g")
        ax.set_title(f"gear {g}", fontsize=9)
    for ax in axes.flat[len(gears):]:
        ax.set_visible(False)
    for ax in axes[-1]:
        ax.set_xlabel("input speed [rpm]")
    for ax in axes[:, 0]:
        ax.set_ylabel("input torque [N*m]")
    fig.colorbar(cs, ax=axes, label="efficiency [%]", shrink=0.8)
    fig.suptitle(title)
    return fig


def plot_neutral(neutrals, title: str = "", ax=None):
    """The neutral parasitic loss [W] over the input speed, by kind, per neutral."""
    import matplotlib.pyplot as plt

    fig, ax = (ax.figure, ax) if ax is not None else plt.subplots(figsize=(7, 4))
    styles = ["-", "--", ":", "-."]
    for k, n in enumerate(neutrals):
        ls = styles[k % len(styles)]
        ax.plot(n.speeds_rpm, n.total, "k" + ls, label=f"{n.name}: total")
        for kind in ("drag", "spin", "pump"):
            ax.plot(n.speeds_rpm, getattr(n, kind), ls, color=_COLORS[kind], label=f"{n.name}: {kind}")
    ax.set_xlabel("input speed [rpm]")
    ax.set_ylabel("parasitic loss [W]")
    ax.set_title(title, fontsize=10)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7)
    fig.tight_layout()
    return fig


def plot_clutch_temperatures(time, temperatures: dict, oil_temperature: float, title: str = "", ax=None):
    """The temperature [degC] of every element over the run."""
    import matplotlib.pyplot as plt

    fig, ax = (ax.figure, ax) if ax is not None else plt.subplots(figsize=(8, 4))
    for name, temp in temperatures.items():
        ax.plot(time, temp, label=f"{name} (peak {np.max(temp):.1f} degC)")
    ax.axhline(oil_temperature, color="0.5", lw=0.8, ls="--", label="oil")
    ax.set_xlabel("time [s]")
    ax.set_ylabel("pack temperature [degC]")
    ax.set_title(title, fontsize=10)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7)
    fig.tight_layout()
    return fig
