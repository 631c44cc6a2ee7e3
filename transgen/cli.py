"""The ``transgen`` command line: a thin layer over the Python API.

Exit codes: 0 success, 1 failure (a run that could not complete, an output that could not be
written; ``ratios``: a declared ``ratio=`` the mechanism does not reproduce, the table printed in
full), 2 bad input (a ``.mech`` or scenario file with errors, invalid options or coordinates).
Errors are printed without a traceback.
"""
from __future__ import annotations

import argparse
import contextlib
import os
import sys
import warnings
from pathlib import Path

from . import __version__
from .cli_args import number_option
from .errors import MechValidationError, ModeError, SimulationError, TransgenError
from .schemas import print_document

__all__ = ["main", "load_checked"]


def load_checked(path: str, runnable: bool = False):
    """Load a mechanism (a path or a bundled name) and check its declared gears (and the
    direction of the one-way clutches they engage); with ``runnable`` also that the simulator can
    run its modes (no massless link left undetermined: :func:`~transgen.modes.massless_problems`)."""
    from .kinematics import check_gears
    from .language import load_mechanism
    from .modes import massless_problems
    from .statics import check_oneways

    mech = load_mechanism(path)
    problems = check_gears(mech)
    problems = problems or check_oneways(mech)
    if runnable:  # `check`: also what the simulator cannot run
        problems = problems or massless_problems(mech)
    if problems:
        raise MechValidationError(problems)
    return mech


def _fmt_ratio(r) -> str:
    return "-" if r is None else f"{r:.4f}"


# ------------------------------------------------------------------------------------ commands


def cmd_check(args) -> int:
    mech = load_checked(args.file, runnable=True)
    if args.json:
        from .describe import MECHANISM_UNITS, mechanism_to_dict

        print_document("transgen.check/1", mechanism_to_dict(mech), MECHANISM_UNITS)
        return 0
    from .kinematics import gear_table

    table = gear_table(mech, all_combinations=False)
    print(f"{mech.source}: ok — {mech.name}")
    stepped = f" (and {len(mech.stepped)} stepped-pinion)" if mech.stepped else ""
    print(f"  {len(mech.links)} links, {len(mech.planetaries)} planetary gearsets{stepped}, {len(mech.gear_pairs)} gear pairs, "
          f"{len(mech.elements)} shift elements ({', '.join(e.name for e in mech.elements)})")
    print(f"  input {mech.input}, output {mech.output}; {sum(1 for g in mech.gears if g.kind == 'gear')} gears, "
          f"{len(mech.neutrals)} neutral(s)")
    for row in table.gears:
        note = ""
        if row.combination.floating:
            note = f"  (floating: {', '.join(row.combination.floating)})"
        note += "  (alternative)" if row.alternative else ""
        print(f"  {row.kind} {row.name:>4}: {' '.join(row.engaged):<14} ratio {_fmt_ratio(row.ratio)}{note}")
    return 0


def cmd_ratios(args) -> int:
    """Exit 1 when a declared ``ratio=`` is not reproduced (the table is printed in full and each
    mismatch reported as a finding); 2 for bad input, including gears that tie up."""
    import dataclasses

    from .kinematics import check_gears, gear_table, published_findings
    from .language import load_mechanism
    from .statics import check_oneways

    mech = load_mechanism(args.file)
    problems = check_gears(mech, published=False)
    problems = problems or check_oneways(mech)
    if problems:
        raise MechValidationError(problems)
    table = gear_table(mech, all_combinations=not args.gears_only)
    findings = [dataclasses.replace(d, severity="warning") for d in published_findings(mech, table)]
    status = 1 if findings else 0
    if args.json:
        data = table.to_dict()
        data["findings"] = [{"line": d.line, "column": d.column, "message": d.message} for d in findings]
        print_document("transgen.ratios/1", data, table.UNITS)
        return status
    print(f"{mech.name}: input {mech.input}, output {mech.output} (ratio = input speed / output speed)")
    print()
    print(f"  {'gear':>8}  {'engaged':<16} {'DOF':>3}  {'ratio':>9}  {'step':>6}  {'published':<16} floating")
    for row in table.gears:
        step = f"{row.step:.3f}" if row.step else ""
        pub = ""
        if row.published:
            how = f"~{row.tolerance}" if row.tolerance else (" trunc" if row.rounding == "truncated" else "")
            pub = f"{row.published}{how} " + ("ok" if row.matches_published else "MISMATCH")
        name = row.name if row.kind == "gear" else f"{row.name} (N)"
        name += " (alt)" if row.alternative else ""
        floating = ", ".join(row.combination.floating) if row.kind == "gear" else ""
        print(f"  {name:>8}  {' '.join(row.engaged):<16} {row.dof:>3}  {_fmt_ratio(row.ratio):>9}  {step:>6}  "
              f"{pub:<16} {floating}".rstrip())
    if table.spread:
        print(f"\n  overall spread {table.spread:.3f}")
    if any(row.alternative for row in table.gears):
        print("  (alt): alternative gear, outside the step sequence, the spread and the default speed phases")
    if findings:
        print(f"\n  {len(findings)} published ratio(s) not reproduced:")
        for d in findings:
            print("  " + d.format().replace("\n", "\n  "))
    if args.gears_only:
        return status
    declared = {frozenset(r.engaged) for r in table.gears}
    print(f"\n  all {len(table.combinations)} combinations of engaged elements (* = declared):")
    print(f"  {'engaged':<24} {'DOF':>3}  {'ratio':>9}  kind")
    for c in table.combinations:
        mark = "*" if frozenset(c.engaged) in declared else " "
        kind = c.kind + (f" ({c.detail})" if c.detail else "") + (
            f" (floating: {', '.join(c.floating)})" if c.floating else "")
        print(f" {mark}{' '.join(c.engaged) or '(none)':<24} {c.dof:>3}  {_fmt_ratio(c.ratio):>9}  {kind}")
    return status


def cmd_graph(args) -> int:
    from .drawing import draw_graph, graph_to_dot, graph_to_graphml, save_figure
    from .export import write_text
    from .graph import build_graph

    from .outputs import is_stream, messages_stream

    mech = load_checked(args.file)
    g = build_graph(mech)
    suffix = Path(args.output).suffix.lower()
    if suffix == ".dot" or not suffix and is_stream(args.output):  # -o -: DOT text
        write_text(args.output, graph_to_dot(g))
    elif suffix == ".graphml":
        write_text(args.output, graph_to_graphml(g))
    else:
        save_figure(draw_graph(g), args.output)
    print(f"wrote {args.output}", file=messages_stream(args.output))
    return 0


def cmd_lever(args) -> int:
    from .drawing import FIGURE_FORMATS, draw_levers, draw_speed_chart, save_figure
    from .drawing.lever import LEVER_UNITS, lever_document

    for out in (args.output, args.chart):
        if out is not None and Path(out).suffix.lower() not in FIGURE_FORMATS:
            raise ValueError(f"cannot draw into {out!r}: unknown suffix {Path(out).suffix!r} "
                             f"(use one of {', '.join(FIGURE_FORMATS)})")
    if not (args.output or args.chart or args.json):
        raise ValueError("nothing to do: give -o levers.svg|png|pdf, --chart speeds.png or --json")
    mech = load_checked(args.file)
    doc = lever_document(mech, args.gear)  # checks the gears
    if args.output:
        save_figure(draw_levers(mech, args.gear), args.output)
    if args.chart:
        save_figure(draw_speed_chart(mech, args.gear), args.chart)
    if args.json:
        print_document("transgen.lever/1", doc, LEVER_UNITS)
    else:
        for out in (args.output, args.chart):
            if out:
                print(f"wrote {out}")
    return 0


def cmd_modes(args) -> int:
    from .describe import MODES_UNITS, modes_report
    from .idle import idle_text

    mech = load_checked(args.file)
    report = modes_report(mech, "all" if args.all else "auto")
    if args.json:
        print_document("transgen.modes/1", report, MODES_UNITS)
        return 0
    print(f"{mech.name}: {len(report['modes'])} modes ({report['selection']})")
    print(f"  {'mode':<5} {'gear':<4} {'locked':<18} {'DOF':>3}  {'kind':<8} label / problem")
    for m in report["modes"]:
        notes = ([m["label"]] * bool(m["label"]) + [f"{'+'.join(grp)} in parallel" for grp in m["parallel"]]
                 + [idle_text(m["dof"], m["idle"])] * bool(m["idle"]))
        extra = "; ".join(notes) + (f"  !! {m['problem']}" if m["problem"] else "")
        print(f"  {m['name']:<5} {m['gear'] or '-':<4} {' '.join(m['locked']) or '(none)':<18} {m['dof']:>3}  "
              f"{m['kind']:<8} {extra}")
    for note in report["notes"]:
        print(f"  note: {note}")
    diag = report["diagnosis"]
    if diag["combinations"] == diag["of"]:
        print(f"\n  static diagnosis over all {diag['combinations']} combinations:")
    else:
        print(f"\n  static diagnosis over {diag['combinations']} of {diag['of']} combinations "
              f"(at most {diag['max_engaged']} engaged):")
    print(f"    tie-ups (bindup, no DOF): {len(diag['tie_ups'])}: " + "; ".join(" ".join(x) for x in diag["tie_ups"]))
    print(f"    locked torques not unique: {len(diag['non_unique_torques'])}: "
          + "; ".join(" ".join(x) for x in diag["non_unique_torques"]))
    if diag["undetermined_massless"]:
        print(f"    undetermined massless members: {len(diag['undetermined_massless'])}: "
              + "; ".join(" ".join(x) for x in diag["undetermined_massless"]))
    if diag["parallel"]:
        print("    elements in parallel (same motion; locked together they are one constraint): "
              + "; ".join(" ".join(x) for x in diag["parallel"]))
    return 0


def _symbolic_progress(i: int, n: int, mode) -> None:
    print(f"\r  solving mode {mode.name} symbolically ({i + 1}/{n})   ", end="", file=sys.stderr, flush=True)


def cmd_matrices(args) -> int:
    from .graph import bond_graph, link_nodes
    from .modes import mode_models, valid_coordinate_sets
    from .statespace import matrices_document, state_space

    if args.output is not None:  # --format and the name agree, before any work
        from .export import output_format

        output_format(args.output, args.format)
    mech = load_checked(args.file)
    which = {"auto": "auto", "all": "all", "declared": "declared", "default": "default"}[args.modes]
    progress = _symbolic_progress if args.symbolic and sys.stderr.isatty() else None
    models = mode_models(mech, which, symbolic=args.symbolic, progress=progress)
    if progress is not None:
        print(file=sys.stderr)
    if args.list_coordinates:
        sets = valid_coordinate_sets(models, link_nodes(bond_graph(mech)))
        if args.json:
            print_document("transgen.coordinates/1",
                        {"mechanism": mech.name, "valid_coordinates": [list(s) for s in sets]}, {})
        else:
            print(f"{len(sets)} valid sets of generalized coordinates:")
            for s in sets:
                print("  " + ",".join(s))
        return 0
    coords = [c.strip() for c in args.coords.split(",") if c.strip()] if args.coords else None
    ss = state_space(mech, coords, which, args.symbolic, models=models)
    if ss.skipped:  # combinations that have no model (tie-ups, ...): named, not an error
        print(f"{mech.name}: {len(ss.skipped)} of {len(models)} combinations have no state-space model "
              f"and are left out:", file=sys.stderr)
        for m in ss.skipped:
            print(f"  {m.name} ({' '.join(m.locked) or 'none'} locked, {m.kind}): {m.problem}", file=sys.stderr)
    if args.output is None:
        if args.format not in (None, "json"):
            raise ModeError("-o OUT is needed for npz, mat and latex output")
        from .schemas import dumps

        print(dumps(matrices_document(ss)))
        return 0
    from .export import write_state_space
    from .outputs import is_stream, messages_stream

    fmt = args.format or ("json" if not Path(args.output).suffix and is_stream(args.output) else None)
    write_state_space(ss, args.output, fmt)
    print(f"wrote {args.output}: {len(ss.modes)} modes, coordinates {', '.join(ss.coordinates)}",
          file=messages_stream(args.output))
    return 0


def cmd_std(args) -> int:
    from .std import state_transition_diagram

    mech = load_checked(args.file)
    modes = None
    if args.all:
        from .modes import select_modes

        modes = select_modes(mech, "all")
    std = state_transition_diagram(mech, modes)
    if args.output:
        from .drawing import draw_std, save_figure, std_to_dot
        from .export import write_text
        from .outputs import is_stream, messages_stream

        suffix = Path(args.output).suffix.lower()
        if suffix == ".dot" or not suffix and is_stream(args.output):  # -o -: DOT text
            write_text(args.output, std_to_dot(std))
        else:
            save_figure(draw_std(std), args.output)
        if not args.json:
            print(f"wrote {args.output}: {len(std.modes)} modes, {len(std.internal)} transitions",
                  file=messages_stream(args.output))
    if args.json:
        print_document("transgen.std/1", std.to_dict(), {})
    elif not args.output:
        from .names import user_name

        # each mode with the name a simulation result gives it (its gear, else its locked set)
        shown = {m.name: m.name if user_name(mech, m.locked) == m.name else f"{m.name} ({user_name(mech, m.locked)})"
                 for m in std.modes}
        for t in std.internal:
            print(f"  {shown[t.source]} -> {shown[t.target]}: {t.event} {t.element}: {t.condition}")
        for t in std.external:
            print(f"  {shown[t.source]} -> (not modelled: {' '.join(t.reaches) or 'none'}): {t.event} {t.element}")
        for m, why in std.unmodellable:
            print(f"  {m.name} ({' '.join(m.locked) or 'none'}) cannot be modelled: {why}")
    return 0


def cmd_powerflow(args) -> int:
    from .powerflow import UNITS, power_flow

    mech = load_checked(args.file)
    flow = power_flow(mech, eta0=args.eta0, input_rpm=args.input_rpm, max_slip_rpm=args.max_slip_rpm,
                      eta_pair=args.eta_pair, design_torque=args.design_torque, safety_factor=args.safety_factor,
                      dynamic_ratio=args.dynamic_ratio, gears=args.gear, coast=args.coast)
    for g in flow.gears:
        for w in g.warnings:
            warnings.warn(f"gear {g.name}: {w}")
    if args.losses is not None:  # drag, spin and pump losses: transgen.losses
        from .losses.command import run_losses

        return run_losses(args, mech, flow)
    if args.map or args.speed is not None or args.torque is not None or args.output:
        raise ValueError("--speed, --torque, --map and -o need --losses")
    if args.json:
        print_document("transgen.powerflow/1", flow.to_dict(), UNITS)
        return 0
    from .powerflow import powerflow_text

    print(powerflow_text(flow))
    return 0


def cmd_list(args) -> int:
    from .library import bundled_mechanisms
    from .language import load_mechanism

    items = []
    for name, path in bundled_mechanisms().items():
        mech = load_mechanism(path)
        items.append({"name": name, "title": mech.name, "path": str(path),
                      "gears": [g.name for g in mech.gears if g.kind == "gear"]})
    if args.json:
        print_document("transgen.list/1", {"mechanisms": items}, {})
    else:
        for it in items:
            print(f"  {it['name']:<24} {it['title']}  (gears {' '.join(it['gears'])})")
    return 0


# ---------------------------------------------------------------------------------- the parser


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="transgen", description=(
        "Equations of motion, modes and shift simulation of automatic transmissions from .mech files. "
        "FILE is a path or the name of a bundled mechanism (see 'transgen list')."))
    p.add_argument("--version", action="version", version=f"transgen {__version__}")
    sub = p.add_subparsers(dest="command", metavar="COMMAND", required=True)

    s = sub.add_parser("check", help="validate a .mech file and summarise it",
                       description="Validate a .mech file (syntax, names, gear ratios) and summarise it.")
    s.add_argument("file", metavar="FILE")
    s.add_argument("--json", action="store_true", help="dump the parsed model as JSON")
    s.set_defaults(func=cmd_check)

    s = sub.add_parser("ratios", help="gear table: DOF and ratio of every combination",
                       description="The declared gears (ratio, step, spread) and every combination of engaged elements.")
    s.add_argument("file", metavar="FILE")
    s.add_argument("--gears-only", action="store_true", help="only the declared gears")
    s.add_argument("--json", action="store_true", help="machine-readable output")
    s.set_defaults(func=cmd_ratios)

    s = sub.add_parser("graph", help="draw the bond-graph-like mechanism graph",
                       description="Draw the mechanism graph (.png/.svg/.pdf) or export it (.dot, .graphml).")
    s.add_argument("file", metavar="FILE")
    s.add_argument("-o", "--output", required=True, help="output file: .png .svg .pdf .dot .graphml")
    s.set_defaults(func=cmd_graph)

    s = sub.add_parser("lever", help="lever diagrams (lever analogy) and the speed chart",
                       description="Lever diagrams (Benford and Leising's lever analogy): every planetary set a lever "
                                   "with nodes spaced by the tooth counts, sets sharing two members combined, one "
                                   "panel per gear with the nodes at their speeds per unit input speed; "
                                   "--chart: every link's speed in every gear.")
    s.add_argument("file", metavar="FILE")
    s.add_argument("--gear", action="append", metavar="G",
                   help="draw this declared gear (repeatable; default: every gear, after a panel of the levers at rest)")
    s.add_argument("-o", "--output", help="the lever diagrams: .svg .png .pdf")
    s.add_argument("--chart", metavar="OUT", help="the speed chart: .svg .png .pdf")
    s.add_argument("--json", action="store_true", help="the lever geometry and the node speeds of every gear as JSON")
    s.set_defaults(func=cmd_lever)

    s = sub.add_parser("modes", help="modes with locked elements, DOF and kind",
                       description="List the modelled modes (or all combinations) and diagnose tie-ups and non-unique torques.")
    s.add_argument("file", metavar="FILE")
    s.add_argument("--all", action="store_true", help="every combination of locked elements")
    s.add_argument("--json", action="store_true", help="machine-readable output")
    s.set_defaults(func=cmd_modes)

    s = sub.add_parser("matrices", help="per-mode state-space matrices",
                       description="State-space matrices B, C, D of every modelled mode (thesis eqs. 3.6-3.15).")
    s.add_argument("file", metavar="FILE")
    s.add_argument("--coords", help="generalized coordinates, e.g. L1,L6 (default: from the file, else input and output)")
    s.add_argument("--symbolic", nargs="?", const="all", choices=("all", "inertias"),
                   help="symbolic matrices in the mechanism's own symbols: all (inertias, tooth counts, radii; "
                        "the default) or inertias (gear geometry kept as exact numbers: fast for multi-DOF modes)")
    s.add_argument("--modes", choices=("auto", "default", "declared", "all"), default="auto",
                   help="which modes (default: declared in the file, else the default choice)")
    s.add_argument("--format", choices=("json", "npz", "mat", "latex"), help="output format (default: from -o suffix)")
    s.add_argument("-o", "--output", help="output file (default: JSON on standard output)")
    s.add_argument("--list-coordinates", action="store_true", help="list every valid set of generalized coordinates")
    s.add_argument("--json", action="store_true", help="with --list-coordinates: JSON output")
    s.set_defaults(func=cmd_matrices)

    s = sub.add_parser("std", help="the state-transition diagram of mode switching",
                       description="Draw (.png/.svg/.pdf) or export (.dot) the state-transition diagram; --json for the simulator.")
    s.add_argument("file", metavar="FILE")
    s.add_argument("-o", "--output", help="output picture or .dot file")
    s.add_argument("--all", action="store_true", help="all combinations as modes")
    s.add_argument("--json", action="store_true", help="modes and transitions with conditions as JSON")
    s.set_defaults(func=cmd_std)

    s = sub.add_parser("powerflow", help="power flow, efficiency and element torques per gear",
                       description="For every declared gear: link speeds, slips of the open elements, torques of the "
                                   "engaged ones, power through every planetary set (circulating power), torque ratio "
                                   "and efficiency with mesh losses, and a capacity sizing of the shift elements.")
    s.add_argument("file", metavar="FILE")
    s.add_argument("--eta0", type=number_option(0, 1), metavar="X",
                   help="standing (carrier-fixed) efficiency of the planetary sets without eta0= in the file, "
                        "and of the gear pairs without eta= unless --eta-pair is given (default 0.98; 1 = lossless)")
    s.add_argument("--eta-pair", type=number_option(0, 1), metavar="X",
                   help="mesh efficiency of the gear pairs without eta= in the file (default: --eta0 if given, else 0.99)")
    s.add_argument("--input-rpm", type=number_option(0, 1e7), metavar="N",
                   help="input speed [rpm]: slips in rpm, over-speed of the open elements")
    s.add_argument("--max-slip-rpm", type=number_option(0, 1e7), metavar="N",
                   help="slip limit [rpm] of the elements without max_slip_rpm= in the file")
    s.add_argument("--design-torque", type=number_option(0, 1e9), metavar="N*m",
                   help="design input torque [N*m] for the capacity sizing")
    s.add_argument("--safety-factor", type=number_option(0, 1e3), default=1.4, metavar="X",
                   help="suggested static capacity over the largest element torque (default 1.4)")
    s.add_argument("--dynamic-ratio", type=number_option(0, 1), default=0.85, metavar="X",
                   help="suggested dynamic over static capacity (default 0.85)")
    s.add_argument("--gear", action="append", metavar="NAME", help="only this gear (repeatable; default: every gear)")
    s.add_argument("--coast", action="store_true",
                   help="coast (overrun, engine braking): the driveline drives the output, the input absorbs")
    s.add_argument("--losses", nargs="?", const="", metavar="LOSSES.toml",
                   help="add drag, spin and pump losses (parameters from the file, else the defaults; docs/losses.md)")
    s.add_argument("--speed", type=number_option(0, 1e6), metavar="RPM", help="--losses: input speed (default 2000)")
    s.add_argument("--torque", type=number_option(0, 1e7), metavar="N*m", help="--losses: input torque (default 200)")
    s.add_argument("--map", action="store_true", help="--losses: efficiency map per gear, neutral loss over speed")
    s.add_argument("--map-speed", metavar="MIN:MAX:N", help="--map: input speeds [rpm] (default 500:6000:23)")
    s.add_argument("--map-torque", metavar="MIN:MAX:N", help="--map: input torques [N*m] (default T/20:2T:40)")
    s.add_argument("-o", "--output", metavar="DIR", help="--losses: write the JSON and the figures into DIR")
    s.add_argument("--json", action="store_true", help="machine-readable output")
    s.set_defaults(func=cmd_powerflow)

    s = sub.add_parser("list", help="list the bundled mechanisms", description="List the bundled mechanisms.")
    s.add_argument("--json", action="store_true", help="machine-readable output")
    s.set_defaults(func=cmd_list)

    from .synthesis.cli import add_commands as add_synthesis_commands

    add_synthesis_commands(sub)
    from .fmu.cli import add_commands as add_fmu_commands

    add_fmu_commands(sub)
    _add_sim_commands(sub)
    _add_force_options(p)
    return p


def _add_sim_commands(sub) -> None:
    """Commands of the simulator (``transgen.sim``)."""
    try:
        from .sim.cli import add_commands
    except ImportError:  # pragma: no cover - the simulator is part of the package
        return
    add_commands(sub)
    from .sim.study.cli import add_commands as add_study_commands

    add_study_commands(sub)


def entry_point() -> int:
    """The program ``transgen`` (console script, ``python -m transgen``): :func:`main`, with the
    exit code ``128 + signum`` for a SIGTERM or SIGHUP at any time after its handler is installed,
    also after the command while the process joins its threads and runs its exit hooks; it ends
    at its last exit hook (:func:`transgen.exiting.exit_hook`), before Python frees its modules
    and resets the handlers (a signal then killed it: exit -15)."""
    import atexit
    import signal

    from .exiting import EXIT, exit_hook, install_terminate, late_code

    installed = install_terminate()
    EXIT["last"] = getattr(atexit, "_ncallbacks", lambda: 1)() == 0
    atexit.register(exit_hook)  # registered before any pool's hooks: runs after them
    try:
        try:
            code = main()
        finally:
            EXIT["ended"] = installed  # from now on a signal is noted, not raised
    except KeyboardInterrupt as exc:  # outside main's own handling (before its command, after its return)
        signum = getattr(exc, "signum", signal.SIGINT)
        _error("interrupted" if signum == signal.SIGINT else f"terminated ({signal.Signals(signum).name})")
        code = 128 + signum
    except SystemExit as exc:  # argparse: --help, --version, a usage error
        code = exc.code if isinstance(exc.code, int) else (0 if exc.code is None else 2)
    EXIT["code"] = code = late_code(code)
    return code


#: options that name a file the command writes, and options that name a file it reads
_OUTPUT_OPTIONS = {"output": "-o", "history": "--history", "chart": "--chart"}
_INPUT_OPTIONS = {"file": "FILE", "scenario": "SCENARIO", "map": "MAPFILE", "compare": "--compare",
                  "no_worse_than": "--no-worse-than", "name": "NAME"}


def _add_force_options(parser: argparse.ArgumentParser) -> None:
    """``--force`` on every command that writes a file (``-o``, ``--history``, ``--chart``,
    ``--plot``): overwrite even one of the command's inputs (:mod:`transgen.outputs`)."""
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for child in dict.fromkeys(action.choices.values()):
                _add_force_options(child)
    dests = {a.dest for a in parser._actions}
    if dests & {*_OUTPUT_OPTIONS, "plot"} and "force" not in dests:
        parser.add_argument("--force", action="store_true",
                            help="write the outputs even where one is an input of the command (it is overwritten)")


def _output_is_input(args) -> str | None:
    """The message refusing an output option that names one of the command's input files (by
    resolved path or by device and inode), before any work; None where there is none."""
    import os

    if getattr(args, "force", False):
        return None

    def identity(path):
        try:
            st = os.stat(path)
        except (OSError, ValueError, TypeError):
            return None
        return (st.st_dev, st.st_ino) if not os.path.isdir(path) else None

    inputs = {}
    for dest, label in _INPUT_OPTIONS.items():
        value = getattr(args, dest, None)
        if isinstance(value, str) and identity(value) is not None:
            inputs.setdefault(identity(value), (label, value))
    for dest, option in _OUTPUT_OPTIONS.items():
        value = getattr(args, dest, None)
        if isinstance(value, str) and identity(value) in inputs:
            label, name = inputs[identity(value)]
            return (f"{option} {value}: is the input {label} ({name}): writing it would destroy it; name another "
                    f"output (or give --force to overwrite it)")
    return None


EXIT_BROKEN_PIPE = 128 + 13
"""Exit code when the reader of standard output went away (``| head``): as a tool killed by
SIGPIPE, without a message."""


def _error(text: str) -> None:
    """Print ``text`` on standard error, which may itself be a closed pipe (``2>&1 | head``)."""
    try:
        print(text, file=sys.stderr)
    except BrokenPipeError:
        pass


def _show_warning(message, category, filename, lineno, file=None, line=None) -> None:
    _error(f"warning: {message}")


def _broken_pipe() -> int:
    """Standard output is a closed pipe: point it at /dev/null so that the interpreter's final
    flush does not complain, and exit quietly."""
    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
    except (OSError, ValueError):  # pragma: no cover - no file descriptor to redirect
        pass
    return EXIT_BROKEN_PIPE


def main(argv: list[str] | None = None) -> int:
    """Run the command line; return the exit code."""
    import signal

    from .blas import one_thread_from_start

    one_thread_from_start()  # small linear algebra: no BLAS thread pool to start (transgen.blas)
    from .exiting import install_terminate
    from .outputs import Terminated, command_scope, remove_temporaries

    install_terminate()
    parser = build_parser()
    args = parser.parse_args(argv)
    refused = _output_is_input(args)
    if refused:
        _error(f"error: {refused}")
        return 2
    with warnings.catch_warnings(), command_scope(getattr(args, "force", False)):
        warnings.showwarning = _show_warning
        try:
            code = args.func(args)
            sys.stdout.flush()  # a closed pipe shows here, not at exit
            return code
        except BrokenPipeError:  # output piped into e.g. head
            return _broken_pipe()
        except SimulationError as exc:
            _error(f"error: {exc}")
            return 1
        except TransgenError as exc:  # a ValueError is bad input (.mech, scenario, map, modes), else a failed run
            _error(str(exc) if _located(str(exc)) else f"error: {exc}")
            return 2 if isinstance(exc, ValueError) else 1
        except ValueError as exc:  # invalid option values found by the library (e.g. output format)
            _error(f"error: {exc}")
            return 2
        except OSError as exc:
            _error(f"error: {exc.strerror or exc}" + (f": {exc.filename}" if exc.filename else ""))
            return 1
        except KeyboardInterrupt as exc:
            signum = exc.signum if isinstance(exc, Terminated) else signal.SIGINT
            _error("interrupted" if signum == signal.SIGINT else f"terminated ({signal.Signals(signum).name})")
            return 128 + signum
        finally:
            remove_temporaries()  # those of outputs left unfinished, whatever ended the command


def _located(message: str) -> bool:
    """Whether ``message`` already starts ``FILE:LINE:COL: error:`` (or ``FILE:LINE: error:``, or
    ``--set KEY: error:``, ``--OPTION ...: error:`` for a value given on the command line)."""
    first = message.split("\n", 1)[0]
    where = first.split(": error: ", 1)[0]
    return ": error: " in first and (where.rsplit(":", 1)[-1].isdigit() or where.startswith("--"))


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
