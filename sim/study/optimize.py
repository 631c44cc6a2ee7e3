"""Shift calibration: tune the apply trajectories of each shift of a scenario (``transgen optimize``).

For every selected shift the nine clutch parameters of a :class:`~transgen.sim.control.schedule.ShiftTemplate`
are tuned: oncoming fill (``fill_time``, ``fill_level``), torque-phase ramp (``ramp_time``,
``ramp_end``), inertia-phase level (``hold_time`` at ``ramp_end``), final rise (``final_time``)
and the offgoing delay, level and release (``offgoing_delay``, ``offgoing_level``,
``offgoing_ramp``), and, where the scenario's input is an engine (``engine_torque``, on by
default there), the seven of its engine torque intervention (:data:`TORQUE_PARAMETERS`: a
torque-phase increase ``torque_boost`` for ``boost_time`` from ``boost_delay`` after the offgoing
release starts, an inertia-phase reduction ``torque_cut`` for ``cut_time`` from ``cut_delay`` after
the release ends, ramps ``torque_ramp``; :mod:`transgen.sim.control.schedule`), to minimise a weighted
objective under constraints:

* objective terms (each divided by the starting calibration's value of the shift, so that the
  weights are pure numbers): ``energy`` (the clutch energy of the shift, J), ``duration`` (the
  shift duration, s), ``hole`` (the torque hole, % of the output torque before), ``flare`` (the
  input speed's flare, rpm; divided by 100 rpm) and ``jerk`` (the largest jerk, m/s^3, from the
  shift report's comfort metrics);
* constraints (:class:`Constraints`): the shift completes (the oncoming element locks), no bindup,
  flare at most ``max_flare_rpm`` (20 rpm by default), no chatter (neither element locks more than
  once in the shift window), and on request a torque hole at most ``max_hole_pct``, a duration at
  most ``max_duration`` and a largest jerk at most ``max_jerk`` (m/s^3, the shift report's
  ``jerk_max``; a comfort limit such as the passenger-car range of ``docs/calibration.md``).

How a scenario carries its calibration (:class:`Calibration`): raw apply tables of the elements
(each shift's piece of the oncoming and offgoing tables is fitted to the template first,
:func:`fit_template`, and replaced by the tuned template's points; the tuned engine torque
intervention goes to ``[input] torque_request`` as a table; where the scenario has its own, as a
tuned file of an earlier pass, the span of each shift whose tuned template intervenes is replaced by
its profile, and a template without an intervention keeps the scenario's own there, so a shift's
tuning starts from the scenario's own request), shift events with templates
(``[shifts] events``: each event's ``template``) or an automatic schedule
(``[auto_shift] templates."1-2"``, a template per shift).

One evaluation simulates one shift window only: the run up to just before the shift
(:data:`PRE_MARGIN` before the shift report's pre-shift window) is computed once and its state
saved (:mod:`transgen.sim.solve.restart`); each candidate starts from that state and runs to the end of
its own trajectories plus :data:`SETTLE` (at most to the next shift). The shifts are tuned in time
order, each from the state after the tuned shifts before it. Candidates are evaluated in batches on
an executor of :mod:`.executors` (in this process, local processes or Dask): the worker gets the
scenario's texts, the overrides of the candidate and the saved state, never live objects.

The optimizer is CMA-ES (the covariance matrix adaptation evolution strategy of the ``cma``
package, pycma; :func:`_search`): each generation of ``population`` candidates is one batch, mapped
over the executor; its normal samples come from a generator seeded by ``seed``, so a run is
repeatable. It searches the box scaled to the unit cube from the scenario's own calibration with a
first step of :data:`SIGMA` of each range, for :data:`CMA_SHARE` of the evaluations; a compass search
(:func:`_compass`, a batch of steps up and down along every parameter at a time) polishes its best
candidate with the rest. ``max_evaluations`` counts every simulation of a shift: the start, and
with the engine torque tuned, :data:`CLUTCH_SHARE` of them over the nine clutch parameters and the
rest over all sixteen from the best clutch calibration, the intervention starting from the middle
of its box (the sixteen at once from the start found a worse 3-4 of the HT-740 than the clutches
alone). Constraints enter as a feasibility-first penalty: an
infeasible candidate scores ``INFEASIBLE * (1 + total violation)``, above every feasible one, so the
search moves towards the feasible region and then minimises the objective inside it. Why this
optimizer: the simulated metrics are not smooth in the parameters (an element locks or does not, a
bindup appears at a threshold), which rules out gradients and makes local derivative-free methods
(Nelder-Mead, COBYLA) stall at the first kink; a population method evaluates a whole generation in
parallel. CMA-ES uses the candidates' ranks only (the penalty's jumps do not distort it) and learns
the correlations of the parameters (fill against ramp, cut against its time), which the
differential evolution used before did not: on the HT-740 3-4 (seed 0) it scored 0.33 after 1041
evaluations where the differential evolution scored 0.40 after 1047 (README "Shift calibration").
"""
from __future__ import annotations

import math
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import asdict, dataclass, field, fields, replace

import numpy as np

from transgen.errors import ScenarioError

__all__ = ["Constraints", "Objective", "ShiftPlan", "Calibration", "ShiftOutcome", "OptimizeResult", "PARAMETERS",
           "TORQUE_PARAMETERS", "BOUNDS", "has_engine", "intervention_text", "fit_template", "plan_calibration", "evaluate_candidate", "shift_metrics", "score", "optimize",
           "tuned_scenario_text", "parse_objective", "OBJECTIVE_TERMS", "PRE_MARGIN", "SETTLE", "INFEASIBLE"]

#: the tuned parameters, in the order of the optimizer's vector (the fields of ShiftTemplate)
PARAMETERS = ("fill_time", "fill_level", "ramp_time", "ramp_end", "hold_time", "final_time", "offgoing_delay",
              "offgoing_level", "offgoing_ramp")

#: the engine torque intervention's parameters (ShiftTemplate; factors [-] and times [s]), tuned after
#: PARAMETERS where the input is an engine
TORQUE_PARAMETERS = ("torque_boost", "boost_delay", "boost_time", "torque_cut", "cut_delay", "cut_time", "torque_ramp")

#: the search box of each parameter [s, apply fraction or torque factor]; widened to hold the starting
#: calibration. The increase goes up to 1.6 times the engine's torque (the engine gives no more than
#: its full-load torque at the current speed anyway), the reduction down to 0.3 times.
BOUNDS = {"fill_time": (0.0, 0.3), "fill_level": (0.0, 0.5), "ramp_time": (0.05, 1.5), "ramp_end": (0.05, 1.0),
          "hold_time": (0.0, 1.5), "final_time": (0.02, 0.5), "offgoing_delay": (0.0, 1.5),
          "offgoing_level": (0.0, 1.0), "offgoing_ramp": (0.01, 1.0),
          "torque_boost": (1.0, 1.6), "boost_delay": (0.0, 0.5), "boost_time": (0.0, 1.0), "torque_cut": (0.3, 1.0),
          "cut_delay": (0.0, 0.5), "cut_time": (0.0, 1.0), "torque_ramp": (0.02, 0.2)}

OBJECTIVE_TERMS = {"energy": "clutch energy of the shift [J]", "duration": "shift duration [s]",
                   "hole": "torque hole [% of the output torque before]", "flare": "flare of the input speed [rpm]",
                   "jerk": "largest jerk [m/s^3]"}

DEFAULT_OBJECTIVE = {"energy": 1.0, "hole": 1.0, "jerk": 0.2, "duration": 0.1}
"""The default objective: clutch energy (the clutches' wear and heat), torque hole and jerk (what
the driver feels) and a little of the shift's duration. Without the jerk term the search finds
shifts of 0.11-0.14 s in the HT-740 with 2-3x the jerk of the hand-tuned calibration (28-48
against 15-32 m/s^3); a term a scenario cannot measure (jerk without a vehicle) is left out."""

PRE_MARGIN = 0.05
"""Time [s] before the shift report's pre-shift window (0.2 s before the shift) where a shift
window starts."""

SETTLE = 0.5
"""Time [s] a shift window goes on after the end of the candidate's trajectories."""

INFEASIBLE = 1e3
"""Score of an infeasible candidate per unit of (1 + violation); a failed run scores 1e3 times more."""

CMA_SHARE = 0.85
"""Share of a search's evaluations that CMA-ES spends; a compass search from its best candidate
spends the rest."""

CLUTCH_SHARE = 0.5
"""Share of a shift's evaluations for the clutch stage where the engine torque intervention is tuned
too (the rest: the sixteen parameters together)."""

SIGMA = 0.2
"""CMA-ES's first step, as a fraction of each parameter's range."""

TUNED_STEP = 0.5
"""In the engine torque stage, the first step of the parameters tuned before (the clutches), as a
multiple of :data:`SIGMA`."""

FRESH_STEP = 1.5
"""In the engine torque stage, the first step of the parameters searched for the first time (the
engine torque intervention, from the middle of its box), as a multiple of :data:`SIGMA`."""


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


# --------------------------------------------------------------------------------- templates


def _template(x: Sequence[float], names: Sequence[str] = PARAMETERS, base=None):
    """The template with the parameters ``names`` set to ``x`` (the others from ``base``, default
    the ShiftTemplate defaults)."""
    from transgen.sim.control.schedule import ShiftTemplate

    return replace(base or ShiftTemplate(), **{k: float(v) for k, v in zip(names, x)})


def _vector(template, names: Sequence[str] = PARAMETERS) -> np.ndarray:
    return np.array([getattr(template, k) for k in names], dtype=float)


def _span(template) -> float:
    """How long after the shift command the template's trajectories end [s] (the apply
    trajectories and the engine torque request)."""
    on = template.fill_time + template.ramp_time + template.hold_time + template.final_time
    off = template.fill_time + template.offgoing_delay + template.offgoing_ramp
    request = template.torque_request(0.0)
    return max(on, off, request[-1][0] if request else 0.0)


def has_engine(scenario) -> bool:
    """Whether the scenario's input is an engine that takes a torque request (map engine, engine
    with converter, turbodiesel)."""
    from transgen.sim.model.components import EngineOnLink, EngineWithConverter
    from transgen.sim.model.powertrain import TurbodieselSource

    return any(isinstance(c, (EngineOnLink, EngineWithConverter, TurbodieselSource))
               for c in scenario.powertrain.components)


def intervention_text(template, own_request: bool = False) -> str:
    """How a template asks the engine for torque, in words: ``none`` or the increase and the
    reduction with their factors and times (``own_request``: the scenario's own ``[input]
    torque_request`` stays where the template asks for nothing)."""
    if not template.torque_intervention:
        return "none tuned: the scenario's own [input] torque_request kept" if own_request else "none"
    parts = []
    if template.torque_boost != 1.0:
        parts.append(f"x{template.torque_boost:.3f} for {template.boost_time:.3f} s from {template.boost_delay:.3f} s "
                     f"after the offgoing release starts")
    if template.torque_cut != 1.0:
        parts.append(f"x{template.torque_cut:.3f} for {template.cut_time:.3f} s from {template.cut_delay:.3f} s "
                     f"after the offgoing release ends")
    return "; ".join(parts) + f" (ramps {template.torque_ramp:.3f} s)"


def _curve(points, before: float):
    from transgen.sim.control.schedule import _merge

    t0 = points[0][0]
    return _merge([(t0 - 1.0, before)] + list(points))


def fit_template(oncoming, offgoing, t0: float, t1: float, samples: int = 400):
    """The :class:`~transgen.sim.control.schedule.ShiftTemplate` closest to the raw apply signals
    ``oncoming`` and ``offgoing`` (piecewise-linear :class:`~transgen.sim.core.signals.Signal` s)
    over the shift ``[t0, t1]`` [s], and the root-mean-square difference of the fitted applies
    from the raw ones over the shift (apply fraction; a fast raw drop that the template makes a
    jump differs for a few ms only, which a largest difference would overstate).

    The template's corners are read off the raw corners first (the fill: a jump and a flat piece
    at the start; the hold: the longest flat piece below full apply; the offgoing drop: where it
    leaves its level, the level just after, the time it reaches zero), then refined by least
    squares on ``samples`` points, the oncoming and the offgoing parameters each on their own
    curve."""
    from scipy.optimize import least_squares

    ts = np.linspace(t0, t1, samples)
    a_on = oncoming.sample(ts)
    a_off = offgoing.sample(ts)
    guess = {**_guess_oncoming(_points(oncoming, t0, t1), t0), **_guess_offgoing(_points(offgoing, t0, t1), t0)}
    guess["offgoing_delay"] = max(guess.pop("release") - t0 - guess["fill_time"], 0.0)
    lo = {k: BOUNDS[k][0] for k in PARAMETERS}
    hi = {k: (max(BOUNDS[k][1], 2.0 * (t1 - t0)) if k.endswith(("_time", "_delay", "_ramp")) else BOUNDS[k][1])
          for k in PARAMETERS}
    x = {k: float(np.clip(guess[k], lo[k], hi[k])) for k in PARAMETERS}

    def refine(names, curve, target):
        def residual(v):
            tmpl = _template([{**x, **dict(zip(names, v))}[k] for k in PARAMETERS])
            return curve(tmpl).sample(ts) - target

        v0 = [x[k] for k in names]
        fit = least_squares(residual, v0, bounds=([lo[k] for k in names], [hi[k] for k in names]), diff_step=1e-4,
                            max_nfev=200)
        if np.max(np.abs(residual(fit.x))) < np.max(np.abs(residual(v0))):
            x.update(zip(names, map(float, fit.x)))

    refine(PARAMETERS[:6], lambda tm: _curve(tm.oncoming(t0), 0.0), a_on)
    refine(PARAMETERS[6:], lambda tm: _curve(tm.offgoing(t0), float(a_off[0])), a_off)
    tmpl = _template([x[k] for k in PARAMETERS])
    fine = np.linspace(t0, t1, 20 * samples)
    diff = np.concatenate([_curve(tmpl.oncoming(t0), 0.0).sample(fine) - oncoming.sample(fine),
                           _curve(tmpl.offgoing(t0), float(a_off[0])).sample(fine) - offgoing.sample(fine)])
    return tmpl, float(np.sqrt(np.mean(diff ** 2)))


_JUMP = 1e-5  # s: a rise or fall this fast is a jump (the template's own jumps take 1e-6 s)


def _guess_oncoming(corners, t0: float) -> dict:
    """Template parameters of the oncoming apply read off its corners ``[(t, value), ...]``."""
    ts = [t for t, _ in corners]
    vs = [v for _, v in corners]
    top = max(vs)
    k_full = next(i for i, v in enumerate(vs) if v >= top - 1e-9)
    t_full = ts[k_full]
    k = 0
    while k + 1 < len(ts) and ts[k + 1] <= t0 + _JUMP and vs[k + 1] > vs[k]:  # a jump at the command
        k += 1
    fill_level, fill_end = vs[k], ts[k]
    if k + 1 < len(ts) and abs(vs[k + 1] - vs[k]) < 1e-9 and ts[k + 1] < t_full:  # a flat fill piece
        fill_end = ts[k + 1]
        k += 1
    flats = [(ts[i + 1] - ts[i], i) for i in range(k, k_full) if abs(vs[i + 1] - vs[i]) < 1e-9 and vs[i] < top - 1e-9
             and ts[i + 1] > ts[i]]
    if flats:
        _, i = max(flats)
        ramp_end, hold_start, hold_end = vs[i], ts[i], ts[i + 1]
    else:
        before = [i for i in range(k + 1, k_full)]
        i = before[-1] if before else None
        if i is None:
            hold_start = hold_end = fill_end + 0.5 * (t_full - fill_end)
            ramp_end = fill_level + 0.5 * (top - fill_level)
        else:
            ramp_end, hold_start, hold_end = vs[i], ts[i], ts[i]
    return {"fill_time": fill_end - t0, "fill_level": fill_level, "ramp_time": max(hold_start - fill_end, 1e-3),
            "ramp_end": ramp_end, "hold_time": hold_end - hold_start, "final_time": max(t_full - hold_end, 1e-3)}


def _guess_offgoing(corners, t0: float) -> dict:
    """The offgoing release read off its corners: its start, the level just after, its length."""
    ts = [t for t, _ in corners]
    vs = [v for _, v in corners]
    k = 0
    while k + 1 < len(ts) and vs[k + 1] >= vs[0] - 1e-9:
        k += 1
    release = ts[k]
    zero = next((t for t, v in zip(ts, vs) if t >= release and v <= 1e-9), ts[-1])
    after = [v for t, v in zip(ts, vs) if release <= t <= release + _JUMP and v < vs[0] - 1e-9]
    if after:
        level = after[0]
    else:  # no jump: the level the first piece of the release would start from
        level = vs[k + 1] if k + 1 < len(vs) else 0.0
        if k + 1 < len(ts) and ts[k + 1] > release and zero > release:
            slope = (vs[k + 1] - vs[k]) / (ts[k + 1] - ts[k])
            level = vs[k] if ts[k + 1] - ts[k] >= 0.5 * (zero - release) else vs[k + 1] - slope * 0.0
    return {"release": release, "offgoing_level": min(max(level, 0.0), 1.0), "offgoing_ramp": max(zero - release, 0.01)}


def _points(signal, t_a: float, t_b: float) -> list[tuple[float, float]]:
    """The corner points of a piecewise-linear ``signal`` on ``[t_a, t_b]`` (jumps as two points
    at one time)."""
    if not getattr(signal, "piecewise_linear", False):
        raise ScenarioError("the apply signal is not piecewise linear: give it as a table to calibrate it")
    out = []
    for t in sorted({t_a, t_b, *signal.breakpoints(t_a, t_b)}):
        left = signal.value(math.nextafter(t, -math.inf))
        if out and abs(left - signal.value(t)) > 1e-12:
            out.append((t, left))
        out.append((t, signal.value(t)))
    return out


# ------------------------------------------------------------------------------- calibration


@dataclass(frozen=True)
class ShiftPlan:
    """One shift of the scenario to tune: its number (from 1), ``name`` (``1-2`` where the gears
    are known), oncoming and offgoing element, command time ``t_start`` [s] of the starting
    calibration, the starting ``template`` and, for raw tables, the end of the raw transition
    ``t_raw_end`` [s] and the fit's RMS difference ``fit_residual`` (apply fraction)."""

    number: int
    name: str
    oncoming: str
    offgoing: str
    t_start: float
    template: object
    key: str = ""
    t_raw_end: float | None = None
    fit_residual: float | None = None


@dataclass(frozen=True)
class Calibration:
    """How the scenario carries its shift calibration: ``kind`` ``"tables"`` (raw apply tables),
    ``"events"`` (``[shifts] events``) or ``"auto"`` (``[auto_shift]``), with what
    :meth:`overrides` needs (the raw signals of the shift elements, the events)."""

    kind: str
    t_start: float
    raw: Mapping[str, object] = field(default_factory=dict)  # element -> raw apply Signal ("tables")
    events: tuple = ()  # the [shifts] events as plain data ("events")
    request: object = None  # the scenario's own [input] torque_request Signal ("tables"), None: none

    def overrides(self, plans: Sequence[ShiftPlan], templates: Mapping[int, object]) -> dict:
        """Dotted-key overrides that give the shifts ``templates`` (shift number -> template);
        the other shifts keep their own calibration."""
        if self.kind == "auto":
            return {f"auto_shift.templates.{p.key}": templates[p.number].as_data() for p in plans
                    if p.number in templates}
        if self.kind == "events":
            events = [dict(ev) for ev in self.events]
            for p in plans:
                if p.number in templates:
                    events[int(p.key)]["template"] = templates[p.number].as_data()
            return {"shifts.events": events}
        pieces: dict[str, list] = {}
        for p in plans:
            if p.number not in templates:
                continue
            tmpl = templates[p.number]
            for element, points in ((p.oncoming, tmpl.oncoming(p.t_start)), (p.offgoing, tmpl.offgoing(p.t_start))):
                t_end = max(points[-1][0], p.t_raw_end)
                pieces.setdefault(element, []).append((p.t_start, t_end, points))
        out = {}
        for element, spans in pieces.items():
            out[f"elements.{element}.apply"] = _spliced_table(self.raw[element], spans, self.t_start)
        from transgen.sim.control.schedule import request_table

        if self.request is not None:  # the scenario's own request, with the span of each shift whose template
            spans = []                   # intervenes replaced by its profile
            for p in plans:
                if p.number in templates and templates[p.number].torque_intervention:
                    profile = templates[p.number].torque_request(p.t_start)
                    t_end = max([t for t, _ in profile] + [p.t_raw_end or p.t_start])
                    spans.append((p.t_start, t_end, [(p.t_start, 1.0)] + profile + [(t_end, 1.0)]))
            if spans:
                out["input.torque_request"] = _spliced_table(self.request, spans, self.t_start)
            return out
        request = request_table([templates[p.number].torque_request(p.t_start) for p in plans if p.number in templates])
        if request is not None:  # the tuned engine torque intervention of the shifts
            out["input.torque_request"] = {"type": "table", "t": list(request.times), "value": list(request.values)}
        return out


def _spliced_table(raw, spans, t_run: float) -> dict:
    """The table of ``raw`` with each span ``(t_a, t_b, points)`` replaced by ``points``."""
    from transgen.sim.control.schedule import _merge

    spans = sorted(spans)
    last = max([t_b for _, t_b, _ in spans] + [t_run]) + 1.0
    bps = [b for b in raw.breakpoints(t_run, math.inf)] if getattr(raw, "piecewise_linear", False) else []
    horizon = max(bps + [last]) + 1.0
    points = []
    cursor = t_run
    for t_a, t_b, piece in spans:
        points += [pt for pt in _points(raw, cursor, t_a) if pt[0] < t_a]
        points += [(t_a, raw.value(math.nextafter(t_a, -math.inf)))] if t_a > t_run else []
        points += list(piece)
        cursor = t_b
    level = piece[-1][1]
    tail = [pt for pt in _points(raw, cursor, horizon) if pt[0] > cursor]
    # after the last span the raw table goes on from its own level there (held by the template's end)
    points += [(cursor, level)] + tail
    table = _merge(points)
    return {"type": "table", "t": list(table.times), "value": list(table.values)}


def plan_calibration(path, files: Mapping[str, str], result, scenario) -> tuple[Calibration, list[ShiftPlan]]:
    """The calibration of the scenario and its shifts (from the shift report of its run
    ``result``), each with its starting template (fitted to raw tables where it has them)."""
    from transgen.sim.analysis.report import shift_report
    from transgen.sim.control.schedule import ShiftTemplate

    qualities = shift_report(result, scenario.shifts or None)
    data = scenario.data
    tr = scenario.powertrain.transmission
    t_run = scenario.options.t_start
    plans: list[ShiftPlan] = []
    if data.get("auto_shift"):
        ctl = scenario.powertrain.controllers[0]
        commands = [h for h in ctl.history]
        for k, q in enumerate(qualities, start=1):
            match = min(commands, key=lambda h: abs(h[0] - q.t_start), default=None)
            if match is None or abs(match[0] - q.t_start) > 1e-3:
                continue
            key = f"{match[1]}-{match[2]}"
            raw = (data["auto_shift"].get("templates") or {}).get(key)
            tmpl = ShiftTemplate(**raw) if raw else ctl.template
            plans.append(ShiftPlan(len(plans) + 1, key, q.oncoming, q.offgoing, q.t_start, tmpl, key))
        return Calibration("auto", t_run), plans
    events = (data.get("shifts") or {}).get("events") or []
    if events:
        from transgen.sim.control.schedule import ShiftTemplate as T

        default = (data.get("shifts") or {}).get("template") or {}
        plain = tuple({k: v for k, v in ev.items()} for ev in events)
        order = sorted(range(len(events)), key=lambda i: events[i]["t"])
        for q in qualities:
            i = min(order, key=lambda j: abs(events[j]["t"] - q.t_start))
            ev = events[i]
            tmpl = T(**{**default, **(ev.get("template") or {})})
            plans.append(ShiftPlan(len(plans) + 1, f"{ev['from']}-{ev['to']}", q.oncoming, q.offgoing,
                                   float(ev["t"]), tmpl, str(i)))
        return Calibration("events", t_run, events=plain), plans
    raw = {e.name: e.apply for e in tr.elements}
    starts = [q.t_start for q in qualities] + [scenario.options.t_end]
    for k, q in enumerate(qualities):
        on, off = raw[q.oncoming], raw[q.offgoing]
        limit = starts[k + 1]
        ts = np.linspace(q.t_start, limit, 2000)
        a_on = np.array([on.value(t) for t in ts])
        a_off = np.array([off.value(t) for t in ts])
        full = ts[np.argmax(a_on >= a_on.max() - 1e-9)]
        zero = ts[np.argmax(a_off <= 1e-9)] if np.any(a_off <= 1e-9) else limit
        t_end = max(full, zero)
        tmpl, residual = fit_template(on, off, q.t_start, min(limit, t_end + 0.1))
        name = q.name  # the shift report's name: its gears (1-2), transgen.names
        plans.append(ShiftPlan(len(plans) + 1, name, q.oncoming, q.offgoing, q.t_start, tmpl, name, float(t_end), residual))
    request = next((c.request for c in scenario.powertrain.components if getattr(c, "request", None) is not None), None)
    return Calibration("tables", t_run, raw=raw, request=request), plans


def reference_limits(reference, overrides: Mapping, plans: Sequence[ShiftPlan]) -> dict[int, tuple]:
    """The torque hole [%] and clutch energy [J] of the scenario ``reference`` (a file or bundled
    name, run with the same ``overrides``) at each shift of ``plans``, matched by name (its gears,
    ``1-2``; the k-th shift of a name to the reference's k-th of that name): {plan number:
    (hole or None, energy)}. ScenarioError where the reference's run fails or lacks a shift."""
    from transgen.sim import load_scenario, scenario_files
    from transgen.sim.analysis.report import shift_report
    from transgen.sim.scenario.load import scenario_path

    key = str(scenario_path(reference).resolve())
    files = scenario_files(key, overrides)
    scenario = load_scenario(key, overrides, files)
    result = scenario.run()
    if not result.success:
        raise ScenarioError(f"--no-worse-than {reference}: error: its run fails, nothing to compare with: {result.message}")
    try:
        _, ref_plans = plan_calibration(key, files, result, scenario)
    except ScenarioError as exc:
        said = str(exc) if ": error: " in str(exc) else f"error: {exc}"
        raise ScenarioError(f"--no-worse-than {reference}: {said}") from None
    qualities = shift_report(result, scenario.shifts or None)
    by_name: dict[str, list] = {}
    for p in ref_plans:
        q = min(qualities, key=lambda q, t=p.t_start: abs(q.t_start - t))
        by_name.setdefault(p.name, []).append((q.torque_hole_pct, q.energy_total))
    limits, seen = {}, {}
    for p in plans:
        k = seen[p.name] = seen.get(p.name, -1) + 1
        found = by_name.get(p.name, [])
        if k >= len(found):
            raise ScenarioError(f"--no-worse-than {reference}: error: its run has no shift {p.name} to compare with "
                                f"(its shifts: {', '.join(by_name) or 'none'})")
        limits[p.number] = found[k]
    return limits


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


# ---------------------------------------------------------------------------------- workers


def evaluate_candidate(shared: Mapping, task: tuple) -> tuple[int, dict]:
    """Executor entry point: one candidate's shift window. ``shared``: ``path`` and ``files``
    (the scenario's texts), ``state`` (the saved state before the shift), ``shift``
    (oncoming, offgoing, t_start, name), ``limit`` (latest window end [s]); ``task``: (index,
    overrides, window end [s]). Returns (index, metrics); never raises for a failed run."""
    from transgen.errors import TransgenError
    from transgen.sim import load_scenario

    index, overrides, t_end = task
    start = time.process_time()
    try:
        scenario = load_scenario(shared["path"], overrides, shared["files"])
        result = scenario.run(start=shared["state"], t_end=t_end)
        on, off, t0, name = shared["shift"]
        metrics = shift_metrics(result, on, off, t0, name)
    except TransgenError as exc:
        metrics = {"success": False, "message": str(exc)}
    except Exception as exc:  # noqa: BLE001 - an unexpected failure of one candidate is its row
        metrics = {"success": False, "message": f"{type(exc).__name__}: {exc}"}
    metrics["cpu_time"] = time.process_time() - start
    return index, metrics


# --------------------------------------------------------------------------------- optimizer


@dataclass
class ShiftOutcome:
    """The tuning of one shift: its plan, the starting and best template, their metrics and
    scores, whether the best is feasible and, if not, the binding constraint; the number of
    evaluations and the CPU time [s] of this process and of the evaluations."""

    plan: ShiftPlan
    start_template: object
    best_template: object
    start_metrics: dict
    best_metrics: dict
    start_score: float
    best_score: float
    feasible: bool
    violations: dict
    evaluations: int
    wall_time: float
    cpu_time: float
    evaluation_cpu_time: float
    constraints: Constraints | None = None  # this shift's own (the reference's limits applied), None: the run's

    @property
    def binding(self) -> str | None:
        """The constraint violated most by the best candidate (None when feasible)."""
        return max(self.violations, key=self.violations.get) if self.violations else None


@dataclass
class OptimizeResult:
    """What :func:`optimize` found: the outcome per shift, the calibration and the overrides of
    the tuned scenario (dotted keys -> values), the history of every evaluation."""

    path: str
    title: str
    objective: Objective
    constraints: Constraints
    calibration: Calibration
    plans: list
    shifts: list
    overrides: dict
    history: list
    seed: int
    parameters: tuple = PARAMETERS  # the tuned template parameters (PARAMETERS, and TORQUE_PARAMETERS with an engine)

    @property
    def engine_torque(self) -> bool:
        """Whether the engine torque intervention was tuned."""
        return "torque_boost" in self.parameters

    @property
    def feasible(self) -> bool:
        return all(s.feasible for s in self.shifts)

    def shift_history(self) -> list[list[dict]]:
        """The history's rows of each tuned shift (in the order of :attr:`shifts`)."""
        parts, start = [], 0
        for s in self.shifts:
            parts.append(self.history[start:start + s.evaluations])
            start += s.evaluations
        return parts


@dataclass(frozen=True)
class OptimizeProgress:
    """Where :func:`optimize` is: shift ``shift`` of ``shifts`` (its name), evaluations of it
    so far, the best score and whether it is feasible."""

    shift: int
    shifts: int
    name: str
    evaluations: int
    budget: int
    best: float
    feasible: bool
    rate: float

    def text(self) -> str:
        from transgen.progress import clock

        left = ((self.budget - self.evaluations) + (self.shifts - self.shift) * self.budget) / self.rate \
            if self.rate > 0 else None
        return (f"shift {self.shift}/{self.shifts} {self.name}: {self.evaluations}/{self.budget} evaluations, "
                f"best {self.best:.4g}{'' if self.feasible else ' (infeasible)'}, {self.rate:.1f} evaluations/s"
                + ("" if left is None else f", at most {clock(left)} left"))


def _bounds(template, t_gap: float, names: Sequence[str] = PARAMETERS) -> list[tuple[float, float]]:
    """The search box of the parameters ``names``: :data:`BOUNDS` widened to hold ``template``,
    the times limited so that a shift's trajectories end within ``t_gap`` [s] (the time to the next
    shift, less the settle time)."""
    out = []
    for k in names:
        lo, hi = BOUNDS[k]
        v = getattr(template, k)
        if k.endswith(("_time", "_delay", "_ramp")):
            hi = min(max(hi, v), max(t_gap / 3.0, lo + 1e-3, v))
        out.append((min(lo, v), max(hi, v)))
    return out


def optimize(path, shifts: Sequence[str] | None = None, objective: Objective = Objective(),
             constraints: Constraints = Constraints(), executor=None, seed: int = 0, max_evaluations: int = 1600,
             population: int = 12, progress: Callable | None = None, overrides: Mapping | None = None,
             engine_torque: bool | None = None, force: bool = False,
             estimate: Callable[[str], None] | None = None) -> OptimizeResult:
    """Tune the shifts of the scenario ``path`` (all, or those named in ``shifts``: ``1-2`` or a
    number from 1); see the module docstring. ``max_evaluations``: simulations per shift at most
    (the start and every stage; whole generations of ``population`` candidates and compass
    steps, so a few less may run); ``executor``: where candidates run (default in
    this process); ``progress(OptimizeProgress)`` after every generation; ``overrides``: dotted
    keys set in the scenario first (as ``--set``); ``engine_torque``: tune the engine torque
    intervention too (None: where the input is an engine; False: the clutches only, the
    scenario's own intervention kept; True: an error without an engine). Before the first
    evaluation the budget's time (the shifts tuned x ``max_evaluations`` x
    :data:`~transgen.limits.EVALUATION_CPU`) is checked against the limit ``optimize_time``
    (``force`` passes it) and given to ``estimate`` (``about 5.3 min of CPU (...)``)."""
    from transgen.limits import check_optimize

    from .executors import SerialExecutor

    check_optimize(max_evaluations, population, force=True)  # the hard limits; the command line has --force
    from transgen.sim.core.jit import expect_many_runs

    expect_many_runs()  # the candidates pay for the compiled kernels (transgen.sim.core.jit.jit_enabled)
    executor = executor or SerialExecutor()
    with executor:  # one pool of workers (or Dask client) for all the generations
        return _optimize(path, shifts, objective, constraints, executor, seed, max_evaluations, population, progress,
                         dict(overrides or {}), engine_torque, (force, estimate))


def _check_time(shifts: int, evaluations: int, executor, force: bool, estimate) -> None:
    """The time of the budget (``shifts`` x ``evaluations`` at :data:`~transgen.limits.EVALUATION_CPU`),
    refused over the limit ``optimize_time`` unless ``force``; the estimate to ``estimate``."""
    from transgen.limits import EVALUATION_CPU, check_time, human_time

    text = check_time("optimize_time", shifts * evaluations * EVALUATION_CPU,
                      f"--evaluations {evaluations} ({shifts} shift(s))",
                      f"{shifts} shift(s) x {evaluations} evaluations at about {human_time(EVALUATION_CPU)} each",
                      getattr(executor, "workers", 1), force)
    if estimate is not None:
        estimate(text)


def _optimize(path, shifts, objective, constraints, executor, seed, max_evaluations, population, progress, base,
              engine_torque=None, timing=(False, None)):
    from transgen.sim import load_scenario, scenario_files
    from transgen.sim.scenario.load import scenario_path

    key = str(scenario_path(path).resolve())
    files = scenario_files(key, base)
    scenario = load_scenario(key, base, files)
    if scenario.options.model != "switching":
        raise ScenarioError(f"{path}: error: shift calibration runs the switching clutch model (the scenario uses "
                            f"{scenario.options.model!r})")
    baseline = scenario.run()
    if not baseline.success:
        raise ScenarioError(f"{path}: error: the scenario's own run fails, nothing to calibrate from: {baseline.message}")
    calibration, plans = plan_calibration(key, files, baseline, scenario)
    if not plans:
        raise ScenarioError(f"{path}: error: the scenario has no shift to calibrate")
    engine = has_engine(scenario)
    if engine_torque and not engine:
        raise ScenarioError(f"{path}: error: the engine torque intervention needs an engine at the input (the scenario's "
                            f"input is a prescribed torque); tune the clutches only")
    engine_torque = engine if engine_torque is None else engine_torque
    if not engine_torque:  # the scenario's own torque request stays as it is
        calibration = replace(calibration, request=None)
    names = PARAMETERS + (TORQUE_PARAMETERS if engine_torque else ())
    selected = _select(plans, shifts, path)
    _check_time(len(selected), max_evaluations, executor, *timing)
    limits = reference_limits(constraints.no_worse_than, base, selected) if constraints.no_worse_than else {}
    templates = {p.number: p.template for p in plans if p.number in {s.number for s in selected}}
    history: list[dict] = []
    outcomes: list[ShiftOutcome] = []
    state = None
    t_state = scenario.options.t_start
    chosen = dict(templates)
    for n, plan in enumerate(selected, start=1):
        wall0, cpu0 = time.perf_counter(), time.process_time()
        own = constraints.for_shift(*limits.get(plan.number, (None, None)))  # this shift's, the reference's limits applied
        # the run up to just before this shift, with the shifts tuned so far, from the last state
        fixed = {k: v for k, v in chosen.items() if k < plan.number}
        run_overrides = {**base, **calibration.overrides(plans, fixed)}
        if calibration.kind == "auto":  # the schedule commands the shift when the output speed crosses its line
            current = load_scenario(key, run_overrides, files).run()
            if not current.success:
                raise ScenarioError(f"{path}: error: the run with the shifts tuned before {plan.name} fails: "
                                    f"{current.message}")
            plan = _refresh(plan, current)
        t_window = max(plan.t_start - _pre_window() - PRE_MARGIN, t_state)
        before = load_scenario(key, run_overrides, files).run(start=state, t_end=t_window) if t_window > t_state else None
        window_state = before.state if before is not None else state
        nxt = [p.t_start for p in plans if p.t_start > plan.t_start + 1e-9]
        limit = (min(nxt) - 1e-3) if nxt else scenario.options.t_end
        if calibration.kind == "auto":  # the next command of the run with the shifts tuned so far
            limit = _next_command(current, plan.t_start, scenario.options.t_end)
        shared = {"path": key, "files": files, "state": window_state,
                  "shift": (plan.oncoming, plan.offgoing, plan.t_start, plan.name), "limit": limit}

        stage = {"names": PARAMETERS, "base": plan.template}  # the parameters searched now, the others from base

        def task_of(index, x, p=plan):
            tmpl = _template(x, stage["names"], stage["base"])
            ov = {**base, **calibration.overrides(plans, {**fixed, p.number: tmpl})}
            return index, ov, min(limit, p.t_start + _span(tmpl) + SETTLE)

        # the starting calibration, evaluated first: the reference of the objective's terms
        [(_, start_metrics)] = list(executor.run(evaluate_candidate, shared,
                                                 [task_of(0, _vector(plan.template, PARAMETERS))]))
        reference = start_metrics if start_metrics.get("success") else {}
        start_score, start_terms, start_viol = score(start_metrics, reference, objective, own)
        best = {"score": start_score, "template": plan.template, "metrics": start_metrics, "violations": start_viol}
        history.append(_row(plan, 0, 0, _vector(plan.template, names), names, start_metrics, start_score, start_terms,
                            start_viol))
        counter = {"evaluations": 1, "generation": 0, "cpu": start_metrics.get("cpu_time", 0.0)}
        total = max(population, max_evaluations - 1)  # after the start: the clutch stage, then the engine torque
        budget = math.floor(CLUTCH_SHARE * total) if engine_torque else total
        torque_budget = total - budget
        t_gen = time.perf_counter()

        def batch_map(func, population_x, p=plan, own=own):
            xs = [np.asarray(x, dtype=float) for x in population_x]
            tasks = [task_of(i, x) for i, x in enumerate(xs)]
            rows = dict(executor.run(evaluate_candidate, shared, tasks))
            counter["generation"] += 1
            scores = []
            for i, x in enumerate(xs):
                m = rows[i]
                s, terms, viol = score(m, reference, objective, own)
                scores.append(s)
                counter["evaluations"] += 1
                counter["cpu"] += m.get("cpu_time", 0.0)
                tmpl = _template(x, stage["names"], stage["base"])
                history.append(_row(p, counter["generation"], counter["evaluations"] - 1, _vector(tmpl, names), names,
                                    m, s, terms, viol))
                if s < best["score"]:
                    best.update(score=s, x=x, template=tmpl, metrics=m, violations=viol)
            if progress is not None:
                elapsed = max(time.perf_counter() - t_gen, 1e-9)
                progress(OptimizeProgress(n, len(selected), p.name, counter["evaluations"], total + 1,
                                          best["score"], not best["violations"], (counter["evaluations"] - 1) / elapsed))
            return scores

        # the clutches: the nine apply parameters from the scenario's calibration
        gap = limit - plan.t_start - SETTLE
        best["x"] = _vector(plan.template, PARAMETERS)
        _search(batch_map, best, counter, _bounds(plan.template, gap, PARAMETERS), budget, population, seed)
        if engine_torque:  # then the engine torque with them, from the best clutch calibration
            stage.update(names=names, base=best["template"])
            best["x"] = _vector(best["template"], names)
            bounds = _bounds(best["template"], gap, names)
            fresh = np.array([k in TORQUE_PARAMETERS for k in names])
            _search(batch_map, best, counter, bounds, budget + torque_budget - (counter["evaluations"] - 1), population,
                    seed + 1, fresh=fresh)
        tuned = best["template"]
        chosen[plan.number] = tuned
        best_score = best["score"]
        if best_score >= start_score:  # nothing better than the start: keep the scenario's own
            tuned, chosen[plan.number] = plan.template, plan.template
        outcomes.append(ShiftOutcome(plan, plan.template, tuned, start_metrics, best["metrics"], start_score,
                                     min(best_score, start_score), not best["violations"], dict(best["violations"]),
                                     counter["evaluations"], time.perf_counter() - wall0, time.process_time() - cpu0,
                                     counter["cpu"], own))
        state, t_state = window_state, t_window if before is not None else t_state
    final = {**base, **calibration.overrides(plans, chosen)}
    return OptimizeResult(key, scenario.title, objective, constraints, calibration, plans, outcomes, final, history, seed,
                          names)


def _search(batch_map, best: dict, counter: dict, bounds, budget: int, population: int, seed: int,
            fresh=None) -> None:
    """One search of at most ``budget`` evaluations over the box ``bounds`` from ``best["x"]``:
    CMA-ES (``population`` candidates per generation, one batch each) for :data:`CMA_SHARE` of the
    budget, then the compass search (:func:`_compass`) from the best candidate with the rest.
    ``batch_map(None, xs)`` evaluates a batch, returns the scores and updates ``best``.

    The search runs in the box scaled to the unit cube, from ``best["x"]`` with a step of
    :data:`SIGMA` of each range. The parameters marked in ``fresh`` (a boolean mask: searched for
    the first time, e.g. the engine torque intervention after the clutches) start from the
    middle of their box with :data:`FRESH_STEP` times that step, the others (already tuned) with
    :data:`TUNED_STEP` times it. Candidates outside the box are brought in by pycma's boundary
    transformation (continuous, so the search sees no wall)."""
    import cma

    lo = np.array([b[0] for b in bounds], dtype=float)
    hi = np.array([b[1] for b in bounds], dtype=float)
    width = np.where(hi > lo, hi - lo, 1.0)
    u0 = np.clip((np.asarray(best["x"], dtype=float) - lo) / width, 0.0, 1.0)
    stds = np.ones(len(bounds))
    if fresh is not None:
        u0 = np.where(fresh, 0.5, u0)
        stds = np.where(fresh, FRESH_STEP, TUNED_STEP)
    rng = np.random.default_rng(seed)  # pycma's own normal samples from it: no global random state
    es = cma.CMAEvolutionStrategy(u0, SIGMA, {
        "bounds": [0.0, 1.0], "popsize": population, "CMA_stds": list(stds), "seed": float("nan"),
        "randn": lambda *shape: rng.standard_normal(shape), "verbose": -9, "verb_log": 0, "verb_disp": 0,
        # stop on the budget or a step below ~1e-5 of the box; the penalties' plateaus are no reason to stop
        "tolfun": 0.0, "tolfunhist": 0.0, "tolx": 1e-5, "tolflatfitness": math.inf, "tolstagnation": math.inf})
    first = counter["evaluations"]
    share = CMA_SHARE * budget if (1.0 - CMA_SHARE) * budget >= 2 * len(bounds) else budget  # room for a compass step
    while counter["evaluations"] - first + population <= share and not es.stop():
        us = es.ask()
        es.tell(us, batch_map(None, [lo + np.clip(u, 0.0, 1.0) * (hi - lo) for u in us]))
    _compass(batch_map, best, bounds, budget - (counter["evaluations"] - first))


def _compass(evaluate, best: dict, bounds, budget: int, step: float = 0.05, smallest: float = 1e-3) -> None:
    """Polish ``best`` (``x``, ``score``) by a compass search that spends at most ``budget``
    evaluations: each batch tries a step up and down along every parameter (a step is a fraction
    of the parameter's range, 5 % at first), all at once; the best point that improves is taken,
    else the step is halved, down to ``smallest``. Parallel like a generation, deterministic, and
    robust to the kinks of the simulated metrics (it compares values only)."""
    lo = np.array([b[0] for b in bounds])
    hi = np.array([b[1] for b in bounds])
    n = len(bounds)
    while budget >= 2 * n and step >= smallest:
        x0 = np.asarray(best["x"], dtype=float)
        trial = []
        for i in range(n):
            for sign in (1.0, -1.0):
                x = x0.copy()
                x[i] = np.clip(x[i] + sign * step * (hi[i] - lo[i]), lo[i], hi[i])
                trial.append(x)
        before = best["score"]
        evaluate(None, trial)  # updates best
        budget -= len(trial)
        if not best["score"] < before:
            step *= 0.5


def _pre_window() -> float:
    from transgen.sim.analysis.shift_quality import PRE_WINDOW

    return PRE_WINDOW


def _next_command(result, t0: float, t_end: float) -> float:
    later = [e.t for e in result.events if e.kind == "command" and e.t > t0 + 1e-9]
    return (min(later) - 1e-3) if later else t_end


def _refresh(plan: ShiftPlan, result) -> ShiftPlan:
    """``plan`` with its command time from ``result`` (the whole run with the shifts tuned before
    it: an automatic schedule commands the shift when the output speed crosses its line, earlier
    or later than before). The schedule's shifts come in the same order, so the plan's number is
    its place in the shift report; a schedule that shifts otherwise now is an error."""
    from transgen.sim.analysis.report import shift_report

    qualities = shift_report(result)
    q = qualities[plan.number - 1] if plan.number <= len(qualities) else None
    if q is None or (q.oncoming, q.offgoing) != (plan.oncoming, plan.offgoing):
        raise ScenarioError(f"{result.meta.get('scenario', '')}: error: with the shifts tuned before {plan.name} the "
                            f"automatic schedule no longer commands it as shift {plan.number}")
    return replace(plan, t_start=q.t_start)


def _select(plans: list[ShiftPlan], names: Sequence[str] | None, path) -> list[ShiftPlan]:
    if not names:
        return plans
    out = []
    for name in names:
        name = str(name).replace("->", "-")  # the separator of shift names before gear names
        found = [p for p in plans if p.name == name or str(p.number) == name]
        if not found:
            known = ", ".join(f"{p.number} ({p.name})" for p in plans)
            raise ValueError(f"--shift {name}: error: no such shift in {path} (shifts: {known})")
        out += [p for p in found if p not in out]
    return sorted(out, key=lambda p: p.number)


def trade_off(rows: Sequence[Mapping], metrics: Sequence[str] = ("hole", "energy")) -> list[dict]:
    """The feasible candidates among ``rows`` (one shift's history rows) that no other feasible one
    beats on every one of ``metrics`` (lower is better; the shift window's numbers), without
    repeats, sorted by the first metric: the trade between them that the objective's weights
    choose a point of. A point of it is reached again with the constraints (``--max-hole``,
    ``--max-energy``)."""
    points = sorted({tuple(float(r[m]) for m in metrics): r for r in rows
                     if r.get("feasible") and all(r.get(m) is not None for m in metrics)}.items())
    front: list[dict] = []
    for values, row in points:  # in order of the first metric: kept where nothing before beats it on the rest
        if not any(all(float(f[m]) <= v for m, v in zip(metrics[1:], values[1:])) for f in front):
            front.append(row)
    return front


def _row(plan, generation, index, x, names, metrics, s, terms, violations) -> dict:
    row = {"shift": plan.name, "generation": generation, "evaluation": index}
    row.update({k: float(v) for k, v in zip(names, x)})
    row.update({k: metrics.get(k) for k in ("success", "completed", "energy", "duration", "hole", "flare", "bindup",
                                            "chatter", "jerk", "cpu_time")})
    row.update({"score": s, "feasible": not violations, "violations": ";".join(sorted(violations)),
                "message": metrics.get("message", "")})
    return row


# ------------------------------------------------------------------------------- the output


def tuned_scenario_text(result: OptimizeResult, output, before: Sequence | None = None,
                        after: Sequence | None = None) -> str:
    """The tuned scenario: a file that includes the original and sets the tuned tables, with a
    comment header stating the objective, the constraints, each shift's engine torque
    intervention and, where given, the shift report's numbers before and after
    (``before``/``after``: :class:`ShiftQuality` lists of full runs). The original is included
    by its bundled name when it is a bundled scenario, else by its path relative to the output's
    folder, so the file runs from any working directory (and moves with its original)."""
    import os
    from pathlib import Path

    from transgen.sim.scenario.overrides import toml_value
    from transgen.sim.scenario.load import bundled_scenarios

    original = Path(result.path)
    out_dir = Path(output).resolve().parent
    bundled = original.parent == next(iter(bundled_scenarios().values())).parent
    ref = original.stem if bundled and not (out_dir / original.stem).exists() else os.path.relpath(original, out_dir)
    lines = [f"# Shift calibration by 'transgen optimize' of {ref}",  # no path of this machine
             f"# objective: {result.objective.text()} (terms relative to the starting calibration of each shift)",
             f"# constraints: {result.constraints.text()}", f"# seed: {result.seed}",
             f"# tuned: {', '.join(result.parameters)}"
             + ("" if result.engine_torque else " (clutches only: the engine torque intervention was not tuned)"),
             "# The scenario is the original (included) with the tuned apply trajectories below."]
    for s in result.shifts:
        status = "feasible" if s.feasible else f"INFEASIBLE (binding: {s.binding})"
        lines.append(f"# shift {s.plan.name} ({s.plan.oncoming} on, {s.plan.offgoing} off): {status}, "
                     f"{s.evaluations} evaluations, score {s.start_score:.4g} -> {s.best_score:.4g}")
        if result.constraints.no_worse_than and s.constraints is not None:
            c = s.constraints
            hole = "free" if c.max_hole_pct is None else f"<= {c.max_hole_pct:.1f} %"
            lines.append(f"#   limits (no worse than {result.constraints.no_worse_than}): torque hole {hole}, "
                         f"clutch energy <= {c.max_energy / 1e3:.2f} kJ")
        if s.plan.fit_residual is not None:
            lines.append(f"#   raw tables fitted to the template (RMS apply difference {s.plan.fit_residual:.3g})")
        lines.append(f"#   engine torque intervention: "
                     f"{intervention_text(s.best_template, result.calibration.request is not None)}")
    if before is not None and after is not None:
        lines.append("# shift report of the whole run, before -> after:")
        lines += ["#   " + row for row in comparison_rows(before, after)]
    lines += ["", f"include = [{toml_value(ref)}]", f"title = {toml_value(result.title + ' (tuned)')}", ""]
    tables: dict[str, list[str]] = {}
    for dotted, value in result.overrides.items():
        parts = dotted.split(".")
        table, name = ".".join(parts[:-1]), parts[-1]
        tables.setdefault(table, []).append(f"{name if name.replace('_', '').isalnum() else toml_value(name)} = "
                                            f"{toml_value(value)}")
    for table, entries in tables.items():
        lines.append(f"[{table}]")
        lines += entries
        lines.append("")
    return "\n".join(lines)


#: the shift report's numbers that the comparison shows: (label, attribute, format)
COMPARED = (("hole %", "torque_hole_pct", ".1f"), ("energy kJ", "energy_total", ".2f"), ("flare rpm", "flare_max_rpm", ".1f"),
            ("bindup", "bindup", ""), ("chatter", "chatter", ""), ("duration s", "shift_duration", ".3f"),
            ("jerk m/s^3", "jerk_max", ".1f"), ("engine x max/min", "torque_request", ""))


def _cell(q, attr: str, fmt: str) -> str:
    if q is None:
        return "-"
    if attr == "torque_request":  # the engine torque intervention: highest and lowest factor
        low, high = getattr(q, "torque_request_min", None), getattr(q, "torque_request_max", None)
        return "none" if low is None or low == high == 1.0 else f"{high:.2f}/{low:.2f}"
    v = getattr(q, attr, None)
    if v is None:
        return "-"
    if attr == "energy_total":
        v = v / 1e3
    if isinstance(v, bool):
        return "yes" if v else "no"
    return format(v, fmt)


def comparison_rows(before: Sequence, after: Sequence, labels: tuple[str, str] = ("before", "after")) -> list[str]:
    """Side-by-side lines of the shift report's numbers of two runs (the shifts in order)."""
    width = max(10, *(len(x) + 2 for x in labels))
    rows = [f"{'':<10}" + "".join(f"{label:^{2 * width}}" for label, _, _ in COMPARED),
            f"{'shift':<10}" + "".join(f"{labels[0]:>{width}}{labels[1]:>{width}}" for _ in COMPARED)]
    for k in range(max(len(before), len(after))):
        b = before[k] if k < len(before) else None
        a = after[k] if k < len(after) else None
        name = (a or b).name
        rows.append(f"{name:<10}" + "".join(f"{_cell(b, attr, fmt):>{width}}{_cell(a, attr, fmt):>{width}}"
                                            for _, attr, fmt in COMPARED))
    return rows
