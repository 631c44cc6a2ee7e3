"""Kill running commands with SIGKILL and check that they leave nothing behind (issue 22).

For each command (``sweep --workers 2``, ``simulate -o ... --plot ...``, ``optimize --workers 2``)
the test starts it N times in its own session (its own process group, as a shell starts a job),
sends SIGKILL to the command after a random delay and checks what is below. The delays are
scaled to the command's own run time, measured first by one run that is not killed (in a folder
of its own): a delay is drawn (seeded) from 0.05 to 0.95 of the expected run time, so that the
kills fall in the start, the runs and the writing. A resumed sweep has only the rows left to run:
its expected time is the time to the first row plus that of the rows left; once a kill leaves the
design complete, the results file is checked (every row once) and removed, and the next kill
starts the design afresh. A run that ends before its kill (the machine got faster) is not
counted as a kill: its delay is drawn again with the run time just seen (at most 5 times).
For every kill the report says whether the command was still running (by ``poll`` just before
the signal) and whether a temporary output file existed at that moment (killed while writing).
Checked:

* no process of the command's group alive 5 s after the kill (workers, resource tracker);
* no temporary file (``.transgen~*``) after the next complete run of the command (the stale
  files of the killed writers are removed by it);
* sweep: every row of the design exactly once in the results file after the final resume, and
  no row twice in the file after any kill.

Usage::

    python benchmarks/kill_test.py --kills 20 --seed 0 [--commands sweep,simulate,optimize] [--json]
"""
from __future__ import annotations

import argparse
import json
import os
import random
import shutil
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

TEMP_PREFIX = ".transgen~"
GRID = [f"{6.0 + 0.02 * k:.2f}" for k in range(24)]  # 2-2.5 s simulated each: the runs take the time, not the start


def commands(folder: Path, grid: list[str]) -> dict[str, list[str]]:
    return {
        "sweep": ["sweep", "simple2_upshift", "--grid", "simulation.t_end=" + ",".join(grid), "--workers", "2",
                  "--quiet", "-o", str(folder / "r.csv")],
        "simulate": ["simulate", "simple2_upshift", "--quiet", "--set", "simulation.output_dt=2e-4",
                     "-o", str(folder / "big.csv"), "--plot", str(folder / "plots")],
        "optimize": ["optimize", "simple2_upshift", "--evaluations", "8", "--population", "4", "--workers", "2",
                     "--quiet", "-o", str(folder / "tuned.toml")],
    }


#: the delays before the kill are drawn from these fractions of the command's expected run time
FRACTIONS = (0.05, 0.95)
RETRIES = 5  # a kill that comes after the run's end is drawn again, at most this many times


def group(pgid: int) -> list[int]:
    """The live (not zombie) processes of process group ``pgid``, from /proc."""
    out = []
    for entry in os.listdir("/proc"):
        if entry.isdigit():
            try:
                text = Path(f"/proc/{entry}/stat").read_text()
            except OSError:
                continue
            fields = text[text.rfind(")") + 2:].split()
            if int(fields[2]) == pgid and fields[0] != "Z":
                out.append(int(entry))
    return out


def temporaries(folder: Path) -> list[str]:
    return [str(p.relative_to(folder)) for p in folder.rglob(f"{TEMP_PREFIX}*")]


def sweep_keys(path: Path) -> list[str]:
    import csv

    if not path.is_file():
        return []
    with open(path, newline="", encoding="utf-8") as fh:
        return [row["key"] for row in csv.DictReader(fh)]


def run(argv: list[str], folder: Path, python: str, timeout: float = 900) -> subprocess.CompletedProcess:
    env = dict(os.environ, MPLBACKEND="Agg", TMPDIR=str(folder / "tmp"))
    return subprocess.run([python, "-m", "transgen", *argv], capture_output=True, text=True, timeout=timeout,
                          env=env, cwd=folder)


def measure(argv: list[str], folder: Path, python: str, first_row: Path | None = None) -> dict:
    """One run of the command, not killed, in ``folder``: its wall time [s] and (``first_row``: a
    sweep's results file) the time to its first row [s]."""
    (folder / "tmp").mkdir(parents=True, exist_ok=True)
    env = dict(os.environ, MPLBACKEND="Agg", TMPDIR=str(folder / "tmp"))
    start = time.monotonic()
    proc = subprocess.Popen([python, "-m", "transgen", *argv], stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                            text=True, env=env, cwd=folder, start_new_session=True)
    first = None
    while proc.poll() is None:
        if first is None and first_row is not None and sweep_keys(first_row):
            first = time.monotonic() - start
        time.sleep(0.05)
    wall = time.monotonic() - start
    if proc.returncode != 0:
        raise SystemExit(f"kill_test: the unkilled run of {argv[0]} exited {proc.returncode}: {proc.stderr.read()[-300:]}")
    return {"wall": round(wall, 2), "first_row": round(first if first is not None else wall, 2)}


def kill_once(argv: list[str], folder: Path, python: str, delay: float) -> dict:
    env = dict(os.environ, MPLBACKEND="Agg", TMPDIR=str(folder / "tmp"))
    start = time.monotonic()
    proc = subprocess.Popen([python, "-m", "transgen", *argv], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                            env=env, cwd=folder, start_new_session=True)
    end = start + delay
    peak = 1
    while time.monotonic() < end and proc.poll() is None:
        peak = max(peak, len(group(proc.pid)))
        time.sleep(0.05)
    writing = bool(temporaries(folder))  # a temporary output file exists: killed while writing
    at_kill = len(group(proc.pid))  # the command and its workers (and resource tracker) at the kill
    finished = proc.poll() is not None
    ran = time.monotonic() - start
    if not finished:
        os.kill(proc.pid, signal.SIGKILL)
    proc.wait()
    deadline = time.monotonic() + 5.0
    while (alive := group(proc.pid)) and time.monotonic() < deadline:
        time.sleep(0.05)
    alive = group(proc.pid)
    for pid in alive:  # do not leave them for the next kill (counted as a failure)
        try:
            os.kill(pid, signal.SIGKILL)
        except ProcessLookupError:
            pass
    return {"delay": round(delay, 2), "finished_before_kill": finished, "ran": round(ran, 2),
            "writing_at_kill": writing and not finished, "group_at_kill": 0 if finished else at_kill, "peak_group": peak,
            "alive_after_5s": len(alive), "temporaries_after_kill": len(temporaries(folder))}


def test_command(name: str, kills: int, rng: random.Random, base: Path, python: str, grid: list[str],
                 complete_each: bool) -> dict:
    folder = base / name
    (folder / "tmp").mkdir(parents=True)
    argv = commands(folder, grid)[name]
    timed = base / f"{name}-unkilled"
    measured = measure(commands(timed, grid)[name], timed, python, timed / "r.csv" if name == "sweep" else None)
    shutil.rmtree(timed, ignore_errors=True)
    run_time, first_row = measured["wall"], measured["first_row"]
    records, problems, retries, rounds = [], [], 0, 0
    for k in range(kills):
        for _ in range(RETRIES + 1):
            expected = run_time
            if name == "sweep":  # a resume runs only the rows left
                left = len(grid) - len(set(sweep_keys(folder / "r.csv")))
                expected = first_row + (run_time - first_row) * left / len(grid)
            record = kill_once(argv, folder, python, rng.uniform(*FRACTIONS) * expected)
            record["expected"] = round(expected, 2)
            if name == "sweep":
                keys = sweep_keys(folder / "r.csv")
                record["rows"] = len(keys)
                if len(keys) != len(set(keys)):
                    problems.append(f"kill {k}: a row twice in the results file")
                if len(set(keys)) == len(grid):  # the design complete: checked, then afresh
                    rounds += 1
                    if len(keys) != len(grid):
                        problems.append(f"kill {k}: {len(keys)} rows of a complete {len(grid)}-run design")
                    (folder / "r.csv").unlink()
            if record["alive_after_5s"]:
                problems.append(f"kill {k}: {record['alive_after_5s']} process(es) of the group alive 5 s after the kill")
            if not record["finished_before_kill"]:
                break
            retries += 1
            if name != "sweep":  # the run just seen, shorter than expected
                run_time = record["ran"]
        if complete_each:  # the next run, to its end: no temporary file after it
            done = run(argv, folder, python)
            record["next_run_exit"] = done.returncode
            record["temporaries_after_next_run"] = len(temporaries(folder))
            if "Traceback" in done.stderr or done.returncode not in (0, 1):
                problems.append(f"kill {k}: the next run exited {done.returncode}: {done.stderr[-300:]}")
            if record["temporaries_after_next_run"]:
                problems.append(f"kill {k}: temporaries after the next run: {temporaries(folder)[:3]}")
        records.append(record)
    final = run(argv, folder, python)
    left = temporaries(folder)
    result = {"command": name, "kills": kills, "unkilled_run": measured, "redrawn_after_the_end": retries,
              "killed_while_running": sum(not r["finished_before_kill"] for r in records),
              "killed_while_writing": sum(r["writing_at_kill"] for r in records), "sweep_rounds_completed": rounds,
              "killed_with_workers": sum(r["group_at_kill"] >= 3 for r in records),
              "alive_after_5s": sum(r["alive_after_5s"] for r in records),
              "stale_temporaries_after_kills": sum(r["temporaries_after_kill"] > 0 for r in records),
              "final_exit": final.returncode, "temporaries_after_final_run": len(left), "records": records}
    if final.returncode not in (0, 1) or "Traceback" in final.stderr:
        problems.append(f"final run exited {final.returncode}: {final.stderr[-300:]}")
    if left:
        problems.append(f"temporaries after the final run: {left[:3]}")
    if name == "sweep":
        keys = sweep_keys(folder / "r.csv")
        result["rows"], result["unique_rows"], result["design_rows"] = len(keys), len(set(keys)), len(grid)
        if not (len(keys) == len(set(keys)) == len(grid)):
            problems.append(f"rows after resume: {len(keys)} ({len(set(keys))} distinct) of {len(grid)}")
    result["problems"] = problems
    return result


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--kills", type=int, default=20)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--commands", default="sweep,simulate,optimize")
    parser.add_argument("--grid", type=int, default=len(GRID), help="sweep design size (default 24)")
    parser.add_argument("--no-complete-each", action="store_true",
                        help="simulate: no complete run after every kill (only the final one)")
    parser.add_argument("--json", action="store_true")
    parser.add_argument("--python", default=sys.executable)
    args = parser.parse_args(argv)
    if sys.platform != "linux":
        print("kill_test: needs Linux (/proc, process groups)", file=sys.stderr)
        return 0
    base = Path(tempfile.mkdtemp(prefix="transgen-kill-"))
    rng = random.Random(args.seed)
    grid = [f"{6.0 + 0.02 * k:.2f}" for k in range(args.grid)]
    start = time.monotonic()
    results = []
    for name in args.commands.split(","):
        results.append(test_command(name, args.kills, rng, base, args.python, grid,
                                    complete_each=name == "simulate" and not args.no_complete_each))
        print(json.dumps({k: v for k, v in results[-1].items() if k != "records"}), file=sys.stderr, flush=True)
    summary = {"kills_per_command": args.kills, "seed": args.seed, "wall_time": round(time.monotonic() - start, 1),
               "results": results}
    if args.json:
        print(json.dumps(summary, indent=2))
    else:
        for r in results:
            extra = f", rows {r['rows']} ({r['unique_rows']} distinct) of {r['design_rows']}" if "rows" in r else ""
            print(f"{r['command']}: unkilled run {r['unkilled_run']['wall']} s; {r['kills']} kills "
                  f"({r['killed_while_running']} while running, {r['killed_with_workers']} of them with 2 or more "
                  f"processes beside the command, {r['killed_while_writing']} while writing; "
                  f"{r['redrawn_after_the_end']} delays drawn again after the run had ended): "
                  f"{r['alive_after_5s']} processes alive 5 s after, stale temporaries after {r['stale_temporaries_after_kills']} "
                  f"kills, {r['temporaries_after_final_run']} after the final run{extra}")
            for p in r["problems"]:
                print(f"  PROBLEM {p}")
    shutil.rmtree(base, ignore_errors=True)
    return 1 if any(r["problems"] for r in results) else 0


if __name__ == "__main__":
    sys.exit(main())
