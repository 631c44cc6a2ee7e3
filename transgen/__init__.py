"""transgen — automatic-transmission equations of motion from a ``.mech`` description.

The pipeline, one module per stage::

    .mech text --language--> Mechanism (model) --graph--> bond graph (networkx)
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
from .graph import build_graph
from .kinematics import analyze, gear_ratios, gear_table
from .language import format_mechanism, load_mechanism, parse_mechanism
from .library import bundled_mechanisms
from .model import HOUSING, Mechanism

__version__ = "0.1.0"

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
]
