"""Pictures and graph-file exports of the mechanism graph and the state-transition diagram.

* :func:`draw_graph` draws the bond-graph-like mechanism graph of :mod:`transgen.graph` in the
  style of thesis Figs. 3.9 and 3.13: links as ``1`` junctions (with their inertia ``J``),
  planetaries as ``MTF`` and gear pairs as ``TF`` nodes, shift elements as boxes, the housing
  as ``Sf=0`` and the external torques as ``Se`` sources; bonds are half-arrows in their
  direction of positive power, transformer ports are named on their bonds.
* :func:`draw_std` draws the state-transition diagram of :mod:`transgen.std` (thesis Figs. 3.8
  and 3.12): modes as bubbles, transitions as curved arrows labelled ``lock X`` / ``unlock X``
  (the conditions themselves belong in the JSON of :meth:`StateTransitionDiagram.to_dict`).
* :func:`graph_to_dot`, :func:`std_to_dot` and :func:`graph_to_graphml` write the same
  diagrams as Graphviz DOT and GraphML text; :func:`save_figure` writes a figure atomically.

Layouts are computed here, deterministically (no random spring layout, no Graphviz needed):

* graph: links on a middle row (declaration order, the input link first and the output link
  last), transformers on the row above and shift elements on the row below, each placed over
  the mean position of the links it connects and pushed apart where they would overlap; the
  housing at the bottom; ``T_in`` left of the input link and ``T_out`` right of the output link
  (other torques on the shift-element row).
* STD: one row per number of locked elements, most locked on top. Every transition locks or
  unlocks one element, so every arrow joins two neighbouring rows. The order within the rows is
  the declaration order improved by barycentre sweeps that reduce crossings.

Drawings are made in inch units: the figure is sized from the layout, so every text has its
measured room. Drawing into a given ``ax`` of another size scales the fonts to fit.
Matplotlib is imported only inside the functions, and only its object API is used (no
``pyplot``), so drawing is safe in any thread and with any backend.
"""
from __future__ import annotations

import math
import textwrap
from dataclasses import dataclass
from pathlib import Path

import networkx as nx

from .export import atomic_path

__all__ = [
    "draw_graph",
    "draw_std",
    "graph_to_dot",
    "std_to_dot",
    "graph_to_graphml",
    "save_figure",
    "FIGURE_FORMATS",
]

FIGURE_FORMATS = {".png": "png", ".svg": "svg", ".pdf": "pdf"}
"""File suffix -> matplotlib format understood by :func:`save_figure`."""

_ELEMENT_KINDS = ("clutch", "brake", "oneway")
_TRANSFORMER_KINDS = ("planetary", "gearpair")

# Sizes in points (fonts) and inches (layout).
_NODE_FONT = 9.0
_SMALL_FONT = 7.0
_TITLE_FONT = 11.0
_MARGIN = 0.35

_COLORS = {
    "link": ("#dbe9f6", "#2b5d8a"),
    "planetary": ("#fdf1cf", "#8a6d1c"),
    "gearpair": ("#fdf1cf", "#8a6d1c"),
    "clutch": ("#f7dede", "#8a2b2b"),
    "brake": ("#f7dede", "#8a2b2b"),
    "oneway": ("#efe0f5", "#5d2b8a"),
    "housing": ("#e4e4e4", "#333333"),
    "source": ("#ffffff", "#2b7a3b"),
}
_MODE_COLORS = {"gear": "#dbe9f6", "speed": "#fdf1cf", "neutral": "#e4e4e4", "reverse": "#f7dede"}
_STUB = 0.32  # length of a stub of a transition leaving the modelled modes (inches)
_LEAVING_NOTE = "dashed: transitions leaving the modelled modes (+X: X locks, \u2212X: X unlocks)"
_LOCK_COLOR = "#1f4e9c"
_UNLOCK_COLOR = "#a02525"


# --------------------------------------------------------------------------------------------
# text measurement and simple geometry (inch units)
# --------------------------------------------------------------------------------------------

def _text_size(text: str, size: float, weight: str = "normal") -> tuple[float, float]:
    """Width and height in inches of (multi-line) ``text`` at font ``size`` (points)."""
    from matplotlib.font_manager import FontProperties
    from matplotlib.textpath import TextToPath

    prop = FontProperties(size=size, weight=weight)
    conv = TextToPath()
    lines = text.split("\n")
    width = max((conv.get_text_width_height_descent(line, prop, ismath=False)[0] if line else 0.0)
                for line in lines)
    height = size * (1.0 + 1.2 * (len(lines) - 1)) + 0.3 * size
    return width / 72.0, height / 72.0


@dataclass
class _Rect:
    """An axis-aligned rectangle by its centre and size (inches)."""

    x: float
    y: float
    w: float
    h: float

    def overlaps(self, other: _Rect, pad: float = 0.0) -> bool:
        return (abs(self.x - other.x) * 2 < self.w + other.w + 2 * pad
                and abs(self.y - other.y) * 2 < self.h + other.h + 2 * pad)

    def overlap_area(self, other: _Rect) -> float:
        dx = (self.w + other.w) / 2 - abs(self.x - other.x)
        dy = (self.h + other.h) / 2 - abs(self.y - other.y)
        return max(dx, 0.0) * max(dy, 0.0)


@dataclass
class _Ellipse:
    x: float
    y: float
    a: float
    b: float

    def overlaps(self, r: _Rect, pad: float = 0.0) -> bool:
        """Whether the rectangle ``r`` (grown by ``pad``) meets the ellipse (sampled test)."""
        hw, hh = r.w / 2 + pad, r.h / 2 + pad
        if abs(r.x - self.x) <= hw and abs(r.y - self.y) <= hh:
            return True
        for fx in (-1.0, -0.5, 0.0, 0.5, 1.0):
            for fy in (-1.0, 0.0, 1.0):
                px, py = r.x + fx * hw, r.y + fy * hh
                if ((px - self.x) / self.a) ** 2 + ((py - self.y) / self.b) ** 2 <= 1.0:
                    return True
        return False

    def overlap_area(self, r: _Rect) -> float:
        return r.overlap_area(_Rect(self.x, self.y, 2 * self.a * 0.8, 2 * self.b * 0.8))


def _place_label(candidates, w: float, h: float, obstacles: list, placed: list[_Rect],
                 lines=None, own: int | None = None) -> _Rect:
    """Choose a ``w`` x ``h`` label box among the ``candidates`` (centres, best first).

    A box that meets no obstacle (node box or bubble) and no label in ``placed`` is preferred;
    among those, the one that covers the fewest sample points of other lines (``lines`` is an
    ``(n, 3)`` array of ``x, y, line id`` and the label's own line is ``own``), then the
    earliest. The chosen box is appended to ``placed``.
    """
    best, best_key = None, None
    for k, (x, y) in enumerate(candidates):
        r = _Rect(x, y, w, h)
        hits = [o for o in obstacles if o.overlaps(r, 0.02)] + [p for p in placed if p.overlaps(r, 0.02)]
        area = sum(o.overlap_area(r) for o in hits) + 1e-3 * len(hits)
        foreign = 0
        if lines is not None and len(lines):
            inside = ((abs(lines[:, 0] - x) <= w / 2 + 0.03) & (abs(lines[:, 1] - y) <= h / 2 + 0.03)
                      & (lines[:, 2] != (-1 if own is None else own)))
            foreign = int(inside.sum())
        key = (area > 0, area, foreign, k)
        if best_key is None or key < best_key:
            best, best_key = r, key
    placed.append(best)
    return best


def _samples(points, line_id: int, step: float = 0.04):
    """``(n, 3)`` samples ``x, y, line_id`` along a polyline, about ``step`` inches apart."""
    import numpy as np

    out = []
    for (x0, y0), (x1, y1) in zip(points, points[1:]):
        n = max(1, int(math.hypot(x1 - x0, y1 - y0) / step))
        t = np.linspace(0.0, 1.0, n, endpoint=False)
        out.append(np.column_stack([x0 + (x1 - x0) * t, y0 + (y1 - y0) * t, np.full(n, line_id)]))
    return np.vstack(out) if out else np.zeros((0, 3))


def _spread(desired: list[float], widths: list[float], gap: float) -> list[float]:
    """Positions for boxes kept in the given order, as close to ``desired`` as a forward push
    allows without overlap (at least ``gap`` apart), then shifted to the desired centroid."""
    xs: list[float] = []
    for i, (d, w) in enumerate(zip(desired, widths)):
        x = d if i == 0 else max(d, xs[-1] + (widths[i - 1] + w) / 2 + gap)
        xs.append(x)
    if xs:
        shift = sum(desired) / len(desired) - sum(xs) / len(xs)
        xs = [x + shift for x in xs]
    return xs


def _figure_and_axes(ax, width: float, height: float):
    """A new figure exactly ``width`` x ``height`` inches with axes filling it, or the figure of
    ``ax``; returns ``(figure, axes, font_scale)``."""
    if ax is None:
        from matplotlib.figure import Figure

        fig = Figure(figsize=(width, height))
        ax = fig.add_axes((0.0, 0.0, 1.0, 1.0))
        scale = 1.0
    else:
        try:
            fig = ax.get_figure(root=True)
        except TypeError:  # matplotlib < 3.10
            fig = ax.figure
        bbox = ax.get_position()
        fw, fh = fig.get_size_inches()
        scale = min(bbox.width * fw / width, bbox.height * fh / height)
        scale = max(min(scale, 1.0), 0.2)
    ax.set_axis_off()
    ax.set_aspect("equal")
    return fig, ax, scale


def _limits(ax, xmin, xmax, ymin, ymax):
    ax.set_xlim(xmin, xmax)
    ax.set_ylim(ymin, ymax)


# --------------------------------------------------------------------------------------------
# mechanism graph
# --------------------------------------------------------------------------------------------

def _fmt(value) -> str:
    if isinstance(value, float):
        return "inf" if math.isinf(value) else f"{value:g}"
    return str(value)


def _param_text(name: str, params: dict) -> str:
    """``{"Ns_P1": 45, "Nr_P1": 75}`` -> ``"Ns=45  Nr=75"``."""
    suffix = f"_{name}"
    parts = []
    for key, value in params.items():
        short = key[: -len(suffix)] if key.endswith(suffix) else key
        parts.append(f"{short}={_fmt(value)}")
    return "  ".join(parts)


def _node_text(name: str, data: dict) -> str:
    """The label drawn in the box of graph node ``name``."""
    kind = data.get("kind", "")
    if kind == "link":
        return f"1: {name}\nJ={_fmt(data.get('J', '?'))}"
    if kind == "housing":
        return f"Sf=0\n{name}"
    if kind == "planetary":
        head = f"MTF: {name}" + (" (double pinion)" if data.get("pinions") == 2 else "")
        return f"{head}\n{_param_text(name, data.get('params', {}))}"
    if kind == "gearpair":
        mesh = data.get("mesh")
        head = f"TF: {name}" + (f" ({mesh})" if mesh else "")
        return f"{head}\n{_param_text(name, data.get('params', {}))}"
    if kind in _ELEMENT_KINDS:
        text = f"{kind}\n{name}"
        if kind == "oneway" and data.get("free"):
            text += f"\nfree {data['free']}"
        return text
    if kind == "source":
        return f"Se: {name}"
    label = str(data.get("label", ""))
    return label if name in label else name


@dataclass
class _GraphLayout:
    """Boxes keyed by node name, plus copies of the housing (key ``"<housing>@<transformer>"``,
    ``owner`` gives the node) above a transformer that has the housing as a member, so that
    its bond does not cross the picture; ``bonds`` are ``(tail box, head box, u, v)``."""

    boxes: dict[str, _Rect]
    texts: dict[str, str]
    rows: dict[str, int]  # +2 housing copies, +1 transformers, 0 links, -1 elements, -2 housing
    owner: dict[str, str]
    bonds: list[tuple[str, str, str, str]]


def _graph_layout(g: nx.DiGraph, font: float = _NODE_FONT) -> _GraphLayout:
    """Boxes (inches) of every node of ``g`` in the layered layout described in the module."""
    texts = {n: _node_text(n, d) for n, d in g.nodes(data=True)}
    sizes = {}
    kind = {n: d.get("kind", "") for n, d in g.nodes(data=True)}
    for n, t in texts.items():
        w, h = _text_size(t, font)
        w = w + 0.22
        if kind[n] == "housing":  # room for every bond's half-arrow
            w = max(w, 0.3 * g.degree(n))
        sizes[n] = (w, h + 0.14)
    links = [n for n in g if kind[n] == "link"]
    inp, out = g.graph.get("input"), g.graph.get("output")
    if inp in links and inp != out:
        links = [inp] + [n for n in links if n != inp]
    if out in links and out != inp:
        links = [n for n in links if n != out] + [out]
    gap = 0.45
    row_gap = 1.35
    boxes: dict[str, _Rect] = {}
    rows: dict[str, int] = {}
    x = 0.0
    for i, n in enumerate(links):
        w, h = sizes[n]
        if i:
            x += (sizes[links[i - 1]][0] + w) / 2 + gap
        boxes[n], rows[n] = _Rect(x, 0.0, w, h), 0
    link_x = {n: boxes[n].x for n in links}
    centre = (sum(link_x.values()) / len(link_x)) if link_x else 0.0

    def anchor(n: str) -> float:
        xs = [link_x[m] for m in nx.all_neighbors(g, n) if m in link_x]
        return sum(xs) / len(xs) if xs else centre

    # external torques at the sides when their link ends the row
    sources = [n for n in g if kind[n] == "source"]
    side_sources: dict[str, int] = {}
    for n in sources:
        nbrs = [m for m in nx.all_neighbors(g, n) if m in link_x]
        if len(nbrs) != 1:
            continue
        for side, end in ((-1, links[0]), (1, links[-1])):
            if nbrs[0] == end and side not in side_sources.values():
                side_sources[n] = side
                break
    for n, side in side_sources.items():
        w, h = sizes[n]
        ref = boxes[links[0] if side < 0 else links[-1]]
        boxes[n] = _Rect(ref.x + side * (ref.w / 2 + gap + 0.25 + w / 2), 0.0, w, h)
        rows[n] = 0

    index = {n: i for i, n in enumerate(g)}
    row_heights = {0: max((b.h for b in boxes.values()), default=0.5)}
    for row, members in ((1, [n for n in g if kind[n] in _TRANSFORMER_KINDS]),
                         (-1, [n for n in g if kind[n] in _ELEMENT_KINDS or (kind[n] == "source" and n not in side_sources)]),
                         (-2, [n for n in g if kind[n] == "housing"]),
                         (-3, [n for n in g if n not in boxes and kind[n] not in _TRANSFORMER_KINDS + _ELEMENT_KINDS
                               + ("housing", "source", "link")])):
        if not members:
            continue
        if row == -2:  # under its shift elements (transformers get a copy of the housing)
            desired = {}
            for n in members:
                xs_ = [boxes[m].x for m in nx.all_neighbors(g, n) if m in boxes and rows[m] != 1]
                desired[n] = sum(xs_) / len(xs_) if xs_ else centre
        else:
            desired = {n: anchor(n) for n in members}
        order = sorted(members, key=lambda n: (round(desired[n], 6), index[n]))
        xs = _spread([desired[n] for n in order], [sizes[n][0] for n in order], gap)
        row_heights[row] = max(sizes[n][1] for n in members)
        for n, xn in zip(order, xs):
            boxes[n], rows[n] = _Rect(xn, 0.0, *sizes[n]), row
    # vertical positions: rows stacked with row_gap between box edges
    ys = {0: 0.0}
    for row in (1,):
        if row in row_heights:
            ys[row] = ys[0] + (row_heights[0] + row_heights[row]) / 2 + row_gap
    prev = 0
    for row in (-1, -2, -3):
        if row in row_heights:
            ys[row] = ys[prev] - (row_heights[prev] + row_heights[row]) / 2 - (row_gap if prev == 0 else 0.95)
            prev = row
    # a copy of the housing above each transformer it is a member of
    owner = {n: n for n in boxes}
    bonds = []
    copies: dict[str, list[str]] = {}
    for u, v in g.edges():
        if kind[u] == "housing" and rows.get(v) == 1:
            key = f"{u}@{v}"
            copies.setdefault(v, []).append(key)
            owner[key], texts[key] = u, texts[u]
            bonds.append((key, v, u, v))
        else:
            bonds.append((u, v, u, v))
    if copies:
        w, h = _text_size(texts[next(iter(copies.values()))[0]], font)
        w, h = w + 0.22, h + 0.14
        ys[2] = ys[1] + (row_heights[1] + h) / 2 + 0.7
        members = [key for t in sorted(copies, key=lambda t: boxes[t].x) for key in copies[t]]
        xs = _spread([boxes[owner_t].x for owner_t in (k.split("@", 1)[1] for k in members)], [w] * len(members), gap)
        for key, xn in zip(members, xs):
            boxes[key], rows[key] = _Rect(xn, 0.0, w, h), 2
    for n, b in boxes.items():
        b.y = ys[rows[n]]
    return _GraphLayout(boxes, texts, rows, owner, bonds)


def _attachments(lay: _GraphLayout) -> dict[tuple[str, str, str], tuple[float, float]]:
    """Where each bond between boxes ``u`` and ``v`` leaves/enters them: key ``(u, v, end)``."""
    sides: dict[tuple[str, str], list[tuple[float, tuple[str, str, str]]]] = {}
    boxes = lay.boxes
    for u, v, _, _ in lay.bonds:
        for me, other in ((u, v), (v, u)):
            bm, bo = boxes[me], boxes[other]
            if abs(bm.y - bo.y) < 1e-9:
                side = "right" if bo.x > bm.x else "left"
                key = bo.y
            else:
                side = "top" if bo.y > bm.y else "bottom"
                key = bo.x
            sides.setdefault((me, side), []).append((key, (u, v, me)))
    points = {}
    for (node, side), items in sides.items():
        b = boxes[node]
        items.sort(key=lambda it: (it[0], it[1]))
        n = len(items)
        for i, (_, key) in enumerate(items):
            f = (i + 1) / (n + 1)
            if side in ("top", "bottom"):
                span = b.w * 0.84
                x = b.x - span / 2 + f * span
                y = b.y + (b.h / 2 if side == "top" else -b.h / 2)
            else:
                span = b.h * 0.7
                y = b.y - span / 2 + f * span
                x = b.x + (b.w / 2 if side == "right" else -b.w / 2)
            points[key] = (x, y)
    return points


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

    if not isinstance(g, nx.Graph):
        from .graph import build_graph

        g = build_graph(g)
    lay = _graph_layout(g)
    boxes = lay.boxes
    title = str(g.graph.get("name", ""))
    title_h = _text_size(title, _TITLE_FONT, "bold")[1] + 0.15 if title else 0.0
    xmin = min((b.x - b.w / 2 for b in boxes.values()), default=0.0) - _MARGIN
    xmax = max((b.x + b.w / 2 for b in boxes.values()), default=1.0) + _MARGIN
    ymin = min((b.y - b.h / 2 for b in boxes.values()), default=0.0) - _MARGIN
    ymax = max((b.y + b.h / 2 for b in boxes.values()), default=1.0) + _MARGIN + title_h
    if title:
        extra = _text_size(title, _TITLE_FONT, "bold")[0] + 2 * _MARGIN - (xmax - xmin)
        if extra > 0:
            xmin, xmax = xmin - extra / 2, xmax + extra / 2
    fig, ax, scale = _figure_and_axes(ax, xmax - xmin, ymax - ymin)
    _limits(ax, xmin, xmax, ymin, ymax)

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
        ax.text(b.x, b.y, lay.texts[n], ha="center", va="center", fontsize=_NODE_FONT * scale,
                zorder=4, gid=n, color="#111111",
                bbox=dict(boxstyle="square,pad=0.05", facecolor=face, edgecolor="none") if kind == "housing" else None)

    points = _attachments(lay)
    obstacles = list(boxes.values())
    placed: list[_Rect] = []
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
        samples.append(_samples([(x0, y0), (x1, y1)], k))
        if data.get("port") is not None:
            port_edges.append((k, u, v, str(data["port"]), (x0, y0), (x1, y1), length))
    lines = np.vstack(samples) if samples else None
    for k, u, v, port, (x0, y0), (x1, y1), length in port_edges:
        w, h = _text_size(port, _SMALL_FONT)
        w, h = w + 0.06, h
        # from the transformer end (the head) towards the link
        cands = []
        for d in (0.3, 0.42, 0.54, 0.66, 0.78, 0.9, 1.02, 1.14):
            if d < length - 0.2:
                f = d / length
                cands.append((x1 + (x0 - x1) * f, y1 + (y0 - y1) * f))
        if not cands:
            cands = [((x0 + x1) / 2, (y0 + y1) / 2)]
        r = _place_label(cands, w, h, obstacles, placed, lines, k)
        ax.text(r.x, r.y, port, ha="center", va="center", fontsize=_SMALL_FONT * scale, zorder=3,
                style="italic", color="#5a4510", gid=f"port:{u}->{v}",
                bbox=dict(boxstyle="round,pad=0.1", facecolor="white", edgecolor="none", alpha=0.9))
    if title:
        ax.text((xmin + xmax) / 2, ymax - _MARGIN / 2 - title_h / 2 + 0.05, title, ha="center", va="center",
                fontsize=_TITLE_FONT * scale, fontweight="bold", gid="title")
    return fig


# --------------------------------------------------------------------------------------------
# state-transition diagram
# --------------------------------------------------------------------------------------------

def _mode_text(mode) -> str:
    locked = " ".join(mode.locked) if mode.locked else "(none locked)"
    lines = [mode.name, locked]
    for part in (mode.label or "").split("; "):
        if part:
            lines.extend(textwrap.wrap(part, width=18, break_on_hyphens=False))
    return "\n".join(lines)


def _mode_color(label: str) -> str:
    first = (label or "").split(" ", 1)[0]
    return _MODE_COLORS.get(first, "#ffffff")


def _crossings(layers: list[list[str]], adj: dict[str, set[str]]) -> int:
    total = 0
    for upper, lower in zip(layers, layers[1:]):
        pu = {n: i for i, n in enumerate(upper)}
        pl = {n: i for i, n in enumerate(lower)}
        edges = sorted({(pu[a], pl[b]) for a in upper for b in adj[a] if b in pl})
        for i, (a1, b1) in enumerate(edges):
            for a2, b2 in edges[i + 1:]:
                if (a1 - a2) * (b1 - b2) < 0:
                    total += 1
    return total


def _inversions(layers: list[list[str]], index: dict[str, int]) -> int:
    return sum(1 for layer in layers for i, a in enumerate(layer) for b in layer[i + 1:] if index[a] > index[b])


def _std_order(std) -> list[list[str]]:
    """Rows of mode names, most locked elements first, ordered to reduce crossings.

    The cost of an order is the number of crossing transitions plus half the number of modes
    out of declaration order (so the gears stay in sequence unless moving one removes more than
    one crossing per place moved); it is lowered from the declaration order and from a
    barycentre-sweep order by moving single modes within their rows.
    """
    modes = list(std.modes)
    index = {m.name: i for i, m in enumerate(modes)}
    counts = sorted({len(m.locked) for m in modes}, reverse=True)
    natural = [[m.name for m in modes if len(m.locked) == k] for k in counts]
    adj: dict[str, set[str]] = {m.name: set() for m in modes}
    for t in std.internal:
        if t.source in adj and t.target in adj:
            adj[t.source].add(t.target)
            adj[t.target].add(t.source)

    def cost(layers):
        return _crossings(layers, adj) + 0.5 * _inversions(layers, index)

    layers = [list(layer) for layer in natural]
    bary_best = [list(layer) for layer in layers]
    for sweep in range(8):
        rng = range(1, len(layers)) if sweep % 2 == 0 else range(len(layers) - 2, -1, -1)
        for i in rng:
            ref = layers[i - 1] if sweep % 2 == 0 else layers[i + 1]
            pos = {n: j for j, n in enumerate(ref)}
            cur = {n: j for j, n in enumerate(layers[i])}

            def bary(n, pos=pos, cur=cur, ref=ref, size=len(layers[i])):
                nb = [pos[m] for m in adj[n] if m in pos]
                return (sum(nb) / len(nb) if nb else cur[n] * len(ref) / max(1, size), index[n])

            layers[i] = sorted(layers[i], key=bary)
        c = _crossings(layers, adj)
        if c < _crossings(bary_best, adj):
            bary_best = [list(layer) for layer in layers]
    starts = [natural, bary_best]
    if len(modes) > 24:  # local search would be slow; the sweeps are good enough
        return min(starts, key=cost)
    results = []
    for start in starts:
        best, best_cost = [list(layer) for layer in start], cost(start)
        improved = True
        while improved:  # first improvement: move one mode to another place in its row
            improved = False
            for li in range(len(best)):
                size = len(best[li])
                for i in range(size):
                    for j in range(size):
                        if i == j:
                            continue
                        cand = [list(x) for x in best]
                        cand[li].insert(j, cand[li].pop(i))
                        c = cost(cand)
                        if c < best_cost - 1e-9:
                            best, best_cost, improved = cand, c, True
        results.append((best_cost, best))
    return min(results, key=lambda r: r[0])[1]


@dataclass
class _StdLayout:
    bubbles: dict[str, _Ellipse]
    texts: dict[str, str]
    rows: list[list[str]]


def _std_layout(std, font: float = _NODE_FONT, gap: float = 0.9) -> _StdLayout:
    texts = {m.name: _mode_text(m) for m in std.modes}
    radii = {}
    for n, t in texts.items():
        w, h = _text_size(t, font)
        radii[n] = (w / 2 * 1.3 + 0.12, h / 2 * 1.3 + 0.1)
    rows = _std_order(std)
    adj: dict[str, set[str]] = {n: set() for n in texts}
    for t in std.internal:
        if t.source in adj and t.target in adj:
            adj[t.source].add(t.target)
            adj[t.target].add(t.source)
    xs: dict[str, float] = {}
    if rows:
        widest = max(range(len(rows)), key=lambda i: (sum(2 * radii[n][0] for n in rows[i]) + gap * len(rows[i]), -i))
        order = [widest] + [i for k in range(1, len(rows)) for i in (widest - k, widest + k) if 0 <= i < len(rows)]
        for i in order:
            row = rows[i]
            widths = [2 * radii[n][0] for n in row]
            if i == widest:
                desired = [0.0] * len(row)
            else:
                ref = i + 1 if i < widest else i - 1
                ref_x = {n: xs[n] for n in rows[ref]}
                desired = []
                for j, n in enumerate(row):
                    nb = [ref_x[m] for m in adj[n] if m in ref_x]
                    desired.append(sum(nb) / len(nb) if nb else (desired[-1] if desired else 0.0))
            for n, x in zip(row, _spread(desired, widths, gap)):
                xs[n] = x
    # vertical: the gap between rows grows with the number of arrows between them
    bubbles: dict[str, _Ellipse] = {}
    y = 0.0
    for i, row in enumerate(rows):
        half = max(radii[n][1] for n in row)
        if i:
            prev_half = max(radii[n][1] for n in rows[i - 1])
            between = sum(1 for a in rows[i - 1] for b in adj[a] if b in set(row))
            y -= prev_half + half + min(4.0, 1.9 + 0.1 * between)
        for n in row:
            bubbles[n] = _Ellipse(xs[n], y, *radii[n])
    return _StdLayout(bubbles, texts, rows)


def _bezier(p0, c, p2, t):
    s = 1 - t
    return (s * s * p0[0] + 2 * s * t * c[0] + t * t * p2[0], s * s * p0[1] + 2 * s * t * c[1] + t * t * p2[1])


def _leaving_stubs(std, lay: _StdLayout) -> list[tuple]:
    """Dashed stubs of the transitions leaving the modelled modes:
    ``(x0, y0, x1, y1, label_x, label_y, text, color, gid)`` in inches.

    They fan out of the top of a bubble in the top row and out of the bottom in the bottom row
    (in a middle row: locks to the right, unlocks to the left; with one row: locks up)."""
    bubbles = lay.bubbles
    row_of = {n: i for i, row in enumerate(lay.rows) for n in row}
    last = len(lay.rows) - 1
    groups: dict[tuple[str, float], list] = {}
    for t in std.external:
        if t.source not in bubbles:
            continue
        i = row_of[t.source]
        if last == 0:
            phi = 90.0 if t.adds else 270.0
        elif i == 0:
            phi = 90.0
        elif i == last:
            phi = 270.0
        else:
            phi = 0.0 if t.adds else 180.0
        groups.setdefault((t.source, phi), []).append(t)
    out = []
    for (source, phi), group in groups.items():
        e = bubbles[source]
        n = len(group)
        step = min(24.0, 110.0 / max(1, n - 1))
        for i, t in enumerate(group):
            theta = math.radians(phi + ((n - 1) / 2 - i) * step)
            c, s_ = math.cos(theta), math.sin(theta)
            x0, y0 = e.x + e.a * c, e.y + e.b * s_
            color = _LOCK_COLOR if t.adds else _UNLOCK_COLOR
            sign = "+" if t.adds else "\u2212"
            out.append((x0, y0, x0 + _STUB * c, y0 + _STUB * s_, x0 + (_STUB + 0.15) * c,
                        y0 + (_STUB + 0.1) * s_, f"{sign}{t.element}", color, f"leaving:{source}:{t.element}"))
    return out


def draw_std(std, ax=None, leaving: bool = False):
    """Draw a state-transition diagram.

    Parameters
    ----------
    std : transgen.std.StateTransitionDiagram or transgen.model.Mechanism
        The diagram (a mechanism is converted with
        :func:`transgen.std.state_transition_diagram` and its default modes).
    ax : matplotlib.axes.Axes, optional
        Axes to draw into; by default a new :class:`matplotlib.figure.Figure` sized from the
        layout.
    leaving : bool, default False
        Also draw the transitions that leave the modelled set of modes, as short dashed stubs
        labelled with the element (upwards when it locks, downwards when it unlocks).

    Returns
    -------
    matplotlib.figure.Figure
        The figure drawn on. Each mode's text artist has the mode name as ``gid``; each
        transition label has the gid ``"transition:<source>-><target>"``.

    Notes
    -----
    Modes are bubbles showing the name, the locked elements and the label; rows hold the modes
    with the same number of locked elements (most locked on top). A transition is a curved
    arrow labelled ``lock X`` (blue) or ``unlock X`` (red); a pair of opposite transitions is
    drawn as two arcs bending to opposite sides. The conditions are left to
    :meth:`~transgen.std.StateTransitionDiagram.to_dict`.
    """
    import numpy as np
    from matplotlib.lines import Line2D
    from matplotlib.patches import Ellipse, FancyArrowPatch

    if not hasattr(std, "transitions"):
        from .std import state_transition_diagram

        std = state_transition_diagram(std)
    middle_stubs = leaving and len({len(m.locked) for m in std.modes}) > 2
    lay = _std_layout(std, gap=0.9 + (0.45 if leaving else 0.0) + (2 * _STUB + 0.3 if middle_stubs else 0.0))
    bubbles = lay.bubbles
    stubs = _leaving_stubs(std, lay) if leaving else []
    title = f"State-transition diagram: {std.mechanism}"
    tw, th = _text_size(title, _TITLE_FONT, "bold")
    xs = [e.x - e.a for e in bubbles.values()] + [e.x + e.a for e in bubbles.values()]
    ys = [e.y - e.b for e in bubbles.values()] + [e.y + e.b for e in bubbles.values()]
    xs += [st[4] + d for st in stubs for d in (-0.15, 0.15)]
    ys += [st[5] + d for st in stubs for d in (-0.08, 0.08)]
    xmin, xmax = min(xs, default=0.0) - _MARGIN, max(xs, default=1.0) + _MARGIN
    ymin = min(ys, default=0.0) - _MARGIN
    ymax = max(ys, default=1.0) + _MARGIN + th + 0.2 + (0.2 if leaving else 0.0)
    if tw + 2 * _MARGIN > xmax - xmin:
        extra = (tw + 2 * _MARGIN - (xmax - xmin)) / 2
        xmin, xmax = xmin - extra, xmax + extra
    fig, ax, scale = _figure_and_axes(ax, xmax - xmin, ymax - ymin)
    _limits(ax, xmin, xmax, ymin, ymax)

    modes = {m.name: m for m in std.modes}
    patches = {}
    for n, e in bubbles.items():
        patch = Ellipse((e.x, e.y), 2 * e.a, 2 * e.b, facecolor=_mode_color(modes[n].label),
                        edgecolor="#222222", linewidth=1.3, zorder=2, gid=n)
        ax.add_patch(patch)
        patches[n] = patch
        ax.text(e.x, e.y, lay.texts[n], ha="center", va="center", fontsize=_NODE_FONT * scale,
                zorder=4, gid=n, linespacing=1.2)

    obstacles = list(bubbles.values())
    placed: list[_Rect] = []
    internal = [t for t in std.internal if t.source in bubbles and t.target in bubbles]
    pairs = {(t.source, t.target) for t in internal}
    arrows = []

    def anchor(e: _Ellipse, other: _Ellipse) -> tuple[float, float]:
        # aim off-centre towards the other end, so arrows spread over a wide bubble
        return e.x + max(-0.5 * e.a, min(0.5 * e.a, 0.3 * (other.x - e.x))), e.y

    for t in internal:
        ea, eb = bubbles[t.source], bubbles[t.target]
        a, b = _Ellipse(*anchor(ea, eb), ea.a, ea.b), _Ellipse(*anchor(eb, ea), eb.a, eb.b)
        paired = (t.target, t.source) in pairs
        length = math.hypot(b.x - a.x, b.y - a.y) or 1.0
        rad = min(0.35, 2 * (0.3 if paired else 0.12) / length)  # the arc bulges 0.3 in / 0.12 in
        color = _LOCK_COLOR if t.adds else _UNLOCK_COLOR
        arrow = FancyArrowPatch((a.x, a.y), (b.x, b.y), patchA=patches[t.source], patchB=patches[t.target],
                                connectionstyle=f"arc3,rad={rad}", arrowstyle="-|>", mutation_scale=13 * scale,
                                shrinkA=1.5, shrinkB=1.5, color=color, linewidth=1.2, zorder=1,
                                gid=f"arrow:{t.source}->{t.target}")
        ax.add_patch(arrow)
        dx, dy = b.x - a.x, b.y - a.y
        ctrl = ((a.x + b.x) / 2 + rad * dy, (a.y + b.y) / 2 - rad * dx)
        k = len(arrows)
        arrows.append((math.hypot(dx, dy), k, t, (a.x, a.y), ctrl, (b.x, b.y), color))
    curve = [i / 40 for i in range(41)]
    ts = sorted((i / 100 for i in range(20, 81, 3)), key=lambda s: (abs(s - 0.5), s))
    lines = np.vstack([_samples([_bezier(p0, c, p2, s) for s in curve], k) for _, k, _, p0, c, p2, _ in arrows]
                      ) if arrows else None
    # label the longer arrows first: they have the fewest good spots
    for _, k, t, p0, ctrl, p2, color in sorted(arrows, key=lambda it: (-it[0], it[1])):
        text = f"{t.event} {t.element}"
        w, h = _text_size(text, 8.0)
        w, h = w + 0.08, h + 0.02
        r = _place_label([_bezier(p0, ctrl, p2, s) for s in ts], w, h, obstacles, placed, lines, k)
        ax.text(r.x, r.y, text, ha="center", va="center", fontsize=8.0 * scale, color=color, zorder=3,
                gid=f"transition:{t.source}->{t.target}",
                bbox=dict(boxstyle="round,pad=0.12", facecolor="white", edgecolor=color, linewidth=0.5, alpha=0.95))

    for x0, y0, x1, y1, lx, ly, text, color, gid in stubs:
        ax.add_line(Line2D([x0, x1], [y0, y1], color=color, linestyle=(0, (2, 1.5)), linewidth=1.0, zorder=1))
        ax.text(lx, ly, text, ha="center", va="center", fontsize=_SMALL_FONT * scale, color=color, zorder=3, gid=gid)
    if leaving:
        ax.text((xmin + xmax) / 2, ymax - _MARGIN / 2 - th - 0.12, _LEAVING_NOTE, ha="center", va="center",
                fontsize=_SMALL_FONT * scale, color="#444444", gid="leaving-note")
    ax.text((xmin + xmax) / 2, ymax - _MARGIN / 2 - th / 2, title, ha="center", va="center",
            fontsize=_TITLE_FONT * scale, fontweight="bold", gid="title")
    return fig


# --------------------------------------------------------------------------------------------
# DOT and GraphML
# --------------------------------------------------------------------------------------------

def _q(text) -> str:
    """A Graphviz double-quoted string (backslashes, quotes and newlines escaped)."""
    s = str(text).replace("\\", "\\\\").replace('"', '\\"').replace("\r", "").replace("\n", "\\n")
    return f'"{s}"'


_DOT_NODE = {
    "link": 'shape=box, style="rounded,filled", fillcolor="#dbe9f6"',
    "planetary": 'shape=box, style=filled, fillcolor="#fdf1cf"',
    "gearpair": 'shape=box, style=filled, fillcolor="#fdf1cf"',
    "clutch": 'shape=box, style=filled, fillcolor="#f7dede"',
    "brake": 'shape=box, style=filled, fillcolor="#f7dede"',
    "oneway": 'shape=box, style=filled, fillcolor="#efe0f5"',
    "housing": 'shape=box, style="rounded,filled", fillcolor="#e4e4e4"',
    "source": 'shape=box, style="rounded,dashed"',
}


def graph_to_dot(g) -> str:
    """Graphviz DOT text of the mechanism graph.

    Parameters
    ----------
    g : networkx.DiGraph or transgen.model.Mechanism
        The graph of :func:`transgen.graph.build_graph`.

    Returns
    -------
    str
        A ``digraph`` with one node per graph node (labelled as in :func:`draw_graph`), one
        edge per bond (half-arrow heads, transformer ports as edge labels) and ``rank=same``
        groups for the transformer, link, shift-element and housing rows.
    """
    if not isinstance(g, nx.Graph):
        from .graph import build_graph

        g = build_graph(g)
    lines = [f"digraph {_q(g.graph.get('name', 'mechanism'))} {{",
             "  rankdir=TB;",
             '  node [fontname="Helvetica", fontsize=10];',
             '  edge [arrowhead=lvee, fontname="Helvetica", fontsize=8];']
    for n, d in g.nodes(data=True):
        attrs = _DOT_NODE.get(d.get("kind", ""), "shape=box")
        lines.append(f"  {_q(n)} [label={_q(_node_text(n, d))}, {attrs}];")
    for u, v, d in g.edges(data=True):
        extra = f" [label={_q(d['port'])}]" if d.get("port") is not None else ""
        lines.append(f"  {_q(u)} -> {_q(v)}{extra};")
    kinds = {n: d.get("kind", "") for n, d in g.nodes(data=True)}
    for group in (_TRANSFORMER_KINDS, ("link",), _ELEMENT_KINDS, ("housing",)):
        members = [n for n in g if kinds[n] in group]
        if members:
            lines.append("  { rank=same; " + " ".join(f"{_q(n)};" for n in members) + " }")
    lines.append("}")
    return "\n".join(lines) + "\n"


def std_to_dot(std, leaving: bool = False) -> str:
    """Graphviz DOT text of a state-transition diagram.

    Parameters
    ----------
    std : transgen.std.StateTransitionDiagram or transgen.model.Mechanism
        The diagram (a mechanism is converted with its default modes).
    leaving : bool, default False
        Also write the transitions leaving the modelled modes, as dashed edges to point nodes.

    Returns
    -------
    str
        A ``digraph`` with one ellipse per mode (name, locked elements, label), one edge per
        transition labelled ``lock X`` / ``unlock X``, and one ``rank=same`` group per number
        of locked elements.
    """
    if not hasattr(std, "transitions"):
        from .std import state_transition_diagram

        std = state_transition_diagram(std)
    lines = [f"digraph {_q('STD ' + str(std.mechanism))} {{",
             "  rankdir=TB;",
             '  node [shape=ellipse, style=filled, fontname="Helvetica", fontsize=10];',
             '  edge [fontname="Helvetica", fontsize=8];']
    for m in std.modes:
        lines.append(f"  {_q(m.name)} [label={_q(_mode_text(m))}, fillcolor={_q(_mode_color(m.label))}];")
    for t in std.internal:
        color = _LOCK_COLOR if t.adds else _UNLOCK_COLOR
        lines.append(f"  {_q(t.source)} -> {_q(t.target)} [label={_q(f'{t.event} {t.element}')}, "
                     f"color={_q(color)}, fontcolor={_q(color)}];")
    if leaving:
        for t in std.external:
            stub = f"{t.source}:{t.event}:{t.element}"
            lines.append(f"  {_q(stub)} [shape=point, width=0.05, label=\"\"];")
            lines.append(f"  {_q(t.source)} -> {_q(stub)} [label={_q(f'{t.event} {t.element}')}, style=dashed];")
    for k in sorted({len(m.locked) for m in std.modes}, reverse=True):
        members = [m.name for m in std.modes if len(m.locked) == k]
        lines.append("  { rank=same; " + " ".join(f"{_q(n)};" for n in members) + " }")
    lines.append("}")
    return "\n".join(lines) + "\n"


def _graphml_value(value):
    if isinstance(value, bool) or isinstance(value, str):
        return value
    if isinstance(value, int | float):
        return value
    if value is None:
        return ""
    try:  # numpy scalars
        import numpy as np

        if isinstance(value, np.generic):
            return value.item()
    except ImportError:  # pragma: no cover
        pass
    return str(value)


def _graphml_attrs(items: list[dict]) -> list[dict]:
    """Attribute dicts with GraphML-writable values and one value type per attribute name."""
    out = [{k: _graphml_value(v) for k, v in d.items()} for d in items]
    keys = {k for d in out for k in d}
    for k in keys:
        types = {type(d[k]) for d in out if k in d}
        if len(types) <= 1:
            continue
        numeric = all(t in (int, float) for t in types)
        for d in out:
            if k in d:
                d[k] = float(d[k]) if numeric else str(d[k])
    return out


def graph_to_graphml(g) -> str:
    """GraphML text of the mechanism graph (for yEd, Gephi, Cytoscape, ...).

    Tuple, dict and ``None`` attributes (ports' ``terms``, transformers' ``params``, an
    element's ``free``) are written as strings; an attribute holding both ints and floats is
    written as floats.

    Parameters
    ----------
    g : networkx.DiGraph or transgen.model.Mechanism
        The graph of :func:`transgen.graph.build_graph`.

    Returns
    -------
    str
        The GraphML document (``networkx.generate_graphml``).
    """
    if not isinstance(g, nx.Graph):
        from .graph import build_graph

        g = build_graph(g)
    h = nx.DiGraph() if g.is_directed() else nx.Graph()
    h.graph.update(_graphml_attrs([dict(g.graph)])[0])
    nodes = list(g.nodes(data=True))
    for (n, _), attrs in zip(nodes, _graphml_attrs([dict(d) for _, d in nodes])):
        h.add_node(n, **attrs)
    edges = list(g.edges(data=True))
    for (u, v, _), attrs in zip(edges, _graphml_attrs([dict(d) for _, _, d in edges])):
        h.add_edge(u, v, **attrs)
    return "\n".join(nx.generate_graphml(h)) + "\n"


# --------------------------------------------------------------------------------------------
# saving
# --------------------------------------------------------------------------------------------

def save_figure(fig, path, dpi: float = 150) -> Path:
    """Write ``fig`` to ``path`` atomically, in the format of its suffix.

    The figure is written to a temporary file in the target's folder and renamed over the
    target only when complete, so a failure never leaves a partial or stray file.

    Parameters
    ----------
    fig : matplotlib.figure.Figure
        The figure (e.g. from :func:`draw_graph` or :func:`draw_std`).
    path : str or os.PathLike
        Target file; its suffix (``.png``, ``.svg`` or ``.pdf``, any case) selects the format.
        Missing parent folders are created.
    dpi : float, default 150
        Resolution of a PNG.

    Returns
    -------
    pathlib.Path
        ``path``.

    Raises
    ------
    ValueError
        If the suffix is not one of :data:`FIGURE_FORMATS`.
    """
    path = Path(path)
    fmt = FIGURE_FORMATS.get(path.suffix.lower())
    if fmt is None:
        raise ValueError(f"cannot save a figure as {path.name!r}: unknown suffix {path.suffix!r} "
                         f"(use one of {', '.join(FIGURE_FORMATS)})")
    with atomic_path(path) as tmp:
        fig.savefig(tmp, format=fmt, dpi=dpi, facecolor="white")
    return path
