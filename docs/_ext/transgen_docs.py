"""Pages generated at build time from the code's own sources of truth (issue 23).

At ``config-inited`` (before Sphinx looks for source files and autosummary reads them) this writes Markdown pages into
``docs/reference/generated/`` (not in git):

* ``cli.md`` — every command and subcommand of :func:`transgen.cli.build_parser`, its usage and
  options as argparse formats them (no help text copied by hand);
* ``scenario_keys.md`` — every table and dotted key a scenario file may have, from the schema
  module's ``key_tree()`` and ``SIGNAL_KEYS`` (the lists the scenario reader checks files against);
* ``grammar.md`` — every ``.lark`` grammar of :mod:`transgen.grammars`, as it is;
* ``schemas.md`` — every JSON Schema shipped in :mod:`transgen.schemas`, with its title, rendered
  from the files;
* ``api.md`` — one autosummary entry per module of the ``transgen`` package, found by walking the
  installed packages, so that moved modules are followed without editing the docs.

The schema module is found by walking ``transgen.sim`` for the module that defines ``key_tree``
and ``TOP_KEYS``: its path is not written here, because modules of ``transgen.sim`` may move.
"""
from __future__ import annotations

import argparse
import importlib
import json
import os
import pkgutil
from pathlib import Path

GENERATED = Path("reference") / "generated"
EXCLUDED_MODULES = ("__main__",)  # importing it runs the command line


def _write(path: Path, text: str) -> None:
    """Write only when the text changed, so that an unchanged page is not re-read."""
    if not path.exists() or path.read_text(encoding="utf-8") != text:
        path.write_text(text, encoding="utf-8")


# --- modules ---------------------------------------------------------------------------------------

def package_modules(root: str = "transgen") -> list[str]:
    """Every importable module of ``root`` and its subpackages, sorted, ``__main__`` left out.

    ``transgen.sim`` is installed from another folder (``package-dir`` in pyproject), which an
    editable install does not show in ``transgen.__path__``; it is added when importable."""
    found: set[str] = set()

    def walk(name: str) -> None:
        module = importlib.import_module(name)
        found.add(name)
        for info in pkgutil.iter_modules(getattr(module, "__path__", []) or []):
            full = f"{name}.{info.name}"
            if info.name in EXCLUDED_MODULES or full in found:
                continue
            if info.ispkg:
                walk(full)
            else:
                found.add(full)

    walk(root)
    for extra in ("transgen.sim", "transgen.grammars", "transgen.mechanisms"):
        if extra not in found:
            try:
                walk(extra)
            except ImportError:
                pass
    return sorted(found)


def find_module(attributes: tuple[str, ...], root: str = "transgen.sim"):
    """The first module under ``root`` that defines every name in ``attributes``."""
    for name in package_modules(root) if root != "transgen" else package_modules():
        if not name.startswith(root):
            continue
        module = importlib.import_module(name)
        if all(name_ in vars(module) for name_ in attributes):
            return module
    raise LookupError(f"no module under {root} defines {', '.join(attributes)}")


# --- the command line -----------------------------------------------------------------------------

def _subcommands(parser: argparse.ArgumentParser, prefix: str):
    yield prefix, parser
    for action in parser._actions:  # argparse keeps its subparsers only here
        if isinstance(action, argparse._SubParsersAction):
            for name, sub in action.choices.items():
                yield from _subcommands(sub, f"{prefix} {name}")


def cli_page() -> str:
    """Markdown: every command's ``--help`` as argparse prints it, at 100 columns."""
    from transgen.cli import build_parser

    old = os.environ.get("COLUMNS")
    os.environ["COLUMNS"] = "100"
    try:
        parser = build_parser()
        parts = ["# Command-line reference", "",
                 "Generated at build time from `transgen.cli.build_parser()`: every command and subcommand "
                 "with its usage and options, as `--help` prints them. Exit codes: 0 success, 1 a run that "
                 "failed, 2 bad input (see [Commands](../../guide/commands.md)).", ""]
        for name, sub in _subcommands(parser, "transgen"):
            if name == "transgen":
                title = "`transgen`"
            else:
                title = f"`{name}`"
            parts += [f"## {title}", "", "```text", sub.format_help().rstrip(), "```", ""]
        return "\n".join(parts)
    finally:
        if old is None:
            os.environ.pop("COLUMNS", None)
        else:
            os.environ["COLUMNS"] = old


# --- scenario keys ----------------------------------------------------------------------------------

def _flatten(tree, prefix: str, module):
    """(dotted key, kind) for every key of the tree; ``*`` is any name, a list an array of tables."""
    for key, sub in sorted(tree.items()):
        name = "<name>" if key == module.ANY else key
        dotted = f"{prefix}.{name}" if prefix else name
        if isinstance(sub, dict):
            yield dotted, "table"
            yield from _flatten(sub, dotted, module)
        elif isinstance(sub, list):
            yield dotted, "array of tables (`.0`, `.1`, ...)"
            yield from _flatten(sub[0], dotted + ".<i>", module)
        elif sub == module.SIGNAL:
            yield dotted, "signal (a number or `{type = ..., ...}`)"
        else:
            yield dotted, "value"


def scenario_keys_page() -> str:
    """Markdown: the tables of the scenario tree, one table of dotted keys per top-level table."""
    schema = find_module(("key_tree", "TOP_KEYS", "SIGNAL_KEYS"))
    tree = schema.key_tree()
    parts = ["# Scenario keys", "",
             f"Generated at build time from `{schema.__name__}.key_tree()`, the tree that the scenario reader "
             "checks every file against and that `--set KEY=VALUE` and `transgen scenario keys` use. "
             "`<name>` stands for a shift element's or link's name of the mechanism, `<i>` for an index "
             "counted from 0. What each key means: [Scenario files](../scenario_files.md).", "",
             "## Top-level keys", "", "| key | kind |", "| --- | --- |"]
    for key in sorted(schema.TOP_KEYS):
        sub = tree.get(key)
        kind = ("table" if isinstance(sub, dict) else "array of tables" if isinstance(sub, list)
                else "value" if key in tree else "value (read before the tree: includes, report)")
        parts.append(f"| `{key}` | {kind} |")
    for key in sorted(k for k, v in tree.items() if isinstance(v, (dict, list))):
        header = f"[[{key}]]" if isinstance(tree[key], list) else f"[{key}]"
        parts += ["", f"## `{header}`", "", "| dotted key | kind |", "| --- | --- |"]
        parts += [f"| `{d}` | {kind} |" for d, kind in _flatten({key: tree[key]}, "", schema) if d != key]
    parts += ["", "## Signal types", "",
              "A signal is a number (a constant) or a table with `type` and the keys of its type:", "",
              "| `type` | keys |", "| --- | --- |"]
    parts += [f"| `{kind}` | {', '.join(f'`{k}`' for k in sorted(keys))} |"
              for kind, keys in sorted(schema.SIGNAL_KEYS.items())]
    return "\n".join(parts) + "\n"


# --- JSON schemas -------------------------------------------------------------------------------------

def schemas_page() -> str:
    """Markdown: every shipped JSON Schema, its id and title, then the file itself."""
    import transgen.schemas as schemas

    folder = Path(schemas.__file__).parent
    files = sorted(folder.glob("*.json"))
    parts = ["# JSON schemas", "",
             "Every `--json` output and JSON file is a document validated by one of these JSON Schemas "
             "(draft 2020-12), installed with the package in `transgen/schemas/` "
             "(`transgen.schemas.schema_path(name)`, `transgen.schemas.validate(doc)`). Generated at build "
             "time from the files; the format is described in [Files for other tools](../../guide/files.md).",
             "", "| file | `$id` | title |", "| --- | --- | --- |"]
    docs = {}
    for path in files:
        data = json.loads(path.read_text(encoding="utf-8"))
        docs[path.name] = data
        title = str(data.get("title", "")).replace("|", "\\|")
        parts.append(f"| [{path.name}](#schema-{path.stem.replace('.', '-').replace('_', '-')}) | "
                     f"`{data.get('$id', '')}` | {title} |")
    for path in files:
        anchor = f"schema-{path.stem.replace('.', '-').replace('_', '-')}"
        parts += ["", f"({anchor})=", f"## `{path.name}`", ""]
        if docs[path.name].get("description"):
            parts += [str(docs[path.name]["description"]), ""]
        parts += ["```json", path.read_text(encoding="utf-8").rstrip(), "```"]
    return "\n".join(parts) + "\n"


# --- the grammar -----------------------------------------------------------------------------------

def grammar_page() -> str:
    """Markdown: every ``.lark`` grammar shipped in :mod:`transgen.grammars`, as it is."""
    import transgen.grammars as grammars

    parts = ["# The `.mech` grammar", "",
             "The parser of `.mech` files is generated from these grammars (lark, LALR), shipped in the wheel "
             "in `transgen/grammars/`; what each statement means is in [The .mech language](../language.md). "
             "Included at build time from the installed files.", ""]
    for path in sorted(Path(grammars.__file__).parent.glob("*.lark")):
        parts += [f"## `{path.name}`", "", "```text", path.read_text(encoding="utf-8").rstrip(), "```", ""]
    return "\n".join(parts)


# --- API ------------------------------------------------------------------------------------------------

def api_page() -> str:
    """Markdown with one autosummary table of every module; autosummary writes their pages."""
    modules = package_modules()
    lines = ["# API reference", "",
             "Every module of the `transgen` package, found when the docs are built (a moved module is "
             "followed), each page generated by `sphinx.ext.autosummary` and `sphinx.ext.autodoc` from the "
             "module's docstrings and `__all__`.", "",
             "```{eval-rst}", ".. autosummary::", "   :toctree: api", ""]
    lines += [f"   {name}" for name in modules]
    lines += ["```", ""]
    return "\n".join(lines)


def generate(app, config=None) -> None:
    folder = Path(app.srcdir) / GENERATED
    api = folder / "api"
    modules = set(package_modules())
    if api.exists():  # stale stubs of modules that moved would fail to import
        for stub in api.glob("*.rst"):
            if stub.stem not in modules:
                stub.unlink()
    folder.mkdir(parents=True, exist_ok=True)
    _write(folder / "cli.md", cli_page())
    _write(folder / "scenario_keys.md", scenario_keys_page())
    _write(folder / "schemas.md", schemas_page())
    _write(folder / "grammar.md", grammar_page())
    _write(folder / "api.md", api_page())


def setup(app):
    app.connect("config-inited", generate)  # before the source files are found and autosummary reads them
    return {"version": "1", "parallel_read_safe": True, "parallel_write_safe": True}
