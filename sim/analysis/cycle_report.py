"""The drive-cycle report: how the driver followed the trace, the shifts by kind, the energies.

For a run with a :class:`~.driver.Driver` (``scenario new --maneuver cycle``):

* tracking by the WLTP rule (:func:`~.cycles.tracking`: +-2 km/h, +-1 s) over the run, with the
  RMS and largest speed error against the trace at the same time;
* shifts: the schedule's commands (its ``command`` events, :mod:`.schedule`) counted by
  direction and power: ``upshift``/``downshift`` x ``power-on``/``power-off``;
* energies [J], trapezoidal integrals of the run's signals: the engine's work (``E_in``), the
  work at the wheels (the driveshaft torque times the vehicle-side speed, ``T_out * omega_v``:
  ``wheels_positive`` the traction, ``wheels_negative`` what the vehicle gives back to the
  gearbox, engine braking), the wheel brakes (``P_brake``), the road load (``road_torque *
  omega_v``), the shift elements (each ``P_<element>``, their sum ``clutches``) and the torque
  converter (``T_pump * omega_engine - T_in * w_input``); with ``[losses]`` the transmission's
  losses by kind (``drag_<element>``, ``loss_spin``, ``loss_pump``, ``loss_mesh``, ``loss_total``:
  the loss integrals of :func:`~transgen.sim.model.losses.loss_energy`);
* fuel [kg] where the engine gives a fuel flow (``m_dot_fuel``: the turbodiesel's, or an engine
  torque map's with ``[input] fuel_map``, :mod:`.fuel`), else None; with the fuel's density
  (:func:`.fuel.fuel_of`) its volume [L] and the consumption [L/100 km] over the distance driven,
  and ``fuel_source`` says where the flow comes from (a measured map or the Willans estimate);
* the distance [m] driven and the trace's, and the run's wall time [s].
"""
from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np

from ..control.cycles import SpeedTrace, Tracking, tracking
from ..core.result import Result
from ..model.losses import loss_energy

__all__ = ["CycleReport", "cycle_report", "cycle_text", "CYCLE_UNITS", "SHIFT_KINDS"]

SHIFT_KINDS = ("upshift power-on", "upshift power-off", "downshift power-on", "downshift power-off")
CYCLE_UNITS = {"energy": "J", "fuel": "kg", "fuel_volume": "L", "fuel_per_100km": "L/100 km",
               "distance": "m", "trace_distance": "m", "wall_time": "s", "t0": "s",
               "t1": "s", "outside_time": "s", "worst": "km/h", "worst_time": "s", "rms_error": "km/h",
               "max_error": "km/h", "inside": "1", "shifts": "1"}


@dataclass(frozen=True)
class CycleReport:
    """The figures of a drive-cycle run (module docstring)."""

    trace: str
    tracking: Tracking
    shifts: dict
    shift_total: int
    energy: dict
    fuel: float | None
    distance: float
    trace_distance: float
    wall_time: float | None
    fuel_volume: float | None = None
    fuel_per_100km: float | None = None
    fuel_source: str | None = None

    def to_dict(self) -> dict:
        from .shift_quality import jsonable

        out = asdict(self)
        out["tracking"] = self.tracking.to_dict()
        return jsonable(out)


def _integral(t, y) -> float:
    return float(np.trapezoid(y, t)) if len(t) > 1 else 0.0


def shift_counts(result: Result) -> dict:
    """The schedule's commanded shifts counted by :data:`SHIFT_KINDS`."""
    counts = dict.fromkeys(SHIFT_KINDS, 0)
    for e in result.events:
        if e.kind != "command":
            continue
        for kind in SHIFT_KINDS:
            direction, power = kind.split()
            if e.detail.startswith(f"{direction} ") and e.detail.endswith(f"; {power})"):
                counts[kind] += 1
    return counts


def cycle_report(result: Result, trace: SpeedTrace, input_link: str | None = None,
                 fuel: tuple[float, str] | None = None) -> CycleReport:
    """The :class:`CycleReport` of ``result`` following ``trace``; ``fuel``: the fuel's density
    [kg/m^3] and the source of its flow (:func:`.fuel.fuel_of`), for the volume."""
    t, sig = result.time, result.signals
    v = sig["vehicle_speed"]
    track = tracking(trace, t, v)
    energy = {"engine": float(result.energy.get("work_in", 0.0)) if result.energy else 0.0}
    if "T_out" in sig and "omega_v" in sig:
        p = sig["T_out"] * sig["omega_v"]
        energy["wheels_positive"] = _integral(t, np.maximum(p, 0.0))
        energy["wheels_negative"] = _integral(t, np.minimum(p, 0.0))
    if "P_brake" in sig:
        energy["brakes"] = _integral(t, sig["P_brake"])
    if "road_torque" in sig and "omega_v" in sig:
        energy["road"] = _integral(t, sig["road_torque"] * sig["omega_v"])
    elements = [k[2:] for k in sig if k.startswith("P_") and f"locked_{k[2:]}" in sig]
    per = {e: _integral(t, sig[f"P_{e}"]) for e in elements}
    energy["clutches"] = float(sum(per.values()))
    energy.update({f"element_{e}": x for e, x in per.items()})
    link = input_link or (result.meta or {}).get("input_link")
    if {"T_pump", "omega_engine", "T_in"} <= set(sig) and link and f"w_{link}" in sig:
        energy["converter"] = _integral(t, sig["T_pump"] * sig["omega_engine"] - sig["T_in"] * sig[f"w_{link}"])
    losses = loss_energy(t, sig)
    if losses is not None:  # the transmission's drag, spin, pump and mesh losses (:mod:`..model.losses`)
        energy.update({f"drag_{e}": x for e, x in losses["drag"].items()})
        energy.update({f"loss_{k}": losses[k] for k in ("spin", "pump", "mesh", "total") if k in losses})
    fuel_info = fuel
    fuel = _integral(t, sig["m_dot_fuel"]) if "m_dot_fuel" in sig else None
    counts = shift_counts(result)
    t0, t1 = float(t[0]), float(t[-1])
    inside = (np.asarray(trace.times) >= t0) & (np.asarray(trace.times) <= t1)
    trace_distance = float(np.trapezoid(np.asarray(trace.speeds)[inside], np.asarray(trace.times)[inside]))
    distance = _integral(t, v)
    volume = per_100km = source = None
    if fuel is not None and fuel_info is not None:
        density, source = fuel_info
        volume = 1000.0 * fuel / density
        per_100km = volume / (distance / 1e5) if distance > 0 else None
    return CycleReport(trace.name, track, counts, sum(counts.values()), energy, fuel, distance, trace_distance,
                       (result.stats or {}).get("wall_time"), volume, per_100km, source)


def cycle_text(c: CycleReport) -> str:
    """The report as text."""
    tk = c.tracking
    lines = [f"Drive cycle {c.trace}: {tk.t0:.1f}-{tk.t1:.1f} s, {c.distance / 1000:.3f} km driven "
             f"(trace {c.trace_distance / 1000:.3f} km)",
             f"  tracking (WLTP: +-2 km/h, +-1 s)  {100 * tk.inside:.2f} % of {tk.samples} samples inside; "
             f"{tk.outside_time:.1f} s outside in {tk.violations} interval(s)"
             + (f", worst {tk.worst:.2f} km/h outside at {tk.worst_time:.1f} s" if tk.violations else ""),
             f"  speed error                      RMS {tk.rms_error:.2f} km/h, largest {tk.max_error:.2f} km/h",
             f"  shifts                           {c.shift_total}: " + ", ".join(f"{k} {n}" for k, n in c.shifts.items()),
             "  energy [kJ]"]
    for k, x in c.energy.items():
        lines.append(f"    {k:<30}{x / 1000:>12.1f}")
    if c.fuel is None:
        text = "- (no fuel map: an engine torque map without [input] fuel_map)"
    else:
        text = f"{c.fuel:.4f} kg"
        if c.fuel_volume is not None:
            text += f", {c.fuel_volume:.3f} L"
        if c.fuel_per_100km is not None:
            text += f", {c.fuel_per_100km:.2f} L/100 km"
        if c.fuel_source:
            text += f" ({c.fuel_source})"
    lines.append("  fuel                             " + text)
    if c.wall_time is not None:
        lines.append(f"  run time                         {c.wall_time:.1f} s wall for {tk.t1 - tk.t0:.0f} s simulated")
    return "\n".join(lines)
