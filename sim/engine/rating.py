"""Full-load curve and rating of the turbodiesel: steady full-load points over engine speed.

:func:`full_load_curve` solves :meth:`TurbochargedDiesel.steady_state
<transgen.sim.engine.diesel.TurbochargedDiesel.steady_state>` at full load over engine speeds
(each point warm-starts the next); :func:`rate` runs it from 800 rpm to the rated speed and
summarises rated power and torque, peak torque, and boost and turbo speed at rated.  Speeds in
rad/s, torque in N*m, power in W.
"""
from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from .diesel import TurbochargedDiesel
from .gas import RPM

__all__ = ["FullLoadCurve", "EngineRating", "full_load_curve", "rate"]


@dataclass(frozen=True)
class FullLoadCurve:
    """Full-load curve: ``engine_speed`` [rad/s], ``torque`` [N*m], ``power`` [W],
    ``boost_pressure_ratio`` [-], ``turbo_speed`` [rad/s], ``fuel`` [kg/cycle/cylinder],
    ``chi`` compressor map coordinate [-] (1 = surge line)."""

    engine_speed: np.ndarray
    torque: np.ndarray
    power: np.ndarray
    boost_pressure_ratio: np.ndarray
    turbo_speed: np.ndarray
    fuel: np.ndarray
    chi: np.ndarray


def full_load_curve(engine: TurbochargedDiesel,
                    engine_speeds: Sequence[float] = tuple(n * RPM for n in range(800, 2101, 100))
                    ) -> FullLoadCurve:
    """Steady full-load points over engine speeds [rad/s] (each warm-starts the next)."""
    pts, guess = [], None
    for w in engine_speeds:
        s = engine.steady_state(w, guess=guess)
        pts.append(s)
        guess = s.state
    arr = lambda name: np.array([getattr(s, name) for s in pts])  # noqa: E731
    return FullLoadCurve(arr("engine_speed"), arr("torque"), arr("power"),
                         arr("boost_pressure_ratio"), arr("turbo_speed"), arr("fuel"),
                         np.array([s.signals["chi"] for s in pts]))


@dataclass(frozen=True)
class EngineRating:
    """Rating summary: ``rated_power`` [W] and ``rated_torque`` [N*m] at ``rated_speed``
    [rad/s]; ``peak_torque`` [N*m] at ``peak_torque_speed`` [rad/s]; boost pressure ratio and
    turbo speed [rad/s] at rated; the full-load curve."""

    rated_speed: float
    rated_power: float
    rated_torque: float
    peak_torque: float
    peak_torque_speed: float
    rated_boost_pressure_ratio: float
    rated_turbo_speed: float
    curve: FullLoadCurve

    def __str__(self) -> str:
        return (f"rated {self.rated_power / 1e3:.1f} kW at {self.rated_speed / RPM:.0f} rpm "
                f"({self.rated_torque:.0f} N*m), peak torque {self.peak_torque:.0f} N*m at "
                f"{self.peak_torque_speed / RPM:.0f} rpm, boost PR at rated "
                f"{self.rated_boost_pressure_ratio:.2f}, turbo speed at rated "
                f"{self.rated_turbo_speed / RPM / 1e3:.1f} krpm")


def rate(engine: TurbochargedDiesel) -> EngineRating:
    """Full-load curve from 800 rpm to rated speed (100 rpm steps) and its rating summary."""
    rated = engine.params.rated_speed
    speeds = [n * RPM for n in range(800, int(round(rated / RPM)), 100)] + [rated]
    curve = full_load_curve(engine, speeds)
    k = int(np.argmax(curve.torque))
    return EngineRating(rated, float(curve.power[-1]), float(curve.torque[-1]),
                        float(curve.torque[k]), float(curve.engine_speed[k]),
                        float(curve.boost_pressure_ratio[-1]), float(curve.turbo_speed[-1]),
                        curve)
