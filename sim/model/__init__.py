"""transgen.sim.model: what is simulated. The transmission at run time (:mod:`.transmission`), the
components on its links and the driveline (:mod:`.components`, :mod:`.brake`), the turbocharged
powertrain (:mod:`.powertrain`), its causality check (:mod:`.assembly`) and a settled start
(:mod:`.settle`). Built on :mod:`transgen.sim.core` and :mod:`transgen.sim.engine`."""
