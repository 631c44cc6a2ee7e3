"""Lever analogy (transgen.drawing.lever, lever_figure, ``transgen lever``): node spacing from the
tooth counts, levers combined where sets share two nodes, every node's speed on its lever's
straight line (in every gear of every bundled mechanism, and for every motion of random gear
trains), every bundled mechanism draws, and the command's errors and outputs."""
from __future__ import annotations

import json
from fractions import Fraction

import matplotlib

matplotlib.use("Agg")

import numpy as np  # noqa: E402
import pytest  # noqa: E402
from hypothesis import given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402
from matplotlib.text import Text  # noqa: E402

from transgen import build_graph, bundled_mechanisms, load_mechanism  # noqa: E402
from transgen.cli import main  # noqa: E402
from transgen.drawing import draw_levers, draw_speed_chart, lever_layout, lever_speeds  # noqa: E402
from transgen.kinematics import constraint_matrix, link_speeds, null_space  # noqa: E402
from transgen.graph import link_nodes  # noqa: E402
from transgen.model import HOUSING, GearPair, Link, Mechanism, Planetary  # noqa: E402

BUNDLED = sorted(bundled_mechanisms())


def _mech(planetaries=(), pairs=(), links=("A", "B", "C", "D")) -> Mechanism:
    return Mechanism("test", tuple(Link(n, 1.0) for n in links), tuple(planetaries), tuple(pairs),
                     input=links[0], output=links[-1])


def _positions(lever):
    return {n.link: n.position for n in lever.nodes}


# ------------------------------------------------------------------------------- node spacing

@pytest.mark.parametrize("ns, nr", [(45, 75), (52, 136), (26, 70), (30, 72), (23, 85)])
def test_simple_set_carrier_between_sun_and_ring_spaced_nr_to_ns(ns, nr):
    (lever, *_) = lever_layout(_mech([Planetary("P", "A", "B", "C", ns, nr)]))
    pos = _positions(lever)
    assert lever.links == ("A", "C", "B")  # sun, carrier, ring
    assert pos["C"] - pos["A"] == nr and pos["B"] - pos["C"] == ns  # C-S ~ Nr, C-R ~ Ns
    assert lever.nodes[0].members == ("P.sun",) and lever.length == ns + nr


@pytest.mark.parametrize("ns, nr", [(30, 72), (40, 98)])
def test_double_pinion_set_ring_between_sun_and_carrier(ns, nr):
    (lever, *_) = lever_layout(_mech([Planetary("P", "A", "B", "C", ns, nr, pinions=2)]))
    pos = _positions(lever)
    assert lever.links == ("A", "B", "C")  # sun, ring, carrier
    assert pos["B"] - pos["A"] == nr - ns and pos["C"] - pos["B"] == ns


def test_gear_pairs_pivot_on_the_housing():
    ext = lever_layout(_mech(pairs=[GearPair("G", "A", "B", 20, 50)]))[0]
    assert ext.links == ("A", HOUSING, "B") and _positions(ext) == {"A": 0, HOUSING: 50, "B": 70}
    inner = lever_layout(_mech(pairs=[GearPair("G", "A", "B", 20, 50, mesh="internal")]))[0]
    assert inner.links == (HOUSING, "B", "A") and _positions(inner) == {HOUSING: 0, "B": 20, "A": 50}


# --------------------------------------------------------------------------- combining levers

def test_ravigneaux_set_is_one_four_node_lever():
    levers = lever_layout(load_mechanism("hsw_ravigneaux4"))
    rav = levers[0]
    assert rav.sets == ("PG_small", "PG_large")
    # small sun, ring, carrier, large sun: small-set teeth (30/72) give S-R 42, R-C 30; the large
    # set (36/72) puts its sun 72/36 * 30 = 60 beyond the carrier
    assert [(n.link, n.position) for n in rav.nodes] == [("Ss", 0), ("OUT_R", 42), ("C", 72), ("Sl", 132)]
    assert dict((n.link, n.members) for n in rav.nodes)["C"] == ("PG_small.carrier", "PG_large.carrier")
    assert [lv.links for lv in levers[1:]] == [("IN",)]  # the input shaft, on no gearset


def test_simpson_set_and_ht740_combine_sets_sharing_two_members():
    (simpson, shaft) = lever_layout(load_mechanism("zf3hp22_big"))
    assert simpson.links == ("S", "Cr", "OUT_Cf_Rr", "Rf") and shaft.links == ("IN",)
    (ht, l1) = lever_layout(load_mechanism("ht740"))
    assert ht.sets == ("P1", "P2", "P3") and ht.links == ("L3", "L4", "L5", "L6", "L2") and l1.links == ("L1",)
    pos = _positions(ht)  # P2 (52/136) maps onto P1 by L3, L6: L2 lies 188/136 of P1's S-R span up
    assert pos["L2"] == pytest.approx(float(Fraction(188 * 120, 136)))


def test_sets_sharing_one_member_stay_separate_levers():
    levers = lever_layout(load_mechanism("zf8hp70"))
    assert [lv.sets for lv in levers] == [("PS1",), ("PS2",), ("PS3",), ("PS4",)]
    shared = [link for link in ("S1_S2", "R2_S3", "R3_S4", "C1_R4") if sum(link in lv.links for lv in levers) == 2]
    assert len(shared) == 4


def test_sets_that_disagree_on_a_third_shared_node_are_not_combined():
    # P1 and P2 share A, C; P3 shares A, B, C with them but puts B elsewhere: no single lever
    m = _mech([Planetary("P1", "A", "B", "C", 30, 70), Planetary("P2", "A", "D", "C", 30, 90),
               Planetary("P3", "A", "B", "C", 40, 70)])
    levers = lever_layout(m)
    assert sorted(lv.sets for lv in levers) == [("P1", "P2"), ("P3",)]


# ------------------------------------------------------------------------ speeds on the lever

def _assert_collinear(lever, speeds, context):
    known = [(n.position, speeds[n.link]) for n in lever.nodes if speeds.get(n.link) is not None]
    if len(lever.nodes) < 2 or len(known) < 2:
        return
    (x0, w0), (x1, w1) = known[0], known[-1]
    if x1 == x0:
        assert all(abs(w - w0) < 1e-9 for _, w in known), context
        return
    slope = (w1 - w0) / (x1 - x0)
    size = max(1.0, max(abs(w) for _, w in known))
    for x, w in known:
        assert abs(w0 + slope * (x - x0) - w) <= 1e-9 * size, f"{context}: node at {x} off the lever line"
    # a lever with two known nodes fixes all of them
    assert len(known) == len(lever.nodes), f"{context}: a node of a determined lever is left free"


@pytest.mark.parametrize("name", BUNDLED)
def test_every_node_speed_lies_on_its_lever_in_every_gear(name):
    mech = load_mechanism(name)
    levers = lever_layout(mech)
    assert sorted({n.link for lv in levers for n in lv.nodes} - {HOUSING}) == sorted(mech.link_names)
    for gear in (g for g in mech.gears if g.kind == "gear"):
        speeds = lever_speeds(mech, gear.name)
        assert speeds[mech.input] == pytest.approx(1.0) and speeds[HOUSING] == 0.0
        for lever in levers:
            _assert_collinear(lever, speeds, f"{name} gear {gear.name} lever {lever.name}")
        # engaged brakes hold their link, engaged clutches join equal speeds
        for e in (mech.element(x) for x in gear.engaged):
            if e.kind != "oneway":
                assert speeds[e.link1] == pytest.approx(speeds[e.link2], abs=1e-12)


def test_published_ratios_follow_from_the_lever_speeds():
    mech = load_mechanism("zf8hp70")
    for gear in (g for g in mech.gears if g.kind == "gear"):
        assert 1 / lever_speeds(mech, gear.name)["OUT_C4"] == pytest.approx(float(gear.ratio), abs=5e-5)


@st.composite
def gear_trains(draw):
    """Random planetaries and gear pairs over 3-6 links (members may be the housing)."""
    n = draw(st.integers(3, 6))
    links = tuple(f"L{i}" for i in range(n))
    pool = list(links) + [HOUSING]
    sets = []
    for k in range(draw(st.integers(1, 4))):
        members = draw(st.permutations(pool))[:3]
        ns = draw(st.integers(12, 60))
        nr = draw(st.integers(ns + 12, 150))
        sets.append(Planetary(f"P{k}", *members, ns, nr, pinions=draw(st.sampled_from([1, 2]))))
    pairs = []
    for k in range(draw(st.integers(0, 2))):
        a, b = draw(st.permutations(links))[:2]
        pairs.append(GearPair(f"G{k}", a, b, draw(st.integers(11, 80)), draw(st.integers(11, 80)),
                              mesh=draw(st.sampled_from(["external", "internal"]))))
    return _mech(sets, pairs, links)


@settings(max_examples=150, deadline=None)
@given(gear_trains())
def test_every_motion_of_a_random_gear_train_is_a_straight_line_on_every_lever(mech):
    g = build_graph(mech)
    names = link_nodes(g)
    basis = null_space(constraint_matrix(g), len(names))
    levers = lever_layout(mech)
    for lever in levers:
        assert [n.position for n in lever.nodes] == sorted(n.position for n in lever.nodes)
        assert lever.nodes[0].position == 0.0
    for motion in basis.T:
        speeds = dict(zip(names, motion)) | {HOUSING: 0.0}
        for lever in levers:
            _assert_collinear(lever, speeds, f"lever {lever.name}")


# ------------------------------------------------------------------------------------ drawing

@pytest.fixture
def figures():
    made = []
    yield made
    for fig in made:
        fig.clear()


@pytest.mark.parametrize("name", BUNDLED)
def test_every_bundled_mechanism_draws_its_levers_and_chart(name, figures):
    mech = load_mechanism(name)
    fig = draw_levers(mech)
    figures.append(fig)
    gids = {t.get_gid() for t in fig.findobj(Text)}
    gears = [g.name for g in mech.gears if g.kind == "gear"]
    for panel in ["levers"] + gears:
        assert f"title:{panel}" in gids
        for lever in lever_layout(mech):
            for n in lever.nodes:
                assert f"node:{panel}:{lever.name}:{n.link}" in gids
    if gears:
        chart = draw_speed_chart(mech)
        figures.append(chart)
        assert {f"speed:{link}" for link in mech.link_names} <= {ln.get_gid() for ln in chart.axes[0].lines}
    else:
        with pytest.raises(ValueError, match="no gear"):
            draw_speed_chart(mech)


def test_node_labels_show_the_speeds_and_do_not_overlap(figures):
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    mech = load_mechanism("ht740")
    fig = draw_levers(mech, ["1", "R"])
    figures.append(fig)
    texts = {t.get_gid(): t for t in fig.findobj(Text) if (t.get_gid() or "").startswith("node:")}
    assert texts["node:1:P1+P2+P3:L6"].get_text() == "L6 out 0.27"
    assert texts["node:R:P1+P2+P3:L2"].get_text() == "L2 -0.61"
    assert not any(g.startswith("node:levers:") for g in texts)  # no topology panel with chosen gears
    canvas = FigureCanvasAgg(fig)
    canvas.draw()
    renderer = canvas.get_renderer()
    boxes = [(g, t.get_window_extent(renderer)) for g, t in texts.items()]
    clashes = [(a, b) for i, (a, ba) in enumerate(boxes) for b, bb in boxes[i + 1:] if ba.overlaps(bb)]
    assert not clashes


def test_a_neutral_or_unknown_gear_is_refused():
    mech = load_mechanism("ht740")
    with pytest.raises(ValueError, match="neutral"):
        draw_levers(mech, ["N"])
    with pytest.raises(ValueError, match=r"gears: 1 2 3 4 R"):
        draw_levers(mech, ["5"])


# ----------------------------------------------------------------------------- command line

def test_lever_command_writes_the_pictures(tmp_path, capsys):
    out, chart = tmp_path / "levers.svg", tmp_path / "speeds.png"
    assert main(["lever", "hsw_ravigneaux4", "-o", str(out), "--chart", str(chart)]) == 0
    assert out.read_text().lstrip().startswith("<?xml") and chart.read_bytes()[:4] == b"\x89PNG"
    assert "wrote" in capsys.readouterr().out
    assert main(["lever", "zf8hp70", "--gear", "1", "--gear", "R", "-o", str(tmp_path / "z.pdf")]) == 0
    assert (tmp_path / "z.pdf").read_bytes()[:4] == b"%PDF"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["levers.svg", "speeds.png", "z.pdf"]


@pytest.mark.parametrize("argv, message", [
    (["-o", "levers.txt"], "unknown suffix '.txt'"),
    (["--chart", "speeds.dot", "-o", "levers.png"], "unknown suffix '.dot'"),
    (["--gear", "7", "-o", "levers.png"], "'7' is not a declared gear"),
    (["--gear", "N", "-o", "levers.png"], "'N' is a neutral"),
    ([], "nothing to do"),
])
def test_lever_command_bad_input_exits_2_and_writes_nothing(argv, message, tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert main(["lever", "ht740"] + argv) == 2
    err = capsys.readouterr().err
    assert err.startswith("error: ") and message in err and "Traceback" not in err
    assert list(tmp_path.iterdir()) == []


def test_lever_json_gives_the_geometry_and_speeds(capsys):
    assert main(["lever", "ht740", "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["schema"] == "transgen.lever/1"
    assert [lv["name"] for lv in doc["levers"]] == ["P1+P2+P3", "L1"]
    rows = {g["name"]: g for g in doc["gears"]}
    assert list(rows) == ["1", "2", "3", "4", "R"]
    assert rows["1"]["ratio"] == pytest.approx(48 / 13) and rows["R"]["ratio"] == pytest.approx(-1021 / 169)
    assert rows["4"]["speeds"] == pytest.approx({f"L{i}": 1.0 for i in range(1, 7)})
    assert rows["1"]["speeds"] == pytest.approx(link_speeds(load_mechanism("ht740"), ("C1", "C5")))


FLOATING = """transmission "a set left free"
link IN J=0.05
link S J=0.01
link R J=0.01
link C J=0.02
link S2 J=0.01
link R2 J=0.01
link C2 J=0.01
planetary P sun=S ring=R carrier=C Ns=30 Nr=70
planetary Q sun=S2 ring=R2 carrier=C2 Ns=30 Nr=70
clutch K1 IN S static=100 dynamic=80
brake B1 R static=100 dynamic=80
clutch K2 C C2 static=100 dynamic=80
input IN
output C
gear 1 = K1 B1
"""


def test_a_lever_the_gear_leaves_free_is_drawn_free(figures):
    from transgen import parse_mechanism

    mech = parse_mechanism(FLOATING, "floating.mech")
    speeds = lever_speeds(mech, "1")
    assert speeds["C"] == pytest.approx(30 / 100) and {speeds[k] for k in ("S2", "R2", "C2")} == {None}
    fig = draw_levers(mech)
    figures.append(fig)
    texts = {t.get_gid(): t.get_text() for t in fig.findobj(Text)}
    assert texts["node:1:Q:C2"] == "C2 free" and texts["node:1:P:C"] == "C out 0.30"
