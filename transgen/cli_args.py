"""argparse value types shared by the command lines (:mod:`transgen.cli`, :mod:`transgen.synthesis.cli`):
numbers are refused at the door when they are NaN, infinite or out of their physical range."""

from __future__ import annotations

import argparse

__all__ = ["number_option"]


def number_option(low: float, high: float, low_open: bool = True):
    """An argparse type: a finite number in ``(low, high]`` (``[low, high]`` when not ``low_open``)."""
    def read(text: str) -> float:
        try:
            value = float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"not a number: {text!r}") from None
        if not (value > low if low_open else value >= low) or not value <= high:  # also refuses nan
            raise argparse.ArgumentTypeError(f"must be a finite number in {'(' if low_open else '['}{low:g}, {high:g}], "
                                             f"not {text}")
        return value
    return read
