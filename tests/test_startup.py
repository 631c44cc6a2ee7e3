"""Start-up of the command line stays lean (issue 11, section 4): structural checks of which
libraries a command imports, in a fresh interpreter; the times are in benchmarks/bench_startup.py."""
from __future__ import annotations

import json
import os
import subprocess
import tempfile
import sys
from pathlib import Path

import lark
import pytest

import transgen
from transgen.grammar_cache import parser_module
from transgen.language import _grammar, grammar_text, load_mechanism


def imported_after(code: str, cache: Path | None = None) -> set[str]:
    """Top-level packages in ``sys.modules`` after running ``code`` in a fresh interpreter
    (with ``cache`` as the user's cache folder: ``XDG_CACHE_HOME``)."""
    probe = code + "\nimport sys\nprint(' '.join(sorted({m.partition('.')[0] for m in sys.modules})))"
    env = dict(os.environ, MPLBACKEND="Agg") | ({"XDG_CACHE_HOME": str(cache)} if cache else {})
    env.pop("TRANSGEN_NO_GRAMMAR_CACHE", None)
    # not from the checkout: `python -c` imports from its working directory first, and a source
    # checkout's transgen folder is not the installed package (sim/ is mapped into it on install)
    out = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True, check=True, env=env,
                         cwd=tempfile.gettempdir())
    return set(out.stdout.strip().splitlines()[-1].split())


@pytest.fixture(scope="module")
def warm_cache(tmp_path_factory) -> Path:
    """A cache folder holding the generated parser of ``mech.lark`` (as after a first run)."""
    cache = tmp_path_factory.mktemp("cache")
    assert "lark" in imported_after(run_cli(["check", "simple2"]), cache)  # a cold cache builds it with lark
    return cache


def run_cli(argv: list[str]) -> str:
    return ("import contextlib, io\nfrom transgen.cli import main\n"
            f"with contextlib.redirect_stdout(io.StringIO()):\n    assert main({argv!r}) == 0\n")


def test_importing_the_cli_loads_no_numeric_library():
    loaded = imported_after("import transgen, transgen.cli")
    assert not loaded & {"numpy", "scipy", "sympy", "matplotlib", "networkx", "lark"}


def test_help_loads_no_numeric_library():
    loaded = imported_after("import contextlib, io\nfrom transgen.cli import main\n"
                            "with contextlib.redirect_stdout(io.StringIO()):\n"
                            "    try: main(['--help'])\n    except SystemExit: pass\n")
    assert not loaded & {"numpy", "scipy", "sympy", "matplotlib", "networkx", "lark"}


NUMERIC = [["check", "ht740"], ["ratios", "ht740"], ["modes", "ht740"], ["matrices", "ht740"], ["std", "ht740", "--json"],
           ["check", "ht740", "--json"], ["ratios", "zf8hp70", "--json"], ["modes", "ht740", "--all", "--json"],
           ["matrices", "ht740", "--list-coordinates"]]


@pytest.mark.parametrize("argv", NUMERIC, ids=" ".join)
def test_numeric_commands_load_numpy_alone(argv, warm_cache):
    """The numeric pipeline works on plain arrays and the BondGraph: no networkx (only for the
    graph as a product: drawing, DOT, GraphML), no lark (the generated parser), no scipy, sympy
    or matplotlib."""
    loaded = imported_after(run_cli(argv), warm_cache)
    assert "numpy" in loaded and "transgen" in loaded  # the probe sees the command's imports
    assert not loaded & {"networkx", "lark", "scipy", "sympy", "matplotlib"}


@pytest.mark.parametrize("argv", [["list"], ["list", "--json"], ["simulate", "--list"]], ids=" ".join)
def test_listing_loads_no_numeric_library(argv, warm_cache):
    loaded = imported_after(run_cli(argv), warm_cache)
    assert not loaded & {"numpy", "scipy", "sympy", "matplotlib", "networkx", "lark"}


def test_the_graph_as_a_product_is_networkx(warm_cache, tmp_path):
    loaded = imported_after(run_cli(["graph", "ht740", "-o", str(tmp_path / "g.dot")]), warm_cache)
    assert "networkx" in loaded and not loaded & {"lark", "scipy", "sympy"}


BLAS_THREADS = ("import threadpoolctl\n"
                "print(sorted({i['num_threads'] for i in threadpoolctl.threadpool_info() if i['user_api'] == 'blas'}))\n")


def _blas_threads(code: str, **env: str) -> str:
    out = subprocess.run([sys.executable, "-c", code + BLAS_THREADS], capture_output=True, text=True, check=True,
                         env={k: v for k, v in os.environ.items() if not k.endswith("_NUM_THREADS")} | env,
                         cwd=tempfile.gettempdir())
    return out.stdout.strip().splitlines()[-1]


def test_the_command_line_starts_the_blas_with_one_thread():
    """No thread pool to start for small linear algebra (transgen.blas.one_thread_from_start); a
    user's own setting is kept, and a program that loaded numpy before calling main keeps its BLAS."""
    many = _blas_threads("import numpy\n", OPENBLAS_NUM_THREADS="2")
    if many == "[]":
        pytest.skip("no BLAS that threadpoolctl knows")
    assert _blas_threads(run_cli(["check", "simple2"])) == "[1]"
    assert _blas_threads(run_cli(["check", "simple2"]), OPENBLAS_NUM_THREADS="2", MKL_NUM_THREADS="2") == many
    assert _blas_threads("import numpy\n" + run_cli(["check", "simple2"])) == _blas_threads("import numpy\n")


def test_a_run_limits_the_blas_to_one_thread_every_time():
    """transgen.blas.single_threaded finds the BLAS libraries once (and again after imports): each
    use limits them to one thread and restores the setting, also with a library loaded in between."""
    many = _blas_threads("import numpy\n", OPENBLAS_NUM_THREADS="2")
    if many in ("[]", "[1]"):
        pytest.skip("no multi-threaded BLAS that threadpoolctl knows")
    code = ("import json, numpy, threadpoolctl\nfrom transgen.blas import single_threaded\n"
            "def blas():\n    return sorted({i['num_threads'] for i in threadpoolctl.threadpool_info() "
            "if i['user_api'] == 'blas'})\n"
            "seen = []\nfor preload in ((), (), ('scipy.linalg',), ('scipy.linalg',)):\n"
            "    with single_threaded(*preload):\n        seen.append(blas())\n    seen.append(blas())\n"
            "print(json.dumps(seen))\n")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True,
                         env={k: v for k, v in os.environ.items() if not k.endswith("_NUM_THREADS")}
                         | {"OPENBLAS_NUM_THREADS": "2"}, cwd=tempfile.gettempdir())
    seen = json.loads(out.stdout.strip().splitlines()[-1])
    assert seen[0::2] == [[1]] * 4
    assert all(after != [1] for after in seen[1::2])


def test_a_blas_loaded_inside_a_run_is_limited_where_the_run_says():
    """single_threaded limits the BLAS libraries loaded when it starts; one loaded later (scipy's,
    by the stiff solvers) from limit_loaded() on; both restored at its end."""
    many = _blas_threads("import numpy\n", OPENBLAS_NUM_THREADS="2")
    if many in ("[]", "[1]"):
        pytest.skip("no multi-threaded BLAS that threadpoolctl knows")
    code = ("import json, numpy, threadpoolctl\nfrom transgen.blas import limit_loaded, single_threaded\n"
            "def blas():\n    return sorted({i['num_threads'] for i in threadpoolctl.threadpool_info() "
            "if i['user_api'] == 'blas'})\n"
            "seen = [len(threadpoolctl.threadpool_info())]\nwith single_threaded():\n    import scipy.linalg\n"
            "    seen += [len(threadpoolctl.threadpool_info()), blas()]\n    limit_loaded()\n    seen.append(blas())\n"
            "seen.append(blas())\nprint(json.dumps(seen))\n")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True,
                         env={k: v for k, v in os.environ.items() if not k.endswith("_NUM_THREADS")}
                         | {"OPENBLAS_NUM_THREADS": "2"}, cwd=tempfile.gettempdir())
    before, during, loaded, limited, after = json.loads(out.stdout.strip().splitlines()[-1])
    if during == before:
        pytest.skip("scipy shares numpy's BLAS here")
    assert 1 in loaded and len(loaded) == 2 and limited == [1] and after == json.loads(many)


def test_the_package_names_still_resolve():
    assert transgen.load_mechanism("ht740").name
    assert {"build_graph", "gear_table", "Mechanism"} <= set(dir(transgen))
    with pytest.raises(AttributeError):
        transgen.no_such_name  # noqa: B018


def test_grammar_cache_round_trip_and_a_broken_file_is_rebuilt(tmp_path, monkeypatch):
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    monkeypatch.delenv("TRANSGEN_NO_GRAMMAR_CACHE", raising=False)
    options = dict(parser="lalr", propagate_positions=True, maybe_placeholders=False)
    built = parser_module(grammar_text(), **options)
    (saved,) = (tmp_path / "transgen").glob("parser-*.py")
    loaded = parser_module(grammar_text(), **options)
    assert loaded is not built and loaded.GRAMMAR == grammar_text()
    text = (Path(__file__).resolve().parents[1] / "mechanisms" / "coupled_clutches.mech").read_text(encoding="utf-8")
    tree = lark.Lark(grammar_text(), **options).parse(text)
    for module in (built, loaded):
        parser = module.Lark_StandAlone()
        assert parser.options.propagate_positions and not parser.options.maybe_placeholders
        assert _same_tree(parser.parse(text), tree)
    for broken in (b"truncated", saved.read_bytes().replace(b"GRAMMAR = ", b"GRAMMAR = 'x' + ")):
        saved.write_bytes(broken)
        rebuilt = parser_module(grammar_text(), **options)
        assert _same_tree(rebuilt.Lark_StandAlone().parse(text), tree)
        assert saved.stat().st_size > 1000 and b"GRAMMAR = 'x'" not in saved.read_bytes()


def test_a_cache_that_cannot_be_written_costs_only_the_build(tmp_path, monkeypatch):
    blocked = tmp_path / "not-a-folder"
    blocked.write_text("a file where the cache folder would be")
    monkeypatch.setenv("XDG_CACHE_HOME", str(blocked))
    monkeypatch.delenv("TRANSGEN_NO_GRAMMAR_CACHE", raising=False)
    module = parser_module(grammar_text(), parser="lalr", propagate_positions=True, maybe_placeholders=False)
    assert module.Lark_StandAlone().parse("link A J=1\n").children[0].data == "link"
    assert blocked.read_text() == "a file where the cache folder would be"


def _same_tree(a, b) -> bool:
    """Trees of the generated parser and of lark (different classes) are equal, with positions."""
    if isinstance(a, str) or isinstance(b, str):
        return (isinstance(a, str) and isinstance(b, str) and str(a) == str(b) and a.type == b.type
                and (a.line, a.column, a.end_line, a.end_column) == (b.line, b.column, b.end_line, b.end_column))
    return (a.data == b.data and len(a.children) == len(b.children)
            and (a.meta.line, a.meta.column, a.meta.end_line, a.meta.end_column)
            == (b.meta.line, b.meta.column, b.meta.end_line, b.meta.end_column)
            and all(_same_tree(x, y) for x, y in zip(a.children, b.children)))


def test_the_generated_parser_reports_syntax_errors_as_lark_does():
    options = dict(parser="lalr", propagate_positions=True, maybe_placeholders=False)
    reference = lark.Lark(grammar_text(), **options)
    generated = _grammar()
    for text in ("link A J=1\nlink B J=\n", "link A J=1 $\n", "gear 1 = \n", "link\n", "planetary P sun=A ring\n",
                 'transmission "open\n', "input A B\n", "link A J=1"):
        with pytest.raises(lark.exceptions.UnexpectedInput) as expected:
            reference.parse(text)
        with pytest.raises(generated.UnexpectedInput) as got:
            generated.parser.parse(text)
        a, b = expected.value, got.value
        assert type(a).__name__ == type(b).__name__
        assert (a.line, a.column, str(getattr(a, "token", "")), getattr(a, "expected", None),
                getattr(a, "allowed", None)) == (b.line, b.column, str(getattr(b, "token", "")),
                                                 getattr(b, "expected", None), getattr(b, "allowed", None))


def test_a_mechanism_parses_the_same_without_the_cache(monkeypatch):
    cached = load_mechanism("ht740")
    monkeypatch.setenv("TRANSGEN_NO_GRAMMAR_CACHE", "1")
    _grammar.cache_clear()
    try:
        assert load_mechanism("ht740") == cached
    finally:
        _grammar.cache_clear()


# --- the simulator's cold start (issue 23): what `transgen simulate` and a script's first run import

def modules_after(code: str, **env: str) -> dict[str, str]:
    """Module name -> type name of every module in ``sys.modules`` after ``code`` in a fresh
    interpreter (``_DeferredPackage``: a package registered whose ``__init__`` has not run)."""
    probe = code + "\nimport sys, json\nprint(json.dumps({m: type(v).__name__ for m, v in list(sys.modules.items())}))"
    out = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True, check=True,
                         env=dict(os.environ, MPLBACKEND="Agg") | env, cwd=tempfile.gettempdir())
    return json.loads(out.stdout.strip().splitlines()[-1])


UNNEEDED_BY_A_RUN = (
    "sympy", "matplotlib", "networkx", "lark", "numba",
    "numpy.f2py", "numpy.testing", "numpy.ma",  # scipy's array-API layer imports these (0.2-0.3 s)
    "scipy._lib._array_api", "scipy.sparse._base", "scipy.linalg._basic", "scipy.optimize._optimize",
    "scipy.integrate._quadpack", "scipy.special",
    "transgen.sim.engine.diesel", "transgen.sim.model.turbodiesel", "transgen.sim.engine.map_generator",
    "transgen.parameters", "transgen.sim.study.runner", "transgen.synthesis.fit")
DEFERRED = ("scipy.integrate", "scipy.linalg", "scipy.optimize", "scipy.sparse")


def _jit_settings() -> list[str]:
    """``TRANSGEN_JIT`` values to probe: the Python path, and the compiled one where its kernels
    are built (else the probe would start their 30-60 s build in the background)."""
    from transgen.sim.core import aot

    return ["0", "1"] if aot.kernels() is not None else ["0"]


@pytest.mark.parametrize("jit", _jit_settings())
@pytest.mark.parametrize("how", ["cli", "script"])
def test_a_simulation_imports_only_what_it_uses(how, jit, warm_cache):
    """``transgen simulate ht740_improved`` and a script's ``load_scenario(...).run()`` (the
    switching model on LSODA with a torque converter) import neither the symbolic, plotting or
    graph libraries nor the turbodiesel, nor scipy's packages beyond the parts the run uses."""
    code = (run_cli(["simulate", "ht740_improved"]) if how == "cli" else
            "from transgen.sim import load_scenario\nassert load_scenario('ht740_improved').run().success\n")
    loaded = modules_after(code, TRANSGEN_JIT=jit, XDG_CACHE_HOME=str(warm_cache))
    assert "transgen.sim.solve.ode_solvers" in loaded and "scipy.integrate._ivp.lsoda" in loaded  # it ran
    found = [m for m in loaded if any(m == u or m.startswith(u + ".") for u in UNNEEDED_BY_A_RUN)]
    assert not found, found
    assert {p: loaded[p] for p in DEFERRED if p in loaded} == {p: "_DeferredPackage" for p in DEFERRED}


def test_the_probe_sees_a_package_completed():
    """The check above can fail: asking scipy.sparse for a name runs its ``__init__``."""
    loaded = modules_after("from transgen.sim.solve import ode_solvers\nimport scipy.sparse\nscipy.sparse.eye\n")
    assert loaded["scipy.sparse"] == "module" and "scipy._lib._array_api" in loaded and "numpy.ma" in loaded


def test_the_engine_package_loads_each_name_from_its_module():
    """``transgen.sim.engine`` (names loaded on first use) offers every public name of its
    modules, each from the module that defines it (``turbo_report`` is that module)."""
    import importlib

    import transgen.sim.engine as engine

    table = engine._WHERE
    assert table and set(engine.__all__) == set(table)
    for module in set(table.values()):
        names = set(importlib.import_module(f"transgen.sim.engine.{module}").__all__) - {"turbo_report"}
        assert {n for n, m in table.items() if m == module} == names, module
    assert all(getattr(engine, n) is getattr(importlib.import_module(f"transgen.sim.engine.{m}"), n)
               for n, m in table.items())
