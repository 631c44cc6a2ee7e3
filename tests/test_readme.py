"""The README's examples work: its .mech worked example parses and gives the ratios it declares,
its scenario reference lists only keys the reader accepts, its commands name real things."""
from __future__ import annotations

import re
import shlex
from pathlib import Path

import pytest

from transgen import bundled_mechanisms, parse_mechanism
from transgen.cli import build_parser
from transgen.kinematics import check_gears
from transgen.sim.scenario.load import bundled_scenarios

README = (Path(__file__).resolve().parent.parent / "README.md").read_text(encoding="utf-8")


def _blocks(lang: str) -> list[str]:
    return re.findall(r"^```" + lang + r"\n(.*?)^```", README, flags=re.S | re.M)


def test_worked_mech_example_parses_and_matches_its_ratios():
    example = re.search(r"^```\n(# Simpson.*?)^```", README, flags=re.S | re.M).group(1)
    mech = parse_mechanism(example, "README.md")
    assert check_gears(mech) == []
    assert [g.name for g in mech.gears] == ["1", "2", "3", "R"]


def test_scenario_reference_uses_known_top_level_tables():
    from transgen.sim.scenario.schema import TOP_KEYS as _TOP_KEYS

    block = next(b for b in _blocks("toml") if "[simulation]" in b)
    for table in re.findall(r"^\[\[?([a-z_]+)", block, flags=re.M):
        assert table in _TOP_KEYS, table


def test_command_examples_parse_and_name_bundled_things():
    parser = build_parser()
    sh = next(b for b in _blocks("sh") if "transgen ratios mechanisms/ht740.mech" in b)
    for line in sh.strip().splitlines():
        words = shlex.split(line.split("#")[0].split(">")[0])
        assert words[0] == "transgen"
        args = parser.parse_args(words[1:])
        target = getattr(args, "file", None) or getattr(args, "scenario", None)
        if target and not target.startswith("mechanisms/"):
            assert target in bundled_mechanisms() or target in bundled_scenarios(), target


@pytest.mark.parametrize("command", ["check", "ratios", "graph", "modes", "matrices", "std", "lever", "simulate", "scenario new", "maps", "list", "sweep", "optimize", "fmu"])
def test_every_command_is_documented(command):
    assert f"transgen {command}" in README


def test_every_turbodiesel_parameter_and_input_key_is_documented():
    from transgen.sim.model.powertrain import ENGINE_KEYS, GAS_KEYS, GOVERNOR_KEYS, PORT_KEYS, SHAFT_KEYS, SOLVER_KEYS
    from transgen.sim.scenario.schema import INPUT_KEYS

    section = README[README.index("## Scenario files"):README.index("### Starting with a new gearbox")]
    for key in sorted(ENGINE_KEYS | PORT_KEYS | SHAFT_KEYS | GOVERNOR_KEYS | GAS_KEYS | SOLVER_KEYS | INPUT_KEYS):
        assert re.search(rf"\b{key}\b", section), key
