"""The transmission at run time: per-mode matrices from the mode generator, shift-element
torques, and the choice of a consistent mode (thesis 3.2.6 and the complementarity view).

Runde's method (thesis 3.2.1-3.2.5): in a mode the states are its generalized coordinates ``q``
and ``dq/dt = B u``; every link speed is ``w = C q`` and the locked elements transmit
``t = D u``. The mode matrices come from :func:`transgen.statespace.state_space` for the modes
of the STD and are computed on demand (and cached) for any other mode the run reaches.

Shift elements (sign convention of :mod:`transgen.model`: slip ``w1 - w2``, torque from link1 to
link2): a slipping friction element transmits ``T_dyn * apply * friction(|slip|) * gain *
sign(slip)``; it can hold ``|t| <= T_static * apply`` when locked. A one-way clutch overruns in its
``free`` direction with no torque and locks against the other.
"""
from __future__ import annotations

import itertools
from dataclasses import dataclass, field

import numpy as np

from transgen.errors import ModeError, SimulationError
from transgen.graph import build_graph, link_nodes
from transgen.model import HOUSING, Mechanism
from transgen.modes import Mode, mode_model, mode_models
from transgen.statespace import _mode_state_space, state_space

from .signals import Constant, Signal

__all__ = ["ElementConfig", "ModeData", "Transmission", "APPLY_THRESHOLD"]

#: An apply fraction at or below this counts as released. The simulator watches every apply signal
#: crossing it (a rise from zero or a fall to zero is a kink of the element torque and may change the
#: mode); slightly above zero so that an apply held at exactly zero never looks like a crossing.
APPLY_THRESHOLD = 1e-12
#: How far past ``t`` [s, relative to max(1, |t|)] :meth:`ElementConfig.applied_after` looks for a
#: rising apply.
APPLY_LOOKAHEAD = 1e-9


@dataclass
class ElementConfig:
    """Run-time data of one shift element.

    ``apply``: fraction of full apply pressure over time (<= 0: open). ``friction``: optional
    ``(slip [rad/s], factor)`` table multiplying the dynamic capacity. ``gain``, ``energizing``:
    a band brake transmits ``gain`` times its capacity when the slip has the sign ``energizing``
    (+1/-1); 1 otherwise.
    """

    name: str
    kind: str
    link1: int | None
    link2: int | None
    static: float
    dynamic: float
    free: int = 0
    apply: Signal = field(default_factory=lambda: Constant(0.0))
    friction: tuple[tuple[float, ...], tuple[float, ...]] | None = None
    gain: float = 1.0
    energizing: int = 0

    def apply_at(self, t: float) -> float:
        return 1.0 if self.kind == "oneway" else max(0.0, self.apply.value(t))

    def apply_over(self, ts: np.ndarray) -> np.ndarray:
        """:meth:`apply_at` at every time of ``ts`` (output sampling)."""
        return np.ones(len(ts)) if self.kind == "oneway" else np.maximum(self.apply.sample(ts), 0.0)

    def applied_after(self, t: float) -> bool:
        """Whether the element can transmit torque just after ``t``: a one-way clutch always, a
        friction element when its apply is above zero at ``t`` or rises from zero right after it
        (the right limit, so that an element whose apply starts to rise at ``t`` is decided as
        applied)."""
        return self.kind == "oneway" or self.apply_at(t) > 0.0 or self.applied_just_after(t)

    def applied_just_after(self, t: float) -> bool:
        """Whether the apply signal is above :data:`APPLY_THRESHOLD` just after ``t`` (the side of the
        threshold a segment starting at ``t`` leaves from)."""
        return self.apply.value(t + APPLY_LOOKAHEAD * max(1.0, abs(t))) > APPLY_THRESHOLD

    def holding_margin(self, t: float, torque: float) -> float:
        """How far the torque [N*m] of the element, locked, is inside its holding limit (>= 0: it
        holds): ``T_static * apply - |t|`` for a friction element, ``-free * t`` for a one-way clutch,
        each with the round-off allowance that the mode decision accepts (so that a lock decided
        at its limit starts on the holding side of the unlock event)."""
        if self.kind == "oneway":
            return 1e-9 * (1.0 + abs(torque)) - self.free * torque
        return self.static_capacity(t) * (1.0 + 1e-9) + 1e-9 - abs(torque)

    def static_capacity(self, t: float) -> float:
        return float("inf") if self.kind == "oneway" else self.static * self.apply_at(t)

    def signed_capacity(self, direction: int, capacity: str = "dynamic") -> float:
        """Capacity [N*m] times the band-brake gain, signed by ``direction``; 0 for none."""
        if self.kind == "oneway" or direction == 0:
            return 0.0
        base = self.static if capacity == "static" else self.dynamic
        if self.energizing and direction == self.energizing:
            base *= self.gain
        return base * direction

    def slip_torque(self, t: float, slip: float, direction: int, capacity: str = "dynamic") -> float:
        """Torque of the element slipping in ``direction`` (+1/-1) at slip speed ``slip``."""
        return self.torque_at(t, slip, self.signed_capacity(direction, capacity), capacity == "dynamic")

    def torque_at(self, t: float, slip: float, scale: float, friction: bool = True) -> float:
        """:meth:`slip_torque` with the signed capacity ``scale`` of :meth:`signed_capacity` given (a
        right-hand side computes it once per segment); ``friction``: apply the friction table."""
        if scale == 0.0:
            return 0.0
        a = self.apply_at(t)
        if a <= 0.0:
            return 0.0
        if friction and self.friction is not None:
            a *= float(np.interp(abs(slip), self.friction[0], self.friction[1]))
        return scale * a

    def slip_torques(self, ts: np.ndarray, slips: np.ndarray, direction: int) -> np.ndarray:
        """:meth:`slip_torque` (dynamic capacity) at the times ``ts`` with the slips ``slips``."""
        scale = self.signed_capacity(direction)
        if scale == 0.0:
            return np.zeros(len(ts))
        a = self.apply_over(ts)
        if self.friction is not None:
            a = a * np.interp(np.abs(slips), self.friction[0], self.friction[1])
        return scale * a

    def breakpoints(self, t0: float = float("-inf"), t1: float = float("inf")) -> tuple[float, ...]:
        """The apply signal's breakpoints in ``[t0, t1]`` (a window is needed when it is periodic)."""
        return self.apply.breakpoints(t0, t1)


@dataclass
class ModeData:
    """Matrices of one mode at run time (numeric)."""

    locked: frozenset
    name: str
    coords: np.ndarray  # link indices of the states
    B: np.ndarray  # d x n_u
    C: np.ndarray  # n_links x d
    D: np.ndarray  # n_locked x n_u
    locked_order: tuple[int, ...]  # element indices of the rows of D
    in_std: bool

    @property
    def dof(self) -> int:
        return len(self.coords)


class Transmission:
    """A mechanism with its shift-element configuration and its modes.

    Parameters
    ----------
    mech : Mechanism
    elements : dict
        element name -> :class:`ElementConfig` fields other than the ones from the model
        (``apply``, ``friction``, ``gain``, ``energizing``).
    coordinates : sequence of link names, optional
        Generalized coordinates (default: those of :func:`transgen.statespace.state_space`).
    """

    def __init__(self, mech: Mechanism, elements: dict | None = None, coordinates=None, modes: str = "auto"):
        self.mech = mech
        self.graph = build_graph(mech)
        self.links = link_nodes(self.graph)
        self.link_index = {name: i for i, name in enumerate(self.links)}
        self.inertia = np.array([self.graph.nodes[k]["J"] for k in self.links])
        elements = elements or {}
        self.elements: list[ElementConfig] = []
        for e in mech.elements:
            extra = elements.get(e.name, {})
            free = {"positive": 1, "negative": -1}.get(e.free or "", 0)
            self.elements.append(ElementConfig(
                e.name, e.kind, self.link_index.get(e.link1), self.link_index.get(e.link2) if e.link2 != HOUSING else None,
                e.static, e.dynamic, free, **extra))
        self.element_index = {e.name: i for i, e in enumerate(self.elements)}
        # slip = P @ w
        self.P = np.zeros((len(self.elements), len(self.links)))
        for i, e in enumerate(self.elements):
            if e.link1 is not None:
                self.P[i, e.link1] += 1
            if e.link2 is not None:
                self.P[i, e.link2] -= 1
        models = mode_models(mech, modes)
        ss = state_space(mech, coordinates, modes, models=[m for m in models if m.equations is not None])
        self.coordinates = ss.coordinates
        self.inputs = ss.inputs
        self.input_index = {name: i for i, name in enumerate(self.inputs)}
        self.element_input = np.array([self.input_index[f"t_{e.name}"] for e in self.elements], dtype=int)
        self._modes: dict[frozenset, ModeData] = {}
        self.std_modes = []
        for m in ss.modes:
            data = self._data(m, in_std=True)
            self._modes[data.locked] = data
            self.std_modes.append(data)

    # ------------------------------------------------------------------ modes
    def _data(self, m, in_std: bool) -> ModeData:
        locked = tuple(self.element_index[x] for x in m.locked)
        return ModeData(frozenset(locked), m.name, np.array([self.link_index[s] for s in m.states], dtype=int),
                        np.asarray(m.B, dtype=float), np.asarray(m.C, dtype=float), np.asarray(m.D, dtype=float),
                        locked, in_std)

    def mode(self, locked) -> ModeData:
        """Matrices of the mode with the element indices ``locked`` (cached; computed on demand
        for modes outside the STD, with coordinates taken from the STD's first)."""
        key = frozenset(locked)
        if key not in self._modes:
            names = tuple(self.elements[i].name for i in sorted(key))
            model = mode_model(self.mech, Mode("+".join(names) or "none", names, "on demand"), self.graph)
            if model.equations is None:
                raise ModeError(model.problem)
            order = list(self.coordinates) + [k for k in self.links if k not in self.coordinates]
            self._modes[key] = self._data(_mode_state_space(model, self.links, order, False), in_std=False)
        return self._modes[key]

    def mode_name(self, locked) -> str:
        data = self._modes.get(frozenset(locked))
        if data is not None and data.in_std:
            return data.name
        return "+".join(self.elements[i].name for i in sorted(locked)) or "none"

    # --------------------------------------------------------- element torques
    def slipping_torques(self, t: float, w: np.ndarray, locked: frozenset, directions: np.ndarray,
                         capacity: str = "dynamic") -> np.ndarray:
        """Torques of every element as inputs (locked ones zero); ``directions`` is the slip
        direction each slipping element transmits in (+1/-1, 0 for none)."""
        slips = self.P @ w
        out = np.zeros(len(self.elements))
        for i, e in enumerate(self.elements):
            if i not in locked:
                out[i] = e.slip_torque(t, slips[i], int(directions[i]), capacity)
        return out

    def slipping_set(self, locked: frozenset, directions: np.ndarray, t0: float = -np.inf,
                     t1: float = np.inf) -> tuple[tuple, ...]:
        """``(element index, input column, element, signed dynamic capacity)`` of every element
        that can transmit torque while slipping in a mode between ``t0`` and ``t1`` (friction
        elements not locked, with a slip direction, whose apply can rise above zero): what a
        right-hand side loops over (with :meth:`ElementConfig.torque_at`)."""
        return tuple((i, int(self.element_input[i]), e, e.signed_capacity(int(directions[i])))
                     for i, e in enumerate(self.elements)
                     if i not in locked and e.kind != "oneway" and directions[i] != 0
                     and e.apply.upper_bound(t0, t1) > 0.0)

    def slipping_torques_at(self, ts: np.ndarray, W: np.ndarray, locked: frozenset,
                            directions: np.ndarray) -> np.ndarray:
        """:meth:`slipping_torques` at the times ``ts`` for the link speeds ``W`` (one column per
        time): rows elements, columns times."""
        slips = self.P @ W
        out = np.zeros((len(self.elements), len(ts)))
        for i, e in enumerate(self.elements):
            if i not in locked:
                out[i] = e.slip_torques(ts, slips[i], int(directions[i]))
        return out

    # ------------------------------------------------------ mode consistency
    def decide(self, t: float, w: np.ndarray, external_u: np.ndarray, slip_tol: float,
               forced: dict[int, int] | None = None) -> tuple[frozenset, np.ndarray]:
        """The consistent mode at time ``t`` and speeds ``w``: which elements at zero slip lock,
        and which way the others slip (complementarity, Pfeiffer & Glocker).

        Elements with ``|slip| <= slip_tol`` are at zero slip (the slip left is round-off). Those
        that can transmit torque (:meth:`ElementConfig.applied_after`: one-way, apply > 0, or an
        apply that rises from zero at ``t``) may be locked or start slipping either way (a one-way
        clutch only in its free direction); the released ones get the direction of their slip
        acceleration in the chosen mode (never the sign of round-off).
        For every combination the mode's locked torques and slip accelerations are computed —
        with the static capacity for elements that start to slip, as the sticking test of 3.2.6
        asks — and the combination is consistent when every locked friction element holds
        ``|t| <= T_static*apply``, every locked one-way clutch transmits in its locking
        direction, and every element starting to slip accelerates in its slip direction. The
        unique consistent combination is returned with the slip directions; none or several
        raise :class:`SimulationError` naming the elements.

        ``forced`` maps elements whose unlocking condition has just been met (their torque reached
        the static capacity, or a one-way clutch's torque reversed) to the direction they start
        to slip in: at that instant locking and slipping are both borderline, and the event has
        already decided for them.
        """
        forced = forced or {}
        slips = self.P @ w
        at_zero = [i for i in range(len(self.elements)) if abs(slips[i]) <= slip_tol]
        zero = [i for i in at_zero if self.elements[i].applied_after(t)]
        released = [i for i in at_zero if i not in zero]
        base_dir = np.sign(slips).astype(int)
        consistent = []
        rejected = 0
        for choice in itertools.product(*[(forced[i],) if i in forced else self._choices(i) for i in zero]):
            locked = frozenset(i for i, c in zip(zero, choice) if c == 0)
            try:
                data = self.mode(locked)
            except ModeError:
                rejected += 1
                continue
            directions = base_dir.copy()
            for i, c in zip(zero, choice):
                directions[i] = c
            u = external_u.copy()
            torques = self.slipping_torques(t, w, locked, directions)
            starting = [i for i in zero if i not in locked]
            if starting:  # elements leaving zero slip are tested at their static capacity
                torques[starting] = self.slipping_torques(t, w, locked, directions, "static")[starting]
            u[self.element_input] += torques
            alpha = data.C @ (data.B @ u)
            slip_acc = self.P @ alpha
            t_locked = data.D @ u
            ok = True
            for row, i in enumerate(data.locked_order):
                if self.elements[i].holding_margin(t, t_locked[row]) < 0.0:
                    ok = False
            for i, c in zip(zero, choice):
                if c != 0 and i not in forced and not c * slip_acc[i] > 0:
                    ok = False
            if ok:
                # a released element at zero slip moves off the way its slip accelerates
                for i in released:
                    directions[i] = int(np.sign(slip_acc[i]))
                consistent.append((locked, directions))
        if len(consistent) == 1:
            return consistent[0]
        names = ", ".join(self.elements[i].name for i in zero) or "none"
        if not consistent:
            raise SimulationError(
                f"t={t:.6g} s: no consistent mode for the elements at zero slip ({names}); "
                f"{rejected} candidate mode(s) have non-unique locked torques or undetermined members")
        options = "; ".join("+".join(self.elements[i].name for i in sorted(lk)) or "none" for lk, _ in consistent)
        raise SimulationError(f"t={t:.6g} s: several consistent modes for the elements at zero slip ({names}): {options}")

    def _choices(self, i: int) -> tuple[int, ...]:
        e = self.elements[i]
        if e.kind == "oneway":
            return (0, e.free)
        return (0, 1, -1)
