"""Benchmark of the simulator's losses (``[losses]``, docs/losses.md): on every bundled scenario,
the run without losses, with drag + spin + pump, and with the mesh losses too; the energy
balance's worst segment (fraction of the monitor's tolerance) and the CPU time of each, and the
energy by kind of each run with losses. ``--solvers`` repeats the full-loss runs with the five
solvers on the named scenarios.

    python benchmarks/bench_losses.py [--scenarios a b ...] [--solvers simple2_upshift oneway_overrun]
                                      [--launch zf8hp70 ...]

``--launch NAME`` adds the car launch of ``transgen scenario new NAME`` (written to a temporary
folder) to the scenarios.

Figures are CPU seconds (``time.process_time``) of one run after a warm-up run of the same
scenario, side by side in one process.
"""
from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

from transgen.sim.scenario import load_scenario
from transgen.sim.scenario.library import bundled_scenarios

CONFIGS = (("off", None), ("drag+spin+pump", ["drag", "spin", "pump"]), ("+mesh", ["drag", "spin", "pump", "mesh"]))
SOLVERS = ("DOP853", "RK45", "LSODA", "Radau", "BDF")


def run(path, kinds, method=None):
    overrides = {}
    if kinds is not None:
        overrides["losses.kinds"] = kinds
    if method is not None:
        overrides["simulation.method"] = method
    sc = load_scenario(path, overrides or None)
    t0 = time.process_time()
    res = sc.run()
    cpu = time.process_time() - t0
    worst = res.stats.get("invariants", {}).get("invariants", {}).get("energy_balance", {}).get("worst")
    return res, cpu, worst


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--scenarios", nargs="*", default=None, help="bundled scenario names (default: all; none: -)")
    p.add_argument("--solvers", nargs="*", default=["simple2_upshift", "oneway_overrun"],
                   help="scenarios run with the five solvers and every loss on")
    p.add_argument("--launch", nargs="*", default=[], help="mechanisms whose derived car launch is run too")
    args = p.parse_args(argv)
    bundled = dict(bundled_scenarios())
    names = args.scenarios if args.scenarios is not None else sorted(bundled)
    folder = Path(tempfile.mkdtemp(prefix="bench_losses_"))
    for mech in args.launch:
        from transgen.cli import main as cli

        out = folder / f"{mech}_launch.toml"
        if cli(["scenario", "new", mech, "--vehicle", "car", "-o", str(out)]) != 0:
            return 2
        bundled[f"{mech}_launch"] = out
        names.append(f"{mech}_launch")
    failed = 0
    print(f"{'scenario':<34}{'losses':<16}{'ok':>4}{'CPU [s]':>9}{'balance worst':>15}{'losses [J]':>12}")
    for name in names:
        run(bundled[name], None)  # warm-up: caches, compilation
        for label, kinds in CONFIGS:
            res, cpu, worst = run(bundled[name], kinds)
            total = (res.energy.get("losses") or {}).get("total", 0.0)
            failed += not res.success
            print(f"{name:<34}{label:<16}{'yes' if res.success else 'NO':>4}{cpu:>9.2f}{worst if worst is not None else float('nan'):>15.3g}"
                  f"{total:>12.1f}" + ("" if res.success else f"  {res.message[:120]}"))
            if kinds and len(kinds) == 4 and res.energy.get("losses"):
                lo = res.energy["losses"]
                parts = ", ".join(f"drag {e} {x:.1f}" for e, x in lo["drag"].items())
                parts += "".join(f", {k} {lo[k]:.1f}" for k in ("spin", "pump", "mesh") if k in lo)
                print(f"{'':<34}by kind [J]: {parts}; dissipated {res.energy['dissipated']:.1f}")
    for name in args.solvers:
        for method in SOLVERS:
            res, cpu, worst = run(bundled[name], CONFIGS[2][1], method)
            failed += not res.success
            print(f"{name:<34}{'all, ' + method:<16}{'yes' if res.success else 'NO':>4}{cpu:>9.2f}{worst if worst is not None else float('nan'):>15.3g}"
                  + ("" if res.success else f"  {res.message[:120]}"))
    return 1 if failed else 0


if __name__ == "__main__":
    raise SystemExit(main())
