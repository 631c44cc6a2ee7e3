"""Language features met while writing real gearboxes (issue 13, section 5): floating members in
the ratios table, truncated and toleranced published ratios, alternative gears, the one-way
clutch direction check, neutrals with more than two DOF, stepped-pinion planetaries and dog
elements."""
from __future__ import annotations

import json

import pytest

from transgen.cli import main
from transgen.kinematics import check_gears, gear_table
from transgen.language import format_mechanism, parse_mechanism

FLOAT = """\
link A J=1
link B J=2
link X J=0.5
link Y J=0.5
gears G A B N1=20 N2=40
clutch KX X Y static=10 dynamic=8
brake BY Y static=10 dynamic=8
input A
output B
"""


def _write(tmp_path, text, name="m.mech"):
    path = tmp_path / name
    path.write_text(text)
    return str(path)


def test_ratios_table_names_the_floating_members(tmp_path, capsys):
    path = _write(tmp_path, FLOAT + "gear 1 = BY ratio=-2\n")
    assert main(["ratios", path, "--gears-only"]) == 0
    out = capsys.readouterr().out
    assert "floating" in out.splitlines()[2]
    row = [line for line in out.splitlines() if line.strip().startswith("1 ")][0]
    assert row.rstrip().endswith("X")
