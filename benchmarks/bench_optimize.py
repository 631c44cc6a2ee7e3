"""Speed of shift calibration (transgen.sim.study.optimize): `transgen optimize` on a scenario
(default ht740_original, its three upshifts), one shift at a time, on N local worker processes
(default 2) or serially.

Printed per shift: evaluations, wall seconds, evaluations per second (wall), the CPU seconds of
the evaluations (each worker's process time, summed: what the shift costs on any machine, also a
loaded one) and the CPU seconds per shift on N cores (that sum / N plus this process's own CPU:
the run up to the shift, the optimizer's bookkeeping), and the cost of one window evaluation
against a whole run of the scenario. Goal (issue 12): each shift in under 60 s on 2 cores.

Wall times on a machine shared with other work are not the machine's speed: read the CPU figures.

With an engine at the input the engine torque intervention is tuned too (the clutches with half of a
shift's evaluations, then all sixteen parameters with the rest); --no-engine-torque measures the
clutches alone.

    python benchmarks/bench_optimize.py [--scenario ht740_original] [--workers 2] [--evaluations 1600]
                                        [--no-engine-torque]
"""
import argparse
import time

from transgen.sim import load_scenario
from transgen.sim.study import LocalExecutor, SerialExecutor
from transgen.sim.study.optimize import optimize


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--scenario", default="ht740_original")
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--evaluations", type=int, default=1600)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--no-engine-torque", action="store_true", help="tune the clutches only")
    args = parser.parse_args()

    start = time.process_time()
    for _ in range(3):
        load_scenario(args.scenario).run()
    whole = (time.process_time() - start) / 3
    executor = SerialExecutor() if args.workers == 1 else LocalExecutor(args.workers)
    print(f"{args.scenario}: a whole run costs {whole:.3f} s CPU; {executor!r}, {args.evaluations} evaluations "
          f"per shift, seed {args.seed}")
    wall = time.perf_counter()
    result = optimize(args.scenario, executor=executor, seed=args.seed, max_evaluations=args.evaluations,
                      engine_torque=False if args.no_engine_torque else None)
    wall = time.perf_counter() - wall
    print(f"  {'shift':<6}{'evals':>7}{'wall s':>9}{'evals/s':>9}{'eval CPU s':>12}{'CPU s/eval':>12}"
          f"{'window/run':>12}{'s/shift on ' + str(args.workers):>16}")
    for s in result.shifts:
        per_eval = s.evaluation_cpu_time / s.evaluations
        own = s.cpu_time - (s.evaluation_cpu_time if args.workers == 1 else 0.0)
        on_cores = s.evaluation_cpu_time / args.workers + own
        print(f"  {s.plan.name:<6}{s.evaluations:>7}{s.wall_time:>9.1f}{s.evaluations / s.wall_time:>9.2f}"
              f"{s.evaluation_cpu_time:>12.1f}{per_eval:>12.3f}{per_eval / whole:>12.2f}{on_cores:>16.1f}")
    total = sum(s.evaluations for s in result.shifts)
    print(f"  all shifts: {total} evaluations in {wall:.1f} s wall, {total / wall:.2f} evaluations/s; "
          f"feasible: {result.feasible}")


if __name__ == "__main__":
    main()
