"""Independent reference methods for the transgen test suite.

Nothing here uses ``transgen.graph``, ``transgen.kinematics``, ``transgen.equations`` or
``transgen.modes``: the kinematic constraints are written down again directly from the
:class:`~transgen.model.Mechanism` object (the formulas of the language reference and of thesis
eqs. 3.37 / 3.45-3.47), with exact sympy Rationals, and the dynamics are solved by a different
formulation (null space + Lagrange multipliers instead of transgen's bond-graph ``E z + F u = 0``):

* kinematics: ``A w = 0``; DOF = n_links - rank(A) (exact); the input/output ratio is found by
  solving ``A w = 0, w_out = 1`` exactly (it is determined iff ``w_in`` is unique there);
* dynamics: ``w = N q`` with ``N`` a basis of ``null(A)``; the accelerations are
  ``alpha = N (N^T J N)^-1 N^T S u``; the constraint reactions are ``A^T lambda = J alpha - S u``
  and a locked element's torque is ``t_e = -lambda_e`` (its row is ``+1`` at link1 and ``-1`` at
  link2; it acts ``-t`` on link1 and ``+t`` on link2).

Everything is exact (sympy ``Rational``) until the final conversion to ``numpy`` floats.
"""
from __future__ import annotations

import functools
import itertools
from dataclasses import dataclass

import numpy as np
import sympy
from sympy import QQ, Matrix, Rational
from sympy.polys.matrices import DomainMatrix

HOUSING = "housing"


def exact(x) -> Rational:
    """A number as written (float via its shortest repr, so 0.03 -> 3/100) as an exact Rational."""
    if isinstance(x, (int, np.integer)):
        return Rational(int(x))
    return Rational(repr(float(x)))


# ---------------------------------------------------------------------------------------------
# Constraints, written directly from the Mechanism


def constraint_rows(mech, engaged=()) -> list[tuple[str, dict]]:
    """``[(name, {link: coefficient})]``: one row per planetary and gear pair, one per pair of
    consecutive central gears of a stepped-pinion set, then one per engaged element, each meaning ``sum(coefficient * w_link) = 0`` (housing terms dropped)."""
    rows: list[tuple[str, dict]] = []

    def add(name, terms):
        coeffs: dict = {}
        for link, c in terms:
            if link == HOUSING:
                continue
            coeffs[link] = coeffs.get(link, 0) + c
        rows.append((name, coeffs))

    for p in mech.planetaries:
        ns, nr = Rational(p.n_sun), Rational(p.n_ring)
        if p.pinions == 1:  # Ns*ws + Nr*wr = (Ns + Nr)*wc
            add(p.name, [(p.sun, ns), (p.ring, nr), (p.carrier, -(ns + nr))])
        else:  # Nr*wr - Ns*ws = (Nr - Ns)*wc
            add(p.name, [(p.sun, -ns), (p.ring, nr), (p.carrier, -(nr - ns))])
    for gp in mech.gear_pairs:
        n1, n2 = exact(gp.n1), exact(gp.n2)
        if gp.mesh == "external":  # n1*w1 = -n2*w2
            add(gp.name, [(gp.link1, n1), (gp.link2, n2)])
        else:  # n1*w1 = n2*w2
            add(gp.name, [(gp.link1, n1), (gp.link2, -n2)])
    for sp in getattr(mech, "stepped", ()):
        # every gear X on pinion step k: (w_p - w_c) = g_X * (w_X - w_c), g_X = sigma_X*N_X/Np_k
        # (sigma -1 sun, +1 ring); one row per pair of consecutive gears
        g = [(link, (1 if role.startswith("ring") else -1) * Rational(teeth, sp.np1 if role.endswith("1") else sp.np2))
             for role, link, teeth in sp.members]
        for (la, ga), (lb, gb) in zip(g, g[1:]):
            add(f"{sp.name}:{la}:{lb}", [(la, ga), (lb, -gb), (sp.carrier, gb - ga)])
    by_name = {e.name: e for e in mech.elements}
    for name in engaged:
        e = by_name[name]
        add(name, [(e.link1, Rational(1)), (e.link2, Rational(-1))])  # w1 = w2 (w1 = 0 to housing)
    return rows


def constraint_matrix(mech, engaged=()) -> Matrix:
    """Exact constraint matrix (rows as :func:`constraint_rows`, columns: links in order)."""
    links = [k.name for k in mech.links]
    rows = constraint_rows(mech, engaged)
    a = sympy.zeros(len(rows), len(links))
    for r, (_, coeffs) in enumerate(rows):
        for link, c in coeffs.items():
            a[r, links.index(link)] = c
    return a


def _qq(m: Matrix) -> DomainMatrix:
    return DomainMatrix.from_Matrix(m).convert_to(QQ)


def _rank(m: Matrix) -> int:
    return 0 if m.rows == 0 or m.cols == 0 else _qq(m).rank()


def _rref(m: Matrix) -> tuple[Matrix, tuple[int, ...]]:
    """Exact reduced row echelon form (sympy, over the rationals) and pivot columns."""
    red, pivots = _qq(m).rref()
    return red.to_Matrix(), tuple(pivots)


def _unique_components(red: Matrix, pivots, n_vars: int) -> dict[int, object]:
    """From the rref of ``[M | b]`` of a consistent system: {variable: value} for every variable
    whose value is unique (a row of the rref that is ``e_k | value``)."""
    out = {}
    for i, p in enumerate(pivots):
        if p < n_vars and all(red[i, j] == 0 for j in range(n_vars) if j != p):
            out[p] = red[i, n_vars]
    return out


def _solve_with(a: Matrix, col: int):
    """Solve ``A w = 0, w[col] = 1`` exactly: (consistent, {variable: unique value})."""
    n = a.cols
    e = sympy.zeros(1, n)
    e[0, col] = 1
    aug = a.col_join(e).row_join(sympy.zeros(a.rows, 1).col_join(Matrix([[1]])))
    red, pivots = _rref(aug)
    if n in pivots:  # a pivot in the right-hand side column: 0 = 1, inconsistent
        return False, {}
    return True, _unique_components(red, pivots, n)


@dataclass(frozen=True)
class Kinematics:
    engaged: tuple
    dof: int
    ratio: object  # sympy Rational or None
    kind: str
    floating: tuple
    detail: str = ""


@functools.lru_cache(maxsize=None)
def _kinematics_cached(mech, engaged_key: tuple) -> Kinematics:
    links = [k.name for k in mech.links]
    a = constraint_matrix(mech, engaged_key)
    n = len(links)
    dof = n - _rank(a)
    if dof == 0:
        return Kinematics(engaged_key, 0, None, "tie-up", ())
    i_in, i_out = links.index(mech.input), links.index(mech.output)
    # output moves <=> A w = 0, w_out = 1 is consistent; the ratio is w_in there, if unique
    out_moves, fixed_by_out = _solve_with(a, i_out)
    in_moves, fixed_by_in = _solve_with(a, i_in)
    w_in = fixed_by_out.get(i_in)
    if out_moves and in_moves and w_in is not None and w_in != 0:
        # floating: links whose speed is not fixed by the input speed (A w = 0, w_in = 1)
        floating = tuple(name for k, name in enumerate(links) if k not in fixed_by_in)
        return Kinematics(engaged_key, dof, w_in, "gear", floating)
    if out_moves and in_moves:
        return Kinematics(engaged_key, dof, None, "neutral", ())
    detail = {(True, False): "output held", (False, True): "input held"}.get((in_moves, out_moves), "input and output held")
    return Kinematics(engaged_key, dof, None, "other", (), detail)


def kinematics(mech, engaged=()) -> Kinematics:
    """Exact DOF, ratio (input/output, Rational), kind and floating links of ``engaged``."""
    return _kinematics_cached(mech, tuple(engaged))


def all_combinations(mech):
    names = [e.name for e in mech.elements]
    return [c for r in range(len(names) + 1) for c in itertools.combinations(names, r)]


# ---------------------------------------------------------------------------------------------
# Dynamics by the null-space method


def input_matrix(mech, inputs, locked=()) -> Matrix:
    """``S`` (links x inputs): link torques produced by the inputs ``u`` named ``inputs``.

    T_in drives the input link (+1), T_out acts -1 on the output link, a named load drives its
    link (+1), a slipping element's torque t_e acts -1 on link1 and +1 on link2; the columns of
    locked elements are zero (their torques are unknowns)."""
    links = [k.name for k in mech.links]
    s = sympy.zeros(len(links), len(inputs))
    loads = {t.name: t.link for t in mech.loads}
    elements = {f"t_{e.name}": e for e in mech.elements}

    def put(link, j, v):
        if link != HOUSING:
            s[links.index(link), j] += v

    for j, name in enumerate(inputs):
        if name == "T_in":
            put(mech.input, j, 1)
        elif name == "T_out":
            put(mech.output, j, -1)
        elif name in elements:
            e = elements[name]
            if e.name not in locked:
                put(e.link1, j, -1)
                put(e.link2, j, 1)
        elif name in loads:
            put(loads[name], j, 1)
        else:  # pragma: no cover - the test fails loudly on an unknown input
            raise KeyError(name)
    return s


def inertia_matrix(mech) -> Matrix:
    return sympy.diag(*[exact(k.inertia) for k in mech.links])


@dataclass(frozen=True)
class Dynamics:
    locked: tuple
    inputs: tuple
    N: np.ndarray  # links x dof, a basis of null(A)
    S: np.ndarray
    J: np.ndarray
    A: np.ndarray
    alpha: np.ndarray | None  # links x inputs
    torques: np.ndarray | None  # locked x inputs
    redundant: tuple  # locked elements whose constraint rows are linearly dependent on the others
    undetermined: tuple  # links whose motion is not determined (massless, no inertia coupled)
    tf_redundant: tuple = ()  # transformers whose constraints are linearly dependent on the others

    @property
    def dof(self) -> int:
        return self.N.shape[1]


def _to_np(m: Matrix, shape=None) -> np.ndarray:
    if m.rows == 0 or m.cols == 0:
        return np.zeros(shape if shape is not None else (m.rows, m.cols))
    return np.array(m.evalf(30).tolist(), dtype=float)


@functools.lru_cache(maxsize=None)
def _dynamics_cached(mech, locked: tuple, inputs: tuple) -> Dynamics:
    links = [k.name for k in mech.links]
    a = constraint_matrix(mech, locked)
    rows = constraint_rows(mech, locked)
    n = len(links)
    n_tf = len(rows) - len(locked)
    J = inertia_matrix(mech)
    S = input_matrix(mech, inputs, locked)
    basis = a.nullspace() if a.rows else [sympy.eye(n)[:, i] for i in range(n)]
    N = Matrix.hstack(*basis) if basis else sympy.zeros(n, 0)
    # a locked element's torque is not unique iff its row takes part in a linear dependence
    # among the rows (a left null vector y, y^T A = 0, with y_e != 0)
    left = a.T.nullspace() if a.rows else []
    redundant = [locked[i - n_tf] for i in range(n_tf, a.rows) if any(y[i] != 0 for y in left)]
    tf_redundant = [rows[i][0] for i in range(n_tf) if any(y[i] != 0 for y in left)]
    undetermined: list[str] = []
    alpha = torques = None
    if N.cols:
        M = N.T * J * N
        free = M.nullspace()
        if free:
            motion = N * Matrix.hstack(*free)
            undetermined = [links[k] for k in range(n) if any(v != 0 for v in motion.row(k))]
    if not undetermined:
        if N.cols:
            alpha_x = N * (N.T * J * N).inv() * N.T * S
        else:
            alpha_x = sympy.zeros(n, len(inputs))
        alpha = _to_np(alpha_x, (n, len(inputs)))
        if not redundant:
            r = _to_np(J * alpha_x - S, (n, len(inputs)))  # = A^T lambda
            if a.rows:
                lam, *_ = np.linalg.lstsq(_to_np(a).T, r, rcond=None)
                assert np.allclose(_to_np(a).T @ lam, r, atol=1e-9 * max(1.0, np.abs(r).max())), "inconsistent"
                torques = -lam[n_tf:, :]
            else:
                torques = np.zeros((0, len(inputs)))
    return Dynamics(tuple(locked), tuple(inputs), _to_np(N, (n, N.cols)), _to_np(S), _to_np(J), _to_np(a, (a.rows, n)),
                    alpha, torques, tuple(redundant), tuple(undetermined), tuple(tf_redundant))


def dynamics(mech, locked, inputs) -> Dynamics:
    """Null-space solution of the mode with ``locked`` elements (see the module docstring)."""
    return _dynamics_cached(mech, tuple(locked), tuple(inputs))


def assert_close(actual, expected, rtol=1e-9, what=""):
    """Elementwise comparison scaled by the largest magnitude of the expected matrix."""
    actual = np.asarray(actual, dtype=float)
    expected = np.asarray(expected, dtype=float)
    assert actual.shape == expected.shape, f"{what}: shape {actual.shape} != {expected.shape}"
    assert np.all(np.isfinite(actual)), f"{what}: non-finite entries"
    scale = max(1.0, float(np.max(np.abs(expected)))) if expected.size else 1.0
    err = float(np.max(np.abs(actual - expected))) if expected.size else 0.0
    assert err <= rtol * scale, f"{what}: max error {err:.3g} > {rtol:g} * {scale:.3g}\n{actual}\n!=\n{expected}"


# ---------------------------------------------------------------------------------------------
# Random mechanisms for property tests


def random_mechanism_text(rng, max_links: int = 6, max_elements: int = 4) -> str:
    """A random but valid ``.mech`` text (``rng``: a ``random.Random``): planetaries of both kinds
    with members on links or the housing, gear pairs by teeth and by radius, external and internal,
    clutches (also to the housing), brakes, one-way clutches, massless links and a named load."""
    n_links = rng.randint(2, max_links)
    links = [f"L{i}" for i in range(n_links)]
    out = [f"link {k} J={rng.choice(['0', '0.5', '1', '2.25', '0.1', '0.04'])}" for k in links]
    pool = links + [HOUSING]
    for i in range(rng.randint(0, 2)):
        ns = rng.randint(10, 40)
        nr = ns + rng.randint(1, 60)
        sun, ring, carrier = rng.sample(pool, 3)
        out.append(f"planetary P{i} sun={sun} ring={ring} carrier={carrier} Ns={ns} Nr={nr} pinions={rng.choice([1, 2])}")
    for i in range(rng.randint(0, 2)):
        a, b = rng.sample(links, 2)
        mesh = rng.choice(["external", "internal"])
        if rng.random() < 0.5:
            out.append(f"gears G{i} {a} {b} N1={rng.randint(10, 60)} N2={rng.randint(10, 60)} mesh={mesh}")
        else:
            out.append(f"gears G{i} {a} {b} r1={rng.choice(['0.03', '0.055', '0.1'])} "
                       f"r2={rng.choice(['0.04', '0.07', '0.125'])} mesh={mesh}")
    for i in range(rng.randint(1, max_elements)):
        kind = rng.choice(["clutch", "brake", "oneway", "oneway2"])
        if kind == "clutch":
            a, b = rng.sample(pool, 2)
            if a == HOUSING:
                a, b = b, a
            out.append(f"clutch K{i} {a} {b} static=10 dynamic=8")
        elif kind == "brake":
            out.append(f"brake K{i} {rng.choice(links)} static=10 dynamic=8")
        elif kind == "oneway":
            out.append(f"oneway K{i} {rng.choice(links)} free={rng.choice(['positive', 'negative'])}")
        else:
            a, b = rng.sample(links, 2)
            out.append(f"oneway K{i} {a} {b} free={rng.choice(['positive', 'negative'])}")
    a, b = rng.sample(links, 2)
    out += [f"input {a}", f"output {b}"]
    if rng.random() < 0.5:
        out.append(f"torque Tx {rng.choice(links)}")
    return "\n".join(out) + "\n"
