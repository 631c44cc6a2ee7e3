"""Names a user recognises (:mod:`transgen.names`): one rule names a mode by its gear, else its
declared mode name, else its locked set, and a shift by its two modes (``1-2``); every command
that shows a mode or a shift agrees with it. Generated scenarios name bundled data by name."""
from __future__ import annotations

import json
import re
from pathlib import Path

import pytest

import transgen
from transgen.cli import main
from transgen.language import load_mechanism, parse_mechanism
from transgen.names import ModeNames, mode_names, numbered, user_name

INSTALL = str(Path(transgen.__file__).resolve().parent.parent)


# ------------------------------------------------------------------------------------- the rule
def test_gears_neutrals_declared_modes_and_locked_sets():
    mech = load_mechanism("ht740")
    names = mode_names(mech)
    assert [names.name(g.engaged) for g in mech.gears] == ["1", "2", "3", "4", "R", "N"]
    assert names.name(("C5", "C1")) == "1"                      # any order
    assert names.name(("C1",)) == "C1" and names.name(()) == "none"  # the speed phase, all open
    assert names.name(("C4", "C1", "C2")) == "C1+C2+C4"         # the locked set in declaration order
    assert names.gear(("C1",)) is None and names.shift(("C1", "C5"), ("C1", "C4")) == "1-2"


def test_a_gear_with_a_one_way_clutch_beside_it_and_a_freewheel():
    mech = load_mechanism("zf3hp22_small")  # gear 1 = FWD OWC, gear 2 = FWD B2
    names = mode_names(mech)
    assert names.name(("FWD", "OWC")) == "1"
    assert names.name(("FWD",)) == "FWD"                        # the one-way clutch overruns: no gear
    assert names.name(("FWD", "B2", "OWC")) == "2"              # a one-way clutch locked besides


def test_a_declared_mode_keeps_its_name_and_a_name_means_one_locked_set():
    """ht740_tc: ``gear 1 = LU C1 C5`` and ``mode 1 = C1 C5``, ``mode 1L = LU C1 C5``."""
    mech = load_mechanism("ht740_tc")
    names = mode_names(mech)
    assert names.name(("C1", "C5")) == "1" and names.name(("LU", "C1", "C5")) == "1L"
    assert names.gear(("LU", "C1", "C5")) == "1" and names.name(("C1",)) == "SP"
    declared = {d.name: d.locked for d in mech.modes}
    assert all(names.name(locked) == name for name, locked in declared.items())


def test_the_names_travel_with_a_result():
    mech = load_mechanism("ht740_tc")
    back = ModeNames.from_dict(json.loads(json.dumps(mode_names(mech).to_dict())))
    for locked in [g.engaged for g in mech.gears] + [d.locked for d in mech.modes] + [("C2",), ()]:
        assert back.name(locked) == user_name(mech, locked)


def test_repeated_names_are_numbered():
    assert numbered(["1-2", "2-3", "2-3", "3-2", "2-3"]) == ["1-2", "2-3", "2-3#2", "3-2", "2-3#3"]


def test_matrices_of_every_combination_name_the_gears():
    """Issue 22: ``matrices --modes all`` called gear 1 ``M10`` with an empty label."""
    from transgen.statespace import state_space

    mech = load_mechanism("ht740")
    ss = state_space(mech, which="all")
    by_locked = {frozenset(m.locked): m for m in ss.modes}
    for gear in mech.gears:
        m = by_locked[frozenset(gear.engaged)]
        assert m.gear == gear.name and gear.name in m.label
    doc = ss.to_dict()
    assert {d["gear"] for d in doc["modes"]} >= {"1", "2", "3", "4", "R", "N"}


# --------------------------------------------------------------------- every command agrees
@pytest.fixture(scope="module")
def ht740_two_shifts():
    from transgen.sim import load_scenario

    scenario = load_scenario("ht740_improved", {"simulation.t_end": 10.5})
    return scenario, scenario.run()


def test_every_command_names_the_shifts_and_modes_alike(ht740_two_shifts, tmp_path, capsys):
    from transgen.sim.analysis.plots import shift_files
    from transgen.sim.analysis.report import report_dict, report_text, shift_report
    from transgen.sim.study.optimize import _select, plan_calibration
    from transgen.sim.study.task import result_scalars

    scenario, result = ht740_two_shifts
    mech = scenario.mechanism
    qualities = shift_report(result, scenario.shifts or None)
    names = [q.name for q in qualities]
    assert names == ["1-2", "2-3"]
    # the result's modes: each by the one rule, with its gear
    for span in result.modes:
        assert span.name == user_name(mech, span.locked) and span.gear == mode_names(mech).gear(span.locked)
    assert [m.name for m in result.modes] == ["1", "C1", "2", "C1", "3"]
    # the report (text and JSON), the plots' files, the sweep columns, the optimizer's shifts
    text = report_text(result, qualities)
    assert "Shift 1-2 (upshift)" in text and "Shift 2-3 (upshift)" in text and "1 [C1+C5] 0.000-" in text
    doc = report_dict(result, qualities)
    assert [s["name"] for s in doc["shifts"]] == names
    assert [m["gear"] for m in doc["modes"]] == ["1", None, "2", None, "3"]
    assert shift_files(qualities) == ["shift_1-2", "shift_2-3"]
    row = result_scalars(scenario, result)
    assert {c.split(".")[1] for c in row if c.startswith("shift.")} == set(names)
    _, plans = plan_calibration(scenario.path, {}, result, scenario)
    assert [p.name for p in plans] == names
    assert [p.name for p in _select(plans, ["2-3"], "x")] == ["2-3"]
    assert [p.name for p in _select(plans, ["1->2"], "x")] == ["1-2"]  # the old separator still accepted
    # modes, std and matrices: the gear beside each mode, joinable by the locked set
    assert main(["modes", "ht740", "--json"]) == 0
    modes = {frozenset(m["locked"]): m for m in json.loads(capsys.readouterr().out)["modes"]}
    assert main(["matrices", "ht740", "--modes", "all"]) == 0
    matrices = {frozenset(m["locked"]): m for m in json.loads(capsys.readouterr().out)["modes"]}
    assert main(["std", "ht740", "--json"]) == 0
    std = {frozenset(m["locked"]): m for m in json.loads(capsys.readouterr().out)["modes"]}
    for span in result.modes:
        key = frozenset(span.locked)
        assert modes[key]["gear"] == matrices[key]["gear"] == std[key]["gear"] == span.gear
    assert main(["std", "ht740"]) == 0
    assert "M1 (1) -> M5 (C1): unlock C5" in capsys.readouterr().out
    # the result files carry each mode's gear and locked set
    from transgen.sim.analysis.result_files import write_result

    write_result(result, tmp_path / "r.json")
    signals = json.loads((tmp_path / "r.json").read_text())
    assert signals["mode_names"] == ["1", "C1", "2", "3"]
    assert signals["mode_gears"] == ["1", "", "2", "3"] and signals["mode_locked"] == ["C1+C5", "C1", "C1+C4", "C1+C3"]


def test_a_shift_the_run_ends_in_is_named_by_the_gear_it_heads_for():
    from transgen.sim import load_scenario
    from transgen.sim.analysis.report import shift_report

    scenario = load_scenario("ht740_improved", {"simulation.t_end": 4.5})
    (q,) = shift_report(scenario.run())
    assert not q.completed and q.name == "1-2"


def test_the_drive_plot_names_the_gears(ht740_two_shifts):
    pytest.importorskip("matplotlib")
    from transgen.sim.analysis.plots import gear_track, plot_drive
    from transgen.sim.analysis.report import shift_report

    scenario, result = ht740_two_shifts
    t, level, ticks = gear_track(result)
    assert ticks == ["1", "2", "3"]
    assert level[0] == 1.0 and level[-1] == 3.0 and 1.0 < level[2] < 2.0  # the 1-2's speed phase between
    fig = plot_drive(result, shift_report(result))
    labels = [ax.get_ylabel() for ax in fig.axes]
    assert labels == ["vehicle speed [km/h]", "engine speed [rpm]", "gear"]
    assert [x.get_text() for x in fig.axes[2].get_yticklabels()] == ticks
    speed = fig.axes[0].get_lines()[0].get_ydata()
    assert max(speed) == pytest.approx(max(result["vehicle_speed"]) * 3.6)


def test_an_old_sweep_table_is_read_with_its_numbered_columns(tmp_path):
    from transgen.sim.study.plots import sweep_metrics
    from transgen.sim.study.table import SweepTable, column_shift, column_unit

    rows = [{"key": "a", "p": 1.0, "success": True, "message": "", "wall_time": 0.1, "shift1.torque_hole": 5.0,
             "shift1.energy.C4": 10.0}]
    table = SweepTable.from_csv(SweepTable(rows, ["p"]).to_csv(tmp_path / "old.csv"))
    assert sweep_metrics(table) == ["shift1.torque_hole"] and column_unit("shift1.energy.C4") == "J"
    assert column_shift("shift.2-3#2.energy.C4") == ("2-3#2", ["energy", "C4"])
    assert column_shift("shifts.events") is None


# ------------------------------------------------------------------- no paths of this machine
def _paths(text: str) -> list[str]:
    """Every absolute path in the TOML values (not in comments) of ``text``."""
    values = [line.split("#")[0] for line in text.splitlines()]
    return [v for v in values if re.search(r'"(/|[A-Za-z]:\\\\)', v)] + [v for v in values if INSTALL in v]


def test_scenario_new_names_bundled_data_by_name_and_a_users_file_relatively(tmp_path, monkeypatch, capsys):
    from transgen.library import bundled_path

    monkeypatch.chdir(tmp_path)
    installed = str(bundled_path("simple2"))
    (tmp_path / "mine.mech").write_text(Path(installed).read_text())
    (tmp_path / "out").mkdir()
    for given, out, ref in (("simple2", "a.toml", "simple2"), (installed, "b.toml", "simple2"),
                            ("mine.mech", "out/c.toml", "../mine.mech")):
        assert main(["scenario", "new", given, "-o", out]) == 0
        text = (tmp_path / out).read_text()
        assert _paths(text) == [] and f'mechanism = "{ref}"' in text
        assert 'converter = "torque_converter_car"' in text
    capsys.readouterr()
    assert main(["scenario", "keys", "out/c.toml", "--json"]) == 0  # it loads from where it was written
    keys = json.loads(capsys.readouterr().out)["keys"]
    assert keys["input.converter"] == "torque_converter_car"


def test_a_bundled_converter_by_name_is_the_bundled_file(tmp_path, monkeypatch):
    from transgen.sim import scenario_files
    from transgen.sim.scenario.library import bundled_data

    monkeypatch.chdir(tmp_path)
    assert main(["scenario", "new", "zf3hp22_small", "-o", "s.toml"]) == 0
    assert str(bundled_data("torque_converter_car")) in scenario_files(tmp_path / "s.toml")
    assert bundled_data("torque_converter_car.toml") == bundled_data("torque_converter_car")
    assert bundled_data("../torque_converter_car") is None and bundled_data("no_such_file") is None


def test_a_bundled_map_by_name_is_the_bundled_file():
    from transgen.sim import load_scenario

    scenario = load_scenario("ht740_turbo", {"input.compressor_map": "we_compressor", "input.turbine_map": "we_turbine"})
    assert scenario.title


def test_scenario_copy_of_every_bundled_scenario_holds_no_machine_path(tmp_path):
    from transgen.sim.scenario.library import bundled_scenarios
    from transgen.sim.scenario.copy import copy_scenario

    for name in bundled_scenarios():
        for path in copy_scenario(name, tmp_path / name):
            assert _paths(path.read_text()) == [], path


def test_a_mechanism_text_without_a_file_is_named_by_its_locked_sets():
    mech = parse_mechanism('transmission "t"\nlink A J=1\nlink B J=1\nclutch K A B static=10 dynamic=8\ninput A\noutput B\n')
    assert user_name(mech, ("K",)) == "K" and user_name(mech, ()) == "none"
