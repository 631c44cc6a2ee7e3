"""A gearbox that models its own torque converter: the one rule every command uses.

A ``.mech`` *has its own converter* (``mechanisms/ht740_tc.mech``) when

* a friction clutch (the **lock-up**) joins the input link (the **pump**: crank, flywheel and
  impeller as one rigid link) to another link (the **turbine**),
* the pump touches nothing else (no planetary, gear pair or other element),
* the lock-up is engaged in every forward gear (declared gears with a positive ratio: the
  published ratios are the mechanical ones, with the converter locked), and
* a named torque (``torque Tp E``) acts on the pump and one (``torque Tt L1``) on the turbine:
  the simulator's converter sets them from the two links' speeds
  (:func:`transgen.sim.model.powertrain.converter_component`).

Then the turbine is the gearbox input: with the lock-up open the converter drives it, the pump's
inertia is the engine's (the scenario adds none), the shifts synchronise the turbine side, and the
lock-up is no shift element (:func:`transgen.sim.control.schedule.gear_swap` leaves it out).
``docs/guide/own_converter.md`` explains how to write such a file.
"""
from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

from .model import HOUSING, Mechanism

__all__ = ["OwnConverter", "own_converter", "lockup_clutches", "converter_drive"]


@dataclass(frozen=True)
class OwnConverter:
    """The converter a mechanism models: ``pump`` and ``turbine`` links, the ``lockup`` clutch
    between them, the named torques ``pump_torque`` (on the pump) and ``turbine_torque`` (on
    the turbine)."""

    pump: str
    turbine: str
    lockup: str
    pump_torque: str
    turbine_torque: str


def lockup_clutches(mech: Mechanism, pump: str, turbine: str) -> tuple[str, ...]:
    """Names of the friction clutches that join the links ``pump`` and ``turbine``."""
    return tuple(e.name for e in mech.elements if e.kind == "clutch" and {e.link1, e.link2} == {pump, turbine})


def _touches(mech: Mechanism, link: str) -> list[str]:
    """Names of the parts (planetaries, gear pairs, elements) that connect to ``link``."""
    out = [p.name for p in mech.planetaries if link in (p.sun, p.ring, p.carrier)]
    out += [s.name for s in mech.stepped if link == s.carrier or any(m[1] == link for m in s.members)]
    out += [g.name for g in mech.gear_pairs if link in (g.link1, g.link2)]
    out += [e.name for e in mech.elements if link in (e.link1, e.link2)]
    return out


def own_converter(mech: Mechanism) -> OwnConverter | None:
    """The converter ``mech`` models (module docstring), or None when it has none."""
    return _own_converter(mech)


@lru_cache(maxsize=32)  # the model is immutable; the gear checks cost some 0.1 s a mechanism
def _own_converter(mech: Mechanism) -> OwnConverter | None:
    pump = mech.input
    if not pump or pump == HOUSING:
        return None
    parts = _touches(mech, pump)
    if len(parts) != 1:
        return None
    lockup = next((e for e in mech.elements if e.name == parts[0] and e.kind == "clutch"), None)
    if lockup is None:
        return None
    turbine = lockup.link2 if lockup.link1 == pump else lockup.link1
    if turbine == HOUSING:
        return None
    named = {t.link: t.name for t in reversed(mech.loads) if t.role == "load"}
    if pump not in named or turbine not in named:
        return None
    forward = _forward_gears(mech)
    if not forward or any(lockup.name not in g.engaged for g in forward):
        return None
    return OwnConverter(pump, turbine, lockup.name, named[pump], named[turbine])


def _forward_gears(mech: Mechanism):
    """The declared gears (not neutral) whose ratio is fixed and positive."""
    from .idle import gear_check

    out = []
    for gear in mech.gears:
        if gear.kind != "gear":
            continue
        check = gear_check(mech, gear.engaged)
        if check.is_gear and check.ratio is not None and check.ratio > 0:
            out.append(gear)
    return out


def converter_drive(engaged, oc: OwnConverter | None) -> tuple[str, ...]:
    """The elements of a gear ``engaged`` in converter drive: without the lock-up (unchanged
    when ``oc`` is None)."""
    return tuple(e for e in engaged if oc is None or e != oc.lockup)
