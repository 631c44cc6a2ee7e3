"""Drag torque of an open wet shift element (clutch or brake pack) over its slip speed.

An open multi-plate pack shears the oil film between its plates: the torque rises with the slip,
at first linearly (a laminar Couette film), then, when the oil supply no longer fills the gap,
falls as the film aerates; some packs rise again at high slip (the gap closes). Two models:

* :class:`ViscousDrag` ``T = c * slip`` (the full film, and the default);
* :class:`TableDrag` a measured curve ``T(|slip|)``, optionally one row per oil temperature,
  interpolated linearly (in slip and in temperature), odd in the slip, held at its last value
  beyond the table's range.

:func:`couette_coefficient` gives ``c`` of a full film from the pack's geometry, and
:func:`aerated_film_torque` the peak-and-fall curve of a film fed with a limited oil flow, to
fill a table when no measured curve is at hand. Forms and sources in ``docs/losses.md``.

Sign convention: ``slip = w1 - w2`` of the element [rad/s]; the drag torque has the sign of the
slip (it is transmitted from LINK1 to LINK2), so its power ``T * slip`` is never negative.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

__all__ = ["ViscousDrag", "TableDrag", "couette_coefficient", "film_flow_demand", "aerated_film_torque",
           "RPM"]

RPM = 2.0 * math.pi / 60.0
"""rad/s per rpm."""


@dataclass(frozen=True)
class ViscousDrag:
    """``T = c * slip``: a viscous film; ``c`` [N*m*s/rad] >= 0."""

    c: float

    kind = "viscous"

    def torque(self, slip, oil_temperature=None):
        """Drag torque [N*m] at the slip ``slip`` [rad/s] (scalar or array); the oil temperature is
        not used."""
        return self.c * np.asarray(slip, dtype=float) if np.ndim(slip) else self.c * float(slip)

    def to_dict(self) -> dict:
        return {"kind": self.kind, "c": self.c}


@dataclass(frozen=True)
class TableDrag:
    """A drag curve: ``values[k][i]`` [N*m] at ``slip_rpm[i]`` [rpm, >= 0, increasing] and the oil
    temperature ``oil_temperature[k]`` [degC, increasing]; one row without temperatures when
    ``oil_temperature`` is empty. The torque at slip 0 is taken as 0 when the table starts above 0."""

    slip_rpm: tuple[float, ...]
    values: tuple[tuple[float, ...], ...]
    oil_temperature: tuple[float, ...] = ()

    kind = "table"

    def _curve(self, oil_temperature) -> tuple[np.ndarray, np.ndarray]:
        rows = np.asarray(self.values, dtype=float)
        if len(self.oil_temperature) <= 1 or oil_temperature is None:
            row = rows[0] if len(self.oil_temperature) <= 1 else rows[len(rows) // 2]
        else:
            temps = np.asarray(self.oil_temperature, dtype=float)
            t = min(max(float(oil_temperature), temps[0]), temps[-1])
            k = int(np.clip(np.searchsorted(temps, t, side="right") - 1, 0, len(temps) - 2))
            f = (t - temps[k]) / (temps[k + 1] - temps[k])
            row = (1.0 - f) * rows[k] + f * rows[k + 1]
        x = np.asarray(self.slip_rpm, dtype=float) * RPM
        if x[0] > 0.0:
            x, row = np.concatenate([[0.0], x]), np.concatenate([[0.0], row])
        return x, row

    def torque(self, slip, oil_temperature=None):
        """Drag torque [N*m] at the slip ``slip`` [rad/s] (scalar or array) and the oil
        temperature [degC] (``None``: the middle row; clamped to the table's range)."""
        x, row = self._curve(oil_temperature)
        s = np.asarray(slip, dtype=float)
        out = np.sign(s) * np.interp(np.abs(s), x, row)
        return out if np.ndim(slip) else float(out)

    def to_dict(self) -> dict:
        return {"kind": self.kind, "slip_rpm": list(self.slip_rpm), "torque": [list(r) for r in self.values],
                "oil_temperature": list(self.oil_temperature)}


def couette_coefficient(faces: int, viscosity: float, gap: float, inner_radius: float, outer_radius: float) -> float:
    """``c`` [N*m*s/rad] of a pack with ``faces`` friction interfaces, each a full laminar film of
    dynamic viscosity ``viscosity`` [Pa*s] and thickness ``gap`` [m] between the radii [m]:
    ``c = faces * pi * mu * (r_o^4 - r_i^4) / (2 h)`` (the shear stress ``mu r w / h`` integrated
    over the annulus).

    >>> round(couette_coefficient(8, 0.015, 0.15e-3, 0.064, 0.085) * 1000 * RPM, 2)  # N*m at 1000 rpm
    4.66
    """
    return faces * math.pi * viscosity * (outer_radius ** 4 - inner_radius ** 4) / (2.0 * gap)


def film_flow_demand(slip, viscosity: float, density: float, gap: float, inner_radius: float,
                     outer_radius: float, supply_pressure: float = 0.0):
    """The oil flow [m^3/s] one face's film draws at the slip ``slip`` [rad/s] to stay full.

    Derived here from lubrication theory (radial momentum with the centrifugal term of the linear
    Couette profile, ``u_theta = w r z / h``): a face between a fixed and a rotating plate pumps
    radially ``Q = pi h^3 (dp + 3 rho w^2 (r_o^2 - r_i^2) / 20) / (6 mu ln(r_o / r_i))``, ``dp``
    the supply pressure at the inner radius over that at the outer one [Pa]."""
    w = np.asarray(slip, dtype=float)
    return (math.pi * gap ** 3 * (supply_pressure + 0.15 * density * w ** 2 * (outer_radius ** 2 - inner_radius ** 2))
            / (6.0 * viscosity * math.log(outer_radius / inner_radius)))


def aerated_film_torque(slip, faces: int, viscosity: float, density: float, gap: float, inner_radius: float,
                        outer_radius: float, flow: float, supply_pressure: float = 0.0):
    """Drag torque [N*m] of a pack whose faces share the oil flow ``flow`` [m^3/s].

    While a face gets at least the flow its film draws (:func:`film_flow_demand`) the film is full
    (:func:`couette_coefficient`); with less, the oil wets only the annulus out to the effective
    radius ``r_e^2 = q r_o^2 + (1 - q) r_i^2``, ``q`` = supplied / demanded flow, and
    ``T = faces * pi * mu * w * (r_e^4 - r_i^4) / (2 h)``: the linear rise, the peak and the fall
    of measured curves (the effective-radius form of Yuan et al. and Iqbal et al., see
    ``docs/losses.md``)."""
    w = np.asarray(slip, dtype=float)
    demand = film_flow_demand(np.abs(w), viscosity, density, gap, inner_radius, outer_radius, supply_pressure)
    q = np.clip(np.divide(flow / faces, demand, out=np.ones_like(w), where=demand > 0), 0.0, 1.0)
    r_e2 = q * outer_radius ** 2 + (1.0 - q) * inner_radius ** 2
    out = faces * math.pi * viscosity * w * (r_e2 ** 2 - inner_radius ** 4) / (2.0 * gap)
    return out if np.ndim(slip) else float(out)
