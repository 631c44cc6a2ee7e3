"""Static torques of a gear under drive, and the check of the one-way clutches a gear engages.

Under *drive* the input torque is positive and the output is loaded so that the mechanism does
not accelerate: ``T_out = ratio * T_in`` (static balance, power in = power out). With every
acceleration zero the inertias drop out (a massless balance): the rows of the mode's equations
``E z + F u = 0`` (:func:`transgen.equations.assemble`) that remain are the link torque balances
and the transformers' power relations, linear in the locked elements' and the transformer ports'
torques, which they determine when the gear's locked torques are unique
(:func:`transgen.equations.diagnose_singular`). Open elements transmit nothing.

A locked one-way clutch transmits torque only against its free direction (``free=positive``:
``t <= 0``, the sign convention of :mod:`transgen.model`). :func:`check_oneways` reports a gear in
which a one-way clutch would have to hold torque in its free direction under drive: it would
overrun instead, so the gear as declared cannot carry drive torque — typically a flipped ``free=``.
"""
from __future__ import annotations

from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from .graph import Graph

import numpy as np

from .equations import assemble, complete_locked, locked_constraints
from .errors import Diagnostic
from .graph import bond_graph
from .idle import gear_check
from .model import Mechanism

__all__ = ["drive_torques", "check_oneways"]

_TOL = 1e-9


def drive_torques(mech: Mechanism, engaged, graph: Graph | None = None) -> dict[str, float] | None:
    """Torque of each locked constraint of the gear ``engaged`` per unit input torque under drive
    [N*m per N*m], keyed by the group label (``"OWC"``, ``"BLR+OWC"``: elements in parallel share
    one torque, in the first member's direction), from ``link1`` to ``link2``.

    ``None`` when the combination is not a usable gear (:func:`transgen.idle.gear_check`: no
    determined ratio, or locked torques that are not unique; ``transgen check`` and ``modes`` say
    why). A gear with idle members is a gear: nothing acts on its idle members under drive.
    """
    g = bond_graph(mech) if graph is None else graph
    combo = gear_check(mech, engaged, g)
    if not combo.is_gear or combo.ratio is None:
        return None
    locked = complete_locked(g, engaged)
    eq = assemble(g, locked)
    E, F, nl = np.asarray(eq.E, float), np.asarray(eq.F, float), eq.n_links
    rows = [i for i in range(E.shape[0]) if np.any(E[i, nl:] != 0) or np.any(F[i] != 0)]
    u = np.zeros(len(eq.u))
    u[eq.u.index("T_in")] = 1.0
    u[eq.u.index("T_out")] = combo.ratio
    a, b = E[np.ix_(rows, range(nl, E.shape[1]))], -F[rows] @ u
    x, *_ = np.linalg.lstsq(a, b, rcond=None)
    if np.linalg.norm(a @ x - b) > 1e-7 * max(1.0, np.linalg.norm(b)):  # pragma: no cover - balance by construction
        return None
    return {grp.label: float(x[k]) for k, grp in enumerate(eq.groups)}


def check_oneways(mech: Mechanism) -> list[Diagnostic]:
    """Errors, each at the one-way clutch's declaration, for the declared gears in which a
    one-way clutch (alone or with other one-way clutches in parallel, no friction element beside
    it) would have to hold torque in its free direction under drive."""
    g = bond_graph(mech)
    kinds = {e.name: e for e in mech.elements}
    problems: list[Diagnostic] = []
    reported: set[str] = set()
    for gear in mech.gears:
        if gear.kind != "gear" or not any(kinds[e].kind == "oneway" for e in complete_locked(g, gear.engaged)):
            continue
        torques = drive_torques(mech, gear.engaged, g)
        if torques is None:
            continue
        for grp in locked_constraints(g, complete_locked(g, gear.engaged)):
            if not all(kinds[e].kind == "oneway" for e in grp.members):
                continue  # a friction element beside it holds either way
            for member, sign in zip(grp.members, grp.signs):
                e = kinds[member]
                t = sign * torques[grp.label]
                wrong = t > _TOL if e.free == "positive" else t < -_TOL
                if wrong and e.name not in reported:
                    reported.add(e.name)
                    holds = "t <= 0" if e.free == "positive" else "t >= 0"
                    problems.append(Diagnostic(
                        mech.source, e.span.line, e.span.column,
                        f"one-way clutch {e.name} (free={e.free}, holds {holds} from {e.link1} to {e.link2}) would have "
                        f"to transmit t = {t:+.4g} N*m per N*m of input torque under drive in gear {gear.name} "
                        f"(line {gear.span.line}): it would overrun, so the gear cannot carry drive torque; "
                        f"is free= flipped?", mech.source_line(e.span.line)))
    return problems
