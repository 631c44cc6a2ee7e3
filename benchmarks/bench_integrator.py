"""Per-step overhead of the simulator's integration driver with LSODA (issue 11, real-time goals):
scipy's ``solve_ivp``, :func:`transgen.sim.solve.ode_solvers.solve_segment` with scipy's LSODA class, and
``solve_segment`` with :class:`~transgen.sim.solve.ode_solvers.LeanLSODA` (what ``method = "LSODA"``
runs), on a trivial right-hand side (ten states, five lightly damped oscillators, ``A @ y``: about
3500 steps over 20 s at rtol 1e-7), without events and with four terminal events that never fire
(three linear in the state, one not), as the simulator's segments have. The overhead per step is
the process time of a run less that of the right-hand side's evaluations alone, over the steps.
Then the process time of a bundled scenario run (default ``ht740_improved``) with scipy's LSODA
class and with the lean one. Process time (``time.process_time``), best and median of N repeats:
on a loaded machine the figures still move by some percent. Prints figures; asserts nothing.

    python benchmarks/bench_integrator.py [--repeats N] [--scenario NAME]
    python benchmarks/bench_integrator.py --once {ivp,scipy,lean,rhs} [--events] [--times K]

``--once``: K runs of one driver on the trivial right-hand side and nothing else (``rhs``: its
evaluations alone), for instruction counts: ``valgrind --tool=callgrind`` with K = 1 and K = 3,
the difference over 2 is one run.
"""
from __future__ import annotations

import argparse
import dataclasses
import statistics
import time

import numpy as np
from scipy.integrate import LSODA, solve_ivp

from transgen.sim.solve import ode_solvers
from transgen.sim.solve.ode_solvers import LeanLSODA, solve_segment

N = 10
_A = np.zeros((N, N))
for _k in range(0, N, 2):
    _w = 5.0 + 3.0 * _k
    _A[_k, _k + 1], _A[_k + 1, _k], _A[_k, _k], _A[_k + 1, _k + 1] = _w, -_w, -0.05, -0.05
Y0 = np.ones(N)
OPTIONS = dict(rtol=1e-7, atol=1e-7)
T_END = 20.0


def rhs(t, y):
    return _A @ y


def events() -> list:
    out = []
    for k in range(3):
        row = np.zeros(3)
        row[k] = 1.0

        def linear(t, y, row=row):
            return float(row @ y[:3]) + 5.0

        linear.terminal, linear.direction, linear.linear = True, -1, (row, 5.0)
        out.append(linear)

    def other(t, y):
        return float(y[4]) + 10.0

    other.terminal, other.direction = True, -1
    return out + [other]


DRIVERS = {
    "solve_ivp, scipy LSODA": lambda evs: solve_ivp(rhs, (0.0, T_END), Y0, method="LSODA", events=evs or None,
                                                    dense_output=True, **OPTIONS),
    "solve_segment, scipy LSODA": lambda evs: solve_segment(rhs, 0.0, T_END, Y0, LSODA, evs, **OPTIONS),
    "solve_segment, LeanLSODA": lambda evs: solve_segment(rhs, 0.0, T_END, Y0, LeanLSODA, evs, **OPTIONS),
}


def process_times(func, repeats: int) -> list[float]:
    func()
    out = []
    for _ in range(repeats):
        t0 = time.process_time()
        func()
        out.append(time.process_time() - t0)
    return out


def trivial(repeats: int) -> None:
    print(f"trivial right-hand side ({N} states, rtol {OPTIONS['rtol']:g}), process time per run, "
          f"best / median of {repeats}")
    print(f"  {'driver':<28} {'events':>6} {'steps':>6} {'rhs':>6} {'run ms':>15} {'overhead/step us':>18}")
    for with_events in (False, True):
        for name, driver in DRIVERS.items():
            sol = driver(events() if with_events else [])
            steps = len(sol.t) - 1
            runs = process_times(lambda: driver(events() if with_events else []), repeats)
            rhs_alone = min(process_times(lambda: [rhs(0.0, Y0) for _ in range(sol.nfev)], repeats))
            best, median = min(runs), statistics.median(runs)
            print(f"  {name:<28} {4 if with_events else 0:>6} {steps:>6} {sol.nfev:>6} "
                  f"{best * 1e3:>7.2f} /{median * 1e3:>6.2f} {(best - rhs_alone) / steps * 1e6:>9.2f} /"
                  f"{(median - rhs_alone) / steps * 1e6:>6.2f}")


def scenario(name: str, repeats: int) -> None:
    from transgen.sim.scenario.load import load_scenario

    s = load_scenario(name)
    s.options = dataclasses.replace(s.options, method="LSODA")
    print(f"{name} with LSODA (its own tolerances), process time per run, best / median of {repeats}")
    classes = {"scipy LSODA": LSODA, "LeanLSODA": LeanLSODA}
    results = {k: [] for k in classes}
    for key, cls in classes.items():  # warm-up
        ode_solvers.SOLVERS["LSODA"] = cls
        r = s.run()
    for _ in range(repeats):  # interleaved: a load change hits both
        for key, cls in classes.items():
            ode_solvers.SOLVERS["LSODA"] = cls
            t0 = time.process_time()
            s.run()
            results[key].append(time.process_time() - t0)
    ode_solvers.SOLVERS["LSODA"] = LeanLSODA
    for key, runs in results.items():
        print(f"  {key:<12} {min(runs) * 1e3:8.1f} / {statistics.median(runs) * 1e3:8.1f} ms   "
              f"({r.stats['segments']} segments, {r.stats['rhs_evaluations']} rhs evaluations, "
              f"{r.time[-1] - r.time[0]:g} s simulated)")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=7)
    parser.add_argument("--scenario", default="ht740_improved")
    parser.add_argument("--once", choices=("ivp", "scipy", "lean", "rhs"))
    parser.add_argument("--events", action="store_true")
    parser.add_argument("--times", type=int, default=1)
    args = parser.parse_args()
    if args.once:
        names = {"ivp": "solve_ivp, scipy LSODA", "scipy": "solve_segment, scipy LSODA", "rhs": "solve_segment, LeanLSODA",
                 "lean": "solve_segment, LeanLSODA"}
        sol = DRIVERS[names[args.once]](events() if args.events else [])
        for _ in range(args.times):
            if args.once == "rhs":
                for _ in range(sol.nfev):
                    rhs(0.0, Y0)
            else:
                sol = DRIVERS[names[args.once]](events() if args.events else [])
        print(f"{len(sol.t) - 1} steps, {sol.nfev} rhs evaluations")
        return
    trivial(args.repeats)
    scenario(args.scenario, args.repeats)


if __name__ == "__main__":
    main()
