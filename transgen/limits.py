"""The limits of the work one command may start: every size a user can type, in one place.

Each :class:`Limit` names what it bounds, the option(s) or scenario key(s) that set it, its
bound and unit, and why it is there. A command checks every size it is given against its limit
*before* anything is allocated (a grid's points are counted, not made; a sine's cycles are
counted, not stepped through) and refuses a size over it with a :class:`LimitExceeded`
(``error: ...``, exit 2) that says the size, the estimate of memory or time where one is known,
and how to go on: a smaller value, or ``--force`` for the limits marked ``forceable`` (those
that only guard against an accident: the work is possible, it is large). The other limits are
hard: beyond them the work cannot succeed (it would not fit in memory, a tolerance below the
floating-point resolution never converges, a zero tooth count divides by zero).

``docs/limits.md`` is the user's table of these limits; ``tests/test_limits.py`` checks that it
lists each one of :data:`LIMITS`.
"""
from __future__ import annotations

import math
import os
from dataclasses import dataclass

from .errors import TransgenError

__all__ = ["Limit", "LIMITS", "LimitExceeded", "limit", "add_force_option", "check_limit",
           "check_workers", "check_optimize", "check_time", "available_memory", "human_bytes", "human_time", "WORKER_MEMORY",
           "EVALUATION_CPU"]


@dataclass(frozen=True)
class Limit:
    """A bound on a size a user gives: ``name`` (the key in :data:`LIMITS`), the ``options`` that
    set it, the bound ``value`` in ``unit``, ``kind`` ``"max"`` or ``"min"``, whether ``--force``
    passes it (``forceable``) and ``why`` (a sentence: what goes wrong beyond it)."""

    name: str
    options: str
    value: float
    unit: str
    kind: str
    forceable: bool
    why: str

    def text(self) -> str:
        """``at most 100000 runs`` / ``at least 1e-12``: the bound in words."""
        return f"{'at most' if self.kind == 'max' else 'at least'} {self.amount(self.value)}"

    def amount(self, value: float) -> str:
        """``value`` in this limit's unit: ``100000 runs``, ``4 GB``, ``1e-12``."""
        if self.unit == "bytes":
            return human_bytes(value)
        number = f"{int(value)}" if float(value).is_integer() and abs(value) < 1e15 else f"{value:.4g}"
        return number + (f" {self.unit}" if self.unit else "")


EVALUATION_CPU = 0.2
"""CPU time of one optimizer evaluation [s]: a shift window of a bundled scenario, its loading and
its metrics (0.05-0.5 s measured), for the ``evaluations`` and ``optimize_time`` estimates."""

WORKER_MEMORY = 200e6
"""Resident memory of one worker process [bytes] (a spawned worker with the simulator loaded:
170-200 MB measured, issue 22), for the ``workers`` estimate."""

_LIMITS = (
    Limit("runs", "sweep --grid, --samples", 100_000, "runs", "max", True,
          "each run is a simulation (0.1 s to minutes) and a results row; beyond it a typing slip "
          "(K=1:2:100000000000) would run for years"),
    Limit("sweep_time", "sweep --grid, --samples (the runs times the estimated CPU time of one)", 86_400,
          "CPU seconds", "max", True,
          "a sweep's runs at the estimated cost of the costliest checked run (its simulated time, periodic "
          "inputs and output samples: transgen.sim.scenario.run_limits.run_seconds); beyond a day of CPU a slip "
          "of the design, not a study, is the likelier cause"),
    Limit("grid_values", "sweep --grid KEY=LO:HI:N", 2_000_000, "values", "max", False,
          "the values of one key are made before the runs; more would not fit in memory"),
    Limit("design_memory", "sweep --grid, --samples", 4e9, "bytes", "max", False,
          "the design and the results table are held in memory, about 3 kB a run"),
    Limit("population", "optimize --population", 1000, "candidates", "max", False,
          "CMA-ES on the ~10 trajectory parameters of a shift wants about 12; a generation is "
          "evaluated together, so a larger one only delays the first improvement"),
    Limit("evaluations", "optimize --evaluations", 100_000, "simulations per shift", "max", True,
          "each evaluation simulates a shift window (about 0.05-0.5 s CPU)"),
    Limit("optimize_time", "optimize --evaluations, the shifts tuned", 86_400, "CPU seconds", "max", True,
          "the evaluations of every shift tuned at the cost of one (a shift window, timed on the scenario's "
          "own run); beyond a day of CPU a slip of the budget is the likelier cause"),
    Limit("min_teeth", "synthesize teeth --min-teeth", 3, "teeth", "min", False,
          "a gear needs teeth: 0 divides by zero in the ring/sun bounds, fewer than 3 is no gear"),
    Limit("max_teeth", "synthesize teeth --max-teeth", 1000, "teeth", "max", False,
          "the candidate pairs of a set grow with the square of the ring size"),
    Limit("teeth_pairs", "synthesize teeth --max-teeth, --min-teeth, --ring-sun, Ns=A..B Nr=C..D", 250_000,
          "candidate pairs", "max", True,
          "the search takes about 0.4 ms a candidate (Ns, Nr) pair of the unknown sets: 44,000 pairs (the "
          "HT-740's three sets at --max-teeth 150) take 13 s"),
    Limit("workers", "sweep, optimize --workers", 64, "processes", "max", True,
          "each worker is a Python process of about 200 MB; more than the cores only share them"),
    Limit("worker_memory", "sweep, optimize --workers", 0.8, "of the available memory", "max", False,
          "workers beyond the memory the machine has free swap or are killed by the kernel"),
    Limit("output_samples", "[simulation] output_dt", 10_000_000, "samples", "max", False,
          "the output is sampled every output_dt from t_start to t_end and held in memory"),
    Limit("output_memory", "[simulation] output_dt, t_start, t_end", 1e9, "bytes", "max", True,
          "the samples of every recorded signal are held in memory (about 18 bytes a value) and written"),
    Limit("signal_periods", "a periodic signal's frequency or period, against t_end - t_start", 100_000, "periods",
          "max", True,
          "an integrator resolves every period of a periodic input (about 30 right-hand-side evaluations "
          "each, 3 ms); a 1e6 Hz sine over 7 s is 7e6 periods: hours (about 2 h measured in issue 22)"),
    Limit("signal_nyquist", "a periodic signal's frequency against output_dt", 0.5, "cycles per output step",
          "max", True,
          "the output samples (every output_dt) cannot show a signal faster than half their rate: "
          "the recorded signals alias"),
    Limit("breakpoints", "a periodic signal's period (pulse, square, periodic)", 100_000, "breakpoints", "max",
          False, "each edge restarts the integrator and is held in memory"),
    Limit("rtol", "[simulation] rtol", 1e-12, "", "min", False,
          "below about 100 machine epsilons (2.2e-14) no step is accurate enough: the integrator "
          "shrinks its step without end"),
    Limit("atol", "[simulation] atol", 1e-12, "", "min", False,
          "near a zero state (a slip, a locked speed) the error test is atol alone; atol=1e-300 "
          "demands steps below the resolution of the time and the run never ends"),
)

LIMITS: dict[str, Limit] = {lim.name: lim for lim in _LIMITS}
"""Every limit by name (the table of ``docs/limits.md``)."""


class LimitExceeded(TransgenError, ValueError):
    """A size over its limit, found before the work started (exit 2). ``limit`` is the
    :class:`Limit`; the message names the option, the size, the estimate and how to go on."""

    def __init__(self, message: str, limit: Limit):
        super().__init__(message)
        self.limit = limit


def add_force_option(parser) -> None:
    """``--force``: run work over a forceable limit (added once: a command whose output layer
    has its own ``--force`` shares it)."""
    if "--force" not in parser._option_string_actions:
        parser.add_argument("--force", action="store_true",
                            help="run work over a size limit that only guards against a slip (docs/limits.md)")


def limit(name: str) -> float:
    """The bound of the limit ``name`` (KeyError for an unknown name)."""
    return LIMITS[name].value


def _how(lim: Limit, force: bool | None, hint: str) -> str:
    if lim.forceable and force is not None:
        return f"; {hint}, or --force to run it anyway"
    return f"; {hint}: {lim.why}" if lim.kind == "max" else f": {lim.why}"


def check_limit(name: str, value: float, what: str, estimate: str = "", force: bool | None = None,
                error=None, hint: str = "give a smaller value") -> None:
    """Refuse ``value`` when it is beyond the limit ``name`` (:class:`LimitExceeded`).

    ``what`` says what the value is, as the option that gave it (``"--population 100000"``);
    ``estimate`` (optional) the memory or time it would take; ``force`` is None where the command
    has no ``--force`` (the refusal then does not offer it), True to pass a forceable limit.
    ``error``: a function of the message giving the exception to raise instead (a scenario's
    error located at the key that set the value; the message then starts with ``what``).
    ``hint``: how to stay within the limit."""
    lim = LIMITS[name]
    over = value > lim.value if lim.kind == "max" else value < lim.value
    if not over or (force and lim.forceable):
        return
    est = f" ({estimate})" if estimate else ""
    where = "over" if lim.kind == "max" else "under"
    text = f"{lim.amount(value)}{est} is {where} the limit, {lim.text()}" + _how(lim, force, hint)
    if error is not None:
        raise error(f"{what}: {text}")
    raise LimitExceeded(f"{what}: error: {text}", lim)


def check_workers(workers: int | None, force: bool | None = False, option: str = "--workers") -> None:
    """Refuse a number of worker processes over the limit ``workers`` or whose memory
    (:data:`WORKER_MEMORY` each) is over the share ``worker_memory`` of :func:`available_memory`
    (``force`` passes both). None (one per core) and 1 (in this process) always pass."""
    if workers is None:
        return
    if isinstance(workers, bool) or not isinstance(workers, int) or workers < 1:
        raise ValueError(f"{option}: error: the number of workers is a whole number >= 1, not {workers!r}")
    if workers == 1:
        return
    memory = workers * WORKER_MEMORY
    cores = os.cpu_count() or 1
    check_limit("workers", workers, f"{option} {workers}",
                f"about {human_bytes(memory)} of worker processes on {cores} cores", force)
    free = available_memory()
    check_limit("worker_memory", memory / free, f"{option} {workers}",
                f"about {human_bytes(memory)} of worker processes, {human_bytes(free)} available", force)


def check_optimize(evaluations: int, population: int, force: bool | None = False) -> None:
    """Refuse an optimizer budget over the limits ``evaluations`` (``force`` passes it) and
    ``population``, or a population larger than the evaluations it has to fit in."""
    check_limit("population", population, f"--population {population}")
    check_limit("evaluations", evaluations, f"--evaluations {evaluations}",
                f"about {human_time(evaluations * EVALUATION_CPU)} of simulation CPU per shift at "
                f"{EVALUATION_CPU:g} s an evaluation", force)
    if population > evaluations:
        raise ValueError(f"--population {population}: error: a generation is larger than --evaluations "
                         f"{evaluations}: give a population of at most the evaluations")


def check_time(name: str, seconds: float, what: str, detail: str, workers: int | None = None,
               force: bool | None = False) -> str:
    """The estimate ``about 3.2 h of CPU (detail), about 1.6 h on 2 workers`` of work of
    ``seconds`` CPU seconds, refused over the time limit ``name`` (``sweep_time``,
    ``optimize_time``; ``force`` passes it) with that estimate. ``workers``: processes sharing
    the work (None: one per core)."""
    share = max(1, min(workers or os.cpu_count() or 1, os.cpu_count() or 1))
    text = f"about {human_time(seconds)} of CPU ({detail})"
    if share > 1:
        text += f", about {human_time(seconds / share)} on {share} workers"
    check_limit(name, float(math.ceil(seconds)), what, text, force, hint="give a smaller design or budget, or a shorter run")
    return text


def available_memory() -> float:
    """Memory the machine has available now [bytes] (``MemAvailable`` of ``/proc/meminfo``;
    the physical memory elsewhere; ``inf`` when neither can be read)."""
    try:
        with open("/proc/meminfo", encoding="ascii") as fh:
            for line in fh:
                if line.startswith("MemAvailable:"):
                    return float(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    try:
        return float(os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES"))
    except (ValueError, OSError, AttributeError):
        return math.inf


def human_bytes(n: float) -> str:
    """``n`` bytes as ``3.2 GB`` (decimal units)."""
    for unit, size in (("TB", 1e12), ("GB", 1e9), ("MB", 1e6), ("kB", 1e3)):
        if n >= size:
            return f"{n / size:.3g} {unit}"
    return f"{n:.0f} B"


def human_time(seconds: float) -> str:
    """``seconds`` as ``45 s``, ``12 min``, ``3.1 h``, ``2.5 days`` or ``40 years``."""
    if not math.isfinite(seconds):
        return "for ever"
    for unit, size in (("years", 365.25 * 86400), ("days", 86400), ("h", 3600), ("min", 60)):
        if seconds >= 2 * size:
            return f"{seconds / size:.3g} {unit}"
    return f"{seconds:.3g} s"
