"""The engine's numerical core compiled with numba: :func:`kernels`.

:mod:`~transgen.sim.engine.kernels` holds every formula of an engine evaluation in the subset of
Python numba compiles; this module compiles all of them (``numba.njit(cache=True)``: the machine
code is kept on disk next to the source, so only the first run after an edit compiles) and gives
them back as a namespace with the same names. numba is imported here, on the first call, never
at import: reading a scenario or drawing a map needs no compiler (numba's import costs about
0.3 s). Why numba: one evaluation of the turbodiesel is a few hundred scalar operations and two
small fixed-point/secant iterations; run by the interpreter they cost 30-100 us, compiled about
a microsecond, which is most of the simulator's time in the turbodiesel scenarios.

Without numba (a platform it has no wheels for) the functions of ``kernels`` are used as they are,
with a warning. A compiled function calls compiled functions only: each function of ``kernels`` is compiled from
a copy whose globals name the compiled versions of the others (``kernels`` itself stays pure
Python, the reference of tests/test_sim_engine_kernels.py).
"""
from __future__ import annotations

import types
import warnings

from . import kernels as _plain

__all__ = ["kernels"]

_COMPILED: types.SimpleNamespace | None = None


def kernels() -> types.SimpleNamespace:
    """The compiled functions of :mod:`~transgen.sim.engine.kernels` (``COMPILED``), by name."""
    global _COMPILED
    if _COMPILED is None:
        try:
            import numba
        except ImportError:  # a platform without numba's wheels: correct, several times slower
            warnings.warn("numba is not installed: the turbodiesel model runs in the interpreter, several "
                          "times slower (pip install numba)", RuntimeWarning, stacklevel=2)
            _COMPILED = types.SimpleNamespace(**{name: getattr(_plain, name) for name in _plain.COMPILED})
            return _COMPILED
        namespace = dict(vars(_plain))
        for name in _plain.COMPILED:
            f = getattr(_plain, name)
            copy = types.FunctionType(f.__code__, namespace, name, f.__defaults__, f.__closure__)
            copy.__qualname__, copy.__module__, copy.__doc__ = f.__qualname__, f.__module__, f.__doc__
            namespace[name] = numba.njit(cache=True)(copy)
        _COMPILED = types.SimpleNamespace(**{name: namespace[name] for name in _plain.COMPILED})
    return _COMPILED
