"""Start-up time of the command line (issue 11, section 4: numeric commands and ``--help`` in
under 0.25 s). Runs each command as a fresh subprocess of this Python (``python -m transgen``,
the same as the ``transgen`` script) and prints the median and the best wall time of several
runs, beside the bare interpreter and the imports that remain. Prints figures; asserts nothing.

    python benchmarks/bench_startup.py [--repeats N]

On a machine shared with other work the median is the figure to quote, the best run the cost
without interference. ``python -X importtime -m transgen matrices ht740`` shows where the time goes.
"""
from __future__ import annotations

import os
import statistics
import subprocess
import sys
import time

COMMANDS = [
    ["--help"],
    ["simulate", "--help"],
    ["list"],
    ["check", "ht740"],
    ["ratios", "ht740"],
    ["modes", "ht740"],
    ["matrices", "ht740"],
    ["simulate", "--list"],
]
BASELINES = {
    "python -c pass": ["-c", "pass"],
    "import numpy": ["-c", "import numpy"],
    "import networkx": ["-c", "import networkx"],
    "import lark": ["-c", "import lark"],
    "import scipy.linalg": ["-c", "import scipy.linalg"],
}
HEAVY = ("sympy", "matplotlib", "scipy", "networkx", "numpy", "lark")


def wall(args: list[str], repeats: int) -> list[float]:
    env = dict(os.environ, MPLBACKEND="Agg")
    times = []
    for _ in range(repeats):
        t = time.perf_counter()
        subprocess.run([sys.executable, *args], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, env=env,
                       check=False)
        times.append(time.perf_counter() - t)
    return times


def loaded_modules(command: list[str]) -> list[str]:
    """The heavy libraries a command has imported when it ends."""
    code = ("import sys, io, contextlib\nfrom transgen.cli import main\n"
            f"with contextlib.redirect_stdout(io.StringIO()):\n    try: main({command!r})\n    except SystemExit: pass\n"
            f"print(' '.join(m for m in {HEAVY!r} if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=False)
    return out.stdout.split()


def main(repeats: int = 7) -> None:
    print(f"wall time of fresh processes, {repeats} runs each (goal: numeric commands and --help < 0.25 s)")
    print(f"  {'command':<30} {'median [s]':>10} {'best [s]':>9}  heavy imports")
    for label, args in BASELINES.items():
        t = wall(args, repeats)
        print(f"  {label:<30} {statistics.median(t):>10.3f} {min(t):>9.3f}")
    for command in COMMANDS:
        t = wall(["-m", "transgen", *command], repeats)
        print(f"  {'transgen ' + ' '.join(command):<30} {statistics.median(t):>10.3f} {min(t):>9.3f}  "
              f"{' '.join(loaded_modules(command)) or '-'}")


if __name__ == "__main__":
    n = int(sys.argv[sys.argv.index("--repeats") + 1]) if "--repeats" in sys.argv else 7
    main(n)
