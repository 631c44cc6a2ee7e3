"""A run's outputs are all or none: CSV and plots appear together, or nothing is written, and no
temporary file is left behind (an error, a failed comparison run, SIGTERM)."""
from __future__ import annotations

import os
import signal
import subprocess
import sys
import time

import pytest

from transgen.cli import main
from transgen.export import output_set, write_text


def _files(folder):
    return sorted(str(p.relative_to(folder)) for p in folder.rglob("*") if p.is_file())


def test_output_set_renames_all_at_the_end_or_removes_all(tmp_path):
    with output_set():
        write_text(tmp_path / "a.txt", "a")
        assert not (tmp_path / "a.txt").exists()  # not yet: the set is not complete
        write_text(tmp_path / "b.txt", "b")
    assert _files(tmp_path) == ["a.txt", "b.txt"]
    with pytest.raises(RuntimeError):
        with output_set():
            write_text(tmp_path / "c.txt", "c")
            raise RuntimeError("the plot failed")
    assert _files(tmp_path) == ["a.txt", "b.txt"]


def test_a_bad_plot_format_is_refused_before_anything_runs(tmp_path, capsys):
    out = tmp_path / "r.csv"
    assert main(["simulate", "simple2_upshift", "--quiet", "-o", str(out), "--plot", str(tmp_path / "p"),
                 "--format", "png,jpgx"]) == 2
    assert "jpgx" in capsys.readouterr().err
    assert _files(tmp_path) == []


def test_a_failing_plot_leaves_neither_csv_nor_plots(tmp_path, monkeypatch):
    import transgen.sim.analysis.plots as plots

    real = plots.plot_all

    def failing(*args, **kwargs):
        real(*args, **kwargs)
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(plots, "plot_all", failing)
    assert main(["simulate", "simple2_upshift", "--quiet", "-o", str(tmp_path / "r.csv"),
                 "--plot", str(tmp_path / "p")]) == 1
    assert [f for f in _files(tmp_path)] == []


LONG = """mechanism = "coupled_clutches"
[simulation]
t_end = 10000.0
output_dt = 1.0
[initial]
speeds = { J1 = 10.0, J2 = 0.0, J3 = 0.0, J4 = 0.0 }
[input]
type = "torque"
torque = { type = "sine", offset = 0.0, amplitude = 5.0, frequency = 5.0 }
"""


def test_sigterm_during_a_run_leaves_no_files(tmp_path):
    (tmp_path / "long.toml").write_text(LONG)
    out = tmp_path / "out"
    env = dict(os.environ, MPLBACKEND="Agg")
    # --force: the 5 Hz input aliases at output_dt = 1 s (a limit of transgen.limits); the run is meant to be long
    proc = subprocess.Popen([sys.executable, "-m", "transgen", "simulate", str(tmp_path / "long.toml"), "--quiet", "--force",
                             "-o", str(out / "r.csv"), "--plot", str(out / "p")],
                            stderr=subprocess.PIPE, stdout=subprocess.PIPE, env=env, cwd=tmp_path)
    time.sleep(3.0)  # a run of minutes: well inside it
    proc.send_signal(signal.SIGTERM)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 143, err.decode()  # 128 + SIGTERM
    assert "Traceback" not in err.decode()
    assert not out.exists() or _files(out) == []
