"""Run the shell examples of the docs pages and time each command (issue 23).

    python benchmarks/docs_examples.py            # the examples tests/test_docs_examples.py runs
    python benchmarks/docs_examples.py --slow     # also those marked slow (minutes: optimize, sweeps, FMUs)
    python benchmarks/docs_examples.py --only-slow  # the pages with a slow example, each page whole

Prints every command with its wall time and whether it ran as the page says; exit 1 if one did not.
"""
from __future__ import annotations

import argparse
import subprocess
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "docs" / "_ext"))

import docs_examples as ex  # noqa: E402


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--slow", action="store_true", help="also the examples marked slow")
    parser.add_argument("--only-slow", action="store_true", help="only the examples marked slow")
    parser.add_argument("--page", help="only this page (path under docs/)")
    parser.add_argument("--timeout", type=float, default=600.0, help="seconds a command may take (default 600)")
    args = parser.parse_args()
    failures = 0
    for page in ex.pages():
        if args.page and str(page.relative_to(ex.DOCS)) != args.page:
            continue
        blocks, files = ex.parse_page(page)
        chosen = [b for b in blocks if (b.slow and (args.slow or args.only_slow)) or (not b.slow and not args.only_slow)]
        if not chosen:
            continue
        if args.only_slow:  # the whole page: a slow example may read the files its earlier blocks write
            chosen = blocks
        with tempfile.TemporaryDirectory() as tmp:
            folder = Path(tmp)
            ex.prepare(folder, files)
            for block in blocks:  # every block in order: a later one may read an earlier one's files
                if block not in chosen:
                    continue
                cluster = ex.Cluster() if "cluster" in block.marks else None
                if cluster:
                    cluster.__enter__()
                try:
                    for command in block.commands:
                        try:
                            code, output, wall, errors = ex.run_command(command, folder, timeout=args.timeout)
                        except subprocess.TimeoutExpired:
                            failures += 1
                            print(f"{args.timeout:7.2f} s  TIMEOUT  {block.page}:{block.line}  "
                                  f"{command.text.splitlines()[0][:90]}", flush=True)
                            continue
                        ok = code == block.exit_code and ex.shown(command.expected, output, errors)
                        failures += not ok
                        print(f"{wall:7.2f} s  {'ok  ' if ok else 'FAIL'}  {block.page}:{block.line}  "
                              f"{command.text.splitlines()[0][:90]}", flush=True)
                        if not ok:
                            print("\n".join("        | " + line for line in output[-15:] + errors.splitlines()[-5:]))
                finally:
                    if cluster:
                        cluster.__exit__(None, None, None)
    return 1 if failures else 0


if __name__ == "__main__":
    raise SystemExit(main())
