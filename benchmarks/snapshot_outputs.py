"""Snapshot of what the numeric commands print and write, to show that a change (start-up work,
refactoring) leaves every output byte-identical.

    python benchmarks/snapshot_outputs.py save DIR [GROUP...]  # run the commands, store their outputs
                                      # GROUP: global, mechanisms, simulator (default: all three)
    python benchmarks/snapshot_outputs.py compare A B    # byte-compare two snapshots

Every command runs as a fresh ``python -m transgen`` process, from a temporary folder, over every
bundled mechanism (``transgen list``): standard output, standard error and exit code, and the
files written with ``-o``; also every bundled scenario simulated (report and result file), the
derived scenarios of ``scenario new`` and a map summary, with the wall time masked. Prints a summary; ``compare`` exits 1 on any difference.
"""
from __future__ import annotations

import filecmp
import os
import re
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

PER_MECHANISM = [
    ["check", "{m}"], ["check", "{m}", "--json"],
    ["ratios", "{m}"], ["ratios", "{m}", "--json"], ["ratios", "{m}", "--gears-only"],
    ["modes", "{m}"], ["modes", "{m}", "--json"], ["modes", "{m}", "--all", "--json"],
    ["matrices", "{m}"], ["matrices", "{m}", "--modes", "all"], ["matrices", "{m}", "--list-coordinates"],
    ["matrices", "{m}", "-o", "OUT/matrices.tex"], ["matrices", "{m}", "-o", "OUT/matrices.json"],
    ["std", "{m}"], ["std", "{m}", "--json"], ["std", "{m}", "--all", "--json"], ["std", "{m}", "-o", "OUT/std.dot"],
    ["graph", "{m}", "-o", "OUT/graph.dot"], ["graph", "{m}", "-o", "OUT/graph.graphml"],
]
SMALL_SYMBOLIC = ["simple2", "simple2_oneway", "coupled_clutches", "freewheel_clutch"]
GLOBAL = [["list"], ["list", "--json"], ["simulate", "--list"], ["simulate", "--list", "--json"],
          ["matrices", "ht740", "--symbolic", "inertias"]] + [
    ["matrices", m, "--symbolic"] for m in SMALL_SYMBOLIC]
# the simulator: every bundled scenario run (report and result file), the derived scenarios, the keys
PER_SCENARIO = [["simulate", "{s}", "--quiet", "--report", "-o", "OUT/run.csv"], ["scenario", "keys", "{s}", "--json"]]
SIMULATOR = [["simulate", "ht740_improved", "--quiet", "--model", "compliant", "-o", "OUT/run.npz"],
             ["simulate", "simple2_upshift", "--quiet", "--plot", "OUT", "--format", "png"],
             ["maps", "we_compressor", "--json"], ["maps", "we_turbine"]] + [
    ["scenario", "new", "ht740", "--maneuver", k] for k in ("launch", "kickdown", "coastdown", "tipin", "tipout", "cycle")]


def _scrub(text: bytes) -> bytes:
    """The output without what differs between two runs of the same command: the wall time."""
    return re.sub(rb"wall_time\s+\d+(\.\d+)? s", b"wall_time * s", re.sub(rb"\d+(\.\d+)? s wall", b"* s wall", text))


def _run(argv: list[str], out: Path, label: str) -> None:
    with tempfile.TemporaryDirectory() as work:
        args = [a.replace("OUT", work) for a in argv]
        p = subprocess.run([sys.executable, "-m", "transgen", *args], capture_output=True, cwd=work,
                           env=dict(os.environ, MPLBACKEND="Agg"), check=False)
        target = out / label
        target.mkdir(parents=True)
        (target / "stdout").write_bytes(_scrub(p.stdout.replace(work.encode(), b"OUT")))
        (target / "stderr").write_bytes(_scrub(p.stderr.replace(work.encode(), b"OUT")))
        (target / "exit").write_text(f"{p.returncode}\n")
        for f in Path(work).iterdir():
            shutil.copyfile(f, target / f.name)


def mechanisms() -> list[str]:
    p = subprocess.run([sys.executable, "-m", "transgen", "list", "--json"], capture_output=True, text=True,
                       check=True, cwd=tempfile.gettempdir())
    import json

    return [m["name"] for m in json.loads(p.stdout)["mechanisms"]]


def scenarios() -> list[str]:
    p = subprocess.run([sys.executable, "-m", "transgen", "simulate", "--list", "--json"], capture_output=True,
                       text=True, check=True, cwd=tempfile.gettempdir())
    import json

    listed = json.loads(p.stdout)
    return sorted(s["name"] if isinstance(s, dict) else s for s in (listed.get("scenarios", listed)
                                                                   if isinstance(listed, dict) else listed))


GROUPS = ("global", "mechanisms", "simulator")


def save(directory: str, groups: tuple[str, ...] = GROUPS) -> None:
    out = Path(directory)
    out.mkdir(parents=True, exist_ok=False)
    runs = [(argv, "_".join(argv).replace("/", "_")) for argv in GLOBAL] if "global" in groups else []
    if "mechanisms" in groups:
        for m in mechanisms():
            runs += [([a.format(m=m) for a in argv], "_".join(argv).replace("{m}", m).replace("/", "_"))
                     for argv in PER_MECHANISM]
    if "simulator" in groups:
        runs += [(argv, "_".join(argv).replace("/", "_")) for argv in SIMULATOR]
        for name in scenarios():
            runs += [([a.format(s=name) for a in argv], "_".join(argv).replace("{s}", name).replace("/", "_"))
                     for argv in PER_SCENARIO]
    for i, (argv, label) in enumerate(runs):
        print(f"\r{i + 1}/{len(runs)} {' '.join(argv):<60}", end="", file=sys.stderr, flush=True)
        _run(argv, out, label)
    print(file=sys.stderr)
    print(f"{len(runs)} commands saved in {out}")


def compare(a: str, b: str) -> int:
    left, right = Path(a), Path(b)
    names = sorted({p.relative_to(left) for p in left.rglob("*") if p.is_file()}
                   | {p.relative_to(right) for p in right.rglob("*") if p.is_file()})
    differ = [n for n in names
              if not ((left / n).is_file() and (right / n).is_file() and filecmp.cmp(left / n, right / n, shallow=False))]
    commands = len({n.parts[0] for n in names})
    for n in differ:
        print(f"  differs: {n}")
    print(f"{commands} commands, {len(names)} outputs (stdout, stderr, exit code, files): "
          f"{len(differ)} differ")
    return 1 if differ else 0


if __name__ == "__main__":
    if len(sys.argv) >= 3 and sys.argv[1] == "save" and set(sys.argv[3:]) <= set(GROUPS):
        save(sys.argv[2], tuple(sys.argv[3:]) or GROUPS)
    elif len(sys.argv) == 4 and sys.argv[1] == "compare":
        sys.exit(compare(sys.argv[2], sys.argv[3]))
    else:
        sys.exit(__doc__)
