"""Saved simulation states: stop a run at ``t``, start another run from there.

A mode-switching run (:mod:`.switching`) ends with its complete state in ``Result.state``: a
:class:`SimState` with the time, all link speeds, the mode (locked elements and the slip
directions of the slipping ones, the unlock directions forced by a torque event), the states of
the components (engine, converter, driveline, turbocharger, ...), the three energy integrals, the
state of every controller (an automatic schedule: its gear and last shift) and the apply signals
that the controllers commanded before ``t``. ``simulate(pt, options, start=state)`` with
``options.t_start == state.t`` continues from it: the first mode decision takes the saved mode as
the previous one, exactly as the run that saved it would have at a segment end, so the restarted
run reproduces the continuous one after ``t`` within the solver tolerance (the only difference
is the extra segment end at ``t``; tests/test_sim_restart.py checks it).

A state is plain picklable data (numbers, arrays, signals, controller fields), so a study sends it
to its workers with the scenario's texts: each worker builds its own powertrain from the texts and
overrides and starts it from the state (:mod:`transgen.sim.study.optimize` runs one shift window
per candidate this way). The powertrain it starts must have the same links, elements and
component states as the one that saved it (checked: :func:`check_compatible`); its own apply
signals are kept except where a controller had commanded one before ``t`` (those are part of
the state), so that a candidate's new apply tables take effect.
"""
from __future__ import annotations

import copy
from dataclasses import dataclass, field

import numpy as np

__all__ = ["SimState", "check_compatible", "controller_state", "restore_controllers"]


@dataclass(frozen=True)
class SimState:
    """The complete state of a mode-switching run at time ``t`` [s].

    ``w``: all link speeds [rad/s]; ``locked``: indices of the locked elements (None before the run's
    first mode decision); ``directions``:
    slip direction (+1/-1/0) of every element; ``forced``: element index -> the direction an
    element was forced to unlock in by a torque event at ``t``; ``components``: the state vector
    of every component in the powertrain's order; ``energy``: work in, dissipated, work into the
    load [J] since the start of the first run; ``controllers``: the state of every controller (a
    dict of its fields, :func:`controller_state`); ``commanded``: element name -> the apply signal a
    controller set before ``t``; ``shape``: the links, elements and component state sizes, for
    :func:`check_compatible`.
    """

    t: float
    w: np.ndarray
    locked: frozenset | None
    directions: np.ndarray
    forced: dict = field(default_factory=dict)
    components: tuple = ()
    energy: np.ndarray = field(default_factory=lambda: np.zeros(3))
    controllers: tuple = ()
    commanded: dict = field(default_factory=dict)
    shape: tuple = ()

    @staticmethod
    def shape_of(pt) -> tuple:
        """What a powertrain must share with the one that saved a state: link and element names
        and the sizes of the component states."""
        tr = pt.transmission
        return (tuple(tr.links), tuple(e.name for e in tr.elements),
                tuple(len(c.state_names) for c in pt.components))


#: fields of a controller that belong to its configuration, not its state
_CONFIGURATION = ("template", "templates", "order", "throttle_points", "upshift", "downshift", "throttle", "output",
                  "gears", "min_interval", "slips", "speed_first",
                  # a drive cycle's driver (transgen.sim.control.driver)
                  "trace", "input", "engine", "idle", "final_drive", "wheel_radius", "mass", "road_force", "schedule",
                  "ratios", "dt", "kp", "ki", "preview", "brake_max", "hold_brake", "converter", "t_start")


def controller_state(controller) -> dict:
    """The mutable state of a controller (e.g. :class:`~.schedule.AutoShift`): a copy of its
    fields other than its configuration (a candidate's own template must not be overwritten)."""
    return {k: copy.deepcopy(v) for k, v in vars(controller).items() if k not in _CONFIGURATION}


def restore_controllers(pt, state: SimState) -> None:
    """Set the controllers' state and the commanded apply signals of ``state`` in ``pt``."""
    for controller, saved in zip(pt.controllers, state.controllers):
        for k, v in saved.items():
            setattr(controller, k, copy.deepcopy(v))
    by_name = {e.name: e for e in pt.transmission.elements}
    for name, signal in state.commanded.items():
        by_name[name].apply = signal


def check_compatible(pt, state: SimState, t_start: float) -> None:
    """Raise ``ValueError`` when ``state`` cannot start ``pt`` at ``t_start``: another
    powertrain (links, elements, component states) or another time."""
    if SimState.shape_of(pt) != state.shape:
        raise ValueError("the saved state belongs to another powertrain (links, elements or component states differ)")
    if len(pt.controllers) != len(state.controllers):
        raise ValueError("the saved state has another number of controllers than the powertrain")
    if abs(t_start - state.t) > 1e-12 * max(1.0, abs(t_start)):
        raise ValueError(f"a run from a saved state starts at its time {state.t:.9g} s, not at t_start = {t_start:.9g} s")
