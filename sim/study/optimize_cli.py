"""``transgen optimize``: the command line of :func:`transgen.sim.study.optimize.optimize` (a thin layer).

Bad options (an unknown objective term, a negative limit, an unknown shift, a bad ``--set``) are
``error:`` lines and exit 2 before anything runs. The tuned scenario, the history and the report
of the whole runs before and after follow; constraints that no candidate met are said with the
best candidate and the binding constraint, and exit 1 (the files are written: the best found).
"""
from __future__ import annotations

import math
import sys
import time
from pathlib import Path

__all__ = ["add_optimize_command", "cmd_optimize", "OPTIMIZE_SCHEMA", "optimize_units"]

OPTIMIZE_SCHEMA = "transgen.optimize/1"


def add_optimize_command(sub) -> None:
    """Add ``optimize`` to the ``transgen`` parser."""
    from transgen.limits import add_force_option
    from transgen.progress import add_progress_option
    from transgen.sim.cli import _set_option

    s = sub.add_parser("optimize", help="tune the clutch apply trajectories of each shift of a scenario",
                       description="Tune the oncoming and offgoing apply trajectories of each shift (fill, torque-phase "
                                   "ramp, inertia-phase level, final rise, offgoing delay, level and release) to "
                                   "minimise a weighted objective under constraints. Raw apply tables are fitted to "
                                   "the shift template first. Each candidate simulates one shift window from the saved "
                                   "state just before it; candidates run in parallel (--workers, --scheduler). Writes "
                                   "an ordinary scenario file (it includes the original and sets the tuned "
                                   "trajectories) and a history of every evaluation.")
    s.add_argument("scenario", metavar="SCENARIO", help="scenario .toml file or bundled name")
    s.add_argument("--shift", metavar="NAME", action="append",
                   help="tune only this shift: its gears (1-2) or number (1 = first); repeatable (default: all)")
    s.add_argument("--objective", default="energy=1,hole=1,jerk=0.2,duration=0.1", metavar="TERM=W,...",
                   help="weights of the objective terms energy, hole, duration, flare, jerk, each relative to "
                        "the starting calibration (default energy=1,hole=1,jerk=0.2,duration=0.1; jerk is left out without a vehicle)")
    s.add_argument("--max-flare", type=float, default=20.0, metavar="RPM",
                   help="largest flare of the input speed [rpm] (default 20)")
    s.add_argument("--max-hole", type=float, metavar="PCT", help="deepest torque hole [%% of the output torque before]")
    bind = s.add_mutually_exclusive_group()
    bind.add_argument("--no-bindup", dest="no_bindup", action="store_true", default=True,
                      help="no bindup at any shift (the default)")
    bind.add_argument("--allow-bindup", dest="no_bindup", action="store_false", help="let the offgoing torque reverse")
    s.add_argument("--allow-chatter", action="store_true", help="let an element lock more than once in a shift")
    s.add_argument("--max-duration", type=float, metavar="S", help="longest shift duration [s]")
    s.add_argument("--max-jerk", type=float, metavar="M/S3",
                   help="largest vehicle jerk of each shift [m/s^3] (a comfort limit; needs a vehicle)")
    s.add_argument("--max-energy", type=float, metavar="KJ",
                   help="most clutch energy of a shift [kJ] (oncoming and offgoing element together)")
    s.add_argument("--max-temperature", type=float, metavar="DEGC",
                   help="highest pack temperature of a shift [degC] (lumped model, default packs; docs/losses.md)")
    s.add_argument("--no-worse-than", metavar="SCENARIO",
                   help="a reference calibration (scenario file or bundled name, run with the same --set): each tuned "
                        "shift's torque hole and clutch energy at most the reference's at the same gears")
    torque = s.add_mutually_exclusive_group()
    torque.add_argument("--engine-torque", dest="engine_torque", action="store_true", default=None,
                        help="tune the engine torque intervention too (torque-phase increase, inertia-phase reduction; "
                             "the default where the input is an engine)")
    torque.add_argument("--no-engine-torque", dest="engine_torque", action="store_false",
                        help="tune the clutch trajectories only (the scenario's own engine torque request is kept)")
    engine = s.add_mutually_exclusive_group()
    engine.add_argument("--workers", type=int, metavar="N",
                        help="local worker processes (default: one per core; 1: in this process)")
    engine.add_argument("--scheduler", metavar="tcp://HOST:PORT",
                        help="evaluate on a Dask distributed cluster (needs transgen[distributed])")
    s.add_argument("--seed", type=int, default=0, help="seed of the optimizer (default 0): the same seed, the same result")
    s.add_argument("--evaluations", type=int, default=1600, metavar="N",
                   help="simulations per shift at most, all stages (clutches, engine torque) and the start included "
                        "(default 1600)")
    s.add_argument("--population", type=int, default=12, metavar="N",
                   help="candidates per generation of the CMA-ES, evaluated together (default 12)")
    s.add_argument("-o", "--output", required=True, metavar="TUNED.toml", help="the tuned scenario file")
    s.add_argument("--history", metavar="FILE.csv",
                   help="every evaluation: shift, parameters, metrics, score (default: OUTPUT with .history.csv)")
    s.add_argument("--report", action="store_true",
                   help="print the shift report of the whole run before and after, side by side")
    s.add_argument("--json", action="store_true", help=f"print a JSON summary (schema {OPTIMIZE_SCHEMA})")
    _set_option(s)
    s.add_argument("--quiet", action="store_true", help="no progress on standard error")
    add_progress_option(s)
    add_force_option(s)
    s.set_defaults(func=cmd_optimize)


def _options(args):
    """(objective, constraints, executor) of the command line; ValueError/ScenarioError: exit 2."""
    from transgen.limits import check_optimize, check_workers

    from .executors import make_executor
    from .optimize import Constraints, parse_objective

    objective = parse_objective(args.objective)
    for name, value, low in (("--max-flare", args.max_flare, 0.0), ("--max-hole", args.max_hole, 0.0),
                             ("--max-duration", args.max_duration, 0.0), ("--max-energy", args.max_energy, 0.0),
                             ("--max-temperature", args.max_temperature, -273.15),
                             ("--max-jerk", args.max_jerk, 0.0)):
        if value is not None and not (math.isfinite(value) and value > low):
            raise ValueError(f"{name}: error: give a finite number > 0, not {value:g}")
    for name, value in (("--evaluations", args.evaluations), ("--population", args.population)):
        if value < 2:
            raise ValueError(f"{name}: error: give a whole number >= 2, not {value}")
    check_optimize(args.evaluations, args.population, args.force)
    check_workers(args.workers, args.force)
    if args.no_worse_than is not None:  # a missing reference is said before anything runs
        from transgen.sim.scenario.load import scenario_path

        scenario_path(args.no_worse_than)
    if not 0 <= args.seed < 2**32:  # the range of numpy's seed
        raise ValueError(f"--seed: error: give a whole number from 0 to 2**32 - 1, not {args.seed}")
    constraints = Constraints(no_bindup=args.no_bindup, max_flare_rpm=args.max_flare,
                              no_chatter=not args.allow_chatter, max_hole_pct=args.max_hole,
                              max_duration=args.max_duration,
                              max_energy=None if args.max_energy is None else 1e3 * args.max_energy,
                              no_worse_than=args.no_worse_than, max_temperature=args.max_temperature,
                              max_jerk=args.max_jerk)
    return objective, constraints, make_executor(args.workers, args.scheduler)


def cmd_optimize(args) -> int:
    from transgen.errors import ScenarioError
    from transgen.export import output_set, write_text
    from transgen.sim.cli import _overrides
    from transgen.sim.analysis.report import shift_report
    from transgen.sim.scenario.load import load_scenario, parse_scenario

    from .optimize import comparison_rows, intervention_text, optimize, trade_off, tuned_scenario_text

    try:
        objective, constraints, executor = _options(args)
        overrides = _overrides(args.overrides)
        output = Path(args.output)
        if output.suffix != ".toml":
            raise ValueError(f"-o {args.output}: error: the tuned scenario is a .toml file")
        history_path = Path(args.history) if args.history else output.with_suffix(".history.csv")
    except (ScenarioError, ValueError, ImportError) as exc:
        return _fail(exc)
    try:  # the tuned scenario includes the original by a path relative to its folder, which must exist
        output.resolve().parent.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        print(f"error: cannot write {output}: {exc.strerror}", file=sys.stderr)
        return 1
    from transgen.progress import ProgressLine

    line = ProgressLine(not (args.quiet or args.json), args.progress)

    def progress(p) -> None:
        line.show(p.text())
    start = time.perf_counter()
    try:
        result = optimize(args.scenario, args.shift, objective, constraints, executor, args.seed, args.evaluations,
                          args.population, progress, overrides, args.engine_torque, args.force,
                          None if args.quiet or args.json else
                          lambda text: print(f"optimize: {text}", file=sys.stderr, flush=True))
    except (ScenarioError, ValueError) as exc:
        line.end()
        return _fail(exc)
    line.end()
    elapsed = time.perf_counter() - start
    original = load_scenario(result.path, overrides)
    before_run = original.run()
    before = shift_report(before_run, original.shifts or None)
    text = tuned_scenario_text(result, output)
    tuned = parse_scenario(text, output.resolve(), overrides)
    after_run = tuned.run()
    after = shift_report(after_run, tuned.shifts or None)
    text = tuned_scenario_text(result, output, before, after)
    with output_set():
        write_text(output, text)
        write_text(history_path, _history_csv(result.history))
    evaluations = sum(s.evaluations for s in result.shifts)
    eval_cpu = sum(s.evaluation_cpu_time for s in result.shifts)
    infeasible = [s for s in result.shifts if not s.feasible]
    if args.json:
        from transgen.schemas import print_document
        from transgen.sim.analysis.shift_quality import jsonable

        print_document(OPTIMIZE_SCHEMA, jsonable(_summary(args, result, executor, elapsed, before, after,
                                                          [str(output), str(history_path)])), optimize_units())
    else:
        print(f"{len(result.shifts)} shift(s) tuned in {elapsed:.1f} s ({executor!r}): {evaluations} evaluations, "
              f"{evaluations / max(elapsed, 1e-9):.1f} evaluations/s, {eval_cpu / max(evaluations, 1):.3f} s CPU per "
              f"evaluation")
        for s in result.shifts:
            print(f"  {s.plan.name:<6} {s.evaluations} evaluations in {s.wall_time:.1f} s "
                  f"({s.evaluations / max(s.wall_time, 1e-9):.1f}/s, {s.evaluation_cpu_time:.1f} s CPU): score {s.start_score:.4g} -> {s.best_score:.4g}"
                  + ("" if s.feasible else f"  INFEASIBLE, binding: {s.binding}"))
            if result.engine_torque:
                print(f"         engine torque: "
                      f"{intervention_text(s.best_template, result.calibration.request is not None)}")
        if args.report:
            print("\nThe trade between torque hole and clutch energy of each shift (the feasible candidates no other "
                  "beats on both, the shift window's numbers; then the objective's choice):")
            for s, rows in zip(result.shifts, result.shift_history()):
                front = trade_off(rows)
                shown = front if len(front) <= 16 else [front[round(i * (len(front) - 1) / 15)] for i in range(16)]
                m = s.best_metrics
                choice = (f"; chosen {m['hole']:.1f} % {m['energy'] / 1e3:.2f} kJ"
                          if s.feasible and m.get("hole") is not None else "")
                print(f"  {s.plan.name:<6} " + (", ".join(f"{r['hole']:.1f} % {r['energy'] / 1e3:.2f} kJ" for r in shown)
                                               or "no feasible candidate") + choice)
            print("\nShift report of the whole run, before -> after:")
            for row in comparison_rows(before, after):
                print("  " + row)
        if not after_run.success:
            print(f"warning: the tuned scenario's run stopped: {after_run.message}")
        print(f"  wrote {output}\n  wrote {history_path}")
    for s in infeasible:
        print(f"error: shift {s.plan.name}: no candidate met the constraints ({constraints.text()}); the best "
              f"found (kept in {output}) violates {_violations(s)}; binding: {s.binding}", file=sys.stderr)
    return 1 if infeasible else 0


def _violations(s) -> str:
    m = s.best_metrics
    shown = {"no bindup": f"no bindup (offgoing torque reversed by {m.get('bindup_torque', 0):.1f} N*m)",
             "max flare": f"max flare (flare {m.get('flare') or 0:.1f} rpm)",
             "max hole": f"max hole (torque hole {m.get('hole') or 0:.1f} %)",
             "max energy": f"max energy (clutch energy {(m.get('energy') or 0) / 1e3:.2f} kJ)",
             "max duration": f"max duration ({m.get('duration') or float('nan'):.3f} s)",
             "no chatter": "no chatter (an element locked more than once)",
             "completes": "completes (the oncoming element never locked)", "run": f"run ({m.get('message', '')})"}
    return ", ".join(shown.get(k, k) for k in sorted(s.violations, key=s.violations.get, reverse=True))


def _history_csv(rows: list[dict]) -> str:
    import csv
    import io

    columns = list(dict.fromkeys(k for r in rows for k in r))
    buf = io.StringIO()
    w = csv.DictWriter(buf, columns, lineterminator="\n")
    w.writeheader()
    for r in rows:
        w.writerow({k: ("" if r.get(k) is None else r.get(k)) for k in columns})
    return buf.getvalue()


def _quality(q) -> dict:
    return {"name": q.name, "oncoming": q.oncoming, "offgoing": q.offgoing, "completed": q.completed,
            "torque_hole_pct": q.torque_hole_pct, "energy_total": q.energy_total, "flare_max_rpm": q.flare_max_rpm,
            "bindup": q.bindup, "shift_duration": q.shift_duration,
            "jerk_max": getattr(q, "jerk_max", None), "chatter": getattr(q, "chatter", None),
            **{k: getattr(q, k, None) for k in ("torque_request_min", "torque_request_max", "torque_increase_duration",
                                                "torque_reduction_duration")}}


def _summary(args, result, executor, elapsed, before, after, written) -> dict:
    from dataclasses import asdict

    from .optimize import trade_off

    shifts = []
    for s, rows in zip(result.shifts, result.shift_history()):
        shifts.append({
            "name": s.plan.name, "number": s.plan.number, "oncoming": s.plan.oncoming, "offgoing": s.plan.offgoing,
            "t_start": s.plan.t_start, "feasible": s.feasible, "binding": s.binding, "violations": s.violations,
            "evaluations": s.evaluations, "wall_time": s.wall_time, "cpu_time": s.cpu_time,
            "evaluation_cpu_time": s.evaluation_cpu_time, "score_before": s.start_score, "score_after": s.best_score,
            "fit_residual": s.plan.fit_residual,
            "constraints": asdict(s.constraints) if s.constraints is not None else None,
            "template_before": asdict(s.start_template), "template_after": asdict(s.best_template),
            "metrics_before": {k: v for k, v in s.start_metrics.items() if k != "message"},
            "metrics_after": {k: v for k, v in s.best_metrics.items() if k != "message"},
            "trade_off": [{k: r.get(k) for k in ("evaluation", "hole", "energy", "jerk", "duration", "score")}
                          for r in trade_off(rows)],
        })
    evaluations = sum(s.evaluations for s in result.shifts)
    return {"scenario": args.scenario, "output": str(args.output), "calibration": result.calibration.kind,
            "objective": dict(result.objective.weights), "constraints": asdict(result.constraints),
            "parameters": list(result.parameters), "engine_torque": result.engine_torque, "seed": result.seed, "executor": repr(executor),
            "feasible": result.feasible, "evaluations": evaluations, "wall_time": elapsed,
            "evaluations_per_second": evaluations / max(elapsed, 1e-9), "shifts": shifts,
            "report_before": [_quality(q) for q in before], "report_after": [_quality(q) for q in after],
            "written": written}


def optimize_units() -> dict[str, str]:
    """Units of the numeric fields of ``transgen optimize --json``."""
    return {"t_start": "s", "wall_time": "s", "cpu_time": "s", "evaluation_cpu_time": "s", "evaluations": "1",
            "evaluations_per_second": "1/s", "score_before": "1", "score_after": "1", "fit_residual": "1",
            "number": "1", "seed": "1", "evaluation": "1", "score": "1", "energy": "J", "energy_total": "J", "duration": "s", "shift_duration": "s",
            "hole": "%", "torque_hole_pct": "%", "hole_torque": "N*m", "flare": "rpm", "flare_max_rpm": "rpm",
            "bindup_torque": "N*m", "offgoing_torque": "N*m", "jerk": "m/s^3", "jerk_max": "m/s^3", "locks": "1",
            "max_flare_rpm": "rpm", "max_hole_pct": "%", "max_duration": "s", "max_energy": "J", "max_temperature": "degC", "max_jerk": "m/s^3", "temperature": "degC", "fill_time": "s", "fill_level": "1",
            "ramp_time": "s", "ramp_end": "1", "hold_time": "s", "final_time": "s", "offgoing_delay": "s",
            "offgoing_level": "1", "offgoing_ramp": "s", "torque_boost": "1", "boost_delay": "s", "boost_time": "s",
            "torque_cut": "1", "cut_delay": "s", "cut_time": "s", "torque_ramp": "s", "ease_slip": "1", "ease_time": "s", "ease_level": "1", "torque_request_min": "1",
            "torque_request_max": "1", "torque_increase_duration": "s", "torque_reduction_duration": "s"}


def _fail(exc) -> int:
    message = str(exc)
    first = message.split("\n", 1)[0]
    print(message if ": error: " in first else f"error: {message}", file=sys.stderr)
    return 2
