"""Scenario fuzz, the long run: at least 1,000 mutated scenario files through the API (issue 10,
section 3): zero tracebacks, zero unlocated errors, zero hangs over 10 s of CPU (or 60 s of wall
time), zero NaN in results. Every bundled scenario runs once first, untimed: the first run of a
powertrain compiles its right-hand side (numba, cached on disk), a cost of the checkout, not of
a case (``--cold`` skips it).
Prints the counts of the outcomes and the failing cases; exits 1 if there is any.

    python benchmarks/fuzz_scenario.py [--seed N] [--count N] [--time-limit S] [--cold]

The fuzzer itself is ``tests/fuzz/fuzz_scenario.py`` (a small seed of it runs in the test suite).
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))

from fuzz.fuzz_scenario import fuzz_scenarios  # noqa: E402


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seed", type=int, default=2026)
    ap.add_argument("--count", type=int, default=1200)
    ap.add_argument("--time-limit", type=float, default=10.0, help="CPU seconds a case may take (default 10)")
    ap.add_argument("--cold", action="store_true", help="no untimed first run of every bundled scenario")
    args = ap.parse_args(argv)

    def progress(k, outcome):
        if (k + 1) % 100 == 0:
            print(f"  {k + 1} cases", file=sys.stderr, flush=True)

    report = fuzz_scenarios(args.seed, args.count, args.time_limit, progress, warm=not args.cold)
    print(report.text())
    return 1 if report.failures else 0


if __name__ == "__main__":
    sys.exit(main())
