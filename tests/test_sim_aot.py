"""The rule that picks the simulator's path (transgen.sim.core.jit.jit_enabled) and the kernels built
ahead of time (transgen.sim.core.aot)."""
import importlib.machinery
import os
import subprocess
import sys

import numpy as np
import pytest

from transgen.sim.core import aot, jit


@pytest.fixture
def fresh_rule(monkeypatch):
    """A process state without a decision of the rule, with ``TRANSGEN_JIT`` unset; records
    the builds the rule starts."""
    monkeypatch.delenv("TRANSGEN_JIT", raising=False)
    monkeypatch.setattr(jit, "_COMPILED", {})
    calls = []
    monkeypatch.setattr(aot, "build_in_background", lambda: calls.append("background") or True)
    monkeypatch.setattr(aot, "build", lambda clone, wait=True: calls.append(("build", clone, wait)))
    return calls


def test_one_run_without_built_kernels_runs_in_python_and_builds_them_in_the_background(fresh_rule, monkeypatch):
    pytest.importorskip("numba")
    monkeypatch.setattr(aot, "kernels", lambda: None)
    assert jit.jit_enabled() is False
    assert jit.jit_enabled() is False  # decided once: one background build
    assert fresh_rule == ["background"]


def test_many_runs_build_the_kernels_in_the_foreground(fresh_rule, monkeypatch):
    pytest.importorskip("numba")
    monkeypatch.setattr(aot, "kernels", lambda: None)
    jit.expect_many_runs()
    assert jit.jit_enabled() is True
    assert fresh_rule == [("build", jit.numba_clone, True)]


def test_built_kernels_are_used_and_nothing_is_built(fresh_rule, monkeypatch):
    monkeypatch.setattr(aot, "kernels", lambda: object())
    assert jit.jit_enabled() is True
    assert fresh_rule == []


def test_transgen_jit_0_is_the_python_path_whatever_is_built(fresh_rule, monkeypatch):
    monkeypatch.setattr(aot, "kernels", lambda: object())
    monkeypatch.setenv("TRANSGEN_JIT", "0")
    jit.expect_many_runs()
    assert jit.jit_enabled() is False
    assert fresh_rule == []


def test_the_kernels_live_in_a_writable_folder_named_by_their_sources(tmp_path, monkeypatch):
    monkeypatch.setenv("TRANSGEN_KERNEL_CACHE", str(tmp_path / "k"))
    assert aot.folders() == [tmp_path / "k"]
    name = aot._file_in(aot.folders()[0]).name
    assert aot.digest() in name and name.endswith(importlib.machinery.EXTENSION_SUFFIXES[0])
    assert aot._writable_folder() == tmp_path / "k"
    assert aot.kernels() is None or aot._LOADED.get("module") is not None  # nothing there: not found


def test_a_second_builder_waits_for_the_first(tmp_path):
    with aot._lock(tmp_path) as first:
        assert first is not None and first.is_file()
        with aot._lock(tmp_path) as second:
            assert second is None
    assert not first.exists()


def _built():
    """The built kernels (built here once where numba and a compiler are there: ~40 s CPU)."""
    pytest.importorskip("numba")
    from transgen.sim.core.jit import numba_clone

    module = aot.build(numba_clone, wait=True)
    if module is None:
        pytest.skip("the kernels cannot be built here (no C compiler or no writable folder)")
    return module


def test_compiled_forms_come_from_the_built_module():
    module = _built()
    from transgen.sim.solve.kernel import rhs_kernel
    from transgen.sim.core.signals import table_values

    assert jit.compiled(rhs_kernel) is module.rhs_kernel
    ts = np.linspace(-1.0, 3.0, 41)
    times, values = np.array([0.0, 1.0, 2.0]), np.array([5.0, -1.0, 2.0])
    out, expected = np.empty(len(ts)), np.empty(len(ts))
    module.table_values(ts, times, values, out)
    table_values(ts, times, values, expected)  # the same function run by the interpreter
    assert out.tolist() == expected.tolist()


def test_a_run_in_a_new_process_loads_the_built_kernels_without_numba(tmp_path):
    _built()
    code = ("import sys\nfrom transgen.sim.scenario.load import load_scenario\n"
            "r = load_scenario('ht740_improved', {'simulation.t_end': 1.0}).run()\n"
            "from transgen.sim.core.jit import compiled_loaded\n"
            "print(r.success, compiled_loaded(), 'numba' in sys.modules)")
    env = {k: v for k, v in os.environ.items() if k != "TRANSGEN_JIT"}
    # in a folder of its own: from the checkout's root, `python -c` would import the source folder
    # transgen/ (which has no sim/) instead of the installed package
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, check=True,
                         cwd=tmp_path)
    assert out.stdout.split() == ["True", "True", "False"]
