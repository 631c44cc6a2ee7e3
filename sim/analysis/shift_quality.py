"""Shift quality of a simulation result (thesis 3.3.1 and 3.4.4): the analysis of each shift.

The phases, the figures of each shift and their definitions: docs/explanation/shift-quality.md.
"""
from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field, replace

import numpy as np

from ..core.result import Result
from ..model.losses import loss_energy
from .comfort import check_weighting, filtered_jerk, jerk, settling_time, vdv, weighted
from .samples import duration_above, integrate, value_at, window
from .shifts import APPLY_ZERO, Shift, infer_shifts, lock_time, lock_times, shift_name

__all__ = [
    "ShiftQuality",
    "shift_report",
    "jsonable",
    "RPM_PER_RAD_S",
    "SHIFT_UNITS",
]

RPM_PER_RAD_S = 60.0 / (2.0 * math.pi)

PRE_WINDOW = 0.2  # s, pre-shift reference window
ONSET_FRACTION = 0.01  # of the oncoming element's peak |torque| in the shift
ZERO_FRACTION = 1e-9  # |t_on| below this fraction of its peak counts as zero (onset trace-back)
RATIO_TOL = 0.005  # relative departure of the speed ratio that starts the speed phase
BINDUP_FRACTION = 0.01  # of the pre-shift |t_off|
BINDUP_MIN = 1.0  # N*m
FLARE_FRACTION = 0.01  # of |w_in(t_start)|
FLARE_MIN = 0.1  # rad/s
RAMP_TOL = 1e-4  # relative, apply at its final value
OVERLAP_FRACTION = 0.01  # of the shift's peak element power
OVERLAP_MIN = 0.005  # s
POST_WINDOW = 2.0  # s after the shift end in the comfort window
SETTLE_FRACTION = 0.05  # of |final output torque|: the settling band
VDV_WEIGHTING = "Wd"  # ISO 2631-1 weighting of the longitudinal (x) acceleration


@dataclass(frozen=True)
class ShiftQuality:
    """Shift-quality numbers of one shift (see the module doc for the definitions). Times in s,
    torques in N*m, speeds in rad/s (``*_rpm`` in rev/min), energies in J, powers in W; ``None``
    where a quantity is undefined (e.g. the oncoming element never locked)."""

    name: str
    oncoming: str
    offgoing: str
    t_start: float
    input_link: str
    output_link: str
    completed: bool  # the oncoming element locked
    direction: str  # "upshift" / "downshift" from the speed ratios, "" if unknown
    # phases
    torque_phase_start: float | None
    torque_phase_end: float | None
    torque_phase_duration: float | None
    inertia_phase_start: float | None
    inertia_phase_end: float | None
    inertia_phase_duration: float | None
    shift_end: float
    shift_duration: float | None
    dissipation_end: float  # the shift end, or later while the offgoing element still slips
    offgoing_unlock: float | None  # when the offgoing element unlocked
    oncoming_lock: float | None  # when the oncoming element locked
    ratio_before: float | None  # input/output speed ratio at t_start
    ratio_after: float | None  # at the shift end
    # output torque
    output_torque_before: float  # mean over the pre-shift window
    output_torque_min: float
    output_torque_min_time: float
    torque_hole: float  # depth [N*m], > 0 is a dip
    torque_hole_pct: float | None  # depth in % of |output_torque_before|
    output_torque_max: float
    output_torque_max_time: float
    output_torque_overshoot_pct: float | None  # (max - before) / |before| in %
    # bindup
    bindup: bool
    bindup_torque: float  # peak offgoing torque opposite to its pre-shift sign [N*m]
    bindup_duration: float  # s
    offgoing_torque_before: float  # mean over the pre-shift window
    offgoing_torque_at_unlock: float | None
    # flare
    flare: bool
    flare_max: float  # rad/s above the pre-shift trajectory
    flare_max_rpm: float
    flare_time: float | None
    # apply ramp
    oncoming_ramp_end: float | None  # oncoming apply reaches its final value
    oncoming_apply_final: float
    speed_phase_past_ramp: bool
    speed_phase_overrun: float  # s the speed phase ran on after the ramp end
    # both elements slipping and dissipating (offgoing forced to unlock)
    both_dissipating_duration: float  # s, both above the power threshold
    forced_duration: float  # s, of that with the offgoing torque reversed
    forced_unlock: bool
    offgoing_energy_share: float  # % of the element energy of the shift
    offgoing_drag_after_lock: float  # s the offgoing element dissipated after the oncoming locked
    offgoing_energy_after_lock: float  # J
    forced_unlock_element: str | None  # the element(s) forced to unlock while fully applied (comma-separated)
    # comfort: the window [t_start, window_end] (the shift and its settling, see the module doc)
    window_end: float
    accel_before: float | None  # m/s^2, mean vehicle acceleration over the pre-shift window
    accel_after: float | None  # m/s^2, mean from the shift end to window_end
    jerk_max: float | None  # m/s^3, max |jerk| in the window
    jerk_max_time: float | None
    jerk_peak_to_peak: float | None  # m/s^3, max jerk - min jerk in the window
    jerk_filtered_max: float | None  # m/s^3, max |jerk| of the 10 Hz low-pass filtered acceleration
    vdv: float | None  # m/s^1.75, vibration dose value of the weighted acceleration over the window
    vdv_weighting: str  # "Wd" (ISO 2631-1, fore-aft), "Wk" (ISO 2631-1, vertical) or "none"
    output_torque_final: float | None  # N*m, mean over the last PRE_WINDOW of the window
    torque_overshoot: float | None  # % of |output_torque_final|: output torque peak above it
    settling_time: float | None  # s after the shift end until T_out stays within 5 % of its final value
    lock_counts: dict = field(hash=False)  # element -> locks in the window
    unlock_counts: dict = field(hash=False)  # element -> unlocks in the window
    chatter: bool  # an element changed its lock state more than once in the window
    # energy
    energy: dict = field(hash=False)  # element -> J dissipated from t_start to dissipation_end
    peak_power: dict = field(hash=False)  # element -> W
    energy_total: float = 0.0
    notes: tuple[str, ...] = ()
    # engine torque intervention in the comfort window (the engine's ``torque_request`` factor [-];
    # None when the run has no torque request)
    torque_request_min: float | None = None  # deepest factor (< 1: a reduction)
    torque_request_max: float | None = None  # highest factor (> 1: an increase)
    torque_increase_duration: float | None = None  # s with the factor above 1
    torque_reduction_duration: float | None = None  # s with the factor below 1
    # pack temperatures of the lumped thermal model (transgen.losses.thermal), element -> value
    temperature_start: dict = field(default_factory=dict, hash=False)  # degC at t_start
    temperature_peak: dict = field(default_factory=dict, hash=False)  # degC, t_start..dissipation_end
    temperature_rise: dict = field(default_factory=dict, hash=False)  # K, peak - start
    # drag, spin, pump and mesh losses from t_start to dissipation_end (transgen.sim.model.losses), J
    losses: dict = field(default_factory=dict, hash=False)

    def to_dict(self) -> dict:
        """JSON-ready (floats, NaN/inf as None); ``losses`` only where the run has losses."""
        out = asdict(self)
        if not out["losses"]:
            del out["losses"]
        return jsonable(out)


_S = ("t_start torque_phase_start torque_phase_end torque_phase_duration inertia_phase_start inertia_phase_end "
      "inertia_phase_duration shift_end shift_duration dissipation_end offgoing_unlock oncoming_lock "
      "output_torque_min_time output_torque_max_time bindup_duration flare_time oncoming_ramp_end "
      "speed_phase_overrun both_dissipating_duration forced_duration offgoing_drag_after_lock pre_window_s "
      "overlap_min_s window_end jerk_max_time settling_time post_window_s torque_increase_duration "
      "torque_reduction_duration").split()
_NM = "output_torque_before output_torque_min torque_hole output_torque_max bindup_torque offgoing_torque_before " \
      "offgoing_torque_at_unlock output_torque_final".split()
SHIFT_UNITS = ({k: "s" for k in _S} | {k: "N*m" for k in _NM}
               | {"ratio_before": "1", "ratio_after": "1", "torque_hole_pct": "%", "output_torque_overshoot_pct": "%",
                  "flare_max": "rad/s", "flare_max_rpm": "rpm", "oncoming_apply_final": "1",
                  "offgoing_energy_share": "%", "offgoing_energy_after_lock": "J", "energy": "J",
                  "peak_power": "W", "energy_total": "J", "accel_before": "m/s^2", "accel_after": "m/s^2",
                  "jerk_max": "m/s^3", "jerk_peak_to_peak": "m/s^3", "jerk_filtered_max": "m/s^3", "vdv": "m/s^1.75", "torque_overshoot": "%",
                  "lock_counts": "1", "unlock_counts": "1", "settle_fraction": "1", "torque_request_min": "1",
                  "torque_request_max": "1", "temperature_start": "degC", "temperature_peak": "degC",
                  "temperature_rise": "K"})
"""Units of the numeric fields of :class:`ShiftQuality` (``energy`` and ``peak_power``: per
element) and of the report's time thresholds."""


def jsonable(x):
    """``x`` made JSON-ready: dict keys as str, tuples as lists, numpy scalars and arrays as Python
    numbers and lists, NaN and inf as None."""
    if isinstance(x, dict):
        return {str(k): jsonable(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [jsonable(v) for v in x]
    if isinstance(x, (bool, np.bool_)):
        return bool(x)
    if isinstance(x, (int, np.integer)):
        return int(x)
    if isinstance(x, (float, np.floating)):
        v = float(x)
        return v if math.isfinite(v) else None
    if isinstance(x, np.ndarray):
        return jsonable(x.tolist())
    return x


# ------------------------------------------------------------------------------ links
def _links(result: Result, input_link: str | None, output_link: str | None) -> tuple[str, str, list[str]]:
    notes = []
    meta = result.meta or {}
    coords = list(meta.get("coordinates") or [])
    links = list(meta.get("links") or [k[2:] for k in result.signals if k.startswith("w_")])
    # the gearbox's input: the turbine where the mechanism models its own converter (the flare of a
    # shift is the turbine's, the engine behind the converter keeps its speed)
    inp = meta.get("gearbox_input") or meta.get("input_link") or input_link
    out = meta.get("output_link") or output_link
    if not inp:
        inp = coords[0] if coords else links[0]
        notes.append(f"input link not recorded in the result: assumed {inp}")
    if not out:
        out = coords[1] if len(coords) > 1 else links[-1]
        notes.append(f"output link not recorded in the result: assumed {out}")
    return inp, out, notes


# ------------------------------------------------------------------------------ one shift
def _pre_trend(t: np.ndarray, y: np.ndarray, t_start: float) -> tuple[float, float]:
    """Value at ``t_start`` (before any event there) and least-squares slope over the pre window."""
    idx = window(t, t_start - PRE_WINDOW, t_start)
    y0 = value_at(t, y, t_start, "left")
    if len(idx) < 2 or np.ptp(t[idx]) <= 0:
        return y0, 0.0
    slope = float(np.polyfit(t[idx], y[idx], 1)[0])
    return y0, slope


def _pre_mean(t: np.ndarray, y: np.ndarray, t_start: float) -> float:
    """Time-average of ``y`` over the pre-shift window (value at ``t_start`` if it is empty)."""
    t0 = max(float(t[0]), t_start - PRE_WINDOW)
    if t_start - t0 <= 0:
        return value_at(t, y, t_start, "left")
    return integrate(t, y, t0, t_start) / (t_start - t0)


def _forced_unlocks(result: Result, elements: list[str], ts: float, t_win: float, unlocks: dict,
                    p_ref: float) -> list[tuple[str, float, float]]:
    """``(element, unlock time, apply)`` of the elements locked at ``ts`` that unlock in the window
    while still fully applied (apply within ``RAMP_TOL`` of its value at ``ts``, above zero) and
    then slip dissipating (power above ``OVERLAP_FRACTION`` of ``p_ref``): driven over their
    static capacity, not released (a one-way clutch overrunning dissipates nothing)."""
    t, sig = result.time, result.signals
    out = []
    for e in elements:
        a, p, lk = sig.get(f"apply_{e}"), sig.get(f"P_{e}"), sig.get(f"locked_{e}")
        if a is None or p is None or not unlocks.get(e) or (lk is not None and value_at(t, lk, ts, "left") < 0.5):
            continue
        a0 = value_at(t, a, ts, "left")
        for t_u in unlocks[e]:
            a_u = value_at(t, a, t_u, "left")
            if a0 <= APPLY_ZERO or a_u < a0 * (1.0 - RAMP_TOL):
                continue
            after = window(t, t_u, t_win)
            if len(after) and p_ref > 0 and float(np.max(p[after])) > OVERLAP_FRACTION * p_ref:
                out.append((e, t_u, a_u))
                break
    return out


def _comfort_signals(result: Result, weighting: str) -> dict | None:
    """The vehicle acceleration, its jerk and its frequency-weighted form over the whole run
    (``None`` when the run has no vehicle: no ``vehicle_accel`` signal)."""
    a = result.signals.get("vehicle_accel")
    if a is None or len(result.time) < 2:
        return None
    if "vehicle_jerk" in result.signals:  # exact, from the driveline and the output link's acceleration
        tj, j = result.time, result.signals["vehicle_jerk"]
    else:  # a result without it (e.g. read from a file): differenced
        tj, j = jerk(result.time, a)
    tw, aw = weighted(result.time, a, weighting)
    tf, jf = filtered_jerk(result.time, a)
    return {"a": a, "tj": tj, "j": j, "tw": tw, "aw": aw, "tf": tf, "jf": jf, "weighting": weighting}


def _comfort_figures(result: Result, c: dict | None, ts: float, t_end: float | None, t_win: float,
                     peak_from: float, notes: list[str]) -> dict:
    """Acceleration, jerk, VDV, overshoot and settling of one shift (see the module doc)."""
    t, T_out = result.time, result.signals["T_out"]
    out = dict(accel_before=None, accel_after=None, jerk_max=None, jerk_max_time=None, jerk_peak_to_peak=None,
               jerk_filtered_max=None, vdv=None, vdv_weighting=c["weighting"] if c else "none", output_torque_final=None,
               torque_overshoot=None, settling_time=None)
    if c is None:
        notes.append("no vehicle in the run (no vehicle_accel signal): no acceleration, jerk or VDV")
    else:
        a = c["a"]
        t0 = max(float(t[0]), ts - PRE_WINDOW)
        if ts > t0:
            out["accel_before"] = integrate(t, a, t0, ts) / (ts - t0)
        if t_end is not None and t_win > t_end:
            out["accel_after"] = integrate(t, a, t_end, t_win) / (t_win - t_end)
        jw = np.nonzero((c["tj"] >= ts) & (c["tj"] <= t_win))[0]
        if len(jw):
            j = c["j"][jw]
            k = int(np.argmax(np.abs(j)))
            out.update(jerk_max=float(abs(j[k])), jerk_max_time=float(c["tj"][jw][k]),
                       jerk_peak_to_peak=float(np.max(j) - np.min(j)))
        fw = (c["tf"] >= ts) & (c["tf"] <= t_win)
        if np.any(fw):
            out["jerk_filtered_max"] = float(np.max(np.abs(c["jf"][fw])))
        out["vdv"] = vdv(c["tw"], c["aw"], ts, t_win)
    if t_end is not None and t_win - t_end > PRE_WINDOW:
        final = integrate(t, T_out, t_win - PRE_WINDOW, t_win) / PRE_WINDOW
        out["output_torque_final"] = final
        if abs(final) > 1e-9:
            sign = 1.0 if final > 0 else -1.0
            seg = T_out[window(t, peak_from, t_win)]
            if len(seg):
                out["torque_overshoot"] = 100.0 * max(0.0, float(np.max(sign * seg)) - abs(final)) / abs(final)
            settle = settling_time(t, T_out, t_end, t_win, final, SETTLE_FRACTION * abs(final))
            if settle is not None and t_end + settle > t_win - PRE_WINDOW:
                notes.append(f"the output torque did not settle within {SETTLE_FRACTION:.0%} of its final value "
                             f"before {t_win:.3f} s")
                settle = None
            out["settling_time"] = settle
    return out


def _analyse(result: Result, shift: Shift, inp: str, out: str, link_notes: list[str],
             limit: float | None = None, comfort_signals: dict | None = None) -> ShiftQuality:
    t = result.time
    sig = result.signals
    t_run_end = float(t[-1])
    limit = t_run_end if limit is None else min(limit, t_run_end)
    on, off, ts = shift.oncoming, shift.offgoing, float(shift.t_start)
    notes = list(link_notes)
    for e in (on, off):
        if f"t_{e}" not in sig:
            raise KeyError(f"the result has no signals of element {e!r}")

    # shift end: the oncoming element locks
    t_lock = lock_time(result, on, ts, t_run_end, locks=True)
    completed = t_lock is not None
    t_end = t_lock if completed else t_run_end
    if not completed:
        notes.append(f"{on} never locked: the shift is not completed (analysed to the end of the run)")

    # torque phase start: onset of the oncoming torque
    t_on = sig[f"t_{on}"]
    win = window(t, ts, t_end)
    peak_on = float(np.max(np.abs(t_on[win]))) if len(win) else 0.0
    tp_start = None
    if peak_on > 0:
        hit = win[np.abs(t_on[win]) > ONSET_FRACTION * peak_on]
        if len(hit):
            k = int(hit[0])
            zero = ZERO_FRACTION * peak_on
            while k > win[0] and abs(t_on[k - 1]) > zero:
                k -= 1
            if k > win[0]:
                k -= 1  # the last sample with (numerically) no torque
            tp_start = float(t[k])
    if tp_start is None:
        notes.append(f"{on} transmitted no torque during the shift")

    # offgoing release: unlock event / locked_ signal drop
    locked_off = sig.get(f"locked_{off}")
    was_locked = bool(locked_off is not None and value_at(t, locked_off, ts, "left") > 0.5)
    unlocks = lock_times(result, off, ts, t_end, locks=False) if was_locked else []
    t_unlock = unlocks[-1] if unlocks else None  # the final release (it may slip and re-lock before)
    if was_locked and t_unlock is None:
        notes.append(f"{off} stayed locked until the shift end")
    if len(unlocks) > 1:
        notes.append(f"{off} unlocked {len(unlocks)} times (first at {unlocks[0]:.4f} s) and re-locked before its "
                     f"final release at {t_unlock:.4f} s")

    # speed ratio
    w_in, w_out = sig[f"w_{inp}"], sig[f"w_{out}"]

    def ratio(x, side):
        wo = value_at(t, w_out, x, side)
        return value_at(t, w_in, x, side) / wo if abs(wo) > 1e-9 else None

    ratio_before = ratio(ts, "left")
    ratio_after = ratio(t_end, "right") if completed else None

    # speed (inertia) phase start
    if t_unlock is not None:
        sp_start = t_unlock
    else:
        sp_start = None
        if ratio_before is not None:
            ref = max(abs(value_at(t, w_in, ts, "left")), 1e-9)
            dev = np.abs(w_in[win] - ratio_before * w_out[win]) - RATIO_TOL * ref
            hit = win[dev > 0]
            if len(hit):
                sp_start = float(t[hit[0]])
        if not was_locked:
            notes.append(f"{off} was not locked at t_start: speed phase start from the speed ratio")
    if sp_start is None and completed:
        sp_start = t_end
    sp_end = t_lock

    direction = ""
    if ratio_before is not None and ratio_after is not None and abs(ratio_after) != abs(ratio_before):
        direction = "upshift" if abs(ratio_after) < abs(ratio_before) else "downshift"

    tp_end = sp_start
    if tp_start is not None and tp_end is not None and tp_end < tp_start:
        why = "speed phase first, as in a power-on downshift" if direction == "downshift" else "early release"
        notes.append(f"{off} let go before {on} transmitted torque ({why}): no torque phase before the "
                     f"speed phase")
        tp_end = tp_start
    tp_dur = (tp_end - tp_start) if tp_start is not None and tp_end is not None else None
    sp_dur = (sp_end - sp_start) if sp_start is not None and sp_end is not None else None
    first = min([x for x in (tp_start, sp_start) if x is not None], default=ts)
    duration = (t_end - first) if completed else None

    # the end of the shift's dissipation: the offgoing element may go on slipping (still applied)
    # after the oncoming one has locked
    p_on, p_off = sig.get(f"P_{on}"), sig.get(f"P_{off}")
    t_diss = t_end
    if completed and p_off is not None and t_end < limit:
        i_post = max(int(np.searchsorted(t, t_end, side="right")) - 1, 0)  # the after-lock sample
        after = np.arange(i_post, int(np.searchsorted(t, limit, side="right")))
        ref = max([float(np.max(np.abs(p[window(t, ts, limit)]))) for p in (p_on, p_off) if p is not None] + [0.0])
        quiet = after[p_off[after] <= ZERO_FRACTION * max(ref, 1.0)]
        t_diss = float(t[quiet[0]]) if len(quiet) else limit
    ewin = window(t, ts, t_diss)

    # output torque: hole and peak (until the dissipation ends)
    T_out = sig["T_out"]
    before = _pre_mean(t, T_out, ts)
    s_out = 1.0 if before >= 0 else -1.0
    seg = T_out[ewin] if len(ewin) else np.array([value_at(t, T_out, ts)])
    tw = t[ewin] if len(ewin) else np.array([ts])
    k_min = int(np.argmin(s_out * seg))
    k_max = int(np.argmax(s_out * seg))
    t_min_val, t_max_val = float(seg[k_min]), float(seg[k_max])
    hole = s_out * (before - t_min_val)
    hole_pct = 100.0 * hole / abs(before) if abs(before) > 1e-9 else None
    over_pct = 100.0 * s_out * (t_max_val - before) / abs(before) if abs(before) > 1e-9 else None

    # bindup: offgoing torque reversed while both transmit
    t_off = sig[f"t_{off}"]
    off_before = _pre_mean(t, t_off, ts)
    s_off = 1.0 if off_before >= 0 else -1.0
    b_end = t_unlock if t_unlock is not None else (sp_start if sp_start is not None else t_end)
    b_start = tp_start if tp_start is not None else ts
    bw = window(t, b_start, b_end)
    opposite = -s_off * t_off[bw] if len(bw) else np.zeros(1)
    bindup_torque = max(0.0, float(np.max(opposite)))
    bindup_duration = duration_above(t[bw], opposite) if len(bw) > 1 else 0.0
    bindup = bindup_torque > max(BINDUP_MIN, BINDUP_FRACTION * abs(off_before))
    off_at_unlock = value_at(t, t_off, t_unlock, "left") if t_unlock is not None else None

    # flare: input speed above its pre-shift trajectory (upshift), above the new gear's
    # synchronous speed (downshift: the input must rise, but not beyond the new gear)
    w0, slope = _pre_trend(t, w_in, ts)
    s_in = 1.0 if w0 >= 0 else -1.0
    if direction == "downshift":
        reference = ratio_after * w_out[win]
    else:
        reference = w0 + slope * (t[win] - ts)
    excess = s_in * (w_in[win] - reference) if len(win) else np.zeros(1)
    k_fl = int(np.argmax(excess))
    flare_max = max(0.0, float(excess[k_fl]))
    flare_time = float(t[win][k_fl]) if flare_max > 0 and len(win) else None
    flare = flare_max > max(FLARE_MIN, FLARE_FRACTION * abs(w0))

    # oncoming apply ramp
    a_on = sig.get(f"apply_{on}")
    ramp_end, a_final, overrun, past_ramp = None, 0.0, 0.0, False
    if a_on is not None:
        aw = window(t, ts, t_run_end)
        a = a_on[aw]
        run_max = np.maximum.accumulate(a)
        release = np.nonzero(a < (1 - 0.01) * run_max - APPLY_ZERO)[0]
        stop = int(release[0]) if len(release) else len(a)
        a_final = float(np.max(a[:stop])) if stop > 0 else float(a[0])
        if a_final > APPLY_ZERO and a[0] < a_final * (1 - RAMP_TOL):  # it ramps (not a one-way clutch)
            reach = np.nonzero(a[:stop] >= a_final * (1 - RAMP_TOL))[0]
            ramp_end = float(t[aw][reach[0]]) if len(reach) else None
        if ramp_end is not None:
            overrun = max(0.0, t_end - ramp_end)
            past_ramp = overrun > OVERLAP_MIN if completed else t_run_end > ramp_end
            if past_ramp and completed:
                notes.append(f"the speed phase ran {overrun:.3g} s past the end of the {on} apply ramp")

    # energies and peak powers per element, from t_start to the end of the dissipation
    elements = list(result.meta.get("elements") or [k[2:] for k in sig if k.startswith("P_")])
    energy, peak = {}, {}
    for e in elements:
        p = sig.get(f"P_{e}")
        if p is None:
            continue
        energy[e] = integrate(t, p, ts, t_diss)
        peak[e] = float(np.max(p[ewin])) if len(ewin) else 0.0

    # both elements slipping and dissipating at once; the offgoing one forced (reversed torque)
    both = forced_dur = drag = 0.0
    drag_energy = integrate(t, p_off, t_end, t_diss) if p_off is not None else 0.0
    p_ref = max(peak.values(), default=0.0)
    if p_on is not None and p_off is not None and len(ewin) > 1 and p_ref > 0:
        th = OVERLAP_FRACTION * p_ref
        tt, pon, poff = t[ewin], p_on[ewin], p_off[ewin]
        both = duration_above(tt, np.minimum(pon, poff) - th)
        # reversed offgoing torque, scaled to power so that the minimum stays piecewise linear
        rev = -s_off * t_off[ewin] * th / max(BINDUP_FRACTION * abs(off_before), BINDUP_MIN)
        lock_on = sig.get(f"locked_{on}")
        holding = (lock_on[ewin] - 0.5) * 2.0 * th if lock_on is not None else np.full(len(ewin), -th)
        forced_dur = duration_above(tt, np.minimum(np.minimum(poff - th, rev), np.maximum(pon - th, holding)))
        if t_diss > t_end:
            dw = window(t, t_end, t_diss)
            drag = duration_above(t[dw], p_off[dw] - th)
    total = sum(energy.values())
    off_share = 100.0 * energy.get(off, 0.0) / total if total > 0 else 0.0

    # the comfort window: the shift, its dissipation and up to POST_WINDOW of settling
    t_win = max(t_diss, min(limit, t_end + POST_WINDOW)) if completed else t_run_end
    locks = {e: lock_times(result, e, ts, t_win, locks=True) for e in elements}
    unlocks_all = {e: lock_times(result, e, ts, t_win, locks=False) for e in elements}
    lock_counts = {e: len(v) for e, v in locks.items()}
    unlock_counts = {e: len(v) for e, v in unlocks_all.items()}
    chattering = [e for e in elements if lock_counts[e] + unlock_counts[e] > 1]
    for e in chattering:
        notes.append(f"chatter: {e} locked {lock_counts[e]} and unlocked {unlock_counts[e]} times in "
                     f"{ts:.3f}-{t_win:.3f} s")
    forced_elements = _forced_unlocks(result, elements, ts, t_win, unlocks_all, p_ref)
    forced = bool(forced_elements)
    for e, t_u, a in forced_elements:
        notes.append(f"{e} was forced to unlock at {t_u:.4f} s while fully applied (apply {a:.3g}, its release "
                     f"not begun) and slipped dissipating: the torque it had to carry exceeded its static capacity "
                     f"({off_share:.2g} % of the element energy in {off})")
    if not forced and forced_dur > OVERLAP_MIN:
        notes.append(f"{off} slipped and dissipated with its torque reversed against {on} for {forced_dur:.3g} s "
                     f"while it was being released (a late release: bindup), not a forced unlock")
    elif not forced and both > OVERLAP_MIN:
        notes.append(f"{on} and {off} slipped and dissipated together for {both:.3g} s with {off} slipping "
                     f"its normal way (released while still applied)")
    if drag > OVERLAP_MIN:
        notes.append(f"{off} went on slipping for {drag:.3g} s after {on} locked ({drag_energy:.4g} J)")

    comfort = _comfort_figures(result, comfort_signals, ts, t_end if completed else None, t_win,
                               sp_start if sp_start is not None else first, notes)

    return ShiftQuality(
        name=shift.name or shift_name(result, on, ts, off), oncoming=on, offgoing=off, t_start=ts,
        input_link=inp, output_link=out, completed=completed, direction=direction,
        torque_phase_start=tp_start, torque_phase_end=tp_end, torque_phase_duration=tp_dur,
        inertia_phase_start=sp_start, inertia_phase_end=sp_end, inertia_phase_duration=sp_dur,
        shift_end=t_end, shift_duration=duration, dissipation_end=t_diss, offgoing_unlock=t_unlock,
        oncoming_lock=t_lock,
        ratio_before=ratio_before, ratio_after=ratio_after,
        output_torque_before=before, output_torque_min=t_min_val, output_torque_min_time=float(tw[k_min]),
        torque_hole=hole, torque_hole_pct=hole_pct, output_torque_max=t_max_val,
        output_torque_max_time=float(tw[k_max]), output_torque_overshoot_pct=over_pct,
        bindup=bool(bindup), bindup_torque=bindup_torque, bindup_duration=bindup_duration,
        offgoing_torque_before=off_before, offgoing_torque_at_unlock=off_at_unlock,
        flare=bool(flare), flare_max=flare_max, flare_max_rpm=flare_max * RPM_PER_RAD_S, flare_time=flare_time,
        oncoming_ramp_end=ramp_end, oncoming_apply_final=a_final, speed_phase_past_ramp=bool(past_ramp),
        speed_phase_overrun=overrun, both_dissipating_duration=both, forced_duration=forced_dur,
        forced_unlock=bool(forced), offgoing_energy_share=off_share, offgoing_drag_after_lock=drag,
        offgoing_energy_after_lock=drag_energy,
        forced_unlock_element=",".join(e for e, _, _ in forced_elements) or None, window_end=t_win, **comfort,
        lock_counts=lock_counts, unlock_counts=unlock_counts, chatter=bool(chattering),
        energy=energy, peak_power=peak, energy_total=float(sum(energy.values())), notes=tuple(notes),
        losses=loss_energy(t, result.signals, ts, t_diss) or {}, **_torque_request(result, ts, t_win))


def _torque_request(result: Result, t0: float, t1: float) -> dict:
    """The engine torque intervention in ``[t0, t1]`` [s] from the run's ``torque_request``
    factor: its lowest and highest value and how long it stays above and below 1 (the four
    ``torque_request_*`` / ``torque_*_duration`` fields; None without a torque request)."""
    factor = result.signals.get("torque_request")
    if factor is None:
        return {}
    w = window(result.time, t0, t1)
    t, f = result.time[w], np.asarray(factor, dtype=float)[w]
    if not len(t):
        return {}
    return {"torque_request_min": float(np.min(f)), "torque_request_max": float(np.max(f)),
            "torque_increase_duration": duration_above(t, f - (1.0 + 1e-9)),
            "torque_reduction_duration": duration_above(t, (1.0 - 1e-9) - f)}


def shift_report(result: Result, shifts: list[Shift] | None = None, input_link: str | None = None,
                 output_link: str | None = None, weighting: str = VDV_WEIGHTING) -> list[ShiftQuality]:
    """Shift quality of every shift in ``result`` (``shifts``, or :func:`infer_shifts`).

    ``input_link`` / ``output_link``: used when the result's ``meta`` does not name them.
    ``weighting``: the frequency weighting of the acceleration for the VDV, ``"Wd"`` (ISO 2631-1
    fore-aft, the default), ``"Wk"`` (ISO 2631-1 vertical) or ``"none"``.
    """
    check_weighting(weighting)
    if len(result.time) < 2:
        return []
    inp, out, notes = _links(result, input_link, output_link)
    if shifts is None:
        lockup = set(result.meta.get("lockup", ()))  # converter lock-up apply/release is no gear shift
        shifts = [s for s in infer_shifts(result) if s.oncoming not in lockup and s.offgoing not in lockup]
    starts = sorted(float(s.t_start) for s in shifts)
    comfort = _comfort_signals(result, weighting) if shifts else None
    out_list = []
    for s in shifts:
        nxt = [x for x in starts if x > float(s.t_start)]
        out_list.append(_analyse(result, s, inp, out, notes, nxt[0] if nxt else None, comfort))
    return _with_temperatures(result, out_list)


def _with_temperatures(result: Result, qualities: list[ShiftQuality]) -> list[ShiftQuality]:
    """Each shift with its pack temperatures (start, peak, rise) from the default packs."""
    if not qualities:
        return qualities
    from transgen.losses.thermal import clutch_temperatures, shift_temperatures

    thermal = clutch_temperatures(result)
    out = []
    for q in qualities:
        temps = shift_temperatures(thermal, q.t_start, q.dissipation_end)
        out.append(replace(q, temperature_start={e: v[0] for e, v in temps.items()},
                           temperature_peak={e: v[1] for e, v in temps.items()},
                           temperature_rise={e: v[2] for e, v in temps.items()}))
    return out
