"""Where the runs of a study execute: in this process, in local processes, or on a Dask cluster.

An executor has one method, ``run(fn, shared, tasks, on_crash=None)``: it calls ``fn(shared, task)``
for every task and yields the results as they complete (in any order); a local worker process that
dies makes its task's result ``on_crash(task, reason)`` (see :meth:`LocalExecutor.run`). ``shared`` (the scenario's texts)
is the same for every task and sent to each worker once where the engine allows it. ``fn`` must
be an importable module-level function (it is sent by name). Stopping the iteration early (an
error, Ctrl-C) cancels the runs not started.

* :class:`SerialExecutor` - one after the other in this process;
* :class:`LocalExecutor` - a :class:`concurrent.futures.ProcessPoolExecutor` (``workers``, default
  :func:`os.cpu_count`), each worker on one BLAS thread. The workers are forked from this process
  where it has the simulator's compiled code loaded already, or can load it in milliseconds (the
  kernels built ahead of time, :mod:`transgen.sim.core.aot`: also a ``transgen sweep`` command's fresh
  process imports the simulator once and forks), and runs no other thread: they start in
  milliseconds with the simulator in their memory. Otherwise (numba would compile or load its
  cache; a Dask client or a Jupyter kernel's threads alive) they are spawned and each imports the
  simulator and loads its compiled code once (why fork is safe then and why spawn otherwise: :func:`_can_fork` and
  ``LocalExecutor._new_pool``; :attr:`LocalExecutor.start_method` says which);
* :class:`DaskExecutor` - a Dask distributed cluster by scheduler address
  (``tcp://HOST:PORT``) or an existing ``distributed.Client``; the optional extra
  ``transgen[distributed]``, imported only here.

Every executor is also a context manager: inside ``with executor:`` the local pool (or the Dask
client) stays open across calls of :meth:`run`, so that a study that runs many small batches one
after the other (an optimizer's generations) starts its workers once.
"""
from __future__ import annotations

import contextlib
import gc
import os
import threading
import time
from collections.abc import Callable, Iterable, Iterator

from transgen.errors import TransgenError

__all__ = ["SerialExecutor", "LocalExecutor", "DaskExecutor", "ClusterError", "make_executor", "DISTRIBUTED_MISSING"]

DISTRIBUTED_MISSING = ("the Dask executor needs dask.distributed, which is not installed: "
                       "pip install 'transgen[distributed]'")


class SerialExecutor:
    """Runs the tasks one after the other in this process."""

    workers = 1

    def run(self, fn: Callable, shared, tasks: Iterable, on_crash: Callable | None = None) -> Iterator:
        for task in tasks:
            yield fn(shared, task)

    def __enter__(self):
        return self

    def __exit__(self, *exc) -> None:
        return None

    def __repr__(self) -> str:
        return "SerialExecutor()"


class LocalExecutor:
    """Runs the tasks in ``workers`` local processes (default: :func:`os.cpu_count`).

    A pool is started by each :meth:`run`, or once for a ``with executor:`` block (kept across the
    sweeps inside it). Its workers are forked from this process where that is both worth it and
    safe (the simulator warm here, one thread, no OpenMP runtime: :func:`_can_fork`), else spawned
    (``start_method`` says which: ``"fork"`` or ``"spawn"``); the numbers are the same."""

    def __init__(self, workers: int | None = None):
        if workers is not None and (isinstance(workers, bool) or not isinstance(workers, int) or workers < 1):
            raise ValueError(f"--workers: error: the number of workers is a whole number >= 1, not {workers!r}")
        self.workers = workers or os.cpu_count() or 1
        #: how the workers of the last pool started: ``"fork"`` or ``"spawn"`` (None before the first pool)
        self.start_method: str | None = None
        self._pool = None

    def _new_pool(self):
        import multiprocessing
        from concurrent.futures import ProcessPoolExecutor

        # fork where this process has the simulator warm and nothing makes fork unsafe (_can_fork
        # says why it is safe then): the workers are ready in milliseconds with the compiled code
        # in their memory, instead of ~0.6 s CPU each. Else spawn: not fork, since threads of the
        # parent (a Dask client's, a Jupyter kernel's) may hold locks a forked child never sees
        # released; not forkserver, since Python 3.11's fork server ignores the parent's sys.path
        # and imports from its working directory first, so a folder named transgen there (a
        # source checkout) shadows the installed package
        if _can_fork():
            _preload()  # once here, not in every child
            # the objects alive now out of the collector's walks (as Python's gc docs advise
            # before a fork): a child's collections would otherwise write to every page holding
            # one and copy it (0.05-0.1 s CPU of a worker's first run here)
            gc.collect()
            gc.freeze()
            self.start_method = "fork"
        else:
            self.start_method = "spawn"
            _end_tracker_at_exit()
        return ProcessPoolExecutor(max_workers=self.workers, mp_context=multiprocessing.get_context(self.start_method),
                                   initializer=_worker_start, initargs=(os.getpid(), self.start_method == "spawn"))

    def __enter__(self):
        """Start the workers now (spawned ones import the simulator while the caller goes on, e.g.
        while :func:`~.runner.sweep` checks the design), not at the first :meth:`run`."""
        if self._pool is None:
            self._pool = self._new_pool()
            # with spawn a pool starts a worker per submitted call; with fork it forks them all
            # at the first (before its manager thread starts: this process has one thread then)
            for _ in range(self.workers):
                self._pool.submit(os.getpid)
        return self

    def __exit__(self, exc_type=None, *exc) -> None:
        """Stop the workers: the runs not started are cancelled; the workers exit in the
        background (spawned ones in 0.1-0.2 s each, forked ones in milliseconds; not waited for
        here, but before a later pool forks, and Python joins them at its exit), at once
        where the block ends with an error (a bad design found while they were starting, Ctrl-C)."""
        pool, self._pool = self._pool, None
        if pool is None:
            return
        if exc_type is not None:  # not worth finishing their start or their run
            _terminate_workers(pool)
        _stop(pool)

    def opened(self):
        """Context manager: the pool open inside; started at its beginning and stopped at its end
        (as ``with executor:``) unless it is open already (then left open)."""
        return contextlib.nullcontext(self) if self._pool is not None else self

    def run(self, fn: Callable, shared, tasks: Iterable, on_crash: Callable | None = None) -> Iterator:
        """Yield ``fn(shared, task)`` for every task as they complete. A worker process that dies
        (killed, out of memory) breaks the pool: a new one takes the unfinished tasks, and those
        that may have run in the dead worker (the first ``workers + 1`` unfinished ones: the pool
        hands the tasks out in order) run again, each alone, so that the one that kills its worker
        is known; with ``on_crash`` its result is ``on_crash(task, reason)`` (a failed row; the
        others go on), without it a :class:`ClusterError`. Stopping the iteration early (an
        error, Ctrl-C, SIGTERM) terminates the workers of a pool of this call at once."""
        from concurrent.futures import FIRST_COMPLETED, wait

        from concurrent.futures.process import BrokenProcessPool

        kept = self._pool is not None
        pool = self._pool if kept else self._new_pool()
        todo = dict(enumerate(tasks))  # order -> task, not finished yet
        suspects: list = []  # orders of tasks that may have killed a worker: each runs alone once more
        finished = False
        pending: dict = {}
        try:
            while todo:
                if suspects:  # alone in the pool: a death now is this task's
                    order = suspects.pop(0)
                    future = pool.submit(fn, shared, todo[order])
                    processes = _workers_of(pool)
                    try:
                        result = future.result()
                    except BrokenProcessPool:
                        reason = (f"the worker process running it died ({_death_reason(processes)}), also when "
                                  f"run again alone")
                        if on_crash is None:
                            raise ClusterError(f"a local worker process died: {reason}; the rows finished so far "
                                               f"are kept: run the sweep again to resume") from None
                        pool = self._replace(pool, kept)
                        result = on_crash(todo[order], reason)
                    del todo[order]
                    yield result
                    continue
                pending = {pool.submit(fn, shared, task): order for order, task in todo.items()}
                broken = False
                while pending and not broken:
                    done, _ = wait(pending, return_when=FIRST_COMPLETED)
                    if any(isinstance(f.exception(), BrokenProcessPool) for f in done):
                        broken = True  # the results that arrived before the death are still taken
                        done = [f for f in pending if f.done() and not isinstance(f.exception(), BrokenProcessPool)]
                    for future in sorted(done, key=pending.get):
                        order = pending.pop(future)
                        result = future.result()
                        del todo[order]
                        yield result
                if broken:  # a new pool for the unfinished tasks; the first ones (those that may have run) alone
                    pending = {}
                    suspects = sorted(todo)[:self.workers + 1]
                    pool = self._replace(pool, kept)
            finished = True
        finally:
            for future in pending:
                future.cancel()
            if not finished:  # stopped early: not worth finishing their runs
                _terminate_workers(pool)
            if not kept:  # the finished workers exit in the background (as in __exit__)
                _stop(pool)

    def _replace(self, pool, kept: bool):
        """A new pool in place of the broken ``pool`` (kept open as ``pool`` was)."""
        _stop(pool)
        new = self._new_pool()
        if kept:
            self._pool = new
        return new

    def __repr__(self) -> str:
        return f"LocalExecutor(workers={self.workers})"


class DaskExecutor:
    """Runs the tasks on a Dask distributed cluster: give the scheduler's ``address``
    (``tcp://HOST:PORT``; a client is opened and closed for each :meth:`run`) or a ``client``.

    The workers need transgen installed (the same version: the numbers come from their copy of
    the simulator); they get the scenario's texts (scattered once to every worker) and the
    overrides of each run."""

    def __init__(self, address: str | None = None, client=None):
        if (address is None) == (client is None):
            raise ValueError("DaskExecutor: give the scheduler address or a distributed.Client (one of them)")
        if address is not None:
            _check_address(address)
        self.address, self.client = address, client
        self._opened = False
        _distributed()  # a missing extra is an error before anything runs

    def __enter__(self):
        if self.client is None:
            try:
                self.client = _distributed().Client(self.address, timeout="20s")
            except (OSError, TimeoutError) as exc:
                raise ClusterError(f"cannot reach the Dask scheduler at {self.address}: {exc}") from None
            self._opened = True
        return self

    def __exit__(self, *exc) -> None:
        if self._opened:
            client, self.client, self._opened = self.client, None, False
            client.close()

    @property
    def workers(self) -> int:
        client = self.client
        return len(client.scheduler_info().get("workers", {})) if client is not None else 0

    def run(self, fn: Callable, shared, tasks: Iterable, on_crash: Callable | None = None) -> Iterator:
        """As :meth:`LocalExecutor.run`; the cluster retries the tasks of a dead worker itself
        (``on_crash`` is not used)."""
        distributed = _distributed()
        if self.client is not None:
            client = self.client
        else:
            try:
                client = distributed.Client(self.address, timeout="20s")
            except (OSError, TimeoutError) as exc:
                raise ClusterError(f"cannot reach the Dask scheduler at {self.address}: {exc}") from None
        try:
            _check_environment(client, self.address or repr(client))
            client.run(_stop_profiler)
            client.run(_warm_up)
            [shared_future] = client.scatter([shared], broadcast=True, hash=False)
            futures = [client.submit(fn, shared_future, task, pure=False) for task in tasks]
            try:
                for future in distributed.as_completed(futures):
                    try:
                        row = future.result()
                    except Exception as exc:  # the task function itself never raises: the cluster failed
                        first = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
                        raise ClusterError(f"the Dask cluster at {self.address or client!r} failed to run a task: "
                                           f"{first}") from None
                    yield row
            finally:
                client.cancel(futures)
        finally:
            if self.client is None:
                client.close()

    def __repr__(self) -> str:
        return f"DaskExecutor({self.address or self.client!r})"


def _check_address(address: str) -> None:
    """A scheduler address this executor can connect to: ``tcp://HOST:PORT`` (or ``HOST:PORT``).
    A ``tls://`` scheduler needs certificates (a ``distributed.Security``), which an address
    alone cannot give: ValueError saying how to connect (exit 2), before anything runs."""
    scheme, sep, rest = address.partition("://")
    if not sep:
        scheme, rest = "tcp", address
    if scheme == "tls":
        raise ValueError(f"--scheduler {address}: error: a TLS scheduler needs its certificates, which an "
                         f"address cannot carry: connect from Python with "
                         f"DaskExecutor(client=distributed.Client('{address}', security=...)), or give a tcp:// address")
    if scheme != "tcp":
        raise ValueError(f"--scheduler {address}: error: unknown protocol '{scheme}://': give tcp://HOST:PORT")
    host, colon, port = rest.rpartition(":")
    if not colon or not host or not port.isdigit() or not 0 < int(port) < 65536:
        raise ValueError(f"--scheduler {address}: error: expected tcp://HOST:PORT with a port from 1 to 65535")


class ClusterError(TransgenError, RuntimeError):
    """A Dask cluster that cannot run the sweep (unreachable, or without the same transgen)."""


def _check_environment(client, where: str) -> None:
    """The scheduler and every worker have this transgen installed (the scheduler unpickles the
    task graph, the workers run the simulator): otherwise a :class:`ClusterError` saying how to
    start them, before any task is sent."""
    from importlib.metadata import version

    from transgen import __version__

    hint = (f"start 'python -m dask scheduler' and 'python -m dask worker ...' with a Python that has "
            f"transgen {__version__} installed")
    try:
        found = {"scheduler": client.run_on_scheduler(version, "transgen")}
        found.update(client.run(version, "transgen"))
    except Exception as exc:
        raise ClusterError(f"the Dask cluster at {where} has no transgen: {type(exc).__name__}: {exc}; {hint}") from None
    wrong = {k: v for k, v in found.items() if v != __version__}
    if wrong:
        raise ClusterError(f"the Dask cluster at {where} runs another transgen ("
                           f"{', '.join(f'{k}: {v}' for k, v in sorted(wrong.items()))}); {hint}")


def _warm_up() -> None:
    """On a Dask worker: the simulator's compiled code loaded before the tasks (the local pool's
    workers load it when they start; a no-op where it is loaded already)."""
    from .task import warm_up

    warm_up()


def _stop_profiler(dask_worker) -> None:
    """On a Dask worker: stop its statistical profiler, which samples the running task's stack
    every 10 ms (distributed.worker.profile) and made a simulation 32 % slower than in the local
    pool (1 % without; benchmarks/bench_sweep.py). A sweep's tasks are all the same function;
    their profile shows nothing the study needs."""
    for name in ("profile", "profile-cycle"):
        callback = dask_worker.periodic_callbacks.pop(name, None)
        if callback is not None:
            callback.stop()


_TRACKER_HOOK = False  # the exit hook of the resource tracker registered (see _end_tracker_at_exit)


def _end_tracker_at_exit() -> None:
    """Once per process: at the interpreter's exit, after the pools' workers have been joined and
    the semaphores released, end multiprocessing's resource tracker (a process spawned pools
    start, which exits once every process holding its pipe has closed it) and wait for it (2 s
    at most), so that it does not outlive the command."""
    global _TRACKER_HOOK
    if not _TRACKER_HOOK:
        from multiprocessing import util

        _TRACKER_HOOK = True
        util.Finalize(None, _end_tracker, exitpriority=-100)  # after the semaphores' finalizers (priority 0)


def _end_tracker() -> None:
    from multiprocessing import resource_tracker

    tracker = resource_tracker._resource_tracker
    fd, pid = getattr(tracker, "_fd", None), getattr(tracker, "_pid", None)
    if fd is None or pid is None:
        return
    with contextlib.suppress(OSError):
        os.close(fd)
    tracker._fd = None
    end = time.monotonic() + 2.0
    with contextlib.suppress(OSError):
        while os.waitpid(pid, os.WNOHANG)[0] == 0 and time.monotonic() < end:
            time.sleep(0.01)
    tracker._pid = None


def _workers_of(pool) -> list:
    """The worker processes of a local pool (3.11 has no public way)."""
    return list((getattr(pool, "_processes", None) or {}).values())


_QUIET_MANAGERS = [False]


def _quiet_pool_managers() -> None:
    """Silence the exception a pool's manager thread raises while the workers it manages are
    being terminated on purpose (CPython 3.11: ``terminate_broken`` on the closing call queue,
    printed as a traceback when SIGTERM stops a sweep); every other thread's exception is shown."""
    if _QUIET_MANAGERS[0]:
        return
    _QUIET_MANAGERS[0] = True
    previous = threading.excepthook

    def hook(args) -> None:
        if type(args.thread).__module__ != "concurrent.futures.process":
            previous(args)
    threading.excepthook = hook


def _terminate_workers(pool) -> None:
    """SIGTERM to the workers of a local pool (they exit at once: a worker's SIGTERM is the default)."""
    _quiet_pool_managers()
    for process in _workers_of(pool):
        with contextlib.suppress(OSError, AttributeError, ValueError):
            process.terminate()


def _death_reason(processes) -> str:
    """How the worker that broke a pool ended (the others were terminated by the pool)."""
    import signal

    end = time.monotonic() + 1.0  # the pool's thread may be reaping it right now
    while not (codes := [p.exitcode for p in processes if p.exitcode not in (None, 0, -signal.SIGTERM)]) \
            and time.monotonic() < end:
        time.sleep(0.02)
    if not codes:
        return "killed"
    code = codes[0]
    if code < 0:
        name = signal.Signals(-code).name if -code in signal.Signals._value2member_map_ else f"signal {-code}"
        return f"killed by {name}" + (" (kill -9, or the out-of-memory killer)" if -code == signal.SIGKILL else "")
    return f"exit code {code}"


_STOPPING: list = []  # the manager threads of the pools stopped and not yet found ended (see _stop)
_EXIT_HOOK = False  # the exit hook registered (see _wait_at_exit)


def _stop(pool) -> None:
    """Stop a local pool without waiting: the runs not started are cancelled, its workers exit in
    the background, and its manager thread (which joins them) is noted for :func:`_can_fork`."""
    thread = getattr(pool, "_executor_manager_thread", None)  # None where no task was submitted (and after shutdown)
    pool.shutdown(wait=False, cancel_futures=True)
    if thread is not None:
        _STOPPING.append(thread)
        _wait_at_exit()


def _wait_at_exit() -> None:
    """Once per process: at the interpreter's exit, wait (5 s at most) for the pools stopped here
    before concurrent.futures' own exit hook wakes their manager threads. That hook writes to a
    thread's wake-up pipe unlocked while the ending thread closes it (CPython 3.11), which now and
    then printed ``OSError: [Errno 9] Bad file descriptor`` when a script ended just after a
    sweep; once the threads have ended it finds the pipes closed and writes nothing. threading's
    exit hooks run last registered first, and concurrent.futures registered its hook when it was
    imported, before any pool of ours stopped."""
    global _EXIT_HOOK
    import threading

    register = getattr(threading, "_register_atexit", None)  # CPython's, as concurrent.futures uses it
    if not _EXIT_HOOK and register is not None:
        _EXIT_HOOK = True
        register(_stopped, 5.0)


def _stopped(timeout: float) -> bool:
    """Whether the manager threads of the pools stopped here have ended, waiting up to ``timeout``
    [s] in all: the thread of a pool stopped after its runs ends once its workers have exited
    (measured 4-12 ms for forked workers, about 50 ms for spawned ones); that of a pool stopped
    during runs only when they finish."""
    end = time.monotonic() + timeout
    for thread in list(_STOPPING):
        thread.join(max(0.0, end - time.monotonic()))
        if not thread.is_alive():
            _STOPPING.remove(thread)
    return not _STOPPING


def _can_fork() -> bool:
    """Whether a local pool's workers can be forked from this process: the platform has fork, the
    workers need no numba compiled code this process has not loaded (:func:`_forking_pays`), only
    the main thread runs and no OpenMP runtime is loaded.

    Fork copies the memory of this process but only the thread that calls it, so it is safe where
    no other thread can hold a lock or run a pool the child would need: the only Python thread is
    the main one (the pool forks its workers before it starts its own manager thread); OpenBLAS
    (numpy's and scipy's, pthreads) stops its thread pool around a fork with pthread_atfork
    handlers and the child starts its own; numba runs no threads of its own (the simulator's code
    is compiled without ``parallel=True``). An OpenMP runtime (GNU libgomp: a child that uses the
    parent's thread pool hangs) may come with an MKL or OpenMP build of the BLAS or numba's
    parallel code: then spawn."""
    import multiprocessing
    import threading

    if not _forking_pays() or "fork" not in multiprocessing.get_all_start_methods():
        return False
    # the previous pool's thread outlives it briefly: a script's next sweep would spawn without this
    if not _stopped(timeout=0.5) or threading.active_count() != 1:
        return False
    from threadpoolctl import threadpool_info

    return not any(library.get("user_api") == "openmp" for library in threadpool_info())


def _forking_pays() -> bool:
    """Whether workers forked from this process start with what they need: the compiled code is
    loaded here (:func:`~transgen.sim.core.jit.compiled_loaded`), or the runs need none that takes time
    to load: the kernels built ahead of time are there (:func:`~transgen.sim.core.aot.kernels`: this
    process loads them in milliseconds with the imports, :func:`_preload`) or ``TRANSGEN_JIT=0``.
    Otherwise (numba would compile or load its cache) each spawned worker loads it in parallel,
    which a fork from this cold process would not save."""
    from transgen.sim.core import aot
    from transgen.sim.core.jit import compiled_loaded

    return compiled_loaded() or os.environ.get("TRANSGEN_JIT") == "0" or aot.kernels() is not None


def _preload() -> None:
    """The modules a worker needs (:data:`~.task.PRELOAD`) imported and the kernels built ahead
    of time loaded (where they are)."""
    import importlib

    from transgen.sim.core import aot
    from .task import PRELOAD

    for name in PRELOAD:
        importlib.import_module(name)
    aot.kernels()


def _worker_start(parent: int, spawned: bool) -> None:
    """A local worker's start: it ends with its parent (:func:`_die_with_parent`), leaves Ctrl-C
    to the parent (which stops the pool) and ends at SIGTERM; then one BLAS thread and, for a
    spawned worker, the simulator loaded (:func:`_start_worker`)."""
    import signal

    signal.signal(signal.SIGINT, signal.SIG_IGN)  # the terminal's Ctrl-C reaches the whole group: the parent decides
    for signum in (signal.SIGTERM, signal.SIGHUP):  # not the command line's handlers a forked worker inherits
        signal.signal(signum, signal.SIG_DFL)
    _die_with_parent(parent)
    if spawned:
        _start_worker()
    else:
        _one_blas_thread()


def _die_with_parent(parent: int) -> None:
    """Make this worker process end when ``parent`` (the process that started the pool) ends,
    however it ends (SIGKILL included): on Linux the kernel sends SIGKILL at the parent's death
    (``prctl(PR_SET_PDEATHSIG)``); everywhere a thread watches the pipe multiprocessing keeps
    open from the parent (it reads end-of-file when the parent is gone) and exits. Without this
    the workers of a killed sweep stayed idle for ever (issue 22)."""
    import multiprocessing
    import signal
    import sys
    import threading

    if sys.platform.startswith("linux"):
        with contextlib.suppress(OSError, AttributeError):
            import ctypes

            libc = ctypes.CDLL(None, use_errno=True)
            libc.prctl(1, signal.SIGKILL, 0, 0, 0)  # PR_SET_PDEATHSIG = 1
    if os.getppid() != parent:  # the parent died before the line above
        os._exit(1)
    sentinel = getattr(multiprocessing.parent_process(), "sentinel", None)
    if sentinel is None:
        return

    def watch() -> None:
        from multiprocessing.connection import wait

        wait([sentinel])  # readable at the parent's death (end of file)
        os._exit(1)

    threading.Thread(target=watch, name="transgen-parent-watch", daemon=True).start()


def _start_worker() -> None:
    """Spawned local worker's start: one BLAS thread, the simulator imported and its compiled
    code loaded once per process."""
    from transgen.blas import one_thread_from_start

    from .task import warm_up

    one_thread_from_start()  # numpy not loaded yet: its BLAS, and scipy's, start with one thread
    _one_blas_thread()
    _preload()
    warm_up()


def _one_blas_thread() -> None:
    """Worker start (a forked worker's whole start: the simulator is in its memory already): one
    BLAS thread (the pool has one process per core; a BLAS pool per process would oversubscribe
    the cores, as Dask's nanny also prevents with OPENBLAS_NUM_THREADS=1).
    threadpoolctl where it is installed, else the BLAS keeps its setting."""
    try:
        from threadpoolctl import threadpool_limits
    except ImportError:  # pragma: no cover - threadpoolctl is optional here
        return
    threadpool_limits(1)


def _distributed():
    try:
        import distributed
    except ImportError as exc:
        raise ImportError(DISTRIBUTED_MISSING) from exc
    return distributed


def make_executor(workers: int | None = None, scheduler: str | None = None):
    """The executor of the command line's options: ``scheduler`` (a Dask address) or ``workers``
    local processes (1: serially in this process; None: one per core)."""
    if scheduler is not None:
        if workers is not None:
            raise ValueError("--workers and --scheduler: error: choose one (the cluster's workers run the tasks)")
        return DaskExecutor(scheduler)
    if workers == 1:
        return SerialExecutor()
    return LocalExecutor(workers)
