"""transgen.sim.control: what commands a run over time. Shift schedules and shift templates
(:mod:`.schedule`), the drive-cycle driver (:mod:`.driver`) and the standard cycles (:mod:`.cycles`)."""
