"""Components that apply torques to the transmission's links: the input torque source, external
loads, the driveline and vehicle.

Causality (thesis 2.4): the transmission links are inertial (they take torques, give speeds);
every component here takes the link speeds and gives torques, and may have states of its own.
The simulator calls, with ``w`` the array of all link speeds [rad/s] (``link_index`` maps names
to positions)::

    ``state_names``                    names of the component's states
    ``initial_state(w)``               their values at the start
    ``derivatives(t, x, w)``           d/dt of the states
    ``torques(t, x, w)``               ``{input name: torque}`` for the mechanism inputs it drives
                                       (``T_in``, ``T_out`` or a named load), sign as in the model:
                                       ``T_in`` and loads drive, ``T_out`` is delivered by the output
    ``power_in(t, x, w)``              power it feeds into the mechanism from outside [W]
    ``dissipation(t, x, w)``           power it dissipates internally [W] (energy balance)
    ``energy(x, w)``                   energy stored in its own states [J] (energy balance)
    ``load_power(t, x, w)``            power it passes to an external load (the road) [W]
    ``signals(t, x, w)``               named outputs for the result
    ``breakpoints(t0, t1)``             times in ``[t0, t1]`` where its inputs are not smooth
    ``evaluate(t, x, w)``              ``(torques, derivatives, power_in, dissipation, load_power)``
                                       in one call: what the right-hand side needs at one point
                                       (components override it to share work between the parts)
    ``sample(ts, X, W)``               ``(torques, signals, energy)`` as arrays over the output
                                       times ``ts`` (``X``, ``W``: one column per time); the default
                                       calls the scalar methods at each time, components override it
                                       with array arithmetic
    ``sample_rates(ts, X, W, A)``      signals that need the link accelerations ``A`` [rad/s^2]
                                       too (one column per time), e.g. the vehicle's jerk; ``{}``
                                       by default
    ``kernel_form()``                  the component as data for the compiled right-hand side
                                       (:mod:`.kernel`), or None: it is then evaluated in Python
                                       and combined with the compiled rest

The scalar formulas are :func:`~.jit.compilable` functions (below the classes) that the methods
and the compiled right-hand side both call.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ..core.interp import interp2
from ..core.jit import compilable, compiled_as, compiled_loop
from ..core.signals import Constant, Signal

__all__ = [
    "Component",
    "InputTorque",
    "EngineMap",
    "EngineOnLink",
    "EngineWithConverter",
    "LinkLoad",
    "Driveline",
    "GRAVITY",
    "own_kernel_form",
]

GRAVITY = 9.81


def own_kernel_form(obj, name: str = "kernel_form") -> bool:
    """Whether ``obj``'s class defines its compiled description ``name`` itself: a subclass that
    inherits it may have changed the physics it describes, and runs in Python."""
    return name in type(obj).__dict__


def elementwise(func, n_out: int = 1):
    """``func`` of scalars applied element by element to arrays (one implementation serves the
    right-hand side's scalar calls and the output sampling)."""
    return np.frompyfunc(func, 2, n_out)


class Component:
    """Base class with no states and no torques."""

    name: str = ""
    state_names: tuple[str, ...] = ()

    def initial_state(self, w: np.ndarray) -> np.ndarray:
        return np.zeros(len(self.state_names))

    def derivatives(self, t: float, x: np.ndarray, w: np.ndarray) -> np.ndarray:
        return np.zeros(len(self.state_names))

    def torques(self, t: float, x: np.ndarray, w: np.ndarray) -> dict[str, float]:
        return {}

    def power_in(self, t: float, x: np.ndarray, w: np.ndarray) -> float:
        return 0.0

    def dissipation(self, t: float, x: np.ndarray, w: np.ndarray) -> float:
        return 0.0

    def energy(self, x: np.ndarray, w: np.ndarray) -> float:
        return 0.0

    def load_power(self, t: float, x: np.ndarray, w: np.ndarray) -> float:
        return 0.0

    def signals(self, t: float, x: np.ndarray, w: np.ndarray) -> dict[str, float]:
        return {}

    def breakpoints(self, t0: float = -math.inf, t1: float = math.inf) -> tuple[float, ...]:
        return ()

    def evaluate(self, t: float, x: np.ndarray, w: np.ndarray) -> tuple:
        """``(torques, derivatives, power_in, dissipation, load_power)`` at one point."""
        return (self.torques(t, x, w), self.derivatives(t, x, w), self.power_in(t, x, w),
                self.dissipation(t, x, w), self.load_power(t, x, w))

    def sample(self, ts: np.ndarray, X: np.ndarray, W: np.ndarray) -> tuple[dict, dict, np.ndarray]:
        """``(torques, signals, energy)`` at the output times ``ts``: dicts of arrays and the
        stored energy [J] (``X``: the component's states, ``W``: the link speeds, one column per
        time)."""
        n = len(ts)
        torques: dict[str, np.ndarray] = {}
        rows = []
        energy = np.zeros(n)
        for k in range(n):
            x, w = X[:, k], W[:, k]
            for name, value in self.torques(ts[k], x, w).items():
                torques.setdefault(name, np.zeros(n))[k] += value
            rows.append(self.signals(ts[k], x, w))
            energy[k] = self.energy(x, w)
        return torques, {name: np.array([r[name] for r in rows], dtype=float) for name in (rows[0] if rows else ())}, energy

    def sample_rates(self, ts: np.ndarray, X: np.ndarray, W: np.ndarray, A: np.ndarray) -> dict:
        """Signals that need the link accelerations ``A`` [rad/s^2] besides the states ``X`` and
        the link speeds ``W`` (one column per time); none by default."""
        return {}

    def kernel_form(self) -> tuple | None:
        """``(kind, integers, numbers, signals, inputs)``: the component as data for the compiled
        right-hand side (:mod:`.kernel`, which documents each kind's layout), or None when it has
        no compiled form (it is then evaluated in Python). Only a class that defines it itself
        is compiled: a subclass that changes the physics and not this runs in Python."""
        return None


@dataclass
class InputTorque(Component):
    """A prescribed torque on the input link [N*m], positive drives: ``T_in = signal(t)``."""

    signal: Signal
    link: int
    name: str = "input"

    def torques(self, t, x, w):
        return {"T_in": self.signal.value(t)}

    def power_in(self, t, x, w):
        return self.signal.value(t) * w[self.link]

    def signals(self, t, x, w):
        return {"T_in": self.signal.value(t)}

    def breakpoints(self, t0=-math.inf, t1=math.inf):
        return self.signal.breakpoints(t0, t1)

    def kernel_form(self):
        return "input_torque", (self.link,), (), (self.signal,), ("T_in",)


@dataclass
class EngineMap:
    """Engine torque [N*m] as a table over engine speed [rad/s] and throttle [0-1].

    ``torque[i_throttle][i_speed]``; clamped outside the table. Used by :class:`InputTorque`-like
    sources directly on a link or behind a torque converter.
    """

    speeds: tuple[float, ...]
    throttles: tuple[float, ...]
    torque: tuple[tuple[float, ...], ...]

    def __post_init__(self):
        self.speeds = tuple(float(x) for x in self.speeds)
        self.throttles = tuple(float(x) for x in self.throttles)
        self.torque = tuple(tuple(float(x) for x in row) for row in self.torque)
        if len(self.torque) != len(self.throttles) or any(len(r) != len(self.speeds) for r in self.torque):
            raise ValueError(f"engine torque table must be {len(self.throttles)} x {len(self.speeds)} (throttles x speeds)")

    def __call__(self, omega: float, throttle: float) -> float:
        return interp2(omega, throttle, self.speeds, self.throttles, self.torque)

    def requested(self, torque: float, omega: float, factor: float) -> float:
        """The engine torque [N*m] under a torque-request factor [-] (a shift's torque
        intervention, :mod:`transgen.sim.control.schedule`): a driving torque times ``factor``, raised at
        most to the full-load torque (the highest throttle) at ``omega`` [rad/s]; a dragging
        (motoring, <= 0) torque is left alone."""
        return requested_torque(torque, factor, omega, self.speeds, self.throttles, self.torque)

    def kernel_numbers(self) -> tuple[tuple[int, int], tuple[float, ...]]:
        """``((n_speeds, n_throttles), numbers)``: speeds, throttles and the torque table row by
        row (one row per throttle), for the compiled right-hand side."""
        return ((len(self.speeds), len(self.throttles)),
                self.speeds + self.throttles + tuple(x for row in self.torque for x in row))


@dataclass
class EngineOnLink(Component):
    """An engine torque map driving the input link directly (the link carries the crank inertia).
    ``idle`` [rad/s]: the minimum-speed governor of :class:`EngineWithConverter` (0: none), for
    an engine that drives a converter the mechanism models itself (:mod:`transgen.own_converter`)."""

    engine: EngineMap
    throttle: Signal
    link: int
    name: str = "engine"
    request: Signal | None = None  # torque-request factor [-] of the shifts (EngineMap.requested)
    fuel: object | None = None  # fuel flow of the map (transgen.sim.engine.fuel): the m_dot_fuel signal [kg/s]
    idle: float = 0.0

    def _throttle(self, t, w):
        return governed_throttle(self.throttle.value(t), w[self.link], self.idle)

    def _torque(self, t, w):
        torque = self.engine(w[self.link], self._throttle(t, w))
        return torque if self.request is None else self.engine.requested(torque, w[self.link], self.request.value(t))

    def torques(self, t, x, w):
        return {"T_in": self._torque(t, w)}

    def power_in(self, t, x, w):
        return self._torque(t, w) * w[self.link]

    def signals(self, t, x, w):
        out = {"T_in": self._torque(t, w), "throttle": self._throttle(t, w)}
        if self.request is not None:
            out["torque_request"] = self.request.value(t)
        if self.fuel is not None:
            out["m_dot_fuel"] = float(self.fuel.flow(w[self.link], out["T_in"], out["throttle"]))
        return out

    def breakpoints(self, t0=-math.inf, t1=math.inf):
        if self.request is not None:
            return tuple(sorted({*self.throttle.breakpoints(t0, t1), *self.request.breakpoints(t0, t1)}))
        return self.throttle.breakpoints(t0, t1)

    def kernel_form(self):
        if type(self.engine) is not EngineMap:
            return None
        sizes, numbers = self.engine.kernel_numbers()
        signals = (self.throttle,) if self.request is None else (self.throttle, self.request)
        return "engine_on_link", (self.link, *sizes, len(signals) - 1), numbers + (float(self.idle),), signals, ("T_in",)


@dataclass
class EngineWithConverter(Component):
    """An engine (torque map, crank + impeller inertia ``J_engine``) driving the input link
    (the turbine) through a torque converter.

    State: engine speed ``omega_e`` [rad/s]. ``converter.torques(omega_pump, omega_turbine)``
    gives (pump torque absorbed, turbine torque delivered) [N*m] (see
    :mod:`transgen.sim.engine.torque_converter`). ``idle`` is a minimum-speed governor: below it the
    throttle rises linearly to hold idle. Energy: the engine's combustion work is the work in;
    the converter's loss is dissipation; the engine inertia's kinetic energy is stored energy.
    """

    engine: EngineMap
    throttle: Signal
    converter: object
    J_engine: float
    link: int
    omega_start: float = 70.0
    idle: float = 0.0
    name: str = "engine"
    state_names: tuple[str, ...] = ("omega_e",)
    request: Signal | None = None  # torque-request factor [-] of the shifts (EngineMap.requested)
    fuel: object | None = None  # fuel flow of the map (transgen.sim.engine.fuel): the m_dot_fuel signal [kg/s]

    def initial_state(self, w):
        return np.array([self.omega_start])

    def _throttle(self, t, omega_e):
        return governed_throttle(self.throttle.value(t), omega_e, self.idle)

    def _engine_torque(self, t, omega_e):
        torque = self.engine(omega_e, self._throttle(t, omega_e))
        return torque if self.request is None else self.engine.requested(torque, omega_e, self.request.value(t))

    def derivatives(self, t, x, w):
        return [self.evaluate(t, x, w)[1][0]]

    def torques(self, t, x, w):
        _, turbine = self.converter.torques(x[0], w[self.link])
        return {"T_in": turbine}

    def power_in(self, t, x, w):
        return self._engine_torque(t, x[0]) * x[0]

    def dissipation(self, t, x, w):
        return self.evaluate(t, x, w)[3]

    def energy(self, x, w):
        return 0.5 * self.J_engine * x[0] ** 2

    def evaluate(self, t, x, w):
        omega_e, omega_t = float(x[0]), float(w[self.link])  # Python floats: faster scalar arithmetic
        pump, turbine = self.converter.torques(omega_e, omega_t)
        rate, p_in, loss = engine_converter_rates(self._engine_torque(t, omega_e), pump, turbine, omega_e,
                                                  omega_t, self.J_engine)
        return {"T_in": turbine}, [rate], p_in, loss, 0.0

    def sample(self, ts, X, W):
        omega_e, omega_t = X[0], W[self.link]
        if own_kernel_form(self) and self.kernel_form() is not None:  # loops over the output times, compiled when the simulator is
            pump, turbine = self.converter.torques_over(omega_e, omega_t)
            demand = np.array([self.throttle.value(t) for t in ts], dtype=float)
            # a shift's torque request (1: none; requested_torque leaves the torque as it is then)
            factor = (np.ones(len(ts)) if self.request is None
                      else np.array([self.request.value(t) for t in ts], dtype=float))
            throttle, t_engine = np.empty(len(ts)), np.empty(len(ts))
            tables = (self.engine.speeds, self.engine.throttles, self.engine.torque)
            over = compiled_loop(engine_over, len(ts))
            if over is None:
                over = engine_over
            else:
                tables = tuple(np.array(x, dtype=float) for x in tables)
            over(demand, factor, np.ascontiguousarray(omega_e, dtype=float), float(self.idle), *tables, throttle,
                 t_engine)
        else:
            pump, turbine = (a.astype(float) for a in elementwise(self.converter.torques, 2)(omega_e, omega_t))
            throttle = elementwise(self._throttle)(ts, omega_e).astype(float)
            t_engine = elementwise(self._engine_torque)(ts, omega_e).astype(float)  # with a shift's torque request
        ratio = np.divide(omega_t, omega_e, out=np.zeros_like(omega_e), where=omega_e > 1e-6)
        signals = {"omega_engine": omega_e, "T_engine": t_engine, "T_pump": pump, "T_in": turbine,
                   "throttle": throttle, "converter_speed_ratio": ratio}
        if self.request is not None:
            signals["torque_request"] = self.request.sample(ts)
        if self.fuel is not None:
            signals["m_dot_fuel"] = self.fuel.flow(omega_e, t_engine, throttle)
        return {"T_in": turbine}, signals, 0.5 * self.J_engine * omega_e ** 2

    def signals(self, t, x, w):
        pump, turbine = self.converter.torques(x[0], w[self.link])
        return {"omega_engine": x[0], "T_engine": self._engine_torque(t, x[0]), "T_pump": pump,
                "T_in": turbine, "throttle": self._throttle(t, x[0]),
                "converter_speed_ratio": w[self.link] / x[0] if x[0] > 1e-6 else 0.0,
                **({} if self.request is None else {"torque_request": self.request.value(t)}),
                **({} if self.fuel is None else {"m_dot_fuel": float(self.fuel.flow(
                    x[0], self._engine_torque(t, x[0]), self._throttle(t, x[0])))})}

    def breakpoints(self, t0=-math.inf, t1=math.inf):
        if self.request is not None:
            return tuple(sorted({*self.throttle.breakpoints(t0, t1), *self.request.breakpoints(t0, t1)}))
        return self.throttle.breakpoints(t0, t1)

    def kernel_form(self):
        if type(self.engine) is not EngineMap or not own_kernel_form(self.converter, "kernel_numbers"):
            return None
        map_sizes, map_numbers = self.engine.kernel_numbers()
        tc_sizes, tc_numbers = self.converter.kernel_numbers()
        signals = (self.throttle,) if self.request is None else (self.throttle, self.request)
        return ("engine_converter", (self.link, *map_sizes, *tc_sizes, len(signals) - 1),
                (float(self.J_engine), float(self.idle)) + map_numbers + tc_numbers, signals, ("T_in",))


@dataclass
class LinkLoad(Component):
    """An external torque on a link: ``T = signal(t) - (c0*sign(w) + c1*w + c2*w*|w|)`` [N*m],
    positive drives the link (the quadratic part is a speed-dependent drag)."""

    input_name: str
    link: int
    signal: Signal = field(default_factory=lambda: Constant(0.0))
    c0: float = 0.0
    c1: float = 0.0
    c2: float = 0.0
    name: str = "load"

    def _torque(self, t, w):
        return link_load_torque(self.signal.value(t), w[self.link], self.c0, self.c1, self.c2)

    def torques(self, t, x, w):
        return {self.input_name: self._torque(t, w)}

    def power_in(self, t, x, w):
        return self._torque(t, w) * w[self.link]

    def signals(self, t, x, w):
        return {self.input_name: self._torque(t, w)}

    def breakpoints(self, t0=-math.inf, t1=math.inf):
        return self.signal.breakpoints(t0, t1)

    def kernel_form(self):
        return "link_load", (self.link,), (float(self.c0), float(self.c1), float(self.c2)), (self.signal,), (self.input_name,)


@dataclass
class Driveline(Component):
    """Driveshaft (spring-damper) from the output link to the vehicle, and the vehicle.

    States: driveshaft twist ``theta`` [rad] (output side minus vehicle side) and the speed of
    the vehicle side referred to the driveshaft, ``omega_v`` [rad/s]. ``T_out = k*theta +
    c*(w_out - omega_v)``. The vehicle-side inertia is ``J_out + m*r^2/i^2`` with final drive
    ``i`` and wheel radius ``r``; the road load at the wheels is rolling resistance
    ``f_r*m*g*cos(grade)`` (fading in below 0.1 m/s so the vehicle can stand), aerodynamic drag
    ``0.5*rho*cd_a*v^2`` and grade ``m*g*sin(grade)``; ``v = omega_v*r/i``.

    With a vehicle (``mass > 0``) the signals include ``vehicle_accel`` [m/s^2], the vehicle's
    longitudinal acceleration from its force balance ``a = (T_out - road)/J_v * r/i``, and
    ``vehicle_jerk`` [m/s^3], its time derivative
    ``(k*(w_out - omega_v) + c*(alpha_out - alpha_v) - road'(omega_v)*alpha_v)/J_v * r/i`` with the
    output link's acceleration ``alpha_out`` from the transmission (:meth:`sample_rates`): both
    exact at every sample (the jerk jumps at a mode change: the two samples of the event show
    both sides). The comfort figures of the shift report use them. Without a vehicle mass there
    is no vehicle acceleration (the speeds are those of an output inertia).
    """

    output: int
    stiffness: float
    damping: float
    J_out: float = 0.0
    final_drive: float = 1.0
    wheel_radius: float = 0.5
    mass: float = 0.0
    rolling: float = 0.0
    cd_a: float = 0.0
    air_density: float = 1.2
    grade: float = 0.0
    initial_twist: float = 0.0  # rad, driveshaft twist at the start (see transgen.sim.model.settle)
    name: str = "driveline"
    state_names: tuple[str, ...] = ("theta_ds", "omega_v")
    signal_units = {"vehicle_accel": "m/s^2", "vehicle_jerk": "m/s^3"}

    def __post_init__(self):
        self.J_v = self.J_out + self.mass * self.wheel_radius ** 2 / self.final_drive ** 2
        if self.J_v <= 0:
            raise ValueError("the driveline needs an output inertia or a vehicle mass")

    def initial_state(self, w):
        return np.array([self.initial_twist, w[self.output]])

    def _speed(self, omega_v):
        return omega_v * self.wheel_radius / self.final_drive

    def _road(self) -> tuple[float, ...]:
        """The numbers of :func:`road_torque` after the speed."""
        return (float(self.mass), float(self.rolling), float(self.grade), float(self.air_density), float(self.cd_a),
                float(self.wheel_radius), float(self.final_drive))

    def road_torque(self, omega_v: float | np.ndarray) -> float | np.ndarray:
        """Road load referred to the driveshaft [N*m] (opposes forward motion, :func:`road_torque`);
        ``omega_v`` a number or an array."""
        return road_torque(omega_v, *self._road())

    def road_slope(self, omega_v: np.ndarray) -> np.ndarray:
        """d(road torque)/d(omega_v) [N*m*s/rad] (the grade term is constant)."""
        g = self.wheel_radius / self.final_drive
        v = omega_v * g
        rolling = self.rolling * self.mass * GRAVITY * math.cos(self.grade) / 0.1 * (1.0 - np.tanh(v / 0.1) ** 2)
        return (rolling + self.air_density * self.cd_a * np.abs(v)) * g * g

    def sample_rates(self, ts, X, W, A):
        if self.mass <= 0:
            return {}
        theta, omega_v = X
        slip = W[self.output] - omega_v
        alpha_v = (self.stiffness * theta + self.damping * slip - self.road_torque(omega_v)) / self.J_v
        d_shaft = self.stiffness * slip + self.damping * (A[self.output] - alpha_v)
        return {"vehicle_jerk": self._speed((d_shaft - self.road_slope(omega_v) * alpha_v) / self.J_v)}

    def shaft_torque(self, x, w) -> float:
        return self.evaluate(0.0, x, w)[0]["T_out"]

    def derivatives(self, t, x, w):
        return self.evaluate(t, x, w)[1]

    def torques(self, t, x, w):
        return {"T_out": self.shaft_torque(x, w)}

    def dissipation(self, t, x, w):
        return self.evaluate(t, x, w)[3]

    def energy(self, x, w):
        return 0.5 * self.stiffness * x[0] ** 2 + 0.5 * self.J_v * x[1] ** 2

    def load_power(self, t, x, w):
        return self.evaluate(t, x, w)[4]

    def evaluate(self, t, x, w):
        shaft, d_theta, d_omega, loss, p_load = driveline_rates(
            float(x[0]), float(x[1]), float(w[self.output]), self.stiffness, self.damping, self.J_v, *self._road())
        return {"T_out": shaft}, [d_theta, d_omega], 0.0, loss, p_load

    def kernel_form(self):
        return ("driveline", (self.output,), (float(self.stiffness), float(self.damping), float(self.J_v)) + self._road(),
                (), ("T_out",))

    def sample(self, ts, X, W):
        theta, omega_v = X
        shaft = self.stiffness * theta + self.damping * (W[self.output] - omega_v)
        v = self._speed(omega_v)
        road = self.road_torque(omega_v)
        signals = {"T_out": shaft, "theta_ds": theta, "omega_v": omega_v, "vehicle_speed": v,
                   "vehicle_speed_mph": v / 0.44704, "road_torque": road}
        if self.mass > 0:
            signals["vehicle_accel"] = self._speed((shaft - road) / self.J_v)
        return {"T_out": shaft}, signals, self.energy(X, W)

    def signals(self, t, x, w):
        v = self._speed(x[1])
        shaft, road = self.shaft_torque(x, w), self.road_torque(x[1])
        out = {"T_out": shaft, "theta_ds": x[0], "omega_v": x[1], "vehicle_speed": v,
               "vehicle_speed_mph": v / 0.44704, "road_torque": road}
        if self.mass > 0:
            out["vehicle_accel"] = self._speed((shaft - road) / self.J_v)
        return out


# ------------------------------------------------------------ formulas (one implementation)


@compilable
def governed_throttle(throttle: float, omega_e: float, idle: float) -> float:
    """The throttle [0-1] with the minimum-speed governor: below ``idle`` [rad/s] (when > 0) it
    rises linearly to hold idle, to full at 90 % of idle."""
    if idle > 0 and omega_e < idle:
        return max(throttle, min(1.0, (idle - omega_e) / (0.1 * idle)))
    return throttle


@compilable
def requested_torque(torque: float, factor: float, omega: float, speeds, throttles, table) -> float:
    """The engine torque [N*m] of the map ``(speeds, throttles, table)`` under a torque-request
    factor [-] (:meth:`EngineMap.requested`): a driving ``torque`` times ``factor``, raised at most
    to the full-load torque (the highest throttle) at ``omega`` [rad/s]; a dragging (motoring,
    <= 0) torque is left alone."""
    if torque <= 0.0 or factor == 1.0:
        return torque
    if factor < 1.0:
        return torque * factor
    return min(torque * factor, max(torque, interp2(omega, throttles[len(throttles) - 1], speeds, throttles, table)))


@compilable
def engine_converter_rates(t_engine: float, pump: float, turbine: float, omega_e: float, omega_t: float,
                           J_engine: float) -> tuple[float, float, float]:
    """``(d omega_e/dt, power in, converter loss)`` of an engine (torque ``t_engine``, inertia
    ``J_engine``) driving a converter (pump torque absorbed ``pump``, turbine torque ``turbine``)."""
    return (t_engine - pump) / J_engine, t_engine * omega_e, converter_loss(pump, turbine, omega_e, omega_t)


@compilable
def engine_over(demand, factor, omega_e, idle: float, speeds, throttles, torque, throttle, t_engine) -> None:
    """The governed throttle and the engine torque of the map ``(speeds, throttles, torque)`` at
    every output time (written into ``throttle`` and ``t_engine``) from the throttle demand
    ``demand``, the torque-request factor ``factor`` (:func:`requested_torque`; 1: none) and the
    engine speeds ``omega_e``."""
    for k in range(len(omega_e)):
        throttle[k] = governed_throttle(demand[k], omega_e[k], idle)
        t_engine[k] = requested_torque(interp2(omega_e[k], throttle[k], speeds, throttles, torque), factor[k],
                                       omega_e[k], speeds, throttles, torque)


@compilable
def converter_loss(pump: float, turbine: float, omega_pump: float, omega_turbine: float) -> float:
    """Power [W] a torque converter dissipates: pump power in minus turbine power out (>= 0)."""
    return pump * omega_pump - turbine * omega_turbine


@compilable
def link_load_torque(drive: float, s: float, c0: float, c1: float, c2: float) -> float:
    """:class:`LinkLoad`'s torque at the link speed ``s``: ``drive - (c0*sign(s) + c1*s + c2*s*|s|)``."""
    return drive - (math.copysign(c0, s) * (s != 0) + c1 * s + c2 * s * abs(s))


@compiled_as(math.tanh)
def _tanh(x):
    """``tanh`` of a number (``math.tanh``) or, in Python, of an array (``numpy.tanh``)."""
    return np.tanh(x) if isinstance(x, np.ndarray) else math.tanh(x)


@compilable
def road_torque(omega_v: float, mass: float, rolling: float, grade: float, air_density: float, cd_a: float,
                wheel_radius: float, final_drive: float) -> float:
    """Road load [N*m] referred to the driveshaft at its vehicle-side speed ``omega_v`` (see
    :class:`Driveline`); ``omega_v`` a number or, in Python, an array."""
    v = omega_v * wheel_radius / final_drive
    mg = mass * GRAVITY
    rolling_force = rolling * mg * math.cos(grade) * _tanh(v / 0.1)
    force = rolling_force + 0.5 * air_density * cd_a * v * abs(v) + mg * math.sin(grade)
    return force * wheel_radius / final_drive


@compilable
def driveline_rates(theta: float, omega_v: float, w_out: float, stiffness: float, damping: float, J_v: float,
                    mass: float, rolling: float, grade: float, air_density: float, cd_a: float, wheel_radius: float,
                    final_drive: float) -> tuple[float, float, float, float, float]:
    """``(shaft torque, d theta/dt, d omega_v/dt, damper loss, road power)`` of :class:`Driveline`."""
    slip = w_out - omega_v
    shaft = stiffness * theta + damping * slip
    road = road_torque(omega_v, mass, rolling, grade, air_density, cd_a, wheel_radius, final_drive)
    return shaft, slip, (shaft - road) / J_v, damping * slip * slip, road * omega_v
