"""The driver of a drive cycle: a speed-tracking controller on throttle and wheel brakes.

A sampled-data controller (a controller of :class:`~.integration.Powertrain`, as the automatic
schedule is): every ``dt`` (0.2 s by default: a driver's reaction time; 0.1 s tracks the WLTC as
well, in twice the run time) it reads the vehicle speed at the gearbox output
(``v = w_out * r / i_final``, the speed a TCU measures) and commands a wheel force

    ``F = F_ff + kp * e + ki * integral(e dt)``,   ``e = v_ref(t) - v``,
    ``F_ff = m_eff * a_ref(t + preview) + F_road(v_ref(t + preview))``

with the trace's speed ``v_ref`` and acceleration ``a_ref`` (the driver sees the trace ahead,
``preview`` s) and the road load ``F_road`` of the driveline (rolling, air, grade).
``m_eff = 1.03 m + J_out i^2 / r^2`` (the vehicle, 3 % for the wheels' and the gearbox's
inertia, and the driveline's output inertia ``J_out``). A force ``F >= F_0`` is the throttle
that gives it through the current gear (the engine torque ``F r / (i_gear i_final)`` at the turbine speed, from the engine
map inverted over throttle, the converter taken as a coupling: the PI part takes up the rest);
below the force the engine gives at zero throttle (``F_0``: the converter's creep torque at idle
through the gear while the turbine is below idle speed, else 0) it is the brake torque
``(F_0 - F) r`` at the wheels (at most ``brake_max``), throttle 0. Where
the trace stands (``v_ref = 0`` now and ``preview`` ahead) the driver holds the brake at
``hold_brake`` and resets the integral. The integral stops while the command is saturated
(anti-windup). Defaults: ``kp = m_eff / tau`` (``tau = 1 s``), ``ki = kp / 4 s``, ``preview``
0.5 s, ``brake_max`` 0.8 and ``hold_brake`` 0.4 of the vehicle's weight times the wheel radius.

The commands are ramps from the previous value to the new one over ``dt`` (the pedal moves
continuously; a first-order hold), read by the engine's throttle, the schedule's throttle and the
driveline's brake as :class:`DriverCommand` signals. Units SI. A scenario's ``[driver]`` table
(:data:`DRIVER_KEYS`) sets it up (:func:`attach_driver`).
"""
from __future__ import annotations

import bisect
import copy
import math
from dataclasses import dataclass, field

import numpy as np

from ..core.signals import Signal

__all__ = ["Driver", "DriverCommand", "attach_driver", "DRIVER_KEYS", "DRIVER_DT"]

DRIVER_KEYS = frozenset({"trace", "dt", "kp", "ki", "preview", "brake_max", "hold_brake", "mass"})
DRIVER_DT = 0.2
"""The driver's sampling time [s]."""


class DriverCommand(Signal):
    """A command of a :class:`Driver` (``"throttle"`` [0-1] or ``"brake"`` [N*m]) as a signal:
    piecewise linear through the driver's history."""

    piecewise_linear = True

    def __init__(self, driver: "Driver", which: str):
        self.driver, self.which = driver, which

    def _points(self):
        d = self.driver
        return d.times, (d.throttles if self.which == "throttle" else d.brakes)

    def value(self, t: float) -> float:
        times, values = self._points()
        if len(times) > 1 and t >= times[-2]:  # the current ramp (the simulator asks for it most)
            t0, t1 = times[-2], times[-1]
            if t >= t1:
                return values[-1]
            return values[-2] + (values[-1] - values[-2]) * (t - t0) / (t1 - t0) if t1 > t0 else values[-1]
        k = bisect.bisect_right(times, t) - 1
        if k < 0:
            return values[0]
        if k + 1 >= len(times):
            return values[-1]
        t0, t1 = times[k], times[k + 1]
        return values[k] + (values[k + 1] - values[k]) * (t - t0) / (t1 - t0) if t1 > t0 else values[k + 1]

    def breakpoints(self, t0: float = -math.inf, t1: float = math.inf) -> tuple[float, ...]:
        times, _ = self._points()
        return tuple(times[bisect.bisect_left(times, t0):bisect.bisect_right(times, t1)])

    def upper_bound(self, t0: float, t1: float) -> float:
        return max([self.value(t0), self.value(t1)] + list(self._points()[1][-2:]))


@dataclass
class Driver:
    """The driver (module docstring). ``trace``: a :class:`~.cycles.SpeedTrace`; ``output`` /
    ``input``: link indices; ``engine``: the :class:`~.components.EngineMap`; ``road_force(v)``:
    the road load [N] at ``v`` [m/s]; ``schedule``: the :class:`~.schedule.AutoShift` (its gear),
    ``ratios``: gear -> ratio."""

    trace: object
    output: int
    input: int
    engine: object
    idle: float
    final_drive: float
    wheel_radius: float
    mass: float
    road_force: object
    schedule: object
    ratios: dict
    dt: float = DRIVER_DT
    kp: float = 0.0
    ki: float = 0.0
    preview: float = 0.5
    brake_max: float = 0.0
    hold_brake: float = 0.0
    converter: object = None  # the torque converter behind the engine (None: the engine drives the input)
    t_start: float = 0.0
    integral: float = 0.0
    next_t: float = 0.0
    times: list = field(default_factory=list)
    throttles: list = field(default_factory=list)
    brakes: list = field(default_factory=list)

    def __post_init__(self):
        self.kp = self.kp or self.mass / 1.0
        self.ki = self.ki or self.kp / 4.0
        if not self.times:
            self.times, self.throttles, self.brakes = [self.t_start], [0.0], [self.hold_brake]
            self.next_t = self.t_start

    #: its sampling events change no input at their instant (the commands continue from their values):
    #: the simulator goes on in the mode it was in (:func:`~.switching._mode_holds`)
    keeps_mode = True

    def event_functions(self):
        return [(lambda t, w: self.next_t - t, "sample")]

    def _throttle(self, torque: float, omega: float) -> float:
        """The throttle [0-1] at which the engine map gives ``torque`` [N*m] at ``omega`` [rad/s]."""
        e = self.engine
        rows = [float(np.interp(omega, e.speeds, row)) for row in e.torque]
        if torque <= rows[0]:
            return 0.0
        if torque >= rows[-1]:
            return 1.0
        return float(np.interp(torque, rows, e.throttles))

    def command(self, t: float, w) -> tuple[float, float]:
        """(throttle, brake torque [N*m]) at ``t`` for the link speeds ``w``; updates the integral."""
        tr = self.trace
        v = float(w[self.output]) * self.wheel_radius / self.final_drive
        v_ref, ahead = float(tr.speed(t)), float(tr.speed(t + self.preview))
        if v_ref <= 0.0 and ahead <= 0.0:
            self.integral = 0.0
            return 0.0, self.hold_brake
        e = v_ref - v
        force = self.mass * tr.slope(t + self.preview) + self.road_force(ahead) + self.kp * e + self.ki * self.integral
        gear_ratio = self.ratios[self.schedule.gear] * self.final_drive if self.schedule is not None else self.final_drive
        w_in = float(w[self.input])
        creep = 0.0  # the converter's torque at idle and zero throttle (creep) at the wheels [N]
        if self.converter is not None and w_in < self.idle:
            creep = max(0.0, float(self.converter.torques(self.idle, max(w_in, 0.0))[1])) * gear_ratio / self.wheel_radius
        if force >= creep:
            throttle = self._throttle(force * self.wheel_radius / gear_ratio, max(w_in, self.idle))
            brake = 0.0
            saturated = throttle >= 1.0 and e > 0
        else:
            throttle, brake = 0.0, min((creep - force) * self.wheel_radius, self.brake_max)
            saturated = brake >= self.brake_max and e < 0
        if not saturated:
            self.integral += e * self.dt
        return throttle, brake

    def fire(self, kind: str, t: float, elements: dict, w=None) -> None:
        """Sample at ``t``: the new commands, reached ``dt`` later (a ramp from the current ones)."""
        if w is None:
            return None
        throttle, brake = self.command(t, w)
        now = (DriverCommand(self, "throttle").value(t), DriverCommand(self, "brake").value(t))
        while self.times and self.times[-1] > t:  # the ramp not yet finished ends here
            self.times.pop(), self.throttles.pop(), self.brakes.pop()
        if not self.times or self.times[-1] < t:
            self.times.append(t), self.throttles.append(now[0]), self.brakes.append(now[1])
        self.times.append(t + self.dt), self.throttles.append(throttle), self.brakes.append(brake)
        self.next_t = t + self.dt
        return None

    def __deepcopy__(self, memo):  # the saved state of a run: the history, not the shared objects
        new = copy.copy(self)
        new.times, new.throttles, new.brakes = list(self.times), list(self.throttles), list(self.brakes)
        return new


def attach_driver(r, data: dict, components: list, controllers: list, mech, tr, t_start: float) -> Driver | None:
    """Build the ``[driver]`` of a scenario (``r``: the scenario reader) and give its commands to
    the engine, the schedule and the wheel brakes; None without a ``[driver]`` table."""
    from ..model.brake import BrakedDriveline
    from ..model.components import EngineOnLink, EngineWithConverter
    from .cycles import load_trace
    from .schedule import AutoShift
    from transgen.errors import ScenarioError

    spec = r.table(data, ("driver",), DRIVER_KEYS)
    if not spec:
        return None
    keys = ("driver",)
    for table, key in (("input", "throttle_signal"), ("auto_shift", "throttle_signal"), ("driveline", "brake")):
        if key in data.get(table, {}):
            raise r.error((table, key), f"the [driver] commands {table}.{key}: remove it")
    ref = r.text(spec, keys, "trace")
    try:
        trace = load_trace(ref, r.source.path.parent if getattr(r.source, "path", None) else None)
    except ScenarioError as exc:
        raise r.error(keys + ("trace",), str(exc)) from None
    engine = next((c for c in components if isinstance(c, (EngineWithConverter, EngineOnLink))), None)
    if engine is None:
        raise r.error(keys, "the driver needs an engine with a torque map ([input] type = \"engine_converter\" or "
                            "\"engine_map\")")
    driveline = next((c for c in components if isinstance(c, BrakedDriveline)), None)
    if driveline is None or driveline.mass <= 0:
        raise r.error(keys, "the driver needs a [driveline] with a vehicle (stiffness, vehicle_mass)")
    schedule = next((c for c in controllers if isinstance(c, AutoShift)), None)
    if schedule is None:
        raise r.error(keys, "the driver needs an [auto_shift] schedule")
    gears = {g.name: g for g in mech.gears}
    from transgen.kinematics import analyze

    ratios = {}
    for name in schedule.order:
        combo = analyze(mech, gears[name].engaged, tr.graph)
        ratios[name] = float(combo.ratio)
    g = driveline.wheel_radius / driveline.final_drive
    m_eff = r.number(spec, keys, "mass", 0.03 * driveline.mass + driveline.J_v / g ** 2, positive=True)
    weight = driveline.mass * 9.81 * driveline.wheel_radius

    def road_force(v: float) -> float:
        return float(driveline.road_torque(v / g)) / g

    driver = Driver(trace, tr.link_index[mech.output], tr.link_index[mech.input], engine.engine,
                    getattr(engine, "idle", 0.0), driveline.final_drive, driveline.wheel_radius, m_eff, road_force,
                    schedule, ratios, dt=r.number(spec, keys, "dt", DRIVER_DT, positive=True),
                    kp=r.number(spec, keys, "kp", m_eff, positive=True),
                    ki=r.number(spec, keys, "ki", m_eff / 4.0, minimum=0.0) or 1e-12,
                    preview=r.number(spec, keys, "preview", 0.5, minimum=0.0),
                    brake_max=r.number(spec, keys, "brake_max", 0.8 * weight, positive=True),
                    hold_brake=r.number(spec, keys, "hold_brake", 0.4 * weight, minimum=0.0),
                    converter=getattr(engine, "converter", None), t_start=t_start)
    throttle = DriverCommand(driver, "throttle")
    engine.throttle = throttle
    schedule.throttle = throttle
    driveline.brake = DriverCommand(driver, "brake")
    controllers.insert(0, driver)
    return driver
