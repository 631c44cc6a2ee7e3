"""The README is short and true, and the docs pages that took over its content keep its checks:
the README has at most 200 lines, gives the test and docs commands that .ci/run runs and links to
pages that exist; the language page's worked example parses and gives the ratios it declares; the
scenario-file page names only tables the reader accepts and every turbodiesel key; the commands
page documents every command with examples that parse and name bundled things."""
from __future__ import annotations

import importlib
import pkgutil
import re
import shlex
from pathlib import Path

import pytest

from transgen import bundled_mechanisms, parse_mechanism
from transgen.cli import build_parser
from transgen.kinematics import check_gears

ROOT = Path(__file__).resolve().parent.parent
README = (ROOT / "README.md").read_text(encoding="utf-8")
DOCS = ROOT / "docs"
CI = (ROOT / ".ci" / "run").read_text(encoding="utf-8")


def _page(name: str) -> str:
    return (DOCS / name).read_text(encoding="utf-8")


def _blocks(text: str, lang: str) -> list[str]:
    return re.findall(r"^```" + lang + r"\n(.*?)^```", text, flags=re.S | re.M)


def _sim_module(*names: str):
    """The module of transgen.sim that defines ``names`` (modules of transgen.sim may move)."""
    import transgen.sim as sim

    for info in pkgutil.walk_packages(sim.__path__, "transgen.sim."):
        module = importlib.import_module(info.name)
        if all(n in vars(module) for n in names):
            return module
    raise LookupError(names)


def test_readme_is_short_and_gives_the_commands_ci_runs():
    assert len(README.splitlines()) <= 200
    assert 'pip install ".[test,distributed,fmu]" && pytest' in README
    assert re.search(r"^pytest\b", CI, flags=re.M)
    docs_command = re.search(r"sphinx-build -W --keep-going -b html docs \S+", README).group(0)
    assert "sphinx-build -W --keep-going" in CI and " docs " in CI, docs_command
    assert "transgen simulate ht740_improved" in README


def test_readme_links_point_to_pages_that_exist():
    for target in re.findall(r"\]\((docs/[^)#]+)", README):
        assert (ROOT / target).is_file(), target


def test_readme_example_parses_and_matches_its_ratios():
    example = re.search(r"^```\n(transmission \"Simpson.*?)^```", README, flags=re.S | re.M).group(1)
    mech = parse_mechanism(example, "README.md")
    assert check_gears(mech) == []
    assert [g.name for g in mech.gears] == ["1", "2", "3", "R"]


def test_worked_mech_example_parses_and_matches_its_ratios():
    example = re.search(r"^```\n(# Simpson.*?)^```", _page("reference/language.md"), flags=re.S | re.M).group(1)
    mech = parse_mechanism(example, "language.md")
    assert check_gears(mech) == []
    assert [g.name for g in mech.gears] == ["1", "2", "3", "R"]


def test_scenario_reference_uses_known_top_level_tables():
    top_keys = _sim_module("TOP_KEYS", "key_tree").TOP_KEYS
    block = next(b for b in _blocks(_page("reference/scenario_files.md"), "toml") if "[simulation]" in b)
    for table in re.findall(r"^\[\[?([a-z_]+)", block, flags=re.M):
        assert table in top_keys, table


def test_command_examples_parse_and_name_bundled_things():
    bundled_scenarios = _sim_module("bundled_scenarios", "load_scenario").bundled_scenarios
    parser = build_parser()
    block = next(b for b in _blocks(_page("guide/commands.md"), "console") if "transgen ratios mechanisms/ht740.mech" in b)
    for line in block.strip().splitlines():
        assert line.startswith("$ transgen "), line
        words = shlex.split(line[2:].split("#")[0].split(">")[0])
        args = parser.parse_args(words[1:])
        target = getattr(args, "file", None) or getattr(args, "scenario", None)
        if target and not target.startswith("mechanisms/"):
            assert target in bundled_mechanisms() or target in bundled_scenarios(), target


@pytest.mark.parametrize("command", ["check", "ratios", "graph", "modes", "matrices", "std", "lever", "simulate",
                                     "scenario new", "maps", "list", "sweep", "optimize", "fmu", "powerflow",
                                     "synthesize teeth", "synthesize table", "synthesize topology"])
def test_every_command_is_documented(command):
    assert f"transgen {command}" in _page("guide/commands.md")


def test_every_turbodiesel_parameter_and_input_key_is_documented():
    powertrain = _sim_module("ENGINE_KEYS", "GAS_KEYS", "GOVERNOR_KEYS", "PORT_KEYS", "SHAFT_KEYS", "SOLVER_KEYS")
    input_keys = _sim_module("INPUT_KEYS", "key_tree").INPUT_KEYS
    section = _page("reference/scenario_files.md")
    keys = set(input_keys)
    for name in ("ENGINE_KEYS", "PORT_KEYS", "SHAFT_KEYS", "GOVERNOR_KEYS", "GAS_KEYS", "SOLVER_KEYS"):
        keys |= set(getattr(powertrain, name))
    for key in sorted(keys):
        assert re.search(rf"\b{key}\b", section), key
