"""Per-mode algebraic equations ``E z + F u = 0`` assembled from the mechanism graph
(thesis section 3.2.5, eqs. 3.8-3.10), with a numeric and a symbolic back-end.

Unknowns ``z`` (in this order):

* ``alpha_<link>``: link accelerations [rad/s^2];
* ``t_<element>``: torques of the locked shift elements [N*m], transmitted from ``link1`` to
  ``link2`` (the element acts ``-t`` on ``link1`` and ``+t`` on ``link2``);
* ``t_<transformer>.<port>``: the intermediate transformer torques [N*m], the torque a link
  exerts on a transformer port (the link feels ``-t``; thesis eqs. 3.39-3.53 use the same sign:
  e.g. ``-t_c4 - t_pc1 = J4*alpha4``).

Inputs ``u`` (the same list for every mode): the external torques ``T_in`` (drives the input),
``T_out`` (delivered by the output to the driveline, acts ``-T_out``), the named loads (drive their
link), then the torque of every shift element; in a given mode the columns of its locked
elements are zero, since their torques are unknowns there.

Rows: one torque balance per link, ``J*alpha = sum of torques``; per transformer, its kinematic
constraint on the accelerations and the power-conservation relations ``t_k*c_ref = c_k*t_ref``
between its port torques (eq. 3.36); per locked element, ``alpha_1 = alpha_2`` (``alpha_1 = 0``
for a brake).

``G = -E^-1 F`` is partitioned (eq. 3.10) into ``G_accel`` (link accelerations),
``G_clutches`` (locked element torques) and ``G_intermediate`` (transformer torques).
"""
from __future__ import annotations

from dataclasses import dataclass

import networkx as nx
import numpy as np
import scipy.linalg

from .errors import ModeError
from .graph import coefficient, element_nodes, link_nodes, transformer_ports
from .kinematics import constraint_matrix, constraints, null_space, numeric_rank
from .model import HOUSING

__all__ = ["ModeEquations", "input_names", "assemble", "solve", "diagnose_singular", "symbols_of"]


@dataclass(frozen=True)
class ModeEquations:
    """``E z + F u = 0`` of one mode, and its solution ``z = G u`` when ``E`` is regular.

    Matrices are ``numpy`` arrays (numeric back-end) or ``sympy.Matrix`` (symbolic back-end).
    ``n_links``, ``n_locked`` give the partition of ``z`` (eq. 3.10).
    """

    locked: tuple[str, ...]
    z: tuple[str, ...]
    u: tuple[str, ...]
    E: object
    F: object
    n_links: int
    n_locked: int
    G: object = None

    @property
    def G_accel(self):
        return self.G[: self.n_links, :]

    @property
    def G_clutches(self):
        return self.G[self.n_links : self.n_links + self.n_locked, :]

    @property
    def G_intermediate(self):
        return self.G[self.n_links + self.n_locked :, :]


def input_names(g: nx.DiGraph) -> tuple[str, ...]:
    """Names of the inputs ``u``: external torques, then every shift element's torque."""
    sources = [n for n, d in g.nodes(data=True) if d["kind"] == "source"]
    return tuple(sources) + tuple(f"t_{e}" for e in element_nodes(g))


def symbols_of(g: nx.DiGraph, which: str = "all") -> dict:
    """Values for the symbolic back-end: sympy symbols for the transformer parameters (tooth
    counts ``Ns_P1``, radii ``r1_G``) and the nonzero inertias (``J_<link>``); massless links
    keep an exact 0. ``which="inertias"`` keeps the gear geometry as exact rational numbers and
    makes only the inertias symbols (much smaller expressions for multi-DOF modes)."""
    import sympy

    if which not in ("all", "inertias"):
        raise ValueError(f"symbols must be 'all' or 'inertias', not {which!r}")
    values = {}
    for node, data in g.nodes(data=True):
        for name, value in data.get("params", {}).items():
            values[name] = sympy.Symbol(name, positive=True) if which == "all" else sympy.nsimplify(value, rational=True)
        if data["kind"] == "link":
            values[f"J_{node}"] = sympy.Symbol(f"J_{node}", positive=True) if data["J"] > 0 else sympy.Integer(0)
    return values


def _numeric_values(g: nx.DiGraph) -> dict:
    values = {}
    for node, data in g.nodes(data=True):
        values.update(data.get("params", {}))
        if data["kind"] == "link":
            values[f"J_{node}"] = data["J"]
    return values


def assemble(g: nx.DiGraph, locked=(), symbolic: bool | str = False) -> ModeEquations:
    """Assemble ``E`` and ``F`` of the mode with the elements ``locked`` from the graph.

    ``symbolic``: False (numbers), True or ``"all"`` (every parameter a symbol) or
    ``"inertias"`` (only the inertias; see :func:`symbols_of`)."""
    locked = tuple(locked)
    if symbolic:
        values = symbols_of(g, "all" if symbolic is True else symbolic)
    else:
        values = _numeric_values(g)
    links = link_nodes(g)
    transformers = [n for n, d in g.nodes(data=True) if d["kind"] in ("planetary", "gearpair")]
    ports = [(t, link, port, terms) for t in transformers for link, port, terms in transformer_ports(g, t)]
    z = tuple(f"alpha_{k}" for k in links) + tuple(f"t_{e}" for e in locked) + tuple(f"t_{t}.{p}" for t, _, p, _ in ports)
    u = input_names(g)
    zi = {name: i for i, name in enumerate(z)}
    ui = {name: i for i, name in enumerate(u)}
    n = len(z)
    if symbolic:
        import sympy

        E, F = sympy.zeros(n, n), sympy.zeros(n, len(u))
    else:
        E, F = np.zeros((n, n)), np.zeros((n, len(u)))
    row = 0
    # torque balance of each link: J*alpha - (sum of torques on it) = 0
    link_row = {k: i for i, k in enumerate(links)}
    for k in links:
        E[link_row[k], zi[f"alpha_{k}"]] = values[f"J_{k}"]
    for e in element_nodes(g):
        data = g.nodes[e]
        for link, sign in ((data["link1"], -1), (data["link2"], 1)):
            if link == HOUSING:
                continue
            if e in locked:
                E[link_row[link], zi[f"t_{e}"]] += -sign
            else:
                F[link_row[link], ui[f"t_{e}"]] += -sign
    for t, link, port, _ in ports:
        if link != HOUSING:
            E[link_row[link], zi[f"t_{t}.{port}"]] += 1  # the link feels -t_port
    for name, data in g.nodes(data=True):
        if data["kind"] == "source":
            F[link_row[data["link"]], ui[name]] += 1 if data["role"] == "output" else -1
    row = len(links)
    # transformers: kinematic constraint and power conservation between port torques
    for t in transformers:
        tp = [(link, port, coefficient(terms, values)) for link, port, terms in transformer_ports(g, t)]
        for link, _, c in tp:
            if link != HOUSING:
                E[row, zi[f"alpha_{link}"]] += c
        row += 1
        _, ref_port, c_ref = tp[-1]
        for _, port, c in tp[:-1]:
            E[row, zi[f"t_{t}.{port}"]] = c_ref
            E[row, zi[f"t_{t}.{ref_port}"]] = -c
            row += 1
    # locked elements: equal accelerations of both halves
    for e in locked:
        data = g.nodes[e]
        E[row, zi[f"alpha_{data['link1']}"]] = 1
        if data["link2"] != HOUSING:
            E[row, zi[f"alpha_{data['link2']}"]] = -1
        row += 1
    assert row == n
    return ModeEquations(locked, z, u, E, F, len(links), len(locked))


def solve(eq: ModeEquations, g: nx.DiGraph) -> ModeEquations:
    """``G = -E^-1 F``: LU with partial pivoting (numeric) or exact sparse elimination (symbolic).

    Raises :class:`ModeError` naming the massless links whose motion is undetermined or the
    locked elements whose torques are not unique when ``E`` is singular.
    """
    if isinstance(eq.E, np.ndarray):
        # E mixes inertias with tooth counts and ones, so a rank test on E itself depends on the
        # units; the structural diagnosis (unitless constraints, mass matrix scaled by its own size)
        # does not.
        problem = diagnose_singular(g, eq.locked)
        if problem:
            raise ModeError(problem)
        # equilibrate rows and columns (accelerations ~ 1/J and torques ~ 1 differ by the
        # inertias' scale), then LU with partial pivoting
        rows = 1.0 / np.abs(eq.E).max(axis=1)
        E1 = eq.E * rows[:, None]
        cols = 1.0 / np.abs(E1).max(axis=0)
        with np.errstate(all="ignore"):
            y = scipy.linalg.lu_solve(scipy.linalg.lu_factor(E1 * cols[None, :], check_finite=False),
                                      -(eq.F * rows[:, None]))
        G = y * cols[:, None]
        if not np.all(np.isfinite(G)):
            raise ModeError(f"mode {'+'.join(eq.locked) or 'none'}: E is singular")
        # accelerations satisfy the constraints exactly: project out the round-off that violates
        # them (a tie-up then has exactly zero accelerations)
        basis = null_space(constraint_matrix(g, eq.locked), eq.n_links)
        G[: eq.n_links] = basis @ (basis.T @ G[: eq.n_links])
        for block in (slice(0, eq.n_links), slice(eq.n_links, eq.n_links + eq.n_locked), slice(eq.n_links + eq.n_locked, None)):
            part = G[block]  # round-off clean-up within quantities of one unit
            part[np.abs(part) < 1e-13 * np.abs(part).max(initial=0.0)] = 0.0
    else:
        problem = diagnose_singular(g, eq.locked)
        if problem:
            raise ModeError(problem)
        G = _sparse_exact_solve(eq.E, eq.F)
    return ModeEquations(eq.locked, eq.z, eq.u, eq.E, eq.F, eq.n_links, eq.n_locked, G)


def diagnose_singular(g: nx.DiGraph, locked=()) -> str:
    """Why the mode's equations have no unique solution, or ``""`` when they do.

    Two causes: locked elements whose torques are not unique (redundant constraints: the
    elements over-constrain the mechanism, a static indeterminacy), and massless links whose
    motion the equations leave undetermined.
    """
    locked = tuple(locked)
    links = link_nodes(g)
    a = constraint_matrix(g, locked)
    problems = []
    if numeric_rank(a) < a.shape[0]:
        left = null_space(a.T, a.shape[0])  # y with y^T A = 0
        rows = [c.name for c in constraints(g, locked)]
        involved = [rows[i] for i in range(a.shape[0]) if np.linalg.norm(left[i]) > 1e-9]
        elements = [x for x in involved if x in locked]
        transformers = [x for x in involved if x not in locked]
        if elements:
            problems.append("the torques of the locked elements " + ", ".join(elements)
                            + " are not unique (they over-constrain the mechanism"
                            + (f" together with {', '.join(transformers)})" if transformers else ")"))
        else:
            problems.append("the transformers " + ", ".join(transformers) + " impose redundant constraints, "
                            "so their internal torques are not unique (e.g. twin load paths)")
    basis = null_space(a, len(links))
    if basis.shape[1]:
        # masslessness is structural: a motion that moves no link with inertia (J > 0) at all
        massive = np.array([g.nodes[k]["J"] > 0 for k in links])
        free = null_space(basis[massive], basis.shape[1], scale=1.0)
        if free.shape[1]:
            motion = basis @ free
            names = [k for k, row in zip(links, motion) if np.linalg.norm(row) > 1e-9]
            problems.append("the motion of the massless link(s) " + ", ".join(names)
                            + " is undetermined (no inertia is coupled to it)")
    if not problems:
        return ""
    return f"mode with {', '.join(locked) or 'no element'} locked: " + "; ".join(problems)


def _sparse_exact_solve(E, F):
    """``G = -E^-1 F`` exactly, for sympy matrices ``E`` (square, regular) and ``F``.

    Gauss-Jordan elimination on the sparse rows of ``[E | -F]`` over the field of rational
    functions of the mechanism's symbols (every entry kept as a reduced fraction). Pivots are
    chosen by the Markowitz count, then numeric entries first, which keeps the fill-in and
    the expression swell of the bond-graph structure small (a dense ``LUsolve`` does not finish
    for the HT-740): the Markowitz count first, then numeric pivots, then small ones.
    """
    import sympy
    from sympy import QQ
    from sympy.polys.fields import field as fraction_field

    n, m = E.shape[0], F.shape[1]
    symbols = sorted(E.free_symbols | F.free_symbols, key=str)
    K = fraction_field(symbols, QQ)[0] if symbols else None

    def convert(x):
        return K.from_expr(x) if K is not None else sympy.Rational(x)

    rows = []
    for i in range(n):
        row = {j: convert(E[i, j]) for j in range(n) if E[i, j] != 0}
        row.update({n + j: convert(-F[i, j]) for j in range(m) if F[i, j] != 0})
        rows.append(row)

    def is_number(a) -> bool:
        return K is None or (a.numer.is_ground and a.denom.is_ground)

    def _size(a) -> int:
        return 0 if K is None else len(a.numer.terms()) + len(a.denom.terms())

    free_rows, free_cols, pivot_row = set(range(n)), set(range(n)), {}
    while free_rows:
        col_count: dict[int, int] = {}
        for i in free_rows:
            for j in rows[i]:
                if j in free_cols:
                    col_count[j] = col_count.get(j, 0) + 1
        best = None
        for i in free_rows:
            in_row = sum(1 for j in rows[i] if j in free_cols)
            for j, a in rows[i].items():
                if j in free_cols:
                    cost = ((in_row - 1) * (col_count[j] - 1), not is_number(a), _size(a))
                    if best is None or cost < best[0]:
                        best = (cost, i, j)
        if best is None:
            raise ModeError("the mode's equations are singular")
        _, p, c = best
        pivot = rows[p][c]
        prow = {j: a / pivot for j, a in rows[p].items()}
        rows[p] = prow
        for i in range(n):
            if i != p and c in rows[i]:
                factor, row = rows[i][c], rows[i]
                for j, a in prow.items():
                    value = row.get(j, 0) - factor * a
                    if value == 0:
                        row.pop(j, None)
                    else:
                        row[j] = value
        free_rows.discard(p)
        free_cols.discard(c)
        pivot_row[c] = p
    G = sympy.zeros(n, m)
    for c, p in pivot_row.items():
        for j, a in rows[p].items():
            if j >= n:
                G[c, j - n] = _readable(a) if K is not None else a
    return G


def _readable(fraction):
    """A fraction-field element as a sympy expression, factored where that is cheap (factoring
    the large numerators of multi-DOF modes costs far more than the elimination itself)."""
    import sympy

    expr = fraction.as_expr()
    if len(fraction.numer.terms()) + len(fraction.denom.terms()) <= 24:
        expr = sympy.factor(expr)
    return expr
