"""The bond-graph-like mechanism graph (thesis Figs. 3.9 and 3.13).

:func:`build_graph` turns a :class:`~transgen.model.Mechanism` into a ``networkx.DiGraph``:

========================  =====================================================================
node ``kind``             meaning
========================  =====================================================================
``"link"``                a rigid link: a 1-junction carrying its inertia (I element), ``J``
``"housing"``             the fixed case: a zero flow source (Sf = 0)
``"planetary"``           a multiport transformer (MTF) with ports sun, ring, carrier
``"gearpair"``            a two-port transformer (TF) with ports 1, 2
``"stepped"``             one constraint of a stepped-pinion planetary: ports for two central
                          gears (``sun1``, ``ring2``, ...) and ``carrier``
``"clutch"``/``"brake"``  a switched element between two junctions: a flow source (equal speeds)
``"oneway"``              when locked, an effort source (slipping torque) when unlocked
``"dog"``                 a dog clutch or brake: a flow source when locked, no effort when open
``"source"``              an external torque (effort source): ``T_in``, ``T_out``, named loads
========================  =====================================================================

Edges are bonds and point in the direction of positive power: from a link into a transformer
port (thesis eq. 3.36 convention), from ``link1`` through a shift element to ``link2``, from the
input source into the input link, from the output link into the output source.

Each transformer port edge carries the kinematic coefficient of its link in the transformer's
constraint ``sum_k c_k * w_k = 0`` as ``terms``: a tuple of ``(factor, parameter)`` pairs whose
values are in the transformer node's ``params`` (so that the numeric and the symbolic back-ends
read the same graph):

* simple planetary: ``Ns*w_s + Nr*w_r - (Ns + Nr)*w_c = 0``
* double-pinion planetary: ``-Ns*w_s + Nr*w_r - (Nr - Ns)*w_c = 0``
* external gear pair: ``n1*w1 + n2*w2 = 0``; internal: ``n1*w1 - n2*w2 = 0``
* stepped-pinion planetary, members ``A``, ``B``: ``sA*NA*Npb*wA - sB*NB*Npa*wB - (sA*NA*Npb -
  sB*NB*Npa)*wc = 0`` (``s`` -1 for a sun, +1 for a ring; ``Npa`` the pinion step ``A`` meshes)

The transformer torques follow from power conservation (eq. 3.36): the torque ``t_k`` a link
exerts on port ``k`` is proportional to ``c_k``.

:func:`bond_graph` builds the same graph as a :class:`BondGraph`: plain dictionaries read
through the same calls as the networkx graph (``g.nodes(data=True)``, ``g.nodes[name]``,
``g.in_edges(node, data=True)``, ``g.edges(data=True)``, ``g.graph``). The numeric pipeline
(kinematics, equations, modes, state space, STD) reads the graph only through these calls and
accepts either; it builds a :class:`BondGraph`, since importing networkx costs a numeric command
more start-up time than numpy does. :func:`build_graph` is that graph converted with
:meth:`BondGraph.to_networkx`, so the two hold the same nodes, attributes and bonds in the same
order; networkx is for where the graph is the product (drawing, DOT and GraphML export, graph
algorithms).
"""
from __future__ import annotations

from typing import TYPE_CHECKING

from .model import HOUSING, Mechanism, SteppedPlanetary

if TYPE_CHECKING:
    import networkx as nx

__all__ = ["build_graph", "bond_graph", "BondGraph", "transformer_ports", "link_nodes", "element_nodes", "coefficient",
           "stepped_nodes", "TRANSFORMER_KINDS"]


class _NodeView:
    """``g.nodes`` of a :class:`BondGraph`, read as networkx's: iterate the names, ``g.nodes[name]``
    for the attributes, ``g.nodes(data=True)`` for ``(name, attributes)`` pairs."""

    __slots__ = ("_nodes",)

    def __init__(self, nodes: dict[str, dict]):
        self._nodes = nodes

    def __call__(self, data: bool = False):
        return iter(self._nodes.items()) if data else iter(self._nodes)

    def __getitem__(self, name: str) -> dict:
        return self._nodes[name]

    def __iter__(self):
        return iter(self._nodes)

    def __len__(self) -> int:
        return len(self._nodes)

    def __contains__(self, name) -> bool:
        return name in self._nodes


class BondGraph:
    """A directed graph of named nodes with attribute dictionaries, at most one bond (edge) per
    ordered pair of nodes, kept in insertion order: the mechanism graph without networkx
    (see the module docstring). Read it as a ``networkx.DiGraph``; :meth:`to_networkx` converts it."""

    __slots__ = ("graph", "_nodes", "_succ", "_pred", "_bonds", "nodes")

    def __init__(self, **attr):
        self.graph = dict(attr)
        self._nodes: dict[str, dict] = {}
        self._succ: dict[str, dict[str, dict]] = {}
        self._pred: dict[str, dict[str, dict]] = {}
        self._bonds: dict[tuple[str, str], dict] = {}  # in the order they were added
        self.nodes = _NodeView(self._nodes)

    def add_node(self, name: str, **attr) -> None:
        """Add ``name`` (or update its attributes), as ``networkx.DiGraph.add_node``."""
        if name not in self._nodes:
            self._nodes[name] = {}
            self._succ[name], self._pred[name] = {}, {}
        self._nodes[name].update(attr)

    def add_edge(self, u: str, v: str, **attr) -> None:
        """Add the bond ``u -> v`` (missing nodes too; an existing bond's attributes are updated),
        as ``networkx.DiGraph.add_edge``."""
        for name in (u, v):
            if name not in self._nodes:
                self.add_node(name)
        data = self._succ[u].get(v)
        if data is None:
            data = self._succ[u][v] = self._pred[v][u] = self._bonds[u, v] = {}
        data.update(attr)

    def in_edges(self, node: str, data: bool = False) -> list[tuple]:
        """Bonds into ``node``: ``(u, node)``, or ``(u, node, attributes)`` with ``data``."""
        return [(u, node, d) if data else (u, node) for u, d in self._pred[node].items()]

    def out_edges(self, node: str, data: bool = False) -> list[tuple]:
        """Bonds out of ``node``: ``(node, v)``, or ``(node, v, attributes)`` with ``data``."""
        return [(node, v, d) if data else (node, v) for v, d in self._succ[node].items()]

    def edges(self, data: bool = False) -> list[tuple]:
        """Every bond, by source node in node order (networkx's order)."""
        return [edge for node in self._nodes for edge in self.out_edges(node, data)]

    @property
    def name(self) -> str:
        return self.graph.get("name", "")

    def to_networkx(self) -> nx.DiGraph:
        """The same graph as a ``networkx.DiGraph`` (same nodes, bonds, attributes and orders)."""
        import networkx as nx

        g = nx.DiGraph(**self.graph)
        for name, attr in self._nodes.items():
            g.add_node(name, **attr)
        for (u, v), attr in self._bonds.items():  # as added: the same order of predecessors
            g.add_edge(u, v, **attr)
        return g


if TYPE_CHECKING:  # what the numeric pipeline accepts (for annotations)
    Graph = BondGraph | nx.DiGraph


def _pname(key: str, owner: str) -> str:
    return f"{key}_{owner}"


def build_graph(mech: Mechanism) -> nx.DiGraph:
    """The bond-graph-like graph of ``mech`` as a ``networkx.DiGraph`` (see the module docstring
    for its vocabulary): :func:`bond_graph` converted."""
    return bond_graph(mech).to_networkx()


def bond_graph(mech: Mechanism) -> BondGraph:
    """The bond-graph-like graph of ``mech`` as a :class:`BondGraph` (no networkx import)."""
    g = BondGraph(name=mech.name, input=mech.input, output=mech.output)
    for link in mech.links:
        g.add_node(link.name, kind="link", J=link.inertia, label=f"1\n{link.name}")
    g.add_node(HOUSING, kind="housing", label="Sf=0")
    for p in mech.planetaries:
        ns, nr = _pname("Ns", p.name), _pname("Nr", p.name)
        g.add_node(p.name, kind="planetary", pinions=p.pinions, params={ns: p.n_sun, nr: p.n_ring},
                   label=f"MTF\n{p.name}")
        if p.pinions == 1:
            terms = {"sun": ((1, ns),), "ring": ((1, nr),), "carrier": ((-1, ns), (-1, nr))}
        else:
            terms = {"sun": ((-1, ns),), "ring": ((1, nr),), "carrier": ((-1, nr), (1, ns))}
        for port, member in zip(("sun", "ring", "carrier"), p.members):
            g.add_edge(member, p.name, bond="port", port=port, terms=terms[port])
    for sp in mech.stepped:
        _add_stepped(g, sp)
    for pair in mech.gear_pairs:
        k1, k2 = ("N1", "N2") if pair.by == "teeth" else ("r1", "r2")
        p1, p2 = _pname(k1, pair.name), _pname(k2, pair.name)
        g.add_node(pair.name, kind="gearpair", mesh=pair.mesh, params={p1: pair.n1, p2: pair.n2},
                   label=f"TF\n{pair.name}")
        g.add_edge(pair.link1, pair.name, bond="port", port="1", terms=((1, p1),))
        g.add_edge(pair.link2, pair.name, bond="port", port="2", terms=((pair.sign * -1, p2),))
    for e in mech.elements:
        g.add_node(e.name, kind=e.kind, static=e.static, dynamic=e.dynamic, free=e.free,
                   link1=e.link1, link2=e.link2, label=f"{e.kind}\n{e.name}")
        g.add_edge(e.link1, e.name, bond="element", side=1)
        g.add_edge(e.name, e.link2, bond="element", side=2)
    for t in mech.torques:
        g.add_node(t.name, kind="source", role=t.role, link=t.link, label=f"Se\n{t.name}")
        if t.role == "output":
            g.add_edge(t.link, t.name, bond="source")
        else:
            g.add_edge(t.name, t.link, bond="source")
    return g


def stepped_nodes(sp: SteppedPlanetary) -> list[str]:
    """The transformer nodes of a stepped-pinion planetary: one per constraint, between its first
    member and each other one (``NAME`` for the first, ``NAME/<role>`` for the others)."""
    return [sp.name if i == 0 else f"{sp.name}/{role}" for i, (role, _, _) in enumerate(sp.members[1:])]


def _add_stepped(g: BondGraph, sp: SteppedPlanetary) -> None:
    """One three-port transformer per constraint of ``sp`` (see
    :class:`~transgen.model.SteppedPlanetary`): member ``A`` (the first), member ``B``, carrier,
    with coefficients ``sigma_A*N_A*Np_b``, ``-sigma_B*N_B*Np_a`` and minus their sum."""
    def teeth_param(role):
        return _pname(("Ns" if role.startswith("sun") else "Nr") + role[-1], sp.name)

    params = {teeth_param(role): teeth for role, _, teeth in sp.members}
    steps = {"1": sp.np1, "2": sp.np2}
    params.update({_pname(f"Np{k}", sp.name): n for k, n in steps.items() if n is not None})
    role_a, link_a, _ = sp.members[0]
    sigma = {"sun": -1, "ring": 1}
    for node, (role_b, link_b, _) in zip(stepped_nodes(sp), sp.members[1:]):
        sa, sb = sigma[role_a[:-1]], sigma[role_b[:-1]]
        na, nb = teeth_param(role_a), teeth_param(role_b)
        pa, pb = _pname(f"Np{role_a[-1]}", sp.name), _pname(f"Np{role_b[-1]}", sp.name)
        used = {k: v for k, v in params.items() if k in (na, nb, pa, pb)}
        g.add_node(node, kind="stepped", params=used, label=f"MTF\n{node}")
        terms = {role_a: ((sa, na, pb),), role_b: ((-sb, nb, pa),), "carrier": ((-sa, na, pb), (sb, nb, pa))}
        for port, member in ((role_a, link_a), (role_b, link_b), ("carrier", sp.carrier)):
            g.add_edge(member, node, bond="port", port=port, terms=terms[port])


def link_nodes(g: Graph) -> list[str]:
    """Links (1-junctions) in declaration order."""
    return [n for n, d in g.nodes(data=True) if d["kind"] == "link"]


def element_nodes(g: Graph) -> list[str]:
    """Shift elements in declaration order."""
    return [n for n, d in g.nodes(data=True) if d["kind"] in ("clutch", "brake", "oneway", "dog")]


def transformer_ports(g: Graph, node: str) -> list[tuple[str, str, tuple]]:
    """``(link, port, terms)`` of a transformer node, in port order."""
    ports = [(u, d["port"], d["terms"]) for u, _, d in g.in_edges(node, data=True) if d.get("bond") == "port"]
    return sorted(ports, key=lambda p: _PORT_ORDER[p[1]])


_PORT_ORDER = {"sun": 0, "ring": 1, "carrier": 9, "1": 0, "2": 1, "sun1": 2, "sun2": 3, "ring1": 4, "ring2": 5}

TRANSFORMER_KINDS = ("planetary", "gearpair", "stepped")
"""Node kinds that are transformers: one kinematic constraint each, torques by power conservation."""


def coefficient(terms: tuple, values) -> object:
    """Evaluate a port coefficient ``sum(factor * values[p1] * values[p2] ...)`` over its terms
    ``(factor, p1, ...)`` (numbers or sympy symbols)."""
    total = 0
    for factor, *names in terms:
        product = factor
        for name in names:
            product = product * values[name]
        total = total + product
    return total
