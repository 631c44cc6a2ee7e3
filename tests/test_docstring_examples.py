"""The examples in the docstrings run, in their own module's namespace (issue 23: every example of
the docs executed). The API reference shows these docstrings; Sphinx's doctest builder runs only
the pages' own ``{doctest}`` blocks (``doctest_test_doctest_blocks = ""`` in docs/conf.py), since
it would run a docstring's example without the names of its module."""
from __future__ import annotations

import doctest
import importlib
import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "docs" / "_ext"))

from transgen_docs import package_modules  # noqa: E402

MODULES = [name for name in package_modules()
           if doctest.DocTestFinder().find(importlib.import_module(name))
           and any(t.examples for t in doctest.DocTestFinder().find(importlib.import_module(name)))]


def test_there_are_docstring_examples():
    assert len(MODULES) >= 5


@pytest.mark.parametrize("name", MODULES)
def test_docstring_examples_run(name, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    module = importlib.import_module(name)
    result = doctest.testmod(module, optionflags=doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE, report=False)
    assert result.failed == 0, f"{result.failed} of {result.attempted} docstring examples of {name} failed"
