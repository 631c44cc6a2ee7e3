"""What a finished shift calibration gives: the trade-off between a shift's candidates, the tuned
scenario text and the before/after rows of the report."""
from __future__ import annotations

import math
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import asdict, dataclass, field, fields, replace

import numpy as np

from transgen.errors import ScenarioError

from .templates import intervention_text

__all__ = ["trade_off", "tuned_scenario_text", "comparison_rows", "COMPARED"]



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


# ------------------------------------------------------------------------------- the output


def tuned_scenario_text(result: "OptimizeResult", output, before: Sequence | None = None,
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
