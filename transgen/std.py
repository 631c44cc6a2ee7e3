"""The state-transition diagram (STD) of mode switching (thesis 3.2.6-3.2.7, Figs. 3.8, 3.12).

From the modelled modes, one transition for every shift element that can lock or unlock in a
mode. The conditions are those of thesis section 3.2.6, in transgen's sign convention (slip
``w1 - w2``, torque ``t`` transmitted from ``link1`` to ``link2``):

* friction clutch / brake, lock: the slip crosses zero and the torque needed to hold the element
  locked satisfies ``|t| <= static capacity * apply``;
* friction clutch / brake, unlock: ``|t| > static capacity * apply``;
* one-way clutch (``free=positive``), lock: the slip reaches zero from above (it would turn
  negative); unlock: the torque it transmits reverses, ``t > 0`` (mirror for ``free=negative``).

A transition whose target is not a modelled mode is kept with ``target=None`` and the locked set
it would reach, so a user sees where the model is incomplete.
"""
from __future__ import annotations

from dataclasses import dataclass

from .model import Mechanism
from .modes import Mode, select_modes

__all__ = ["Transition", "StateTransitionDiagram", "state_transition_diagram", "lock_condition", "unlock_condition"]


@dataclass(frozen=True)
class Transition:
    """``source`` -> ``target`` when ``element`` locks (``event="lock"``) or unlocks."""

    source: str
    target: str | None
    element: str
    event: str
    condition: str
    reaches: tuple[str, ...]

    @property
    def leaves_model(self) -> bool:
        return self.target is None


@dataclass(frozen=True)
class StateTransitionDiagram:
    mechanism: str
    modes: tuple[Mode, ...]
    transitions: tuple[Transition, ...]

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
            "modes": [{"name": m.name, "locked": list(m.locked), "label": m.label} for m in self.modes],
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
        }


def lock_condition(kind: str, name: str, free: str | None = None) -> str:
    """Human-readable locking condition of a shift element (thesis 3.2.6)."""
    if kind == "oneway":
        sign = "negative" if free == "positive" else "positive"
        return f"slip of {name} reaches 0 and would turn {sign}"
    return f"slip of {name} crosses 0 and |t_{name}| <= static capacity"


def unlock_condition(kind: str, name: str, free: str | None = None) -> str:
    """Human-readable unlocking condition of a shift element (thesis 3.2.6)."""
    if kind == "oneway":
        sign = ">" if free == "positive" else "<"
        return f"t_{name} reverses (t_{name} {sign} 0)"
    return f"|t_{name}| > static capacity"


def state_transition_diagram(mech: Mechanism, modes: list[Mode] | None = None) -> StateTransitionDiagram:
    """The STD of the modelled modes (default: :func:`~transgen.modes.select_modes`)."""
    modes = select_modes(mech) if modes is None else modes
    by_key = {m.key: m for m in modes}
    transitions = []
    for mode in modes:
        for e in mech.elements:
            if e.name in mode.locked:
                reaches = tuple(x for x in mode.locked if x != e.name)
                event, condition = "unlock", unlock_condition(e.kind, e.name, e.free)
            else:
                reaches = tuple(x for x in mech.element_names if x in mode.locked or x == e.name)
                event, condition = "lock", lock_condition(e.kind, e.name, e.free)
            target = by_key.get(frozenset(reaches))
            transitions.append(Transition(mode.name, target.name if target else None, e.name, event, condition, reaches))
    return StateTransitionDiagram(mech.name, tuple(modes), tuple(transitions))
