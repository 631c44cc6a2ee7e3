"""transgen.sim.scenario.load: scenario files. Reading a TOML file with its includes and key positions
(:mod:`.file`, :mod:`.tomlpos`, :mod:`.file_access`), the tables and keys it may have (:mod:`.schema`),
``--set`` overrides (:mod:`.overrides`), the bundled scenarios and data (:mod:`.library`), copies
(:mod:`.copy`), size estimates (:mod:`.run_limits`) and the :class:`~.load.Scenario` ready to run
(:mod:`.load`). The scenario API is importable from here, loaded on first use."""
from __future__ import annotations

from transgen.lazy import lazy_module_attributes

__all__ = ["load_scenario", "scenario_files", "scenario_keys", "parse_override", "Scenario"]

_WHERE = {"load_scenario": "load", "scenario_files": "load", "scenario_keys": "load", "Scenario": "load",
          "parse_override": "overrides"}


__getattr__, __dir__ = lazy_module_attributes(__name__, _WHERE)
