"""How the command line's process ends: SIGTERM and SIGHUP turned into
:class:`~transgen.outputs.Terminated` while the command runs, noted after it, and the exit code
``128 + signum`` (docs/safety.md)."""
from __future__ import annotations

import contextlib
import os
import sys

#: the program's state (:func:`transgen.cli.entry_point`): "ended" once the command is over (the
#: process exits), "late" the signals that arrived after that, "code" the exit code, "last"
#: whether its exit hook runs last (no hook was registered before it)
EXIT: dict = {"ended": False, "late": [], "code": 0, "last": False}


def terminate(signum, frame):
    """SIGTERM (SIGHUP) ends the run like Ctrl-C: the temporary files of the outputs are removed,
    the workers stopped, the rows of a sweep kept; the exit code is 128 + signum. Once the command
    is over (:func:`transgen.cli.entry_point`) it is only noted: raised in an exit hook it was a
    traceback and exit code 0."""
    if EXIT["ended"]:
        EXIT["late"].append(signum)
        return
    from .outputs import Terminated

    raise Terminated(signum)


def install_terminate() -> bool:
    """:func:`terminate` for SIGTERM and SIGHUP where they have their default action (not in a
    program that set its own, nor outside the main thread, nor SIGHUP under ``nohup``, which
    ignores it); whether it handles at least one of them."""
    import signal

    for signum in (signal.SIGTERM, signal.SIGHUP):
        if signal.getsignal(signum) is signal.SIG_DFL:
            with contextlib.suppress(ValueError):  # not the main thread
                signal.signal(signum, terminate)
    return any(signal.getsignal(signum) is terminate for signum in (signal.SIGTERM, signal.SIGHUP))


def late_code(code: int) -> int:
    """``code``, or 128 + the first signal noted after the command had ended."""
    return 128 + EXIT["late"][0] if EXIT["late"] and code < 128 else code


def exit_hook() -> None:
    """The program's last exit hook: the threads are joined and every other hook has run. SIGTERM
    and SIGHUP are ignored from here on, and the process ends now with its exit code (``128 +
    signum`` for a signal noted since the code was chosen): while Python frees its modules it
    resets the handlers to the default action, so that a signal then killed the process. Where
    a hook of another program was registered before this one (it must still run) the process is
    left to end as usual and a signal in those last milliseconds is ignored."""
    import signal

    if not EXIT["ended"]:
        return
    for signum in (signal.SIGTERM, signal.SIGHUP):
        signal.signal(signum, signal.SIG_IGN)
    if EXIT["late"] or EXIT["last"]:
        for stream in (sys.stdout, sys.stderr):
            with contextlib.suppress(Exception):
                stream.flush()
        os._exit(late_code(EXIT["code"]))
