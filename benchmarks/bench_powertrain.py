"""Cost of the full turbocharged powertrain run (thesis 4.6), both turbo algorithms.

Run:  python benchmarks/bench_powertrain.py [--plot DIR]

Scenarios ``ht740_turbo`` (basic algorithm) and ``ht740_turbo_iterative``: turbodiesel, torque
converter with lock-up, HT-740, driveline and vehicle, 20 s, the scenario's solver settings
(BDF). Prints wall time (best of three runs), real-time factor (simulated / wall time; goal >= 20), right-hand-side
evaluations, integration segments and events, the part of the wall time spent sampling the
output (``output_dt`` = 0.01 s, every sample re-evaluates the engine), the shift and lock-up
events, and the turbocharger report comparing the two algorithms. ``--plot DIR`` also writes the
thesis Fig. 4.17-4.24 comparison plots.
"""
import argparse
import time
import warnings

import transgen.sim.solve.switching as switching_module
from transgen.sim.engine import RPM
from transgen.sim.engine.turbo_report import turbo_report
from transgen.sim.model.turbodiesel import TurbodieselSource
from transgen.sim.scenario.load import load_scenario

SCENARIOS = (("basic", "ht740_turbo"), ("iterative", "ht740_turbo_iterative"))


def run(name: str, repeats: int = 3) -> dict:
    """The scenario's run, timed as the best of ``repeats`` fresh runs (the machine's load moves
    single timings by some 20 %)."""
    sc = None
    best = (float("inf"), 0.0, None)
    collect = switching_module.collect
    for _ in range(repeats):
        sc = load_scenario(name)
        sampled = {}

        def timed_collect(*args, **kwargs):
            t0 = time.perf_counter()
            out = collect(*args, **kwargs)
            sampled["wall"] = time.perf_counter() - t0
            return out

        switching_module.collect = timed_collect
        try:
            start = time.perf_counter()
            result = sc.run()
            wall = time.perf_counter() - start
        finally:
            switching_module.collect = collect
        if wall < best[0]:
            best = (wall, sampled.get("wall", 0.0), result)
    wall, sampling, result = best
    sim_time = sc.options.t_end - sc.options.t_start
    engine = next(c.engine for c in sc.powertrain.components if isinstance(c, TurbodieselSource))
    return {"result": result, "wall": wall, "rtf": sim_time / wall, "sampling": sampling,
            "method": sc.options.method, "rtol": sc.options.rtol, "engine": engine}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--plot", metavar="DIR", help="write the comparison plots into DIR")
    args = parser.parse_args()
    warnings.simplefilter("ignore")
    runs = {kind: run(name) for kind, name in SCENARIOS}
    print("ht740_turbo, 20 s: turbodiesel + converter (lock-up) + HT-740 + driveline + vehicle")
    print(f"{'algorithm':10s} {'method':6s} {'rtol':>6s} {'wall [s]':>9s} {'x real time':>12s} {'RHS evals':>10s} "
          f"{'segments':>9s} {'events':>7s} {'sampling [s]':>13s}  result")
    for kind, r in runs.items():
        res = r["result"]
        st = res.stats
        print(f"{kind:10s} {r['method']:6s} {r['rtol']:6.0e} {r['wall']:9.2f} {r['rtf']:12.1f} "
              f"{st['rhs_evaluations']:10d} {st['segments']:9d} {st['events']:7d} {r['sampling']:13.2f}  "
              f"{'ok' if res.success else res.message}")
    for kind, r in runs.items():
        res = r["result"]
        e = res["w_E"] / RPM
        print(f"\n{kind}: engine {e[0]:.0f} rpm -> max {e.max():.0f} rpm, end {e[-1]:.0f} rpm; energy residual "
              f"{res.energy.get('relative_residual', float('nan')):.1e}")
        for ev in res.events:
            if ev.kind != "start":
                print(f"  t = {ev.t:7.3f} s  {ev.kind:<7} {' '.join(ev.elements):<4} {ev.source} -> {ev.target}")
    basic, iterative = runs["basic"]["result"], runs["iterative"]["result"]
    print()
    print(turbo_report(iterative).text())
    print(turbo_report(basic, iterative, engine=runs["basic"]["engine"]).text())
    if args.plot:
        from transgen.sim.engine.plots import plot_turbo_comparison

        for p in plot_turbo_comparison({"basic": basic, "iterative": iterative}, args.plot):
            print(f"  wrote {p}")
    rtf = runs["basic"]["rtf"]
    print(f"\nthe powertrain run (ht740_turbo, basic algorithm): {rtf:.1f}x real time, goal 20x "
          f"{'met' if rtf >= 20.0 else 'NOT met'}; the iterative variant: {runs['iterative']['rtf']:.1f}x "
          "(two Mach-number solves per evaluation)")


if __name__ == "__main__":
    main()
