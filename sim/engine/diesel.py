"""Mean-value turbocharged diesel engine: a torque source on the crank link.

Structure (thesis 2.4.6 and chapter 4; equations of Wahlström & Eriksson):

    ambient --compressor(flow)--> intake manifold (control volume) --cylinders(flow)-->
    exhaust manifold (control volume) --turbine(flow)--> ambient;  compressor + turbine on the
    turbo shaft (inertial).

States ``x = (p_im [Pa], p_em [Pa], omega_tc [rad/s])``.  The engine speed is an *input*: the
crank/flywheel inertia is a link of the simulator's mechanism, and this model only gives the
torque applied to it (positive drives the crank).

Equations (W&E with the EGR valve closed and the VGT frozen, i.e. a fixed-geometry turbine):

* manifolds, isothermal filling and emptying (the intercooler is ideal, T_im constant)::

      dp_im/dt = R_a*T_im*(W_c - W_ei)/V_im,     dp_em/dt = R_e*T_em*(W_ei + W_f - W_t)/V_em

* cylinder air flow from the volumetric efficiency (n_e in rpm)::

      eta_vol = c_vol1*sqrt(p_im) + c_vol2*sqrt(n_e) + c_vol3
      W_ei = eta_vol*p_im*n_e*V_d/(120*R_a*T_im),   W_f = u_f*n_e*n_cyl/120

* torque ("mean torque" model): indicated work of an ideal cycle times a factor, minus pumping
  and friction (FMEP polynomial)::

      W_ig = eta_igch*min(1, lambda)*(1 - r_c^(1-gamma_cyl))*u_f*n_cyl*q_HV
      M_e  = (W_ig - V_d*(p_em - p_im) - V_d*1e5*FMEP(n_e))/(4*pi)

* exhaust temperature: W&E's ideal-cycle (Seiliger) model, solved for the residual gas fraction
  and charge temperature by a bounded fixed point, plus the pipe heat loss.

Parameters and their sources (:class:`EngineParams`): every number of the air path, the
cylinder, the torque and the exhaust-temperature models is W&E's published parameter set
(12.74 L, 6 cylinders, r_c = 17) [WE-pkg, via shared/reference/turbo_engine.md 1.1].  What this
project chose to meet an M915-class rating (Cummins NTC-400: 298 kW at 2100 rpm, about
1.4-1.7 kN*m peak torque, boost pressure ratio 2.5-2.9 at rated) is:

* the frozen vane position of the turbine map
  (:data:`~transgen.sim.engine.map_generator.DEFAULT_VGT_POSITION`);
* the full-load fuel curve ``full_load_fuel`` (fuel per cycle and cylinder over engine speed),
  which also contains the max-speed governor run-out from rated speed (2100 rpm) to high idle;
* a minimum firing speed and a standstill regularisation of friction and pumping (the W&E fits
  are valid for 500-2000 rpm).

Fuel command: ``rack(t)`` in [0, 1] scales the full-load fuel at the current speed (a pump rack
or pedal); an optional :class:`SpeedGovernor` raises the rack to hold idle speed.

Robustness: a NaN or infinity in the state or in any computed quantity raises
:class:`NonFiniteError` naming the component, the time and the state; a failed turbocharger
solve or exhaust-temperature fixed point raises its error with the time.

Computation: one evaluation (cylinders, exhaust temperature, turbocharger, manifolds, shaft) is
:func:`transgen.sim.engine.kernels.engine_evaluate`, compiled with numba on first use
(:mod:`transgen.sim.engine.compiled`); this class checks the state, calls it, and turns its
status into the errors and map warnings above.

The full-load curve and the rating of the engine are :mod:`transgen.sim.engine.rating`.
"""
from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from functools import cached_property
from typing import ClassVar, Mapping

import numpy as np

from transgen.errors import SimulationError, StateOutOfDomain

from ..core.causality import Block, Causality, ports
from ..core.interp import interp_like_numpy
from . import kernels as _k
from .compiled import kernels
from .gas import AIR, EXHAUST, RPM, Gas
from .turbocharger import BasicTurbo, TurboShaft, _Where, make_turbo

__all__ = [
    "EngineParams",
    "SpeedGovernor",
    "TurbochargedDiesel",
    "SteadyState",
    "NonFiniteError",
    "SteadyStateError",
    "exhaust_temperature",
]


class NonFiniteError(StateOutOfDomain):
    """A NaN or infinity appeared in the engine model; the message names where."""


class SteadyStateError(SimulationError):
    """No steady operating point was found."""


_MG = 1e-6  # kg per mg


@dataclass(frozen=True)
class EngineParams:
    """Parameters of the mean-value engine (SI units; sources in the module docstring).

    Ambient and air path: ``p_amb`` [Pa], ``T_amb`` [K], ``T_im`` intake-manifold temperature
    [K], ``V_im``/``V_em`` manifold volumes [m^3].  Cylinders: ``V_d`` displacement [m^3],
    ``n_cyl``, ``r_c``, ``c_vol`` volumetric-efficiency coefficients (p in Pa, n in rpm).
    Torque: ``q_HV`` [J/kg], ``AFs`` stoichiometric air/fuel ratio, ``eta_igch``, ``gamma_cyl``,
    ``c_fric`` FMEP polynomial [bar] in (n/1000 rpm).  Exhaust temperature: ``eta_sc``, ``x_cv``,
    ``h_tot`` [W/(m^2 K)], pipe ``d_pipe``, ``l_pipe`` [m], ``n_pipe``, wall ``T_w`` [K].
    Fuel: ``full_load_speed`` [rad/s] and ``full_load_fuel`` [kg per cycle per cylinder].
    ``firing_speed`` [rad/s]: no injection below it (no starter is modelled).
    ``friction_blend_speed`` [rad/s]: friction and pumping torque fade linearly to zero at
    standstill below it, so that a stopped engine does not drive itself backwards.
    """

    # -- W&E published parameters [WE-pkg] (EGR and VGT parameters unused: EGR closed, VGT
    #    frozen inside the turbine map) ------------------------------------------------------
    p_amb: float = 101111.34
    T_amb: float = 298.46
    T_im: float = 300.62
    T_w: float = 298.46
    V_im: float = 0.022
    V_em: float = 0.020
    V_d: float = 0.01274
    n_cyl: int = 6
    r_c: float = 17.0
    c_vol: tuple[float, float, float] = (-2.08166198e-04, -3.44651581e-03, 1.14970210)
    q_HV: float = 4.29e7
    AFs: float = 14.57
    eta_igch: float = 0.6893563
    gamma_cyl: float = 1.35
    c_fric: tuple[float, float, float] = (0.97272276, -0.67688303, 0.59818913)
    eta_sc: float = 1.10152946
    x_cv: float = 2.3e-14
    h_tot: float = 96.27545984
    d_pipe: float = 0.1
    l_pipe: float = 1.0
    n_pipe: int = 2
    air: Gas = AIR
    exhaust: Gas = EXHAUST
    shaft: TurboShaft = field(default_factory=TurboShaft)          # J_t = 2.0e-4 kg*m^2
    # -- chosen in this project for the M915-class rating (see the module docstring) -------
    full_load_speed: tuple[float, ...] = tuple(n * RPM for n in (
        500, 800, 1000, 1200, 1400, 1600, 1800, 2000, 2100, 2300))
    full_load_fuel: tuple[float, ...] = tuple(u * _MG for u in (
        110, 150, 180, 195, 200, 200, 203, 207, 210, 0))
    firing_speed: float = 300.0 * RPM
    friction_blend_speed: float = 100.0 * RPM
    rated_speed: float = 2100.0 * RPM

    def full_load_fuel_at(self, omega_engine: float) -> float:
        """Full-load fuel [kg per cycle per cylinder] at an engine speed [rad/s]."""
        if omega_engine < self.firing_speed:
            return 0.0
        return interp_like_numpy(float(omega_engine), self.full_load_speed, self.full_load_fuel)

    @cached_property
    def kernel_params(self) -> np.ndarray:
        """These parameters as the kernels' array (``kernels.ENGINE_FIELDS``)."""
        return np.array([self.p_amb, self.T_amb, self.T_im, self.T_w, self.V_im, self.V_em, self.V_d,
                         self.n_cyl, self.r_c, *self.c_vol, self.q_HV, self.AFs, self.eta_igch,
                         self.gamma_cyl, *self.c_fric, self.eta_sc, self.x_cv, self.h_tot, self.d_pipe,
                         self.l_pipe, self.n_pipe, self.air.cp, self.air.R, self.exhaust.cp, self.exhaust.R,
                         self.friction_blend_speed], dtype=float)


@dataclass(frozen=True)
class SpeedGovernor:
    """Idle governor: ``rack = max(rack_demand, clamp(gain*(idle - omega)/idle, 0, 1))``.

    ``idle_speed`` [rad/s]; ``gain`` [rack per unit relative speed error].  The max-speed
    governor is the run-out of the full-load fuel curve above rated speed.
    """

    idle_speed: float = 600.0 * RPM
    gain: float = 20.0

    def rack(self, rack_demand: float, omega_engine: float) -> float:
        """Governed rack position [0, 1]."""
        g = self.gain * (self.idle_speed - omega_engine) / self.idle_speed
        return max(rack_demand, min(max(g, 0.0), 1.0))


def exhaust_temperature(p: EngineParams, p_im: float, p_em: float, fuel_air: float,
                        W_eo: float, tol: float = _k.EXHAUST_TOL,
                        maxiter: int = _k.EXHAUST_MAXITER) -> tuple[float, float, float, float]:
    """W&E exhaust-temperature model: ``(T_em, T_e, x_r, T_1)``.

    Parameters
    ----------
    p : EngineParams
    p_im, p_em : float
        Manifold pressures [Pa].
    fuel_air : float
        Fuel/air mass ratio of the charge [-].
    W_eo : float
        Exhaust mass flow [kg/s] (for the pipe heat loss).

    Notes
    -----
    The fixed point on the residual gas fraction ``x_r`` and the charge temperature ``T_1``
    starts from ``x_r = 0``, ``T_1 = T_im`` at every call and is converged tightly, so that the
    result is a smooth function of the inputs (no history, clean finite-difference Jacobians).
    The computation is :func:`transgen.sim.engine.kernels.exhaust_temperature`.

    Raises
    ------
    SimulationError
        If the fixed point does not converge within ``maxiter``.
    """
    T_em, T_e, x_r, T_1, converged = kernels().exhaust_temperature(p.kernel_params, p_im, p_em, fuel_air,
                                                                  W_eo, tol, maxiter)
    if not converged:
        raise _exhaust_error(p_im, p_em, fuel_air, maxiter)
    return T_em, T_e, x_r, T_1


def _exhaust_error(p_im: float, p_em: float, fuel_air: float, maxiter: int) -> SimulationError:
    return SimulationError(f"exhaust temperature: residual-gas fixed point did not converge in {maxiter} "
                           f"iterations (p_im = {p_im:.6g} Pa, p_em = {p_em:.6g} Pa, fuel/air = {fuel_air:.4g})")


def _check_finite(component: str, t: float, x, names: tuple[str, ...], values: tuple[float, ...]) -> None:
    """Raise :class:`NonFiniteError` naming the first of ``values`` (called ``names``) that is
    NaN or infinite."""
    if math.isfinite(sum(values)):  # the every-call case in one test: a NaN or inf makes the sum one
        return
    for k, v in zip(names, values):
        if not math.isfinite(v):
            raise NonFiniteError(
                f"engine: non-finite {k} = {v} in the {component} at t = {t:.6g} s, state "
                f"p_im = {x[0]:.6g} Pa, p_em = {x[1]:.6g} Pa, omega_tc = {x[2]:.6g} rad/s")


def _named_signals(p: EngineParams, turbo: BasicTurbo, quantities: tuple) -> dict[str, float]:
    """The engine's named signals (SI units) from the quantities of one evaluation."""
    p_im, p_em, w_tc, omega_e, u_f, out = quantities
    o = out.tolist() if out.ndim == 1 else list(out)  # numbers, or (:meth:`sample`) rows over times
    torque = o[_k.O_TORQUE]
    sig = {"p_im": p_im, "p_em": p_em, "boost_pressure_ratio": p_im / p.p_amb,
           "turbo_speed": w_tc, "turbo_speed_rpm": w_tc / RPM, "engine_speed": omega_e,
           "fuel_per_cycle": u_f, "lambda": o[_k.O_LAMBDA], "T_em": o[_k.O_T_EM], "T_e": o[_k.O_T_E],
           "residual_gas_fraction": o[_k.O_X_R], "power_engine": torque * omega_e,
           "eta_vol": o[_k.O_ETA_VOL], "m_dot_air_cyl": o[_k.O_W_EI], "m_dot_fuel": o[_k.O_W_F],
           "torque_engine": torque}
    sig.update(turbo.turbo_point(o, w_tc).signals())
    return sig


@dataclass(frozen=True)
class SteadyState:
    """A steady operating point.

    ``engine_speed`` [rad/s], ``fuel`` [kg per cycle per cylinder], ``state`` (p_im [Pa],
    p_em [Pa], omega_tc [rad/s]), ``torque`` [N*m], ``power`` [W], ``boost_pressure_ratio``
    p_im/p_amb [-], ``turbo_speed`` [rad/s], ``signals`` (all named quantities).
    """

    engine_speed: float
    fuel: float
    state: tuple[float, float, float]
    torque: float
    power: float
    boost_pressure_ratio: float
    turbo_speed: float
    signals: Mapping[str, float]


class TurbochargedDiesel:
    """Mean-value turbocharged diesel; the torque source of the crank link.

    Parameters
    ----------
    params : EngineParams
    turbo : {"basic", "iterative"} or BasicTurbo
        Turbocharger algorithm (:class:`~transgen.sim.engine.turbocharger.BasicTurbo` or
        :class:`~transgen.sim.engine.turbocharger.IterativeTurbo`) built with ``params.shaft`` and the
        shipped maps, or an instance (which keeps its own maps and shaft).
    rack : float or callable
        Rack position in [0, 1], constant or a function of time [s].
    governor : SpeedGovernor, optional
        Idle governor acting on the rack.

    Notes
    -----
    The interface the simulator calls (duck-typed): ``state_names``, ``initial_state``,
    ``derivatives``, ``torque``, ``signals``.  Results of the last evaluation are cached, so
    ``torque`` and ``signals`` after ``derivatives`` at the same arguments cost nothing.
    """

    state_names: ClassVar[tuple[str, ...]] = ("p_im", "p_em", "omega_tc")
    causality: ClassVar[Mapping[str, Causality]] = ports(crank=Causality.RESISTIVE)

    def __init__(self, params: EngineParams = EngineParams(), turbo: str | BasicTurbo = "basic",
                 rack: float | Callable[[float], float] = 1.0,
                 governor: SpeedGovernor | None = None):
        self.params = params
        self.turbo = make_turbo(turbo, shaft=params.shaft) if isinstance(turbo, str) else turbo
        self.rack = rack if callable(rack) else (lambda t, r=float(rack): r)
        self.governor = governor
        self._cache_key: tuple | None = None
        self._cache: tuple[np.ndarray, float, tuple] | None = None
        self._solve_state = np.empty(_k.N_SOLVE)  # work array of the iterative solves

    # ---------------------------------------------------------------- inputs
    def fuel(self, t: float, omega_engine: float) -> float:
        """Injected fuel [kg per cycle per cylinder] at time t [s] and engine speed [rad/s]."""
        r = self.rack(t)
        if self.governor is not None:
            r = self.governor.rack(r, omega_engine)
        return self.params.full_load_fuel_at(omega_engine) * min(max(r, 0.0), 1.0)

    # ---------------------------------------------------------------- model
    def _state(self, t: float, x, omega_e: float) -> tuple[float, float, float]:
        """The state ``(p_im, p_em, omega_tc)`` as floats, checked: finite, positive pressures."""
        p_im, p_em, w_tc = float(x[0]), float(x[1]), float(x[2])
        _check_finite("engine state", t, (p_im, p_em, w_tc), ("p_im", "p_em", "omega_tc", "omega_engine"),
                      (p_im, p_em, w_tc, omega_e))
        if p_im <= 0.0 or p_em <= 0.0:
            raise StateOutOfDomain(f"engine: non-physical manifold pressure at t = {t:.6g} s "
                                   f"(p_im = {p_im:.6g} Pa, p_em = {p_em:.6g} Pa)")
        return p_im, p_em, w_tc

    def _cylinders(self, t: float, x, omega_e: float, u_f: float) -> float:
        """The crank torque [N*m] from the state checks and the cylinders' flow and torque model
        alone (no exhaust temperature, no turbocharger): the kernel that :meth:`_evaluate`'s
        compiled evaluation calls, so both give the same torque to the bit."""
        p_im, p_em, _ = self._state(t, x, omega_e)
        eta_vol, _, _, W_ei, W_f, _, _, torque = self._kernels.cylinders(self.params.kernel_params, p_im, p_em,
                                                                         omega_e, u_f)
        _check_finite("cylinders", t, x, ("eta_vol", "m_dot_air_cyl", "m_dot_fuel", "torque_engine"),
                      (eta_vol, W_ei, W_f, torque))
        return torque

    @cached_property
    def _kernels(self):
        return kernels()

    def __getstate__(self) -> dict:
        # the compiled functions are found again after unpickling, not pickled with the engine
        return {k: v for k, v in vars(self).items() if k not in ("_kernels", "_kernel_inputs")}

    @cached_property
    def _kernel_inputs(self) -> tuple:
        """The compiled evaluation and its fixed arguments: engine parameters, compressor and
        turbine, turbocharger algorithm, warm start."""
        turbo = self.turbo
        return (self._kernels.engine_evaluate, self.params.kernel_params, turbo.compressor.kernel_device,
                turbo.turbine.kernel_device, turbo.kernel_turbo(), turbo.kernel_warm())

    def _evaluate(self, t: float, x, omega_e: float, u_f: float):
        """``(dx, torque, quantities)`` of one evaluation (:func:`transgen.sim.engine.kernels.
        engine_evaluate`, compiled): cylinders, exhaust temperature (the algebraic loop hidden
        inside the block, thesis 2.4.3), turbocharger (flow blocks + shaft), manifolds (control
        volumes). The named signals are built from ``quantities`` by :func:`_named_signals` only
        when asked for."""
        p_im, p_em, w_tc = float(x[0]), float(x[1]), float(x[2])
        if not (math.isfinite(p_im + p_em + w_tc + omega_e) and p_im > 0.0 and p_em > 0.0):
            self._state(t, x, omega_e)  # raises, naming what is wrong
        evaluate, P, cdev, tdev, TB, warm = self._kernel_inputs
        out = np.empty(_k.N_OUT)
        status = evaluate(P, cdev, tdev, TB, warm, p_im, p_em, w_tc, omega_e, u_f, out, self._solve_state)
        if out[_k.O_C + _k.O_RANGE] != _k.IN_RANGE or out[_k.O_T + _k.O_RANGE] != _k.IN_RANGE:
            for device, at in ((self.turbo.compressor, _k.O_C), (self.turbo.turbine, _k.O_T)):
                device.table.warn_range(*out[at + _k.O_RANGE:at + _k.O_RANGE + 4].tolist())
        if status != _k.OK:
            self._raise(status, t, x, p_im, p_em, w_tc, out)
        return out[:3], float(out[_k.O_TORQUE]), (p_im, p_em, w_tc, omega_e, u_f, out)

    def _raise(self, status: int, t: float, x, p_im: float, p_em: float, w_tc: float, out) -> None:
        """Raise the error of a failed evaluation (``kernels.ST_*`` status), naming the part of
        the engine, the time and the state."""
        o = out.tolist()
        groups = {_k.ST_CYLINDERS: ("cylinders", ("eta_vol", "m_dot_air_cyl", "m_dot_fuel", "torque_engine"),
                                    (_k.O_ETA_VOL, _k.O_W_EI, _k.O_W_F, _k.O_TORQUE)),
                  _k.ST_EXHAUST_NONFINITE: ("exhaust-temperature model", ("T_em", "T_e", "x_r", "T_1"),
                                            (_k.O_T_EM, _k.O_T_E, _k.O_X_R, _k.O_T_1)),
                  _k.ST_COMPRESSOR_NONFINITE: ("compressor", ("m_dot", "T_out", "torque", "chi"),
                                               (_k.O_C, _k.O_C + 1, _k.O_C + 3, _k.O_C + 6)),
                  _k.ST_TURBINE_NONFINITE: ("turbine", ("m_dot", "T_out", "torque"), (_k.O_T, _k.O_T + 1, _k.O_T + 3)),
                  _k.ST_DERIVATIVES_NONFINITE: ("manifold and shaft derivatives",
                                                ("dp_im/dt", "dp_em/dt", "domega_tc/dt"), (0, 1, 2))}
        if status in groups:
            component, names, at = groups[status]
            _check_finite(component, t, x, names, tuple(o[k] for k in at))
        if status == _k.ST_EXHAUST:
            error = _exhaust_error(p_im, p_em, o[_k.O_FUEL_AIR], _k.EXHAUST_MAXITER)
        elif _k.ST_COMPRESSOR < status < _k.ST_TURBINE + 10:
            p = self.params
            where = (_Where("compressor", p.p_amb, p.T_amb, p_im, w_tc) if status < _k.ST_TURBINE
                     else _Where("turbine", p_em, o[_k.O_T_EM], p.p_amb, w_tc))
            error = self.turbo.solve_error(status % 10, where, o[_k.O_INFO0], o[_k.O_INFO1])
        else:
            error = SimulationError(f"evaluation failed (status {status})")
        raise type(error)(f"engine at t = {t:.6g} s: {error}")

    @staticmethod
    def _key(t: float, x, omega_engine: float) -> tuple:
        """What an evaluation depends on: the cache key of :meth:`_cached`."""
        return t, float(x[0]), float(x[1]), float(x[2]), omega_engine

    def _cached(self, t: float, x, omega_engine: float):
        key = self._key(t, x, omega_engine)
        if key != self._cache_key:
            self._cache = self._evaluate(t, x, omega_engine, self.fuel(t, omega_engine))
            self._cache_key = key
        return self._cache

    # ---------------------------------------------------------------- simulator interface
    def initial_state(self, omega_engine: float) -> np.ndarray:
        """Steady state at the engine speed [rad/s] and the fuel of t = 0 (p_im, p_em, omega_tc).

        Below the firing speed (an engine at rest, no starter modelled) there is no steady
        state; the rest state (ambient manifolds, turbo at its floor speed) is returned.
        """
        if abs(omega_engine) < self.params.firing_speed:
            p_amb = self.params.p_amb
            return np.array([p_amb, p_amb, self.turbo.shaft.omega_floor])
        return np.array(self.steady_state(omega_engine, self.fuel(0.0, omega_engine)).state)

    def derivatives(self, t: float, x: np.ndarray, omega_engine: float) -> np.ndarray:
        """``dx/dt`` = (dp_im/dt [Pa/s], dp_em/dt [Pa/s], domega_tc/dt [rad/s^2])."""
        return self._cached(t, x, omega_engine)[0].copy()

    def torque(self, t: float, x: np.ndarray, omega_engine: float) -> float:
        """Torque [N*m] delivered to the crank link; positive drives it."""
        return self._cached(t, x, omega_engine)[1]

    def torque_and_derivatives(self, t: float, x: np.ndarray, omega_engine: float) -> tuple[float, list]:
        """:meth:`torque` and :meth:`derivatives` (as a list) from one look-up of the evaluation
        cache: what the simulator's right-hand side asks at every call."""
        p_im, p_em, w_tc = x.tolist()
        key = (t, p_im, p_em, w_tc, omega_engine)  # :meth:`_key`
        if key != self._cache_key:
            self._cache = self._evaluate(t, x, omega_engine, self.fuel(t, omega_engine))
            self._cache_key = key
        cache = self._cache
        return cache[1], cache[0].tolist()

    def crank_torque(self, t: float, x: np.ndarray, omega_engine: float) -> float:
        """:meth:`torque` from the cylinders' model alone (the same number): the exhaust
        temperature and the turbocharger, most of an evaluation's cost, only set the state
        derivatives. What a torque event of the simulator needs at every step; the state checks
        are the same, the turbocharger's own checks come with the next full evaluation."""
        if self._key(t, x, omega_engine) == self._cache_key:
            return self._cache[1]
        return self._cylinders(t, x, omega_engine, self.fuel(t, omega_engine))

    def signals(self, t: float, x: np.ndarray, omega_engine: float) -> dict[str, float]:
        """Named quantities (SI units): turbo speed, chi, mass flows, PR, ER, temperatures,
        boost, torque, lambda, ..."""
        return _named_signals(self.params, self.turbo, self._cached(t, x, omega_engine)[2])

    def sample(self, ts: np.ndarray, X: np.ndarray, omegas: np.ndarray) -> dict[str, np.ndarray]:
        """:meth:`signals` at the times ``ts`` [s] (states: the columns of ``X``; engine speeds
        ``omegas`` [rad/s]) as arrays: the same evaluations in the same order (the iterative
        turbocharger's warm start follows them), the names computed once over all times."""
        if not len(ts):
            return {}
        rows = [self._cached(t, X[:, k], omega)[2] for k, (t, omega) in enumerate(zip(ts, omegas.tolist()))]
        columns = [np.array(c, dtype=float) for c in zip(*(r[:5] for r in rows))]
        return _named_signals(self.params, self.turbo, (*columns, np.array([r[5] for r in rows]).T))

    # ---------------------------------------------------------------- steady state
    def steady_state(self, engine_speed: float, fuel: float | None = None,
                     guess: Sequence[float] | None = None) -> SteadyState:
        """Steady operating point at an engine speed [rad/s] and fuel [kg per cycle per
        cylinder] (default: full load).

        A pseudo-transient (stiff integration) brings a default or given guess near the
        equilibrium, and a Newton-type solve (``scipy.optimize.root``) polishes it.

        Raises
        ------
        SteadyStateError
            If no equilibrium is found.
        """
        u_f = self.params.full_load_fuel_at(engine_speed) if fuel is None else fuel
        scale = np.array([1e5, 1e5, 1e4])

        def f(z):
            return self._evaluate(0.0, z * scale, engine_speed, u_f)[0] / scale

        def fz(_t, z):
            return f(z)

        p_amb = self.params.p_amb
        z0 = np.asarray(guess if guess is not None else (p_amb * 1.1, p_amb * 1.2, 6000.0))
        from scipy.integrate import solve_ivp  # here, not at import: reading a scenario needs no scipy
        from scipy.optimize import root

        z0 = z0 / scale
        sol = None
        ok = lambda s: s is not None and np.max(np.abs(f(s.x))) < 1e-6  # noqa: E731
        # The search passes through points that are not operating points: keep it from using
        # up the maps' single out-of-data warning (the final point is checked below).
        tables = (self.turbo.compressor.table, self.turbo.turbine.table)
        warned = [tab.warned for tab in tables]
        try:
            for tab in tables:
                tab.warned = True
            if guess is not None:
                sol = root(f, z0, method="hybr", options={"xtol": 1e-12})
            if not ok(sol):
                ivp = solve_ivp(fz, (0.0, 30.0), z0, method="BDF", rtol=1e-8, atol=1e-8)
                sol = root(f, ivp.y[:, -1], method="hybr", options={"xtol": 1e-12})
        finally:
            for tab, w in zip(tables, warned):
                tab.warned = w
        if not ok(sol):
            raise SteadyStateError(f"engine: no steady state at {engine_speed / RPM:.0f} rpm and "
                                   f"{u_f / _MG:.1f} mg/cycle ({sol.message}; scaled residual "
                                   f"{f(sol.x)})")
        x = sol.x * scale
        _, torque, quantities = self._evaluate(0.0, x, engine_speed, u_f)
        sig = _named_signals(self.params, self.turbo, quantities)
        return SteadyState(engine_speed, u_f, tuple(map(float, x)), torque,
                           torque * engine_speed, sig["boost_pressure_ratio"], float(x[2]), sig)

    # ---------------------------------------------------------------- structure
    def causal_structure(self) -> tuple[list[Block], list[tuple[str, str]]]:
        """Blocks and joints of the engine air path, for
        :func:`~transgen.sim.core.causality.check_connections`."""
        cv = ports(port_a=Causality.CONTROL_VOLUME, port_b=Causality.CONTROL_VOLUME)
        blocks = [Block("ambient_in", ports(port=Causality.CONTROL_VOLUME)),
                  Block.of("compressor", self.turbo.compressor),
                  Block("intake_manifold", cv),
                  Block("cylinders", ports(intake=Causality.FLOW, exhaust=Causality.FLOW,
                                           crank=Causality.RESISTIVE)),
                  Block("exhaust_manifold", cv),
                  Block.of("turbine", self.turbo.turbine),
                  Block("ambient_out", ports(port=Causality.CONTROL_VOLUME)),
                  Block.of("turbo_shaft", self.turbo.shaft),
                  Block("crank", ports(shaft=Causality.INERTIAL))]
        joints = [("ambient_in", "compressor.inlet"),
                  ("compressor.outlet", "intake_manifold.port_a"),
                  ("intake_manifold.port_b", "cylinders.intake"),
                  ("cylinders.exhaust", "exhaust_manifold.port_a"),
                  ("exhaust_manifold.port_b", "turbine.inlet"), ("turbine.outlet", "ambient_out"),
                  ("compressor.shaft", "turbo_shaft"), ("turbine.shaft", "turbo_shaft"),
                  ("cylinders.crank", "crank")]
        return blocks, joints
