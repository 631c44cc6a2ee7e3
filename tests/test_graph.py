"""The mechanism graph without networkx (:class:`transgen.graph.BondGraph`, what the numeric
pipeline builds) and the networkx graph of :func:`transgen.graph.build_graph` (the documented
model, drawn and exported) are the same graph: the same nodes, attributes and bonds, read in the
same order through the same calls, and every stage of the numeric pipeline gives bit-identical
results on either."""
from __future__ import annotations

import networkx as nx
import numpy as np
import pytest

from transgen import bundled_mechanisms, load_mechanism, parse_mechanism
from transgen.equations import assemble, diagnose_singular, input_names, locking_groups, solve
from transgen.errors import ModeError
from transgen.graph import BondGraph, bond_graph, build_graph, element_nodes, link_nodes, transformer_ports
from transgen.kinematics import analyze, constraint_matrix, engaged_combinations

# every kind of node and bond: double-pinion and simple planetaries, gear pairs by teeth and by
# radius, external and internal, elements in parallel (a brake beside a one-way clutch), a brake
# on a massless link, named loads
EVERY_KIND = """\
transmission "every kind of bond"
link A J=0.1
link B J=0.2
link C J=0.3
link D J=0
link E J=0.05
planetary P1 sun=A ring=B carrier=C Ns=30 Nr=70
planetary P2 sun=D ring=C carrier=B Ns=25 Nr=75 pinions=2
gears G1 C E N1=20 N2=40
gears G2 E B r1=0.03 r2=0.09 mesh=internal
clutch K1 A B static=100 dynamic=80
brake BD D static=100 dynamic=80
oneway F D free=positive
brake BE E static=100 dynamic=80
input A
output E
torque Tload C
"""


def mechanisms():
    yield parse_mechanism(EVERY_KIND, "every_kind.mech")
    for name in bundled_mechanisms():
        yield load_mechanism(name)


MECHANISMS = list(mechanisms())
IDS = [m.name for m in MECHANISMS]


@pytest.mark.parametrize("mech", MECHANISMS, ids=IDS)
def test_the_bond_graph_reads_as_the_networkx_graph(mech):
    light, g = bond_graph(mech), build_graph(mech)
    assert isinstance(light, BondGraph) and isinstance(g, nx.DiGraph)
    assert light.graph == g.graph and light.name == g.name
    assert list(light.nodes) == list(g.nodes) and len(light.nodes) == len(g.nodes)
    assert list(light.nodes(data=True)) == list(g.nodes(data=True))
    assert all(light.nodes[n] == g.nodes[n] and n in light.nodes for n in g.nodes)
    assert list(light.edges(data=True)) == list(g.edges(data=True))
    assert list(light.edges()) == list(g.edges())
    for n in g.nodes:
        assert list(light.in_edges(n, data=True)) == list(g.in_edges(n, data=True))
        assert list(light.out_edges(n, data=True)) == list(g.out_edges(n, data=True))
        assert list(light.in_edges(n)) == list(g.in_edges(n))
    for nodes_of in (link_nodes, element_nodes, input_names, locking_groups):
        assert nodes_of(light) == nodes_of(g)
    for t in (n for n, d in g.nodes(data=True) if d["kind"] in ("planetary", "gearpair")):
        assert transformer_ports(light, t) == transformer_ports(g, t)


@pytest.mark.parametrize("mech", MECHANISMS, ids=IDS)
def test_the_numeric_pipeline_gives_the_same_numbers_on_either_graph(mech):
    light, g = bond_graph(mech), build_graph(mech)
    combos = engaged_combinations(element_nodes(g))[:64]
    for locked in combos:
        assert np.array_equal(constraint_matrix(light, locked), constraint_matrix(g, locked))
        assert analyze(mech, locked, light) == analyze(mech, locked, g)
        problem = diagnose_singular(light, locked)
        assert problem == diagnose_singular(g, locked)
        a, b = assemble(light, locked), assemble(g, locked)
        assert a.z == b.z and a.u == b.u and np.array_equal(a.E, b.E) and np.array_equal(a.F, b.F)
        if problem:
            continue
        try:
            x = solve(a, light)
        except ModeError as exc:
            with pytest.raises(ModeError, match=str(exc)):
                solve(b, g)
            continue
        assert np.array_equal(x.G, solve(b, g).G)


def test_the_bond_graph_adds_edges_and_nodes_as_networkx_does():
    light, g = BondGraph(name="x"), nx.DiGraph(name="x")
    for graph in (light, g):
        graph.add_node("a", kind="link", J=1.0)
        graph.add_edge("d", "b")  # missing nodes are added, without attributes
        graph.add_edge("a", "b", bond="element")  # b's predecessors: d, a (not in the order of the nodes)
        graph.add_edge("c", "a", bond="source")
        graph.add_edge("a", "b", side=1)  # the same bond again: its attributes are updated
        graph.add_node("a", label="A")
    assert list(light.nodes(data=True)) == list(g.nodes(data=True))
    assert list(light.edges(data=True)) == list(g.edges(data=True))
    converted = light.to_networkx()
    assert nx.utils.graphs_equal(converted, g)
    assert list(converted.edges(data=True)) == list(g.edges(data=True))
    for n in g:
        assert list(light.in_edges(n)) == list(converted.in_edges(n)) == list(g.in_edges(n))
        assert list(light.out_edges(n)) == list(converted.out_edges(n)) == list(g.out_edges(n))
