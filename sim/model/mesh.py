"""Mesh losses in the dynamic model: the power flow's carrier-frame rule (Müller) in every mode.

The power flow (:mod:`transgen.powerflow_gear`) writes each planetary set's and gear pair's
torque relation with a loss factor, ``c_a t_b = c_b f t_a`` (and ``t_s + t_r + t_c = 0`` for a
massless set), ``f = eta0 ** d``, ``d = +1`` when member ``a`` drives in the carrier frame (its
carrier-frame power ``t_a (w_a - w_c) > 0``), ``-1`` when it is driven, and iterates the
directions to a consistent set. Here the same relations replace the lossless ones of
:func:`transgen.equations.assemble` in the mode's equations ``E z + F u = 0`` (``z``: link
accelerations, locked torques, port torques), with the direction **blended** over the
carrier-frame power: ``d = tanh(p / P_0)``, ``P_0`` = :data:`BLEND_POWER` (1 W). The factor then
changes smoothly through a reversal of the power (drive to coast) instead of jumping, so a set
whose power passes through zero does not chatter; beyond a few ``P_0`` it is the power flow's
``eta0 ** (+-1)`` to round-off, so a steady state (same gear, same torque) gives the power flow's
efficiency. The port torques depend on ``f`` and ``f`` on the port torques: each evaluation
iterates ``f`` to a fixed point, to 1e-10 (from the last one of the mode: one to seven solves in the
bundled runs; Newton's method where the plain iteration cycles); one that does not settle stops
the run with a :class:`SimulationError`.

The transformers' efficiencies are the power flow's (:func:`transgen.powerflow._efficiencies`:
the file's ``eta0=``/``eta=``, else the given, else the defaults); their ports, coefficients and
members ``a``, ``b``, ``base`` are :func:`transgen.powerflow_gear._transformers`'. Stepped-pinion
sets are not modelled here (refused). The power the meshes lose, ``sum over ports t_port w_link``
(the links' power into the sets, zero without losses), is what :meth:`MeshModel.solve` returns
for the energy balance.
"""
from __future__ import annotations

import math

import numpy as np

from transgen.equations import assemble
from transgen.errors import SimulationError
from transgen.graph import TRANSFORMER_KINDS, link_nodes
from transgen.model import HOUSING
from transgen.powerflow import _efficiencies
from transgen.powerflow_gear import _transformers

__all__ = ["BLEND_POWER", "MeshModel"]

BLEND_POWER = 1.0
"""``P_0`` [W]: the carrier-frame power over which a set's loss factor blends from coast to drive."""
_PLAIN_ITERATIONS = 20
_MAX_ITERATIONS = 30  # Newton steps after the plain iteration
_F_TOL = 1e-10  # a set turning as a block has round-off power (1e-10 W): its factor moves by 1e-12


class _ModeMesh:
    """The lossy equations of one mode: ``E(f) = E_base + sum_k f_k * coef_k e_(row_k) e_(col_k)^T``
    (scaled rows and columns), ``F``, and where each set's member torques and speeds are."""

    def __init__(self, model: "MeshModel", locked: tuple[str, ...]):
        g = model.graph
        eq = assemble(g, locked)
        n = eq.n_links
        zi = {name: i for i, name in enumerate(eq.z)}
        E = np.array(eq.E, dtype=float)
        row = n
        nodes = [x for x, d in g.nodes(data=True) if d["kind"] in TRANSFORMER_KINDS]
        by_name = {t.name: t for t in model.transformers}
        entries = []  # (row, column, coefficient of f)
        self.sets = []  # (column of t_a, link index of a, link index of base or -1, port columns, port links)
        for node in nodes:
            t = by_name[node]
            cols = [zi[f"t_{t.name}.{port}"] for _, port, _ in t.ports]
            links = [model.link_index.get(link, -1) for link, _, _ in t.ports]
            c = [p[2] for p in t.ports]
            row += 1  # the kinematic row stays
            ratio = row
            E[ratio] = 0.0
            E[ratio, cols[t.b]] = c[t.a]
            entries.append((ratio, cols[t.a], -c[t.b]))
            if len(cols) == 3:
                E[ratio + 1] = 0.0
                E[ratio + 1, cols] = 1.0
            row += len(cols) - 1
            base = links[t.base] if t.base is not None else -1
            self.sets.append((cols[t.a], links[t.a], base, cols, links))
        self.names = [t.name for t in (by_name[x] for x in nodes)]
        self.n_links, self.n_locked = n, eq.n_locked
        self.F = np.array(eq.F, dtype=float)
        self.rows = np.array([e[0] for e in entries], dtype=int)
        self.cols = np.array([e[1] for e in entries], dtype=int)
        self.coef = np.array([e[2] for e in entries])
        E[self.rows, self.cols] = self.coef  # f = 1: scale from the lossless matrix
        self.row_scale = 1.0 / np.abs(E).max(axis=1)
        E1 = E * self.row_scale[:, None]
        self.col_scale = 1.0 / np.abs(E1).max(axis=0)
        self.E = E1 * self.col_scale[None, :]
        self.coef_scaled = self.coef * self.row_scale[self.rows] * self.col_scale[self.cols]
        self.eta = np.array(model.eta)
        self.f = np.ones(len(entries))  # the last fixed point: the next evaluation's start

    def _solve(self, f: np.ndarray, rhs: np.ndarray) -> np.ndarray:
        E = self.E.copy()
        E[self.rows, self.cols] = self.coef_scaled * f
        return np.linalg.solve(E, rhs * self.row_scale) * self.col_scale

    def factors(self, z: np.ndarray, w: np.ndarray) -> np.ndarray:
        """``eta0 ** tanh(p / P_0)`` of every set at the solution ``z`` and the speeds ``w``."""
        out = np.empty(len(self.sets))
        for k, (col, a, base, _, _) in enumerate(self.sets):
            rel = (w[a] if a >= 0 else 0.0) - (w[base] if base >= 0 else 0.0)
            out[k] = self.eta[k] ** math.tanh(z[col] * rel / BLEND_POWER)
        return out

    def _fixed_point(self, f: np.ndarray, rhs: np.ndarray, w: np.ndarray) -> np.ndarray:
        """The factors ``f = factors(z(f))``: plain iteration (it settles in a few steps where
        the sets' powers are far from zero), then Newton's method on ``factors(z(f)) - f`` with
        a forward-difference Jacobian, each step kept inside the factors' range ``[eta, 1/eta]``
        (where a set's power passes near zero while the others carry much more, the plain
        iteration can cycle)."""
        for _ in range(_PLAIN_ITERATIONS):
            new = self.factors(self._solve(f, rhs), w)
            if np.max(np.abs(new - f), initial=0.0) <= _F_TOL:
                return new
            f = new
        low, high = np.minimum(self.eta, 1.0 / self.eta), np.maximum(self.eta, 1.0 / self.eta)
        for _ in range(_MAX_ITERATIONS):
            g = self.factors(self._solve(f, rhs), w) - f
            if np.max(np.abs(g), initial=0.0) <= _F_TOL:
                return f + g
            jac = np.empty((len(f), len(f)))
            for j in range(len(f)):
                h = 1e-7 * max(1.0, abs(f[j]))
                fj = f.copy()
                fj[j] += h
                jac[:, j] = (self.factors(self._solve(fj, rhs), w) - fj - g) / h
            try:
                step = np.linalg.solve(jac, -g)
            except np.linalg.LinAlgError:
                step = g
            f = np.clip(f + step, low, high)
        raise SimulationError(f"the mesh loss factors of {', '.join(self.names)} do not settle "
                              "(a self-locking set with these efficiencies?)")

    def solve(self, u: np.ndarray, w: np.ndarray) -> tuple[np.ndarray, np.ndarray, float]:
        rhs = -(self.F @ u)
        f = self._fixed_point(self.f, rhs, w)
        self.f = f
        z = self._solve(f, rhs)
        loss = 0.0
        for _, _, _, cols, links in self.sets:
            for col, k in zip(cols, links):
                if k >= 0:
                    loss += z[col] * w[k]
        n = self.n_links
        return z[:n], z[n:n + self.n_locked], loss


class MeshModel:
    """The mesh losses of a mechanism in the simulation (see the module docstring).

    ``eta0``, ``eta_pair``: the power flow's global efficiencies (None: the file's or the
    defaults). Raises ``ValueError`` for a mechanism with stepped-pinion sets."""

    def __init__(self, mech, graph, eta0: float | None = None, eta_pair: float | None = None):
        if mech.stepped:
            raise ValueError(f"mesh losses in the simulation do not model stepped-pinion sets "
                             f"({', '.join(s.name for s in mech.stepped)})")
        self.graph = graph
        self.links = link_nodes(graph)
        self.link_index = {k: i for i, k in enumerate(self.links)}
        self.link_index[HOUSING] = -1
        self.transformers = _transformers(mech, graph)
        eta = _efficiencies(mech, eta0, eta_pair)
        self.eta = [eta[t.name] for t in self.transformers]
        self.efficiencies = {t.name: eta[t.name] for t in self.transformers}
        self._modes: dict = {}

    def mode(self, names: tuple[str, ...]) -> _ModeMesh:
        """The lossy equations of the mode locking the element names ``names`` (its constraint
        rows in the order of the mode's ``D``: the groups in row order, each member in order)."""
        m = self._modes.get(names)
        if m is None:
            m = self._modes[names] = _ModeMesh(self, names)
        return m

    def solve(self, names: tuple[str, ...], u: np.ndarray, w: np.ndarray) -> tuple[np.ndarray, np.ndarray, float]:
        """``(link accelerations [rad/s^2], locked-row torques [N*m], mesh loss [W])`` of the mode
        ``names`` for the inputs ``u`` at the link speeds ``w`` [rad/s]."""
        return self.mode(names).solve(np.asarray(u, dtype=float), np.asarray(w, dtype=float))
