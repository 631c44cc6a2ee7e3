"""Figure helpers shared by the pictures, and the figure writer.

Everything is in inch units (fonts in points): text measurement, rectangles and ellipses with
overlap tests, placing a label where it meets no box and the fewest lines, sampling polylines,
making a figure sized from a layout (or scaling the fonts to a caller's axes), and
:func:`save_figure`, which writes a figure atomically through :func:`transgen.export.atomic_path`.
Matplotlib is imported only inside the functions, and only its object API is used (no ``pyplot``).
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

from ..export import atomic_path

# Sizes in points (fonts) and inches (layout).
NODE_FONT = 9.0
SMALL_FONT = 7.0
TITLE_FONT = 11.0
MARGIN = 0.35


FIGURE_FORMATS = {".png": "png", ".svg": "svg", ".pdf": "pdf"}
"""File suffix -> matplotlib format understood by :func:`save_figure`."""


def text_size(text: str, size: float, weight: str = "normal") -> tuple[float, float]:
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
class Rect:
    """An axis-aligned rectangle by its centre and size (inches)."""

    x: float
    y: float
    w: float
    h: float

    def overlaps(self, other: Rect, pad: float = 0.0) -> bool:
        return (abs(self.x - other.x) * 2 < self.w + other.w + 2 * pad
                and abs(self.y - other.y) * 2 < self.h + other.h + 2 * pad)

    def overlap_area(self, other: Rect) -> float:
        dx = (self.w + other.w) / 2 - abs(self.x - other.x)
        dy = (self.h + other.h) / 2 - abs(self.y - other.y)
        return max(dx, 0.0) * max(dy, 0.0)


@dataclass
class Oval:
    """An axis-aligned ellipse by its centre and semi-axes ``a`` (along x), ``b`` (inches)."""

    x: float
    y: float
    a: float
    b: float

    def overlaps(self, r: Rect, pad: float = 0.0) -> bool:
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

    def overlap_area(self, r: Rect) -> float:
        return r.overlap_area(Rect(self.x, self.y, 2 * self.a * 0.8, 2 * self.b * 0.8))


def place_label(candidates, w: float, h: float, obstacles: list, placed: list[Rect],
                 lines=None, own: int | None = None) -> Rect:
    """Choose a ``w`` x ``h`` label box among the ``candidates`` (centres, best first).

    A box that meets no obstacle (node box or bubble) and no label in ``placed`` is preferred;
    among those, the one that covers the fewest sample points of other lines (``lines`` is an
    ``(n, 3)`` array of ``x, y, line id`` and the label's own line is ``own``), then the
    earliest. The chosen box is appended to ``placed``.
    """
    best, best_key = None, None
    for k, (x, y) in enumerate(candidates):
        r = Rect(x, y, w, h)
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


def line_samples(points, line_id: int, step: float = 0.04):
    """``(n, 3)`` samples ``x, y, line_id`` along a polyline, about ``step`` inches apart."""
    import numpy as np

    out = []
    for (x0, y0), (x1, y1) in zip(points, points[1:]):
        n = max(1, int(math.hypot(x1 - x0, y1 - y0) / step))
        t = np.linspace(0.0, 1.0, n, endpoint=False)
        out.append(np.column_stack([x0 + (x1 - x0) * t, y0 + (y1 - y0) * t, np.full(n, line_id)]))
    return np.vstack(out) if out else np.zeros((0, 3))


def figure_and_axes(ax, width: float, height: float):
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


def set_limits(ax, xmin, xmax, ymin, ymax):
    ax.set_xlim(xmin, xmax)
    ax.set_ylim(ymin, ymax)


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
