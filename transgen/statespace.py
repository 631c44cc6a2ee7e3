"""Per-mode state-space matrices (thesis eqs. 3.6-3.7 and 3.11-3.15).

For a mode with generalized coordinates ``q_gc`` (link speeds; the states ``x``):

* ``A = 0``;
* ``B = G_accel,gc`` (eq. 3.14): ``dx/dt = B u``;
* ``C_speeds`` from ``G_accel,gc^T C_speeds^T = G_accel^T`` (eq. 3.13), a rank-revealing
  least-squares solve (numeric) or an exact solve on independent columns (symbolic): every link
  speed ``w = C_speeds x``;
* ``D_torques = G_clutches`` (eq. 3.15): locked element torques ``t = D_torques u`` (one row per
  constraint: elements in parallel share a row, ``t_<A>+<B>``, see ``locked_groups``).

For control tools the two output equations are stacked into one, ``y = Cy x + Dy u`` with
``y = [w; t]`` (the link speeds, then the locked torques; names in ``outputs``):
``Cy = [C_speeds; 0]`` and ``Dy = [0; D_torques]``, so that MATLAB/Octave ``ss(A, B, Cy, Dy)``
and ``scipy.signal.StateSpace(A, B, Cy, Dy)`` take them as they are.

Inputs ``u`` are the same for every mode (:func:`transgen.equations.input_names`).
"""
from __future__ import annotations

import warnings
from dataclasses import dataclass, field

import numpy as np

from .equations import kinematic_basis
from .errors import MAX_SHOWN, ModeError
from .graph import bond_graph, link_nodes
from .model import Mechanism
from .modes import (
    ModeModel,
    check_coordinates,
    coordinate_subset,
    default_coordinates,
    mode_models,
)

__all__ = ["ModeStateSpace", "SkippedMode", "StateSpaceSet", "state_space", "matrices_document", "MATRICES"]


@dataclass(frozen=True)
class ModeStateSpace:
    """State-space matrices of one mode (numpy arrays, or sympy matrices when symbolic)."""

    name: str
    locked: tuple[str, ...]
    label: str
    kind: str
    dof: int
    states: tuple[str, ...]
    inputs: tuple[str, ...]
    B: object = field(repr=False)
    C: object = field(repr=False)
    D: object = field(repr=False)
    speed_outputs: tuple[str, ...] = ()
    torque_outputs: tuple[str, ...] = ()
    locked_groups: tuple[tuple[str, ...], ...] = ()
    """The locked elements behind each row of ``D`` (several for elements in parallel, whose
    row is the group's torque in its first member's direction)."""
    idle: tuple[str, ...] = ()
    """Idle members of a gear mode (:mod:`transgen.idle`): links that move with the input held;
    their motions are states besides the gear's (e.g. ``states = (IN, H)``)."""
    gear: str | None = None
    """The gear-table row (gear or neutral) the mode is, else None (:attr:`transgen.modes.Mode.gear`):
    with ``locked``, what joins the matrices to a simulation result's modes."""

    @property
    def A(self) -> np.ndarray:
        """Always zero for a linear inertial field (eq. 3.6): ``n_states x n_states``."""
        if isinstance(self.B, np.ndarray):
            return np.zeros((self.dof, self.dof))
        import sympy

        return sympy.zeros(self.dof, self.dof)

    @property
    def C_speeds(self):
        """Link speeds from the states, ``w = C_speeds x``: ``n_links x n_states`` (``C``)."""
        return self.C

    @property
    def D_torques(self):
        """Locked torques from the inputs, ``t = D_torques u``: ``n_locked x n_inputs`` (``D``)."""
        return self.D

    @property
    def outputs(self) -> tuple[str, ...]:
        """Names of the stacked outputs ``y = [w; t]``: ``w_<link>`` [rad/s], then ``t_<element>`` [N*m]."""
        return tuple(f"w_{s}" for s in self.speed_outputs) + tuple(self.torque_outputs)

    @property
    def Cy(self):
        """``[C_speeds; 0]``: ``n_outputs x n_states`` (sympy when the matrices are symbolic)."""
        return self._stack(self.C, (len(self.torque_outputs), self.dof), below=True)

    @property
    def Dy(self):
        """``[0; D_torques]``: ``n_outputs x n_inputs`` (sympy when the matrices are symbolic)."""
        return self._stack(self.D, (len(self.speed_outputs), len(self.inputs)), below=False)

    def _stack(self, block, zero_shape: tuple[int, int], below: bool):
        """``block`` with a zero block of ``zero_shape`` below (or above) it."""
        if isinstance(block, np.ndarray):
            parts = [np.asarray(block, dtype=float), np.zeros(zero_shape)]
            return np.vstack(parts if below else parts[::-1])
        import sympy

        parts = [block, sympy.zeros(*zero_shape)]
        return sympy.Matrix.vstack(*(parts if below else parts[::-1]))

    def to_control(self):
        """A ``control.StateSpace`` (python-control, optional) with outputs ``y = [w; t]``."""
        import control  # optional dependency

        return control.ss(self.A, np.asarray(self.B, dtype=float), np.asarray(self.Cy, dtype=float),
                          np.asarray(self.Dy, dtype=float), inputs=list(self.inputs), states=list(self.states),
                          outputs=list(self.outputs))


@dataclass(frozen=True)
class SkippedMode:
    """A combination of locked elements that has no state-space model (a tie-up, locked torques
    that are not unique, an undetermined massless link): ``problem`` says which."""

    name: str
    locked: tuple[str, ...]
    kind: str
    problem: str

    def to_dict(self) -> dict:
        return {"name": self.name, "locked": list(self.locked), "kind": self.kind, "problem": self.problem}


@dataclass(frozen=True)
class StateSpaceSet:
    """The state-space matrices of every modelled mode, for one choice of coordinates."""

    mechanism: str
    coordinates: tuple[str, ...]
    inputs: tuple[str, ...]
    modes: tuple[ModeStateSpace, ...]
    symbolic: bool = False
    skipped: tuple[SkippedMode, ...] = ()

    def mode(self, name: str) -> ModeStateSpace:
        for m in self.modes:
            if m.name == name:
                return m
        raise KeyError(name)

    def to_dict(self) -> dict:
        """JSON form (a ``transgen.matrices/1`` document without its head, see
        :func:`matrices_document`): matrices as nested lists of numbers (or of expression strings)."""

        def mat(x):
            if self.symbolic:
                return [[str(v) for v in x.row(i)] for i in range(x.rows)]
            return np.asarray(x, dtype=float).tolist()

        return {
            "mechanism": self.mechanism,
            "coordinates": list(self.coordinates),
            "inputs": list(self.inputs),
            "symbolic": self.symbolic,
            "modes": [
                {"name": m.name, "gear": m.gear, "label": m.label, "locked": list(m.locked), "kind": m.kind, "dof": m.dof,
                 "states": list(m.states), "inputs": list(m.inputs), "outputs": list(m.outputs),
                 **{k: mat(getattr(m, k)) for k in MATRICES},
                 "speed_outputs": list(m.speed_outputs), "torque_outputs": list(m.torque_outputs),
                 "locked_groups": [list(grp) for grp in m.locked_groups], "idle": list(m.idle)}
                for m in self.modes
            ],
            "skipped": [m.to_dict() for m in self.skipped],
        }


MATRICES = ("A", "B", "C_speeds", "D_torques", "Cy", "Dy")
"""The matrices of a mode in every export, in this order."""

MATRICES_SCHEMA = "transgen.matrices/1"

MATRICES_UNITS = {"dof": "1", "A": "1/s", "B": "1/(kg*m^2)", "C_speeds": "1", "D_torques": "1", "Cy": "1", "Dy": "1",
                  "states": "rad/s", "inputs": "N*m", "speed_outputs": "rad/s", "torque_outputs": "N*m"}
"""Units of the matrices (``B`` maps torques to accelerations) and of the named signals; the
outputs ``y = [w; t]`` are rad/s, then N*m."""


def matrices_document(ss: StateSpaceSet) -> dict:
    """``ss`` as a ``transgen.matrices/1`` JSON document (``transgen matrices``, ``-o x.json``)."""
    from .schemas import json_document

    return json_document(MATRICES_SCHEMA, ss.to_dict(), MATRICES_UNITS)


def _numeric_C(G_accel: np.ndarray, rows: list[int]) -> np.ndarray:
    G_gc = G_accel[rows]
    if not rows:
        return np.zeros((G_accel.shape[0], 0))
    Ct, *_ = np.linalg.lstsq(G_gc.T, G_accel.T, rcond=None)  # eq. 3.13
    C = Ct.T
    C[np.abs(C) < 1e-12 * max(1.0, np.abs(C).max())] = 0.0
    return C


def _symbolic_C(eq, rows: list[int]):
    """Exact ``C_speeds``: every link speed in terms of the coordinates ``rows``. For valid
    coordinates it is what eq. 3.13 gives (``G_accel = C G_accel,gc``); it is computed from the
    kinematics alone (gear geometry only), which stays small where ``G_accel`` is large."""
    import sympy

    if not rows:
        return sympy.zeros(eq.n_links, 0)
    return sympy.Matrix(kinematic_basis(eq.E, eq.n_links, rows))


def _mode_state_space(model: ModeModel, links: list[str], coords, symbolic: bool) -> ModeStateSpace:
    eq = model.symbolic_equations if symbolic else model.equations
    states = coordinate_subset(model, links, coords)
    rows = [links.index(s) for s in states]
    G_accel = eq.G_accel
    if symbolic:
        B = G_accel.extract(rows, list(range(G_accel.cols)))
        C = _symbolic_C(eq, rows)
    else:
        B = G_accel[rows].copy()
        C = _numeric_C(G_accel, rows)
    D = eq.G_clutches
    return ModeStateSpace(model.name, model.locked, model.mode.label, model.kind, model.dof, states, eq.u,
                          B, C, D, tuple(links), tuple(f"t_{grp.label}" for grp in eq.groups),
                          tuple(grp.members for grp in eq.groups), model.idle, model.mode.gear)


def state_space(mech: Mechanism, coordinates=None, which: str = "auto", symbolic: bool | str = False,
                models: list[ModeModel] | None = None) -> StateSpaceSet:
    """State-space matrices of the modelled modes of ``mech``.

    ``coordinates``: link names (default: the file's ``coordinates`` statement, else
    :func:`~transgen.modes.default_coordinates`). When the modes are every combination of
    elements (``which="all"``, or a mechanism without gear table or modes), the combinations that
    cannot be modelled (tie-ups, ...) are left out and listed in ``skipped``. Raises
    :class:`ModeError` when a chosen mode (declared or default) or every combination cannot be
    modelled, or the coordinates are not valid.
    """
    g = bond_graph(mech)
    links = link_nodes(g)
    models = mode_models(mech, which, symbolic) if models is None else models
    bad = [m for m in models if m.equations is None]
    if bad and (len(bad) == len(models) or not _every_combination(mech, which)):
        shown = [f"{m.name}: {m.problem}" for m in bad[:MAX_SHOWN]]
        raise ModeError("; ".join(shown + ([f"... and {len(bad) - MAX_SHOWN} more modes"] if len(bad) > MAX_SHOWN else [])))
    skipped = tuple(SkippedMode(m.name, m.locked, m.kind, m.problem) for m in bad)
    models = [m for m in models if m.equations is not None]
    for m in models:
        if m.problem:
            warnings.warn(f"mode {m.name}: {m.problem}", stacklevel=2)
    coords = tuple(coordinates or mech.coordinates) or default_coordinates(models, links, mech.input, mech.output)
    check_coordinates(models, links, coords)
    modes = tuple(_mode_state_space(m, links, coords, bool(symbolic)) for m in models)
    return StateSpaceSet(mech.name, coords, models[0].equations.u if models else (), modes, bool(symbolic), skipped)


def _every_combination(mech: Mechanism, which: str) -> bool:
    """Whether the mode selection ``which`` is every combination (see :func:`select_modes`)."""
    if which == "auto":
        which = "declared" if mech.modes else "default"
    return which == "all" or (which == "default" and not any(g.kind == "gear" for g in mech.gears))
