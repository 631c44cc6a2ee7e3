"""Pictures and graph-file exports (transgen.drawing): every bundled mechanism draws, every node
and mode is labelled, labels do not overlap, STD arrows end on the bubbles they join, DOT and
GraphML are well formed, and figures are saved atomically."""

import os
import subprocess
import sys
from itertools import combinations
from pathlib import Path

import matplotlib

matplotlib.use("Agg")

import networkx as nx  # noqa: E402
import pytest  # noqa: E402
from matplotlib.backends.backend_agg import FigureCanvasAgg  # noqa: E402
from matplotlib.figure import Figure  # noqa: E402
from matplotlib.patches import Ellipse, FancyArrowPatch  # noqa: E402
from matplotlib.text import Text  # noqa: E402

from transgen import build_graph, bundled_mechanisms, load_mechanism  # noqa: E402
from transgen.drawing import (  # noqa: E402
    FIGURE_FORMATS,
    draw_graph,
    draw_std,
    graph_to_dot,
    graph_to_graphml,
    save_figure,
    std_to_dot,
)
from transgen.std import state_transition_diagram  # noqa: E402

BUNDLED = sorted(bundled_mechanisms())


@pytest.fixture
def figures():
    """Collects figures and clears them after the test (no pyplot registry to close)."""
    made = []
    yield made
    for fig in made:
        fig.clear()


def _texts(fig):
    return [t for t in fig.findobj(Text) if t.get_text()]


def _rendered(fig):
    """Draw with Agg and return the renderer (window extents are then final)."""
    canvas = FigureCanvasAgg(fig)
    canvas.draw()
    return canvas.get_renderer()


def _assert_no_overlap(fig, texts):
    renderer = _rendered(fig)
    boxes = [(t.get_gid(), t.get_window_extent(renderer)) for t in texts]
    clashes = [(a, b) for (a, ba), (b, bb) in combinations(boxes, 2) if ba.overlaps(bb)]
    assert not clashes, f"overlapping labels: {clashes[:5]}"


# ------------------------------------------------------------------------------ mechanism graph

@pytest.mark.parametrize("name", BUNDLED)
def test_graph_figure_has_a_label_for_every_node(name, figures):
    g = build_graph(load_mechanism(name))
    fig = draw_graph(g)
    figures.append(fig)
    assert isinstance(fig, Figure)
    texts = _texts(fig)
    by_gid = {t.get_gid(): t.get_text() for t in texts}
    for node, data in g.nodes(data=True):
        assert node in by_gid, f"no text artist for node {node}"
        words = by_gid[node].replace(":", " ").split()
        assert node in words
    # every transformer port is named on its bond
    ports = {t.get_gid() for t in texts if (t.get_gid() or "").startswith("port:")}
    expected = {f"port:{u}->{v}" for u, v, d in g.edges(data=True) if d.get("bond") == "port"}
    assert ports == expected


def test_graph_labels_show_the_bond_graph_vocabulary(figures):
    g = build_graph(load_mechanism("ht740"))
    fig = draw_graph(g)
    figures.append(fig)
    by_gid = {t.get_gid(): t.get_text() for t in _texts(fig)}
    assert by_gid["L1"] == "1: L1\nJ=0.25"
    assert by_gid["P2"] == "MTF: P2\nNs=52  Nr=136"
    assert by_gid["C3"] == "brake\nC3"
    assert by_gid["housing"].startswith("Sf=0")
    assert by_gid["T_in"] == "Se: T_in"
    assert by_gid["port:L6->P2"] == "carrier"
    simple = {t.get_gid(): t.get_text() for t in _texts(draw_graph(load_mechanism("simple2")))}
    assert simple["Gi1"] == "TF: Gi1 (external)\nr1=0.03  r2=0.08"


@pytest.mark.parametrize("name", ["ht740", "zf8hp70", "simple2", "mb722_6_w5a330_1996"])
def test_graph_labels_do_not_overlap(name, figures):
    fig = draw_graph(build_graph(load_mechanism(name)))
    figures.append(fig)
    _assert_no_overlap(fig, [t for t in _texts(fig) if t.get_gid() != "title"])


def test_graph_figure_size_grows_with_the_mechanism(figures):
    small = draw_graph(load_mechanism("simple2"))
    big = draw_graph(load_mechanism("zf8hp70"))
    figures += [small, big]
    assert big.get_size_inches()[0] > small.get_size_inches()[0]


def test_graph_layout_is_deterministic(figures):
    a = draw_graph(load_mechanism("zf8hp70"))
    b = draw_graph(load_mechanism("zf8hp70"))
    figures += [a, b]
    assert [(t.get_gid(), t.get_position()) for t in _texts(a)] == [(t.get_gid(), t.get_position()) for t in _texts(b)]


def test_housing_as_planetary_member_gets_its_own_copy(figures):
    from transgen import parse_mechanism

    mech = parse_mechanism(
        "transmission \"t\"\nlink A J=1\nlink B J=1\n"
        "planetary P sun=A ring=housing carrier=B Ns=30 Nr=70\n"
        "brake K A static=10 dynamic=8\ninput A\noutput B\n")
    fig = draw_graph(mech)
    figures.append(fig)
    gids = {t.get_gid() for t in _texts(fig)}
    assert {"housing", "housing@P", "port:housing->P"} <= gids


# ----------------------------------------------------------------------- state-transition diagram

@pytest.mark.parametrize("name", ["simple2", "ht740"])
def test_std_figure_has_every_mode_and_transition(name, figures):
    std = state_transition_diagram(load_mechanism(name))
    fig = draw_std(std)
    figures.append(fig)
    texts = _texts(fig)
    by_gid = {t.get_gid(): t.get_text() for t in texts}
    for mode in std.modes:
        lines = by_gid[mode.name].split("\n")
        assert lines[0] == mode.name
        assert lines[1] == (" ".join(mode.locked) if mode.locked else "(none locked)")
    labels = sorted(t.get_text() for t in texts if (t.get_gid() or "").startswith("transition:"))
    assert labels == sorted(f"{t.event} {t.element}" for t in std.internal)
    assert not any("capacity" in t.get_text() or "slip" in t.get_text() for t in texts)


def test_ht740_mode_bubble_text():
    std = state_transition_diagram(load_mechanism("ht740"))
    fig = draw_std(std)
    by_gid = {t.get_gid(): t.get_text() for t in _texts(fig)}
    assert by_gid["M5"] == "M5\nC1\nspeed phase 1-2,\n2-3, 3-4"
    fig.clear()


def _arrow_ends(fig, std):
    """For every transition arrow: (source, target, min normalised radius of its path w.r.t. the
    source, the target and every other bubble)."""
    _rendered(fig)
    ellipses = {p.get_gid(): p for p in fig.findobj(Ellipse)}
    out = []
    for arrow in fig.findobj(FancyArrowPatch):
        source, target = arrow.get_gid().removeprefix("arrow:").split("->")
        verts = arrow.get_path().vertices  # data coordinates

        def radius(name):
            e = ellipses[name]
            (cx, cy), a, b = e.center, e.width / 2, e.height / 2
            return min((((x - cx) / a) ** 2 + ((y - cy) / b) ** 2) ** 0.5 for x, y in verts)

        others = [radius(n) for n in ellipses if n not in (source, target)]
        out.append((source, target, radius(source), radius(target), min(others, default=9.0)))
    return out


@pytest.mark.parametrize("name", ["simple2", "ht740", "zf8hp70"])
def test_std_arrows_end_on_their_bubbles(name, figures):
    std = state_transition_diagram(load_mechanism(name))
    fig = draw_std(std)
    figures.append(fig)
    ends = _arrow_ends(fig, std)
    assert sorted((s, t) for s, t, *_ in ends) == sorted((t.source, t.target) for t in std.internal)
    for source, target, r_source, r_target, r_other in ends:
        assert 0.97 < r_source < 1.12, (source, target, r_source)
        assert 0.97 < r_target < 1.12, (source, target, r_target)
        assert r_other > 1.0, f"arrow {source}->{target} crosses another bubble"


def test_std_paired_arrows_are_two_separate_arcs(figures):
    std = state_transition_diagram(load_mechanism("simple2"))
    fig = draw_std(std)
    figures.append(fig)
    _rendered(fig)
    arrows = {a.get_gid(): a.get_path().vertices for a in fig.findobj(FancyArrowPatch)}
    down, up = arrows["arrow:M1->M3"], arrows["arrow:M3->M1"]
    mid_down, mid_up = down[len(down) // 4], up[len(up) // 4]
    # the arcs bulge to opposite sides: their middles are well apart
    assert abs(mid_down[0] - mid_up[0]) > 0.15


@pytest.mark.parametrize("name", ["simple2", "ht740", "zf8hp70"])
def test_std_labels_do_not_overlap(name, figures):
    fig = draw_std(state_transition_diagram(load_mechanism(name)))
    figures.append(fig)
    _assert_no_overlap(fig, [t for t in _texts(fig) if t.get_gid() != "title"])


def test_std_modes_in_rows_by_number_of_locked_elements(figures):
    std = state_transition_diagram(load_mechanism("zf8hp70"))
    fig = draw_std(std)
    figures.append(fig)
    y = {t.get_gid(): t.get_position()[1] for t in _texts(fig)}
    rows = {}
    for m in std.modes:
        rows.setdefault(len(m.locked), set()).add(round(y[m.name], 6))
    assert all(len(ys) == 1 for ys in rows.values())
    assert rows[3].pop() > rows[2].pop()
    # the gears stay in sequence from left to right
    x = {t.get_gid(): t.get_position()[0] for t in _texts(fig)}
    gears = [f"M{i}" for i in range(1, 9)]
    assert sorted(gears, key=x.get) == gears


def test_std_leaving_stubs(figures):
    std = state_transition_diagram(load_mechanism("ht740"))
    fig = draw_std(std, leaving=True)
    figures.append(fig)
    stubs = [t for t in _texts(fig) if (t.get_gid() or "").startswith("leaving:")]
    assert len(stubs) == len(std.external)
    assert {t.get_text()[1:] for t in stubs} <= set(load_mechanism("ht740").element_names)
    _assert_no_overlap(fig, [t for t in _texts(fig) if t.get_gid() not in ("title", "leaving-note")])


def test_draw_into_a_given_axes_returns_its_figure():
    fig = Figure(figsize=(10, 4))
    ax1, ax2 = fig.subplots(1, 2)
    assert draw_graph(load_mechanism("ht740"), ax=ax1) is fig
    assert draw_std(load_mechanism("ht740"), ax=ax2) is fig
    fig.clear()


def test_drawing_uses_no_pyplot(tmp_path):
    code = ("import matplotlib, sys; from transgen import load_mechanism; "
            "from transgen.drawing import draw_graph, draw_std; m = load_mechanism('simple2'); "
            "draw_graph(m); draw_std(m); print('matplotlib.pyplot' in sys.modules)")
    # run outside the source tree: "python -c" puts the working directory first on sys.path
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True, cwd=tmp_path)
    assert out.stdout.strip() == "False"


# ---------------------------------------------------------------------------------- DOT, GraphML

def _dot_structure_ok(text: str) -> bool:
    """Braces balanced outside double-quoted strings, and every string closed."""
    depth, in_string, escaped = 0, False, False
    for ch in text:
        if in_string:
            if escaped:
                escaped = False
            elif ch == "\\":
                escaped = True
            elif ch == '"':
                in_string = False
        elif ch == '"':
            in_string = True
        elif ch == "{":
            depth += 1
        elif ch == "}":
            depth -= 1
            if depth < 0:
                return False
    return depth == 0 and not in_string


@pytest.mark.parametrize("name", BUNDLED)
def test_graph_to_dot_has_every_node_and_edge(name):
    g = build_graph(load_mechanism(name))
    dot = graph_to_dot(g)
    assert dot.startswith("digraph ")
    assert _dot_structure_ok(dot)
    for node in g:
        assert f'\n  "{node}" [label=' in dot
    for u, v in g.edges():
        assert f'"{u}" -> "{v}"' in dot
    assert dot.count(" -> ") == g.number_of_edges()
    if any(d.get("bond") == "port" for _, _, d in g.edges(data=True)):  # port labels on transformer bonds
        assert 'label="sun"' in dot or 'label="1"' in dot


@pytest.mark.parametrize("name", ["simple2", "ht740", "zf8hp70"])
def test_std_to_dot_has_every_mode_and_transition(name):
    std = state_transition_diagram(load_mechanism(name))
    dot = std_to_dot(std)
    assert _dot_structure_ok(dot)
    for mode in std.modes:
        assert f'\n  "{mode.name}" [label=' in dot
    for t in std.internal:
        assert f'"{t.source}" -> "{t.target}" [label="{t.event} {t.element}"' in dot
    assert dot.count(" -> ") == len(std.internal)
    leaving = std_to_dot(std, leaving=True)
    assert _dot_structure_ok(leaving)
    assert leaving.count(" -> ") == len(std.transitions)


def test_dot_quotes_awkward_names():
    g = nx.DiGraph(name='say "hi" {now}\\')
    g.add_node('a "b" {c}', kind="link", J=1.0)
    g.add_node("back\\slash", kind="brake")
    g.add_edge('a "b" {c}', "back\\slash", bond="element")
    dot = graph_to_dot(g)
    assert _dot_structure_ok(dot)
    assert '"a \\"b\\" {c}" -> "back\\\\slash"' in dot


@pytest.mark.parametrize("name", BUNDLED)
def test_graphml_round_trip(name):
    g = build_graph(load_mechanism(name))
    back = nx.parse_graphml(graph_to_graphml(g))
    assert set(back.nodes) == set(g.nodes)
    assert set(back.edges) == set(g.edges)
    assert back.is_directed()
    for n, d in g.nodes(data=True):
        assert back.nodes[n]["kind"] == d["kind"]
        if d["kind"] == "link":
            assert back.nodes[n]["J"] == pytest.approx(float(d["J"]))
        if "params" in d:
            assert back.nodes[n]["params"] == str(d["params"])


# ------------------------------------------------------------------------------------- saving

@pytest.mark.parametrize("suffix, magic", [(".png", b"\x89PNG"), (".svg", b"<svg"), (".pdf", b"%PDF"),
                                           (".PNG", b"\x89PNG")])
def test_save_figure_writes_the_format_of_the_suffix(tmp_path, suffix, magic):
    fig = draw_std(load_mechanism("simple2"))
    target = tmp_path / f"std{suffix}"
    assert save_figure(fig, target) == target
    data = target.read_bytes()
    assert magic in data[:400]
    assert sorted(p.name for p in tmp_path.iterdir()) == [target.name]
    fig.clear()


def test_save_figure_creates_folders_and_replaces(tmp_path):
    fig = draw_graph(load_mechanism("simple2"))
    target = tmp_path / "a" / "b" / "graph.svg"
    save_figure(fig, target)
    save_figure(fig, target)
    assert [p.name for p in target.parent.iterdir()] == ["graph.svg"]
    mask = os.umask(0o022)
    os.umask(mask)
    assert os.stat(target).st_mode & 0o777 == 0o666 & ~mask  # not mkstemp's 0600
    fig.clear()


def test_save_figure_rejects_unknown_suffix(tmp_path):
    fig = draw_std(load_mechanism("simple2"))
    for name in ("std.jpgx", "std", "std.txt"):
        with pytest.raises(ValueError, match="unknown suffix"):
            save_figure(fig, tmp_path / name)
    assert list(tmp_path.iterdir()) == []
    assert set(FIGURE_FORMATS) == {".png", ".svg", ".pdf"}
    fig.clear()


def test_save_figure_leaves_nothing_on_failure(tmp_path):
    fig = draw_std(load_mechanism("simple2"))

    def broken(*args, **kwargs):
        raise RuntimeError("disk full")

    fig.savefig = broken
    with pytest.raises(RuntimeError, match="disk full"):
        save_figure(fig, tmp_path / "std.png")
    assert list(tmp_path.iterdir()) == []
    fig.clear()


def test_save_figure_keeps_the_old_file_on_failure(tmp_path):
    target = tmp_path / "std.png"
    target.write_bytes(b"old")
    fig = draw_std(load_mechanism("simple2"))
    fig.savefig = lambda *a, **k: (_ for _ in ()).throw(OSError("boom"))
    with pytest.raises(OSError):
        save_figure(fig, target)
    assert target.read_bytes() == b"old"
    assert [p.name for p in tmp_path.iterdir()] == ["std.png"]
    fig.clear()


def test_rendered_files_of_the_thesis_examples(tmp_path):
    """The pictures the docs show: HT-740 graph and STD, simple2 STD, ZF 8HP graph and STD."""
    written = []
    for name in ("ht740", "zf8hp70"):
        mech = load_mechanism(name)
        written.append(save_figure(draw_graph(build_graph(mech)), tmp_path / f"graph_{name}.png"))
    for name in ("ht740", "simple2", "zf8hp70"):
        written.append(save_figure(draw_std(state_transition_diagram(load_mechanism(name))),
                                   tmp_path / f"std_{name}.png"))
    assert all(Path(p).stat().st_size > 10_000 for p in written)
    assert len(list(tmp_path.iterdir())) == 5


def test_titles_with_dollar_signs_are_drawn_as_text(tmp_path):
    """A title is plain text: '$' is no mathtext markup (matplotlib refused '$x' before)."""
    from transgen import parse_mechanism
    from transgen.drawing import draw_graph, draw_std, save_figure

    mech = parse_mechanism('transmission "costs $5 and 50% of $x$ \\\\ done"\nlink A J=1\nlink B J=1\n'
                           "clutch C A B static=10 dynamic=10\ninput A\noutput B\n")
    for draw, name in ((draw_graph, "g.svg"), (draw_std, "s.png")):
        save_figure(draw(mech), tmp_path / name)
        assert (tmp_path / name).stat().st_size > 0
