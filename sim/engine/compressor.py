"""Quasi-steady centrifugal compressor from its causal map (thesis sections 4.3.1 and 4.4.1).

Inputs are the inlet total pressure and temperature, the outlet total pressure and the rotor
speed; outputs are the mass flow, the outlet total temperature and the shaft torque (thesis
Figure 4.5).  With the basic algorithm (no kinetic energy) the manifold static values are used
as total values; :class:`transgen.sim.turbocharger.IterativeTurbo` supplies Mach-corrected totals.

Sign conventions: the mass flow is positive from inlet to outlet; ``power`` and ``torque`` are
what the compressor *absorbs* from the shaft (positive opposes rotation).  Below PR = 1 the map
gives the stall-line flow (see :mod:`transgen.sim.maps`) with no temperature rise and no power.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar, Mapping

from ..causality import Causality, ports
from .map_file import (AIR, OMEGA_FLOOR, CompressorTable, Gas, actual_flow,
                   compression_outlet_temperature, corrected_speed, torque_from_power)

__all__ = ["Compressor", "CompressorPoint"]


@dataclass(frozen=True)
class CompressorPoint:
    """One quasi-steady compressor operating point.

    Attributes
    ----------
    m_dot : float
        Mass flow [kg/s], inlet to outlet.
    T_out : float
        Outlet total temperature [K] (eq. 4.7).
    power : float
        Shaft power absorbed [W], ``m_dot*cp*(T_out - T_in)``.
    torque : float
        Shaft torque absorbed [N*m] (eq. 4.9); positive opposes rotation.
    eta : float
        Isentropic efficiency [-].
    pressure_ratio : float
        Total pressure ratio p02/p01 [-].
    chi : float
        Normalised pressure coordinate (eq. 4.25), unclamped.
    corrected_speed : float
        [rad/s] (eq. 4.21).
    corrected_flow : float
        [kg/s] (eq. 4.22).
    """

    m_dot: float
    T_out: float
    power: float
    torque: float
    eta: float
    pressure_ratio: float
    chi: float
    corrected_speed: float
    corrected_flow: float


@dataclass(frozen=True)
class Compressor:
    """A compressor described by its causal table.

    Parameters
    ----------
    table : CompressorTable
        ``m_corr(N_corr, chi)``, ``eta(N_corr, chi)`` from
        :func:`~transgen.sim.maps.preprocess_compressor`.
    gas : Gas
        Working gas (air).
    omega_floor : float
        Speed floor [rad/s] for ``torque = power/speed``
        (see :data:`~transgen.sim.maps.OMEGA_FLOOR`).
    """

    table: CompressorTable
    gas: Gas = AIR
    omega_floor: float = OMEGA_FLOOR
    causality: ClassVar[Mapping[str, Causality]] = ports(
        inlet=Causality.FLOW, outlet=Causality.FLOW, shaft=Causality.RESISTIVE)

    def operate(self, p_in: float, T_in: float, p_out: float, omega: float) -> CompressorPoint:
        """Operating point at inlet total pressure [Pa] and temperature [K], outlet total
        pressure [Pa] and rotor speed [rad/s] (thesis Figure 4.8)."""
        tab = self.table
        n_corr = corrected_speed(omega, T_in, tab.T_ref)
        pr = p_out / p_in
        m_corr, eta, chi = tab.lookup(n_corr, pr)
        m_dot = actual_flow(m_corr, p_in, T_in, tab.p_ref, tab.T_ref)
        T_out = compression_outlet_temperature(T_in, max(pr, 1.0), eta, self.gas)
        power = m_dot * self.gas.cp * (T_out - T_in)
        return CompressorPoint(m_dot, T_out, power, torque_from_power(power, omega,
                                                                      self.omega_floor),
                               eta, pr, chi, n_corr, m_corr)
