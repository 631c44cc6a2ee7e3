"""transgen.sim.solve: how a run is integrated. The shared integration core (:mod:`.integration`),
the ODE solvers (:mod:`.ode_solvers`, :mod:`.ode_stiff`, scipy access in :mod:`.scipy_parts`), the
compiled right-hand side (:mod:`.kernel`), dense output (:mod:`.dense`), the invariant monitor
(:mod:`.monitor`), the two clutch models (:mod:`.switching`, :mod:`.compliant`), saved states
(:mod:`.restart`) and the one entry point :func:`~.simulate.simulate`."""
