"""``transgen sweep``: the command line of :func:`transgen.sim.study.sweep` (a thin layer).

``--grid KEY=V1,V2,...`` (TOML values), ``--grid KEY=LO:HI:N`` (N values from LO to HI inclusive)
or, with ``--samples N``, ``--grid KEY=LO:HI`` (a Latin-hypercube range) or ``--grid KEY=V`` (fixed). Bad keys and values are
``error:`` lines naming the key, with the closest known key, and exit 2 before any run starts.
"""
from __future__ import annotations

import re
import sys
import time

__all__ = ["add_commands", "cmd_sweep", "parse_grid", "sweep_units"]

_RANGE = re.compile(r"\s*([^:,]+?)\s*:\s*([^:,]+?)\s*(?::\s*([^:,]+?)\s*)?")


def add_commands(sub) -> None:
    """Add ``sweep`` to the ``transgen`` parser."""
    from transgen.limits import add_force_option
    from transgen.progress import add_progress_option

    s = sub.add_parser("sweep", help="run a scenario over a grid or a Latin-hypercube sample of parameters",
                       description="Run a scenario (a .toml file or a bundled name) over a full grid of dotted-key "
                                   "overrides (--grid KEY=V1,V2,... or KEY=LO:HI:N) or a Latin-hypercube sample "
                                   "(--samples N with --grid KEY=LO:HI). One CSV row per run: the parameters, "
                                   "success, message, wall time, the energy balance, every scalar of the shift "
                                   "report per shift and the turbocharger figures. Rerunning with the same -o "
                                   "resumes: finished rows are kept, not run again.")
    s.add_argument("scenario", metavar="SCENARIO", help="scenario .toml file or bundled name")
    s.add_argument("--grid", metavar="KEY=VALUES", action="append", required=True,
                   help="a parameter and its values: KEY=V1,V2,... (TOML values), KEY=LO:HI:N (N values, "
                        "inclusive) or, with --samples, KEY=LO:HI (sampled) or KEY=V (fixed); repeatable")
    s.add_argument("--samples", type=int, metavar="N", help="a Latin-hypercube sample of N runs over the LO:HI ranges")
    s.add_argument("--seed", type=int, default=0, help="seed of the Latin-hypercube sample (default 0)")
    engine = s.add_mutually_exclusive_group()
    engine.add_argument("--workers", type=int, metavar="N",
                        help="local worker processes (default: one per core; 1: in this process)")
    engine.add_argument("--scheduler", metavar="tcp://HOST:PORT",
                        help="run on a Dask distributed cluster (needs transgen[distributed])")
    s.add_argument("-o", "--output", required=True, metavar="RESULTS.csv",
                   help="results CSV, rewritten atomically as rows complete; an existing one is resumed")
    s.add_argument("--json", action="store_true", help="print a JSON summary (schema transgen.sweep/1)")
    s.add_argument("--plot", metavar="DIR", help="write plots of the shift metrics into DIR")
    s.add_argument("--format", default="png", help="plot formats, comma-separated: png,svg,pdf (default png)")
    s.add_argument("--quiet", action="store_true", help="no progress on standard error")
    add_progress_option(s)
    add_force_option(s)
    s.set_defaults(func=cmd_sweep)
    from .optimize_cli import add_optimize_command

    add_optimize_command(sub)


def _values(spec: str) -> list[str]:
    """``spec`` split at the commas outside brackets, braces and quotes."""
    parts, depth, quote, current = [], 0, None, []
    for ch in spec:
        if quote:
            quote = None if ch == quote else quote
        elif ch in "\"'":
            quote = ch
        elif ch in "[{":
            depth += 1
        elif ch in "]}":
            depth -= 1
        elif ch == "," and depth == 0:
            parts.append("".join(current))
            current = []
            continue
        current.append(ch)
    parts.append("".join(current))
    return parts


def _is_number(x) -> bool:
    return isinstance(x, (int, float)) and not isinstance(x, bool)


def parse_grid(text: str, sampled: bool = False) -> tuple[str, object]:
    """``(key, values)`` of one ``--grid`` option; with ``sampled`` ``(key, (lo, hi))``.
    Raises ScenarioError (``--grid KEY: error: ...``)."""
    from transgen.errors import ScenarioError
    from transgen.sim import parse_override

    from .design import linspace_values

    key, eq, spec = text.partition("=")
    key = key.strip()
    if not eq or not key:
        raise ScenarioError(f"--grid {text}: error: expected KEY=V1,V2,... or KEY=LO:HI:N, "
                            f"e.g. driveline.vehicle_mass=20000,36000")

    def value(part: str):
        return parse_override(f"{key}={part}")[1]

    match = _RANGE.fullmatch(spec)
    if match:
        lo, hi = value(match.group(1)), value(match.group(2))
        if _is_number(lo) and _is_number(hi):
            count = match.group(3)
            if sampled:
                if count is not None:
                    raise ScenarioError(f"--grid {key}: error: with --samples give the range as LO:HI, not LO:HI:N")
                return key, (lo, hi)
            n = value(count) if count is not None else None
            if not isinstance(n, int) or isinstance(n, bool) or n < 1:
                raise ScenarioError(f"--grid {key}: error: LO:HI:N needs the number of values N (a whole number "
                                    f">= 1), e.g. {key}={lo}:{hi}:5; or sample the range with --samples")
            from transgen.limits import check_limit

            check_limit("grid_values", n, f"--grid {key}={spec.strip()}")  # before the values are made
            return key, linspace_values(lo, hi, n)
    values = [value(part) for part in _values(spec)]
    if sampled and len(values) != 1:
        raise ScenarioError(f"--grid {key}: error: with --samples a parameter is a range LO:HI (e.g. {key}=0.5:0.9) "
                            f"or one fixed value")
    return key, values


def _as_grid_error(message: str) -> str:
    """An override error of the scenario reader (``--set KEY: error: ...``) as the option that
    gave the value (``--grid KEY: error: ...``)."""
    return message.replace("--set", "--grid") if message.startswith("--set ") else message


def cmd_sweep(args) -> int:
    from transgen.errors import ScenarioError
    from transgen.limits import check_workers
    from transgen.progress import ProgressLine

    from .design import check_design
    from .executors import make_executor
    from .runner import sweep

    sampled = args.samples is not None
    grid: dict = {}
    try:
        for text in args.grid:
            key, values = parse_grid(text, sampled)
            if key in grid:
                raise ScenarioError(f"--grid {key}: error: given twice (list all its values in one --grid)")
            grid[key] = values
        if args.plot:
            from transgen.sim.cli import _plot_formats

            formats = _plot_formats(args.format)
        check_design(grid, args.samples, args.force)  # counted, not made: before anything is allocated
        check_workers(args.workers, args.force)
        executor = make_executor(args.workers, args.scheduler)
    except (ScenarioError, ValueError, ImportError) as exc:
        return _fail(exc)
    line = ProgressLine(not (args.quiet or args.json), args.progress)
    last = []

    def progress(p) -> None:
        if p.estimate and not last and not (args.quiet or args.json):  # once, before the first run
            print(f"sweep: {p.total - p.resumed} runs to do, {p.estimate}", file=sys.stderr, flush=True)
        last[:] = [p]
        line.show(p.text(), final=p.done == p.total)
    start = time.perf_counter()
    try:
        table = sweep(args.scenario, grid, samples=args.samples, seed=args.seed, executor=executor,
                      progress=progress, results=args.output, force=args.force)
    except (ScenarioError, ValueError) as exc:  # found before any run: bad values, design or results file
        line.end()
        return _fail(exc)
    finally:
        line.end()
    elapsed = time.perf_counter() - start
    written = [args.output]
    if args.plot:
        from transgen.export import output_set

        from .plots import plot_sweep

        with output_set():
            written += [str(p) for p in plot_sweep(table, args.plot, formats)]
    rows = table.rows
    failed = table.failed
    if args.json:
        from transgen.schemas import print_document

        summary = {
            "scenario": args.scenario,
            "design": {"kind": "latin_hypercube" if sampled else "grid", "parameters": grid,
                       "samples": args.samples, "seed": args.seed if sampled else None},
            "executor": repr(executor),
            "runs": len(rows),
            "succeeded": len(rows) - len(failed),
            "failed": len(failed),
            "resumed": last[-1].resumed if last else 0,
            "wall_time": elapsed,
            "results": args.output,
            "written": written,
            "parameters": table.parameters,
            "columns": table.columns,
            "failures": [{"key": r["key"], "message": r.get("message", "")} for r in failed],
            "rows": table.rows,
        }
        print_document("transgen.sweep/1", summary, sweep_units(table))
    else:
        from transgen.outputs import messages_stream

        out = messages_stream(args.output)  # standard error where the table goes to standard output
        resumed = last[-1].resumed if last else 0
        print(f"{len(rows)} runs: {len(rows) - len(failed)} succeeded, {len(failed)} failed"
              f"{f' ({resumed} finished before, kept from {args.output})' if resumed else ''}, {elapsed:.1f} s "
              f"({executor!r})", file=out)
        for r in failed[:10]:
            print(f"  failed {r['key']}: {' '.join(f'{p}={r.get(p)}' for p in table.parameters)}: "
                  f"{str(r.get('message', '')).splitlines()[0] if r.get('message') else ''}", file=out)
        if len(failed) > 10:
            print(f"  ... and {len(failed) - 10} more failed runs (see the message column)", file=out)
        for w in written:
            print(f"  wrote {w}", file=out)
    return 0


def sweep_units(table) -> dict[str, str]:
    """The ``units`` map of the ``--json`` summary (schema ``transgen.sweep/1``): the unit of
    every result column that has one, ``"1"`` for the counts, ``""`` for the parameters (their
    SI unit as in the scenario file; transgen does not know the unit of every key)."""
    counts = dict.fromkeys(("runs", "succeeded", "failed", "resumed", "samples", "seed"), "1")
    return {"wall_time": "s", **counts, **dict.fromkeys(table.parameters, ""), **table.units()}


def _fail(exc) -> int:
    message = _as_grid_error(str(exc))
    first = message.split("\n", 1)[0]
    print(message if ": error: " in first else f"error: {message}", file=sys.stderr)
    return 2
