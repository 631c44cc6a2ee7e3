"""An FMU run against ``transgen simulate``, side by side (issue 24): for each scenario the wall
time of the simulator's run (after a warm-up run, so that numba's compilation is not counted),
of the export (``transgen.fmu.export_fmu``: tables, C generation, gcc, archive) and of FMPy's
runs of the FMU (Model Exchange with CVode at a 1 ms output interval; Co-Simulation at 1 ms and
10 ms; and in one communication step over the whole run, which times the FMU's C integrator
without FMPy's Python loop per step), best of ``--repeats``, with the largest speed difference [% of range] at the simulator's
sample times and the largest event-time difference [s]. Needs fmpy and a C compiler. Prints
figures; asserts nothing (the checks are tests/test_fmu.py).

    python benchmarks/bench_fmu.py [--repeats N] [SCENARIO ...]
"""
from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

import numpy as np
from fmpy import simulate_fmu

from transgen.fmu import export_fmu
from transgen.sim.scenario.load import load_scenario

DEFAULT = ["coupled_clutches", "freewheel_clutch", "zf3hp22_manual_first_coast", "ht740_improved"]


def best(f, repeats: int):
    times, out = [], None
    for _ in range(repeats):
        t = time.perf_counter()
        out = f()
        times.append(time.perf_counter() - t)
    return min(times), out


def compare(sc, res, r) -> tuple[float, float]:
    """(largest speed difference [% of range] at the simulator's samples, largest event shift [s])."""
    tr = sc.powertrain.transmission
    common = np.isin(np.round(r["time"], 9), np.round(res.time, 9))
    worst = 0.0
    for link in tr.links:
        ref = res[f"w_{link}"]
        span = max(float(np.ptp(ref)), 1e-9)
        worst = max(worst, float(np.max(np.abs(r[f"w_{link}"][common] - np.interp(r["time"][common], res.time, ref))))
                    / span * 100)
    le, tc = r["lockedElements"], r["t_mode_change"]
    got = [float(tc[k]) for k in range(1, len(le)) if le[k] != le[k - 1]]
    want = [span.t0 for span in res.modes[1:]]
    shift = max((abs(a - b) for a, b in zip(got, want)), default=0.0) if len(got) == len(want) else float("nan")
    return worst, shift


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("scenarios", nargs="*", default=DEFAULT)
    p.add_argument("--repeats", type=int, default=3)
    args = p.parse_args()
    print(f"{'scenario':<28} {'t_end':>6} {'simulate':>9} {'export':>7} {'ME 1ms':>8} {'CS 1ms':>8} {'CS 10ms':>8}"
          f" {'CS 1 step':>9}   max speed diff [% range] / event shift [s] (ME, CS 1 ms, CS 10 ms)")
    with tempfile.TemporaryDirectory() as tmp:
        for name in args.scenarios:
            sc = load_scenario(name)
            sc.run()  # warm-up: numba compiles the right-hand side once per process
            t_sim, res = best(sc.run, args.repeats)
            path = Path(tmp, f"{name}.fmu")
            t_exp, _ = best(lambda: export_fmu(name, path), 1)
            outputs = [f"w_{k}" for k in sc.powertrain.transmission.links] + ["lockedElements", "t_mode_change"]
            runs = []
            for kind, dt in (("ModelExchange", 1e-3), ("CoSimulation", 1e-3), ("CoSimulation", 1e-2)):
                t_run, r = best(lambda: simulate_fmu(str(path), fmi_type=kind, stop_time=sc.options.t_end,
                                                     output_interval=dt, output=outputs), args.repeats)
                runs.append((t_run, compare(sc, res, r)))
            t_one, _ = best(lambda: simulate_fmu(str(path), fmi_type="CoSimulation", stop_time=sc.options.t_end,
                                                 output_interval=sc.options.t_end, output=outputs), args.repeats)
            diffs = ", ".join(f"{d:.1e} / {s:.0e}" for _, (d, s) in runs)
            print(f"{name:<28} {sc.options.t_end:>6g} {t_sim:>8.3f}s {t_exp:>6.2f}s "
                  + " ".join(f"{t:>7.3f}s" for t, _ in runs) + f" {t_one:>8.3f}s   {diffs}", flush=True)


if __name__ == "__main__":
    main()
