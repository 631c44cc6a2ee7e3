"""``transgen simulate -o FILE``: the format by suffix (CSV, MATLAB .mat, NumPy .npz, JSON), the same
columns in each (time, mode name, signals with units), unique time stamps on request, unknown
suffixes refused before the run."""
from __future__ import annotations

import csv
import json

import numpy as np
import pytest
import scipy.io

from transgen.cli import main
from transgen.describe import modes_report
from transgen.language import load_mechanism
from transgen.sim.analysis.result_files import csv_mode_text, result_columns, write_result
from transgen.sim.scenario.load import Scenario, load_scenario

NAME = "simple2_upshift"


@pytest.fixture(scope="module")
def run():
    scenario = load_scenario(NAME)
    return scenario, scenario.run()


def _csv(path):
    with open(path, newline="") as f:
        rows = list(csv.reader(f))
    return rows[0], rows[1:]


def test_csv_header_has_units_and_the_mode_column(run, tmp_path):
    _, result = run
    out = tmp_path / "r.csv"
    assert main(["simulate", NAME, "--quiet", "-o", str(out)]) == 0
    header, rows = _csv(out)
    assert header[:2] == ["time [s]", "mode"]
    assert "w_Li [rad/s]" in header and "t_C1 [N*m]" in header and "apply_C1 [1]" in header
    assert "T_out [N*m]" in header and "E_dissipated [J]" in header
    names = [h.split(" [")[0] for h in header]
    assert names.count("mode") == 1 and len(rows) == len(result.time)
    for h in header[2:]:
        name, unit = h[:-1].split(" [")
        assert unit == result.units[name] and unit
    # the values: time with every digit, the signals with 9 significant digits
    assert np.array_equal([float(r[0]) for r in rows], result.time)
    col = names.index("w_Li")
    np.testing.assert_allclose([float(r[col]) for r in rows], result["w_Li"], rtol=1e-8, atol=1e-12)


def test_mode_column_names_the_modes_as_transgen_modes_does(run, tmp_path):
    scenario, result = run
    out = tmp_path / "r.csv"
    assert main(["simulate", NAME, "--quiet", "-o", str(out)]) == 0
    header, rows = _csv(out)
    modes = [r[1] for r in rows]
    # named by gear (transgen.names); each joins a mode of `transgen modes` by its locked set and gear
    known = {frozenset(m["locked"]): m for m in modes_report(load_mechanism(scenario.mechanism.source))["modes"]}
    # the CSV's mode column holds each mode's name, a name that a reader takes for a number written
    # with its gear (csv_mode_text: "gear 1"), the other formats the names themselves
    field = {s.name: csv_mode_text(s.name, s.gear) for s in result.modes}
    assert set(modes) == {field["1"], field["none"], field["2"]} == {"gear 1", "none", "gear 2"}
    for span in result.modes:
        assert known[frozenset(span.locked)]["gear"] == span.gear
        assert span.name == (span.gear or "+".join(span.locked) or "none")
    for span in result.modes:                                     # inside each span: its name
        inside = [m for t, m in zip(result.time, modes) if span.t0 < t < span.t1]
        assert inside and set(inside) == {field[span.name]}
    assert modes[0] == field[result.modes[0].name] and modes[-1] == field[result.modes[-1].name]


def test_every_format_holds_the_same_columns(run, tmp_path):
    _, result = run
    files = {s: tmp_path / f"r.{s}" for s in ("csv", "mat", "npz", "json")}
    for path in files.values():
        assert main(["simulate", NAME, "--quiet", "-o", str(path)]) == 0
    header, rows = _csv(files["csv"])
    names = [h.split(" [")[0] for h in header]
    units = [h[:-1].split(" [")[1] if " [" in h else "" for h in header]
    columns, _ = result_columns(result)
    assert list(columns) == names

    mat = scipy.io.loadmat(files["mat"], squeeze_me=True)
    assert list(mat["names"]) == names
    assert [u if isinstance(u, str) else "" for u in mat["units"]] == units    # MATLAB's '' is an empty array
    gears = [g if isinstance(g, str) else "" for g in mat["mode_gears"]]
    field = {m: csv_mode_text(m, g) for m, g in zip(mat["mode_names"], gears)}  # the CSV's text of each name
    csv_modes = [r[1] for r in rows]
    assert list(mat["mode_names"]) == ["1", "none", "2"] and [field[m] for m in mat["mode"]] == csv_modes
    assert [g if isinstance(g, str) else "" for g in mat["mode_gears"]] == ["1", "", "2"]
    assert [x if isinstance(x, str) else "" for x in mat["mode_locked"]] == ["C1", "none", "C2"]
    npz = np.load(files["npz"])
    assert list(npz["names"]) == names and list(npz["units"]) == units and [field[m] for m in npz["mode"]] == csv_modes
    doc = json.loads(files["json"].read_text())
    assert doc["names"] == names and doc["units"] == {n: u for n, u in zip(names, units) if n != "mode"}
    assert [field[m] for m in doc["columns"]["mode"]] == csv_modes and doc["mode_names"] == list(mat["mode_names"])
    for n in names[2:] + ["time"]:
        np.testing.assert_array_equal(mat[n], columns[n])
        np.testing.assert_array_equal(npz[n], columns[n])
        np.testing.assert_array_equal(doc["columns"][n], columns[n])


def test_unique_times_keep_the_row_after_each_event(run, tmp_path):
    _, result = run
    t = result.time
    repeated = t[1:][np.diff(t) == 0]
    assert len(repeated) >= 2                                     # the events and the signal steps
    out = tmp_path / "u.npz"
    assert main(["simulate", NAME, "--quiet", "--unique-times", "-o", str(out)]) == 0
    u = np.load(out)
    assert np.all(np.diff(u["time"]) > 0) and len(u["time"]) == len(np.unique(t))
    for event in (e for e in result.events if e.kind != "start"):
        last = np.flatnonzero(t == event.t)[-1]                   # the state after the event
        kept = np.flatnonzero(u["time"] == event.t)
        assert len(kept) == 1 and u["mode"][kept[0]] == event.target
        for n in ("w_Li", "t_C1", "t_C2", "locked_C2"):
            assert u[n][kept[0]] == result[n][last]


def test_unique_times_serve_pandas_reindexing_and_interpolation(tmp_path):
    pandas = pytest.importorskip("pandas")
    from scipy.interpolate import interp1d

    both = tmp_path / "d.csv"
    once = tmp_path / "u.csv"
    assert main(["simulate", NAME, "--quiet", "-o", str(both)]) == 0
    assert main(["simulate", NAME, "--quiet", "--unique-times", "-o", str(once)]) == 0
    grid = np.linspace(4.0, 6.0, 201)
    with pytest.raises(ValueError):                               # duplicates: reindexing refused
        pandas.read_csv(both, index_col="time [s]").reindex(grid)
    df = pandas.read_csv(once, index_col="time [s]")
    assert df.index.is_unique and df.index.is_monotonic_increasing
    w = df["w_Li [rad/s]"]
    resampled = w.reindex(w.index.union(grid)).interpolate("index").loc[grid]
    f = interp1d(df.index.to_numpy(), w.to_numpy(), assume_sorted=True)   # as MATLAB interp1
    np.testing.assert_allclose(resampled.to_numpy(), f(grid), rtol=1e-12)


@pytest.mark.parametrize("name", ["r.txt", "r.xlsx", "r", "r.csv.gz"])
def test_other_suffixes_are_refused_before_the_run(name, tmp_path, capsys, monkeypatch):
    def no_run(*args, **kwargs):
        raise AssertionError("the scenario ran")

    monkeypatch.setattr(Scenario, "run", no_run)
    out = tmp_path / name
    assert main(["simulate", NAME, "--quiet", "-o", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.startswith("error: unknown result file format") and ".csv, .mat, .npz, .json" in err
    assert list(tmp_path.iterdir()) == []


def test_a_failing_mat_write_leaves_nothing(tmp_path, monkeypatch):
    def broken(*args, **kwargs):
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(scipy.io, "savemat", broken)
    assert main(["simulate", NAME, "--quiet", "-o", str(tmp_path / "r.mat")]) == 1
    assert list(tmp_path.iterdir()) == []


def test_save_in_the_python_api_with_chosen_signals(run, tmp_path):
    _, result = run
    write_result(result, tmp_path / "r.csv", ["w_Li", "mode", "T_out"], unique_times=True)
    header, rows = _csv(tmp_path / "r.csv")
    assert header == ["time [s]", "mode", "w_Li [rad/s]", "T_out [N*m]"]
    assert len(rows) == len(np.unique(result.time))


def test_unique_times_without_a_result_file_is_refused(capsys):
    assert main(["simulate", NAME, "--quiet", "--unique-times"]) == 2
    assert capsys.readouterr().err.startswith("error: --unique-times applies to the result file")


@pytest.mark.parametrize("name", sorted(__import__("transgen.sim.scenario.library", fromlist=["x"]).bundled_scenarios()))
def test_every_signal_of_the_bundled_scenarios_is_a_matlab_name(name):
    """In the .mat file the columns are variables by their own names (R.w_L1), none renamed."""
    import re

    from transgen.sim.scenario.load import output_signals

    names = output_signals(load_scenario(name).powertrain)
    assert all(re.fullmatch(r"[A-Za-z][A-Za-z0-9_]{0,62}", n) for n in ["time", "mode", *names]), names
