"""Quasi-steady radial turbine from its causal map (thesis sections 4.3.2 and 4.4.2).

Inputs are the inlet total pressure and temperature, the outlet total pressure and the rotor
speed; outputs are the mass flow, the outlet total temperature and the shaft torque (thesis
Figure 4.9); the computation is :meth:`Turbomachine.operate
<transgen.sim.engine.turbomachine.Turbomachine.operate>`.

Sign conventions: the mass flow is positive from inlet (exhaust manifold) to outlet; ``power``
and ``torque`` are what the turbine *delivers* to the shaft (positive drives the rotor).  There is
no reverse flow: an expansion ratio below 1 clamps to the map's ER = 1 line (zero flow).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

from .gas import EXHAUST, Gas
from .preprocessor import TurbineTable
from .turbomachine import MachinePoint, Turbomachine

__all__ = ["Turbine", "TurbinePoint"]


@dataclass(frozen=True)
class TurbinePoint(MachinePoint):
    """One quasi-steady turbine operating point: the :class:`MachinePoint` attributes (outlet
    temperature by eq. 4.16, power ``m_dot*cp*(T_in - T_out)`` delivered, torque by eq. 4.18,
    efficiency - for the shipped map W&E's eta_tm, mechanical losses included), the total
    expansion ratio ``expansion_ratio`` p01/p02 [-], and the corrected speed [rad/s] and flow
    [kg/s] of eqs 4.28-4.29."""

    expansion_ratio: float
    corrected_speed: float
    corrected_flow: float


@dataclass(frozen=True)
class Turbine(Turbomachine):
    """A turbine described by its causal table ``m_corr(N_corr, ER)``, ``eta(N_corr, ER)`` (a
    :class:`~transgen.sim.engine.preprocessor.TurbineTable` from
    :func:`~transgen.sim.engine.preprocessor.preprocess_turbine`); working gas exhaust by
    default; parameters as for :class:`~transgen.sim.engine.turbomachine.Turbomachine`."""

    table: TurbineTable
    gas: Gas = EXHAUST
    compresses: ClassVar[bool] = False
    point: ClassVar[type] = TurbinePoint
