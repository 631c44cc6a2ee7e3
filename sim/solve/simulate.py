"""Running a powertrain: the one entry point :func:`simulate` for both clutch models.

``SolverOptions.model`` chooses Runde's mode-switching method (:mod:`.switching`, the default) or
Haessig's compliant clutch model (:mod:`.compliant`, for comparison, thesis 3.2.2). Both are
built on the shared integration core :mod:`.integration`.
"""
from __future__ import annotations

from ...blas import one_blas_thread
from .compliant import simulate_compliant
from .integration import Powertrain, SolverOptions
from ..core.result import Result
from .switching import simulate_switching

__all__ = ["SolverOptions", "Powertrain", "simulate"]

_MODELS = {"switching": simulate_switching, "compliant": simulate_compliant}


@one_blas_thread()
def simulate(pt: Powertrain, options: SolverOptions = SolverOptions(), progress=None, start=None) -> Result:
    """Simulate ``pt`` from ``options.t_start`` to ``options.t_end`` with the clutch model
    ``options.model``.

    ``start``: a saved state (:class:`~transgen.sim.solve.restart.SimState`, the ``state`` of an earlier
    mode-switching run's result, at ``options.t_start``) to start from instead of the powertrain's
    initial speeds and states; the switching model only.

    ``progress``: optional callable ``progress(t)`` called after every integration segment.
    Returns a :class:`Result`; on failure ``success`` is False and ``message`` says when, in which
    mode and why (the samples up to the failure are kept). The run's small dense linear algebra
    uses one BLAS thread (:mod:`transgen.blas`; also a BLAS loaded during the run, e.g. scipy's with the stiff
    solvers, before they step).
    """
    try:
        run = _MODELS[options.model]
    except KeyError:
        raise ValueError(f"unknown clutch model {options.model!r}: choose 'switching' or 'compliant'") from None
    if start is not None:
        if options.model != "switching":
            raise ValueError("a run from a saved state needs the switching clutch model")
        return run(pt, options, progress, start)
    return run(pt, options, progress)
