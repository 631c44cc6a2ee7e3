"""Gas and thermodynamic helpers of the turbocharger (thesis sections 4.3-4.4).

The ideal gases of the air and exhaust paths (:data:`AIR`, :data:`EXHAUST`), the corrected
quantities of the maps (thesis eqs 4.21-4.22 and 4.28-4.29: ``N_corr = N*sqrt(T_std/T01)``,
``m_corr = m*(p_std/p01)*sqrt(T01/T_std)``), the isentropic outlet temperatures of compression
(eq. 4.7) and expansion (eq. 4.16), and shaft torque from power with a speed floor.  Shared by
the map pre-processor, the compressor, the turbine, the turbocharger and the engine.  Every speed
is in rad/s (:data:`RPM` converts), temperatures in K, pressures in Pa.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property

from . import kernels as _k

__all__ = [
    "RPM",
    "OMEGA_FLOOR",
    "Gas",
    "AIR",
    "EXHAUST",
    "corrected_speed",
    "corrected_flow",
    "actual_flow",
    "compression_outlet_temperature",
    "expansion_outlet_temperature",
    "torque_from_power",
]

RPM = _k.RPM
"""One revolution per minute in rad/s (pi/30)."""

OMEGA_FLOOR = 100.0 * RPM
"""Lowest turbo speed [rad/s] used to turn power into torque (``torque = P/max(omega, floor)``).

Wahlström & Eriksson clamp their turbo-speed integrator at 100 rpm for the same reason: the
turbine still delivers power at zero speed, so ``P/omega`` would be unbounded.
"""


@dataclass(frozen=True)
class Gas:
    """Ideal gas with constant specific heats.

    Parameters
    ----------
    cp : float
        Specific heat at constant pressure [J/(kg*K)].
    R : float
        Specific gas constant [J/(kg*K)].
    """

    cp: float
    R: float

    @cached_property  # read in every turbocharger evaluation
    def gamma(self) -> float:
        """Ratio of specific heats cp/cv [-]."""
        return self.cp / (self.cp - self.R)

    @cached_property
    def kappa(self) -> float:
        """Isentropic exponent (gamma-1)/gamma = R/cp [-] used in eqs 4.4 and 4.13."""
        return self.R / self.cp


AIR = Gas(cp=1011.0, R=287.0)
"""Air, c_pa and R_a of Wahlström & Eriksson (gamma = 1.3964)."""
EXHAUST = Gas(cp=1332.0, R=286.0)
"""Exhaust gas, c_pe and R_e of Wahlström & Eriksson (gamma = 1.2734)."""


def corrected_speed(omega: float, T0: float, T_ref: float) -> float:
    """Corrected speed ``N*sqrt(T_std/T01)`` (eqs 4.21, 4.28); same unit as ``omega``."""
    return _k.corrected_speed(omega, T0, T_ref)


def corrected_flow(m_dot: float, p0: float, T0: float, p_ref: float, T_ref: float) -> float:
    """Corrected mass flow ``m*(p_std/p01)*sqrt(T01/T_std)`` [kg/s] (eqs 4.22, 4.29)."""
    return m_dot * (p_ref / p0) * math.sqrt(T0 / T_ref)


def actual_flow(m_corr: float, p0: float, T0: float, p_ref: float, T_ref: float) -> float:
    """Mass flow [kg/s] from a corrected flow: the inverse of :func:`corrected_flow`."""
    return _k.actual_flow(m_corr, p0, T0, p_ref, T_ref)


def compression_outlet_temperature(T_in: float, PR: float, eta: float, gas: Gas) -> float:
    """Compressor outlet temperature [K], thesis eq. 4.7: ``T1*(1 + (PR^kappa - 1)/eta)``."""
    return _k.compression_outlet_temperature(T_in, PR, eta, gas.kappa)


def expansion_outlet_temperature(T_in: float, ER: float, eta: float, gas: Gas) -> float:
    """Turbine outlet temperature [K], thesis eq. 4.16 with ``P2/P1 = 1/ER``.

    ``T2 = T1*(1 + eta*((1/ER)^kappa - 1)) = T1*(1 - eta*(1 - ER^-kappa))``.
    """
    return _k.expansion_outlet_temperature(T_in, ER, eta, gas.kappa)


def torque_from_power(power: float, omega: float, omega_floor: float = OMEGA_FLOOR) -> float:
    """Shaft torque [N*m] from shaft power [W] (eqs 4.8-4.9, 4.17-4.18).

    ``torque = power / max(omega, omega_floor)``: the floor keeps the torque finite at a standing
    rotor (the turbine delivers power at zero speed); see :data:`OMEGA_FLOOR`.
    """
    return _k.torque_from_power(power, omega, omega_floor)
