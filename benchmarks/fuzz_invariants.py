"""Long fuzz of the simulator's physical invariants and solver independence (issue 10).

Run:  python benchmarks/fuzz_invariants.py [--examples 300] [--seed 0] [--out DIR] [--solvers DOP853,RK45,...]

Random chains of 2-5 inertias joined by clutches, one-way clutches and simple planetaries, with
brakes, random apply signals and input torques (tests/random_mechanisms.py, the generator of
tests/test_sim_properties.py), each run for 0.2-0.5 s on every solver through the public API.
Prints how many cases were rejected at load, how each solver fared (completed, stopped with a
message, crashed), the property violations (physics re-checked on the samples, solver
differences) grouped by kind, and the wall times. Every case that violates a property is written
to DIR (default: a fresh temporary folder) as ``case_NNN.mech`` / ``case_NNN.toml`` /
``case_NNN.txt`` (what went wrong). Violations that a known bug of ``KNOWN_BUGS`` explains are counted apart from the new ones.
Asserts nothing; the exit status is 1 when a new violation was found.
"""
from __future__ import annotations

import argparse
import collections
import re
import sys
import tempfile
import time
from pathlib import Path

from hypothesis import HealthCheck, Phase, given, seed, settings

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "tests"))
import random_mechanisms as rm  # noqa: E402


def category(message: str) -> str:
    """A stop or violation message without its numbers and names, for grouping."""
    text = message.splitlines()[0] if message else ""
    text = re.sub(r"\(mode [^)]*\)", "", text)
    text = re.sub(r"[-+]?\d[\d.e+-]*", "#", text)
    text = re.sub(r"\b[LCBFP]\d\b", "X", text)
    text = re.sub(r"in mode \S+", "in mode M", text)
    return text.strip()[:150]


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--examples", type=int, default=300)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--out", type=Path, default=None)
    parser.add_argument("--solvers", default=",".join(rm.SOLVERS))
    args = parser.parse_args(argv)
    methods = tuple(args.solvers.split(","))
    out_dir = args.out or Path(tempfile.mkdtemp(prefix="fuzz_invariants_"))
    out_dir.mkdir(parents=True, exist_ok=True)
    work = Path(tempfile.mkdtemp(prefix="fuzz_work_"))

    counts = collections.Counter()
    rejected = collections.Counter()
    stops = collections.Counter()
    violations = collections.Counter()  # (property, category) of the violations no known bug explains
    known = collections.Counter()  # (property, known bug)
    per_solver = {m: collections.Counter() for m in methods}
    seconds = {m: [] for m in methods}
    events = []
    found = []
    wall = time.perf_counter()

    @seed(args.seed)
    @settings(max_examples=args.examples, deadline=None, database=None, phases=[Phase.generate],
              suppress_health_check=list(HealthCheck))
    @given(rm.cases())
    def fuzz(case):
        counts["cases"] += 1
        outcome = rm.examine(case, work, methods)
        if outcome.rejected is not None:
            counts["rejected at load"] += 1
            rejected[category(outcome.rejected.splitlines()[-1])] += 1
            return
        counts["runnable"] += 1
        for m in methods:
            if m in outcome.results:
                per_solver[m]["completed"] += 1
                events.append(outcome.results[m].stats["events"])
            elif m in outcome.stopped:
                per_solver[m]["stopped"] += 1
                stops[category(outcome.stopped[m])] += 1
            elif m in outcome.crashed:
                per_solver[m]["crashed"] += 1
            if m in outcome.seconds:
                seconds[m].append(outcome.seconds[m])
        problems = [(prop, p) for prop, ps in outcome.violations().items() for p in ps]
        for prop, p in problems:
            bug = rm.known_bug(p, case, outcome)
            if bug:
                known[(prop, bug)] += 1
            else:
                violations[(prop, category(p))] += 1
        if problems:
            k = len(found)
            found.append(case)
            (out_dir / f"case_{k:03d}.mech").write_text(case.mech)
            (out_dir / f"case_{k:03d}.toml").write_text(case.scenario.replace("random.mech", f"case_{k:03d}.mech"))
            (out_dir / f"case_{k:03d}.txt").write_text(
                "\n".join(f"[{prop}] {rm.known_bug(p, case, outcome) or 'NEW'}: {p}" for prop, p in problems) + "\n")

    fuzz()
    total = time.perf_counter() - wall
    print(f"{counts['cases']} random cases in {total:.0f} s (seed {args.seed}): {counts['runnable']} runnable, "
          f"{counts['rejected at load']} rejected at load")
    for text, n in rejected.most_common(8):
        print(f"  rejected {n:4d}x  {text}")
    print(f"\n{'solver':<8}{'completed':>10}{'stopped':>9}{'crashed':>9}{'mean s':>9}{'max s':>8}")
    for m in methods:
        c, s = per_solver[m], seconds[m]
        print(f"{m:<8}{c['completed']:>10}{c['stopped']:>9}{c['crashed']:>9}"
              f"{(sum(s) / len(s) if s else 0):>9.3f}{(max(s) if s else 0):>8.2f}")
    if events:
        print(f"events per completed run: mean {sum(events) / len(events):.1f}, max {max(events)}")
    print("\nstopped with a message (all solvers together):")
    for text, n in stops.most_common(12):
        print(f"  {n:4d}x  {text}")
    print(f"\nproperty violations: {len(found)} case(s) (reproducers in {out_dir})")
    print("  explained by a known bug (tests/random_mechanisms.py KNOWN_BUGS):")
    for (prop, bug), n in known.most_common():
        print(f"  {n:4d}x  [{prop}] {bug}")
    print("  new (no known bug explains them):")
    for (prop, text), n in violations.most_common(20):
        print(f"  {n:4d}x  [{prop}] {text}")
    return 1 if violations else 0


if __name__ == "__main__":
    sys.exit(main())
