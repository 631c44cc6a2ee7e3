"""Acceptance of a launch's upshifts: the rule issue 21 sets for an untuned first result.

An upshift from a gear of ratio ``r_low`` to one of ratio ``r_high`` (input/output speeds, the
step ``step = r_low / r_high > 1``) is *acceptable* when the shift report
(:func:`transgen.sim.analysis.shift_quality.shift_report`, measured as it is) shows

* no bindup (the offgoing element's torque never reverses beyond the report's threshold while both
  elements transmit),
* a flare of at most :data:`FLARE_LIMIT_RPM` (50 rpm) above the input's pre-shift trajectory,
* a torque hole of at most ``100 * (1 - 1/step) + HOLE_MARGIN`` percent of the pre-shift output
  torque (:func:`hole_limit`): the output torque falls by ``1 - 1/step`` when the new gear takes the
  input torque, a handover that is neither late nor early adds little to that dip,
* and the oncoming element locks (the shift completes).

:func:`launch_acceptance` runs the launch ``transgen scenario new`` writes for a mechanism and a
vehicle class and judges each upshift; ``benchmarks/bench_launch_acceptance.py`` and the tests call
it, so that the benchmark's table and the tests apply one rule. A double swap is reported by the
shift analysis once per oncoming/offgoing pair; the upshift takes the worst of its pairs.
"""
from __future__ import annotations

import math
import tempfile
import warnings
from dataclasses import asdict, dataclass
from pathlib import Path

__all__ = ["FLARE_LIMIT_RPM", "HOLE_MARGIN", "hole_limit", "UpshiftVerdict", "judge_upshift", "launch_acceptance"]

FLARE_LIMIT_RPM = 50.0
"""Largest acceptable flare [rpm] of the input above its pre-shift trajectory."""
HOLE_MARGIN = 20.0
"""Percentage points of torque hole allowed beyond the dip the ratio step makes."""


def hole_limit(step: float) -> float:
    """Largest acceptable torque hole [% of the pre-shift output torque] of an upshift whose ratio
    step (lower gear's ratio over the higher gear's) is ``step``."""
    if not (math.isfinite(step) and step > 0):
        raise ValueError(f"a ratio step must be a positive finite number, not {step!r}")
    return 100.0 * (1.0 - 1.0 / step) + HOLE_MARGIN


@dataclass(frozen=True)
class UpshiftVerdict:
    """One upshift judged: ``bindup`` [N*m] the peak reversed offgoing torque when the report flags
    bindup (0 otherwise), ``flare`` [rpm], ``hole`` and ``limit`` [%], ``jerk`` [m/s^3] (largest
    ``|jerk|`` in the comfort window, None without a vehicle; ``jerk_filtered``: the same of the 10 Hz
    low-pass filtered acceleration), ``completed``: the oncoming locked."""

    name: str
    step: float
    bindup: float
    flare: float
    hole: float
    limit: float
    jerk: float | None
    completed: bool
    jerk_filtered: float | None = None

    @property
    def acceptable(self) -> bool:
        return self.completed and self.bindup == 0.0 and self.flare <= FLARE_LIMIT_RPM and self.hole <= self.limit

    def to_dict(self) -> dict:
        return {**asdict(self), "acceptable": self.acceptable}


def judge_upshift(name: str, step: float, qualities) -> UpshiftVerdict:
    """The verdict of an upshift from its shift-quality records (one per oncoming/offgoing pair:
    two for a double swap): the worst figure of each."""
    qs = list(qualities)
    if not qs:
        return UpshiftVerdict(name, step, 0.0, 0.0, math.inf, hole_limit(step), None, False)
    holes = [q.torque_hole_pct if q.torque_hole_pct is not None else math.inf for q in qs]
    jerks = [q.jerk_max for q in qs if q.jerk_max is not None]
    filtered = [q.jerk_filtered_max for q in qs if getattr(q, "jerk_filtered_max", None) is not None]
    return UpshiftVerdict(
        name, step,
        bindup=max((q.bindup_torque for q in qs if q.bindup), default=0.0),
        flare=max(q.flare_max_rpm for q in qs), hole=max(holes), limit=hole_limit(step),
        jerk=max(jerks) if jerks else None, completed=all(q.completed for q in qs),
        jerk_filtered=max(filtered) if filtered else None)


def launch_acceptance(mech, vehicle: str = "car", mechanism_ref: str | None = None):
    """``(launch, verdicts, result)``: the launch :func:`~transgen.sim.derive.launch.derive_launch` derives
    for ``mech`` (a :class:`~transgen.model.Mechanism`) in the class ``vehicle``, simulated from its
    scenario text as ``transgen simulate`` runs it, and one :class:`UpshiftVerdict` per upshift of
    its sequence (the shift reports that start between one shift command and the next)."""
    from .launch import derive_launch, launch_scenario
    from ..scenario.load import load_scenario
    from ..analysis.shift_quality import shift_report

    launch = derive_launch(mech, vehicle)
    ref = mechanism_ref or str(Path(mech.source).resolve())
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "launch.toml"
        path.write_text(launch_scenario(mech, vehicle, ref, launch), encoding="utf-8")
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)
            scenario = load_scenario(path)
            result = scenario.run()
    qualities = shift_report(result)
    commands = [e.t for e in result.events if e.kind == "command"]
    ratio = {g.name: g.ratio for g in launch.gears}
    verdicts = []
    for k, (a, b) in enumerate(zip(launch.order, launch.order[1:])):
        t0 = commands[k] if k < len(commands) else math.inf
        t1 = commands[k + 1] if k + 1 < len(commands) else math.inf
        mine = [q for q in qualities if t0 - 1e-9 <= q.t_start < t1 - 1e-9]
        verdicts.append(judge_upshift(f"{a}-{b}", ratio[a] / ratio[b], mine))
    return launch, verdicts, result
