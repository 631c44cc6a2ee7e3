"""Start-up time of the command line (issue 11, section 4: numeric commands and ``--help`` in
under 0.25 s). Runs each command as a fresh subprocess of this Python (``python -m transgen``,
the same as the ``transgen`` script) and prints per command the median wall time against the
goal, the best wall time, the median CPU time of the process (user + system, less sensitive to
other work on the machine than the wall time) and the heavy libraries it imports, after one
warm-up run (the state of an installed transgen: bytecode and the grammar's parser tables
cached). Prints figures; asserts nothing.

    python benchmarks/bench_startup.py [--repeats N] [--instructions]
    python benchmarks/bench_startup.py --first-run [--fresh-install] [--repeats N]
    python benchmarks/bench_startup.py --side-by-side OTHER_PYTHON [--repeats N]

``--first-run`` (issue 23): the first ``transgen simulate ht740_improved`` (with
``--fresh-install``: in a new virtual environment after a non-editable ``pip install`` of this
checkout, about 3 minutes), then, once the kernels built in the background are there, later cold
runs, and the first simulation in a process against a warm one.

``--side-by-side OTHER_PYTHON``: the later cold run and the first simulation in a process
against a warm one, for this Python and another one's installation of transgen (e.g. a virtual
environment of the main branch), kernels built in both: each figure alternately for the two, the
median of ``N`` (default 7) runs, CPU and wall time, with the load average before and after.

``--instructions`` also counts the instructions of one run of each command under valgrind's
callgrind (slow: about a minute per command; independent of the machine's load, so the figure to
compare changes with on a shared machine). On an idle machine the median wall time is the figure
to quote. ``python -X importtime -m transgen matrices ht740`` shows where the import time goes.
"""
from __future__ import annotations

import os
import re
import resource
import shutil
import statistics
import subprocess
import sys
import tempfile
import time

GOAL = 0.25
"""Seconds: numeric commands and ``--help`` (issue 11, section 4)."""

COMMANDS = [
    ["--help"],
    ["simulate", "--help"],
    ["list"],
    ["check", "ht740"],
    ["ratios", "ht740"],
    ["modes", "ht740"],
    ["matrices", "ht740"],
    ["std", "ht740", "--json"],
    ["simulate", "--list"],
]
BASELINES = {
    "python -c pass": ["-c", "pass"],
    "import numpy": ["-c", "import numpy"],
    "import numpy, 1 BLAS thread": ["-c", "import os\nfor v in ('OPENBLAS_NUM_THREADS', 'MKL_NUM_THREADS'): "
                                           "os.environ.setdefault(v, '1')\nimport numpy"],
    "import networkx": ["-c", "import networkx"],
    "import lark": ["-c", "import lark"],
    "import scipy.linalg": ["-c", "import scipy.linalg"],
}
HEAVY = ("sympy", "matplotlib", "scipy", "networkx", "numpy", "lark")
# as installed: the modules' bytecode is cached (pip compiles it on install; a source checkout
# writes it on the first run), which PYTHONDONTWRITEBYTECODE would prevent for the checkout's own
# modules: each run would compile them all again
ENV = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"} | {"MPLBACKEND": "Agg"}
CWD = tempfile.gettempdir()  # not a checkout: `python -m` imports from its working directory first


def run_once(args: list[str]) -> tuple[float, float]:
    """Wall time and CPU time (user + system of the child) of one fresh process."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t = time.perf_counter()
    subprocess.run([sys.executable, *args], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, env=ENV, cwd=CWD,
                   check=False)
    wall = time.perf_counter() - t
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return wall, (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def instructions(args: list[str]) -> int | None:
    """Instructions of one run under callgrind (None without valgrind)."""
    if shutil.which("valgrind") is None:
        return None
    p = subprocess.run(["valgrind", "--tool=callgrind", "--callgrind-out-file=/dev/null", sys.executable, *args],
                       stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True, env=ENV, cwd=CWD, check=False)
    found = re.search(r"Collected : (\d+)", p.stderr)
    return int(found.group(1)) if found else None


def loaded_modules(command: list[str]) -> list[str]:
    """The heavy libraries a command has imported when it ends."""
    code = ("import sys, io, contextlib\nfrom transgen.cli import main\n"
            f"with contextlib.redirect_stdout(io.StringIO()):\n    try: main({command!r})\n    except SystemExit: pass\n"
            f"print(' '.join(m for m in {HEAVY!r} if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=ENV, cwd=CWD, check=False)
    return out.stdout.split()


def main(repeats: int = 7, count_instructions: bool = False) -> None:
    print(f"fresh processes, {repeats} runs each; goal: numeric commands and --help < {GOAL} s "
          f"(median wall time on an idle machine)")
    head = f"  {'command':<30} {'median [s]':>10} {'goal':>5} {'best [s]':>9} {'cpu [s]':>8}"
    print(head + (f" {'instr [G]':>9}" if count_instructions else "") + "  heavy imports")
    rows = [(label, args, None) for label, args in BASELINES.items()]
    rows += [("transgen " + " ".join(c), ["-m", "transgen", *c], c) for c in COMMANDS]
    for label, args, command in rows:
        run_once(args)  # warm-up: bytecode and the grammar's parser tables are cached as in use
        runs = [run_once(args) for _ in range(repeats)]
        walls, cpus = [w for w, _ in runs], [c for _, c in runs]
        median = statistics.median(walls)
        goal = ("ok" if median < GOAL else "OVER") if command is not None else ""
        line = f"  {label:<30} {median:>10.3f} {goal:>5} {min(walls):>9.3f} {statistics.median(cpus):>8.3f}"
        if count_instructions:
            n = instructions(args)
            line += f" {n / 1e9:>9.3f}" if n is not None else f" {'-':>9}"
        if command is not None:
            line += f"  {' '.join(loaded_modules(command)) or '-'}"
        print(line, flush=True)


FIRST_RUN = ["-m", "transgen", "simulate", "ht740_improved"]
FIRST_GOALS = {"first": 3.0, "later": 1.0, "ratio": 2.0}
"""Issue 23: the first ``transgen simulate ht740_improved`` after an install <= 3 s, a later cold
one <= 1 s, the first simulation in a process <= 2x a warm one (idle machine, wall time)."""
_IN_PROCESS = """
import os, sys, time
if sys.argv[1] == "cli":
    for v in ("OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"): os.environ.setdefault(v, "1")
from transgen.sim.scenario.load import load_scenario
out = []
for k in range(6):
    s = load_scenario("ht740_improved")
    t, c = time.perf_counter(), time.process_time()
    s.run()
    out.append((time.perf_counter() - t, time.process_time() - c))
from transgen.sim.core.jit import jit_enabled
print(out[0][0], out[0][1], sorted(w for w, _ in out[1:])[2], sorted(c for _, c in out[1:])[2], jit_enabled())
"""


def _kernels_built(python: str) -> bool:
    code = "from transgen.sim.core import aot; print(aot.kernels() is not None)"
    done = subprocess.run([python, "-c", code], capture_output=True, text=True, env=ENV, cwd=CWD, check=False)
    return done.stdout.strip() == "True"


def first_run(fresh: bool, repeats: int) -> None:
    """The first run after an install and later cold runs (issue 23). ``fresh``: a new virtual
    environment with a non-editable ``pip install`` of this checkout (its numba cache and its
    kernels built ahead of time empty: the state after an install); else this Python as it is
    (the first command then is a "first" one only where nothing was built yet)."""
    python = sys.executable
    with tempfile.TemporaryDirectory() as folder:
        if fresh:
            venv = os.path.join(folder, "venv")
            subprocess.run([sys.executable, "-m", "venv", venv], check=True)
            python = os.path.join(venv, "bin", "python")
            start = time.perf_counter()
            subprocess.run([python, "-m", "pip", "install", "-q", os.path.dirname(os.path.dirname(
                os.path.abspath(__file__)))], check=True, stdout=subprocess.DEVNULL)
            print(f"fresh venv, `pip install .` (not editable): {time.perf_counter() - start:.0f} s")
        built = _kernels_built(python)
        wall, cpu = _run_with(python, FIRST_RUN)
        label = "first run (kernels not built)" if not built else "first run (kernels were built already)"
        print(f"  {label:<46} {wall:7.2f} s wall {cpu:6.2f} s CPU  goal {FIRST_GOALS['first']:g} s", flush=True)
        end = time.monotonic() + 900
        while not _kernels_built(python) and time.monotonic() < end:  # the background build
            time.sleep(2)
        print(f"  kernels built in the background: {_kernels_built(python)} (after "
              f"{900 - (end - time.monotonic()):.0f} s more)", flush=True)
        runs = [_run_with(python, FIRST_RUN) for _ in range(repeats)]
        print(f"  later cold run, median of {repeats}:{'':<20} {statistics.median(w for w, _ in runs):7.2f} s wall "
              f"{statistics.median(c for _, c in runs):6.2f} s CPU  goal {FIRST_GOALS['later']:g} s", flush=True)
        for how in ("cli", "script"):
            out = subprocess.run([python, "-c", _IN_PROCESS, how], capture_output=True, text=True, env=ENV, cwd=CWD,
                                 check=True).stdout.split()
            w0, c0, w, c = map(float, out[:4])
            print(f"  in one process ({how}{', one BLAS thread' if how == 'cli' else ''}): first simulation "
                  f"{w0:.3f} s wall {c0:.3f} s CPU, warm {w:.3f} s wall {c:.3f} s CPU: {w0 / w:.2f}x wall "
                  f"{c0 / c:.2f}x CPU (goal {FIRST_GOALS['ratio']:g}x; compiled: {out[4]})", flush=True)


def side_by_side(other: str, repeats: int) -> None:
    """Later cold runs and first / warm simulations in a process (issue 23) of this Python and
    ``other``, measured alternately (the order swapped every round), medians of ``repeats``."""
    pythons = {"this": sys.executable, "other": other}
    for label, python in pythons.items():
        if not _kernels_built(python):
            print(f"  {label} ({python}): kernels not built; `python -m transgen.sim.core.build_kernels` first")
            return
        _run_with(python, FIRST_RUN)  # warm-up: bytecode, the grammar's parser
    load = os.getloadavg()
    cold: dict[str, list] = {k: [] for k in pythons}
    inside: dict[tuple[str, str], list] = {(k, how): [] for k in pythons for how in ("cli", "script")}
    for r in range(repeats):
        for label in (list(pythons) if r % 2 == 0 else list(pythons)[::-1]):
            cold[label].append(_run_with(pythons[label], FIRST_RUN))
            for how in ("cli", "script"):
                out = subprocess.run([pythons[label], "-c", _IN_PROCESS, how], capture_output=True, text=True, env=ENV,
                                     cwd=CWD, check=True).stdout.split()
                inside[label, how].append(tuple(map(float, out[:4])))
    print(f"side by side, median of {repeats} alternating runs (load average {load[0]:.1f} before, "
          f"{os.getloadavg()[0]:.1f} after; 1-minute)")
    med = statistics.median
    for label, python in pythons.items():
        runs = cold[label]
        print(f"  {label} ({python})")
        print(f"    later cold `transgen simulate ht740_improved`: {med(c for _, c in runs):.3f} s CPU, "
              f"{med(w for w, _ in runs):.3f} s wall (goal {FIRST_GOALS['later']:g} s)")
        for how in ("cli", "script"):
            rows = inside[label, how]
            print(f"    first simulation in a process ({how}): {med(r[1] for r in rows):.3f} s CPU against warm "
                  f"{med(r[3] for r in rows):.3f} s: {med(r[1] / r[3] for r in rows):.2f}x CPU, "
                  f"{med(r[0] / r[2] for r in rows):.2f}x wall (goal {FIRST_GOALS['ratio']:g}x)", flush=True)


def _run_with(python: str, args: list[str]) -> tuple[float, float]:
    """Wall and CPU time of ``python args`` as a fresh process (its children waited for included;
    a detached background build is not)."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t = time.perf_counter()
    subprocess.run([python, *args], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, env=ENV, cwd=CWD,
                   check=True)
    wall = time.perf_counter() - t
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return wall, (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


if __name__ == "__main__":
    n = int(sys.argv[sys.argv.index("--repeats") + 1]) if "--repeats" in sys.argv else 7
    if "--side-by-side" in sys.argv:
        side_by_side(sys.argv[sys.argv.index("--side-by-side") + 1], n)
    elif "--first-run" in sys.argv:
        first_run("--fresh-install" in sys.argv, n if "--repeats" in sys.argv else 5)
    else:
        main(n, "--instructions" in sys.argv)
