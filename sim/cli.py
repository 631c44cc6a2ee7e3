"""Simulator commands of the ``transgen`` command line (filled in by the simulator)."""
from __future__ import annotations

__all__ = ["add_commands"]


def add_commands(sub) -> None:
    """Add the simulator's sub-commands to the ``transgen`` parser."""
