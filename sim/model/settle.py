"""The settled start of a run: the driveshaft wound to the torque of steady acceleration.

A run that starts with the driveshaft unwound (no twist) while the input already drives makes the
driveline ring from the first instant: the output torque swings about its mean at the driveline's
natural frequency and, lightly damped, still does seconds later when the first shift begins.
:func:`settled_driveshaft_torque` gives the driveshaft torque ``T`` with which both ends of the
driveshaft accelerate alike in the initial mode - the twist ``T/k`` of a run that has settled:

* the transmission side: its link accelerations are ``C B u`` (:class:`~transgen.sim.model.transmission.ModeData`)
  with ``u`` the external torques at ``t0`` (the components' torques at their initial states, the
  torques of the slipping elements at their initial slips) and ``T_out = T``, so the output
  link's acceleration is ``a0 + g T`` (``g < 0``: the driveshaft holds the output back);
* the vehicle side: ``(T - road load) / J_v`` (:class:`~transgen.sim.model.components.Driveline`);

equal when ``T = (a0 + road/J_v) / (1/J_v - g)``. With a constant input torque and no
speed-dependent load this is the exact constant-acceleration solution (the twist then stays put);
otherwise it is the quasi-steady start. Torques in N*m, accelerations in rad/s^2.
"""
from __future__ import annotations

import numpy as np

from .components import Driveline

__all__ = ["settled_driveshaft_torque"]


def settled_driveshaft_torque(pt, locked: frozenset, t0: float) -> float:
    """Driveshaft torque [N*m] of steady acceleration at ``t0`` in the mode with the element
    indices ``locked``, for the powertrain ``pt`` (its initial speeds and component states)."""
    tr = pt.transmission
    driveline = next((c for c in pt.components if isinstance(c, Driveline)), None)
    if driveline is None:
        raise ValueError("a settled driveshaft needs a driveline (a [driveline] with a stiffness)")
    w0 = np.asarray(pt.initial_speeds, dtype=float)
    mode = tr.mode(locked)
    u = np.zeros(len(tr.inputs))
    for c in pt.components:
        if c is driveline:
            continue
        for name, value in c.torques(t0, np.asarray(c.initial_state(w0), dtype=float), w0).items():
            u[tr.input_index[name]] += value
    slips = tr.P @ w0
    u[tr.element_input] += tr.slipping_torques(t0, w0, locked, np.sign(slips))
    out = driveline.output
    a0 = float((mode.C @ (mode.B @ u))[out])
    unit = np.zeros(len(tr.inputs))
    unit[tr.input_index["T_out"]] = 1.0
    g = float((mode.C @ (mode.B @ unit))[out])
    road = float(driveline.road_torque(float(w0[out])))
    return (a0 + road / driveline.J_v) / (1.0 / driveline.J_v - g)
