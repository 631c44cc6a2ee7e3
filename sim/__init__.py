"""transgen.sim — the powertrain simulator (installed from the top-level ``sim/`` folder).

The scenario API is importable from here: :func:`load_scenario`, :func:`scenario_files`,
:func:`scenario_keys` (:mod:`transgen.sim.scenario.load`) and :func:`parse_override`
(:mod:`transgen.sim.scenario.overrides`). They are loaded on first use, so that ``import transgen.sim``
stays cheap.
"""
from __future__ import annotations

from transgen.lazy import lazy_module_attributes

__all__ = ["load_scenario", "scenario_files", "scenario_keys", "parse_override", "Scenario"]

_WHERE = {"load_scenario": "scenario.load", "scenario_files": "scenario.load", "scenario_keys": "scenario.load",
          "Scenario": "scenario.load", "parse_override": "scenario.overrides"}


__getattr__, __dir__ = lazy_module_attributes(__name__, _WHERE)
