"""transgen — automatic-transmission equations of motion from a ``.mech`` description.

The pipeline, one module per stage::

    .mech text --language--> Mechanism (model) --graph--> bond graph (networkx; BondGraph for numbers)
      --kinematics--> DOF, ratios, gear table
      --equations--> per-mode E, F, G --modes--> modes, coordinates
      --statespace--> B, C, D --std--> state-transition diagram --> sim (transgen.sim)
"""
from .errors import (
    Diagnostic,
    MechError,
    MechSyntaxError,
    MechValidationError,
    ModeError,
    ScenarioError,
    SimulationError,
    TransgenError,
)
from typing import TYPE_CHECKING

from .lazy import lazy_module_attributes

if TYPE_CHECKING:  # the names below are loaded on first use (see __getattr__)
    from .graph import build_graph
    from .kinematics import analyze, gear_ratios, gear_table
    from .language import format_mechanism, load_mechanism, parse_mechanism
    from .library import bundled_mechanisms
    from .model import HOUSING, Mechanism
    from .powerflow import power_flow

__version__ = "0.1.0"

# Loaded on first access, not at import: networkx, numpy and lark take most of the start-up time
# of the command line, and ``transgen --help`` or the simulator's commands need none of them here.
_LAZY = {
    "build_graph": "graph",
    "analyze": "kinematics", "gear_ratios": "kinematics", "gear_table": "kinematics",
    "format_mechanism": "language", "load_mechanism": "language", "parse_mechanism": "language",
    "bundled_mechanisms": "library",
    "HOUSING": "model", "Mechanism": "model",
    "power_flow": "powerflow",
}


__getattr__, __dir__ = lazy_module_attributes(__name__, _LAZY)

__all__ = [
    "Diagnostic",
    "MechError",
    "MechSyntaxError",
    "MechValidationError",
    "ModeError",
    "ScenarioError",
    "SimulationError",
    "TransgenError",
    "build_graph",
    "analyze",
    "gear_ratios",
    "gear_table",
    "format_mechanism",
    "load_mechanism",
    "parse_mechanism",
    "bundled_mechanisms",
    "HOUSING",
    "Mechanism",
    "power_flow",
]
