"""The state-transition diagram (STD) of mode switching (thesis 3.2.6-3.2.7, Figs. 3.8, 3.12).

From the modelled modes, one transition for every shift element that can lock or unlock in a
mode. The conditions are those of thesis section 3.2.6, in transgen's sign convention (slip
``w1 - w2``, torque ``t`` transmitted from ``link1`` to ``link2``):

* friction clutch / brake, lock: the slip crosses zero and the torque needed to hold the element
  locked satisfies ``|t| <= static capacity * apply``;
* friction clutch / brake, unlock: ``|t| > static capacity * apply``;
* one-way clutch (``free=positive``), lock: the slip reaches zero from above (it would turn
  negative); unlock: the torque it transmits reverses, ``t > 0`` (mirror for ``free=negative``);
* dog clutch / brake, lock: the slip reaches zero (synchronism) while it is engaged; unlock: it
  is disengaged (a torque beyond its static capacity while engaged stops the simulation).

Elements in parallel (:class:`~transgen.equations.LockingGroup`: the same two links, e.g. a
brake beside a one-way clutch on one carrier) lock one motion, so the diagram treats them as the
simulator does: a group whose motion is free locks with any of its members that can transmit
(every one-way member, and any applied friction members): one transition per such set, labelled
``A+B``; a locked group unlocks as a whole when its torque ``t_A+B`` (in the first member's
direction) leaves the combined holding range (friction members ``+-static x apply`` each, a
one-way member without limit in its locking direction and nothing in its free one); while the
group holds, a friction member joins it when applied (``apply``) and leaves it when released
(``release``), and a one-way member joins it at once.

Modes of the selection whose equations have no unique solution (over-constrained tie-ups,
undetermined massless members: :func:`~transgen.equations.diagnose_singular`) are not modes of
the diagram: they are listed in ``unmodellable`` with the reason, and transitions into them
leave the model, as the simulator refuses them.

A transition whose target is not a modelled mode is kept with ``target=None`` and the locked set
it would reach, so a user sees where the model is incomplete.
"""
from __future__ import annotations

from dataclasses import dataclass, replace

import itertools

from .equations import LockingGroup, diagnose_singular, locking_groups
from .graph import bond_graph
from .model import Mechanism
from .modes import Mode, select_modes
from .names import mode_names

__all__ = ["Transition", "StateTransitionDiagram", "state_transition_diagram", "lock_condition", "unlock_condition",
           "group_lock_condition", "group_unlock_condition"]


@dataclass(frozen=True)
class Transition:
    """``source`` -> ``target`` when ``element`` locks (``event="lock"``) or unlocks; for
    elements in parallel ``element`` is the set that locks or unlocks together (``"BLR+OWC"``),
    and ``"apply"`` / ``"release"`` are a member joining or leaving a group that holds."""

    source: str
    target: str | None
    element: str
    event: str
    condition: str
    reaches: tuple[str, ...]

    @property
    def leaves_model(self) -> bool:
        return self.target is None

    @property
    def adds(self) -> bool:
        """Whether the transition locks elements (``lock``, ``apply``) rather than freeing them."""
        return self.event in ("lock", "apply")

    @property
    def elements(self) -> tuple[str, ...]:
        """The elements that lock or unlock."""
        return tuple(self.element.split("+"))


@dataclass(frozen=True)
class StateTransitionDiagram:
    mechanism: str
    modes: tuple[Mode, ...]
    transitions: tuple[Transition, ...]
    unmodellable: tuple[tuple[Mode, str], ...] = ()
    """Modes of the selection that cannot be modelled, with the reason."""

    @property
    def internal(self) -> tuple[Transition, ...]:
        """Transitions between modelled modes."""
        return tuple(t for t in self.transitions if t.target is not None)

    @property
    def external(self) -> tuple[Transition, ...]:
        """Transitions that would leave the modelled set of modes."""
        return tuple(t for t in self.transitions if t.target is None)

    def to_dict(self) -> dict:
        return {
            "mechanism": self.mechanism,
            "modes": [{"name": m.name, "gear": m.gear, "locked": list(m.locked), "label": m.label} for m in self.modes],
            "transitions": [
                {"from": t.source, "to": t.target, "element": t.element, "event": t.event,
                 "condition": t.condition, "reaches": list(t.reaches)}
                for t in self.internal
            ],
            "leaving": [
                {"from": t.source, "element": t.element, "event": t.event, "condition": t.condition,
                 "reaches": list(t.reaches)}
                for t in self.external
            ],
            "unmodellable": [{"name": m.name, "locked": list(m.locked), "problem": why}
                             for m, why in self.unmodellable],
        }


def lock_condition(kind: str, name: str, free: str | None = None) -> str:
    """Human-readable locking condition of a shift element (thesis 3.2.6)."""
    if kind == "oneway":
        sign = "negative" if free == "positive" else "positive"
        return f"slip of {name} reaches 0 and would turn {sign}"
    if kind == "dog":
        return f"slip of {name} reaches 0 (synchronous) while {name} is engaged: a dog locks only at zero slip"
    return f"slip of {name} crosses 0 and |t_{name}| <= static capacity"


def unlock_condition(kind: str, name: str, free: str | None = None) -> str:
    """Human-readable unlocking condition of a shift element (thesis 3.2.6)."""
    if kind == "oneway":
        sign = ">" if free == "positive" else "<"
        return f"t_{name} reverses (t_{name} {sign} 0)"
    if kind == "dog":
        return (f"{name} is disengaged (it never slips under torque: |t_{name}| > static capacity while engaged "
                f"stops the simulation)")
    return f"|t_{name}| > static capacity"


def _holding_range(mech: Mechanism, group: LockingGroup, held: tuple[str, ...]) -> str:
    """The combined holding range of the locked members ``held`` of ``group``, in the first
    member's direction, as text: ``[-inf, static_BLR]``."""
    sign = dict(zip(group.members, group.signs))
    friction = [x for x in held if mech.element(x).kind != "oneway"]
    # a one-way clutch free in +slip (in the group's direction) locks against -: holds t <= 0
    locks = {-(1 if mech.element(x).free == "positive" else -1) * sign[x] for x in held if x not in friction}
    cap = " + ".join(f"static_{x}" for x in friction)
    if any(mech.element(x).kind == "dog" and mech.element(x).static == float("inf") for x in friction):
        locks = {1, -1}  # an engaged dog without a capacity limit holds any torque
    hi = "inf" if 1 in locks else (cap or "0")
    lo = "-inf" if -1 in locks else (f"-({cap})" if len(friction) > 1 else f"-{cap}" if cap else "0")
    return f"[{lo}, {hi}]"


def group_lock_condition(mech: Mechanism, group: LockingGroup, held: tuple[str, ...]) -> str:
    """Locking condition of the members ``held`` of a group of elements in parallel."""
    return (f"slip of {held[0]} reaches 0 and t_{'+'.join(held)} is within the combined holding range "
            f"{_holding_range(mech, group, held)} (static x apply per friction element)")


def group_unlock_condition(mech: Mechanism, group: LockingGroup, held: tuple[str, ...]) -> str:
    """Unlocking condition of the locked members ``held`` of a group of elements in parallel."""
    return (f"t_{'+'.join(held)} leaves the combined holding range {_holding_range(mech, group, held)} "
            f"(static x apply per friction element)")


def _group_transitions(mech: Mechanism, group: LockingGroup, locked: tuple[str, ...]):
    """``(event, elements, reaches, condition)`` of one group in a mode with ``locked``."""
    order = mech.element_names
    held = tuple(x for x in group.members if x in locked)
    oneway = tuple(x for x in group.members if mech.element(x).kind == "oneway")
    friction = tuple(x for x in group.members if x not in oneway)

    def reach(add=(), remove=()):
        return tuple(x for x in order if (x in locked or x in add) and x not in remove)

    def condition(which, members):
        if len(members) == 1:
            e = mech.element(members[0])
            return (lock_condition if which == "lock" else unlock_condition)(e.kind, e.name, e.free)
        return (group_lock_condition if which == "lock" else group_unlock_condition)(mech, group, members)

    if not held:  # every one-way member locks, with any set of applied friction members
        for r in range(len(friction) + 1):
            for chosen in itertools.combinations(friction, r):
                sets = tuple(x for x in group.members if x in oneway or x in chosen)
                if sets:
                    yield "lock", sets, reach(add=sets), condition("lock", sets)
        return
    yield "unlock", held, reach(remove=held), condition("unlock", held)
    for x in group.members:
        if x in held and x in friction and len(held) > 1:
            rest = "+".join(y for y in held if y != x)
            yield "release", (x,), reach(remove=(x,)), f"apply of {x} falls to 0 while {rest} holds t_{rest}"
        elif x not in held:
            why = (f"{x} is applied" if x in friction else f"{x} engages at once (a one-way clutch at zero slip)")
            yield "apply", (x,), reach(add=(x,)), f"{why} while {'+'.join(held)} holds the motion (slip 0)"


def state_transition_diagram(mech: Mechanism, modes: list[Mode] | None = None) -> StateTransitionDiagram:
    """The STD of the modelled modes (default: :func:`~transgen.modes.select_modes`); modes that
    cannot be modelled go to ``unmodellable``."""
    names = mode_names(mech)
    modes = select_modes(mech) if modes is None else [replace(m, gear=names.gear(m.locked)) for m in modes]
    g = bond_graph(mech)
    problems = {m.key: diagnose_singular(g, m.locked) for m in modes}
    good = [m for m in modes if not problems[m.key]]
    by_key = {m.key: m for m in good}
    groups = locking_groups(g)
    transitions = []
    for mode in good:
        for group in groups:
            for event, elements, reaches, condition in _group_transitions(mech, group, mode.locked):
                target = by_key.get(frozenset(reaches))
                transitions.append(Transition(mode.name, target.name if target else None, "+".join(elements), event,
                                              condition, reaches))
    unmodellable = tuple((m, problems[m.key]) for m in modes if problems[m.key])
    return StateTransitionDiagram(mech.name, tuple(good), tuple(transitions), unmodellable)
