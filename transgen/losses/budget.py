"""Per-gear loss budget, efficiency map and neutral parasitic loss with drag, spin and pump losses.

Superposition of the load-dependent and the load-independent losses (the ISO/TR 14179 way of
adding a gearbox's losses): the **mesh** loss is the power flow's, Müller's carrier-frame rule of
:func:`transgen.powerflow.power_flow`, a fixed fraction ``1 - eta_mesh`` of the transmitted power;
the **drag** of every open element ``T_k(slip_k) * slip_k``, the **spin** of every link
``T_j(w_j) * w_j`` and the **pump** ``p Q / eta`` come from the gear's kinematics (the power
flow's link speeds and slips per unit input speed, scaled by the input speed) and add:

    drive:  ``P_out = eta_mesh * P_in - P_drag - P_spin - P_pump``, ``eta = P_out / P_in``
            (so the drag alone lowers eta by exactly ``sum(T_k slip_k) / P_in``);
    coast:  the input absorbs ``P_abs = |T_in| w_in``; the output supplies
            ``P_out = P_abs / eta_mesh + P_drag + P_spin + P_pump``, ``eta = P_abs / P_out``.

The drag and spin torques' reactions are not passed through the meshes a second time (their own
mesh loss is of the order ``(1 - eta_mesh) * P_drag``, 1-2 % of the drag; see ``docs/losses.md``). A
link or element the input speed does not fix (a floating member) has an unknown speed: its loss
is left out and named in ``unknown``.

The **neutral parasitic loss** (SAE J2453's structure: in-gear efficiency over input speed and
torque, plus the neutral's losses over input speed) is the drag, spin and pump power with the
input turning, the neutral's elements engaged and the output held (vehicle at rest).
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..graph import bond_graph, link_nodes
from ..kinematics import constraint_matrix, floating_links
from ..model import HOUSING
from .drag import RPM
from .lossfile import LossModel

__all__ = ["GearLosses", "NeutralLosses", "EfficiencyMap", "gear_losses", "loss_budget", "efficiency_map",
           "neutral_losses", "LOSS_UNITS"]

LOSS_UNITS = {
    "input_rpm": "rpm", "input_torque": "N*m", "input_power": "W", "output_power": "W", "efficiency": "1",
    "mesh_efficiency": "1", "ratio": "1", "mesh": "W", "drag": "W", "spin": "W", "pump": "W", "total": "W",
    "slip": "rad/s", "slip_rpm": "rpm", "torque": "N*m", "power": "W", "speed_rpm": "rpm", "speeds_rpm": "rpm",
    "torques": "N*m", "oil_temperature": "degC", "c": "N*m*s/rad", "coefficients": "N*m*(s/rad)^k",
    "displacement": "m^3/rev", "line_pressure": "Pa", "pressure_per_torque": "Pa/(N*m)", "speed_ratio": "1",
    "loss": "W", "drag_elements": "W",
}
"""Units of the numeric fields of ``transgen powerflow --losses --json``."""


@dataclass(frozen=True)
class GearLosses:
    """The losses of one gear at one operating point (SI; ``*_rpm`` in rpm).

    ``drag[element] = (slip [rad/s], torque [N*m], power [W])`` of each open element with a known
    slip; ``spin[link] = (speed [rad/s], power [W])``; ``mesh``, ``pump`` [W]; ``unknown``: open
    elements and links whose speed the input does not fix (their loss is left out)."""

    gear: str
    engaged: tuple[str, ...]
    ratio: float
    input_rpm: float
    input_torque: float
    mesh_efficiency: float
    mesh: float
    drag: dict = field(compare=False)
    spin: dict = field(compare=False)
    pump: float = 0.0
    coast: bool = False
    unknown: tuple[str, ...] = ()

    @property
    def input_speed(self) -> float:
        return self.input_rpm * RPM

    @property
    def drag_total(self) -> float:
        return sum(p for _, _, p in self.drag.values())

    @property
    def spin_total(self) -> float:
        return sum(p for _, p in self.spin.values())

    @property
    def parasitic(self) -> float:
        """Drag + spin + pump [W]: the load-independent losses."""
        return self.drag_total + self.spin_total + self.pump

    @property
    def input_power(self) -> float:
        """Power into the input [W] (negative in coast: absorbed)."""
        return self.input_torque * self.input_speed

    @property
    def output_power(self) -> float:
        """Power out of the output [W] (negative in coast: supplied by the driveline)."""
        p = abs(self.input_power)
        return (self.mesh_efficiency * p - self.parasitic) if not self.coast else -(p / self.mesh_efficiency
                                                                                    + self.parasitic)

    @property
    def total(self) -> float:
        return self.mesh + self.parasitic

    @property
    def efficiency(self) -> float:
        """``P_out / P_in`` in drive, ``P_in / P_out`` in coast (may be <= 0 at low load: the
        parasitic losses exceed what the input delivers)."""
        if self.coast:
            return abs(self.input_power) / abs(self.output_power)
        return self.output_power / self.input_power if self.input_power else float("nan")

    def to_dict(self) -> dict:
        return {"name": self.gear, "engaged": list(self.engaged), "ratio": self.ratio, "input_rpm": self.input_rpm,
                "input_torque": self.input_torque, "input_power": self.input_power,
                "output_power": self.output_power, "efficiency": self.efficiency,
                "mesh_efficiency": self.mesh_efficiency,
                "losses": {"mesh": self.mesh, "drag": self.drag_total, "spin": self.spin_total, "pump": self.pump,
                           "total": self.total},
                "drag": {e: {"slip": s, "slip_rpm": s / RPM, "torque": t, "power": p}
                         for e, (s, t, p) in self.drag.items()},
                "spin": {k: {"speed_rpm": w / RPM, "power": p} for k, (w, p) in self.spin.items()},
                "unknown": list(self.unknown)}


def _parasitic(mech, model: LossModel, link_speed: dict, slips: dict, w_in: float):
    """Drag per open element and spin per link at the input speed ``w_in`` [rad/s] from the
    speeds per unit input speed (``None``: unknown)."""
    drag, spin, unknown = {}, {}, []
    for name, s in slips.items():
        e = mech.element(name)
        m = model.drag_model(e)
        if s is None:
            if m.torque(1.0, model.oil_temperature) != 0.0:  # a floating member that would drag
                unknown.append(name)
            continue
        slip = s * w_in
        t = float(m.torque(slip, model.oil_temperature))
        drag[name] = (slip, t, t * slip)
    for link, v in link_speed.items():
        if link == HOUSING:
            continue
        m = model.spin_model(link)
        if v is None:
            if m.torque(1.0) != 0.0:
                unknown.append(link)
            continue
        w = v * w_in
        spin[link] = (w, float(m.torque(w)) * w)
    return drag, spin, tuple(unknown)


def gear_losses(flow, gear_flow, model: LossModel, input_rpm: float, input_torque: float) -> GearLosses:
    """The losses of ``gear_flow`` (a :class:`~transgen.powerflow.GearFlow` of the power flow
    ``flow``) at ``input_rpm`` [rpm] and ``input_torque`` [N*m, its magnitude in coast]."""
    mech = flow.mechanism
    w_in = input_rpm * RPM
    torque = abs(input_torque)
    drag, spin, unknown = _parasitic(mech, model, gear_flow.link_speeds, gear_flow.element_slips, w_in)
    eta = gear_flow.efficiency
    p = torque * w_in
    mesh = (1.0 - eta) * p if not flow.coast else p * (1.0 / eta - 1.0)
    return GearLosses(gear_flow.name, gear_flow.engaged, gear_flow.ratio, float(input_rpm),
                      -torque if flow.coast else torque, eta, mesh, drag, spin,
                      float(model.pump.power(w_in, torque)), flow.coast, unknown)


def loss_budget(flow, model: LossModel, input_rpm: float, input_torque: float) -> list[GearLosses]:
    """:func:`gear_losses` of every gear of the power flow ``flow``."""
    return [gear_losses(flow, g, model, input_rpm, input_torque) for g in flow.gears]


@dataclass(frozen=True)
class EfficiencyMap:
    """``efficiency[gear]`` and ``loss[gear]`` [W]: arrays over ``(torques[i], speeds_rpm[j])``."""

    speeds_rpm: np.ndarray
    torques: np.ndarray
    efficiency: dict
    loss: dict

    def to_dict(self) -> dict:
        return {"speeds_rpm": self.speeds_rpm.tolist(), "torques": self.torques.tolist(),
                "gears": {g: {"efficiency": self.efficiency[g].tolist(), "loss": self.loss[g].tolist()}
                          for g in self.efficiency}}


def efficiency_map(flow, model: LossModel, speeds_rpm, torques) -> EfficiencyMap:
    """Efficiency and total loss of every gear of ``flow`` over the input speeds [rpm] and
    input torques [N*m] (the SAE J2453 map)."""
    speeds, torques = np.asarray(speeds_rpm, dtype=float), np.asarray(torques, dtype=float)
    eff, loss = {}, {}
    for g in flow.gears:
        e = np.empty((len(torques), len(speeds)))
        lo = np.empty_like(e)
        for j, n in enumerate(speeds):
            for i, t in enumerate(torques):
                gl = gear_losses(flow, g, model, n, t)
                e[i, j], lo[i, j] = gl.efficiency, gl.total
        eff[g.name], loss[g.name] = e, lo
    return EfficiencyMap(speeds, torques, eff, loss)


@dataclass(frozen=True)
class NeutralLosses:
    """The parasitic loss of a neutral (``engaged``) over the input speed, output held: arrays
    [W] over ``speeds_rpm`` by kind, ``drag_elements[name]`` per open element."""

    name: str
    engaged: tuple[str, ...]
    speeds_rpm: np.ndarray
    drag: np.ndarray
    spin: np.ndarray
    pump: np.ndarray
    drag_elements: dict
    unknown: tuple[str, ...] = ()

    @property
    def total(self) -> np.ndarray:
        return self.drag + self.spin + self.pump

    def to_dict(self) -> dict:
        return {"name": self.name, "engaged": list(self.engaged), "speeds_rpm": self.speeds_rpm.tolist(),
                "drag": self.drag.tolist(), "spin": self.spin.tolist(), "pump": self.pump.tolist(),
                "total": self.total.tolist(), "drag_elements": {k: v.tolist() for k, v in self.drag_elements.items()},
                "unknown": list(self.unknown)}


def held_output_speeds(mech, engaged) -> dict:
    """Speed of every link per unit input speed with ``engaged`` locked and the output held
    (``None``: not fixed by the input speed). Raises ``ValueError`` when the input is held too."""
    g = bond_graph(mech)
    links = link_nodes(g)
    i_in, i_out = links.index(mech.input), links.index(mech.output)
    eye = np.eye(len(links))
    a = np.vstack([constraint_matrix(g, engaged), eye[i_out]])
    m = np.vstack([a, eye[i_in]])
    rhs = np.zeros(m.shape[0])
    rhs[-1] = 1.0
    w, *_ = np.linalg.lstsq(m, rhs, rcond=None)
    if np.linalg.norm(m @ w - rhs) > 1e-9:
        raise ValueError(f"{' '.join(engaged) or 'no element'} engaged with the output held: the input is held too")
    free = set(floating_links(a, i_in))
    return {name: (None if k in free else float(w[k])) for k, name in enumerate(links)}


def neutral_losses(mech, model: LossModel, speeds_rpm, engaged=(), name: str = "N") -> NeutralLosses:
    """:class:`NeutralLosses` of ``mech`` with ``engaged`` locked over ``speeds_rpm``."""
    speed = held_output_speeds(mech, engaged)
    speed[HOUSING] = 0.0
    slips = {}
    for e in mech.elements:
        if e.name in engaged:
            continue
        w1, w2 = speed.get(e.link1), speed.get(e.link2)
        slips[e.name] = None if w1 is None or w2 is None else w1 - w2
    speeds = np.asarray(speeds_rpm, dtype=float)
    drag, spin, pump = (np.zeros(len(speeds)) for _ in range(3))
    per = {}
    unknown: tuple = ()
    for j, n in enumerate(speeds):
        d, s, unknown = _parasitic(mech, model, speed, slips, n * RPM)
        drag[j], spin[j] = sum(p for _, _, p in d.values()), sum(p for _, p in s.values())
        pump[j] = model.pump.power(n * RPM, 0.0)
        for k, (_, _, p) in d.items():
            per.setdefault(k, np.zeros(len(speeds)))[j] = p
    return NeutralLosses(name, tuple(engaged), speeds, drag, spin, pump, per, unknown)
