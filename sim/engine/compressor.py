"""Quasi-steady centrifugal compressor from its causal map (thesis sections 4.3.1 and 4.4.1).

Inputs are the inlet total pressure and temperature, the outlet total pressure and the rotor
speed; outputs are the mass flow, the outlet total temperature and the shaft torque (thesis
Figure 4.5); the computation is :meth:`Turbomachine.operate
<transgen.sim.engine.turbomachine.Turbomachine.operate>`.  With the basic algorithm (no kinetic
energy) the manifold static values are used as total values;
:class:`transgen.sim.engine.turbocharger.IterativeTurbo` supplies Mach-corrected totals.

Sign conventions: the mass flow is positive from inlet to outlet; ``power`` and ``torque`` are
what the compressor *absorbs* from the shaft (positive opposes rotation).  Below PR = 1 the map
gives the stall-line flow (see :mod:`transgen.sim.engine.preprocessor`) with no temperature rise
and no power.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

from .gas import AIR, Gas
from .preprocessor import CompressorTable
from .turbomachine import MachinePoint, Turbomachine

__all__ = ["Compressor", "CompressorPoint"]


@dataclass(frozen=True)
class CompressorPoint(MachinePoint):
    """One quasi-steady compressor operating point: the :class:`MachinePoint` attributes (outlet
    temperature by eq. 4.7, power ``m_dot*cp*(T_out - T_in)`` absorbed, torque by eq. 4.9,
    isentropic efficiency), the total pressure ratio ``pressure_ratio`` p02/p01 [-], the
    unclamped normalised pressure coordinate ``chi`` [-] (eq. 4.25), and the corrected speed
    [rad/s] and flow [kg/s] of eqs 4.21-4.22."""

    pressure_ratio: float
    chi: float
    corrected_speed: float
    corrected_flow: float


@dataclass(frozen=True)
class Compressor(Turbomachine):
    """A compressor described by its causal table ``m_corr(N_corr, chi)``, ``eta(N_corr, chi)``
    (a :class:`~transgen.sim.engine.preprocessor.CompressorTable` from
    :func:`~transgen.sim.engine.preprocessor.preprocess_compressor`); working gas air by
    default; parameters as for :class:`~transgen.sim.engine.turbomachine.Turbomachine`."""

    table: CompressorTable
    gas: Gas = AIR
    compresses: ClassVar[bool] = True
    point: ClassVar[type] = CompressorPoint
