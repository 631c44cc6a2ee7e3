"""The named parameters of a mechanism: ``NAME.PARAM`` for every parameter of its statements.

A link's inertia is ``L1.J``, a planetary's tooth counts ``P2.Ns`` and ``P2.Nr``, a gear pair's
``G1.N1`` (or ``G1.r1`` when it is given by radii), a clutch's or brake's capacities ``C4.static``
and ``C4.dynamic``; the parameter names are those of the ``.mech`` language (its table of
statement parameters). :func:`with_parameter` gives a new :class:`~transgen.model.Mechanism` with
one parameter changed, checked as a file's value is (type and range) and then the whole mechanism
as loading checks it (e.g. ``Nr > Ns``, ``dynamic <= static``).
"""
from __future__ import annotations

import difflib
from dataclasses import replace

from .errors import MechError
from .language import _PARAMS, format_mechanism, parse_mechanism, read_number
from .model import GearPair, Mechanism, SteppedPlanetary

__all__ = ["mechanism_parameters", "with_parameter", "ParameterError"]

# .mech parameter -> field of the model object, per statement keyword (the names are _PARAMS')
_FIELDS = {"J": "inertia", "Ns": "n_sun", "Nr": "n_ring", "pinions": "pinions", "N1": "n1", "N2": "n2", "r1": "n1",
           "r2": "n2", "mesh": "mesh", "static": "static", "dynamic": "dynamic", "type": "brake_type", "free": "free"}
POWER_FLOW_ONLY = frozenset({"eta0", "eta", "max_slip_rpm"})
"""Parameters that only ``transgen powerflow`` reads (the simulator has no mesh losses or slip
limits): not settable here, so that a study cannot vary something without effect."""
NOT_STUDIED = frozenset({"drag"})
"""Parameters a study does not vary: an element's ``drag=`` (the loss models', :mod:`transgen.losses`)."""


class ParameterError(ValueError):
    """A mechanism parameter that does not exist or a value it cannot take (message without a location)."""


def _statements(m: Mechanism):
    """``(name, keyword, object)`` of every statement with parameters."""
    for link in m.links:
        yield link.name, "link", link
    for p in m.planetaries:
        yield p.name, "planetary", p
    for g in m.gear_pairs:
        yield g.name, "gears", g
    for sp in m.stepped:
        yield sp.name, "stepped", sp
    for e in m.elements:
        yield e.name, e.kind, e


def _params(keyword: str, obj) -> dict:
    """The settable parameters of a statement: its keyword's numbers and words (not link names),
    a gear pair's sizes as it gives them (teeth or radii)."""
    allowed = {k: v for k, v in _PARAMS[keyword].items() if v != "name" and k not in POWER_FLOW_ONLY | NOT_STUDIED}
    if isinstance(obj, GearPair):
        drop = ("r1", "r2") if obj.by == "teeth" else ("N1", "N2")
        allowed = {k: v for k, v in allowed.items() if k not in drop}
    if isinstance(obj, SteppedPlanetary):  # the teeth of its gears and pinion steps that it has
        allowed = {k: v for k, v in allowed.items() if _get(obj, k) is not None}
    return allowed


def _teeth_key(role: str) -> str:
    return ("Ns" if role.startswith("sun") else "Nr") + role[-1]


def _get(obj, key: str):
    """The value of parameter ``key`` of a statement object (``None``: the statement has none)."""
    if isinstance(obj, SteppedPlanetary):
        if key in ("Np1", "Np2"):
            return obj.np1 if key == "Np1" else obj.np2
        return next((t for role, _, t in obj.members if _teeth_key(role) == key), None)
    return getattr(obj, _FIELDS[key])


def _set(obj, key: str, value):
    """``obj`` with parameter ``key`` set to ``value``."""
    if isinstance(obj, SteppedPlanetary):
        if key in ("Np1", "Np2"):
            return replace(obj, **{key.lower(): value})
        return replace(obj, members=tuple((r, link, value if _teeth_key(r) == key else t) for r, link, t in obj.members))
    return replace(obj, **{_FIELDS[key]: value})


def mechanism_parameters(m: Mechanism) -> dict[str, object]:
    """``"NAME.PARAM"`` -> current value of every parameter of ``m`` (SI units); ``None`` where the
    file leaves it to its default (a dog's unlimited ``static``)."""
    out = {}
    for name, keyword, obj in _statements(m):
        for key in _params(keyword, obj):
            value = _get(obj, key)
            out[f"{name}.{key}"] = None if value == float("inf") else value
    return out


def with_parameter(m: Mechanism, name: str, key: str, value) -> Mechanism:
    """``m`` with parameter ``key`` of the statement ``name`` set to ``value``.

    Raises
    ------
    ParameterError
        For an unknown statement or parameter (with the closest known one), a value of the wrong
        type or out of range, or a mechanism that the change makes invalid.
    """
    found = {n: (kw, obj) for n, kw, obj in _statements(m)}
    if name not in found:
        close = _closest(name, found)
        raise ParameterError(f"no link, planetary, gear pair or shift element '{name}' in the mechanism"
                             + (f"; did you mean '{close[0]}'?" if close else f" (names: {', '.join(found)})"))
    keyword, obj = found[name]
    allowed = _params(keyword, obj)
    if key in POWER_FLOW_ONLY and key in _PARAMS[keyword]:
        raise ParameterError(f"{keyword} {name}: {key} is read by 'transgen powerflow' only (the simulator has no "
                             f"mesh losses or slip limits); write it in the .mech file")
    if key not in allowed:
        close = _closest(key, allowed)
        raise ParameterError(f"{keyword} {name} has no parameter '{key}'" + (f"; did you mean '{close[0]}'?" if close else "")
                             + f" (parameters: {', '.join(allowed) or 'none'})")
    kind = allowed[key]
    if isinstance(kind, tuple):  # a word
        word = str(value) if isinstance(value, (str, int)) and not isinstance(value, bool) else None
        if word not in kind:
            raise ParameterError(f"{key} must be one of {', '.join(kind)}, not {value!r}")
        new = int(word) if key == "pinions" else word
    else:
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise ParameterError(f"{key} must be a number, not {value!r}")
        number = read_number(repr(value) if isinstance(value, float) else str(value), key, kind)
        if isinstance(number, str):
            raise ParameterError(number)
        new = float(number) if isinstance(_get(obj, key), float) else number
    changed = _replace(m, obj, _set(obj, key, new))
    try:
        parse_mechanism(format_mechanism(changed), m.source)
    except MechError as exc:
        raise ParameterError("; ".join(d.message for d in exc.diagnostics)) from None
    return changed


def _closest(name: str, known) -> list[str]:
    """The known name closest to ``name`` (case aside first), as a list of at most one."""
    same_case = [k for k in known if k.lower() == name.lower()]
    return same_case[:1] or difflib.get_close_matches(name, list(known), n=1, cutoff=0.5)


def _replace(m: Mechanism, old, new) -> Mechanism:
    """``m`` with the statement object ``old`` replaced by ``new``."""
    for field in ("links", "planetaries", "gear_pairs", "elements", "stepped"):
        items = getattr(m, field)
        if any(x is old for x in items):
            return replace(m, **{field: tuple(new if x is old else x for x in items)})
    raise AssertionError("statement not in the mechanism")
