"""The long fuzz run of ``.mech`` input (issue 10): 10,000 inputs through the API and 200
command-line calls (every command), with the contract of ``tests/fuzz/fuzz_mech.py``. Prints the
figures and every failure; exits 1 if there is one.

    python benchmarks/fuzz_mech.py                 # seed 0: 10000 API inputs + 200 CLI calls
    python benchmarks/fuzz_mech.py --seed 7 --api 2000 --cli 0
    python benchmarks/fuzz_mech.py --show 0 1234   # print API input 1234 of seed 0
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))

from fuzz.fuzz_mech import fuzz_api, fuzz_cli, generate  # noqa: E402


def _progress(every: int):
    def show(i, report):
        if (i + 1) % every == 0:
            print(f"  {i + 1}: {len(report.failures)} failures, {report.slowest:.2f} s slowest", file=sys.stderr, flush=True)
    return show


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--api", type=int, default=10_000, help="inputs through the API (default 10000)")
    p.add_argument("--cli", type=int, default=200, help="command-line calls (default 200)")
    p.add_argument("--workers", type=int, default=2, help="command-line calls run at a time")
    p.add_argument("--time-limit", type=float, default=10.0, help="seconds (CPU) per input or call")
    p.add_argument("--show", nargs=2, type=int, metavar=("SEED", "INDEX"), help="print one API input and exit")
    args = p.parse_args()
    if args.show:
        origin, text = generate(*args.show)
        print(f"# {origin}", file=sys.stderr)
        (sys.stdout.buffer.write(text) if isinstance(text, bytes) else sys.stdout.write(text))
        return 0
    failures = []
    for label, count, run in (("API", args.api, lambda: fuzz_api(args.seed, args.api, args.time_limit, _progress(1000))),
                              ("CLI", args.cli, lambda: fuzz_cli(args.seed, args.cli, args.time_limit, args.workers,
                                                                 _progress(50)))):
        if count <= 0:
            continue
        report = run()
        print(f"{label}: {report.summary()}")
        for f in report.failures:
            print(f"  {f}")
        failures += report.failures
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
