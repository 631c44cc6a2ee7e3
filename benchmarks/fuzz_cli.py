"""Fuzz the outputs of every command: ``-o`` (``--history``, ``--chart``, ``--plot``) pointed at
device nodes, FIFOs (read or not), symbolic links (to files, to the command's inputs, dangling),
the command's own inputs, folders, read-only folders, a full file system, standard output.

Every invocation is a real ``transgen`` process in a sandbox folder (``TMPDIR`` inside it). After
each one the fuzzer checks (issue 22):

* no traceback, an exit code of 0, 1 or 2, no hang: an invocation still running after 600 s
  (killed), or one over 60 s of wall time whose process group gained no CPU time for 30 s (it
  waits for something that does not come). One over 60 s that kept gaining CPU time is slow, not
  hung (starved by the machine's load): reported with its wall and CPU times, not a failure. The
  CPU time of the group (the command and its workers, from ``/proc``) is sampled every second;
* no file replaced that was not the command's output: every node, FIFO and symbolic link is still
  what it was (same type, inode, device numbers, link text), every input is unchanged (unless
  ``--force`` named it as the output), every other file of the sandbox unchanged;
* no temporary file (``.transgen~*``) left anywhere in the sandbox.

Device nodes are our own (``os.mknod`` in the sandbox, the null and full devices' numbers), never
the system's; they need root, as the tiny tmpfs of the full-disk case: without root those cases
are skipped (counted). Usage::

    python benchmarks/fuzz_cli.py --invocations 1000 --seed 0 --jobs 2 [--json]
"""
from __future__ import annotations

import argparse
import contextlib
import hashlib
import json
import os
import random
import shutil
import stat
import subprocess
import sys
import tempfile
import threading
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

TIMEOUT = 60.0  # an invocation over this wall time is reported (a hang by the acceptance's measure)
KILL_AFTER = 600.0  # one still running after this is killed: it does not end by itself
STALL = 30.0  # over TIMEOUT, a stretch this long [s] without CPU progress of the group is a hang
SAMPLE = 1.0  # the period [s] of the CPU samples
TICK = os.sysconf("SC_CLK_TCK") if hasattr(os, "sysconf") else 100
TEMP_PREFIX = ".transgen~"
ROOT = hasattr(os, "geteuid") and os.geteuid() == 0

#: (name, weight, arguments with {IN}, {MECH}, {SC}, {OUT}, {OUT2}, {DIR}, suffixes of OUT)
#: (the weights favour the commands that draw no figure: a figure costs 5-20 s on a loaded machine)
OPTIMIZE = ["optimize", "{SC}", "--set", "simulation.t_end=6", "--evaluations", "2", "--population", "2",
            "--workers", "1", "--quiet"]
COMMANDS = [
    ("graph", 6, ["graph", "{MECH}", "-o", "{OUT}"], [".dot", ".graphml", ".dot", ".svg", ""]),
    ("std", 4, ["std", "{MECH}", "-o", "{OUT}"], [".dot", ".dot", ".svg", ""]),
    ("matrices", 8, ["matrices", "{MECH}", "-o", "{OUT}"], [".json", ".npz", ".mat", ".tex", ""]),
    ("lever", 1, ["lever", "{MECH}", "-o", "{OUT}"], [".svg", ".png"]),
    ("lever-chart", 1, ["lever", "{MECH}", "--chart", "{OUT}"], [".png"]),
    ("scenario-new", 8, ["scenario", "new", "{MECH}", "-o", "{OUT}"], [".toml", ""]),
    ("synthesize", 1, ["synthesize", "teeth", "{UNKNOWN}", "-o", "{OUT}"], [".mech", ""]),
    ("simulate", 6, ["simulate", "{SC}", "--quiet", "--set", "simulation.t_end=4.3", "-o", "{OUT}"],
     [".csv", ".json", ".npz", ".mat", ""]),
    ("simulate-plot", 1, ["simulate", "{SC}", "--quiet", "--set", "simulation.t_end=4.3", "--plot", "{DIR}"], []),
    ("sweep", 4, ["sweep", "{SC}", "--grid", "simulation.t_end=4.3,4.35", "--workers", "1", "--quiet", "-o", "{OUT}"],
     [".csv", ""]),
    ("sweep-2", 1, ["sweep", "{SC}", "--grid", "simulation.t_end=4.3,4.35", "--workers", "2", "--quiet", "-o", "{OUT}"],
     [".csv"]),
    ("optimize", 1, [*OPTIMIZE, "-o", "{OUT}", "--history", "{OUT2}"], [".toml"]),
    ("optimize-history", 1, [*OPTIMIZE, "-o", "{OUT2}", "--history", "{OUT}"], [".csv", ""]),
    ("maps", 1, ["maps", "we_compressor", "--plot", "{DIR}"], []),
    ("scenario-copy", 4, ["scenario", "copy", "{SC}", "{DIR}"], []),
]

#: kinds of output target, with what each needs
KINDS = ["regular", "missing", "nested", "symlink", "dangling", "input", "input-link", "input-force", "fifo-read",
         "fifo-nobody", "node-null", "node-full", "folder", "readonly", "full", "stdout"]
NEEDS_ROOT = {"node-null", "node-full", "full"}


def _identity(path: Path) -> tuple | None:
    """What a path is, to see whether it was replaced: type, inode, device numbers, link text and
    (regular files) a hash of the content."""
    try:
        st = os.lstat(path)
    except OSError:
        return None
    if stat.S_ISLNK(st.st_mode):
        return ("link", st.st_ino, os.readlink(path))
    if stat.S_ISREG(st.st_mode):
        return ("file", hashlib.sha1(path.read_bytes()).hexdigest())
    if stat.S_ISDIR(st.st_mode):
        return ("dir", st.st_ino)
    return ("node", stat.S_IFMT(st.st_mode), st.st_ino, st.st_rdev)


def _snapshot(root: Path) -> dict:
    out = {}
    for dirpath, dirnames, filenames in os.walk(root):
        for name in dirnames + filenames:
            p = Path(dirpath) / name
            out[p] = _identity(p)
    return out


class Sandbox:
    """A folder with the inputs (a .mech, one with unknown teeth, a scenario) and a tiny tmpfs."""

    def __init__(self, base: Path, python: str):
        self.base = base
        self.python = python
        self.inputs = base / "inputs"
        self.inputs.mkdir()
        from transgen.library import bundled_mechanisms

        mechs = bundled_mechanisms()
        self.mech = self.inputs / "in.mech"
        self.mech.write_text(mechs["simple2"].read_text())
        text = mechs["zf3hp22_small"].read_text()
        i = text.index("Ns=")
        j = i + 3
        while text[j].isdigit():
            j += 1
        self.unknown = self.inputs / "unknown.mech"
        self.unknown.write_text(text[:i] + "Ns=?" + text[j:])
        subprocess.run([python, "-m", "transgen", "scenario", "copy", "simple2_upshift", str(self.inputs)],
                       check=True, capture_output=True, cwd=self.inputs)
        self.scenario = self.inputs / "simple2_upshift.toml"
        self.full = None
        if ROOT:
            full = base / "full"
            full.mkdir()
            if subprocess.run(["mount", "-t", "tmpfs", "-o", "size=64k", "tmpfs", str(full)],
                              capture_output=True).returncode == 0:
                self.full = full
                with contextlib.suppress(OSError), open(full / "filler", "wb") as fh:
                    fh.write(b"\0" * (60 * 1024))

    def close(self) -> None:
        if self.full is not None:
            subprocess.run(["umount", "-l", str(self.full)], capture_output=True)


def _make_target(case: Path, kind: str, suffix: str, sandbox: Sandbox, input_file: Path):
    """The output path of one invocation and the files it may change legitimately."""
    name = "out" + suffix
    allowed: set[Path] = set()
    reader = None
    if kind == "regular":
        out = case / name
        out.write_text("earlier output\n")
    elif kind == "missing":
        out = case / name
    elif kind == "nested":
        out = case / "a" / "b" / name
    elif kind == "symlink":
        real = case / ("real" + suffix)
        real.write_text("earlier output\n")
        out = case / name
        out.symlink_to(real.name)
        allowed.add(real)
    elif kind == "dangling":
        out = case / name
        out.symlink_to("made" + suffix)
        allowed.add(case / ("made" + suffix))
    elif kind in ("input", "input-force"):
        out = input_file
        if kind == "input-force":
            allowed.add(input_file)
    elif kind == "input-link":
        out = case / name
        out.symlink_to(input_file)
    elif kind in ("fifo-read", "fifo-nobody"):
        out = case / name
        os.mkfifo(out)
        if kind == "fifo-read":
            def read():
                with contextlib.suppress(OSError):
                    fd = os.open(out, os.O_RDONLY | os.O_NONBLOCK)
                    end = time.monotonic() + KILL_AFTER + 5
                    while time.monotonic() < end:
                        try:
                            if os.read(fd, 1 << 16) == b"" and stop.is_set():
                                break
                        except BlockingIOError:
                            time.sleep(0.01)
                    os.close(fd)
            stop = threading.Event()
            reader = (threading.Thread(target=read, daemon=True), stop)
            reader[0].start()
    elif kind in ("node-null", "node-full"):
        out = case / name
        os.mknod(out, stat.S_IFCHR | 0o666, os.makedev(1, 3 if kind == "node-null" else 7))
    elif kind == "folder":
        out = case / name
        out.mkdir()
    elif kind == "readonly":
        folder = case / "ro"
        folder.mkdir()
        out = folder / name
        folder.chmod(0o555)
    elif kind == "full":
        out = sandbox.full / f"{case.name}{suffix}"
        allowed.add(out)
    elif kind == "stdout":
        out = Path("-")
    else:  # pragma: no cover
        raise ValueError(kind)
    if kind in ("regular", "missing", "nested", "readonly"):
        allowed.add(out)
    return out, allowed, reader


def _group_cpu(pgid: int) -> float:
    """CPU time [s] of process group ``pgid`` so far: its live processes' own and that of the
    children they have reaped (a finished worker counts once it is joined), from /proc."""
    total = 0
    for entry in os.listdir("/proc"):
        if not entry.isdigit():
            continue
        try:
            with open(f"/proc/{entry}/stat", "rb") as fh:
                data = fh.read()
        except OSError:
            continue
        fields = data[data.rfind(b")") + 2:].split()
        if len(fields) > 14 and int(fields[2]) == pgid:
            total += sum(int(f) for f in fields[11:15])  # utime, stime, cutime, cstime
    return total / TICK


def _wait(pid: int) -> tuple[int | None, bool, float, float]:
    """Wait for process ``pid`` (the leader of its own group), sampling the group's CPU time every
    :data:`SAMPLE` s; its group killed after :data:`KILL_AFTER` s. (exit code or None, killed,
    CPU time [s] of the process and its reaped children, longest stretch [s] of wall time in
    which the group gained no CPU time)."""
    start = time.monotonic()
    next_sample, last_cpu, last_progress, stall = start + SAMPLE, 0.0, start, 0.0
    while time.monotonic() < start + KILL_AFTER:
        done, status, usage = os.wait4(pid, os.WNOHANG)
        if done:
            return os.waitstatus_to_exitcode(status), False, usage.ru_utime + usage.ru_stime, stall
        now = time.monotonic()
        if now >= next_sample:
            cpu = _group_cpu(pid)
            if cpu > last_cpu:
                last_cpu, last_progress = cpu, now
            stall = max(stall, now - last_progress)
            next_sample = now + SAMPLE
        time.sleep(0.02)
    with contextlib.suppress(ProcessLookupError):
        os.killpg(pid, 9)
    _, status, usage = os.wait4(pid, 0)
    return None, True, usage.ru_utime + usage.ru_stime, max(stall, time.monotonic() - last_progress)


def _subprocess(args: list[str], case: Path, python: str, log: Path) -> tuple[int | None, str, bool, float, float]:
    """Run ``transgen ARGS`` as a new interpreter: (exit code, standard error, killed, CPU time,
    longest stall; see :func:`_wait`)."""
    log.parent.mkdir(exist_ok=True)
    env = dict(os.environ, MPLBACKEND="Agg", TMPDIR=str(case / "tmp"))
    err_path = log.with_suffix(".err")
    with open(log.with_suffix(".out"), "wb") as out, open(err_path, "wb") as err:
        proc = subprocess.Popen([python, "-m", "transgen", *args], stdout=out, stderr=err, env=env, cwd=case,
                                stdin=subprocess.DEVNULL, start_new_session=True)
    code, killed, cpu, stall = _wait(proc.pid)
    proc.returncode = -9 if code is None else code  # reaped by _wait: Popen must not wait for it
    return code, err_path.read_text(errors="replace"), killed, cpu, stall


_FORK_LOCK = threading.Lock()


def _forked(args: list[str], case: Path, python: str, log: Path) -> tuple[int | None, str, bool, float, float]:
    """Run the command line's ``main(ARGS)`` in a process forked from this one (transgen imported
    and its compiled code loaded here once: no interpreter start per invocation). The child is a
    process of its own (group, standard streams, working folder, TMPDIR, signal handlers); an
    exception escaping ``main`` is printed with its traceback. (exit code, standard error, killed,
    CPU time, longest stall; see :func:`_wait`)."""
    log.parent.mkdir(exist_ok=True)
    err_path = log.with_suffix(".err")
    with _FORK_LOCK:  # one fork at a time; the child touches no lock of this process's threads
        pid = os.fork()
        if pid == 0:
            _child(args, case, err_path, log.with_suffix(".out"))
    code, killed, cpu, stall = _wait(pid)
    return code, err_path.read_text(errors="replace") if err_path.exists() else "", killed, cpu, stall


def _child(args: list[str], case: Path, err_path: Path, out_path: Path) -> None:
    import io
    import signal
    import traceback

    code = 99
    try:
        os.setpgid(0, 0)
        os.chdir(case)
        os.environ["TMPDIR"] = str(case / "tmp")
        tempfile.tempdir = None  # read TMPDIR again
        for fd, path, flags in ((0, os.devnull, os.O_RDONLY), (1, out_path, os.O_WRONLY | os.O_CREAT | os.O_TRUNC),
                                (2, err_path, os.O_WRONLY | os.O_CREAT | os.O_TRUNC)):
            new = os.open(path, flags, 0o644)
            os.dup2(new, fd)
            os.close(new)
        sys.stdout = io.TextIOWrapper(io.FileIO(1, "w", closefd=False), encoding="utf-8", write_through=True)
        sys.stderr = io.TextIOWrapper(io.FileIO(2, "w", closefd=False), encoding="utf-8", write_through=True)
        for signum in (signal.SIGTERM, signal.SIGHUP):
            signal.signal(signum, signal.SIG_DFL)
        signal.signal(signal.SIGINT, signal.default_int_handler)
        from transgen.cli import main as transgen_main

        try:
            code = transgen_main(args)
        except SystemExit as exc:  # argparse
            code = exc.code if isinstance(exc.code, int) else 2
    except BaseException:  # noqa: BLE001 - what the user would see
        with contextlib.suppress(Exception):
            traceback.print_exc()
        code = 99
    with contextlib.suppress(Exception):
        sys.stdout.flush()
        sys.stderr.flush()
    os._exit(code)


def run_one(index: int, rng: random.Random, sandbox: Sandbox, python: str, fork: bool = False) -> dict:
    name, _, template, suffixes = rng.choices(COMMANDS, weights=[c[1] for c in COMMANDS])[0]
    kinds = [k for k in KINDS if (ROOT or k not in NEEDS_ROOT) and (k != "full" or sandbox.full is not None)]
    kind = rng.choice(kinds)
    suffix = rng.choice(suffixes) if suffixes else ""
    case = sandbox.base / f"case{index:05d}"
    case.mkdir()
    (case / "tmp").mkdir()
    inputs = case / "inputs"  # a copy per case: a case with --force may overwrite its own
    shutil.copytree(sandbox.inputs, inputs)
    mech, unknown, scenario = inputs / sandbox.mech.name, inputs / sandbox.unknown.name, inputs / sandbox.scenario.name
    uses_dir = "{DIR}" in template
    input_file = mech if "{MECH}" in template else unknown if "{UNKNOWN}" in template else scenario
    out, allowed, reader = _make_target(case, kind, suffix, sandbox, input_file)
    force = kind == "input-force"
    if uses_dir:  # a folder option: the plots or copies go inside the target
        if kind in ("regular", "missing", "nested", "readonly", "folder", "full"):
            allowed_dir = out if kind != "regular" else None
        else:
            allowed_dir = None
    args = [a.replace("{MECH}", str(mech)).replace("{UNKNOWN}", str(unknown)).replace("{SC}", str(scenario)).replace("{OUT}", str(out)).replace("{DIR}", str(out))
             .replace("{OUT2}", str(case / "other.toml" if name == "optimize-history" else case / "hist.csv"))
            for a in template]
    if force:
        args.append("--force")
    allowed |= {case / "hist.csv", case / "other.toml", case / "other.history.csv"}
    before = _snapshot(case)  # this case's folder only: the other jobs write theirs meanwhile
    inputs_before = {p: _identity(p) for p in inputs.iterdir()}
    start = time.monotonic()
    code, err, killed, cpu, stall = (_forked if fork else _subprocess)(args, case, python, sandbox.base / "logs" / case.name)
    wall = time.monotonic() - start
    hang = killed or (wall > TIMEOUT and stall >= STALL)
    if reader is not None:
        reader[1].set()
        reader[0].join(KILL_AFTER + 10)
    problems = []
    if hang:  # killed after KILL_AFTER s, or over TIMEOUT and idle for STALL s
        problems.append("hang")
    if "Traceback" in err:
        problems.append("traceback")
    if code not in (0, 1, 2, None):
        problems.append(f"exit code {code}")
    after = _snapshot(case)
    for path, identity in before.items():
        if path in allowed or identity is None:
            continue
        if uses_dir and allowed_dir is not None and (path == allowed_dir or allowed_dir in path.parents):
            continue
        now = after.get(path)
        if now != identity and not (identity[0] == "dir" and now is not None and now[0] == "dir"):
            if force and path == input_file:
                continue
            problems.append(f"replaced {path.relative_to(sandbox.base)}")
    for path, identity in inputs_before.items():
        if _identity(path) != identity and not (force and path == input_file):
            problems.append(f"input changed {path.name}")
    temporaries = [str(p.relative_to(sandbox.base)) for p in after if p.name.startswith(TEMP_PREFIX)]
    if temporaries:
        problems.append(f"temporaries left {temporaries[:3]}")
    if kind == "readonly":
        with contextlib.suppress(OSError):
            (case / "ro").chmod(0o755)
    if kind == "full":
        with contextlib.suppress(OSError):
            out.unlink()
    return {"index": index, "command": name, "kind": kind, "suffix": suffix, "args": args, "exit": code,
            "wall": round(wall, 2), "cpu": None if cpu is None else round(cpu, 2), "stall": round(stall, 1),
            "killed": killed, "problems": problems, "stderr": err[-600:] if problems else ""}


def _span(values) -> list | None:
    """[smallest, largest] of ``values``, None where there is none."""
    values = list(values)
    return [min(values), max(values)] if values else None


def main(argv=None) -> int:
    global TIMEOUT
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--invocations", type=int, default=1000)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--jobs", type=int, default=2)
    parser.add_argument("--json", action="store_true")
    parser.add_argument("--python", default=sys.executable)
    parser.add_argument("--timeout", type=float, default=TIMEOUT,
                        help=f"seconds after which an invocation counts as a hang (default {TIMEOUT:g})")
    parser.add_argument("--log", help="append every invocation's result to this JSON-lines file as it ends")
    parser.add_argument("--subprocess", action="store_true",
                        help="start a new interpreter per invocation (slower) instead of forking a warm one")
    args = parser.parse_args(argv)
    TIMEOUT = args.timeout
    base = Path(tempfile.mkdtemp(prefix="transgen-fuzz-cli-"))
    sandbox = Sandbox(base, args.python)
    if not args.subprocess:  # what every invocation would import and load: once, here
        import matplotlib

        matplotlib.use("Agg")
        import transgen.cli
        import transgen.sim.cli  # noqa: F401
        from transgen.sim.study.task import warm_up

        transgen.cli.build_parser()
        warm_up()
    rng = random.Random(args.seed)
    seeds = [rng.randrange(2**32) for _ in range(args.invocations)]
    start = time.monotonic()
    lock = threading.Lock()

    def one(i: int) -> dict:
        result = run_one(i, random.Random(seeds[i]), sandbox, args.python, fork=not args.subprocess)
        if args.log:
            with lock, open(args.log, "a", encoding="utf-8") as fh:
                fh.write(json.dumps(result) + "\n")
        return result

    try:
        with ThreadPoolExecutor(args.jobs) as pool:
            results = list(pool.map(one, range(args.invocations)))
    finally:
        sandbox.close()
    left = [str(p.relative_to(base)) for p in base.rglob(f"{TEMP_PREFIX}*")]  # also in the full file system
    if left:
        results.append({"index": -1, "command": "(end)", "kind": "", "suffix": "", "args": [], "exit": 0, "wall": 0,
                        "problems": [f"temporaries left {left[:3]}"], "stderr": ""})
    bad = [r for r in results if r["problems"]]
    slow = [r for r in results if r["index"] >= 0 and r["wall"] > TIMEOUT and "hang" not in r["problems"]]
    summary = {
        "invocations": len(results), "seed": args.seed, "root": ROOT, "timeout": TIMEOUT,
        "mode": "subprocess" if args.subprocess else "fork", "full_filesystem": sandbox.full is not None,
        "wall_time": round(time.monotonic() - start, 1),
        "tracebacks": sum("traceback" in r["problems"] for r in results),
        "hangs": sum("hang" in r["problems"] for r in results),
        "killed": sum(bool(r.get("killed")) for r in results),
        "over_timeout": len(slow),
        "over_timeout_wall": _span(r["wall"] for r in slow),
        "over_timeout_cpu": _span(r["cpu"] or 0 for r in slow),
        "over_timeout_stall_max": max((r["stall"] for r in slow), default=None),
        "cpu_max": max((r["cpu"] or 0 for r in results if r["index"] >= 0), default=None),
        "slowest": sorted(({k: r[k] for k in ("index", "command", "kind", "wall", "cpu", "stall")} for r in results
                           if r["index"] >= 0), key=lambda r: -r["wall"])[:15],
        "replaced": sum(any(p.startswith(("replaced", "input changed")) for p in r["problems"]) for r in results),
        "temporaries_left": sum(any(p.startswith("temporaries") for p in r["problems"]) for r in results),
        "bad_exit": sum(any(p.startswith("exit code") for p in r["problems"]) for r in results),
        "by_command": {c[0]: sum(r["command"] == c[0] for r in results) for c in COMMANDS},
        "by_kind": {k: sum(r["kind"] == k for r in results) for k in KINDS},
        "exit_codes": {str(k): sum(r["exit"] == k for r in results) for k in sorted({str(r["exit"]) for r in results})},
        "failures": bad[:20],
    }
    summary["exit_codes"] = {k: sum(str(r["exit"]) == k for r in results) for k in summary["exit_codes"]}
    if args.json:
        print(json.dumps(summary, indent=2))
    else:
        print(f"{summary['invocations']} invocations in {summary['wall_time']} s (root: {ROOT}, full file system: "
              f"{summary['full_filesystem']}): {summary['tracebacks']} tracebacks, {summary['hangs']} hangs "
              f"({summary['killed']} killed after {KILL_AFTER:g} s), {summary['over_timeout']} slow: over {TIMEOUT:g} s "
              f"wall but gaining CPU time (wall {summary['over_timeout_wall']} s, CPU {summary['over_timeout_cpu']} s, "
              f"longest stall {summary['over_timeout_stall_max']} s), "
              f"{summary['replaced']} with files replaced, {summary['temporaries_left']} with temporaries left, "
              f"{summary['bad_exit']} other exit codes; exit codes {summary['exit_codes']}")
        for r in slow[:20]:
            print(f"  slow: {r['command']} {r['kind']}: {r['wall']} s wall, {r['cpu']} s CPU, longest stall {r['stall']} s")
        for r in bad[:20]:
            print(f"  {r['command']} {r['kind']} {r['suffix']}: {r['problems']}\n    {' '.join(r['args'])}\n"
                  f"    {r['stderr'].strip()[-300:]}")
    shutil.rmtree(base, ignore_errors=True)
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
