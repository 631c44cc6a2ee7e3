"""The ``share`` statement of the ``.mech`` language: two planetary statements that name one
physical gear or pinion (``share PG_small.ring PG_large.ring``), checked against the whole file.

A share is read after every other statement (it may come before the sets it names). Checks, each
reported at its word: the set is a declared planetary, the member one it has
(:func:`transgen.model.share_members`), the two sides are different sets, the same kind of gear
(sun with sun, ring with ring, carrier with carrier, pinion with pinion), on the same link (a
pinion: on the same carrier), with equal tooth counts where both are known; no two shares
make two members of one set one gear, or repeat what others already say; and the sets of a shared
pinion also share a gear it meshes in both (so the kinematics of the two statements, which know
nothing of shares, hold the pinion's one speed).
"""
from __future__ import annotations

from typing import Any

from .mech_numbers import _suggest, shorten
from .model import Planetary, Share, Span, share_groups, share_members

_Reporter = _Statement = _Word = Any
"""Here :mod:`transgen.language`'s statement records and reporter, which import this module."""

__all__: list[str] = []


def _kind(member: str) -> str:
    return "pinion" if member.endswith("pinion") else member


def _side(word: _Word, declared: dict, sets: dict[str, Planetary], report: _Reporter) -> tuple[str, str] | None:
    """``(set, member)`` of one ``SET.MEMBER`` word, or ``None`` after reporting why not."""
    name, member = word.text.split(".", 1)
    if name not in sets:
        what = declared.get(name, (None,))[0]
        if what == "planetary":
            return None  # the set has errors of its own, reported at its statement
        if what:
            report.error(word.span, f"'{name}' is a {what}, not a planetary: share names planetary members")
        else:
            known = [n for n, (w, _) in declared.items() if w == "planetary"]
            report.error(word.span, f"unknown planetary '{shorten(name)}'{report.suggest(name, known)}")
        return None
    allowed = share_members(sets[name].pinions)
    if member not in allowed:
        span = Span(word.span.line, word.span.column + len(name) + 1)
        report.error(span, f"planetary {name} has no member '{shorten(member)}'{_suggest(member, allowed)} "
                           f"(members: {', '.join(allowed)})")
        return None
    return name, member


def _check_pair(a: tuple[str, str], b: tuple[str, str], words, sets: dict[str, Planetary],
                report: _Reporter) -> bool:
    """The rules between the two sides of one share (see the module docstring)."""
    (s1, m1), (s2, m2) = a, b
    if s1 == s2:
        report.error(words[1].span, f"share {s1}.{m1} {s2}.{m2}: a set cannot share a gear with itself (its members "
                                    f"are different gears)")
        return False
    if _kind(m1) != _kind(m2):
        report.error(words[1].span, f"share {s1}.{m1} {s2}.{m2}: a {_kind(m1)} and a {_kind(m2)} cannot be one gear")
        return False
    p1, p2 = sets[s1], sets[s2]
    role = "carrier" if _kind(m1) == "pinion" else m1
    l1, l2 = getattr(p1, role), getattr(p2, role)
    if l1 != l2:
        what = "a shared pinion turns on one carrier" if role != m1 else f"a shared {m1} is one link"
        report.error(words[1].span, f"share {s1}.{m1} {s2}.{m2}: {what}, but {s1}.{role} is '{l1}' and "
                                    f"{s2}.{role} is '{l2}'")
        return False
    if m1 in ("sun", "ring"):
        key = "Ns" if m1 == "sun" else "Nr"
        n1, n2 = (getattr(p, "n_" + m1) for p in (p1, p2))
        if n1 is not None and n2 is not None and n1 != n2:
            report.error(words[1].span, f"share {s1}.{m1} {s2}.{m2}: one gear has one tooth count, but {s1} has "
                                        f"{key}={n1} and {s2} has {key}={n2}")
            return False
    return True


def resolve_shares(statements: list[_Statement], declared: dict, planetaries: list[Planetary],
                   report: _Reporter) -> tuple[Share, ...]:
    """The :class:`~transgen.model.Share` of every valid ``share`` statement, in file order."""
    sets = {p.name: p for p in planetaries}
    out: list[Share] = []
    for stmt in statements:
        words = stmt.words
        sides = [_side(w, declared, sets, report) for w in words]
        if None in sides or not _check_pair(sides[0], sides[1], words, sets, report):
            continue
        (s1, m1), (s2, m2) = sides
        share = Share(s1, m1, s2, m2, stmt.span)
        before = next((g for g in share_groups(out) if sides[0] in g and sides[1] in g), None)
        if before is not None:
            line = next(s.span.line for s in out if {(s.set1, s.member1), (s.set2, s.member2)} & set(before))
            report.error(stmt.span, f"{s1}.{m1} and {s2}.{m2} are already one gear (share at line {line})")
            continue
        clash = next((_same_set(g) for g in share_groups(out + [share]) if sides[0] in g and _same_set(g)), None)
        if clash:
            report.error(stmt.span, f"conflicting shares: with this one {clash[0]}.{clash[1]} and {clash[0]}.{clash[2]} "
                                    f"would be one gear")
            continue
        out.append(share)
    for share in list(out):
        if _kind(share.member1) == "pinion" and not _meshes_shared(share, out):
            report.error(share.span, f"share {share.set1}.{share.member1} {share.set2}.{share.member2}: a pinion turns "
                                     f"with the gears it meshes, and {share.set1} and {share.set2} share none of them: "
                                     f"share the sun or ring it meshes in both (one link), or the kinematics miss it")
            out.remove(share)
    return tuple(out)


_MESHES = {"pinion": ("sun", "ring"), "inner_pinion": ("sun",), "outer_pinion": ("ring",)}
"""The gears a pinion meshes."""


def _meshes_shared(share: Share, shares: list[Share]) -> bool:
    """Whether the two sets of a pinion share also share a gear that this pinion meshes in both:
    then the pinion's speed is the same in both statements (with the shared carrier), and the
    kinematics of the two statements hold it."""
    groups = share_groups(shares)
    for gear in set(_MESHES[share.member1]) & set(_MESHES[share.member2]):
        if any((share.set1, gear) in g and (share.set2, gear) in g for g in groups):
            return True
    return False


def _same_set(members: list[tuple[str, str]]) -> tuple[str, str, str] | None:
    """``(set, member, other member)`` when two members of one set are in ``members``."""
    seen: dict[str, str] = {}
    for s, m in members:
        if s in seen and seen[s] != m:
            return s, seen[s], m
        seen[s] = m
    return None
