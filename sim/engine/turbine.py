"""Quasi-steady radial turbine from its causal map (thesis sections 4.3.2 and 4.4.2).

Inputs are the inlet total pressure and temperature, the outlet total pressure and the rotor
speed; outputs are the mass flow, the outlet total temperature and the shaft torque (thesis
Figure 4.9).

Sign conventions: the mass flow is positive from inlet (exhaust manifold) to outlet; ``power``
and ``torque`` are what the turbine *delivers* to the shaft (positive drives the rotor).  There is
no reverse flow: an expansion ratio below 1 clamps to the map's ER = 1 line (zero flow).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar, Mapping

from ..causality import Causality, ports
from .map_file import (EXHAUST, OMEGA_FLOOR, Gas, TurbineTable, actual_flow, corrected_speed,
                   expansion_outlet_temperature, torque_from_power)

__all__ = ["Turbine", "TurbinePoint"]


@dataclass(frozen=True)
class TurbinePoint:
    """One quasi-steady turbine operating point.

    Attributes
    ----------
    m_dot : float
        Mass flow [kg/s], inlet to outlet.
    T_out : float
        Outlet total temperature [K] (eq. 4.16).
    power : float
        Shaft power delivered [W], ``m_dot*cp*(T_in - T_out)``.
    torque : float
        Shaft torque delivered [N*m] (eq. 4.18); positive drives the rotor.
    eta : float
        Turbine efficiency [-] (for the shipped map: W&E's eta_tm, mechanical losses included).
    expansion_ratio : float
        Total expansion ratio p01/p02 [-].
    corrected_speed : float
        [rad/s] (eq. 4.28).
    corrected_flow : float
        [kg/s] (eq. 4.29).
    """

    m_dot: float
    T_out: float
    power: float
    torque: float
    eta: float
    expansion_ratio: float
    corrected_speed: float
    corrected_flow: float


@dataclass(frozen=True)
class Turbine:
    """A turbine described by its causal table.

    Parameters
    ----------
    table : TurbineTable
        ``m_corr(N_corr, ER)``, ``eta(N_corr, ER)`` from
        :func:`~transgen.sim.maps.preprocess_turbine`.
    gas : Gas
        Working gas (exhaust).
    omega_floor : float
        Speed floor [rad/s] for ``torque = power/speed``.
    """

    table: TurbineTable
    gas: Gas = EXHAUST
    omega_floor: float = OMEGA_FLOOR
    causality: ClassVar[Mapping[str, Causality]] = ports(
        inlet=Causality.FLOW, outlet=Causality.FLOW, shaft=Causality.RESISTIVE)

    def operate(self, p_in: float, T_in: float, p_out: float, omega: float) -> TurbinePoint:
        """Operating point at inlet total pressure [Pa] and temperature [K], outlet total
        pressure [Pa] and rotor speed [rad/s] (thesis Figure 4.12)."""
        tab = self.table
        n_corr = corrected_speed(omega, T_in, tab.T_ref)
        er = p_in / p_out
        m_corr, eta = tab.lookup(n_corr, er)
        m_dot = actual_flow(m_corr, p_in, T_in, tab.p_ref, tab.T_ref)
        T_out = expansion_outlet_temperature(T_in, max(er, 1.0), eta, self.gas)
        power = m_dot * self.gas.cp * (T_in - T_out)
        return TurbinePoint(m_dot, T_out, power, torque_from_power(power, omega,
                                                                   self.omega_floor),
                            eta, er, n_corr, m_corr)
