"""The one home of scipy's private names in the simulator, each with a public fallback; and the parts
of scipy the default path uses, imported without the rest of their packages.

Private names used (scipy 1.10-1.17 seen; 1.15-1.17 supported): ``scipy.integrate._odepack.lsoda`` (the compiled routine
:class:`~.ode_solvers.LeanLSODA` steps directly), ``scipy.integrate._ivp.lsoda`` / ``.base`` /
``.common`` / ``.bdf`` / ``.radau`` (classes, BDF's constants and ``compute_R``), ``scipy.integrate._ode``
and ``scipy.optimize._zeros._brentq``. Where one fails to import or to pass its check, or where the
environment sets ``TRANSGEN_SCIPY_PUBLIC=1`` (:data:`PUBLIC`), the public API is used instead:
``scipy.integrate.LSODA`` / ``BDF`` / ``Radau`` / ``OdeSolution`` with their own steps, and
``scipy.optimize.brentq``; the results agree within the solvers' tolerances
(tests/test_scipy_parts.py runs both). The narrative of the deferred import is
docs/explanation/scipy-internals.md.

The default path imports those without running ``scipy/integrate/__init__.py`` and
``scipy/optimize/__init__.py`` (:func:`deferred_package`; 0.18 s of a sweep worker's start).
"""
from __future__ import annotations

import importlib
import importlib.machinery
import importlib.util
import os
import sys
import threading
import types

__all__ = ["deferred_package", "lsoda_classes", "lsoda_routine", "lsoda_dense_type", "stiff_internals",
           "is_bdf", "brentq", "PUBLIC"]

PUBLIC = os.environ.get("TRANSGEN_SCIPY_PUBLIC", "") == "1"
"""Use scipy's public API only (``TRANSGEN_SCIPY_PUBLIC=1`` in the environment at import)."""

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
        for done in _ON_COMPLETE.pop(name, ()):
            done(module)


_ON_COMPLETE: dict[str, list] = {}  # package -> what to do once its __init__ has run


def _stand_ins(package: types.ModuleType, names: tuple[str, ...], load):
    """``load()`` (an import that takes ``names`` from the deferred ``package``) with stand-ins
    for those names in the package: functions that complete the package and call its own. The
    stand-ins are in the package during ``load()`` only; in the modules that took them, they are
    replaced by the package's own names once its ``__init__`` has run."""
    def stand_in(name: str):
        def forward(*args, **kwargs):
            _complete(package)
            return getattr(package, name)(*args, **kwargs)

        forward.__name__ = forward.__qualname__ = name
        return forward

    placed = {name: stand_in(name) for name in names}
    before = set(sys.modules)
    package.__dict__.update(placed)
    try:
        loaded = load()
    finally:
        for name, value in placed.items():
            if package.__dict__.get(name) is value:
                del package.__dict__[name]
    takers = [sys.modules[m] for m in set(sys.modules) - before]

    def restore(done: types.ModuleType) -> None:
        for module in takers:
            for name, value in placed.items():
                if getattr(module, name, None) is value:
                    setattr(module, name, getattr(done, name))

    if type(package) is _DeferredPackage:
        _ON_COMPLETE.setdefault(package.__name__, []).append(restore)
    else:
        restore(package)
    return loaded


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


def _public_lsoda_classes() -> tuple:
    """The public stand-ins of :func:`lsoda_classes`: ``DenseOutput`` for the two dense-output
    classes (only the lean step makes those, and it is off without :func:`lsoda_routine`)."""
    from scipy.integrate import LSODA, DenseOutput, OdeSolution

    return LSODA, DenseOutput, DenseOutput, OdeSolution


def lsoda_classes() -> tuple:
    """``(LSODA, LsodaDenseOutput, ConstantDenseOutput, OdeSolution)`` of ``scipy.integrate``,
    without running ``scipy/integrate/__init__.py`` (see the module docstring); the public
    classes (:func:`_public_lsoda_classes`) under :data:`PUBLIC` or where the private ones fail.

    scipy.linalg is deferred too: the simulator's path does not use it, but loading numba's
    compiled code imports ``scipy.linalg.cython_blas`` (numba's check for a BLAS), which ran
    scipy.linalg's ``__init__`` (0.03 s of a sweep worker's start). So is scipy.sparse, whose
    ``find`` and ``coo_matrix`` ``_ivp.common`` imports for sparse Jacobians (not the simulator's)
    and whose ``__init__`` costs 0.2-0.3 s (scipy's array-API layer, which imports numpy.f2py,
    numpy.testing and numpy.ma): ``_ivp.common`` takes stand-ins (:func:`_stand_ins`)."""

    def load():
        integrate = sys.modules["scipy.integrate"]
        if type(integrate) is _DeferredPackage and "ode" not in integrate.__dict__:
            from scipy.integrate._ode import ode  # the one name _ivp.lsoda takes from the package

            integrate.ode = ode
        sparse = sys.modules["scipy.sparse"]
        if type(sparse) is _DeferredPackage and "scipy.integrate._ivp.common" not in sys.modules:
            _stand_ins(sparse, ("find", "coo_matrix"), lambda: importlib.import_module("scipy.integrate._ivp.common"))
        from scipy.integrate._ivp.base import ConstantDenseOutput
        from scipy.integrate._ivp.common import OdeSolution
        from scipy.integrate._ivp.lsoda import LSODA, LsodaDenseOutput

        return LSODA, LsodaDenseOutput, ConstantDenseOutput, OdeSolution

    if PUBLIC:
        return _public_lsoda_classes()
    try:
        return _deferred_import(("scipy.integrate", "scipy.integrate._ivp", "scipy.linalg", "scipy.sparse"), load)
    except Exception:  # noqa: BLE001 - a scipy without these private modules: the public classes
        return _public_lsoda_classes()


def lsoda_routine():
    """The compiled ``lsoda`` of ``scipy.integrate._odepack`` that scipy's LSODA calls per step, or
    None (:data:`PUBLIC`, or missing): :class:`~.ode_solvers.LeanLSODA` then runs scipy's own step."""
    if PUBLIC:
        return None
    try:
        from scipy.integrate import _odepack
    except Exception:  # noqa: BLE001 - another scipy
        return None
    return getattr(_odepack, "lsoda", None)


def lsoda_dense_type():
    """scipy's ``LsodaDenseOutput`` class (the Nordsieck interpolant that :mod:`.dense` evaluates in
    a compiled loop), or None where it is not to be relied on (then ``sol(t)`` is used)."""
    if PUBLIC:
        return None
    try:
        from scipy.integrate._ivp.lsoda import LsodaDenseOutput
    except Exception:  # noqa: BLE001 - another scipy
        return None
    return LsodaDenseOutput


def stiff_internals():
    """``(BDF, Radau, MAX_FACTOR, MAX_ORDER, MIN_FACTOR, NEWTON_MAXITER, compute_R)`` of
    ``scipy.integrate._ivp.bdf`` / ``.radau`` for the lean BDF step (:mod:`.ode_stiff`), or None
    (:data:`PUBLIC`, or a scipy without them): scipy's public ``BDF`` and ``Radau`` are then used."""
    if PUBLIC:
        return None
    try:
        from scipy.integrate._ivp.bdf import BDF, MAX_FACTOR, MAX_ORDER, MIN_FACTOR, NEWTON_MAXITER, compute_R
        from scipy.integrate._ivp.radau import Radau
    except Exception:  # noqa: BLE001 - another scipy
        return None
    return BDF, Radau, MAX_FACTOR, MAX_ORDER, MIN_FACTOR, NEWTON_MAXITER, compute_R


def is_bdf(method) -> bool:
    """Whether ``method`` is scipy's BDF class (solve_ivp's ``alt_segment`` of the dense output),
    without importing it where it is not loaded (then it cannot be ``method``)."""
    for name in ("scipy.integrate._ivp.bdf", "scipy.integrate"):
        module = sys.modules.get(name)
        if module is not None and type(module) is not _DeferredPackage and method is getattr(module, "BDF", None):
            return True
    return False


def _scipy_brentq():
    from scipy.optimize import brentq as scipy_brentq

    return scipy_brentq


def _load_brentq():
    """The compiled Brent routine behind ``scipy.optimize.brentq`` called as that function calls it
    (scipy 1.17: ``_zeros._brentq(f, a, b, xtol, rtol, maxiter, args, full_output, disp)`` with
    ``f`` wrapped to raise ValueError on NaN), checked on a root it must find exactly; scipy's
    ``brentq`` where that differs or fails, or under :data:`PUBLIC`."""
    if PUBLIC:
        return _scipy_brentq()
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
