"""The transmission at run time: per-mode matrices from the mode generator, shift-element
torques, and the choice of a consistent mode (thesis 3.2.6 and the complementarity view).

Runde's method (thesis 3.2.1-3.2.5): in a mode the states are its generalized coordinates ``q``
and ``dq/dt = B u``; every link speed is ``w = C q`` and the locked elements transmit
``t = D u``. The mode matrices come from :func:`transgen.statespace.state_space` for the modes
of the STD and are computed on demand (and cached) for any other mode the run reaches.

Shift elements (sign convention of :mod:`transgen.model`: slip ``w1 - w2``, torque from link1 to
link2): a slipping friction element transmits ``T_dyn * apply * friction(|slip|) * gain *
sign(slip)``; it can hold ``|t| <= T_static * apply`` when locked. A one-way clutch overruns in its
``free`` direction with no torque and locks against the other. A dog element (``kind="dog"``) is
open or locked: engaged (apply > 0) while slipping it transmits nothing and waits for synchronism
— it locks when its slip passes through zero, and locked it cannot slip (at zero slip an engaged
dog's only option is to lock); it holds up to its full ``T_static`` whatever the apply level, and
a torque beyond that while engaged stops the run with a :class:`SimulationError` (a dog cannot
slip under load); released (apply 0) it unlocks.

Elements in parallel (the same two links: :func:`transgen.equations.locking_groups`, e.g. the
3HP22's low/reverse brake beside its one-way clutch on the rear carrier, or a freewheel beside an
engageable clutch) always have the same slip, so they are decided as one: at zero slip the group
locks — with every member that can transmit (its one-way clutches, its applied friction
elements) — or slips in one direction (only the free direction of its one-way members). Locked,
it is **one** constraint (one row of ``D``) whose holding range is the sum of its members':
``+-T_static*apply`` per friction element, without limit in a one-way clutch's locking direction
and nothing in its free direction (:meth:`Transmission.holding_limits`); it unlocks as a whole
when its torque leaves that range.

**Torque split rule** (:meth:`Transmission.split_locked_torques`; the motion is unique, the split
is not): the friction elements carry the group's torque first, shared in proportion to their
static capacities ``T_static*apply`` (each at the same fraction of its own limit), up to their
combined capacity; the one-way clutches that lock in the torque's direction carry the rest,
shared equally, and so do the dog elements in either direction. Why: a one-way clutch (sprag or roller) wedges only after a small relative
rotation (its engagement lash), while a clamped friction pack holds from standstill, so in the
rigid limit the friction elements take the torque until they would slip and the one-way clutch
takes what exceeds them. Every member's torque stays within its own limit, a one-way clutch's
only in its locking direction, and the members' torques sum (each counted in the group's
direction) to the constraint torque.

With mesh losses (:attr:`Transmission.mesh`, a :class:`~.mesh.MeshModel`) a mode's response
to its inputs is the lossy equations' (:meth:`Transmission.response`), not ``B u`` and ``D u``.

Size: over the project's 500 lines: the run-time elements, the locking groups and the mode
decision are one concept (the decision is the complementarity over the groups' holding
ranges), kept together so that the decision and the torque split cannot drift apart.
"""
from __future__ import annotations

import itertools
import math
from dataclasses import dataclass, field

import numpy as np

from transgen.equations import locking_groups
from transgen.errors import MechValidationError, ModeError, SimulationError
from transgen.graph import bond_graph, link_nodes
from transgen.kinematics import constraint_matrix, numeric_rank
from transgen.model import HOUSING, Mechanism
from transgen.modes import Mode, massless_problems, mode_model, mode_models
from transgen.names import mode_names
from transgen.statespace import _mode_state_space, state_space

from ..core.signals import Constant, Signal
from .elements import (APPLY_THRESHOLD, DOG, FRICTION, ONEWAY, add_holding_range, element_margin, group_margin,  # noqa: F401
                       slipping_torque, static_capacity)

__all__ = ["ElementConfig", "ModeData", "Transmission", "APPLY_THRESHOLD"]

#: How far past ``t`` [s, relative to max(1, |t|)] :meth:`ElementConfig.applied_after` looks for a
#: rising apply.
APPLY_LOOKAHEAD = 1e-9
_KIND_CODES = {"oneway": ONEWAY, "dog": DOG}


_DERIVED: dict[tuple, tuple[dict, dict]] = {}
_DERIVED_MECHANISMS = 16  # the most recent mechanisms whose derived data is kept


def _derived(mech: Mechanism, coordinates: tuple, modes: str) -> tuple[dict, dict]:
    """The caches of :class:`Transmission` that depend on the mechanism alone (see there), one
    pair per mechanism, coordinates and mode selection (the models are immutable: equal ones
    share them); the least recently built of more than :data:`_DERIVED_MECHANISMS` is dropped."""
    key = (mech, coordinates, modes)
    pair = _DERIVED.pop(key, None) or ({}, {})
    _DERIVED[key] = pair
    while len(_DERIVED) > _DERIVED_MECHANISMS:
        del _DERIVED[next(iter(_DERIVED))]
    return pair


_SPACES: dict[tuple, object] = {}


def _state_space(mech: Mechanism, coordinates, modes: str):
    """:func:`~transgen.statespace.state_space` of the modes of ``mech`` (their models from
    :func:`~transgen.modes.mode_models`): what the gearing alone decides, built once per
    mechanism, coordinates and mode selection in a process and shared by its transmissions (a
    sweep's runs, an optimizer's candidates: the mechanism is parsed anew for each, equal to the
    last); immutable. The least recently built of more than :data:`_DERIVED_MECHANISMS` is dropped."""
    key = (mech, None if coordinates is None else tuple(coordinates), modes)
    ss = _SPACES.pop(key, None)
    if ss is None:
        problems = massless_problems(mech, modes)  # as `transgen check` refuses them
        if problems:
            raise MechValidationError(problems)
        models = mode_models(mech, modes)
        ss = state_space(mech, coordinates, modes, models=[m for m in models if m.equations is not None])
    _SPACES[key] = ss
    while len(_SPACES) > _DERIVED_MECHANISMS:
        del _SPACES[next(iter(_SPACES))]
    return ss


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

    @property
    def code(self) -> int:
        """The kind as :data:`FRICTION`, :data:`ONEWAY` or :data:`DOG` (for the compilable functions)."""
        return _KIND_CODES.get(self.kind, FRICTION)

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
        holds): :func:`element_margin`."""
        return element_margin(self.code, self.static_capacity(t), self.free, torque)

    def static_capacity(self, t: float) -> float:
        return static_capacity(self.code, self.static, self.apply_at(t))

    def signed_capacity(self, direction: int, capacity: str = "dynamic") -> float:
        """Capacity [N*m] times the band-brake gain, signed by ``direction``; 0 for none."""
        if self.kind in ("oneway", "dog") or direction == 0:  # a slipping dog transmits nothing
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
        if friction and self.friction is not None:
            return slipping_torque(self.apply_at(t), slip, scale, self.friction[0], self.friction[1])
        return slipping_torque(self.apply_at(t), slip, scale, (), ())

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
    """Matrices of one mode at run time (numeric).

    ``D`` has one row per constraint: a locked element, or a group of locked elements in
    parallel (``groups[row]``, the representative ``locked_order[row]`` first; ``signs[row]``:
    +1 where a member's slip equals the representative's, -1 where its links are swapped). A
    row's torque is the group's, in the representative's direction.
    """

    locked: frozenset
    name: str
    coords: np.ndarray  # link indices of the states
    B: np.ndarray  # d x n_u
    C: np.ndarray  # n_links x d
    D: np.ndarray  # n_constraints x n_u
    locked_order: tuple[int, ...]  # element index of the representative of each row of D
    in_std: bool
    groups: tuple[tuple[int, ...], ...] = ()  # locked elements of each row of D
    signs: tuple[tuple[int, ...], ...] = ()

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
        self.names = mode_names(mech)  # the user names of its modes (gear, declared mode, locked set)
        self.graph = bond_graph(mech)  # the numeric pipeline's graph: no networkx (import and copy) per run
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
        # elements in parallel: (member indices, signs relative to the first member)
        self.groups = [(tuple(self.element_index[x] for x in grp.members), grp.signs)
                       for grp in locking_groups(self.graph)]
        ss = _state_space(mech, coordinates, modes)
        self.coordinates = ss.coordinates
        self.inputs = ss.inputs
        self.input_index = {name: i for i, name in enumerate(self.inputs)}
        self.element_input = np.array([self.input_index[f"t_{e.name}"] for e in self.elements], dtype=int)
        self._modes: dict[frozenset, ModeData] = {}
        self.mesh = None  # a MeshModel: mesh losses in every mode (:meth:`response`)
        # what the gearing alone decides, shared by the transmissions of one mechanism in a process
        # (a sweep's runs, a benchmark's repeats): the modes computed on demand (or why a lock set
        # is no mode) and :meth:`_without_implied`'s answers
        self._on_demand, self._implied = _derived(mech, tuple(ss.coordinates), modes)
        self.std_modes = []
        for m in ss.modes:
            data = self._data(m, in_std=True)
            self._modes[data.locked] = data
            self.std_modes.append(data)

    # ------------------------------------------------------------------ modes
    def _data(self, m, in_std: bool) -> ModeData:
        locked = tuple(self.element_index[x] for x in m.locked)
        groups = tuple(tuple(self.element_index[x] for x in grp) for grp in m.locked_groups)
        signs = tuple(tuple(int(round(self.P[i] @ self.P[grp[0]] / (self.P[grp[0]] @ self.P[grp[0]]))) for i in grp)
                      for grp in groups)
        return ModeData(frozenset(locked), m.name, np.array([self.link_index[s] for s in m.states], dtype=int),
                        np.asarray(m.B, dtype=float), self._snap(np.asarray(m.C, dtype=float), locked, m.states),
                        np.asarray(m.D, dtype=float), tuple(grp[0] for grp in groups), in_std, groups, signs)

    def _snap(self, C: np.ndarray, locked: tuple[int, ...], states) -> np.ndarray:
        """``C`` with the rows of the links a mode's locked elements join made exactly equal (zero
        for links held to the housing), so that every locked element — also a member of a group
        in parallel that is not the equations' representative — has exactly zero slip, not
        round-off that a slip event could mistake for a crossing."""
        C = C.copy()
        housing = len(self.links)
        parent = list(range(housing + 1))

        def find(x):
            while parent[x] != x:
                x = parent[x]
            return x

        for i in locked:
            e = self.elements[i]
            a, b = sorted((find(e.link1), find(housing if e.link2 is None else e.link2)))
            parent[a if b == housing else b] = b if b == housing else a  # the housing stays a root
        classes: dict[int, list[int]] = {}
        for k in range(housing):
            classes.setdefault(find(k), []).append(k)
        coords = {self.link_index[x] for x in states}
        for root, members in classes.items():
            if root == housing:
                C[members] = 0.0
            elif len(members) > 1:
                source = next((k for k in members if k in coords), members[0])
                C[members] = C[source]
        return C

    def mode(self, locked) -> ModeData:
        """Matrices of the mode with the element indices ``locked`` (cached; computed on demand
        for modes outside the STD, with coordinates taken from the STD's first)."""
        key = frozenset(locked)
        if key not in self._modes:
            data = self._on_demand.get(key)
            if data is None:
                names = tuple(self.elements[i].name for i in sorted(key))
                model = mode_model(self.mech, Mode("+".join(names) or "none", names, "on demand"), self.graph)
                if model.equations is None:
                    data = model.problem
                else:
                    order = list(self.coordinates) + [k for k in self.links if k not in self.coordinates]
                    data = self._data(_mode_state_space(model, self.links, order, False), in_std=False)
                self._on_demand[key] = data
            if isinstance(data, str):
                raise ModeError(data)
            self._modes[key] = data
        return self._modes[key]

    def response(self, data: ModeData, u: np.ndarray, w: np.ndarray) -> tuple[np.ndarray, np.ndarray, float]:
        """``(dq/dt, locked-row torques, mesh loss [W])`` of the mode ``data`` for the inputs
        ``u`` at the link speeds ``w``: ``(B u, D u, 0)``, or the lossy equations' (:attr:`mesh`)."""
        if self.mesh is None:
            return data.B @ u, data.D @ u, 0.0
        alpha, torques, loss = self.mesh.solve(tuple(self.elements[i].name for grp in data.groups for i in grp), u, w)
        return alpha[data.coords], torques, loss

    def mode_name(self, locked) -> str:
        """The user name of the mode with the element indices ``locked``: its gear, else its
        declared mode name, else its locked elements (:class:`transgen.names.ModeNames`)."""
        return self.names.name(self.elements[i].name for i in locked)

    # --------------------------------------------------------- element torques
    def slipping_torques(self, t: float, w: np.ndarray, locked: frozenset, directions: np.ndarray,
                         capacity: str = "dynamic") -> np.ndarray:
        """Torques of every element as inputs (locked ones zero); ``directions`` is the slip
        direction each slipping element transmits in (+1/-1, 0 for none)."""
        return self._slipping_torques_memo(t, self.P @ w, locked, directions, capacity, {})

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

    # ------------------------------------------------- locked groups: limits, split
    def holding_limits(self, mode: ModeData, row: int, t: float) -> tuple[float, float]:
        """The range ``(lo, hi)`` [N*m] of torques that row ``row`` of ``mode.D`` (a locked
        element or group in parallel, in its representative's direction) holds at time ``t``:
        the sum of its members' ranges — ``+-T_static*apply`` per friction element, ``(-inf, 0]``
        or ``[0, inf)`` per one-way clutch (unlimited in its locking direction)."""
        lo = hi = 0.0
        for i, sign in zip(mode.groups[row], mode.signs[row]):
            e = self.elements[i]
            lo, hi = add_holding_range(lo, hi, e.code, e.free, sign, 0.0 if e.kind == "oneway" else e.static_capacity(t))
        return lo, hi

    def holding_margin(self, mode: ModeData, row: int, t: float, torque: float) -> float:
        """How far the row's torque ``torque`` is inside its holding range (:meth:`holding_limits`):
        >= 0 while the constraint holds, crossing zero where it unlocks (the root of the
        integrator's torque event, and the mode decision's test). A lone element's is
        :meth:`ElementConfig.holding_margin` (``T_static*apply - |t|``, or ``-free*t``); a group's
        has the same round-off allowance, relative to its friction capacity and the torque."""
        members = mode.groups[row]
        if len(members) == 1:
            return self.elements[members[0]].holding_margin(t, torque)
        lo, hi = self.holding_limits(mode, row, t)
        friction = sum(self.elements[i].static_capacity(t) for i in members if self.elements[i].kind != "oneway")
        return group_margin(lo, hi, friction, torque)

    def unlock_directions(self, mode: ModeData, row: int, t: float, torque: float) -> dict[int, int]:
        """At the unlock of row ``row`` (its torque ``torque`` at a limit): the direction each of
        its locked elements starts to slip in (+1/-1, each in its own slip convention) — the
        direction of the torque at the limit reached, so slipping dissipates. For
        :meth:`decide`'s ``forced``."""
        lo, hi = self.holding_limits(mode, row, t)
        side = 1 if hi - torque <= torque - lo else -1
        return {i: side * sign for i, sign in zip(mode.groups[row], mode.signs[row])}

    def split_locked_torques(self, mode: ModeData, ts: np.ndarray, T: np.ndarray) -> np.ndarray:
        """Each locked element's torque [N*m] (its own direction, link1 to link2) at the times
        ``ts`` from the constraint torques ``T`` (rows of ``mode.D``, one column per time); rows
        elements, other elements zero.

        A lone element carries its row. A group in parallel follows the split rule of the module
        docstring: friction members first, in proportion to ``T_static*apply``, up to their
        combined capacity; the rest to the one-way members locking in its direction, shared
        equally. Beyond the combined range (only at an unlock event's own instant) the excess
        goes to the friction members, so the members always sum to the row's torque.
        """
        out = np.zeros((len(self.elements), len(ts)))
        for row, (members, signs) in enumerate(zip(mode.groups, mode.signs)):
            tau = T[row]
            if len(members) == 1:
                out[members[0]] = tau
                continue
            friction = [(i, sgn) for i, sgn in zip(members, signs) if self.elements[i].kind not in ("oneway", "dog")]
            oneway = [(i, sgn) for i, sgn in zip(members, signs) if self.elements[i].kind == "oneway"]
            dogs = [(i, sgn) for i, sgn in zip(members, signs) if self.elements[i].kind == "dog"]
            caps = [self.elements[i].static * self.elements[i].apply_over(ts) for i, _ in friction]
            total = np.sum(caps, axis=0) if caps else np.zeros(len(ts))
            carried = np.clip(tau, -total, total)
            rest = tau - carried
            for direction in (1, -1):
                # the one-way members locking in this direction and the dogs (teeth, like a sprag, take
                # load only after their lash: the friction members carry first)
                carriers = [(i, sgn) for i, sgn in oneway if -self.elements[i].free * sgn == direction] + dogs
                part = np.where(rest * direction > 0, rest, 0.0)
                for i, sgn in carriers:
                    out[i] += sgn * part / len(carriers)
                if not carriers:
                    carried = carried + part  # beyond the range: stays with the friction elements
            if friction:
                for (i, sgn), c in zip(friction, caps):
                    share = np.divide(c, total, out=np.full(len(ts), 1.0 / len(friction)), where=total > 0)
                    out[i] += sgn * carried * share
            else:
                out[members[0]] += carried
        return out

    # ------------------------------------------------------ mode consistency
    def decide(self, t: float, w: np.ndarray, external_u: np.ndarray, slip_tol: float,
               forced: dict[int, int] | None = None, previous: frozenset = frozenset(),
               sliding: np.ndarray | None = None) -> tuple[frozenset, np.ndarray]:
        """The consistent mode at time ``t`` and speeds ``w``: which elements at zero slip lock,
        and which way the others slip (complementarity, Pfeiffer & Glocker).

        Elements at zero slip (``|slip| <= slip_tol``: the slip left is round-off) are decided by
        groups: elements in parallel (:attr:`groups`) have one slip and are decided as one. A
        group at zero slip with a member that can transmit torque
        (:meth:`ElementConfig.applied_after`: one-way, apply > 0, or an apply that rises from zero
        at ``t``) may lock — with all such members — or start slipping either way (only in the
        free direction of its one-way members); the released elements at zero slip get the
        direction of their slip acceleration in the chosen mode (never the sign of round-off).
        For every combination the mode's locked torques and slip accelerations are computed —
        with the static capacity for elements that start to slip, as the sticking test of 3.2.6
        asks — and the combination is consistent when every locked row's torque is within its
        holding range (:meth:`holding_margin`: ``|t| <= T_static*apply`` for a lone friction
        element, the locking direction for a lone one-way clutch, the combined range for a
        group) and every group starting to slip accelerates in its slip direction. The unique
        consistent combination is returned with the slip directions; none or several raise
        :class:`SimulationError` naming the elements.

        A lock that the other locked elements already imply through the gearing (a third clutch
        applied on a planetary set that two locked clutches already turn as one block) has no
        unique torque: such a group stays out of the mode's constraints, at zero slip and without
        torque, while the elements locked before it (``previous``) keep carrying the load; it
        takes its share when one of them lets go (the next decision finds it at zero slip, now
        needed). Groups in parallel on the same two links are handled by :attr:`groups` instead.

        An element forced to slip (below) whose slip the chosen locks hold at zero through the
        gearing cannot slip: it stays at zero slip at its limit, sliding — transmitting its
        dynamic torque in the forced direction (a clutch pack that has broken loose without
        moving) — while the locks carry the rest of the load (three clutches on a block in a
        double swap: the two offgoing ones saturate in turn). An element that slid like this in
        the previous segment (``sliding``: the previous slip directions) is tested at its dynamic
        capacity when it starts to slip, not its static one: it is not stuck. Where no
        combination passes, a second pass lets unforced redundant groups slide like that too (a
        motion that several weak elements hold only together); of several that then pass (one
        motion, different splits) the first in declaration order is taken.

        Where several combinations pass and all but one hold a lock that carries only round-off
        torque (a torque passing through zero, a tiny apply), the one that needs no such lock is
        taken: locking and slipping then describe the same motion. Where several pass because an
        element sliding at zero slip could also stick (its torque between its dynamic and static
        capacity), the one where it slides on is taken.

        ``forced`` maps elements whose unlocking condition has just been met (their row's torque
        reached its holding limit: :meth:`unlock_directions`) to the direction they start to slip
        in: at that instant locking and slipping are both borderline, and the event has already
        decided for them (and for their group).
        """
        forced = forced or {}
        for i in forced:
            e = self.elements[i]
            if e.kind == "dog" and e.apply_at(t) > APPLY_THRESHOLD:
                raise SimulationError(f"t={t:.6g} s: dog element {e.name} would have to hold more than its static "
                                      f"capacity {e.static:g} N*m while engaged: a dog cannot slip under load")
        slips = self.P @ w
        zero = []  # (members, signs, members that can transmit, choices) of the groups at zero slip
        for members, signs in self.groups:
            capable = tuple(i for i in members if self.elements[i].applied_after(t))
            if capable and abs(slips[members[0]]) <= slip_tol:
                # an engaged dog at zero slip locks: its teeth are in mesh, it has no slipping state
                dog = any(self.elements[i].kind == "dog" for i in capable)
                zero.append((members, signs, capable, (0,) if dog else self._choices(members, signs, forced)))
        deciding = {i for z in zero for i in z[0]}
        released = [i for i in range(len(self.elements)) if abs(slips[i]) <= slip_tol and i not in deciding]
        base_dir = np.sign(slips).astype(int)
        consistent = []
        rejected = 0
        torque_memo: dict = {}  # (element, direction, capacity) -> its slipping torque, at this t and w
        for share in (False, True):
            if share and consistent:
                break
            for choice in itertools.product(*[z[3] for z in zero]):
                wanted = frozenset(i for z, c in zip(zero, choice) if c == 0 for i in z[2])
                found = refused = False
                for locked in self._lock_sets(wanted, previous):
                    try:
                        data = self.mode(locked)
                    except ModeError:
                        refused = True
                        continue
                    refused = False
                    passed = self._consistent(t, w, external_u, zero, choice, locked, data, forced, released,
                                              base_dir, sliding, share, (slips, torque_memo))
                    if passed is None:
                        break  # an unforced group that cannot slip: the lock choice decides it
                    if passed is not False:
                        directions, idle = passed
                        if not any(lk == locked and np.array_equal(d, directions) for lk, d, _ in consistent):
                            consistent.append((locked, directions, idle))
                        found = True
                        break
                rejected += refused and not found and not share
            if share and consistent:
                # the same motion, the load shared: the first in the elements' declaration order
                consistent = consistent[:1]
        if len(consistent) > 1:
            # locking and slipping both pass where a lock would hold nothing (a torque through zero):
            # the combination that needs no such lock is the motion
            needed = [c for c in consistent if not c[2]]
            consistent = needed if len(needed) == 1 else consistent
        if len(consistent) > 1:
            # the same, where several locks hold nothing: a combination whose extra locks over
            # another's all hold only round-off torque describes that one's motion
            fewer = [c for c in consistent
                     if not any(o[0] < c[0] and c[0] - o[0] <= c[2] for o in consistent)]
            consistent = fewer if len(fewer) == 1 else consistent
        if len(consistent) > 1 and sliding is not None:
            # an element sliding at zero slip keeps sliding (kinetic friction) where it can: it
            # sticks only where sliding on is inconsistent
            on = [c for c in consistent
                  if all(c[1][i] == sliding[i] for i in range(len(sliding)) if i not in previous and sliding[i] != 0
                         and abs(slips[i]) <= slip_tol and i not in forced)]
            consistent = on if len(on) == 1 else consistent
        if len(consistent) == 1:
            return consistent[0][:2]
        names = ", ".join(self.elements[i].name for z in zero for i in z[0]) or "none"
        if not consistent:
            raise SimulationError(
                f"t={t:.6g} s: no consistent mode for the elements at zero slip ({names}); "
                f"{rejected} candidate mode(s) have non-unique locked torques or undetermined members")
        options = "; ".join("+".join(self.elements[i].name for i in sorted(lk)) or "none" for lk, _, _ in consistent)
        raise SimulationError(f"t={t:.6g} s: several consistent modes for the elements at zero slip ({names}): {options}")

    def _consistent(self, t, w, external_u, zero, choice, locked, data, forced, released, base_dir, sliding,
                    share: bool = False, memo: tuple | None = None):
        """:meth:`decide`'s test of one combination ``choice`` realised by the lock set ``locked``
        (mode ``data``): ``(directions, idle)`` when consistent, ``False`` when not, ``None`` when
        an unforced group that the locks hold at zero kinematically would have to slip. ``idle``:
        the locked elements whose row holds only round-off torque. ``memo``: the slips ``P @ w``
        and a dict of the slipping torques computed so far at ``t`` and ``w`` (:meth:`decide` tests
        many combinations at the same instant; each element slips one of two ways)."""
        slips, torque_memo = memo if memo is not None else (self.P @ w, {})
        directions = base_dir.copy()
        implied = set()  # slipping groups whose slip the mode's locks hold at zero kinematically
        for (members, signs, _, _), c in zip(zero, choice):
            directions[list(members)] = c * np.asarray(signs)
            if c != 0 and not np.any(np.abs(self.P[members[0]] @ data.C) > 1e-12):
                implied.add(members)
        unforced = [m for m in implied if not any(i in forced for i in m)]
        if unforced and not share:
            return None
        if share and not unforced:
            return False  # tested in the first pass
        free = set(forced) | {i for m in unforced for i in m}  # sliding without the slip test
        u = external_u.copy()
        torques = self._slipping_torques_memo(t, slips, locked, directions, "dynamic", torque_memo)
        # elements leaving zero slip are tested at their static capacity, except those that have
        # broken loose already: forced ones (their static limit was just exceeded) and sliding ones
        starting = [i for z, c in zip(zero, choice) if c != 0 and z[0] not in implied for i in z[0]
                    if i not in forced and (sliding is None or sliding[i] != directions[i])]
        if starting:
            torques[starting] = self._slipping_torques_memo(t, slips, locked, directions, "static",
                                                            torque_memo)[starting]
        u[self.element_input] += torques
        qd, t_locked, _ = self.response(data, u, w)
        slip_acc = self.P @ (data.C @ qd)
        if any(self.holding_margin(data, row, t, t_locked[row]) < 0.0 for row in range(len(data.locked_order))):
            return False
        for (members, _, _, _), c in zip(zero, choice):
            if c != 0 and not any(i in free for i in members) and not c * slip_acc[members[0]] > 0:
                return False
        # a released element at zero slip moves off the way its slip accelerates
        for i in released:
            directions[i] = int(np.sign(slip_acc[i]))
        # a lock that holds only round-off torque is no lock the motion needs
        tiny = np.abs(t_locked) <= 1e-9 * (1.0 + np.max(np.abs(u)))
        idle = frozenset(i for row in np.flatnonzero(tiny) for i in data.groups[row])
        return directions, idle

    def _slipping_torques_memo(self, t: float, slips: np.ndarray, locked: frozenset, directions: np.ndarray,
                               capacity: str, memo: dict) -> np.ndarray:
        """:meth:`slipping_torques` at the slips ``slips`` (``P @ w``), each element's torque taken
        from ``memo`` where it was computed already (the same call, the same number)."""
        out = np.zeros(len(self.elements))
        for i, e in enumerate(self.elements):
            if i not in locked:
                key = (i, int(directions[i]), capacity)
                torque = memo.get(key)
                if torque is None:
                    torque = memo[key] = e.slip_torque(t, slips[i], key[1], capacity)
                out[i] = torque
        return out

    def _lock_sets(self, locked: frozenset, previous: frozenset):
        """The lock sets that realise the lock choice ``locked``: itself, and where its torques are
        not unique (a lock the others imply through the gearing), each reduction without the
        implied groups (:meth:`_without_implied`) — the newcomers dropped first, then each group
        dropped first in turn — so that the load finds the elements that can carry it (a weak
        element left without torque while a strong one holds)."""
        yield locked
        seen = {locked}
        groups = [m for m, _ in self.groups if any(i in locked for i in m)]
        for first in [None] + groups:
            reduced = self._without_implied(locked, previous, first)
            if reduced not in seen:
                seen.add(reduced)
                yield reduced

    def _without_implied(self, locked: frozenset, previous: frozenset, first: tuple | None = None) -> frozenset:
        """``locked`` without the groups whose lock the other locked elements already imply
        kinematically (their slip row lies in the span of the gear constraints and the other
        locks): the group ``first`` tried first, then the newcomers (not in ``previous``)."""
        groups = [m for m, _ in self.groups if any(i in locked for i in m)]
        # a pure function of the gearing: remembered (the decision asks it for every candidate
        # at every event, and each answer costs two rank tests of the constraint matrix)
        key = (locked, first, frozenset(i for m in groups for i in m if i in previous))
        if key in self._implied:
            return self._implied[key]
        current = set(locked)
        groups.sort(key=lambda m: (m != first, any(i in previous for i in m)))
        for members in groups:
            rest = sorted(current - set(members))
            a = constraint_matrix(self.graph, [self.elements[i].name for i in rest])
            if numeric_rank(np.vstack([a, self.P[members[0]]])) == numeric_rank(a):
                current -= set(members)
        self._implied[key] = frozenset(current)
        return self._implied[key]

    def _choices(self, members: tuple[int, ...], signs: tuple[int, ...], forced: dict[int, int]) -> tuple[int, ...]:
        """A group's options at zero slip: lock (0) or slip +1/-1 in its first member's
        direction, not against a one-way member's free direction; one option when forced."""
        for i, sign in zip(members, signs):
            if i in forced:
                return (forced[i] * sign,)
        free = {self.elements[i].free * sign for i, sign in zip(members, signs) if self.elements[i].kind == "oneway"}
        return (0,) + tuple(d for d in (1, -1) if free <= {d})
