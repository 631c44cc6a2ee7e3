"""The dense output of an integration segment at many times at once.

The simulator samples every segment's dense output at its output times (2000-4000 per 20-s run)
and scans the steps near a slip crossing at interior points (:func:`.integration.missed_crossing`).
``scipy``'s ``OdeSolution`` evaluates such a batch one integrator step at a time, a few numpy calls
per step: on LSODA's thousands of short steps that costs more than the interpolation. For LSODA's
interpolants (a Nordsieck array ``yh`` per step: ``y(t) = yh @ x**[0..order]``, ``x = (t -
t_step)/h``) :func:`dense_values` evaluates every time in one compiled loop when the simulator
runs compiled (:func:`~.jit.compiled_loop`): the same interpolant for each time as ``OdeSolution``
chooses, the same powers (``pow``), the products summed in order (numpy's ``dot`` may sum in
another order: the values agree to round-off). Any other dense output is called as it is.
"""
from __future__ import annotations

import math

import numpy as np

from ..core.jit import compilable, compiled_loop

__all__ = ["dense_values"]


@compilable
def nordsieck_values(ts, segment, t_step, h, width, offset, yh, out) -> None:
    """``out[:, k]``: the Nordsieck interpolant ``segment[k]`` (its step time ``t_step``, step size
    ``h``, ``width`` = order + 1 columns of ``yh`` stored row by row from ``offset``) at ``ts[k]``;
    the powers of ``x`` with ``pow`` as numpy takes them."""
    n = out.shape[0]
    powers = np.empty(np.max(width))
    for k in range(len(ts)):
        s = segment[k]
        x = (ts[k] - t_step[s]) / h[s]
        m = width[s]
        base = offset[s]
        for j in range(m):
            powers[j] = math.pow(x, float(j))
        for i in range(n):
            acc = 0.0
            for j in range(m):
                acc += yh[base + i * m + j] * powers[j]
            out[i, k] = acc


def dense_values(sol, ts: np.ndarray) -> np.ndarray:
    """``sol(ts)`` (states as rows, one column per time) for the dense output ``sol`` of a segment
    (:func:`.ode_solvers.solve_segment`), in one compiled loop for LSODA's (module docstring)."""
    ts = np.asarray(ts, dtype=float)
    loop = compiled_loop(nordsieck_values, len(ts))
    interpolants = getattr(sol, "interpolants", None)
    if loop is None or not interpolants or ts.ndim != 1 or not getattr(sol, "ascending", False) \
            or not hasattr(sol, "side"):  # scipy < 1.11: OdeSolution's own choice of segment
        return sol(ts)
    from .scipy_parts import lsoda_dense_type  # here: reading a scenario needs no scipy

    LsodaDenseOutput = lsoda_dense_type()
    if LsodaDenseOutput is None or not all(isinstance(ip, LsodaDenseOutput) for ip in interpolants):  # scipy's or LeanLSODA's lazy one
        return sol(ts)
    # OdeSolution's choice of the interpolant of each time
    segment = np.searchsorted(sol.ts_sorted, ts, side=sol.side) - 1
    np.clip(segment, 0, sol.n_segments - 1, out=segment)
    used = np.flatnonzero(np.bincount(segment))  # the steps with a time: np.unique (which imports numpy.ma)
    index = np.searchsorted(used, segment)
    parts = [interpolants[s] for s in used.tolist()]
    n = parts[0].yh.shape[0]
    width = np.array([ip.yh.shape[1] for ip in parts], dtype=np.int64)
    offset = np.zeros(len(parts), dtype=np.int64)
    np.cumsum(width[:-1] * n, out=offset[1:])
    yh = np.concatenate([ip.yh.ravel() for ip in parts])
    out = np.empty((n, len(ts)))
    loop(ts, index.astype(np.int64), np.array([ip.t for ip in parts]), np.array([ip.h for ip in parts]), width, offset,
         yh, out)
    return out
