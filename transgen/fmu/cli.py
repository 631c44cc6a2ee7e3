"""``transgen fmu``: the command-line layer over :func:`transgen.fmu.export_fmu`."""
from __future__ import annotations

__all__ = ["add_commands"]

EXAMPLE = """examples:
  transgen fmu coupled_clutches.mech -o cc.fmu           # the transmission alone (inputs T_in, T_out, apply_*)
  transgen fmu freewheel_clutch -o fw.fmu --fmi 3        # a scenario: its signals are the inputs' defaults
  fmpy validate cc.fmu && fmpy simulate fw.fmu --interface-type CoSimulation
"""


def cmd_fmu(args) -> int:
    import hashlib

    from ..schemas import print_document
    from .description import variables
    from .export import INTERFACES, fmu_files, load_source, model_identifier
    from .build import write_fmu
    from .data import FmuError

    if not args.output:
        raise FmuError("-o NAME.fmu is required")
    if not args.output.endswith(".fmu"):
        raise FmuError(f"{args.output}: the output file must end in .fmu")
    from pathlib import Path

    out = Path(args.output)
    overrides = None
    if args.set:
        from ..sim.overrides import parse_override

        overrides = dict(parse_override(t) for t in args.set)
    d = load_source(args.source, model_identifier(out.stem), overrides)
    files = fmu_files(d, args.fmi, args.interface)
    write_fmu(out, files)
    data = out.read_bytes()
    vs = variables(d)
    info = {"path": str(out), "fmi": args.fmi, "interfaces": list(INTERFACES[args.interface]),
            "model_identifier": d.model_name, "source": d.source, "bytes": len(data),
            "sha256": hashlib.sha256(data).hexdigest(), "states": len(d.links),
            "event_indicators": d.n_indicators, "modes": [d.mode_label(m) for m in d.mode_masks],
            "inputs": [{"name": i.name, "built_in_signal": i.signal is not None} for i in d.inputs],
            "outputs": [v.name for v in vs if v.causality == "output"],
            "parameters": [v.name for v in vs if v.causality == "parameter"]}
    if args.json:
        print_document("transgen.fmu/1", info, {})
        return 0
    kind = " + ".join({"me": "Model Exchange", "cs": "Co-Simulation"}[i] for i in INTERFACES[args.interface])
    print(f"wrote {out}: FMI {args.fmi}.0 {kind}, {len(d.links)} states, {len(d.mode_masks)} modes, "
          f"{d.n_indicators} event indicators, {len(data)} bytes")
    builtin = [i.name for i in d.inputs if i.signal is not None]
    if builtin:
        print(f"  inputs with the scenario's signals as defaults: {', '.join(builtin)}")
    return 0


def add_commands(sub) -> None:
    """Add ``transgen fmu`` to the ``transgen`` parser."""
    import argparse

    s = sub.add_parser("fmu", help="export an FMU (FMI 2.0/3.0, Model Exchange and Co-Simulation)",
                       description="Export a transmission (FILE.mech: inputs T_in, T_out, apply_<element>) or a "
                                   "scenario (its signals built in as the inputs' defaults) as an FMU, compiled with "
                                   "the system C compiler; needs fmpy for the FMI headers (pip install "
                                   "'transgen[fmu]'). A bare name is a bundled scenario if there is one, else a "
                                   "bundled mechanism; NAME.mech is always the mechanism. See docs/fmu.md.",
                       epilog=EXAMPLE, formatter_class=argparse.RawDescriptionHelpFormatter)
    s.add_argument("source", metavar="SCENARIO|FILE.mech", help="scenario (.toml or bundled name) or .mech file")
    s.add_argument("-o", "--output", metavar="NAME.fmu", help="the FMU to write (NAME is the model identifier)")
    s.add_argument("--fmi", type=int, choices=(2, 3), default=2, help="FMI version (default 2)")
    s.add_argument("--interface", choices=("me", "cs", "both"), default="both",
                   help="Model Exchange, Co-Simulation or both in one FMU (default both)")
    s.add_argument("--set", action="append", metavar="KEY=VALUE", help="override a scenario key (as simulate --set)")
    s.add_argument("--json", action="store_true", help="machine-readable summary")
    s.set_defaults(func=cmd_fmu)
