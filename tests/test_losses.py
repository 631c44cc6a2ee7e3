"""Drag, spin and pump losses, the per-gear loss budget, the efficiency map and the neutral loss
(transgen.losses), and ``transgen powerflow --losses``."""
from __future__ import annotations

import json
import math

import numpy as np
import pytest

from transgen.cli import main
from transgen.kinematics import link_speeds
from transgen.language import load_mechanism
from transgen.library import bundled_mechanisms
from transgen.losses import (LossFileError, LossModel, PolynomialSpin, Pump, TableDrag, TableSpin, ViscousDrag,
                             aerated_film_torque, couette_coefficient, efficiency_map, loss_budget, neutral_losses,
                             parse_losses)
from transgen.losses.budget import held_output_speeds
from transgen.losses.drag import RPM, film_flow_demand
from transgen.losses.lossfile import DEFAULT_DRAG, NO_DRAG
from transgen.model import HOUSING
from transgen.powerflow import PowerFlowError, power_flow

NO_PUMP = Pump()


def _drag_only(mech, c: float) -> LossModel:
    """``c * slip`` on every open element (one-way clutches and dogs included), nothing else."""
    return LossModel(ViscousDrag(c), {e.name: ViscousDrag(c) for e in mech.elements}, pump=NO_PUMP)


def _kinematic_slips(mech, engaged) -> dict:
    """Slip per unit input speed of every open element from the gear's kinematics alone."""
    w = link_speeds(mech, engaged) | {HOUSING: 0.0}
    return {e.name: None if w[e.link1] is None or w[e.link2] is None else w[e.link1] - w[e.link2]
            for e in mech.elements if e.name not in engaged}


def _flows():
    for name in bundled_mechanisms():
        mech = load_mechanism(name)
        try:
            yield name, mech, power_flow(mech)
        except PowerFlowError:
            continue


@pytest.mark.parametrize("name, mech, flow", list(_flows()), ids=lambda x: x if isinstance(x, str) else "")
def test_drag_lowers_every_gears_efficiency_by_its_power_over_the_input_power(name, mech, flow):
    c, rpm, torque = 0.037, 2300.0, 180.0
    w_in = rpm * RPM
    p_in = torque * w_in
    for g in loss_budget(flow, _drag_only(mech, c), rpm, torque):
        slips = _kinematic_slips(mech, flow.gear(g.gear).engaged)
        expected = sum(c * (s * w_in) ** 2 for s in slips.values() if s is not None)
        assert g.drag_total == pytest.approx(expected, rel=1e-12, abs=1e-9)
        assert g.mesh_efficiency - g.efficiency == pytest.approx(expected / p_in, rel=1e-12, abs=1e-15)
        # the power balance: in = out + mesh + drag
        assert g.input_power - g.output_power == pytest.approx(g.mesh + expected, rel=1e-12)
        assert g.spin_total == 0.0 and g.pump == 0.0


def test_lossless_meshes_lose_exactly_the_drag():
    mech = load_mechanism("mb7g_tronic")
    flow = power_flow(mech, eta0=1.0)
    for g in loss_budget(flow, _drag_only(mech, 0.05), 1500.0, 300.0):
        assert g.mesh == pytest.approx(0.0, abs=1e-9)
        assert g.input_power - g.output_power == pytest.approx(g.drag_total, rel=1e-12)


def test_zf8hp70_has_two_open_elements_in_each_of_its_nine_gears_with_the_kinematic_slips():
    mech = load_mechanism("zf8hp70")
    flow = power_flow(mech)
    losses = loss_budget(flow, LossModel(pump=NO_PUMP), 1000.0, 100.0)
    assert [g.gear for g in losses] == ["1", "2", "3", "4", "5", "6", "7", "8", "R"]
    for g in losses:
        assert len(g.drag) == 2 and len(g.engaged) == 3 and not g.unknown
        slips = _kinematic_slips(mech, g.engaged)
        assert set(slips) == set(g.drag)
        for e, (slip, t, p) in g.drag.items():
            assert slip == pytest.approx(slips[e] * 1000.0 * RPM, rel=1e-12, abs=1e-12)
            assert t == pytest.approx(DEFAULT_DRAG.c * slip) and p == pytest.approx(DEFAULT_DRAG.c * slip ** 2)
    # 6th gear (C D E) is direct drive: A and B slip at input speed, no mesh loss
    sixth = next(g for g in losses if g.gear == "6")
    assert {e: round(s / RPM, 6) for e, (s, _, _) in sixth.drag.items()} == {"A": 1000.0, "B": 1000.0}
    assert sixth.mesh == pytest.approx(0.0, abs=1e-9)


def test_couette_drag_of_the_reference_pack_is_4_7_nm_at_1000_rpm():
    t = couette_coefficient(8, 0.015, 0.15e-3, 0.064, 0.085) * 1000 * RPM
    assert t == pytest.approx(4.7, rel=0.01)
    assert DEFAULT_DRAG.torque(1000 * RPM) == pytest.approx(t)
    assert DEFAULT_DRAG.torque(-1000 * RPM) == pytest.approx(-t)  # odd: power >= 0


def test_aerated_film_rises_like_the_full_film_peaks_and_falls():
    args = dict(faces=8, viscosity=0.015, density=850.0, gap=0.15e-3, inner_radius=0.064, outer_radius=0.085)
    flow = 0.5e-3 / 60  # 0.5 L/min per pack
    c = couette_coefficient(8, 0.015, 0.15e-3, 0.064, 0.085)
    w = np.linspace(1.0, 6000 * RPM, 400)
    t = aerated_film_torque(w, flow=flow, **args)
    # a face's demand exceeds its share at the peak; below, the film is full (Couette)
    demand = film_flow_demand(w, 0.015, 850.0, 0.15e-3, 0.064, 0.085)
    full = demand <= flow / 8
    assert full[0] and not full[-1]
    assert np.allclose(t[full], c * w[full])
    k = int(np.argmax(t))
    assert 0 < k < len(w) - 1 and t[-1] < 0.5 * t[k]
    assert np.all(np.diff(t[k:]) < 0)
    assert aerated_film_torque(-w[k], flow=flow, **args) == pytest.approx(-t[k])


def test_table_drag_interpolates_in_slip_and_oil_temperature():
    d = TableDrag((0.0, 1000.0, 2000.0), ((0.0, 6.0, 4.0), (0.0, 3.0, 2.0)), (40.0, 80.0))
    assert d.torque(500 * RPM, 40.0) == pytest.approx(3.0)
    assert d.torque(1500 * RPM, 60.0) == pytest.approx(0.5 * (5.0 + 2.5))
    assert d.torque(-1000 * RPM, 200.0) == pytest.approx(-3.0)  # clamped to the hottest row, odd
    assert d.torque(5000 * RPM, 40.0) == pytest.approx(4.0)  # held beyond the table
    assert TableDrag((500.0,), ((2.0,),)).torque(250 * RPM) == pytest.approx(1.0)  # 0 at rest


def test_spin_and_pump_closed_forms():
    s = PolynomialSpin((0.1, 0.002, 1e-5))
    w = 300.0
    assert s.torque(w) * w == pytest.approx((0.1 + 0.002 * w + 1e-5 * w * w) * w)
    assert s.torque(-w) == pytest.approx(-s.torque(w))
    assert TableSpin((0.0, 3000.0), (0.0, 1.5)).torque(1500 * RPM) == pytest.approx(0.75)
    p = Pump(displacement=10e-6, line_pressure=1.2e6, pressure_per_torque=2000.0, efficiency=0.8, speed_ratio=1.0)
    n = 2400.0
    q = 10e-6 * n / 60
    assert p.power(n * RPM, 250.0) == pytest.approx((1.2e6 + 2000 * 250) * q / 0.8)


def test_spin_and_pump_enter_the_budget():
    mech = load_mechanism("ht740")
    spin = PolynomialSpin((0.2, 0.0, 0.0))
    pump = Pump(12e-6, 1.0e6, 0.0, 0.85)
    model = LossModel(NO_DRAG, {}, spin, {}, pump)
    flow = power_flow(mech)
    rpm = 1800.0
    for g in loss_budget(flow, model, rpm, 900.0):
        speeds = link_speeds(mech, g.engaged)
        expected = sum(0.2 * abs(v) * rpm * RPM for v in speeds.values() if v is not None)
        assert g.spin_total == pytest.approx(expected)
        assert g.pump == pytest.approx(1.0e6 * 12e-6 * rpm / 60 / 0.85)
        assert g.drag_total == 0.0


def test_efficiency_map_rises_with_torque_toward_the_mesh_efficiency():
    mech = load_mechanism("zf8hp70")
    flow = power_flow(mech, gears=["3", "8"])
    emap = efficiency_map(flow, LossModel(), [1000.0, 3000.0], [20.0, 100.0, 400.0, 4000.0])
    for g in flow.gears:
        e = emap.efficiency[g.name]
        assert e.shape == (4, 2)
        assert np.all(np.diff(e, axis=0) > 0)  # more torque: the parasitic share falls
        assert np.all(np.diff(e, axis=1) < 0)  # more speed at the same torque: more drag and pump
        assert np.all(e < g.efficiency) and e[-1, 0] > g.efficiency - 0.01


def test_neutral_parasitic_loss_of_the_ht740_with_the_output_held():
    mech = load_mechanism("ht740")
    speeds = held_output_speeds(mech, ("C5",))
    assert speeds[mech.output] == 0.0 and speeds[mech.input] == pytest.approx(1.0)
    n = neutral_losses(mech, LossModel(), [1000.0, 2000.0], ("C5",), "N")
    w = {k: v for k, v in speeds.items()} | {HOUSING: 0.0}
    c = DEFAULT_DRAG.c
    for j, rpm in enumerate((1000.0, 2000.0)):
        expected = sum(c * ((w[e.link1] - w[e.link2]) * rpm * RPM) ** 2 for e in mech.elements
                       if e.name != "C5" and e.kind in ("clutch", "brake"))
        assert n.drag[j] == pytest.approx(expected)
        assert n.total[j] == pytest.approx(expected + LossModel().pump.power(rpm * RPM))
    assert n.drag[1] == pytest.approx(4 * n.drag[0])  # viscous: quadratic in speed


def test_coast_adds_the_losses_to_what_the_driveline_supplies():
    mech = load_mechanism("zf8hp70")
    flow = power_flow(mech, coast=True, gears=["4"])
    (g,) = loss_budget(flow, LossModel(), 2000.0, 50.0)
    p_abs = 50.0 * 2000 * RPM
    assert g.input_power == pytest.approx(-p_abs)
    assert -g.output_power == pytest.approx(p_abs / g.mesh_efficiency + g.parasitic)
    assert g.efficiency == pytest.approx(p_abs / -g.output_power)


LOSS_FILE = """\
oil_temperature = 60.0
[drag.default]
kind = "viscous"
c = 0.02
[drag.elements.A]
kind = "table"
slip_rpm = [0, 1000, 3000]
torque = [[0, 4, 2], [0, 2, 1]]
oil_temperature = [40.0, 80.0]
[spin.links.C3]
coefficients = [0.1]
[pump]
displacement = 1e-5
line_pressure = 8e5
efficiency = 0.9
"""


def test_a_loss_file_sets_every_model():
    mech = load_mechanism("zf8hp70")
    m = parse_losses(LOSS_FILE, "l.toml", mech)
    assert m.oil_temperature == 60.0 and m.default_drag == ViscousDrag(0.02)
    assert m.drag_model(mech.element("A")).torque(1000 * RPM, m.oil_temperature) == pytest.approx(3.0)
    assert m.spin_model("C3") == PolynomialSpin((0.1,)) and m.spin_model(mech.input) == PolynomialSpin(())
    assert m.pump == Pump(1e-5, 8e5, 0.0, 0.9, 1.0)


@pytest.mark.parametrize("text, where, message", [
    ("[drag.default]\nc = -1\n", (2, 1), "'c' = -1 is outside"),
    ("[drag.elements.Q]\nc = 0.01\n", (1, 1), "no shift element 'Q'"),
    ("[pump]\nefficiency = 0\n", (2, 1), "'efficiency' = 0 is outside (0, 1]"),
    ("[drag.elements.A]\nkind = \"table\"\nslip_rpm = [0, 100]\ntorque = [1]\n", (4, 1), "needs 2 values"),
    ("[spin.links.C3]\nkind = \"magic\"\n", (2, 1), "unknown spin kind"),
    ("oil_temperature = \n", (1, 19), "not valid TOML"),
    ("pumps = 1\n", (1, 1), "unknown key 'pumps'"),
])
def test_loss_file_errors_are_located(text, where, message):
    with pytest.raises(LossFileError) as info:
        parse_losses(text, "bad.toml", load_mechanism("zf8hp70"))
    head = str(info.value).splitlines()[0]
    assert head.startswith(f"bad.toml:{where[0]}:{where[1]}: error: ") and message in head, head


def test_cli_losses_text_json_map_and_figures(tmp_path, capsys):
    path = tmp_path / "l.toml"
    path.write_text(LOSS_FILE, encoding="utf-8")
    assert main(["powerflow", "zf8hp70", "--losses", str(path), "--speed", "1500", "--torque", "150"]) == 0
    text = capsys.readouterr().out
    assert "gear 1 (A B C): efficiency" in text and "open (2)" in text
    out = tmp_path / "out"
    assert main(["powerflow", "zf8hp70", "--losses", "--map", "--map-speed", "1000:3000:3",
                 "--map-torque", "50:300:4", "-o", str(out), "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["schema"] == "transgen.losses/1" and len(doc["gears"]) == 9
    assert np.array(doc["map"]["gears"]["1"]["efficiency"]).shape == (4, 3)
    assert sorted(p.name for p in out.iterdir()) == ["zf8hp70_efficiency_map.png", "zf8hp70_loss_breakdown.png",
                                                     "zf8hp70_losses.json", "zf8hp70_neutral_losses.png"]


@pytest.mark.parametrize("argv, message", [
    (["powerflow", "zf8hp70", "--map"], "need --losses"),
    (["powerflow", "zf8hp70", "--losses", "--map", "--map-speed", "1:2"], "--map-speed must be MIN:MAX:N"),
    (["powerflow", "zf8hp70", "--losses", "nothere.toml"], "nothere.toml:1:1: error: cannot read"),
])
def test_cli_bad_loss_input_exits_2(argv, message, capsys):
    assert main(argv) == 2
    assert message in capsys.readouterr().err


def test_unknown_floating_members_are_named_not_guessed():
    mech = load_mechanism("ht740")
    n = neutral_losses(mech, LossModel(), [1000.0], (), "all open")
    assert n.unknown and math.isfinite(n.total[0])
