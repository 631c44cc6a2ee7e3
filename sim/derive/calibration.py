"""A default upshift calibration from the gearbox's own physics (``transgen scenario new``).

For an upshift from gear A to gear B under drive, :func:`upshift_calibration` derives the shift
template (:class:`~transgen.sim.control.schedule.ShiftTemplate`, apply levels as fractions of full apply)
from four things the mechanism and the vehicle class fix (the method, with its reasoning, is in
``docs/calibration.md``):

* the **statics of the two gears**: each element's torque per unit input torque, ``k`` (the
  numbers ``transgen powerflow`` and ``scenario new`` print: :func:`~transgen.sim.derive.launch.static_element_torques`).
  While the offgoing element is still locked, its torque falls linearly with the oncoming
  element's torque and reaches zero when the oncoming element carries its gear-B share
  ``|k_on^B| * T_in`` (the gear-B torque distribution is the only static balance with the
  offgoing torque zero). That is the **handover**;
* the **expected input torque** ``T_in`` at the shift point (the engine/converter match at the
  turbine speed of the upshift line: :func:`~transgen.sim.derive.launch.derive_launch`);
* the **inertia to synchronise**: ``J_eff = sum_i J_i (dw_i / dw_in)^2`` over the links, with
  ``dw_i`` the change of link i's speed from gear A to gear B at a fixed output speed (the
  vehicle hardly changes speed during a shift), and the input's speed change ``dw_in = w_in (1 -
  r_B/r_A)`` (the ratio step);
* the class's **target times**: torque phase ``t_tp`` and inertia phase ``t_ip``.

The template: the oncoming element ramps from zero so that it reaches the handover level
``a_h = lam |k_on^B| T_in / T_dyn`` after ``t_tp`` (``lam``: where the handover lies with the
gearbox accelerating as in the launch, :func:`handover`; 1 at rest) and goes on to the
inertia-phase level ``a_ip = |k_on^B| (T_ip + J_eff dw_in / t_ip) / T_dyn`` (``T_ip`` the mean input
torque of the phase, which the converter raises as the turbine slows; the extra torque
decelerates the input side in ``t_ip``), holds it until the element locks and then applies fully.
The offgoing element drops, when the oncoming ramp starts, to ``OFFGOING_MARGIN`` times the
static level that holds its torque before the shift and falls linearly to zero a little
(``RELEASE_LEAD`` of the torque phase) *before* the handover: its capacity stays above the torque
it must still carry until shortly before, so it never holds against the oncoming element (bindup)
and lets go while the input torque it leaves uncarried is a few percent (a flare of some rpm).
Where the inertia-phase level would exceed :data:`MAX_LEVEL`, the level is capped and the inertia
phase lasts longer. Several oncoming (offgoing) elements of a double swap share one profile: the
largest level of them. A one-way clutch needs no command; a dog clutch (no finite capacity)
holds at any apply, so only its release time matters.

Downshifts use the same pieces: :func:`coast_downshift_calibration` (power-off, torque phase
first: the upshift method with the engine's drag as the input torque) and
:func:`kickdown_calibration` (power-on, speed phase first: the slipping offgoing element holds
what the flare does not need to raise ``J_eff`` by ``dw`` in ``t_ip``).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, fields

import numpy as np

from transgen.graph import build_graph

from transgen.kinematics import link_speeds
from transgen.model import Mechanism
from transgen.own_converter import converter_drive, own_converter

from ..control.schedule import ShiftTemplate

__all__ = ["ShiftTiming", "UpshiftCalibration", "upshift_calibration", "synchronised_inertia",
           "OFFGOING_MARGIN", "RELEASE_LEAD", "MAX_LEVEL", "EASE_SLIP", "EASE_RESIDUAL", "ease", "coast_downshift_calibration", "kickdown_calibration",
           "KickdownCalibration", "SYNC_FILL", "FLARE_RAMP"]

OFFGOING_MARGIN = 2.0
"""Offgoing static capacity over the torque it carries while the torque is handed over."""
RELEASE_LEAD = 0.1
"""Fraction of the torque phase by which the offgoing apply reaches zero before the handover."""
MAX_LEVEL = 0.95
"""Highest inertia-phase apply level (a reserve to full apply)."""
MIN_LEVEL = 1e-4
"""Lowest handover level (a floor for an oncoming element with no static torque share)."""
EASE_SLIP = 0.5
"""Fraction of the oncoming slip at the command at which an upshift's inertia phase eases."""
EASE_RESIDUAL = 0.1
"""Share of the inertia-phase torque above the static share that the eased oncoming level keeps
(the slip deceleration at the lock, relative to the inertia phase's: docs/calibration.md)."""


def _calibration_data(calibration) -> dict:
    """A shift calibration record as plain data, its fields in declared order: ``source`` and
    ``target`` named ``from`` and ``to``, the template as its own data."""
    rename = {"source": "from", "target": "to"}
    data = {rename.get(f.name, f.name): getattr(calibration, f.name) for f in fields(calibration)}
    data["template"] = calibration.template.as_data()
    return data


@dataclass(frozen=True)
class ShiftTiming:
    """Target times of a vehicle class's upshifts [s]: ``fill`` (oncoming stroke, no torque),
    ``torque_phase`` (the handover), ``inertia_phase`` (the speed change), ``final`` (ramp to
    full apply after the lock)."""

    fill: float = 0.05
    torque_phase: float = 0.2
    inertia_phase: float = 0.4
    final: float = 0.2


@dataclass(frozen=True)
class UpshiftCalibration:
    """The derived numbers of one upshift and its template. Torques in N*m, speeds in rad/s,
    inertia in kg*m^2, times in s, levels as fractions of full apply."""

    source: str
    target: str
    input_torque: float
    input_speed: float
    speed_change: float
    inertia: float
    handover_level: float
    inertia_level: float
    offgoing_level: float
    inertia_phase: float
    template: ShiftTemplate

    def as_data(self) -> dict:
        return _calibration_data(self)


def synchronised_inertia(mech: Mechanism, source: tuple[str, ...], target: tuple[str, ...], graph=None) -> float:
    """Inertia [kg*m^2] referred to the input that a shift from the gear ``source`` to ``target``
    (engaged elements) speeds up or slows down at a fixed output speed: ``sum J_i (dw_i/dw_in)^2``
    with ``dw_i`` the change of link i's speed per unit output speed between the two gears. A
    member that floats in either gear is counted with the speed of the other (its own inertia
    moves it freely). Where the mechanism models its own converter (:mod:`transgen.own_converter`)
    the input is the turbine: the pump (engine) link keeps its speed behind the open converter and
    is not counted."""
    a, b = link_speeds(mech, source, graph), link_speeds(mech, target, graph)
    own = own_converter(mech)
    pump = own.pump if own is not None else None
    out = mech.output
    ra, rb = 1.0 / a[out], 1.0 / b[out]  # input/output ratios
    d_in = ra - rb
    if abs(d_in) < 1e-12:
        return 0.0
    total = 0.0
    for link in mech.links:
        wa, wb = a.get(link.name), b.get(link.name)
        if wa is None or wb is None or link.name == pump:
            continue
        total += link.inertia * ((wa * ra - wb * rb) / d_in) ** 2
    return total


def handover(mech: Mechanism, source_engaged, oncoming: dict, offgoing, input_torque: float,
             output_accel: float = 0.0, graph=None) -> tuple[float, dict]:
    """``(lam, before)``: the handover of a torque phase from the gear ``source_engaged`` with the
    gearbox accelerating as in that gear (output link ``output_accel`` [rad/s^2]).

    In the torque-phase mode (the source gear's elements locked, the oncoming ones slipping) every
    locked torque is linear in the input torque, the output torque and the oncoming torques
    (:func:`transgen.modes.mode_model`). The oncoming elements carry ``lam`` times their gear-B
    static torque ``oncoming[e] * input_torque``; the output torque is the one that keeps the
    output's acceleration. ``lam`` is the smallest value at which an offgoing element's torque
    vanishes (1 at zero acceleration: the statics), ``before`` each offgoing element's torque
    [N*m] at ``lam = 0`` (before the shift). With the mechanism's own converter
    (:mod:`transgen.own_converter`) the mode is the converter drive's and ``input_torque`` the
    turbine's: the pump link's inertia is not accelerated with the gearbox."""
    from transgen.graph import link_nodes
    from transgen.modes import Mode, mode_model

    g = graph if graph is not None else build_graph(mech)
    # a mechanism with its own converter: the torque phase runs in converter drive (the lock-up
    # open, the pump link with the engine outside the gearbox), the input torque is the turbine's
    own = own_converter(mech)
    engaged = converter_drive(source_engaged, own)
    model = mode_model(mech, Mode("torque phase", tuple(engaged)), g)
    eq = model.equations
    names = list(eq.u)
    i_out = list(link_nodes(g)).index(mech.output)
    base = np.zeros(len(names))
    base[names.index(own.turbine_torque if own is not None else "T_in")] = input_torque
    e_out = np.zeros(len(names))
    e_out[names.index("T_out")] = 1.0
    e_on = np.zeros(len(names))
    for name, k in oncoming.items():
        e_on[names.index(f"t_{name}")] = k * input_torque
    acc, clu = np.asarray(eq.G_accel, float), np.asarray(eq.G_clutches, float)
    a0, a1, a2 = acc[i_out] @ base, acc[i_out] @ e_out, acc[i_out] @ e_on
    if abs(a1) < 1e-12:
        raise ValueError("the output torque does not act on the output in the torque phase")
    lams, before = [], {}
    for name in offgoing:
        if name not in model.locked:
            continue
        row = clu[list(model.locked).index(name)]
        b0, b1, b2 = row @ base, row @ e_out, row @ e_on
        t0 = b0 + b1 * (output_accel - a0) / a1
        before[name] = float(t0)
        slope = b2 - b1 * a2 / a1
        if abs(slope) > 1e-12 and -t0 / slope > 0:
            lams.append(-t0 / slope)
    return (float(min(lams)) if lams else 1.0), before


def _capacity(mech: Mechanism, name: str, kind: str) -> float:
    e = mech.element(name)
    value = getattr(e, kind, None)
    return float(value) if value is not None and math.isfinite(value) and value > 0 else math.inf


def upshift_calibration(mech: Mechanism, source, target, oncoming: tuple[str, ...], offgoing: tuple[str, ...],
                        input_torque: float, input_speed: float, timing: ShiftTiming = ShiftTiming(),
                        graph=None, output_accel: float = 0.0, torque_after: float | None = None,
                        extra_inertia: float = 0.0, torque_end: float | None = None,
                        eases: bool = True) -> UpshiftCalibration:
    """The calibration of the upshift from ``source`` to ``target`` (:class:`~transgen.sim.derive.launch.ForwardGear`:
    ratio, engaged elements, static torque factors) with the commanded ``oncoming`` and
    ``offgoing`` elements, at the expected input torque ``input_torque`` [N*m] and input speed
    ``input_speed`` [rad/s] at the shift command, the output link's acceleration there
    ``output_accel`` [rad/s^2] (the handover, :func:`handover`) and the input torque expected at
    the end of the inertia phase ``torque_after`` [N*m] (None: ``input_torque``) and an inertia
    ``extra_inertia`` [kg*m^2] outside the gearbox that the input's speed change moves too (0 for
    an upshift: the converter leaves the engine at its speed) and the input torque expected when the
    slip closes ``torque_end`` [N*m] (None: the inertia phase's mean), the static share the
    easing keeps (:func:`ease`; ``eases`` False: no easing); see the module docstring."""
    t_in = max(float(input_torque), 1e-6)
    # the input's speed change at a fixed output speed (an upshift slows it, a downshift raises it)
    dw = max(float(input_speed), 0.0) * abs(1.0 - target.ratio / source.ratio)
    j_eff = synchronised_inertia(mech, source.engaged, target.engaged, graph) + max(float(extra_inertia), 0.0)

    def level(names, factors, torque, kind):
        levels = [abs(factors.get(n, 0.0)) * torque / _capacity(mech, n, kind) for n in names]
        return max(levels, default=0.0)

    factors = {n: target.torque_factors.get(n, 0.0) for n in oncoming}
    lam, before = handover(mech, source.engaged, factors, offgoing, t_in, output_accel, graph)
    a_h = max(lam * level(oncoming, target.torque_factors, t_in, "dynamic"), MIN_LEVEL)
    # in the inertia phase the input torque rises towards the converter's at the new gear's turbine
    # speed (``torque_after``): its mean over the phase
    t_ip_in = 0.5 * (t_in + max(t_in, float(torque_after))) if torque_after is not None else t_in
    a_ip = level(oncoming, target.torque_factors, t_ip_in + j_eff * dw / timing.inertia_phase, "dynamic")
    a_ip = min(max(a_ip, 1.05 * a_h), MAX_LEVEL)
    # the inertia phase at the level reached: J dw / (extra torque referred to the input)
    a_static = level(oncoming, target.torque_factors, t_ip_in, "dynamic")
    extra = (a_ip / a_static - 1.0) * t_ip_in if a_static > 0 else 0.0
    t_ip = j_eff * dw / extra if extra > 0 else timing.inertia_phase
    off = max((abs(t) / _capacity(mech, n, "static") for n, t in before.items()), default=0.0)
    off_level = min(1.0, OFFGOING_MARGIN * off) if off > 0 else 1.0  # a dog holds at any apply
    ramp_time = timing.torque_phase * a_ip / a_h
    # the end of the inertia phase eased: the static share at the torque expected there
    a_end = level(oncoming, target.torque_factors, t_ip_in if torque_end is None else max(float(torque_end), 0.0),
                  "dynamic")
    ease_level, ease_time, longer = ease(a_ip, a_static, a_end, t_ip) if eases else (0.0, 0.0, 0.0)
    template = ShiftTemplate(
        fill_time=timing.fill, fill_level=0.0, ramp_time=_round(ramp_time), ramp_end=_round(a_ip),
        hold_time=_round(max(1.5 * t_ip, 0.1) + longer), final_time=timing.final, offgoing_delay=0.0,
        offgoing_level=_round(off_level), offgoing_ramp=_round(timing.torque_phase * (1.0 - RELEASE_LEAD)),
        **({"ease_slip": EASE_SLIP, "ease_time": _round(ease_time), "ease_level": _round(ease_level)}
           if ease_time > 0 else {}))
    return UpshiftCalibration(source.name, target.name, t_in, float(input_speed), dw, j_eff, a_h, a_ip, off_level,
                              t_ip, template)


def ease(inertia_level: float, static_level: float, end_level: float, inertia_phase: float) -> tuple[float, float, float]:
    """``(ease_level, ease_time [s], longer [s])``: how an upshift eases the end of its inertia
    phase (:data:`EASE_SLIP`, :data:`EASE_RESIDUAL`; docs/calibration.md). The oncoming element
    at ``inertia_level`` carries the static share ``static_level`` plus the inertia torque that
    closes the slip in ``inertia_phase``; eased, it carries the static share at the phase's end
    ``end_level`` plus :data:`EASE_RESIDUAL` of that inertia torque, so the slip deceleration
    at the lock is about that share of the phase's. The ramp to it lasts until the slip is
    expected to close: the slip falls linearly in rate from ``a`` to ``EASE_RESIDUAL a``, so
    ``EASE_SLIP s0 = (1 + EASE_RESIDUAL) a T / 2`` with ``a = s0 / t_ip``; ``longer`` is what
    that adds to the inertia phase. No easing (``ease_time`` 0) without an inertia torque."""
    inertia = inertia_level - static_level
    if inertia <= 0 or inertia_phase <= 0:
        return 0.0, 0.0, 0.0
    level = min(end_level + EASE_RESIDUAL * inertia, inertia_level)
    ease_time = 2.0 * EASE_SLIP * inertia_phase / (1.0 + EASE_RESIDUAL)
    return level, ease_time, ease_time - EASE_SLIP * inertia_phase


SYNC_FILL = 0.02
"""Apply level [-] of a kickdown's oncoming element while the input flares to synchronism."""
FLARE_RAMP = 2.0
"""A kickdown's offgoing release lasts this many times its inertia phase (nearly a constant level
while the input flares; what is left is released at synchronism)."""


def coast_downshift_calibration(mech: Mechanism, source, target, oncoming, offgoing, drag_torque: float,
                                input_speed: float, timing: ShiftTiming = ShiftTiming(), graph=None,
                                engine_inertia: float = 0.0) -> UpshiftCalibration:
    """A power-off (coast) downshift from ``source`` to ``target``: torque phase first, as an
    upshift under drive is, with the input torque the engine's drag ``drag_torque`` [N*m, its
    magnitude is used]. The statics are linear in the input torque, so the handover is the same
    fraction of the oncoming's gear-B share as under drive; in the inertia phase the oncoming
    element carries the drag and the torque that raises the input by ``w_in (r_B/r_A - 1)``
    against ``J_eff`` in the class's inertia-phase time (:func:`upshift_calibration`), with the
    engine's inertia ``engine_inertia`` added: the input pulls the engine up too (the turbine
    overruns the pump and the converter's torque grows with that slip; counted as if coupled, an
    upper bound - without it the HT-740 truck's 4-3 coast-down took 1.9 s to synchronise). At the
    low speeds of the throttle-0 downshift lines the converter's torque is near zero (the engine
    idles), the handover level tiny and the ramp through it would take seconds: the oncoming ramp
    reaches its inertia-phase level by ``t_tp`` at the latest (there is hardly a torque to hand
    of; a ramp to ``t_tp + t_ip`` synchronised the truck's 4-3 in 1.25 s). It does not ease
    (:func:`ease`): the drag's share is too uncertain to ease to (eased to it plus 0.1 of the
    inertia torque, the 8HP70 car's 4-3 and 2-1 stalled until the hold's end: 1.0 s to
    synchronism, 26-30 m/s^3)."""
    from dataclasses import replace

    cal = upshift_calibration(mech, source, target, oncoming, offgoing, abs(float(drag_torque)), input_speed,
                              timing, graph, extra_inertia=engine_inertia, eases=False)
    ramp = min(cal.template.ramp_time, _round(timing.torque_phase))
    return replace(cal, template=replace(cal.template, ramp_time=ramp))


@dataclass(frozen=True)
class KickdownCalibration:
    """The derived numbers of a power-on downshift (speed phase first) and its template: the
    input torque ``input_torque`` [N*m] (mean over the flare), ``speed_change`` [rad/s],
    ``inertia`` [kg*m^2] referred to the input, ``offgoing_level`` [-] of its dynamic capacity,
    ``inertia_phase`` [s] (the target flare time)."""

    source: str
    target: str
    input_torque: float
    input_speed: float
    speed_change: float
    inertia: float
    offgoing_level: float
    inertia_phase: float
    template: ShiftTemplate

    def as_data(self) -> dict:
        return _calibration_data(self)


def kickdown_calibration(mech: Mechanism, source, target, oncoming, offgoing, input_torque: float,
                         input_speed: float, timing: ShiftTiming = ShiftTiming(), graph=None,
                         torque_after: float | None = None) -> KickdownCalibration:
    """A power-on downshift (kickdown) from ``source`` to ``target`` (speed phase first,
    :mod:`.schedule`): the input must rise by ``dw = w_in (r_B/r_A - 1)`` against the inertia
    ``J_eff`` (:func:`synchronised_inertia`) in the class's inertia-phase time ``t_ip``, so the
    offgoing element, slipping, holds the rest of the input torque: its level is
    ``|k_off^A| (T_in - J_eff dw / t_ip) / T_dyn`` (``T_in`` the mean of the turbine torque
    before, ``input_torque``, and at synchronism, ``torque_after``), released linearly over
    :data:`FLARE_RAMP` x ``t_ip`` (raised so that its mean over ``t_ip`` is that level). The
    oncoming element fills at :data:`SYNC_FILL` and is applied at synchronism (when its slip is
    down to :data:`~.schedule.SYNC_FRACTION` of what it was, about ``SYNC_FRACTION t_ip`` before
    synchronism at the flare's rate), ramping to full so that it reaches 1.2 x its static share
    in gear B, ``|k_on^B| T_in / T_dyn``, by synchronism (at most over the class's ``final``
    time): an element sized close to the torque needs a fast ramp or the input overshoots. The
    jerk at the lock is the inertia torque ``J_eff dw / t_ip`` handed to the
    output, so sizing the flare for ``t_ip`` (not as fast as the engine can) is what keeps it low."""
    t_in = max(float(input_torque), 1e-6)
    t_mean = 0.5 * (t_in + max(float(torque_after), 0.0)) if torque_after is not None else t_in
    dw = max(float(input_speed), 0.0) * abs(target.ratio / source.ratio - 1.0)
    j_eff = synchronised_inertia(mech, source.engaged, target.engaged, graph)
    t_ip = timing.inertia_phase
    held = max(t_mean - j_eff * dw / t_ip, 0.0)
    ramp = FLARE_RAMP * t_ip
    mean = 1.0 - t_ip / (2.0 * ramp)  # mean of the linear release over t_ip
    levels = [abs(source.torque_factors.get(n, 0.0)) * held / _capacity(mech, n, "dynamic") / mean for n in offgoing]
    off = min(max(levels, default=0.0), 1.0)
    from ..control.schedule import SYNC_FRACTION

    share = max((abs(target.torque_factors.get(n, 0.0)) * t_mean / _capacity(mech, n, "dynamic") for n in oncoming),
                default=0.0)
    final = timing.final
    if 1.2 * share > SYNC_FILL:
        final = min(final, max((1.0 - SYNC_FILL) * SYNC_FRACTION * t_ip / (1.2 * share - SYNC_FILL), 0.02))
    template = ShiftTemplate(
        fill_time=timing.fill, fill_level=SYNC_FILL, ramp_time=_round(t_ip), ramp_end=_round(MAX_LEVEL),
        hold_time=_round(t_ip), final_time=_round(final), offgoing_delay=0.0,
        offgoing_level=_round(max(off, 1e-3)), offgoing_ramp=_round(ramp))
    return KickdownCalibration(source.name, target.name, t_mean, float(input_speed), dw, j_eff, off, t_ip, template)


def _round(x: float) -> float:
    """Four significant digits (the scenario file's numbers stay readable)."""
    return float(f"{x:.4g}")
