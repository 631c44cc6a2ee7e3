"""Processes: a local worker that dies is its task's failed result (retried once, alone) and the
others go on; workers end with their parent, however it ends; a finished sweep leaves no process
behind (workers, multiprocessing's resource tracker)."""
from __future__ import annotations

import functools
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from transgen.sim.study.executors import ClusterError, LocalExecutor

pytestmark = pytest.mark.skipif(sys.platform != "linux", reason="process groups and /proc: Linux")


def _task(shared, task):
    """Test task: ("ok", n) -> n squared; ("die", n) kills its worker every time; ("once", n)
    kills its worker the first time only (a marker file in ``shared``)."""
    kind, n = task
    if kind == "die" or kind == "once" and not _mark(Path(shared) / f"died{n}"):
        os.kill(os.getpid(), signal.SIGKILL)
    time.sleep(0.05)
    return n, n * n


def _mark(path: Path) -> bool:
    """Whether ``path`` existed; made now."""
    try:
        path.touch(exist_ok=False)
        return False
    except FileExistsError:
        return True


def test_a_worker_killed_once_is_retried_and_nothing_is_lost(tmp_path):
    tasks = [("ok", n) for n in range(6)] + [("once", 6)] + [("ok", n) for n in range(7, 10)]
    got = dict(LocalExecutor(2).run(_task, str(tmp_path), tasks))
    assert got == {n: n * n for n in range(10)}


def test_a_task_that_kills_its_worker_is_a_failed_result_and_the_others_go_on(tmp_path):
    tasks = [("ok", n) for n in range(4)] + [("die", 4)] + [("ok", n) for n in range(5, 8)]
    got = dict(LocalExecutor(2).run(_task, str(tmp_path), tasks, on_crash=lambda task, why: (task[1], why)))
    assert {n: got[n] for n in got if n != 4} == {n: n * n for n in range(8) if n != 4}
    assert "died (killed by SIGKILL" in got[4] and "run again alone" in got[4]
    with pytest.raises(ClusterError, match="died"):  # without on_crash: the error of before
        list(LocalExecutor(2).run(_task, str(tmp_path), [("die", 1)]))


@functools.lru_cache(maxsize=None)
def _kill_test():
    import importlib.util

    spec = importlib.util.spec_from_file_location("_kill_test", Path(__file__).resolve().parents[1] / "benchmarks"
                                                  / "kill_test.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _group(pgid: int) -> list[int]:
    """The live processes of process group ``pgid`` (benchmarks/kill_test.py's, from /proc)."""
    return _kill_test().group(pgid)


def _wait_empty(pgid: int, timeout: float) -> list[int]:
    end = time.monotonic() + timeout
    while (left := _group(pgid)) and time.monotonic() < end:
        time.sleep(0.1)
    return left


SWEEP = ["sweep", "simple2_upshift", "--grid", "simulation.t_end=4.5,4.6,4.7", "--workers", "2", "--quiet"]


def test_a_finished_two_worker_sweep_leaves_no_process(tmp_path):
    env = dict(os.environ, MPLBACKEND="Agg")
    proc = subprocess.Popen([sys.executable, "-m", "transgen", *SWEEP, "-o", str(tmp_path / "r.csv")], env=env, cwd=tmp_path,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, start_new_session=True)
    _, err = proc.communicate(timeout=600)
    assert proc.returncode == 0, err
    assert _group(proc.pid) == []  # the pid of a session leader is its group's id: at once, no process left


def test_the_workers_of_a_killed_sweep_end_with_it_and_it_resumes(tmp_path):
    env = dict(os.environ, MPLBACKEND="Agg")
    out = tmp_path / "r.csv"
    grid = ["--grid", "simulation.t_end=" + ",".join(f"{4.3 + 0.05 * k:.2f}" for k in range(8))]
    command = [sys.executable, "-m", "transgen", *SWEEP[:2], *grid, *SWEEP[4:], "-o", str(out)]
    proc = subprocess.Popen(command, env=env, cwd=tmp_path, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                            start_new_session=True)
    end = time.monotonic() + 300
    while len(_group(proc.pid)) < 3 and time.monotonic() < end:  # the command and its two workers
        time.sleep(0.1)
    time.sleep(1.0)
    os.kill(proc.pid, signal.SIGKILL)
    proc.wait()
    assert _wait_empty(proc.pid, 5.0) == []
    again = subprocess.run(command, env=env, cwd=tmp_path, capture_output=True, text=True, timeout=600)
    assert again.returncode == 0, again.stderr
    from transgen.sim.study import SweepTable

    keys = [r["key"] for r in SweepTable.from_csv(out).rows]
    assert len(keys) == 8 and len(set(keys)) == 8
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".transgen~")]


def test_sigterm_stops_a_sweep_with_its_rows_kept(tmp_path):
    env = dict(os.environ, MPLBACKEND="Agg")
    out = tmp_path / "r.csv"
    grid = ["--grid", "simulation.t_end=" + ",".join(f"{4.3 + 0.05 * k:.2f}" for k in range(10))]
    command = [sys.executable, "-m", "transgen", *SWEEP[:2], *grid, *SWEEP[4:], "-o", str(out)]
    proc = subprocess.Popen(command, env=env, cwd=tmp_path, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True,
                            start_new_session=True)
    from transgen.sim.study import SweepTable

    end = time.monotonic() + 300
    while not (out.is_file() and SweepTable.from_csv(out).rows) and time.monotonic() < end:
        time.sleep(0.1)
    proc.send_signal(signal.SIGTERM)
    _, err = proc.communicate(timeout=120)
    assert _wait_empty(proc.pid, 5.0) == []
    kept = SweepTable.from_csv(out).rows
    # 143 wherever the signal lands (in the runs, the cleanup, the exit hooks); 0 only where the
    # process had ended its last exit hook (it exits at once then) with every row written
    assert (proc.returncode == 143 or proc.returncode == 0 and len(kept) == 10) and "Traceback" not in err, \
        (proc.returncode, err)
    assert 1 <= len(kept) <= 10 and not [p for p in tmp_path.iterdir() if p.name.startswith(".transgen~")]
    again = subprocess.run(command, env=env, cwd=tmp_path, capture_output=True, text=True, timeout=600)
    assert again.returncode == 0, again.stderr
    keys = [r["key"] for r in SweepTable.from_csv(out).rows]
    assert len(keys) == len(set(keys)) == 10


_LATE_SIGNAL = """
import os, signal, sys, threading, time, atexit
import transgen.cli as cli

def late():
    os.kill(os.getpid(), signal.SIGTERM)
    time.sleep(0.3)  # the handler runs meanwhile

command = cli.main

def main(argv=None):
    code = command(argv)
    HOOK(late)  # registered after the program's own exit hook: runs before it
    return code

cli.main = main
sys.argv = ["transgen", "list"]
sys.exit(cli.entry_point())
"""


@pytest.mark.parametrize("nohup", [False, True])
@pytest.mark.parametrize("hook", ["atexit.register", "threading._register_atexit"])
def test_sigterm_after_the_command_exits_143_without_a_traceback(tmp_path, hook, nohup):
    # before: exit 0 and a traceback (Terminated raised in an exit hook), or exit -15 (while the
    # interpreter freed its modules, its handler reset to the default action); under nohup (SIGHUP
    # ignored) the traceback came back: the late rule waited for both handlers
    ignore_hup = (lambda: signal.signal(signal.SIGHUP, signal.SIG_IGN)) if nohup else None
    done = subprocess.run([sys.executable, "-c", _LATE_SIGNAL.replace("HOOK", hook)], cwd=tmp_path,
                          capture_output=True, text=True, timeout=120, preexec_fn=ignore_hup)
    assert done.returncode == 143 and "Traceback" not in done.stderr and "Exception" not in done.stderr, \
        (done.returncode, done.stderr)
    assert done.stdout.strip()  # the command's own output is kept


def test_the_program_without_a_signal_exits_with_its_code(tmp_path):
    ok = subprocess.run([sys.executable, "-m", "transgen", "list"], cwd=tmp_path, capture_output=True, text=True,
                        timeout=120)
    bad = subprocess.run([sys.executable, "-m", "transgen", "check", "nosuch.mech"], cwd=tmp_path,
                         capture_output=True, text=True, timeout=120)
    usage = subprocess.run([sys.executable, "-m", "transgen", "nosuchcommand"], cwd=tmp_path, capture_output=True,
                           text=True, timeout=120)
    assert (ok.returncode, bad.returncode, usage.returncode) == (0, 2, 2), (ok.stderr, bad.stderr, usage.stderr)
    assert ok.stdout.strip() and "Traceback" not in bad.stderr + usage.stderr
