"""Benchmark of tooth-count synthesis: ZF 8HP70 with all four sets unknown and its 8 forward and
reverse published ratios (9 targets, 4 decimals). Goal: under 30 s.

Prints the process time (``time.process_time``, CPU seconds of this process: wall time is
meaningless on a loaded machine) of each repeat, the number of solutions and whether the
published teeth are among them.

    python benchmarks/bench_synthesis.py [--repeats N]
"""
from __future__ import annotations

import argparse
import re
import time

from transgen.language import parse_mechanism
from transgen.library import bundled_path
from transgen.synthesis.teeth import ratio_targets, synthesize_teeth

PUBLISHED = {"PS1": (48, 96), "PS2": (48, 96), "PS3": (69, 111), "PS4": (23, 85)}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()
    text = re.sub(r"Ns=\d+ Nr=\d+", "Ns=? Nr=?", bundled_path("zf8hp70.mech").read_text())
    mech = parse_mechanism(text, "zf8hp70_unknown.mech", unknown_teeth=True)
    targets = ratio_targets(mech)
    times = []
    for _ in range(args.repeats):
        start = time.process_time()
        result = synthesize_teeth(mech, targets, top=0)
        times.append(time.process_time() - start)
    found = any({t.name: (t.n_sun, t.n_ring) for t in s.teeth} == PUBLISHED for s in result.solutions)
    print(f"zf8hp70, 4 unknown sets, {len(targets)} targets: {result.count} solutions, published teeth found: {found}")
    print(f"process time per run [s]: {' '.join(f'{t:.2f}' for t in times)} (best {min(times):.2f}, goal < 30)")


if __name__ == "__main__":
    main()
