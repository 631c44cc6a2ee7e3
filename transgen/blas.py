"""Small dense linear algebra on one BLAS thread.

The matrices of the mode generator and of the simulator are a few rows wide; a multi-threaded
BLAS (OpenBLAS, MKL) hands such a solve to its thread pool, whose start-up and spinning cost more
than the arithmetic, and on a loaded machine (other processes on the other cores) the threads wait
for a core: small solves then run 1.7-2x slower (``benchmarks/bench_blas_threads.py``).
:func:`single_threaded` limits the BLAS to one thread for the duration of a run (with
``threadpoolctl``), where a run starts, not at import: a program that imports transgen keeps its
own BLAS settings outside transgen's calls, and they are restored when the run ends.

A process that starts with transgen's command line goes further (:func:`one_thread_from_start`):
its BLAS starts with one thread, so OpenBLAS does not start a thread pool when numpy is imported,
which cost a numeric command 40-60 ms of its 0.25-0.3 s on a loaded 2-core machine.
"""
from __future__ import annotations

import contextlib
import functools
import os
import sys

__all__ = ["single_threaded", "limit_loaded", "one_blas_thread", "one_thread_from_start", "BLAS_THREAD_VARIABLES"]

BLAS_THREAD_VARIABLES = ("OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS")
"""The environment variables that set a BLAS library's threads when it is loaded."""


def one_thread_from_start() -> None:
    """Before numpy is imported: the BLAS libraries will start with one thread (each variable of
    :data:`BLAS_THREAD_VARIABLES` the user has not set is set to 1, and child processes inherit
    it). Nothing once numpy is loaded (a program that calls the command line in-process keeps its
    BLAS as it is)."""
    if "numpy" in sys.modules:
        return
    for name in BLAS_THREAD_VARIABLES:
        os.environ.setdefault(name, "1")


def single_threaded(*preload: str):
    """Context manager: the BLAS libraries loaded in this process use one thread inside it (the
    previous limits are restored on exit; nested use is harmless). A library loaded later is
    limited where :func:`limit_loaded` is called after its import (the simulator does before each
    integration segment); ``preload`` names modules to import first (``"scipy.linalg"``: scipy
    has a BLAS of its own), except where every variable of :data:`BLAS_THREAD_VARIABLES` is 1
    (the command line, a sweep's worker): a library loaded later starts with one thread, and a
    run that does not need it does not import it (scipy.linalg costs a worker 0.05 s)."""
    import importlib

    if not all(os.environ.get(name) == "1" for name in BLAS_THREAD_VARIABLES):
        for name in preload:
            importlib.import_module(name)
    return _Limits()


class _Limits(contextlib.ExitStack):
    """The limits of one :func:`single_threaded`: the first set when it is made, those of
    :func:`limit_loaded` after; undone in the reverse order on exit."""

    def __init__(self):
        super().__init__()
        self.enter_context(_controller().limit(limits=1, user_api="blas"))
        self.modules = len(sys.modules)
        _ACTIVE.append(self)

    def __exit__(self, *exc):
        with contextlib.suppress(ValueError):
            _ACTIVE.remove(self)
        return super().__exit__(*exc)


_ACTIVE: list = []  # the single_threaded limits in force


def limit_loaded() -> None:
    """Inside :func:`single_threaded`: limit to one thread the BLAS libraries loaded since it
    began or since the last call (a module that brings one was imported: e.g. scipy.linalg by
    the stiff solvers); nothing where no module was imported since (a comparison of counts)."""
    if _ACTIVE and _ACTIVE[-1].modules != len(sys.modules):
        limits = _ACTIVE[-1]
        limits.modules = len(sys.modules)
        limits.enter_context(_controller().limit(limits=1, user_api="blas"))


_CONTROLLER: list = []  # [(number of modules loaded when scanned, threadpoolctl.ThreadpoolController)]


def _controller():
    """The BLAS libraries of this process (a ``threadpoolctl.ThreadpoolController``), found once
    and again only after modules were imported since (a BLAS comes with an extension module): the
    search reads the process's loaded libraries, 0.6 ms per call in a simulator process, which
    every run (an optimizer's candidate costs about 40 ms) would otherwise pay."""
    from threadpoolctl import ThreadpoolController  # here: start-up time of the command line

    if not _CONTROLLER or _CONTROLLER[0][0] != len(sys.modules):
        _CONTROLLER[:] = [(len(sys.modules), ThreadpoolController())]
    return _CONTROLLER[0][1]


def one_blas_thread(*preload: str):
    """Decorator: the function runs inside :func:`single_threaded` (``preload`` as there);
    ``func.__wrapped__`` is the undecorated function (the benchmark's multi-threaded comparison)."""

    def decorate(func):
        @functools.wraps(func)
        def run(*args, **kwargs):
            with single_threaded(*preload):
                return func(*args, **kwargs)

        return run

    return decorate
