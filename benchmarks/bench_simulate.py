"""Benchmark of the shift simulator (issue goals: mode switching >= 100x faster than real time on
one core, >= 10x faster than the compliant model at equal accuracy, energy residual < 0.1 %).
Prints figures; asserts nothing.

    python benchmarks/bench_simulate.py [scenario]
"""
from __future__ import annotations

import dataclasses
import sys
import time

import numpy as np

from transgen.sim.scenario import load_scenario


def run(name: str, **changes):
    s = load_scenario(name)
    s.options = dataclasses.replace(s.options, **changes)
    t = time.perf_counter()
    r = s.run()
    return r, time.perf_counter() - t


def accuracy(r, ref) -> tuple[float, float]:
    """Largest event-time difference [s] and largest output-speed difference [rad/s] vs ``ref``."""
    ev = [e.t for e in r.events if e.kind in ("lock", "unlock")]
    ev_ref = [e.t for e in ref.events if e.kind in ("lock", "unlock")]
    dt = max((abs(a - b) for a, b in zip(ev, ev_ref)), default=float("nan")) if len(ev) == len(ev_ref) else float("inf")
    out = ref.meta["links"][-1]
    grid = np.linspace(ref.time[0], ref.time[-1], 2001)
    dw = float(np.max(np.abs(np.interp(grid, r.time, r[f"w_{out}"]) - np.interp(grid, ref.time, ref[f"w_{out}"]))))
    return dt, dw


def main(name: str = "ht740_improved") -> None:
    t_sim = load_scenario(name).options.t_end - load_scenario(name).options.t_start
    print(f"{name}: {t_sim:g} s of simulated time")
    ref, _ = run(name, method="DOP853", rtol=1e-11, atol=1e-11)
    print(f"  reference: switching model, DOP853, rtol 1e-11 ({ref.stats['events']} events)")
    print(f"  {'model':<10} {'method':<7} {'rtol':>6} {'wall [s]':>9} {'x real':>7} {'RHS':>7} {'events':>6} "
          f"{'max |dt_event| [s]':>18} {'max |dw_out| [rad/s]':>20} {'energy resid.':>13}")
    rows = [("switching", dict(method="LSODA", rtol=1e-7, atol=1e-7)),
            ("switching", dict(method="DOP853", rtol=1e-6, atol=1e-6)),
            ("switching", dict(method="RK45", rtol=1e-5, atol=1e-5)),
            ("compliant", dict(method="Radau", rtol=1e-6, atol=1e-6, stiffness=1e5, damping=100.0)),
            ("compliant", dict(method="Radau", rtol=1e-6, atol=1e-6, stiffness=1e6, damping=300.0)),
            ("compliant", dict(method="BDF", rtol=1e-6, atol=1e-6, stiffness=1e6, damping=300.0))]
    for model, opts in rows:
        r, wall = run(name, model=model, **opts)
        dt, dw = accuracy(r, ref) if r.success else (float("nan"), float("nan"))
        print(f"  {model:<10} {opts['method']:<7} {opts['rtol']:>6.0e} {wall:>9.3f} {t_sim / wall:>7.1f} "
              f"{r.stats['rhs_evaluations']:>7} {r.stats['events']:>6} {dt:>18.2e} {dw:>20.2e} "
              f"{r.energy.get('relative_residual', float('nan')):>13.1e}" + ("" if r.success else f"  FAILED: {r.message}"))


if __name__ == "__main__":
    main(*sys.argv[1:])
