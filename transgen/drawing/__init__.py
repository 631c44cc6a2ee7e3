"""Pictures and graph-file exports of the mechanism graph and the state-transition diagram.

* :func:`draw_graph` draws the bond-graph-like mechanism graph of :mod:`transgen.graph` in the
  style of thesis Figs. 3.9 and 3.13: links as ``1`` junctions (with their inertia ``J``),
  planetaries as ``MTF`` and gear pairs as ``TF`` nodes, shift elements as boxes, the housing
  as ``Sf=0`` and the external torques as ``Se`` sources; bonds are half-arrows in their
  direction of positive power, transformer ports are named on their bonds.
* :func:`draw_std` draws the state-transition diagram of :mod:`transgen.std` (thesis Figs. 3.8
  and 3.12): modes as bubbles, transitions as curved arrows labelled ``lock X`` / ``unlock X``
  (the conditions themselves belong in the JSON of :meth:`StateTransitionDiagram.to_dict`).
* :func:`draw_levers` draws the lever diagrams of the lever analogy (Benford and Leising, 1981),
  one panel per gear with the nodes at their speeds, and :func:`draw_speed_chart` every link's
  speed per gear; :func:`lever_layout` gives the levers' geometry from the tooth counts.
* :func:`graph_to_dot`, :func:`std_to_dot` and :func:`graph_to_graphml` write the same
  diagrams as Graphviz DOT and GraphML text; :func:`save_figure` writes a figure atomically.

Layouts are computed by hand, deterministically (no random spring layout, no Graphviz needed);
see :mod:`transgen.drawing.layout`. Drawings are made in inch units: the figure is sized from
the layout, so every text has its measured room. Drawing into a given ``ax`` of another size
scales the fonts to fit. Matplotlib is imported only inside the functions, and only its object
API is used (no ``pyplot``), so drawing is safe in any thread and with any backend.

The package's modules, one job each:

* :mod:`~transgen.drawing.common`: node kinds, colours and the texts of nodes and modes, shared
  by the pictures and the DOT text;
* :mod:`~transgen.drawing.figure`: text measurement, inch geometry, label placement, figure
  set-up and :func:`save_figure`;
* :mod:`~transgen.drawing.layout`: the hand-made layouts of the graph and the STD;
* :mod:`~transgen.drawing.graph_figure`: :func:`draw_graph`;
* :mod:`~transgen.drawing.std_figure`: :func:`draw_std`;
* :mod:`~transgen.drawing.lever`: the levers' geometry (:func:`lever_layout`) and node speeds;
* :mod:`~transgen.drawing.lever_figure`: :func:`draw_levers`, :func:`draw_speed_chart`;
* :mod:`~transgen.drawing.dot_graphml`: :func:`graph_to_dot`, :func:`std_to_dot`,
  :func:`graph_to_graphml`.

The names listed in ``__all__`` here are the public API; the modules' own names may change.
"""
from __future__ import annotations

from ..lazy import lazy_module_attributes

_WHERE = {"graph_to_dot": "dot_graphml", "graph_to_graphml": "dot_graphml", "std_to_dot": "dot_graphml",
          "FIGURE_FORMATS": "figure", "save_figure": "figure", "draw_graph": "graph_figure", "Lever": "lever",
          "LeverNode": "lever", "lever_layout": "lever", "lever_speeds": "lever", "draw_levers": "lever_figure",
          "draw_speed_chart": "lever_figure", "draw_std": "std_figure"}
# each name loaded from its module on first use: checking a plot format (the simulator's command
# line) needs FIGURE_FORMATS, not networkx, which the graph exports import (0.1-0.3 s)
__getattr__, __dir__ = lazy_module_attributes(__name__, _WHERE)

__all__ = [
    "draw_graph",
    "draw_std",
    "graph_to_dot",
    "std_to_dot",
    "graph_to_graphml",
    "save_figure",
    "FIGURE_FORMATS",
    "draw_levers",
    "draw_speed_chart",
    "lever_layout",
    "lever_speeds",
    "Lever",
    "LeverNode",
]
