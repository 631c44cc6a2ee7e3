"""A gearbox that models its own torque converter (transgen.own_converter): the rule on the bundled
mechanisms and on variants that break one condition each, every command reading the same fact,
``scenario new`` adding no inertia of its own, the lock-up no shift element, and the launch of
ht740_tc through every gear acceptable by issue 21's rule."""
from __future__ import annotations

import math
import re
import warnings

import pytest

from transgen import bundled_mechanisms, load_mechanism, parse_mechanism
from transgen.cli import main
from transgen.own_converter import OwnConverter, converter_drive, own_converter
from transgen.sim.control.schedule import gear_swap
from transgen.sim.derive.calibration import handover, synchronised_inertia
from transgen.sim.derive.launch import VEHICLES, derive_launch, launch_scenario
from transgen.sim.model.components import Driveline, EngineOnLink, EngineWithConverter
from transgen.sim.scenario.load import load_scenario

TC = OwnConverter(pump="E", turbine="L1", lockup="LU", pump_torque="Tp", turbine_torque="Tt")


def _tc_text() -> str:
    return load_mechanism("ht740_tc").text


def test_the_rule_on_the_bundled_mechanisms():
    found = {name: own_converter(load_mechanism(name)) for name in bundled_mechanisms()}
    assert found.pop("ht740_tc") == TC
    assert found and all(v is None for v in found.values()), {k: v for k, v in found.items() if v}


@pytest.mark.parametrize("pattern, new", [
    (r"^(gear \w+ = )LU ", r"\1"),                                  # the gears without the lock-up: none is a
                                                                    # forward gear (the pump floats)
    (r"^torque Tp E ", "torque Tp L2 "),                              # no converter torque on the pump
    (r"^torque Tt L1 ", "torque Tt L2 "),                             # none on the turbine
    (r"^input E", "input E\nbrake BE E static=100 dynamic=80"),      # the pump touches another element
    (r"^clutch LU E  L1", "clutch LU E  L2"),                         # the lock-up to a link without Tt
])
def test_each_condition_is_needed(pattern, new):
    text, n = re.subn(pattern, new, _tc_text(), flags=re.M)
    assert n >= 1
    assert own_converter(parse_mechanism(text, "variant.mech")) is None


def test_the_lockup_is_no_shift_element():
    table = {"1": ("C1", "C5"), "2": ("LU", "C1", "C4"), "3": ("LU", "C1", "C3")}
    assert gear_swap(table, "1", "2") == (("C4", "LU"), ("C5",))
    assert gear_swap(table, "1", "2", lockup=frozenset({"LU"})) == (("C4",), ("C5",))
    assert gear_swap(table, "2", "3", lockup=frozenset({"LU"})) == (("C3",), ("C4",))
    assert converter_drive(("LU", "C1", "C5"), TC) == ("C1", "C5") and converter_drive(("C1",), None) == ("C1",)


def test_the_turbine_side_is_the_gearbox_without_its_converter():
    """ht740_tc is ht740.mech plus the pump link E and the lock-up: seen from the turbine, a shift
    synchronises exactly the inertia ht740's does, and the handover is ht740's (the pump's 2.5
    kg*m^2 stays with the engine behind the open converter)."""
    tc, plain = load_mechanism("ht740_tc"), load_mechanism("ht740")
    for a, b in ((("C1", "C5"), ("C1", "C4")), (("C1", "C4"), ("C1", "C3")), (("C1", "C3"), ("C1", "C2"))):
        j_tc = synchronised_inertia(tc, ("LU",) + a, ("LU",) + b)
        assert j_tc == pytest.approx(synchronised_inertia(plain, a, b), rel=1e-12)
        assert j_tc < tc.link("E").inertia  # the pump is not in it
        on = {b[1]: 0.5}
        lam_tc, before_tc = handover(tc, ("LU",) + a, on, (a[1],), 800.0, 2.0)
        lam, before = handover(plain, a, on, (a[1],), 800.0, 2.0)
        assert lam_tc == pytest.approx(lam, rel=1e-9) and before_tc[a[1]] == pytest.approx(before[a[1]], rel=1e-9)


@pytest.fixture(scope="module")
def tc_launch(tmp_path_factory):
    mech = load_mechanism("ht740_tc")
    launch = derive_launch(mech, "truck")
    path = tmp_path_factory.mktemp("tc") / "launch.toml"
    path.write_text(launch_scenario(mech, "truck", "ht740_tc", launch), encoding="utf-8")
    return mech, launch, path


def test_scenario_new_adds_no_inertia(tc_launch):
    """The powertrain's inertias are the .mech's links and the driveline's: no J_engine (the
    engine map drives the pump link E, whose inertia is the engine's)."""
    mech, launch, path = tc_launch
    scenario = load_scenario(path)
    pt = scenario.powertrain
    assert not any(isinstance(c, EngineWithConverter) for c in pt.components)
    (engine,) = [c for c in pt.components if isinstance(c, EngineOnLink)]
    assert pt.transmission.links[engine.link] == "E"
    assert engine.idle == pytest.approx(VEHICLES["truck"].idle_rpm * math.pi / 30)
    (driveline,) = [c for c in pt.components if isinstance(c, Driveline)]
    total = float(sum(pt.transmission.inertia)) + driveline.J_out
    assert total == pytest.approx(sum(k.inertia for k in mech.links) + VEHICLES["truck"].output_inertia, rel=1e-12)
    # every command reads the same converter: the scenario's [converter], the loader's lock-up and
    # gearbox input, the schedule's lock-up, the launch's gears (no LU torque share, no LU sizing)
    conv = scenario.data["converter"]
    assert (conv["pump"], conv["turbine"], conv["pump_torque"], conv["turbine_torque"]) == ("E", "L1", "Tp", "Tt")
    assert scenario.lockup == ["LU"] and scenario.gearbox_input == "L1"
    assert pt.controllers[0].lockup == frozenset({"LU"})
    assert scenario.data["elements"]["LU"]["apply"] == 0.0
    assert all("LU" not in g.torque_factors for g in launch.gears) and all(c.element != "LU" for c in launch.sizing)
    assert all("LU" not in s.oncoming + s.offgoing for s in launch.shifts)


def test_a_launch_through_every_gear_is_acceptable():
    from transgen.sim.derive.acceptance import launch_acceptance

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        launch, verdicts, result = launch_acceptance(load_mechanism("ht740_tc"), "truck")
    assert launch.order == ("1", "2", "3", "4")
    assert [v.name for v in verdicts] == ["1-2", "2-3", "3-4"]
    assert all(v.acceptable for v in verdicts), [v.to_dict() for v in verdicts]
    assert result.meta["gearbox_input"] == "L1"
    assert max(result["apply_LU"]) == 0.0 and max(result["locked_LU"]) == 0.0  # the lock-up open throughout
    assert min(result["w_E"]) > 0.9 * VEHICLES["truck"].idle_rpm * math.pi / 30  # the governor holds idle


def test_maneuvers_are_refused_with_the_lockup_named(capsys):
    assert main(["scenario", "new", "ht740_tc", "--vehicle", "truck", "--maneuver", "kickdown"]) == 2
    err = capsys.readouterr().err
    assert "ht740_tc.mech:" in err and ": error: --maneuver kickdown is not supported" in err
    assert "lock-up LU" in err and "Traceback" not in err
