"""Idle members: gears whose extra degrees of freedom carry no torque — the one rule every command
uses (``ratios``, ``check``, ``modes``, ``matrices``, ``std``, ``scenario new``, ``synthesize
teeth`` / ``table`` and the simulator).

A combination of engaged shift elements is a *gear* when it fixes the input/output speed ratio
(:func:`transgen.kinematics.analyze`, kind ``"gear"``). Its degrees of freedom beyond the first
are motions with the input held — and so, the ratio being fixed, the output held too. The links
that move in them are the gear's **idle members** (:func:`transgen.kinematics.floating_links`):

* a hub between two elements in series when neither holds it: an A340E-like Simpson set's
  brake B2 holds the outer race of the one-way clutch F1; in 1st and reverse both are open and
  the race floats (``mechanisms/a340e_like.mech``);
* a member that only open elements touch: the hub of the clutches C, D, F of a Ford 10R80 in 1st
  (``mechanisms/idle_hub3.mech`` reproduces it on a Simpson set).

Why they carry no torque: in an idle motion the input and the output do not turn, so the input
and output torques do no work on it; only the inertia of the idle members and the torques of the
open elements on them (drag; zero for an element released in transgen's element model) act.
The gear's ratio, its static element torques per unit input torque and its output-referred
inertia are those of its one torque-carrying motion.

Such a gear can be modelled — it is a gear for every command — when its equations have a unique
solution (:func:`transgen.equations.diagnose_singular`): every idle motion moves some inertia (a
massless idle hub has an undetermined speed) and the locked torques are unique. Its state space
has one coordinate per idle motion (the idle member's own speed) besides the gear's.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from .equations import complete_locked, diagnose_singular
from .graph import TRANSFORMER_KINDS, bond_graph, transformer_ports
from .kinematics import analyze, floating_links, numeric_rank
from .model import Mechanism

if TYPE_CHECKING:
    from .graph import Graph

__all__ = ["GearCheck", "gear_check", "holds_only_idle", "idle_hubs", "idle_members", "is_gear", "idle_text",
           "idle_pins"]


@dataclass(frozen=True)
class GearCheck:
    """What the one rule decides about a combination of engaged elements.

    ``kind``, ``dof``, ``ratio``: the kinematics (:func:`~transgen.kinematics.analyze`);
    ``idle``: the idle members (links) when it fixes the ratio, else ``()``; ``problem``: why a
    combination that fixes the ratio cannot be modelled (``""`` when it can, or when it fixes no
    ratio)."""

    engaged: tuple[str, ...]
    kind: str
    dof: int
    ratio: float | None
    idle: tuple[str, ...] = ()
    problem: str = ""
    hubs: tuple[str, ...] = ()
    """The idle members no gearset touches: bare hubs between open elements (a hub between
    elements in series, the hub of clutches only open elements touch), as opposed to members of a
    gearset that floats as a whole."""

    @property
    def is_gear(self) -> bool:
        """A usable gear: the ratio is fixed and the equations solve (idle members or not)."""
        return self.kind == "gear" and not self.problem

    @property
    def has_idle(self) -> bool:
        """A usable gear with idle members (more than one degree of freedom)."""
        return self.is_gear and bool(self.idle)

    @property
    def idle_dof(self) -> int:
        """Degrees of freedom of the idle members (``dof - 1`` in a gear, else 0)."""
        return self.dof - 1 if self.kind == "gear" else 0

    def text(self) -> str:
        """``"2 DOF: 1 + 1 idle (H)"`` in a gear with idle members, ``"1 DOF"`` else (``idle_text``)."""
        return idle_text(self.dof, self.idle if self.kind == "gear" else ())


def gear_check(mech: Mechanism, engaged, graph: Graph | None = None) -> GearCheck:
    """The rule applied to ``engaged`` (one-way clutches beside engaged elements completed, as
    in the modes: :func:`~transgen.equations.complete_locked`)."""
    g = bond_graph(mech) if graph is None else graph
    engaged = tuple(engaged)
    combo = analyze(mech, engaged, g)
    if combo.kind != "gear":
        return GearCheck(engaged, combo.kind, combo.dof, combo.ratio)
    problem = diagnose_singular(g, complete_locked(g, engaged))
    geared = {link for node, data in g.nodes(data=True) if data["kind"] in TRANSFORMER_KINDS
              for link, _, _ in transformer_ports(g, node)}
    hubs = tuple(x for x in combo.floating if x not in geared)
    return GearCheck(engaged, combo.kind, combo.dof, combo.ratio, combo.floating, problem, hubs)


def holds_only_idle(full: GearCheck, without: GearCheck) -> bool:
    """Whether an element of the gear ``full`` is superfluous: ``without`` (the same elements but
    that one) is still a gear and the element only repeats another's constraint (no new motion)
    or only holds idle hubs (every link it would free is a bare hub, :attr:`GearCheck.hubs`). A
    gearset that would float as a whole is not an idle hub: holding it is a designer's choice
    (the 722.6 keeps K1 in 3rd), so that element counts as needed."""
    if without.kind != "gear" or not full.is_gear:
        return False
    freed = set(without.idle) - set(full.idle)
    return freed <= set(without.hubs)


def idle_hubs(mech: Mechanism, engaged, graph: Graph | None = None) -> tuple[tuple[str, tuple[str, ...]], ...]:
    """The idle hubs of the gear ``engaged`` (``()`` when it is no usable gear), each with the
    links on the other side of the elements that touch it (``"housing"`` for a brake): the
    speeds an open element's torque pulls the hub toward (the simulator's ``idle_speed``
    invariant, :mod:`transgen.sim.solve.monitor`)."""
    check = gear_check(mech, engaged, graph)
    out = []
    for hub in (check.hubs if check.is_gear else ()):
        others = tuple(e.link2 if e.link1 == hub else e.link1 for e in mech.elements if hub in (e.link1, e.link2))
        out.append((hub, others))
    return tuple(out)


def idle_members(mech: Mechanism, engaged, graph: Graph | None = None) -> tuple[str, ...]:
    """The idle members of the gear ``engaged`` (``()`` when it has none or fixes no ratio)."""
    return gear_check(mech, engaged, graph).idle


def is_gear(mech: Mechanism, engaged, graph: Graph | None = None) -> bool:
    """Whether ``engaged`` is a usable gear (:attr:`GearCheck.is_gear`)."""
    return gear_check(mech, engaged, graph).is_gear


def idle_text(dof: int, idle) -> str:
    """How every command states a gear's degrees of freedom: ``"1 DOF"``, or with idle members
    ``"2 DOF: 1 + 1 idle (H)"``."""
    if not idle:
        return f"{dof} DOF"
    return f"{dof} DOF: 1 + {dof - 1} idle ({', '.join(idle)})"


def idle_pins(a: np.ndarray, i_in: int, i_out: int) -> tuple[int, ...]:
    """Idle links whose speeds, set to zero, fix the idle motions of the constraint matrix ``a``
    (columns: links; ``i_in``, ``i_out``: input and output columns) without touching the ratio:
    greedily, the idle links whose unit row adds to the rank. ``()`` when the output is not fixed
    by the input (no gear) or nothing idles. For ratio solves that need one degree of freedom
    (:mod:`transgen.synthesis.kinematic` with unknown teeth)."""
    floating = floating_links(a, i_in)
    if i_out in floating or not floating:
        return ()
    n = a.shape[1]
    rows, pins = a, []
    target = n - 1  # one degree of freedom left: the input's
    for k in floating:
        if numeric_rank(rows) >= target:
            break
        trial = np.vstack([rows, np.eye(n)[k]])
        if numeric_rank(trial) > numeric_rank(rows):
            rows, pins = trial, pins + [k]
    return tuple(pins)

