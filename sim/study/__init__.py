"""transgen.sim.study — parameter studies on top of the simulator (the simulator never imports it).

:func:`sweep` runs a scenario over a full-factorial grid or a Latin-hypercube sample of dotted-key
overrides (:mod:`transgen.sim.overrides`) and returns a :class:`SweepTable`: one row per run with
the parameters, success, message, wall time, the energy balance, every scalar of the shift report
per shift (``shift1.torque_hole``, ...) and the turbocharger figures where an engine runs.

* :mod:`.design` - grids, Latin-hypercube samples and the row key (a hash of the parameters);
* :mod:`.task` - one run: scenario texts + overrides -> row (what a worker executes);
* :mod:`.executors` - serial, local process pool, Dask distributed;
* :mod:`.table` - :class:`SweepTable`, CSV in and out, units of the columns;
* :mod:`.sweep` - :func:`sweep`: validation, resume, progress, atomic results file;
* :mod:`.plots` - metrics over one parameter, heat maps over two.
"""
from __future__ import annotations

from .design import full_grid, latin_hypercube, row_key
from .executors import DaskExecutor, LocalExecutor, SerialExecutor, make_executor
from .sweep import SweepProgress, sweep, validate_variants
from .table import SweepTable, column_unit

__all__ = ["sweep", "SweepTable", "SweepProgress", "SerialExecutor", "LocalExecutor", "DaskExecutor",
           "make_executor", "full_grid", "latin_hypercube", "row_key", "column_unit", "validate_variants"]
