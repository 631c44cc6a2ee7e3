"""Losses of a transmission beyond the mesh losses: drag of the open shift elements, spin of the
links, the pump; the per-gear loss budget and efficiency map; the clutch thermal model.

One module per concept: :mod:`.drag`, :mod:`.spin`, :mod:`.pump` (the models),
:mod:`.lossfile` (their parameters and the TOML loss file), :mod:`.budget` (per gear, over the
operating range, in neutral), :mod:`.thermal` (clutch temperature from a simulation result),
:mod:`.plots`. The narrative, the parameter values and their sources: ``docs/losses.md``.
"""
from .budget import EfficiencyMap, GearLosses, NeutralLosses, efficiency_map, gear_losses, loss_budget, neutral_losses
from .drag import TableDrag, ViscousDrag, aerated_film_torque, couette_coefficient
from .lossfile import LossFileError, LossModel, load_losses, parse_losses
from .pump import Pump
from .spin import PolynomialSpin, TableSpin

__all__ = ["EfficiencyMap", "GearLosses", "NeutralLosses", "efficiency_map", "gear_losses", "loss_budget",
           "neutral_losses", "TableDrag", "ViscousDrag", "aerated_film_torque", "couette_coefficient",
           "LossFileError", "LossModel", "load_losses", "parse_losses", "Pump", "PolynomialSpin", "TableSpin"]
