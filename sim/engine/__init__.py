"""The turbocharged engine of thesis chapter 4 and the torque converter: ``transgen.sim.engine``.

The package re-exports the public names of its modules, so ``transgen.sim.engine.TurbochargedDiesel``,
``transgen.sim.engine.rate`` or ``transgen.sim.engine.load_map`` work without naming the module; each
is imported at its first use (``turbo_report`` is the module of that name: its function of that
name is ``transgen.sim.engine.turbo_report.turbo_report``).
Data flow one way, from the top of the list to the bottom:

* :mod:`~transgen.sim.engine.gas` - ideal gases, corrected quantities, isentropic outlet
  temperatures, torque from power (units: rad/s, K, Pa);
* :mod:`~transgen.sim.engine.map_file` - compressor and turbine maps in a manufacturer-like TOML
  format: reader, writer, validation (:class:`MapError`);
* :mod:`~transgen.sim.engine.preprocessor` - the map pre-processor (thesis 4.4): causal tables
  over corrected speed and chi (compressor) or expansion ratio (turbine);
* :mod:`~transgen.sim.engine.map_generator` - the shipped maps regenerated from the published
  Wahlström & Eriksson fits;
* :mod:`~transgen.sim.engine.turbomachine`, :mod:`~transgen.sim.engine.compressor`,
  :mod:`~transgen.sim.engine.turbine` - quasi-steady compressor and turbine from their tables
  (thesis 4.3);
* :mod:`~transgen.sim.engine.turbocharger` - the two turbocharger algorithms, basic and
  iterative with kinetic energy (thesis 4.4, 4.5);
* :mod:`~transgen.sim.engine.diesel` - the mean-value turbodiesel and its steady state;
* :mod:`~transgen.sim.engine.rating` - its full-load curve and rating (:func:`rate`);
* :mod:`~transgen.sim.engine.torque_converter` - the hydrodynamic torque converter;
* :mod:`~transgen.sim.engine.turbo_report`, :mod:`~transgen.sim.engine.plots`,
  :mod:`~transgen.sim.engine.map_summary` - the turbocharger report of a run, the thesis'
  figures, and the summary of a map (``transgen maps``); the last two are not re-exported.

How the engine and the converter become components of the shift simulator is
:mod:`transgen.sim.model.turbodiesel` and :mod:`transgen.sim.model.powertrain`; the causality check of such an assembly is
:mod:`transgen.sim.model.assembly`.  The shipped maps and converter table are in ``sim/data/``
(:data:`DATA_DIR`).
"""
from __future__ import annotations

from transgen.lazy import lazy_module_attributes

# loaded on first use: a run of the switching model needs the torque converter alone (0.1 s of a
# cold command's start went to importing the turbodiesel, its maps and their TOML reader)
_WHERE = {
    "RPM": "gas", "OMEGA_FLOOR": "gas", "Gas": "gas", "AIR": "gas", "EXHAUST": "gas", "corrected_speed": "gas",
    "corrected_flow": "gas", "actual_flow": "gas", "compression_outlet_temperature": "gas",
    "expansion_outlet_temperature": "gas", "torque_from_power": "gas",
    "DATA_DIR": "map_file", "MapError": "map_file", "MapLine": "map_file", "CompressorSpeedLine": "map_file",
    "TurbineSpeedLine": "map_file", "CompressorMap": "map_file", "TurbineMap": "map_file", "load_map": "map_file",
    "parse_map": "map_file", "save_map": "map_file",
    "MIN_CHI_SPAN": "preprocessor", "MapRangeWarning": "preprocessor", "chi_coordinate": "preprocessor",
    "CompressorTable": "preprocessor", "TurbineTable": "preprocessor", "preprocess_compressor": "preprocessor",
    "preprocess_turbine": "preprocessor", "default_compressor_table": "preprocessor",
    "default_turbine_table": "preprocessor",
    "LiUCompressorFit": "map_generator", "WECompressorFit": "map_generator", "WETurbineFit": "map_generator",
    "DEFAULT_VGT_POSITION": "map_generator", "generate_compressor_map": "map_generator",
    "generate_we_compressor_map": "map_generator", "DEFAULT_FLOW_SCALE": "map_generator",
    "CHOKE_EFFICIENCY": "map_generator", "DEFAULT_SPEED_SCALE": "map_generator",
    "generate_turbine_map": "map_generator",
    "MachinePoint": "turbomachine", "Turbomachine": "turbomachine",
    "Compressor": "compressor", "CompressorPoint": "compressor",
    "Turbine": "turbine", "TurbinePoint": "turbine",
    "TurboShaft": "turbocharger", "PortAreas": "turbocharger", "TurboPoint": "turbocharger",
    "BasicTurbo": "turbocharger", "IterativeTurbo": "turbocharger", "make_turbo": "turbocharger",
    "TurboSolveError": "turbocharger", "ChokedFlowError": "turbocharger", "TurboConvergenceError": "turbocharger",
    "mach_number": "turbocharger", "mach_from_total_temperature": "turbocharger",
    "total_temperature": "turbocharger", "total_pressure": "turbocharger",
    "EngineParams": "diesel", "SpeedGovernor": "diesel", "TurbochargedDiesel": "diesel", "SteadyState": "diesel",
    "NonFiniteError": "diesel", "SteadyStateError": "diesel", "exhaust_temperature": "diesel",
    "FullLoadCurve": "rating", "EngineRating": "rating", "full_load_curve": "rating", "rate": "rating",
    "TorqueConverter": "torque_converter", "TorqueConverterError": "torque_converter",
    "DEFAULT_TORQUE_CONVERTER": "torque_converter", "converter_torques": "torque_converter",
    "TurboReport": "turbo_report", "algorithm_difference": "turbo_report", "unique_times": "turbo_report",
    "TURBO_UNITS": "turbo_report",
}

__all__ = list(_WHERE)

__getattr__, __dir__ = lazy_module_attributes(__name__, _WHERE)
