"""The numbers of a ``.mech`` file: the admissible range of each kind of parameter (SI units) and
the reading of a number's text with a located, bounded message for an inadmissible one.

Part of the language (:mod:`transgen.language`), in a module of its own so that the ranges are
one short list to read.
"""
from __future__ import annotations

import math
import sys
from dataclasses import dataclass

__all__ = ["Quantity", "MAX_NUMBER_LENGTH", "INERTIA", "TEETH", "RADIUS", "CAPACITY", "RATIO", "EFFICIENCY",
           "SLIP_SPEED", "DRAG", "RATIO_TOL", "read_number", "shorten"]


@dataclass(frozen=True)
class Quantity:
    """The admissible values of a numeric parameter (SI units).

    A value is a finite, normal double (no overflow to infinity, no underflow to a subnormal or to
    0) or exactly 0 where ``zero`` allows it; its magnitude lies in ``[low, high]``. The range is
    physical: it keeps out values no transmission has (and whose ratios would defeat the rank
    tests of 64-bit arithmetic, e.g. inertias 1e-300 next to 1e300).
    """

    low: float
    high: float
    unit: str = ""
    sign: str = "any"  # "any", ">=0" (zero and positive), ">0"
    integer: bool = False  # a tooth count

    @property
    def zero(self) -> bool:
        return self.sign == ">=0"

    def describe(self) -> str:
        unit = f" {self.unit}" if self.unit else ""
        span = f"{self.low:g} and {self.high:g}{unit}"
        if self.integer:
            return f"a whole number between {span}"
        if self.sign == "any":
            return f"between {span} in magnitude (negative allowed)"
        return ("0 or " if self.zero else "") + f"between {span}"


MAX_NUMBER_LENGTH = 64
"""Longest number text accepted (a double has 17 significant digits)."""

INERTIA = Quantity(1e-15, 1e15, "kg*m^2", ">=0")
TEETH = Quantity(1, 100_000, sign=">0", integer=True)
RADIUS = Quantity(1e-4, 100.0, "m", ">0")
CAPACITY = Quantity(sys.float_info.min, 1e8, "N*m", ">=0")
RATIO = Quantity(1e-6, 1e6)
EFFICIENCY = Quantity(1e-6, 1.0, sign=">0")
SLIP_SPEED = Quantity(1e-3, 1e6, "rpm", ">0")
DRAG = Quantity(1e-9, 1e4, "N*m*s/rad", ">=0")
RATIO_TOL = Quantity(1e-12, 1e6, sign=">0")
"""Ranges of the numbers of a ``.mech`` file (see README, "Numbers")."""

_NOT_FINITE = frozenset({"nan", "inf", "infinity"})


def _suggest(name: str, known) -> str:
    if len(name) > 100:
        return ""
    import difflib  # only for a message

    close = difflib.get_close_matches(name, list(known), n=1, cutoff=0.5)
    return f"; did you mean '{close[0]}'?" if close else ""


def shorten(text: str, limit: int = 40) -> str:
    """``text``, or its start and length when longer than ``limit`` (keeps messages bounded)."""
    return text if len(text) <= limit else f"{text[:limit - 16]}... ({len(text)} characters)"


def read_number(text: str, key: str, quantity: Quantity) -> float | int | str:
    """The value of the number ``text`` for parameter ``key``, or an error message (a ``str``
    that starts with ``key``) when it is not admissible for ``quantity``."""
    shown = shorten(text)
    if len(text) > MAX_NUMBER_LENGTH:
        return f"{key} is written with {len(text)} characters (at most {MAX_NUMBER_LENGTH}): {shown}"
    number = float(text)
    if quantity.integer:
        if not math.isfinite(number) or number != int(number) or number <= 0:
            return f"{key} is a tooth count: a positive whole number, not {shown}"
        if number > quantity.high:
            return f"{key} is a tooth count: at most {quantity.high:g}, not {shown}"
        return int(number)
    if not math.isfinite(number):
        return f"{key} must be a finite number, not {shown} (beyond the largest double, 1.8e308)"
    mantissa = text.lower().split("e")[0]
    if abs(number) < sys.float_info.min and any(c in mantissa for c in "123456789"):
        return (f"{key} {shown} is below the smallest normal double (2.2e-308) and would read as "
                f"{'0' if number == 0 else 'a subnormal'}; {key} must be {quantity.describe()}")
    if quantity.sign == ">0" and number <= 0:
        return f"{key} must be positive, not {shown}"
    if quantity.sign == ">=0" and number < 0:
        return f"{key} must not be negative, not {shown}"
    if number == 0 and quantity.zero:
        return 0.0
    if not quantity.low <= abs(number) <= quantity.high:
        return f"{key} must be {quantity.describe()}, not {shown}"
    return number


