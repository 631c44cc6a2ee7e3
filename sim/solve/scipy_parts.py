"""The parts of scipy the simulator's default path uses, imported without the rest of their packages.

The switching model with LSODA needs scipy's ``_odepack`` (the compiled lsoda routine), the LSODA
solver class around it (``scipy.integrate._ivp.lsoda``, with its base classes and
``OdeSolution``) and Brent's root finder (the compiled ``scipy.optimize._zeros``). Importing them
the ordinary way runs ``scipy/integrate/__init__.py`` and ``scipy/optimize/__init__.py``, which
import boundary-value solvers, quadrature, scipy.special, scipy.linalg and every optimizer: 0.18 s
of CPU of which the simulator uses nothing, paid by every process that runs a simulation (each
worker of a sweep; ``benchmarks/bench_sweep.py``).

:func:`deferred_package` registers such a package under its real name with its ``__init__`` not
yet run: its submodules import as usual (the real files, the real modules), and the first time
anything asks the package for a name it does not have (``from scipy.integrate import quad``,
``scipy.integrate.solve_ivp``, ``import *``, ``dir``), the package's own ``__init__`` runs in it,
once, reusing the submodules already loaded (so ``scipy.integrate.LSODA`` is the class the
simulator's solver derives from). Nothing is copied from scipy and no other module is touched; if
anything is unexpected (the package imported already, a file missing, an import failing) the
ordinary import is used.

:func:`brentq` is ``scipy.optimize.brentq`` as the simulator calls it (defaults, no extra
arguments, a NaN of the function an error): the same compiled routine with the same arguments,
so the same roots, bit for bit; checked on a known root when first loaded, else scipy's.
"""
from __future__ import annotations

import importlib
import importlib.machinery
import importlib.util
import sys
import threading
import types

__all__ = ["deferred_package", "lsoda_classes", "brentq"]

_LOCK = threading.RLock()


class _DeferredPackage(types.ModuleType):
    """A package whose ``__init__`` runs at the first look-up of a name it lacks (see the module
    docstring). Submodule imports read only ``__path__`` and ``__spec__`` and set attributes:
    they do not run it; nor does the import system's probe of ``from . import submodule`` (it
    looks the name up first, and imports the submodule where it is missing)."""

    def __getattr__(self, name: str):
        caller = sys._getframe(1).f_code
        if caller.co_name == "_handle_fromlist" and caller.co_filename.startswith("<frozen importlib") \
                and importlib.machinery.PathFinder.find_spec(f"{self.__name__}.{name}", self.__path__) is not None:
            raise AttributeError(name)  # `from package import submodule`: imported next, as usual
        _complete(self)
        return types.ModuleType.__getattribute__(self, name)

    def __dir__(self):
        _complete(self)
        return types.ModuleType.__dir__(self)


_RUNNING: set[str] = set()  # packages whose __init__ is running


def _complete(module: types.ModuleType) -> None:
    """Run the package's own ``__init__`` in ``module`` (once; other threads wait for it; a name
    looked up during it by the same thread is missing, as in any package being initialised)."""
    with _LOCK:
        name = module.__name__
        if type(module) is not _DeferredPackage or name in _RUNNING:
            return
        _RUNNING.add(name)
        try:
            module.__spec__.loader.exec_module(module)
        finally:
            _RUNNING.discard(name)
            module.__class__ = types.ModuleType


def deferred_package(name: str) -> types.ModuleType:
    """The package ``name`` (its parent imported as usual), registered in ``sys.modules`` with
    its ``__init__`` deferred; the package itself where it is imported already."""
    with _LOCK:
        found = sys.modules.get(name)
        if found is not None:
            return found
        parent, _, child = name.rpartition(".")
        if parent:
            importlib.import_module(parent)
        spec = importlib.util.find_spec(name)
        if spec is None or spec.loader is None or spec.submodule_search_locations is None \
                or not hasattr(spec.loader, "exec_module"):
            raise ImportError(f"{name} is not a package that can be deferred")
        module = importlib.util.module_from_spec(spec)
        module.__class__ = _DeferredPackage
        sys.modules[name] = module
        if parent:
            setattr(sys.modules[parent], child, module)
        return module


def _deferred_import(packages: tuple[str, ...], load):
    """``load()`` with ``packages`` deferred; on any failure the deferred packages that are left
    are completed (their ``__init__`` run) and ``load()`` is called again: the ordinary import."""
    try:
        with _LOCK:
            for name in packages:
                deferred_package(name)
            return load()
    except Exception:  # noqa: BLE001 - anything unexpected: the ordinary import
        for name in packages:
            module = sys.modules.get(name)
            if type(module) is _DeferredPackage:
                _complete(module)
        return load()


def lsoda_classes() -> tuple:
    """``(LSODA, LsodaDenseOutput, ConstantDenseOutput, OdeSolution)`` of ``scipy.integrate``,
    without running ``scipy/integrate/__init__.py`` (see the module docstring).

    scipy.linalg is deferred too: the simulator's path does not use it, but loading numba's
    compiled code imports ``scipy.linalg.cython_blas`` (numba's check for a BLAS), which ran
    scipy.linalg's ``__init__`` (0.03 s of a sweep worker's start)."""

    def load():
        integrate = sys.modules["scipy.integrate"]
        if type(integrate) is _DeferredPackage and "ode" not in integrate.__dict__:
            from scipy.integrate._ode import ode  # the one name _ivp.lsoda takes from the package

            integrate.ode = ode
        from scipy.integrate._ivp.base import ConstantDenseOutput
        from scipy.integrate._ivp.common import OdeSolution
        from scipy.integrate._ivp.lsoda import LSODA, LsodaDenseOutput

        return LSODA, LsodaDenseOutput, ConstantDenseOutput, OdeSolution

    return _deferred_import(("scipy.integrate", "scipy.integrate._ivp", "scipy.linalg"), load)


def _scipy_brentq():
    from scipy.optimize import brentq as scipy_brentq

    return scipy_brentq


def _load_brentq():
    """The compiled Brent routine behind ``scipy.optimize.brentq`` called as that function calls it
    (scipy 1.17: ``_zeros._brentq(f, a, b, xtol, rtol, maxiter, args, full_output, disp)`` with
    ``f`` wrapped to raise ValueError on NaN), checked on a root it must find exactly; scipy's
    ``brentq`` where that differs or fails."""
    try:
        zeros = _deferred_import(("scipy.optimize",), lambda: importlib.import_module("scipy.optimize._zeros"))
        routine = zeros._brentq
    except Exception:  # noqa: BLE001 - scipy's own function
        return _scipy_brentq()
    maxiter = 100  # scipy's default _iter

    def brentq(f, a: float, b: float, xtol: float, rtol: float) -> float:
        """``scipy.optimize.brentq(f, a, b, xtol=xtol, rtol=rtol)``; rtol >= 4 eps."""

        def f_raise(x):
            fx = f(x)
            if fx != fx:  # scipy's np.isnan(fx) on the function's float
                raise ValueError(f"The function value at x={x} is NaN; solver cannot continue.")
            return fx

        return routine(f_raise, a, b, xtol, rtol, maxiter, (), False, True)

    try:
        eps = sys.float_info.epsilon
        root = brentq(lambda x: x * x - 2.0, 0.0, 2.0, 4 * eps, 4 * eps)
        ok = type(root) is float and abs(root - 2.0 ** 0.5) < 1e-12
    except Exception:  # noqa: BLE001 - another signature: scipy's function
        ok = False
    return brentq if ok else _scipy_brentq()


_BRENTQ = None


def brentq(f, a: float, b: float, xtol: float, rtol: float) -> float:
    """A root of ``f`` in [a, b] (``f(a)``, ``f(b)`` of opposite signs): ``scipy.optimize.brentq(f,
    a, b, xtol=xtol, rtol=rtol)``, bit for bit (module docstring)."""
    global _BRENTQ
    if _BRENTQ is None:
        _BRENTQ = _load_brentq()
    return _BRENTQ(f, a, b, xtol=xtol, rtol=rtol)
