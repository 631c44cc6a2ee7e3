"""Sphinx configuration of the transgen documentation (Sphinx + MyST + furo; see dependencies.md).

Build offline, warnings as errors: ``sphinx-build -W --keep-going -b html docs /tmp/transgen-docs``.
"""
from __future__ import annotations

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent / "_ext"))

import transgen  # noqa: E402  (the installed package documents itself)

project = "transgen"
author = "transgen developers"
copyright = "2026, transgen developers"
release = version = transgen.__version__

extensions = [
    "myst_parser",
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "sphinx.ext.doctest",
    "sphinx.ext.mathjax",
    "sphinx.ext.napoleon",  # the docstrings are numpydoc (Parameters, Returns, Notes sections)
    "transgen_docs",  # docs/_ext: the CLI, scenario keys, JSON schemas and API pages from the code
]
source_suffix = {".md": "markdown", ".rst": "restructuredtext"}
root_doc = "index"
exclude_patterns = ["_build", "README.md"]
templates_path = ["_templates"]

myst_enable_extensions = ["colon_fence", "deflist", "dollarmath"]
myst_heading_anchors = 3

html_theme = "furo"
html_title = f"transgen {release}"

from transgen_docs import package_modules  # noqa: E402

autosummary_generate = True
# A package's page lists the names it re-exports without indexing them again: the module that
# defines a name is its one target, so cross-references resolve to one place.
autosummary_context = {"packages": [name for name in package_modules()
                                    if hasattr(__import__("importlib").import_module(name), "__path__")]}
autosummary_imported_members = False
autodoc_default_options = {"members": True}
autodoc_member_order = "bysource"
autodoc_typehints = "none"  # signatures as written; the docstrings state units
add_module_names = False
napoleon_google_docstring = False
napoleon_numpy_docstring = True

# The Python examples run in a fresh folder holding the files the pages show (``:caption:`` blocks)
# and ``mechanisms/``, as the shell examples do (docs/_ext/docs_examples.py).
doctest_test_doctest_blocks = ""  # docstrings: tests/test_docstring_examples.py runs them in their modules
doctest_global_setup = """
import os, tempfile
os.environ.setdefault("MPLBACKEND", "Agg")
from pathlib import Path
import docs_examples as _examples
_folder = Path(tempfile.mkdtemp(prefix="transgen-doctest-"))
_examples.prepare(_folder, {name: text for page in _examples.pages() for name, text in _examples.parse_page(page)[1].items()})
os.chdir(_folder)
"""
