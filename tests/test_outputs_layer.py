"""The output layer (transgen.outputs): what the user's name points at is respected.

A device node or FIFO is written through (never replaced), a symbolic link is followed (the
link kept), an input of the command is refused unless --force, a folder is refused, a failed
write names the user's path, and a temporary file of a dead writer is removed by the next write
into its folder, never one of a live process.
"""
from __future__ import annotations

import errno
import os
import stat
import subprocess
import sys
import threading

import pytest

from transgen.cli import main
from transgen.errors import TransgenError
from transgen.outputs import (TEMP_PREFIX, OutputError, OutputRefused, atomic_path, command_scope, is_temporary,
                              note_input, output_set, remove_stale)
from transgen.export import write_text

ROOT = os.geteuid() == 0 if hasattr(os, "geteuid") else False


def _temporaries(folder):
    return [p.name for p in folder.rglob("*") if is_temporary(p.name)]


def _null_node(path):
    """A character device node of our own with the null device's numbers (root only)."""
    os.mknod(path, stat.S_IFCHR | 0o666, os.makedev(1, 3))


@pytest.mark.skipif(not ROOT or not hasattr(os, "mknod"), reason="making a device node needs root")
def test_a_device_node_is_written_through_not_replaced(tmp_path):
    node = tmp_path / "out.csv"
    _null_node(node)
    before = os.stat(node)
    write_text(node, "a,b\n1,2\n")
    after = os.stat(node)
    assert stat.S_ISCHR(after.st_mode) and after.st_ino == before.st_ino and after.st_rdev == before.st_rdev
    assert _temporaries(tmp_path) == []


@pytest.mark.skipif(not os.path.exists("/dev/full"), reason="no /dev/full")
def test_a_full_device_is_an_error_naming_the_path(tmp_path):
    with pytest.raises(OutputError) as info:
        write_text("/dev/full", "x" * 10000)
    assert "/dev/full" in str(info.value) and "No space left" in str(info.value)
    assert TEMP_PREFIX not in str(info.value)


def test_a_fifo_is_written_through_and_one_without_reader_is_an_error_not_a_hang(tmp_path):
    fifo = tmp_path / "pipe.csv"
    os.mkfifo(fifo)
    with pytest.raises(OutputError, match="no process is reading"):
        write_text(fifo, "nobody reads\n")
    got = []
    reader = threading.Thread(target=lambda: got.append(open(fifo, "rb").read()))
    reader.start()
    import time

    for _ in range(200):  # the reader opens the FIFO
        try:
            write_text(fifo, "x,y\n3,4\n")
            break
        except OutputError:
            time.sleep(0.01)
    reader.join(10)
    assert got == [b"x,y\n3,4\n"] and stat.S_ISFIFO(os.stat(fifo).st_mode)
    assert _temporaries(tmp_path) == []


def test_a_symlink_is_followed_and_kept(tmp_path):
    target = tmp_path / "real.csv"
    target.write_text("old\n")
    link = tmp_path / "link.csv"
    link.symlink_to(target.name)
    write_text(link, "new\n")
    assert link.is_symlink() and os.readlink(link) == "real.csv" and target.read_text() == "new\n"
    dangling = tmp_path / "dangling.csv"
    dangling.symlink_to("made.csv")
    write_text(dangling, "made\n")
    assert dangling.is_symlink() and (tmp_path / "made.csv").read_text() == "made\n"
    assert _temporaries(tmp_path) == []


def test_standard_output(capfd):
    write_text("-", "to standard output\n")
    assert capfd.readouterr().out == "to standard output\n"


def test_a_folder_is_refused(tmp_path):
    with pytest.raises(OutputRefused, match="is a folder"):
        write_text(tmp_path, "x")


def test_an_input_of_the_command_is_refused_unless_forced(tmp_path):
    from transgen.sim.scenario.file_access import FileAccess

    source = tmp_path / "base.toml"
    source.write_text("t = 1\n")
    link = tmp_path / "alias.toml"
    link.symlink_to(source)
    hard = tmp_path / "hard.toml"
    os.link(source, hard)
    with command_scope():
        FileAccess().read_text(source)  # every file a scenario reads is noted
        for name in (source, link, hard):
            with pytest.raises(OutputRefused, match="one of the command's input files"):
                write_text(name, "overwritten")
        write_text(tmp_path / "other.toml", "fine")
    assert source.read_text() == "t = 1\n"
    with command_scope(force=True):
        note_input(source)
        write_text(source, "forced\n")
    assert source.read_text() == "forced\n"
    write_text(source, "outside a command nothing is refused\n")  # the library's own calls
    assert isinstance(OutputRefused("x"), TransgenError) and isinstance(OutputRefused("x"), ValueError)


def test_a_failed_write_names_the_users_path_and_leaves_nothing(tmp_path):
    out = tmp_path / "r.csv"
    with pytest.raises(OutputError) as info:
        with atomic_path(out) as tmp:
            tmp.write_text("partial")
            raise OSError(errno.ENOSPC, "No space left on device", str(tmp))
    assert str(out) in str(info.value) and TEMP_PREFIX not in str(info.value)
    assert list(tmp_path.iterdir()) == []


def test_a_set_with_a_stream_writes_nothing_when_it_fails(tmp_path, capfd):
    with pytest.raises(RuntimeError):
        with output_set():
            write_text("-", "never shown\n")
            write_text(tmp_path / "a.txt", "a")
            raise RuntimeError("a plot failed")
    assert capfd.readouterr().out == "" and list(tmp_path.iterdir()) == []


def _dead_pid() -> int:
    child = subprocess.Popen([sys.executable, "-c", "pass"])
    child.wait()
    return child.pid


def test_stale_temporaries_of_dead_writers_are_removed_live_ones_kept(tmp_path):
    from transgen.outputs import _own, _start_time

    pid, start = _own()
    stale = tmp_path / f"{TEMP_PREFIX}{_dead_pid()}.123.abcd.r.csv"
    reused = tmp_path / f"{TEMP_PREFIX}{os.getppid()}.1.abcd.r.csv"  # a live pid with another start time
    parent = tmp_path / f"{TEMP_PREFIX}{os.getppid()}.{_start_time(os.getppid())}.abcd.r.csv"
    mine = tmp_path / f"{TEMP_PREFIX}{pid}.{start}.abcd.r.csv"
    other = tmp_path / ".r.csv.not-ours"
    for p in (stale, reused, parent, mine, other):
        p.write_text("x")
    removed = remove_stale(tmp_path)
    assert sorted(removed) == sorted([stale, reused])
    assert parent.exists() and mine.exists() and other.exists()


def test_the_next_command_removes_stale_temporaries(tmp_path, capsys):
    stale = tmp_path / f"{TEMP_PREFIX}{_dead_pid()}.99.abcd.graph.dot"
    stale.write_text("left by a killed run")
    assert main(["graph", "simple2", "-o", str(tmp_path / "graph.dot")]) == 0
    assert not stale.exists() and (tmp_path / "graph.dot").is_file()


def test_commands_refuse_their_inputs(tmp_path, capsys):
    mech = tmp_path / "X.mech"
    assert main(["scenario", "new", "simple2", "-o", str(tmp_path / "s.toml")]) == 0
    from transgen.library import bundled_mechanisms

    mech.write_text(bundled_mechanisms()["simple2"].read_text())
    text = mech.read_text()
    capsys.readouterr()
    assert main(["scenario", "new", str(mech), "-o", str(mech)]) == 2
    err = capsys.readouterr().err
    assert err.startswith("error: -o ") and "--force" in err and "Traceback" not in err
    assert mech.read_text() == text
    scenario = tmp_path / "s.toml"
    before = scenario.read_text()
    assert main(["optimize", str(scenario), "-o", str(tmp_path / "t.toml"), "--history", str(scenario)]) == 2
    assert scenario.read_text() == before
    (tmp_path / "d.dot").mkdir()
    assert main(["graph", str(mech), "-o", str(tmp_path / "d.dot")]) == 2  # a folder
    assert "is a folder" in capsys.readouterr().err


def test_o_dash_writes_standard_output(capsys):
    assert main(["graph", "simple2", "-o", "-"]) == 0
    out = capsys.readouterr()
    assert out.out.startswith("digraph") and "wrote -" in out.err
