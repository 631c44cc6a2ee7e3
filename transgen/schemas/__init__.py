"""JSON documents of transgen and the JSON Schemas that describe them.

Every machine-readable output (each command's ``--json``, the JSON result and matrices files)
is a *document*: a JSON object with

* ``schema``: its name and version, ``"transgen.<name>/<version>"`` (e.g. ``"transgen.modes/1"``);
  the version goes up when a field changes meaning or is removed (adding a field does not);
* ``transgen_version``: the version of transgen that wrote it;
* ``units``: the SI unit of every numeric field, by field name (``"1"`` for a pure number);

and then the command's own fields. The schemas ship as package data in this folder, one file per
document, ``<name>.json`` (``transgen.modes/1`` is ``modes.json``, whose ``$id`` is its file name
``modes.json``); each refers to ``document.json`` for the three keys above by the relative
``"$ref": "document.json"``, so that a validator given the folder (check-jsonschema, ajv with
``-r document.json``, :func:`validate`) resolves it offline, with no registry or network.

The pattern for a new command (or a new JSON file):

1. write ``transgen/schemas/<name>.json`` (draft 2020-12) with ``"$id": "<name>.json"``,
   ``"allOf": [{"$ref": "document.json"}]``, ``properties.schema.const`` =
   ``"transgen.<name>/1"`` and the command's own fields;
2. print the output with ``print_document("transgen.<name>/1", data, units)`` (or build it with
   :func:`json_document` and write it with :func:`transgen.export.write_json`);
3. add the command line to ``COMMANDS`` in ``tests/test_schemas.py``, which validates it with
   :func:`validate`.

:func:`validate` needs ``jsonschema`` (the ``test`` extra); nothing else here does.
"""
from __future__ import annotations

import json
import re
from functools import cache
from pathlib import Path

__all__ = ["SCHEMA_DIR", "schema_path", "load_schema", "json_document", "dumps", "print_document", "validate",
           "schema_names"]

SCHEMA_DIR = Path(__file__).resolve().parent

_NAME = re.compile(r"^transgen\.([a-z][a-z0-9_-]*(?:\.[a-z][a-z0-9_-]*)*)/(\d+)$")


def _parse(name: str) -> tuple[str, int]:
    match = _NAME.match(name)
    if not match:
        raise ValueError(f"not a transgen schema name: {name!r} (expected 'transgen.<name>/<version>')")
    return match.group(1), int(match.group(2))


def schema_path(name: str) -> Path:
    """The schema file of the document name ``name`` (``"transgen.modes/1"``); ValueError when
    transgen ships no schema of that name and version."""
    short, version = _parse(name)
    path = SCHEMA_DIR / f"{short}.json"
    if not path.is_file() or load_schema(path).get("properties", {}).get("schema", {}).get("const") != name:
        raise ValueError(f"no JSON Schema for {name!r} in {SCHEMA_DIR}")
    return path


@cache
def load_schema(path: Path | str) -> dict:
    """The JSON Schema in ``path`` (a file, or a document name as for :func:`schema_path`)."""
    if isinstance(path, str) and _NAME.match(path):
        path = schema_path(path)
    return json.loads(Path(path).read_text(encoding="utf-8"))


def schema_names() -> list[str]:
    """The document names of every shipped schema except the common ``document`` part."""
    names = []
    for path in sorted(SCHEMA_DIR.glob("*.json")):
        if path.name != "document.json":
            names.append(load_schema(path)["properties"]["schema"]["const"])
    return names


def json_document(schema: str, data: dict, units: dict[str, str]) -> dict:
    """The document ``data`` (a dict of the command's fields) headed by ``schema``,
    ``transgen_version`` and ``units`` (field name -> SI unit)."""
    from transgen import __version__

    schema_path(schema)  # only documents with a shipped schema
    return {"schema": schema, "transgen_version": __version__, "units": dict(units), **data}


def dumps(document: dict) -> str:
    """The document as indented JSON text (numpy numbers as floats)."""
    return json.dumps(document, indent=2, default=float)


def print_document(schema: str, data: dict, units: dict[str, str]) -> None:
    """Print ``json_document(schema, data, units)`` on standard output (a command's ``--json``)."""
    print(dumps(json_document(schema, data, units)))


def validate(document: dict) -> None:
    """Validate ``document`` against the schema its ``schema`` key names (jsonschema needed);
    raises ``jsonschema.ValidationError``."""
    import jsonschema
    from referencing import Registry, Resource

    # the shipped files by their file-name $id: the relative $ref "document.json" resolves among them
    resources = [Resource.from_contents(load_schema(p)) for p in sorted(SCHEMA_DIR.glob("*.json"))]
    registry = Registry().with_resources((r.contents["$id"], r) for r in resources)
    name = document.get("schema") if isinstance(document, dict) else None
    named = isinstance(name, str) and _NAME.match(name)
    schema = load_schema(schema_path(name) if named else SCHEMA_DIR / "document.json")
    jsonschema.Draft202012Validator(schema, registry=registry).validate(document)
