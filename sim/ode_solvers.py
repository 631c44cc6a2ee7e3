"""scipy's BDF and Radau integrators with a lean dense LU.

Both solve their Newton systems through ``scipy.linalg.lu_factor`` / ``lu_solve``, whose Python
layers (batch dispatch, argument checks, LAPACK look-up) cost tens of microseconds per call, ten
times the LAPACK work on the simulator's few-state systems; a turbodiesel run makes thousands of
such calls. These subclasses call the same LAPACK routines (``getrf``, ``getrs``) directly, with
the same finiteness checks (a NaN from a rejected trial state raises the same ``ValueError``) and
the same singular-matrix warning: the results are those of the scipy classes, bit for bit.
Sparse Jacobians keep scipy's ``splu``.
"""
from __future__ import annotations

import warnings

import numpy as np
from scipy.integrate import BDF, Radau
from scipy.linalg import LinAlgWarning, get_lapack_funcs
from scipy.sparse import issparse

__all__ = ["LeanBDF", "LeanRadau", "SOLVERS"]


class _LeanLU:
    """Mix-in: dense ``lu`` and ``solve_lu`` through LAPACK directly (set after the solver's own
    ``__init__``, which installs scipy's)."""

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        if not issparse(self.J):
            self._lapack = {}
            self.lu, self.solve_lu = self._lu, self._solve_lu

    def _funcs(self, a: np.ndarray):
        funcs = self._lapack.get(a.dtype.char)
        if funcs is None:
            funcs = self._lapack[a.dtype.char] = get_lapack_funcs(("getrf", "getrs"), (a,))
        return funcs

    def _lu(self, a):
        self.nlu += 1
        a = np.asarray_chkfinite(a)
        getrf, _ = self._funcs(a)
        lu, piv, info = getrf(a, overwrite_a=True)
        if info < 0:
            raise ValueError(f"illegal value in {-info}th argument of internal getrf (lu_factor)")
        if info > 0:
            warnings.warn(f"Diagonal number {info} is exactly zero. Singular matrix.", LinAlgWarning, stacklevel=2)
        return lu, piv

    def _solve_lu(self, lu_piv, b):
        lu, piv = lu_piv
        b = np.asarray_chkfinite(b)
        getrs = self._funcs(lu)[1] if b.dtype == lu.dtype else get_lapack_funcs(("getrs",), (lu, b))[0]
        x, info = getrs(lu, piv, b, trans=0, overwrite_b=True)
        if info != 0:
            raise ValueError(f"illegal value in {-info}th argument of internal gesv|posv")
        return x


class LeanBDF(_LeanLU, BDF):
    """:class:`scipy.integrate.BDF` with the lean dense LU."""


class LeanRadau(_LeanLU, Radau):
    """:class:`scipy.integrate.Radau` with the lean dense LU."""


SOLVERS = {"BDF": LeanBDF, "Radau": LeanRadau}
"""Solver classes used for these method names (the others are passed to ``solve_ivp`` by name)."""
