"""Drag, spin and pump losses of the transmission in the simulation, as link torques.

The loss models are :mod:`transgen.losses`' (called here, one implementation with ``transgen
powerflow --losses``); this module applies them to the dynamic model in every mode:

* **drag** of a shift element: the drag torque ``T_k(slip_k)`` of its model
  (:meth:`~transgen.losses.LossModel.drag_model`: the loss file's, else ``drag=`` in the
  ``.mech``, else the default of its kind) is added to the element's own torque input
  ``t_<name>`` (link1 to link2, as a slipping element's friction torque). A locked element has
  zero slip and so no drag; an open and a slipping one drag (the film shears in both);
* **spin** of a link: ``-T_j(w_j)`` of its spin model on the link;
* **pump**: ``-P(w) / w`` on the link that drives it (default the input link), ``P`` the power
  of :class:`~transgen.losses.Pump` at the constant line pressure.

The spin and pump torques act on links, which the mechanism's inputs do not reach in general:
:func:`with_loss_torques` adds one external torque ``loss@<link>`` per such link to the
mechanism, so that every mode's matrices (``B``, ``D``) carry them exactly as the equations of
motion give them. A spin torque with a constant part (``a0``) and the pump torque change sign
with the speed; both are multiplied by ``w^2 / (w^2 + w_s^2)`` (:data:`REGULARIZATION_SPEED`
``w_s``), continuous and smooth through rest, within ``(w_s / w)^2`` of the model beyond.

The component dissipates the power the torques take (``sum T_k slip_k + sum T_j w_j + P``,
never negative), so the energy balance of :mod:`transgen.sim.solve.monitor` closes with them,
and integrates it by kind in its states ``E_drag_<element>``, ``E_spin``, ``E_pump`` [J]
(and ``E_mesh``, whose rate the mode-switching right-hand side gives: the mesh loss of
:mod:`.mesh` is the transmission's, not a torque of this component).
It has no compiled form: the compiled right-hand side evaluates it in Python
(:mod:`transgen.sim.solve.kernel`), so the two paths give the same numbers.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np

from transgen.losses import LossModel
from transgen.model import ExternalTorque, Mechanism

from .components import Component

__all__ = ["LOSS_KINDS", "LOSS_TORQUE_PREFIX", "REGULARIZATION_SPEED", "LossComponent", "with_loss_torques",
           "loss_links", "loss_component"]

LOSS_KINDS = ("drag", "spin", "pump", "mesh")
"""The kinds of losses (``[losses] kinds`` of a scenario); ``mesh``: :mod:`.mesh`."""
LOSS_TORQUE_PREFIX = "loss@"
"""Name of the external torque a link's spin and pump losses act through: ``loss@<link>`` (not a
name a ``.mech`` file can declare, so it cannot clash with the file's torques)."""
REGULARIZATION_SPEED = 0.1
"""``w_s`` [rad/s] of the factor ``w^2 / (w^2 + w_s^2)`` on the spin and pump torques (about 1 rpm)."""


def _active(model) -> bool:
    """Whether a drag or spin model ever gives a torque (a coefficient or a table value not 0)."""
    if hasattr(model, "c"):
        return model.c != 0.0
    if hasattr(model, "coefficients"):
        return any(c != 0.0 for c in model.coefficients)
    return bool(np.any(np.asarray(model.values, dtype=float) != 0.0))


def _spins(model: LossModel, link: str) -> bool:
    return _active(model.spin_model(link))


def loss_links(mech: Mechanism, model: LossModel, kinds=LOSS_KINDS, pump_link: str | None = None) -> tuple[str, ...]:
    """The links the spin (a nonzero spin model) and pump losses act on, in the mechanism's order."""
    out = []
    for name in mech.link_names:
        if ("spin" in kinds and _spins(model, name)) or ("pump" in kinds and model.pump.displacement > 0
                                                          and name == (pump_link or mech.input)):
            out.append(name)
    return tuple(out)


def with_loss_torques(mech: Mechanism, links) -> Mechanism:
    """``mech`` with an external torque ``loss@<link>`` (role ``load``: it drives its link) on
    each of ``links`` (``mech`` itself when there are none)."""
    if not links:
        return mech
    return replace(mech, loads=mech.loads + tuple(ExternalTorque(LOSS_TORQUE_PREFIX + k, k, "load") for k in links))


def _regularized(torque: float, w: float) -> float:
    return torque * (w * w / (w * w + REGULARIZATION_SPEED ** 2))


@dataclass
class LossComponent(Component):
    """The drag, spin and pump losses of a transmission (see the module docstring).

    ``drag``: ``(element name, link1 index, link2 index or None, input name, model)``;
    ``spin``: ``(link name, link index, input name, model)``; ``pump``: ``(link index, input
    name, Pump)`` or None. ``oil_temperature`` [degC] picks a drag table's row."""

    drag: tuple = ()
    spin: tuple = ()
    pump: tuple | None = None
    oil_temperature: float = 90.0
    mesh: bool = False
    name: str = "losses"
    state_names: tuple = field(init=False)
    signal_units: dict = field(init=False)

    def __post_init__(self):
        names = [f"E_drag_{d[0]}" for d in self.drag] + (["E_spin"] if self.spin else []) + (
            ["E_pump"] if self.pump is not None else [])
        self.state_names = tuple(names) + (("E_mesh",) if self.mesh else ())
        units = {n: "J" for n in self.state_names}
        if self.mesh:
            units["P_mesh"] = "W"
        units.update({f"P_drag_{d[0]}": "W" for d in self.drag})
        units.update({"P_spin": "W", "P_pump": "W", "P_losses": "W"})
        self.signal_units = units

    # the loss torques and powers at one point: {input: torque}, [drag powers..., spin, pump]
    def _point(self, w) -> tuple[dict, list]:
        torques: dict = {}
        powers = []
        oil = self.oil_temperature
        for _, l1, l2, col, model in self.drag:
            slip = float(w[l1]) - (float(w[l2]) if l2 is not None else 0.0)
            t = float(model.torque(slip, oil)) if slip != 0.0 else 0.0
            torques[col] = torques.get(col, 0.0) + t
            powers.append(t * slip)
        if self.spin:
            p = 0.0
            for _, k, col, model in self.spin:
                wk = float(w[k])
                t = _regularized(float(model.torque(wk)), wk)
                torques[col] = torques.get(col, 0.0) - t
                p += t * wk
            powers.append(p)
        if self.pump is not None:
            k, col, pump = self.pump
            wk = float(w[k])
            t = pump.power(wk) * wk / (wk * wk + REGULARIZATION_SPEED ** 2)
            torques[col] = torques.get(col, 0.0) - t
            powers.append(t * wk)
        if self.mesh:
            powers.append(0.0)  # E_mesh: its rate is the transmission's (switching's right-hand side)
        return torques, powers

    def torques(self, t, x, w):
        return self._point(w)[0]

    def derivatives(self, t, x, w):
        return self._point(w)[1]

    def dissipation(self, t, x, w):
        return math.fsum(self._point(w)[1])

    def evaluate(self, t, x, w):
        torques, powers = self._point(w)
        return torques, powers, 0.0, math.fsum(powers), 0.0

    def sample(self, ts, X, W):
        n = len(ts)
        torques: dict = {}
        powers = np.zeros((len(self.state_names), n))  # (the E_mesh row stays zero)
        for k in range(n):
            tk, pk = self._point(W[:, k])
            for name, value in tk.items():
                torques.setdefault(name, np.zeros(n))[k] += value
            powers[:, k] = pk
        signals = {name: X[j] for j, name in enumerate(self.state_names)}
        for j, d in enumerate(self.drag):
            signals[f"P_drag_{d[0]}"] = powers[j]
        j = len(self.drag)
        signals["P_spin"] = powers[j] if self.spin else np.zeros(n)
        signals["P_pump"] = powers[len(self.state_names) - 1 - self.mesh] if self.pump is not None else np.zeros(n)
        signals["P_losses"] = powers.sum(axis=0)
        return torques, signals, np.zeros(n)

    def signals(self, t, x, w):
        _, signals, _ = self.sample(np.array([t]), np.asarray(x, dtype=float)[:, None], np.asarray(w)[:, None])
        return {k: float(v[0]) for k, v in signals.items()}


def loss_component(tr, model: LossModel, kinds=LOSS_KINDS, pump_link: str | None = None) -> LossComponent:
    """The :class:`LossComponent` of the transmission ``tr`` (its mechanism carrying the loss
    torques of :func:`with_loss_torques` for :func:`loss_links`) with the loss model ``model``
    and the loss ``kinds`` on."""
    mech = tr.mech
    drag = []
    if "drag" in kinds:
        for e, cfg in zip(mech.elements, tr.elements):
            m = model.drag_model(e)
            if _active(m):
                drag.append((e.name, cfg.link1, cfg.link2, f"t_{e.name}", m))
    spin = tuple((k, tr.link_index[k], LOSS_TORQUE_PREFIX + k, model.spin_model(k)) for k in mech.link_names
                 if "spin" in kinds and _spins(model, k))
    pump = None
    link = pump_link or mech.input
    if "pump" in kinds and model.pump.displacement > 0:
        pump = (tr.link_index[link], LOSS_TORQUE_PREFIX + link, model.pump)
    for col in [d[3] for d in drag] + [s[2] for s in spin] + ([pump[1]] if pump else []):
        if col not in tr.input_index:
            raise ValueError(f"the mechanism has no input {col}: build it with with_loss_torques(mech, loss_links(...))")
    return LossComponent(tuple(drag), spin, pump, model.oil_temperature, "mesh" in kinds)


def loss_energy(time: np.ndarray, signals: dict, t0: float | None = None, t1: float | None = None) -> dict | None:
    """The loss energies by kind [J] of a run from its ``E_drag_<element>``, ``E_spin``,
    ``E_pump`` and ``E_mesh`` signals (the loss component's integrals): their change from the
    first sample at or after ``t0`` to the last at or before ``t1`` (default the whole run).
    ``{"drag": {element: J}, "drag_total", "spin", "pump", "mesh", "total"}`` with the kinds the
    run has; None without losses."""
    drag = [k for k in signals if k.startswith("E_drag_")]
    kinds = [k for k in ("E_spin", "E_pump", "E_mesh") if k in signals]
    if not drag and not kinds or not len(time):
        return None
    i0 = int(np.searchsorted(time, -math.inf if t0 is None else t0, side="left"))
    i1 = int(np.searchsorted(time, math.inf if t1 is None else t1, side="right")) - 1
    i0, i1 = min(i0, len(time) - 1), max(i1, 0)

    def change(name):
        y = signals[name]
        return float(y[i1] - y[i0]) if i1 > i0 else 0.0

    out: dict = {"drag": {k[len("E_drag_"):]: change(k) for k in drag}}
    out["drag_total"] = math.fsum(out["drag"].values())
    for k in kinds:
        out[k[2:]] = change(k)
    out["total"] = out["drag_total"] + math.fsum(out[k[2:]] for k in kinds)
    return out
