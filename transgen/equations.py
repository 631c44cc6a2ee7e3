"""Per-mode algebraic equations ``E z + F u = 0`` assembled from the mechanism graph
(thesis section 3.2.5, eqs. 3.8-3.10), with a numeric and a symbolic back-end.

Unknowns ``z`` (in this order):

* ``alpha_<link>``: link accelerations [rad/s^2];
* ``t_<element>``: torques of the locked shift elements [N*m], transmitted from ``link1`` to
  ``link2`` (the element acts ``-t`` on ``link1`` and ``+t`` on ``link2``); elements in parallel
  (the same two links, e.g. a brake beside a one-way clutch on one carrier) locked together are
  one constraint with one torque ``t_<A>+<B>`` (:class:`LockingGroup`);
* ``t_<transformer>.<port>``: the intermediate transformer torques [N*m], the torque a link
  exerts on a transformer port (the link feels ``-t``; thesis eqs. 3.39-3.53 use the same sign:
  e.g. ``-t_c4 - t_pc1 = J4*alpha4``).

Inputs ``u`` (the same list for every mode): the external torques ``T_in`` (drives the input),
``T_out`` (delivered by the output to the driveline, acts ``-T_out``), the named loads (drive their
link), then the torque of every shift element; in a given mode the columns of its locked
elements are zero, since their torques are unknowns there.

Rows: one torque balance per link, ``J*alpha = sum of torques``; per transformer, its kinematic
constraint on the accelerations and the power-conservation relations ``t_k*c_ref = c_k*t_ref``
between its port torques (eq. 3.36); per locked element (per locked group), ``alpha_1 = alpha_2``
(``alpha_1 = 0`` for a brake).

``G = -E^-1 F`` is partitioned (eq. 3.10) into ``G_accel`` (link accelerations),
``G_clutches`` (locked element torques) and ``G_intermediate`` (transformer torques).

Symbolic back-end: with only the inertias symbolic, an exact sparse elimination over the rational
functions of the symbols gives every entry as one reduced fraction. With symbolic gear geometry
that reduction can take hours (multivariate greatest common divisors), and the null-space
(virtual work) route of :func:`_structured_solve` gives the same matrices, exact, in structured
form: the kinematic ratios, the reflected (generalized) inertia and the torques built from them.

Size: about 570 lines, over the project's 500: the numeric and the exact symbolic solve of the
same equations stay beside their one assembly, so that both back-ends read one set of unknowns.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from .errors import ModeError
from .graph import TRANSFORMER_KINDS, coefficient, element_nodes, link_nodes, transformer_ports
from .kinematics import constraint_matrix, constraints, null_space, numeric_rank
from .model import HOUSING

if TYPE_CHECKING:
    from .graph import Graph

__all__ = ["ModeEquations", "LockingGroup", "locking_groups", "locked_constraints", "complete_locked", "input_names",
           "assemble", "solve", "diagnose_singular", "undetermined_links", "symbols_of", "kinematic_basis"]


@dataclass(frozen=True)
class LockingGroup:
    """Shift elements in parallel: they lock the same relative motion (their slip rows are
    parallel: the same two links, in either order, or brakes on the same link), so locked
    together they are **one** constraint with one torque.

    ``members`` in declaration order (or, for :func:`locked_constraints`, in the order of the
    locked set); ``signs[k]`` is +1 when member ``k`` has the first member's orientation
    (``slip_k = slip_first``) and -1 when its links are swapped (``slip_k = -slip_first``). The
    group's torque is measured in the first member's direction: ``t_group = sum(signs[k] * t_k)``.
    """

    members: tuple[str, ...]
    signs: tuple[int, ...]

    @property
    def label(self) -> str:
        """``"BLR+OWC"``: the name of the constraint (its torque is ``t_<label>``)."""
        return "+".join(self.members)

    @property
    def first(self) -> str:
        return self.members[0]


def _grouped(g: Graph, names) -> tuple[LockingGroup, ...]:
    """``names`` (shift elements) grouped by the pair of links they join, in order of first
    appearance."""
    groups: dict[frozenset, list[tuple[str, tuple[str, str]]]] = {}
    for e in dict.fromkeys(names):
        links = (g.nodes[e]["link1"], g.nodes[e]["link2"])
        groups.setdefault(frozenset(links), []).append((e, links))
    return tuple(LockingGroup(tuple(e for e, _ in items), tuple(1 if links == items[0][1] else -1 for _, links in items))
                 for items in groups.values())


def locking_groups(g: Graph) -> tuple[LockingGroup, ...]:
    """Every shift element in exactly one :class:`LockingGroup` (most are alone), ordered by
    their first member's declaration."""
    return _grouped(g, element_nodes(g))


def locked_constraints(g: Graph, locked) -> tuple[LockingGroup, ...]:
    """The constraints of a mode: its locked elements grouped by :func:`locking_groups`, in the
    order of first appearance in ``locked``; each group's first member is its *representative*
    (the element whose ``alpha_1 = alpha_2`` row and torque unknown the equations carry)."""
    return _grouped(g, locked)


@dataclass(frozen=True)
class ModeEquations:
    """``E z + F u = 0`` of one mode, and its solution ``z = G u`` when ``E`` is regular.

    Matrices are ``numpy`` arrays (numeric back-end) or ``sympy.Matrix`` (symbolic back-end).
    ``n_links``, ``n_locked`` give the partition of ``z`` (eq. 3.10). ``locked`` is every locked
    element; ``groups`` the mode's constraints (:func:`locked_constraints`), one torque unknown
    (one row of ``G_clutches``) each: elements in parallel share one, ``t_<group label>``, the
    group's torque in its first member's direction.
    """

    locked: tuple[str, ...]
    z: tuple[str, ...]
    u: tuple[str, ...]
    E: object
    F: object
    n_links: int
    n_locked: int
    G: object = None
    groups: tuple[LockingGroup, ...] = ()

    @property
    def G_accel(self):
        return self.G[: self.n_links, :]

    @property
    def G_clutches(self):
        return self.G[self.n_links : self.n_links + self.n_locked, :]

    @property
    def G_intermediate(self):
        return self.G[self.n_links + self.n_locked :, :]


def input_names(g: Graph) -> tuple[str, ...]:
    """Names of the inputs ``u``: external torques, then every shift element's torque."""
    sources = [n for n, d in g.nodes(data=True) if d["kind"] == "source"]
    return tuple(sources) + tuple(f"t_{e}" for e in element_nodes(g))


def symbols_of(g: Graph, which: str = "all") -> dict:
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


def _numeric_values(g: Graph) -> dict:
    values = {}
    for node, data in g.nodes(data=True):
        values.update(data.get("params", {}))
        if data["kind"] == "link":
            values[f"J_{node}"] = data["J"]
    return values


def assemble(g: Graph, locked=(), symbolic: bool | str = False) -> ModeEquations:
    """Assemble ``E`` and ``F`` of the mode with the elements ``locked`` from the graph.

    Elements in parallel (:func:`locked_constraints`) lock one motion: the group has one
    constraint row and one torque unknown, carried by its first member (the representative).

    ``symbolic``: False (numbers), True or ``"all"`` (every parameter a symbol) or
    ``"inertias"`` (only the inertias; see :func:`symbols_of`)."""
    locked = tuple(locked)
    groups = locked_constraints(g, locked)
    reps = tuple(grp.first for grp in groups)
    if symbolic:
        values = symbols_of(g, "all" if symbolic is True else symbolic)
    else:
        values = _numeric_values(g)
    links = link_nodes(g)
    transformers = [n for n, d in g.nodes(data=True) if d["kind"] in TRANSFORMER_KINDS]
    ports = [(t, link, port, terms) for t in transformers for link, port, terms in transformer_ports(g, t)]
    z = (tuple(f"alpha_{k}" for k in links) + tuple(f"t_{grp.label}" for grp in groups)
         + tuple(f"t_{t}.{p}" for t, _, p, _ in ports))
    torque_of = {grp.first: f"t_{grp.label}" for grp in groups}
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
            if e in torque_of:
                E[link_row[link], zi[torque_of[e]]] += -sign
            elif e not in locked:  # (a group's other members act through its one torque)
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
    # locked elements (one per group): equal accelerations of both halves
    for e in reps:
        data = g.nodes[e]
        E[row, zi[f"alpha_{data['link1']}"]] = 1
        if data["link2"] != HOUSING:
            E[row, zi[f"alpha_{data['link2']}"]] = -1
        row += 1
    assert row == n
    return ModeEquations(locked, z, u, E, F, len(links), len(reps), groups=groups)


def solve(eq: ModeEquations, g: Graph) -> ModeEquations:
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
        # numpy's gesv, not scipy's lu_factor/lu_solve: the same LU with partial pivoting, but
        # scipy's costs milliseconds per small system (thread start-up in getrs)
        with np.errstate(all="ignore"):
            try:
                y = np.linalg.solve(E1 * cols[None, :], -(eq.F * rows[:, None]))
            except np.linalg.LinAlgError:
                raise ModeError(f"mode {'+'.join(eq.locked) or 'none'}: E is singular") from None
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
        if any(not str(x).startswith("J_") for x in eq.E.free_symbols):
            # symbolic gear geometry: reduced fractions can take hours (multivariate gcds)
            G = _structured_solve(eq.E, eq.F, eq.n_links, _numeric_values(g))
        else:
            G = _sparse_exact_solve(eq.E, eq.F)
    return ModeEquations(eq.locked, eq.z, eq.u, eq.E, eq.F, eq.n_links, eq.n_locked, G, eq.groups)


def complete_locked(g: Graph, locked) -> tuple[str, ...]:
    """``locked`` with the one-way clutches in parallel with a locked element added (in
    declaration order, after the given ones): a one-way clutch whose motion is held is engaged —
    it holds in its locking direction whenever its group does — so a mode that locks a group
    always includes its one-way members (the friction members are in it only when applied)."""
    locked = tuple(dict.fromkeys(locked))
    held = {frozenset((g.nodes[e]["link1"], g.nodes[e]["link2"])) for e in locked}
    extra = tuple(e for e in element_nodes(g) if e not in locked and g.nodes[e]["kind"] == "oneway"
                  and frozenset((g.nodes[e]["link1"], g.nodes[e]["link2"])) in held)
    return locked + extra


def undetermined_links(g: Graph, locked=(), a: np.ndarray | None = None) -> list[str]:
    """The massless links whose motion a mode with ``locked`` leaves undetermined: those a
    motion the constraints allow moves while it moves no link with inertia (J > 0) at all
    (structural: no torque accelerates such a motion). ``a``: the mode's constraint matrix,
    if known."""
    links = link_nodes(g)
    if a is None:
        a = constraint_matrix(g, tuple(grp.first for grp in locked_constraints(g, tuple(locked))))
    basis = null_space(a, len(links))
    if not basis.shape[1]:
        return []
    massive = np.array([g.nodes[k]["J"] > 0 for k in links])
    free = null_space(basis[massive], basis.shape[1], scale=1.0)
    if not free.shape[1]:
        return []
    motion = basis @ free
    return [k for k, row in zip(links, motion) if np.linalg.norm(row) > 1e-9]


def diagnose_singular(g: Graph, locked=()) -> str:
    """Why the mode's equations have no unique solution, or ``""`` when they do.

    Two causes: locked elements whose torques are not unique (redundant constraints: the
    elements over-constrain the mechanism, a static indeterminacy), and massless links whose
    motion the equations leave undetermined. Elements in parallel (:func:`locked_constraints`)
    are one constraint and no cause: their motion is unique, and their torque split is a rule
    of the simulator (:meth:`transgen.sim.model.transmission.Transmission.split_locked_torques`).
    """
    locked = tuple(locked)
    groups = locked_constraints(g, locked)
    reps = tuple(grp.first for grp in groups)
    label = {grp.first: grp.label for grp in groups}
    a = constraint_matrix(g, reps)
    problems = []
    if numeric_rank(a) < a.shape[0]:
        left = null_space(a.T, a.shape[0])  # y with y^T A = 0
        rows = [c.name for c in constraints(g, reps)]
        involved = [rows[i] for i in range(a.shape[0]) if np.linalg.norm(left[i]) > 1e-9]
        elements = [label[x] for x in involved if x in reps]
        transformers = [x for x in involved if x not in reps]
        if elements:
            problems.append("the torques of the locked elements " + ", ".join(elements)
                            + " are not unique (they over-constrain the mechanism"
                            + (f" together with {', '.join(transformers)})" if transformers else ")"))
        else:
            problems.append("the transformers " + ", ".join(transformers) + " impose redundant constraints, "
                            "so their internal torques are not unique (e.g. twin load paths)")
    names = undetermined_links(g, locked, a)
    if names:
        problems.append("the motion of the massless link(s) " + ", ".join(names)
                        + " is undetermined (no inertia is coupled to it)")
    if not problems:
        return ""
    return f"mode with {', '.join(locked) or 'no element'} locked: " + "; ".join(problems)


def _fraction_field(*matrices):
    """The field of rational functions (over QQ) of the symbols in ``matrices``, and a converter
    from sympy expressions to its elements (None, sympy.Rational when there are no symbols)."""
    import sympy
    from sympy import QQ
    from sympy.polys.fields import field as fraction_field

    symbols = sorted(set().union(*(m.free_symbols for m in matrices)), key=str)
    K = fraction_field(symbols, QQ)[0] if symbols else None
    return K, (K.from_expr if K is not None else sympy.Rational)


def _eliminate(rows: list[dict], n: int, K) -> dict[int, dict]:
    """Gauss-Jordan elimination of the sparse rows (``{column: field element}``) of ``[E | R]``
    with ``E`` square (columns ``0..n-1``), in place; returns ``{column of E: its pivot row}``,
    each pivot row holding ``E^-1 R`` in the columns ``>= n``.

    Pivots by the Markowitz count, then numeric entries first, then small ones, which keeps the
    fill-in and the expression swell of the bond-graph structure small.
    """
    def is_number(a) -> bool:
        return K is None or (a.numer.is_ground and a.denom.is_ground)

    def size(a) -> int:
        return 0 if K is None else len(a.numer.terms()) + len(a.denom.terms())

    free_rows, free_cols, pivot_row = set(range(len(rows))), set(range(n)), {}
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
                    cost = ((in_row - 1) * (col_count[j] - 1), not is_number(a), size(a))
                    if best is None or cost < best[0]:
                        best = (cost, i, j)
        if best is None:
            raise ModeError("the mode's equations are singular")
        _, p, c = best
        pivot = rows[p][c]
        prow = {j: a / pivot for j, a in rows[p].items()}
        rows[p] = prow
        for i in range(len(rows)):
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
        pivot_row[c] = rows[p]
    return pivot_row


def _solve_rows(E: list[list], R: list[list], K) -> list[list]:
    """``E^-1 R`` exactly for dense lists of field elements (``E`` square and regular)."""
    n = len(E)
    rows = []
    for i in range(n):
        row = {j: a for j, a in enumerate(E[i]) if a != 0}
        row.update({n + j: a for j, a in enumerate(R[i]) if a != 0})
        rows.append(row)
    pivots = _eliminate(rows, n, K)
    m = len(R[0]) if R else 0
    zero = K.zero if K is not None else 0
    return [[pivots[c].get(n + j, zero) for j in range(m)] for c in range(n)]


def _sparse_exact_solve(E, F):
    """``G = -E^-1 F`` exactly, for sympy matrices ``E`` (square, regular) and ``F``: sparse
    Gauss-Jordan elimination over the field of rational functions of the mechanism's symbols
    (every entry kept as a reduced fraction; see :func:`_eliminate`)."""
    import sympy

    K, convert = _fraction_field(E, F)
    n, m = E.shape[0], F.shape[1]
    X = _solve_rows([[convert(E[i, j]) for j in range(n)] for i in range(n)],
                    [[convert(-F[i, j]) for j in range(m)] for i in range(n)], K)
    G = sympy.zeros(n, m)
    for i in range(n):
        for j in range(m):
            G[i, j] = _to_expr(X[i][j], K)
    return G


def _independent(a: np.ndarray, rank: int) -> list[int]:
    """Indices of ``rank`` linearly independent columns of ``a`` (QR with column pivoting)."""
    if rank == 0:
        return []
    import scipy.linalg  # only the symbolic back-end comes here; its import costs start-up time

    _, _, piv = scipy.linalg.qr(a, mode="economic", pivoting=True)
    return sorted(int(j) for j in piv[:rank])


def _to_expr(x, K, readable: bool = True):
    """A field element (or rational number when ``K`` is None) as a sympy expression, factored
    where cheap when ``readable`` (intermediate results skip that)."""
    import sympy

    if x == 0:
        return sympy.Integer(0)
    if K is None:
        return sympy.sympify(x)
    return _readable(x) if readable else x.as_expr()


def _kinematic_rows(E, n_links: int) -> list[int]:
    """Rows of ``E`` that are kinematic constraints (transformers, locked elements): entries in
    the acceleration columns only."""
    n = E.shape[0]
    return [i for i in range(n_links, n) if all(E[i, j] == 0 for j in range(n_links, n))]


def kinematic_basis(E, n_links: int, free: list[int]) -> list[list]:
    """Exact basis of the link accelerations (and speeds) the kinematic rows of the symbolic
    ``E`` allow: ``N`` (rows: links, columns: the links ``free``) with ``alpha = N alpha_free``.
    It holds only the gear geometry. Raises :class:`ModeError` when ``free`` are not independent
    coordinates of the mode."""
    import sympy

    kin = _kinematic_rows(E, n_links)
    dep = [j for j in range(n_links) if j not in free]
    if len(dep) != len(kin):
        raise ModeError(f"{len(free)} coordinates for a mode with {n_links - len(kin)} degrees of freedom")
    N = [[sympy.Integer(int(j == f)) for f in free] for j in range(n_links)]
    if dep:
        K, convert = _fraction_field(E.extract(kin, list(range(n_links))))
        X = _solve_rows([[convert(E[i, j]) for j in dep] for i in kin],
                        [[convert(-E[i, j]) for j in free] for i in kin], K)
        for r, j in enumerate(dep):
            N[j] = [_to_expr(x, K) for x in X[r]]
    return N


def _det(M: list[list]):
    """Determinant by cofactors (the generalized mass matrix is DOF x DOF, small), unexpanded."""
    import sympy

    if not M:
        return sympy.Integer(1)
    if len(M) == 1:
        return M[0][0]
    return sympy.Add(*[(-1) ** c * M[0][c] * _det([row[:c] + row[c + 1:] for row in M[1:]])
                       for c in range(len(M)) if M[0][c] != 0])


def _structured_solve(E, F, n_links: int, numbers: dict):
    """``G = -E^-1 F`` by the null-space (virtual work) route, for modes whose gear geometry is
    symbolic, where the exact elimination drowns in greatest common divisors.

    The rows of ``E z + F u = 0`` are the link balances ``J alpha + R lambda = -F_l u``, the
    kinematic constraints ``A alpha = 0`` and the power relations ``P lambda = 0`` between the
    internal torques ``lambda`` (locked elements, transformer ports). With an exact basis ``N``
    of the null space of ``A`` (:func:`kinematic_basis`, ``alpha = N qdot``) and workless internal
    torques (``N^T R lambda = 0`` when ``P lambda = 0``):

    * ``M qdot = -N^T F_l u`` with the generalized mass matrix ``M = N^T J N`` (DOF x DOF),
      solved by cofactors: ``qdot = -adj(M) N^T F_l u / det(M)``;
    * ``alpha = N qdot``;
    * ``lambda = S^-1 [-F_l u - J alpha]`` on independent rows ``S`` of ``[R; P]`` (geometry
      only, inverted exactly).

    The results are exact but not reduced to single fractions (that reduction, a multivariate
    greatest common divisor per entry, is what does not finish: minutes for one entry of the
    HT-740's 2-DOF modes). ``numbers`` gives a numeric value per symbol, used only to choose
    independent columns and rows.
    """
    import sympy

    n, m = E.shape[0], F.shape[1]
    nl = n_links
    num = {sym: numbers[str(sym)] for sym in (E.free_symbols | F.free_symbols)}

    E_num = np.array(E.xreplace(num).tolist(), dtype=float)

    def numeric(rows, cols) -> np.ndarray:
        return E_num[np.ix_(list(rows), list(cols))]

    kin = _kinematic_rows(E, nl)
    a_num = numeric(kin, range(nl))
    rank = numeric_rank(a_num) if kin else 0
    if rank != len(kin):
        raise ModeError("the mode's kinematic constraints are not independent")
    dep = _independent(a_num, rank)
    free = [j for j in range(nl) if j not in dep]
    d = len(free)
    N = kinematic_basis(E, nl, free)
    J = [E[k, k] for k in range(nl)]
    M = [[sympy.Add(*[J[k] * N[k][a] * N[k][b] for k in range(nl)]) for b in range(d)] for a in range(d)]
    Q = [[-sympy.Add(*[N[k][a] * F[k, j] for k in range(nl)]) for j in range(m)] for a in range(d)]
    det = _det(M)
    adj = [[(-1) ** (a + b) * _det([row[:a] + row[a + 1:] for r, row in enumerate(M) if r != b])
            for b in range(d)] for a in range(d)]
    Bq = [[sympy.Add(*[adj[a][b] * Q[b][j] for b in range(d)]) / det for j in range(m)] for a in range(d)]
    G_alpha = [[sympy.Add(*[N[k][a] * Bq[a][j] for a in range(d)]) for j in range(m)] for k in range(nl)]
    lam_cols = list(range(nl, n))
    rows = list(range(nl)) + [i for i in range(nl, n) if i not in kin]
    pick = [rows[i] for i in _independent(numeric(rows, lam_cols).T, len(lam_cols))]
    if len(pick) != len(lam_cols) or numeric_rank(numeric(pick, lam_cols)) != len(lam_cols):
        raise ModeError("the mode's internal torques are not unique")
    Lam = []
    if lam_cols:
        K, convert = _fraction_field(E.extract(pick, lam_cols))
        inverse = _solve_rows([[convert(E[i, j]) for j in lam_cols] for i in pick],
                              [[convert(int(r == c)) for c in range(len(pick))] for r in range(len(pick))], K)
        T = [[_to_expr(x, K, readable=False) for x in row] for row in inverse]
        rhs = [[(-F[i, j] - J[i] * G_alpha[i][j]) if i < nl else sympy.Integer(0) for j in range(m)] for i in pick]
        Lam = [[sympy.Add(*[T[r][c] * rhs[c][j] for c in range(len(pick)) if T[r][c] != 0]) for j in range(m)]
               for r in range(len(lam_cols))]
    return sympy.Matrix(G_alpha + Lam)


def _readable(fraction):
    """A fraction-field element as a sympy expression, factored where that is cheap (factoring
    the large numerators of multi-DOF modes costs far more than the elimination itself)."""
    import sympy

    expr = fraction.as_expr()
    if len(fraction.numer.terms()) + len(fraction.denom.terms()) <= 24:
        expr = sympy.factor(expr)
    return expr
