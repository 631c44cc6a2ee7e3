"""Writing a :class:`~transgen.model.Mechanism` back as ``.mech`` text, in canonical form: the
text parses (:func:`transgen.language.parse_mechanism`) to an equal mechanism."""
from __future__ import annotations

import math
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from .model import Mechanism

__all__ = ["format_mechanism", "ALTERNATIVE"]

ALTERNATIVE = "alternative"
"""The word that marks a gear row as an alternative of its gear (``gear L = K1 B3 alternative``)."""


def _number(x: float) -> str:
    return repr(float(x))  # shortest text that reads back as the same float


def _optional(key: str, value: float | None) -> str:
    """`` key=value`` for an optional number that is given, else ``""``."""
    return "" if value is None else f" {key}={_number(value)}"


def _teeth_text(n: int | None, bounds: tuple[int, int] | None) -> str:
    return str(n) if n is not None else ("?" if bounds is None else f"{bounds[0]}..{bounds[1]}")


def format_mechanism(m: Mechanism) -> str:
    """Write a mechanism back as ``.mech`` text (canonical form; parses to an equal mechanism)."""
    out = [f'transmission "{m.name}"']
    out += [f"link {k.name} J={_number(k.inertia)}" for k in m.links]
    for p in m.planetaries:
        pin = " pinions=2" if p.pinions == 2 else ""
        ns, nr = (_teeth_text(n, b) for n, b in ((p.n_sun, p.sun_bounds), (p.n_ring, p.ring_bounds)))
        out.append(f"planetary {p.name} sun={p.sun} ring={p.ring} carrier={p.carrier} Ns={ns} Nr={nr}{pin}"
                   + _optional("eta0", p.eta0))
    out += [f"share {s.set1}.{s.member1} {s.set2}.{s.member2}" for s in m.shares]
    for sp in m.stepped:
        members = " ".join(f"{role}={link} {'Ns' if role.startswith('sun') else 'Nr'}{role[-1]}={teeth}"
                           for role, link, teeth in sp.members)
        steps = "".join(f" Np{k}={n}" for k, n in (("1", sp.np1), ("2", sp.np2)) if n is not None)
        out.append(f"stepped {sp.name} carrier={sp.carrier} {members}{steps}" + _optional("eta0", sp.eta0))
    for g in m.gear_pairs:
        k1, k2 = ("N1", "N2") if g.by == "teeth" else ("r1", "r2")
        v1, v2 = (int(g.n1), int(g.n2)) if g.by == "teeth" else (_number(g.n1), _number(g.n2))
        out.append(f"gears {g.name} {g.link1} {g.link2} {k1}={v1} {k2}={v2} mesh={g.mesh}" + _optional("eta", g.eta))
    for e in m.elements:
        slip = _optional("max_slip_rpm", e.max_slip_rpm) + _optional("drag", e.drag)
        if e.kind == "clutch":
            out.append(f"clutch {e.name} {e.link1} {e.link2} static={_number(e.static)} dynamic={_number(e.dynamic)}{slip}")
        elif e.kind == "brake":
            typ = f" type={e.brake_type}" if e.brake_type else ""
            out.append(f"brake {e.name} {e.link1} static={_number(e.static)} dynamic={_number(e.dynamic)}{typ}{slip}")
        elif e.kind == "dog":
            static = f" static={_number(e.static)}" if math.isfinite(e.static) else ""
            out.append(f"dog {e.name} {e.link1} {e.link2}{static}{slip}")
        else:
            out.append(f"oneway {e.name} {e.link1} {e.link2} free={e.free}{slip}")
    out += [f"input {m.input}", f"output {m.output}"]
    out += [f"torque {t.name} {t.link}" for t in m.loads]
    for g in m.gears:
        ratio = f" ratio={g.ratio}" if g.ratio is not None else ""
        ratio += f" tol={g.tolerance}" if g.tolerance is not None else ""
        ratio += " rounding=truncated" if g.rounding == "truncated" else ""
        ratio += f" {ALTERNATIVE}" if g.alternative else ""
        out.append(f"{g.kind} {g.name} = {' '.join(g.engaged)}{ratio}")
    for d in m.modes:
        out.append(f"mode {d.name} = {' '.join(d.locked) or 'none'}")
    if m.coordinates:
        out.append("coordinates " + " ".join(m.coordinates))
    return "\n".join(out) + "\n"
