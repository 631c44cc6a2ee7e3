"""Benchmark of the shift simulator on the HT-740 20-s scenario: both clutch models at matched
accuracy (issue goals: mode switching >= 100x faster than real time on one core, >= 10x faster
than the compliant model at equal accuracy, energy residual < 0.1 %). Prints figures; asserts
nothing.

    python benchmarks/bench_simulate.py [scenario] [--quick]   (--quick: three switching settings, k = 1e10 only)
    python benchmarks/bench_simulate.py --realtime [--repeats N]

``--realtime``: the real-time factor (simulated time / wall time, in-process, after one warm-up
run, median and best of N) of the bundled scenarios with their own settings; issue 11 goals:
``ht740_improved`` >= 150x, ``ht740_turbo`` >= 50x, ``ht740_turbo_iterative`` >= 30x.

Accuracy is measured against a reference run of the mode-switching model (DOP853, rtol 1e-11):
the largest difference of the lock/unlock event times and of the output-shaft speed (on a
2001-point grid). The compliant model converges to that reference only as its lock-up stiffness
grows (its error is a model error as well as an integration error), so it is swept over
stiffness (with about critical damping, ``c ~ 2 sqrt(k J)``) and solver tolerance. For each model
the cheapest setting that meets the target is timed (best of five runs).
"""
from __future__ import annotations

import dataclasses
import sys
import time

import numpy as np

from transgen.sim.scenario.load import load_scenario

TARGET_EVENT = 1e-4     # s
TARGET_SPEED = 1e-2     # rad/s at the output shaft (0.1 rpm)

SWITCHING = [dict(method=m, rtol=tol, atol=tol) for m, tols in
             (("LSODA", (1e-4, 1e-5, 1e-6, 1e-7)), ("BDF", (1e-5, 1e-6)), ("Radau", (1e-5, 1e-6)),
              ("RK45", (1e-5, 1e-6)), ("DOP853", (1e-6,))) for tol in tols]
COMPLIANT = [dict(method=m, rtol=tol, atol=tol, stiffness=k, damping=c) for k, c in
             ((1e5, 1e2), (1e6, 3e3), (1e7, 1e4), (1e8, 2e4), (1e9, 6e4), (1e10, 2e5), (1e11, 6e5))
             for m, tol in (("Radau", 1e-5), ("Radau", 1e-6), ("LSODA", 1e-6), ("BDF", 1e-6))]
# an explicit solver on the compliant model: the stiffness of the locked springs sets its step
COMPLIANT_EXPLICIT = [dict(method="RK45", rtol=1e-6, atol=1e-6, stiffness=k, damping=c) for k, c in ((1e5, 1e2), (1e6, 3e3))]


def run(name: str, **changes):
    s = load_scenario(name)
    s.options = dataclasses.replace(s.options, **changes)
    t = time.perf_counter()
    r = s.run()
    return r, time.perf_counter() - t


def best_wall(name: str, repeats: int = 5, **changes) -> float:
    return min(run(name, **changes)[1] for _ in range(repeats))


def accuracy(r, ref) -> tuple[float, float]:
    """Largest event-time difference [s] and largest output-speed difference [rad/s] vs ``ref``."""
    ev = [e.t for e in r.events if e.kind in ("lock", "unlock")]
    ev_ref = [e.t for e in ref.events if e.kind in ("lock", "unlock")]
    dt = max((abs(a - b) for a, b in zip(ev, ev_ref)), default=float("nan")) if len(ev) == len(ev_ref) else float("inf")
    out = ref.meta["links"][-1]
    grid = np.linspace(ref.time[0], ref.time[-1], 2001)
    dw = float(np.max(np.abs(np.interp(grid, r.time, r[f"w_{out}"]) - np.interp(grid, ref.time, ref[f"w_{out}"]))))
    return dt, dw


def sweep(name: str, model: str, settings: list[dict], ref, t_sim: float) -> list[tuple]:
    rows = []
    for opts in settings:
        r, wall = run(name, model=model, **opts)
        dt, dw = accuracy(r, ref) if r.success else (float("nan"), float("nan"))
        ok = r.success and dt <= TARGET_EVENT and dw <= TARGET_SPEED
        rows.append((opts, wall, r, dt, dw, ok))
        k = f"{opts['stiffness']:.0e}" if "stiffness" in opts else "-"
        print(f"  {model:<10} {opts['method']:<7} {opts['rtol']:>6.0e} {k:>7} {wall:>9.3f} {t_sim / wall:>7.1f} "
              f"{r.stats['rhs_evaluations']:>8} {r.stats['events']:>6} {dt:>11.2e} {dw:>11.2e} "
              f"{r.energy.get('relative_residual', float('nan')):>9.1e}  {'yes' if ok else 'no'}"
              + ("" if r.success else f"  FAILED: {r.message}"), flush=True)
    return rows


def main(name: str = "ht740_improved", quick: bool = False) -> None:
    t_sim = load_scenario(name).options.t_end - load_scenario(name).options.t_start
    ref, _ = run(name, method="DOP853", rtol=1e-11, atol=1e-11)
    print(f"{name}: {t_sim:g} s of simulated time; reference: mode switching, DOP853, rtol 1e-11 "
          f"({ref.stats['events']} events)")
    print(f"accuracy target: events within {TARGET_EVENT:g} s, output speed within {TARGET_SPEED:g} rad/s")
    print(f"  {'model':<10} {'method':<7} {'rtol':>6} {'k':>7} {'wall [s]':>9} {'x real':>7} {'RHS':>8} {'events':>6} "
          f"{'|dt_event|':>11} {'|dw_out|':>11} {'E resid.':>9}  meets")
    switching = sweep(name, "switching", SWITCHING[:3] if quick else SWITCHING, ref, t_sim)
    compliant = sweep(name, "compliant", COMPLIANT[20:24] if quick else COMPLIANT, ref, t_sim)
    if not quick:
        sweep(name, "compliant", COMPLIANT_EXPLICIT, ref, t_sim)
    chosen = {}
    for model, rows in (("switching", switching), ("compliant", compliant)):
        good = [row for row in rows if row[5]]
        if not good:
            print(f"{model}: no setting meets the accuracy target")
            continue
        opts = min(good, key=lambda row: row[1])[0]
        chosen[model] = (opts, best_wall(name, model=model, **opts))
    print()
    for model, (opts, wall) in chosen.items():
        k = f", k = {opts['stiffness']:.0e} N*m/rad, c = {opts['damping']:.0e} N*m*s/rad" if "stiffness" in opts else ""
        print(f"{model:<10} cheapest at the target: {opts['method']} rtol {opts['rtol']:.0e}{k}: "
              f"{wall:.3f} s = {t_sim / wall:.0f}x real time (best of 5)")
    if len(chosen) == 2:
        ratio = chosen["compliant"][1] / chosen["switching"][1]
        print(f"mode switching vs compliant at matched accuracy: {ratio:.1f}x faster (goal 10x)")
    print(f"goal 100x real time: {'met' if 'switching' in chosen and t_sim / chosen['switching'][1] >= 100 else 'not met'}")


REALTIME_GOALS = {"ht740_improved": 150.0, "ht740_turbo": 50.0, "ht740_turbo_iterative": 30.0}


def realtime(repeats: int = 5) -> None:
    """Real-time factors of the bundled scenarios as they are (scenario loading not timed). On a
    machine shared with other work the wall time varies with the load; the process's CPU time
    (``time.process_time``, one thread: the BLAS is limited to one) varies much less. ``RHS``: full
    right-hand-side evaluations; ``inputs``: evaluations of the input vector alone (the torque
    events at the step ends; with the compiled right-hand side, one evaluation gives every event's
    value there); ``met``: the wall-time factor against the goal. The compiled right-hand side
    (``transgen.sim.solve.kernel``) is built first where it is not (:func:`~.jit.expect_many_runs`:
    without that, the first run of a fresh install goes on in Python and so would every run
    measured here); ``TRANSGEN_JIT=0`` measures the Python path."""
    from transgen.sim.core.jit import expect_many_runs, jit_enabled

    expect_many_runs()  # the compiled path, built now if it is not (else a first run goes on in Python)
    print(f"real-time factor = simulated time / time of the run, in-process, median of {repeats} "
          f"(wall and CPU time); right-hand side: {'compiled' if jit_enabled() else 'Python'}")
    print(f"  {'scenario':<24} {'t_sim [s]':>9} {'wall [s]':>9} {'x real':>7} {'CPU [s]':>8} {'x CPU':>7} "
          f"{'RHS':>7} {'inputs':>7} {'goal':>6}  met")
    for name, goal in REALTIME_GOALS.items():
        s = load_scenario(name)
        s.run()  # warm-up: map tables, lazily built caches, imports, the compiled right-hand side
        t_sim = s.options.t_end - s.options.t_start
        walls, cpus = [], []
        for _ in range(repeats):
            s = load_scenario(name)
            t, c = time.perf_counter(), time.process_time()
            r = s.run()
            walls.append(time.perf_counter() - t)
            cpus.append(time.process_time() - c)
        wall, cpu = float(np.median(walls)), float(np.median(cpus))
        print(f"  {name:<24} {t_sim:>9g} {wall:>9.3f} {t_sim / wall:>7.1f} {cpu:>8.3f} {t_sim / cpu:>7.1f} "
              f"{r.stats['rhs_evaluations']:>7} {r.stats.get('input_evaluations', 0):>7} {goal:>5g}x  "
              f"{'yes' if t_sim / wall >= goal else 'no'}" + ("" if r.success else f"  FAILED: {r.message}"), flush=True)


if __name__ == "__main__":
    args = [a for a in sys.argv[1:] if not a.startswith("--")]
    if "--realtime" in sys.argv:
        realtime(int(args[0]) if args and "--repeats" in sys.argv else 5)
    else:
        main(*args, quick="--quick" in sys.argv)
