"""Maneuver scenarios derived from a mechanism: kickdown, coast-down, tip-in, tip-out, drive cycle.

``transgen scenario new FILE --maneuver KIND`` starts from the launch that
:func:`~transgen.sim.derive.launch.derive_launch` derives (forward gears, final drive, shift lines,
template, vehicle class) and changes what the maneuver needs::

    ``launch``     from rest through every gear (:func:`~transgen.sim.derive.launch.launch_scenario`, unchanged);
    ``kickdown``   cruising at the road-load throttle in the highest gear in which the schedule holds
                   a speed its full-throttle downshift line lies above; at :data:`T_STEP` the throttle
                   goes to 1 in :data:`PEDAL_TIME`: power-on downshifts (speed phase first: the
                   offgoing element releases, the input flares to the new synchronous speed, the
                   oncoming element is applied near synchronism, :mod:`.schedule`);
    ``coastdown``  the same cruise; at :data:`T_STEP` the throttle goes to 0 and the wheel brakes to a
                   torque giving :attr:`ManeuverClass.brake_decel`, or less where the schedule could
                   not keep pace (one downshift per ``min_interval`` between its throttle-0 lines,
                   with 20 % margin) (:mod:`.brake`): power-off downshifts (torque phase first)
                   down the throttle-0 lines to low speed;
    ``tipin``      the same cruise; the throttle rises to the highest level that does not cross a
                   downshift line (no shift: the driveline's response to the torque step);
    ``tipout``     cruising in a middle gear at a speed between its upshift line at throttle 0 and
                   at 0.9 x :data:`~.schedule.POWER_ON_THROTTLE`; the throttle goes to 0 and crosses
                   the line below the power-on throttle: a power-off upshift (speed phase first);
    ``cycle``      a drive cycle (:mod:`.cycles`): the driver model of :mod:`.driver` follows a
                   standard speed trace, from rest in first gear.

The cruise state is quasi-static: the road load at the speed ``v`` (:func:`~.launch_estimate._road_force`)
equals the turbine torque (the engine/converter match, :func:`~.launch_estimate._converter_match`) times
the gear and final-drive ratios; the throttle that gives it is found by bisection. The run starts
there with the driveshaft wound to its steady torque (``[initial] driveshaft = "settled"``) and
:data:`T_STEP` s to settle.

Downshift templates come from the same physics as the upshift calibration
(:mod:`.calibration`, ``docs/calibration.md``): power-on downshifts
(``[auto_shift.speed_first_templates]``, :func:`~.calibration.kickdown_calibration`) hold the part
of the full-throttle turbine torque with the slipping offgoing element that leaves the torque to
raise the input's synchronised inertia to the new speed in the class's inertia-phase time; the
oncoming element fills and is applied at synchronism. Power-off downshifts (torque phase first,
``[auto_shift.templates]``, :func:`~.calibration.coast_downshift_calibration`) are sized as an
upshift under drive is, with the engine's drag at the throttle-0 downshift line as the input
torque. Units SI; the file in rpm where the scenario format wants it.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, replace
from pathlib import Path

from transgen.model import Mechanism

from .launch import Launch, _num, derive_launch, launch_scenario
from .launch_estimate import RPM, _converter_match, _road_force
from ..control.schedule import POWER_ON_THROTTLE, ShiftTemplate

__all__ = ["MANEUVERS", "ManeuverClass", "MANEUVER_CLASSES", "Maneuver", "derive_maneuver", "maneuver_scenario",
           "cycle_scenario", "set_key", "add_templates",
           "cruise_throttle", "T_STEP", "PEDAL_TIME"]

MANEUVERS = ("launch", "kickdown", "coastdown", "tipin", "tipout", "cycle")
"""The maneuvers of ``scenario new --maneuver``."""
T_STEP = 3.0
"""Time [s] of the pedal step after the cruise start (the converter and driveshaft settle)."""
PEDAL_TIME = 0.2
"""Time [s] the pedal takes to move (throttle ramp)."""
MAX_CRUISE_THROTTLE = 0.8
"""Highest road-load throttle [-] a cruise may need (above it the class cannot cruise there)."""


@dataclass(frozen=True)
class ManeuverClass:
    """What a maneuver takes from the vehicle class: the wheel brake deceleration of a coast-down
    [m/s^2] and the speed [m/s] at which it ends."""

    brake_decel: float
    end_speed: float


MANEUVER_CLASSES = {"car": ManeuverClass(brake_decel=1.5, end_speed=2.0),
                    "truck": ManeuverClass(brake_decel=1.0, end_speed=1.5)}
"""Coast-down braking per vehicle class (a moderate service-brake stop: ECE R13-H asks 6.43
m/s^2 of a car's full braking, R13 5 m/s^2 of a truck's; these are a fraction of it)."""


@dataclass(frozen=True)
class Maneuver:
    """A derived maneuver: ``gear`` and ``speed`` [m/s] of the cruise at ``throttle`` [-];
    ``throttle_after`` from :data:`T_STEP` on; ``brake`` [N*m] wheel torque from then (coast-down);
    ``t_end`` [s]; ``templates``: per-shift templates ("SOURCE-TARGET") of the downshifts;
    ``expected``: the shifts the schedule should command, quasi-statically."""

    kind: str
    gear: str
    speed: float
    throttle: float
    throttle_after: float
    brake: float
    t_end: float
    templates: dict
    expected: tuple[str, ...]


def _ratio(launch: Launch, gear: str) -> float:
    return launch.gear(gear).ratio


def _line(rows, k: int, throttle: float) -> float:
    """A shift line [rad/s of the output] of ``rows`` (rpm at throttle 0 and 1) at ``throttle``."""
    lo, hi = rows[k]
    return (lo + (hi - lo) * min(max(throttle, 0.0), 1.0)) * RPM


def _turbine_torque(launch: Launch, throttle: float, w_t: float) -> float:
    vc = launch.vehicle
    return _converter_match(vc.engine(launch.torque_scale), vc.converter_model(), vc.idle_rpm * RPM, throttle, w_t)


def cruise_throttle(launch: Launch, gear: str, speed: float) -> float | None:
    """The throttle [-] at which the vehicle of ``launch`` holds ``speed`` [m/s] in ``gear`` (the
    turbine torque times the ratios equals the road load), None above :data:`MAX_CRUISE_THROTTLE`."""
    vc = launch.vehicle
    ratio = _ratio(launch, gear) * launch.final_drive
    w_t = speed / vc.wheel_radius * ratio
    need = _road_force(vc, speed) * vc.wheel_radius / ratio

    def excess(x):
        return _turbine_torque(launch, x, w_t) - need

    if excess(MAX_CRUISE_THROTTLE) < 0:
        return None
    lo, hi = 0.0, MAX_CRUISE_THROTTLE
    if excess(lo) >= 0:
        return 0.0
    for _ in range(40):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if excess(mid) < 0 else (lo, mid)
    return hi


def _cruise(launch: Launch, k: int, lower, upper) -> tuple[float, float] | None:
    """(output speed [rad/s], throttle) of a cruise in gear ``order[k]`` at the middle of the band
    ``lower(thr) .. upper(thr)`` of output speeds (functions of the cruise throttle), or None."""
    vc, gear = launch.vehicle, launch.order[k]
    w = None
    thr = 0.2
    for _ in range(20):  # fixed point: the band depends on the cruise throttle, the throttle on the speed
        lo, hi = lower(thr), upper(thr)
        if not lo < hi:
            return None
        w = math.sqrt(lo * hi) if lo > 0 else 0.5 * hi
        new = cruise_throttle(launch, gear, w / launch.final_drive * vc.wheel_radius)
        if new is None:
            return None
        if abs(new - thr) < 1e-4:
            break
        thr = new
    lo, hi = lower(thr), upper(thr)
    return (w, thr) if lo < w < hi else None


def _held_band(launch: Launch, k: int, extra):
    """The band of output speeds in which the schedule holds gear ``order[k]`` at a throttle (above
    its upshift line into it, below its upshift line out of it) intersected with ``extra``."""
    top = len(launch.order) - 1

    def lower(thr):
        return max(_line(launch.upshift_rpm, k - 1, thr) if k > 0 else 0.0, extra[0](thr))

    def upper(thr):
        return min(_line(launch.upshift_rpm, k, thr) if k < top else math.inf, extra[1](thr))

    return lower, upper


def _downshifts(launch: Launch, k: int, w: float, throttle: float) -> list[str]:
    """The downshifts the schedule commands from gear ``order[k]`` at output speed ``w`` and
    ``throttle`` (the speed held)."""
    out = []
    while k > 0 and w < _line(launch.downshift_rpm, k - 1, throttle):
        out.append(f"{launch.order[k]}-{launch.order[k - 1]}")
        k -= 1
    return out


def _downshift_templates(launch: Launch, mech: Mechanism, w_out: float) -> dict:
    """Power-on downshift templates at output speed ``w_out`` [rad/s], each from the statics of its
    source gear and the inertia it synchronises (:func:`~.calibration.kickdown_calibration`, the
    full-throttle turbine torque at the source and the target gear's turbine speed); a power-off
    upshift (speed phase first too) the same with its offgoing element at 0.05 (it carries the
    small coast torque)."""
    from .calibration import kickdown_calibration
    from ..control.schedule import gear_swap

    table = {g.name: g.engaged for g in launch.gears}
    oneway = frozenset(e.name for e in mech.elements if e.kind == "oneway")
    timing = launch.vehicle.shift_timing
    out = {}
    for a, b in zip(launch.order, launch.order[1:]):
        high, low = launch.gear(b), launch.gear(a)  # the downshift b -> a starts in gear b
        on, off = gear_swap(table, b, a, oneway)
        w_in = w_out * high.ratio
        cal = kickdown_calibration(mech, high, low, on, off, _turbine_torque(launch, 1.0, w_in), w_in, timing,
                                   torque_after=_turbine_torque(launch, 1.0, w_out * low.ratio))
        out[f"{b}-{a}"] = cal.template
        out[f"{a}-{b}"] = replace(cal.template, offgoing_level=0.05)
    return out


def _coast_templates(launch: Launch, mech: Mechanism) -> dict:
    """Power-off downshift templates (torque phase first), each at its throttle-0 downshift line
    from the statics of its two gears, the engine's drag there and the inertia it synchronises
    (:func:`~.calibration.coast_downshift_calibration`: the upshift calibration's method with the
    drag as the input torque), with the class's target times."""
    from .calibration import coast_downshift_calibration
    from ..control.schedule import gear_swap

    table = {g.name: g.engaged for g in launch.gears}
    oneway = frozenset(e.name for e in mech.elements if e.kind == "oneway")
    timing = launch.vehicle.shift_timing
    out = {}
    for k, (a, b) in enumerate(zip(launch.order, launch.order[1:])):
        low, high = launch.gear(a), launch.gear(b)
        on, off = gear_swap(table, b, a, oneway)
        w_in = _line(launch.downshift_rpm, k, 0.0) * high.ratio
        drag = _turbine_torque(launch, 0.0, w_in)
        out[f"{b}-{a}"] = coast_downshift_calibration(mech, high, low, on, off, drag, w_in, timing,
                                                      engine_inertia=launch.vehicle.J_engine).template
    return out


def derive_maneuver(mech: Mechanism, launch: Launch, kind: str) -> Maneuver:
    """The maneuver ``kind`` (one of :data:`MANEUVERS` but ``launch`` and ``cycle``) for the
    vehicle and gearbox of ``launch``; ``ValueError`` when the class cannot cruise where it needs."""
    if kind not in ("kickdown", "coastdown", "tipin", "tipout"):
        raise ValueError(f"unknown maneuver {kind!r} (known: {', '.join(MANEUVERS)})")
    vc = launch.vehicle
    n = len(launch.order)
    never = (lambda thr: 0.0, lambda thr: math.inf)
    found = None
    if kind in ("kickdown", "coastdown", "tipin"):
        # the highest gear held where full throttle crosses its downshift line (a kickdown happens)
        for k in range(n - 1, 0, -1):
            extra = (never[0], lambda thr, k=k: _line(launch.downshift_rpm, k - 1, 1.0))
            cruise = _cruise(launch, k, *_held_band(launch, k, extra))
            if cruise is not None:
                found = (k, *cruise)
                break
    else:  # tipout: a gear held at the cruise throttle whose throttle-0 upshift line lies below
        for k in range(n - 2, -1, -1):
            extra = (lambda thr, k=k: _line(launch.upshift_rpm, k, 0.0),  # crossed below the power-on throttle
                     lambda thr, k=k: _line(launch.upshift_rpm, k, 0.9 * POWER_ON_THROTTLE))
            cruise = _cruise(launch, k, *_held_band(launch, k, extra))
            if cruise is not None:
                found = (k, *cruise)
                break
    if found is None:
        raise ValueError(f"the {vc.name} cannot cruise in a gear where a {kind} shifts (road-load throttle above "
                         f"{MAX_CRUISE_THROTTLE:g} or no band between the shift lines)")
    k, w, thr = found
    gear = launch.order[k]
    speed = w / launch.final_drive * vc.wheel_radius
    templates = _downshift_templates(launch, mech, w)
    brake = 0.0
    if kind == "kickdown":
        after, expected = 1.0, tuple(_downshifts(launch, k, w, 1.0))
        t_end = T_STEP + PEDAL_TIME + len(expected) * launch.min_interval + 3.0
    elif kind == "tipin":
        # the highest throttle that crosses no downshift line at this speed
        lo, hi = thr, 1.0
        for _ in range(40):
            mid = 0.5 * (lo + hi)
            lo, hi = (mid, hi) if w >= _line(launch.downshift_rpm, k - 1, mid) else (lo, mid)
        after, expected, t_end = round(lo - 0.01, 3), (), T_STEP + PEDAL_TIME + 4.0
    elif kind == "tipout":
        after, expected = 0.0, (f"{gear}-{launch.order[k + 1]}",)
        t_end = T_STEP + PEDAL_TIME + launch.min_interval + 3.0
    else:  # coastdown
        mc = MANEUVER_CLASSES[vc.name] if vc.name in MANEUVER_CLASSES else MANEUVER_CLASSES["car"]
        after = 0.0
        lines = [(f"{launch.order[j]}-{launch.order[j - 1]}",
                  _line(launch.downshift_rpm, j - 1, 0.0) * vc.wheel_radius / launch.final_drive) for j in range(k, 0, -1)]
        lines = [(name, v) for name, v in lines if v > mc.end_speed]
        expected = tuple(name for name, _ in lines)
        # a deceleration the schedule keeps pace with: one downshift per min_interval between the lines
        decel = mc.brake_decel
        if len(lines) > 1:
            decel = min(decel, (lines[0][1] - lines[-1][1]) / ((len(lines) - 1) * launch.min_interval * 1.2))
        brake = round(vc.mass * decel * vc.wheel_radius, 1)
        last = lines[-1][1] if lines else mc.end_speed
        t_end = T_STEP + PEDAL_TIME + max(speed - last, 0.0) / decel + launch.min_interval + 2.0
    return Maneuver(kind, gear, speed, round(thr, 4), after, brake, float(math.ceil(t_end)), templates, expected)


def _section_lines(lines: list[str], section: str) -> tuple[int, int]:
    """(first, end) line indices of the body of ``[section]`` in ``lines`` (``""``: the top level)."""
    if not section:
        return 0, next(i for i, x in enumerate(lines) if x.startswith("["))
    start = lines.index(f"[{section}]") if f"[{section}]" in lines else next(
        i for i, x in enumerate(lines) if x.startswith(f"[{section}]"))
    end = next((i for i in range(start + 1, len(lines)) if lines[i].startswith("[")), len(lines))
    return start + 1, end


def set_key(text: str, section: str, key: str, line: str) -> str:
    """``text`` (a scenario's TOML) with the line of ``key`` in ``[section]`` replaced by ``line``
    (appended to the section when it has no such key)."""
    lines = text.split("\n")
    first, end = _section_lines(lines, section)
    for i in range(first, end):
        if lines[i].split("=")[0].strip() == key:
            lines[i] = line
            return "\n".join(lines)
    while end > first and not lines[end - 1].strip():
        end -= 1
    lines.insert(end, line)
    return "\n".join(lines)


def _pedal(before: float, after: float) -> str:
    return (f"{{ type = \"ramp\", t0 = {_num(T_STEP)}, t1 = {_num(T_STEP + PEDAL_TIME)}, v0 = {_num(before)}, "
            f"v1 = {_num(after)} }}")


def _template_line(name: str, template: ShiftTemplate) -> str:
    return f'"{name}" = {{ ' + ", ".join(f"{k} = {_num(v)}" for k, v in template.as_data().items()) + " }"


def add_templates(text: str, templates: dict, table: str = "speed_first_templates") -> str:
    """``text`` with the per-shift ``templates`` ("SOURCE-TARGET" -> template) in
    ``[auto_shift.TABLE]`` (those the text already has for a shift are kept; the table, when the
    text has it, must be its last)."""
    import tomllib

    given = tomllib.loads(text).get("auto_shift", {}).get(table, {})
    rows = [_template_line(k, v) for k, v in templates.items() if k not in given]
    if not rows:
        return text
    header = f"[auto_shift.{table}]"
    if header in text.split("\n"):
        return text.rstrip("\n") + "\n" + "\n".join(rows) + "\n"
    return text.rstrip("\n") + "\n\n" + "\n".join([header] + rows) + "\n"


def maneuver_scenario(mech: Mechanism, vehicle: str = "car", kind: str = "kickdown", mechanism_ref: str | None = None,
                      launch: Launch | None = None, cycle: str | None = None) -> str:
    """A commented scenario (TOML text) of the maneuver ``kind`` for ``mech`` in a ``vehicle``
    (module docstring); ``launch``: the derived launch when the caller has it."""
    if kind != "launch":
        refuse_own_converter(mech, kind)
    lc = launch or derive_launch(mech, vehicle)
    if kind == "launch":
        return launch_scenario(mech, vehicle, mechanism_ref, lc)
    text = launch_scenario(mech, vehicle, mechanism_ref, lc)
    if kind == "cycle":
        return cycle_scenario(mech, lc, text, cycle)
    m = derive_maneuver(mech, lc, kind)
    vc = lc.vehicle
    w_out = m.speed / vc.wheel_radius * lc.final_drive
    w_t = w_out * _ratio(lc, m.gear)
    what = {"kickdown": "full throttle: power-on downshifts (speed phase first)",
            "coastdown": f"throttle off and wheel brakes ({m.brake:.0f} N*m): power-off downshifts",
            "tipin": f"throttle to {m.throttle_after:g}, below every downshift line: no shift",
            "tipout": "throttle off: a power-off upshift (speed phase first)"}[kind]
    header = [f"# {kind} maneuver for {mech.name}: {vc.description}.",
              f"# Written by 'transgen scenario new --maneuver {kind}': the vehicle cruises in gear {m.gear} at "
              f"{3.6 * m.speed:.1f} km/h",
              f"# (road-load throttle {m.throttle:.3f}); at {T_STEP:g} s, in {PEDAL_TIME:g} s, {what}.",
              "# Shifts the schedule commands (quasi-static estimate): " + (" ".join(m.expected) or "none") + ".",
              "# The launch derivation below gives the gears, capacities, final drive and shift lines.", "#"]
    text = "\n".join(header) + "\n" + text
    text = set_key(text, "", "title", f'title = "{mech.name}: {kind} of a {vc.name} from gear {m.gear} at '
                                      f'{3.6 * m.speed:.0f} km/h"')
    text = set_key(text, "simulation", "t_end", f"t_end = {_num(m.t_end)}              # s")
    text = set_key(text, "initial", "gear", f'gear = "{m.gear}"')
    text = set_key(text, "initial", "speeds", f"speeds = {{ {mech.output} = {_num(round(w_out, 4))} }}      "
                                              f"# {3.6 * m.speed:.1f} km/h in gear {m.gear}")
    text = set_key(text, "initial", "driveshaft", 'driveshaft = "settled"   # wound to its steady torque')
    text = set_key(text, "input", "engine_speed_rpm", f"engine_speed_rpm = {_num(round(1.05 * w_t / RPM, 1))}   "
                                                      "# the turbine speed and the converter's slip, about")
    pedal = _pedal(m.throttle, m.throttle_after)
    text = set_key(text, "input", "throttle_signal", f"throttle_signal = {pedal}")
    text = set_key(text, "auto_shift", "throttle_signal", f"throttle_signal = {pedal}")
    if m.brake > 0:
        text = set_key(text, "driveline", "brake", f"brake = {{ type = \"ramp\", t0 = {_num(T_STEP)}, "
                                                   f"t1 = {_num(T_STEP + 0.5)}, v0 = 0.0, v1 = {_num(m.brake)} }}"
                                                   "   # N*m at the wheels")
    text = text.rstrip("\n") + ("\n# power-on downshifts (speed phase first): the slipping offgoing element holds the torque the"
                               "\n# flare does not need (the input's inertia raised in the class's inertia-phase time,"
                               "\n# docs/calibration.md); the oncoming one fills and is applied at synchronism\n")
    text = add_templates(text, _coast_templates(lc, mech), "templates")
    return add_templates(text, m.templates)


def refuse_own_converter(mech: Mechanism, kind: str) -> None:
    """A maneuver other than the launch for a mechanism with its own converter is refused
    (``FILE:LINE:COL: error:`` at its lock-up clutch): it starts in a gear at speed, where the
    engine (the pump link), the turbine and the lock-up's state need their own derivation."""
    from transgen.errors import ScenarioError
    from transgen.own_converter import own_converter

    own = own_converter(mech)
    if own is None:
        return
    span = mech.element(own.lockup).span
    raise ScenarioError(f"{mech.source}:{span.line}:{span.column}: error: --maneuver {kind} is not supported for a "
                        f"mechanism that models its own torque converter (pump {own.pump}, turbine {own.turbine}, "
                        f"lock-up {own.lockup}); use --maneuver launch, or a gearbox without the converter "
                        f"(scenario new then adds the engine and converter)")


def cycle_scenario(mech, launch, text: str, cycle: str | None) -> str:
    """The drive-cycle scenario (TOML text) from the launch scenario ``text``: from rest in first
    gear, the driver (:mod:`.driver`) following the trace ``cycle`` (default ``wltc_class3b``) on
    throttle and wheel brakes, the automatic schedule with its speed-phase-first templates."""
    from ..control.cycles import DEFAULT_CYCLE, bundled_cycles, load_trace

    name = cycle or DEFAULT_CYCLE
    trace = load_trace(name, Path.cwd())
    ref = name if name in bundled_cycles() else str(Path(name).resolve())
    vc = launch.vehicle
    header = [f"# Drive cycle {trace.name} for {mech.name}: {vc.description}.",
              "# Written by 'transgen scenario new --maneuver cycle': the driver model (transgen.sim.control.driver: a",
              "# PI speed controller with feed-forward, on throttle and wheel brakes) follows the speed trace from",
              f"# rest; the automatic schedule shifts. Trace: {trace.source[:300]}",
              "# The launch derivation below gives the gears, capacities, final drive and shift lines.", "#"]
    text = "\n".join(header) + "\n" + text
    text = set_key(text, "", "title", f'title = "{mech.name}: drive cycle {trace.name} of a {vc.name}"')
    text = set_key(text, "simulation", "t_end", f"t_end = {_num(trace.times[-1])}              # s: the whole trace")
    text = set_key(text, "simulation", "output_dt", "output_dt = 0.1")
    text = set_key(text, "simulation", "rtol", "rtol = 1e-6             # a cycle: energy residual ~1e-5 of the work in")
    text = set_key(text, "simulation", "atol", "atol = 1e-6")
    lines = text.split("\n")
    lines = [x for x in lines if not x.startswith("throttle_signal =")]  # the driver commands the throttle
    text = "\n".join(lines)
    w_mid = 0.5 * (launch.upshift_rpm[-1][0] + launch.downshift_rpm[-1][1]) * RPM
    text = add_templates(text, _coast_templates(launch, mech), "templates")
    text = add_templates(text, _downshift_templates(launch, mech, w_mid))
    text = text.rstrip("\n") + "\n\n[driver]                # speed-tracking driver (transgen.sim.control.driver)\n" \
                               f'trace = "{ref}"\n' \
                               "# it commands [input] throttle, [auto_shift] throttle and the wheel brakes\n"
    return text
