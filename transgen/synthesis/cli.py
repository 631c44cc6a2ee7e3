"""``transgen synthesize teeth|table|topology``: the command-line layer over :mod:`transgen.synthesis`.

Exit codes: 0 solutions found; 1 no solution (``teeth``: the targets cannot be met under the
rules, the closest candidates are printed; the input was valid, the search ran, the answer is
"none"); 2 bad input.
"""
from __future__ import annotations

import sys

from ..cli_args import number_option
from ..limits import add_force_option
from .topology_cli import add_topology
from .topology_cli import progress_line as _progress
from .topology_cli import ring_sun_range as _k_range

__all__ = ["add_commands"]


def _int_list(text: str) -> tuple[int, ...]:
    try:
        values = tuple(int(x) for x in text.split(",") if x.strip())
    except ValueError:
        raise ValueError(f"--planets: a comma-separated list of whole numbers, not {text!r}") from None
    if not values or min(values) < 1:
        raise ValueError(f"--planets: positive planet counts, not {text!r}")
    return values


def cmd_teeth(args) -> int:
    from ..language import load_mechanism
    from ..schemas import print_document
    from .teeth import AssemblyRules, completed_text, parse_ratio_targets, ratio_targets, synthesize_teeth

    mech = load_mechanism(args.file, unknown_teeth=True)
    k_min, k_max = _k_range(args.ring_sun)
    rules = AssemblyRules(_int_list(args.planets), args.min_teeth, k_min, k_max, args.max_teeth, args.profile_shift)
    targets = ratio_targets(mech, parse_ratio_targets(args.ratios) if args.ratios else None, args.tolerance)
    progress = _progress if sys.stderr.isatty() and not args.json else None
    result = synthesize_teeth(mech, targets, rules, top=args.top, progress=progress, force=args.force)
    if progress:
        print(file=sys.stderr)
    if args.output and result.solutions:
        from ..export import write_text

        write_text(args.output, completed_text(mech, result.solutions[0]))
    if args.json:
        print_document("transgen.synthesis_teeth/1", result.to_dict(), result.UNITS)
        return 0 if result.solutions else 1
    print(f"{mech.name}: tooth counts of {', '.join(result.unknown) or 'no unknown set'} for "
          f"{len(targets)} target ratios (ratio = input speed / output speed)")
    for t in targets:
        print(f"  gear {t.gear:>3}: {t.text} +- {float(t.tolerance):.2g}")
    print("assembly rules:")
    for rule in rules.describe():
        print(f"  - {rule}")
    for note in result.notes:
        print(f"note: {note}")
    shown = result.solutions or result.closest
    if result.solutions:
        print(f"{result.count} solutions; ranked by the largest ratio error, then size sum(Ns + Nr); "
              f"{'all' if not args.top or args.top >= result.count else f'best {len(result.solutions)}'} shown:")
    else:
        print("no solution meets every target within its tolerance under these rules; the closest candidates:")
    if not shown:
        print("  (none near the continuous solutions: none of them obeys the shares)")
    for i, s in enumerate(shown, start=1):
        teeth = "  ".join(f"{t.name} Ns={t.n_sun} Nr={t.n_ring} n={t.planets}" for t in s.teeth)
        print(f"  {i:>3}. {teeth}   max error {s.max_error:.2e}")
        print("       errors: " + ", ".join(f"{g} {e:+.1e}" for g, e in s.errors.items()))
    if result.solutions and args.output:
        from ..outputs import messages_stream

        print(f"\nwrote {args.output}: the .mech completed with the best solution", file=messages_stream(args.output))
    elif result.solutions:
        print("\ncompleted .mech (best solution):")
        print(completed_text(mech, result.solutions[0]).rstrip("\n"))
    return 0 if result.solutions else 1


def cmd_table(args) -> int:
    from ..language import load_mechanism
    from ..schemas import print_document
    from .table import SCORE_FORMULA, synthesize_table

    mech = load_mechanism(args.file)
    forward = args.forward
    if forward is None:
        declared = [g for g in mech.gears if g.kind == "gear" and not g.alternative]
        if not declared:
            raise ValueError("--forward N is needed: the file declares no gear table to take the number from")
        forward = sum(1 for g in declared if g.ratio is None or float(g.ratio) > 0)
    progress = _progress if sys.stderr.isatty() and not args.json else None
    result = synthesize_table(mech, forward, args.reverse, args.top, not args.single_only, progress)
    if progress:
        print(file=sys.stderr)
    if args.json:
        print_document("transgen.synthesis_table/1", result.to_dict(), result.UNITS)
        return 0 if result.tables else 1
    print(f"{mech.name}: {result.forward_candidates} forward and {result.reverse_candidates} reverse combinations "
          f"that are gears (idle members allowed); {result.searched} "
          f"sequences of {forward} forward gears scored")
    print(f"score = {SCORE_FORMULA}")
    for note in result.notes:
        print(f"note: {note}")
    order = mech.element_names
    for i, t in enumerate(result.tables, start=1):
        steps = " ".join(f"{s:.3f}" for s in t.steps)
        print(f"\ntable {i}: score {t.score:.3f}, spread {t.spread:.3f}, steps {steps}"
              + (f", double swaps {' '.join(a + '-' + b for a, b in t.double_swaps)}" if t.double_swaps else "")
              + (f", dogs engage in {' '.join(f'{d} {shift}' for shift, d in t.dog_shifts)}" if t.dog_shifts else ""))
        for line in t.mech_lines(order):
            print(f"  {line}")
    return 0 if result.tables else 1


def add_commands(sub) -> None:
    """Add ``synthesize`` with its ``teeth``, ``table`` and ``topology`` sub-commands to ``sub``."""
    s = sub.add_parser("synthesize", help="tooth counts from target ratios, a shift table, or new concepts",
                       description="Design synthesis: 'teeth' finds planetary tooth counts (Ns=? Nr=? in the file) "
                                   "that reproduce target ratios; 'table' chooses a gear table of shift elements; 'topology' "
                                   "proposes whole concepts from target ratios.")
    what = s.add_subparsers(dest="what", metavar="WHAT", required=True)

    t = what.add_parser("teeth", help="tooth counts of the sets written Ns=? Nr=? (or ranges Ns=20..60)",
                        description="Every assemblable integer tooth count of the unknown planetaries that reproduces "
                                    "every target ratio within its tolerance. Exit 1 when there is none (the closest "
                                    "candidates are printed).")
    t.add_argument("file", metavar="FILE")
    t.add_argument("--ratios", help="targets GEAR=RATIO,... (default: the gear lines' ratio=); tolerance half a unit "
                                    "of the last digit written")
    t.add_argument("--tolerance", type=number_option(0, 1e6), help="absolute tolerance of every target ratio (published ratios are "
                                                   "sometimes truncated, not rounded)")
    t.add_argument("--planets", default="3,4,5", help="admissible numbers of equally spaced planets (default 3,4,5)")
    t.add_argument("--min-teeth", type=int, default=17, help="fewest teeth on sun and planets (default 17)")
    t.add_argument("--ring-sun", default="1.5,4.5", help="bounds of the ring/sun ratio Nr/Ns (default 1.5,4.5)")
    t.add_argument("--max-teeth", type=int, default=150, help="largest ring of a set written Nr=? (default 150)")
    t.add_argument("--profile-shift", action="store_true", help="allow odd Nr - Ns (profile-shifted planets)")
    t.add_argument("--top", type=int, default=10, help="solutions shown (0 = all; default 10)")
    t.add_argument("-o", "--output", help="write the .mech completed with the best solution here (else it is printed)")
    add_force_option(t)
    t.add_argument("--json", action="store_true", help="machine-readable output")
    t.set_defaults(func=cmd_teeth)

    t = what.add_parser("table", help="choose a gear table (shift elements per gear)",
                        description="Choose N forward gears with falling ratios, one element swap between neighbours "
                                    "(double swaps reported), and R reverse gears, ranked by spread, steps and "
                                    "elements per gear. Gear lines in the file are ignored.")
    t.add_argument("file", metavar="FILE")
    t.add_argument("--forward", type=int, help="number of forward gears (default: as many as the file declares)")
    t.add_argument("--reverse", type=int, default=1, help="number of reverse gears (default 1)")
    t.add_argument("--top", type=int, default=5, help="tables shown (default 5)")
    t.add_argument("--single-only", action="store_true", help="only single swaps between neighbouring gears")
    t.add_argument("--json", action="store_true", help="machine-readable output")
    t.set_defaults(func=cmd_table)

    add_topology(what)
