"""Hydrodynamic torque converter (pump/impeller, turbine, freewheeling stator), no lock-up.

The converter is a resistive block between two links of the mechanism: it takes the pump and
turbine speeds and gives their torques.  The lock-up clutch is a clutch of the mechanism
(handled by the transmission's lock/unlock logic), not part of this model.

Model
-----
Drive (``omega_turbine <= omega_pump``), speed ratio ``SR = omega_turbine/omega_pump``::

    T_pump = (omega_pump / K(SR))^2,      T_turbine = TR(SR) * T_pump

Coast (``omega_turbine > omega_pump``: the vehicle drives the engine, flow reverses, the stator
freewheels and the converter acts as a fluid coupling), ``SR_c = omega_pump/omega_turbine``::

    T_turbine_absorbed = (omega_turbine / K_coast(SR_c))^2
    T_pump = T_turbine = -T_turbine_absorbed

Both branches give zero torque at SR = 1, so the characteristic is continuous.  The tables hold
the capacity factor K [rad/s/sqrt(N*m)] (infinite at SR = 1); interpolation is done on the torque
coefficient ``1/K^2`` [N*m*s^2], which is smooth and zero at SR = 1.

Sign conventions: ``T_pump_absorbed`` is the torque the converter applies *against* the pump
(positive loads the engine); ``T_turbine_delivered`` is the torque applied to the turbine shaft
in its direction of rotation (positive drives the transmission input).  The model is odd in the
speeds, ``torques(-wp, -wt) = -torques(wp, wt)``.  With the pump turning forwards and the turbine
backwards (SR < 0) the stall values (SR = 0) are used.

The shipped table (``data/torque_converter_heavy_truck.toml``) is synthetic data of typical
published shape for a heavy-truck converter; its header states what was chosen.
"""
from __future__ import annotations

import math
import tomllib
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path
from typing import ClassVar, Mapping

import numpy as np

from transgen.errors import TransgenError

from ..core.causality import Causality, ports
from ..core.interp import interp1, interp1_pair
from ..core.jit import compilable, compiled_loop
from .map_file import DATA_DIR

__all__ = ["TorqueConverter", "TorqueConverterError", "DEFAULT_TORQUE_CONVERTER", "converter_torques"]

DEFAULT_TORQUE_CONVERTER = DATA_DIR / "torque_converter_heavy_truck.toml"
"""Path of the shipped heavy-truck converter table."""


class TorqueConverterError(TransgenError, ValueError):
    """Invalid torque-converter data; the message lists every problem."""


def _coefficient(K) -> np.ndarray:
    K = np.asarray(K, dtype=float)
    return np.where(np.isinf(K), 0.0, 1.0 / np.square(K))


@dataclass(frozen=True)
class TorqueConverter:
    """Torque-converter characteristics.

    Parameters
    ----------
    speed_ratio : tuple of float
        Drive speed-ratio grid, increasing from 0 to 1.
    capacity_factor : tuple of float
        Drive capacity factor K(SR) = omega_pump/sqrt(T_pump) [rad/s/sqrt(N*m)]; inf at SR = 1.
    torque_ratio : tuple of float
        Drive torque ratio TR(SR) = T_turbine/T_pump [-].
    coast_speed_ratio : tuple of float
        Coast speed-ratio grid omega_pump/omega_turbine, increasing from 0 to 1.
    coast_capacity_factor : tuple of float
        Coast capacity factor omega_turbine/sqrt(T_turbine) [rad/s/sqrt(N*m)]; inf at 1.
    name : str
    provenance : tuple of (key, text)
    """

    speed_ratio: tuple[float, ...]
    capacity_factor: tuple[float, ...]
    torque_ratio: tuple[float, ...]
    coast_speed_ratio: tuple[float, ...]
    coast_capacity_factor: tuple[float, ...]
    name: str = "torque converter"
    provenance: tuple[tuple[str, str], ...] = ()
    causality: ClassVar[Mapping[str, Causality]] = ports(pump=Causality.RESISTIVE,
                                                         turbine=Causality.RESISTIVE)

    def __post_init__(self):
        problems = []
        for label, sr, cols in (("drive", self.speed_ratio, (self.capacity_factor,
                                                             self.torque_ratio)),
                                ("coast", self.coast_speed_ratio, (self.coast_capacity_factor,))):
            if len(sr) < 2 or sr[0] != 0.0 or sr[-1] != 1.0 or any(
                    b <= a for a, b in zip(sr, sr[1:])):
                problems.append(f"{label}: speed ratios must increase from 0 to 1")
            if any(len(c) != len(sr) for c in cols):
                problems.append(f"{label}: columns must have as many values as speed ratios")
            if any(not k > 0.0 for k in cols[0]) or any(math.isinf(k) for k in cols[0][:-1]):
                problems.append(f"{label}: capacity factors must be > 0 (inf only at SR = 1)")
        if any(not (t >= 0.0 and math.isfinite(t)) for t in self.torque_ratio):
            problems.append("drive: torque ratios must be finite and >= 0")
        if problems:
            raise TorqueConverterError(f"torque converter '{self.name}': " + "; ".join(problems))
        # plain tuples: scalar look-ups in the simulator's right-hand side (see sim/core/interp.py)
        object.__setattr__(self, "_sr", tuple(float(x) for x in self.speed_ratio))
        object.__setattr__(self, "_c", tuple(float(x) for x in _coefficient(self.capacity_factor)))
        object.__setattr__(self, "_tr", tuple(float(x) for x in self.torque_ratio))
        object.__setattr__(self, "_csr", tuple(float(x) for x in self.coast_speed_ratio))
        object.__setattr__(self, "_cc", tuple(float(x) for x in _coefficient(self.coast_capacity_factor)))

    @classmethod
    def load(cls, path: str | Path = DEFAULT_TORQUE_CONVERTER) -> "TorqueConverter":
        """Read a converter table (TOML; format of ``data/torque_converter_heavy_truck.toml``)."""
        path = Path(path)
        return _load(str(path))

    @classmethod
    def parse(cls, text: str, path: str | Path = "<converter>") -> "TorqueConverter":
        """A converter table from its TOML text; ``path`` names it in messages (and its stem is
        the default name)."""
        return _parse(text, str(path))

    def torque_ratio_at(self, speed_ratio: float) -> float:
        """Drive torque ratio TR [-] at a speed ratio (clamped to [0, 1])."""
        return interp1(speed_ratio, self._sr, self._tr)

    def capacity_factor_at(self, speed_ratio: float) -> float:
        """Drive capacity factor K [rad/s/sqrt(N*m)] at a speed ratio (inf at SR = 1)."""
        c = interp1(speed_ratio, self._sr, self._c)
        return math.inf if c == 0.0 else 1.0 / math.sqrt(c)

    def efficiency(self, speed_ratio: float) -> float:
        """Drive efficiency SR*TR [-]."""
        return speed_ratio * self.torque_ratio_at(speed_ratio)

    def torques(self, omega_pump: float, omega_turbine: float) -> tuple[float, float]:
        """``(T_pump_absorbed, T_turbine_delivered)`` [N*m] at pump and turbine speeds [rad/s].

        Examples
        --------
        >>> tc = TorqueConverter.load()
        >>> tp, tt = tc.torques(1500 * 3.14159 / 30, 0.0)   # stall at 1500 rpm
        >>> round(tt / tp, 2)
        2.2
        """
        return converter_torques(omega_pump, omega_turbine, self._sr, self._c, self._tr, self._csr, self._cc)

    def torques_over(self, omega_pump: np.ndarray, omega_turbine: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """:meth:`torques` at every pair of the arrays ``omega_pump``, ``omega_turbine`` (output
        sampling; one compiled loop when the simulator compiles its right-hand side)."""
        pump, turbine = np.empty(len(omega_pump)), np.empty(len(omega_pump))
        over, tables = compiled_loop(converter_torques_over, len(pump)), self.tables()
        if over is None:
            over = converter_torques_over
        else:
            tables = tuple(np.array(x, dtype=float) for x in tables)
        over(np.ascontiguousarray(omega_pump, dtype=float), np.ascontiguousarray(omega_turbine, dtype=float), *tables,
             pump, turbine)
        return pump, turbine

    def tables(self) -> tuple[tuple[float, ...], ...]:
        """The tables of :func:`converter_torques`: drive speed ratios, coefficients ``1/K^2``,
        torque ratios, then the coast speed ratios and coefficients."""
        return self._sr, self._c, self._tr, self._csr, self._cc

    def kernel_numbers(self) -> tuple[tuple[int, int], tuple[float, ...]]:
        """``((n_drive, n_coast), numbers)``: :meth:`tables` as data for the compiled right-hand
        side (:mod:`transgen.sim.solve.kernel`), one after the other."""
        return (len(self._sr), len(self._csr)), sum(self.tables(), ())


@compilable
def converter_torques(omega_pump: float, omega_turbine: float, sr, coefficient, torque_ratio, coast_sr,
                      coast_coefficient) -> tuple[float, float]:
    """``(T_pump_absorbed, T_turbine_delivered)`` [N*m] at pump and turbine speeds [rad/s] of the
    converter with the drive table ``(sr, coefficient = 1/K^2, torque_ratio)`` and the coast table
    ``(coast_sr, coast_coefficient)`` (the model of the module docstring; odd in the speeds)."""
    s = 1.0 if (omega_pump > 0.0 or (omega_pump == 0.0 and omega_turbine >= 0.0)) else -1.0
    wp, wt = s * omega_pump, s * omega_turbine
    if wt <= wp:                       # drive, wp > 0 here (or both zero)
        if wp == 0.0:
            return 0.0, 0.0
        capacity, ratio = interp1_pair(max(wt / wp, 0.0), sr, coefficient, torque_ratio)
        tp = wp * wp * capacity
        return s * tp, s * tp * ratio
    t = wt * wt * interp1(wp / wt, coast_sr, coast_coefficient)   # coast, wt > wp >= 0
    return -s * t, -s * t


@lru_cache(maxsize=None)
def _load(path: str) -> TorqueConverter:
    return _parse(Path(path).read_text(encoding="utf-8"), path)


@lru_cache(maxsize=None)
def _parse(text: str, path: str) -> TorqueConverter:
    try:
        doc = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise TorqueConverterError(f"{path}: error: not valid TOML: {exc}") from None
    if doc.get("format") != "transgen-torque-converter" or doc.get("version") != 1:
        raise TorqueConverterError(f"{path}: error: expected format = "
                                   "\"transgen-torque-converter\" and version = 1")
    try:
        d, c = doc["drive"], doc["coast"]
        return TorqueConverter(
            tuple(map(float, d["speed_ratio"])), tuple(map(float, d["capacity_factor"])),
            tuple(map(float, d["torque_ratio"])), tuple(map(float, c["speed_ratio"])),
            tuple(map(float, c["capacity_factor"])), str(doc.get("name", Path(path).stem)),
            tuple((str(k), str(v)) for k, v in doc.get("provenance", {}).items()))
    except (KeyError, TypeError, ValueError) as exc:
        if isinstance(exc, TorqueConverterError):
            raise TorqueConverterError(f"{path}: {exc}") from None
        raise TorqueConverterError(f"{path}: error: missing or non-numeric data ({exc})") from None


@compilable
def converter_torques_over(omega_pump, omega_turbine, sr, coefficient, torque_ratio, coast_sr, coast_coefficient,
                           pump, turbine) -> None:
    """:func:`converter_torques` at every pair of speeds, written into ``pump`` and ``turbine``."""
    for k in range(len(omega_pump)):
        pump[k], turbine[k] = converter_torques(omega_pump[k], omega_turbine[k], sr, coefficient, torque_ratio,
                                                coast_sr, coast_coefficient)
