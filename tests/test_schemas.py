"""Every JSON output of every command is a document named by its ``schema``, with
``transgen_version`` and ``units``, and valid against the JSON Schema shipped for it; every
numeric field has a unit in ``units``; every shipped schema is used by some command here."""
from __future__ import annotations

import json
from pathlib import Path

import jsonschema
import pytest

from transgen import __version__
from transgen.cli import main
from transgen.schemas import SCHEMA_DIR, json_document, load_schema, schema_names, schema_path, validate

_STEPPED = Path(__file__).parent / "data" / "stepped_test2.mech"

#: each command line with JSON on standard output, and the schema it must carry
COMMANDS = [
    (["check", "ht740", "--json"], "transgen.check/1"),
    (["check", "zf8hp70", "--json"], "transgen.check/1"),
    (["ratios", "ht740", "--json"], "transgen.ratios/1"),
    (["ratios", "zf8hp70", "--gears-only", "--json"], "transgen.ratios/1"),
    (["modes", "ht740", "--json"], "transgen.modes/1"),
    (["modes", "simple2", "--all", "--json"], "transgen.modes/1"),
    (["matrices", "ht740", "--coords", "L1,L6"], "transgen.matrices/1"),
    (["matrices", "simple2", "--symbolic"], "transgen.matrices/1"),
    (["matrices", "simple2", "--modes", "all"], "transgen.matrices/1"),
    (["matrices", "ht740", "--list-coordinates", "--json"], "transgen.coordinates/1"),
    (["std", "simple2", "--json"], "transgen.std/1"),
    (["list", "--json"], "transgen.list/1"),
    (["powerflow", "zf8hp70", "--json"], "transgen.powerflow/1"),
    (["powerflow", "hsw_ravigneaux4", "--input-rpm", "6000", "--max-slip-rpm", "8000", "--design-torque", "400",
      "--json"], "transgen.powerflow/1"),
    (["powerflow", "mb722_6_w5a580_2004", "--coast", "--json"], "transgen.powerflow/1"),
    (["lever", "zf8hp70", "--json"], "transgen.lever/1"),
    (["simulate", "--list", "--json"], "transgen.scenarios/1"),
    (["simulate", "simple2_upshift", "--json"], "transgen.simulate/1"),
    (["simulate", "simple2_upshift", "--set", 'losses.kinds=["drag", "pump", "mesh"]', "--report", "--json"],
     "transgen.simulate/1"),
    (["simulate", "simple2_upshift", "--compare-model", "compliant", "--json"], "transgen.simulate/1"),
    (["simulate", "ht740_turbo", "--json"], "transgen.simulate/1"),
    (["scenario", "new", "ht740", "--vehicle", "truck", "--json"], "transgen.scenario-new/1"),
    (["maps", "we_compressor", "--json"], "transgen.maps/1"),
    (["maps", "we_turbine", "--json"], "transgen.maps/1"),
    (["scenario", "keys", "ht740_improved", "--json"], "transgen.scenario-keys/1"),
    (["sweep", "ht740_improved", "--grid", "simulation.t_end=4.6", "--grid", "driveline.vehicle_mass=20000,36000",
      "--workers", "1", "-o", "results.csv", "--json"], "transgen.sweep/1"),
    (["optimize", "simple2_upshift", "--workers", "1", "--evaluations", "10", "--population", "9", "--allow-bindup",
      "--max-flare", "1000", "-o", "tuned.toml", "--json"], "transgen.optimize/1"),
    # the language's constructs through every command: stepped pinions, dogs, alternative gears
    (["check", str(_STEPPED), "--json"], "transgen.check/1"),
    (["powerflow", str(_STEPPED), "--json"], "transgen.powerflow/1"),
    (["powerflow", "zf9hp48", "--input-rpm", "2000", "--max-slip-rpm", "6000", "--design-torque", "480", "--json"],
     "transgen.powerflow/1"),
    (["powerflow", "mb7g_tronic", "--json"], "transgen.powerflow/1"),
    (["powerflow", "zf8hp70", "--losses", "--json"], "transgen.losses/1"),
    (["powerflow", "ht740", "--losses", "--map", "--map-speed", "600:2400:4", "--map-torque", "100:1500:3",
      "--coast", "--json"], "transgen.losses/1"),
    (["lever", str(_STEPPED), "--json"], "transgen.lever/1"),
    (["lever", "zf9hp48", "--json"], "transgen.lever/1"),
    (["synthesize", "table", "zf9hp48", "--top", "2", "--json"], "transgen.synthesis_table/1"),
]

#: keys whose values are names, counts of things or free-form data, not measured quantities
NO_UNIT = {"units", "columns", "stats", "meta", "invariants", "provenance",
           "keys"}  # scenario keys: in the units of the scenario file (README "Scenario files")


def _missing_units(doc) -> list[str]:
    """Numeric fields whose key (or the key of an enclosing field, e.g. ``energy`` for
    ``energy.C1``) has no unit in ``units``."""
    units, missing = doc["units"], []

    def walk(x, path, unit_found):
        if isinstance(x, dict):
            for k, v in x.items():
                if k not in NO_UNIT:
                    walk(v, path + [k], unit_found or k in units)
        elif isinstance(x, list):
            for v in x:
                walk(v, path, unit_found)
        elif isinstance(x, (int, float)) and not isinstance(x, bool) and not unit_found:
            missing.append(".".join(path))

    walk(doc, [], False)
    return sorted(set(missing))


@pytest.mark.parametrize("argv, schema", COMMANDS, ids=[" ".join(a) for a, _ in COMMANDS])
def test_every_json_output_is_a_valid_document(argv, schema, capsys, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert main(argv + (["--quiet"] if argv[0] == "simulate" and "--list" not in argv else [])) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["schema"] == schema and doc["transgen_version"] == __version__
    validate(doc)
    assert _missing_units(doc) == []


def test_a_failed_run_prints_a_valid_document(capsys, monkeypatch):
    from transgen.sim.scenario.load import Scenario

    run = Scenario.run

    def failing(self, *args, **kwargs):
        result = run(self, *args, **kwargs)
        result.success, result.message = False, "stopped at t=4.5 s (test)"
        return result

    monkeypatch.setattr(Scenario, "run", failing)
    assert main(["simulate", "simple2_upshift", "--json", "--quiet"]) == 1
    doc = json.loads(capsys.readouterr().out)
    validate(doc)
    assert doc["schema"] == "transgen.simulate/1" and doc["success"] is False and "report" not in doc


@pytest.mark.parametrize("suffix, schema", [(".json", "transgen.signals/1")])
def test_the_json_result_file_is_a_valid_document(suffix, schema, tmp_path):
    out = tmp_path / f"r{suffix}"
    assert main(["simulate", "simple2_upshift", "--quiet", "-o", str(out)]) == 0
    doc = json.loads(out.read_text())
    validate(doc)
    assert doc["schema"] == schema and _missing_units({**doc, "columns": {}}) == []


def test_the_json_matrices_file_is_the_printed_document(tmp_path, capsys):
    out = tmp_path / "m.json"
    assert main(["matrices", "ht740", "-o", str(out)]) == 0
    capsys.readouterr()
    assert main(["matrices", "ht740"]) == 0
    printed = json.loads(capsys.readouterr().out)
    written = json.loads(out.read_text())
    validate(written)
    assert written == printed


def test_every_shipped_schema_is_a_valid_schema_and_used():
    # transgen.fmu/1: tests/test_fmu.py validates it (it needs fmpy and a C compiler)
    used = {schema for _, schema in COMMANDS} | {"transgen.signals/1", "transgen.fmu/1"} | SYNTHESIS_SCHEMAS
    assert set(schema_names()) == used
    for path in SCHEMA_DIR.glob("*.json"):
        jsonschema.Draft202012Validator.check_schema(load_schema(path))
    for name in schema_names():
        assert load_schema(name)["properties"]["schema"]["const"] == name


def test_a_document_that_breaks_its_schema_is_refused(capsys):
    assert main(["modes", "simple2", "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    for broken in ({k: v for k, v in doc.items() if k != "units"},                  # the common head
                   {**doc, "transgen_version": 1},
                   {**doc, "modes": [{**doc["modes"][0], "dof": "one"}]},            # the command's part
                   {**doc, "schema": "transgen.modes/2"}):
        with pytest.raises((jsonschema.ValidationError, ValueError)):
            validate(broken)


def test_documents_only_for_shipped_schemas():
    with pytest.raises(ValueError, match="no JSON Schema"):
        json_document("transgen.nothing/1", {}, {})
    with pytest.raises(ValueError, match="not a transgen schema name"):
        schema_path("modes")
    assert schema_path("transgen.modes/1") == SCHEMA_DIR / "modes.json"


SYNTHESIS_SCHEMAS = {"transgen.synthesis_teeth/1", "transgen.synthesis_table/1",
                     "transgen.synthesize.topology/1"}  # the last validated in tests/test_topology.py


def test_synthesis_outputs_are_valid_documents(capsys, tmp_path):
    """``synthesize teeth`` needs a file with unknown teeth (none is bundled: every other command
    refuses them), ``synthesize table`` one without a gear table."""
    import re

    from transgen.library import bundled_path

    text = bundled_path("zf8hp70.mech").read_text()
    unknown = tmp_path / "unknown.mech"
    unknown.write_text(re.sub(r"Ns=23 Nr=85", "Ns=? Nr=?", text))
    no_table = tmp_path / "no_table.mech"
    no_table.write_text("\n".join(line for line in text.split("\n") if not line.startswith("gear ")))
    for argv, schema in ((["synthesize", "teeth", str(unknown), "--json"], "transgen.synthesis_teeth/1"),
                         (["synthesize", "table", str(no_table), "--forward", "8", "--json"],
                          "transgen.synthesis_table/1")):
        assert main(argv) == 0
        doc = json.loads(capsys.readouterr().out)
        assert doc["schema"] == schema
        validate(doc)
        assert _missing_units(doc) == []
