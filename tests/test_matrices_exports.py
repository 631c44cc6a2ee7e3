"""Matrices exports: every mode has A, B, C_speeds, D_torques and the stacked Cy = [C_speeds; 0],
Dy = [0; D_torques] that ``ss(A, B, Cy, Dy)`` accepts (checked with scipy.signal.StateSpace on
every bundled mechanism, outputs against the independent null-space solution), in the .mat,
.npz and JSON files with state, input and output names; LaTeX for more than 10 inputs."""
from __future__ import annotations

import json
import re
import shutil
import subprocess

import numpy as np
import pytest
import scipy.io
import scipy.signal

import independent as ind
from transgen import bundled_mechanisms, load_mechanism
from transgen.cli import main
from transgen.export import matlab_name, state_space_latex
from transgen.statespace import MATRICES, state_space

BUNDLED = bundled_mechanisms()


def _chain(n: int, folder) -> str:
    """A mechanism of n clutches in a chain between input and output: n + 2 inputs."""
    lines = ['transmission "chain of clutches"'] + [f"link L{i} J=0.1" for i in range(n + 1)]
    lines += [f"clutch C{i} L{i - 1} L{i} static=100 dynamic=80" for i in range(1, n + 1)]
    lines += ["input L0", f"output L{n}", "gear 1 = " + " ".join(f"C{i}" for i in range(1, n + 1)) + " ratio=1",
              "neutral N = " + " ".join(f"C{i}" for i in range(2, n + 1))]
    path = folder / "chain.mech"
    path.write_text("\n".join(lines) + "\n")
    return str(path)


@pytest.mark.parametrize("name", sorted(BUNDLED))
def test_stacked_outputs_make_a_state_space_system(name):
    mech = load_mechanism(BUNDLED[name])
    ss = state_space(mech)
    links = list(mech.link_names)
    rng = np.random.default_rng(7)
    for md in ss.modes:
        n, m = md.dof, len(md.inputs)
        n_out = len(md.speed_outputs) + len(md.torque_outputs)
        assert md.A.shape == (n, n) and np.asarray(md.B).shape == (n, m)
        assert md.Cy.shape == (n_out, n) and md.Dy.shape == (n_out, m)
        assert md.outputs == tuple(f"w_{k}" for k in links) + md.torque_outputs
        sys = scipy.signal.StateSpace(md.A, md.B, md.Cy, md.Dy)   # what ss(A, B, Cy, Dy) takes
        assert (sys.A.shape, sys.B.shape, sys.C.shape, sys.D.shape) == ((n, n), (n, m), (n_out, n), (n_out, m))
        # y = Cy x + Dy u: every link speed, then the locked torques, by the null-space method
        ref = ind.dynamics(mech, tuple(grp[0] for grp in md.locked_groups), md.inputs)
        rows = [links.index(s) for s in md.states]
        others = [md.inputs.index(f"t_{e}") for grp in md.locked_groups for e in grp[1:]]
        q = rng.normal(size=ref.dof) * 50
        u = rng.normal(size=m) * 100
        u[others] = 0.0                                           # parallel members: no own torque input
        w = ref.N @ q
        y = sys.C @ w[rows] + sys.D @ u
        scale = 1 + np.abs(w).max() + np.abs(ref.torques @ u).max(initial=0)
        np.testing.assert_allclose(y, np.r_[w, ref.torques @ u], atol=1e-9 * scale)
        # and the state equation: dx/dt = A x + B u is the coordinates' acceleration
        np.testing.assert_allclose(sys.A @ w[rows] + sys.B @ u, ref.alpha[rows] @ u, atol=1e-9 * scale)


def test_mat_npz_and_json_hold_every_matrix_with_names(tmp_path, capsys):
    ss = state_space(load_mechanism(BUNDLED["ht740"]), ["L1", "L6"])
    for suffix in ("mat", "npz", "json"):
        assert main(["matrices", "ht740", "--coords", "L1,L6", "-o", str(tmp_path / f"m.{suffix}")]) == 0
    mat = scipy.io.loadmat(tmp_path / "m.mat", squeeze_me=True, struct_as_record=False)
    npz = np.load(tmp_path / "m.npz")
    doc = json.loads((tmp_path / "m.json").read_text())
    meta = json.loads(str(npz["meta"]))
    assert doc["schema"] == meta["schema"] == "transgen.matrices/1"
    for md, d, d_meta in zip(ss.modes, doc["modes"], meta["modes"]):
        s = mat[matlab_name(md.name)]
        for key in MATRICES:
            expected = np.asarray(getattr(md, key), dtype=float)
            np.testing.assert_array_equal(np.reshape(getattr(s, key), expected.shape), expected)
            np.testing.assert_array_equal(npz[f"{matlab_name(md.name)}_{key}"], expected)
            np.testing.assert_array_equal(np.reshape(d[key], expected.shape), expected)
        for names, key in ((md.states, "states"), (md.inputs, "inputs"), (md.outputs, "outputs")):
            assert list(np.atleast_1d(getattr(s, key))) == list(names) == d[key] == d_meta[key]
        assert np.reshape(s.Cy, (-1, md.dof)).shape == (len(md.outputs), md.dof)
        assert np.reshape(s.Dy, (len(md.outputs), -1)).shape == (len(md.outputs), len(md.inputs))
    assert list(mat["inputs"]) == list(ss.inputs) and list(mat["modes"]) == [m.name for m in ss.modes]


def test_symbolic_json_has_the_stacked_matrices_as_expressions(capsys):
    assert main(["matrices", "simple2", "--symbolic"]) == 0
    m1 = json.loads(capsys.readouterr().out)["modes"][0]
    n_out = len(m1["outputs"])
    assert len(m1["Cy"]) == n_out and all(len(r) == m1["dof"] for r in m1["Cy"])
    assert len(m1["Dy"]) == n_out and all(len(r) == len(m1["inputs"]) for r in m1["Dy"])
    assert m1["Cy"][:len(m1["speed_outputs"])] == m1["C_speeds"]
    assert m1["Dy"][len(m1["speed_outputs"]):] == m1["D_torques"]
    assert {v for r in m1["Dy"][:len(m1["speed_outputs"])] for v in r} == {"0"}


def _arrays(tex: str):
    """(column specifier, body) of every array environment (they are not nested)."""
    return re.findall(r"\\begin\{array\}\{(c+)\}(.*?)\\end\{array\}", tex, flags=re.S)


@pytest.mark.parametrize("symbolic", [False, True])
def test_latex_takes_more_than_ten_inputs(symbolic, tmp_path):
    mech = load_mechanism(_chain(11, tmp_path))
    ss = state_space(mech, symbolic=symbolic)
    assert len(ss.inputs) == 13
    tex = state_space_latex(ss)
    # amsmath's matrix environments stop at MaxMatrixCols = 10 columns: only arrays are used
    assert not re.search(r"\\begin\{[pbvBV]?matrix\}", tex)
    arrays = _arrays(tex)
    assert arrays and max(len(spec) for spec, _ in arrays) == 13
    for spec, body in arrays:
        for row in body.split(r"\\"):
            assert row.count("&") + 1 == len(spec), (spec, row)
    assert tex.count(r"\begin{array}") == tex.count(r"\end{array}") == len(arrays)
    assert tex.count(r"\left(") == tex.count(r"\right)")
    assert tex.count(r"\begin{align*}") == tex.count(r"\end{align*}") == len(ss.modes)


@pytest.mark.skipif(not shutil.which("pdflatex"), reason="no LaTeX engine on this machine")
def test_latex_compiles_for_more_than_ten_inputs(tmp_path):
    out = tmp_path / "m.tex"
    assert main(["matrices", _chain(11, tmp_path), "-o", str(out)]) == 0
    doc = tmp_path / "doc.tex"
    doc.write_text("\\documentclass{article}\\usepackage{amsmath}\\begin{document}\\input{m.tex}\\end{document}\n")
    run = subprocess.run(["pdflatex", "-interaction=nonstopmode", "-halt-on-error", doc.name], cwd=tmp_path,
                         capture_output=True, text=True, timeout=120)
    assert run.returncode == 0, run.stdout[-2000:]
