"""The shell examples of the docs pages, extracted and run (issue 23: every example executed).

A page's examples are its ```` ```console ```` blocks: a line ``$ COMMAND`` is a command (a
trailing ``\\`` continues it on the next line), the lines after it down to the next command are
its expected output (none shown: only the exit code is checked) on standard output, or on
standard error for messages. A line ``...`` in the expected
output stands for any number of lines; every other line must equal the output's line (trailing
blanks ignored). The comment line right before a block (``% docs-example: WORDS``) says more:

* ``slow`` — not run by ``tests/test_docs_examples.py`` (over a few seconds);
  ``python benchmarks/docs_examples.py --slow`` runs them;
* ``exit=N`` — every command of the block is expected to exit with N (default 0);
* ``cluster`` — a local Dask scheduler on ``tcp://127.0.0.1:8786`` with two workers is started
  for the block (implies ``slow``).

Files a page shows in full are ```` ```{code-block} LANG ```` blocks with a ``:caption: NAME``
line; they are written into the page's folder before its commands run. The commands of one page
run in order in one fresh folder that holds ``mechanisms/`` (the bundled ``.mech`` files, as in
a clone of the repository), so a command may read what an earlier one wrote.
"""
from __future__ import annotations

import os
import re
import signal
import subprocess
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

DOCS = Path(__file__).resolve().parent.parent
SKIP_DIRS = ("_build", "reference/generated", "_ext", "_templates")
MARK = re.compile(r"^%\s*docs-example:\s*(.*)$")


@dataclass
class Command:
    text: str
    expected: list[str] = field(default_factory=list)


@dataclass
class Block:
    page: str
    line: int
    commands: list[Command]
    marks: set[str]

    @property
    def slow(self) -> bool:
        return "slow" in self.marks or "cluster" in self.marks

    @property
    def exit_code(self) -> int:
        for mark in self.marks:
            if mark.startswith("exit="):
                return int(mark[5:])
        return 0


def pages() -> list[Path]:
    """Every Markdown page of the docs, generated ones left out."""
    return sorted(p for p in DOCS.rglob("*.md")
                  if not any(str(p.relative_to(DOCS)).startswith(d) for d in SKIP_DIRS))


def _parse_console(lines: list[str]) -> list[Command]:
    commands: list[Command] = []
    continuing = False
    for line in lines:
        if continuing:
            commands[-1].text += "\n" + line
            continuing = line.endswith("\\")
        elif line.startswith("$ "):
            commands.append(Command(line[2:]))
            continuing = line.endswith("\\")
        elif commands:
            commands[-1].expected.append(line.rstrip())
    for c in commands:
        while c.expected and not c.expected[-1]:
            c.expected.pop()
    return commands


def parse_page(path: Path) -> tuple[list[Block], dict[str, str]]:
    """The console blocks of a page and the files it shows (name -> text)."""
    text = path.read_text(encoding="utf-8").split("\n")
    blocks, files = [], {}
    i = 0
    while i < len(text):
        line = text[i]
        fence = re.match(r"^( *)(`{3,})(.*)$", line)
        if not fence:
            i += 1
            continue
        indent, ticks, info = fence.group(1), fence.group(2), fence.group(3).strip()
        j = i + 1
        while j < len(text) and text[j] != indent + ticks:
            j += 1
        body = [b[len(indent):] if b.startswith(indent) else b for b in text[i + 1:j]]
        mark = MARK.match(text[i - 1].strip()) if i else None
        marks = set(mark.group(1).split()) if mark else set()
        if info == "console":
            blocks.append(Block(str(path.relative_to(DOCS)), i + 1, _parse_console(body), marks))
        elif info.startswith("{code-block}"):
            options = [b for b in body if b.startswith(":")]
            caption = next((o.split(":", 2)[2].strip() for o in options if o.startswith(":caption:")), None)
            if caption:
                content = body[len(options):]
                if content and not content[0].strip():
                    content = content[1:]
                files[caption] = "\n".join(content) + "\n"
        i = j + 1
    return blocks, files


def matches(expected: list[str], actual: list[str]) -> bool:
    """Expected lines against the output, ``...`` matching any run of lines."""
    if not expected:
        return True
    if expected[0].strip() == "...":
        rest = expected[1:]
        return any(matches(rest, actual[k:]) for k in range(len(actual) + 1))
    return bool(actual) and actual[0].rstrip() == expected[0] and matches(expected[1:], actual[1:])


def shown(expected: list[str], output: list[str], errors: str) -> bool:
    """The page shows standard output, or a message (errors and warnings go to standard error)."""
    return matches(expected, output) or matches(expected, errors.splitlines()) \
        or matches(expected, output + errors.splitlines())


def prepare(folder: Path, files: dict[str, str]) -> None:
    """The page's folder: the shown files and ``mechanisms/`` as in a clone."""
    from transgen.library import bundled_mechanisms  # noqa: F401  (the package is importable)
    import transgen.mechanisms as mechanisms

    link = folder / "mechanisms"
    if not link.exists():
        link.symlink_to(Path(mechanisms.__file__).parent, target_is_directory=True)
    for name, content in files.items():
        (folder / name).parent.mkdir(parents=True, exist_ok=True)
        (folder / name).write_text(content, encoding="utf-8")


def _environment() -> dict[str, str]:
    env = dict(os.environ, MPLBACKEND="Agg", COLUMNS="100")
    env["PATH"] = str(Path(sys.executable).parent) + os.pathsep + env.get("PATH", "")
    return env


def run_command(command: Command, folder: Path, timeout: float = 600.0) -> tuple[int, list[str], float, str]:
    """Run one command with bash in ``folder``: (exit code, standard output's lines, wall time [s],
    standard error). The page shows standard output; progress and ``wrote`` lines may go to
    standard error."""
    start = time.perf_counter()
    proc = subprocess.run(["bash", "-o", "pipefail", "-c", command.text], cwd=folder, env=_environment(),
                          stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, timeout=timeout)
    return proc.returncode, proc.stdout.splitlines(), time.perf_counter() - start, proc.stderr


class Cluster:
    """A local Dask scheduler and two single-threaded workers, ended with their process groups."""

    def __enter__(self):
        env = dict(_environment(), DASK_DISTRIBUTED__WORKER__PROFILE__ENABLED="False")
        self.procs = [subprocess.Popen([sys.executable, "-m", "dask", "scheduler", "--host", "127.0.0.1",
                                        "--port", "8786"], env=env, start_new_session=True,
                                       stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)]
        time.sleep(3)
        self.procs.append(subprocess.Popen([sys.executable, "-m", "dask", "worker", "tcp://127.0.0.1:8786",
                                            "--nworkers", "2", "--nthreads", "1"], env=env,
                                           start_new_session=True, stdout=subprocess.DEVNULL,
                                           stderr=subprocess.DEVNULL))
        time.sleep(5)
        return self

    def __exit__(self, *exc):
        for proc in reversed(self.procs):
            os.killpg(proc.pid, signal.SIGTERM)
            proc.wait(timeout=30)


def check_block(block: Block, folder: Path) -> list[str]:
    """Problems of one block (empty: it ran as the page says)."""
    problems = []
    for command in block.commands:
        code, output, _, errors = run_command(command, folder)
        if code != block.exit_code:
            problems.append(f"{block.page}:{block.line}: `{command.text}` exited {code}, expected "
                            f"{block.exit_code}:\n" + "\n".join(output[-10:]) + "\n" + errors[-2000:])
        elif not shown(command.expected, output, errors):
            problems.append(f"{block.page}:{block.line}: `{command.text}` printed other output than the page "
                            "shows:\n" + "\n".join(output[:40]))
    return problems
