"""Spin losses of a link (bearings, seals, churning) over its speed.

A link turning at ``w`` [rad/s] relative to the housing loses ``P = T(w) * w`` >= 0 with

* :class:`PolynomialSpin` ``T = sign(w) * (a0 + a1 |w| + a2 w^2 + ...)`` [N*m], coefficients
  ``a_k`` in N*m*(s/rad)^k: ``a0`` a seal's or bearing's constant drag torque, ``a1`` a viscous
  term, ``a2`` churning and windage;
* :class:`TableSpin` a measured curve ``T(|n|)`` over the speed in rpm, linear between its points,
  held beyond them.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .drag import RPM

__all__ = ["PolynomialSpin", "TableSpin"]


@dataclass(frozen=True)
class PolynomialSpin:
    """``T = sign(w) * sum_k a_k |w|^k`` [N*m]; ``coefficients = (a0, a1, ...)``."""

    coefficients: tuple[float, ...] = ()

    kind = "polynomial"

    def torque(self, speed):
        """Spin torque [N*m] at the link speed ``speed`` [rad/s] (scalar or array), with its sign."""
        s = np.asarray(speed, dtype=float)
        a = np.abs(s)
        out = np.sign(s) * sum(c * a ** k for k, c in enumerate(self.coefficients))
        return out if np.ndim(speed) else float(out)

    def to_dict(self) -> dict:
        return {"kind": self.kind, "coefficients": list(self.coefficients)}


@dataclass(frozen=True)
class TableSpin:
    """``values[i]`` [N*m] at ``speed_rpm[i]`` [rpm, >= 0, increasing]; 0 at rest when the table
    starts above 0."""

    speed_rpm: tuple[float, ...]
    values: tuple[float, ...]

    kind = "table"

    def torque(self, speed):
        """Spin torque [N*m] at the link speed ``speed`` [rad/s], with its sign."""
        x = np.asarray(self.speed_rpm, dtype=float) * RPM
        y = np.asarray(self.values, dtype=float)
        if x[0] > 0.0:
            x, y = np.concatenate([[0.0], x]), np.concatenate([[0.0], y])
        s = np.asarray(speed, dtype=float)
        out = np.sign(s) * np.interp(np.abs(s), x, y)
        return out if np.ndim(speed) else float(out)

    def to_dict(self) -> dict:
        return {"kind": self.kind, "speed_rpm": list(self.speed_rpm), "torque": list(self.values)}
