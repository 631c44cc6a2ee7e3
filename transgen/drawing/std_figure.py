"""The picture of the state-transition diagram (thesis Figs. 3.8 and 3.12).

Modes are bubbles, transitions curved arrows labelled ``lock X`` / ``unlock X`` (the conditions
themselves belong in the JSON of :meth:`transgen.std.StateTransitionDiagram.to_dict`);
optionally the transitions leaving the modelled modes as dashed stubs. The layout is
:func:`transgen.drawing.layout.std_layout`.
"""
from __future__ import annotations

import math

from .common import LOCK_COLOR, UNLOCK_COLOR, as_std, mode_color
from .figure import (MARGIN, NODE_FONT, SMALL_FONT, TITLE_FONT, Oval, Rect, figure_and_axes, line_samples,
                     place_label, set_limits, text_size)
from .layout import StdLayout, std_layout

_STUB = 0.32  # length of a stub of a transition leaving the modelled modes (inches)
_LEAVING_NOTE = "dashed: transitions leaving the modelled modes (+X: X locks, \u2212X: X unlocks)"


def _bezier(p0, c, p2, t):
    s = 1 - t
    return (s * s * p0[0] + 2 * s * t * c[0] + t * t * p2[0], s * s * p0[1] + 2 * s * t * c[1] + t * t * p2[1])


def _leaving_stubs(std, lay: StdLayout) -> list[tuple]:
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
            color = LOCK_COLOR if t.adds else UNLOCK_COLOR
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

    std = as_std(std)
    middle_stubs = leaving and len({len(m.locked) for m in std.modes}) > 2
    lay = std_layout(std, gap=0.9 + (0.45 if leaving else 0.0) + (2 * _STUB + 0.3 if middle_stubs else 0.0))
    bubbles = lay.bubbles
    stubs = _leaving_stubs(std, lay) if leaving else []
    title = f"State-transition diagram: {std.mechanism}"
    tw, th = text_size(title, TITLE_FONT, "bold")
    xs = [e.x - e.a for e in bubbles.values()] + [e.x + e.a for e in bubbles.values()]
    ys = [e.y - e.b for e in bubbles.values()] + [e.y + e.b for e in bubbles.values()]
    xs += [st[4] + d for st in stubs for d in (-0.15, 0.15)]
    ys += [st[5] + d for st in stubs for d in (-0.08, 0.08)]
    xmin, xmax = min(xs, default=0.0) - MARGIN, max(xs, default=1.0) + MARGIN
    ymin = min(ys, default=0.0) - MARGIN
    ymax = max(ys, default=1.0) + MARGIN + th + 0.2 + (0.2 if leaving else 0.0)
    if tw + 2 * MARGIN > xmax - xmin:
        extra = (tw + 2 * MARGIN - (xmax - xmin)) / 2
        xmin, xmax = xmin - extra, xmax + extra
    fig, ax, scale = figure_and_axes(ax, xmax - xmin, ymax - ymin)
    set_limits(ax, xmin, xmax, ymin, ymax)

    modes = {m.name: m for m in std.modes}
    patches = {}
    for n, e in bubbles.items():
        patch = Ellipse((e.x, e.y), 2 * e.a, 2 * e.b, facecolor=mode_color(modes[n].label),
                        edgecolor="#222222", linewidth=1.3, zorder=2, gid=n)
        ax.add_patch(patch)
        patches[n] = patch
        ax.text(e.x, e.y, lay.texts[n], ha="center", va="center", parse_math=False, fontsize=NODE_FONT * scale,
                zorder=4, gid=n, linespacing=1.2)

    obstacles = list(bubbles.values())
    placed: list[Rect] = []
    internal = [t for t in std.internal if t.source in bubbles and t.target in bubbles]
    pairs = {(t.source, t.target) for t in internal}
    arrows = []

    def anchor(e: Oval, other: Oval) -> tuple[float, float]:
        # aim off-centre towards the other end, so arrows spread over a wide bubble
        return e.x + max(-0.5 * e.a, min(0.5 * e.a, 0.3 * (other.x - e.x))), e.y

    for t in internal:
        ea, eb = bubbles[t.source], bubbles[t.target]
        a, b = Oval(*anchor(ea, eb), ea.a, ea.b), Oval(*anchor(eb, ea), eb.a, eb.b)
        paired = (t.target, t.source) in pairs
        length = math.hypot(b.x - a.x, b.y - a.y) or 1.0
        rad = min(0.35, 2 * (0.3 if paired else 0.12) / length)  # the arc bulges 0.3 in / 0.12 in
        color = LOCK_COLOR if t.adds else UNLOCK_COLOR
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
    lines = np.vstack([line_samples([_bezier(p0, c, p2, s) for s in curve], k) for _, k, _, p0, c, p2, _ in arrows]
                      ) if arrows else None
    # label the longer arrows first: they have the fewest good spots
    for _, k, t, p0, ctrl, p2, color in sorted(arrows, key=lambda it: (-it[0], it[1])):
        text = f"{t.event} {t.element}"
        w, h = text_size(text, 8.0)
        w, h = w + 0.08, h + 0.02
        r = place_label([_bezier(p0, ctrl, p2, s) for s in ts], w, h, obstacles, placed, lines, k)
        ax.text(r.x, r.y, text, ha="center", va="center", parse_math=False, fontsize=8.0 * scale, color=color, zorder=3,
                gid=f"transition:{t.source}->{t.target}",
                bbox=dict(boxstyle="round,pad=0.12", facecolor="white", edgecolor=color, linewidth=0.5, alpha=0.95))

    for x0, y0, x1, y1, lx, ly, text, color, gid in stubs:
        ax.add_line(Line2D([x0, x1], [y0, y1], color=color, linestyle=(0, (2, 1.5)), linewidth=1.0, zorder=1))
        ax.text(lx, ly, text, ha="center", va="center", parse_math=False, fontsize=SMALL_FONT * scale, color=color, zorder=3, gid=gid)
    if leaving:
        ax.text((xmin + xmax) / 2, ymax - MARGIN / 2 - th - 0.12, _LEAVING_NOTE, ha="center", va="center", parse_math=False,
                fontsize=SMALL_FONT * scale, color="#444444", gid="leaving-note")
    ax.text((xmin + xmax) / 2, ymax - MARGIN / 2 - th / 2, title, ha="center", va="center", parse_math=False,
            fontsize=TITLE_FONT * scale, fontweight="bold", gid="title")
    return fig
