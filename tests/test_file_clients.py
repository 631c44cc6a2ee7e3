"""The files transgen writes, read by the tools engineers open them with (issue 22): pandas
(default settings), python-control, GNU Octave (when installed; skipped otherwise) and a JSON
Schema validator that has only the shipped schema files (no registry, no network)."""
from __future__ import annotations

import json
import shutil
import subprocess
from pathlib import Path
from urllib.parse import urljoin

import numpy as np
import pytest
import scipy.io

from transgen.cli import main
from transgen.export import field_names, matlab_name, output_format
from transgen.schemas import SCHEMA_DIR
from transgen.sim.analysis.result_files import csv_float


@pytest.fixture(scope="module")
def ht740_tc(tmp_path_factory):
    """The matrices of ht740_tc (declared modes named 1, 1L, SP, ...) in every format."""
    folder = tmp_path_factory.mktemp("matrices")
    for suffix in ("mat", "npz", "json"):
        assert main(["matrices", "ht740_tc", "-o", str(folder / f"m.{suffix}")]) == 0
    return folder


# ------------------------------------------------------------------------------------ names
def test_field_names_are_identifiers_unique_and_kept_where_they_are_one():
    names = ["1", "1L", "SP", "C1+C4", "C1_C4", "none", "é", "x" * 80]
    fields = field_names(names)
    assert fields[:6] == ["m_1", "m_1L", "SP", "C1_C4", "C1_C4_2", "none"]
    assert len(set(fields)) == len(fields)
    assert all(f.isascii() and f[0].isalpha() and len(f) <= 63 and f.replace("_", "").isalnum() for f in fields)
    assert matlab_name("w_L1") == "w_L1"


def test_mat_carries_the_names_their_fields_and_the_json_metadata(ht740_tc):
    m = scipy.io.loadmat(ht740_tc / "m.mat", simplify_cells=True)
    doc = json.loads((ht740_tc / "m.json").read_text(encoding="utf-8"))
    names = [d["name"] for d in doc["modes"]]
    assert list(m["modes"]) == names and "1" in names and "1L" in names
    assert list(m["fields"]) == field_names(names)
    for name, field, d in zip(m["modes"], m["fields"], doc["modes"]):
        mode = m[field]  # M.(M.fields{k}) in MATLAB/Octave is the mode M.modes{k}
        assert mode["name"] == name and mode["field"] == field
        assert isinstance(mode["dof"], float) and mode["dof"] == d["dof"]  # a double, as MATLAB computes with
        np.testing.assert_allclose(np.atleast_2d(mode["B"]).reshape(np.shape(d["B"])), d["B"])
    assert m["schema"] == doc["schema"] and m["units"] == doc["units"]
    assert m["transgen_version"] == doc["transgen_version"] and "skipped" in m


def test_npz_keys_are_the_fields_and_meta_maps_them(ht740_tc):
    data = np.load(ht740_tc / "m.npz")
    meta = json.loads(str(data["meta"]))
    assert meta["fields"]["1L"] == "m_1L" and [d["field"] for d in meta["modes"]] == list(meta["fields"].values())
    for field in meta["fields"].values():
        assert f"{field}_Cy" in data.files


def test_format_and_suffix_must_agree(tmp_path, capsys):
    assert output_format("x.npz") == "npz" and output_format("x.dat", "mat") == "mat"
    with pytest.raises(ValueError, match="the name says npz"):
        output_format("x.npz", "mat")
    assert main(["matrices", "simple2", "--format", "mat", "-o", str(tmp_path / "x.npz")]) == 2
    assert "name the file .mat" in capsys.readouterr().err and not list(tmp_path.iterdir())


# ------------------------------------------------------------------------------------ pandas
def test_csv_floats_are_floats():
    assert [csv_float(x) for x in (0.0, 12.0, -3.0, 1.5, 1e20, float("nan"))] == \
        ["0.0", "12.0", "-3.0", "1.5", "1e+20", "nan"]


def test_pandas_reads_float_columns_as_float_and_the_mode_as_text(tmp_path):
    pd = pytest.importorskip("pandas")
    out = tmp_path / "r.csv"
    assert main(["simulate", "simple2_upshift", "--set", "simulation.t_end=4.5", "--quiet", "-o", str(out)]) == 0
    df = pd.read_csv(out)  # default settings
    assert pd.api.types.is_string_dtype(df["mode"]) and all(isinstance(v, str) for v in df["mode"])
    numeric = [c for c in df.columns if c != "mode"]
    assert all(df[c].dtype == np.float64 for c in numeric), {c: df[c].dtype for c in numeric}
    zeros = [c for c in numeric if (df[c] == 0).all()]
    assert zeros  # C2's torque while it is open: written 0.0, read as float
    assert "0.0" in out.read_text(encoding="utf-8").splitlines()[1].split(",")


def test_a_run_in_a_mode_named_1_gives_a_text_mode_column(tmp_path):
    pd = pytest.importorskip("pandas")
    from transgen.sim.core.result import Result
    from transgen.sim.analysis.result_files import write_result

    result = Result(np.array([0.0, 1.0]), {"mode": np.array([1.0, 1.0]), "t_C1": np.zeros(2)}, {"t_C1": "N*m"},
                    [], [], True, "", meta={"mode_names": ["1"]})
    write_result(result, tmp_path / "r.csv")
    write_result(result, tmp_path / "r.mat")
    df = pd.read_csv(tmp_path / "r.csv")
    assert pd.api.types.is_string_dtype(df["mode"]) and df["mode"].tolist() == ["mode 1", "mode 1"]  # no gear given
    assert df["t_C1 [N*m]"].dtype == np.float64
    m = scipy.io.loadmat(tmp_path / "r.mat", simplify_cells=True)
    assert list(np.atleast_1d(m["mode_names"])) == ["1"] and list(np.atleast_1d(m["mode_fields"])) == ["m_1"]


# ------------------------------------------------------------------------------------ python-control
def test_python_control_builds_every_mode_and_lsim_matches_scipy(ht740_tc):
    control = pytest.importorskip("control")
    from scipy.signal import lsim

    m = scipy.io.loadmat(ht740_tc / "m.mat", simplify_cells=True)
    for field in m["fields"]:
        mode = m[field]
        A, B, Cy, Dy = (np.atleast_2d(np.asarray(mode[k], dtype=float)) for k in ("A", "B", "Cy", "Dy"))
        n, k = len(np.atleast_1d(mode["states"])), len(np.atleast_1d(mode["inputs"]))
        A, B = A.reshape(n, n), B.reshape(n, k)
        Cy, Dy = Cy.reshape(-1, n), Dy.reshape(-1, k)
        sys = control.ss(A, B, Cy, Dy)
        t = np.linspace(0.0, 1.0, 51)
        u = np.vstack([np.sin(3 * t + i) for i in range(k)])
        y = control.forced_response(sys, t, u).outputs
        _, y_ref, _ = lsim((A, B, Cy, Dy), u.T, t)
        np.testing.assert_allclose(np.atleast_2d(y), np.atleast_2d(y_ref.T), rtol=1e-9, atol=1e-9)


# ------------------------------------------------------------------------------------ Octave
@pytest.mark.skipif(shutil.which("octave-cli") is None and shutil.which("octave") is None,
                    reason="GNU Octave is not installed")
def test_octave_loads_modes_by_their_fields(ht740_tc):
    octave = shutil.which("octave-cli") or shutil.which("octave")
    script = ("M = load('m.mat'); for k = 1:numel(M.modes), m = M.(M.fields{k}); "
              "assert(strcmp(m.name, M.modes{k})); assert(isa(m.dof, 'double')); "
              "assert(all(size(m.Cy) == [numel(m.outputs), numel(m.states)])); end; disp(numel(M.modes))")
    out = subprocess.run([octave, "--no-gui", "--quiet", "--eval", script], cwd=ht740_tc, capture_output=True,
                         text=True, timeout=120)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == str(len(json.loads((ht740_tc / "m.json").read_text())["modes"]))


# ------------------------------------------------------------------------------------ JSON Schema
def _offline_validator(schema_file: Path):
    """A validator that knows nothing but the files: the schema is read at its file URI and each
    ``$ref`` is resolved against it and read from the folder (no registry, no network)."""
    import jsonschema
    from referencing import Registry, Resource

    base = schema_file.resolve().as_uri()

    def retrieve(uri: str):
        target = Path(urljoin(base, uri).removeprefix("file://"))
        assert target.parent == SCHEMA_DIR, f"a $ref outside the shipped schemas: {uri}"
        return Resource.from_contents(json.loads(target.read_text(encoding="utf-8")))

    registry = Registry(retrieve=retrieve)
    return jsonschema.Draft202012Validator({"$ref": base}, registry=registry)


def test_every_schema_refers_only_by_relative_file_names():
    for path in SCHEMA_DIR.glob("*.json"):
        text = path.read_text(encoding="utf-8")
        assert "urn:" not in text, path.name
        schema = json.loads(text)
        assert schema["$id"] == path.name


def test_documents_validate_with_only_the_schema_files(ht740_tc, tmp_path):
    doc = json.loads((ht740_tc / "m.json").read_text(encoding="utf-8"))
    validator = _offline_validator(SCHEMA_DIR / "matrices.json")
    validator.validate(doc)
    bad = dict(doc)
    del bad["transgen_version"]  # required by document.json: the $ref was followed
    assert not validator.is_valid(bad)
    out = tmp_path / "r.json"
    assert main(["simulate", "simple2_upshift", "--set", "simulation.t_end=4.2", "--quiet", "-o", str(out)]) == 0
    _offline_validator(SCHEMA_DIR / "signals.json").validate(json.loads(out.read_text(encoding="utf-8")))
