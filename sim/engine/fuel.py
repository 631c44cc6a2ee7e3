"""Fuel flow of an engine torque map: a measured fuel map or a Willans-line estimate.

An engine torque map (``[input] type = "engine_map"`` or ``"engine_converter"``) says nothing of
the fuel it burns. ``[input] fuel_map`` adds it, as the ``m_dot_fuel`` signal [kg/s] of the run
(evaluated at the output samples from the engine's speed, torque and throttle; the simulation
itself is unchanged) which the drive-cycle report integrates (:mod:`.cycle_report`):

* ``fuel_map = { type = "table", speed_rpm = [...], torque = [...], fuel_rate = [[...]] }``: the
  fuel flow [g/s] measured over engine speed [rpm] (columns) and brake torque [N*m] (rows), or
  ``bsfc = [[...]]`` [g/kWh] instead of ``fuel_rate`` (flow = bsfc x power; a BSFC map has no
  value at zero power, so a row at a torque <= 0 is taken as 0 g/s there); bilinear, clamped at
  the table's edges; ``density`` [kg/m^3] for the volume (default petrol's);
* ``fuel_map = "willans"`` or ``{ type = "willans", efficiency = 0.38, heating_value = 42.7e6,
  density = 745 }``: an **estimate**, the Willans line (Guzzella and Sciarretta, *Vehicle
  Propulsion Systems*, 3rd ed., Springer 2013, sec. 3.2: the brake mean effective pressure is
  linear in the fuel's, ``p_me = e p_mf - p_me0``). The loss ``p_me0`` is taken from the torque
  map itself: its throttle-0 row is the motored (friction and pumping) torque ``T_0(w) < 0``, so
  the fuel power is ``(T - T_0(w)) w / e``, ``m_dot = (T - T_0(w)) w / (e H_l)``. Closed throttle
  above idle is an overrun fuel cut-off (no fuel); the idle governor's throttle burns the idle
  fuel. ``e`` = 0.38 (petrol) and 0.42 (heavy diesel, the truck class) are estimates of the
  class, not measured engines; ``H_l`` = 42.7 MJ/kg and 745 kg/m^3 are typical petrol values
  (EN 228 allows 720-775 kg/m^3). Being an estimate, the report labels it so.

Units SI inside (rad/s, N*m, kg/s); the file in rpm, g/s and g/kWh as engine maps are published.
The scenario key is read by :mod:`.fuel_file` (this module imports nothing of the scenario
reader, so that its schema can name :data:`FUEL_KEYS`).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

__all__ = ["FuelMap", "WillansFuel", "fuel_of", "FUEL_KEYS", "DIESEL_DENSITY", "PETROL_DENSITY", "PETROL_HEATING_VALUE",
           "WILLANS_EFFICIENCY"]

FUEL_KEYS = frozenset({"type", "speed_rpm", "torque", "fuel_rate", "bsfc", "efficiency", "heating_value", "density"})
PETROL_HEATING_VALUE = 42.7e6
"""Lower heating value of petrol [J/kg] (a typical value; petrol and diesel lie near 42-43 MJ/kg)."""
PETROL_DENSITY = 745.0
"""Density of petrol [kg/m^3] (EN 228: 720-775 kg/m^3 at 15 C)."""
WILLANS_EFFICIENCY = 0.38
"""Willans slope ``e`` [-] of a petrol engine (an estimate of the class, module docstring)."""
RPM = 2.0 * math.pi / 60.0


@dataclass(frozen=True)
class FuelMap:
    """Fuel flow [kg/s] tabulated over engine speed ``speeds`` [rad/s] and brake torque
    ``torques`` [N*m]: ``rate[i_torque][i_speed]``; bilinear, clamped at the edges."""

    speeds: tuple[float, ...]
    torques: tuple[float, ...]
    rate: tuple[tuple[float, ...], ...]
    density: float = PETROL_DENSITY
    label: str = "fuel map"

    def flow(self, omega, torque, throttle=None):
        """Fuel flow [kg/s] at engine speeds ``omega`` [rad/s] and torques ``torque`` [N*m]
        (arrays or numbers; ``throttle`` unused: a measured map includes the fuel cut-off)."""
        w = np.clip(np.asarray(omega, float), self.speeds[0], self.speeds[-1])
        q = np.clip(np.asarray(torque, float), self.torques[0], self.torques[-1])
        table = np.asarray(self.rate, float)
        sp, tq = np.asarray(self.speeds), np.asarray(self.torques)
        i = np.clip(np.searchsorted(sp, w, side="right") - 1, 0, max(len(sp) - 2, 0))
        j = np.clip(np.searchsorted(tq, q, side="right") - 1, 0, max(len(tq) - 2, 0))
        if len(sp) == 1 or len(tq) == 1:
            return np.interp(w if len(tq) == 1 else q, sp if len(tq) == 1 else tq, table.ravel())
        u = (w - sp[i]) / (sp[i + 1] - sp[i])
        v = (q - tq[j]) / (tq[j + 1] - tq[j])
        return ((1 - u) * (1 - v) * table[j, i] + u * (1 - v) * table[j, i + 1]
                + (1 - u) * v * table[j + 1, i] + u * v * table[j + 1, i + 1])


@dataclass(frozen=True)
class WillansFuel:
    """The Willans-line estimate (module docstring) for the torque map ``engine``
    (:class:`~.components.EngineMap`): ``m_dot = max(T - T_0(w), 0) w / (e H_l)``, none at closed
    throttle (overrun cut-off)."""

    engine: object
    efficiency: float = WILLANS_EFFICIENCY
    heating_value: float = PETROL_HEATING_VALUE
    density: float = PETROL_DENSITY
    label: str = "Willans-line estimate"

    def flow(self, omega, torque, throttle=None):
        w = np.asarray(omega, float)
        t = np.asarray(torque, float)
        eng = self.engine
        row0 = np.asarray(eng.torque[0], float)  # throttle 0: the motored torque
        t0 = np.interp(w, np.asarray(eng.speeds), row0)
        power = np.maximum(t - t0, 0.0) * np.maximum(w, 0.0) / self.efficiency
        out = power / self.heating_value
        if throttle is not None:
            out = np.where(np.asarray(throttle, float) > 1e-9, out, 0.0)
        return out


DIESEL_DENSITY = 832.0
"""Density of diesel fuel [kg/m^3] (EN 590: 820-845 kg/m^3 at 15 C)."""


def fuel_of(powertrain) -> tuple[float, str] | None:
    """``(density [kg/m^3], source)`` of the fuel the engine of ``powertrain`` burns: its fuel map
    (``[input] fuel_map``) or the turbodiesel's own fuel flow; None without either."""
    for c in getattr(powertrain, "components", ()):
        fuel = getattr(c, "fuel", None)
        if isinstance(fuel, (FuelMap, WillansFuel)):
            return fuel.density, fuel.label
        if type(c).__name__ == "TurbodieselSource":
            return DIESEL_DENSITY, "turbodiesel model"
    return None
