"""scipy's BDF and Radau integrators with a lean dense LU (the solvers of
:data:`.ode_solvers.SOLVERS` ``"BDF"`` and ``"Radau"``; a module of their own because they import
scipy.linalg, which the default LSODA path does not need: :mod:`.scipy_parts`).

Both solve their Newton systems through ``scipy.linalg.lu_factor`` / ``lu_solve``, whose Python
layers (batch dispatch, argument checks, LAPACK look-up) cost tens of microseconds per call, ten
times the LAPACK work on the simulator's few-state systems; a turbodiesel run makes thousands of
such calls. These subclasses call the same LAPACK routines (``getrf``, ``getrs``) directly, with
the same finiteness checks (a NaN from a rejected trial state raises the same ``ValueError``) and
the same singular-matrix warning: the results are those of the scipy classes, bit for bit.
Sparse Jacobians keep scipy's ``splu``.
"""
from __future__ import annotations

import math
import warnings

import numpy as np
from scipy.linalg import LinAlgWarning, get_lapack_funcs
from scipy.sparse import issparse

from .scipy_parts import stiff_internals

_INTERNALS = stiff_internals()
if _INTERNALS is None:  # the public API only (scipy_parts): scipy's classes, as they are
    from scipy.integrate import BDF, Radau

    MAX_FACTOR = MAX_ORDER = MIN_FACTOR = NEWTON_MAXITER = compute_R = None
else:
    BDF, Radau, MAX_FACTOR, MAX_ORDER, MIN_FACTOR, NEWTON_MAXITER, compute_R = _INTERNALS

__all__ = ["LeanBDF", "LeanRadau", "change_D"]


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
        a = np.asarray(a)
        if not np.isfinite(a).all():  # ``np.asarray_chkfinite`` without its layers
            raise ValueError("array must not contain infs or NaNs")
        getrf, _ = self._funcs(a)
        lu, piv, info = getrf(a, overwrite_a=True)
        if info < 0:
            raise ValueError(f"illegal value in {-info}th argument of internal getrf (lu_factor)")
        if info > 0:
            warnings.warn(f"Diagonal number {info} is exactly zero. Singular matrix.", LinAlgWarning, stacklevel=2)
        return lu, piv

    def _solve_lu(self, lu_piv, b):
        lu, piv = lu_piv
        if not np.isfinite(b).all():  # ``np.asarray_chkfinite(b)`` (b is an array) without its layers
            raise ValueError("array must not contain infs or NaNs")
        getrs = self._funcs(lu)[1] if b.dtype == lu.dtype else get_lapack_funcs(("getrs",), (lu, b))[0]
        x, info = getrs(lu, piv, b, trans=0, overwrite_b=True)
        if info != 0:
            raise ValueError(f"illegal value in {-info}th argument of internal gesv|posv")
        return x


_UNIT_R: dict[int, np.ndarray] = {}


def change_D(D: np.ndarray, order: int, factor: float) -> None:
    """scipy's ``change_D`` (the differences array rescaled to a new step size, in place) with
    its step-independent factor ``compute_R(order, 1)`` computed once per order: the same
    products, bit for bit."""
    U = _UNIT_R.get(order)
    if U is None:
        U = _UNIT_R[order] = compute_R(order, 1)
    RU = compute_R(order, factor).dot(U)
    D[:order + 1] = np.dot(RU.T, D[:order + 1])


def _rms(x: np.ndarray) -> float:
    """scipy's RMS norm of its step control (``np.linalg.norm(x) / sqrt(x.size)``) without the
    dispatch of ``np.linalg.norm``: the same ``sqrt(x.dot(x))``, bit for bit."""
    return math.sqrt(x.dot(x)) / x.size ** 0.5


class LeanBDF(_LeanLU, BDF):
    """:class:`scipy.integrate.BDF` with the lean dense LU and a lean step: scipy's
    ``_step_impl`` and Newton iteration (version 1.17) with the RMS norms taken directly and the
    Newton loop inline; the same arithmetic, so the same steps and states, bit for bit (a
    scipy whose BDF lacks the attributes this step reads runs its own step)."""

    _STATE = ("D", "alpha", "gamma", "error_const", "newton_tol", "n_equal_steps", "I", "LU", "J", "h_abs", "order")

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        self._lean_step = not issparse(self.J) and all(hasattr(self, a) for a in self._STATE)

    def _step_impl(self):
        if not self._lean_step:
            return super()._step_impl()
        t = self.t
        D = self.D
        max_step = self.max_step
        min_step = 10 * abs(math.nextafter(t, self.direction * math.inf) - t)
        if self.h_abs > max_step:
            h_abs = max_step
            change_D(D, self.order, max_step / self.h_abs)
            self.n_equal_steps = 0
        elif self.h_abs < min_step:
            h_abs = min_step
            change_D(D, self.order, min_step / self.h_abs)
            self.n_equal_steps = 0
        else:
            h_abs = self.h_abs
        atol, rtol, order = self.atol, self.rtol, self.order
        alpha, gamma, error_const = self.alpha, self.gamma, self.error_const
        J, LU = self.J, self.LU
        current_jac = self.jac is None
        fun, solve_lu, newton_tol = self.fun, self.solve_lu, self.newton_tol
        step_accepted = False
        while not step_accepted:
            if h_abs < min_step:
                return False, self.TOO_SMALL_STEP
            h = h_abs * self.direction
            t_new = t + h
            if self.direction * (t_new - self.t_bound) > 0:
                t_new = self.t_bound
                change_D(D, order, np.abs(t_new - t) / h_abs)
                self.n_equal_steps = 0
                LU = None
            h = t_new - t
            h_abs = np.abs(h)
            y_predict = D[:order + 1].sum(axis=0)
            scale = atol + rtol * np.abs(y_predict)
            psi = np.dot(D[1: order + 1].T, gamma[1: order + 1]) / alpha[order]
            converged = False
            c = h / alpha[order]
            while not converged:
                if LU is None:
                    LU = self.lu(self.I - c * J)
                # scipy's solve_bdf_system
                d = 0
                y_new = y_predict.copy()
                dy_norm_old = None
                for n_iter in range(1, NEWTON_MAXITER + 1):
                    f = fun(t_new, y_new)
                    if not np.isfinite(f).all():
                        break
                    dy = solve_lu(LU, c * f - psi - d)
                    dy_norm = _rms(dy / scale)
                    rate = None if dy_norm_old is None else dy_norm / dy_norm_old
                    if rate is not None and (rate >= 1 or rate ** (NEWTON_MAXITER - n_iter + 1) / (1 - rate) * dy_norm > newton_tol):
                        break
                    y_new += dy
                    d += dy
                    if dy_norm == 0 or rate is not None and rate / (1 - rate) * dy_norm < newton_tol:
                        converged = True
                        break
                    dy_norm_old = dy_norm
                if not converged:
                    if current_jac:
                        break
                    J = self.jac(t_new, y_predict)
                    LU = None
                    current_jac = True
            if not converged:
                factor = 0.5
                h_abs *= factor
                change_D(D, order, factor)
                self.n_equal_steps = 0
                LU = None
                continue
            safety = 0.9 * (2 * NEWTON_MAXITER + 1) / (2 * NEWTON_MAXITER + n_iter)
            scale = atol + rtol * np.abs(y_new)
            error = error_const[order] * d
            error_norm = _rms(error / scale)
            if error_norm > 1:
                factor = max(MIN_FACTOR, safety * error_norm ** (-1 / (order + 1)))
                h_abs *= factor
                change_D(D, order, factor)
                self.n_equal_steps = 0
            else:
                step_accepted = True
        self.n_equal_steps += 1
        self.t = t_new
        self.y = y_new
        self.h_abs = h_abs
        self.J = J
        self.LU = LU
        D[order + 2] = d - D[order + 1]
        D[order + 1] = d
        for i in reversed(range(order + 1)):
            D[i] += D[i + 1]
        if self.n_equal_steps < order + 1:
            return True, None
        if order > 1:
            error_m_norm = _rms(error_const[order - 1] * D[order] / scale)
        else:
            error_m_norm = np.inf
        if order < MAX_ORDER:
            error_p_norm = _rms(error_const[order + 1] * D[order + 2] / scale)
        else:
            error_p_norm = np.inf
        error_norms = np.array([error_m_norm, error_norm, error_p_norm])
        with np.errstate(divide="ignore"):
            factors = error_norms ** (-1 / np.arange(order, order + 3))
        delta_order = np.argmax(factors) - 1
        order += delta_order
        self.order = order
        factor = min(MAX_FACTOR, safety * np.max(factors))
        self.h_abs *= factor
        change_D(D, order, factor)
        self.n_equal_steps = 0
        self.LU = None
        return True, None


class LeanRadau(_LeanLU, Radau):
    """:class:`scipy.integrate.Radau` with the lean dense LU."""


if _INTERNALS is None:  # the public API only: scipy's own BDF and Radau (their own LU and step)
    LeanBDF, LeanRadau = BDF, Radau  # noqa: F811
