"""The driveline of a vehicle class from its parts: propeller shaft, half-shafts and tyres.

``transgen scenario new`` gives the simulator's driveline (:class:`~transgen.sim.model.components.Driveline`:
one torsional spring-damper from the gearbox output to the vehicle) the compliance of the class's
real parts, in series and referred to the gearbox output (final drive ``i``, wheel radius ``r``):

* the propeller shaft turns with the gearbox output: ``k_prop`` as it is;
* the half-shafts (``n`` in parallel, ``k_half`` each) turn with the wheels: ``n k_half / i^2``;
* the tyres' longitudinal compliance: a driven tyre with slip stiffness ``C_kappa = c_kappa F_z``
  (force per unit longitudinal slip, ``c_kappa`` per newton of wheel load) deflects its carcass
  and tread by a relaxation length ``sigma`` before the slip builds up (Pacejka's transient
  slip model), a longitudinal spring ``C_kappa / sigma`` [N/m] at the contact patch, ``r^2 C_kappa /
  sigma`` torsionally at the wheel; ``m_t`` driven tyres share the driven axles' load ``F``:
  ``m_t r^2 c_kappa (F / m_t) / sigma / i^2 = r^2 c_kappa F / (sigma i^2)``.

``1/k = 1/k_prop + i^2/(n k_half) + sigma i^2/(r^2 c_kappa F)``. The damping ``c`` gives the
driveline's first torsional mode (the gearbox-side inertia ``J_1`` in the launch gear against the
vehicle ``J_2 = J_out + m r^2 / i^2`` on the spring) the class's damping ratio ``zeta``:
``c = 2 zeta sqrt(k J_1 J_2 / (J_1 + J_2))``. The numbers and their sources are in
``sim/data/vehicle_classes.toml``; the method in ``docs/calibration.md``.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

from ..model.components import GRAVITY

__all__ = ["DrivelineParts", "EquivalentDriveline"]


@dataclass(frozen=True)
class EquivalentDriveline:
    """The one spring-damper at the gearbox output [N*m/rad, N*m*s/rad] and its parts' shares:
    ``parts`` maps each part to its own stiffness referred to the gearbox output [N*m/rad];
    ``frequency`` [Hz] of the first torsional mode with the inertias it was damped for."""

    stiffness: float
    damping: float
    parts: dict
    frequency: float


@dataclass(frozen=True)
class DrivelineParts:
    """A class's driveline parts. ``propshaft`` [N*m/rad] (0: none, a transaxle), ``halfshaft``
    [N*m/rad] each, ``halfshafts`` their number, ``tyre_slip_stiffness`` ``c_kappa`` [1/1: N per
    unit slip per N of load], ``relaxation_length`` ``sigma`` [m], ``driven_axle_load`` the share
    of the vehicle's weight on the driven axles [-], ``damping_ratio`` ``zeta`` [-]."""

    propshaft: float
    halfshaft: float
    halfshafts: int
    tyre_slip_stiffness: float
    relaxation_length: float
    driven_axle_load: float
    damping_ratio: float

    def __post_init__(self):
        for name in ("halfshaft", "tyre_slip_stiffness", "relaxation_length", "driven_axle_load"):
            v = getattr(self, name)
            if not (math.isfinite(v) and v > 0):
                raise ValueError(f"driveline: {name} must be a positive finite number, not {v!r}")
        if not (math.isfinite(self.propshaft) and self.propshaft >= 0):
            raise ValueError(f"driveline: propshaft must be >= 0, not {self.propshaft!r}")
        if not (isinstance(self.halfshafts, int) and self.halfshafts >= 1):
            raise ValueError(f"driveline: halfshafts must be a whole number >= 1, not {self.halfshafts!r}")
        if not (math.isfinite(self.damping_ratio) and 0 <= self.damping_ratio < 1):
            raise ValueError(f"driveline: damping_ratio must be in [0, 1), not {self.damping_ratio!r}")

    def equivalent(self, final_drive: float, wheel_radius: float, mass: float, output_inertia: float,
                   gearbox_inertia: float) -> EquivalentDriveline:
        """The spring-damper referred to the gearbox output for a vehicle of ``mass`` [kg] with
        ``final_drive``, ``wheel_radius`` [m], ``output_inertia`` [kg*m^2] beyond the shaft and the
        gearbox's inertia ``gearbox_inertia`` [kg*m^2] at its output in the launch gear."""
        i2 = final_drive ** 2
        parts = {"halfshafts": self.halfshafts * self.halfshaft / i2,
                 "tyres": wheel_radius ** 2 * self.tyre_slip_stiffness * self.driven_axle_load * mass * GRAVITY
                 / self.relaxation_length / i2}
        if self.propshaft > 0:
            parts = {"propshaft": self.propshaft, **parts}
        k = 1.0 / sum(1.0 / v for v in parts.values())
        j2 = output_inertia + mass * wheel_radius ** 2 / i2
        j1 = max(gearbox_inertia, 1e-9)
        j_red = j1 * j2 / (j1 + j2)
        c = 2.0 * self.damping_ratio * math.sqrt(k * j_red)
        return EquivalentDriveline(k, c, parts, math.sqrt(k / j_red) / (2 * math.pi))
