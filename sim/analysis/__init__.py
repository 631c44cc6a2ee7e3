"""transgen.sim.analysis: what a run means. The shifts of a result (:mod:`.shifts`), their quality
(:mod:`.shift_quality`, :mod:`.downshift_quality`, :mod:`.comfort`, :mod:`.samples`), the reports
(:mod:`.report`, :mod:`.cycle_report`), plots (:mod:`.plots`) and result files (:mod:`.result_files`).
Takes a :class:`~transgen.sim.core.result.Result`; never runs the simulator."""
