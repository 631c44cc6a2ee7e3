"""Dog clutches and dog brakes (``dog NAME LINK1 [LINK2] [static=...]``): open or locked only,
engaging only at synchronous speed, no slipping torque; in the language, the gear table, the
modes, the STD and the simulator's mode decision."""
from __future__ import annotations

import math
import textwrap

import numpy as np
import pytest

from transgen.errors import MechValidationError
from transgen.kinematics import analyze
from transgen.language import format_mechanism, parse_mechanism

DOG = """\
transmission "dog test"
link A J=0.5
link B J=2.0
dog D A B
clutch C A B static=100 dynamic=80
input A
output B
"""


def test_dog_parses_as_an_element_without_slipping_torque():
    m = parse_mechanism(DOG + "dog DB B static=500\n")
    d, db = m.element("D"), m.element("DB")
    assert (d.kind, d.link2, d.static, d.dynamic) == ("dog", "B", math.inf, 0.0)
    assert (db.kind, db.link2, db.static) == ("dog", "housing", 500.0)
    assert parse_mechanism(format_mechanism(m)) == m
    assert analyze(m, ("D",)).ratio == pytest.approx(1.0)
    assert analyze(m, ("DB",)).kind == "other"


@pytest.mark.parametrize("extra, message", [
    ("dog D2 A B dynamic=5", "unknown parameter 'dynamic' for 'dog'"),
    ("dog D2 A B static=-5", "must not be negative"),
    ("dog D2 A A", "connects 'A' to itself"),
    ("dog C A B", "duplicate name 'C'"),
    ("gear 1 = DX", "unknown shift element 'DX'"),
])
def test_dog_errors(extra, message):
    with pytest.raises(MechValidationError) as exc:
        parse_mechanism(DOG + extra + "\n")
    assert message in str(exc.value)


def test_dogs_in_gears_modes_and_std():
    from transgen.modes import mode_models
    from transgen.std import state_transition_diagram

    m = parse_mechanism(DOG + "dog DB B\ngear 1 = D\n")
    models = mode_models(m, "all")
    assert all(mm.problem == "" for mm in models if mm.kind != "tie-up")
    std = state_transition_diagram(m)
    conditions = {t.element: t.condition for t in std.transitions}
    assert "slip of DB reaches 0 (synchronous) while DB is engaged" in conditions["DB"]
    unlock = [t.condition for t in std.transitions if t.event == "unlock" and t.element == "D"]
    assert unlock and "DB" not in unlock[0] and "is disengaged" in unlock[0]


def _run(tmp_path, mech: str, scenario: str):
    from transgen.sim.scenario.load import load_scenario

    (tmp_path / "dog.mech").write_text(mech)
    path = tmp_path / "s.toml"
    path.write_text('mechanism = "dog.mech"\n' + textwrap.dedent(scenario))
    return load_scenario(path).run()


def test_an_engaged_dog_waits_for_synchronism_then_locks(tmp_path):
    # A driven from rest by 20 N*m, B turning at 10 rad/s: the dog is engaged from the start but
    # transmits nothing until A catches up (w_A = 40 t: t = 0.25 s), then locks
    r = _run(tmp_path, DOG, """
        [simulation]
        t_end = 1.0
        [initial]
        speeds = { A = 0.0, B = 10.0 }
        [input]
        type = "torque"
        torque = 20.0
        [driveline]
        output_torque = 0.0
        [elements.D]
        apply = 1.0
        [elements.C]
        apply = 0.0
        """)
    assert r.success, r.message
    locks = [e for e in r.events if e.kind == "lock"]
    assert [e.elements for e in locks] == [("D",)] and locks[0].t == pytest.approx(0.25, abs=1e-6)
    s, t = r.signals, r.time
    before, after = t < 0.249, t > 0.251
    assert np.all(s["t_D"][before] == 0.0) and np.allclose(s["w_B"][before], 10.0)
    assert np.allclose(s["t_D"][after], 20.0 * 2.0 / 2.5)  # B's share of the input torque
    assert np.allclose(s["w_A"][after], s["w_B"][after])


def test_dog_engaged_at_synchronism_behind_a_friction_clutch_takes_over(tmp_path):
    r = _run(tmp_path, DOG, """
        [simulation]
        t_end = 3.0
        [initial]
        speeds = { A = 0.0, B = 0.0 }
        [input]
        type = "torque"
        torque = 30.0
        [driveline]
        output_torque = 5.0
        [elements.C]
        apply = { type = "table", t = [0.0, 0.5, 0.6, 2.0, 2.1], value = [0.0, 0.0, 1.0, 1.0, 0.0] }
        [elements.D]
        apply = { type = "table", t = [0.0, 1.5, 1.501], value = [0.0, 0.0, 1.0] }
        """)
    assert r.success, r.message
    assert [(e.kind, e.elements) for e in r.events if e.kind != "start"] == [
        ("lock", ("C",)), ("lock", ("D",)), ("unlock", ("C",))]
    k = int(np.searchsorted(r.time, 2.5))
    assert r.signals["t_C"][k] == 0.0 and r.signals["t_D"][k] == pytest.approx(25.0)


def test_a_dog_over_its_static_capacity_stops_the_run(tmp_path):
    r = _run(tmp_path, DOG.replace("dog D A B", "dog D A B static=10"), """
        [simulation]
        t_end = 2.0
        [initial]
        speeds = { A = 0.0, B = 0.0 }
        [input]
        type = "torque"
        torque = { type = "table", t = [0.0, 1.0, 1.1, 2.0], value = [5.0, 5.0, 60.0, 60.0] }
        [driveline]
        output_torque = 0.0
        [elements.D]
        apply = 1.0
        [elements.C]
        apply = 0.0
        """)
    assert not r.success
    assert "dog element D would have to hold more than its static capacity 10 N*m" in r.message
    # it stopped where the locked torque reached 10 N*m (B's share 2/2.5 of the input torque)
    assert r.time[-1] == pytest.approx(1.0 + 0.1 * (12.5 - 5.0) / 55.0, abs=1e-4)


def test_the_compliant_model_refuses_dogs(tmp_path):
    from transgen.errors import SimulationError
    from transgen.sim.scenario.load import load_scenario

    (tmp_path / "dog.mech").write_text(DOG)
    path = tmp_path / "s.toml"
    path.write_text('mechanism = "dog.mech"\n[simulation]\nt_end = 0.1\nmodel = "compliant"\n[initial]\n'
                    'speeds = { A = 0.0, B = 0.0 }\n[input]\ntype = "torque"\ntorque = 1.0\n[driveline]\n'
                    'output_torque = 0.0\n[elements.D]\napply = 0.0\n[elements.C]\napply = 0.0\n')
    try:
        r = load_scenario(path).run()
    except SimulationError as exc:
        message = str(exc)
    else:
        assert not r.success
        message = r.message
    assert "compliant clutch model has no dog elements (D" in message


def test_zf9hp48_reproduces_the_published_ratios_with_its_dogs():
    from transgen.kinematics import check_gears, gear_table
    from transgen.language import load_mechanism
    from transgen.statics import check_oneways

    m = load_mechanism("zf9hp48")
    assert [e.name for e in m.elements if e.kind == "dog"] == ["A", "F"]
    assert m.element("F").link2 == "housing" and m.element("A").static == math.inf
    table = gear_table(m, all_combinations=False)
    published = {"1": 4.700, "2": 2.842, "3": 1.909, "4": 1.382, "5": 1.000, "6": 0.808, "7": 0.699,
                 "8": 0.580, "9": 0.479, "R": -3.805}
    assert {r.name: round(r.ratio, 3) for r in table.gears} == published
    assert all(r.matches_published for r in table.gears) and check_gears(m) == [] and check_oneways(m) == []
    assert table.spread == pytest.approx(9.816, abs=5e-4)  # W9HP: nominal span 9.808 from rounded ratios


def test_dog_capacity_is_a_settable_parameter_and_unlimited_is_null():
    from transgen.language import load_mechanism
    from transgen.parameters import mechanism_parameters, with_parameter

    m = load_mechanism("zf9hp48")
    params = mechanism_parameters(m)
    assert params["A.static"] is None and params["B.static"] > 0
    changed = with_parameter(m, "A", "static", 900.0)
    assert changed.element("A").static == 900.0 and changed.element("A").kind == "dog"


def test_zf9hp48_launch_through_the_dog_shifts(tmp_path):
    """The derived launch scenario runs the 9HP from rest through 1-2-3-4-5: its dog brake F holds
    in 1st to 4th and is released in the 4-5 shift, when B takes over."""
    from transgen.language import load_mechanism
    from transgen.sim.derive.launch import launch_scenario
    from transgen.sim.scenario.load import load_scenario

    path = tmp_path / "zf9.toml"
    path.write_text(launch_scenario(load_mechanism("zf9hp48"), mechanism_ref="zf9hp48"))
    r = load_scenario(path, {"simulation.t_end": 16.0, "simulation.output_dt": 0.05}).run()
    assert r.success, r.message
    events = [(e.kind, e.elements) for e in r.events if e.kind in ("lock", "unlock")]
    assert events == [("unlock", ("D",)), ("lock", ("C",)), ("unlock", ("C",)), ("lock", ("B",)),
                      ("unlock", ("B",)), ("lock", ("E",)), ("unlock", ("F",)), ("lock", ("B",))]
    assert np.all(r.signals["locked_A"] == 1.0)  # the dog clutch A holds throughout 1st-5th


def test_std_holding_range_of_a_dog_beside_a_clutch():
    from transgen.std import state_transition_diagram

    m = parse_mechanism(DOG + "gear 1 = C D\n")
    std = state_transition_diagram(m)
    both = [t for t in std.transitions if t.element == "D+C" or t.element == "C+D"]
    assert both and "[-inf, inf]" in both[0].condition


def test_zf9hp48_power_on_downshift_engages_the_dog_brake_at_synchronism(tmp_path):
    """5-4 under drive torque: B lets go, the input speeds up, and the dog brake F, engaged from the
    start of the shift, transmits nothing until the common sun 3/4 it holds comes to rest; then it
    locks (no torque at nonzero slip, no slip after)."""
    from transgen.sim.scenario.load import load_scenario

    path = tmp_path / "down.toml"
    path.write_text(textwrap.dedent("""
        mechanism = "zf9hp48"
        [simulation]
        t_end = 3.0
        [initial]
        gear = "5"
        speeds = { OUT = 150.0 }
        [input]
        type = "torque"
        torque = 60.0
        [driveline]
        output_inertia = 5.0
        stiffness = 8000.0
        damping = 150.0
        [shifts]
        events = [ { t = 1.0, from = "5", to = "4" } ]
        """))
    r = load_scenario(path).run()
    assert r.success, r.message
    events = [(e.kind, e.elements) for e in r.events if e.kind in ("lock", "unlock")]
    assert events == [("unlock", ("B",)), ("lock", ("F",))]
    t_lock = next(e.t for e in r.events if e.kind == "lock")
    s, t = r.signals, r.time
    engaged_slipping = (s["apply_F"] > 0) & (t < t_lock)
    assert engaged_slipping.any() and np.all(s["t_F"][engaged_slipping] == 0.0)
    assert np.all(np.abs(s["slip_F"][engaged_slipping]) > 0)
    after = t > t_lock + 1e-6
    assert np.allclose(s["slip_F"][after], 0.0, atol=1e-6) and np.all(s["locked_F"][after] == 1.0)
    assert np.all(np.abs(s["t_F"][after][-10:]) > 1.0)  # it carries the 4th-gear reaction
