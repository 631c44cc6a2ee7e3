"""The tables and keys a scenario file may have: the one list that the readers of
:mod:`.scenario.load` check a file against and that the dotted keys of ``--set`` come from.

Each ``*_KEYS`` set is what one table accepts (the sub-tables of a turbodiesel's ``[input]``
are :mod:`.powertrain`'s); :func:`key_tree` arranges them as a tree over
the dotted keys (``driveline.vehicle_mass``, ``elements.C4.apply``, ``load.0.c1``), with the
names that depend on the mechanism (its shift elements and links) filled in. Signals
(``elements.C4.apply``, ``input.throttle_signal``, ...) accept the keys of every signal type
(:data:`SIGNAL_KEYS`).
"""
from __future__ import annotations

__all__ = ["TOP_KEYS", "SIMULATION_KEYS", "COMPLIANT_KEYS", "ELEMENT_KEYS", "FRICTION_KEYS", "INITIAL_KEYS",
           "SHIFTS_KEYS", "EVENT_KEYS", "AUTO_SHIFT_KEYS", "OUTPUT_KEYS", "INPUT_KEYS",
           "LOAD_KEYS", "LOSSES_KEYS", "CONVERTER_KEYS", "DRIVELINE_KEYS", "SIGNAL_KEYS", "SIGNAL", "LEAF", "ANY", "key_tree"]

TOP_KEYS = frozenset({"mechanism", "include", "title", "description", "simulation", "compliant", "initial", "input",
                      "load", "driveline", "elements", "shifts", "auto_shift", "output", "report", "converter",
                      "driver", "losses"})
SIMULATION_KEYS = frozenset({"t_start", "t_end", "model", "method", "rtol", "atol", "max_step", "output_dt", "slip_tol",
                             "energy_tol", "coordinates", "modes"})
COMPLIANT_KEYS = frozenset({"stiffness", "damping"})
ELEMENT_KEYS = frozenset({"apply", "friction", "gain", "energizing"})
FRICTION_KEYS = frozenset({"slip", "factor"})
INITIAL_KEYS = frozenset({"gear", "locked", "speeds", "speeds_rpm", "driveshaft"})
SHIFTS_KEYS = frozenset({"template", "events"})
EVENT_KEYS = frozenset({"t", "from", "to", "template"})
AUTO_SHIFT_KEYS = frozenset({"order", "throttle", "upshift_rpm", "downshift_rpm", "template", "templates",
                             "min_interval", "throttle_signal", "speed_first_templates"})
OUTPUT_KEYS = frozenset({"signals", "dt"})
INPUT_KEYS = frozenset({"type", "torque", "speed_rpm", "throttle", "torque_table", "throttle_signal", "converter",
                        "J_engine", "engine_speed_rpm", "idle_rpm", "engine", "turbo", "fuel_signal", "governor",
                        "crank_model", "shaft", "ports", "compressor_map", "turbine_map", "air", "exhaust",
                        "turbo_solver", "torque_request", "fuel_map"})
LOAD_KEYS = frozenset({"torque", "signal", "c0", "c1", "c2"})
LOSSES_KEYS = frozenset({"file", "kinds", "pump_link", "eta0", "eta_pair", "oil_temperature", "drag", "spin", "pump"})
CONVERTER_KEYS = frozenset({"pump", "turbine", "pump_torque", "turbine_torque", "file"})
DRIVELINE_KEYS = frozenset({"output_inertia", "stiffness", "damping", "final_drive", "wheel_radius", "vehicle_mass",
                            "rolling_resistance", "cd_a", "air_density", "grade", "grade_percent", "output_torque",
                            "brake"})

SIGNAL_KEYS = {"constant": {"value"}, "step": {"t", "before", "after"}, "ramp": {"t0", "t1", "v0", "v1"},
               "table": {"t", "value"}, "sine": {"offset", "amplitude", "frequency", "phase"},
               "pulse": {"t0", "width", "period", "low", "high"}, "square": {"period", "duty", "t0", "low", "high"},
               "periodic": {"t", "value", "period"}}
"""The keys of each signal type (besides ``type``)."""

LEAF = None
"""A value of the tree that is a value in the file (a number, string or list), not a table."""
SIGNAL = "signal"
"""A value of the tree that is a signal: a number or a table ``{type = ..., ...}``."""
ANY = "*"
"""A key of the tree that stands for any name (of a shift element or link not known yet)."""


def _leaves(keys) -> dict:
    return {k: LEAF for k in sorted(keys)}


def key_tree(elements=None, links=None) -> dict:
    """The keys of a scenario as a tree: a dict maps a key to its subtree, :data:`LEAF` or
    :data:`SIGNAL`; a one-entry list ``[subtree]`` is an array of tables (keys are indices).
    ``elements`` and ``links`` are the mechanism's shift-element and link names (None: any
    name, the key :data:`ANY`)."""
    from ..control.driver import DRIVER_KEYS
    from ..engine.fuel import FUEL_KEYS
    from ..model.powertrain import ENGINE_KEYS, GAS_KEYS, GOVERNOR_KEYS, PORT_KEYS, SHAFT_KEYS, SOLVER_KEYS
    from ..control.schedule import ShiftTemplate

    signals = {"torque", "throttle_signal", "fuel_signal", "output_torque", "signal", "apply", "torque_request",
               "brake"}
    template = _leaves(ShiftTemplate.__dataclass_fields__)

    def names(names, sub) -> dict:
        return {ANY: sub} if names is None else {name: sub for name in names}

    def table(keys, **sub) -> dict:
        return {k: sub.get(k, SIGNAL if k in signals else LEAF) for k in sorted(keys)}

    element = table(ELEMENT_KEYS, friction=_leaves(FRICTION_KEYS))
    tree = table(TOP_KEYS - {"include", "report"},
                 simulation=_leaves(SIMULATION_KEYS), compliant=_leaves(COMPLIANT_KEYS),
                 elements=names(elements, element),
                 initial=table(INITIAL_KEYS, speeds=names(links, LEAF), speeds_rpm=names(links, LEAF)),
                 shifts=table(SHIFTS_KEYS, template=template, events=[table(EVENT_KEYS, template=template)]),
                 auto_shift=table(AUTO_SHIFT_KEYS, template=template, templates={ANY: template},
                                  speed_first_templates={ANY: template}), output=_leaves(OUTPUT_KEYS),
                 input=table(INPUT_KEYS, governor=_leaves(GOVERNOR_KEYS), engine=_leaves(ENGINE_KEYS),
                             shaft=_leaves(SHAFT_KEYS), ports=_leaves(PORT_KEYS), air=_leaves(GAS_KEYS),
                             exhaust=_leaves(GAS_KEYS), turbo_solver=_leaves(SOLVER_KEYS),
                             fuel_map=_leaves(FUEL_KEYS)),
                 load=[table(LOAD_KEYS, torque=LEAF)], converter=_leaves(CONVERTER_KEYS), driveline=table(DRIVELINE_KEYS),
                 driver=_leaves(DRIVER_KEYS), losses=_leaves(LOSSES_KEYS))
    return tree
