"""The simulator's compiled kernels built ahead of time into an extension module (numba's ``pycc``).

A numba-compiled kernel costs its process numba's import and the loading of its machine code
(about 0.7 s on a 2-core machine, five times a 20-s run of ``ht740_improved``) and, after an
install, 20-30 s of compilation. The same functions (:data:`EXPORTS`, the :func:`~.jit.compilable`
kernels of :mod:`.kernel` and the output-sampling loops), built once into an ordinary extension
module, load in milliseconds without numba: :func:`kernels` finds that module, :func:`build`
makes it (numba and a C compiler needed then only), :func:`build_in_background` makes it in a
detached process while a first run goes on in Python (:mod:`.jit` says when which is used).

The module's name carries a digest of the sources it was compiled from (an edit builds a new
one); it is kept in the package's ``__pycache__`` where that is writable, else in the user's
cache folder (``$XDG_CACHE_HOME/transgen`` or ``~/.cache/transgen``), or where
``TRANSGEN_KERNEL_CACHE`` says. ``python -m transgen.sim.core.build_kernels`` builds it in the foreground.
"""
from __future__ import annotations

import contextlib
import hashlib
import importlib.machinery
import importlib.util
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

__all__ = ["EXPORTS", "kernels", "build", "build_in_background", "digest", "folders"]

_A = "f8[:]"      # any float64 array (e.g. a solver's state)
_C = "f8[::1]"    # a contiguous one (the simulator's own arrays)
_I = "i8[::1]"
_C2 = "f8[:, ::1]"
_ARGS = f"f8, {_A}, {_I}, {_C}, {_I}, {_C}, {_C}"  # t, y, P, F, S, G, ext (see .kernel)
EXPORTS = {
    "rhs_kernel": ("solve.kernel", f"void({_ARGS}, {_C})"),
    "inputs_kernel": ("solve.kernel", f"{_C}({_ARGS})"),
    "events_kernel": ("solve.kernel", f"void({_ARGS}, {_C})"),
    "jacobian_kernel": ("solve.kernel", f"void({_ARGS}, i8, f8, {_C2})"),
    "table_values": ("core.signals", f"void({_A}, {_A}, {_A}, {_C})"),
    "engine_over": ("model.components", f"void({_A}, {_A}, {_A}, f8, {_C}, {_C}, {_C2}, {_C}, {_C})"),
    "converter_torques_over": ("engine.torque_converter", f"void({_A}, {_A}, " + ", ".join([_C] * 7) + ")"),
    "nordsieck_values": ("solve.dense", f"void({_A}, {_I}, {_C}, {_C}, {_I}, {_I}, {_C}, {_C2})"),
}
"""Name -> (module of :mod:`transgen.sim`, numba signature) of every function the module exports:
the argument types the simulator passes (float64 numbers and arrays, int64 index arrays)."""
_SOURCES = ("solve.kernel", "core.signals", "model.components", "solve.dense", "core.interp", "model.transmission",
            "model.brake", "engine.torque_converter", "core.jit", "core.aot")
"""The modules whose text the digest covers: every one with compilable code, the rules of the
clone (.jit) and the signatures (here)."""
_STALE_LOCK = 900.0  # s: a build lock older than this is an abandoned build's
_LOADED: dict = {}


def digest() -> str:
    """A digest of the source files the kernels are compiled from (and of this builder)."""
    if "digest" not in _LOADED:
        here = Path(__file__).resolve().parents[1]  # the folder of transgen.sim
        h = hashlib.sha1()
        for name in _SOURCES:
            h.update((here / (name.replace(".", "/") + ".py")).read_bytes())
        _LOADED["digest"] = h.hexdigest()[:16]
    return _LOADED["digest"]


def _module_name() -> str:
    return f"transgen_kernels_{digest()}"


def folders() -> list[Path]:
    """Where the module is looked for, in order (the first writable one is where it is built)."""
    own = os.environ.get("TRANSGEN_KERNEL_CACHE")
    if own:
        return [Path(own)]
    cache = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return [Path(__file__).resolve().parent / "__pycache__", Path(cache) / "transgen"]


def _file_in(folder: Path) -> Path:
    return folder / (_module_name() + importlib.machinery.EXTENSION_SUFFIXES[0])


def kernels():
    """The extension module of the compiled kernels, or None where it is not built (for these
    sources and this Python); looked for once per process until found."""
    module = _LOADED.get("module")
    if module is not None:
        return module
    for folder in folders():
        path = _file_in(folder)
        if path.is_file():
            spec = importlib.util.spec_from_file_location(_module_name(), path)
            try:
                module = importlib.util.module_from_spec(spec)
                spec.loader.exec_module(module)
            except ImportError:  # another platform's or a damaged file: built again
                continue
            _LOADED["module"] = module
            return module
    return None


def _writable_folder() -> Path | None:
    for folder in folders():
        with contextlib.suppress(OSError):
            folder.mkdir(parents=True, exist_ok=True)
            probe = tempfile.NamedTemporaryFile(dir=folder, prefix=".probe-")
            probe.close()
            return folder
    return None


@contextlib.contextmanager
def _lock(folder: Path):
    """Inside: this process alone builds in ``folder`` (None yielded when another one does)."""
    lock = folder / (_module_name() + ".lock")
    with contextlib.suppress(OSError):
        if time.time() - lock.stat().st_mtime > _STALE_LOCK:
            lock.unlink()
    try:
        fd = os.open(lock, os.O_CREAT | os.O_EXCL | os.O_WRONLY)
    except FileExistsError:
        yield None
        return
    try:
        os.write(fd, str(os.getpid()).encode())
        os.close(fd)
        yield lock
    finally:
        with contextlib.suppress(OSError):
            lock.unlink()


def build(clone, wait: bool = True):
    """Build the module (numba.pycc: 30-60 s of CPU) where :func:`folders` says, unless it is
    there, compiling ``clone(f)`` of each function ``f`` (:func:`~.jit.numba_clone`); returns it loaded, or None where numba or a compiler is missing, no folder is writable
    or (``wait`` False) another process is building it. Where another process builds it and
    ``wait``, waits for that one (up to the lock's age limit)."""
    module = kernels()
    if module is not None:
        return module
    folder = _writable_folder()
    if folder is None:
        return None
    deadline = time.monotonic() + _STALE_LOCK
    while True:
        with _lock(folder) as mine:
            if mine is not None:
                if not _file_in(folder).is_file():
                    _compile_into(folder, clone)
                return kernels()
        if not wait or time.monotonic() > deadline:
            return None
        time.sleep(0.5)
        if kernels() is not None:
            return kernels()


def _compile_into(folder: Path, clone) -> None:
    """Compile :data:`EXPORTS` into ``folder`` (written under a temporary name, then renamed: a
    reader never sees half a file)."""
    import importlib as _importlib

    from numba.pycc import CC

    cc = CC(_module_name())
    cc.verbose = False
    with tempfile.TemporaryDirectory(dir=folder, prefix=".build-") as scratch:
        cc.output_dir = scratch
        for name, (module, signature) in EXPORTS.items():
            func = getattr(_importlib.import_module(f"transgen.sim.{module}"), name)
            cc.export(name, signature)(clone(func))
        cc.compile()
        built = Path(scratch) / os.path.basename(cc.output_file)
        os.replace(built, _file_in(folder))


def build_in_background() -> bool:
    """Start a detached, low-priority process that builds the module (once per process; in a
    session of its own, so that it is no part of the caller's process group and outlives it);
    False where none was started (numba missing, started already)."""
    if _LOADED.get("started") or importlib.util.find_spec("numba") is None:
        return False
    _LOADED["started"] = True
    env = dict(os.environ, PYTHONWARNINGS="ignore")
    try:
        subprocess.Popen([sys.executable, "-m", f"{__package__}.build_kernels", "--quiet"], stdin=subprocess.DEVNULL,
                         stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True,
                         close_fds=True, cwd=tempfile.gettempdir(), env=env, preexec_fn=_lower_priority)
    except OSError:
        return False
    return True


def _lower_priority() -> None:
    with contextlib.suppress(OSError, AttributeError):
        os.nice(10)
