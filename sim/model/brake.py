"""The vehicle's service brakes: a driveline whose vehicle side a brake torque slows.

:class:`BrakedDriveline` is the :class:`~.components.Driveline` (driveshaft spring-damper, the
vehicle and its road load) with a wheel brake torque ``brake(t)`` [N*m, the sum over the wheels,
>= 0] on the vehicle side: referred to the driveshaft it is ``brake / final_drive``; it opposes
the motion and fades in below :data:`BRAKE_FADE_SPEED` (``tanh(v / 0.02 m/s)``, as the rolling
resistance does below 0.1 m/s), so that a braked vehicle can stand without the torque reversing
at zero speed (a creeping converter moves it at about a centimetre per second where ``brake``
exceeds the creep torque well). The brakes act at the wheels, after the driveshaft: the shaft torque ``T_out`` the
gearbox sees is the vehicle's, not the brakes'.

Energy: the brake power ``brake_torque * omega_v`` leaves the system with the road load (the
load power): the energy balance ``E_in = E_dissipated + E_load + E_stored`` keeps holding; the
signals ``brake_torque`` (wheels, N*m, the signal's value before the fade-in) and ``P_brake``
[W] give it apart. The drive cycle's driver (:mod:`.driver`) commands ``brake``; a scenario sets
it as ``[driveline] brake = SIGNAL``.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .components import Driveline, _tanh, driveline_rates
from ..core.jit import compilable
from ..core.signals import Constant, Signal

__all__ = ["BrakedDriveline", "braked_driveline_rates", "brake_fade", "BRAKE_FADE_SPEED"]

BRAKE_FADE_SPEED = 0.02
"""Vehicle speed [m/s] below which the brake torque fades to zero."""


@compilable
def brake_fade(v: float) -> float:
    """The fraction [-1, 1] of the brake torque that acts at vehicle speed ``v`` [m/s] (sign: opposes
    the motion); ``v`` a number or, in Python, an array."""
    return _tanh(v / BRAKE_FADE_SPEED)


@compilable
def braked_driveline_rates(theta: float, omega_v: float, w_out: float, brake: float, stiffness: float, damping: float,
                           J_v: float, mass: float, rolling: float, grade: float, air_density: float, cd_a: float,
                           wheel_radius: float, final_drive: float) -> tuple[float, float, float, float, float]:
    """``(shaft torque, d theta/dt, d omega_v/dt, damper loss, road and brake power)`` of
    :class:`BrakedDriveline` with the wheel brake torque ``brake`` [N*m] (negative values count as 0)."""
    shaft, d_theta, d_omega, loss, p_load = driveline_rates(theta, omega_v, w_out, stiffness, damping, J_v, mass,
                                                            rolling, grade, air_density, cd_a, wheel_radius,
                                                            final_drive)
    torque = max(brake, 0.0) / final_drive * brake_fade(omega_v * wheel_radius / final_drive)
    return shaft, d_theta, d_omega - torque / J_v, loss, p_load + torque * omega_v


@dataclass
class BrakedDriveline(Driveline):
    """:class:`~.components.Driveline` with a wheel brake torque ``brake`` [N*m] (module docstring)."""

    brake: Signal = Constant(0.0)

    def _brake_torque(self, t: float, omega_v):
        """The brake torque referred to the driveshaft [N*m] at ``t`` (a number) and ``omega_v``."""
        level = max(float(self.brake.value(t)), 0.0)
        return level / self.final_drive * brake_fade(self._speed(omega_v))

    def evaluate(self, t, x, w):
        shaft, d_theta, d_omega, loss, p_load = braked_driveline_rates(
            float(x[0]), float(x[1]), float(w[self.output]), float(self.brake.value(t)), self.stiffness, self.damping,
            self.J_v, *self._road())
        return {"T_out": shaft}, [d_theta, d_omega], 0.0, loss, p_load

    def breakpoints(self, t0=-math.inf, t1=math.inf):
        return self.brake.breakpoints(t0, t1)

    def kernel_form(self):
        kind, ints, numbers, _, inputs = Driveline.kernel_form(self)
        return "braked_driveline", ints, numbers, (self.brake,), inputs

    def sample(self, ts, X, W):
        torques, signals, energy = Driveline.sample(self, ts, X, W)
        level = np.maximum(self.brake.sample(np.asarray(ts, dtype=float)), 0.0)
        referred = level / self.final_drive * brake_fade(self._speed(X[1]))
        signals["brake_torque"] = level
        signals["P_brake"] = referred * X[1]
        if self.mass > 0:
            signals["vehicle_accel"] = signals["vehicle_accel"] - self._speed(referred / self.J_v)
        return torques, signals, energy

    def sample_rates(self, ts, X, W, A):
        rates = Driveline.sample_rates(self, ts, X, W, A)
        if not rates:
            return rates
        base = rates["vehicle_jerk"]
        # the brake torque's own rate of change is left out (the driver's commands are ramps of
        # 0.1 s or longer): its part of the jerk is the fade-in's slope times the deceleration
        level = np.maximum(self.brake.sample(np.asarray(ts, dtype=float)), 0.0)
        theta, omega_v = X
        g = self.wheel_radius / self.final_drive
        referred = level / self.final_drive * brake_fade(omega_v * g)
        alpha_v = (self.stiffness * theta + self.damping * (W[self.output] - omega_v) - self.road_torque(omega_v)
                   - referred) / self.J_v
        slope = level / self.final_drive * g / BRAKE_FADE_SPEED * (1.0 - np.tanh(omega_v * g / BRAKE_FADE_SPEED) ** 2)
        # the base jerk used the unbraked alpha_v: correct both its terms to the braked one
        d_alpha = -referred / self.J_v
        corr = (-self.damping * d_alpha - self.road_slope(omega_v) * d_alpha - slope * alpha_v) / self.J_v
        return {"vehicle_jerk": base + self._speed(corr)}

    def signals(self, t, x, w):
        out = Driveline.signals(self, t, x, w)
        referred = self._brake_torque(t, x[1])
        out["brake_torque"] = max(float(self.brake.value(t)), 0.0)
        out["P_brake"] = referred * x[1]
        if self.mass > 0:
            out["vehicle_accel"] -= self._speed(referred / self.J_v)
        return out
