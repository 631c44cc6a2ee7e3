"""One exception hierarchy for transgen, and located diagnostics for input files.

Every problem found in a ``.mech`` or scenario file is a :class:`Diagnostic` that prints as
``FILE:LINE:COL: error: message`` followed by the source line and a caret under the column.
A :class:`MechError` carries all the diagnostics of one file, so that a user sees every problem
at once.
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
]


class TransgenError(Exception):
    """Base class of every error transgen raises on purpose."""


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
        head = f"{self.filename}:{self.line}:{self.column}: {self.severity}: {self.message}"
        if not self.source_line:
            return head
        line = self.source_line.rstrip("\n").expandtabs(1)
        caret = " " * max(self.column - 1, 0) + "^"
        return f"{head}\n    {line}\n    {caret}"

    def __str__(self) -> str:
        return self.format()


class MechError(TransgenError, ValueError):
    """Problems in a ``.mech`` file; ``diagnostics`` lists all of them in file order."""

    def __init__(self, diagnostics: list[Diagnostic]):
        self.diagnostics = sorted(diagnostics, key=lambda d: (d.line, d.column))
        super().__init__("\n".join(d.format() for d in self.diagnostics))


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


class StateOutOfDomain(SimulationError):
    """A state outside a model's domain (a negative manifold pressure, a NaN in an engine block).

    An integrator's trial state may be one (an explicit Runge-Kutta stage can overshoot where the
    accepted step does not): the integration core then makes the solver retry a shorter step. An
    accepted state may not: the run stops with this message."""

