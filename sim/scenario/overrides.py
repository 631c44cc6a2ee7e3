"""Dotted keys for every scenario value: ``--set KEY=VALUE`` overrides and the settable keys.

A key names a value of the scenario file after its includes are merged: ``driveline.vehicle_mass``,
``elements.C4.apply`` (a whole signal) or ``elements.C4.apply.t1`` (one of its keys),
``shifts.events.0.t`` (an entry of an array of tables, counted from 0), ``elements.C4.apply.t.2``
(an entry of a list), ``initial.speeds_rpm.E``;
keys starting with ``mech.`` name a parameter of the mechanism (``mech.L1.J``, ``mech.C4.static``,
``mech.P2.Nr``, see :mod:`transgen.parameters`). The keys a scenario accepts are those of
:mod:`.scenario.schema` (the readers' own tables), with the mechanism's element and link names.

An override is set in the merged data before the scenario is built, so every check of
:mod:`.scenario.load` applies to it; errors about it read ``--set KEY: error: ...``. Values are TOML
values (``20000``, ``"turbodiesel"``, ``{ type = "ramp", ... }``, ``[1, 2]``); a bare word that is
not TOML is a string. NaN and infinity are refused.
"""
from __future__ import annotations

import copy
import difflib
import json
import re
import tomllib
from collections.abc import Mapping

from transgen.errors import ScenarioError

from .file import Source, bounded, non_finite, shown
from .schema import ANY as _ANY
from .schema import LEAF, SIGNAL, SIGNAL_KEYS, key_tree

__all__ = ["parse_override", "parse_value", "toml_value", "split_key", "apply_overrides", "check_keys", "mech_overrides",
           "settable_keys", "MECH_PREFIX"]

MECH_PREFIX = "mech"
_PART = re.compile(r"[A-Za-z0-9_-]+")
_SIGNAL_SUBKEYS = {"type"}.union(*SIGNAL_KEYS.values())


def _error(key: str, message: str) -> ScenarioError:
    return ScenarioError(f"--set {key}: error: {message}")


def split_key(key: str) -> tuple:
    """The parts of a dotted key; whole-number parts are array indices (ints)."""
    parts = key.split(".")
    if not key or not all(_PART.fullmatch(p) for p in parts):
        raise _error(key, "a key is names joined by dots, such as driveline.vehicle_mass or elements.C4.apply")
    return tuple(int(p) if p.isdigit() else p for p in parts)


def parse_value(text: str, key: str = "?"):
    """The TOML value of ``text``; a bare word that is not TOML is a string. NaN and infinity
    are refused."""
    stripped = text.strip()
    if not stripped:
        raise _error(key, "no value after '=' (give a TOML value, e.g. 20000, \"text\", [1, 2])")
    try:
        doc = tomllib.loads(f"v = {stripped}")
        if set(doc) != {"v"}:
            raise tomllib.TOMLDecodeError("one value expected")
        value = doc["v"]
    except tomllib.TOMLDecodeError as exc:
        if stripped[0] in "[{\"'" or "\n" in stripped:
            raise _error(key, f"{shown(stripped)} is not a TOML value ({re.sub(r' [(]at line.*', '', str(exc))})") from None
        value = stripped
    return _plain(value, key)


def parse_override(text: str) -> tuple[str, object]:
    """``(key, value)`` of ``KEY=VALUE`` (the value a TOML value, see :func:`parse_value`).

    Raises
    ------
    ScenarioError
        If there is no ``=``, the key is not a dotted key, or the value is malformed or not finite.
    """
    key, eq, value = text.partition("=")
    key = key.strip()
    if not eq or not key:
        raise ScenarioError(f"--set {bounded(text.strip(), 200)}: error: expected KEY=VALUE, e.g. driveline.vehicle_mass=20000")
    split_key(key)
    return key, parse_value(value, key)


def toml_value(value) -> str:
    """``value`` (plain TOML data) written as a TOML value, as ``--set`` reads it back."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, (int, float)):
        return repr(value)
    if isinstance(value, str):
        return json.dumps(value, ensure_ascii=False)  # a TOML basic string
    if isinstance(value, dict):
        return "{ " + ", ".join(f"{_toml_key(k)} = {toml_value(v)}" for k, v in value.items()) + " }" if value else "{}"
    return "[" + ", ".join(toml_value(v) for v in value) + "]"


def _toml_key(key: str) -> str:
    return key if _PART.fullmatch(key) else json.dumps(key)


def _plain(value, key: str):
    """``value`` as plain TOML data (dicts, lists, str, bool, int, float; numpy scalars become
    Python numbers), NaN and infinity refused."""
    if hasattr(value, "item") and not isinstance(value, (list, dict, str)):
        value = value.item()  # a numpy scalar
    if isinstance(value, (bool, int, str)):
        out = value
    elif isinstance(value, float):
        out = float(value)
    elif isinstance(value, Mapping):  # its entries are checked (the first bad one named) as they are converted
        return {str(k): _plain(v, key) for k, v in value.items()}
    elif isinstance(value, (list, tuple)):
        return [_plain(v, key) for v in value]
    else:
        raise _error(key, f"{shown(value)} is not a TOML value (a number, string, boolean, list or table)")
    bad = non_finite(out)
    if bad is not None:
        raise _error(key, f"{shown(value)} is not a finite number (NaN and infinity are refused)")
    return out


def _split(overrides: Mapping[str, object] | None) -> tuple[dict, dict]:
    """(scenario overrides, mechanism overrides): key parts -> (dotted key, plain value)."""
    data, mech = {}, {}
    for key, value in (overrides or {}).items():
        parts = split_key(str(key))
        target = mech if parts[0] == MECH_PREFIX else data
        target[parts] = (str(key), _plain(value, str(key)))
    return data, mech


def apply_overrides(data: dict, source: Source, overrides: Mapping[str, object] | None) -> None:
    """Set the scenario (not ``mech.``) overrides in the merged ``data``, checked against the
    scenario keys (names of the mechanism not yet: see :func:`check_keys`), and record them in
    ``source`` so that errors about them name the override."""
    scenario, _ = _split(overrides)
    if not scenario:
        return
    tree = key_tree(None, None)
    for parts, (key, value) in scenario.items():
        _check(parts, key, tree, data)
        node = data
        for i, part in enumerate(parts[:-1]):
            child = node[part] if isinstance(node, list) else node.get(part)
            if child is None:
                child = node[part] = {}
                source.created.add(parts[:i + 1])
            elif not isinstance(child, (dict, list)):
                raise _error(key, f"'{'.'.join(map(str, parts[:i + 1]))}' is {shown(child)}, not a table: "
                                  f"set it as a whole")
            node = child
        node[parts[-1]] = copy.deepcopy(value)
        source.overrides[parts] = key


def check_keys(overrides: Mapping[str, object] | None, data: dict, mech) -> None:
    """Check the overrides' keys against the keys the scenario accepts with the mechanism's
    element and link names (unknown keys: with the closest known key)."""
    scenario, _ = _split(overrides)
    if not scenario:
        return  # the key tree imports every model (the turbodiesel's keys are its parameters' fields)
    tree = key_tree(mech.element_names, mech.link_names)
    for parts, (key, _value) in scenario.items():
        _check(parts, key, tree, data, mech)


def mech_overrides(mech, overrides: Mapping[str, object] | None):
    """``mech`` with the ``mech.NAME.PARAM`` overrides set (each checked, see
    :func:`transgen.parameters.with_parameter`)."""
    _, params = _split(overrides)
    if not params:
        return mech
    from transgen.parameters import ParameterError, with_parameter

    for parts, (key, value) in params.items():
        if len(parts) != 3 or not all(isinstance(p, str) for p in parts):
            raise _error(key, "a mechanism parameter is mech.NAME.PARAM, e.g. mech.L1.J or mech.C4.static")
        try:
            mech = with_parameter(mech, parts[1], parts[2], value)
        except ParameterError as exc:
            raise _error(key, str(exc)) from None
    return mech


def _check(parts: tuple, key: str, tree, data, mech=None) -> None:
    node, value = tree, data
    for i, part in enumerate(parts):
        where = ".".join(map(str, parts[:i])) or "top level"
        if isinstance(node, list):
            size = len(value) if isinstance(value, list) else 0
            if not isinstance(part, int) or part >= size:
                raise _error(key, f"'{where}' is an array of tables with {size} entries: give an index "
                                  f"0..{size - 1} after '{where}.'" if size else f"'{where}' has no entries to set")
            node, value = node[0], value[part]
            continue
        if node is SIGNAL:
            if part not in _SIGNAL_SUBKEYS:
                raise _error(key, f"unknown key '{part}' of the signal '{where}'{_hint(key, settable_keys(data, mech))}")
            node, value = LEAF, value.get(part) if isinstance(value, dict) else None
            continue
        if node is LEAF:
            if isinstance(value, list) and isinstance(part, int) and part < len(value):  # an entry of a list
                value = value[part]
                continue
            if isinstance(value, list):
                raise _error(key, f"'{where}' is a list of {len(value)} entries: give an index 0..{len(value) - 1}")
            raise _error(key, f"'{where}' is a value, not a table")
        sub = node.get(part, node.get(_ANY, _MISSING)) if isinstance(part, str) else _MISSING
        if sub is _MISSING:
            raise _error(key, f"unknown key '{part}' in [{where}]{_hint(key, settable_keys(data, mech))}")
        node = sub
        value = value.get(part) if isinstance(value, dict) else None


_MISSING = object()


def _hint(key: str, known) -> str:
    known = list(known)
    close = difflib.get_close_matches(key, known, n=1, cutoff=0.6)
    if not close:  # a key without its table: driveline.vehicle_mass for vehicle_mass
        last = key.rsplit(".", 1)[-1]
        close = [k for k in known if k.rsplit(".", 1)[-1] == last][:1]
    return f"; did you mean '{close[0]}'?" if close else ""


def settable_keys(data: dict, mech=None) -> dict[str, object]:
    """Every dotted key the scenario ``data`` accepts -> its value in ``data`` (None where the
    file does not set it and the default applies; a turbodiesel's engine, shaft and port
    parameters show their defaults). Signals are one key each (their keys are
    settable too); with ``mech``, the mechanism's parameters (``mech.NAME.PARAM``) follow."""
    tree = key_tree(mech.element_names, mech.link_names) if mech is not None else key_tree(None, None)
    out: dict[str, object] = {}

    def walk(node, value, name):
        if isinstance(node, dict) and isinstance(value, (dict, type(None))):
            names = dict(node)
            if _ANY in names:
                sub = names.pop(_ANY)
                names.update({k: sub for k in (value or {})})
            for k, sub in names.items():
                walk(sub, value.get(k) if value else None, f"{name}.{k}" if name else k)
        elif isinstance(node, list):
            for i, entry in enumerate(value if isinstance(value, list) else []):
                walk(node[0], entry, f"{name}.{i}")
        else:
            out[name] = value

    walk(tree, data, "")
    inp = data.get("input")
    if isinstance(inp, dict) and inp.get("type") == "turbodiesel":
        from ..model.turbodiesel import turbodiesel_defaults

        for key, value in turbodiesel_defaults().items():
            if out.get(f"input.{key}", 0) is None and (inp.get("turbo") == "iterative" or not key.startswith(("ports.", "turbo_solver."))):
                out[f"input.{key}"] = value
    if mech is not None:
        from transgen.parameters import mechanism_parameters

        out.update({f"{MECH_PREFIX}.{k}": v for k, v in mechanism_parameters(mech).items()})
    return out
