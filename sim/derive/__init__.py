"""transgen.sim.derive: scenarios derived from a mechanism alone (``transgen scenario new``): the
launch (:mod:`.launch`, :mod:`.launch_estimate`, :mod:`.driveline_class`), the default shift
calibration (:mod:`.calibration`), the other maneuvers (:mod:`.maneuver`) and the acceptance rule
of a first result (:mod:`.acceptance`)."""
