"""Estimates of a simulation's size before it runs, checked against :mod:`transgen.limits`.

A scenario is read in milliseconds; its run may take hours or more memory than the machine
has. :func:`run_estimate` says, from the scenario alone, how many output samples the run will
hold (every ``output_dt`` from ``t_start`` to ``t_end``), how much memory they take
(:data:`SAMPLE_BYTES` a value of every signal the run records), how many periods of the periodic inputs the file gives
the integrator has to resolve and about how long that takes (measured: about
:data:`RHS_PER_PERIOD` right-hand-side evaluations a period with DOP853 at the default
tolerances, about :data:`RHS_SECONDS` each; a 1000 Hz sine over 3 s took 93821 evaluations in
10.6 s), and the fastest periodic input against the output rate (faster than half of it, the
recorded signals alias). :func:`check_run` refuses what is over a limit, with the estimate, in an
error located at the key that set it.
"""
from __future__ import annotations

from dataclasses import dataclass

from transgen.limits import check_limit, human_bytes, human_time

from ..core.signals import Sine

__all__ = ["RunEstimate", "run_estimate", "check_run", "run_seconds", "RHS_PER_PERIOD", "RHS_SECONDS",
           "SIMULATED_SECOND_CPU"]

RHS_PER_PERIOD = 30
"""Right-hand-side evaluations a period of a periodic input takes (DOP853, rtol = atol = 1e-8:
31 measured on a 1000 Hz sine driving simple2)."""

RHS_SECONDS = 1.1e-4
"""Wall time of one right-hand-side evaluation with its share of event handling and output
[s] (113 us measured on simple2, 2 cores shared)."""

SAMPLE_BYTES = 18.5
"""Memory of one value of one recorded signal at one output sample [bytes]: 8 for the number,
and the copies the run and its summary make (simple2_upshift at output_dt = 1e-5 s: 300001 samples
of 29 signals took 156 MB more than at 1e-3 s)."""

SAMPLE_SECONDS = 7.7e-5
"""Wall time of one output sample [s] (the same measurement: 23 s more for 297000 more samples)."""


SIMULATED_SECOND_CPU = 0.1
"""CPU time of one simulated second of a bundled scenario without periodic inputs, its kernel
compiled [s]: the highest of the bundled scenarios measured (coupled_clutches 0.10, ht740_turbo
0.054, simple2_upshift 0.027, ht740_improved 0.010; 2 shared cores), the base of :func:`run_seconds`."""


@dataclass(frozen=True)
class RunEstimate:
    """What a run will take: ``samples`` output samples of ``columns`` recorded signals
    (``memory`` bytes); ``periods`` periods of its periodic inputs (``seconds`` of integration
    for them); the fastest input's ``frequency`` [Hz] (0 without a periodic input), at the key
    path ``fastest``."""

    samples: int
    columns: int
    memory: float
    periods: float
    seconds: float
    frequency: float
    fastest: tuple = ()

    def text(self) -> str:
        text = f"{self.samples} samples of {self.columns} signals, about {human_bytes(self.memory)}"
        if self.periods:
            text += f"; {self.periods:.3g} periods of periodic inputs, about {human_time(self.seconds)} to integrate"
        return text


def _frequency(signal) -> float:
    """The frequency of a periodic signal [Hz]: a sine's, or one over a pulse train's period."""
    return float(signal.frequency) if isinstance(signal, Sine) else 1.0 / float(signal.period)


def run_estimate(scenario) -> RunEstimate:
    """The :class:`RunEstimate` of ``scenario`` (a :class:`~.scenario.load.Scenario`), from its
    options and the periodic signals its file gives (``scenario.periodic``)."""
    from .load import output_signals

    o = scenario.options
    duration = o.t_end - o.t_start
    columns = len(output_signals(scenario.powertrain)) + 1  # and the time
    samples = int(duration / o.output_dt) + 1
    periods, fastest, frequency = 0.0, (), 0.0
    for keys, signal in scenario.periodic:
        if isinstance(signal, Sine) and signal.amplitude == 0:
            continue  # a constant
        f = _frequency(signal)
        periods += f * duration
        if f > frequency:
            frequency, fastest = f, keys
    seconds = periods * RHS_PER_PERIOD * RHS_SECONDS
    return RunEstimate(samples, columns, SAMPLE_BYTES * samples * columns, periods, seconds, frequency, fastest)


def run_seconds(scenario, est: RunEstimate | None = None) -> float:
    """Estimated CPU time of one run of ``scenario`` [s]: its simulated time at
    :data:`SIMULATED_SECOND_CPU`, the periods of its periodic inputs (``est.seconds``) and its
    output samples at :data:`SAMPLE_SECONDS` each (the cost a sweep or an optimizer multiplies)."""
    est = est if est is not None else run_estimate(scenario)
    o = scenario.options
    return max(o.t_end - o.t_start, 0.0) * SIMULATED_SECOND_CPU + est.seconds + est.samples * SAMPLE_SECONDS


def check_run(scenario, force: bool | None = False) -> RunEstimate:
    """The :class:`RunEstimate` of ``scenario``, refused over the limits ``output_memory``,
    ``signal_periods`` and ``signal_nyquist`` of :mod:`transgen.limits` (``force`` passes them;
    None: no ``--force`` is offered) with an error located at the key that sets the size."""
    est = run_estimate(scenario)
    o = scenario.options
    locate = scenario.locate

    def at(keys):
        return None if locate is None else (lambda message: locate(keys, message))
    check_limit("output_memory", est.memory, f"output_dt = {o.output_dt:g} s",
                f"{est.samples} samples of {est.columns} signals from t_start to t_end, about "
                f"{human_time(est.samples * SAMPLE_SECONDS)}", force,
                at(("simulation", "output_dt")), "give a larger output_dt or a shorter run")
    if est.periods:
        what = f"{'.'.join(map(str, est.fastest[:-1]))}: a periodic input of {est.frequency:g} Hz"
        check_limit("signal_periods", est.periods, what,
                    f"over the simulated {o.t_end - o.t_start:g} s, about {human_time(est.seconds)} to integrate at "
                    f"{RHS_PER_PERIOD} right-hand-side evaluations a period", force, at(est.fastest),
                    "give a lower frequency (a longer period) or a shorter run")
        check_limit("signal_nyquist", est.frequency * o.output_dt, what,
                    f"output every {o.output_dt:g} s: the recorded signals alias; an output_dt below "
                    f"{0.5 / est.frequency:.3g} s shows it", force, at(est.fastest),
                    f"give a lower frequency or an output_dt of at most {0.5 / est.frequency:.3g} s")
    return est
