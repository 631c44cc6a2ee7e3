"""Issue 22's acceptance, what the long fuzz runs and the review found: the failing examples of
the fuzzers kept as regression tests, the time estimates of sweeps and optimize, and the CSV mode
column as pandas reads it, joined to the matrices files."""
from __future__ import annotations

import json

import numpy as np
import pytest

from transgen.cli import main
from transgen.errors import TransgenError
from transgen.limits import LIMITS, LimitExceeded
from transgen.sim.analysis.result_files import csv_mode_text, reads_as_text
from transgen.sim.scenario.load import bundled_scenarios, load_scenario, parse_scenario

# ------------------------------------------------------------------------- fuzz regressions

# benchmarks/fuzz_scenario.py --seed 2026 --count 1200, case 1175 (from ht740_turbo.toml): a
# converter file name longer than a file name may be; the look-up of the bundled data file
# raised OSError (ENAMETOOLONG), a traceback at load
CASE_1175 = """mechanism = "ht740_tc"
include = ["shared/m915_driveline.toml"]
title = "HT-740 + converter + turbodiesel, basic turbo algorithm (thesis 4.6)"

[simulation]
t_end = 0.351
method = "BDF"
rtol = 1e-05
atol = 1e-05
output_dt = 0.01

[initial]
locked = ["C1", "C5"]
speeds_rpm = { E = 800.0, L1 = 0.0 }

[input]
type = "turbodiesel"
turbo = "basic"
fuel_signal = { type = "table", t = [0.0, 0.5, 0.8], value = [0.3, 0.3, 0.85] }
governor = { idle_rpm = 600, gain = 20 }

[converter]
file = "%s"
""" % ("c" * 300)


def test_fuzz_scenario_1175_a_converter_name_too_long_for_a_file_is_a_located_error():
    folder = next(iter(bundled_scenarios().values())).parent
    with pytest.raises(TransgenError, match=r"case\.toml:\d+:\d+: error: .*cannot read"):
        parse_scenario(CASE_1175, folder / "case.toml")


# ------------------------------------------------------------------------- time estimates
def _refused(argv, capsys, *needles, seconds=30.0):
    import time

    start = time.perf_counter()
    assert main(argv) == 2
    assert time.perf_counter() - start < seconds  # refused at the first variant, not after loading all
    err = capsys.readouterr().err
    assert "Traceback" not in err and err.count("error:") == 1, err
    for needle in needles:
        assert needle in err, err
    return err


def test_a_sweep_over_a_day_of_cpu_is_refused_with_its_estimate(tmp_path, capsys):
    out = tmp_path / "r.csv"
    # 2000 runs of 1000 simulated seconds each: within the count of runs, over the time limit
    _refused(["sweep", "simple2_upshift", "--grid", "simulation.t_end=1000,1001", "--grid",
              "driveline.damping=100:300:1000", "-o", str(out)], capsys,
             "--grid (2000 runs to do): error:", "of CPU", "2000 runs at about", "--force")
    assert not out.exists()


def test_sweep_time_estimates_runs_times_the_costliest_run_and_force_passes_it():
    from transgen.sim.study.runner import sweep_time

    assert sweep_time(10, [1.0, 3.0], 1).startswith("about 30 s of CPU (10 runs at about 3 s each")
    day = LIMITS["sweep_time"].value
    with pytest.raises(LimitExceeded, match="or --force"):
        sweep_time(1000, [day / 100], 1)
    assert "days of CPU" in sweep_time(1000, [day / 100], 1, force=True)


def test_the_run_cost_grows_with_the_simulated_time():
    from transgen.sim.scenario.run_limits import SAMPLE_SECONDS, SIMULATED_SECOND_CPU, run_seconds

    scenario = load_scenario("simple2_upshift")
    short = run_seconds(scenario)
    long = run_seconds(load_scenario("simple2_upshift", {"simulation.t_end": scenario.options.t_end + 100.0}))
    samples = 100.0 / scenario.options.output_dt  # and the output samples of the 100 s more
    assert long - short == pytest.approx(100 * SIMULATED_SECOND_CPU + samples * SAMPLE_SECONDS, rel=1e-3)


def test_a_sweep_shows_its_estimate_before_the_first_run(tmp_path, capsys):
    out = tmp_path / "r.csv"
    assert main(["sweep", "simple2_upshift", "--grid", "simulation.t_end=4.3,4.35", "--workers", "1",
                 "-o", str(out)]) == 0
    err = capsys.readouterr().err
    assert "sweep: 2 runs to do, about" in err and "of CPU (2 runs at about" in err
    assert main(["sweep", "simple2_upshift", "--grid", "simulation.t_end=4.3,4.35", "--workers", "1", "--quiet",
                 "-o", str(out)]) == 0
    assert "runs to do" not in capsys.readouterr().err


def test_optimize_time_is_shifts_times_evaluations_refused_over_a_day_unless_forced():
    from transgen.limits import EVALUATION_CPU
    from transgen.sim.study.executors import SerialExecutor
    from transgen.sim.study.optimize import _check_time

    seen = []
    _check_time(2, 100, SerialExecutor(), False, seen.append)
    assert seen == [f"about {2 * 100 * EVALUATION_CPU:g} s of CPU (2 shift(s) x 100 evaluations at about "
                    f"{EVALUATION_CPU:g} s each)"]
    with pytest.raises(LimitExceeded, match=r"--evaluations 100000 \(7 shift\(s\)\): error: .* or --force"):
        _check_time(7, 100_000, SerialExecutor(), False, None)
    _check_time(7, 100_000, SerialExecutor(), True, seen.append)
    assert "h of CPU" in seen[-1]


# ------------------------------------------------------------------------- CSV mode column
@pytest.mark.parametrize("name, gear, text", [
    ("1", "1", "gear 1"), ("10", "10", "gear 10"), ("1", None, "mode 1"), ("1", "", "mode 1"),
    ("NA", None, "mode NA"), ("True", None, "mode True"), ("1e3", None, "mode 1e3"), ("inf", None, "mode inf"),
    ("1_0", None, "mode 1_0"), ("1L", "1L", "1L"), ("R", "R", "R"), ("C1+C4", None, "C1+C4"), ("none", None, "none"),
    ("M3", None, "M3"), ("SP", None, "SP"),
])
def test_a_mode_is_written_by_its_name_unless_a_reader_takes_that_for_a_number(name, gear, text):
    assert csv_mode_text(name, gear) == text
    assert reads_as_text(text)


def test_pandas_reads_the_mode_column_as_the_names_and_joins_the_matrices_by_gear(tmp_path):
    pd = pytest.importorskip("pandas")
    csv, mat, matrices = tmp_path / "r.csv", tmp_path / "r.json", tmp_path / "m.json"
    assert main(["simulate", "simple2_upshift", "--quiet", "-o", str(csv)]) == 0
    assert main(["simulate", "simple2_upshift", "--quiet", "-o", str(mat)]) == 0
    assert main(["matrices", "simple2", "-o", str(matrices)]) == 0
    df = pd.read_csv(csv)  # no dtype given
    assert pd.api.types.is_string_dtype(df["mode"]) and set(df["mode"]) == {"gear 1", "none", "gear 2"}
    result = json.loads(mat.read_text())
    texts = [csv_mode_text(n, g) for n, g in zip(result["mode_names"], result["mode_gears"])]
    assert list(dict.fromkeys(df["mode"])) == texts  # the same modes in the same order as the other formats
    by_gear = {m["gear"]: m for m in json.loads(matrices.read_text())["modes"] if m.get("gear")}
    locked = dict(zip(result["mode_names"], result["mode_locked"]))
    for text, name in zip(texts, result["mode_names"]):
        if text.startswith("gear "):  # the join: the gear after "gear ", the same locked set
            mode = by_gear[text[len("gear "):]]
            assert "+".join(mode["locked"]) == locked[name]
    assert np.issubdtype(df["time [s]"].dtype, np.floating)
