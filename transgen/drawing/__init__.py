"""Pictures and graph-file exports of the mechanism graph and the state-transition diagram."""
from .layout import (
    FIGURE_FORMATS,
    draw_graph,
    draw_std,
    graph_to_dot,
    graph_to_graphml,
    save_figure,
    std_to_dot,
)

__all__ = ["draw_graph", "draw_std", "graph_to_dot", "std_to_dot", "graph_to_graphml", "save_figure", "FIGURE_FORMATS"]
