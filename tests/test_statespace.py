"""State-space matrices (thesis eqs. 3.6-3.15): numeric against the independent null-space method,
symbolic against the thesis' printed equations 3.25-3.34 for the simple transmission."""
from __future__ import annotations

import functools

import numpy as np
import pytest
import sympy

import independent as ind
from transgen import ModeError, bundled_mechanisms, load_mechanism
from transgen.graph import build_graph
from transgen.equations import input_names
from transgen.modes import mode_model, mode_models, select_modes
from transgen.statespace import state_space

BUNDLED = bundled_mechanisms()


def _check_mode(mech, md, coords, where=""):
    """B, C, D of one mode against the null-space solution."""
    links = list(mech.link_names)
    # elements in parallel are one constraint: the reference locks one of each group, and the
    # others' torque inputs (locked too) have no effect
    assert sorted(e for grp in md.locked_groups for e in grp) == sorted(md.locked)
    others = [md.inputs.index(f"t_{e}") for grp in md.locked_groups for e in grp[1:]]
    keep = [j for j in range(len(md.inputs)) if j not in others]
    ref = ind.dynamics(mech, tuple(grp[0] for grp in md.locked_groups), md.inputs)
    assert ref.alpha is not None and ref.torques is not None, (where, md.locked)
    assert md.dof == ref.dof
    assert len(md.states) == md.dof
    assert set(md.states) <= set(coords)
    assert list(md.states) == [c for c in coords if c in md.states]  # in the order of the coordinates
    rows = [links.index(s) for s in md.states]
    B = np.asarray(md.B, dtype=float)
    C = np.asarray(md.C, dtype=float)
    D = np.asarray(md.D, dtype=float)
    assert not np.any(B[:, others]) and not np.any(D[:, others])
    ind.assert_close(B[:, keep], ref.alpha[rows][:, keep], what=f"{where} {md.name} B")
    ind.assert_close(D[:, keep], ref.torques[:, keep], what=f"{where} {md.name} D")
    assert C.shape == (len(links), md.dof)
    assert md.speed_outputs == tuple(links)
    assert md.torque_outputs == tuple("t_" + "+".join(grp) for grp in md.locked_groups)
    assert np.array_equal(md.A, np.zeros((md.dof, md.dof)))
    # C maps the states to every link speed consistently with w = N q
    rng = np.random.default_rng(abs(hash((where, md.locked))) % 2**32)
    for _ in range(3):
        q = rng.normal(size=ref.dof) * 50
        w = ref.N @ q
        np.testing.assert_allclose(C @ w[rows], w, atol=1e-9 * (1 + np.abs(w).max(initial=0)))
    # C applied to the coordinate accelerations gives every link acceleration (eq. 3.13)
    ind.assert_close(C @ B, ref.alpha, what=f"{where} {md.name} C B")
    # the coordinate rows of C are the identity
    np.testing.assert_allclose(C[rows], np.eye(md.dof), atol=1e-12)


@pytest.mark.parametrize("name", sorted(BUNDLED))
def test_default_state_space_matches_the_null_space_method(name):
    mech = load_mechanism(BUNDLED[name])
    ss = state_space(mech)
    g = build_graph(mech)
    assert ss.inputs == input_names(g)
    assert ss.symbolic is False
    assert [m.locked for m in ss.modes] == [m.locked for m in select_modes(mech)]
    assert mech.input in ss.coordinates
    for md in ss.modes:
        _check_mode(mech, md, ss.coordinates, name)
    d = ss.to_dict()
    assert d["coordinates"] == list(ss.coordinates) and len(d["modes"]) == len(ss.modes)
    for md, dm in zip(ss.modes, d["modes"]):
        assert np.allclose(np.array(dm["B"], dtype=float).reshape(np.asarray(md.B).shape), md.B)


@pytest.mark.parametrize("name", ["simple2", "ht740"])
def test_all_solvable_modes_state_space(name):
    mech = load_mechanism(name)
    models = mode_models(mech, "all")
    u = input_names(build_graph(mech))
    solvable = [m for m in models if m.equations is not None]
    for m in models:
        ref = ind.dynamics(mech, m.locked, u)
        assert (m.equations is None) == (ref.alpha is None or ref.torques is None), m.locked
    # every combination: those that cannot be modelled are left out and listed
    every = state_space(mech, which="all")
    assert [m.name for m in every.modes] == [m.name for m in solvable]
    assert [(s.name, s.locked, s.problem) for s in every.skipped] == [
        (m.name, m.locked, m.problem) for m in models if m.equations is None]
    assert every.to_dict()["skipped"] == [s.to_dict() for s in every.skipped]
    if len(solvable) < len(models):  # chosen modes that cannot be modelled are refused
        with pytest.raises(ModeError):
            state_space(mech, which="declared", models=models)
    ss = state_space(mech, models=solvable)
    dof_max = max(m.dof for m in solvable)
    assert len(ss.coordinates) == dof_max == {"simple2": 2, "ht740": 3}[name]
    for md in ss.modes:
        _check_mode(mech, md, ss.coordinates, name)


def test_ht740_coordinates_l1_l6():
    mech = load_mechanism("ht740")
    ss = state_space(mech, coordinates=("L1", "L6"))
    assert ss.coordinates == ("L1", "L6")
    dofs = [m.dof for m in ss.modes]
    assert dofs == [1, 1, 1, 1, 2, 2, 1]
    for md in ss.modes:
        assert md.states == (("L1", "L6") if md.dof == 2 else ("L1",))
        _check_mode(mech, md, ss.coordinates, "ht740")
    # other valid coordinates give the same physics: speeds reconstructed identically
    other = state_space(mech, coordinates=("L1", "L4"))
    for a, b in zip(ss.modes, other.modes):
        if a.dof == 2:
            # w = C_a x_a = C_b x_b for the same motion
            ref = ind.dynamics(mech, a.locked, a.inputs)
            q = np.array([1.3, -0.7])
            w = ref.N @ q
            links = list(mech.link_names)
            np.testing.assert_allclose(np.asarray(a.C, float) @ w[[links.index(s) for s in a.states]],
                                       np.asarray(b.C, float) @ w[[links.index(s) for s in b.states]], atol=1e-9)


def test_invalid_coordinates_are_refused():
    mech = load_mechanism("ht740")
    with pytest.raises(ModeError, match="M5"):
        state_space(mech, coordinates=("L1", "L2"))
    with pytest.raises(ModeError, match="unknown link"):
        state_space(mech, coordinates=("L1", "L9"))


def test_unsolvable_mode_is_refused_by_state_space():
    from transgen import parse_mechanism

    m = parse_mechanism("""\
link A J=1
link B J=2
link X J=0
gears G A B N1=20 N2=40
clutch K A X static=10 dynamic=8
input A
output B
mode M1 = K
mode M2 = none
""")
    with pytest.raises(ModeError, match=r"M2: .*massless link\(s\) X"):
        state_space(m)
    ss = state_space(m, models=[mode_model(m, select_modes(m)[0])])
    assert np.all(np.isfinite(np.asarray(ss.modes[0].B, float)))


# ---------------------------------------------------------------------------------------------
# symbolic: the thesis' equations 3.25-3.34 for the simple transmission


def P(name):
    return sympy.Symbol(name, positive=True)


@functools.lru_cache(maxsize=None)
def _simple2_symbolic():
    return state_space(load_mechanism("simple2"), symbolic=True)


# thesis radius ratios (eqs. 3.21-3.24) in transgen's gear-pair parameters
Ri1 = P("r2_Gi1") / P("r1_Gi1")
Ri2 = P("r2_Gi2") / P("r1_Gi2")
Ro1 = P("r2_Go1") / P("r1_Go1")
Ro2 = P("r2_Go2") / P("r1_Go2")
Ji, Jo = P("J_Li"), P("J_Lo")
t_eng, t_ds, t_C1, t_C2 = sympy.symbols("t_eng t_ds t_C1 t_C2")  # the thesis' inputs
DEN1 = Jo + Ri1**2 * Ro1**2 * Ji
DEN2 = Jo + Ri2**2 * Ro2**2 * Ji
THESIS = {
    "3.26": ((Ri1**2 * Ro1**2) * t_eng + (Ri1 * Ro1 / Ri2) * (Ri2 * Ro2 - Ri1 * Ro1) * t_C2 - (Ri1 * Ro1) * t_ds) / DEN1,
    "3.27": ((Ri1 * Ro1) * t_eng + (1 / Ri2) * (Ri2 * Ro2 - Ri1 * Ro1) * t_C2 - t_ds) / DEN1,
    "3.28": ((Ri1 * Jo) * t_eng - (Ri1 / Ri2) * (Ri1 * Ri2 * Ro1 * Ro2 * Ji + Jo) * t_C2 + (Ri1**2 * Ro1 * Ji) * t_ds) / DEN1,
    "3.30": ((Ri2**2 * Ro2**2) * t_eng + (Ri2 * Ro2 / Ri1) * (Ri1 * Ro1 - Ri2 * Ro2) * t_C1 - (Ri2 * Ro2) * t_ds) / DEN2,
    "3.31": ((Ri2 * Ro2) * t_eng + (1 / Ri1) * (Ri1 * Ro1 - Ri2 * Ro2) * t_C1 - t_ds) / DEN2,
    "3.32": ((Ri2 * Jo) * t_eng - (Ri2 / Ri1) * (Ri1 * Ri2 * Ro1 * Ro2 * Ji + Jo) * t_C1 + (Ri2**2 * Ro2 * Ji) * t_ds) / DEN2,
    "3.33": (t_eng - (1 / Ri1) * t_C1 - (1 / Ri2) * t_C2) / Ji,
    "3.34": ((Ro1) * t_C1 + (Ro2) * t_C2 - t_ds) / Jo,
}
# transgen's inputs (T_in, T_out, t_C1, t_C2) in the thesis' terms: the clutches sit on
# countershafts that turn backwards, so the thesis' clutch torques are minus transgen's.
TO_THESIS = {"T_in": t_eng, "T_out": t_ds, "t_C1": -t_C1, "t_C2": -t_C2}


def _row_in_thesis_terms(matrix, row, inputs):
    return sum(matrix[row, j] * TO_THESIS[name] for j, name in enumerate(inputs))


def _assert_same(ours, thesis, label):
    for v in (t_eng, t_ds, t_C1, t_C2):
        diff = sympy.simplify(sympy.diff(ours, v) - sympy.diff(thesis, v))
        assert diff == 0, f"eq. {label}, coefficient of {v}: transgen - thesis = {diff}"
    assert sympy.simplify(ours - thesis) == 0


def test_simple2_symbolic_structure():
    ss = _simple2_symbolic()
    assert ss.symbolic and ss.coordinates == ("Li", "Lo")
    assert ss.inputs == ("T_in", "T_out", "t_C1", "t_C2")
    assert [(m.locked, m.states) for m in ss.modes] == [(("C1",), ("Li",)), (("C2",), ("Li",)), ((), ("Li", "Lo"))]
    free = set().union(*(m.B.free_symbols | m.C.free_symbols | m.D.free_symbols for m in ss.modes))
    assert free == {P(f"r{i}_{g}") for i in (1, 2) for g in ("Gi1", "Gi2", "Go1", "Go2")} | {Ji, Jo}
    # the massless countershafts contribute no symbol (exact zero inertia)
    assert not any(str(s).startswith(("J_La", "J_Lb", "J_Lc", "J_Ld")) for s in free)


@pytest.mark.parametrize("label, mode, what", [
    ("3.26", "M1", "alpha_i"), ("3.27", "M1", "alpha_o"), ("3.28", "M1", "t_C1"),
    ("3.30", "M2", "alpha_i"), ("3.31", "M2", "alpha_o"), ("3.32", "M2", "t_C2"),
    ("3.33", "M3", "alpha_i"), ("3.34", "M3", "alpha_o"),
])
def test_simple2_reproduces_thesis_equations(label, mode, what):
    ss = _simple2_symbolic()
    md = ss.mode(mode)
    links = list(load_mechanism("simple2").link_names)
    if what == "alpha_i":
        ours = _row_in_thesis_terms(md.B, md.states.index("Li"), ss.inputs)
    elif what == "alpha_o":
        if "Lo" in md.states:
            ours = _row_in_thesis_terms(md.B, md.states.index("Lo"), ss.inputs)
        else:  # 1-DOF mode: the output acceleration is C_speeds row Lo times B (eq. 3.13)
            ours = _row_in_thesis_terms(md.C * md.B, links.index("Lo"), ss.inputs)
    else:  # the locked clutch torque (D), measured the thesis' way: minus transgen's
        ours = -_row_in_thesis_terms(md.D, md.torque_outputs.index(what), ss.inputs)
    _assert_same(ours, THESIS[label], label)


def test_thesis_comparison_can_fail():
    # a sign error in one coefficient is caught (guards against a vacuous comparison)
    with pytest.raises(AssertionError):
        _assert_same(THESIS["3.33"] + 2 * t_C1 / (Ri1 * Ji), THESIS["3.33"], "3.33'")


@pytest.mark.parametrize("mode, pair", [("M1", ("La", "Lc")), ("M2", ("Lb", "Ld"))])
def test_simple2_locked_clutch_halves_turn_together(mode, pair):
    """Eqs. 3.25 / 3.29: alpha_i1 = alpha_o1 (resp. alpha_i2 = alpha_o2): the C rows of the two
    halves of the locked clutch are equal, and they are the countershaft's backward ratio."""
    ss = _simple2_symbolic()
    md = ss.mode(mode)
    links = list(load_mechanism("simple2").link_names)
    a, b = (links.index(x) for x in pair)
    assert sympy.simplify(md.C[a, 0] - md.C[b, 0]) == 0
    Ri = Ri1 if mode == "M1" else Ri2
    assert sympy.simplify(md.C[a, 0] + 1 / Ri) == 0  # the countershaft turns backwards
    # the other clutch's halves do not turn together (its slip is free)
    other = ("Lb", "Ld") if mode == "M1" else ("La", "Lc")
    c, d = (links.index(x) for x in other)
    assert sympy.simplify(md.C[c, 0] - md.C[d, 0]) != 0
    # and the output follows at the gear ratio
    Ro = Ro1 if mode == "M1" else Ro2
    assert sympy.simplify(md.C[links.index("Lo"), 0] - 1 / (Ri * Ro)) == 0


def test_simple2_mode3_C_is_the_gear_kinematics():
    ss = _simple2_symbolic()
    md = ss.mode("M3")
    expected = sympy.Matrix([[1, 0], [-1 / Ri1, 0], [-1 / Ri2, 0], [0, -Ro1], [0, -Ro2], [0, 1]])
    assert (md.C - expected).applyfunc(sympy.simplify) == sympy.zeros(6, 2)
    assert md.D.shape == (0, 4)


def _numeric_values(mech):
    values = {}
    for gp in mech.gear_pairs:
        k1, k2 = ("N1", "N2") if gp.by == "teeth" else ("r1", "r2")
        values[P(f"{k1}_{gp.name}")] = ind.exact(gp.n1)
        values[P(f"{k2}_{gp.name}")] = ind.exact(gp.n2)
    for p in mech.planetaries:
        values[P(f"Ns_{p.name}")] = sympy.Integer(p.n_sun)
        values[P(f"Nr_{p.name}")] = sympy.Integer(p.n_ring)
    for k in mech.links:
        values[P(f"J_{k.name}")] = ind.exact(k.inertia)
    return values


def _assert_symbolic_equals_numeric(sym_md, num_md, values, where):
    for mat in ("B", "C", "D"):
        s = getattr(sym_md, mat)
        n = np.asarray(getattr(num_md, mat), dtype=float)
        got = np.array(s.subs(values).evalf().tolist(), dtype=float).reshape(n.shape) if s.rows * s.cols else np.zeros(n.shape)
        ind.assert_close(got, n, what=f"{where} {sym_md.name} {mat}")


def test_simple2_symbolic_evaluates_to_numeric():
    mech = load_mechanism("simple2")
    sym = _simple2_symbolic()
    num = state_space(mech)
    values = _numeric_values(mech)
    for s, n in zip(sym.modes, num.modes):
        assert s.states == n.states and s.locked == n.locked
        _assert_symbolic_equals_numeric(s, n, values, "simple2")


def _one_dof_symbolic_matches_numeric(name, coordinate):
    """The 1-DOF default modes of ``name``, solved symbolically and evaluated, equal the numeric ones."""
    mech = load_mechanism(name)
    models = [m for m in mode_models(mech) if m.dof == 1]
    sym_models = [mode_model(mech, m.mode, symbolic=True) for m in models]
    sym = state_space(mech, coordinates=(coordinate,), models=sym_models, symbolic=True)
    num = state_space(mech, coordinates=(coordinate,), models=models)
    assert sym.symbolic and len(sym.modes) == len(models) >= 1
    values = _numeric_values(mech)
    for s, n in zip(sym.modes, num.modes):
        assert s.states == n.states == (coordinate,)
        _assert_symbolic_equals_numeric(s, n, values, name)


def test_simple2_one_dof_modes_symbolic_with_output_coordinate():
    _one_dof_symbolic_matches_numeric("simple2", "Lo")


def test_ht740_symbolic_one_dof_modes_evaluate_to_numeric():
    _one_dof_symbolic_matches_numeric("ht740", "L1")


@pytest.mark.parametrize("name", ["simple2", "ht740"])
def test_symbolic_inertias_only_evaluates_to_numeric_for_every_mode(name):
    """symbolic="inertias": exact gear geometry, inertia symbols only (also the 2-DOF modes)."""
    mech = load_mechanism(name)
    models = mode_models(mech, symbolic="inertias")
    sym = state_space(mech, models=models, symbolic="inertias")
    num = state_space(mech)
    assert sym.symbolic and sym.coordinates == num.coordinates
    free = set().union(*(m.B.free_symbols | m.C.free_symbols | m.D.free_symbols for m in sym.modes))
    assert free and all(str(x).startswith("J_") for x in free)
    values = {P(f"J_{k.name}"): ind.exact(k.inertia) for k in mech.links}
    for s, n in zip(sym.modes, num.modes):
        assert s.states == n.states
        _assert_symbolic_equals_numeric(s, n, values, name)


# every parameter symbolic, multi-DOF modes included (structured null-space solution)


def _at(matrix, values: dict) -> np.ndarray:
    symbols = sorted(values, key=str)
    f = sympy.lambdify(symbols, matrix, "mpmath")
    import mpmath

    with mpmath.workdps(40):
        return np.array(f(*[mpmath.mpf(sympy.Rational(values[s]).p) / sympy.Rational(values[s]).q for s in symbols]).tolist(),
                        dtype=float)


@functools.lru_cache(maxsize=None)
def _ht740_all_symbolic():
    mech = load_mechanism("ht740")
    return mech, state_space(mech, symbolic=True)


def test_ht740_every_mode_fully_symbolic_evaluates_to_numeric():
    """``--symbolic all`` finishes for the HT-740's 2-DOF modes and each of its matrices, evaluated
    at the mechanism's values, equals the numeric one."""
    mech, sym = _ht740_all_symbolic()
    num = state_space(mech)
    assert [m.dof for m in sym.modes] == [1, 1, 1, 1, 2, 2, 1]
    values = _numeric_values(mech)
    for s, n in zip(sym.modes, num.modes):
        for mat in ("B", "C", "D"):
            got = _at(getattr(s, mat), values) if getattr(s, mat).shape[1] else np.zeros(getattr(n, mat).shape)
            ind.assert_close(got, np.asarray(getattr(n, mat), dtype=float), what=f"ht740 {s.name} {mat}")


def test_structured_and_eliminated_symbolic_solutions_are_the_same_functions(seed=1):
    """The structured null-space route and the exact elimination give the same rational functions:
    compared at random parameter values (not only the mechanism's), for 1-DOF HT-740 modes where
    both are affordable."""
    from transgen.equations import _numeric_values as graph_values
    from transgen.equations import _sparse_exact_solve, _structured_solve, assemble

    mech = load_mechanism("ht740")
    g = build_graph(mech)
    rng = np.random.default_rng(seed)
    values = {k: v * rng.uniform(0.7, 1.4) for k, v in graph_values(g).items()}
    for mode in select_modes(mech)[:2]:
        eq = assemble(g, mode.locked, symbolic=True)
        a = _sparse_exact_solve(eq.E, eq.F)
        b = _structured_solve(eq.E, eq.F, eq.n_links, graph_values(g))
        at = {sympy.Symbol(k, positive=True): sympy.Rational(str(round(v, 9))) for k, v in values.items()}
        np.testing.assert_allclose(_at(b, at), _at(a, at), rtol=1e-12, atol=1e-12 * float(np.abs(_at(a, at)).max()))
