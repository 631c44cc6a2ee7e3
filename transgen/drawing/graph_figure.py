"""The picture of the mechanism graph in bond-graph style (thesis Figs. 3.9 and 3.13).

Links are ``1`` junctions (with their inertia ``J``), planetaries ``MTF`` and gear pairs ``TF``
nodes, shift elements boxes, the housing ``Sf=0`` and the external torques ``Se`` sources; bonds
are half-arrows in their direction of positive power, transformer ports are named on their
bonds. The layout is :func:`transgen.drawing.layout.graph_layout`.
"""
from __future__ import annotations

import math

from .common import as_graph
from .figure import (MARGIN, NODE_FONT, SMALL_FONT, TITLE_FONT, Rect, figure_and_axes, line_samples,
                     place_label, set_limits, text_size)
from .layout import attachments, graph_layout

_COLORS = {
    "link": ("#dbe9f6", "#2b5d8a"),
    "planetary": ("#fdf1cf", "#8a6d1c"),
    "gearpair": ("#fdf1cf", "#8a6d1c"),
    "stepped": ("#fdf1cf", "#8a6d1c"),
    "clutch": ("#f7dede", "#8a2b2b"),
    "brake": ("#f7dede", "#8a2b2b"),
    "oneway": ("#efe0f5", "#5d2b8a"),
    "dog": ("#e0f0e0", "#2b6a2b"),
    "housing": ("#e4e4e4", "#333333"),
    "source": ("#ffffff", "#2b7a3b"),
}


def draw_graph(g, ax=None):
    """Draw the mechanism graph in bond-graph style.

    Parameters
    ----------
    g : networkx.DiGraph or transgen.model.Mechanism
        The graph of :func:`transgen.graph.build_graph` (a mechanism is converted with it).
    ax : matplotlib.axes.Axes, optional
        Axes to draw into. By default a new :class:`matplotlib.figure.Figure` is created, sized
        from the layout (about one inch per row and per link).

    Returns
    -------
    matplotlib.figure.Figure
        The figure drawn on. Every node's label is a text artist whose ``gid`` is the node name;
        port labels have the gid ``"port:<link>-><transformer>"``.

    Notes
    -----
    Links are ``1`` junctions with their inertia, planetaries ``MTF`` and gear pairs ``TF``
    nodes with their tooth counts or radii, shift elements boxes with their kind, the housing
    ``Sf=0`` and the external torques ``Se`` sources. Bonds are drawn as half-arrows in the
    edge direction (the direction of positive power).
    """
    import numpy as np
    from matplotlib.lines import Line2D
    from matplotlib.patches import FancyBboxPatch

    g = as_graph(g)
    lay = graph_layout(g)
    boxes = lay.boxes
    title = str(g.graph.get("name", ""))
    title_h = text_size(title, TITLE_FONT, "bold")[1] + 0.15 if title else 0.0
    xmin = min((b.x - b.w / 2 for b in boxes.values()), default=0.0) - MARGIN
    xmax = max((b.x + b.w / 2 for b in boxes.values()), default=1.0) + MARGIN
    ymin = min((b.y - b.h / 2 for b in boxes.values()), default=0.0) - MARGIN
    ymax = max((b.y + b.h / 2 for b in boxes.values()), default=1.0) + MARGIN + title_h
    if title:
        extra = text_size(title, TITLE_FONT, "bold")[0] + 2 * MARGIN - (xmax - xmin)
        if extra > 0:
            xmin, xmax = xmin - extra / 2, xmax + extra / 2
    fig, ax, scale = figure_and_axes(ax, xmax - xmin, ymax - ymin)
    set_limits(ax, xmin, xmax, ymin, ymax)

    for n, b in boxes.items():
        kind = g.nodes[lay.owner[n]].get("kind", "")
        face, edge = _COLORS.get(kind, ("#ffffff", "#333333"))
        style = "round,pad=0,rounding_size=0.08" if kind in ("link", "housing") else "square,pad=0"
        if kind == "source":
            style = "round,pad=0,rounding_size=0.16"
        patch = FancyBboxPatch((b.x - b.w / 2, b.y - b.h / 2), b.w, b.h, boxstyle=style,
                               facecolor=face, edgecolor=edge, linewidth=1.2 if kind != "source" else 1.0,
                               linestyle="-" if kind != "source" else "--", zorder=2,
                               hatch="///" if kind == "housing" else None)
        ax.add_patch(patch)
        ax.text(b.x, b.y, lay.texts[n], ha="center", va="center", parse_math=False, fontsize=NODE_FONT * scale,
                zorder=4, gid=n, color="#111111",
                bbox=dict(boxstyle="square,pad=0.05", facecolor=face, edgecolor="none") if kind == "housing" else None)

    points = attachments(lay)
    obstacles = list(boxes.values())
    placed: list[Rect] = []
    harpoon_len, harpoon_w = 0.16, 0.09
    port_edges = []
    samples = []
    for k, (bu, bv, u, v) in enumerate(lay.bonds):
        data = g.edges[u, v]
        (x0, y0), (x1, y1) = points[(bu, bv, bu)], points[(bu, bv, bv)]
        dx, dy = x1 - x0, y1 - y0
        length = math.hypot(dx, dy) or 1.0
        ux, uy = dx / length, dy / length
        color = "#333333"
        ax.add_line(Line2D([x0, x1], [y0, y1], color=color, linewidth=1.1, zorder=1, solid_capstyle="butt"))
        # bond half-arrow: a barb on the left of the head
        bx, by = x1 - harpoon_len * ux - harpoon_w * uy, y1 - harpoon_len * uy + harpoon_w * ux
        ax.add_line(Line2D([x1, bx], [y1, by], color=color, linewidth=1.1, zorder=1))
        samples.append(line_samples([(x0, y0), (x1, y1)], k))
        if data.get("port") is not None:
            port_edges.append((k, u, v, str(data["port"]), (x0, y0), (x1, y1), length))
    lines = np.vstack(samples) if samples else None
    for k, u, v, port, (x0, y0), (x1, y1), length in port_edges:
        w, h = text_size(port, SMALL_FONT)
        w, h = w + 0.06, h
        # from the transformer end (the head) towards the link
        cands = []
        for d in (0.3, 0.42, 0.54, 0.66, 0.78, 0.9, 1.02, 1.14):
            if d < length - 0.2:
                f = d / length
                cands.append((x1 + (x0 - x1) * f, y1 + (y0 - y1) * f))
        if not cands:
            cands = [((x0 + x1) / 2, (y0 + y1) / 2)]
        r = place_label(cands, w, h, obstacles, placed, lines, k)
        ax.text(r.x, r.y, port, ha="center", va="center", parse_math=False, fontsize=SMALL_FONT * scale, zorder=3,
                style="italic", color="#5a4510", gid=f"port:{u}->{v}",
                bbox=dict(boxstyle="round,pad=0.1", facecolor="white", edgecolor="none", alpha=0.9))
    if title:
        ax.text((xmin + xmax) / 2, ymax - MARGIN / 2 - title_h / 2 + 0.05, title, ha="center", va="center", parse_math=False,
                fontsize=TITLE_FONT * scale, fontweight="bold", gid="title")
    return fig
