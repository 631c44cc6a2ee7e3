"""Kinematic analysis: constraints, degrees of freedom, speed ratios, the gear table.

The speeds ``w`` of the links obey linear constraints ``A w = 0``: one row per transformer
(planetary or gear pair, always present) and one per engaged shift element (``w1 - w2 = 0``, or
``w1 = 0`` for a brake). The degrees of freedom of a combination are ``n_links - rank(A)``; the
link speeds are ``w = N q`` with ``N`` an orthonormal basis of the null space of ``A`` (SVD).
The speed ratio input/output is determined when the input and output rows of ``N`` are
proportional (rank one) and the output row is not zero.

Classification of a combination of engaged elements:

``gear``      the input/output ratio is determined (other members may still float: ``floating``)
``neutral``   input and output can turn independently (the input is free)
``tie-up``    no degree of freedom is left: the mechanism locks (bindup)
``other``     one or more degrees of freedom but the input or the output is held
"""
from __future__ import annotations

import dataclasses
import itertools
import math
import warnings
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from .errors import CombinationLimitWarning, Diagnostic
from .graph import TRANSFORMER_KINDS, bond_graph, coefficient, element_nodes, link_nodes, transformer_ports
from .model import HOUSING, Mechanism

if TYPE_CHECKING:
    from .graph import Graph

__all__ = [
    "Constraint",
    "constraints",
    "constraint_matrix",
    "numeric_rank",
    "null_space",
    "Combination",
    "analyze",
    "combinations",
    "engaged_combinations",
    "MAX_COMBINATIONS",
    "gear_ratios",
    "GearRow",
    "GearTable",
    "gear_table",
    "check_gears",
    "link_speeds",
    "floating_links",
    "published_findings",
]

RANK_RTOL = 1e-9
"""Relative tolerance (to the largest singular value) for numerical rank decisions."""


@dataclass(frozen=True)
class Constraint:
    """One kinematic constraint ``sum(coeffs[link] * w_link) = 0`` (housing terms dropped)."""

    name: str
    kind: str  # "transformer" or "element"
    coeffs: dict = field(compare=False)


def _values(g: Graph) -> dict:
    values = {}
    for _, data in g.nodes(data=True):
        values.update(data.get("params", {}))
    return values


def constraints(g: Graph, locked=(), values: dict | None = None) -> list[Constraint]:
    """Kinematic constraints of the graph with the shift elements ``locked`` engaged.

    ``values`` maps the transformer parameters (``Ns_P1``, ``N1_G``, ...) to numbers (default:
    the mechanism's own) or to sympy symbols for the symbolic back-end.
    """
    values = _values(g) if values is None else values
    rows = []
    for node, data in g.nodes(data=True):
        if data["kind"] in TRANSFORMER_KINDS:
            coeffs = {link: coefficient(terms, values) for link, _, terms in transformer_ports(g, node) if link != HOUSING}
            rows.append(Constraint(node, "transformer", coeffs))
    for name in locked:
        data = g.nodes[name]
        coeffs = {data["link1"]: 1}
        if data["link2"] != HOUSING:
            coeffs[data["link2"]] = -1
        rows.append(Constraint(name, "element", coeffs))
    return rows


def constraint_matrix(g: Graph, locked=()) -> np.ndarray:
    """Numeric constraint matrix ``A`` (rows: transformers, then locked elements; columns: links)."""
    links = link_nodes(g)
    index = {name: i for i, name in enumerate(links)}
    rows = constraints(g, locked)
    a = np.zeros((len(rows), len(links)))
    for r, c in enumerate(rows):
        for link, value in c.coeffs.items():
            a[r, index[link]] = float(value)
    return a


def numeric_rank(a: np.ndarray, scale: float | None = None) -> int:
    """Rank by SVD: singular values above :data:`RANK_RTOL` times ``scale`` (default: the largest
    singular value; pass the matrix's natural size, e.g. the largest inertia, when the matrix
    may be all round-off)."""
    if a.size == 0:
        return 0
    s = np.linalg.svd(a, compute_uv=False)
    ref = s[0] if scale is None else scale
    return int(np.sum(s > RANK_RTOL * ref)) if s.size and ref > 0 else 0


def floating_links(a: np.ndarray, i_in: int, tol: float = 1e-9) -> tuple[int, ...]:
    """Indices of the links (columns of the constraint matrix ``a``) whose speed the input speed
    (column ``i_in``) does not fix: the links that still move with the input held. In a gear
    (ratio determined) these are its idle members (:mod:`transgen.idle`); the one kinematic rule
    that :func:`analyze`, :func:`link_speeds` and the tooth synthesis share."""
    n = a.shape[1]
    held = null_space(np.vstack([a, np.eye(n)[i_in]]), n)
    return tuple(k for k in range(n) if np.linalg.norm(held[k]) > tol)


def null_space(a: np.ndarray, n: int, scale: float | None = None) -> np.ndarray:
    """Orthonormal basis (columns) of the null space of ``a`` with ``n`` columns (``scale`` as in
    :func:`numeric_rank`)."""
    if a.shape[0] == 0:
        return np.eye(n)
    _, s, vt = np.linalg.svd(a)
    ref = s[0] if scale is None else scale
    rank = int(np.sum(s > RANK_RTOL * ref)) if s.size and ref > 0 else 0
    return vt[rank:].T.copy()


@dataclass(frozen=True)
class Combination:
    """Kinematic facts of one combination of engaged shift elements.

    ``ratio`` is input speed / output speed (negative: reverse) where determined, else ``None``.
    ``floating`` names links whose speed is not fixed by the input speed (in a gear): its idle
    members (:func:`floating_links`; :mod:`transgen.idle` decides whether such a gear can be used).
    ``detail`` explains ``other`` (e.g. "output held").
    """

    engaged: tuple[str, ...]
    dof: int
    ratio: float | None
    kind: str
    floating: tuple[str, ...] = ()
    detail: str = ""


def analyze(mech: Mechanism, engaged=(), graph: Graph | None = None) -> Combination:
    """Degrees of freedom, ratio and kind of ``mech`` with the elements ``engaged``."""
    g = bond_graph(mech) if graph is None else graph
    links = link_nodes(g)
    a = constraint_matrix(g, engaged)
    basis = null_space(a, len(links))
    dof = basis.shape[1]
    engaged = tuple(engaged)
    if dof == 0:
        return Combination(engaged, 0, None, "tie-up")
    i_in, i_out = links.index(mech.input), links.index(mech.output)
    v_in, v_out = basis[i_in], basis[i_out]
    tol = 1e-9
    in_moves, out_moves = np.linalg.norm(v_in) > tol, np.linalg.norm(v_out) > tol
    if in_moves and out_moves and numeric_rank(np.vstack([v_in, v_out])) == 1:
        ratio = float(np.dot(v_in, v_out) / np.dot(v_out, v_out))
        # links not fixed by the input speed (the idle members of :mod:`transgen.idle`)
        floating = tuple(links[k] for k in floating_links(a, i_in, tol))
        return Combination(engaged, dof, ratio, "gear", floating)
    if in_moves and out_moves:
        return Combination(engaged, dof, None, "neutral")
    detail = "input and output held" if not (in_moves or out_moves) else ("output held" if in_moves else "input held")
    return Combination(engaged, dof, None, "other", detail=detail)


MAX_COMBINATIONS = 1024
"""Most combinations of shift elements enumerated (all of them for up to 10 elements)."""


def engaged_combinations(names, limit: int = MAX_COMBINATIONS) -> list[tuple[str, ...]]:
    """Every combination of ``names`` (all 2^k, fewest engaged first).

    When 2^k exceeds ``limit`` (the work grows as 2^k: 14 elements give 16384 modes), only the
    combinations with at most ``r`` engaged elements, ``r`` the largest with at most ``limit`` of
    them, and a :class:`~transgen.errors.CombinationLimitWarning` says so. Real gears engage two
    or three elements, so these are the ones that matter.
    """
    names = list(names)
    top, count = len(names), 2 ** len(names)
    if count > limit:
        top, count = -1, 0
        while top < len(names) and count + math.comb(len(names), top + 1) <= limit:
            top += 1
            count += math.comb(len(names), top)
        warnings.warn(f"{len(names)} shift elements give {2 ** len(names)} combinations; only the {count} with at "
                      f"most {top} engaged are enumerated (limit {limit}): declare the gear table "
                      f"('gear NAME = ...') or the modes ('mode NAME = ...') to choose",
                      CombinationLimitWarning)  # one place: shown once per run
    return [c for r in range(top + 1) for c in itertools.combinations(names, r)]


def combinations(mech: Mechanism, max_engaged: int | None = None) -> list[Combination]:
    """Every combination of engaged shift elements (all 2^k, or up to ``max_engaged``; at most
    :data:`MAX_COMBINATIONS`, see :func:`engaged_combinations`)."""
    g = bond_graph(mech)
    names = element_nodes(g)
    if max_engaged is None:
        return [analyze(mech, combo, g) for combo in engaged_combinations(names)]
    top = min(max_engaged, len(names))
    return [analyze(mech, combo, g) for r in range(top + 1) for combo in itertools.combinations(names, r)]


def gear_ratios(mech: Mechanism) -> dict[str, float | None]:
    """Input/output speed ratio of every declared gear (``None`` where not determined)."""
    g = bond_graph(mech)
    return {gear.name: analyze(mech, gear.engaged, g).ratio for gear in mech.gears if gear.kind == "gear"}


@dataclass(frozen=True)
class GearRow:
    """A declared gear (or neutral) with its computed kinematics.

    ``step`` is this gear's ratio over the next forward gear's (``None`` for the last one and for
    reverse gears, alternative gears and neutrals); ``published`` is the ratio written in the file, compared with
    ``tolerance`` (``tol=``) or by ``rounding`` (see :class:`~transgen.model.Gear`).
    """

    name: str
    kind: str
    engaged: tuple[str, ...]
    combination: Combination
    step: float | None = None
    published: str | None = None
    tolerance: str | None = None
    rounding: str = "nearest"
    alternative: bool = False

    @property
    def dof(self) -> int:
        return self.combination.dof

    @property
    def ratio(self) -> float | None:
        return self.combination.ratio

    @property
    def published_range(self) -> tuple[float, float] | None:
        """The interval of computed ratios that agree with the published one: ``pub +- tol``;
        ``pub +- half a unit of its last printed digit`` (rounded); for a truncated one, from
        ``pub`` to one unit further from zero (cut toward zero after the printed digits)."""
        if self.published is None:
            return None
        pub = float(self.published)
        if self.tolerance is not None:
            tol = float(self.tolerance)
            return (pub - tol, pub + tol)
        half = _half_unit(self.published)
        if self.rounding == "truncated":
            return (pub, pub + 2 * half) if pub > 0 else (pub - 2 * half, pub)
        return (pub - half, pub + half)

    @property
    def matches_published(self) -> bool | None:
        """Whether the computed ratio agrees with the published one (:attr:`published_range`,
        widened by 1e-12 for round-off)."""
        if self.published is None or self.ratio is None:
            return None
        low, high = self.published_range
        return low - 1e-12 <= self.ratio <= high + 1e-12


def _half_unit(text: str) -> float:
    mantissa = text.lower().split("e")[0]
    decimals = len(mantissa.split(".")[1]) if "." in mantissa else 0
    exponent = int(text.lower().split("e")[1]) if "e" in text.lower() else 0
    return 0.5 * 10.0 ** (exponent - decimals)


@dataclass(frozen=True)
class GearTable:
    """The declared gears with ratios and steps, and every combination of engaged elements."""

    mechanism: Mechanism
    gears: tuple[GearRow, ...]
    combinations: tuple[Combination, ...]

    @property
    def spread(self) -> float | None:
        """Overall spread: lowest over highest forward ratio (alternative gears left out)."""
        forward = [r.ratio for r in self.gears if r.kind == "gear" and not r.alternative and r.ratio is not None
                   and r.ratio > 0]
        return max(forward) / min(forward) if len(forward) >= 2 else None

    UNITS = {"ratio": "1", "step": "1", "spread": "1", "dof": "1", "published": "1", "published_range": "1"}
    """Units of the numeric fields of :meth:`to_dict` (ratios: input speed / output speed)."""

    def to_dict(self) -> dict:
        """The JSON form of ``transgen ratios --json``."""
        m = self.mechanism
        return {
            "mechanism": m.name,
            "input": m.input,
            "output": m.output,
            "gears": [
                {"name": r.name, "kind": r.kind, "engaged": list(r.engaged), "dof": r.dof, "ratio": r.ratio,
                 "step": r.step, "published": r.published, "floating": list(r.combination.floating),
                 "alternative": r.alternative, "matches_published": r.matches_published, "published_range": list(r.published_range or []) or None}
                for r in self.gears
            ],
            "spread": self.spread,
            "combinations": [
                {"engaged": list(c.engaged), "dof": c.dof, "ratio": c.ratio, "kind": c.kind,
                 "floating": list(c.floating), "detail": c.detail}
                for c in self.combinations
            ],
        }


def gear_table(mech: Mechanism, all_combinations: bool = True) -> GearTable:
    """Analyse the declared gears and (optionally) every combination of engaged elements."""
    g = bond_graph(mech)
    rows = [GearRow(gear.name, gear.kind, gear.engaged, analyze(mech, gear.engaged, g), None, gear.ratio,
                    gear.tolerance, gear.rounding, gear.alternative)
            for gear in mech.gears]
    forward = [i for i, (r, gear) in enumerate(zip(rows, mech.gears))
               if r.kind == "gear" and not gear.alternative and r.ratio is not None and r.ratio > 0]
    for i, j in zip(forward, forward[1:]):
        rows[i] = dataclasses.replace(rows[i], step=rows[i].ratio / rows[j].ratio)
    combos = tuple(combinations(mech)) if all_combinations else ()
    return GearTable(mech, tuple(rows), combos)


def _mismatch_message(row: GearRow) -> str:
    low, high = row.published_range
    how = (f"tol={row.tolerance}" if row.tolerance is not None else
           "truncated" if row.rounding == "truncated" else "rounded")
    return (f"gear {row.name}: computed ratio {row.ratio:.6g} does not match the declared ratio={row.published} "
            f"({how}: {low:.10g} to {high:.10g})")


def published_findings(mech: Mechanism, table: GearTable) -> list[Diagnostic]:
    """The declared gears whose computed ratio misses the published one, each located at the
    gear's name (``transgen ratios`` reports them beside the table; ``check`` as errors)."""
    out = []
    for row in table.gears:
        if row.kind == "gear" and row.matches_published is False:
            gear = mech.gear(row.name)
            out.append(Diagnostic(mech.source, gear.span.line, gear.span.column, _mismatch_message(row),
                                  mech.source_line(gear.span.line)))
    return out


def check_gears(mech: Mechanism, published: bool = True) -> list[Diagnostic]:
    """Errors for declared gears that tie up, have no determined ratio, or (with ``published``)
    miss their published ratio, and for neutrals that are not neutral; each located at the
    gear's name."""
    problems = []
    for row in gear_table(mech, all_combinations=False).gears:
        gear = mech.gear(row.name)
        c = row.combination
        message = None
        if row.kind == "gear":
            if c.kind == "tie-up":
                message = f"gear {row.name} ({' '.join(row.engaged)}) ties up the mechanism: no degree of freedom is left"
            elif c.ratio is None:
                message = (f"gear {row.name} ({' '.join(row.engaged)}) does not determine the input/output ratio "
                           f"({c.dof} degrees of freedom, {c.kind}{': ' + c.detail if c.detail else ''})")
            elif published and row.matches_published is False:
                message = _mismatch_message(row)
        elif c.kind != "neutral":
            message = f"neutral {row.name} ({' '.join(row.engaged)}) is not a neutral: it is {c.kind}" + (
                f" with ratio {c.ratio:.6g}" if c.ratio is not None else "")
        if message:
            line = gear.span.line
            problems.append(Diagnostic(mech.source, line, gear.span.column, message, mech.source_line(line)))
    return problems


def link_speeds(mech: Mechanism, engaged=(), graph: Graph | None = None) -> dict[str, float | None]:
    """Speed of every link per unit input speed with the elements ``engaged`` (``w_link / w_in``).

    Links whose speed the input speed does not fix (floating members, or every link but the
    input in a neutral) get ``None``; the input link gets 1. Raises ``ValueError`` when the
    combination holds the input (a tie-up, or the input braked).
    """
    g = bond_graph(mech) if graph is None else graph
    links = link_nodes(g)
    a = constraint_matrix(g, engaged)
    basis = null_space(a, len(links))
    i_in = links.index(mech.input)
    v_in = basis[i_in] if basis.shape[1] else np.zeros(0)
    tol = 1e-9
    if np.linalg.norm(v_in) <= tol:
        raise ValueError(f"{' '.join(engaged) or 'no element'} engaged: the input {mech.input} is held, "
                         f"the link speeds are not proportional to the input speed")
    # the least-norm motion with unit input speed: A w = 0, w_in = 1 by least squares with one step
    # of iterative refinement (to about a unit in the last place; basis @ v_in alone is off by
    # some 1e-14, which shows e.g. as a direct drive's efficiency 1 - 3e-15)
    m = np.vstack([a, np.eye(len(links))[i_in]])
    rhs = np.zeros(m.shape[0])
    rhs[-1] = 1.0
    w = np.linalg.lstsq(m, rhs, rcond=None)[0]
    w += np.linalg.lstsq(m, rhs - m @ w, rcond=None)[0]
    free = set(floating_links(a, i_in, tol))
    return {name: (None if k in free else float(w[k])) for k, name in enumerate(links)}
