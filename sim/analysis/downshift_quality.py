"""Downshift figures of the shift report: synchronism, overshoot past it and tie-up.

In a downshift the input must rise to the new gear's synchronous speed ``w_sync = ratio_after *
w_out``. Power-on (a kickdown) the engine drives it there once the offgoing element lets go, and
the flare is the point: how long it takes, how far the input overshoots, and how much the
elements fight (a tie-up). Power-off the oncoming element pulls the input up; the same figures say
how fast and how cleanly. For a completed downshift of :func:`~.shift_quality.shift_report`:

* ``power``: ``"on"`` or ``"off"`` as the automatic schedule classed the shift at its command
  (its ``command`` event, :mod:`.schedule`: the throttle demand against
  :data:`~.schedule.POWER_ON_THROTTLE`); for a shift without one (a scenario's ``[shifts]``
  events) from the sign of the input torque ``T_in`` over the pre-shift window;
* ``time_to_sync`` [s]: from the command to the first sample where the input (in its direction of
  rotation) reaches ``w_sync``; ``sync_time`` [s] that instant;
* ``overshoot`` [rad/s] and ``overshoot_rpm``: the largest excess of the input over ``w_sync``
  from the command to :data:`SETTLE_AFTER` after the shift end (the lock);
* ``tie_up_energy`` [J] and ``tie_up_torque`` [N*m]: what the oncoming element dissipates, and its
  largest torque, before synchronism. Power-on its torque then opposes the flare (a tie-up, which
  slows the flare and costs torque at the output); power-off it is the torque that raises the
  input (the shift's work, not a fault);
* ``offgoing_after_sync`` [J]: what the offgoing element dissipates after synchronism (the input
  has passed its old speed long before; still applied, it drags against the new gear).

Units SI; the report (:mod:`.report`) prints them in a ``synchronism`` row and gives them in the
JSON as each downshift's ``downshift``.
"""
from __future__ import annotations

from ..core.result import Result
from .samples import integrate, value_at, window
from .shift_quality import PRE_WINDOW, RPM_PER_RAD_S, ShiftQuality

__all__ = ["downshift_figures", "SETTLE_AFTER", "DOWNSHIFT_UNITS"]

SETTLE_AFTER = 0.2
"""Time [s] after the lock in which an overshoot past synchronism is still counted."""
DOWNSHIFT_UNITS = {"time_to_sync": "s", "sync_time": "s", "overshoot": "rad/s", "overshoot_rpm": "rpm",
                   "tie_up_energy": "J", "tie_up_torque": "N*m", "offgoing_after_sync": "J"}


def downshift_figures(result: Result, q: ShiftQuality) -> dict | None:
    """The downshift figures (module docstring) of the shift ``q`` of ``result``; None when ``q``
    is no completed downshift."""
    import numpy as np

    if q.direction != "downshift" or not q.completed or q.ratio_after is None:
        return None
    t, sig = result.time, result.signals
    w_in, w_out = sig[f"w_{q.input_link}"], sig[f"w_{q.output_link}"]
    s = 1.0 if value_at(t, w_in, q.t_start, "left") >= 0 else -1.0
    end = min(q.shift_end + SETTLE_AFTER, q.window_end)
    win = window(t, q.t_start, end)
    excess = s * (w_in[win] - q.ratio_after * w_out[win])
    reached = np.nonzero(excess >= 0.0)[0]
    t_sync = float(t[win][reached[0]]) if len(reached) else q.shift_end
    power = _power(result, q)
    before = window(t, q.t_start, t_sync)
    t_on, p_on, p_off = sig.get(f"t_{q.oncoming}"), sig.get(f"P_{q.oncoming}"), sig.get(f"P_{q.offgoing}")
    overshoot = max(0.0, float(np.max(excess))) if len(excess) else 0.0
    return {
        "power": power,
        "time_to_sync": t_sync - q.t_start,
        "sync_time": t_sync,
        "overshoot": overshoot,
        "overshoot_rpm": overshoot * RPM_PER_RAD_S,
        "tie_up_energy": integrate(t, p_on, q.t_start, t_sync) if p_on is not None else 0.0,
        "tie_up_torque": float(np.max(np.abs(t_on[before]))) if t_on is not None and len(before) else 0.0,
        "offgoing_after_sync": (integrate(t, p_off, t_sync, max(t_sync, q.dissipation_end))
                                if p_off is not None else 0.0),
    }


def _power(result: Result, q: ShiftQuality) -> str | None:
    """"on"/"off": the schedule's class of the shift at its command, else the sign of ``T_in``."""
    for e in result.events:
        if e.kind == "command" and abs(e.t - q.t_start) < 1e-6 * max(1.0, abs(q.t_start)) + 1e-9:
            for power in ("on", "off"):
                if e.detail.endswith(f"; power-{power})"):
                    return power
    t_in = result.signals.get("T_in")
    if t_in is None:
        return None
    return "on" if integrate(result.time, t_in, q.t_start - PRE_WINDOW, q.t_start) > 0 else "off"


def downshift_text(d: dict, q: ShiftQuality) -> str:
    """The report's ``synchronism`` row of the figures ``d`` of the downshift ``q``."""
    what = "tie-up" if d["power"] == "on" else "pull-up"
    return (f"power-{d['power'] or '?'}: {q.input_link} at the new gear's speed {d['time_to_sync']:.3f} s after the "
            f"command ({d['sync_time']:.3f} s), overshoot {d['overshoot_rpm']:.1f} rpm; {what} {q.oncoming} "
            f"{d['tie_up_energy']:.1f} J, {d['tie_up_torque']:.1f} N*m before sync; {q.offgoing} "
            f"{d['offgoing_after_sync']:.1f} J after")
