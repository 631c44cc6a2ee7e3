"""One implementation of the scalar physics for both paths of the simulator's right-hand side.

The formulas of the right-hand side (table look-ups, signal values, a torque converter's torques,
a driveline's rates, a shift element's torque and holding margin, ...) are plain Python functions
marked :func:`compilable`. The Python classes (:mod:`.components`, :mod:`.signals`,
:mod:`.transmission`, ...) call them as they are; :mod:`.kernel` calls them compiled
(:func:`compiled`): built ahead of time into an extension module (:mod:`.aot`, loaded in
milliseconds), or by numba just in time. :func:`jit_enabled` is the one rule for which path a
run takes: compile only where many runs pay for it. Reading a scenario or a command that does not
simulate never loads either.

A compilable function is written in the subset of Python that numba compiles: scalars, and
sequences indexed by position (tuples in the Python path, float64 arrays in the compiled one). The
few library calls numba does not know have compiled stand-ins (:data:`_STAND_INS`: a binary
search for ``bisect``, ``numpy.spacing`` for ``math.ulp``), which give the same numbers.
"""
from __future__ import annotations

import gc
import hashlib
import math
import os
import sys
import types
from bisect import bisect_left, bisect_right

__all__ = ["compilable", "compiled_as", "compiled", "jit_enabled", "compiled_loop", "settle_after_loading",
           "compiled_loaded", "expect_many_runs", "numba_clone"]

_COMPILABLE: set = set()
_COMPILED: dict = {}
_REPLACED: dict = {}  # Python function -> the compilable function compiled code calls instead


def compilable(func):
    """Mark ``func`` (a plain function in numba's subset, see the module docstring) as compiled
    by :func:`compiled` when a compiled right-hand side calls it; returned unchanged."""
    _COMPILABLE.add(func)
    return func


def compiled_as(replacement):
    """Decorator: compiled code calls ``replacement`` (compilable, or a built-in numba knows) where Python calls
    the decorated one (a helper that also takes arrays in Python, e.g. ``np.tanh`` for arrays and
    ``math.tanh`` for numbers, whose compiled form takes numbers only)."""
    def mark(func):
        _REPLACED[func] = replacement  # a compilable function, or a built-in numba compiles
        return func
    return mark


def jit_enabled() -> bool:
    """Whether this run of the simulator uses its compiled right-hand side; one rule, decided once
    per process (the runs of a process give the same numbers):

    * ``TRANSGEN_JIT=0``: never (the Python path alone, e.g. to compare the two);
    * the kernels built ahead of time are there (:func:`.aot.kernels`: they load in milliseconds):
      always;
    * else, where many runs will pay for a compilation (:func:`expect_many_runs`: a sweep, an
      optimization, a study's worker): build them now (:func:`.aot.build`, 30-60 s once per
      install), or, without a C compiler, compile with numba just in time;
    * else (one run after an install): not; this run goes on in Python, while a detached process
      builds the kernels for the next ones (:func:`.aot.build_in_background`).
    """
    setting = os.environ.get("TRANSGEN_JIT", "1")
    if setting == "0":
        return False
    key = ("enabled", setting, bool(_COMPILED.get("many")))
    if key not in _COMPILED:
        _COMPILED[key] = _decide()
    return _COMPILED[key]


def _decide() -> bool:
    from . import aot

    if aot.kernels() is not None:
        return True
    try:
        import numba  # noqa: F401  (~0.3 s: only a compiled simulation needs it)
    except ImportError:
        return False
    if not _COMPILED.get("many"):
        aot.build_in_background()
        return False
    aot.build(numba_clone, wait=True)  # None without a C compiler: numba compiles just in time then
    return True


def expect_many_runs() -> None:
    """Say that this process will simulate many times (a sweep, an optimization, a worker of a
    study): from now on :func:`jit_enabled` compiles where the kernels are not built yet."""
    _COMPILED["many"] = True


def compiled_loop(func, n: int):
    """The compiled form of the compilable loop ``func`` when a compiled simulation is under way
    (:func:`jit_enabled`, its kernels loaded) and its ``n`` points are worth a call (output
    sampling); None otherwise (the caller runs ``func`` in Python: e.g. reading a scenario,
    which samples one point to learn the signal names, never loads a compiled kernel)."""
    if n >= 16 and compiled_loaded() and jit_enabled():
        return compiled(func)
    return None


def settle_after_loading() -> None:
    """Once per process, after the compiled kernels are loaded: where numba is loaded, move the
    objects that exist then (numba's and llvmlite's ~75,000, the modules') out of the cyclic
    garbage collector's view (``gc.freeze``). They live as long as the process; without this every
    full collection walks them, about 60 ms each on the simulator's runs, a tenth of a 20-s run's
    time on average. Objects alive now that die later are still freed by reference counting; only
    their cycles wait (``gc.unfreeze`` undoes it). The kernels built ahead of time bring no such
    objects: nothing to move then."""
    if not _COMPILED.get("settled"):
        _COMPILED["settled"] = True
        if "numba" in sys.modules:
            gc.collect()
            gc.freeze()


def compiled_loaded() -> bool:
    """Whether this process has the simulator's compiled right-hand side loaded (a compiled run
    was set up here, :func:`settle_after_loading` ran): what a local worker's warm-up
    (:func:`~.study.task.warm_up`) loads, so that a process forked from this one need not."""
    return bool(_COMPILED.get("settled"))


def _sources_digest() -> str:
    """A digest of the source files of the compilable functions and of this module."""
    if "digest" not in _COMPILED:
        files = sorted({f.__code__.co_filename for f in _COMPILABLE if hasattr(f, "__code__")} | {__file__})
        h = hashlib.sha1()
        for name in files:
            with open(name, "rb") as fh:
                h.update(fh.read())
        _COMPILED["digest"] = h.hexdigest()[:12]
    return _COMPILED["digest"]


def _stand_ins() -> dict:
    """Compiled stand-ins for the library functions compilable code calls (same results)."""
    import numba
    import numpy as np

    @numba.njit(cache=True)
    def search_right(xs, x):
        return np.searchsorted(xs, x, side="right")

    @numba.njit(cache=True)
    def search_left(xs, x):
        return np.searchsorted(xs, x, side="left")

    @numba.njit(cache=True)
    def ulp(x):
        return np.spacing(abs(x))

    return {bisect_right: search_right, bisect_left: search_left, math.ulp: ulp}


def numba_clone(func):
    """A copy of the compilable function ``func`` whose globals name the numba-compiled forms of
    the compilable functions it calls (and the library stand-ins): what numba compiles, just in
    time (:func:`compiled`) or ahead of time (:mod:`.aot`)."""
    import numba  # noqa: F401  (the stand-ins and the callees are numba dispatchers)

    if "stand-ins" not in _COMPILED:
        _COMPILED["stand-ins"] = _stand_ins()
    stand_ins = _COMPILED["stand-ins"]
    namespace = dict(func.__globals__)
    for name in func.__code__.co_names:
        value = namespace.get(name)
        try:
            if value in _REPLACED:
                namespace[name] = _jitted(_REPLACED[value])
            elif value in _COMPILABLE:
                namespace[name] = _jitted(value)
            elif value in stand_ins:
                namespace[name] = stand_ins[value]
        except TypeError:  # unhashable globals are no functions
            pass
    clone = types.FunctionType(func.__code__, namespace, func.__name__, func.__defaults__, func.__closure__)
    # numba keys its disk cache by the function's own file; the digest of every file of compilable
    # code in the name makes an edit of a function it calls (in another file) compile afresh
    clone.__qualname__ = f"{func.__qualname__}_{_sources_digest()}"
    clone.__module__, clone.__doc__ = func.__module__, func.__doc__
    return clone


def _jitted(func):
    """``func`` compiled by numba just in time (``cache=True``: its machine code kept on disk)."""
    done = _COMPILED.get(func)
    if done is not None:
        return done
    if not hasattr(func, "__code__"):  # a built-in numba knows (math.tanh, ...)
        return func
    import numba

    done = _COMPILED[func] = numba.njit(cache=True)(numba_clone(func))
    return done


def compiled(func):
    """The compiled form of the compilable function ``func``: from the kernels built ahead of time
    (:func:`.aot.kernels`, loaded in milliseconds) where they export it, else compiled by numba
    (``cache=True``: compiled machine code is kept on disk, a second process loads it). The
    compilable functions it calls are compiled too and called compiled; so are the library
    stand-ins."""
    from . import aot

    name = getattr(func, "__name__", "")
    if name in aot.EXPORTS and func.__module__ == f"transgen.sim.{aot.EXPORTS[name][0]}":
        module = aot.kernels()
        if module is not None:
            return getattr(module, name)
    return _jitted(func)
