"""Small dense linear algebra with the BLAS thread pool vs one BLAS thread (issue 11, section 4:
"small dense solves run 1.7-2x slower when the BLAS spins its thread pool on a loaded machine").

Times, with the BLAS libraries' default thread count and limited to one thread
(:func:`transgen.blas.single_threaded`), best of several repeats:

* 6x6 solves (numpy ``solve``; scipy ``lu_factor``/``lu_solve``, which the BDF, Radau and LSODA
  integrators use per step);
* the mode generator (:func:`transgen.modes.mode_models` of the HT-740, all combinations);
* whole runs of ``ht740_improved`` and ``ht740_turbo`` (:func:`transgen.sim.solve.simulate.simulate`;
  its undecorated ``__wrapped__`` is the threaded case).

alternating, each on an idle machine and with busy-loop processes on the other cores (a loaded machine: the
BLAS's threads then wait for a core). Prints figures; asserts nothing.

    python benchmarks/bench_blas_threads.py [--repeats N]
"""
from __future__ import annotations

import multiprocessing as mp
import os
import sys
import time

import numpy as np
import scipy.linalg

from transgen.blas import single_threaded
from transgen.language import load_mechanism
from transgen.modes import mode_models
from transgen.sim.scenario.load import load_scenario
from transgen.sim.solve.simulate import simulate


def busy(stop) -> None:
    while not stop.is_set():
        pass


def small_solves(n: int = 3000) -> None:
    rng = np.random.default_rng(1)
    a = rng.standard_normal((6, 6)) + 6 * np.eye(6)
    b = rng.standard_normal(6)
    for _ in range(n):
        np.linalg.solve(a, b)
        scipy.linalg.lu_solve(scipy.linalg.lu_factor(a, check_finite=False), b, check_finite=False)


def modes() -> None:
    mode_models.__wrapped__(load_mechanism("ht740"), "all")


def run(name: str):
    def go() -> None:
        s = load_scenario(name)
        simulate.__wrapped__(s.powertrain, s.options)
    return go


CASES = {"3000 x 6x6 solve + LU": small_solves, "mode generator ht740 (all)": modes,
         "simulate ht740_improved": run("ht740_improved"), "simulate ht740_turbo": run("ht740_turbo")}


def timed(func) -> float:
    t = time.perf_counter()
    func()
    return time.perf_counter() - t


def measure(repeats: int) -> None:
    """Threaded and single-threaded runs alternate (the load of a shared machine drifts); the
    best of each, and the median of the pairwise ratios."""
    for label, func in CASES.items():
        func()  # warm-up
        threaded, single = [], []
        for _ in range(repeats):
            threaded.append(timed(func))
            with single_threaded("scipy.linalg"):
                single.append(timed(func))
        ratio = float(np.median(np.array(threaded) / np.array(single)))
        print(f"  {label:<30} {min(threaded):>12.4f} {min(single):>12.4f} {ratio:>9.2f}x", flush=True)


def main(repeats: int = 5) -> None:
    from threadpoolctl import threadpool_info

    load_scenario("ht740_improved")  # scipy and its BLAS loaded
    threads = ", ".join(f"{i['internal_api']} {i['num_threads']}" for i in threadpool_info() if i["user_api"] == "blas")
    print(f"BLAS thread pools: {threads}; {os.cpu_count()} cores; best of {repeats}")
    header = f"  {'case':<30} {'threaded [s]':>12} {'1 thread [s]':>12} {'median ratio':>13}"
    print("idle machine (other load of the machine not controlled):")
    print(header)
    measure(repeats)
    n_busy = max(1, (os.cpu_count() or 2) - 1)
    stop = mp.Event()
    workers = [mp.Process(target=busy, args=(stop,), daemon=True) for _ in range(n_busy)]
    for w in workers:
        w.start()
    try:
        print(f"loaded machine ({n_busy} busy-loop process(es) on the other cores):")
        print(header)
        measure(repeats)
    finally:
        stop.set()
        for w in workers:
            w.join()


if __name__ == "__main__":
    main(int(sys.argv[sys.argv.index("--repeats") + 1]) if "--repeats" in sys.argv else 5)
