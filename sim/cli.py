"""Simulator commands of the ``transgen`` command line: ``simulate``, ``scenario`` and ``maps``."""
from __future__ import annotations

import sys
from pathlib import Path

from transgen.schemas import print_document

__all__ = ["add_commands", "cmd_simulate", "cmd_scenario_new", "cmd_scenario_keys", "cmd_scenario_copy", "cmd_maps"]


def add_commands(sub) -> None:
    """Add the simulator's sub-commands to the ``transgen`` parser."""
    from transgen.limits import add_force_option
    from transgen.progress import add_progress_option
    s = sub.add_parser("simulate", help="simulate a scenario (shifts, driveline, vehicle)",
                       description="Simulate a scenario file (TOML) or a bundled scenario by name "
                                   "(see 'transgen simulate --list').")
    s.add_argument("scenario", metavar="SCENARIO", nargs="?", help="scenario .toml file or bundled name")
    s.add_argument("-o", "--output", metavar="FILE",
                   help="write the signals (time, mode name, signals with units) to FILE: .csv, .mat, .npz or .json")
    s.add_argument("--unique-times", action="store_true",
                   help="in -o FILE, one row per time: at an event only the row after it (for pandas, interp1)")
    s.add_argument("--plot", metavar="DIR", help="write the plots into DIR")
    s.add_argument("--format", default="png", help="plot formats, comma-separated: png,svg,pdf (default png)")
    s.add_argument("--report", action="store_true", help="print the shift-quality report")
    s.add_argument("--json", action="store_true", help="machine-readable summary (events, modes, energy, report)")
    s.add_argument("--model", choices=("switching", "compliant"), help="override the clutch model of the scenario")
    s.add_argument("--compare", metavar="SCENARIO2",
                   help="also run SCENARIO2 and compare: overlay plots (with --plot; the Chapter-4 turbocharger "
                        "plots of both runs for turbo scenarios) and side-by-side report numbers")
    s.add_argument("--compare-model", choices=("switching", "compliant"),
                   help="clutch model of the compared run (default: as the first run); without --compare the "
                        "scenario is compared with itself, e.g. '--compare-model compliant' reruns the thesis' "
                        "comparison of Runde's and Haessig's models (3.2.2)")
    _set_option(s)
    s.add_argument("--quiet", action="store_true", help="no progress on standard error")
    add_progress_option(s)
    add_force_option(s)
    s.add_argument("--list", action="store_true", help="list the bundled scenarios")
    s.set_defaults(func=cmd_simulate)

    s = sub.add_parser("scenario", help="scenario files: new (a launch from a .mech file), keys (the settable "
                                        "keys), copy (a bundled scenario with its includes)",
                       description="Scenario files. 'transgen scenario new FILE' writes a commented "
                                   "launch scenario: from rest through every forward gear with an automatic schedule "
                                   "derived from the gear table, for a car or a truck. 'transgen scenario keys "
                                   "SCENARIO' lists the keys that --set can change, with their values. 'transgen "
                                   "scenario copy NAME DIR' writes a bundled scenario and the files it includes.")
    group = s.add_subparsers(dest="scenario_command", metavar="COMMAND", required=True)
    n = group.add_parser("new", help="a launch scenario derived from a .mech file alone",
                         description="Derive a launch scenario from a mechanism: the forward gears and their ratios, "
                                     "the elements swapped per upshift (single or double swaps; one-way clutches "
                                     "overrun or lock by themselves), capacities checked against the vehicle class's "
                                     "engine and converter (the engine torque is limited where they do not hold), "
                                     "final drive, shift lines and t_end, each upshift's calibration from the statics "
                                     "of its two gears and the inertia it synchronises (docs/calibration.md), and the "
                                     "driveline's compliance from the class's shafts and tyres. Without -o the TOML goes "
                                     "to standard output.")
    n.add_argument("file", metavar="FILE", help=".mech file or bundled mechanism name")
    n.add_argument("--vehicle", choices=("car", "truck"), default="car",
                   help="vehicle class: car (1700 kg, 340 N*m) or truck (M915 class, 36 t; default car)")
    n.add_argument("--maneuver", choices=("launch", "kickdown", "coastdown", "tipin", "tipout", "cycle"), default="launch",
                   help="launch (from rest through the gears, the default); kickdown (full throttle from a cruise: "
                        "power-on downshifts); coastdown (throttle off and brakes: power-off downshifts); tipin / tipout "
                        "(a throttle step up without a shift / to zero: a power-off upshift); cycle (a driver follows "
                        "a standard speed trace, --cycle)")
    n.add_argument("--cycle", default=None, metavar="NAME",
                   help="speed trace of --maneuver cycle: wltc_class3b (default) or ftp75, or a CSV file "
                        "(time_s,speed_kmh)")
    n.add_argument("-o", "--output", metavar="FILE", help="write the scenario here (default: standard output)")
    n.add_argument("--json", action="store_true",
                   help="print what was derived as JSON (with -o; without -o the JSON replaces the TOML)")
    n.set_defaults(func=cmd_scenario_new)
    k = group.add_parser("keys", help="the settable keys of a scenario and their values",
                         description="List every key of a scenario that 'transgen simulate --set KEY=VALUE' can "
                                     "change, with its value (keys the file does not set are shown as '(default)'); "
                                     "the mechanism's parameters are the keys mech.NAME.PARAM.")
    k.add_argument("scenario", metavar="SCENARIO", help="scenario .toml file or bundled name")
    _set_option(k)
    k.add_argument("--json", action="store_true", help="the keys and values as JSON (null: not set, the default applies)")
    k.set_defaults(func=cmd_scenario_keys)
    c = group.add_parser("copy", help="write a bundled scenario and its include files into a folder",
                         description="Write the scenario NAME (a bundled name or a scenario file) and every file it "
                                     "includes into DIR, in the same layout, so that the copy runs as it is and can "
                                     "be edited. Existing files are kept unless --force; all files are written or none.")
    c.add_argument("name", metavar="NAME", help="bundled scenario name (see 'transgen simulate --list') or file")
    c.add_argument("directory", metavar="DIR", help="folder to write into (made if missing)")
    c.add_argument("--force", action="store_true", help="overwrite existing files")
    c.set_defaults(func=cmd_scenario_copy)

    s = sub.add_parser("maps", help="pre-process a compressor or turbine map and summarise it (thesis 4.4)",
                       description="Run the map pre-processor on a compressor or turbine map file (or a bundled "
                                   "map by name: we_compressor, we_turbine) and print a summary of the map and "
                                   "of its causal tables (speed lines, chi or expansion-ratio grid, ranges).")
    s.add_argument("map", metavar="MAPFILE", help="map .toml file or bundled map name")
    s.add_argument("--plot", metavar="DIR", help="write the map plots (thesis Figs. 4.4, 4.6, 4.7, 4.10, 4.11) into DIR")
    s.add_argument("--format", default="png", help="plot formats, comma-separated: png,svg,pdf (default png)")
    s.add_argument("--json", action="store_true", help="machine-readable summary")
    s.set_defaults(func=cmd_maps)


SIMULATE_SCHEMA = "transgen.simulate/1"


def _set_option(parser) -> None:
    parser.add_argument("--set", metavar="KEY=VALUE", action="append", default=[], dest="overrides",
                        help="set a scenario value by its dotted key, e.g. driveline.vehicle_mass=20000 or "
                             "mech.L1.J=0.3 (a TOML value; repeatable; 'transgen scenario keys SCENARIO' lists the keys)")


def _overrides(texts: list[str]) -> dict[str, object]:
    """The ``--set`` options as a key -> value mapping (the last of a repeated key wins)."""
    from .scenario.overrides import parse_override

    return dict(parse_override(t) for t in texts)


def _plot_formats(spec: str) -> tuple[str, ...]:
    """The plot formats of ``--format`` (comma-separated), each checked (ValueError: exit 2)."""
    from transgen.drawing import FIGURE_FORMATS

    formats = tuple(f.strip().lower() for f in spec.split(",") if f.strip())
    known = sorted(set(FIGURE_FORMATS.values()))
    bad = [f for f in formats if f not in known]
    if bad or not formats:
        raise ValueError(f"unknown plot format {', '.join(map(repr, bad)) or repr(spec)}: choose from {', '.join(known)}")
    return formats


def _progress(t_start: float, t_end: float, enabled: bool, log: bool):
    """The progress of a run, ``(show(t), line)``: the fraction of ``t_start..t_end`` done, with
    the time elapsed and left (:class:`transgen.progress.ProgressLine`); ``show`` is None where
    nothing is shown."""
    from transgen.progress import ProgressLine, eta_text

    line = ProgressLine(enabled, log)
    if not line.active:
        return None, line
    span = t_end - t_start

    def show(t):
        fraction = (t - t_start) / span if span > 0 else 1.0
        line.show(f"simulating: t = {t:7.3f} s, {eta_text(fraction, line.elapsed())}", final=t >= t_end)
    return show, line


def cmd_simulate(args) -> int:
    from transgen.errors import ScenarioError

    if args.list or not args.scenario:
        if not args.list:
            raise ScenarioError("name a scenario file (or use --list to see the bundled ones)")
        from .scenario.library import bundled_scenarios  # not the simulator: listing needs no numeric library

        items = {name: str(path) for name, path in bundled_scenarios().items()}
        if args.json:
            print_document("transgen.scenarios/1", {"scenarios": items}, {})
        else:
            print("\n".join(f"  {k:<24} {v}" for k, v in items.items()))
        return 0
    from .analysis.report import report_dict, report_text, shift_report, simulate_units
    from .scenario.load import load_scenario

    formats = _plot_formats(args.format)  # checked before anything runs or is written
    if args.output:
        from .analysis.result_files import result_format

        result_format(args.output)
    elif args.unique_times:
        raise ValueError("--unique-times applies to the result file: name one with -o FILE")
    overrides = _overrides(args.overrides)
    scenario = _with_model(load_scenario(args.scenario, overrides), args.model)
    from .scenario.run_limits import check_run

    check_run(scenario, args.force)  # samples, memory, periodic inputs: refused before the run
    o = scenario.options
    progress, line = _progress(o.t_start, o.t_end, not (args.quiet or args.json), args.progress)
    if not args.quiet and not args.json:
        print(f"{scenario.title}: {scenario.mechanism.name}, {scenario.options.model} model, "
              f"t = {scenario.options.t_start:g}..{scenario.options.t_end:g} s", file=sys.stderr)
    try:
        result = scenario.run(progress)
    finally:
        line.end()
    if not result.success:  # nothing is written for a failed run
        print(f"error: {result.message}", file=sys.stderr)
        if args.json:
            print_document(SIMULATE_SCHEMA, result.summary(), simulate_units("omega_tc" in result.signals))
        return 1
    qualities = shift_report(result, scenario.shifts or None) if len(result.time) else []
    other = other_q = None
    compare = args.compare or (args.scenario if args.compare_model else None)
    if compare:  # both runs before anything is written: the outputs are all or none
        other_s = _with_model(load_scenario(compare, overrides if compare == args.scenario else None),
                              args.compare_model or args.model)
        check_run(other_s, args.force)
        other = other_s.run()
        if not other.success:
            print(f"error: {compare}: {other.message}", file=sys.stderr)
            return 1
        other_q = shift_report(other, other_s.shifts or None)
    written = []
    from transgen.export import output_set
    from transgen.outputs import messages_stream

    with output_set():
        if args.output:
            from .analysis.result_files import write_result

            write_result(result, args.output, scenario.outputs or None, args.unique_times)
            written.append(args.output)
        if args.plot and len(result.time):
            from .analysis.plots import plot_all

            written += [str(p) for p in plot_all(result, qualities, Path(args.plot), formats=formats)]
        if compare and args.plot:
            written += _comparison_plots(scenario, result, other_s, other, Path(args.plot), formats)
    cycle = _cycle_report(scenario, result)
    if args.json:
        summary = result.summary()
        summary["report"] = report_dict(result, qualities)
        if cycle is not None:
            summary["cycle"] = cycle.to_dict()
        if "omega_tc" in result.signals:
            from .engine.turbo_report import turbo_report

            summary["turbo"] = turbo_report(result).to_dict()
        if other is not None:
            summary["compare"] = {"scenario": compare, "model": other_s.options.model, "summary": other.summary(),
                                  "report": report_dict(other, other_q)}
            if "omega_tc" in result.signals and "omega_tc" in other.signals:
                from .engine.turbo_report import turbo_report

                summary["compare"]["turbo"] = turbo_report(result, other, engine=_engine_of(scenario)).to_dict()
        summary["written"] = written
        print_document(SIMULATE_SCHEMA, summary, simulate_units("omega_tc" in result.signals))
    else:
        print("completed")
        st = result.stats
        print(f"  {st.get('wall_time', 0):.3f} s wall, {st.get('rhs_evaluations', 0)} right-hand-side evaluations, "
              f"{st.get('events', 0)} events, {len(result.modes)} mode spans")
        for e in result.events:
            if e.kind != "start":
                print(f"  t = {e.t:8.4f} s  {e.kind:<7} {' '.join(e.elements):<8} {e.source} -> {e.target} {e.detail}")
        if cycle is not None:
            from .analysis.cycle_report import cycle_text

            print()
            print(cycle_text(cycle))
        if args.report:
            print()
            print(report_text(result, qualities))
            if "omega_tc" in result.signals:
                from .engine.turbo_report import turbo_report

                print(turbo_report(result).text())
        if other is not None:
            print()
            print(_comparison_text(scenario, result, qualities, _labels(scenario, other_s)[1], other, other_q))
        for w in written:
            print(f"  wrote {w}", file=messages_stream(args.output))
    return 0 if result.success else 1


def _cycle_report(scenario, result):
    """The drive-cycle report of a run whose scenario has a driver (:mod:`.driver`), else None."""
    from .control.driver import Driver

    driver = next((c for c in scenario.powertrain.controllers if isinstance(c, Driver)), None)
    if driver is None or not len(result.time):
        return None
    from .analysis.cycle_report import cycle_report
    from .engine.fuel import fuel_of

    return cycle_report(result, driver.trace, fuel=fuel_of(scenario.powertrain))


def _with_model(scenario, model: str | None):
    """``scenario`` with its clutch model replaced by ``model`` (None: unchanged); the compliant
    model is integrated with Radau (stiff)."""
    import dataclasses

    if model:
        method = "Radau" if model == "compliant" and model != scenario.options.model else scenario.options.method
        scenario.options = dataclasses.replace(scenario.options, model=model, method=method)
    return scenario


def _labels(a, b) -> tuple[str, str]:
    """Names of two compared runs: their file names, with the clutch model where those are equal."""
    if a.path.stem != b.path.stem:
        return a.path.stem, b.path.stem
    return f"{a.path.stem} ({a.options.model})", f"{b.path.stem} ({b.options.model})"


def _comparison_plots(scenario, result, other_s, other, directory: Path, formats) -> list[str]:
    """Overlay plots of two runs: input and output torque and speeds, and for turbocharged runs the
    thesis' Figs. 4.17-4.24 with both runs."""
    from transgen.drawing import save_figure

    from .analysis.plots import compare

    first, second = _labels(scenario, other_s)
    runs = {first: result, second: other}
    written = []
    inp = f"w_{scenario.mechanism.input}"
    for signal in ("T_out", "T_in", inp, "vehicle_speed"):
        if all(signal in r.signals for r in runs.values()):
            for fmt in formats:
                written.append(str(save_figure(compare(runs, signal), directory / f"compare_{signal}.{fmt}")))
    if all("omega_tc" in r.signals for r in runs.values()):
        from .engine.plots import plot_turbo_comparison

        written += [str(p) for p in plot_turbo_comparison(runs, directory, formats=formats, engine=_engine_of(scenario))]
    return written


def _engine_of(scenario):
    """The scenario's turbodiesel engine, or None."""
    from .model.powertrain import TurbodieselSource

    return next((c.engine for c in scenario.powertrain.components if isinstance(c, TurbodieselSource)), None)


def _comparison_text(scenario, a, qa, name_b, b, qb) -> str:
    """Side-by-side shift numbers of two runs, and the turbocharger comparison where both have one
    (with both algorithms evaluated on the first run's states)."""
    lines = [f"Comparison: {scenario.title}  vs  {name_b}  (each column: this run, then {name_b})",
             f"  {'shift':<8} {'torque hole [N*m]':>22} {'bindup [N*m]':>18} {'energy [kJ]':>16} {'flare [rpm]':>16}"
             f" {'max |jerk| [m/s^3]':>19} {'VDV [m/s^1.75]':>16}"]

    def num(v, fmt):
        return "-" if v is None else format(v, fmt)

    for x, y in zip(qa, qb):
        lines.append(f"  {x.name:<8} {x.torque_hole:>10.0f} {y.torque_hole:>11.0f} {x.bindup_torque:>8.0f} "
                     f"{y.bindup_torque:>9.0f} {x.energy_total / 1e3:>7.1f} {y.energy_total / 1e3:>8.1f} "
                     f"{x.flare_max_rpm:>7.1f} {y.flare_max_rpm:>8.1f} {num(x.jerk_max, '.1f'):>9} "
                     f"{num(y.jerk_max, '.1f'):>9} {num(x.vdv, '.3f'):>7} {num(y.vdv, '.3f'):>8}")
    lines.append(f"  energy dissipated [kJ]: {a.energy.get('dissipated', 0) / 1e3:.1f} vs {b.energy.get('dissipated', 0) / 1e3:.1f}")
    if "omega_tc" in a.signals and "omega_tc" in b.signals:
        from .engine.turbo_report import turbo_report

        lines.append(turbo_report(a, b, engine=_engine_of(scenario)).text())
    return "\n".join(lines)


def cmd_scenario_new(args) -> int:
    """``transgen scenario new``: derive a launch scenario, write it (atomically) or print it."""
    from transgen.export import write_text
    from transgen.language import load_mechanism
    from transgen.schemas import dumps

    from .derive.launch import derive_launch, launch_scenario, mechanism_reference

    mech = load_mechanism(args.file)
    if args.maneuver != "launch":  # refused before the launch is derived (transgen.own_converter)
        from .derive.maneuver import refuse_own_converter

        refuse_own_converter(mech, args.maneuver)
    launch = derive_launch(mech, args.vehicle)
    # a bundled mechanism by its name, a user's file relative to where the scenario is written
    where = Path(args.output).resolve().parent if args.output else Path.cwd()
    ref = mechanism_reference(args.file, where)
    from transgen.errors import ScenarioError

    if args.cycle is not None and args.maneuver != "cycle":
        raise ScenarioError("--cycle: error: --cycle goes with --maneuver cycle")
    if args.maneuver == "launch":
        text = launch_scenario(mech, args.vehicle, ref, launch)
    else:
        from .derive.maneuver import maneuver_scenario

        try:
            text = maneuver_scenario(mech, args.vehicle, args.maneuver, ref, launch, args.cycle)
        except ScenarioError:
            raise
        except ValueError as exc:
            raise ScenarioError(f"{mech.source}:1:1: error: {exc}") from None
    for w in launch.warnings:
        print(f"warning: {w}", file=sys.stderr)
    if args.output:
        write_text(args.output, text)
    if args.json:
        summary = launch.to_dict()
        summary["maneuver"] = _maneuver_summary(mech, launch, args.maneuver, args.cycle)
        summary["written"] = [args.output] if args.output else []
        print(dumps(summary))
    elif args.output:
        from transgen.outputs import messages_stream

        print(f"wrote {args.output}: {mech.name}, {args.vehicle}, {args.maneuver}, gears {' '.join(launch.order)}",
              file=messages_stream(args.output))
    else:
        sys.stdout.write(text)
    return 0


def _maneuver_summary(mech, launch, kind: str, cycle: str | None) -> dict:
    """What ``scenario new --json`` says of the maneuver: its kind and, for a maneuver from a
    cruise, the cruise (gear, speed [m/s], throttle), the throttle and brake [N*m] after the step,
    ``t_end`` [s] and the shifts expected."""
    out = {"kind": kind}
    if kind == "cycle":
        from .control.cycles import DEFAULT_CYCLE

        out["cycle"] = cycle or DEFAULT_CYCLE
    elif kind != "launch":
        from .derive.maneuver import derive_maneuver

        m = derive_maneuver(mech, launch, kind)
        out.update({"gear": m.gear, "speed": m.speed, "throttle": m.throttle, "throttle_after": m.throttle_after,
                    "brake": m.brake, "t_end": m.t_end, "expected_shifts": list(m.expected)})
    return out


def cmd_scenario_keys(args) -> int:
    """``transgen scenario keys``: the settable keys of a scenario with their values."""
    from .scenario.overrides import toml_value
    from .scenario.load import scenario_keys, scenario_path

    keys = scenario_keys(args.scenario, _overrides(args.overrides))
    if args.json:
        # values in the units the scenario file takes them in (README, "Scenario files")
        print_document("transgen.scenario-keys/1", {"scenario": str(scenario_path(args.scenario)), "keys": keys}, {})
    else:
        width = max(map(len, keys), default=0)
        for key, value in keys.items():
            print(f"{key:<{width}} = {'(default)' if value is None else toml_value(value)}")
    return 0


def cmd_scenario_copy(args) -> int:
    """``transgen scenario copy``: a bundled scenario and its include files, written into a folder."""
    from .scenario.copy import copy_scenario

    for path in copy_scenario(args.name, args.directory, args.force):
        print(f"wrote {path}")
    return 0


def cmd_maps(args) -> int:
    """``transgen maps``: pre-process a map, print (or JSON) its summary, optionally plot it."""
    from .engine.map_summary import MAP_UNITS, load_named_map, map_summary, map_summary_text
    from .engine.plots import plot_map_file

    formats = _plot_formats(args.format)
    path, m = load_named_map(args.map)
    summary = map_summary(path, m)
    written = []
    if args.plot:
        from transgen.export import output_set

        with output_set():
            written = [str(p) for p in plot_map_file(m, Path(args.plot), formats=formats)]
    if args.json:
        summary["written"] = written
        print_document("transgen.maps/1", summary, MAP_UNITS)
    else:
        print(map_summary_text(summary))
        for w in written:
            print(f"  wrote {w}")
    return 0
