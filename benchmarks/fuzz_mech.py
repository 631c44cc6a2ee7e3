"""The long fuzz run of ``.mech`` input (issue 10): 10,000 inputs through the API and 200
command-line calls (every command), with the contract of ``tests/fuzz/fuzz_mech.py``. Prints the
figures and every failure; exits 1 if there is one.

    python benchmarks/fuzz_mech.py                 # seed 0: 10000 API inputs + 200 CLI calls
    python benchmarks/fuzz_mech.py --seed 7 --api 2000 --cli 0
    python benchmarks/fuzz_mech.py --show 0 1234   # print API input 1234 of seed 0
    python benchmarks/fuzz_mech.py --processes 2   # the API inputs shared by 2 processes
"""
from __future__ import annotations

import argparse
import multiprocessing
import os
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))

from fuzz.fuzz_mech import _collect, check_api, fuzz_api, fuzz_cli, generate  # noqa: E402


def _check(job: tuple[int, int, float, str]):
    """One API input in a pool process (a scratch folder of its own inside the run's)."""
    folder = Path(job[3]) / str(os.getpid())
    folder.mkdir(exist_ok=True)
    return check_api(job[0], job[1], folder, job[2])


def fuzz_api_parallel(seed: int, count: int, time_limit: float, processes: int, progress):
    """Inputs ``0 .. count-1`` of ``seed`` through the API in ``processes`` processes: the same
    inputs and checks as :func:`fuzz_api` (each input depends on its seed and index alone); the
    CPU limit of an input is set in the process that runs it."""
    with tempfile.TemporaryDirectory(prefix="fuzz_mech_") as tmp, \
            multiprocessing.get_context("fork").Pool(processes, maxtasksperchild=500) as pool:
        jobs = ((seed, i, time_limit, tmp) for i in range(count))
        return _collect(pool.imap(_check, jobs, chunksize=4), progress)


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
    p.add_argument("--processes", type=int, default=1, help="processes sharing the API inputs")
    p.add_argument("--time-limit", type=float, default=10.0, help="seconds (CPU) per input or call")
    p.add_argument("--show", nargs=2, type=int, metavar=("SEED", "INDEX"), help="print one API input and exit")
    args = p.parse_args()
    if args.show:
        origin, text = generate(*args.show)
        print(f"# {origin}", file=sys.stderr)
        (sys.stdout.buffer.write(text) if isinstance(text, bytes) else sys.stdout.write(text))
        return 0
    failures = []
    for label, count, run in (("API", args.api, lambda: (fuzz_api(args.seed, args.api, args.time_limit, _progress(1000)) if args.processes <= 1 else
                                                        fuzz_api_parallel(args.seed, args.api, args.time_limit,
                                                                          args.processes, _progress(1000)))),
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
