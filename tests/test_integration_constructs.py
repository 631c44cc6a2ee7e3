"""Every command on every construct of the language: stepped-pinion planetaries (``stepped``),
dog clutches and brakes (``dog``), alternative gears (``gear ... alternative``).

Power flow: a stepped set's losses against Müller's closed forms (with the standing efficiency
``eta0`` of the set between two of its gears), against a simple planetary (equal steps), and the
torque and power balances; dogs as locked elements; alternative gears marked.
"""
from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

from transgen import bundled_mechanisms, load_mechanism, parse_mechanism
from transgen.cli import main
from transgen.model import HOUSING
from transgen.powerflow import power_flow
from test_lever import _assert_collinear
from test_powerflow import _link_balance_residuals

DATA = Path(__file__).parent / "data"
STEPPED2 = DATA / "stepped_test2.mech"
BUNDLED = sorted(bundled_mechanisms())


def _stepped_text(members: str, np1: int, np2: int, brake: str, inp: str, out: str, eta0=None, extra="") -> str:
    """A stepped set on links G1, G2 (, G3) and carrier C; ``brake`` holds one link."""
    eta = f" eta0={eta0}" if eta0 is not None else ""
    links = sorted({w.split("=")[1] for w in members.split() if "=" in w and not w.split("=")[1].isdigit()} | {"C"})
    return ("transmission \"stepped\"\n" + "".join(f"link {k} J=0.01\n" for k in links)
            + f"stepped P carrier=C {members} Np1={np1} Np2={np2}{eta}\n"
            + f"brake B {brake} static=100 dynamic=80\n{extra}input {inp}\noutput {out}\ngear 1 = B\n")


# ------------------------------------------------------------------------------- power flow


def test_stepped_gear_is_determinate_and_lossless_torque_ratio_is_the_ratio():
    mech = load_mechanism(STEPPED2)
    flow = power_flow(mech, eta0=1.0)
    g1 = flow.gear("1")
    k = 80 * 25 / (30 * 20)  # Nr*Np1 / (Ns*Np2): the stepped set's basic ratio magnitude
    assert abs(g1.ratio - (1 + k)) <= 1e-12
    assert abs(g1.torque_ratio - g1.ratio) <= 1e-12 and g1.losses == 0.0
    assert abs(g1.element_torques["B1"] - (-k)) <= 1e-12  # the ring's reaction into the housing


@pytest.mark.parametrize("eta0", [0.97, 0.9, 0.995])
def test_stepped_closed_forms_of_mueller(eta0):
    """Ring fixed, sun in, carrier out: ``(1 + eta0*k)/(1 + k)``; carrier fixed (reverse):
    ``eta0``; sun fixed, ring in, carrier out: ``(k + eta0)/(k + 1)`` ... with ``k = Nr*Np1/(Ns*Np2)``."""
    members = "sun1=S Ns1=30 ring2=R Nr2=80"
    k = 80 * 25 / (30 * 20)
    g = power_flow(parse_mechanism(_stepped_text(members, 25, 20, "R", "S", "C", eta0))).gear("1")
    assert abs(g.efficiency - (1 + eta0 * k) / (1 + k)) <= 1e-12
    assert g.set("P").driving == "sun1"
    g = power_flow(parse_mechanism(_stepped_text(members, 25, 20, "C", "S", "R", eta0))).gear("1")
    assert abs(g.efficiency - eta0) <= 1e-12 and g.ratio < 0
    g = power_flow(parse_mechanism(_stepped_text(members, 25, 20, "S", "R", "C", eta0))).gear("1")
    assert abs(g.efficiency - (k + eta0) / (k + 1)) <= 1e-12
    assert g.set("P").driving == "ring2"


@pytest.mark.parametrize("fixed, inp, out", [("R", "S", "C"), ("C", "S", "R"), ("S", "C", "R"), ("R", "C", "S")])
def test_stepped_with_equal_steps_is_the_simple_planetary(fixed, inp, out):
    """Equal pinion steps: the stepped set is a simple planetary with the same eta0, in drive
    and coast (an independent formulation: the planetary's loss relations)."""
    stepped = parse_mechanism(_stepped_text("sun1=S Ns1=33 ring1=R Nr1=75", 21, 21, fixed, inp, out, 0.96)
                              .replace(" Np2=21", ""))
    simple = parse_mechanism(_stepped_text("sun1=S Ns1=33 ring1=R Nr1=75", 21, 21, fixed, inp, out)
                             .replace("stepped P carrier=C sun1=S Ns1=33 ring1=R Nr1=75 Np1=21 Np2=21",
                                      "planetary P sun=S ring=R carrier=C Ns=33 Nr=75 eta0=0.96"))
    for coast in (False, True):
        a, b = power_flow(stepped, coast=coast).gear("1"), power_flow(simple, coast=coast).gear("1")
        assert abs(a.efficiency - b.efficiency) <= 1e-12 and abs(a.torque_ratio - b.torque_ratio) <= 1e-12
        assert {"sun1": "sun", "ring1": "ring", None: None}[a.set("P").driving] == b.set("P").driving


def _stepped_balance(mech, g, eta):
    """A stepped set in equilibrium with its pinion's carrier-frame balance
    ``sum f_X * r_X * T_X = 0``, ``r_X = sigma_X*Np_k/N_X``, ``f_X = sqrt(eta0)**(+1 driving, -1
    driven)``, written from the Mechanism."""
    for sp in mech.stepped:
        s = g.set(sp.name)
        assert abs(sum(s.torques.values())) <= 1e-10
        w = {port: s.speeds[port] for port in s.torques}
        if None in w.values():
            continue
        total = 0.0
        for role, _, teeth in sp.members:
            r = (-1 if role.startswith("sun") else 1) * sp.step_teeth(role) / teeth
            p = s.torques[role] * (w[role] - w["carrier"])
            f = 1.0 if abs(p) <= 1e-12 else math.sqrt(eta[sp.name]) ** (1 if p > 0 else -1)
            total += f * r * s.torques[role]
        assert abs(total) <= 1e-10, (sp.name, g.name)


THREE = ("sun1=S1 Ns1=30 sun2=S2 Ns2=24 ring1=R Nr1=90", 20, 26)


@pytest.mark.parametrize("brake, inp, out", [("S2", "S1", "R"), ("C", "S1", "R"), ("S2", "S1", "C"), ("R", "S2", "C"),
                                             ("S1", "S2", "R")])
@pytest.mark.parametrize("coast", [False, True])
def test_three_gear_stepped_set_balances_torque_and_power(brake, inp, out, coast):
    members, np1, np2 = THREE
    mech = parse_mechanism(_stepped_text(members, np1, np2, brake, inp, out, 0.95))
    g = power_flow(mech, coast=coast).gear("1")
    lossless = power_flow(parse_mechanism(_stepped_text(members, np1, np2, brake, inp, out)), eta0=1.0,
                          coast=coast).gear("1")
    assert abs(lossless.torque_ratio - lossless.ratio) <= 1e-12
    for link, r in _link_balance_residuals(mech, g).items():
        assert abs(r) <= 1e-10, link
    assert abs(g.input_power - g.output_power - g.losses) <= 1e-10
    assert abs(g.losses - sum(g.set("P").powers.values())) <= 1e-10 and g.losses > 0
    assert 0 < g.efficiency < 1
    _stepped_balance(mech, g, power_flow(mech).eta)


def test_unloaded_third_gear_changes_nothing():
    """A stepped set's gear that floats (no element on it) carries no torque: the flow is that of
    the two-gear set, whose efficiency has the closed form."""
    members, np1, np2 = THREE
    mech = parse_mechanism(_stepped_text(members, np1, np2, "R", "S1", "C", 0.95))
    g = power_flow(mech).gear("1")
    k = 90 * 20 / (30 * 20)
    assert abs(g.efficiency - (1 + 0.95 * k) / (1 + k)) <= 1e-12
    assert g.link_speeds["S2"] is not None and abs(g.set("P").torques["sun2"]) <= 1e-14


@pytest.mark.parametrize("name", BUNDLED + [str(STEPPED2)])
def test_every_bundled_gear_is_lossless_at_eta0_one(name):
    mech = load_mechanism(name)
    flow = power_flow(mech, eta0=1.0)
    assert [g.name for g in flow.gears] == [g.name for g in mech.gears if g.kind == "gear"]
    for g in flow.gears:
        assert abs(g.torque_ratio - g.ratio) <= 1e-12 * max(1.0, abs(g.ratio)), (name, g.name)
        assert g.losses == 0.0
    lossy = power_flow(mech)
    for g in lossy.gears:
        for link, r in _link_balance_residuals(mech, g).items():
            assert abs(r) <= 1e-10, (name, g.name, link)
        _stepped_balance(mech, g, lossy.eta)


def test_dogs_carry_torque_when_locked_and_report_their_slip_when_open():
    mech = load_mechanism("zf9hp48")
    flow = power_flow(mech, eta0=1.0, input_rpm=2000, max_slip_rpm=6000, design_torque=480)
    g1 = flow.gear("1")
    assert abs(g1.element_torques["F"]) > 1.0 and abs(g1.element_torques["A"]) > 0.0
    g8 = flow.gear("8")  # A and F open in 8th
    assert "A" in g8.element_slips and "F" in g8.element_slips
    assert abs(g8.element_slip_rpm["F"] - 2000 * g8.element_slips["F"]) <= 1e-9
    assert "F" in g8.overspeed  # the dog brake's hub over 6000 rpm relative to the case in 8th
    cap = {c.element: c for c in flow.capacities}
    assert cap["F"].kind == "dog" and cap["F"].static > 0 and cap["F"].dynamic is None
    assert cap["F"].declared_dynamic is None
    # a locked dog clutch is a branch of the circulating power like a friction clutch
    g5 = flow.gear("5")
    assert g5.circulating_power >= abs(g5.element_torques["A"]) - 1.0 - 1e-12


def test_alternative_gears_are_analysed_and_marked(capsys):
    flow = power_flow(load_mechanism("mb7g_tronic"))
    assert flow.gear("R2").alternative and not flow.gear("R1").alternative
    assert main(["powerflow", "mb7g_tronic"]) == 0
    assert "gear R2 (K3 B1 BR, alternative)" in capsys.readouterr().out
    assert main(["powerflow", "mb7g_tronic", "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert {g["name"]: g["alternative"] for g in doc["gears"]}["R2"] is True


def test_stepped_eta0_in_the_file_round_trips_and_wins():
    from transgen.language import format_mechanism
    mech = parse_mechanism(_stepped_text("sun1=S Ns1=30 ring2=R Nr2=80", 25, 20, "R", "S", "C", 0.93))
    assert mech.stepped[0].eta0 == 0.93
    assert parse_mechanism(format_mechanism(mech)) == mech
    flow = power_flow(mech, eta0=0.99)
    assert flow.eta["P"] == 0.93
    assert power_flow(mech, eta0=0.99).to_dict()["eta0"] == {"P": 0.93}
    from transgen.describe import mechanism_to_dict
    assert mechanism_to_dict(mech)["stepped"][0]["eta0"] == 0.93  # transgen check --json


def test_cli_powerflow_of_the_stepped_example(capsys):
    assert main(["powerflow", str(STEPPED2)]) == 0
    out = capsys.readouterr().out
    assert "gear 1 (B1): ratio 4.3333" in out and "sun1 drives" in out


# ------------------------------------------------------------------------------- lever diagrams

import matplotlib  # noqa: E402

matplotlib.use("Agg")

from hypothesis import given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402
from matplotlib.text import Text  # noqa: E402

from transgen.drawing import draw_levers, lever_layout, lever_speeds  # noqa: E402
from transgen.graph import build_graph, link_nodes  # noqa: E402
from transgen.kinematics import constraint_matrix, null_space  # noqa: E402
from transgen.model import Link, Mechanism, Planetary, SteppedPlanetary  # noqa: E402


def test_stepped_set_is_one_lever_spaced_by_its_relation():
    mech = load_mechanism(STEPPED2)
    (lever,) = lever_layout(mech)
    pos = {n.link: n.position for n in lever.nodes}
    assert lever.links == ("IN", "OUT", "R") and lever.sets == ("P",)  # sun1, carrier, ring2
    # C-S : C-R = Nr*Np1 : Ns*Np2, the coefficients of Ns*Np2*w_s + Nr*Np1*w_r = (...)*w_c
    assert (pos["OUT"] - pos["IN"]) / (pos["R"] - pos["OUT"]) == pytest.approx(80 * 25 / (30 * 20), rel=1e-15)
    assert [n.members for n in lever.nodes] == [("P.sun1",), ("P.carrier",), ("P.ring2",)]
    for gear in ("1", "2"):
        _assert_collinear(lever, lever_speeds(mech, gear), gear)


def test_stepped_set_with_equal_steps_is_the_planetary_lever():
    a = _plain([Planetary("P", "A", "B", "C", 33, 75)])
    b = _plain(stepped=[SteppedPlanetary("P", "C", (("sun1", "A", 33), ("ring1", "B", 75)), np1=21)])
    assert [(n.link, n.position) for n in lever_layout(a)[0].nodes] == \
        [(n.link, n.position) for n in lever_layout(b)[0].nodes]


def _plain(planetaries=(), stepped=(), links=("A", "B", "C", "D", "E")):
    return Mechanism("test", tuple(Link(n, 1.0) for n in links), tuple(planetaries), stepped=tuple(stepped),
                     input=links[0], output=links[-1])


def test_stepped_set_and_planetary_sharing_two_members_are_one_lever():
    """A stepped set (sun1 A, ring2 B, carrier C) and a simple set on the same sun and carrier (ring
    D): one four-node lever, every motion a straight line on it."""
    mech = _plain([Planetary("Q", "A", "D", "C", 30, 70)],
                  [SteppedPlanetary("P", "C", (("sun1", "A", 30), ("ring2", "B", 80)), np1=25, np2=20)])
    levers = lever_layout(mech)
    (lever,) = [lv for lv in levers if len(lv.nodes) > 1]
    assert set(lever.sets) == {"P", "Q"} and set(lever.links) == {"A", "B", "C", "D"}
    g = build_graph(mech)
    names = link_nodes(g)
    for motion in null_space(constraint_matrix(g), len(names)).T:
        _assert_collinear(lever, dict(zip(names, motion)) | {HOUSING: 0.0}, "P+Q")


@st.composite
def stepped_trains(draw):
    """One stepped set of 2-4 central gears (a member may be the housing) and 0-2 planetaries."""
    links = tuple(f"L{i}" for i in range(draw(st.integers(3, 6))))
    pool = list(links) + [HOUSING]
    roles = draw(st.lists(st.sampled_from(["sun1", "sun2", "ring1", "ring2"]), min_size=2, max_size=4, unique=True))
    chosen = draw(st.permutations(pool))[:len(roles) + 1]
    np1, np2 = draw(st.integers(12, 30)), draw(st.integers(12, 30))
    members, seen = [], set()
    for role, link in zip(roles, chosen[1:]):
        step = np1 if role.endswith("1") else np2
        teeth = draw(st.integers(step + 20, 140) if role.startswith("ring") else st.integers(14, 70))
        key = (role[:3], teeth * (np2 if role.endswith("1") else np1))
        if key in seen:
            return None
        seen.add(key)
        members.append((role, link, teeth))
    sp = SteppedPlanetary("S", chosen[0], tuple(members), np1 if any(r.endswith("1") for r in roles) else None,
                          np2 if any(r.endswith("2") for r in roles) else None)
    sets = []
    for k in range(draw(st.integers(0, 2))):
        m = draw(st.permutations(pool))[:3]
        ns = draw(st.integers(12, 60))
        sets.append(Planetary(f"P{k}", *m, ns, draw(st.integers(ns + 12, 150)), pinions=draw(st.sampled_from([1, 2]))))
    return _plain(sets, [sp], links)


@settings(max_examples=120, deadline=None)
@given(stepped_trains())
def test_every_motion_of_a_stepped_train_is_a_straight_line_on_every_lever(mech):
    if mech is None:
        return
    g = build_graph(mech)
    names = link_nodes(g)
    basis = null_space(constraint_matrix(g), len(names))
    levers = lever_layout(mech)
    assert any("S" in lv.sets and len(lv.nodes) >= len(mech.stepped[0].members) + 1 for lv in levers)
    for motion in basis.T:
        speeds = dict(zip(names, motion)) | {HOUSING: 0.0}
        for lever in levers:
            _assert_collinear(lever, speeds, f"lever {lever.name}")


@pytest.mark.parametrize("name", BUNDLED + [str(STEPPED2)])
def test_every_node_on_its_lever_line_in_every_gear(name):
    mech = load_mechanism(name)
    levers = lever_layout(mech)
    assert sorted({n.link for lv in levers for n in lv.nodes} - {HOUSING}) == sorted(mech.link_names)
    for gear in (g for g in mech.gears if g.kind == "gear"):
        speeds = lever_speeds(mech, gear.name)
        for lever in levers:
            _assert_collinear(lever, speeds, f"{name} gear {gear.name} lever {lever.name}")


def test_dogs_and_alternative_gears_in_the_lever_figure():
    fig = draw_levers(load_mechanism("zf9hp48"), ["1", "8"])
    gids = {t.get_gid(): t.get_text() for t in fig.findobj(Text)}
    assert "legend:dog clutch engaged" in gids and "legend:dog brake engaged" in gids
    assert gids["element:1:A"] == "A (dog)" and gids["element:8:F"] == "F (dog)"
    fig.clear()
    fig = draw_levers(load_mechanism("mb7g_tronic"), ["R1", "R2"])
    gids = {t.get_gid(): t.get_text() for t in fig.findobj(Text)}
    assert gids["title:R2"] == "gear R2 (alternative)" and gids["title:R1"] == "gear R1"
    assert "legend:dog clutch engaged" not in gids
    fig.clear()


# ---------------------------------------------------------------------------------- synthesis

import dataclasses  # noqa: E402

from transgen.synthesis.table import DOG_UPSHIFT_PENALTY, gear_candidates, synthesize_table  # noqa: E402
from transgen.synthesis.teeth import ratio_targets, synthesize_teeth  # noqa: E402


def _published(mech):
    """The published table without its alternative gears: forward gears in order, reverse set."""
    real = [g for g in mech.gears if g.kind == "gear" and not g.alternative]
    return ([frozenset(g.engaged) for g in real if float(g.ratio) > 0],
            {frozenset(g.engaged) for g in real if float(g.ratio) < 0})


def _rank(mech, top=50):
    fwd, rev = _published(mech)
    result = synthesize_table(dataclasses.replace(mech, gears=()), len(fwd), len(rev), top=top)
    for i, t in enumerate(result.tables, start=1):
        if [c.engaged for c in t.forward] == fwd and {c.engaged for c in t.reverse} == rev:
            return i, result
    return None, result


def test_zf9hp48_table_with_its_dogs_comes_out_first():
    """Measured: rank 1. Its dogs engage only on downshifts (F in 5-4, A in 8-7), at synchronism.
    Without the dog rule the table ties with one that shifts 3-4 on B E F (releasing A) and engages
    A again on the 4-5 upshift: the runner-up now, lower by exactly the dog-upshift penalty."""
    mech = load_mechanism("zf9hp48")
    rank, result = _rank(mech)
    print(f"zf9hp48: published table ranks {rank} of {len(result.tables)}")
    assert rank == 1
    best, second = result.tables[:2]
    assert best.dog_shifts == (("5-4", "F"), ("8-7", "A"))
    assert [c.names for c in second.forward][3] == ("B", "E", "F")
    assert ("4-5", "A") in second.dog_shifts
    assert best.score - second.score == pytest.approx(DOG_UPSHIFT_PENALTY, abs=1e-9)
    assert best.to_dict()["dog_shifts"] == [["5-4", "F"], ["8-7", "A"]]


def test_mb7g_tronic_table_ignoring_its_alternative_reverse():
    """Measured: the 722.9's table (7 forward, the first reverse; the alternative R2 left out)
    ranks 1."""
    mech = load_mechanism("mb7g_tronic")
    rank, result = _rank(mech)
    print(f"mb7g_tronic: published table ranks {rank} of {len(result.tables)}")
    assert rank == 1


def test_table_command_counts_no_alternative_gear_and_reports_dog_shifts(tmp_path, capsys):
    bare = tmp_path / "bare.mech"
    bare.write_text("\n".join(line for line in load_mechanism("zf9hp48").text.split("\n")
                              if not line.startswith("gear")))
    assert main(["synthesize", "table", str(bare), "--forward", "9", "--top", "2"]) == 0
    out = capsys.readouterr().out
    assert "dogs engage in F 5-4 A 8-7" in out
    # --forward from the file: the 722.9's alternative reverse is not counted
    assert main(["synthesize", "table", "mb7g_tronic", "--top", "1", "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert len([k for k in doc["tables"][0]["gears"] if not k.startswith("R")]) == 7


@pytest.mark.parametrize("free, holds", [("positive", True), ("negative", False)])
def test_one_way_clutch_on_a_stepped_set_holds_by_its_static_torque(free, holds):
    """The ring's reaction (powerflow: -3.27 N*m per N*m through B1, from R to the housing) loads a
    one-way clutch in its place against ``free=positive`` only."""
    text = STEPPED2.read_text().replace("brake B1 R static=500 dynamic=400", f"oneway F R free={free}")
    text = text.replace("gear 1 = B1", "gear 1 = F")
    mech = parse_mechanism(text)
    found = {c.engaged for c in gear_candidates(mech)}
    assert (frozenset({"F"}) in found) == holds
    assert frozenset({"K"}) in found


def test_tooth_synthesis_beside_a_stepped_set():
    text = (DATA / "stepped_unknown_planetary.mech").read_text()
    mech = parse_mechanism(text, unknown_teeth=True)
    result = synthesize_teeth(mech, ratio_targets(mech), top=3)
    assert result.solutions
    for s in result.solutions:
        (q,) = s.teeth
        k = 1 + q.n_sun / q.n_ring  # gear 2: K locks the stepped set, Q with its sun held
        assert abs(k - 1.43) <= 0.005
        assert abs(k * (1 + 80 * 25 / (30 * 20)) - 6.21) <= 0.005


def test_unknown_teeth_on_a_stepped_set_is_a_clear_error(tmp_path, capsys):
    path = tmp_path / "q.mech"
    path.write_text(STEPPED2.read_text().replace("Ns1=30", "Ns1=?"))
    assert main(["synthesize", "teeth", str(path)]) == 2
    err = capsys.readouterr().err
    assert "q.mech:5:" in err and "Ns1 cannot be unknown" in err and "only the tooth counts Ns, Nr of a planetary" in err


# ------------------------------------------------------------- random stepped trains with dogs

import random  # noqa: E402
import re  # noqa: E402

import independent as ind  # noqa: E402
from hypothesis import HealthCheck  # noqa: E402

from transgen.errors import MechError  # noqa: E402
from transgen.kinematics import combinations  # noqa: E402
from transgen.powerflow import PowerFlowError  # noqa: E402


def _random_stepped_text(rng: random.Random) -> str:
    """A stepped set of 2-4 gears (carrier or a gear possibly the housing), maybe a planetary,
    clutches, brakes and dogs; every combination with one DOF becomes a gear."""
    links = [f"L{i}" for i in range(rng.randint(4, 6))]
    pool = links + [HOUSING]
    roles = rng.sample(["sun1", "sun2", "ring1", "ring2"], rng.randint(2, 4))
    members = rng.sample(pool, len(roles) + 1)
    np1, np2 = rng.randint(12, 30), rng.randint(12, 30)
    parts = []
    for role, link in zip(roles, members[1:]):
        step = np1 if role.endswith("1") else np2
        teeth = rng.randint(step + 20, 140) if role.startswith("ring") else rng.randint(14, 70)
        parts.append(f"{role}={link} {'Ns' if role.startswith('sun') else 'Nr'}{role[-1]}={teeth}")
    steps = "".join(f" Np{k}={n}" for k, n in (("1", np1), ("2", np2)) if any(r.endswith(k) for r in roles))
    out = [f"link {k} J=0.1" for k in links]
    out.append(f"stepped S carrier={members[0]} {' '.join(parts)}{steps} eta0={rng.choice([0.9, 0.95, 0.98])}")
    if rng.random() < 0.5:
        sun, ring, carrier = rng.sample(pool, 3)
        ns = rng.randint(15, 40)
        out.append(f"planetary P sun={sun} ring={ring} carrier={carrier} Ns={ns} Nr={ns + rng.randint(20, 60)} "
                   f"pinions={rng.choice([1, 2])}")
    for i in range(rng.randint(2, 4)):
        kind = rng.choice(["clutch", "brake", "dog", "dogbrake"])
        if kind in ("clutch", "dog"):
            a, b = rng.sample(links, 2)
            out.append(f"clutch K{i} {a} {b} static=10 dynamic=8" if kind == "clutch" else f"dog K{i} {a} {b}")
        else:
            out.append(f"brake K{i} {rng.choice(links)} static=10 dynamic=8" if kind == "brake"
                       else f"dog K{i} {rng.choice(links)}")
    a, b = rng.sample(links, 2)
    return "\n".join(out + [f"input {a}", f"output {b}"]) + "\n"


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(seed=st.integers(0, 2**32 - 1))
def test_power_flow_of_random_stepped_trains_with_dogs(seed):
    """Lossless: the torque ratio and element torques of an independent exact static solution
    (constraints written from the Mechanism, tests/independent.py); lossy: torque and power
    balances, the pinion balance and an efficiency no better than lossless."""
    text = _random_stepped_text(random.Random(seed))
    try:
        mech = parse_mechanism(text)
    except MechError:
        return  # two gears that would turn together, ...
    gears = [c for c in combinations(mech) if c.kind == "gear" and c.engaged]
    if not gears:
        return
    text += "".join(f"gear g{i} = {' '.join(c.engaged)}\n" for i, c in enumerate(gears))
    mech = parse_mechanism(text)
    plain = parse_mechanism(re.sub(r" eta0=\S+", "", text))  # without the file's eta0, which would win
    for gear in mech.gears:
        try:
            lossless = power_flow(plain, eta0=1.0, gears=[gear.name]).gears[0]
        except PowerFlowError as exc:
            assert "not unique" in str(exc) or "no static equilibrium" in str(exc)
            continue
        a = ind.constraint_matrix(mech, gear.engaged)
        s = ind.input_matrix(mech, ("T_in", "T_out"))
        sol, params = s[:, 1].row_join(a.T).gauss_jordan_solve(-s[:, 0])
        # elements in parallel split their torque freely (transgen reports their sum as a group)
        assert not sol[0].free_symbols, text
        assert abs(lossless.torque_ratio - float(sol[0])) <= 1e-9 * max(1.0, abs(float(sol[0]))), text
        n_tf = a.rows - len(gear.engaged)
        for k, e in enumerate(gear.engaged):
            if sol[1 + n_tf + k].free_symbols:
                continue
            t = -float(sol[1 + n_tf + k])
            found = [v for label, v in lossless.element_torques.items() if label.split("+")[0] == e]
            if found:
                assert abs(found[0] - t) <= 1e-9 * max(1.0, abs(t)), (text, gear.name, e)
        flow = power_flow(mech, gears=[gear.name])
        g = flow.gears[0]
        size = max(1.0, abs(g.torque_ratio))
        for r in _link_balance_residuals(mech, g).values():
            assert abs(r) <= 1e-8 * size, text
        assert abs(g.input_power - g.output_power - g.losses) <= 1e-8 * size
        assert g.losses >= -1e-10
        _stepped_balance(mech, g, flow.eta)
        if not g.warnings:
            assert 0 < g.efficiency <= lossless.efficiency + 1e-12


# ---------------------------------------------------------------------------------- simulator


def test_launch_of_the_stepped_example_runs_its_ratios_and_balances_energy(tmp_path):
    """``transgen scenario new`` and the simulator on a stepped set: 1st holds the stepped ratio
    1 + Nr*Np1/(Ns*Np2), the 1-2 upshift hands B1 over to K, and the energy balance closes."""
    from transgen.sim.derive.launch import launch_scenario
    from transgen.sim.scenario.load import load_scenario

    path = tmp_path / "stepped.toml"
    path.write_text(launch_scenario(load_mechanism(STEPPED2), mechanism_ref=str(STEPPED2)))
    r = load_scenario(path, {"simulation.t_end": 8.0}).run()
    assert r.success, r.message
    assert [(e.kind, e.elements) for e in r.events if e.kind in ("lock", "unlock")] == [
        ("unlock", ("B1",)), ("lock", ("K",))]
    s = r.signals
    first = (s["locked_B1"] == 1.0) & (s["w_OUT"] > 1.0)
    assert first.sum() > 10
    assert np.allclose(s["w_IN"][first] / s["w_OUT"][first], 1 + 80 * 25 / (30 * 20), rtol=1e-9)
    assert np.allclose(s["w_R"][first], 0.0, atol=1e-9)
    residual = s["E_in"] - s["E_load"] - s["E_dissipated"] - s["E_stored"]  # E_stored: from its start value
    assert np.max(np.abs(residual - residual[0])) <= 1e-5 * np.max(np.abs(s["E_in"]))
