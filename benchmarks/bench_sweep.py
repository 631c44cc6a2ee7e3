"""Throughput of a parameter study (transgen.sim.study): 64 HT-740 runs (ht740_improved, 20 s
each; an 8 x 8 grid of vehicle mass and throttle) serially in this process, on 1 and 2 local
worker processes and on a Dask cluster of 2 worker processes on 127.0.0.1 (started here, its start
and the workers' import of the simulator not timed: a cluster is started once and used for many
sweeps).

Three kinds of figure for the local workers, each sweep timed end to end (validation, pool start,
runs) and, in this process, also over its runs alone (from the moment the runs start to the last
row):

* ``transgen sweep`` commands, as a user runs them from a shell: a cold interpreter each
  (``--workers 1``: the runs in the command's process; ``--workers 2``: 2 spawned workers, each
  importing the simulator and loading its compiled code when it starts), wall clock of the whole
  command, two repetitions alternating;
* new pools in this process, started by the sweep after its serial sweep: this process has the
  simulator warm, so the workers are forked from it (ready in milliseconds, as in a script that
  calls ``sweep()`` again; a Jupyter kernel runs threads of its own, so its pools spawn);
* kept pools (``with LocalExecutor(n) as executor:`` started and used by a first small sweep, then
  the 64 runs on it: what a script that runs many sweeps on one pool gets, as the Dask cluster's
  start is not timed either).

The rows of every engine (and the commands' CSV files) are checked to be identical, number for
number. A worker's start (interpreter, imports, the simulator's compiled code) is measured as the
CPU time of the worker process at its first task, spawned and forked. The cost of an engine per
task (sending the scenario texts and overrides, scheduling, returning the row) is measured with
tasks that do nothing: the marginal time of 220 against 20 of them, which a loaded machine
disturbs far less than the runs.

Goals (issue 11): on an idle 2-core machine 2 local workers at least 1.8x faster than 1; Dask adds
at most 10 % per run over the local pool.

    python benchmarks/bench_sweep.py [--runs 64] [--t-end 20] [--no-dask]
    python benchmarks/bench_sweep.py --commands 8,64 [--pairs 3]

``--commands``: issue 23's figures only: per size, the median of ``--pairs`` pairs of whole
``transgen sweep`` commands with 1 and 2 workers (goals 1.3x at 8 runs, 1.8x at 64), and the
processes left in a 2-worker command's process group after it ended (goal: none).
"""
import argparse
import contextlib
import math
import os
import subprocess
import sys
import tempfile
import threading
import time

from transgen.sim.study import DaskExecutor, LocalExecutor, SerialExecutor, SweepTable, sweep


def grid(runs: int, t_end: float | None) -> dict:
    side = max(d for d in range(1, math.isqrt(max(runs, 1)) + 1) if runs % d == 0)  # side * other = runs
    other = max(1, runs // side)
    g = {"driveline.vehicle_mass": [20000 + i * (16000 // max(side - 1, 1)) for i in range(side)],
         "input.throttle_signal": [round(0.55 + j * 0.35 / max(other - 1, 1), 4) for j in range(other)]}
    if t_end is not None:
        g = {"simulation.t_end": [t_end], **g}
    return g


def timed(label: str, executor, design: dict) -> tuple[float, float, list]:
    marks = []

    def progress(p):
        marks.append(time.perf_counter())
    start = time.perf_counter()
    table = sweep("ht740_improved", design, executor=executor, progress=progress)
    total = time.perf_counter() - start
    runs = time.perf_counter() - marks[0]
    assert not table.failed, table.failed[0]["message"]
    n = len(table)
    method = f", {executor.start_method}ed" if isinstance(executor, LocalExecutor) else ""
    print(f"  {label + method:<34} {n / total:7.3f} runs/s end to end ({total:6.1f} s), {n / runs:7.3f} runs/s over "
          f"the runs ({runs:6.1f} s)", flush=True)
    return total, runs, cells(table)


def cells(table: SweepTable) -> list[list]:
    """Every cell of the table but the wall times (the only column that may differ)."""
    return [[r.get(c) for c in table.columns if c != "wall_time"] for r in table.rows]


def commands(design: dict, repetitions: int = 2) -> tuple[list[float], list[float], list]:
    """``transgen sweep ... --workers 1`` and ``--workers 2`` run as commands in a temporary folder
    (a cold interpreter each; not a source checkout), alternating; returns the wall-clock seconds
    of each command with 1 and with 2 workers and the cells of the results, which must be equal."""
    options = [f"--grid={key}={','.join(str(v) for v in values)}" for key, values in design.items()]
    times: dict[int, list[float]] = {1: [], 2: []}
    results = []
    with tempfile.TemporaryDirectory() as folder:
        for repetition in range(repetitions):
            for workers in (1, 2):
                out = os.path.join(folder, f"r{workers}_{repetition}.csv")
                start = time.perf_counter()
                done = subprocess.run([sys.executable, "-m", "transgen", "sweep", "ht740_improved", *options,
                                       "--workers", str(workers), "--quiet", "-o", out],
                                      cwd=folder, capture_output=True, text=True)
                times[workers].append(time.perf_counter() - start)
                assert done.returncode == 0, done.stderr
                table = SweepTable.from_csv(out)
                assert not table.failed, table.failed[0]["message"]
                results.append(cells(table))
    assert all(r == results[0] for r in results), "the commands' results differ"
    return times[1], times[2], results[0]


def _group_members(pgid: int) -> list[int]:
    """The processes of the process group ``pgid`` still alive (Linux: /proc)."""
    members = []
    for entry in os.listdir("/proc"):
        if entry.isdigit():
            try:
                with open(f"/proc/{entry}/stat") as fh:
                    fields = fh.read().rsplit(")", 1)[1].split()
            except OSError:
                continue
            if int(fields[2]) == pgid and fields[0] != "Z":
                members.append(int(entry))
    return members


_CPU_WRAPPER = """
import atexit, resource, runpy, sys
out = sys.argv.pop(1)
def report():
    me, kids = resource.getrusage(resource.RUSAGE_SELF), resource.getrusage(resource.RUSAGE_CHILDREN)
    with open(out, "w") as fh:
        fh.write(f"{me.ru_utime + me.ru_stime} {kids.ru_utime + kids.ru_stime}")
atexit.register(report)
sys.argv[0] = "transgen"
runpy.run_module("transgen", run_name="__main__")
"""
"""``python -c`` of a ``transgen`` command that writes its own CPU time and its workers' (joined
before ``atexit`` handlers run) into a file."""


def command_pairs(runs: int, pairs: int = 3) -> tuple[float, float, float, list[int], float]:
    """``pairs`` pairs of whole ``transgen sweep`` commands of ``runs`` runs, ``--workers 1`` then
    ``--workers 2``, each in a process group of its own; returns the median wall time [s] with 1
    and with 2 workers, the median of the pairs' speed-ups, the processes left in the groups
    of the 2-worker commands once they ended (none expected) and the median speed-up estimated
    from CPU times: the command's own CPU time plus its workers' shared by 2, against the 1-worker
    command's (what an idle 2-core machine gives; on a loaded Linux machine the scheduler shares a
    core between the sessions, autogroup, so that a session's second worker gains little wall time)."""
    design = grid(runs, None)
    options = [f"--grid={key}={','.join(str(v) for v in values)}" for key, values in design.items()]
    times: dict[int, list[float]] = {1: [], 2: []}
    cpu: dict[int, list[float]] = {1: [], 2: []}
    left: list[int] = []
    with tempfile.TemporaryDirectory() as folder:
        for pair in range(pairs):
            for workers in (1, 2):
                out = os.path.join(folder, f"p{workers}_{pair}.csv")
                cpu_file = os.path.join(folder, "cpu.txt")
                start = time.perf_counter()
                child = subprocess.Popen([sys.executable, "-c", _CPU_WRAPPER, cpu_file, "sweep", "ht740_improved", *options,
                                          "--workers", str(workers), "--quiet", "-o", out], cwd=folder,
                                         stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True,
                                         start_new_session=True)
                _, err = child.communicate()
                times[workers].append(time.perf_counter() - start)
                assert child.returncode == 0, err
                with open(cpu_file) as fh:
                    own, kids = map(float, fh.read().split())
                cpu[workers].append(own + kids / workers)
                if workers == 2:
                    time.sleep(0.2)  # what a shell's next prompt sees
                    left += _group_members(child.pid)
    median = lambda xs: sorted(xs)[len(xs) // 2]  # noqa: E731
    return (median(times[1]), median(times[2]), median([a / b for a, b in zip(times[1], times[2])]), left,
            median([a / b for a, b in zip(cpu[1], cpu[2])]))


def commands_only(sizes: list[int], pairs: int) -> None:
    """The issue-23 figures: ``transgen sweep`` commands, 1 against 2 workers, per size."""
    goals = {8: 1.3, 64: 1.8}
    print(f"`transgen sweep ht740_improved` commands on {os.cpu_count()} cores, median of {pairs} pairs "
          f"(--workers 1, then --workers 2; cold interpreters, the workers forked or spawned as the command decides):", flush=True)
    for runs in sizes:
        one, two, ratio, left, estimate = command_pairs(runs, pairs)
        goal = goals.get(runs)
        print(f"  {runs:3d} runs: 1 worker {one:6.2f} s, 2 workers {two:6.2f} s: {ratio:.2f}x wall, {estimate:.2f}x "
              f"estimated from CPU times" + (f" (goal >= {goal}x)" if goal else "")
              + f"; processes left in the 2-worker commands' groups: {len(left)}", flush=True)


@contextlib.contextmanager
def spawned():
    """Inside: a second thread alive, so that a new local pool spawns its workers (as in a cold
    process) instead of forking them from this warm one."""
    release = threading.Event()
    thread = threading.Thread(target=release.wait)
    thread.start()
    try:
        yield
    finally:
        release.set()
        thread.join()


def _noop(shared, task):
    """A task that does nothing: what an executor costs per run (sending the scenario texts and
    the overrides, scheduling, returning a row)."""
    return task[0], {"success": True, "files": len(shared["files"])}


def _cpu_task(shared, task):
    """A sweep's task with the CPU time [s] of its worker process before and after it and the
    worker's pid (the CPU-time estimate)."""
    import resource

    from transgen.sim.study.task import run_task

    def cpu() -> float:
        usage = resource.getrusage(resource.RUSAGE_SELF)
        return usage.ru_utime + usage.ru_stime

    before = cpu()
    index, row = run_task(shared, task)
    return index, row, os.getpid(), before, cpu()


def cpu_estimate(workers: int, design: dict) -> tuple[float, float, float]:
    """The sweep's end-to-end time on an idle machine estimated from CPU times, which other
    processes on the machine disturb less than wall-clock (on a busy machine a run's CPU time
    still grows, by a third at a load of 8 on 2 cores): the design checked in this process,
    a worker's start (its process's CPU time at its first task, the mean of the workers) and the
    runs' CPU time (each task's in its worker) shared evenly by the workers (the end of a sweep
    leaves one worker idle for up to one run, 0.1 s: not counted); and without the start (a kept
    pool). The workers are spawned, as a ``transgen sweep`` command's. Returns (cold, kept, mean
    start) in seconds."""
    from transgen.sim.study.runner import design_variants, scenario_path, validate_variants

    path = scenario_path("ht740_improved")
    tasks = list(enumerate(design_variants(design)))
    start = time.process_time()
    files = validate_variants(path, [v for _, v in tasks])
    check = time.process_time() - start
    first, runs = {}, 0.0
    with spawned():  # the workers' start as in a `transgen sweep` command
        for _, _, pid, before, after in LocalExecutor(workers).run(_cpu_task, {"path": path, "files": files}, tasks):
            first[pid] = min(first.get(pid, before), before)
            runs += after - before
    start = sum(first.values()) / len(first)
    return check + start + runs / workers, runs / workers, start


def _without_bytecode() -> list[str]:
    """The modules of transgen a worker imports that have no up-to-date cached bytecode."""
    import importlib
    import importlib.util
    import sys

    from transgen.sim.study.task import PRELOAD

    for name in PRELOAD + ("transgen.sim.solve.ode_solvers",):
        importlib.import_module(name)
    missing = []
    for name, module in list(sys.modules.items()):
        source = getattr(module, "__file__", None) or ""
        if name.startswith("transgen") and source.endswith(".py"):
            cached = importlib.util.cache_from_source(source)
            if not os.path.exists(cached) or os.path.getmtime(cached) < os.path.getmtime(source):
                missing.append(name)
    return missing


def _start_cpu(shared, task) -> tuple[int, float]:
    """In a fresh worker: the CPU time [s] its process has used before this, its first task."""
    import resource

    time.sleep(0.5)  # the other worker takes the other task
    usage = resource.getrusage(resource.RUSAGE_SELF)
    return task, usage.ru_utime + usage.ru_stime


def _preload() -> None:
    """As a local pool's worker starts: the simulator imported and its compiled code loaded."""
    import importlib

    from transgen.sim.study.task import PRELOAD, warm_up

    for name in PRELOAD:
        importlib.import_module(name)
    warm_up()


def task_overhead(executor, shared: dict, few: int = 20, many: int = 220) -> float:
    """Marginal seconds per task of ``executor`` (start-up cancels out of the difference)."""
    def timed_run(n: int) -> float:
        start = time.perf_counter()
        for _ in executor.run(_noop, shared, [(i, {"driveline.vehicle_mass": 20000 + i}) for i in range(n)]):
            pass
        return time.perf_counter() - start
    return (timed_run(many) - timed_run(few)) / (many - few)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--runs", type=int, default=64)
    ap.add_argument("--t-end", type=float, default=None, help="simulated time per run (default: the scenario's 20 s)")
    ap.add_argument("--no-dask", action="store_true")
    ap.add_argument("--commands", metavar="SIZES", help="only the `transgen sweep` command pairs of these sizes "
                    "(e.g. 8,64: issue 23's figures)")
    ap.add_argument("--pairs", type=int, default=3, help="pairs of commands per size with --commands (default 3)")
    args = ap.parse_args()
    if args.commands:
        commands_only([int(x) for x in args.commands.split(",")], args.pairs)
        return
    design = grid(args.runs, args.t_end)
    print(f"sweep of {args.runs} ht740_improved runs on {os.cpu_count()} cores:", flush=True)
    uncached = _without_bytecode()
    if uncached:
        print(f"  note: {len(uncached)} of transgen's modules have no cached bytecode (PYTHONDONTWRITEBYTECODE="
              f"{os.environ.get('PYTHONDONTWRITEBYTECODE', '')!r}): every worker compiles them from source, about 0.1 s of "
              f"its start that an installed transgen does not pay (pip compiles them); 'python -m compileall' on the "
              f"source folders caches them", flush=True)
    one_cmd, two_cmd, command_cells = commands(design)
    n = len(command_cells)
    for label, times in (("--workers 1", one_cmd), ("--workers 2", two_cmd)):
        print(f"  {'transgen sweep ' + label:<34} " + ", ".join(f"{n / t:7.3f} runs/s ({t:6.1f} s)" for t in times)
              + " end to end", flush=True)
    print(f"  speed-up of 2 workers over 1, `transgen sweep` commands (cold interpreter, spawned workers): "
          f"{sum(one_cmd) / sum(two_cmd):.2f}x end to end (goal >= 1.8x on an idle machine)", flush=True)
    serial = timed("serial", SerialExecutor(), design)
    assert command_cells == serial[2], "the commands gave other numbers than this process"
    one = timed("1 local worker, new pool", LocalExecutor(1), design)
    two = timed("2 local workers, new pool", LocalExecutor(2), design)
    assert one[2] == serial[2] and two[2] == serial[2], "local workers gave different numbers"
    print(f"  speed-up of 2 workers over 1, new pools, forked from this warm process: {one[0] / two[0]:.2f}x end "
          f"to end, {one[1] / two[1]:.2f}x over the runs (goal >= 1.8x on an idle machine)", flush=True)
    kept = []
    for workers in (1, 2):
        with LocalExecutor(workers) as executor:
            sweep("ht740_improved", {"simulation.t_end": [0.5], "driveline.vehicle_mass": [20000 + i for i in range(workers)]},
                  executor=executor)  # the workers started and warm
            kept.append(timed(f"{workers} local worker{'s' * (workers > 1)}, kept", executor, design))
    assert kept[0][2] == serial[2] and kept[1][2] == serial[2], "kept local workers gave different numbers"
    print(f"  speed-up of 2 workers over 1, kept pools: {kept[0][0] / kept[1][0]:.2f}x end to end, "
          f"{kept[0][1] / kept[1][1]:.2f}x over the runs (goal >= 1.8x on an idle machine)")
    for how, context, what in (("spawned", spawned, "interpreter, imports, compiled code"),
                               ("forked", contextlib.nullcontext, "fork, one BLAS thread")):
        with context():
            starts = [cpu for _, cpu in LocalExecutor(2).run(_start_cpu, None, [0, 1])]
        print(f"  a {how} worker's start: {min(starts):.3f}-{max(starts):.3f} s CPU ({what}; 2 workers starting "
              f"together)", flush=True)
    (cold1, kept1, start1), (cold2, kept2, start2) = cpu_estimate(1, design), cpu_estimate(2, design)
    print(f"  estimate from CPU times (the design's check, a worker's start, the runs shared evenly; less "
          f"disturbed by other load than wall-clock): 1 worker "
          f"{cold1:.2f} s, 2 workers {cold2:.2f} s: {cold1 / cold2:.2f}x spawned; {kept1:.2f} s and {kept2:.2f} s: "
          f"{kept1 / kept2:.2f}x kept (a spawned worker's start {start1:.2f}, {start2:.2f} s CPU)", flush=True)
    from transgen.sim import scenario_files
    from transgen.sim.study.runner import scenario_path

    path = scenario_path("ht740_improved")
    shared = {"path": path, "files": scenario_files(path)}
    per_run = two[1] / len(serial[2]) * 2  # seconds of one run on one of the 2 workers
    pool_cost = task_overhead(LocalExecutor(2), shared)
    print(f"  cost per task of the 2-worker pool: {pool_cost * 1e3:.2f} ms ({100 * pool_cost / per_run:.2f} % of a "
          f"{per_run:.2f} s run)")
    if args.no_dask:
        return
    try:
        import distributed
    except ImportError:
        print("  Dask: not installed (pip install 'transgen[distributed]')")
        return
    import dask

    # as the README starts workers: without Dask's statistical profiler (a stack sample every
    # 10 ms of the running task; with it the runs measured 17-32 % slower than in the pool)
    with dask.config.set({"distributed.worker.profile.enabled": False}), \
            distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1",
                                     dashboard_address=None) as cluster:
        with distributed.Client(cluster) as client:  # as the pool's workers: the simulator imported once
            client.run(_preload)
        dask = timed("Dask, 2 workers", DaskExecutor(cluster.scheduler_address), design)
        dask_cost = task_overhead(DaskExecutor(cluster.scheduler_address), shared)
    assert dask[2] == serial[2], "Dask gave different numbers"
    print(f"  Dask per run: over the new 2-worker pool {100 * (dask[0] / two[0] - 1):+.1f} % end to end, "
          f"{100 * (dask[1] / two[1] - 1):+.1f} % over the runs; over the kept pool (warm, as the cluster) "
          f"{100 * (dask[0] / kept[1][0] - 1):+.1f} % end to end, {100 * (dask[1] / kept[1][1] - 1):+.1f} % over the "
          f"runs (goal <= +10 %)")
    print(f"  cost per task on Dask: {dask_cost * 1e3:.2f} ms, {1e3 * (dask_cost - pool_cost):+.2f} ms over the pool = "
          f"{100 * (dask_cost - pool_cost) / per_run:+.2f} % of a run")
    print("  rows identical, number for number: commands = serial = 1 worker = 2 workers = Dask")


if __name__ == "__main__":
    main()
