"""Cost of the run-time invariant monitor (sim/solve/monitor.py) on every bundled scenario, on the
scenario's own solver: the time spent inside the monitor's checks against the run's wall time
(best of ``--repeats`` runs), and, for reference, the wall time with the monitor switched off
(that difference is within the machine's noise).

Goal (issue 10): the monitor costs at most 5 % of the run time.
"""
import argparse
import time
import warnings
from dataclasses import replace

from transgen.sim.solve.monitor import InvariantMonitor
from transgen.sim.scenario.load import bundled_scenarios, load_scenario

_check = InvariantMonitor.check
_spent = [0.0]


def _timed_check(self, *args, **kwargs):
    start = time.perf_counter()
    try:
        return _check(self, *args, **kwargs)
    finally:
        _spent[0] += time.perf_counter() - start


def best_run(name: str, monitor: bool, repeats: int) -> tuple[float, float]:
    """(wall time, time inside the monitor) of the fastest of ``repeats`` runs."""
    best = (float("inf"), 0.0)
    for _ in range(repeats):
        sc = load_scenario(name)
        sc.options = replace(sc.options, monitor=monitor)
        _spent[0] = 0.0
        start = time.perf_counter()
        result = sc.run()
        wall = time.perf_counter() - start
        assert result.success, result.message
        best = min(best, (wall, _spent[0]))
    return best


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=5)
    args = parser.parse_args()
    warnings.simplefilter("ignore")
    InvariantMonitor.check = _timed_check
    totals = [0.0, 0.0, 0.0]
    print(f"{'scenario':<28}{'run [s]':>9}{'monitor [ms]':>14}{'share':>8}{'off [s]':>9}")
    for name in sorted(bundled_scenarios()):
        wall, spent = best_run(name, True, args.repeats)
        off, _ = best_run(name, False, args.repeats)
        for k, v in enumerate((wall, spent, off)):
            totals[k] += v
        print(f"{name:<28}{wall:>9.3f}{spent * 1e3:>14.2f}{spent / wall:>8.1%}{off:>9.3f}")
    wall, spent, off = totals
    print(f"{'all':<28}{wall:>9.3f}{spent * 1e3:>14.2f}{spent / wall:>8.1%}{off:>9.3f}   (goal <= 5 %)")


if __name__ == "__main__":
    main()
