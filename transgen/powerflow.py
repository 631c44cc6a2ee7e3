"""Power flow and efficiency per gear: speeds, static torques, mesh losses, circulating power,
shift-element capacities.

The method (static torque balance per gear, mesh losses by power direction, circulating power,
capacities) is described in docs/explanation/power-flow.md.
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
from .powerflow_gear import (_MAX_ENUMERATED, _MAX_ITERATIONS, _POWER_TOL, PowerFlowConvergenceError,  # noqa: F401
                             PowerFlowError, _Gear, _solve_directions, _transformers)

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
    motion or no torque, lossless); ``rolling`` the rolling power: the carrier-frame power the
    members feed into the meshes (the sum of the positive ``t * (w - w_carrier)``; a gear pair's
    is its throughput), what the meshes carry and lose by however little of it leaves the set.
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
    rolling: float = 0.0


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
    def set_rolling(self) -> dict[str, float]:
        """Rolling (carrier-frame) power of every transformer per unit input power."""
        return {s.name: s.rolling for s in self.sets}

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
    "set_member_power": "1 (per unit input power)", "set_rolling": "1 (per unit input power)",
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
                 "set_loss": {s.name: s.loss for s in g.sets}, "set_rolling": g.set_rolling,
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
    for k, (t, sl, (rel, ok)) in enumerate(zip(gear.transformers, gear.var_slices, gear.relative)):
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
        # rolling power: what the members feed into the meshes in the carrier frame (none when a
        # member floats: it carries no torque)
        rolling = float(sum(max(0.0, v * r) for v, r in zip(values, rel))) if ok else 0.0
        sets.append(SetFlow(t.name, t.kind, eta[t.name], torques, speeds, powers,
                            sum(p for p in powers.values() if p > 0), loss, driving,
                            {port: link for link, port, _ in t.ports}, rolling))
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
        rolling = "  ".join(f"{s.name} {s.rolling:.3f}" for s in g.sets)
        out.append(f"    set power        {sets or '(none)'}")
        out.append(f"    rolling power    {rolling or '(none)'}")
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
