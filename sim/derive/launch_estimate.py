"""Quasi-static estimates of a vehicle class's launch for ``transgen scenario new``
(:func:`~transgen.sim.derive.launch.derive_launch`): engine torque with the idle governor, the turbine
torque of the engine/converter match, the largest input torque, the road load, and the launch
integrated gear by gear (vehicle speed, and the engine speed with its inertia against the pump
torque). Units SI (rad/s, N*m, m/s, kg, s).
"""
from __future__ import annotations

import math

import numpy as np

from ..model.components import GRAVITY, EngineMap

__all__ = ["MAX_LAUNCH_TIME", "RPM", "phase_end_torque"]

RPM = 2 * math.pi / 60
MAX_LAUNCH_TIME = 300.0
"""Longest launch [s] the estimate allows before it calls the top gear unreachable."""


def _engine_torque(engine: EngineMap, idle: float, throttle: float, w: float) -> float:
    """Engine torque [N*m] at ``w`` with the idle governor of EngineWithConverter."""
    if idle > 0 and w < idle:
        throttle = max(throttle, min(1.0, (idle - w) / (0.1 * idle)))
    return engine(w, throttle)


def _input_torque_max(vehicle, scale: float) -> float:
    """Largest turbine torque [N*m] over the converter's drive range at the class throttle: at each
    speed ratio the engine/converter match (the largest torque both the engine gives and the pump
    absorbs) times the torque ratio."""
    engine, tc = vehicle.engine(scale), vehicle.converter_model()
    ws = np.linspace(0.5 * vehicle.speed_rpm[0], vehicle.speed_rpm[-1], 400) * RPM
    t_eng = np.array([_engine_torque(engine, vehicle.idle_rpm * RPM, vehicle.throttle_signal, w) for w in ws])
    best = 0.0
    for sr in tc.speed_ratio[:-1]:
        pump = np.square(ws / tc.capacity_factor_at(sr))
        best = max(best, tc.torque_ratio_at(sr) * float(np.max(np.minimum(t_eng, pump))))
    return best


def _engine_torque_max(vehicle, scale: float) -> float:
    engine = vehicle.engine(scale)
    return max(engine(s * RPM, vehicle.throttle_signal) for s in vehicle.speed_rpm)


def _road_force(v, speed: float) -> float:
    return v.rolling_resistance * v.mass * GRAVITY * math.tanh(speed / 0.1) + 0.6 * v.cd_a * speed * abs(speed)


def _converter_match(engine, tc, idle, throttle, w_t) -> float:
    """Turbine torque [N*m] at turbine speed ``w_t`` with the engine at its steady match."""
    return _engine_match(engine, tc, idle, throttle, w_t)[1]


def _engine_match(engine, tc, idle, throttle, w_t) -> tuple[float, float]:
    """(engine speed [rad/s], turbine torque [N*m]) of the steady engine/converter match at
    turbine speed ``w_t``."""
    def excess(w_e):
        return _engine_torque(engine, idle, throttle, w_e) - tc.torques(w_e, w_t)[0]

    lo = max(w_t, 1e-3)
    if excess(lo) <= 0:
        return lo, tc.torques(lo, w_t)[1]
    hi = 2 * lo + 100.0
    while excess(hi) > 0 and hi < 1e4:
        hi *= 1.5
    for _ in range(30):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if excess(mid) > 0 else (lo, mid)
    return lo, tc.torques(lo, w_t)[1]


def phase_end_torque(engine, tc, idle: float, throttle: float, J_engine: float, w_e: float, w_t: float,
                     w_t_end: float, duration: float, steps: int = 50) -> float:
    """The turbine torque [N*m] at the end of an inertia phase in which the turbine speed falls (or
    rises) linearly from ``w_t`` to ``w_t_end`` [rad/s] in ``duration`` [s], the engine from
    ``w_e`` [rad/s] pulled by the pump torque against its inertia ``J_engine`` [kg*m^2] (explicit
    Euler, as :func:`_estimate_launch`): the converter's torque rises as the turbine slows and
    falls as the engine follows it."""
    dt = max(float(duration), 0.0) / steps
    for k in range(steps):
        w = w_t + (w_t_end - w_t) * k / steps
        t_pump = tc.torques(w_e, w)[0]
        w_e = max(w_e + (_engine_torque(engine, idle, throttle, w_e) - t_pump) / J_engine * dt, 1e-3)
    return float(tc.torques(w_e, w_t_end)[1])


def _estimate_launch(vehicle, scale, gears, order, final_drive, up_rpm, template, min_interval):
    """Quasi-static launch: vehicle speed integrated gear by gear (the engine speed with the
    engine's inertia against the converter's pump torque, road load, gearbox inertias referred to
    the output; the shifts themselves instantaneous); returns the shift command times [s] and,
    at each, (engine speed [rad/s], turbine speed [rad/s], turbine torque [N*m]), or raises
    ``ValueError`` when the vehicle cannot reach an upshift speed."""
    engine, tc = vehicle.engine(scale), vehicle.converter_model()
    idle, throttle = vehicle.idle_rpm * RPM, vehicle.throttle_signal
    ratio = {g.name: g.ratio for g in gears}
    inertia = {g.name: g.inertia + vehicle.output_inertia for g in gears}
    r = vehicle.wheel_radius
    t, v, dt, last, times, states = 0.0, 0.0, 0.02, -math.inf, [], []
    w_e = idle
    for k, source in enumerate(order[:-1]):
        m = 1.03 * vehicle.mass + inertia[source] * (final_drive / r) ** 2
        line = float(np.interp(throttle, (0.0, 1.0), up_rpm[k])) * RPM
        while True:
            w_out = v * final_drive / r
            w_t = w_out * ratio[source]
            t_pump, torque = tc.torques(w_e, w_t)
            if w_out >= line and t >= last + min_interval:
                break
            a = (torque * ratio[source] * final_drive / r - _road_force(vehicle, v)) / m
            if (a <= 0 or t > MAX_LAUNCH_TIME) and w_out < line:
                raise ValueError(f"the vehicle cannot reach the {source}-{order[k + 1]} upshift speed "
                                 f"({line / RPM:.0f} rpm at the output) within {MAX_LAUNCH_TIME:g} s: "
                                 f"{w_out / RPM:.0f} rpm at {t:.0f} s")
            w_e = max(w_e + (_engine_torque(engine, idle, throttle, w_e) - t_pump) / vehicle.J_engine * dt, 1e-3)
            v, t = v + a * dt, t + dt
        times.append(t)
        states.append((w_e, w_t, torque))
        last = t
    return times, states
