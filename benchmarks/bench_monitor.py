"""Cost of the run-time invariant monitor (sim/monitor.py): every bundled scenario with the
monitor on and off, best of ``--repeats`` runs each, on the scenario's own solver.

Goal (issue 10): the monitor costs at most 5 % of the run time.
"""
import argparse
import time
import warnings
from dataclasses import replace

from transgen.sim.scenario import bundled_scenarios, load_scenario


def best_wall(name: str, monitor: bool, repeats: int) -> float:
    best = float("inf")
    for _ in range(repeats):
        sc = load_scenario(name)
        sc.options = replace(sc.options, monitor=monitor)
        start = time.perf_counter()
        result = sc.run()
        best = min(best, time.perf_counter() - start)
        assert result.success, result.message
    return best


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=5)
    args = parser.parse_args()
    warnings.simplefilter("ignore")
    total_on = total_off = 0.0
    print(f"{'scenario':<26}{'off [s]':>9}{'on [s]':>9}{'overhead':>10}")
    for name in sorted(bundled_scenarios()):
        # interleaved, so that a change of the machine's load hits both
        off = best_wall(name, False, args.repeats)
        on = best_wall(name, True, args.repeats)
        total_on += on
        total_off += off
        print(f"{name:<26}{off:>9.3f}{on:>9.3f}{(on - off) / off:>9.1%}")
    print(f"{'all':<26}{total_off:>9.3f}{total_on:>9.3f}{(total_on - total_off) / total_off:>9.1%}   (goal <= 5 %)")


if __name__ == "__main__":
    main()
