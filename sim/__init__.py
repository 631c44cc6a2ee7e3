"""transgen.sim — the powertrain simulator (installed from the top-level ``sim/`` folder)."""
