"""Drag, spin, pump and mesh losses in the simulation (``[losses]``, :mod:`transgen.sim.model.losses`,
:mod:`transgen.sim.model.mesh`): closed forms, the power flow's steady state, the energy balance."""
from __future__ import annotations

import math
import textwrap

import numpy as np
import pytest
from scipy.optimize import brentq

from transgen.cli import main
from transgen.equations import complete_locked
from transgen.errors import ScenarioError
from transgen.language import format_mechanism, load_mechanism, parse_mechanism
from transgen.library import bundled_path
from transgen.losses import LossModel, ViscousDrag
from transgen.powerflow import power_flow
from transgen.sim.model.mesh import MeshModel
from transgen.sim.model.transmission import Transmission
from transgen.sim.scenario.library import bundled_scenarios
from transgen.sim.scenario.load import load_scenario

ALL = ["drag", "spin", "pump", "mesh"]

TWO = """
link A J=0.2
link B J=0.3
clutch K A B static=100 dynamic=80 drag=0.05
input A
output B
"""


def _write(tmp_path, mech: str, scenario: str, losses: str | None = None):
    (tmp_path / "two.mech").write_text(textwrap.dedent(mech))
    if losses is not None:
        (tmp_path / "my.losses.toml").write_text(textwrap.dedent(losses))
    p = tmp_path / "s.toml"
    p.write_text(textwrap.dedent(scenario))
    return p


def test_drag_of_an_open_clutch_decays_its_slip_exponentially(tmp_path):
    """Two inertias joined by an open clutch with ``drag=c``: ``slip = s0 exp(-t/tau)``,
    ``tau = 1 / (c (1/J_A + 1/J_B))``, and the drag energy ``c s0^2 tau/2 (1 - exp(-2t/tau))``."""
    p = _write(tmp_path, TWO, """
        mechanism = "two.mech"
        [simulation]
        t_end = 2.0
        [initial]
        speeds = { A = 100.0, B = 0.0 }
        [input]
        torque = 0.0
        [losses]
        kinds = ["drag"]
        """)
    res = load_scenario(p).run()
    assert res.success, res.message
    c, s0 = 0.05, 100.0
    tau = 1.0 / (c * (1 / 0.2 + 1 / 0.3))
    t = res.time
    assert np.allclose(res["slip_K"], s0 * np.exp(-t / tau), rtol=1e-6, atol=1e-6)
    assert np.allclose(res["P_drag_K"], c * res["slip_K"] ** 2, rtol=1e-12)
    exact = c * s0 ** 2 * tau / 2 * (1 - math.exp(-2 * t[-1] / tau))
    assert res.energy["losses"]["drag"]["K"] == pytest.approx(exact, rel=1e-6)
    assert res.energy["dissipated"] == pytest.approx(exact, rel=1e-6)  # the only loss: the balance's dissipation


def test_spin_and_pump_of_a_loss_file_follow_their_closed_forms(tmp_path):
    """A viscous spin ``a1 w`` on B decays it exponentially (``tau = J_B / a1``); the pump on A
    takes ``p D / (2 pi eta)``, a constant torque: A decelerates linearly."""
    p = _write(tmp_path, TWO.replace(" drag=0.05", " drag=0"), """
        mechanism = "two.mech"
        [simulation]
        t_end = 1.0
        [initial]
        speeds = { A = 300.0, B = 200.0 }
        [input]
        torque = 0.0
        [losses]
        file = "my.losses.toml"
        kinds = ["spin", "pump"]
        """, """
        [spin.links.B]
        coefficients = [0.0, 0.06]
        [pump]
        displacement = 10e-6
        line_pressure = 1.2e6
        efficiency = 0.8
        """)
    res = load_scenario(p).run()
    assert res.success, res.message
    t = res.time
    assert np.allclose(res["w_B"], 200.0 * np.exp(-t * 0.06 / 0.3), rtol=1e-6)
    torque = 1.2e6 * 10e-6 / (2 * math.pi * 0.8)
    wa = res["w_A"]
    assert np.allclose(wa, 300.0 - torque / 0.2 * t, rtol=1e-6)  # (w_s / w)^2 < 1e-6 here
    assert np.allclose(res["P_pump"], torque * wa, rtol=1e-6)
    lo = res.energy["losses"]
    assert lo["pump"] == pytest.approx(0.2 * (300.0 ** 2 - wa[-1] ** 2) / 2, rel=1e-6)
    assert lo["spin"] == pytest.approx(0.3 * (200.0 ** 2 - res["w_B"][-1] ** 2) / 2, rel=1e-6)


def _steady_efficiencies(name: str, coast: bool):
    """Per gear: the power flow's efficiency and the dynamic model's in steady state, the output
    torque that holds every acceleration at zero at 200 rad/s input with 100 N*m on the input."""
    mech = load_mechanism(bundled_path(name))
    flow = power_flow(mech, coast=coast)
    tr = Transmission(mech)
    tr.mesh = MeshModel(mech, tr.graph)
    i_in, i_out = tr.input_index["T_in"], tr.input_index["T_out"]
    li, lo = tr.link_index[mech.input], tr.link_index[mech.output]
    out = []
    for g in flow.gears:
        data = tr.mode(frozenset(tr.element_index[e] for e in complete_locked(tr.graph, g.engaged)))
        w = data.C @ np.linalg.lstsq(data.C[[li]], [200.0], rcond=None)[0]
        t_in = -100.0 if coast else 100.0

        def accelerations(t_out, data=data, w=w, t_in=t_in):
            u = np.zeros(len(tr.inputs))
            u[i_in], u[i_out] = t_in, t_out
            return data.C @ tr.response(data, u, w)[0]

        guess = abs(t_in * g.torque_ratio)
        t_out = brentq(lambda x: accelerations(x)[lo], -2 * guess - 10, 2 * guess + 10, xtol=1e-12, rtol=1e-15)
        assert np.max(np.abs(accelerations(t_out))) < 1e-9  # every link steady
        p_in, p_out = t_in * w[li], t_out * w[lo]
        out.append((g.name, g.efficiency, p_in / p_out if coast else p_out / p_in))
    return out


@pytest.mark.parametrize("name", ["zf8hp70", "ht740", "simple2"])
@pytest.mark.parametrize("coast", [False, True], ids=["drive", "coast"])
def test_mesh_losses_in_steady_state_are_the_power_flows(name, coast):
    for gear, expected, simulated in _steady_efficiencies(name, coast):
        assert simulated == pytest.approx(expected, abs=1e-6), gear
        if name == "zf8hp70" and gear != "6":
            assert simulated < 0.996  # the losses are there (6th is direct: no mesh loss)


def test_lossless_meshes_give_the_mode_matrices():
    """With every efficiency 1 the lossy equations are the mode's ``B u`` and ``D u``."""
    mech = load_mechanism(bundled_path("zf8hp70"))
    tr = Transmission(mech)
    rng = np.random.default_rng(1)
    plain = [(data, rng.normal(size=len(tr.inputs)) * 100, data.C @ (rng.normal(size=data.dof) * 100))
             for data in tr.std_modes]
    tr.mesh = MeshModel(mech, tr.graph, eta0=1.0, eta_pair=1.0)
    for data, u, w in plain:
        qd, torques, loss = tr.response(data, u, w)
        scale = 1 + np.max(np.abs(data.B @ u))
        assert np.allclose(qd, data.B @ u, atol=1e-9 * scale), data.name
        assert np.allclose(torques, data.D @ u, atol=1e-9 * (1 + np.max(np.abs(data.D @ u)))), data.name
        assert abs(loss) < 1e-7 * np.max(np.abs(u)) * np.max(np.abs(w))


def test_mesh_factor_blends_through_a_power_reversal_without_chatter():
    """An input torque alternating drive and coast in one gear: the run has the segments of the
    lossless one (no event from the power's reversals), loses energy in both directions, and
    closes its balance."""
    sine = {"type": "sine", "offset": 0.0, "amplitude": 200.0, "frequency": 2.0, "phase": 0.0}
    runs = {}
    for kinds in ([], ["mesh"]):
        sc = load_scenario(bundled_scenarios()["simple2_upshift"],
                           {"input.torque": sine, "elements.C1.apply": 1.0, "elements.C2.apply": 0.0,
                            "losses.kinds": kinds})
        runs[bool(kinds)] = sc.run()
    off, on = runs[False], runs[True]
    assert on.success, on.message
    assert on.stats["segments"] == off.stats["segments"]
    p_mesh = on["P_mesh"]
    assert np.min(p_mesh) >= -1e-6 and on.energy["losses"]["mesh"] > 0
    drive = on["T_in"] * on["w_Li"] > 100.0
    assert drive.any() and (~drive).any()  # both directions of power were run through
    assert np.all(np.abs(np.diff(p_mesh)) < 0.05 * np.max(p_mesh))  # smooth, no jumps
    assert on.stats["invariants"]["invariants"]["energy_balance"]["worst"] < 1.0


@pytest.mark.parametrize("name", ["simple2_upshift", "oneway_overrun", "coupled_clutches", "freewheel_clutch"])
def test_energy_balance_closes_with_every_loss_on(name):
    res = load_scenario(bundled_scenarios()[name], {"losses.kinds": ALL}).run()
    assert res.success, res.message
    assert res.stats["invariants"]["invariants"]["energy_balance"]["worst"] < 1.0
    lo = res.energy["losses"]
    assert all(x >= -1e-9 for x in lo["drag"].values()) and lo["pump"] > 0 and lo["mesh"] >= 0
    assert lo["total"] == pytest.approx(lo["drag_total"] + lo["pump"] + lo["mesh"] + lo.get("spin", 0.0))
    assert lo["total"] <= res.energy["dissipated"] * (1 + 1e-9)


@pytest.mark.parametrize("method", ["DOP853", "RK45", "LSODA", "Radau", "BDF"])
@pytest.mark.parametrize("name", ["simple2_upshift", "freewheel_clutch"])
def test_energy_balance_closes_with_every_solver(name, method):
    res = load_scenario(bundled_scenarios()[name], {"losses.kinds": ALL, "simulation.method": method}).run()
    assert res.success, res.message
    assert res.stats["invariants"]["invariants"]["energy_balance"]["worst"] < 1.0
    assert res.energy["losses"]["total"] > 0


def test_losses_lower_the_output_and_the_reports_give_them_by_kind():
    from transgen.sim.analysis.report import report_dict, report_text

    path = bundled_scenarios()["simple2_upshift"]
    off = load_scenario(path).run()
    on = load_scenario(path, {"losses.kinds": ALL}).run()
    assert "losses" not in off.energy and not any(k.startswith("E_drag") for k in off.signals)
    assert on.signals["w_Li"][-1] < off.signals["w_Li"][-1]  # the same input torque accelerates less
    text = report_text(on)
    assert "Losses over the run [J]" in text and "losses mesh" in text
    shift = report_dict(on)["shifts"][0]
    assert shift["losses"]["total"] > 0 and "losses" not in report_dict(off)["shifts"][0]


def test_no_losses_is_the_run_without_them():
    path = bundled_scenarios()["simple2_upshift"]
    a, b = load_scenario(path).run(), load_scenario(path, {"losses.kinds": []}).run()
    assert a.signals.keys() == b.signals.keys()
    assert all(np.array_equal(a.signals[k], b.signals[k]) for k in a.signals)


@pytest.mark.parametrize("extra, where, words", [
    ('kinds = ["drag", "churn"]', "kinds", "unknown loss kind 'churn'"),
    ('pump_link = "Q"', "pump_link", "pump_link 'Q' is not a link"),
    ("eta0 = 1.5", "eta0", "'eta0' must be in (0, 1]"),
    ("eta0 = nan", "eta0", "NaN and infinity are refused"),
    ('file = "missing.toml"', "file", "cannot read the loss file"),
    ('file = "my.losses.toml"', "file", "bad loss file"),
    ("foo = 1", "foo", "unknown key 'foo'"),
])
def test_losses_table_errors_are_located(tmp_path, extra, where, words):
    p = _write(tmp_path, TWO, f"""
        mechanism = "two.mech"
        [simulation]
        t_end = 0.1
        [initial]
        speeds = {{ A = 1.0, B = 0.0 }}
        [losses]
        {extra}
        """, "[pump]\nefficiency = nan\n")
    with pytest.raises(ScenarioError) as exc:
        load_scenario(p)
    message = str(exc.value)
    assert message.startswith(f"{p}:8:"), message
    assert words in message, message


def test_mesh_losses_need_the_switching_model(tmp_path):
    p = _write(tmp_path, TWO, """
        mechanism = "two.mech"
        [simulation]
        model = "compliant"
        t_end = 0.1
        [initial]
        speeds = { A = 1.0, B = 0.0 }
        [losses]
        """)
    with pytest.raises(ScenarioError, match="mode-switching model only"):
        load_scenario(p)


def test_drag_in_the_mech_file(tmp_path, capsys):
    mech = parse_mechanism(TWO)
    assert mech.element("K").drag == 0.05
    assert parse_mechanism(format_mechanism(mech)) == mech
    assert LossModel().drag_model(mech.element("K")) == ViscousDrag(0.05)  # over the default
    for bad, words in (("drag=nan", "NaN and infinity are refused"), ("drag=-1", "drag"), ("drag=1e9", "drag")):
        f = tmp_path / "bad.mech"
        f.write_text(TWO.replace("drag=0.05", bad))
        assert main(["check", str(f)]) == 2
        err = capsys.readouterr().err
        assert f"{f}:4:" in err and words in err, err


def test_the_compiled_path_runs_the_losses_as_the_python_path(monkeypatch):
    """Drag, spin and pump run in Python inside the compiled right-hand side: both paths agree."""
    from transgen.sim.solve.kernel import compiled_powertrain
    from transgen.sim.solve.simulate import simulate

    sc = load_scenario(bundled_scenarios()["simple2_upshift"], {"losses.kinds": ["drag", "spin", "pump"]})
    if compiled_powertrain(sc.powertrain) is None:
        pytest.skip("no compiled right-hand side in this process (numba, TRANSGEN_JIT or no built kernels)")
    fast = simulate(sc.powertrain, sc.options)
    monkeypatch.setenv("TRANSGEN_JIT", "0")
    assert compiled_powertrain(sc.powertrain) is None
    slow = simulate(sc.powertrain, sc.options)
    assert fast.success and slow.success
    assert [(e.kind, e.elements) for e in fast.events] == [(e.kind, e.elements) for e in slow.events]
    grid = np.linspace(sc.options.t_start, sc.options.t_end, 401)
    for name in ("w_Lo", "E_pump", "E_drag_C1"):
        a, b = np.interp(grid, fast.time, fast[name]), np.interp(grid, slow.time, slow[name])
        assert np.max(np.abs(a - b)) < 1e-6 * max(1.0, np.max(np.abs(b))), name


def test_loss_parameters_in_the_losses_table(tmp_path):
    """The loss file's keys in ``[losses]`` itself: the same model, errors located there."""
    base = """
        mechanism = "two.mech"
        [simulation]
        t_end = 0.5
        [initial]
        speeds = { A = 100.0, B = 0.0 }
        [losses]
        kinds = ["drag"]
        """
    p = _write(tmp_path, TWO, base + "[losses.drag.elements.K]\nc = 0.1\n")
    res = load_scenario(p).run()
    assert res.success
    assert np.allclose(res["P_drag_K"], 0.1 * res["slip_K"] ** 2, rtol=1e-12)
    for extra, line, words in (("[losses.drag.elements.K]\nc = -1\n", 10, "'c' = -1 is outside"),
                               ("[losses.drag.elements.Q]\nc = 1\n", 9, "no shift element 'Q'"),
                               ('file = "x.toml"\noil_temperature = 40.0\n', 10, "not both")):
        p = _write(tmp_path, TWO, base + extra)
        with pytest.raises(ScenarioError) as exc:
            load_scenario(p)
        assert str(exc.value).startswith(f"{p}:{line}:") and words in str(exc.value), str(exc.value)


@pytest.mark.parametrize("name, gear", [("zf8hp70", "3"), ("ht740", "2"), ("simple2", "1")])
@pytest.mark.parametrize("coast", [False, True], ids=["drive", "coast"])
def test_a_simulated_steady_state_brackets_the_power_flows_efficiency(tmp_path, name, gear, coast):
    """A run in one gear with 100 N*m on the input and the output torque of the power flow's
    efficiency prescribed, times (1 +- 1e-6): the input speeds up with the one and slows down
    with the other, so the simulation's efficiency is the power flow's within 1e-6."""
    mech = load_mechanism(bundled_path(name))
    g = next(x for x in power_flow(mech, coast=coast).gears if x.name == gear)
    t_in = -100.0 if coast else 100.0
    t_out = t_in * g.ratio / g.efficiency if coast else t_in * g.ratio * g.efficiency
    drift = {}
    for sign in (1, -1):
        p = tmp_path / f"s{sign}.toml"
        p.write_text(textwrap.dedent(f"""
            mechanism = "{name}"
            [simulation]
            t_end = 0.2
            [initial]
            gear = "{gear}"
            speeds = {{ {mech.input} = 200.0 }}
            [input]
            torque = {t_in!r}
            [driveline]
            output_torque = {t_out * (1 + sign * 1e-6)!r}
            [losses]
            kinds = ["mesh"]
            """))
        res = load_scenario(p).run()
        assert res.success, res.message
        assert [m.name for m in res.modes] == [gear]
        w = res[f"w_{mech.input}"]
        drift[sign] = w[-1] - w[0]
    # more output torque: the output takes more than the input gives, the input slows (drive: it
    # is the load; coast: the driveline supplies more than the input absorbs, the input speeds up)
    assert (drift[1] < 0 < drift[-1]) if not coast else (drift[1] > 0 > drift[-1]), drift


def test_drag_spin_and_pump_run_with_the_compliant_model():
    path = bundled_scenarios()["simple2_upshift"]
    res = load_scenario(path, {"simulation.model": "compliant", "losses.kinds": ["drag", "spin", "pump"]}).run()
    assert res.success, res.message
    assert res.stats["invariants"]["invariants"]["energy_balance"]["worst"] < 1.0
    switching = load_scenario(path, {"losses.kinds": ["drag", "spin", "pump"]}).run()
    assert res.energy["losses"]["pump"] == pytest.approx(switching.energy["losses"]["pump"], rel=1e-3)
