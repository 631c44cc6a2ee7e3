"""The lever analogy (Benford and Leising, SAE 810102, 1981): the geometry of the levers.

A simple planetary set is a lever with three nodes, sun S, carrier C and ring R, the carrier
between them: the distance C-S is proportional to the ring teeth ``Nr`` and C-R to the sun teeth
``Ns``. A double-pinion set puts the ring between sun and carrier: S-R is ``Nr - Ns`` and R-C is
``Ns`` (from ``Nr*w_r - Ns*w_s = (Nr - Ns)*w_c``: the ring speed is the mean of the sun and
carrier speeds weighted ``Ns/Nr`` and ``(Nr - Ns)/Nr``). A gear pair is a lever that pivots on
the housing, its gear axes. A stepped-pinion set with ``k`` central gears is one lever of ``k + 1``
nodes, each gear at a distance from the carrier proportional to its speed relative to the pinion
(``sigma_X*Np_k/N_X``; see :func:`_stepped_lever`). For a gear pair, an external mesh puts the pivot between the two gears (link1-pivot
``n2``, pivot-link2 ``n1``), an internal mesh puts both gears on the same side (pivot-link1
``n2``, pivot-link2 ``n1``).

Why a lever: along every one of these levers a node's speed is an affine function of its
position, ``w(x) = a + b*x``, so the speeds of its nodes lie on a straight line (the lever
displaced by the speeds, a Kutzbach plan). Two levers that share two nodes (two links, or a link
and the housing) are then one lever: the shared nodes fix the line of both. :func:`lever_layout`
combines them: a Ravigneaux set or a Simpson set (two shared members) becomes one four-node
lever, the thesis' HT-740 layout one five-node lever. Sets that share one member stay separate
levers; the shared link is a node on each (drawn joined). A link on no gearset (an input shaft,
a clutch hub) is a lever of one node.

Positions are in the tooth units of the lever's first set (radii in m for a gear pair sized by
radius), measured from the lower end (position 0); a combined lever keeps the orientation of its
first set, whose sun (or gear 1) lies towards the lower end.
"""
from __future__ import annotations

from dataclasses import dataclass
from fractions import Fraction

from ..model import HOUSING, Mechanism

__all__ = ["LeverNode", "Lever", "lever_layout", "lever_speeds", "lever_document", "drawn_gears", "LEVER_UNITS", "LEVER_TOLERANCE"]

LEVER_TOLERANCE = 1e-9
"""Relative tolerance (to the lever's length) of the check that a third shared node agrees."""


@dataclass(frozen=True)
class LeverNode:
    """A node of a lever: the link (or :data:`~transgen.model.HOUSING`) at ``position``.

    ``members`` names the gear members at this node, ``"SET.sun"``, ``"SET.ring"``,
    ``"SET.carrier"`` of a planetary, ``"SET.sun1"``, ``"SET.ring2"``, ... and ``"SET.carrier"`` of
    a stepped-pinion set, and ``"SET.1"``, ``"SET.2"``, ``"SET.axis"`` (the housing pivot) of a
    gear pair.
    """

    link: str
    position: float
    members: tuple[str, ...] = ()


@dataclass(frozen=True)
class Lever:
    """A lever: the gearsets it combines (``sets``, none for a lone link) and its ``nodes`` in
    ascending ``position`` (the first at 0; tooth units of the first set)."""

    name: str
    sets: tuple[str, ...]
    nodes: tuple[LeverNode, ...]

    @property
    def length(self) -> float:
        """Distance of the end nodes (0 for a lever of one node)."""
        return self.nodes[-1].position - self.nodes[0].position

    @property
    def links(self) -> tuple[str, ...]:
        """The links (and the housing) at the nodes, bottom to top."""
        return tuple(n.link for n in self.nodes)

    def position(self, link: str) -> float:
        """Position of the node of ``link``; KeyError if the lever has none."""
        for n in self.nodes:
            if n.link == link:
                return n.position
        raise KeyError(link)

    def to_dict(self) -> dict:
        return {"name": self.name, "sets": list(self.sets),
                "nodes": [{"link": n.link, "position": n.position, "members": list(n.members)} for n in self.nodes]}


def _set_levers(mech: Mechanism) -> list[tuple[list[str], dict[str, Fraction], dict[str, list[str]]]]:
    """One lever per planetary and gear pair: (sets, link -> exact position, link -> members)."""
    out = []
    for p in mech.planetaries:
        ns, nr = Fraction(p.n_sun), Fraction(p.n_ring)
        if p.pinions == 1:  # S -Nr- C -Ns- R
            pos = {p.sun: Fraction(0), p.carrier: nr, p.ring: nr + ns}
        else:  # S -(Nr-Ns)- R -Ns- C
            pos = {p.sun: Fraction(0), p.ring: nr - ns, p.carrier: nr}
        members = {p.sun: [f"{p.name}.sun"], p.ring: [f"{p.name}.ring"], p.carrier: [f"{p.name}.carrier"]}
        out.append(([p.name], pos, members))
    for sp in mech.stepped:
        out.append(_stepped_lever(sp))
    for g in mech.gear_pairs:
        n1, n2 = Fraction(g.n1), Fraction(g.n2)
        if g.mesh == "external":  # w1 = -(n2/n1) w2 about the pivot
            pos = {g.link1: Fraction(0), HOUSING: n2, g.link2: n1 + n2}
        else:  # w1 = (n2/n1) w2, both on one side of the pivot
            pos = {HOUSING: Fraction(0), g.link1: n2, g.link2: n1}
        members = {g.link1: [f"{g.name}.1"], g.link2: [f"{g.name}.2"], HOUSING: [f"{g.name}.axis"]}
        out.append(([g.name], pos, members))
    return out


def _stepped_lever(sp):
    """A stepped-pinion set as one lever of its carrier and central gears: gear ``X`` turns
    relative to the carrier at ``(w_X - w_c) = r_X*(w_p - w_c)``, ``r_X = sigma_X*Np_k/N_X``, so its
    node sits at ``r_X`` times a common scale from the carrier (suns below it, rings above). The
    scale ``prod(N_X)/max(Np)`` keeps whole tooth units and gives the simple planetary's lever for
    one sun and one ring on equal steps; for a sun on step 1 and a ring on step 2 the distances
    C-S and C-R are in the ratio ``Nr*Np1 : Ns*Np2``, the coefficients of the stepped relation."""
    scale = Fraction(1)
    for _, _, teeth in sp.members:
        scale *= teeth
    scale /= max(n for n in (sp.np1, sp.np2) if n is not None)
    pos = {sp.carrier: Fraction(0)}
    members = {sp.carrier: [f"{sp.name}.carrier"]}
    for role, link, teeth in sp.members:
        sigma = -1 if role.startswith("sun") else 1
        pos[link] = sigma * Fraction(sp.step_teeth(role), teeth) * scale
        members[link] = [f"{sp.name}.{role}"]
    low = min(pos.values())
    return [sp.name], {k: x - low for k, x in pos.items()}, members


def _merge(a, b):
    """``b`` mapped onto ``a`` when they share two nodes at distinct positions in both and any
    further shared node agrees; else None."""
    sets_a, pos_a, mem_a = a
    sets_b, pos_b, mem_b = b
    shared = [link for link in pos_a if link in pos_b]
    if len(shared) < 2:
        return None
    pairs = [(p, q) for i, p in enumerate(shared) for q in shared[i + 1:]
             if pos_a[p] != pos_a[q] and pos_b[p] != pos_b[q]]
    if not pairs:
        return None
    p, q = max(pairs, key=lambda pq: abs(pos_b[pq[0]] - pos_b[pq[1]]))
    scale = (pos_a[q] - pos_a[p]) / (pos_b[q] - pos_b[p])
    mapped = {link: pos_a[p] + scale * (x - pos_b[p]) for link, x in pos_b.items()}
    length = max(pos_a.values()) - min(pos_a.values())
    if any(abs(mapped[s] - pos_a[s]) > LEVER_TOLERANCE * length for s in shared):
        return None  # the sets lock each other: not one lever
    pos = dict(pos_a)
    members = {k: list(v) for k, v in mem_a.items()}
    for link, x in mapped.items():
        pos.setdefault(link, x)
        members.setdefault(link, []).extend(mem_b[link])
    return sets_a + sets_b, pos, members


def lever_layout(mech: Mechanism) -> tuple[Lever, ...]:
    """The levers of ``mech``: every gearset a lever, sets that share two nodes combined.

    Returns the levers in declaration order of their first set (planetaries, stepped-pinion sets,
    then gear pairs),
    then one single-node lever for every link on no gearset, in declaration order.

    Examples
    --------
    >>> from transgen import load_mechanism
    >>> [(lv.name, lv.links) for lv in lever_layout(load_mechanism("hsw_ravigneaux4"))]
    [('PG_small+PG_large', ('Ss', 'OUT_R', 'C', 'Sl')), ('IN', ('IN',))]
    """
    levers = _set_levers(mech)
    merged = True
    while merged:
        merged = False
        for i in range(len(levers)):
            for j in range(i + 1, len(levers)):
                m = _merge(levers[i], levers[j])
                if m is not None:
                    levers[i] = m
                    del levers[j]
                    merged = True
                    break
            if merged:
                break
    out = []
    for sets, pos, members in levers:
        low = min(pos.values())
        nodes = sorted((LeverNode(link, float(x - low), tuple(members[link])) for link, x in pos.items()),
                       key=lambda n: (n.position, n.link))
        out.append(Lever("+".join(sets), tuple(sets), tuple(nodes)))
    on_lever = {n.link for lv in out for n in lv.nodes}
    out.extend(Lever(link.name, (), (LeverNode(link.name, 0.0),)) for link in mech.links if link.name not in on_lever)
    return tuple(out)


def drawn_gears(mech: Mechanism, gears=None) -> list[str]:
    """The gears to draw: ``gears`` checked against the declared ones (ValueError naming the
    declared gears for an unknown one or a neutral), or every declared gear that is not a neutral."""
    declared = [g.name for g in mech.gears if g.kind == "gear"]
    if gears is None:
        return declared
    out = []
    for name in gears:
        if name not in declared:
            neutral = any(g.name == name for g in mech.neutrals)
            why = "is a neutral: no speeds follow from the input speed" if neutral else "is not a declared gear"
            raise ValueError(f"{name!r} {why} of {mech.name} (gears: {' '.join(declared) or 'none'})")
        if name not in out:
            out.append(name)
    return out


def lever_speeds(mech: Mechanism, gear: str) -> dict[str, float | None]:
    """Speed of every link per unit input speed in the declared gear ``gear`` (the housing 0),
    from :func:`transgen.kinematics.link_speeds`; ``None`` for a link the gear leaves free.

    Raises ``KeyError`` for a gear the mechanism does not declare."""
    from ..kinematics import link_speeds

    row = mech.gear(gear)
    speeds = link_speeds(mech, row.engaged)
    speeds = {k: (None if v is None else (0.0 if abs(v) < 1e-12 else v)) for k, v in speeds.items()}
    speeds[HOUSING] = 0.0
    return speeds


LEVER_UNITS = {"position": "1", "ratio": "1", "speeds": "1"}
"""Units of :func:`lever_document`: positions in tooth counts (radii for gear pairs sized by
radius, in the first set's units), speeds per unit input speed, ratios input/output."""


def lever_document(mech: Mechanism, gears=None) -> dict:
    """The JSON form of ``transgen lever --json``: the levers and, for every drawn gear (``gears``,
    default every declared gear but the neutrals), its engaged elements, ratio and the speed of
    every link per unit input speed (``null``: left free by the gear)."""
    rows = []
    for name in drawn_gears(mech, gears):
        speeds = lever_speeds(mech, name)
        w_out = speeds.get(mech.output)
        rows.append({"name": name, "engaged": list(mech.gear(name).engaged),
                     "ratio": (1.0 / w_out) if w_out else None,
                     "speeds": {link.name: speeds[link.name] for link in mech.links}})
    return {"mechanism": mech.name, "input": mech.input, "output": mech.output,
            "levers": [lv.to_dict() for lv in lever_layout(mech)], "gears": rows}
