"""Run a scenario over a design of overrides: :func:`sweep`.

Every distinct value is checked before any run starts (:func:`validate_variants`: a bad key or
value is a :class:`~transgen.errors.ScenarioError` naming the key, with the closest known key; a
combination that only fails together is a failed row). Each run
is then a task for the executor: the texts of the scenario's files, its path and the overrides
(:func:`.task.run_task`). A failed run is a row, never the end of the sweep.

With ``results=PATH`` the study resumes: rows of an earlier file at that path whose key
(:func:`~.design.row_key`) is in the design are kept and not run again, and the file is
rewritten atomically (temporary file + rename) as rows complete, and once more when the sweep
ends or is interrupted, so that a killed sweep loses nothing it finished. Rows of that file that
are not in the design are kept, after the design's rows.
"""
from __future__ import annotations

import contextlib
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

from .design import check_design, full_grid, latin_hypercube, row_key
from .table import FIRST_COLUMNS, SweepTable, column_shift

__all__ = ["sweep", "SweepProgress", "validate_variants", "design_variants", "scenario_path", "sweep_time"]


@dataclass(frozen=True)
class SweepProgress:
    """Where a sweep is: ``done`` of ``total`` rows (``resumed`` of them from an earlier results
    file), ``failed`` of the done, ``elapsed`` seconds since the runs started; ``estimate``:
    before the first run, the estimate of the runs to do (``about 2.1 min of CPU (...)``,
    :func:`sweep_time`), else ""."""

    done: int
    failed: int
    total: int
    resumed: int
    elapsed: float
    estimate: str = ""

    @property
    def rate(self) -> float:
        """Runs per second finished in this sweep (0 before the first)."""
        ran = self.done - self.resumed
        return ran / self.elapsed if ran and self.elapsed > 0 else 0.0

    @property
    def remaining(self) -> float | None:
        """Estimated seconds left (None before the first run finished)."""
        return (self.total - self.done) / self.rate if self.rate > 0 else None

    def text(self) -> str:
        left = self.remaining
        eta = "" if left is None else f", {_clock(left)} left"
        if left is None and self.estimate:
            eta = f", {self.estimate}"
        return (f"{self.done}/{self.total} runs, {self.failed} failed, {self.rate:.2f} runs/s, "
                f"{_clock(self.elapsed)} elapsed{eta}")


def _clock(seconds: float) -> str:
    seconds = int(round(seconds))
    return f"{seconds // 3600}:{seconds // 60 % 60:02d}:{seconds % 60:02d}"


def scenario_path(scenario: str | Path) -> str:
    """The key the workers load the scenario by: the resolved path of the file (or of the bundled
    scenario) ``scenario`` names, which keys its text in :func:`transgen.sim.scenario_files`.
    Raises ScenarioError (with the closest bundled name) when there is none."""
    from transgen.sim.scenario.load import scenario_path as named_file

    return str(named_file(scenario).resolve())


def design_variants(grid: Mapping[str, Sequence], samples: int | None = None, seed: int = 0,
                    force: bool = False) -> list[dict]:
    """The variants of a design: the full grid, or with ``samples`` a Latin-hypercube sample of
    the ranges ``grid`` gives (key -> (lo, hi) tuple; key -> [value]: fixed). Its size is checked
    first (:func:`~.design.check_design`; ``force`` passes the limit on the number of runs)."""
    if not grid:
        raise ValueError("--grid: error: give at least one parameter to vary (--grid KEY=V1,V2,...)")
    for key in grid:
        if key == "key" or key in FIRST_COLUMNS or key.split(".")[0] in ("energy", "turbo") \
                or column_shift(key) is not None:
            raise ValueError(f"--grid {key}: error: not a scenario key (the name of a result column)")
    if samples is None:
        check_design(grid, None, force)
        return full_grid(grid)
    ranges = {k: v for k, v in grid.items() if isinstance(v, tuple)}
    fixed = {}
    for key, values in grid.items():
        if key not in ranges:
            if isinstance(values, (str, bytes)) or not isinstance(values, Sequence) or len(values) != 1:
                raise ValueError(f"--grid {key}: error: a sampled parameter is a range (LO, HI) (LO:HI on the "
                                 f"command line); a fixed one has one value")
            fixed[key] = values[0]
    check_design(grid, samples, force)
    return [{k: fixed[k] if k in fixed else v[k] for k in grid} for v in latin_hypercube(ranges, samples, seed)]


def validate_variants(path: str, variants: Sequence[Mapping], force: bool = False,
                      costs: list | None = None, budget: Callable[[list], None] | None = None) -> dict[str, str]:
    """Load the scenario with the first variant that has each distinct key/value (every variant
    of a sample; the first row and column of a grid) and return the texts of every file those
    loads read. Raises :class:`~transgen.errors.ScenarioError` (``--set KEY: error: ...`` for a bad key
    or value, or a run over a limit of :mod:`transgen.limits`: ``force`` passes the forceable
    ones) at the first problem: before any run. ``costs``: a list that receives the estimated CPU
    seconds of each variant loaded (:func:`~transgen.sim.scenario.run_limits.run_seconds`); ``budget``: called
    with that list after each (a design over its time limit is refused at its first variant, not
    after loading them all)."""
    from transgen.sim import scenario_files
    from transgen.sim.scenario.run_limits import check_run, run_seconds

    def check(scenario):
        est = check_run(scenario, force)
        if costs is not None:
            costs.append(run_seconds(scenario, est))
            if budget is not None:
                budget(costs)

    first: dict[tuple, int] = {}  # each distinct key/value -> the first variant that has it
    for index, variant in enumerate(variants):
        for key, value in variant.items():
            first.setdefault((key, repr(value)), index)
    checks = [variants[i] for i in sorted(set(first.values()))]
    files: dict[str, str] = {}
    for overrides in checks:
        files.update(scenario_files(path, overrides, check=check))
    return files


def sweep_time(runs: int, costs: Sequence[float], workers: int | None, force: bool | None = False) -> str:
    """The estimate of ``runs`` runs at the costliest of the checked variants' ``costs`` [CPU s]
    on ``workers`` processes, refused over the limit ``sweep_time`` (``force`` passes it)."""
    from transgen.limits import check_time, human_time

    each = max(costs, default=0.0)
    return check_time("sweep_time", runs * each, f"--grid ({runs} runs to do)",
                      f"{runs} runs at about {human_time(each)} each, estimated from the scenario", workers, force)


def sweep(scenario: str | Path, grid: Mapping[str, Sequence], samples: int | None = None, seed: int = 0,
          executor=None, progress: Callable[[SweepProgress], None] | None = None,
          results: str | Path | None = None, force: bool = False) -> SweepTable:
    """Run ``scenario`` (a file or a bundled name) over a design of overrides; one row per run.

    Parameters
    ----------
    grid : mapping
        Dotted key (``driveline.vehicle_mass``, ``mech.C4.static``, see
        :func:`transgen.sim.scenario_keys`) -> list of values (TOML data): the full factorial
        grid; with ``samples``: key -> ``(lo, hi)`` (a tuple), the ranges of a Latin-hypercube
        sample, or a list of one value (fixed in every run).
    samples, seed : int
        Number of Latin-hypercube samples and the seed of the sample (reproducible).
    executor :
        :class:`~.executors.SerialExecutor`, :class:`~.executors.LocalExecutor` (the default:
        one process per core) or :class:`~.executors.DaskExecutor`; the numbers are the same.
    progress : callable
        Called with a :class:`SweepProgress` when the runs start and after every row.
    results : path
        CSV results file: resume from it and rewrite it atomically as rows complete.
    force : bool
        Run a design over the limit on the number of runs (:mod:`transgen.limits`).

    Returns
    -------
    SweepTable
        Rows in the design's order (see :mod:`transgen.sim.study.table` for the columns).

    Raises
    ------
    ScenarioError
        For a bad key or value (before any run); ValueError for a bad design or results file.
    """
    from .executors import LocalExecutor

    path = scenario_path(scenario)
    name = Path(path).stem
    variants = design_variants(grid, samples, seed, force)
    parameters = list(grid)
    by_key: dict[str, dict] = {}
    for variant in variants:  # a value given twice is one run
        by_key.setdefault(row_key(name, variant), variant)
    keys, unique = list(by_key), list(by_key.values())
    earlier = SweepTable.from_csv(results) if results is not None and Path(results).is_file() else None
    previous = {str(r["key"]): r for r in (earlier.rows if earlier else [])}
    rows: list[dict | None] = [previous.get(k) for k in keys]
    extra = [r for k, r in previous.items() if k not in by_key]
    parameters += [p for p in (earlier.parameters if earlier else []) if p not in parameters]
    todo = [(i, unique[i]) for i, row in enumerate(rows) if row is None]
    resumed = len(keys) - len(todo)
    failed = sum(1 for r in rows if r is not None and not r.get("success"))
    if executor is None and todo:
        executor = LocalExecutor()
    with executor.opened() if isinstance(executor, LocalExecutor) and todo else contextlib.nullcontext():
        # a local pool's workers start here and import the simulator while the design is checked
        costs: list[float] = []
        workers = getattr(executor, "workers", 1)
        files = validate_variants(path, unique, force, costs, lambda c: sweep_time(len(todo), c, workers, force))
        estimate = sweep_time(len(todo), costs, workers, force) if todo else ""
        return _run(executor, path, files, keys, unique, rows, extra, parameters, todo, resumed, failed, results,
                    progress, estimate)


def _run(executor, path: str, files: dict, keys: list, unique: list, rows: list, extra: list, parameters: list,
         todo: list, resumed: int, failed: int, results, progress, estimate: str = "") -> SweepTable:
    """The runs of :func:`sweep` (its design checked): rows as they complete, the results file
    rewritten, progress reported."""
    from .task import run_task

    def table() -> SweepTable:
        return SweepTable([r for r in rows if r is not None] + extra, parameters)

    writer = _ResultsWriter(results)
    start = time.perf_counter()
    done = resumed
    if progress is not None:
        progress(SweepProgress(done, failed, len(keys), resumed, 0.0, estimate))
    try:
        if todo:
            for index, row in executor.run(run_task, {"path": path, "files": files}, todo, on_crash=_crashed_row):
                rows[index] = {"key": keys[index], **unique[index], **row}
                done += 1
                failed += not row.get("success")
                writer.write(table, final=False)
                if progress is not None:
                    progress(SweepProgress(done, failed, len(keys), resumed, time.perf_counter() - start))
    finally:
        writer.write(table, final=True)
    return table()


def _crashed_row(task: tuple, reason: str) -> tuple[int, dict]:
    """The row of a run whose worker process died (twice: :meth:`~.executors.LocalExecutor.run`)."""
    index, _ = task
    return index, {"success": False, "message": reason, "wall_time": None}


class _ResultsWriter:
    """Rewrites the results file atomically after rows complete: after every row while writing
    takes little time, else at most once per four write durations (a big file is not rewritten
    for every row), and always at the end."""

    def __init__(self, path):
        from transgen.outputs import is_stream

        self.path = path
        self.next_time = 0.0
        self.dirty = False
        #: a FIFO, device or standard output is written through once, at the end (not a file to resume from)
        self.only_final = path is not None and is_stream(path)

    def write(self, table: Callable[[], SweepTable], final: bool) -> None:
        """``final=False``: a row completed; ``final=True``: the sweep ends (write what is pending)."""
        if self.path is None:
            return
        self.dirty = self.dirty or not final
        now = time.perf_counter()
        if not self.dirty or (not final and (now < self.next_time or self.only_final)):
            return
        table().to_csv(self.path)
        self.dirty = False
        took = time.perf_counter() - now
        self.next_time = time.perf_counter() + 4 * took
