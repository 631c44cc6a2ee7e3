"""Power flow and efficiency per gear: speeds, static torques, mesh losses, circulating power,
shift-element capacities.

For every declared gear, with the input turning at unit speed and driven by unit torque (massless,
steady state: the static torque balance of :mod:`transgen.equations` with the accelerations left
out), :func:`power_flow` gives

* the speed of every link and the slip ``w1 - w2`` of every open shift element, per unit input
  speed (the null space of the gear's kinematic constraints, :mod:`transgen.kinematics`);
* the torque of every engaged shift element per unit input torque, in the ``.mech`` sign
  convention (transmitted from LINK1 to LINK2: ``-t`` on LINK1, ``+t`` on LINK2); elements in
  parallel locked together (a brake beside a one-way clutch) carry one torque, reported under the
  group's label ``"B1+F1"`` in its first member's direction: their split is not static;
* the **torque ratio** ``T_out / T_in``: the torque the output delivers to the driveline (the
  simulator's ``T_out``, acting ``-T_out`` on the output link) per unit input torque. It has the
  sign of the speed ratio (negative in reverse) and equals it without losses;
* the **efficiency** ``eta = P_out / P_in = torque_ratio / ratio`` (drive);
* per transformer (planetary set or gear pair) the power each member feeds into it, its
  throughput (the sum of the positive ones), its loss and which member drives in the carrier frame;
* the circulating (recirculated) power of the gear;
* the slip in rpm at a given input speed, and the open elements over their slip limit.

``coast=True`` analyses overrun (engine braking) instead: the driveline drives the output in its
direction of rotation and the input absorbs unit torque (``T_in = -1``); the torque ratio is then
``ratio / eta`` and the efficiency ``P_in / P_out``.

Loss model (Müller's carrier-frame rule)
----------------------------------------
A planetary set seen from its carrier is a fixed-axis train between sun and ring with the basic
ratio ``i0 = -Nr/Ns`` (simple) or ``+Nr/Ns`` (double pinion) and the **standing efficiency**
``eta0`` (``.mech``: ``planetary ... eta0=0.98``; the default :data:`DEFAULT_ETA0`). The member
that feeds power into the train in the carrier frame (``t_k * (w_k - w_c) > 0``, ``t_k`` the torque
its link exerts on the set) drives; the other receives ``eta0`` times that power. With ``c_k`` the
member's coefficient in the kinematic constraint ``sum c_k w_k = 0`` (:mod:`transgen.graph`) the
torques obey

    ``t_sun + t_ring + t_carrier = 0``  (equilibrium of the massless set),
    ``t_ring = (c_ring / c_sun) * eta0**s * t_sun``, ``s = +1`` when the sun drives, ``-1`` when
    the ring drives

(simple set: ``t_ring / t_sun = +eta0**s * Nr/Ns``; double pinion: ``-eta0**s * Nr/Ns``). For a
double-pinion set ``eta0`` is the **overall** standing efficiency of its two meshes (sun-planet and
planet-ring through the planet-planet mesh), e.g. ``0.98 * 0.99``: state it per set. A gear pair
is the same with the housing as carrier and its mesh efficiency ``eta`` (``gears ... eta=0.99``;
default :data:`DEFAULT_ETA_PAIR`, or the global ``eta0`` when one is given: a gear pair is a
train whose carrier is the housing, so that ``eta0=1`` alone is lossless); the reaction goes into
the housing.

A **stepped-pinion set** (``stepped``) has one mesh per central gear, each on the pinion step it
meshes. Its ``eta0`` (``stepped ... eta0=``, else the planetaries' default) is, as for a planetary,
the standing efficiency between two of its central gears in the carrier frame: two meshes, each of
efficiency ``sqrt(eta0)``. With ``r_X = sigma_X*Np_k/N_X`` the speed of gear ``X`` relative to the
pinion's (both in the carrier frame; ``sigma`` -1 sun, +1 ring) and ``f_X = sqrt(eta0)`` when
``X`` feeds power into the pinion (``t_X*(w_X - w_c) > 0``), ``1/sqrt(eta0)`` when it takes power
out, the massless pinion and set give ``sum_X f_X*r_X*t_X = 0`` and ``sum t = 0`` (carrier
included). A two-gear set is thus Müller's planetary with the basic ratio of its steps (ring
fixed, sun in: ``eta = (1 + eta0*k)/(1 + k)``, ``k = Nr*Np_s/(Ns*Np_r)``; equal steps: the simple
planetary), and a set with three or four gears loses ``sqrt(eta0)`` per loaded mesh. A dog
element, when locked, carries torque as a clutch does (its suggested capacity has no dynamic
part); open, its slip is reported and checked against its ``max_slip_rpm`` like any element's.
Alternative gears are analysed and marked. A set without relative motion (all members at one speed) or without torque is
lossless, and so is a set with a floating member (one the input speed does not fix: its relative
speeds are undetermined, and it carries no torque in the bundled and the randomly generated
gears). The power directions are first taken from the lossless solution and then iterated until
the assumed and the resulting directions agree; when the iteration cycles, every assignment of directions is tried, and a gear without
exactly one consistent assignment is reported by name (:class:`PowerFlowConvergenceError`), never
answered. Classical checks (tests): ring fixed, sun in, carrier out ``eta = (1 + eta0*Nr/Ns) /
(1 + Nr/Ns)``; carrier fixed ``eta = eta0``.

Circulating power: a gear recirculates power when some branch carries more than the power of the
source (the input's in drive, the output's in coast): a set's throughput, or the power ``t * w``
through a locked clutch; the **circulating power** is the excess ``max(branch) - P_source``, per
unit input power (0 when no branch exceeds the source).

Capacity sizing: the largest element torque over the gears, times a design input torque, times a
safety factor gives a suggested static capacity; the dynamic one is ``dynamic_ratio`` (the ratio of
the sliding to the static friction coefficient, default 0.85) times it.
"""
from __future__ import annotations

from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from .graph import Graph

import itertools
import math
from dataclasses import dataclass, field

import numpy as np

from .equations import assemble, complete_locked, locked_constraints
from .errors import TransgenError
from .graph import bond_graph, coefficient, link_nodes, stepped_nodes, transformer_ports
from .kinematics import analyze, link_speeds, numeric_rank
from .model import HOUSING, Mechanism

__all__ = [
    "DEFAULT_ETA0",
    "DEFAULT_ETA_PAIR",
    "DEFAULT_SAFETY_FACTOR",
    "DEFAULT_DYNAMIC_RATIO",
    "PowerFlowError",
    "PowerFlowConvergenceError",
    "SetFlow",
    "GearFlow",
    "Capacity",
    "PowerFlow",
    "power_flow",
    "powerflow_text",
    "UNITS",
]

DEFAULT_ETA0 = 0.98
"""Standing (carrier-fixed) efficiency of a planetary set without ``eta0`` in the file."""
DEFAULT_ETA_PAIR = 0.99
"""Mesh efficiency of a gear pair without ``eta`` in the file."""
DEFAULT_SAFETY_FACTOR = 1.4
"""Suggested static capacity over the largest element torque at the design input torque."""
DEFAULT_DYNAMIC_RATIO = 0.85
"""Suggested dynamic capacity over the static one (sliding over static friction coefficient)."""

_POWER_TOL = 1e-12
"""Carrier-frame power (per unit input power) below which a set counts as not transmitting."""
_MAX_ITERATIONS = 50
_MAX_ENUMERATED = 12
"""Most sets whose power directions are enumerated after the iteration cycles (2^12 solves)."""


class PowerFlowError(TransgenError, ValueError):
    """Bad arguments, or a gear whose static torques are not unique or not in equilibrium."""


class PowerFlowConvergenceError(TransgenError, RuntimeError):
    """The assumed power directions of the mesh losses do not settle to one consistent set."""


@dataclass(frozen=True)
class SetFlow:
    """One transformer (planetary set, stepped-pinion set or gear pair) in one gear, per unit
    input torque and speed.

    ``torques[port]``: the torque the member's link exerts on the set (the link feels the
    opposite), ports ``sun``/``ring``/``carrier``, a stepped set's ``sun1``/``ring2``/.../``carrier``
    (summed over its constraint nodes) or ``1``/``2``; ``powers[port] = t * w`` the power
    the member feeds into the set (per unit input power); ``throughput`` the sum of the positive
    ones; ``loss`` the power lost in the meshes (``sum(powers)``, >= 0); ``eta`` the standing or
    mesh efficiency applied; ``driving`` the member that drives in the carrier frame (a stepped
    set: every gear that feeds power into the pinion, joined by ``+``; ``None``: no relative
    motion or no torque, lossless).
    """

    name: str
    kind: str
    eta: float
    torques: dict = field(compare=False)
    speeds: dict = field(compare=False)
    powers: dict = field(compare=False)
    throughput: float = 0.0
    loss: float = 0.0
    driving: str | None = None
    links: dict = field(default_factory=dict, compare=False)
    """The link (or ``housing``) on each port."""


@dataclass(frozen=True)
class GearFlow:
    """The power flow of one declared gear (see the module docstring for every convention).

    Speeds are per unit input speed (``None``: a floating link, not fixed by the input speed);
    torques per unit input torque; powers per unit input power. In drive the input torque is
    ``input_torque = 1``; in coast (the driveline drives the output, the input absorbs) it is
    ``-1``, and ``torque_ratio = T_out/T_in`` is ``ratio / efficiency`` with ``efficiency =
    P_in/P_out``.
    """

    name: str
    engaged: tuple[str, ...]
    ratio: float
    torque_ratio: float
    efficiency: float
    link_speeds: dict = field(compare=False)
    element_torques: dict = field(compare=False)
    element_slips: dict = field(compare=False)
    sets: tuple[SetFlow, ...] = ()
    losses: float = 0.0
    circulating_power: float = 0.0
    iterations: int = 0
    element_slip_rpm: dict | None = field(default=None, compare=False)
    overspeed: tuple[str, ...] = ()
    warnings: tuple[str, ...] = ()
    input_torque: float = 1.0
    alternative: bool = False
    """An alternative gear of the table (``gear ... alternative``): outside the step sequence."""

    @property
    def set_power(self) -> dict[str, float]:
        """Throughput of every transformer per unit input power."""
        return {s.name: s.throughput for s in self.sets}

    @property
    def input_power(self) -> float:
        """Power into the transmission at the input: 1 in drive, -1 in coast (absorbed)."""
        return self.input_torque

    @property
    def output_power(self) -> float:
        """Power out of the transmission at the output (negative in coast: supplied by the driveline)."""
        return self.input_torque * self.torque_ratio / self.ratio

    def set(self, name: str) -> SetFlow:
        for s in self.sets:
            if s.name == name:
                return s
        raise KeyError(name)


@dataclass(frozen=True)
class Capacity:
    """Sizing of one shift element over the gears.

    ``max_torque``: the largest magnitude of its torque per unit input torque and the ``gear``
    where it occurs (``None``: engaged in no gear). With a design input torque ``T_d`` [N*m]:
    ``torque = max_torque * T_d``, ``static = safety_factor * torque``, ``dynamic = dynamic_ratio
    * static`` (``None`` for a one-way clutch). ``declared_*`` are the file's capacities.
    """

    element: str
    kind: str
    max_torque: float
    gear: str | None
    torque: float | None = None
    static: float | None = None
    dynamic: float | None = None
    declared_static: float | None = None
    declared_dynamic: float | None = None


UNITS = {
    "ratio": "1", "torque_ratio": "1", "efficiency": "1", "losses": "1 (per unit input power)",
    "circulating_power": "1 (per unit input power)", "iterations": "1", "input_torque": "1 (+1 drive, -1 coast)",
    "link_speeds": "1 (per unit input speed)", "element_slips": "1 (per unit input speed)",
    "element_slip_rpm": "rpm", "element_torques": "1 (per unit input torque)",
    "set_power": "1 (per unit input power)", "set_loss": "1 (per unit input power)",
    "set_member_power": "1 (per unit input power)",
    "eta0": "1", "eta_pair": "1", "eta": "1", "input_rpm": "rpm", "max_slip_rpm": "rpm",
    "design_torque": "N*m", "safety_factor": "1", "dynamic_ratio": "1",
    "max_torque": "1 (per unit input torque)", "torque": "N*m", "static": "N*m", "dynamic": "N*m",
    "declared_static": "N*m", "declared_dynamic": "N*m",
}
"""Units of the numeric fields of :meth:`PowerFlow.to_dict`."""


@dataclass(frozen=True)
class PowerFlow:
    """The power flow of every declared gear of a mechanism, and the capacity sizing."""

    mechanism: Mechanism
    gears: tuple[GearFlow, ...]
    eta: dict = field(compare=False)
    capacities: tuple[Capacity, ...] = ()
    input_rpm: float | None = None
    max_slip_rpm: float | None = None
    design_torque: float | None = None
    safety_factor: float = DEFAULT_SAFETY_FACTOR
    dynamic_ratio: float = DEFAULT_DYNAMIC_RATIO
    coast: bool = False

    def gear(self, name: str) -> GearFlow:
        for g in self.gears:
            if g.name == name:
                return g
        raise KeyError(name)

    def to_dict(self) -> dict:
        """The JSON form of ``transgen powerflow --json``."""
        m = self.mechanism
        planetaries = {p.name for p in m.planetaries} | {sp.name for sp in m.stepped}
        return {
            "mechanism": m.name,
            "input": m.input,
            "output": m.output,
            "direction": "coast" if self.coast else "drive",
            "eta0": {k: v for k, v in self.eta.items() if k in planetaries},
            "eta_pair": {k: v for k, v in self.eta.items() if k not in planetaries},
            "input_rpm": self.input_rpm,
            "max_slip_rpm": self.max_slip_rpm,
            "gears": [
                {"name": g.name, "alternative": g.alternative, "engaged": list(g.engaged), "ratio": g.ratio,
                 "torque_ratio": g.torque_ratio,
                 "input_torque": g.input_torque,
                 "efficiency": g.efficiency, "losses": g.losses, "circulating_power": g.circulating_power,
                 "iterations": g.iterations, "element_torques": dict(g.element_torques),
                 "element_slips": dict(g.element_slips), "element_slip_rpm": g.element_slip_rpm,
                 "overspeed": list(g.overspeed), "link_speeds": dict(g.link_speeds), "set_power": g.set_power,
                 "set_loss": {s.name: s.loss for s in g.sets},
                 "set_driving": {s.name: s.driving for s in g.sets},
                 "set_member_power": {s.name: dict(s.powers) for s in g.sets}, "warnings": list(g.warnings)}
                for g in self.gears
            ],
            "design_torque": self.design_torque,
            "safety_factor": self.safety_factor,
            "dynamic_ratio": self.dynamic_ratio,
            "capacities": [
                {"element": c.element, "kind": c.kind, "max_torque": c.max_torque, "gear": c.gear, "torque": c.torque,
                 "static": c.static, "dynamic": c.dynamic, "declared_static": c.declared_static,
                 "declared_dynamic": c.declared_dynamic}
                for c in self.capacities
            ],
        }


# ---------------------------------------------------------------------------------------------


def _check_number(name: str, value, low: float, high: float, low_open: bool = True) -> float | None:
    if value is None:
        return None
    if isinstance(value, bool) or not isinstance(value, (int, float, np.floating, np.integer)):
        raise PowerFlowError(f"{name} must be a number, not {value!r}")
    value = float(value)
    if not math.isfinite(value):
        raise PowerFlowError(f"{name} must be finite, not {value!r}")
    if (value <= low if low_open else value < low) or value > high:
        raise PowerFlowError(f"{name} must be in {'(' if low_open else '['}{low:g}, {high:g}], not {value:g}")
    return value


def _efficiencies(mech: Mechanism, eta0: float | None, eta_pair: float | None) -> dict[str, float]:
    """The efficiency of every transformer: the file's own value, else the given global one (for
    a gear pair ``eta_pair``, else ``eta0``), else the default."""
    out = {p.name: p.eta0 if p.eta0 is not None else (eta0 if eta0 is not None else DEFAULT_ETA0)
           for p in mech.planetaries}
    out.update({sp.name: sp.eta0 if sp.eta0 is not None else (eta0 if eta0 is not None else DEFAULT_ETA0)
                for sp in mech.stepped})
    if eta_pair is None:
        eta_pair = eta0 if eta0 is not None else DEFAULT_ETA_PAIR
    out.update({g.name: g.eta if g.eta is not None else eta_pair for g in mech.gear_pairs})
    return out


@dataclass(frozen=True)
class _Transformer:
    """A transformer's ports for the loss relations: ``a`` and ``b`` are the two gear members
    (sun and ring, or ports 1 and 2), ``base`` the carrier (``None`` for a gear pair: the housing).
    One direction variable: the sign of member ``a``'s carrier-frame power."""

    name: str
    kind: str
    ports: tuple  # ((link, port, c), ...) in port order
    a: int
    b: int
    base: int | None

    @property
    def n_vars(self) -> int:
        return 1


@dataclass(frozen=True)
class _SteppedSet:
    """A stepped-pinion set for the loss relations. ``ports``: ``(link, role, r)`` of its central
    gears, carrier last (``r = 0``), with ``r = (w_X - w_c) / (w_p - w_c) = sigma_X * Np_k / N_X``
    the gear's speed relative to the pinion's, both in the carrier frame; ``nodes``: the graph's
    constraint nodes ``(node, b)``, each between gear 0 and gear ``b``. One direction variable per
    central gear: the sign of its carrier-frame power."""

    name: str
    ports: tuple
    nodes: tuple
    kind: str = "stepped"

    @property
    def n_vars(self) -> int:
        return len(self.ports) - 1

    @property
    def base(self) -> int:
        return len(self.ports) - 1


def _transformers(mech: Mechanism, g: Graph) -> list:
    out = []
    for node, data in g.nodes(data=True):
        if data["kind"] not in ("planetary", "gearpair"):
            continue
        ports = [(link, port, float(coefficient(terms, data["params"]))) for link, port, terms in transformer_ports(g, node)]
        scale = max(abs(c) for _, _, c in ports)  # rows of order one beside the link balances
        ports = tuple((link, port, c / scale) for link, port, c in ports)
        if data["kind"] == "planetary":
            out.append(_Transformer(node, "planetary", ports, 0, 1, 2))
        else:
            out.append(_Transformer(node, "gearpair", ports, 0, 1, None))
    for sp in mech.stepped:
        r = [(-1 if role.startswith("sun") else 1) * sp.step_teeth(role) / teeth for role, _, teeth in sp.members]
        scale = max(abs(x) for x in r)
        ports = tuple((link, role, x / scale) for (role, link, _), x in zip(sp.members, r)) + ((sp.carrier, "carrier", 0.0),)
        out.append(_SteppedSet(sp.name, ports, tuple((node, b + 1) for b, node in enumerate(stepped_nodes(sp)))))
    return out


class _Gear:
    """The static torque problem of one gear: unknowns ``x = [lambda..., T]`` with the
    locked-group and transformer-port torques ``lambda`` as in :func:`transgen.equations.assemble`
    and ``T = T_out`` for ``T_in = 1`` (drive) or ``T = T_in`` for ``T_out = -sign(w_out)`` (coast:
    the driveline drives the output in its direction of rotation)."""

    def __init__(self, mech: Mechanism, g: Graph, engaged, eta: dict[str, float], coast: bool = False):
        links = link_nodes(g)
        self.links = links
        self.locked = complete_locked(g, engaged)
        self.groups = locked_constraints(g, self.locked)
        eq = assemble(g, self.locked)
        n = eq.n_links
        self.lam = eq.z[n:]
        col = {name: i for i, name in enumerate(self.lam)}
        ui = {name: i for i, name in enumerate(eq.u)}
        # the link balances without the accelerations (massless, static); the driven end's torque
        # joins the unknowns
        speeds = link_speeds(mech, tuple(grp.first for grp in self.groups), g)
        self.determined = np.array([speeds[k] is not None for k in links])
        # a floating link's speed is undetermined: 0 here, and its sets are lossless (directions 0)
        self.w = np.array([0.0 if speeds[k] is None or abs(speeds[k]) < 1e-12 else speeds[k] for k in links])
        given, unknown = ("T_out", "T_in") if coast else ("T_in", "T_out")
        value = -np.sign(self.w[links.index(mech.output)]) if coast else 1.0
        self.balance = np.hstack([eq.E[:n, n:], eq.F[:n, [ui[unknown]]]])
        self.rhs_balance = -eq.F[:n, ui[given]] * value
        self.transformers = _transformers(mech, g)
        # per transformer: its port columns (a stepped set: (gear 0, gear b, carrier) per node)
        self.port_col = []
        for t in self.transformers:
            if t.kind == "stepped":
                self.port_col.append([tuple(col[f"t_{node}.{t.ports[k][1]}"] for k in (0, b, t.base))
                                      for node, b in t.nodes])
            else:
                self.port_col.append([col[f"t_{t.name}.{port}"] for _, port, _ in t.ports])
        self.eta = [eta[t.name] for t in self.transformers]
        # the direction variables: one per planetary or pair, one per central gear of a stepped set
        self.var_slices, start = [], 0
        for t in self.transformers:
            self.var_slices.append(slice(start, start + t.n_vars))
            start += t.n_vars
        self.var_names = [t.name if t.n_vars == 1 and t.kind != "stepped" else f"{t.name}.{t.ports[k][1]}"
                          for t in self.transformers for k in range(t.n_vars)]
        self.group_col = [col[f"t_{grp.label}"] for grp in self.groups]
        speed = dict(zip(links, self.w))
        known = dict(zip(links, self.determined))
        speed[HOUSING], known[HOUSING] = 0.0, True
        # per transformer: relative speeds of its members to the base, and whether they are known
        self.relative = []
        for t in self.transformers:
            base = 0.0 if t.base is None else speed[t.ports[t.base][0]]
            rel = [speed[link] - base for link, _, _ in t.ports]
            ok = all(known[link] for link, _, _ in t.ports)
            self.relative.append((rel, ok))

    @property
    def n_vars(self) -> int:
        return len(self.var_names)

    def torques(self, k: int, x) -> list[float]:
        """The torque every port's link exerts on transformer ``k`` (a stepped set: summed over
        its constraint nodes), in port order."""
        t, cols = self.transformers[k], self.port_col[k]
        if t.kind != "stepped":
            return [float(x[c]) for c in cols]
        out = [0.0] * len(t.ports)
        for (node, b), (ca, cb, cc) in zip(t.nodes, cols):
            out[0] += float(x[ca])
            out[b] += float(x[cb])
            out[t.base] += float(x[cc])
        return out

    def matrix(self, factors) -> tuple[np.ndarray, np.ndarray]:
        """The equations with the loss factors: ``t_b = (c_b/c_a) * f * t_a`` for a planetary or
        pair; for a stepped set ``f_0*r_0*t_0 + f_b*r_b*t_b = 0`` per constraint node (the pinion's
        carrier-frame balance, see the module docstring)."""
        n_x = self.balance.shape[1]
        rows = [self.balance]
        for t, cols, sl in zip(self.transformers, self.port_col, self.var_slices):
            f = factors[sl]
            if t.kind == "stepped":
                r = [p[2] for p in t.ports]
                for (node, b), (ca, cb, cc) in zip(t.nodes, cols):
                    ratio_row, eq_row = np.zeros(n_x), np.zeros(n_x)
                    ratio_row[ca], ratio_row[cb] = f[0] * r[0], f[b] * r[b]
                    eq_row[[ca, cb, cc]] = 1.0
                    rows += [ratio_row[None, :], eq_row[None, :]]
                continue
            c = [p[2] for p in t.ports]
            ratio_row = np.zeros(n_x)
            ratio_row[cols[t.b]] = c[t.a]
            ratio_row[cols[t.a]] = -c[t.b] * f[0]
            rows.append(ratio_row[None, :])
            if t.base is not None:  # equilibrium of the massless set
                eq_row = np.zeros(n_x)
                eq_row[cols] = 1.0
                rows.append(eq_row[None, :])
        a = np.vstack(rows)
        rhs = np.concatenate([self.rhs_balance, np.zeros(a.shape[0] - len(self.rhs_balance))])
        return a, rhs

    def solve(self, factors, gear: str) -> np.ndarray:
        a, b = self.matrix(factors)
        if numeric_rank(a) < a.shape[1]:
            raise PowerFlowError(f"gear {gear}: the static torques are not unique: the engaged elements "
                                 f"{' '.join(self.locked)} or the gearsets over-constrain the mechanism "
                                 f"(a statically indeterminate torque split, see 'transgen modes')")
        x, *_ = np.linalg.lstsq(a, b, rcond=None)
        x += np.linalg.lstsq(a, b - a @ x, rcond=None)[0]  # one step of iterative refinement
        if np.linalg.norm(a @ x - b) > 1e-9 * (1.0 + np.linalg.norm(b)):
            raise PowerFlowError(f"gear {gear}: no static equilibrium with torque on the input")
        return x

    def directions(self, x) -> list[int]:
        """Per direction variable: +1 when its member drives in the carrier frame (a planetary's
        or pair's member ``a``; a stepped set's central gear), -1 when it is driven (a planetary's
        ``b`` drives), 0 when no power flows through its meshes (or a member floats)."""
        out = []
        for k, (t, (rel, ok)) in enumerate(zip(self.transformers, self.relative)):
            torques = self.torques(k, x)
            for m in range(t.n_vars):
                i = m if t.kind == "stepped" else t.a
                p = torques[i] * rel[i]
                out.append(0 if not ok or abs(p) <= _POWER_TOL else (1 if p > 0 else -1))
        return out

    def factors(self, directions) -> list[float]:
        """The loss factor of every direction variable: ``eta0**d`` for a planetary or pair,
        ``sqrt(eta0)**d`` (one mesh of the two between two gears) for a stepped set's gear."""
        out = []
        for t, eta, sl in zip(self.transformers, self.eta, self.var_slices):
            e = math.sqrt(eta) if t.kind == "stepped" else eta
            out += [1.0 if d == 0 else e ** d for d in directions[sl]]
        return out


def _consistent(gear: _Gear, x, directions) -> bool:
    return all(d == 0 or d == n for d, n in zip(directions, gear.directions(x)))


def _solve_directions(gear: _Gear, name: str) -> tuple[np.ndarray, list[int], int]:
    """Iterate the assumed power directions to a consistent solution (see the module docstring)."""
    x = gear.solve([1.0] * gear.n_vars, name)
    directions = gear.directions(x)
    seen = []
    for iteration in range(1, _MAX_ITERATIONS + 1):
        x = gear.solve(gear.factors(directions), name)
        new = gear.directions(x)
        # a set that was lossless (no power) stays so: its meshes carry no power whatever the factor
        new = [0 if d == 0 else n for d, n in zip(directions, new)]
        if new == directions:
            return x, directions, iteration
        if new in seen:
            break
        seen.append(directions)
        directions = new
    active = [k for k, d in enumerate(directions) if d != 0]
    cycling = [gear.var_names[k] for k in active if any(s[k] != directions[k] for s in seen)]
    if len(active) <= _MAX_ENUMERATED:
        found = []
        for signs in itertools.product((1, -1), repeat=len(active)):
            trial = list(directions)
            for k, s in zip(active, signs):
                trial[k] = s
            xt = gear.solve(gear.factors(trial), name)
            if _consistent(gear, xt, trial):
                found.append((xt, trial))
        if len(found) == 1:
            return found[0][0], found[0][1], iteration + 2 ** len(active)
        what = "no" if not found else f"{len(found)}"
        raise PowerFlowConvergenceError(
            f"gear {name}: the power directions of {', '.join(cycling) or 'the sets'} oscillate and {what} "
            f"assignment of directions is consistent (self-locking or ambiguous with these efficiencies)")
    raise PowerFlowConvergenceError(f"gear {name}: the power directions of {', '.join(cycling)} do not settle")


def _gear_flow(mech: Mechanism, g: Graph, gear_decl, eta: dict, input_rpm, max_slip_rpm,
               coast: bool = False) -> GearFlow:
    name = gear_decl.name
    combo = analyze(mech, gear_decl.engaged, g)
    if combo.ratio is None:
        raise PowerFlowError(f"gear {name} ({' '.join(gear_decl.engaged)}) has no determined ratio ({combo.kind})")
    gear = _Gear(mech, g, gear_decl.engaged, eta, coast)
    x, directions, iterations = _solve_directions(gear, name)
    x = np.where(np.abs(x) < 1e-14 * max(1.0, float(np.abs(x).max())), 0.0, x)
    if coast:  # per unit torque absorbed at the input (T_in = -1); a positive scale keeps the directions
        if x[-1] >= 0.0:
            raise PowerFlowError(f"gear {name} self-locks in coast: the output cannot drive the input with these "
                                 f"efficiencies (the input would receive {x[-1]:+.4g} N*m per N*m at the output)")
        scale = -1.0 / float(x[-1])
        x = x * scale  # now x[-1] = T_in = -1 and T_out = -sign(w_out) * scale
        input_torque, torque_ratio = -1.0, float(np.sign(gear.w[gear.links.index(mech.output)])) * scale
    else:
        input_torque, torque_ratio = 1.0, float(x[-1])
    speed = {k: float(w) for k, w in zip(gear.links, gear.w)}
    ratio = 1.0 / speed[mech.output]  # = combo.ratio, more accurately
    known_speeds = {k: (speed[k] if ok else None) for k, ok in zip(gear.links, gear.determined)}

    sets = []
    for k, (t, sl, (rel, _)) in enumerate(zip(gear.transformers, gear.var_slices, gear.relative)):
        values = gear.torques(k, x)
        torques = {port: v for (_, port, _), v in zip(t.ports, values)}
        speeds = {port: (0.0 if link == HOUSING else known_speeds[link]) for link, port, _ in t.ports}
        powers = {port: (0.0 if torques[port] == 0.0 else torques[port] * (speeds[port] or 0.0)) for port in torques}
        ds = directions[sl]
        if t.kind == "stepped":
            # every gear's mesh: (1 - f) times its carrier-frame power (exact 0 when lossless)
            fs = gear.factors(directions)[sl]
            driving = "+".join(t.ports[i][1] for i, d in enumerate(ds) if d > 0) or None
            loss = sum((1.0 - f) * values[i] * rel[i] for i, (d, f) in enumerate(zip(ds, fs)) if d != 0)
        else:
            d = ds[0]
            driver = t.a if d > 0 else t.b
            driving = None if d == 0 else t.ports[driver][1]
            # the loss from the carrier-frame power of the driving member (exact 0 when lossless);
            # sum(powers) is the same up to round-off, which the tests check
            loss = 0.0 if d == 0 else (1.0 - eta[t.name]) * abs(values[driver] * rel[driver])
        sets.append(SetFlow(t.name, t.kind, eta[t.name], torques, speeds, powers,
                            sum(p for p in powers.values() if p > 0), loss, driving,
                            {port: link for link, port, _ in t.ports}))
    losses = sum(s.loss for s in sets)

    element_torques, warnings = {}, []
    branches = [s.throughput for s in sets]
    for grp, c in zip(gear.groups, gear.group_col):
        t = float(x[c])
        element_torques[grp.label] = t
        first = mech.element(grp.first)
        w = speed[first.link1]
        if first.kind in ("clutch", "dog") and first.link2 != HOUSING and known_speeds[first.link1] is not None:
            branches.append(abs(t * w))
        holding = [e for e, sgn in zip(grp.members, grp.signs) if _holds(mech.element(e), sgn * t)]
        if not holding:
            warnings.append(f"one-way clutch {grp.label} overruns under this torque: the gear holds only in "
                            f"{'drive' if coast else 'coast'}")
    # the power of the source: the input's (1) in drive, the output's in coast
    source = torque_ratio * speed[mech.output] if coast else 1.0
    circulating = max(0.0, max(branches, default=0.0) - source)
    if circulating < 1e-12:
        circulating = 0.0

    open_elements = [e for e in mech.elements if e.name not in gear.locked]
    slips = {}
    for e in open_elements:
        w1 = 0.0 if e.link1 == HOUSING else known_speeds[e.link1]
        w2 = 0.0 if e.link2 == HOUSING else known_speeds[e.link2]
        slips[e.name] = None if w1 is None or w2 is None else w1 - w2
    slip_rpm, overspeed = None, []
    if input_rpm is not None:
        slip_rpm = {k: (None if v is None else v * input_rpm) for k, v in slips.items()}
        for e in open_elements:
            limit = e.max_slip_rpm if e.max_slip_rpm is not None else max_slip_rpm
            if limit is not None and slip_rpm[e.name] is not None and abs(slip_rpm[e.name]) > limit:
                overspeed.append(e.name)
    # P_out / P_in in drive, P_in / P_out in coast (powers into the input, out of the output)
    efficiency = 1.0 / (torque_ratio * speed[mech.output]) if coast else torque_ratio * speed[mech.output]
    if efficiency <= 0.0:
        warnings.append(f"efficiency {efficiency:.4g} <= 0: the gear self-locks in drive with these efficiencies")
    return GearFlow(name, tuple(gear_decl.engaged), ratio, torque_ratio, efficiency, known_speeds, element_torques,
                    slips, tuple(sets), losses, circulating, iterations, slip_rpm, tuple(overspeed), tuple(warnings),
                    input_torque, gear_decl.alternative)


def _holds(e, t: float) -> bool:
    """Whether element ``e`` can carry the torque ``t`` (its own direction) while locked: a
    friction element always (up to its capacity), a one-way clutch only in its locking direction
    (``free=positive`` carries ``t <= 0``)."""
    if e.kind != "oneway":
        return True
    return t <= 1e-12 if e.free == "positive" else t >= -1e-12


def _capacities(mech: Mechanism, gears, design_torque, safety_factor, dynamic_ratio) -> tuple[Capacity, ...]:
    g = bond_graph(mech)
    best: dict[str, tuple[float, str | None]] = {e.name: (0.0, None) for e in mech.elements}
    for flow in gears:
        for grp in locked_constraints(g, complete_locked(g, flow.engaged)):
            t = flow.element_torques[grp.label]
            for e, sgn in zip(grp.members, grp.signs):
                element = mech.element(e)
                # a member in parallel is sized to carry the group's torque alone, a one-way
                # clutch only in its locking direction
                if _holds(element, sgn * t) and abs(t) > best[e][0]:
                    best[e] = (abs(t), flow.name)
    out = []
    for e in mech.elements:
        top, where = best[e.name]
        torque = static = dynamic = None
        if design_torque is not None:
            torque = top * design_torque
            static = safety_factor * torque
            dynamic = None if e.kind in ("oneway", "dog") else dynamic_ratio * static
        out.append(Capacity(e.name, e.kind, top, where, torque, static, dynamic,
                            None if math.isinf(e.static) else e.static,
                            None if e.kind in ("oneway", "dog") else e.dynamic))
    return tuple(out)


def power_flow(mech: Mechanism, eta0: float | None = None, input_rpm: float | None = None,
               max_slip_rpm: float | None = None, eta_pair: float | None = None,
               design_torque: float | None = None, safety_factor: float = DEFAULT_SAFETY_FACTOR,
               dynamic_ratio: float = DEFAULT_DYNAMIC_RATIO, gears=None, coast: bool = False) -> PowerFlow:
    """Power flow, efficiency and element loads of every declared gear of ``mech``.

    Parameters
    ----------
    mech
        The mechanism; every declared gear (not the neutrals) is analysed, or those named in
        ``gears``.
    eta0
        Standing efficiency of the planetary sets (and, unless ``eta_pair`` is given, of the gear
        pairs) that give none in the file (default :data:`DEFAULT_ETA0`); ``1`` is lossless. The
        file's ``eta0=`` of a set (``eta=`` of a pair) wins.
    input_rpm
        Input speed [rpm]: gives the slips in rpm and flags the open elements whose slip exceeds
        their ``max_slip_rpm`` (the file's, else ``max_slip_rpm`` here) as ``overspeed``.
    max_slip_rpm
        Slip limit [rpm] for the elements that give none in the file.
    eta_pair
        Mesh efficiency of the gear pairs that give none in the file (default: ``eta0`` when
        given, else :data:`DEFAULT_ETA_PAIR`).
    design_torque
        Design input torque [N*m] for the capacity sizing (without it only the per-unit largest
        torques are given).
    safety_factor, dynamic_ratio
        Suggested static capacity = ``safety_factor`` x the largest element torque; dynamic =
        ``dynamic_ratio`` x static.
    gears
        Names of the gears to analyse (default: every declared gear).
    coast
        Coast (overrun, engine braking) instead of drive: the driveline drives the output and the
        input absorbs unit torque (``input_torque = -1``); the mesh losses then act the other way.

    Raises
    ------
    PowerFlowError
        Bad arguments, a gear without a determined ratio or with non-unique static torques.
    PowerFlowConvergenceError
        A gear whose power directions have no single consistent assignment.

    Examples
    --------
    >>> from transgen.language import load_mechanism
    >>> flow = power_flow(load_mechanism("zf8hp70"), eta0=1.0)
    >>> g1 = flow.gear("1")
    >>> round(g1.ratio, 4), round(g1.torque_ratio, 4), round(g1.efficiency, 12)
    (4.6957, 4.6957, 1.0)
    """
    eta0 = _check_number("eta0", eta0, 0.0, 1.0)
    eta_pair = _check_number("eta_pair", eta_pair, 0.0, 1.0)
    input_rpm = _check_number("input_rpm", input_rpm, 0.0, 1e7)
    max_slip_rpm = _check_number("max_slip_rpm", max_slip_rpm, 0.0, 1e7)
    design_torque = _check_number("design_torque", design_torque, 0.0, 1e9)
    safety_factor = _check_number("safety_factor", safety_factor, 0.0, 1e3)
    dynamic_ratio = _check_number("dynamic_ratio", dynamic_ratio, 0.0, 1.0)
    unknown_teeth = [p.name for p in mech.planetaries if not p.teeth_known]
    if unknown_teeth:
        raise PowerFlowError(f"the tooth counts of {', '.join(unknown_teeth)} are unknown: choose them first "
                             f"('transgen synthesize teeth')")
    eta = _efficiencies(mech, eta0, eta_pair)
    g = bond_graph(mech)
    declared = [gr for gr in mech.gears if gr.kind == "gear"]
    if gears is not None:
        names = [gr.name for gr in declared]
        unknown = [n for n in gears if n not in names]
        if unknown:
            raise PowerFlowError(f"no gear {', '.join(unknown)} in {mech.name} (gears: {', '.join(names) or 'none'})")
        declared = [gr for gr in declared if gr.name in set(gears)]
    flows = tuple(_gear_flow(mech, g, gr, eta, input_rpm, max_slip_rpm, bool(coast)) for gr in declared)
    capacities = _capacities(mech, flows, design_torque, safety_factor, dynamic_ratio)
    return PowerFlow(mech, flows, eta, capacities, input_rpm, max_slip_rpm, design_torque, safety_factor,
                     dynamic_ratio, bool(coast))


def _pairs(values: dict, fmt: str = "{:+.4f}") -> str:
    return "  ".join(f"{k} {'-' if v is None else fmt.format(v)}" for k, v in values.items()) or "(none)"


def _driver(s: SetFlow) -> str:
    """The driving member: ``sun``/``ring`` of a planetary, the driving link of a gear pair."""
    return s.driving if s.kind in ("planetary", "stepped") else s.links[s.driving]


def powerflow_text(flow: PowerFlow) -> str:
    """A readable table per gear and the capacity sizing (``transgen powerflow``)."""
    m = flow.mechanism
    eta = ", ".join(f"{k} {v:g}" for k, v in flow.eta.items()) or "none"
    out = [f"{m.name}: power flow per gear in {'coast (the driveline drives the output)' if flow.coast else 'drive'}; "
           f"input {m.input}, output {m.output}",
           f"  per unit input speed, torque and power{' (input torque -1: absorbed)' if flow.coast else ''}; "
           f"efficiencies: {eta}",
           "  torque ratio = output torque to the driveline / input torque; element torques from LINK1 to LINK2"]
    for g in flow.gears:
        out.append("")
        alt = ", alternative" if g.alternative else ""
        out.append(f"gear {g.name} ({' '.join(g.engaged)}{alt}): ratio {g.ratio:.4f}, torque ratio {g.torque_ratio:.4f}, "
                   f"efficiency {100 * g.efficiency:.2f} %, losses {100 * g.losses:.2f} %, "
                   f"circulating power {g.circulating_power:.3f}")
        out.append(f"    link speeds      {_pairs(g.link_speeds)}")
        out.append(f"    element torques  {_pairs(g.element_torques)}")
        out.append(f"    open slips       {_pairs(g.element_slips)}")
        if g.element_slip_rpm is not None:
            out.append(f"    slips at {flow.input_rpm:g} rpm  {_pairs(g.element_slip_rpm, '{:+.0f}')}"
                       + (f"   OVER-SPEED: {', '.join(g.overspeed)}" if g.overspeed else ""))
        sets = "  ".join(f"{s.name} {s.throughput:.3f}" + (f" (loss {s.loss:.4f}, {_driver(s)} drives)" if s.driving else "")
                         for s in g.sets)
        out.append(f"    set power        {sets or '(none)'}")
        for w in g.warnings:
            out.append(f"    warning: {w}")
    out.append("")
    over = f"over gears {' '.join(g.name for g in flow.gears)}"
    if flow.design_torque is None:
        out.append(f"largest element torques per unit input torque {over} (give --design-torque for capacities):")
    else:
        out.append(f"capacities {over} at a design input torque of {flow.design_torque:g} N*m, safety factor "
                   f"{flow.safety_factor:g}, dynamic = {flow.dynamic_ratio:g} x static:")
    out.append(f"  {'element':<10} {'kind':<7} {'max t/T_in':>10} {'gear':>5} {'torque':>9} {'static':>9} "
               f"{'dynamic':>9}   declared static/dynamic [N*m]")
    for c in flow.capacities:
        def num(x):
            return "-" if x is None else f"{x:.0f}"
        declared = f"{num(c.declared_static)}/{num(c.declared_dynamic)}"
        out.append(f"  {c.element:<10} {c.kind:<7} {c.max_torque:>10.4f} {c.gear or '-':>5} {num(c.torque):>9} "
                   f"{num(c.static):>9} {num(c.dynamic):>9}   {declared}")
    return "\n".join(out)
