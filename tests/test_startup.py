"""Start-up of the command line stays lean (issue 11, section 4): structural checks of which
libraries a command imports, in a fresh interpreter; the times are in benchmarks/bench_startup.py."""
from __future__ import annotations

import os
import subprocess
import tempfile
import sys
from pathlib import Path

import pytest

import transgen
from transgen.grammar_cache import cached_lark
from transgen.language import _parser, grammar_text, load_mechanism


def imported_after(code: str) -> set[str]:
    """Top-level packages in ``sys.modules`` after running ``code`` in a fresh interpreter."""
    probe = code + "\nimport sys\nprint(' '.join(sorted({m.partition('.')[0] for m in sys.modules})))"
    # not from the checkout: `python -c` imports from its working directory first, and a source
    # checkout's transgen folder is not the installed package (sim/ is mapped into it on install)
    out = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True, check=True,
                         env=dict(os.environ, MPLBACKEND="Agg"), cwd=tempfile.gettempdir())
    return set(out.stdout.strip().splitlines()[-1].split())


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


@pytest.mark.parametrize("argv", [["check", "ht740"], ["ratios", "ht740"], ["modes", "ht740"], ["matrices", "ht740"]])
def test_numeric_commands_load_neither_sympy_nor_scipy_nor_matplotlib(argv):
    loaded = imported_after(run_cli(argv))
    assert "numpy" in loaded  # the probe sees the command's imports
    assert not loaded & {"scipy", "sympy", "matplotlib"}


def test_the_package_names_still_resolve():
    assert transgen.load_mechanism("ht740").name
    assert {"build_graph", "gear_table", "Mechanism"} <= set(dir(transgen))
    with pytest.raises(AttributeError):
        transgen.no_such_name  # noqa: B018


def test_grammar_cache_round_trip_and_a_broken_file_is_rebuilt(tmp_path, monkeypatch):
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    monkeypatch.delenv("TRANSGEN_NO_GRAMMAR_CACHE", raising=False)
    options = dict(parser="lalr", propagate_positions=True, maybe_placeholders=False)
    built = cached_lark(grammar_text(), **options)
    (saved,) = (tmp_path / "transgen").glob("*.pickle")
    loaded = cached_lark(grammar_text(), **options)
    text = (Path(__file__).resolve().parents[1] / "mechanisms" / "coupled_clutches.mech").read_text(encoding="utf-8")
    assert loaded.parse(text) == built.parse(text)
    assert loaded.options.propagate_positions
    saved.write_bytes(b"truncated")
    rebuilt = cached_lark(grammar_text(), **options)
    assert rebuilt.parse(text) == built.parse(text)
    assert saved.stat().st_size > 100


def test_a_mechanism_parses_the_same_without_the_cache(monkeypatch):
    cached = load_mechanism("ht740")
    monkeypatch.setenv("TRANSGEN_NO_GRAMMAR_CACHE", "1")
    _parser.cache_clear()
    try:
        assert load_mechanism("ht740") == cached
    finally:
        _parser.cache_clear()
