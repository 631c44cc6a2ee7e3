"""What the pictures and the DOT text share: node kinds, colours, the texts of graph nodes and
STD modes, and accepting a mechanism where a graph or a diagram is expected.

Colours are hex strings; a mode's colour comes from the first word of its label (``gear``,
``speed``, ``neutral``, ``reverse``).
"""
from __future__ import annotations

import math
import textwrap

import networkx as nx

ELEMENT_KINDS = ("clutch", "brake", "oneway", "dog")
TRANSFORMER_KINDS = ("planetary", "gearpair", "stepped")

_MODE_COLORS = {"gear": "#dbe9f6", "speed": "#fdf1cf", "neutral": "#e4e4e4", "reverse": "#f7dede"}
LOCK_COLOR = "#1f4e9c"  # arrows and labels of transitions that lock an element
UNLOCK_COLOR = "#a02525"  # ... and of those that unlock one


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


def node_text(name: str, data: dict) -> str:
    """The label drawn in the box of graph node ``name``."""
    kind = data.get("kind", "")
    if kind == "link":
        return f"1: {name}\nJ={_fmt(data.get('J', '?'))}"
    if kind == "housing":
        return f"Sf=0\n{name}"
    if kind == "planetary":
        head = f"MTF: {name}" + (" (double pinion)" if data.get("pinions") == 2 else "")
        return f"{head}\n{_param_text(name, data.get('params', {}))}"
    if kind == "stepped":
        return f"MTF: {name} (stepped pinion)\n{_param_text(name.split('/')[0], data.get('params', {}))}"
    if kind == "gearpair":
        mesh = data.get("mesh")
        head = f"TF: {name}" + (f" ({mesh})" if mesh else "")
        return f"{head}\n{_param_text(name, data.get('params', {}))}"
    if kind in ELEMENT_KINDS:
        text = f"{kind}\n{name}"
        if kind == "oneway" and data.get("free"):
            text += f"\nfree {data['free']}"
        return text
    if kind == "source":
        return f"Se: {name}"
    label = str(data.get("label", ""))
    return label if name in label else name


def mode_text(mode) -> str:
    """The text drawn in the bubble of an STD mode: name, locked elements, label (wrapped)."""
    locked = " ".join(mode.locked) if mode.locked else "(none locked)"
    lines = [mode.name, locked]
    for part in (mode.label or "").split("; "):
        if part:
            lines.extend(textwrap.wrap(part, width=18, break_on_hyphens=False))
    return "\n".join(lines)


def mode_color(label: str) -> str:
    """The fill colour of a mode with ``label``, by the label's first word."""
    first = (label or "").split(" ", 1)[0]
    return _MODE_COLORS.get(first, "#ffffff")


def as_graph(g) -> nx.Graph:
    """``g`` itself if it is a graph, else the mechanism graph of :func:`transgen.graph.build_graph`."""
    if isinstance(g, nx.Graph):
        return g
    from ..graph import build_graph

    return build_graph(g)


def as_std(std):
    """``std`` itself if it is a state-transition diagram, else the diagram of
    :func:`transgen.std.state_transition_diagram` with the mechanism's default modes."""
    if hasattr(std, "transitions"):
        return std
    from ..std import state_transition_diagram

    return state_transition_diagram(std)
