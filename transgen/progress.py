"""Progress of a long command on standard error: on a terminal, elsewhere as log lines.

On a terminal the progress is one line rewritten in place (at most :data:`TERMINAL_INTERVAL`
apart); where standard error is not a terminal (a log file, CI) nothing is shown unless the user
asks with ``--progress``: then a whole line every :data:`LOG_INTERVAL` seconds, prefixed
``progress:``, so that a log shows the run advancing without a line per step. Every line says
where the work is, the time elapsed and an estimate of the time left (:func:`eta_text`).
"""
from __future__ import annotations

import sys
import time

__all__ = ["ProgressLine", "eta_text", "clock", "add_progress_option", "TERMINAL_INTERVAL", "LOG_INTERVAL"]

TERMINAL_INTERVAL = 0.1
"""Seconds between two updates of the line on a terminal."""

LOG_INTERVAL = 10.0
"""Seconds between two ``progress:`` lines where standard error is not a terminal."""


def clock(seconds: float) -> str:
    """``seconds`` as ``H:MM:SS``."""
    seconds = int(round(max(seconds, 0.0)))
    return f"{seconds // 3600}:{seconds // 60 % 60:02d}:{seconds % 60:02d}"


def eta_text(fraction: float, elapsed: float) -> str:
    """``42 %, 0:00:03 elapsed, 0:00:04 left``: the time left extrapolated from the rate so far
    (left out before 1 % is done, when it says nothing yet)."""
    fraction = min(max(fraction, 0.0), 1.0)
    text = f"{int(100 * fraction):3d} %, {clock(elapsed)} elapsed"
    if fraction >= 0.01 and elapsed > 0:
        text += f", {clock(elapsed * (1 - fraction) / fraction)} left"
    return text


def add_progress_option(parser) -> None:
    """``--progress``: progress lines on standard error also where it is not a terminal."""
    parser.add_argument("--progress", action="store_true",
                        help=f"progress on standard error also where it is not a terminal: a line every "
                             f"{LOG_INTERVAL:g} s (on a terminal the progress line is shown anyway, unless --quiet)")


class ProgressLine:
    """Shows progress texts on ``stream`` (standard error): rewritten in place on a terminal,
    a ``progress:`` line every :data:`LOG_INTERVAL` s with ``log`` elsewhere, nothing when
    ``enabled`` is false (``--quiet``, ``--json``) or elsewhere without ``log``."""

    def __init__(self, enabled: bool = True, log: bool = False, stream=None, interval: float | None = None):
        self.stream = stream if stream is not None else sys.stderr
        tty = bool(getattr(self.stream, "isatty", lambda: False)())
        self.mode = None if not enabled else ("terminal" if tty else ("log" if log else None))
        self.interval = interval if interval is not None else (TERMINAL_INTERVAL if self.mode == "terminal"
                                                               else LOG_INTERVAL)
        self.start = time.perf_counter()
        self._last = -float("inf")
        self._width = 0

    @property
    def active(self) -> bool:
        return self.mode is not None

    def elapsed(self) -> float:
        return time.perf_counter() - self.start

    def show(self, text: str, final: bool = False) -> None:
        """Show ``text`` now if the interval since the last one has passed (or ``final``)."""
        if self.mode is None:
            return
        now = time.perf_counter()
        if not final and now - self._last < self.interval:
            return
        self._last = now
        if self.mode == "terminal":
            line = "  " + text
            print("\r" + line.ljust(self._width), end="", file=self.stream, flush=True)
            self._width = max(self._width, len(line))
        else:
            print(f"progress: {text}", file=self.stream, flush=True)

    def end(self) -> None:
        """End the line on a terminal (nothing elsewhere)."""
        if self.mode == "terminal" and self._width:
            print(file=self.stream, flush=True)
            self._width = 0
