"""Shared gears in tooth-count synthesis: the ``share`` statements of a mechanism as rules on the
tooth counts of its planetary sets (:mod:`transgen.synthesis.teeth`).

A shared sun or ring is one gear: one tooth count. A shared pinion is one pinion on one carrier:
one tooth count ``Np`` at one centre distance ``a`` from the axis (in modules):

* a simple set's pinion meshes its sun and ring: ``Np = (Nr - Ns)/2``, ``a = (Ns + Nr)/4``;
* a double-pinion set's inner pinion (``Ni`` teeth) meshes the sun, ``a = (Ns + Ni)/2``; its
  outer pinion (``No``) the ring, ``a = (Nr - No)/2``. ``Ns`` and ``Nr`` alone do not fix them,
  so a double-pinion set whose pinion is shared must also have a partner pinion that closes the
  chain: ``Ni, No >= min_teeth``; the pinions reach each other, ``|Nr - No - Ns - Ni| <= Ni +
  No`` (the triangle of the axis and the two pinion centres); the inner pinion's tip clears the
  ring's, ``Ns + 2 Ni + 4 < Nr``, and the outer pinion's the sun's, ``Nr - 2 No > Ns + 4``
  (standard addendum of one module, like the planet clearance of the assembly rules).

The sets on one pinion have as many pinions: a planet count admissible for each of them (the
largest is reported). The HowStuffWorks Ravigneaux (a simple set with the large sun on the long
pinion, a double-pinion set with the small sun whose outer pinion is the long one) thus gets
equal rings (``a`` of the long pinion is ``(Nsl + Nr)/4`` and ``(Nr' - Np)/2``), a large sun
bigger than the small one by more than four teeth, a short pinion that fits, and one planet count.
Neighbouring pinion pairs of a double-pinion set are not checked for clearance.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Callable

from ..model import Mechanism, share_groups

AssemblyRules = Any
"""Here :class:`transgen.synthesis.teeth.AssemblyRules` (``min_teeth``, ``max_teeth``, ``planets``),
which imports this module."""
Counts = Callable[[int, int, int], tuple]
"""``counts(Ns, Nr, pinions)``: the admissible planet counts of a set
(:func:`transgen.synthesis.teeth.planet_counts` under the rules)."""

__all__ = ["ShareRules", "share_rules", "shared_choices", "double_pinions_fit"]


def double_pinions_fit(ns: int, nr: int, ni: int, no: int, min_teeth: int) -> bool:
    """Whether a double-pinion set (sun ``ns``, ring ``nr``) can carry an inner pinion of ``ni``
    and an outer pinion of ``no`` teeth (the rules of the module docstring)."""
    return (min(ni, no) >= min_teeth and ns + 2 * ni + 4 < nr and nr - 2 * no > ns + 4
            and abs(nr - no - ns - ni) <= ni + no)


def _partner(ns: int, nr: int, ni: int | None, no: int | None, min_teeth: int) -> bool:
    """Whether the pinion not given (``None``) can be chosen so that the set fits."""
    if ni is not None and no is not None:
        return double_pinions_fit(ns, nr, ni, no, min_teeth)
    if ni is None and no is None:
        return True
    return any(double_pinions_fit(ns, nr, ni if ni is not None else x, no if no is not None else x, min_teeth)
               for x in range(min_teeth, nr // 2 + 1))


@dataclass(frozen=True)
class ShareRules:
    """The shared gears of a mechanism: ``groups`` as :func:`transgen.model.share_groups`,
    ``pinions`` the pinion count of every set named in them."""

    groups: tuple[tuple[tuple[str, str], ...], ...]
    pinions: dict

    @property
    def sets(self) -> frozenset[str]:
        """The sets named by a share."""
        return frozenset(s for g in self.groups for s, _ in g)

    def equal_teeth(self, teeth: dict) -> bool:
        """Shared suns and rings of the sets in ``teeth`` (name -> ``(Ns, Nr)``) have equal counts."""
        for g in self.groups:
            for index, member in ((0, "sun"), (1, "ring")):
                counts = {teeth[s][index] for s, m in g if m == member and s in teeth}
                if len(counts) > 1:
                    return False
        return True

    def planets(self, teeth: dict, rules: AssemblyRules, counts: Counts) -> dict | None:
        """The planet count of every set when ``teeth`` (every named set -> ``(Ns, Nr)``) obeys all
        the shares (the module docstring), else ``None``. Sets on a shared pinion get their
        largest common count; the others their own largest."""
        if not self.equal_teeth(teeth):
            return None
        fixed: dict[tuple[str, str], int] = {}  # (double-pinion set, inner/outer) -> teeth
        out = {}
        for g in self.groups:
            pinion = [(s, m) for s, m in g if m.endswith("pinion")]
            if not pinion:
                continue
            if not self._pinion(pinion, teeth, rules, fixed):
                return None
            common = set(rules.planets)
            for s, _ in pinion:
                common &= set(counts(*teeth[s], self.pinions[s]))
            if not common:
                return None
            out.update({s: max(common) for s, _ in pinion})
        for s in {s for s, _ in fixed}:
            ns, nr = teeth[s]
            if not _partner(ns, nr, fixed.get((s, "inner_pinion")), fixed.get((s, "outer_pinion")), rules.min_teeth):
                return None
        return out

    def _pinion(self, members, teeth: dict, rules: AssemblyRules, fixed: dict) -> bool:
        """One shared pinion: one tooth count at one centre distance; records in ``fixed`` the
        pinions of double-pinion sets it determines."""
        simple = {((nr - ns) // 2, ns + nr) for s, _ in members if self.pinions[s] == 1 for ns, nr in [teeth[s]]}
        if len(simple) > 1:
            return False
        candidates = [next(iter(simple))[0]] if simple else range(rules.min_teeth, rules.max_teeth + 1)
        doubles = [(s, m) for s, m in members if self.pinions[s] == 2]
        for np_ in candidates:
            # four times the centre distance of each member, in modules
            centres = {ns + nr for s, _ in members if self.pinions[s] == 1 for ns, nr in [teeth[s]]}
            centres |= {2 * (teeth[s][0] + np_) if m == "inner_pinion" else 2 * (teeth[s][1] - np_) for s, m in doubles}
            if len(centres) == 1 and (simple or all(_partner(*teeth[s], np_ if m == "inner_pinion" else None,
                                                             np_ if m == "outer_pinion" else None, rules.min_teeth)
                                                    for s, m in doubles)):
                fixed.update({(s, m): np_ for s, m in doubles})
                return True
        return False


def share_rules(mech: Mechanism) -> ShareRules | None:
    """The shares of ``mech`` as rules on tooth counts (``None``: it declares none)."""
    if not mech.shares:
        return None
    pinions = {p.name: p.pinions for p in mech.planetaries}
    return ShareRules(share_groups(mech.shares), pinions)


def shared_choices(rules_: ShareRules, names: list[str], lists: list[list[tuple[int, int, int]]], known: dict,
                   rules: AssemblyRules, counts: Counts) -> list[tuple[dict, tuple]]:
    """Every joint choice of ``(Ns, Nr, planets)`` for the unknown sets ``names`` (one from each of
    ``lists``) that obeys the shares with the sets of ``known`` (name -> ``(Ns, Nr)``), smallest
    first: ``(planets of every named set, the choice with its planet counts)``. Depth first,
    dropping a branch as soon as two shared suns or rings differ."""
    out = []
    assigned = {s: t for s, t in known.items() if s in rules_.sets}

    def visit(i: int, picked: list) -> None:
        if i == len(names):
            planets = rules_.planets(assigned, rules, counts)
            if planets is not None:
                out.append((planets, tuple((ns, nr, planets.get(s, n)) for s, (ns, nr, n) in zip(names, picked))))
            return
        for item in lists[i]:
            assigned[names[i]] = item[:2]
            if rules_.equal_teeth(assigned):
                visit(i + 1, picked + [item])
        assigned.pop(names[i], None)

    if names:
        visit(0, [])
    else:
        planets = rules_.planets(assigned, rules, counts)
        out = [] if planets is None else [(planets, ())]
    out.sort(key=lambda c: sum(ns + nr for ns, nr, _ in c[1]))
    return out
