"""One gear of the power-flow analysis (:mod:`transgen.powerflow`): the transformers (planetary
sets, stepped sets, gear pairs) of a mechanism, the gear's static torque balance with mesh losses,
and the iteration on the power directions those losses depend on."""
from __future__ import annotations

import itertools
import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from .equations import assemble, complete_locked, locked_constraints
from .errors import TransgenError
from .graph import coefficient, link_nodes, stepped_nodes, transformer_ports
from .kinematics import link_speeds, numeric_rank
from .model import HOUSING, Mechanism

if TYPE_CHECKING:
    from .graph import Graph

#: nothing public: the errors are :mod:`transgen.powerflow`'s (defined here, where they are raised first)
__all__: list[str] = []

_POWER_TOL = 1e-12
"""Carrier-frame power (per unit input power) below which a set counts as not transmitting."""
_MAX_ITERATIONS = 50
_MAX_ENUMERATED = 12
"""Most sets whose power directions are enumerated after the iteration cycles (2^12 solves)."""


class PowerFlowError(TransgenError, ValueError):
    """Bad arguments, or a gear whose static torques are not unique or not in equilibrium."""


class PowerFlowConvergenceError(TransgenError, RuntimeError):
    """The assumed power directions of the mesh losses do not settle to one consistent set."""



@dataclass(frozen=True)
class _Transformer:
    """A transformer's ports for the loss relations: ``a`` and ``b`` are the two gear members
    (sun and ring, or ports 1 and 2), ``base`` the carrier (``None`` for a gear pair: the housing).
    One direction variable: the sign of member ``a``'s carrier-frame power."""

    name: str
    kind: str
    ports: tuple  # ((link, port, c), ...) in port order
    a: int
    b: int
    base: int | None

    @property
    def n_vars(self) -> int:
        return 1


@dataclass(frozen=True)
class _SteppedSet:
    """A stepped-pinion set for the loss relations. ``ports``: ``(link, role, r)`` of its central
    gears, carrier last (``r = 0``), with ``r = (w_X - w_c) / (w_p - w_c) = sigma_X * Np_k / N_X``
    the gear's speed relative to the pinion's, both in the carrier frame; ``nodes``: the graph's
    constraint nodes ``(node, b)``, each between gear 0 and gear ``b``. One direction variable per
    central gear: the sign of its carrier-frame power."""

    name: str
    ports: tuple
    nodes: tuple
    kind: str = "stepped"

    @property
    def n_vars(self) -> int:
        return len(self.ports) - 1

    @property
    def base(self) -> int:
        return len(self.ports) - 1


def _transformers(mech: Mechanism, g: Graph) -> list:
    out = []
    for node, data in g.nodes(data=True):
        if data["kind"] not in ("planetary", "gearpair"):
            continue
        ports = [(link, port, float(coefficient(terms, data["params"]))) for link, port, terms in transformer_ports(g, node)]
        scale = max(abs(c) for _, _, c in ports)  # rows of order one beside the link balances
        ports = tuple((link, port, c / scale) for link, port, c in ports)
        if data["kind"] == "planetary":
            out.append(_Transformer(node, "planetary", ports, 0, 1, 2))
        else:
            out.append(_Transformer(node, "gearpair", ports, 0, 1, None))
    for sp in mech.stepped:
        r = [(-1 if role.startswith("sun") else 1) * sp.step_teeth(role) / teeth for role, _, teeth in sp.members]
        scale = max(abs(x) for x in r)
        ports = tuple((link, role, x / scale) for (role, link, _), x in zip(sp.members, r)) + ((sp.carrier, "carrier", 0.0),)
        out.append(_SteppedSet(sp.name, ports, tuple((node, b + 1) for b, node in enumerate(stepped_nodes(sp)))))
    return out


class _Gear:
    """The static torque problem of one gear: unknowns ``x = [lambda..., T]`` with the
    locked-group and transformer-port torques ``lambda`` as in :func:`transgen.equations.assemble`
    and ``T = T_out`` for ``T_in = 1`` (drive) or ``T = T_in`` for ``T_out = -sign(w_out)`` (coast:
    the driveline drives the output in its direction of rotation)."""

    def __init__(self, mech: Mechanism, g: Graph, engaged, eta: dict[str, float], coast: bool = False):
        links = link_nodes(g)
        self.links = links
        self.locked = complete_locked(g, engaged)
        self.groups = locked_constraints(g, self.locked)
        eq = assemble(g, self.locked)
        n = eq.n_links
        self.lam = eq.z[n:]
        col = {name: i for i, name in enumerate(self.lam)}
        ui = {name: i for i, name in enumerate(eq.u)}
        # the link balances without the accelerations (massless, static); the driven end's torque
        # joins the unknowns
        speeds = link_speeds(mech, tuple(grp.first for grp in self.groups), g)
        self.determined = np.array([speeds[k] is not None for k in links])
        # a floating link's speed is undetermined: 0 here, and its sets are lossless (directions 0)
        self.w = np.array([0.0 if speeds[k] is None or abs(speeds[k]) < 1e-12 else speeds[k] for k in links])
        given, unknown = ("T_out", "T_in") if coast else ("T_in", "T_out")
        value = -np.sign(self.w[links.index(mech.output)]) if coast else 1.0
        self.balance = np.hstack([eq.E[:n, n:], eq.F[:n, [ui[unknown]]]])
        self.rhs_balance = -eq.F[:n, ui[given]] * value
        self.transformers = _transformers(mech, g)
        # per transformer: its port columns (a stepped set: (gear 0, gear b, carrier) per node)
        self.port_col = []
        for t in self.transformers:
            if t.kind == "stepped":
                self.port_col.append([tuple(col[f"t_{node}.{t.ports[k][1]}"] for k in (0, b, t.base))
                                      for node, b in t.nodes])
            else:
                self.port_col.append([col[f"t_{t.name}.{port}"] for _, port, _ in t.ports])
        self.eta = [eta[t.name] for t in self.transformers]
        # the direction variables: one per planetary or pair, one per central gear of a stepped set
        self.var_slices, start = [], 0
        for t in self.transformers:
            self.var_slices.append(slice(start, start + t.n_vars))
            start += t.n_vars
        self.var_names = [t.name if t.n_vars == 1 and t.kind != "stepped" else f"{t.name}.{t.ports[k][1]}"
                          for t in self.transformers for k in range(t.n_vars)]
        self.group_col = [col[f"t_{grp.label}"] for grp in self.groups]
        speed = dict(zip(links, self.w))
        known = dict(zip(links, self.determined))
        speed[HOUSING], known[HOUSING] = 0.0, True
        # per transformer: relative speeds of its members to the base, and whether they are known
        self.relative = []
        for t in self.transformers:
            base = 0.0 if t.base is None else speed[t.ports[t.base][0]]
            rel = [speed[link] - base for link, _, _ in t.ports]
            ok = all(known[link] for link, _, _ in t.ports)
            self.relative.append((rel, ok))

    @property
    def n_vars(self) -> int:
        return len(self.var_names)

    def torques(self, k: int, x) -> list[float]:
        """The torque every port's link exerts on transformer ``k`` (a stepped set: summed over
        its constraint nodes), in port order."""
        t, cols = self.transformers[k], self.port_col[k]
        if t.kind != "stepped":
            return [float(x[c]) for c in cols]
        out = [0.0] * len(t.ports)
        for (node, b), (ca, cb, cc) in zip(t.nodes, cols):
            out[0] += float(x[ca])
            out[b] += float(x[cb])
            out[t.base] += float(x[cc])
        return out

    def matrix(self, factors) -> tuple[np.ndarray, np.ndarray]:
        """The equations with the loss factors: ``t_b = (c_b/c_a) * f * t_a`` for a planetary or
        pair; for a stepped set ``f_0*r_0*t_0 + f_b*r_b*t_b = 0`` per constraint node (the pinion's
        carrier-frame balance, see the module docstring)."""
        n_x = self.balance.shape[1]
        rows = [self.balance]
        for t, cols, sl in zip(self.transformers, self.port_col, self.var_slices):
            f = factors[sl]
            if t.kind == "stepped":
                r = [p[2] for p in t.ports]
                for (node, b), (ca, cb, cc) in zip(t.nodes, cols):
                    ratio_row, eq_row = np.zeros(n_x), np.zeros(n_x)
                    ratio_row[ca], ratio_row[cb] = f[0] * r[0], f[b] * r[b]
                    eq_row[[ca, cb, cc]] = 1.0
                    rows += [ratio_row[None, :], eq_row[None, :]]
                continue
            c = [p[2] for p in t.ports]
            ratio_row = np.zeros(n_x)
            ratio_row[cols[t.b]] = c[t.a]
            ratio_row[cols[t.a]] = -c[t.b] * f[0]
            rows.append(ratio_row[None, :])
            if t.base is not None:  # equilibrium of the massless set
                eq_row = np.zeros(n_x)
                eq_row[cols] = 1.0
                rows.append(eq_row[None, :])
        a = np.vstack(rows)
        rhs = np.concatenate([self.rhs_balance, np.zeros(a.shape[0] - len(self.rhs_balance))])
        return a, rhs

    def solve(self, factors, gear: str) -> np.ndarray:
        a, b = self.matrix(factors)
        if numeric_rank(a) < a.shape[1]:
            raise PowerFlowError(f"gear {gear}: the static torques are not unique: the engaged elements "
                                 f"{' '.join(self.locked)} or the gearsets over-constrain the mechanism "
                                 f"(a statically indeterminate torque split, see 'transgen modes')")
        x, *_ = np.linalg.lstsq(a, b, rcond=None)
        x += np.linalg.lstsq(a, b - a @ x, rcond=None)[0]  # one step of iterative refinement
        if np.linalg.norm(a @ x - b) > 1e-9 * (1.0 + np.linalg.norm(b)):
            raise PowerFlowError(f"gear {gear}: no static equilibrium with torque on the input")
        return x

    def directions(self, x) -> list[int]:
        """Per direction variable: +1 when its member drives in the carrier frame (a planetary's
        or pair's member ``a``; a stepped set's central gear), -1 when it is driven (a planetary's
        ``b`` drives), 0 when no power flows through its meshes (or a member floats)."""
        out = []
        for k, (t, (rel, ok)) in enumerate(zip(self.transformers, self.relative)):
            torques = self.torques(k, x)
            for m in range(t.n_vars):
                i = m if t.kind == "stepped" else t.a
                p = torques[i] * rel[i]
                out.append(0 if not ok or abs(p) <= _POWER_TOL else (1 if p > 0 else -1))
        return out

    def factors(self, directions) -> list[float]:
        """The loss factor of every direction variable: ``eta0**d`` for a planetary or pair,
        ``sqrt(eta0)**d`` (one mesh of the two between two gears) for a stepped set's gear."""
        out = []
        for t, eta, sl in zip(self.transformers, self.eta, self.var_slices):
            e = math.sqrt(eta) if t.kind == "stepped" else eta
            out += [1.0 if d == 0 else e ** d for d in directions[sl]]
        return out


def _consistent(gear: _Gear, x, directions) -> bool:
    return all(d == 0 or d == n for d, n in zip(directions, gear.directions(x)))


def _solve_directions(gear: _Gear, name: str) -> tuple[np.ndarray, list[int], int]:
    """Iterate the assumed power directions to a consistent solution (see the module docstring)."""
    x = gear.solve([1.0] * gear.n_vars, name)
    directions = gear.directions(x)
    seen = []
    for iteration in range(1, _MAX_ITERATIONS + 1):
        x = gear.solve(gear.factors(directions), name)
        new = gear.directions(x)
        # a set that was lossless (no power) stays so: its meshes carry no power whatever the factor
        new = [0 if d == 0 else n for d, n in zip(directions, new)]
        if new == directions:
            return x, directions, iteration
        if new in seen:
            break
        seen.append(directions)
        directions = new
    active = [k for k, d in enumerate(directions) if d != 0]
    cycling = [gear.var_names[k] for k in active if any(s[k] != directions[k] for s in seen)]
    if len(active) <= _MAX_ENUMERATED:
        found = []
        for signs in itertools.product((1, -1), repeat=len(active)):
            trial = list(directions)
            for k, s in zip(active, signs):
                trial[k] = s
            xt = gear.solve(gear.factors(trial), name)
            if _consistent(gear, xt, trial):
                found.append((xt, trial))
        if len(found) == 1:
            return found[0][0], found[0][1], iteration + 2 ** len(active)
        what = "no" if not found else f"{len(found)}"
        raise PowerFlowConvergenceError(
            f"gear {name}: the power directions of {', '.join(cycling) or 'the sets'} oscillate and {what} "
            f"assignment of directions is consistent (self-locking or ambiguous with these efficiencies)")
    raise PowerFlowConvergenceError(f"gear {name}: the power directions of {', '.join(cycling)} do not settle")
