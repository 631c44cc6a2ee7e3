"""Plain-data (JSON-ready) descriptions of a mechanism and of its modes."""
from __future__ import annotations

from .equations import diagnose_singular, locking_groups
from .graph import bond_graph
from .kinematics import analyze, engaged_combinations
from .model import Mechanism
from .modes import mode_models, neutral_note

__all__ = ["mechanism_to_dict", "modes_report"]


def _capacity(x: float):
    return None if x == float("inf") else x


MECHANISM_UNITS = {"J": "kg*m^2", "static": "N*m", "dynamic": "N*m", "Ns": "1", "Nr": "1",
                   "n1": "1 (by = teeth) or m (by = radius)", "n2": "1 (by = teeth) or m (by = radius)",
                   "ratio": "1", "eta0": "1", "eta": "1", "max_slip_rpm": "rpm", "drag": "N*m*s/rad", "Np1": "1", "Np2": "1",
                   "teeth": "1"}
"""Units of the numeric fields of :func:`mechanism_to_dict` (``static`` None: no limit)."""

MODES_UNITS = {"dof": "1", "kinematic_dof": "1", "combinations": "1", "of": "1", "max_engaged": "1"}
"""Units of the numeric fields of :func:`modes_report` (counts)."""


def mechanism_to_dict(m: Mechanism) -> dict:
    """The parsed model as JSON-ready data (``transgen check --json``)."""
    return {
        "name": m.name,
        "source": m.source,
        "links": [{"name": k.name, "J": k.inertia} for k in m.links],
        "stepped": [
            {"name": sp.name, "carrier": sp.carrier, "Np1": sp.np1, "Np2": sp.np2, "eta0": sp.eta0,
             "members": [{"role": role, "link": link, "teeth": teeth} for role, link, teeth in sp.members]}
            for sp in m.stepped
        ],
        "planetaries": [
            {"name": p.name, "type": "double-pinion" if p.pinions == 2 else "simple", "sun": p.sun, "ring": p.ring,
             "carrier": p.carrier, "Ns": p.n_sun, "Nr": p.n_ring, "eta0": p.eta0}
            for p in m.planetaries
        ],
        "gear_pairs": [
            {"name": g.name, "link1": g.link1, "link2": g.link2, "by": g.by, "n1": g.n1, "n2": g.n2, "mesh": g.mesh, "eta": g.eta}
            for g in m.gear_pairs
        ],
        "elements": [
            {"name": e.name, "kind": e.kind, "links": [e.link1, e.link2], "static": _capacity(e.static),
             "dynamic": e.dynamic, "free": e.free, "brake_type": e.brake_type,
             "max_slip_rpm": e.max_slip_rpm, "drag": e.drag}
            for e in m.elements
        ],
        "input": m.input,
        "output": m.output,
        "torques": [{"name": t.name, "link": t.link, "role": t.role} for t in m.torques],
        "gears": [{"name": g.name, "kind": g.kind, "engaged": list(g.engaged), "ratio": g.ratio,
                   "tol": g.tolerance, "rounding": g.rounding, "alternative": g.alternative} for g in m.gears],
        "modes": [{"name": d.name, "locked": list(d.locked)} for d in m.modes],
        "coordinates": list(m.coordinates),
    }


def modes_report(mech: Mechanism, which: str = "auto") -> dict:
    """Modes with locked elements, DOF, kind and problems, and a static diagnosis of every
    combination: tie-ups, non-unique locked torques, undetermined massless members.

    ``parallel`` (per mode, and ``diagnosis.parallel`` for the mechanism): the elements in
    parallel (same two links) that lock one motion as one constraint — not a problem: the
    motion is unique, the simulator splits their torque by its documented rule."""
    models = mode_models(mech, which)
    g = bond_graph(mech)
    tie_ups, non_unique, massless = [], [], []
    combos = engaged_combinations(mech.element_names)
    for combo in combos:
        if analyze(mech, combo, g).kind == "tie-up":
            tie_ups.append(list(combo))
        problem = diagnose_singular(g, combo)
        if "not unique" in problem:
            non_unique.append(list(combo))
        if "massless" in problem:
            massless.append(list(combo))
    return {
        "mechanism": mech.name,
        "selection": "all combinations" if which == "all" else ("declared" if mech.modes else "default"),
        "modes": [
            {"name": m.name, "gear": m.mode.gear, "locked": list(m.locked), "dof": m.dof, "kinematic_dof": m.kinematic_dof,
             "kind": m.kind, "label": m.mode.label, "problem": m.problem, "idle": list(m.idle),
             "parallel": [list(grp.members) for grp in m.parallel]}
            for m in models
        ],
        "notes": [note for note in [neutral_note(mech) if which != "all" else ""] if note],
        "diagnosis": {"combinations": len(combos), "of": 2 ** len(mech.element_names),
                      "max_engaged": max(map(len, combos), default=0), "tie_ups": tie_ups, "non_unique_torques": non_unique,
                      "undetermined_massless": massless,
                      "parallel": [list(grp.members) for grp in locking_groups(g) if len(grp.members) > 1]},
    }
