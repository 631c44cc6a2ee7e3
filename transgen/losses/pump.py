"""The oil pump's loss: the hydraulic power it delivers at line pressure over its efficiency.

A fixed-displacement pump turning ``speed_ratio`` times as fast as its drive (the transmission
input here: the impeller hub, which turns at engine speed) delivers ``Q = D * n_pump`` [m^3/s] at
the line pressure ``p = p_line + k * |T_in|`` [Pa] (a pressure schedule that rises with the
input torque, so that the engaged elements hold: ``k = 0`` for a constant line pressure) and
takes ``P = p * Q / eta`` [W] from its drive, ``eta`` its overall (volumetric x mechanical)
efficiency. Values and sources in ``docs/losses.md``.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

__all__ = ["Pump"]


@dataclass(frozen=True)
class Pump:
    """``displacement`` [m^3/rev] (0: no pump), ``line_pressure`` [Pa], ``pressure_per_torque``
    [Pa/(N*m)], ``efficiency`` (0, 1], ``speed_ratio`` pump speed / input speed."""

    displacement: float = 0.0
    line_pressure: float = 0.0
    pressure_per_torque: float = 0.0
    efficiency: float = 1.0
    speed_ratio: float = 1.0

    def flow(self, input_speed):
        """Delivered flow [m^3/s] at the input speed [rad/s]."""
        return self.displacement * self.speed_ratio * np.abs(np.asarray(input_speed, dtype=float)) / (2.0 * math.pi)

    def pressure(self, input_torque):
        """Line pressure [Pa] at the input torque [N*m]."""
        return self.line_pressure + self.pressure_per_torque * np.abs(np.asarray(input_torque, dtype=float))

    def power(self, input_speed, input_torque=0.0):
        """Power [W] the pump takes from the input at its speed [rad/s] and torque [N*m]."""
        out = self.pressure(input_torque) * self.flow(input_speed) / self.efficiency
        return out if np.ndim(out) else float(out)

    def to_dict(self) -> dict:
        return {"displacement": self.displacement, "line_pressure": self.line_pressure,
                "pressure_per_torque": self.pressure_per_torque, "efficiency": self.efficiency,
                "speed_ratio": self.speed_ratio}
