"""What the compressor and the turbine share: a quasi-steady turbomachine read from its causal map.

Both devices (thesis sections 4.3-4.4) take the inlet total pressure [Pa] and temperature [K],
the outlet total pressure [Pa] and the rotor speed [rad/s]; they look up their causal table
(:mod:`transgen.sim.engine.preprocessor`) at the corrected speed and the pressure ratio across
them, turn the corrected flow into the actual mass flow, and get the outlet temperature from the
isentropic relation and the efficiency (:mod:`transgen.sim.engine.gas`).  The one difference is
the direction of the work: a compressor raises the pressure (``PR = p02/p01``, eq. 4.7) and
absorbs shaft power, a turbine expands the gas (``ER = p01/p02``, eq. 4.16) and delivers it.
"""
from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property
from typing import ClassVar, Mapping

from ..core.causality import Causality, ports
from . import kernels as _k
from .compiled import kernels
from .gas import OMEGA_FLOOR, Gas

__all__ = ["MachinePoint", "Turbomachine"]


@dataclass(frozen=True)
class MachinePoint:
    """The attributes every quasi-steady operating point has.

    Attributes
    ----------
    m_dot : float
        Mass flow [kg/s], inlet to outlet.
    T_out : float
        Outlet total temperature [K].
    power : float
        Shaft power [W], ``m_dot*cp*|T_out - T_in|``: absorbed by a compressor, delivered by a
        turbine.
    torque : float
        Shaft torque [N*m], ``power/max(omega, omega_floor)``: positive opposes rotation for a
        compressor and drives the rotor for a turbine.
    eta : float
        Efficiency [-].

    The subclasses add the pressure or expansion ratio and, last, ``corrected_speed`` [rad/s]
    and ``corrected_flow`` [kg/s], the table's coordinates.
    """

    m_dot: float
    T_out: float
    power: float
    torque: float
    eta: float


@dataclass(frozen=True)
class Turbomachine:
    """A compressor or turbine described by its causal table.

    Parameters
    ----------
    table : CompressorTable or TurbineTable
        ``m_corr(N_corr, ...)``, ``eta(N_corr, ...)`` from the pre-processor.
    gas : Gas
        Working gas.
    omega_floor : float
        Speed floor [rad/s] for ``torque = power/speed``
        (see :data:`~transgen.sim.engine.gas.OMEGA_FLOOR`).
    """

    table: object
    gas: Gas
    omega_floor: float = OMEGA_FLOOR
    causality: ClassVar[Mapping[str, Causality]] = ports(
        inlet=Causality.FLOW, outlet=Causality.FLOW, shaft=Causality.RESISTIVE)
    compresses: ClassVar[bool]
    """True for a compressor (works on the gas), False for a turbine (work from the gas)."""
    point: ClassVar[type]
    """The operating-point class; built from the :class:`MachinePoint` attributes, the ratio,
    what the table's look-up gives beyond flow and efficiency, and the corrected quantities."""

    def operate(self, p_in: float, T_in: float, p_out: float, omega: float):
        """Operating point at inlet total pressure [Pa] and temperature [K], outlet total
        pressure [Pa] and rotor speed [rad/s] (thesis Figures 4.8 and 4.12)."""
        return self.point(*self.flow(p_in, T_in, p_out, omega))

    def flow(self, p_in: float, T_in: float, p_out: float, omega: float) -> tuple:
        """The fields of :meth:`operate`'s point as a tuple, ``m_dot`` and ``T_out`` first (an
        iteration over the operating point reads those two; building the frozen point at every
        step cost more than the look-up). The computation is
        :func:`transgen.sim.engine.kernels.machine_flow`."""
        f = kernels().device_flow(self.kernel_device, p_in, T_in, p_out, omega)
        self.table.warn_range(f[9], f[7], f[5], f[6])
        return self.point_fields(f)

    def point_fields(self, flow) -> tuple:
        """The fields of :attr:`point` from a kernel flow (``kernels.FLOW_FIELDS``: the turbine's
        point has no chi)."""
        if self.compresses:
            return tuple(flow[:9])
        return (*flow[:6], flow[7], flow[8])

    @cached_property
    def kernel_device(self) -> np.ndarray:
        """This device as the kernels' packed array (:func:`transgen.sim.engine.kernels.pack_device`;
        a copy of the table, made at the first evaluation)."""
        tab, gas = self.table, self.gas
        if self.compresses:
            grid, stall, span = tab.chi, tab.pr_stall, tab.pr_span
        else:
            grid, stall, span = tab.expansion_ratio, None, None
        return _k.pack_device(self.compresses, tab.speed, grid, tab.mass_flow, tab.efficiency, stall, span,
                              tab.T_ref, tab.p_ref, gas.kappa, gas.cp, gas.gamma, gas.R, self.omega_floor)
