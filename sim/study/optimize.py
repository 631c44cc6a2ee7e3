"""Shift calibration: tune the apply trajectories of each shift of a scenario (``transgen optimize``).

The method (windows from a saved state, CMA-ES then a compass search, the penalties) and its
measurements: docs/explanation/shift-calibration.md.
"""
from __future__ import annotations

import math
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import asdict, dataclass, field, fields, replace

import numpy as np

from transgen.errors import ScenarioError
# the optimizer's parts (re-exported: the module's API is unchanged)
from .scoring import (DEFAULT_OBJECTIVE, INFEASIBLE, OBJECTIVE_TERMS, Constraints, Objective,  # noqa: F401
                      parse_objective, score, shift_metrics)
from .templates import (BOUNDS, EASE_PARAMETERS, PARAMETERS, TORQUE_PARAMETERS, _points, _span, _template, _vector,  # noqa: F401
                        fit_template, has_engine, intervention_text)
from .tuned import COMPARED, comparison_rows, trade_off, tuned_scenario_text  # noqa: F401

__all__ = ["Constraints", "Objective", "ShiftPlan", "Calibration", "ShiftOutcome", "OptimizeResult", "PARAMETERS",
           "TORQUE_PARAMETERS", "EASE_PARAMETERS", "BOUNDS", "has_engine", "intervention_text", "fit_template", "plan_calibration", "evaluate_candidate", "shift_metrics", "score", "optimize",
           "tuned_scenario_text", "parse_objective", "OBJECTIVE_TERMS", "PRE_MARGIN", "SETTLE", "INFEASIBLE"]

PRE_MARGIN = 0.05
"""Time [s] before the shift report's pre-shift window (0.2 s before the shift) where a shift
window starts."""

SETTLE = 0.5
"""Time [s] a shift window goes on after the end of the candidate's trajectories."""

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
    clutch = PARAMETERS + (EASE_PARAMETERS if calibration.kind == "auto" else ())  # easing needs the schedule
    names = clutch + (TORQUE_PARAMETERS if engine_torque else ())
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

        stage = {"names": clutch, "base": plan.template}  # the parameters searched now, the others from base

        def task_of(index, x, p=plan):
            tmpl = _template(x, stage["names"], stage["base"])
            ov = {**base, **calibration.overrides(plans, {**fixed, p.number: tmpl})}
            return index, ov, min(limit, p.t_start + _span(tmpl) + SETTLE)

        # the starting calibration, evaluated first: the reference of the objective's terms
        [(_, start_metrics)] = list(executor.run(evaluate_candidate, shared,
                                                 [task_of(0, _vector(plan.template, clutch))]))
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

        # the clutches: the nine apply parameters (and the easing) from the scenario's calibration
        gap = limit - plan.t_start - SETTLE
        best["x"] = _vector(plan.template, clutch)
        _search(batch_map, best, counter, _bounds(plan.template, gap, clutch), budget, population, seed)
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


def _row(plan, generation, index, x, names, metrics, s, terms, violations) -> dict:
    row = {"shift": plan.name, "generation": generation, "evaluation": index}
    row.update({k: float(v) for k, v in zip(names, x)})
    row.update({k: metrics.get(k) for k in ("success", "completed", "energy", "duration", "hole", "flare", "bindup",
                                            "chatter", "jerk", "cpu_time")})
    row.update({"score": s, "feasible": not violations, "violations": ";".join(sorted(violations)),
                "message": metrics.get("message", "")})
    return row
