"""Lever diagrams and the speed chart (the lever analogy of Benford and Leising, 1981).

:func:`draw_levers` draws one panel per gear: every lever of :func:`~transgen.drawing.lever.lever_layout`
upright, its nodes at their heights along the lever (spaced by the tooth counts) and displaced
sideways by their speeds per unit input speed, so that each lever is the straight line of its
nodes' speeds (a speed lever, or Kutzbach plan). The thin vertical line of a lever is its zero
speed (the lever at rest), the dotted one the input speed. Engaged brakes are grounds (the node
sits on the zero line), engaged clutches thick joins between nodes, open elements faint; a link
that is a node of two levers is joined by a thin grey line (one shaft); the input and output
nodes are marked. An optional first panel shows the levers at rest: the topology.

:func:`draw_speed_chart` draws every link's speed per unit input speed over the gears.

Drawings are in inch units (see :mod:`transgen.drawing.figure`); matplotlib is imported only
inside the functions.
"""
from __future__ import annotations

from dataclasses import dataclass

from ..model import HOUSING, Mechanism
from .common import LOCK_COLOR
from .figure import MARGIN, NODE_FONT, SMALL_FONT, TITLE_FONT, Rect, figure_and_axes, place_label, set_limits, text_size
from .lever import Lever, drawn_gears, lever_layout, lever_speeds

__all__ = ["draw_levers", "draw_speed_chart"]

LEVER_HEIGHT = 2.3  # inches from the lowest to the highest node of a lever
_LEVER_COLOR = "#2b5d8a"
_REST_COLOR = "#9a9a9a"
_OPEN_COLOR = "#c4c4c4"
_BRAKE_COLOR = "#8a2b2b"
_IN_COLOR = "#2b7a3b"
_OUT_COLOR = "#c06000"
_JOIN_COLOR = "#7a7a7a"


def _element_kind_label(e) -> str:
    return e.name + {"oneway": " (1-way)", "dog": " (dog)"}.get(e.kind, "")


@dataclass
class _Column:
    lever: Lever
    ys: dict  # link -> height (inches above the panel's lever base)
    wmin: float
    wmax: float
    left: float = 0.0  # room left of the speed range (inches)
    right: float = 0.0  # room right of it
    x0: float = 0.0  # x of zero speed, from the panel's left edge
    brake_w: float = 0.0  # room of the brake labels left of the zero line
    n_same: int = 0  # clutches between two nodes of this lever
    lane: float = 0.0  # x of the first lane of those clutches, from x0


def _column_order(levers, mech, max_search: int = 7):
    """The levers left to right: the order (of at most ``max_search`` levers; else as given) in
    which the joins of a link on two levers and the clutches jump over the fewest levers, the
    given order (gearsets in declaration order, then lone links) among equals."""
    import itertools

    if len(levers) > max_search:
        return levers
    owners: dict[str, list[int]] = {}
    for k, lv in enumerate(levers):
        for n in lv.nodes:
            if n.link != HOUSING:
                owners.setdefault(n.link, []).append(k)
    pairs = [(ks[0], k) for ks in owners.values() for k in ks[1:]]
    pairs += [(owners[e.link1][0], owners[e.link2][0]) for e in mech.elements
              if e.link2 != HOUSING and e.link1 in owners and e.link2 in owners]
    best, best_cost = None, None
    for order in itertools.permutations(range(len(levers))):
        at = {k: i for i, k in enumerate(order)}
        cost = sum(max(abs(at[a] - at[b]) - 1, 0) for a, b in pairs)
        if best_cost is None or cost < best_cost:
            best, best_cost = order, cost
    return tuple(levers[k] for k in best)


def _orient(levers, mech) -> dict[str, dict[str, float]]:
    """Heights of every node, lever by lever: the first multi-node lever as laid out, each next
    one flipped where that brings its links nearer to the same links (or the links they are
    joined to by a shift element) on the levers before it; a lone link at the mean height of
    the nodes it is joined to."""
    partners: dict[str, set] = {}
    for e in mech.elements:
        if e.link2 != HOUSING:
            partners.setdefault(e.link1, set()).add(e.link2)
            partners.setdefault(e.link2, set()).add(e.link1)
    placed: dict[str, list[float]] = {}
    heights = {}
    for lv in levers:
        if len(lv.nodes) < 2:
            continue
        up = {n.link: LEVER_HEIGHT * n.position / lv.length for n in lv.nodes}
        down = {k: LEVER_HEIGHT - y for k, y in up.items()}

        def cost(ys):
            c = 0.0
            for link, y in ys.items():
                c += 4 * sum(abs(y - p) for p in placed.get(link, ()))  # the same shaft: weighs most
                for other in sorted(partners.get(link, ())):
                    c += sum(abs(y - p) for p in placed.get(other, ()))
            return c

        ys = down if cost(down) < cost(up) - 1e-9 else up
        heights[lv.name] = ys
        for link, y in ys.items():
            if link != HOUSING:
                placed.setdefault(link, []).append(y)
    for lv in levers:
        if len(lv.nodes) == 1:
            link = lv.nodes[0].link
            near = [y for other in partners.get(link, ()) for y in placed.get(other, ())]
            heights[lv.name] = {link: sum(near) / len(near) if near else LEVER_HEIGHT / 2}
    return heights


def _node_text(link: str, mech: Mechanism, w) -> str:
    """``"L6 out 0.27"``: the link, its role, its speed per unit input speed (if given)."""
    role = " in" if link == mech.input else (" out" if link == mech.output else "")
    if w is None:
        return f"{link}{role}"
    return f"{link}{role} {w:.2f}".replace("-0.00", "0.00")


def _spread_1d(ys: list[float], gap: float) -> list[float]:
    """Heights kept in order and at least ``gap`` apart, as near to ``ys`` as a push allows."""
    order = sorted(range(len(ys)), key=lambda i: ys[i])
    out = list(ys)
    for _ in range(50):
        moved = False
        for a, b in zip(order, order[1:]):
            if out[b] - out[a] < gap - 1e-9:
                d = (gap - (out[b] - out[a])) / 2
                out[a] -= d
                out[b] += d
                moved = True
        if not moved:
            break
    return out


def draw_levers(mech: Mechanism, gears=None, topology: bool | None = None, ax=None):
    """Draw the lever diagram of ``mech``: one panel per gear (and the levers at rest).

    Parameters
    ----------
    mech : transgen.model.Mechanism
        The mechanism.
    gears : sequence of str, optional
        Declared gears to draw, one panel each (default: every declared gear, neutrals left out).
    topology : bool, optional
        Draw a first panel with the levers at rest, every shift element and the gear members at
        each node (default: when ``gears`` is not given).
    ax : matplotlib.axes.Axes, optional
        Axes to draw into; by default a new figure sized from the layout.

    Returns
    -------
    matplotlib.figure.Figure
        Node labels have the gid ``"node:<panel>:<lever>:<link>"``, panel titles
        ``"title:<panel>"`` (``<panel>`` is the gear name, or ``levers`` for the topology).

    Notes
    -----
    The horizontal displacement of a node from its lever's zero line is its speed per unit input
    speed (``w_link / w_in``, positive in the input's direction); its height is its position
    along the lever (tooth counts, see :mod:`transgen.drawing.lever`). Each lever is scaled to
    the same height; speeds share one scale across the figure.
    """
    from matplotlib.lines import Line2D
    from matplotlib.patches import Circle, Polygon

    names = drawn_gears(mech, gears)
    if topology is None:
        topology = gears is None
    levers = _column_order(lever_layout(mech), mech)
    panels: list[tuple[str, dict | None]] = [("levers", None)] if topology else []
    panels += [(g, lever_speeds(mech, g)) for g in names]
    if not panels:
        raise ValueError(f"{mech.name} declares no gear to draw")
    heights = _orient(levers, mech)
    brakes = [e for e in mech.elements if e.link2 == HOUSING]
    clutches = [e for e in mech.elements if e.link2 != HOUSING]
    # where each link is drawn: its first node (levers in order), and every other node of it
    home: dict[str, tuple[int, str]] = {}
    for k, lv in enumerate(levers):
        for n in lv.nodes:
            if n.link != HOUSING:
                home.setdefault(n.link, (k, n.link))

    # the columns: speed ranges over every panel, room for the labels
    cols = []
    gap_label = 0.1
    for k, lv in enumerate(levers):
        ws = [0.0, 1.0] + [sp[n.link] for _, sp in panels if sp for n in lv.nodes if sp.get(n.link) is not None]
        col = _Column(lv, heights[lv.name], min(ws), max(ws))
        widths = []
        for name, sp in panels:
            for n in lv.nodes:
                widths.append(text_size(_node_text(n.link, mech, sp.get(n.link) if sp else None), NODE_FONT)[0])
                if sp is None and n.members:
                    widths.append(text_size(" ".join(n.members), SMALL_FONT)[0])
        col.right = max(widths) + gap_label + 0.25
        col.brake_w = max((text_size(_element_kind_label(e), SMALL_FONT)[0] + 0.2 for e in brakes
                           if home.get(e.link1, (None,))[0] == k), default=0.0)
        col.n_same = sum(1 for e in clutches if home.get(e.link1, (None,))[0] == k == home.get(e.link2, (None,))[0])
        cols.append(col)
    span = max(c.wmax - c.wmin for c in cols)
    scale = min(1.0, max(0.35, 1.5 / span))  # inches per unit speed
    x = 0.0
    for c in cols:
        c.lane = min(scale * c.wmin - 0.14, -0.17) - c.brake_w - 0.04  # first lane of same-lever clutches, from x0
        c.left = max(0.15, -c.lane + scale * c.wmin - 0.08) + 0.16 * c.n_same
        c.x0 = x + c.left - scale * c.wmin
        x = c.x0 + scale * c.wmax + c.right
    panel_w = x + 0.1
    title_h = 0.7
    axis_h = 0.35
    panel_h = title_h + LEVER_HEIGHT + 0.5 + axis_h
    legend_h = 1.0  # about; measured once the width is known

    def misfit(n):  # the panels' grid nearest a 4:3 page no wider than 24 inches
        w, h = n * panel_w, -(-len(panels) // n) * panel_h + legend_h
        return (w > 24.0 and n > 1, abs(w / h - 4 / 3))

    ncols = min(range(1, len(panels) + 1), key=misfit)
    nrows = -(-len(panels) // ncols)
    width = max(ncols * panel_w + 2 * MARGIN, 7.0)
    pivot = any(n.link == HOUSING for lv in levers for n in lv.nodes)
    twice = any(n.link != HOUSING and home[n.link][0] != k for k, lv in enumerate(levers) for n in lv.nodes)
    shown = {"lever", "input", "output"}
    dogs = [e for e in mech.elements if e.kind == "dog"]
    for text, present in (("brake engaged (ground)", [e for e in brakes if e.kind != "dog"]),
                          ("clutch engaged", [e for e in clutches if e.kind != "dog"]),
                          ("dog brake engaged", [e for e in dogs if e.link2 == HOUSING]),
                          ("dog clutch engaged", [e for e in dogs if e.link2 != HOUSING]),
                          ("open element", mech.elements), ("same link on two levers", twice),
                          ("housing (gear axes)", pivot)):
        if present:
            shown.add(text)
    legend_rows, note = _legend_rows(width, shown)
    legend_h = 0.3 * len(legend_rows) + 0.16 * len(note) + 0.2
    height = nrows * panel_h + legend_h + 2 * MARGIN + 0.45
    fig, ax, fs = figure_and_axes(ax, width, height)
    set_limits(ax, 0, width, 0, height)
    ax.text(width / 2, height - MARGIN - 0.15, f"{mech.name}: lever diagrams", ha="center", va="center",
            fontsize=TITLE_FONT * fs * 1.1, fontweight="bold", parse_math=False, gid="title")

    def line(xs, ys, **kw):
        ax.add_line(Line2D(xs, ys, **kw))

    def ground(xg, yg, color, z=3):
        _ground(ax, xg, yg, color, z)

    for p, (pname, speeds) in enumerate(panels):
        px = MARGIN + (p % ncols) * panel_w
        top = height - MARGIN - 0.45 - (p // ncols) * panel_h
        base = top - title_h - 0.25 - LEVER_HEIGHT  # y of lever position 0
        if speeds is None:
            head, sub = "levers at rest", "every shift element; gear members at each node"
            engaged: tuple = ()
        else:
            row = mech.gear(pname)
            engaged = row.engaged
            w_out = speeds.get(mech.output)
            ratio = f"ratio {1 / w_out:.3f}" if w_out else "ratio -"
            head = f"gear {pname}" + (" (alternative)" if row.alternative else "")
            sub = f"{' '.join(engaged)} engaged \u00b7 {ratio}"
        ax.text(px + panel_w / 2, top - 0.12, head, ha="center", va="center", fontsize=TITLE_FONT * fs,
                fontweight="bold", parse_math=False, gid=f"title:{pname}")
        ax.text(px + panel_w / 2, top - 0.34, sub, ha="center", va="center", fontsize=SMALL_FONT * fs * 1.1,
                parse_math=False, color="#333333", gid=f"subtitle:{pname}")
        ax.add_patch(_frame(px + 0.03, top - panel_h + 0.06, panel_w - 0.06, panel_h - 0.06))

        def xy(k, link):
            c = cols[k]
            w = speeds.get(link) if speeds else 0.0
            return px + c.x0 + scale * (w or 0.0), base + c.ys[link]

        obstacles: list[Rect] = []
        placed: list[Rect] = []
        # reference lines, lever lines, nodes
        for k, c in enumerate(cols):
            x0 = px + c.x0
            y_lo, y_hi = base + min(c.ys.values()), base + max(c.ys.values())
            line([x0, x0], [min(y_lo, base) - 0.2, max(y_hi, base + LEVER_HEIGHT) + 0.1], color=_REST_COLOR,
                 linewidth=0.8, zorder=1)
            if speeds is not None:
                line([x0 + scale, x0 + scale], [base - 0.2, base + LEVER_HEIGHT + 0.1], color=_REST_COLOR,
                     linewidth=0.7, linestyle=(0, (1, 2)), zorder=1)
                for tick in range(int(c.wmin) - 1, int(c.wmax) + 2):
                    if c.wmin - 1e-9 <= tick <= c.wmax + 1e-9:
                        xt = x0 + scale * tick
                        line([xt, xt], [base - 0.27, base - 0.22], color="#555555", linewidth=0.8, zorder=1)
                        ax.text(xt, base - 0.36, f"{tick:g}".replace("-", "\u2212"), ha="center", va="center",
                                fontsize=SMALL_FONT * fs, color="#555555", parse_math=False)
                line([x0 + scale * c.wmin, x0 + scale * c.wmax], [base - 0.245] * 2, color="#555555",
                     linewidth=0.6, zorder=1)
            lv = c.lever
            known = [n for n in lv.nodes if speeds is None or speeds.get(n.link) is not None]
            if len(lv.nodes) > 1:
                ends = [xy(k, n.link) for n in (known[0], known[-1])] if len(known) >= 2 else None
                if ends:
                    line([ends[0][0], ends[1][0]], [ends[0][1], ends[1][1]],
                         color=_LEVER_COLOR if speeds is not None else "#333333", linewidth=3.2,
                         solid_capstyle="round", zorder=2, gid=f"lever:{pname}:{lv.name}")
                else:
                    line([x0, x0], [y_lo, y_hi], color=_REST_COLOR, linewidth=2.5, linestyle="--", zorder=2)
                ax.text(x0, base + LEVER_HEIGHT + 0.3, " + ".join(lv.sets), ha="center", va="bottom",
                        fontsize=SMALL_FONT * fs, color="#333333", style="italic", parse_math=False)
            texts = []
            for n in lv.nodes:
                w = speeds.get(n.link) if speeds else None
                xn, yn = xy(k, n.link)
                if n.link == HOUSING:
                    ground(xn - 0.07, yn, "#222222")
                face = "white"
                if n.link == mech.input:
                    face = _IN_COLOR
                elif n.link == mech.output:
                    face = _OUT_COLOR
                ax.add_patch(Circle((xn, yn), 0.055, facecolor=face, edgecolor="#222222", linewidth=1.0, zorder=5))
                if speeds is not None and w is None:
                    texts.append((yn, xn, f"{n.link} free", n))
                else:
                    texts.append((yn, xn, _node_text(n.link, mech, w if speeds is not None else None), n))
                obstacles.append(Rect(xn, yn, 0.12, 0.12))
            hs = [text_size(t, NODE_FONT)[1] for _, _, t, _ in texts]
            gap = max(hs) * 0.8 if speeds is not None else max(hs) + text_size("P", SMALL_FONT)[1] + 0.02
            ys = _spread_1d([t[0] + 0.02 for t in texts], gap)
            for (yn, xn, t, n), yl in zip(texts, ys):
                color = _IN_COLOR if n.link == mech.input else (_OUT_COLOR if n.link == mech.output else "#111111")
                xl = max(xn, px + c.x0) + 0.09 if speeds is None else xn + 0.09
                ax.text(xl, yl, t, ha="left", va="bottom" if speeds is None else "center", fontsize=NODE_FONT * fs,
                        color=color, fontweight="bold" if n.link in (mech.input, mech.output) else "normal",
                        parse_math=False, zorder=6, gid=f"node:{pname}:{lv.name}:{n.link}",
                        bbox=dict(boxstyle="square,pad=0.02", facecolor="white", edgecolor="none", alpha=0.85))
                tw, th = text_size(t, NODE_FONT)
                placed.append(Rect(xl + tw / 2, yl + (th / 2 if speeds is None else 0), tw, th))
                if speeds is None and n.members:
                    ms = " ".join(n.members)
                    ax.text(xl, yl - 0.01, ms, ha="left", va="top", fontsize=SMALL_FONT * fs, color="#5a4510",
                            style="italic", parse_math=False, zorder=6,
                            bbox=dict(boxstyle="square,pad=0.02", facecolor="white", edgecolor="none", alpha=0.85))
                    mw, mh = text_size(ms, SMALL_FONT)
                    placed.append(Rect(xl + mw / 2, yl - mh / 2, mw, mh))
        # the same link on two levers: one shaft
        for k, c in enumerate(cols):
            for n in c.lever.nodes:
                if n.link != HOUSING and home[n.link][0] != k:
                    (x1, y1), (x2, y2) = xy(home[n.link][0], n.link), xy(k, n.link)
                    line([x1, x2], [y1, y2], color=_JOIN_COLOR, linewidth=1.0, zorder=1)
        # brakes: grounds on the zero line at the node's height
        for e in brakes:
            k = home[e.link1][0]
            x0, yn = px + cols[k].x0, base + cols[k].ys[e.link1]
            on = speeds is None or e.name in engaged
            color = _BRAKE_COLOR if on else _OPEN_COLOR
            ground(x0 - 0.07, yn, color, z=4)
            if e.kind == "dog":
                _dog_teeth(ax, x0 - 0.07, yn, color)
            if speeds is not None and on:
                xn = xy(k, e.link1)[0]
                if abs(xn - x0) > 0.08:
                    line([x0 - 0.07, xn], [yn, yn], color=color, linewidth=1.6, zorder=4)
            label = _element_kind_label(e)
            tw, th = text_size(label, SMALL_FONT)
            xl = x0 - 0.17 if speeds is None else min(x0 - 0.17, x0 + scale * cols[k].wmin - 0.14)
            ax.text(xl, yn + 0.03, label, ha="right", va="bottom", fontsize=SMALL_FONT * fs, color=color,
                    fontweight="bold" if on and speeds is not None else "normal", parse_math=False, zorder=6,
                    gid=f"element:{pname}:{e.name}",
                    bbox=dict(boxstyle="square,pad=0.02", facecolor="white", edgecolor="none", alpha=0.85))
            placed.append(Rect(xl - tw / 2, yn + 0.03 + th / 2, tw, th))
        # clutches: joins between nodes; beside the lever when both nodes are on it
        lane: dict[int, int] = {}
        pair = {e.name: frozenset((home[e.link1], home[e.link2])) for e in clutches}
        done: dict[frozenset, int] = {}
        for e in sorted(clutches, key=lambda e: speeds is not None and e.name in engaged):  # engaged on top
            k1, k2 = home[e.link1][0], home[e.link2][0]
            on = speeds is None or e.name in engaged
            color = (LOCK_COLOR if speeds is not None else "#333333") if on else _OPEN_COLOR
            lw = 2.0 if on and speeds is not None else 1.2
            style = "-" if on else (0, (3, 2))
            (x1, y1), (x2, y2) = xy(k1, e.link1), xy(k2, e.link2)
            if k1 == k2:
                lane[k1] = lane.get(k1, 0) + 1
                xb = px + cols[k1].x0 + cols[k1].lane - 0.16 * (lane[k1] - 1)
                line([x1, xb, xb, x2], [y1, y1, y2, y2], color=color, linewidth=lw, linestyle=style, zorder=3)
                mx, my, vertical = xb, (y1 + y2) / 2, True
            else:
                line([x1, x2], [y1, y2], color=color, linewidth=lw, linestyle=style, zorder=3)
                # elements in parallel (the same two nodes) get their symbols side by side
                done[pair[e.name]] = done.get(pair[e.name], 0) + 1
                m = 1 + sum(1 for v in pair.values() if v == pair[e.name])
                t0 = done[pair[e.name]] / m
                # the symbol where it meets no label: near its share of the line
                for dt in (0.0, -0.08, 0.08, -0.16, 0.16, -0.24, 0.24):
                    t = min(max(t0 + dt / (m - 1), 0.15), 0.85)
                    box = Rect(x1 + t * (x2 - x1), y1 + t * (y2 - y1), 0.2, 0.2)
                    if not any(box.overlaps(r) for r in placed):
                        break
                else:
                    t = t0
                mx, my, vertical = x1 + t * (x2 - x1), y1 + t * (y2 - y1), abs(x2 - x1) < abs(y2 - y1)
                placed.append(Rect(mx, my, 0.18, 0.18))
            (_dog if e.kind == "dog" else _plates)(ax, mx, my, vertical, color)
            label = _element_kind_label(e)
            tw, th = text_size(label, SMALL_FONT)
            cands = [(mx + 0.12 + tw / 2, my), (mx - 0.12 - tw / 2, my), (mx, my + 0.16), (mx, my - 0.16),
                     (mx + 0.12 + tw / 2, my + 0.15), (mx - 0.12 - tw / 2, my - 0.15)]
            r = place_label(cands, tw + 0.04, th, obstacles, placed)
            ax.text(r.x, r.y, label, ha="center", va="center", fontsize=SMALL_FONT * fs, color=color if on else "#999999",
                    fontweight="bold" if on and speeds is not None else "normal", parse_math=False, zorder=6,
                    gid=f"element:{pname}:{e.name}",
                    bbox=dict(boxstyle="square,pad=0.02", facecolor="white", edgecolor="none", alpha=0.85))
        # the input arrow: from below into a lone input shaft, else from the left
        if mech.input in home:
            xi, yi = xy(home[mech.input][0], mech.input)
            ux, uy = (1.0, 0.0)
            if len(cols[home[mech.input][0]].lever.nodes) == 1:  # a lone shaft: from below, or above
                ux, uy = (0.0, 1.0) if yi - base > 0.5 else (0.0, -1.0)
            tip, back = 0.07, 0.2
            ax.add_patch(Polygon([(xi - tip * ux, yi - tip * uy),
                                  (xi - back * ux - 0.06 * uy, yi - back * uy + 0.06 * ux),
                                  (xi - back * ux + 0.06 * uy, yi - back * uy - 0.06 * ux)], closed=True,
                                 facecolor=_IN_COLOR, edgecolor="none", zorder=5))
            line([xi - 0.4 * ux, xi - back * ux], [yi - 0.4 * uy, yi - back * uy], color=_IN_COLOR, linewidth=1.6,
                 zorder=5)
    _legend(ax, fs, legend_rows, note, MARGIN + legend_h, Line2D)
    return fig


def _frame(x, y, w, h):
    from matplotlib.patches import FancyBboxPatch

    return FancyBboxPatch((x, y), w, h, boxstyle="round,pad=0,rounding_size=0.06", facecolor="none",
                          edgecolor="#d0d0d0", linewidth=0.8, zorder=0)


_LEGEND = ("lever", "brake engaged (ground)", "dog brake engaged", "housing (gear axes)", "clutch engaged",
           "dog clutch engaged", "open element",
           "same link on two levers", "input", "output")
_NOTE = ("Horizontal: the speed of each node per unit input speed (the numbers; thin line 0, dotted line 1 = "
         "the input speed). Vertical: the position along the lever, spaced by the tooth counts: simple set "
         "S-C : C-R = Nr : Ns, double-pinion set S-R : R-C = (Nr - Ns) : Ns, stepped pinions: each gear X "
         "at C-X proportional to Np/N_X of the pinion step it meshes (suns below C, rings above).")


def _legend_rows(width: float, shown) -> tuple[list[list[tuple[str, float]]], list[str]]:
    """The legend's entries ``(text, x)`` in rows that fit ``width``, and the note's lines."""
    rows: list[list[tuple[str, float]]] = [[]]
    x = MARGIN + 0.3
    for text in (t for t in _LEGEND if t in shown):
        step = 0.28 + text_size(text, SMALL_FONT * 1.1)[0] + 0.45
        if rows[-1] and x + step > width - MARGIN:
            rows.append([])
            x = MARGIN + 0.3
        rows[-1].append((text, x))
        x += step
    lines, current = [], ""
    for word in _NOTE.split(" "):
        trial = (current + " " + word).strip()
        if current and text_size(trial, SMALL_FONT)[0] > 0.92 * (width - 2 * MARGIN - 0.2):
            lines.append(current)
            trial = word
        current = trial
    lines.append(current)
    return rows, lines


def _ground(ax, x: float, y: float, color: str, z: float = 3) -> None:
    """A ground symbol: a short wall at ``x`` hatched on its left (inches)."""
    from matplotlib.lines import Line2D

    h = 0.09
    ax.add_line(Line2D([x, x], [y - h, y + h], color=color, linewidth=1.6, zorder=z, solid_capstyle="butt"))
    for t in (-1.0, -0.33, 0.33, 1.0):
        ax.add_line(Line2D([x, x - 0.06], [y + t * h * 0.85, y + t * h * 0.85 - 0.06], color=color, linewidth=0.9,
                           zorder=z))


def _plates(ax, x: float, y: float, vertical: bool, color: str) -> None:
    """The clutch symbol at ``(x, y)``: two plates across a join (horizontal plates on a vertical one)."""
    from matplotlib.lines import Line2D

    for s in (-0.035, 0.035):
        xs, ys = ([x - 0.08, x + 0.08], [y + s] * 2) if vertical else ([x + s] * 2, [y - 0.08, y + 0.08])
        ax.add_line(Line2D(xs, ys, color=color, linewidth=2.2, zorder=4))


def _dog(ax, x: float, y: float, vertical: bool, color: str) -> None:
    """The dog-clutch symbol at ``(x, y)``: two toothed halves whose teeth interleave across a join
    (drawn for a horizontal join; ``vertical`` turns it a quarter)."""
    from matplotlib.lines import Line2D

    def seg(a, b):  # (along the join, across it) -> inches
        (u1, v1), (u2, v2) = a, b
        if vertical:
            return [x + v1, x + v2], [y + u1, y + u2]
        return [x + u1, x + u2], [y + v1, y + v2]

    for side, teeth in ((-1, (-0.065, 0.015)), (1, (-0.015, 0.065))):
        xs, ys = seg((0.055 * side, -0.09), (0.055 * side, 0.09))
        ax.add_line(Line2D(xs, ys, color=color, linewidth=2.0, zorder=4, solid_capstyle="butt"))
        for v in teeth:
            xs, ys = seg((0.055 * side, v), (-0.02 * side, v))
            ax.add_line(Line2D(xs, ys, color=color, linewidth=2.0, zorder=4, solid_capstyle="butt"))


def _dog_teeth(ax, x: float, y: float, color: str) -> None:
    """The teeth of a dog brake on its ground wall at ``x`` (pointing at the node, to the right)."""
    from matplotlib.lines import Line2D

    for v in (-0.075, 0.075):  # clear of the node's circle (radius 0.055) at the wall
        ax.add_line(Line2D([x, x + 0.05], [y + v, y + v], color=color, linewidth=2.2, zorder=4,
                           solid_capstyle="butt"))


def _legend(ax, fs, rows, note, top, Line2D):
    """The key to the symbols under the panels."""
    def line(xs, ys, **kw):
        ax.add_line(Line2D(xs, ys, **kw))

    def clutch(x, y):
        line([x - 0.2, x + 0.2], [y, y], color=LOCK_COLOR, linewidth=2.0)
        _plates(ax, x, y, False, LOCK_COLOR)

    def dog_clutch(x, y):
        line([x - 0.2, x + 0.2], [y, y], color=LOCK_COLOR, linewidth=2.0)
        _dog(ax, x, y, False, LOCK_COLOR)

    def dog_brake(x, y):
        _ground(ax, x, y, _BRAKE_COLOR)
        _dog_teeth(ax, x, y, _BRAKE_COLOR)

    symbols = {
        "dog clutch engaged": dog_clutch,
        "dog brake engaged": dog_brake,
        "lever": lambda x, y: line([x - 0.15, x + 0.15], [y - 0.06, y + 0.06], color=_LEVER_COLOR, linewidth=3.2),
        "brake engaged (ground)": lambda x, y: _ground(ax, x, y, _BRAKE_COLOR),
        "housing (gear axes)": lambda x, y: _ground(ax, x, y, "#222222"),
        "clutch engaged": clutch,
        "open element": lambda x, y: line([x - 0.2, x + 0.2], [y, y], color=_OPEN_COLOR, linewidth=1.2,
                                          linestyle=(0, (3, 2))),
        "same link on two levers": lambda x, y: line([x - 0.2, x + 0.2], [y, y], color=_JOIN_COLOR, linewidth=1.0),
        "input": lambda x, y: ax.plot([x], [y], marker="o", markersize=7, color=_IN_COLOR, markeredgecolor="#222222"),
        "output": lambda x, y: ax.plot([x], [y], marker="o", markersize=7, color=_OUT_COLOR, markeredgecolor="#222222"),
    }
    y = top - 0.2
    for row in rows:
        for text, x in row:
            symbols[text](x, y)
            ax.text(x + 0.28, y, text, ha="left", va="center", fontsize=SMALL_FONT * fs * 1.1, parse_math=False,
                    gid=f"legend:{text}")
        y -= 0.3
    ax.text(MARGIN + 0.1, y + 0.08, "\n".join(note), ha="left", va="top", fontsize=SMALL_FONT * fs, color="#333333",
            parse_math=False, gid="note", linespacing=1.3)


def draw_speed_chart(mech: Mechanism, gears=None, ax=None):
    """Every link's speed per unit input speed in every gear, one line per link.

    Parameters
    ----------
    mech : transgen.model.Mechanism
    gears : sequence of str, optional
        Declared gears, in this order on the x axis (default: every declared gear, no neutrals).
    ax : matplotlib.axes.Axes, optional

    Returns
    -------
    matplotlib.figure.Figure
        Each link's line has the gid ``"speed:<link>"``; a link a gear leaves free has a gap.
    """
    import math

    names = drawn_gears(mech, gears)
    if not names:
        raise ValueError(f"{mech.name} declares no gear to draw")
    speeds = {g: lever_speeds(mech, g) for g in names}
    links = [link.name for link in mech.links]
    if ax is None:
        from matplotlib.figure import Figure

        fig = Figure(figsize=(max(6.0, 1.0 + 0.75 * len(names)) + 1.8, 5.0), layout="constrained")
        ax = fig.add_subplot()
    else:
        try:
            fig = ax.get_figure(root=True)
        except TypeError:  # matplotlib < 3.10
            fig = ax.figure
    forward = [g for g in names if (speeds[g].get(mech.output) or 0.0) >= 0.0]
    backward = [g for g in names if g not in forward]
    xs = {g: float(i) for i, g in enumerate(forward)}
    xs.update({g: len(forward) + 0.5 + i for i, g in enumerate(backward)})
    markers = "osD^v<>pPhX*"
    for i, link in enumerate(links):
        role = " (input)" if link == mech.input else " (output)" if link == mech.output else ""
        bold = link in (mech.input, mech.output)
        line = None
        for group in (forward, backward):  # reverse gears apart: no line joins them to the forward ones
            ys = [speeds[g][link] if speeds[g][link] is not None else math.nan for g in group]
            if not group:
                continue
            kw = {"color": line.get_color()} if line is not None else {"label": link + role}
            (line,) = ax.plot([xs[g] for g in group], ys, "-", marker=markers[i % len(markers)],
                              linewidth=2.4 if bold else 1.4, markersize=5, gid=f"speed:{link}",
                              zorder=3 if bold else 2, **kw)
    ax.axhline(0.0, color="#555555", linewidth=0.8, zorder=1)
    ax.set_xticks([xs[g] for g in names], [f"{g}\n{_ratio_text(speeds[g], mech)}" for g in names])
    ax.set_xlabel("gear (ratio input/output)")
    ax.set_ylabel("link speed / input speed")
    ax.set_title(f"{mech.name}: speed chart", fontweight="bold")
    ax.grid(True, color="#e4e4e4", linewidth=0.6)
    ax.legend(loc="center left", bbox_to_anchor=(1.01, 0.5), frameon=False, fontsize=8)
    return fig


def _ratio_text(speeds, mech) -> str:
    w = speeds.get(mech.output)
    return f"{1 / w:.3f}" if w else "-"
