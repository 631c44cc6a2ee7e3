"""The hand-made, deterministic layouts of the pictures (no random spring layout, no Graphviz).

* graph: links on a middle row (declaration order, the input link first and the output link
  last), transformers on the row above and shift elements on the row below, each placed over
  the mean position of the links it connects and pushed apart where they would overlap; the
  housing at the bottom; ``T_in`` left of the input link and ``T_out`` right of the output link
  (other torques on the shift-element row). A transformer that has the housing as a member gets
  its own copy of the housing above it, so that its bond does not cross the picture.
* STD: one row per number of locked elements, most locked on top. Every transition locks or
  unlocks one element, so every arrow joins two neighbouring rows. The order within the rows is
  the declaration order improved by barycentre sweeps that reduce crossings.

Positions and sizes are in inches, measured from the texts at the node font, so every text has
its room. For large transmissions this draws better than Graphviz's general-purpose layouts.
"""
from __future__ import annotations

from dataclasses import dataclass

import networkx as nx

from .common import ELEMENT_KINDS, TRANSFORMER_KINDS, mode_text, node_text
from .figure import NODE_FONT, Oval, Rect, text_size


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


@dataclass
class GraphLayout:
    """Boxes keyed by node name, plus copies of the housing (key ``"<housing>@<transformer>"``,
    ``owner`` gives the node) above a transformer that has the housing as a member, so that
    its bond does not cross the picture; ``bonds`` are ``(tail box, head box, u, v)``."""

    boxes: dict[str, Rect]
    texts: dict[str, str]
    rows: dict[str, int]  # +2 housing copies, +1 transformers, 0 links, -1 elements, -2 housing
    owner: dict[str, str]
    bonds: list[tuple[str, str, str, str]]


def graph_layout(g: nx.DiGraph, font: float = NODE_FONT) -> GraphLayout:
    """Boxes (inches) of every node of ``g`` in the layered layout described in the module."""
    texts = {n: node_text(n, d) for n, d in g.nodes(data=True)}
    sizes = {}
    kind = {n: d.get("kind", "") for n, d in g.nodes(data=True)}
    for n, t in texts.items():
        w, h = text_size(t, font)
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
    boxes: dict[str, Rect] = {}
    rows: dict[str, int] = {}
    x = 0.0
    for i, n in enumerate(links):
        w, h = sizes[n]
        if i:
            x += (sizes[links[i - 1]][0] + w) / 2 + gap
        boxes[n], rows[n] = Rect(x, 0.0, w, h), 0
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
        boxes[n] = Rect(ref.x + side * (ref.w / 2 + gap + 0.25 + w / 2), 0.0, w, h)
        rows[n] = 0

    index = {n: i for i, n in enumerate(g)}
    row_heights = {0: max((b.h for b in boxes.values()), default=0.5)}
    for row, members in ((1, [n for n in g if kind[n] in TRANSFORMER_KINDS]),
                         (-1, [n for n in g if kind[n] in ELEMENT_KINDS or (kind[n] == "source" and n not in side_sources)]),
                         (-2, [n for n in g if kind[n] == "housing"]),
                         (-3, [n for n in g if n not in boxes and kind[n] not in TRANSFORMER_KINDS + ELEMENT_KINDS
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
            boxes[n], rows[n] = Rect(xn, 0.0, *sizes[n]), row
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
        w, h = text_size(texts[next(iter(copies.values()))[0]], font)
        w, h = w + 0.22, h + 0.14
        ys[2] = ys[1] + (row_heights[1] + h) / 2 + 0.7
        members = [key for t in sorted(copies, key=lambda t: boxes[t].x) for key in copies[t]]
        xs = _spread([boxes[owner_t].x for owner_t in (k.split("@", 1)[1] for k in members)], [w] * len(members), gap)
        for key, xn in zip(members, xs):
            boxes[key], rows[key] = Rect(xn, 0.0, w, h), 2
    for n, b in boxes.items():
        b.y = ys[rows[n]]
    return GraphLayout(boxes, texts, rows, owner, bonds)


def attachments(lay: GraphLayout) -> dict[tuple[str, str, str], tuple[float, float]]:
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
class StdLayout:
    """Bubbles (inches) and their texts keyed by mode name; ``rows`` are the mode names by row,
    most locked elements first."""

    bubbles: dict[str, Oval]
    texts: dict[str, str]
    rows: list[list[str]]


def std_layout(std, font: float = NODE_FONT, gap: float = 0.9) -> StdLayout:
    """Bubbles (inches) of every mode of ``std`` in the rows described in the module, at least
    ``gap`` inches apart within a row."""
    texts = {m.name: mode_text(m) for m in std.modes}
    radii = {}
    for n, t in texts.items():
        w, h = text_size(t, font)
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
    bubbles: dict[str, Oval] = {}
    y = 0.0
    for i, row in enumerate(rows):
        half = max(radii[n][1] for n in row)
        if i:
            prev_half = max(radii[n][1] for n in rows[i - 1])
            between = sum(1 for a in rows[i - 1] for b in adj[a] if b in set(row))
            y -= prev_half + half + min(4.0, 1.9 + 0.1 * between)
        for n in row:
            bubbles[n] = Oval(xs[n], y, *radii[n])
    return StdLayout(bubbles, texts, rows)
