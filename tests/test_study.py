"""Parameter studies (transgen.sim.study, ``transgen sweep``): designs, the result table and its
CSV, failed runs as rows, resume after a kill, and the same numbers serially, in a local process
pool and on a real Dask cluster started here."""
from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest

from transgen.errors import ScenarioError, SimulationError
from transgen.schemas import validate
from transgen.sim.study import (LocalExecutor, SerialExecutor, SweepTable, full_grid, latin_hypercube, row_key,
                                sweep)
from transgen.sim.study.cli import parse_grid
from transgen.sim.study.design import linspace_values
from transgen.sim.study.task import run_variant

SCENARIO = "ht740_improved"
# the 1-2 shift starts at 4 s: 4.6 s covers it and keeps each run near 0.3 s
GRID = {"simulation.t_end": [4.6], "driveline.vehicle_mass": [20000, 36000], "input.throttle_signal": [0.6, 0.8]}
TRANSGEN = [sys.executable, "-m", "transgen"]  # run with cwd=tmp_path: never from a source checkout


def _numbers(table: SweepTable) -> list[list]:
    """Every cell but the wall time (the only column that may differ between executors)."""
    columns = [c for c in table.columns if c != "wall_time"]
    return [[row.get(c) for c in columns] for row in table.rows]


@pytest.fixture(scope="module")
def serial() -> SweepTable:
    return sweep(SCENARIO, GRID, executor=SerialExecutor())


# ------------------------------------------------------------------------------------ designs
def test_full_grid_is_every_combination_first_key_slowest():
    variants = full_grid({"a": [1, 2], "b": ["x", "y", "z"]})
    assert len(variants) == 6
    assert variants[:3] == [{"a": 1, "b": "x"}, {"a": 1, "b": "y"}, {"a": 1, "b": "z"}]
    with pytest.raises(ValueError, match="no values"):
        full_grid({"a": []})


def test_latin_hypercube_hits_every_stratum_once_and_is_reproducible():
    n = 16
    variants = latin_hypercube({"m": (20000.0, 36000.0), "z": (40, 80)}, n, seed=3)
    assert variants == latin_hypercube({"m": (20000.0, 36000.0), "z": (40, 80)}, n, seed=3)
    assert variants != latin_hypercube({"m": (20000.0, 36000.0), "z": (40, 80)}, n, seed=4)
    strata = sorted(int((v["m"] - 20000.0) / 16000.0 * n) for v in variants)
    assert strata == list(range(n))
    assert all(isinstance(v["z"], int) and 40 <= v["z"] <= 80 for v in variants)  # integer bounds: integers
    with pytest.raises(ValueError, match="empty"):
        latin_hypercube({"m": (2.0, 1.0)}, 4)


def test_sampled_design_fixes_single_values_and_refuses_lists():
    from transgen.sim.study.runner import design_variants

    variants = design_variants({"simulation.t_end": [6.0], "driveline.vehicle_mass": (20000.0, 36000.0)}, 4, seed=2)
    assert [v["simulation.t_end"] for v in variants] == [6.0] * 4
    assert [v["driveline.vehicle_mass"] for v in variants] == \
        [v["m"] for v in latin_hypercube({"m": (20000.0, 36000.0)}, 4, seed=2)]
    with pytest.raises(ValueError, match="a sampled parameter is a range"):
        design_variants({"a.b": [1, 2]}, 4)
    with pytest.raises(ValueError, match="the name of a result column"):
        design_variants({"shift1.torque_hole": [1]})  # an old table's column
    with pytest.raises(ValueError, match="the name of a result column"):
        design_variants({"shift.1-2.torque_hole": [1]})


def test_linspace_is_inclusive_and_keeps_whole_numbers():
    assert linspace_values(20000, 36000, 3) == [20000, 28000, 36000]
    assert linspace_values(0.6, 0.8, 3) == pytest.approx([0.6, 0.7, 0.8])
    assert isinstance(linspace_values(0, 1, 3)[1], float)


def test_row_key_is_a_hash_of_the_parameters():
    assert row_key("s", {"a": 1, "b": 2.5}) == row_key("s", {"b": 2.5, "a": 1})
    assert row_key("s", {"a": 1}) != row_key("t", {"a": 1})
    assert row_key("s", {"a": 20000}) != row_key("s", {"a": 20000.0})  # different TOML values
    assert len(row_key("s", {"a": [1, 2]})) == 16


def test_grid_options():
    assert parse_grid("driveline.vehicle_mass=20000,36000") == ("driveline.vehicle_mass", [20000, 36000])
    assert parse_grid("input.throttle_signal=0.6:0.8:3")[1] == pytest.approx([0.6, 0.7, 0.8])
    assert parse_grid("input.throttle_signal=0.5:0.9", sampled=True) == ("input.throttle_signal", (0.5, 0.9))
    key, values = parse_grid('elements.C4.apply={ type = "ramp", t0 = 4.0, t1 = 5.0, v0 = 0, v1 = 1 },0.5')
    assert values == [{"type": "ramp", "t0": 4.0, "t1": 5.0, "v0": 0, "v1": 1}, 0.5]
    assert parse_grid("x.model=compliant,switching")[1] == ["compliant", "switching"]
    for bad, message in (("novalue", "expected KEY="), ("a.b=1:2", "needs the number of values"),
                         ("a.b=nan", "finite"), ("a.b=1,2", None)):
        if message is None:
            with pytest.raises(ScenarioError, match="a parameter is a range LO:HI"):
                parse_grid(bad, sampled=True)
        else:
            with pytest.raises(ScenarioError, match=message):
                parse_grid(bad)


# ------------------------------------------------------------------------------------ the table
def test_csv_round_trip_is_exact(tmp_path):
    rows = [{"key": "0123", "p": 0.1 + 0.2, "q": "a,b\nc", "success": True, "message": "12", "wall_time": 1e-300,
             "shift1.flare_time": None, "shift1.x": -3},
            {"key": "ab", "p": 1, "q": [1, 2], "success": False, "message": "boom", "wall_time": 2.0}]
    table = SweepTable(rows, ["p", "q"])
    back = SweepTable.from_csv(table.to_csv(tmp_path / "t.csv"))
    assert back.parameters == ["p", "q"] and back.columns == table.columns
    assert back.rows[0] == rows[0]  # the key and the message stay text
    assert back.rows[1]["q"] == "[1, 2]" and back.rows[1]["success"] is False
    (tmp_path / "bad.csv").write_text("a,b\n1,2\n")
    with pytest.raises(ValueError, match="bad.csv:1:1: error: not a sweep results file"):
        SweepTable.from_csv(tmp_path / "bad.csv")


def test_rows_have_parameters_energy_and_every_shift_scalar(serial):
    assert len(serial) == 4 and not serial.failed
    columns = serial.columns
    assert columns[:7] == ["key", *GRID, "success", "message", "wall_time"]
    assert serial["driveline.vehicle_mass"] == [20000, 20000, 36000, 36000]
    from transgen.sim.analysis.shift_quality import ShiftQuality

    scalars = [f for f, t in ShiftQuality.__annotations__.items() if "dict" not in str(t) and "tuple" not in str(t)]
    assert all(f"shift.1-2.{f}" in columns for f in scalars), [f for f in scalars if f"shift.1-2.{f}" not in columns]
    assert "shift.1-2.energy.C4" in columns and "shift.1-2.peak_power.C4" in columns
    assert all(serial["energy.passed"]) and "energy.residual" in columns
    assert serial.units()["shift.1-2.torque_hole"] == "N*m" and serial.units()["shift.1-2.energy.C4"] == "J"
    light, heavy = serial.rows[0], serial.rows[2]
    assert heavy["shift.1-2.energy_total"] != light["shift.1-2.energy_total"]


def test_to_pandas(serial):
    pytest.importorskip("pandas")
    frame = serial.to_pandas()
    assert list(frame.columns) == serial.columns and len(frame) == 4
    assert frame["shift.1-2.torque_hole"].tolist() == serial["shift.1-2.torque_hole"]


def test_a_failed_run_is_a_row_with_its_message(monkeypatch):
    row = run_variant(SCENARIO, {"simulation.t_end": 4.6, "simulation.energy_tol": 1e-30})
    assert row["success"] is False and "invariant 'energy_balance' violated" in row["message"]
    assert row["wall_time"] > 0 and "energy.work_in" in row
    from transgen.sim.scenario.load import Scenario

    for exc, text in ((SimulationError("t=1 s: stuck"), "t=1 s: stuck"), (ZeroDivisionError("x"), "ZeroDivisionError: x")):
        def run(self, progress=None, exc=exc):
            raise exc
        monkeypatch.setattr(Scenario, "run", run)
        assert run_variant(SCENARIO, {"simulation.t_end": 4.6}) == {"success": False, "message": text,
                                                                    "wall_time": pytest.approx(0.5, abs=10)}
    monkeypatch.undo()
    table = sweep(SCENARIO, {"simulation.t_end": [4.6], "simulation.energy_tol": [1e-30, 1e-3]},
                  executor=SerialExecutor())
    assert [r["success"] for r in table.rows] == [False, True]


def test_bad_keys_and_values_stop_before_any_run(tmp_path):
    out = tmp_path / "r.csv"
    with pytest.raises(ScenarioError, match="did you mean 'driveline.vehicle_mass'"):
        sweep(SCENARIO, {"driveline.vehicle_mas": [1]}, executor=SerialExecutor(), results=out)
    with pytest.raises(ScenarioError, match="vehicle_mass"):
        sweep(SCENARIO, {"driveline.vehicle_mass": [20000, -1]}, executor=SerialExecutor(), results=out)
    assert not out.exists()


def test_validation_loads_each_value_within_a_run_of_the_design():
    from transgen.sim.study.runner import scenario_path, validate_variants

    path = scenario_path(SCENARIO)
    # t_start = 25 s is valid with t_end = 30 s, not with the file's t_end = 20 s
    files = validate_variants(path, full_grid({"simulation.t_start": [25.0], "simulation.t_end": [30.0, 40.0]}))
    assert path in files and any(f.endswith("ht740.mech") for f in files)
    with pytest.raises(ScenarioError, match="t_end"):
        validate_variants(path, full_grid({"simulation.t_start": [25.0]}))


# ------------------------------------------------------------------------------------ executors
def test_local_process_pool_gives_the_same_numbers(serial):
    pooled = sweep(SCENARIO, GRID, executor=LocalExecutor(2))
    assert _numbers(pooled) == _numbers(serial)


def test_a_sweep_on_an_open_pool_leaves_it_open_and_a_bad_design_stops_the_pool_it_started(serial):
    with LocalExecutor(2) as executor:
        pool = executor._pool
        first = sweep(SCENARIO, GRID, executor=executor)
        assert executor._pool is pool  # the caller's pool: used, not stopped
        second = sweep(SCENARIO, GRID, executor=executor)
    assert executor._pool is None and _numbers(first) == _numbers(second) == _numbers(serial)
    executor = LocalExecutor(2)
    with pytest.raises(ScenarioError, match="did you mean 'driveline.vehicle_mass'"):
        sweep(SCENARIO, {"driveline.vehicle_mas": [1]}, executor=executor)  # found while its workers start
    assert executor._pool is None


# a script that has simulated (warm), then sweeps on new pools one after the other and on a kept
# one; stdout is a pipe (block-buffered): a line written before the fork is still in its buffer
_WARM_SCRIPT = """
import atexit, json, sys
from transgen.sim import load_scenario
from transgen.sim.study import LocalExecutor, SerialExecutor, sweep

GRID = {"simulation.t_end": [0.8], "driveline.vehicle_mass": [20000, 36000], "input.throttle_signal": [0.6, 0.8]}


def numbers(table):
    return [[row.get(c) for c in table.columns if c != "wall_time"] for row in table.rows]


def main():
    atexit.register(print, "atexit handler")
    load_scenario("ht740_improved", {"simulation.t_end": 0.3}).run()
    serial = numbers(sweep("ht740_improved", GRID, executor=SerialExecutor()))
    sys.stdout.write("written before the fork\\n")
    methods, same = [], []
    for executor in (LocalExecutor(2), LocalExecutor(2)):
        same.append(numbers(sweep("ht740_improved", GRID, executor=executor)) == serial)
        methods.append(executor.start_method)
    with LocalExecutor(2) as executor:
        same.append(numbers(sweep("ht740_improved", GRID, executor=executor)) == serial)
        methods.append(executor.start_method)
    print(json.dumps({"methods": methods, "same": same}))


if __name__ == "__main__":
    main()
"""


def test_a_warm_process_forks_its_workers_and_they_give_the_same_numbers(tmp_path):
    """In a fresh interpreter (pytest's own threads, e.g. left by a Dask test, would make it spawn)."""
    (tmp_path / "warm.py").write_text(_WARM_SCRIPT)
    done = subprocess.run([sys.executable, "warm.py"], capture_output=True, text=True, timeout=300, cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    [result] = [line for line in done.stdout.splitlines() if line.startswith("{")]
    assert json.loads(result) == {"methods": ["fork"] * 3, "same": [True] * 3}
    # the children leave with os._exit: neither the parent's buffered output nor its atexit handlers again
    assert done.stdout.count("written before the fork") == 1 and done.stdout.count("atexit handler") == 1


def test_a_second_thread_makes_the_pool_spawn_its_workers(serial):
    release = threading.Event()
    thread = threading.Thread(target=release.wait)
    thread.start()
    try:
        executor = LocalExecutor(2)
        spawned = sweep(SCENARIO, GRID, executor=executor)
    finally:
        release.set()
        thread.join()
    assert executor.start_method == "spawn" and _numbers(spawned) == _numbers(serial)


def _start_method_of_a_cold_process(tmp_path, **env) -> list[str]:
    code = ("from transgen.sim.study import LocalExecutor\n"
            "executor = LocalExecutor(1)\n"
            "executor._new_pool().shutdown()\n"  # no task: no worker started
            "print(executor.start_method)")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120, cwd=tmp_path,
                          env={**os.environ, **env})
    assert done.returncode == 0, done.stderr
    return done.stdout.split()


def test_a_cold_process_spawns_its_workers_where_they_would_load_numba(tmp_path):
    empty = tmp_path / "no-kernels"  # the kernels built ahead of time not found: numba just in time
    assert _start_method_of_a_cold_process(tmp_path, TRANSGEN_KERNEL_CACHE=str(empty)) == ["spawn"]


def test_a_cold_process_forks_its_workers_where_the_kernels_are_built(tmp_path):
    pytest.importorskip("numba")
    from transgen.sim.core import aot
    from transgen.sim.core.jit import numba_clone

    if aot.build(numba_clone, wait=True) is None:
        pytest.skip("the kernels cannot be built here")
    env = {k: v for k, v in os.environ.items() if k != "TRANSGEN_JIT"}
    assert _start_method_of_a_cold_process(tmp_path, **env) == ["fork"]
    assert _start_method_of_a_cold_process(tmp_path, TRANSGEN_JIT="0",
                                           TRANSGEN_KERNEL_CACHE=str(tmp_path / "none")) == ["fork"]


def test_dask_cluster_gives_the_same_numbers(serial):
    distributed = pytest.importorskip("distributed")
    from transgen.sim.study import DaskExecutor

    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1",
                                  dashboard_address=None) as cluster:
        on_dask = sweep(SCENARIO, GRID, executor=DaskExecutor(cluster.scheduler_address))
        with distributed.Client(cluster) as client:
            assert len(client.scheduler_info()["workers"]) == 2
    assert _numbers(on_dask) == _numbers(serial)


# ------------------------------------------------------------------------------------ resume
def test_resume_keeps_finished_rows_and_runs_only_the_rest(tmp_path, serial):
    out = tmp_path / "r.csv"
    half = {**GRID, "driveline.vehicle_mass": [20000]}
    sweep(SCENARIO, half, executor=SerialExecutor(), results=out)
    first = SweepTable.from_csv(out)
    seen = []
    table = sweep(SCENARIO, GRID, executor=SerialExecutor(), results=out, progress=seen.append)
    assert seen[0].resumed == 2 and seen[-1].done == 4 and seen[-1].total == 4
    assert table.rows[:2] == first.rows  # not run again: the same wall time too
    assert _numbers(SweepTable.from_csv(out)) == _numbers(serial)


def test_cli_sweep_resumes_after_a_kill(tmp_path):
    out = tmp_path / "r.csv"
    grid = ["--grid", "simulation.t_end=4.6", "--grid", "driveline.vehicle_mass=20000:36000:3",
            "--grid", "input.throttle_signal=0.6,0.8"]
    proc = subprocess.Popen([*TRANSGEN, "sweep", SCENARIO, *grid, "--workers", "1", "-o", str(out)],
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, cwd=tmp_path)
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline and proc.poll() is None:
        if out.exists() and len(SweepTable.from_csv(out)) >= 2:
            break
        time.sleep(0.05)
    proc.send_signal(signal.SIGKILL)
    proc.wait()
    finished = SweepTable.from_csv(out)
    assert 2 <= len(finished) < 6
    done = subprocess.run([*TRANSGEN, "sweep", SCENARIO, *grid, "--workers", "1", "-o", str(out), "--json"],
                          capture_output=True, text=True, timeout=300, cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    summary = json.loads(done.stdout)
    assert summary["schema"] == "transgen.sweep/1" and summary["transgen_version"]
    assert summary["runs"] == 6 and summary["failed"] == 0 and summary["units"]["shift.1-2.torque_hole"] == "N*m"
    assert summary["resumed"] == len(finished) and summary["design"]["kind"] == "grid"
    numeric = {c for r in summary["rows"] for c, v in r.items() if isinstance(v, (int, float)) and not isinstance(v, bool)}
    assert numeric <= set(summary["units"]), sorted(numeric - set(summary["units"]))
    validate(summary)
    table = SweepTable.from_csv(out)
    assert len(table) == 6 and len({r["key"] for r in table.rows}) == 6
    before = {r["key"]: r["wall_time"] for r in finished.rows}
    assert all(r["wall_time"] == before[r["key"]] for r in table.rows if r["key"] in before)


def test_cli_bad_key_is_an_error_before_any_run(tmp_path):
    out = tmp_path / "r.csv"
    res = subprocess.run([*TRANSGEN, "sweep", SCENARIO, "--grid", "driveline.vehicle_mas=20000,36000", "-o", str(out)],
                         capture_output=True, text=True, timeout=120, cwd=tmp_path)
    assert res.returncode == 2 and res.stdout == ""
    assert res.stderr.startswith("--grid driveline.vehicle_mas: error: unknown key")
    assert "did you mean 'driveline.vehicle_mass'" in res.stderr and "Traceback" not in res.stderr
    assert not out.exists()


def test_cli_without_distributed_is_a_clear_error(tmp_path, monkeypatch):
    from transgen.cli import main
    from transgen.sim.study import executors

    def missing():
        raise ImportError(executors.DISTRIBUTED_MISSING)
    monkeypatch.setattr(executors, "_distributed", missing)
    assert main(["sweep", SCENARIO, "--grid", "driveline.vehicle_mass=1", "--scheduler", "tcp://127.0.0.1:8786",
                 "-o", str(tmp_path / "r.csv")]) == 2
    assert not (tmp_path / "r.csv").exists()


# ------------------------------------------------------------------------------------ plots
def test_plots_over_one_parameter_and_heat_maps_over_two(serial, tmp_path):
    os.environ.setdefault("MPLBACKEND", "Agg")
    from transgen.sim.study.plots import plot_heatmap, plot_metric, plot_sweep

    fig = plot_heatmap(serial, "shift.1-2.torque_hole", "driveline.vehicle_mass", "input.throttle_signal")
    image = fig.axes[0].images[0].get_array()
    assert image.shape == (2, 2) and image[0, 1] == serial.rows[2]["shift.1-2.torque_hole"]
    fig = plot_metric(serial, "shift.1-2.energy_total", "driveline.vehicle_mass")
    assert len(fig.axes[0].lines) == 2  # one line per throttle
    written = plot_sweep(serial, tmp_path / "plots")
    assert {p.name for p in written} >= {"shift_1-2_torque_hole_map.png", "energy_dissipated_map.png"}
    assert all(p.stat().st_size > 0 for p in written)
    one = SweepTable([r for r in serial.rows if r["input.throttle_signal"] == 0.6], serial.parameters)
    assert any(p.name == "shift_1-2_torque_hole_over_driveline_vehicle_mass.png" for p in plot_sweep(one, tmp_path / "one"))


def test_readme_sweep_commands_parse_and_name_known_keys():
    import re
    import shlex

    from transgen.cli import build_parser
    from transgen.sim import scenario_keys

    docs = Path(__file__).resolve().parent.parent / "docs"
    readme = "\n".join(p.read_text(encoding="utf-8") for p in sorted(docs.rglob("*.md")) if "generated" not in p.parts)
    lines = [line.strip().removeprefix("$ ") for line in re.sub(r"\\\n\s*", " ", readme).splitlines()
             if line.strip().removeprefix("$ ").startswith("transgen sweep ")]
    assert len(lines) >= 5
    parser = build_parser()
    keys = {}
    for line in lines:
        args = parser.parse_args(shlex.split(line.split("#")[0].split(">")[0].strip("` "))[1:])
        known = keys.setdefault(args.scenario, scenario_keys(args.scenario))
        for text in args.grid:
            key, _ = parse_grid(text, sampled=args.samples is not None)
            assert key in known, (line, key)


def test_a_dask_cluster_without_transgen_is_refused_before_any_task():
    from transgen.sim.study.executors import ClusterError, _check_environment

    class NoTransgen:  # the scheduler of a cluster started from another Python
        def run_on_scheduler(self, fn, *args):
            return fn("surely-not-an-installed-distribution-name")

        def run(self, fn, *args):
            raise AssertionError("the workers are not asked once the scheduler failed")

    class OtherVersion:
        def run_on_scheduler(self, fn, *args):
            return fn(*args)

        def run(self, fn, *args):
            return {"tcp://127.0.0.1:1": "0.0.0-other"}

    with pytest.raises(ClusterError, match="has no transgen.*python -m dask"):
        _check_environment(NoTransgen(), "tcp://here")
    with pytest.raises(ClusterError, match=r"runs another transgen \(tcp://127.0.0.1:1: 0.0.0-other\)"):
        _check_environment(OtherVersion(), "tcp://here")
