"""transgen.sim.study — parameter studies on top of the simulator (the simulator never imports it).

:func:`sweep` runs a scenario over a full-factorial grid or a Latin-hypercube sample of dotted-key
overrides (:mod:`transgen.sim.scenario.overrides`) and returns a :class:`SweepTable`: one row per run with
the parameters, success, message, wall time, the energy balance, every scalar of the shift report
per shift (``shift1.torque_hole``, ...) and the turbocharger figures where an engine runs.

* :mod:`.design` - grids, Latin-hypercube samples and the row key (a hash of the parameters);
* :mod:`.task` - one run: scenario texts + overrides -> row (what a worker executes);
* :mod:`.executors` - serial, local process pool, Dask distributed;
* :mod:`~.study.table` - :class:`SweepTable`, CSV in and out, units of the columns;
* :mod:`.runner` - :func:`sweep`: validation, resume, progress, atomic results file;
* :mod:`.plots` - metrics over one parameter, heat maps over two;
* :mod:`.optimize` - :func:`~.optimize.optimize`: shift calibration, one shift window per candidate from a
  saved state, candidates evaluated in batches on an executor (``transgen optimize``,
  :mod:`.optimize_cli`), with the template <-> vector conversion (:mod:`.templates`), the objective
  and score (:mod:`.scoring`) and the finished result's texts (:mod:`.tuned`).
"""
from __future__ import annotations

from transgen.lazy import lazy_module_attributes

__all__ = ["sweep", "SweepTable", "SweepProgress", "SerialExecutor", "LocalExecutor", "DaskExecutor",
           "make_executor", "full_grid", "latin_hypercube", "row_key", "column_unit", "validate_variants", "Objective",
           "Constraints"]

# loaded on first use, so that the command line's parser (which adds `sweep`) imports no numeric library
_WHERE = {"sweep": "runner", "SweepProgress": "runner", "validate_variants": "runner", "SweepTable": "table",
          "column_unit": "table", "SerialExecutor": "executors", "LocalExecutor": "executors",
          "DaskExecutor": "executors", "make_executor": "executors", "full_grid": "design",
          "latin_hypercube": "design", "row_key": "design", "Objective": "optimize",
          "Constraints": "optimize"}


__getattr__, __dir__ = lazy_module_attributes(__name__, _WHERE)
