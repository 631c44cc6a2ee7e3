"""Benchmark of concept synthesis (``transgen synthesize topology``): counts per stage and process
time for N = 2, 3 (whole search) and N = 4 (every ``--step``-th gear train, extrapolated).

Cases, from published ratios only: ZF 3HP22 Simpson (2 sets, 2 brakes, 2 clutches), Ford AXOD
(2 sets, 2 brakes, 3 clutches), Allison HT 740 (3 sets, 3 brakes, 2 clutches, the thesis
layout), ZF 8HP (4 sets, 2 brakes, 3 clutches, 3 engaged); with Ravigneaux compounds the
HowStuffWorks 4-speed (one compound) and the ZF 6HP (a simple set with its sun held and a
compound: ``--grounded 1``). Process time (CPU seconds of this
process) is printed: wall time is meaningless on a loaded machine. ``--levels`` sets the cell
screen's subdivisions (default: the search's, 2 up to three sets, 0 for four).

    python benchmarks/bench_topology.py [--case simpson|axod|ht740|zf8hp|hsw4|zf6hp] [--step 290] [--levels L]
    python benchmarks/bench_topology.py --case zf8hp --partial DIR   # rank what a checkpoint holds so far
"""
from __future__ import annotations

import argparse
import time

from transgen.synthesis.rank import synthesize_topology
from transgen.synthesis.search import SearchSpec, TrainResult, train_task
from transgen.synthesis.ravigneaux import spec_trains

CASES = {
    "simpson": (2, 2, 2, 2, "1=2.479,2=1.479,3=1.000,R=-2.086"),
    "axod": (2, 2, 3, 2, "1=2.77,2=1.54,3=1.00,4=0.69,R=-2.26"),
    "ht740": (3, 3, 2, 2, "1=3.69,2=2.02,3=1.38,4=1.00,R=-6.04"),
    "zf8hp": (4, 2, 3, 3, "1=4.696,2=3.130,3=2.104,4=1.667,5=1.285,6=1.000,7=0.839,8=0.667,R=-3.297"),
    # Ravigneaux compounds: (sets, brakes, clutches, engaged, ratios, ravigneaux, grounded)
    "hsw4": (1, 2, 3, 2, "1=2.4,2=1.4667,3=1.0,OD=0.6667,R=-2.0", 1, 0),
    "zf6hp": (2, 2, 3, 2, "1=4.171,2=2.340,3=1.521,4=1.143,5=0.867,6=0.691,R=-3.403", 1, 1),
}


def spec_of(case: str, levels: int | None = None) -> SearchSpec:
    sets, brakes, clutches, engaged, text, *compound = CASES[case]
    ravigneaux, grounded = compound or (0, 0)
    gears, targets = zip(*[(g, float(r)) for g, r in (item.split("=") for item in text.split(","))])
    return SearchSpec(sets, brakes, clutches, engaged, gears, targets, levels=levels, ravigneaux=ravigneaux,
                      grounded=grounded)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--case", choices=sorted(CASES), default="simpson")
    parser.add_argument("--step", type=int, default=0, help="search only every STEP-th gear train (0: all)")
    parser.add_argument("--levels", type=int, help="subdivisions of the screen's cells (default: the search's)")
    parser.add_argument("--partial", metavar="DIR", help="rank the trains finished so far in DIR's checkpoint")
    args = parser.parse_args()
    spec = spec_of(args.case, args.levels)
    start = time.process_time()
    if args.partial:
        return partial(spec, args.partial)
    if not args.step:
        result = synthesize_topology(spec, top=20)
        print(f"{args.case}: trains {result.trains}, counts {result.counts}, "
              f"process time {time.process_time() - start:.1f} s")
        for c in result.candidates[:5]:
            d = c.to_dict()
            print(f"  {c.rank}. error {c.max_ratio_error:.3%} in {d['input']} out {d['output']} "
                  f"{d['elements']} table {c.gears} teeth {c.teeth}")
        return
    all_trains = spec_trains(spec)
    t_trains = time.process_time() - start
    sample = all_trains[::args.step]
    total = TrainResult()
    t0 = time.process_time()
    for train in sample:
        total.merge(train_task(train, spec))
    per = (time.process_time() - t0) / len(sample)
    scale = len(all_trains) / len(sample)
    print(f"{args.case}: {len(all_trains)} trains (enumerated in {t_trains:.0f} s); sample of {len(sample)}: "
          f"enumerated {total.enumerated}, distinct {total.distinct}, feasible {total.feasible}, screened "
          f"{total.screened}, refined {total.refined}, fitted {total.fitted}; {per:.2f} s per train, "
          f"whole search about {per * len(all_trains) / 3600:.1f} h on one core; the whole space about "
          f"{total.enumerated * scale:.3g} enumerated, {total.distinct * scale:.3g} distinct, "
          f"{total.feasible * scale:.3g} feasible")


def partial(spec: SearchSpec, folder: str) -> None:
    """Counts and the ranking of the trains a (running or stopped) search has finished."""
    from transgen.synthesis.checkpoint import Checkpoint
    from transgen.synthesis.rank import rank_fitted

    all_trains = spec_trains(spec)
    saved = Checkpoint(folder, spec, all_trains)
    total = TrainResult()
    for index in sorted(saved.done):
        total.merge(saved.done[index])
    result = rank_fitted(spec, total, len(all_trains), top=20)
    print(f"{len(saved.done)} of {len(all_trains)} trains done (last {max(saved.done, default=-1)}); counts "
          f"{result.counts}")
    for c in result.candidates:
        d = c.to_dict()
        print(f"  {c.rank}. error {c.max_ratio_error:.3%} in {d['input']} out {d['output']} {d['elements']} "
              f"table {' '.join(g + ':' + ''.join(e) for g, e in c.gears.items())} k "
              f"{' '.join(f'{v:.3f}' for v in c.k)} teeth {c.teeth}")


if __name__ == "__main__":
    main()
