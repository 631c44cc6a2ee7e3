"""One exception hierarchy for transgen, and located diagnostics for input files.

Every problem found in a ``.mech`` or scenario file is a :class:`Diagnostic` that prints as
``FILE:LINE:COL: error: message`` followed by the source line and a caret under the column.
A :class:`MechError` carries all the diagnostics of one file, so that a user sees every problem
at once.

Every message is bounded, whatever the input: a diagnostic shows at most
:data:`MAX_MESSAGE` characters of its message and a window of :data:`MAX_SOURCE` characters of
its line around the column; an error prints its first :data:`MAX_SHOWN` diagnostics and then
``... and N more errors`` (all of them stay in ``diagnostics``).
"""
from __future__ import annotations

from dataclasses import dataclass

__all__ = [
    "TransgenError",
    "Diagnostic",
    "MechError",
    "MechSyntaxError",
    "MechValidationError",
    "ModeError",
    "ScenarioError",
    "SimulationError",
    "CombinationLimitWarning",
]


MAX_MESSAGE = 400
MAX_SOURCE = 100
MAX_SHOWN = 20


class TransgenError(Exception):
    """Base class of every error transgen raises on purpose.

    Errors that are also :class:`ValueError` are bad input (the command line exits with 2);
    the others are failures of a run (exit 1).
    """


def _clip(text: str, limit: int) -> str:
    return text if len(text) <= limit else text[: limit - 3] + "..."


@dataclass(frozen=True)
class Diagnostic:
    """One located problem in a text file (lines and columns count from 1)."""

    filename: str
    line: int
    column: int
    message: str
    source_line: str = ""
    severity: str = "error"

    def format(self) -> str:
        """``FILE:LINE:COL: error: message`` plus the offending line and a caret."""
        head = (f"{_clip(self.filename, MAX_SOURCE)}:{self.line}:{self.column}: {self.severity}: "
                f"{_clip(self.message, MAX_MESSAGE)}")
        if not self.source_line:
            return head
        line = self.source_line.rstrip("\n").expandtabs(1)
        at = max(self.column - 1, 0)
        if len(line) > MAX_SOURCE:  # a window around the column
            start = max(0, min(at - MAX_SOURCE // 2, len(line) - MAX_SOURCE))
            window = line[start:start + MAX_SOURCE]
            prefix, suffix = ("..." if start > 0 else ""), ("..." if start + MAX_SOURCE < len(line) else "")
            line, at = prefix + window + suffix, at - start + len(prefix)
        return f"{head}\n    {line}\n    {' ' * at}^"

    def __str__(self) -> str:
        return self.format()


class MechError(TransgenError, ValueError):
    """Problems in a ``.mech`` file; ``diagnostics`` lists all of them in file order."""

    def __init__(self, diagnostics: list[Diagnostic]):
        self.diagnostics = sorted(diagnostics, key=lambda d: (d.line, d.column))
        shown = [d.format() for d in self.diagnostics[:MAX_SHOWN]]
        if len(self.diagnostics) > MAX_SHOWN:
            shown.append(f"... and {len(self.diagnostics) - MAX_SHOWN} more errors")
        super().__init__("\n".join(shown))


class MechSyntaxError(MechError):
    """The text does not follow the grammar of the ``.mech`` language."""


class MechValidationError(MechError):
    """The text parses but describes an invalid mechanism (unknown names, bad numbers, ...)."""


class ModeError(TransgenError, ValueError):
    """A mode or a choice of generalized coordinates cannot be modelled (named in the message)."""


class ScenarioError(TransgenError, ValueError):
    """Problems in a scenario file (TOML); the message is located ``FILE:LINE: error: ...``."""


class SimulationError(TransgenError, RuntimeError):
    """A simulation could not go on; the message names time, mode and reason."""


class CombinationLimitWarning(UserWarning):
    """Only part of the 2^k combinations of shift elements is enumerated (too many elements)."""


class StateOutOfDomain(SimulationError):
    """A state outside a model's domain (a negative manifold pressure, a NaN in an engine block).

    An integrator's trial state may be one (an explicit Runge-Kutta stage can overshoot where the
    accepted step does not): the integration core then makes the solver retry a shorter step. An
    accepted state may not: the run stops with this message."""
