"""Launch scenarios derived from a mechanism alone: from rest through every forward gear.

:func:`derive_launch` reads what a gearbox's ``.mech`` file fixes and chooses the rest from a
vehicle class (:data:`VEHICLES`), the way one starts with a new gearbox:

* the forward gears: declared gears with a fixed positive input/output speed ratio (computed from
  the kinematics; a gear with idle members is a gear: :mod:`transgen.idle`), sorted by ratio,
  largest first; a declared gear that cannot be used is left out with a warning; the shift sequence takes
  each next gear that a single or double swap reaches (:func:`~transgen.sim.control.schedule.gear_swap`)
  and names the gears it cannot schedule;
* the static element torques per unit input torque in each gear (``k``), from the D matrix of
  the gear's mode with the output torque that holds the gear at zero acceleration;
* the input torque the engine and converter can deliver (the converter's torque ratio times the
  torque at the engine/converter match, over the converter's drive range, with the idle governor);
* whether the declared capacities hold that torque: holding ``static >= HOLD_FACTOR * |k| *
  T_in,max``; shifting ``ramp_end * dynamic >= SHIFT_FACTOR * |k| * T_engine,max`` for each
  oncoming element (its inertia-phase level must exceed its static share). Where they do not,
  the engine torque is limited (the whole map scaled, as a transmission control unit limits the
  engine torque to protect the gearbox), the vehicle's mass and drag area are scaled by the same
  factor (the class's performance kept: a truck on a car gearbox becomes a light truck), and a
  warning says so;
* each upshift's own calibration from the statics of its two gears, the inertia it synchronises
  and the expected input torque (:mod:`~transgen.sim.derive.calibration`, ``docs/calibration.md``), and
  the driveline's compliance from the class's parts (:mod:`~transgen.sim.derive.driveline_class`);
* for a mechanism that models its own converter (:mod:`transgen.own_converter`), the engine map on
  its pump link (no ``J_engine``: the link's inertia is the engine's), its ``[converter]`` and the
  lock-up open through the launch (:mod:`.launch_converter`, ``docs/guide/own_converter.md``);
* the final drive from the class's overall first-gear ratio, an automatic schedule whose upshift
  and downshift lines are the class's engine-speed band divided by the gear ratios, and ``t_end``
  from a quasi-static estimate of the launch (vehicle speed integrated gear by gear with the
  engine/converter match and the road load).

:func:`launch_scenario` writes the result as a commented scenario file (TOML) for
:func:`~transgen.sim.scenario.load.load_scenario`. Units SI; speeds in the file in rpm as the scenario
format wants them.

Size: about 600 lines, over the project's 500, because the derivation and the commented TOML
writer read the same dataclasses field by field; split them when either grows.
"""
from __future__ import annotations

import dataclasses
import math
import tomllib
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from transgen.errors import ScenarioError
from transgen.graph import build_graph, link_nodes
from transgen.idle import gear_check
from transgen.model import Mechanism
from transgen.modes import Mode, mode_model
from transgen.own_converter import own_converter

from . import calibration
from .calibration import ShiftTiming, UpshiftCalibration, upshift_calibration
from ..model.components import EngineMap
from .driveline_class import DrivelineParts, EquivalentDriveline
from .launch_estimate import (MAX_LAUNCH_TIME, RPM, _engine_match, phase_end_torque, _engine_torque_max,
                              _estimate_launch, _input_torque_max, _road_force)
from ..engine.map_file import DATA_DIR
from ..control.schedule import ShiftTemplate, gear_swap
from ..engine.torque_converter import DEFAULT_TORQUE_CONVERTER, TorqueConverter

__all__ = ["VehicleClass", "VEHICLES", "ForwardGear", "LaunchShift", "ElementSizing", "Launch",
           "derive_launch", "launch_scenario", "mechanism_reference", "static_element_torques", "HOLD_FACTOR",
           "SHIFT_FACTOR"]

HOLD_FACTOR = 1.2
"""Safety factor of a holding element's static capacity over its largest static torque."""
SHIFT_FACTOR = 1.5
"""Oncoming torque in the inertia phase over the element's static share of the engine torque."""
RAMP_END_RANGE = (0.3, 0.9)
"""Inertia-phase apply levels the generator chooses from (fractions of full apply)."""
SCHEMA = "transgen.scenario-new/1"
LAUNCH_UNITS = {"ratio": "1", "torque_factors": "1", "output_inertia": "kg*m^2", "static": "N*m", "dynamic": "N*m",
                "factor": "1", "required_static": "N*m", "engine_torque_scale": "1", "input_torque_max": "N*m",
                "final_drive": "1", "fill_time": "s", "fill_level": "1", "ramp_time": "s", "ramp_end": "1",
                "hold_time": "s", "final_time": "s", "offgoing_delay": "s", "offgoing_level": "1", "offgoing_ramp": "s",
                "ease_slip": "1", "ease_time": "s", "ease_level": "1",
                "upshift_rpm": "rpm", "downshift_rpm": "rpm", "min_interval": "s", "estimated_shift_times": "s",
                "t_end": "s", "speed": "m/s", "throttle": "1", "throttle_after": "1", "brake": "N*m",
                "input_torque": "N*m", "input_speed": "rad/s", "speed_change": "rad/s",
                "inertia": "kg*m^2", "handover_level": "1", "inertia_level": "1", "inertia_phase": "s",
                "stiffness": "N*m/rad", "damping": "N*m*s/rad", "parts": "N*m/rad", "frequency": "Hz"}
"""Units of the numeric fields of ``transgen scenario new --json`` (shift lines: output speed, rev/min)."""
@dataclass(frozen=True)
class VehicleClass:
    """A vehicle class: engine map, converter, driveline, vehicle and shift speed band.

    ``overall_first``: overall ratio (gearbox first gear times final drive) the final drive is
    chosen for. ``upshift_rpm`` / ``downshift_rpm``: engine (turbine) speeds [rpm] at throttle 0
    and 1 at which the schedule shifts up / down. Estimates of the class, not data of a vehicle.
    """

    name: str
    description: str
    speed_rpm: tuple[float, ...]
    throttle: tuple[float, ...]
    torque_table: tuple[tuple[float, ...], ...]
    J_engine: float
    idle_rpm: float
    throttle_signal: float
    converter: str | None  # file in sim/data, None: the scenario loader's default
    mass: float
    wheel_radius: float
    rolling_resistance: float
    cd_a: float
    output_inertia: float
    driveline: DrivelineParts
    overall_first: float
    last_upshift_speed: float  # m/s: the launch reaches the top gear by this vehicle speed
    upshift_rpm: tuple[float, float]
    downshift_rpm: tuple[float, float]
    shift_timing: ShiftTiming = ShiftTiming()
    comments: dict = field(default_factory=dict, compare=False)
    fuel_map: dict | None = None  # [input] fuel_map of the class's scenarios (transgen.sim.engine.fuel)

    def engine(self, scale: float = 1.0) -> EngineMap:
        return EngineMap(tuple(s * RPM for s in self.speed_rpm), self.throttle,
                         tuple(tuple(scale * x for x in row) for row in self.torque_table))

    def converter_model(self) -> TorqueConverter:
        return TorqueConverter.load(DATA_DIR / self.converter if self.converter else DEFAULT_TORQUE_CONVERTER)


def _load_vehicles() -> dict[str, VehicleClass]:
    """The vehicle classes of ``data/vehicle_classes.toml``."""
    doc = tomllib.loads((DATA_DIR / "vehicle_classes.toml").read_text(encoding="utf-8"))
    out = {}
    for name, spec in doc["vehicle"].items():
        spec = dict(spec)
        for key in ("speed_rpm", "throttle", "upshift_rpm", "downshift_rpm"):
            spec[key] = tuple(float(x) for x in spec[key])
        spec["torque_table"] = tuple(tuple(float(x) for x in row) for row in spec["torque_table"])
        spec["converter"] = spec.get("converter") or None
        spec["driveline"] = DrivelineParts(**spec["driveline"])
        if "shift_timing" in spec:
            spec["shift_timing"] = ShiftTiming(**{k: float(v) for k, v in spec["shift_timing"].items()})
        out[name] = VehicleClass(name=name, **spec)
    return out


VEHICLES: dict[str, VehicleClass] = _load_vehicles()
"""Vehicle classes by name (``car``, ``truck``), from ``sim/data/vehicle_classes.toml``."""


@dataclass(frozen=True)
class ForwardGear:
    """A forward gear: ``ratio`` = input/output speed [-]; ``torque_factors``: static torque of
    each engaged element per unit input torque [-] (sign: the element's torque convention)."""

    name: str
    ratio: float
    engaged: tuple[str, ...]
    torque_factors: dict
    inertia: float = 0.0  # referred to the output [kg*m^2]
    idle: tuple[str, ...] = ()  # idle members (links): :mod:`transgen.idle`


@dataclass(frozen=True)
class LaunchShift:
    """An upshift of the launch: commanded ``oncoming`` and ``offgoing`` elements; one-way
    clutches that overrun (leave) or lock (enter) by themselves."""

    source: str
    target: str
    oncoming: tuple[str, ...]
    offgoing: tuple[str, ...]
    overrunning: tuple[str, ...] = ()
    self_locking: tuple[str, ...] = ()

    @property
    def kind(self) -> str:
        return "double swap" if max(len(self.oncoming), len(self.offgoing)) > 1 else "single swap"


@dataclass(frozen=True)
class ElementSizing:
    """Capacity check of one friction element [N*m]: ``factor`` = largest ``|k|`` over the forward
    gears where it holds; ``required`` = HOLD_FACTOR * factor * the class's largest input torque."""

    element: str
    static: float
    dynamic: float
    factor: float
    gears: tuple[str, ...]
    required: float

    @property
    def sufficient(self) -> bool:
        return self.static >= self.required


@dataclass(frozen=True)
class Launch:
    """Everything :func:`derive_launch` derived; :meth:`to_dict` for JSON, :func:`launch_scenario`
    for the scenario text."""

    mechanism: Mechanism
    vehicle: VehicleClass
    gears: tuple[ForwardGear, ...]
    order: tuple[str, ...]
    shifts: tuple[LaunchShift, ...]
    skipped: tuple[tuple[str, str], ...]
    sizing: tuple[ElementSizing, ...]
    torque_scale: float
    input_torque_max: float
    final_drive: float
    template: ShiftTemplate
    upshift_rpm: tuple[tuple[float, float], ...]
    downshift_rpm: tuple[tuple[float, float], ...]
    min_interval: float
    shift_times: tuple[float, ...]
    t_end: float
    warnings: tuple[str, ...]
    calibrations: tuple[UpshiftCalibration, ...] = ()
    driveline: EquivalentDriveline | None = None

    def gear(self, name: str) -> ForwardGear:
        return next(g for g in self.gears if g.name == name)

    def to_dict(self) -> dict:
        """The ``transgen.scenario-new/1`` JSON document of ``transgen scenario new --json``."""
        from transgen.schemas import json_document

        return json_document(SCHEMA, {
            "mechanism": self.mechanism.name,
            "vehicle": self.vehicle.name,
            "forward_gears": [{"name": g.name, "ratio": g.ratio, "engaged": list(g.engaged),
                               "torque_factors": dict(g.torque_factors), "output_inertia": g.inertia,
                               "idle": list(g.idle)}
                              for g in self.gears],
            "order": list(self.order),
            "shifts": [{"from": s.source, "to": s.target, "kind": s.kind, "oncoming": list(s.oncoming),
                        "offgoing": list(s.offgoing), "overrunning": list(s.overrunning),
                        "self_locking": list(s.self_locking)} for s in self.shifts],
            "not_schedulable": [{"gear": g, "reason": why} for g, why in self.skipped],
            "capacities": [{"element": c.element, "static": c.static, "dynamic": c.dynamic, "factor": c.factor,
                            "gears": list(c.gears), "required_static": c.required, "sufficient": c.sufficient}
                           for c in self.sizing],
            "engine_torque_scale": self.torque_scale, "input_torque_max": self.input_torque_max,
            "final_drive": self.final_drive, "template": self.template.as_data(),
            "upshift_rpm": [list(r) for r in self.upshift_rpm], "downshift_rpm": [list(r) for r in self.downshift_rpm],
            "min_interval": self.min_interval, "estimated_shift_times": list(self.shift_times),
            "t_end": self.t_end, "warnings": list(self.warnings),
            "calibration": [c.as_data() for c in self.calibrations],
            "driveline": {"stiffness": self.driveline.stiffness, "damping": self.driveline.damping,
                          "parts": dict(self.driveline.parts), "frequency": self.driveline.frequency},
        }, LAUNCH_UNITS)


# ---------------------------------------------------------------------------------- derivation


def _gear_equations(mech: Mechanism, engaged: tuple[str, ...], graph=None):
    """(mode model, index of the input torque, index of the output torque in ``u``)."""
    model = mode_model(mech, Mode("gear", tuple(engaged)), graph)
    if model.equations is None:
        raise ValueError(model.problem)
    names = list(model.equations.u)
    i_in = names.index(next(t.name for t in mech.torques if t.role == "input"))
    i_out = names.index(next(t.name for t in mech.torques if t.role == "output"))
    return model, i_in, i_out


def static_element_torques(mech: Mechanism, engaged: tuple[str, ...], graph=None) -> dict[str, float]:
    """Torque of each element of a one-DOF gear per unit input torque at zero acceleration [-].

    The gear's mode gives the locked torques ``t = D u`` and the accelerations ``B u`` for the
    inputs ``u`` (the external torques and the slipping element torques); with unit input torque
    the output torque is chosen so that the acceleration vanishes (the static balance), other
    loads zero. Raises ``ValueError`` when the gear's mode cannot be modelled.
    """
    model, i_in, i_out = _gear_equations(mech, engaged, graph)
    eq = model.equations
    g_in, g_out = eq.G_accel[:, i_in], eq.G_accel[:, i_out]
    row = int(np.argmax(np.abs(g_out)))
    if abs(g_out[row]) < 1e-12:
        raise ValueError("the output torque does not act on the gear's motion")
    s = -g_in[row] / g_out[row]
    torques = eq.G_clutches[:, i_in] + s * eq.G_clutches[:, i_out]
    # one row per locked constraint: elements in parallel share their group's torque (each member
    # in its own direction; the friction members carry it first, so each must be able to hold it)
    return {e: float(sign * t) for grp, t in zip(model.groups, torques) for e, sign in zip(grp.members, grp.signs)}


def output_inertia(mech: Mechanism, engaged: tuple[str, ...], graph=None) -> float:
    """Inertia of the gearbox in a one-DOF gear referred to the output link [kg*m^2]: output
    torque over the output's deceleration, from the gear's mode."""
    model, _, i_out = _gear_equations(mech, engaged, graph)
    links = list(link_nodes(graph if graph is not None else build_graph(mech)))
    accel = model.equations.G_accel[links.index(mech.output), i_out]
    return 1.0 / abs(accel) if accel else math.inf


def _forward_gears(mech: Mechanism) -> tuple[list[ForwardGear], list[tuple[str, str]]]:
    """The declared forward gears (not alternative), largest ratio first, and ``(gear, reason)``
    for each declared gear that cannot be used. Whether a combination is a gear is the one rule
    of :mod:`transgen.idle`: a gear whose extra degrees of freedom are idle members (a hub between
    elements in series, a hub only open elements touch) is a gear like any other."""
    g = build_graph(mech)
    out, unusable = [], []
    own = own_converter(mech)
    for gear in mech.gears:
        if gear.kind != "gear" or gear.alternative:  # a manual low or extra ratio: not in the launch
            continue
        check = gear_check(mech, gear.engaged, g)
        if check.kind == "gear" and check.ratio is not None and check.ratio < 0:
            continue  # a reverse gear: not in a launch
        if not check.is_gear:
            why = (check.problem if check.kind == "gear" else
                   f"it does not fix the input/output ratio ({check.dof} degrees of freedom, {check.kind})")
            unusable.append((gear.name, why))
            continue
        try:
            factors = static_element_torques(mech, gear.engaged, g)
            inertia = output_inertia(mech, gear.engaged, g)
            if own is not None:  # converter drive: the lock-up open, the pump (engine) link not in the gearbox
                factors.pop(own.lockup, None)
                inertia -= mech.link(own.pump).inertia * float(check.ratio) ** 2
        except ValueError as exc:
            raise ScenarioError(f"{mech.source}:{gear.span.line}:{gear.span.column}: error: gear {gear.name} "
                                f"cannot be modelled: {exc}") from None
        out.append(ForwardGear(gear.name, float(check.ratio), tuple(gear.engaged), factors, inertia, check.idle))
    return sorted(out, key=lambda x: -x.ratio), unusable


def _sequence(mech: Mechanism, gears: list[ForwardGear]):
    """Shift sequence: from first gear, each next gear a single or double swap reaches."""
    table = {g.name: g.engaged for g in gears}
    oneway = frozenset(e.name for e in mech.elements if e.kind == "oneway")
    own = own_converter(mech)
    lockup = frozenset({own.lockup}) if own else frozenset()
    order, shifts, skipped = [gears[0].name], [], []
    ratios = {g.name: g.ratio for g in gears}
    table_ratio = ratios.__getitem__
    for gear in gears[1:]:
        source = order[-1]
        if gear.ratio >= table_ratio(source) * (1 - 1e-6):
            skipped.append((gear.name, f"same ratio as gear {source} ({gear.ratio:.4f})"))
            continue
        try:
            on, off = gear_swap(table, source, gear.name, oneway, lockup)
        except ValueError as exc:
            skipped.append((gear.name, str(exc)))
            continue
        a, b = set(table[source]), set(table[gear.name])
        shifts.append(LaunchShift(source, gear.name, on, off, tuple(sorted((a - b) & oneway)),
                                  tuple(sorted((b - a) & oneway))))
        order.append(gear.name)
    return order, shifts, skipped


def _sizing(mech: Mechanism, gears: list[ForwardGear], t_in: float) -> list[ElementSizing]:
    out = []
    own = own_converter(mech)
    for e in mech.elements:
        if e.kind == "oneway" or (own is not None and e.name == own.lockup):  # the lock-up: open in the launch
            continue
        holding = [(abs(g.torque_factors[e.name]), g.name) for g in gears if e.name in g.torque_factors]
        if not holding:
            continue
        factor = max(k for k, _ in holding)
        out.append(ElementSizing(e.name, e.static, e.dynamic, factor, tuple(n for _, n in holding),
                                 HOLD_FACTOR * factor * t_in))
    return out


def _ramp_end_needed(mech: Mechanism, gears: dict, shifts: list[LaunchShift], t_engine: float) -> float:
    """Inertia-phase apply level at which every oncoming element carries SHIFT_FACTOR times its
    static share of ``t_engine``."""
    need = 0.0
    for s in shifts:
        for name in s.oncoming:
            dyn = mech.element(name).dynamic
            need = max(need, SHIFT_FACTOR * abs(gears[s.target].torque_factors[name]) * t_engine / dyn
                       if dyn > 0 else math.inf)
    return need


def _torque_scale(mech, vehicle, gears, shifts) -> float:
    """Largest engine-torque scale in (0, 1] at which the declared capacities suffice."""
    by_name = {g.name: g for g in gears}

    def ok(scale):
        t_in = _input_torque_max(vehicle, scale)
        holds = all(c.sufficient for c in _sizing(mech, gears, t_in))
        return holds and _ramp_end_needed(mech, by_name, shifts, _engine_torque_max(vehicle, scale)) <= RAMP_END_RANGE[1]

    if ok(1.0):
        return 1.0
    lo, hi = 0.0, 1.0
    for _ in range(30):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if ok(mid) else (lo, mid)
    return lo


def derive_launch(mech: Mechanism, vehicle: str = "car") -> Launch:
    """Derive a launch scenario for ``mech`` in a vehicle of class ``vehicle`` (a key of
    :data:`VEHICLES`). Raises :class:`~transgen.errors.ScenarioError` (``FILE:LINE:COL: error:``)
    when the mechanism has fewer than two schedulable forward gears or the launch cannot work."""
    if vehicle not in VEHICLES:
        raise ValueError(f"unknown vehicle class {vehicle!r} (known: {', '.join(VEHICLES)})")
    vc = VEHICLES[vehicle]
    own = own_converter(mech)
    if own is not None:  # the engine's inertia is the .mech's pump link (no J_engine added)
        vc = dataclasses.replace(vc, J_engine=mech.link(own.pump).inertia)
    where = f"{mech.source}:{mech.gears[0].span.line}:{mech.gears[0].span.column}" if mech.gears else f"{mech.source}:1:1"
    gears, unusable = _forward_gears(mech)
    if len(gears) < 2:
        raise ScenarioError(f"{where}: error: a launch scenario needs a gear table with at least two forward gears "
                            f"(a fixed positive ratio; idle members allowed); found {len(gears)}"
                            + "".join(f"; gear {g} cannot be used: {why}" for g, why in unusable))
    order, shifts, skipped = _sequence(mech, gears)
    if len(order) < 2:
        raise ScenarioError(f"{where}: error: no forward gear can be shifted to from gear {order[0]}: "
                            + "; ".join(why for _, why in skipped))
    warnings = [f"gear {g} cannot be used and is left out: {why}" for g, why in unusable]
    warnings += [f"gear {g} is not schedulable and is left out: {why}" for g, why in skipped]
    scale = _torque_scale(mech, vc, gears, shifts)
    t_in = _input_torque_max(vc, scale)
    sizing = _sizing(mech, gears, _input_torque_max(vc, 1.0))
    for c in sizing:
        if not c.sufficient:
            warnings.append(f"{c.element}: declared static capacity {c.static:.0f} N*m is below the {c.required:.0f} N*m "
                            f"the {vc.name} needs ({HOLD_FACTOR:g} x {c.factor:.3f} x {c.required / HOLD_FACTOR / c.factor:.0f} N*m "
                            f"input torque in gear {', '.join(c.gears)})")
    by_name = {g.name: g for g in gears}
    need = _ramp_end_needed(mech, by_name, shifts, _engine_torque_max(vc, scale))
    if scale < 1.0:
        warnings.append(f"engine torque limited to {100 * scale:.1f} % of the {vc.name} engine so that the declared "
                        f"capacities hold (largest input torque {t_in:.0f} N*m); vehicle mass and drag area scaled "
                        f"by the same factor to keep the class's performance")
        vc = dataclasses.replace(vc, mass=vc.mass * scale, cd_a=vc.cd_a * scale,
                                 description=f"{vc.description}, scaled to {100 * scale:.1f} % (gearbox capacities)")
    ramp_end = min(max(need, RAMP_END_RANGE[0]), RAMP_END_RANGE[1])
    template = ShiftTemplate(ramp_end=round(ramp_end, 3))
    final_drive = vc.overall_first / gears[0].ratio
    ratio = {g.name: g.ratio for g in gears}
    # engine speed at the upshifts: the class band at the first, falling geometrically with the
    # ratio to the one that puts the last upshift at the class's launch speed (if lower)
    n_up = float(np.interp(vc.throttle_signal, (0.0, 1.0), vc.upshift_rpm))
    cap = vc.last_upshift_speed * final_drive / vc.wheel_radius / RPM  # output rpm
    c = min(1.0, cap * ratio[order[-2]] / n_up)
    span = math.log(ratio[order[0]] / ratio[order[-2]])
    up, down = [], []
    for a, b in zip(order, order[1:]):
        f = c ** (math.log(ratio[order[0]] / ratio[a]) / span) if span > 0 else c
        u = tuple(f * n / ratio[a] for n in vc.upshift_rpm)
        d = tuple(min(n / ratio[b], 0.8 * x) for n, x in zip(vc.downshift_rpm, u))
        up.append(tuple(round(x, 1) for x in u))
        down.append(tuple(round(x, 1) for x in d))
    # the calibration at the steady engine/converter match first (it spaces the shifts), then at the
    # state the launch estimate reaches at each shift
    first_pass = _calibrate(mech, vc, scale, by_name, shifts, up, final_drive)
    min_interval = round(max(_duration(c.template) for c in first_pass) + 0.5, 3)
    try:
        times, states = _estimate_launch(vc, scale, gears, order, final_drive, up, template, min_interval)
    except ValueError as exc:
        raise ScenarioError(f"{where}: error: {exc}; the {vc.name} cannot be launched through the gears "
                            f"with this gearbox") from None
    calibrations = _calibrate(mech, vc, scale, by_name, shifts, up, final_drive, states)
    duration = max(_duration(c.template) for c in first_pass + calibrations)
    min_interval = round(duration + 0.5, 3)
    t_end = float(math.ceil(1.3 * times[-1] + duration + 3.0))
    driveline = vc.driveline.equivalent(final_drive, vc.wheel_radius, vc.mass, vc.output_inertia, gears[0].inertia)
    return Launch(mech, vc, tuple(gears), tuple(order), tuple(shifts), tuple(skipped), tuple(sizing), scale, t_in,
                  final_drive, template, tuple(up), tuple(down), min_interval, tuple(times), t_end, tuple(warnings),
                  tuple(calibrations), driveline)


def _duration(t: ShiftTemplate) -> float:
    return t.fill_time + t.ramp_time + t.hold_time + t.final_time


def _calibrate(mech, vc: VehicleClass, scale: float, gears: dict, shifts, up, final_drive: float,
               states=None) -> list[UpshiftCalibration]:
    """Each upshift's calibration (:func:`~transgen.sim.derive.calibration.upshift_calibration`) at the
    input torque and speed at its command: ``states`` (engine speed, turbine speed, turbine torque
    from :func:`_estimate_launch`), else the steady engine/converter match at the turbine speed of
    the schedule's upshift line. In the inertia phase the turbine slows to the new gear's speed
    while the engine (its inertia) keeps its speed, and the converter's torque rises with the
    lower speed ratio."""
    engine, tc = vc.engine(scale), vc.converter_model()
    idle, throttle = vc.idle_rpm * RPM, vc.throttle_signal
    graph = build_graph(mech)
    out = []
    for k, (s, line) in enumerate(zip(shifts, up)):
        a, b = gears[s.source], gears[s.target]
        if states is None:
            w_t = float(np.interp(throttle, (0.0, 1.0), line)) * RPM * a.ratio
            w_e, torque = _engine_match(engine, tc, idle, throttle, w_t)
        else:
            w_e, w_t, torque = states[k]
        # the vehicle's acceleration there (as _estimate_launch): the gearbox accelerates with it
        speed = w_t / a.ratio / final_drive * vc.wheel_radius
        mass = 1.03 * vc.mass + (a.inertia + vc.output_inertia) * (final_drive / vc.wheel_radius) ** 2
        accel = (torque * a.ratio * final_drive / vc.wheel_radius - _road_force(vc, speed)) / mass
        w_t_end = w_t * b.ratio / a.ratio
        out.append(upshift_calibration(mech, a, b, s.oncoming, s.offgoing, torque, w_t, vc.shift_timing, graph,
                                       accel * final_drive / vc.wheel_radius,
                                       tc.torques(w_e, w_t_end)[1],  # the engine keeps its speed
                                       torque_end=phase_end_torque(engine, tc, idle, throttle, vc.J_engine, w_e, w_t,
                                                                   w_t_end, vc.shift_timing.inertia_phase)))
    return out


# --------------------------------------------------------------------------------- TOML text


def _num(x: float) -> str:
    """A TOML number: shortest text that reads back as ``x`` (6 significant digits)."""
    text = f"{x:.6g}"
    return text if any(c in text for c in ".en") else text + ".0"


def _list(xs) -> str:
    return "[" + ", ".join(_num(x) for x in xs) + "]"


def _string(s: str) -> str:
    return '"' + s.replace("\\", "\\\\").replace('"', '\\"') + '"'


def mechanism_reference(source: str | Path, where: str | Path | None = None) -> str:
    """How a scenario names the mechanism ``source`` (a path or a bundled name, as the user gave
    it): a bundled mechanism by its bundled name (``ht740``, also when given as the path of the
    installed file), a user's file by its path relative to the folder ``where`` the scenario is
    written (as given, without ``where``) - never the absolute path of the install."""
    import os

    from transgen.library import bundled_path

    path = Path(source)
    if not path.exists():
        return path.stem if path.suffix == ".mech" else str(source)
    found = bundled_path(path.name)
    if found is not None and found.resolve() == path.resolve():
        return path.stem
    if where is None:
        return path.as_posix()
    return Path(os.path.relpath(path.resolve(), Path(where).resolve())).as_posix()


def launch_scenario(mech: Mechanism, vehicle: str = "car", mechanism_ref: str | None = None,
                    launch: Launch | None = None) -> str:
    """A commented launch scenario (TOML text) for ``mech``: from rest in first gear through every
    schedulable forward gear. ``mechanism_ref``: how the file names the mechanism (a path relative
    to the scenario file, or a bundled name; default :func:`mechanism_reference` of its source)."""
    lc = launch or derive_launch(mech, vehicle)
    vc = lc.vehicle
    scale = lc.torque_scale
    ref = mechanism_ref or mechanism_reference(mech.source)
    first = lc.gear(lc.order[0])
    lines = [
        f"# Launch scenario for {mech.name}: {vc.description}.",
        "# Written by 'transgen scenario new' from the gear table alone: the vehicle starts from rest in gear",
        f"# {first.name} at part throttle and the automatic schedule shifts up through gears {' '.join(lc.order)}.",
        "# Every number below is an estimate of the vehicle class or derived from the mechanism; edit freely.",
        "#",
        "# Forward gears (ratio input/output; static element torque per unit input torque):",
    ]
    for g in lc.gears:
        factors = ", ".join(f"{e} {k:+.3f}" for e, k in g.torque_factors.items())
        lines.append(f"#   {g.name:<4} {g.ratio:7.4f}   {factors}")
    lines.append("# Shifts:")
    for s in lc.shifts:
        extra = "".join([f"; one-way {' '.join(s.overrunning)} overruns by itself" if s.overrunning else "",
                         f"; one-way {' '.join(s.self_locking)} locks by itself" if s.self_locking else ""])
        lines.append(f"#   {s.source}-{s.target}: {s.kind}, on {' '.join(s.oncoming) or '-'}, "
                     f"off {' '.join(s.offgoing) or '-'}{extra}")
    for g, why in lc.skipped:
        lines.append(f"#   gear {g} NOT SCHEDULABLE: {why}")
    lines.append(f"# Capacities (static [N*m] declared vs {HOLD_FACTOR:g} x |k| x largest input torque of the class):")
    for c in lc.sizing:
        lines.append(f"#   {c.element:<6} {c.static:8.0f} vs {c.required:8.0f}  {'ok' if c.sufficient else 'INSUFFICIENT'}"
                     f"  (|k| = {c.factor:.3f} in gear {', '.join(c.gears)})")
    for w in lc.warnings:
        lines.append(f"# warning: {w}")
    lines += [
        "",
        f"mechanism = {_string(ref)}",
        f"title = {_string(f'{mech.name}: launch of a {vc.name} through gears ' + ' '.join(lc.order))}",
        "",
        "[simulation]",
        f"t_end = {_num(lc.t_end)}              # s: estimated last upshift at {lc.shift_times[-1]:.1f} s, with margin",
        'method = "LSODA"',
        "rtol = 1e-7",
        "atol = 1e-7",
        "output_dt = 0.01",
        "",
    ]
    own = own_converter(mech)
    if own is not None:  # the .mech models its converter (docs/guide/own_converter.md)
        from . import launch_converter as lcv

        lines += lcv.initial_lines(mech, vc, first, own, _num) + [""] + lcv.input_head_lines(mech, vc, own, _num)
    else:
        lines += [
            "[initial]",
            f"gear = {_string(first.name)}",
            f"speeds = {{ {', '.join(f'{x} = 0.0' for x in (mech.output,) + first.idle)} }}      # vehicle at rest, "
            f"gear {first.name} engaged" + (f" (idle member {', '.join(first.idle)} at rest too)" if first.idle else ""),
            "",
            "[input]                 # engine (torque map) driving the gearbox input through a torque converter",
            'type = "engine_converter"',
            f"J_engine = {_num(vc.J_engine)}          # kg*m^2: {vc.comments.get('J_engine', '')}",
            f"engine_speed_rpm = {_num(vc.idle_rpm)}",
            f"idle_rpm = {_num(vc.idle_rpm)}"]
    lines += [
        f"# engine: {vc.comments.get('engine', '')}"
        + (f"; torque limited to {100 * scale:.1f} % (capacities)" if scale < 1 else ""),
        f"speed_rpm = {_list(vc.speed_rpm)}",
        f"throttle = {_list(vc.throttle)}",
        "torque_table = [",
    ]
    lines += [f"  {_list(scale * x for x in row)}," for row in vc.torque_table]
    lines.append("]")
    lines.append(f"throttle_signal = {_num(vc.throttle_signal)}   # part throttle, constant")
    if vc.fuel_map:
        items = ", ".join(f"{k} = {_string(v) if isinstance(v, str) else _num(v)}" for k, v in vc.fuel_map.items())
        lines.append(f"fuel_map = {{ {items} }}   # {vc.comments.get('fuel_map', 'fuel flow (transgen.sim.engine.fuel)')}")
    if own is not None:
        lines += lcv.converter_lines(vc, own)
    elif vc.converter:
        lines.append(f"converter = {_string(Path(vc.converter).stem)}   # transgen's bundled {vc.name} converter, by its name")
    else:
        lines.append("# converter: the bundled heavy-truck three-element converter (transgen/sim/data)")
    lines += [
        "",
        "[driveline]",
        f"output_inertia = {_num(vc.output_inertia)}       # kg*m^2: {vc.comments.get('output_inertia', '')}",
        "# the propeller shaft, half-shafts and tyres in series, referred to the gearbox output (N*m/rad):",
        "# " + ", ".join(f"{k} {v:.0f}" for k, v in lc.driveline.parts.items())
        + f"; first torsional mode {lc.driveline.frequency:.1f} Hz in gear {first.name}, damping ratio "
        f"{vc.driveline.damping_ratio:g} (sim/data/vehicle_classes.toml has the sources)",
        f"stiffness = {_num(round(lc.driveline.stiffness, 1))}           # N*m/rad",
        f"damping = {_num(round(lc.driveline.damping, 2))}             # N*m*s/rad",
        f"final_drive = {_num(round(lc.final_drive, 4))}          # overall first-gear ratio {_num(vc.overall_first)}"
        f" / gear {first.name} ratio {first.ratio:.4f}",
        f"wheel_radius = {_num(vc.wheel_radius)}        # m",
        f"vehicle_mass = {_num(vc.mass)}        # kg",
        f"rolling_resistance = {_num(vc.rolling_resistance)}",
        f"cd_a = {_num(vc.cd_a)}                 # m^2",
        "",
        "[auto_shift]            # upshift/downshift lines: the class's engine-speed band / gear ratio",
        f"# engine speed band [rpm] at throttle 0 and 1: upshift {_list(vc.upshift_rpm)}, downshift "
        f"{_list(vc.downshift_rpm)}",
        f"order = [{', '.join(_string(g) for g in lc.order)}]",
        "throttle = [0.0, 1.0]",
        "upshift_rpm = [" + ", ".join(_list(r) for r in lc.upshift_rpm) + "]     # output speed, one row per upshift",
        "downshift_rpm = [" + ", ".join(_list(r) for r in lc.downshift_rpm) + "]   # below the upshift lines",
        f"throttle_signal = {_num(vc.throttle_signal)}",
        f"min_interval = {_num(lc.min_interval)}      # s: one shift's duration and 0.5 s",
        "# shift template (for a shift without its own below): the oncoming element(s) fill, ramp to ramp_end",
        f"# (torque phase), hold (inertia phase), then apply fully; ramp_end carries {SHIFT_FACTOR:g} x an oncoming",
        "# element's static share of the engine torque. The offgoing element(s) drop and release.",
        "# One-way clutches are not commanded: they overrun or lock by themselves.",
        "template = { " + ", ".join(f"{k} = {_num(v)}" for k, v in lc.template.as_data().items()) + " }",
        "",
    ]
    lines += _calibration_lines(lc)
    return "\n".join(lines)


def _calibration_lines(lc: Launch) -> list[str]:
    """The ``[auto_shift.templates."A-B"]`` tables of the derived calibration, each with the numbers
    it comes from (docs/calibration.md)."""
    t = lc.vehicle.shift_timing
    lines = ["# Each upshift's own calibration, derived from the statics of its two gears and the inertia it",
             "# synchronises (docs/calibration.md): the oncoming ramps to the handover level (its gear-B torque",
             f"# share of the expected input torque) in the torque phase ({t.torque_phase:g} s), the offgoing falls from",
             f"# {100 * calibration.OFFGOING_MARGIN:.0f} % of the level holding its gear-A torque to zero just before it; the inertia-phase level",
             f"# adds the torque that synchronises the inertia in {t.inertia_phase:g} s (at most {calibration.MAX_LEVEL:g} of full apply);",
             f"# at {calibration.EASE_SLIP:g} of its slip the oncoming eases to its static share plus {calibration.EASE_RESIDUAL:g} of that torque.", ""]
    for c in lc.calibrations:
        lines += [f'[auto_shift.templates."{c.source}-{c.target}"]   # input torque {c.input_torque:.0f} N*m at '
                  f'{c.input_speed / RPM:.0f} rpm; input slows by {c.speed_change / RPM:.0f} rpm; J = {c.inertia:.4g} kg*m^2;'
                  f' handover level {c.handover_level:.3f}; inertia phase {c.inertia_phase:.2f} s']
        lines += [f"{k} = {_num(v)}" for k, v in c.template.as_data().items()]
        lines.append("")
    return lines
