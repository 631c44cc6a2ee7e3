"""The mechanism graph and the state-transition diagram as Graphviz DOT and GraphML text.

Nodes carry the same texts and colours as in the pictures; the texts are returned, and the
caller writes them (the CLI with :func:`transgen.export.write_text`).
"""
from __future__ import annotations

import networkx as nx

from .common import (ELEMENT_KINDS, LOCK_COLOR, TRANSFORMER_KINDS, UNLOCK_COLOR, as_graph, as_std, mode_color,
                     mode_text, node_text)


def _q(text) -> str:
    """A Graphviz double-quoted string (backslashes, quotes and newlines escaped)."""
    s = str(text).replace("\\", "\\\\").replace('"', '\\"').replace("\r", "").replace("\n", "\\n")
    return f'"{s}"'


_DOT_NODE = {
    "link": 'shape=box, style="rounded,filled", fillcolor="#dbe9f6"',
    "planetary": 'shape=box, style=filled, fillcolor="#fdf1cf"',
    "gearpair": 'shape=box, style=filled, fillcolor="#fdf1cf"',
    "stepped": 'shape=box, style=filled, fillcolor="#fdf1cf"',
    "clutch": 'shape=box, style=filled, fillcolor="#f7dede"',
    "brake": 'shape=box, style=filled, fillcolor="#f7dede"',
    "oneway": 'shape=box, style=filled, fillcolor="#efe0f5"',
    "dog": 'shape=box, style=filled, fillcolor="#e0f0e0"',
    "housing": 'shape=box, style="rounded,filled", fillcolor="#e4e4e4"',
    "source": 'shape=box, style="rounded,dashed"',
}


def graph_to_dot(g) -> str:
    """Graphviz DOT text of the mechanism graph.

    Parameters
    ----------
    g : networkx.DiGraph or transgen.model.Mechanism
        The graph of :func:`transgen.graph.build_graph`, or a mechanism to build it from.

    Returns
    -------
    str
        A ``digraph`` with one node per graph node (labelled as in :func:`draw_graph`), one
        edge per bond (half-arrow heads, transformer ports as edge labels) and ``rank=same``
        groups for the transformer, link, shift-element and housing rows.
    """
    g = as_graph(g)
    lines = [f"digraph {_q(g.graph.get('name', 'mechanism'))} {{",
             "  rankdir=TB;",
             '  node [fontname="Helvetica", fontsize=10];',
             '  edge [arrowhead=lvee, fontname="Helvetica", fontsize=8];']
    for n, d in g.nodes(data=True):
        attrs = _DOT_NODE.get(d.get("kind", ""), "shape=box")
        lines.append(f"  {_q(n)} [label={_q(node_text(n, d))}, {attrs}];")
    for u, v, d in g.edges(data=True):
        extra = f" [label={_q(d['port'])}]" if d.get("port") is not None else ""
        lines.append(f"  {_q(u)} -> {_q(v)}{extra};")
    kinds = {n: d.get("kind", "") for n, d in g.nodes(data=True)}
    for group in (TRANSFORMER_KINDS, ("link",), ELEMENT_KINDS, ("housing",)):
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
    std = as_std(std)
    lines = [f"digraph {_q('STD ' + str(std.mechanism))} {{",
             "  rankdir=TB;",
             '  node [shape=ellipse, style=filled, fontname="Helvetica", fontsize=10];',
             '  edge [fontname="Helvetica", fontsize=8];']
    for m in std.modes:
        lines.append(f"  {_q(m.name)} [label={_q(mode_text(m))}, fillcolor={_q(mode_color(m.label))}];")
    for t in std.internal:
        color = LOCK_COLOR if t.adds else UNLOCK_COLOR
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
        The graph of :func:`transgen.graph.build_graph` (a mechanism is converted with it, as in
        :func:`draw_graph`).

    Returns
    -------
    str
        The GraphML document (``networkx.generate_graphml``).
    """
    g = as_graph(g)
    h = nx.DiGraph() if g.is_directed() else nx.Graph()
    h.graph.update(_graphml_attrs([dict(g.graph)])[0])
    nodes = list(g.nodes(data=True))
    for (n, _), attrs in zip(nodes, _graphml_attrs([dict(d) for _, d in nodes])):
        h.add_node(n, **attrs)
    edges = list(g.edges(data=True))
    for (u, v, _), attrs in zip(edges, _graphml_attrs([dict(d) for _, _, d in edges])):
        h.add_edge(u, v, **attrs)
    return "\n".join(nx.generate_graphml(h)) + "\n"
