"""transgen.sim.core: what every room of the simulator shares: the scalar physics compiled or in
Python (:mod:`.jit`), table look-ups (:mod:`.interp`), time signals (:mod:`.signals`), block causality
(:mod:`.causality`) and the :class:`~.result.Result` of a run. Imports nothing else of the simulator."""
