"""Where one optimizer evaluation's CPU goes (transgen.sim.study.optimize.evaluate_candidate): the
candidates of the first generations of a seeded `transgen optimize` run of a scenario (default
ht740_original, all its shifts; recorded in this process, as a worker gets them), evaluated again
in parts: loading the scenario from its texts with the candidate's overrides, running the shift
window from the saved state, the shift metrics, and the whole evaluation; and pickling a task with
its shared data (what the local pool sends per candidate).

Printed: milliseconds of process CPU per evaluation, per shift and over all, the best of
--repeats passes (process time: a loaded machine slows it less than the wall clock, but still
does; compare figures of one invocation).

    python benchmarks/bench_evaluation.py [--scenario ht740_original] [--evaluations 108] [--repeats 3]
"""
import argparse
import pickle
import time

from transgen.sim import load_scenario
from transgen.sim.study import SerialExecutor
from transgen.sim.study.optimize import evaluate_candidate, optimize, shift_metrics


class RecordingExecutor(SerialExecutor):
    """Runs in this process and keeps every (shared, task) it ran."""

    def __init__(self):
        self.tasks = []

    def run(self, fn, shared, tasks):
        for task in tasks:
            self.tasks.append((shared, task))
            yield fn(shared, task)


def parts(shared, task) -> dict:
    """CPU seconds of the parts of one evaluation."""
    _, overrides, t_end = task
    out = {}
    t0 = time.process_time()
    blob = pickle.dumps((shared, task))
    pickle.loads(blob)
    t1 = time.process_time()
    scenario = load_scenario(shared["path"], overrides, shared["files"])
    t2 = time.process_time()
    result = scenario.run(start=shared["state"], t_end=t_end)
    t3 = time.process_time()
    on, off, t_start, name = shared["shift"]
    shift_metrics(result, on, off, t_start, name)
    t4 = time.process_time()
    evaluate_candidate(shared, task)
    t5 = time.process_time()
    out.update(pickle=t1 - t0, load=t2 - t1, run=t3 - t2, metrics=t4 - t3, whole=t5 - t4)
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--scenario", default="ht740_original")
    parser.add_argument("--evaluations", type=int, default=108, help="simulations per shift of the recorded run (all stages, as optimize's --evaluations)")
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()

    recorder = RecordingExecutor()
    optimize(args.scenario, executor=recorder, seed=args.seed, max_evaluations=args.evaluations)
    shifts = {}
    for shared, task in recorder.tasks:
        shifts.setdefault(shared["shift"][3], []).append((shared, task))
    names = ("pickle", "load", "run", "metrics", "whole")
    print(f"{args.scenario}: {len(recorder.tasks)} candidates of a seed-{args.seed} run "
          f"(--evaluations {args.evaluations}); ms of CPU per evaluation, best of {args.repeats}")
    print(f"  {'shift':<8}{'evals':>6}" + "".join(f"{n:>9}" for n in names))
    total = dict.fromkeys(names, 0.0)
    for shift, tasks in shifts.items():
        best = None
        for _ in range(args.repeats):
            sums = dict.fromkeys(names, 0.0)
            for shared, task in tasks:
                for k, v in parts(shared, task).items():
                    sums[k] += v
            best = sums if best is None or sums["whole"] < best["whole"] else best
        for k in names:
            total[k] += best[k]
        print(f"  {shift:<8}{len(tasks):>6}" + "".join(f"{1000 * best[k] / len(tasks):>9.2f}" for k in names))
    n = len(recorder.tasks)
    print(f"  {'all':<8}{n:>6}" + "".join(f"{1000 * total[k] / n:>9.2f}" for k in names))
    size = max(len(pickle.dumps(shared)) for shared, _ in recorder.tasks)
    print(f"  shared data pickled per task: {size} bytes")


if __name__ == "__main__":
    main()
