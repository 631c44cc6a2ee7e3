"""Benchmark of a whole drive cycle: the ZF 8HP70 car (``scenario new zf8hp70 --vehicle car
--maneuver cycle``) driven through the WLTC class 3b (1800 s) by the driver model. Prints the
tracking by the WLTP rule (+-2 km/h, +-1 s), the shift counts by kind, the energies, the fuel
where there is one and the run time (wall, after a short warm-up run that compiles the
right-hand side); asserts nothing.

    python benchmarks/bench_cycle.py [--mechanism zf8hp70] [--vehicle car] [--cycle wltc_class3b]
                                     [--t-end S] [--dt S] [--json]

``--t-end``: stop there (a piece of the cycle); ``--dt``: the driver's sampling time.
"""
from __future__ import annotations

import argparse
import json
import tempfile
import time
from pathlib import Path

from transgen import load_mechanism
from transgen.sim.analysis.cycle_report import cycle_report, cycle_text
from transgen.sim.control.driver import Driver
from transgen.sim.engine.fuel import fuel_of
from transgen.sim.derive.launch import derive_launch
from transgen.sim.derive.maneuver import maneuver_scenario
from transgen.sim.analysis.report import energy_balance
from transgen.sim.scenario.load import load_scenario


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--mechanism", default="zf8hp70")
    p.add_argument("--vehicle", default="car")
    p.add_argument("--cycle", default="wltc_class3b")
    p.add_argument("--t-end", type=float, default=None)
    p.add_argument("--dt", type=float, default=None)
    p.add_argument("--json", action="store_true")
    args = p.parse_args(argv)
    mech = load_mechanism(args.mechanism)
    text = maneuver_scenario(mech, args.vehicle, "cycle", args.mechanism, derive_launch(mech, args.vehicle), args.cycle)
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "cycle.toml"
        path.write_text(text)
        overrides = {} if args.dt is None else {"driver.dt": args.dt}
        load_scenario(path, {**overrides, "simulation.t_end": 5.0}).run()  # compile the right-hand side
        if args.t_end is not None:
            overrides["simulation.t_end"] = args.t_end
        scenario = load_scenario(path, overrides)
    wall = time.perf_counter()
    result = scenario.run()
    wall = time.perf_counter() - wall
    driver = next(c for c in scenario.powertrain.controllers if isinstance(c, Driver))
    report = cycle_report(result, driver.trace, fuel=fuel_of(scenario.powertrain))
    balance = energy_balance(result)
    if args.json:
        print(json.dumps({"success": result.success, "message": result.message, "wall_time": wall,
                          "cycle": report.to_dict(), "energy_balance": balance, "stats": result.stats}, default=str))
        return 0
    print(f"{scenario.title}: {'completed' if result.success else 'FAILED: ' + result.message}")
    print(cycle_text(report))
    print(f"  energy balance residual          {balance.get('relative_residual', float('nan')):.2e} of the work in "
          f"({'PASS' if balance.get('passed') else 'FAIL'})")
    print(f"  wall time                        {wall:.1f} s for {result.time[-1] - result.time[0]:.0f} s simulated "
          f"({(result.time[-1] - result.time[0]) / wall:.1f}x real time), {result.stats.get('segments')} segments, "
          f"{result.stats.get('rhs_evaluations')} right-hand-side evaluations")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
