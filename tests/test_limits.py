"""Every size a user can type is checked before work starts (issue 22): over its limit, an
``error:`` naming the option with the estimate and how to go on, exit 2, within a second and
without allocating the work; the limits are listed in one module and in docs/limits.md; and the
tracebacks of the issue are located messages."""
from __future__ import annotations

import re
import time
from pathlib import Path

import pytest

from transgen import bundled_mechanisms
from transgen.cli import main
from transgen.limits import LIMITS, LimitExceeded, Limit, check_limit, check_workers
from transgen.progress import ProgressLine, eta_text

ROOT = Path(__file__).resolve().parents[1]
SIMPLE2 = bundled_mechanisms()["simple2"].read_text(encoding="utf-8")
SINE = """mechanism = "simple2"
[simulation]
t_start = 4.0
t_end = 7.0
[initial]
gear = "1"
speeds_rpm = {{ Li = 1230 }}
[input]
type = "torque"
torque = {{ type = "sine", offset = 400.0, amplitude = 50.0, frequency = {f} }}
[driveline]
output_inertia = 100.0
stiffness = 12000.0
damping = 200.0
"""


def _refused(argv, capsys, *needles, seconds=20.0):
    start = time.perf_counter()
    assert main(argv) == 2
    assert time.perf_counter() - start < seconds  # refused before the work, not after it
    err = capsys.readouterr().err
    assert "Traceback" not in err and err.count("error:") == 1, err
    for needle in needles:
        assert needle in err, err
    return err


# ------------------------------------------------------------------------------------ the table
def test_every_limit_is_documented_in_docs_limits_md():
    text = (ROOT / "docs" / "limits.md").read_text(encoding="utf-8")
    for name, lim in LIMITS.items():
        assert isinstance(lim, Limit) and lim.name == name and lim.why and lim.kind in ("max", "min")
        assert f"`{name}`" in text, f"docs/limits.md does not list the limit {name}"


def test_a_forceable_limit_passes_with_force_and_a_hard_one_does_not():
    check_limit("runs", 10 ** 6, "--samples", force=True)
    with pytest.raises(LimitExceeded, match="--force"):
        check_limit("runs", 10 ** 6, "--samples", force=False)
    with pytest.raises(LimitExceeded) as info:
        check_limit("grid_values", 10 ** 8, "--grid K", force=True)
    assert "--force" not in str(info.value) and info.value.limit is LIMITS["grid_values"]


def test_workers_are_bounded_by_count_and_by_memory():
    check_workers(None)
    check_workers(2)
    with pytest.raises(LimitExceeded, match=r"--workers 100000: error: .*TB of worker processes"):
        check_workers(100_000, force=False)
    with pytest.raises(LimitExceeded, match="available"):  # memory is a hard limit: --force does not pass it
        check_workers(10 ** 7, force=True)
    with pytest.raises(ValueError, match="whole number >= 1"):
        check_workers(0)


# ------------------------------------------------------------------------------------ sweep
def test_a_huge_grid_is_refused_before_its_values_are_made(tmp_path, capsys):
    out = tmp_path / "r.csv"
    _refused(["sweep", "simple2_upshift", "--grid", "K=1:2:100000000000", "-o", str(out)], capsys,
             "--grid K=1:2:100000000000: error:", "100000000000 values", "at most")
    assert not out.exists()


def test_a_grid_product_over_the_limit_says_runs_memory_and_force(tmp_path, capsys):
    _refused(["sweep", "simple2_upshift", "--grid", "simulation.t_end=5:7:400", "--grid",
              "driveline.stiffness=1000:20000:400", "-o", str(tmp_path / "r.csv")], capsys,
             "160000 runs", "MB for the design", "--force")


def test_a_billion_samples_are_refused_by_memory_even_with_force(tmp_path, capsys):
    _refused(["sweep", "simple2_upshift", "--grid", "simulation.t_end=5:7", "--samples", "1000000000", "--force",
              "-o", str(tmp_path / "r.csv")], capsys, "3 TB", "at most 4 GB")


@pytest.mark.parametrize("address, needle", [("tls://10.0.0.1:8786", "certificates"), ("ucx://a:1", "protocol"),
                                             ("tcp://host", "HOST:PORT")])
def test_scheduler_addresses_that_cannot_connect_are_refused(address, needle, tmp_path, capsys):
    pytest.importorskip("distributed")
    _refused(["sweep", "simple2_upshift", "--grid", "simulation.t_end=6", "--scheduler", address,
              "-o", str(tmp_path / "r.csv")], capsys, f"--scheduler {address}: error:", needle)


# ------------------------------------------------------------------------------------ optimize
@pytest.mark.parametrize("argv, needles", [
    (["--population", "100000"], ["--population 100000: error:", "at most 1000"]),
    (["--evaluations", "1000000"], ["--evaluations 1000000: error:", "days", "--force"]),
    (["--evaluations", "20", "--population", "30"], ["larger than --evaluations"]),
    (["--workers", "100000"], ["--workers 100000: error:", "--force"]),
    (["--scheduler", "tls://10.0.0.1:8786"], ["certificates"]),
])
def test_optimize_sizes_are_refused_before_it_runs(argv, needles, tmp_path, capsys):
    if "--scheduler" in argv:
        pytest.importorskip("distributed")
    _refused(["optimize", "simple2_upshift", *argv, "-o", str(tmp_path / "t.toml")], capsys, *needles)
    assert not list(tmp_path.iterdir())


# ------------------------------------------------------------------------------------ synthesize
@pytest.mark.parametrize("argv, needle", [(["--min-teeth", "0"], "at least 3 teeth"),
                                          (["--min-teeth", "-5"], "at least 3 teeth"),
                                          (["--max-teeth", "100000"], "at most 1000 teeth")])
def test_tooth_bounds_are_limits(argv, needle, capsys):
    _refused(["synthesize", "teeth", str(ROOT / "tests" / "data" / "stepped_unknown_planetary.mech"), *argv],
             capsys, needle)


def test_a_tooth_search_over_the_limit_is_refused_with_its_time(tmp_path, capsys):
    text = re.sub(r"Ns=\d+ Nr=\d+", "Ns=? Nr=?", bundled_mechanisms()["ht740"].read_text(encoding="utf-8"))
    path = tmp_path / "u.mech"
    path.write_text(text, encoding="utf-8")
    _refused(["synthesize", "teeth", str(path), "--max-teeth", "1000"], capsys,
             "candidate pairs", "min to search", "--force")


# ------------------------------------------------------------------------------------ simulate
def test_a_megahertz_sine_is_refused_at_its_key_with_the_time_it_would_take(tmp_path, capsys):
    path = tmp_path / "s.toml"
    path.write_text(SINE.format(f="1e6"), encoding="utf-8")
    err = _refused(["simulate", str(path)], capsys, "3000000 periods", "h to integrate", "--force")
    assert err.startswith(f"{path}:10:61: error: input.torque:")


def test_a_sine_faster_than_the_output_rate_is_refused_and_force_runs_it(tmp_path, capsys):
    path = tmp_path / "s.toml"
    path.write_text(SINE.format(f="1000.0").replace("t_end = 7.0", "t_end = 4.1"), encoding="utf-8")
    _refused(["simulate", str(path)], capsys, "alias", "output_dt of at most 0.0005 s")
    assert main(["simulate", str(path), "--force", "--quiet"]) == 0


def test_output_samples_over_the_memory_limit_are_refused(capsys):
    _refused(["simulate", "simple2_upshift", "--set", "simulation.output_dt=1e-6"], capsys,
             "--set simulation.output_dt: error:", "3000001 samples", "larger output_dt")


@pytest.mark.parametrize("key", ["atol", "rtol"])
def test_tolerances_below_the_floor_are_refused_at_the_key(key, capsys):
    _refused(["simulate", "simple2_upshift", "--set", f"simulation.{key}=1e-300"], capsys,
             f"--set simulation.{key}: error:", "below the limit of 1e-12")


def test_progress_counts_from_t_start_and_says_the_time_left(capsys):
    import io

    from transgen.sim.cli import _progress

    stream = io.StringIO()

    assert eta_text(0.5, 10.0) == " 50 %, 0:00:10 elapsed, 0:00:10 left"
    assert "left" not in eta_text(0.001, 10.0)
    show, line = _progress(4.0, 7.0, True, True)
    line.stream, line.interval = stream, 0.0
    show(4.0)
    show(5.5)
    first, second = stream.getvalue().splitlines()
    assert first.startswith("progress: simulating: t =   4.000 s,   0 %")  # from t_start, not t / t_end = 57 %
    assert second.startswith("progress: simulating: t =   5.500 s,  50 %") and second.endswith(" left")
    assert ProgressLine(True, log=False, stream=io.StringIO()).mode is None  # no terminal, no --progress
    assert main(["simulate", "simple2_upshift", "--progress", "--set", "simulation.t_end=4.5"]) == 0
    lines = [x for x in capsys.readouterr().err.splitlines() if x.startswith("progress:")]
    assert lines and " 0 %" not in lines[-1] and "100 %" in lines[-1] and "left" in lines[-1]


# ------------------------------------------------------------------------------------ tracebacks
def _massless(tmp_path, links):
    text = SIMPLE2
    for link in links:
        text = re.sub(rf"^link {link} J=[0-9.]+", f"link {link} J=0", text, flags=re.M)
    path = tmp_path / "m.mech"
    path.write_text(text, encoding="utf-8")
    return path, text


@pytest.mark.parametrize("links, named", [(("Li", "Lo"), "Li, La, Lb, Lc, Ld, Lo"), (("Lo",), "Lc, Ld, Lo")])
def test_check_refuses_massless_links_the_simulator_cannot_run(links, named, tmp_path, capsys):
    path, text = _massless(tmp_path, links)
    assert main(["check", str(path)]) == 2
    err = capsys.readouterr().err
    first = next(i for i, line in enumerate(text.splitlines(), 1) if line.startswith(f"link {named.split(', ')[0]} "))
    assert err.startswith(f"{path}:{first}:6: error: mode ") and f"massless link(s) {named} is undetermined" in err
    assert "Traceback" not in err and "J > 0" in err


def test_a_scenario_on_massless_links_is_refused_not_a_key_error(tmp_path, capsys):
    path, _ = _massless(tmp_path, ("Li", "Lo"))
    scenario = tmp_path / "s.toml"
    scenario.write_text(SINE.format(f="5.0").replace('mechanism = "simple2"', 'mechanism = "m.mech"'), encoding="utf-8")
    assert main(["simulate", str(scenario), "--quiet"]) == 2
    err = capsys.readouterr().err
    assert "KeyError" not in err and "mechanism 'm.mech' has errors" in err and "massless link(s)" in err


def test_declared_modes_without_mode_statements_are_a_located_error(tmp_path, capsys):
    assert main(["simulate", "simple2_upshift", "--set", 'simulation.modes="declared"']) == 2
    err = capsys.readouterr().err
    assert err.startswith("--set simulation.modes: error:") and "declares none" in err
    assert main(["matrices", "simple2", "--modes", "declared"]) == 2
    assert "declares none" in capsys.readouterr().err
