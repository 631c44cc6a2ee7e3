"""What the shift calibration minimises: the objective's terms and weights, the constraints, the
metrics of one shift window and the score of a candidate against the reference run."""
from __future__ import annotations

import math
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import asdict, dataclass, field, fields, replace

import numpy as np

from transgen.errors import ScenarioError

__all__ = ["Objective", "Constraints", "parse_objective", "OBJECTIVE_TERMS", "DEFAULT_OBJECTIVE", "INFEASIBLE", "shift_metrics", "score"]


OBJECTIVE_TERMS = {"energy": "clutch energy of the shift [J]", "duration": "shift duration [s]",
                   "hole": "torque hole [% of the output torque before]", "flare": "flare of the input speed [rpm]",
                   "jerk": "largest jerk [m/s^3]"}

DEFAULT_OBJECTIVE = {"energy": 1.0, "hole": 1.0, "jerk": 0.2, "duration": 0.1}
"""The default objective: clutch energy (the clutches' wear and heat), torque hole and jerk (what
the driver feels) and a little of the shift's duration. Without the jerk term the search finds
shifts of 0.11-0.14 s in the HT-740 with 2-3x the jerk of the hand-tuned calibration (28-48
against 15-32 m/s^3); a term a scenario cannot measure (jerk without a vehicle) is left out."""

INFEASIBLE = 1e3
"""Score of an infeasible candidate per unit of (1 + violation); a failed run scores 1e3 times more."""


@dataclass(frozen=True)
class Objective:
    """Weights of the objective terms (:data:`OBJECTIVE_TERMS`), each term divided by the
    starting calibration's value of the shift."""

    weights: Mapping[str, float] = field(default_factory=lambda: dict(DEFAULT_OBJECTIVE))

    def text(self) -> str:
        return ",".join(f"{k}={v:g}" for k, v in self.weights.items())


@dataclass(frozen=True)
class Constraints:
    """The constraints of every shift: ``no_bindup``, ``max_flare_rpm`` [rpm], ``no_chatter``,
    ``max_hole_pct`` [% of the output torque before, None: free], ``max_duration`` [s, None:
    free], ``max_energy`` [J, the clutch energy of the shift, None: free], ``max_jerk`` [m/s^3,
    the largest jerk of the shift's comfort window, None: free; not checked without a vehicle]; the shift must
    complete. ``no_worse_than``: a reference scenario (file or bundled name, None: none) whose
    torque hole and clutch energy at the same shift (the same gears) each tuned shift must not
    exceed (:func:`reference_limits`, :meth:`for_shift`)."""

    no_bindup: bool = True
    max_flare_rpm: float | None = 20.0
    no_chatter: bool = True
    max_hole_pct: float | None = None
    max_duration: float | None = None
    max_energy: float | None = None
    no_worse_than: str | None = None
    max_temperature: float | None = None  # degC: peak pack temperature of the shift (transgen.losses.thermal)
    max_jerk: float | None = None

    def for_shift(self, hole_pct: float | None = None, energy: float | None = None) -> Constraints:
        """These constraints with the torque hole [%] and clutch energy [J] of one shift limited to
        ``hole_pct`` and ``energy`` too (a reference calibration's at that shift)."""
        def tighter(limit, other):
            return other if limit is None else limit if other is None else min(limit, other)
        return replace(self, max_hole_pct=tighter(self.max_hole_pct, hole_pct),
                       max_energy=tighter(self.max_energy, energy))

    def text(self) -> str:
        parts = ["completes"] + (["no bindup"] if self.no_bindup else [])
        parts += [f"flare <= {self.max_flare_rpm:g} rpm"] if self.max_flare_rpm is not None else []
        parts += ["no chatter"] if self.no_chatter else []
        parts += [f"torque hole <= {self.max_hole_pct:g} %"] if self.max_hole_pct is not None else []
        parts += [f"duration <= {self.max_duration:g} s"] if self.max_duration is not None else []
        parts += [f"clutch energy <= {self.max_energy / 1e3:g} kJ"] if self.max_energy is not None else []
        parts += [f"pack temperature <= {self.max_temperature:g} degC"] if self.max_temperature is not None else []
        parts += [f"jerk <= {self.max_jerk:g} m/s^3"] if self.max_jerk is not None else []
        parts += [f"torque hole and clutch energy of each shift <= {self.no_worse_than}'s"] if self.no_worse_than else []
        return ", ".join(parts)



def parse_objective(text: str) -> Objective:
    """``energy=1,jerk=0.2,duration=0.1`` -> :class:`Objective`; ValueError naming the bad part."""
    weights = {}
    for part in filter(None, (p.strip() for p in text.split(","))):
        name, eq, value = part.partition("=")
        name = name.strip()
        if name not in OBJECTIVE_TERMS:
            raise ValueError(f"--objective: error: unknown term {name!r} (terms: {', '.join(OBJECTIVE_TERMS)})")
        try:
            weight = float(value) if eq else 1.0
        except ValueError:
            raise ValueError(f"--objective: error: the weight of {name} is {value.strip()!r}, not a number") from None
        if not math.isfinite(weight) or weight < 0:
            raise ValueError(f"--objective: error: the weight of {name} must be a finite number >= 0, not {value.strip()}")
        weights[name] = weight
    if not any(weights.values()):
        raise ValueError("--objective: error: give at least one term with a weight > 0, e.g. energy=1,duration=0.1")
    return Objective(weights)


def shift_metrics(result, oncoming: str, offgoing: str, t_start: float, name: str = "") -> dict:
    """The numbers of one shift window's run that the objective and the constraints use (plain
    data) from the shift report: completed, energy [J], duration [s], hole [%], flare [rpm],
    bindup, bindup torque [N*m], chatter (an element that changed its lock state more than once),
    locks (lock and unlock events of the window), jerk [m/s^3] (None without a vehicle)."""
    from transgen.sim.analysis.report import Shift, shift_report

    if not result.success or len(result.time) < 2:
        return {"success": False, "message": result.message}
    # no frequency weighting: the VDV is the only figure that needs it (its FFT filter is a fifth of
    # the report's cost), and no metric here reads it; jerk and all else are the same numbers
    [q] = shift_report(result, [Shift(oncoming, offgoing, t_start, name)], weighting="none")
    jerk = q.jerk_max
    return {"success": True, "completed": bool(q.completed), "energy": float(q.energy_total),
            "duration": None if q.shift_duration is None else float(q.shift_duration),
            "hole": None if q.torque_hole_pct is None else float(q.torque_hole_pct),
            "hole_torque": float(q.torque_hole), "flare": float(q.flare_max_rpm), "bindup": bool(q.bindup),
            "bindup_torque": float(q.bindup_torque), "offgoing_torque": abs(float(q.offgoing_torque_before)),
            "chatter": bool(q.chatter), "locks": int(sum(q.lock_counts.values()) + sum(q.unlock_counts.values())),
            "jerk": None if jerk is None else float(jerk),
            "temperature": max((float(v) for v in q.temperature_peak.values()), default=None)}


def score(metrics: Mapping, reference: Mapping, objective: Objective, constraints: Constraints) -> tuple[float, dict, dict]:
    """(score, objective terms, violations) of a candidate's ``metrics``: the weighted objective
    (terms divided by the ``reference`` shift's) when every constraint holds, else
    ``INFEASIBLE * (1 + sum of violations)``; a failed run scores ``INFEASIBLE ** 2``.
    Violations are relative (0.5: 50 % beyond the limit); a violated yes/no constraint counts 1
    plus its size where it has one."""
    if not metrics.get("success"):
        return INFEASIBLE ** 2, {}, {"run": 1.0}
    violations = {}
    if not metrics["completed"]:
        violations["completes"] = 10.0
    if constraints.no_bindup and metrics["bindup"]:
        violations["no bindup"] = 1.0 + metrics["bindup_torque"] / max(metrics["offgoing_torque"], 1.0)
    if constraints.max_flare_rpm is not None and metrics["flare"] > constraints.max_flare_rpm:
        violations["max flare"] = (metrics["flare"] - constraints.max_flare_rpm) / max(constraints.max_flare_rpm, 1.0)
    if constraints.no_chatter and metrics["chatter"]:
        violations["no chatter"] = 1.0 + max(metrics["locks"] - 3, 0)
    if constraints.max_hole_pct is not None and (metrics["hole"] or 0.0) > constraints.max_hole_pct:
        violations["max hole"] = (metrics["hole"] - constraints.max_hole_pct) / max(constraints.max_hole_pct, 1.0)
    if constraints.max_energy is not None and metrics["energy"] > constraints.max_energy:
        violations["max energy"] = (metrics["energy"] - constraints.max_energy) / max(constraints.max_energy, 1.0)
    limit = constraints.max_temperature
    if limit is not None and (metrics.get("temperature") or -math.inf) > limit:
        violations["max temperature"] = (metrics["temperature"] - limit) / max(abs(limit), 1.0)
    if constraints.max_duration is not None and (metrics["duration"] is None or metrics["duration"] > constraints.max_duration):
        violations["max duration"] = (((metrics["duration"] or 10 * constraints.max_duration) - constraints.max_duration)
                                      / constraints.max_duration)
    if constraints.max_jerk is not None and metrics.get("jerk") is not None and metrics["jerk"] > constraints.max_jerk:
        violations["max jerk"] = (metrics["jerk"] - constraints.max_jerk) / max(constraints.max_jerk, 1.0)
    terms = {}
    for name, weight in objective.weights.items():
        if not weight:
            continue
        value, ref = _term(metrics, name), _term(reference, name)
        if value is None and ref is None:  # not measured in this scenario (jerk without a vehicle)
            continue
        floor = {"energy": 1.0, "duration": 0.05, "hole": 1.0, "flare": 100.0, "jerk": 1.0}[name]
        if name == "flare":
            ref = 0.0  # flare in units of 100 rpm: the reference is often none at all
        terms[name] = weight * (value if value is not None else 10 * max(ref or 0.0, floor)) / max(ref or 0.0, floor)
    if violations:
        return INFEASIBLE * (1.0 + sum(violations.values())), terms, violations
    return float(sum(terms.values())), terms, violations


def _term(metrics: Mapping, name: str):
    value = metrics.get(name)
    if name == "hole" and value is not None:
        return max(value, 0.0)
    return value
