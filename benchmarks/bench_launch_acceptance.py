"""Benchmark: are the untuned launches of 'transgen scenario new' acceptable, gearbox by gearbox?

For every gearbox (the bundled mechanisms with a forward gear table, and the real gearboxes of
``benchmarks/gearboxes/*.mech``, which are not in the package) and each vehicle class, derive the
launch scenario as ``transgen scenario new FILE --vehicle V`` does, simulate it as ``transgen
simulate --report`` does, and judge every upshift by the rule of issue 21
(:mod:`transgen.sim.derive.acceptance`: no bindup, flare <= 50 rpm, torque hole <= 100*(1 - 1/step) + 20
points). Prints one row per upshift (bindup [N*m], flare [rpm], hole and its limit [%], largest
|jerk| [m/s^3], exact and of the 10 Hz filtered acceleration, acceptable) and the totals; asserts nothing.

    python benchmarks/bench_launch_acceptance.py [--vehicle car|truck|both] [--only NAME ...] [--json FILE]
"""
from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

from transgen.library import bundled_mechanisms, bundled_path
from transgen.language import load_mechanism
from transgen.sim.derive.acceptance import launch_acceptance

HERE = Path(__file__).resolve().parent


def gearboxes() -> list[tuple[str, Path]]:
    """(label, path) of every gearbox of the benchmark: bundled ones with two forward gears, then
    ``benchmarks/gearboxes``."""
    from transgen.kinematics import gear_ratios

    out = []
    for name in bundled_mechanisms():
        mech = load_mechanism(name)
        if sum(1 for r in gear_ratios(mech).values() if r is not None and r > 0) >= 2:
            out.append((name, bundled_path(name + ".mech")))
    out += [(f"bench/{p.stem}", p) for p in sorted((HERE / "gearboxes").glob("*.mech"))]
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--vehicle", choices=("car", "truck", "both"), default="both")
    ap.add_argument("--only", nargs="*", help="gearbox labels to run (default: all)")
    ap.add_argument("--json", metavar="FILE", help="write every row as JSON here")
    args = ap.parse_args(argv)
    vehicles = ("car", "truck") if args.vehicle == "both" else (args.vehicle,)
    rows, failures = [], []
    head = f"{'gearbox':<28} {'veh':<5} {'shift':<6} {'step':>5} {'bindup':>7} {'flare':>6} {'hole':>6} {'limit':>6} {'jerk':>7} {'filt.':>6}  ok"
    print(head)
    print(f"{'':<28} {'':<5} {'':<6} {'':>5} {'N*m':>7} {'rpm':>6} {'%':>6} {'%':>6} {'m/s^3':>7} {'m/s^3':>6}")
    t_all = time.perf_counter()
    for label, path in gearboxes():
        if args.only and label not in args.only and Path(label).name not in args.only:
            continue
        mech = load_mechanism(str(path))
        for vehicle in vehicles:
            t0 = time.perf_counter()
            try:
                _, verdicts, _ = launch_acceptance(mech, vehicle)
            except Exception as exc:  # a gearbox the generator refuses: reported, counted as not acceptable
                failures.append((label, vehicle, f"{type(exc).__name__}: {exc}"))
                print(f"{label:<28} {vehicle:<5} FAILED: {type(exc).__name__}: {str(exc)[:120]}")
                continue
            for v in verdicts:
                jerk = f"{v.jerk:7.1f}" if v.jerk is not None else "      -"
                jerk += f" {v.jerk_filtered:6.1f}" if v.jerk_filtered is not None else "      -"
                print(f"{label:<28} {vehicle:<5} {v.name:<6} {v.step:5.3f} {v.bindup:7.1f} {v.flare:6.1f} "
                      f"{v.hole:6.1f} {v.limit:6.1f} {jerk}  {'yes' if v.acceptable else 'NO'}"
                      + ("" if v.completed else "  (not completed)"))
                rows.append({"gearbox": label, "vehicle": vehicle, **v.to_dict()})
            print(f"{'':<28} {vehicle:<5} ({time.perf_counter() - t0:.1f} s)", file=sys.stderr)
    ok = sum(r["acceptable"] for r in rows)
    print(f"\nacceptable upshifts: {ok} of {len(rows)}; launches refused by the generator: {len(failures)}")
    for veh in vehicles:
        mine = [r for r in rows if r["vehicle"] == veh]
        jerks = sorted(r["jerk"] for r in mine if r["jerk"] is not None)
        filt = sorted(r["jerk_filtered"] for r in mine if r.get("jerk_filtered") is not None)
        if mine:
            med = jerks[len(jerks) // 2] if jerks else float("nan")
            print(f"  {veh}: {sum(r['acceptable'] for r in mine)} of {len(mine)} acceptable; "
                  f"bindup in {sum(r['bindup'] > 0 for r in mine)}, flare > 50 rpm in "
                  f"{sum(r['flare'] > 50 for r in mine)}, hole over its limit in {sum(r['hole'] > r['limit'] for r in mine)}; "
                  f"jerk median {med:.1f}, max {max(jerks, default=float('nan')):.1f} m/s^3 (10 Hz filtered: median "
                  f"{filt[len(filt) // 2] if filt else float('nan'):.1f}, max {max(filt, default=float('nan')):.1f})")
    for label, veh, why in failures:
        print(f"  refused: {label} {veh}: {why[:160]}")
    print(f"({time.perf_counter() - t_all:.0f} s)")
    if args.json:
        Path(args.json).write_text(json.dumps({"rows": rows, "failures": failures}, indent=1, default=str))
    return 0


if __name__ == "__main__":
    sys.exit(main())
