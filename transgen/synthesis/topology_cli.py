"""``transgen synthesize topology``: the command-line layer over :mod:`transgen.synthesis.rank`.

Exit codes: 0 candidates found; 1 no concept meets the targets (the counts are printed); 2 bad
input (sizes out of bounds, a search estimated to take too long, unreadable ratios).
"""
from __future__ import annotations

import math
import sys

__all__ = ["add_topology", "parse_targets", "ring_sun_range", "progress_line"]


def parse_targets(text: str) -> tuple[tuple[str, ...], tuple[float, ...]]:
    """``"1=2.45,2=1.45,3=1.00,R=-2.1"`` -> gear names and ratios (finite, nonzero, distinct names)."""
    from .teeth import parse_ratio_targets

    ratios = parse_ratio_targets(text)
    if not ratios:
        raise ValueError("--ratios: give the target ratios GEAR=RATIO,..., e.g. 1=2.45,2=1.45,3=1.00,R=-2.1")
    values = []
    for gear, value in ratios.items():
        x = float(value)
        if not math.isfinite(x) or x == 0:
            raise ValueError(f"--ratios: gear {gear}: a finite, nonzero ratio, not {value}")
        values.append(x)
    return tuple(ratios), tuple(values)


def ring_sun_range(text: str) -> tuple[float, float]:
    """``--ring-sun MIN,MAX`` as two finite numbers (shared by ``synthesize teeth``)."""
    try:
        low, high = (float(x) for x in text.split(","))
    except ValueError:
        raise ValueError(f"--ring-sun: two numbers MIN,MAX, e.g. 1.5,4.5, not {text!r}") from None
    if not (math.isfinite(low) and math.isfinite(high)):
        raise ValueError(f"--ring-sun: finite numbers, not {text!r}")
    return low, high


def progress_line(text: str) -> None:
    """Progress on standard error, rewritten in place (a terminal only)."""
    print(f"\r  {text}   ", end="", file=sys.stderr, flush=True)


def cmd_topology(args) -> int:
    from pathlib import Path

    from ..schemas import print_document
    from .rank import synthesize_topology, validate_spec
    from .search import SearchSpec

    gears, targets = parse_targets(args.ratios)
    low, high = ring_sun_range(args.ring_sun)
    engaged = args.engaged if args.engaged is not None else max(2, args.sets + args.ravigneaux - 1)
    spec = SearchSpec(args.sets, args.brakes, args.clutches, engaged, gears, targets, args.tolerance, low, high,
                      ravigneaux=args.ravigneaux, grounded=args.grounded)
    limit = args.max_hours * 3600
    validate_spec(spec, limit)  # before any executor starts
    executor = None
    if args.workers not in (None, 1) or args.scheduler:
        from ..sim.study.executors import make_executor

        executor = make_executor(args.workers, args.scheduler)
    progress = progress_line if sys.stderr.isatty() and not args.json else None
    checkpoint = args.output  # the finished trains are kept there: a second run resumes
    if executor is not None:
        with executor:
            result = synthesize_topology(spec, args.top, executor, progress, max_seconds=limit, checkpoint=checkpoint)
    else:
        result = synthesize_topology(spec, args.top, None, progress, max_seconds=limit, checkpoint=checkpoint)
    if progress:
        print(file=sys.stderr)
    if args.output:
        from ..export import write_text

        out = Path(args.output)
        out.mkdir(parents=True, exist_ok=True)
        rows = ["rank,max_ratio_error,with_teeth,input,output,elements,table,k,teeth,designer_cost,"
                "mean_forward_efficiency,max_circulating_power,file"]
        for c in result.candidates:
            name = f"candidate_{c.rank:02d}.mech"
            write_text(out / name, c.mech)
            if c.teeth and not args.no_levers:
                from ..drawing import draw_levers, save_figure
                from ..language import parse_mechanism

                fig = draw_levers(parse_mechanism(c.mech, name))
                save_figure(fig, out / f"candidate_{c.rank:02d}_levers.svg")
                import matplotlib.pyplot as plt

                plt.close(fig)
            d = c.to_dict()
            rows.append(",".join([
                str(c.rank), f"{c.max_ratio_error:.6g}", str(bool(c.teeth)).lower(), d["input"], d["output"],
                '"' + " ".join(f"{e}:{'-'.join(ls)}" for e, ls in d["elements"].items()) + '"',
                '"' + " ".join(f"{g}:{''.join(e)}" for g, e in c.gears.items()) + '"',
                '"' + " ".join(f"{v:.4f}" for v in c.k) + '"',
                '"' + (" ".join(f"{n}:{ns}/{nr}" for n, ns, nr, _ in c.teeth) if c.teeth else "") + '"',
                f"{c.figures.get('designer_cost') if c.figures.get('designer_cost') is not None else float('nan'):.6g}",
                f"{c.figures.get('mean_forward_efficiency', float('nan')):.6g}",
                f"{c.figures.get('max_circulating_power', float('nan')):.6g}", name]))
        write_text(out / "summary.csv", "\n".join(rows) + "\n")
    if args.json:
        print_document("transgen.synthesize.topology/1", result.to_dict(), result.UNITS)
        return 0 if result.candidates else 1
    s = spec
    kinds = f"{s.sets - s.ravigneaux} simple sets, {s.ravigneaux} Ravigneaux" if s.ravigneaux else f"{s.sets} simple sets"
    print(f"topology search: {kinds}, {s.brakes} brakes, {s.clutches} clutches, {s.engaged} engaged "
          f"per gear, {len(gears)} targets " + ", ".join(f"{g}={t:g}" for g, t in zip(gears, targets))
          + f", tolerance {s.tolerance:.2%}, ring/sun {low:g}..{high:g}")
    c = result.counts
    print(f"gear trains {result.trains}; concepts enumerated {c['enumerated']}, distinct {c['distinct']}, feasible "
          f"{c['feasible']}, screened {c['screened']}, refined {c['refined']}, fitted {c['fitted']}, with teeth "
          f"{c['with_teeth']} of {c['teeth_searched']}, ranked {c['ranked']}  ({result.seconds:.1f} s)")
    for note in result.notes:
        print(f"note: {note}")
    for cand in result.candidates:
        d = cand.to_dict()
        elems = " ".join(f"{e}={'-'.join(ls)}" for e, ls in d["elements"].items())
        table = " ".join(f"{g}:{''.join(e)}" for g, e in cand.gears.items())
        teeth = " ".join(f"{n} {ns}/{nr}" for n, ns, nr, _ in cand.teeth) if cand.teeth else "no teeth found"
        print(f"\n{cand.rank:>3}. max error {cand.max_ratio_error:.3%}  in {d['input']} out {d['output']}  {elems}")
        print(f"     table {table}")
        print("     ratios " + " ".join(f"{g} {r:.3f}" for g, r in cand.ratios.items()) + f"   teeth {teeth}")
        if cand.figures and "powerflow_error" not in cand.figures:
            f = cand.figures
            print(f"     efficiency {f['mean_forward_efficiency']:.4f} (mean fwd), circulating power "
                  f"{f['max_circulating_power']:.2f}, open slip {f['max_open_slip']:.2f}, element torque "
                  f"{f['max_element_torque']:.2f}, table score {f['table_score']:.2f}")
    if args.output:
        print(f"\nwrote {len(result.candidates)} .mech files and summary.csv to {args.output}")
    return 0 if result.candidates else 1


def add_topology(what) -> None:
    """Add ``topology`` to the ``synthesize`` sub-commands ``what``."""
    from ..cli_args import number_option

    t = what.add_parser(
        "topology", help="new gearbox concepts (sets, links, brakes, clutches, gear table, teeth) from target ratios",
        description="Enumerate planetary concepts of N simple sets with B brakes and C clutches (K engaged per gear), "
                    "remove isomorphic ones, prune those without enough one-DOF gears, fit the ring/sun ratios and the "
                    "gear table to the target ratios, find tooth counts and rank the candidates (docs/topology.md). "
                    "Example: transgen synthesize topology --sets 2 --brakes 2 --clutches 2 "
                    "--ratios 1=2.45,2=1.45,3=1.00,R=-2.1 --tolerance 0.02")
    t.add_argument("--sets", type=int, required=True, help="simple planetary sets (1..4)")
    t.add_argument("--ravigneaux", type=int, default=0,
                   help="how many of the --sets are Ravigneaux compounds (small sun, large sun, carrier, ring; two "
                        "planetary statements sharing ring and carrier, each Nr/Ns within --ring-sun; default 0)")
    t.add_argument("--grounded", type=int, default=0,
                   help="members that may be fixed to the housing (0..2; a fixed member makes its set a fixed "
                        "reduction, as a Lepelletier design's front set; default 0)")
    t.add_argument("--brakes", type=int, required=True, help="brakes (link to housing)")
    t.add_argument("--clutches", type=int, required=True, help="clutches (link to link)")
    t.add_argument("--engaged", type=int, help="elements engaged per gear (default max(2, planetary statements - 1), "
                                                "a Ravigneaux counting two)")
    t.add_argument("--ratios", required=True, help="target ratios GEAR=RATIO,... (input/output speed; reverse negative)")
    t.add_argument("--tolerance", type=number_option(0, 0.2), default=0.01,
                   help="largest relative ratio error (default 0.01)")
    t.add_argument("--ring-sun", default="1.5,4.5", help="bounds of every set's Nr/Ns (default 1.5,4.5)")
    t.add_argument("--top", type=int, default=20, help="candidates kept (default 20)")
    t.add_argument("--max-hours", type=number_option(0, 1000), default=6.0,
                   help="refuse a search estimated to take longer on one core (default 6)")
    t.add_argument("--workers", type=int, help="local worker processes (default: this process)")
    t.add_argument("--scheduler", help="Dask scheduler address tcp://HOST:PORT")
    t.add_argument("-o", "--output", metavar="DIR", help="write candidate_NN.mech, its lever diagram and summary.csv here; the finished "
                        "gear trains are kept in DIR/topology_checkpoint.json, and the same command "
                        "again resumes from them")
    t.add_argument("--no-levers", action="store_true", help="with -o: no lever diagrams (candidate_NN_levers.svg)")
    t.add_argument("--json", action="store_true", help="machine-readable output")
    t.set_defaults(func=_checked)


def _checked(args) -> int:
    if args.workers is not None and not 1 <= args.workers <= 256:
        raise ValueError(f"--workers must be 1..256, not {args.workers}")
    return cmd_topology(args)
