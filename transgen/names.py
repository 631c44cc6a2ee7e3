"""The names a user recognises for the modes and shifts of a mechanism.

Every command shows a mode, a shift or a gear by the one rule of :class:`ModeNames`: a set of
locked shift elements is named

1. by its **gear** when it is a row of the gear table (``gear 2 = C1 C4``: ``2``; a declared
   ``neutral N = C5``: ``N``) - the gear's elements locked, and at most one-way clutches besides
   (they lock by themselves beside a locked element, the motion is the gear's);
2. else by its **declared mode** name (``mode SP = C1``: ``SP``);
3. else by its **locked elements** joined by ``+`` in declaration order (``C1+C4``; ``none`` when
   every element is open).

A gear name that a declared mode of another locked set already carries (``mode 1 = C1 C5``
beside ``gear 1 = LU C1 C5``) yields to that mode: the gear's set then takes its own declared
name (``1L``), so that a name always means one locked set. A shift is named by its two modes,
``2-3`` (:func:`shift_name`; names never contain ``-`` or ``+`` of their own: the grammar's
names are letters, digits and ``_``).

The simulator names the modes of a result this way (:meth:`transgen.sim.model.transmission.Transmission.mode_name`),
the shift report its shifts, ``modes``, ``std`` and ``matrices`` show the name beside the
selection's mode name (``M1``) with the locked set, so that results and matrices join on either.
"""
from __future__ import annotations

from collections.abc import Iterable
from functools import lru_cache

from .model import Mechanism

__all__ = ["ModeNames", "mode_names", "user_name", "gear_name", "shift_name", "locked_text", "numbered"]


def locked_text(locked: Iterable[str]) -> str:
    """The locked elements joined by ``+`` (``C1+C4``), ``none`` for an empty set."""
    return "+".join(locked) or "none"


def shift_name(source: str, target: str) -> str:
    """The name of a shift from the mode named ``source`` to the mode named ``target``: ``2-3``."""
    return f"{source}-{target}"


def numbered(names: Iterable[str]) -> list[str]:
    """``names`` made unique by their occurrence: the second ``2-3`` of a run is ``2-3#2``, the
    third ``2-3#3`` (the first keeps its name). Shift plots and sweep columns are named so."""
    seen: dict[str, int] = {}
    out = []
    for name in names:
        seen[name] = seen.get(name, 0) + 1
        out.append(name if seen[name] == 1 else f"{name}#{seen[name]}")
    return out


class ModeNames:
    """The user names of the locked sets of one mechanism (see the module doc for the rule):
    from its ``elements`` (in declaration order), the ``oneway`` clutches among them, the gear
    table ``gears`` (name -> engaged elements, gears and neutrals in the file's order) and the
    ``declared`` modes (name -> locked elements). :meth:`of` builds it from a mechanism,
    :meth:`to_dict` / :meth:`from_dict` carry it in a result's ``meta["naming"]``."""

    def __init__(self, elements, oneway=(), gears=None, declared=None):
        self.order = {name: k for k, name in enumerate(elements)}
        self.oneway = frozenset(oneway)
        self.gears = tuple((name, frozenset(eng)) for name, eng in (gears or {}).items())
        self.declared = {frozenset(locked): name for name, locked in (declared or {}).items()}
        self._taken = {name: key for key, name in self.declared.items()}

    @classmethod
    def of(cls, mech: Mechanism) -> ModeNames:
        """The names of the modes of ``mech``."""
        return cls(mech.element_names, [e.name for e in mech.elements if e.kind == "oneway"],
                   {g.name: g.engaged for g in mech.gears}, {d.name: d.locked for d in mech.modes})

    def to_dict(self) -> dict:
        """JSON-ready: ``elements``, ``oneway``, ``gears`` and ``declared`` (name -> elements)."""
        return {"elements": list(self.order), "oneway": sorted(self.oneway, key=self.order.get),
                "gears": {name: list(self._sorted(eng)) for name, eng in self.gears},
                "declared": {name: list(self._sorted(key)) for key, name in self.declared.items()}}

    @classmethod
    def from_dict(cls, data: dict) -> ModeNames:
        """The inverse of :meth:`to_dict`."""
        return cls(data.get("elements", ()), data.get("oneway", ()), data.get("gears"), data.get("declared"))

    def _sorted(self, locked: Iterable[str]) -> tuple[str, ...]:
        return tuple(sorted(set(locked), key=lambda e: (self.order.get(e, len(self.order)), e)))

    def gear(self, locked: Iterable[str]) -> str | None:
        """The gear-table row (gear or neutral) whose elements are ``locked``, with at most
        one-way clutches besides (the row with the most elements when several fit), or None."""
        key = frozenset(locked)
        fits = [(len(eng), -k, name) for k, (name, eng) in enumerate(self.gears)
                if eng <= key and key - eng <= self.oneway]
        return max(fits)[2] if fits else None

    def name(self, locked: Iterable[str]) -> str:
        """The user name of the mode with the elements ``locked``: gear, declared mode, locked set."""
        key = frozenset(locked)
        gear = self.gear(key)
        if gear is not None and self._taken.get(gear, key) == key:
            return gear
        if key in self.declared:
            return self.declared[key]
        return gear if gear is not None else locked_text(self._sorted(key))

    def shift(self, source: Iterable[str], target: Iterable[str]) -> str:
        """The name of the shift from the locked set ``source`` to ``target``."""
        return shift_name(self.name(source), self.name(target))


@lru_cache(maxsize=64)
def mode_names(mech: Mechanism) -> ModeNames:
    """The :class:`ModeNames` of ``mech`` (remembered for the last few mechanisms)."""
    return ModeNames.of(mech)


def user_name(mech: Mechanism, locked: Iterable[str]) -> str:
    """The user name of the mode of ``mech`` with the elements ``locked`` (:meth:`ModeNames.name`)."""
    return mode_names(mech).name(locked)


def gear_name(mech: Mechanism, locked: Iterable[str]) -> str | None:
    """The gear (or neutral) of ``mech`` the elements ``locked`` engage, or None (:meth:`ModeNames.gear`)."""
    return mode_names(mech).gear(locked)
