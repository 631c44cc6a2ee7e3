"""Turbocharger: compressor and turbine on one shaft, with two interchangeable algorithms.

Both algorithms have the same causality (thesis 4.5: "the modified algorithm block can directly
replace the basic algorithm block"): they take the static pressures and temperatures of the
control volumes on either side of the compressor and the turbine plus the turbo speed, and give
mass flows, outlet temperatures, shaft torques, chi, PR and ER (:class:`TurboPoint`).

* :class:`BasicTurbo` (thesis 4.4): no kinetic energy; the static values are used as totals.
* :class:`IterativeTurbo` (thesis 4.5, eqs 4.34-4.41): each device port is a duct of known area.
  The manifold values are the *static* state at the ports (as in the thesis), the Mach numbers
  follow from eq. 4.36 and the totals from eqs 4.34-4.35; the maps are read with totals.  The
  unknown of each device is its mass flow ``m``, solved from ``m = m_map(m)`` by a secant
  iteration (bounded to the subsonic range) warm-started from the previous call: its kinetic-
  energy correction ``m/m_basic`` and slope. The outlet total temperature (which sets the outlet
  Mach number) is updated once per secant evaluation, a joint iteration that ends when both have
  converged (about five map evaluations per solve). The fallback is Brent's method on a bracket
  grown from the warm start, with the outlet temperature converged by a bounded fixed point at
  every evaluation.  A choke check comes first: if the map flow exceeds what a port duct can
  pass at Mach 1 (static-state choking, ``m* = p*A*sqrt(gamma/(R*T))`` at the inlet and
  ``p*A*sqrt(gamma/(R*T0))*sqrt((gamma+1)/2)`` at the outlet) :class:`ChokedFlowError` is raised;
  if the solve does not converge :class:`TurboConvergenceError` is raised.  No silent value is
  ever returned.  The solve is :func:`transgen.sim.engine.kernels.solve_device` (compiled with
  numba; its Brent's method is scipy's ``brentq`` step for step).

Shaft dynamics (eqs 4.32-4.33)::

    J * domega/dt = t_turb - t_comp - c(omega),    c(omega) = c1*omega + c2*omega*|omega|

Guard at low turbo speed: torques are ``power / max(omega, omega_floor)`` with ``omega_floor``
= 100 rpm, and the speed is held at the floor while the net torque would decelerate it below
(the saturated integrator of Wahlström & Eriksson).

About ``c(omega)``: the shipped turbine map's efficiency is W&E's ``eta_tm``, which already
contains the bearing losses; the default damping is therefore zero so as not to count friction
twice.  With an aerodynamic turbine map, use e.g. ``c2 = 4.9e-9 N*m*s^2`` (the ECOSM'12 model's
``J*w_fric`` for a 12.7 L engine).
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import ClassVar, Mapping, NamedTuple

import numpy as np

from transgen.errors import SimulationError

from ..core.causality import Causality, ports
from . import kernels as _k
from .compiled import kernels
from .compressor import Compressor, CompressorPoint
from .gas import OMEGA_FLOOR, Gas
from .preprocessor import default_compressor_table, default_turbine_table
from .turbine import Turbine, TurbinePoint

__all__ = [
    "TurboShaft",
    "PortAreas",
    "TurboPoint",
    "BasicTurbo",
    "IterativeTurbo",
    "make_turbo",
    "TurboSolveError",
    "ChokedFlowError",
    "TurboConvergenceError",
    "mach_number",
    "mach_from_total_temperature",
    "total_temperature",
    "total_pressure",
]


class TurboSolveError(SimulationError):
    """The iterative (kinetic-energy) turbocharger algorithm found no valid solution."""


class ChokedFlowError(TurboSolveError):
    """A port duct would have to pass more than its choked (Mach 1) mass flow."""


class TurboConvergenceError(TurboSolveError):
    """The bracketed solve or the inner fixed point did not converge within its bound."""


# --------------------------------------------------------------------------------------------
# Compressible-flow relations (thesis eqs 4.34-4.37)
# --------------------------------------------------------------------------------------------
def total_temperature(T: float, M: float, gas: Gas) -> float:
    """Total temperature [K] from static temperature [K] and Mach number (eq. 4.34)."""
    return _k.total_temperature(T, M, gas.gamma)


def total_pressure(p: float, M: float, gas: Gas) -> float:
    """Total pressure [Pa] from static pressure [Pa] and Mach number (eq. 4.35)."""
    return _k.total_pressure(p, M, gas.gamma, gas.kappa)


def mach_number(m_dot: float, p: float, T: float, area: float, gas: Gas) -> float:
    """Mach number from mass flow [kg/s], static pressure [Pa], static temperature [K] and duct
    area [m^2] (eq. 4.36)."""
    return _k.mach_number(m_dot, p, T, area, gas.R, gas.gamma)


def mach_from_total_temperature(m_dot: float, p: float, T0: float, area: float,
                                gas: Gas) -> float:
    """Mach number from mass flow, static pressure, *total* temperature and area.

    Eq. 4.36 with ``T = T0/(1 + (gamma-1)/2*M^2)`` (eq. 4.34) is a quadratic in ``M^2``, solved
    here in closed form (the numerically stable root).
    """
    return _k.mach_from_total_temperature(m_dot, p, T0, area, gas.R, gas.gamma)


# --------------------------------------------------------------------------------------------
# Parameters and results
# --------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class TurboShaft:
    """Turbo rotor (thesis eqs 4.32-4.33).

    Parameters
    ----------
    inertia : float
        ``J_comp + J_turb + J_shaft`` [kg*m^2]; default W&E's J_t = 2.0e-4.
    c1 : float
        Linear damping coefficient [N*m*s/rad].
    c2 : float
        Quadratic damping coefficient [N*m*s^2/rad^2] (see the module docstring for defaults).
    omega_floor : float
        Lowest speed [rad/s]: torque = power/max(omega, floor), and the speed does not
        decelerate below it.
    """

    inertia: float = 2.0e-4
    c1: float = 0.0
    c2: float = 0.0
    omega_floor: float = OMEGA_FLOOR
    causality: ClassVar[Mapping[str, Causality]] = ports(shaft=Causality.INERTIAL)

    def damping(self, omega: float) -> float:
        """Nonlinear damping torque ``c(omega) = c1*omega + c2*omega*|omega|`` [N*m]."""
        return _k.shaft_damping(self.c1, self.c2, omega)

    def acceleration(self, torque_turbine: float, torque_compressor: float,
                     omega: float) -> float:
        """``domega/dt`` [rad/s^2] from turbine (driving) and compressor (absorbed) torques."""
        return _k.shaft_acceleration(self.inertia, self.c1, self.c2, self.omega_floor, torque_turbine,
                                     torque_compressor, omega)


@dataclass(frozen=True)
class PortAreas:
    """Flow areas [m^2] of the four device ports used by :class:`IterativeTurbo`.

    Defaults are assumed duct sizes of a heavy-duty turbocharger (the thesis gives none):
    compressor inlet and outlet 100 mm (4 in. charge-air piping), turbine inlet 76 mm, turbine
    outlet 100 mm diameter.

    The compressor's area ratio sets the sign of the iterative algorithm's chi shift: the map's
    total pressure ratio is the static one times ``((1 + (g-1)/2 M_out^2) / (1 + (g-1)/2
    M_in^2))^(g/(g-1))``, and ``M_out/M_in = (A_in/A_out) sqrt(T_out/T_in) / PR``. With equal
    areas ``M_out < M_in`` at every pressure ratio above 1, so the iterative algorithm puts the
    compressor at a lower chi (more corrected flow at a given speed), as the thesis found (4.6).
    With an outlet duct smaller than the inlet (e.g. 76 mm) ``M_out > M_in`` at low pressure
    ratios and chi there comes out slightly higher instead.
    """

    compressor_inlet: float = math.pi / 4 * 0.100 ** 2
    compressor_outlet: float = math.pi / 4 * 0.100 ** 2
    turbine_inlet: float = math.pi / 4 * 0.076 ** 2
    turbine_outlet: float = math.pi / 4 * 0.100 ** 2


@dataclass(frozen=True)
class TurboPoint:
    """Result of one turbocharger evaluation.

    ``compressor`` and ``turbine`` hold the device points (mass flows [kg/s], outlet total
    temperatures [K], torques [N*m], chi, PR, ER, efficiencies); ``omega`` [rad/s] is the turbo
    speed, ``omega_dot`` [rad/s^2] its derivative (eq. 4.33), ``damping_torque`` [N*m] is
    ``c(omega)``; ``mach`` are the Mach numbers at (compressor inlet, compressor outlet, turbine
    inlet, turbine outlet), zero for the basic algorithm.
    """

    compressor: CompressorPoint
    turbine: TurbinePoint
    omega: float
    omega_dot: float
    damping_torque: float
    mach: tuple[float, float, float, float] = (0.0, 0.0, 0.0, 0.0)

    def signals(self) -> dict[str, float]:
        """Flat dict of the named quantities (SI units)."""
        c, t = self.compressor, self.turbine
        return {
            "omega_tc": self.omega, "omega_tc_dot": self.omega_dot,
            "m_dot_c": c.m_dot, "m_dot_t": t.m_dot, "T_c_out": c.T_out, "T_t_out": t.T_out,
            "torque_c": c.torque, "torque_t": t.torque, "torque_tc_damping": self.damping_torque,
            "power_c": c.power, "power_t": t.power, "chi": c.chi, "PR_c": c.pressure_ratio,
            "ER_t": t.expansion_ratio, "eta_c": c.eta, "eta_t": t.eta,
            "N_corr_c": c.corrected_speed, "N_corr_t": t.corrected_speed,
            "mach_c_in": self.mach[0], "mach_c_out": self.mach[1],
            "mach_t_in": self.mach[2], "mach_t_out": self.mach[3],
        }


# --------------------------------------------------------------------------------------------
# The two algorithms
# --------------------------------------------------------------------------------------------
class BasicTurbo:
    """Turbocharger without kinetic-energy effects (thesis 4.4).

    Parameters
    ----------
    compressor, turbine : Compressor, Turbine, optional
        Devices; default: the shipped W&E-derived maps.
    shaft : TurboShaft
        Rotor inertia and damping.
    """

    kind: ClassVar[str] = "basic"
    causality: ClassVar[Mapping[str, Causality]] = ports(
        compressor_inlet=Causality.FLOW, compressor_outlet=Causality.FLOW,
        turbine_inlet=Causality.FLOW, turbine_outlet=Causality.FLOW,
        shaft=Causality.RESISTIVE)

    def __init__(self, compressor: Compressor | None = None, turbine: Turbine | None = None,
                 shaft: TurboShaft = TurboShaft()):
        self.compressor = compressor or Compressor(default_compressor_table())
        self.turbine = turbine or Turbine(default_turbine_table())
        self.shaft = shaft

    def _devices(self, p_c_in, T_c_in, p_c_out, p_t_in, T_t_in, p_t_out, omega):
        return (self.compressor.operate(p_c_in, T_c_in, p_c_out, omega),
                self.turbine.operate(p_t_in, T_t_in, p_t_out, omega), (0.0,) * 4)

    def evaluate(self, p_c_in: float, T_c_in: float, p_c_out: float, p_t_in: float,
                 T_t_in: float, p_t_out: float, omega: float) -> TurboPoint:
        """Evaluate the turbocharger.

        Parameters
        ----------
        p_c_in, T_c_in : float
            Static pressure [Pa] and temperature [K] upstream of the compressor (ambient).
        p_c_out : float
            Static pressure [Pa] downstream of the compressor (intake manifold).
        p_t_in, T_t_in : float
            Static pressure [Pa] and temperature [K] upstream of the turbine (exhaust manifold).
        p_t_out : float
            Static pressure [Pa] downstream of the turbine (ambient / exhaust system).
        omega : float
            Turbo speed [rad/s].
        """
        c, t, mach = self._devices(p_c_in, T_c_in, p_c_out, p_t_in, T_t_in, p_t_out, omega)
        return TurboPoint(c, t, omega, self.shaft.acceleration(t.torque, c.torque, omega),
                          self.shaft.damping(omega), mach)

    def reset(self) -> None:
        """Forget any warm-start information (nothing for the basic algorithm)."""

    def kernel_turbo(self) -> np.ndarray:
        """The algorithm and its parameters as the kernels' array (``kernels.TURBO_FIELDS``)."""
        s = self.shaft
        return np.array([0.0, 1.0, 1.0, 1.0, 1.0, 0.0, 0.0, 0.0, 0.0, 0.0,
                         s.inertia, s.c1, s.c2, s.omega_floor], dtype=float)

    def kernel_warm(self) -> np.ndarray:
        """The warm start of the iterative solves (``kernels.solve_device``): compressor, turbine
        rows of (m/m_basic, T02/T_basic, slope); unused by the basic algorithm."""
        return np.ones((2, 3))

    def turbo_point(self, out, omega: float) -> TurboPoint:
        """The :class:`TurboPoint` at turbo speed ``omega`` of a kernel engine evaluation ``out``
        (a list in the order of ``kernels.OUT_FIELDS``)."""
        c, t, m, n = _k.O_C, _k.O_T, _k.O_MACH, _k.O_RANGE
        return TurboPoint(self.compressor.point(*self.compressor.point_fields(out[c:c + n])),
                          self.turbine.point(*self.turbine.point_fields(out[t:t + n])), omega,
                          out[_k.O_OMEGA_DOT], out[_k.O_DAMPING], tuple(out[m:m + 4]))


class _Where(NamedTuple):
    """Operating point named in error messages (formatted only when an error is raised; a named
    tuple, built at every solve: a frozen dataclass cost more to build than it is ever read)."""

    device: str
    p_in: float
    T_in: float
    p_out: float
    omega: float

    def __str__(self) -> str:
        return (f"{self.device} (p_in = {self.p_in:.6g} Pa, T_in = {self.T_in:.6g} K, "
                f"p_out = {self.p_out:.6g} Pa, omega = {self.omega:.6g} rad/s)")


class IterativeTurbo(BasicTurbo):
    """Turbocharger with kinetic-energy effects: Mach numbers and total properties (thesis 4.5).

    Parameters
    ----------
    compressor, turbine, shaft
        As for :class:`BasicTurbo`.
    ports : PortAreas
        Duct areas of the four device ports [m^2].
    xtol : float
        Absolute tolerance [kg/s] of the mass-flow solve.  It is tight so that the result is a
        smooth function of the inputs for the finite-difference Jacobians of stiff solvers.
    maxiter : int
        Iteration bound of the mass-flow solve (the secant fast path takes at most 8 of them;
        Brent's method on a bracket, the fallback, at most ``maxiter``).
    inner_tol : float
        Relative tolerance of the outlet total-temperature fixed point.
    inner_maxiter : int
        Iteration bound of that fixed point.
    """

    kind: ClassVar[str] = "iterative"
    secant_iterations: ClassVar[int] = 8
    """Bound of the secant fast path (at most ``maxiter``); 0: Brent's method on a bracket always."""

    def __init__(self, compressor: Compressor | None = None, turbine: Turbine | None = None,
                 shaft: TurboShaft = TurboShaft(), ports: PortAreas = PortAreas(),
                 xtol: float = 1e-13, maxiter: int = 60, inner_tol: float = 1e-12,
                 inner_maxiter: int = 50):
        super().__init__(compressor, turbine, shaft)
        self.ports = ports
        self.xtol, self.maxiter = xtol, maxiter
        self.inner_tol, self.inner_maxiter = inner_tol, inner_maxiter
        # compressor, turbine -> (m / m_basic, T02 / T_basic, slope) of the last solution: the
        # kinetic-energy correction changes slowly, so scaling the basic answer by it is a close
        # first guess (shared with the engine's compiled evaluation)
        self._warm = np.ones((2, 3))

    def reset(self) -> None:
        """Forget the previous solutions used as warm starts."""
        self._warm[:] = 1.0

    def kernel_turbo(self) -> np.ndarray:
        """The algorithm and its parameters as the kernels' array (``kernels.TURBO_FIELDS``)."""
        a, s = self.ports, self.shaft
        return np.array([1.0, a.compressor_inlet, a.compressor_outlet, a.turbine_inlet, a.turbine_outlet,
                         self.xtol, self.maxiter, self.inner_tol, self.inner_maxiter, self.secant_iterations,
                         s.inertia, s.c1, s.c2, s.omega_floor], dtype=float)

    def kernel_warm(self) -> np.ndarray:
        return self._warm

    def _devices(self, p_c_in, T_c_in, p_c_out, p_t_in, T_t_in, p_t_out, omega):
        a = self.ports
        c, mc = self._solve("compressor", self.compressor, p_c_in, T_c_in, p_c_out, omega,
                            a.compressor_inlet, a.compressor_outlet)
        t, mt = self._solve("turbine", self.turbine, p_t_in, T_t_in, p_t_out, omega,
                            a.turbine_inlet, a.turbine_outlet)
        return c, t, mc + mt

    def _solve(self, name, device, p1, T1, p2, omega, area_in, area_out):
        """Solve ``m = m_map(m)`` for one device between static states (p1, T1) and p2
        (:func:`transgen.sim.engine.kernels.solve_device`): ``(point, (M_in, M_out))``."""
        st = np.empty(_k.N_SOLVE)
        status = kernels().solve_device(device.kernel_device, p1, T1, p2, omega, area_in, area_out,
                                        self._warm[0 if name == "compressor" else 1], self.xtol, self.maxiter,
                                        self.inner_tol, self.inner_maxiter, self.secant_iterations, st)
        r = _k.S_RANGE
        device.table.warn_range(st[r], st[r + 1], st[r + 2], st[r + 3])
        if status != _k.OK:
            raise self.solve_error(status, _Where(name, p1, T1, p2, omega), st[_k.S_INFO0], st[_k.S_INFO1])
        point = device.point(*device.point_fields(st[_k.S_POINT:_k.S_RANGE].tolist()))
        return point, ((st[_k.S_M1], st[_k.S_M2]) if st[_k.S_M] == st[_k.S_M] else (0.0, 0.0))

    def solve_error(self, status: int, where, info0: float, info1: float) -> TurboSolveError:
        """The error of a failed solve (``kernels.ST_*`` status) at the operating point ``where``."""
        if status == _k.ST_CHOKED:
            return ChokedFlowError(f"{where}: map flow {info0:.4g} kg/s exceeds the choked flow {info1:.4g} "
                                   "kg/s of its port ducts")
        if status == _k.ST_BRACKET_CHOKED:
            return ChokedFlowError(f"{where}: no subsonic solution; the ports would choke below the map "
                                   f"flow (bracket up to {info0:.4g} kg/s)")
        if status == _k.ST_SUPERSONIC:
            return ChokedFlowError(f"{where}: solution is not subsonic (M_in = {info0:.3f}, "
                                   f"M_out = {info1:.3f})")
        if status == _k.ST_INNER:
            return TurboConvergenceError(f"{where}: outlet total temperature did not converge in "
                                         f"{self.inner_maxiter} iterations")
        if status == _k.ST_NO_BRACKET:
            return TurboConvergenceError(f"{where}: no bracket of the mass-flow solution found")
        return TurboConvergenceError(f"{where}: mass-flow solve did not converge in {self.maxiter} "
                                     "iterations (convergence error)")



def make_turbo(kind: str = "basic", compressor: Compressor | None = None,
               turbine: Turbine | None = None, shaft: TurboShaft = TurboShaft()) -> BasicTurbo:
    """A turbocharger by algorithm name, ``"basic"`` or ``"iterative"``."""
    classes = {"basic": BasicTurbo, "iterative": IterativeTurbo}
    if kind not in classes:
        raise ValueError(f"unknown turbocharger algorithm {kind!r}; use 'basic' or 'iterative'")
    return classes[kind](compressor, turbine, shaft)
