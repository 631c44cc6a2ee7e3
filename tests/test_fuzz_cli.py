"""Small seeds of the output fuzzer and the kill test in the suite: ``benchmarks/fuzz_cli.py``
(60 invocations here, 1,000 in the long run) and ``benchmarks/kill_test.py`` (one SIGKILL of
``simulate -o`` and of ``optimize`` here, 20 of each and of ``sweep --workers 2`` in the long
run; the sweep's kill and resume is in tests/test_processes.py)."""
from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

import pytest

BENCHMARKS = Path(__file__).resolve().parents[1] / "benchmarks"


def _load(name: str):
    spec = importlib.util.spec_from_file_location(f"_bench_{name}", BENCHMARKS / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.mark.skipif(sys.platform != "linux", reason="FIFOs, fork and /proc: Linux")
def test_output_fuzzer_small_seed(capsys):
    fuzz = _load("fuzz_cli")
    # a hang is > 60 s in the long run; here more, so that a loaded machine does not fail the suite
    code = fuzz.main(["--invocations", "60", "--jobs", "2", "--seed", "20261203", "--timeout", "300"])
    out = capsys.readouterr().out
    assert code == 0, out
    assert "60 invocations" in out and "0 tracebacks, 0 hangs" in out and "0 with files replaced, 0 with temporaries left" in out


@pytest.mark.skipif(sys.platform != "linux", reason="process groups and /proc: Linux")
def test_kill_test_small_seed(capsys):
    kill = _load("kill_test")
    code = kill.main(["--kills", "1", "--seed", "5", "--commands", "simulate,optimize", "--no-complete-each"])
    out = capsys.readouterr().out
    assert code == 0, out
    assert "0 processes alive 5 s after" in out and "0 after the final run" in out
