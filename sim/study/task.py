"""One run of a study: scenario texts + overrides -> a row of scalars.

This is what a worker executes, in this process, a local process or on a Dask worker: it gets the
texts of every file the scenario reads (:func:`transgen.sim.scenario_files`), the scenario's path
(the key of its text) and the overrides, never live objects, so that every executor computes the
same numbers. A failed run (a :class:`~transgen.errors.ScenarioError`, a
:class:`~transgen.errors.SimulationError`, an invariant violation, any unexpected exception) is a
row with ``success = False`` and its message.

The scalars are found generically in the JSON of the reports: the energy balance
(:func:`transgen.sim.analysis.report.energy_balance`) as ``energy.NAME``, every scalar of each shift's
:meth:`~transgen.sim.analysis.shift_quality.ShiftQuality.to_dict` as ``shift.<shift>.NAME`` (the shift
by its name, ``shift.1-2.torque_hole``, a repeated one ``shift.2-3#2``: :func:`.table.shift_columns`;
the per-element dicts as ``shift.1-2.energy.C4``), and where a turbodiesel runs the
:class:`~transgen.sim.engine.turbo_report.TurboReport` as ``turbo.NAME``. Lists (notes) are left out.
"""
from __future__ import annotations

import time
from collections.abc import Mapping

__all__ = ["run_variant", "run_task", "result_scalars", "flatten", "PRELOAD", "warm_up"]

#: modules a worker needs, imported once when a local worker process starts (not at its first task)
PRELOAD = ("transgen.sim.study.task", "transgen.sim.scenario", "transgen.sim.analysis.report", "transgen.sim.solve.switching",
           "transgen.sim.solve.compliant", "transgen.sim.model.powertrain", "transgen.sim.model.turbodiesel",
           "transgen.sim.engine.turbo_report",
           "transgen.sim.solve.ode_solvers")  # the integrator (scipy.integrate): else imported by the first run

#: fields of the turbo report that compare two runs (a sweep row is one run)
_TURBO_COMPARISONS = ("comparison", "decoupled")


def warm_up() -> None:
    """Load the simulator's compiled code into this process (its kernels built ahead of time, or
    built now after an install: :func:`~transgen.sim.core.jit.jit_enabled`) and import what a run
    needs, with a 0.2-s run of a bundled scenario: a worker pays for it when it starts, not in its
    first task, as it pays for its imports (:data:`PRELOAD`). A failure here is left to the tasks
    to report."""
    from transgen.sim.core.jit import expect_many_runs, jit_enabled

    expect_many_runs()  # a study's worker: its runs pay for compiled kernels (built here once if need be)
    if not jit_enabled():
        return
    from transgen.sim.scenario.load import load_scenario

    try:
        load_scenario("ht740_improved", {"simulation.t_end": 0.2}).run()
    except Exception:  # noqa: BLE001 - a task that needs the simulator says what is wrong
        pass


def flatten(prefix: str, data: Mapping, out: dict | None = None) -> dict:
    """``data`` (JSON-ready) as flat ``prefix.name`` -> scalar (numbers, booleans, strings, None;
    an empty string becomes None); nested dicts give dotted names, lists are left out."""
    out = {} if out is None else out
    for name, value in data.items():
        column = f"{prefix}.{name}" if prefix else str(name)
        if isinstance(value, Mapping):
            flatten(column, value, out)
        elif value is None or isinstance(value, (bool, int, float, str)):
            out[column] = None if value == "" else value  # an empty text is unknown (as in a CSV cell)
    return out


def result_scalars(scenario, result) -> dict:
    """The scalars of a finished run: energy balance, shift report per shift (successful runs
    only: a stopped run has no complete shifts) and turbocharger figures."""
    from transgen.sim.analysis.report import energy_balance, report_dict, shift_report
    from transgen.sim.analysis.shift_quality import jsonable

    row = flatten("energy", jsonable(energy_balance(result)))
    if result.success and len(result.time):
        report = report_dict(result, shift_report(result, scenario.shifts or None))
        from .table import shift_columns

        for prefix, shift in zip(shift_columns(s["name"] for s in report["shifts"]), report["shifts"]):
            flatten(prefix, shift, row)
        if "omega_tc" in result.signals:
            from transgen.sim.engine.turbo_report import turbo_report

            turbo = {k: v for k, v in turbo_report(result).to_dict().items() if k not in _TURBO_COMPARISONS}
            flatten("turbo", jsonable(turbo), row)
    return row


def run_variant(path: str, overrides: Mapping[str, object] | None = None,
                files: Mapping[str, str] | None = None) -> dict:
    """Load the scenario ``path`` with ``overrides`` (its files from ``files`` where given), run
    it and return its row: ``success``, ``message``, ``wall_time`` [s] (load, run and report) and
    the scalars of :func:`result_scalars`. Never raises for a failed run (only for
    KeyboardInterrupt and the like)."""
    from transgen.errors import TransgenError
    from transgen.sim import load_scenario

    start = time.perf_counter()
    row: dict = {"success": False, "message": "", "wall_time": None}
    try:
        scenario = load_scenario(path, overrides, files)
        result = scenario.run()
        row["success"] = bool(result.success)
        row["message"] = str(result.message)
        row.update(result_scalars(scenario, result))
    except TransgenError as exc:
        row["success"], row["message"] = False, str(exc)
    except Exception as exc:  # noqa: BLE001 - an unexpected failure of one run is that run's row
        row["success"], row["message"] = False, f"{type(exc).__name__}: {exc}"
    row["wall_time"] = time.perf_counter() - start
    return row


def run_task(shared: Mapping, task: tuple) -> tuple[int, dict]:
    """Executor entry point: ``shared`` = {"path": scenario key, "files": texts}, ``task`` =
    (index, overrides); returns (index, row)."""
    index, overrides = task
    return index, run_variant(shared["path"], overrides, shared["files"])
