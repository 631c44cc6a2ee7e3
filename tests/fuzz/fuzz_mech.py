"""Fuzzer of ``.mech`` input: through the Python API and through the command line.

Inputs are random mutations of every bundled file under ``mechanisms/`` and generated text
(random mechanisms, token soup, bytes that are not UTF-8), salted with hostile content: numbers
such as ``nan``, ``inf``, ``1e400``, ``0e400``, ``5e-324``, digit strings of thousands of
characters, lines with thousands of parameters, unicode, missing links, duplicate names, gear
cycles, many shift elements and no gear table.

The contract checked (issue 10): every input is either processed or refused with one of the
project's :class:`~transgen.errors.TransgenError` subclasses carrying a bounded message (a
``.mech`` error located at ``LINE:COL``); anything else is a failure: another exception, a
NaN or infinity in a result, a message of unbounded size, or more than ``time_limit`` CPU seconds
for one input. On the command line every call exits 0 or 2, never prints ``Traceback`` and
leaves no output file behind when it refuses the input.

Input ``i`` of seed ``s`` is generated from ``random.Random(f"{s}:{i}")`` alone, so a failure
is reproduced with :func:`generate` (``python benchmarks/fuzz_mech.py --show S I``).
"""
from __future__ import annotations

import math
import os
import random
import re
import signal
import subprocess
import sys
import tempfile
import time
import traceback
import warnings
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from transgen import bundled_mechanisms, format_mechanism, gear_table, load_mechanism, parse_mechanism
from transgen.describe import modes_report
from transgen.errors import MechError, TransgenError
from transgen.kinematics import check_gears
from transgen.modes import mode_models
from transgen.statespace import state_space
from transgen.std import state_transition_diagram

__all__ = ["generate", "check_api", "fuzz_api", "fuzz_cli", "FuzzReport", "Failure", "CLI_COMMANDS"]

WALL_FACTOR = 6
"""A command-line call is a hang after ``time_limit`` CPU seconds, or this many times
``time_limit`` wall-clock seconds (the machine may be shared)."""

MAX_MESSAGE_CHARS = 20_000
"""Largest error message accepted (20 diagnostics of bounded size and a count)."""

NUMBERS = [
    "nan", "NaN", "inf", "-inf", "Infinity", "1e400", "-1e400", "0e400", "0e-400", "5e-324", "-5e-324",
    "2.2250738585072014e-308", "1e-308", "1e-400", "0", "-0", "0.0", "+0", "1e308", "1.7976931348623157e308",
    "1e-9", "1e-10", "1e6", "1e7", "1e8", "1e9", "100000", "100001", "1e-6", "1e-7", "-1", "3.5", "+1", ".5",
    "1e-15", "1e15", "1e-16", "1e16", "1e-4", "100", "1e-12", "1e12", "99999",
    "5.", "1", "2", "20", "0.123456789012345678901234567890", "123456789012345678901234567890",
]
HUGE_NUMBERS = [lambda r: "1" + "0" * r.randint(300, 5000), lambda r: "0." + "0" * r.randint(300, 5000) + "1",
                lambda r: "9" * r.randint(100, 5000), lambda r: "1e" + "9" * r.randint(10, 4401),
                lambda r: "1e-" + "9" * r.randint(10, 4401), lambda r: "0e" + "9" * r.randint(10, 4401)]
UNICODE = ["é", "∞", "\u00a0", "\u2028", "\u0085", "\x00", "\ufeff", "\x0c", "\r", "\t", "😀", "Ω", "ı", "\u200b", "٣"]
KEYWORDS = ["link", "planetary", "gears", "clutch", "brake", "oneway", "input", "output", "torque", "gear",
            "neutral", "mode", "coordinates", "none", "housing", "transmission", "=", "T_in", "T_out", "t_C1"]
PARAMS = ["J", "Ns", "Nr", "N1", "N2", "r1", "r2", "static", "dynamic", "ratio", "free", "mesh", "pinions", "type",
          "sun", "ring", "carrier", "x"]
WORDS = ["positive", "negative", "external", "internal", "plate", "band", "1", "2", "3", "housing", "none"]


# ---------------------------------------------------------------------------------------------
# generation


def _bundled_texts() -> dict[str, str]:
    if not hasattr(_bundled_texts, "cache"):
        _bundled_texts.cache = {n: p.read_text(encoding="utf-8") for n, p in bundled_mechanisms().items()}
    return _bundled_texts.cache


def _number(rng: random.Random) -> str:
    if rng.random() < 0.15:
        return rng.choice(HUGE_NUMBERS)(rng)
    if rng.random() < 0.2:
        return f"{rng.uniform(-2, 2):.{rng.randint(0, 20)}g}e{rng.randint(-330, 330)}"
    return rng.choice(NUMBERS)


def _names(text: str) -> list[str]:
    return sorted(set(re.findall(r"\b[A-Za-z_][A-Za-z0-9_]*\b", re.sub(r"#.*", "", text))) - set(KEYWORDS)) or ["L1"]


def _value_spans(text: str) -> list[tuple[int, int]]:
    return [m.span(1) for m in re.finditer(r"=[ \t]*([^\s#]+)", text)]


def _mutate(rng: random.Random, text: str) -> str:
    """One random mutation of ``text``."""
    op = rng.choice(["value", "value", "value", "char", "char", "token", "line", "rename", "duplicate",
                     "params", "long_name", "cycle", "no_gears", "elements", "unicode"])
    lines = text.split("\n")
    names = _names(text)
    if op == "value":
        spans = _value_spans(text)
        if spans:
            a, b = rng.choice(spans)
            return text[:a] + (_number(rng) if rng.random() < 0.8 else rng.choice(WORDS + names)) + text[b:]
        return text
    if op in ("char", "unicode"):
        i = rng.randint(0, max(len(text) - 1, 0))
        c = rng.choice(UNICODE) if op == "unicode" else chr(rng.randint(32, 126))
        how = rng.randint(0, 2)
        return text[:i] + ("" if how == 0 else c) + text[i + (how != 1):]
    if op == "token":
        parts = re.split(r"(\s+)", text)
        idx = [k for k, p in enumerate(parts) if p and not p.isspace()]
        if idx:
            k = rng.choice(idx)
            new = rng.choice(KEYWORDS + names + PARAMS + [_number(rng), f"{rng.choice(PARAMS)}={_number(rng)}"])
            parts[k] = rng.choice(["", new, new + " " + parts[k]])
        return "".join(parts)
    if op == "line":
        i, j = rng.randrange(len(lines)), rng.randrange(len(lines))
        how = rng.randint(0, 2)
        if how == 0:
            del lines[i]
        elif how == 1:
            lines.insert(j, lines[i])
        else:
            lines[i], lines[j] = lines[j], lines[i]
        return "\n".join(lines)
    if op == "rename":  # a missing link or element: one use of a name renamed
        name = rng.choice(names)
        spots = [m.start() for m in re.finditer(rf"\b{re.escape(name)}\b", text)]
        if spots:
            at = rng.choice(spots)
            return text[:at] + name + rng.choice(["x", "_", "2", ""]) + text[at + len(name):]
        return text
    if op == "duplicate":  # a declaration twice (duplicate names)
        decls = [k for k, line in enumerate(lines) if re.match(r"\s*(link|planetary|gears|clutch|brake|oneway|torque|gear|mode)\b", line)]
        if decls:
            k = rng.choice(decls)
            lines.insert(rng.randrange(len(lines) + 1), lines[k])
        return "\n".join(lines)
    if op == "params":  # a line with thousands of parameters
        k = rng.randrange(len(lines))
        n = rng.choice([10, 100, 1000, 10_000])
        key = rng.choice(PARAMS + ["J"])
        extra = " ".join(f"{key if rng.random() < 0.5 else key + str(i)}={_number(rng) if i < 5 else '1'}" for i in range(n))
        lines[k] = lines[k] + " " + extra
        return "\n".join(lines)
    if op == "long_name":
        name = rng.choice(names)
        return text.replace(name, "N" * rng.choice([100, 1000, 20_000]), rng.randint(1, 3))
    if op == "cycle":  # a gear pair or planetary that closes a loop between existing links
        links = re.findall(r"^\s*link\s+(\w+)", text, re.M) or ["A", "B", "C"]
        a, b, c = (rng.choice(links) for _ in range(3))
        lines.append(rng.choice([f"gears Gcyc{rng.randint(0, 9)} {a} {b} N1={rng.randint(1, 90)} N2={rng.randint(1, 90)}",
                                 f"planetary Pcyc sun={a} ring={b} carrier={c} Ns={rng.randint(1, 50)} Nr={rng.randint(40, 120)}",
                                 f"clutch Kcyc {a} {b} static=10 dynamic=5", f"gears Gself {a} {a} N1=10 N2=10"]))
        return "\n".join(lines)
    if op == "no_gears":  # no gear table: every combination is modelled
        return "\n".join(line for line in lines if not re.match(r"\s*(gear|neutral|mode)\s", line))
    # many shift elements (the 2^k paths)
    links = re.findall(r"^\s*link\s+(\w+)", text, re.M) or ["A"]
    for i in range(rng.randint(1, 12)):
        lines.append(f"clutch Kx{i} {rng.choice(links)} {rng.choice(links + ['housing'])} static=100 dynamic=80"
                     if rng.random() < 0.5 else f"brake Bx{i} {rng.choice(links)} static=100 dynamic=80")
    return "\n".join(lines)


def _random_mechanism(rng: random.Random) -> str:
    """A generated mechanism: a chain or tree of links joined by gears, planetaries and shift
    elements, with a gear table of random element pairs (often inconsistent)."""
    n = rng.randint(2, 9)
    links = [f"L{i}" for i in range(n)]
    out = [f'transmission "fuzz {rng.random():.6f}"']
    out += [f"link {k} J={rng.choice(['0', '0.1', '1', '2.5', '1e-6', '1e3', '1e-15', '1e15'])}" for k in links]
    for i in range(rng.randint(0, 3)):
        s, r, c = rng.sample(links + ["housing"], 3)
        ns = rng.randint(10, 60)
        out.append(f"planetary P{i} sun={s} ring={r} carrier={c} Ns={ns} Nr={ns + rng.randint(1, 80)} pinions={rng.choice([1, 2])}")
    for i in range(rng.randint(0, 3)):
        a, b = rng.sample(links, 2)
        out.append(f"gears G{i} {a} {b} N1={rng.randint(10, 60)} N2={rng.randint(10, 60)} mesh={rng.choice(['external', 'internal'])}")
    elements = []
    for i in range(rng.randint(1, 14 if rng.random() < 0.1 else 6)):
        kind = rng.choice(["clutch", "brake", "oneway"])
        a, b = rng.sample(links, 2)
        elements.append(f"K{i}")
        out.append({"clutch": f"clutch K{i} {a} {b} static=500 dynamic=400",
                    "brake": f"brake K{i} {a} static=500 dynamic=400",
                    "oneway": f"oneway K{i} {a} {rng.choice([b, ''])} free={rng.choice(['positive', 'negative'])}"}[kind])
    a, b = rng.sample(links, 2)
    out += [f"input {a}", f"output {b}"]
    for g in range(rng.randint(0, 6)):
        engaged = " ".join(rng.sample(elements, min(len(elements), rng.randint(1, 3))))
        ratio = f" ratio={_number(rng) if rng.random() < 0.3 else round(rng.uniform(-4, 5), 3)}" if rng.random() < 0.6 else ""
        out.append(f"gear {g + 1} = {engaged}{ratio}")
    if rng.random() < 0.2:
        out.append("coordinates " + " ".join(rng.sample(links, rng.randint(1, min(3, n)))))
    return "\n".join(out) + "\n"


def _token_soup(rng: random.Random) -> str:
    pieces = KEYWORDS + PARAMS + WORDS + UNICODE + ["\n", "\n", " ", "=", '"', "#", "L1", "L2", "C1"]
    return "".join(rng.choice(pieces + [_number(rng)]) + rng.choice(["", " ", " ", "\n"]) for _ in range(rng.randint(1, 200)))


def generate(seed: int, index: int) -> tuple[str, str | bytes]:
    """Input ``index`` of ``seed``: ``(how it was made, text or bytes)``."""
    rng = random.Random(f"{seed}:{index}")
    pick = rng.random()
    if pick < 0.6:  # mutations of a bundled file
        name, text = rng.choice(sorted(_bundled_texts().items()))
        if rng.random() < 0.5:
            text = "\n".join(line for line in (re.sub(r"#.*", "", raw).rstrip() for raw in text.split("\n")) if line) + "\n"
        n = rng.choice([1, 1, 1, 2, 3, 5])
        for _ in range(n):
            text = _mutate(rng, text)
        return f"{name} x{n}", text
    if pick < 0.85:
        text = _random_mechanism(rng)
        n = rng.choice([0, 0, 1, 2])
        for _ in range(n):
            text = _mutate(rng, text)
        return f"generated x{n}", text
    if pick < 0.97:
        return "token soup", _token_soup(rng)
    raw = bytes(rng.randrange(256) for _ in range(rng.randint(0, 300)))
    return "bytes", raw if rng.random() < 0.7 else "link A J=1\n".encode() + b"\xff\xfe" + raw


# ---------------------------------------------------------------------------------------------
# checking one input


@dataclass(frozen=True)
class Failure:
    """An input that broke the contract."""

    seed: int
    index: int
    origin: str
    kind: str  # "exception", "nan", "message", "unlocated", "hang", "exit code", "traceback", "half-written"
    detail: str

    def __str__(self) -> str:
        return f"[{self.seed}:{self.index} {self.origin}] {self.kind}: {self.detail}"


@dataclass
class FuzzReport:
    """What a fuzz run did: inputs, how far they got, failures, time."""

    inputs: int = 0
    outcomes: dict[str, int] = field(default_factory=dict)  # "modelled", "refused by ModeError", ...
    failures: list[Failure] = field(default_factory=list)
    seconds: float = 0.0  # wall clock, the whole run
    slowest: float = 0.0  # CPU seconds, the slowest input

    def count(self, outcome: str) -> None:
        self.outcomes[outcome] = self.outcomes.get(outcome, 0) + 1

    def summary(self) -> str:
        parts = ", ".join(f"{k} {v}" for k, v in sorted(self.outcomes.items()))
        return (f"{self.inputs} inputs in {self.seconds:.1f} s (slowest {self.slowest:.2f} CPU s): {parts}; "
                f"{len(self.failures)} failures")


class _Hang(Exception):
    pass


def _alarm(signum, frame):
    raise _Hang()


def _finite(name: str, values) -> None:
    array = np.asarray(values, dtype=float)
    if not np.all(np.isfinite(array)):
        raise ValueError(f"non-finite values in {name}")


def _pipeline(text: str | bytes, directory: Path, stage: list[str]) -> str:
    """Run ``text`` through the API as far as it goes; return how far (raises what it raises)."""
    stage[0] = "parse"
    if isinstance(text, bytes) or len(text) % 2:  # through a file: also the reading and decoding
        path = directory / "fuzz.mech"
        path.write_bytes(text if isinstance(text, bytes) else text.encode("utf-8", "surrogatepass"))
        mech = load_mechanism(path)
    else:
        mech = parse_mechanism(text, "fuzz.mech")
    stage[0] = "format"
    if parse_mechanism(format_mechanism(mech), "fuzz.mech") != mech:
        raise ValueError("format_mechanism does not parse back to the same mechanism")
    stage[0] = "gear_table"
    table = gear_table(mech)
    for row in table.gears:
        if row.ratio is not None:
            _finite(f"ratio of gear {row.name}", row.ratio)
    _finite("combination ratios", [c.ratio for c in table.combinations if c.ratio is not None])
    stage[0] = "check_gears"
    problems = check_gears(mech)
    if problems:
        raise MechError(problems)
    stage[0] = "mode_models"
    models = mode_models(mech, "auto")
    stage[0] = "state_space"
    ss = state_space(mech, models=models)
    for m in ss.modes:
        _finite(f"matrices of mode {m.name}", np.concatenate([np.ravel(m.B), np.ravel(m.C), np.ravel(m.D)]))
    if len(mech.elements) <= 6:
        stage[0] = "std"
        state_transition_diagram(mech)
        stage[0] = "modes_report"
        modes_report(mech)
    return "modelled"


def check_api(seed: int, index: int, directory: Path, time_limit: float = 10.0) -> tuple[str, Failure | None, float]:
    """Generate input ``index`` of ``seed`` and run it through the API: ``(outcome, failure or
    None, CPU seconds)``."""
    origin, text = generate(seed, index)
    stage = ["generate"]
    previous = signal.signal(signal.SIGPROF, _alarm)
    signal.setitimer(signal.ITIMER_PROF, time_limit)  # CPU seconds: a loaded machine is no hang
    start = time.process_time()
    failure = None
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # CombinationLimitWarning, modes with problems
            warnings.simplefilter("error", RuntimeWarning)  # numpy overflow, invalid value: a NaN in the making
            outcome = _pipeline(text, directory, stage)
    except _Hang:
        outcome = "hang"
        failure = Failure(seed, index, origin, "hang", f"more than {time_limit:g} s in {stage[0]}")
    except TransgenError as exc:
        outcome = f"refused by {type(exc).__name__} in {stage[0]}"
        message = str(exc)
        if len(message) > MAX_MESSAGE_CHARS:
            failure = Failure(seed, index, origin, "message", f"{len(message)} characters from {stage[0]}")
        elif isinstance(exc, MechError) and not all(d.line >= 1 and d.column >= 1 and d.message for d in exc.diagnostics):
            failure = Failure(seed, index, origin, "unlocated", message[:300])
        elif isinstance(exc, MechError) and not exc.diagnostics:
            failure = Failure(seed, index, origin, "unlocated", "a MechError without diagnostics")
    except Exception as exc:  # noqa: BLE001 - anything else is what we are looking for
        outcome = "failure"
        failure = Failure(seed, index, origin, "exception",
                          f"{type(exc).__name__} in {stage[0]}: {str(exc)[:300]}\n{traceback.format_exc(limit=-4)}")
    finally:
        signal.setitimer(signal.ITIMER_PROF, 0)
        signal.signal(signal.SIGPROF, previous)
    return outcome, failure, time.process_time() - start


def fuzz_api(seed: int, count: int, time_limit: float = 10.0, progress=None) -> FuzzReport:
    """Run inputs ``0 .. count-1`` of ``seed`` through the API (:func:`check_api`)."""
    with tempfile.TemporaryDirectory() as tmp:
        return _collect((check_api(seed, i, Path(tmp), time_limit) for i in range(count)), progress)


def _collect(results, progress=None) -> FuzzReport:
    """The report of ``(outcome, failure, seconds)`` triples, timed as they are produced."""
    report = FuzzReport()
    start = time.perf_counter()
    for i, (outcome, failure, seconds) in enumerate(results):
        report.inputs += 1
        report.count(outcome)
        report.slowest = max(report.slowest, seconds)
        if failure is not None:
            report.failures.append(failure)
        if progress is not None:
            progress(i, report)
    report.seconds = time.perf_counter() - start
    return report


# ---------------------------------------------------------------------------------------------
# the command line

CLI_COMMANDS = ("check", "ratios", "graph", "modes", "matrices", "std", "list")


def _cli_arguments(rng: random.Random, command: str, file: str, out: Path) -> tuple[list[str], Path | None]:
    """Arguments of one call and the output file it may write."""
    if command == "list":
        return ["list"] + rng.choice([[], ["--json"]]), None
    args, target = [command, file], None
    if command == "graph":
        target = out / rng.choice(["g.dot", "g.graphml", "g.svg"])
        args += ["-o", str(target)]
    elif command == "std":
        if rng.random() < 0.5:
            target = out / rng.choice(["s.dot", "s.svg"])
            args += ["-o", str(target)]
        args += rng.choice([[], ["--json"], ["--all"]])
    elif command == "matrices":
        args += rng.choice([[], ["--modes", "all"], ["--modes", "declared"], ["--list-coordinates"],
                            ["--coords", "L1,L2"], ["--coords", "nan"]])
        if rng.random() < 0.3:
            target = out / rng.choice(["m.npz", "m.json", "m.tex"])
            args += ["-o", str(target)]
    else:
        args += rng.choice([[], ["--json"]] + ([["--all"]] if command == "modes" else [])
                           + ([["--gears-only"]] if command == "ratios" else []))
    return args, target


def _cli_input(seed: int, index: int, rng: random.Random, directory: Path) -> tuple[str, str]:
    """``(how it was made, FILE argument)``: a bundled name (sometimes misspelled), a bundled file
    as it is, or a fuzz input written to a file."""
    names = sorted(_bundled_texts())
    pick = rng.random()
    if pick < 0.15:
        name = rng.choice(names)
        return "bundled name", name if rng.random() < 0.6 else name[:-1] + rng.choice("xyz0")
    origin, text = generate(seed, 1_000_000 + index)
    path = directory / f"in{index}.mech"
    path.write_bytes(text if isinstance(text, bytes) else text.encode("utf-8", "surrogatepass"))
    return origin, str(path)


# the same transgen as this process (PYTHONPATH), plots without a display
_ENV = {"MPLBACKEND": "Agg", "PATH": "/usr/bin:/bin", **{k: v for k, v in os.environ.items() if k == "PYTHONPATH"}}


def check_cli(seed: int, index: int, directory: Path, time_limit: float = 10.0) -> tuple[str, Failure | None, float]:
    """One command-line call (command ``index`` modulo :data:`CLI_COMMANDS`): ``(outcome,
    failure or None, CPU seconds of the call)``."""
    rng = random.Random(f"cli:{seed}:{index}")
    command = CLI_COMMANDS[index % len(CLI_COMMANDS)]
    work = directory / f"call{index}"
    work.mkdir()
    origin, file = _cli_input(seed, index, rng, work)
    args, target = _cli_arguments(rng, command, file, work)
    origin = f"{origin}: transgen {' '.join(a if len(a) < 60 else a[:40] + '...' for a in args)}"
    limit = math.ceil(time_limit)
    cpu_file = work / "cpu.txt"
    # bash sets the CPU limit (the kernel stops the call after `limit` CPU seconds), GNU time
    # measures the call's CPU time
    wrapper = ['/bin/bash', '-c', 'ulimit -t "$1"; shift; exec /usr/bin/time -f "%U %S" -o "$0" "$@"',
               str(cpu_file), str(limit), sys.executable, "-m", "transgen", *args]
    try:
        run = subprocess.run(wrapper, capture_output=True, cwd=work, env=_ENV, timeout=WALL_FACTOR * time_limit)
    except subprocess.TimeoutExpired:
        return "hang", Failure(seed, index, origin, "hang", f"more than {WALL_FACTOR * time_limit:g} s wall"), time_limit
    cpu = sum(float(x) for x in cpu_file.read_text().split("\n")[-2].split()) if cpu_file.exists() else float("nan")
    if run.returncode in (128 + signal.SIGXCPU, 128 + signal.SIGKILL) or cpu > time_limit:
        return "hang", Failure(seed, index, origin, "hang", f"more than {limit} CPU seconds"), cpu
    err = run.stderr
    stderr = err.decode("utf-8", "replace")
    outcome = f"{command} exit {run.returncode}"
    if "Traceback" in stderr:
        return outcome, Failure(seed, index, origin, "traceback", stderr[-1500:]), cpu
    if run.returncode not in (0, 2):
        return outcome, Failure(seed, index, origin, "exit code", f"{run.returncode}: {stderr[-500:]}"), cpu
    if len(stderr) > MAX_MESSAGE_CHARS:
        return outcome, Failure(seed, index, origin, "message", f"{len(stderr)} characters on stderr"), cpu
    if run.returncode == 2 and target is not None and target.exists():
        return outcome, Failure(seed, index, origin, "half-written", f"{target.name} written, exit 2"), cpu
    if run.returncode == 2 and not re.search(r"(:\d+(:\d+)?: error: |^error: |^usage: )", stderr, re.M):
        return outcome, Failure(seed, index, origin, "unlocated", stderr[:500]), cpu
    return outcome, None, cpu


def fuzz_cli(seed: int, count: int, time_limit: float = 10.0, workers: int = 2, progress=None) -> FuzzReport:
    """``count`` command-line calls (every command in turn) on fuzz inputs, ``workers`` at a time."""
    with tempfile.TemporaryDirectory() as tmp, ThreadPoolExecutor(max_workers=workers) as pool:
        return _collect(pool.map(lambda k: check_cli(seed, k, Path(tmp), time_limit), range(count)), progress)
