"""Start-up time of the command line (issue 11, section 4: numeric commands and ``--help`` in
under 0.25 s). Runs each command as a fresh subprocess of this Python (``python -m transgen``,
the same as the ``transgen`` script) and prints per command the median wall time against the
goal, the best wall time, the median CPU time of the process (user + system, less sensitive to
other work on the machine than the wall time) and the heavy libraries it imports, after one
warm-up run (the state of an installed transgen: bytecode and the grammar's parser tables
cached). Prints figures; asserts nothing.

    python benchmarks/bench_startup.py [--repeats N] [--instructions]

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


if __name__ == "__main__":
    n = int(sys.argv[sys.argv.index("--repeats") + 1]) if "--repeats" in sys.argv else 7
    main(n, "--instructions" in sys.argv)
