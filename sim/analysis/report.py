"""The shift-quality report of a simulation result: readable text and a JSON-ready dict.

The public entry point of the shift analysis: :func:`shift_report` measures every shift (torque
and inertia phase, torque hole, bindup, flare, element energies, comfort: acceleration, jerk,
VDV, overshoot, settling, lock/unlock counts; the definitions are in
:mod:`transgen.sim.analysis.shift_quality`), :func:`infer_shifts` finds the shifts when none are given
(:mod:`transgen.sim.analysis.shifts`), :func:`energy_balance` checks the run's energy balance, and
:func:`report_text` / :func:`report_dict` put the shift numbers, the energy balance and the run
statistics into a text report (one table per shift, units in the headers) or a JSON-ready dict.
Times in s, torques in N*m, speeds in rad/s, energies in J, powers in W.
"""
from __future__ import annotations

import math

from transgen.names import locked_text

from ..core.result import Result
from .shift_quality import (BINDUP_FRACTION, FLARE_FRACTION, ONSET_FRACTION, OVERLAP_FRACTION, OVERLAP_MIN,
                            POST_WINDOW, PRE_WINDOW, RAMP_TOL, RATIO_TOL, RPM_PER_RAD_S, SETTLE_FRACTION, ShiftQuality,
                            jsonable, shift_report)
from .shifts import Shift, infer_shifts

__all__ = [
    "Shift",
    "ShiftQuality",
    "shift_report",
    "simulate_units",
    "infer_shifts",
    "energy_balance",
    "report_text",
    "report_dict",
    "RPM_PER_RAD_S",
]

ENERGY_TOL = 1e-3  # energy residual tolerance, relative to the input work


def energy_balance(result: Result, tolerance: float = ENERGY_TOL) -> dict:
    """The run's energy balance (``work_in = stored_change + dissipated + work_to_load +
    residual``) with ``passed``: ``|residual| <= tolerance * |work_in|`` (0.1 % by default)."""
    out = {k: float(v) for k, v in (result.energy or {}).items() if not isinstance(v, dict)}
    if "residual" not in out or "work_in" not in out:
        out.update({"tolerance": None, "passed": False, "note": "no energy balance in the result"})
        return out
    limit = tolerance * abs(out["work_in"])
    out["tolerance"] = limit
    out["tolerance_relative"] = tolerance
    out["passed"] = bool(abs(out["residual"]) <= limit)
    return out


# ------------------------------------------------------------------------------ text
def _f(x, fmt=".3f", unit=""):
    if x is None or (isinstance(x, float) and not math.isfinite(x)):
        return "-"
    return f"{x:{fmt}}{(' ' + unit) if unit else ''}"


def _shift_text(q: ShiftQuality, downshift: dict | None = None) -> str:
    lines = [f"Shift {q.name}{' (' + q.direction + ')' if q.direction else ''}: oncoming {q.oncoming}, "
             f"offgoing {q.offgoing}, command at {q.t_start:.3f} s"
             + ("" if q.completed else "  (NOT COMPLETED)"),
             f"  {'phase':<24}{'start [s]':>11}{'end [s]':>11}{'duration [s]':>14}"]
    rows = [("torque phase", q.torque_phase_start, q.torque_phase_end, q.torque_phase_duration),
            ("inertia (speed) phase", q.inertia_phase_start, q.inertia_phase_end, q.inertia_phase_duration),
            ("whole shift", min([x for x in (q.torque_phase_start, q.inertia_phase_start) if x is not None],
                                default=q.t_start), q.shift_end if q.completed else None, q.shift_duration)]
    for label, a, b, d in rows:
        lines.append(f"  {label:<24}{_f(a):>11}{_f(b):>11}{_f(d):>14}")
    lines.append(f"  speed ratio {q.input_link}/{q.output_link}: {_f(q.ratio_before, '.4f')} -> "
                 f"{_f(q.ratio_after, '.4f')}")
    kv = [
        ("output torque before", f"{q.output_torque_before:.1f} N*m (mean over {PRE_WINDOW:g} s before the command)"),
        ("torque hole", f"{q.torque_hole:.1f} N*m = {_f(q.torque_hole_pct, '.1f')} % "
                        f"(minimum {q.output_torque_min:.1f} N*m at {q.output_torque_min_time:.3f} s)"),
        ("output torque peak", f"{q.output_torque_max:.1f} N*m at {q.output_torque_max_time:.3f} s "
                               f"({_f(q.output_torque_overshoot_pct, '+.1f')} %)"),
        ("bindup", (f"YES - {q.offgoing} torque reversed: {q.bindup_torque:.1f} N*m opposite for "
                    f"{q.bindup_duration:.3f} s" if q.bindup else f"no (opposite torque {q.bindup_torque:.1f} N*m)")
         + f"; {q.offgoing} torque {q.offgoing_torque_before:.1f} N*m before, "
           f"{_f(q.offgoing_torque_at_unlock, '.1f', 'N*m')} at unlock"),
        ("flare", (f"YES - {q.input_link} {q.flare_max:.2f} rad/s = {q.flare_max_rpm:.1f} rpm above its "
                   f"pre-shift trajectory at {_f(q.flare_time)} s" if q.flare else
                   f"no (max excess {q.flare_max:.3f} rad/s = {q.flare_max_rpm:.2f} rpm)")),
        ("oncoming apply ramp", "no ramp during the shift" if q.oncoming_ramp_end is None else
         f"final {q.oncoming_apply_final:.3g} reached at {_f(q.oncoming_ramp_end)} s; "
         + (f"speed phase ran {q.speed_phase_overrun:.3f} s PAST the ramp end"
            if q.speed_phase_past_ramp else "locked within the ramp")),
        ("both dissipating", f"{q.both_dissipating_duration:.3f} s; {q.offgoing} took "
                             f"{q.offgoing_energy_share:.2f} % of the element energy"),
        ("offgoing after lock", f"{q.offgoing} slipped {q.offgoing_drag_after_lock:.3f} s after {q.oncoming} "
                                f"locked, {q.offgoing_energy_after_lock:.1f} J (dissipation ends at "
                                f"{q.dissipation_end:.3f} s)"),
        ("forced unlock", (f"YES - {q.forced_unlock_element} unlocked while fully applied and slipped: forced by "
                           f"{q.oncoming} over its static capacity (reversed overlap {q.forced_duration:.3f} s)"
                           if q.forced_unlock else
                           f"no (reversed overlap {q.forced_duration * 1e3:.1f} ms)")),
    ]
    if downshift is not None:
        from .downshift_quality import downshift_text

        kv.append(("synchronism", downshift_text(downshift, q)))
    if q.torque_request_min is not None:
        parts = ([f"up to x{q.torque_request_max:.3f} for {q.torque_increase_duration:.3f} s"]
                 if q.torque_request_max > 1.0 else [])
        parts += ([f"down to x{q.torque_request_min:.3f} for {q.torque_reduction_duration:.3f} s"]
                  if q.torque_request_min < 1.0 else [])
        kv.append(("engine torque request", ", ".join(parts) + " (factor on the engine torque)" if parts else
                   "none (factor 1)"))
    kv += _comfort_rows(q)
    for k, v in kv:
        lines.append(f"  {k:<24}{v}")
    lines.append(f"  {'element':<10}{'energy [J]':>14}{'peak power [W]':>17}{'peak T [degC]':>15}{'rise [K]':>10}   "
                 f"({q.t_start:.3f}-{q.dissipation_end:.3f} s)")
    for e in q.energy:
        mark = " (on)" if e == q.oncoming else (" (off)" if e == q.offgoing else "")
        lines.append(f"  {e + mark:<10}{q.energy[e]:>14.1f}{q.peak_power.get(e, 0.0):>17.1f}"
                     f"{_f(q.temperature_peak.get(e), '.1f'):>15}{_f(q.temperature_rise.get(e), '.1f'):>10}")
    lines.append(f"  {'total':<10}{q.energy_total:>14.1f}")
    lines += _losses_text(q.losses, "", "  losses ")
    for n in q.notes:
        lines.append(f"  note: {n}")
    return "\n".join(lines)


def _comfort_rows(q: ShiftQuality) -> list[tuple[str, str]]:
    """The comfort figures of a shift as (label, text) rows."""
    window = f"{q.t_start:.3f}-{q.window_end:.3f} s"
    if q.vdv is None:
        rows = [("vehicle acceleration", "- (no vehicle in the run)")]
    else:
        rows = [("vehicle acceleration", f"{_f(q.accel_before, '.3f')} m/s^2 before -> {_f(q.accel_after, '.3f')} "
                                         f"m/s^2 after (mean to {q.window_end:.3f} s)"),
                ("jerk", f"max |jerk| {_f(q.jerk_max, '.2f')} m/s^3 at {_f(q.jerk_max_time)} s, peak-to-peak "
                         f"{_f(q.jerk_peak_to_peak, '.2f')} m/s^3 ({window}); filtered (10 Hz low-pass) "
                         f"max {_f(q.jerk_filtered_max, '.2f')} m/s^3"),
                ("vibration dose value", f"{q.vdv:.4f} m/s^1.75 ("
                                         + ("unweighted" if q.vdv_weighting == "none" else f"ISO 2631-1 {q.vdv_weighting}")
                                         + f", {window})")]
    rows.append(("output torque after", f"{_f(q.output_torque_final, '.1f', 'N*m')} (final), overshoot "
                                        f"{_f(q.torque_overshoot, '.1f', '%')} of it, settles within "
                                        f"{SETTLE_FRACTION:.0%} after {_f(q.settling_time, '.3f', 's')}"))
    changes = ", ".join(f"{e} {q.lock_counts.get(e, 0)}/{q.unlock_counts.get(e, 0)}" for e in q.lock_counts
                        if q.lock_counts.get(e, 0) or q.unlock_counts.get(e, 0)) or "none"
    rows.append(("locks/unlocks", f"{changes} ({window}); chatter: {'YES' if q.chatter else 'no'}"))
    return rows


def _mode_text(name: str, locked) -> str:
    """A mode's name with its locked elements when the name does not say them: ``2 [C1+C4]``."""
    text = locked_text(locked)
    return name if name == text else f"{name} [{text}]"


def _invariants_text(summary: dict | None) -> list[str]:
    """The invariant monitor's summary (:meth:`~transgen.sim.solve.monitor.InvariantMonitor.summary`):
    which invariants were checked, how often, and the worst margin (1 = at the tolerance)."""
    if not summary:
        return ["", "Invariants: NOT checked (the monitor was switched off)"]
    lines = ["", f"Invariants checked on {summary['segments']} segments (worst = violation measure / tolerance, "
                 f"a run stops above 1)"]
    for name, v in summary["invariants"].items():
        lines.append(f"  {name:<24}{v['checks']:>10} checks   worst {v['worst']:9.3g}")
    return lines


def report_text(result: Result, qualities: list[ShiftQuality] | None = None) -> str:
    """A readable report: one table per shift (units in the headers), the energy balance and the
    run statistics."""
    if qualities is None:
        qualities = shift_report(result)
    meta = result.meta or {}
    head = [f"Shift report: {meta.get('mechanism', '')} ({meta.get('model', '')} model)",
            f"run {'completed' if result.success else 'FAILED'}: {result.message}",
            f"time {float(result.time[0]):.3f} .. {float(result.time[-1]):.3f} s, {len(result.time)} samples"
            if len(result.time) else "no samples", ""]
    from .downshift_quality import downshift_figures

    body = [_shift_text(q, downshift_figures(result, q)) + "\n" for q in qualities] or ["no shifts found\n"]
    eb = energy_balance(result)
    bal = ["Energy balance [J]"]
    for k in ("work_in", "stored_change", "dissipated", "work_to_load", "residual"):
        if k in eb:
            bal.append(f"  {k:<24}{eb[k]:>16.6g}")
    if "relative_residual" in eb:
        bal.append(f"  {'relative residual':<24}{eb['relative_residual']:>16.3e}")
    bal.append(f"  {'check':<24}{'PASS' if eb.get('passed') else 'FAIL'} "
               f"(|residual| <= {ENERGY_TOL:.1%} of the input work)")
    bal += _losses_text((result.energy or {}).get("losses"), "Losses over the run [J] (within dissipated)")
    bal += _thermal_text(result)
    stats = _invariants_text((result.stats or {}).get("invariants")) + ["", "Run statistics"]
    units = {"wall_time": "s"}
    for k, v in (result.stats or {}).items():
        if k == "invariants":
            continue
        stats.append(f"  {k:<24}{(f'{v:.4g}' if isinstance(v, float) else str(v)):>16} {units.get(k, '')}".rstrip())
    modes = [f"{_mode_text(m.name, m.locked)} {m.t0:.3f}-{m.t1:.3f} s" for m in result.modes]
    if modes:
        stats.append(f"  {'modes':<24}" + ", ".join(modes))
    return "\n".join(head + body + bal + stats) + "\n"


def _losses_text(losses: dict | None, title: str, indent: str = "  ") -> list[str]:
    """The loss energies by kind (:func:`~transgen.sim.model.losses.loss_energy`) as lines."""
    if not losses:
        return []
    lines = ["", title] if title else []
    for e, x in losses["drag"].items():
        lines.append(f"{indent}{'drag ' + e:<24}{x:>16.6g}")
    for k in ("spin", "pump", "mesh", "total"):
        if k in losses:
            lines.append(f"{indent}{k:<24}{losses[k]:>16.6g}")
    return lines


def _clutch_temperatures(result: Result) -> dict | None:
    """The peak pack temperature per element over the run (:mod:`transgen.losses.thermal`)."""
    if len(result.time) < 2 or not any(k.startswith("P_") for k in result.signals):
        return None
    from transgen.losses.thermal import clutch_temperatures

    return clutch_temperatures(result).summary()


def _thermal_text(result: Result) -> list[str]:
    summary = _clutch_temperatures(result)
    if summary is None:
        return []
    lines = ["", f"Clutch temperatures (lumped one-node packs, oil {summary['oil_temperature']:g} degC; "
                 f"docs/losses.md)"]
    for e, v in summary["elements"].items():
        lines.append(f"  {e:<10} peak {v['peak']:8.1f} degC at {v['peak_time']:8.3f} s, final {v['final']:7.1f} degC  "
                     f"(pack {v['pack']['name']}: m c {v['pack']['heat_capacity']:.0f} J/K, tau "
                     f"{_f(v['pack']['time_constant'], '.1f', 's')})")
    return lines


def simulate_units(turbo: bool = False) -> dict[str, str]:
    """Units of the numeric fields of ``transgen simulate --json`` (the summary, the report and,
    for a turbocharged run, the turbocharger figures)."""
    from .cycle_report import CYCLE_UNITS
    from .downshift_quality import DOWNSHIFT_UNITS
    from .shift_quality import SHIFT_UNITS

    units = {"t": "s", "t0": "s", "t1": "s", "t_start": "s", "t_end": "s", "work_in": "J", "stored_change": "J",
             "dissipated": "J", "work_to_load": "J", "residual": "J", "relative_residual": "1", "tolerance": "J",
             "tolerance_relative": "1", "wall_time": "s", "rhs_evaluations": "1", "input_evaluations": "1", "events": "1", "segments": "1",
             "onset_fraction": "1", "ratio_tol": "1", "bindup_fraction": "1", "flare_fraction": "1", "ramp_tol": "1",
             "overlap_fraction": "1", "energy_tol": "1", "peak": "degC", "peak_time": "s", "final": "degC",
             "oil_temperature": "degC", "mass": "kg", "specific_heat": "J/(kg*K)", "conductance": "W/K",
             "heat_capacity": "J/K", "time_constant": "s"} | CYCLE_UNITS | SHIFT_UNITS | DOWNSHIFT_UNITS
    if turbo:
        from ..engine.turbo_report import TURBO_UNITS

        units |= TURBO_UNITS
    return units


def _shift_dict(result: Result, q: ShiftQuality) -> dict:
    """A shift's JSON: its :class:`ShiftQuality` and, for a downshift, ``downshift``
    (:mod:`.downshift_quality`)."""
    from .downshift_quality import downshift_figures

    out = q.to_dict()
    figures = downshift_figures(result, q)
    if figures is not None:
        out["downshift"] = figures
    return out


def report_dict(result: Result, qualities: list[ShiftQuality] | None = None) -> dict:
    """JSON-ready report: run status, shifts, energy balance, run statistics."""
    if qualities is None:
        qualities = shift_report(result)
    meta = result.meta or {}
    return jsonable({
        "mechanism": meta.get("mechanism", ""),
        "model": meta.get("model", ""),
        "success": result.success,
        "message": result.message,
        "t_start": float(result.time[0]) if len(result.time) else None,
        "t_end": float(result.time[-1]) if len(result.time) else None,
        "thresholds": {"pre_window_s": PRE_WINDOW, "onset_fraction": ONSET_FRACTION, "ratio_tol": RATIO_TOL,
                       "bindup_fraction": BINDUP_FRACTION, "flare_fraction": FLARE_FRACTION,
                       "ramp_tol": RAMP_TOL, "overlap_fraction": OVERLAP_FRACTION, "overlap_min_s": OVERLAP_MIN,
                       "energy_tol": ENERGY_TOL, "post_window_s": POST_WINDOW, "settle_fraction": SETTLE_FRACTION},
        "shifts": [_shift_dict(result, q) for q in qualities],
        "energy_balance": energy_balance(result),
        "clutch_temperature": _clutch_temperatures(result),
        "stats": dict(result.stats or {}),
        "modes": [m.to_dict() for m in result.modes],
    })
