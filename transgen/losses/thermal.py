"""Clutch temperature: a lumped one-node model per shift element, driven by its slipping power.

Each pack is one node of heat capacity ``C = m c`` [J/K] cooled to the oil at ``T_oil`` through
the conductance ``G = h A`` [W/K]:

    ``C dT/dt = P(t) - G (T - T_oil)``,   ``P = |T_c * slip|`` the element's dissipated power
    (the simulation result's ``P_<element>`` signal).

One-way coupling: the temperature does not act back on the run, so it is integrated after it,
over the result's samples. Between two samples the power is linear (the result is piecewise
linear in time), and the step uses the exact solution for a linear input: with ``a = h / tau``,
``tau = C / G``, ``theta = T - T_oil``,

    ``theta1 = theta0 e^-a + (p0 h / C) phi1(a) + (s h^2 / C) phi2(a)``,
    ``phi1 = (1 - e^-a) / a``, ``phi2 = (a - 1 + e^-a) / a^2``, ``s`` the power's slope,

so the temperatures are those of the model for that power, whatever the sample spacing. Closed
forms (tested): without cooling the rise is the dissipated energy over ``C``; after the power
stops, ``theta`` decays as ``e^(-t/tau)``. A peak between two samples (where ``P = G theta``) is
found by bisection on the exact solution.

:class:`TwoNodePack` / :func:`two_node_response`: the optional plate/lining model, the friction heat
split between a steel node and a lining node coupled to each other and to the oil, stepped exactly
in the modal coordinates of its 2 x 2 system (no peak search, no report hook).

Pack parameters: :class:`ClutchPack`; typical car and truck packs in ``data/clutch_packs.toml``
(:func:`class_packs`); :func:`default_packs` gives each element of a run the class pack nearest its
static capacity, scaled by capacity over the class's reference (mass and area grow with the
friction area that carries the torque). Values and sources in ``docs/losses.md``.
"""
from __future__ import annotations

import math
import tomllib
from dataclasses import dataclass, replace
from functools import cache
from pathlib import Path

import numpy as np

__all__ = ["ClutchPack", "TwoNodePack", "two_node_response", "ThermalResult", "pack_from_geometry", "class_packs", "default_packs",
           "temperature_response", "clutch_temperatures", "shift_temperatures", "DEFAULT_OIL_TEMPERATURE",
           "PACKS_FILE", "THERMAL_UNITS"]

PACKS_FILE = Path(__file__).resolve().parent / "data" / "clutch_packs.toml"
DEFAULT_OIL_TEMPERATURE = 90.0
"""Oil (sump) temperature [degC] of a warm transmission (estimate)."""
THERMAL_UNITS = {"temperature_start": "degC", "temperature_peak": "degC", "temperature_rise": "K",
                 "peak": "degC", "peak_time": "s", "final": "degC", "oil_temperature": "degC",
                 "heat_capacity": "J/K", "conductance": "W/K", "time_constant": "s"}


@dataclass(frozen=True)
class ClutchPack:
    """One node: ``mass`` [kg], ``specific_heat`` [J/(kg*K)], ``conductance = h A`` [W/K] to the oil."""

    mass: float
    specific_heat: float
    conductance: float
    name: str = ""

    @property
    def heat_capacity(self) -> float:
        """``m c`` [J/K]."""
        return self.mass * self.specific_heat

    @property
    def time_constant(self) -> float:
        """``m c / (h A)`` [s] (inf without cooling)."""
        return self.heat_capacity / self.conductance if self.conductance > 0 else math.inf

    def scaled(self, factor: float, name: str | None = None) -> ClutchPack:
        """The pack with mass and cooling area times ``factor``."""
        return replace(self, mass=self.mass * factor, conductance=self.conductance * factor,
                       name=self.name if name is None else name)

    def to_dict(self) -> dict:
        return {"name": self.name, "mass": self.mass, "specific_heat": self.specific_heat,
                "conductance": self.conductance, "heat_capacity": self.heat_capacity,
                "time_constant": None if math.isinf(self.time_constant) else self.time_constant}


def pack_from_geometry(steel_plates: int, plate_thickness: float, inner_radius: float, outer_radius: float,
                       density: float, specific_heat: float, heat_transfer: float, name: str = "") -> ClutchPack:
    """The pack of ``steel_plates`` separator plates (annuli between the radii [m], thickness [m],
    ``density`` [kg/m^3]): their mass, and ``h A`` with both faces of every plate cooled at
    ``heat_transfer`` [W/(m^2*K)]."""
    area = math.pi * (outer_radius ** 2 - inner_radius ** 2)
    return ClutchPack(steel_plates * area * plate_thickness * density, specific_heat,
                      heat_transfer * 2 * steel_plates * area, name)


@cache
def class_packs(path: str | None = None) -> dict[str, tuple[ClutchPack, float]]:
    """``{class: (pack, reference static capacity [N*m])}`` from the packs file (default
    :data:`PACKS_FILE`)."""
    data = tomllib.loads(Path(path or PACKS_FILE).read_text(encoding="utf-8"))
    out = {}
    for name, p in data["pack"].items():
        pack = pack_from_geometry(p["steel_plates"], p["plate_thickness"], p["inner_radius"], p["outer_radius"],
                                  p["density"], p["specific_heat"], p["heat_transfer"], name)
        out[name] = (pack, float(p["reference_capacity"]))
    return out


def default_packs(capacities: dict) -> dict[str, ClutchPack]:
    """Each element's pack from its static capacity [N*m]: the class pack whose reference capacity
    is nearest (in ratio), scaled by capacity / reference; an element without a finite capacity
    gets the car pack as it is."""
    classes = class_packs()
    out = {}
    for e, cap in capacities.items():
        if cap is None or not math.isfinite(cap) or cap <= 0:
            out[e] = classes["car"][0]
            continue
        name, (pack, ref) = min(classes.items(), key=lambda kv: abs(math.log(cap / kv[1][1])))
        out[e] = pack.scaled(cap / ref, f"{name} x {cap / ref:.3g}")
    return out


def _phi(a: float) -> tuple[float, float, float]:
    """``e^-a``, ``phi1``, ``phi2`` of the module docstring, accurate for small ``a``."""
    if a < 1e-4:
        return math.exp(-a), 1.0 - a / 2 + a * a / 6, 0.5 - a / 6 + a * a / 24
    e = math.exp(-a)
    return e, -math.expm1(-a) / a, (a - 1.0 + e) / (a * a)


def _step(theta0: float, p0: float, slope: float, h: float, pack: ClutchPack) -> float:
    c = pack.heat_capacity
    a = h * pack.conductance / c
    e, phi1, phi2 = _phi(a)
    return theta0 * e + p0 * h / c * phi1 + slope * h * h / c * phi2


def _phis(a: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``phi1``, ``phi2`` of the module docstring for an array of ``a >= 0``."""
    small = a < 1e-4
    safe = np.where(small, 1.0, a)
    phi1 = np.where(small, 1.0 - a / 2 + a * a / 6, -np.expm1(-safe) / safe)
    phi2 = np.where(small, 0.5 - a / 6 + a * a / 24, (safe - 1.0 + np.exp(-safe)) / (safe * safe))
    return phi1, phi2


_CHUNK = 200.0
"""Most decay exponent summed in one block of the vectorised recurrence (e^200 is far from overflow)."""


def temperature_response(time, power, pack: ClutchPack, oil_temperature: float = DEFAULT_OIL_TEMPERATURE,
                         initial: float | None = None) -> tuple[np.ndarray, float, float]:
    """The pack temperature [degC] at every sample of ``time`` [s] for the dissipated ``power``
    [W] (linear between samples; repeated times are allowed), starting at ``initial`` (default
    the oil temperature); also the peak temperature and its time (between samples included).

    The steps ``theta[k+1] = e_k theta[k] + b_k`` are summed in closed form, blockwise:
    ``theta[k] = e^-L_k (theta[k0] + sum_{m<k} b_m e^L_{m+1})``, ``L`` the decay exponent summed
    from the block's start."""
    t = np.asarray(time, dtype=float)
    p = np.abs(np.asarray(power, dtype=float))
    theta0 = (oil_temperature if initial is None else initial) - oil_temperature
    if len(t) < 2:
        return np.full(len(t), theta0 + oil_temperature), theta0 + oil_temperature, float(t[0]) if len(t) else 0.0
    g, c = pack.conductance, pack.heat_capacity
    h = np.diff(t)
    valid = h > 0.0
    h = np.where(valid, h, 0.0)
    slope = np.where(valid, np.diff(p) / np.where(valid, h, 1.0), 0.0)
    a = h * g / c
    phi1, phi2 = _phis(a)
    b = np.where(valid, p[:-1] * h / c * phi1 + slope * h * h / c * phi2, 0.0)
    theta = np.empty(len(t))
    theta[0] = theta0
    total = np.concatenate([[0.0], np.cumsum(a)])
    k0 = 0
    while k0 < len(t) - 1:
        k1 = int(np.searchsorted(total, total[k0] + _CHUNK, side="right"))
        k1 = min(max(k1, k0 + 2), len(t))  # samples k0 .. k1-1 in this block
        lk = total[k0:k1] - total[k0]  # L_k of the block's samples
        acc = np.concatenate([[0.0], np.cumsum(b[k0:k1 - 1] * np.exp(lk[1:]))])
        theta[k0:k1] = np.exp(-lk) * (theta[k0] + acc)
        k0 = k1 - 1
    peak_k = int(np.argmax(theta))
    peak, peak_t = float(theta[peak_k]), float(t[peak_k])
    rate0, rate1 = p[:-1] - g * theta[:-1], p[1:] - g * theta[1:]
    for k in np.nonzero(valid & (rate0 > 0.0) & (rate1 < 0.0))[0]:  # a maximum inside the step
        lo, hi = 0.0, float(h[k])
        for _ in range(60):  # bisect the rate P - G theta on the exact solution
            mid = 0.5 * (lo + hi)
            if p[k] + slope[k] * mid - g * _step(theta[k], p[k], slope[k], mid, pack) > 0.0:
                lo = mid
            else:
                hi = mid
        value = _step(theta[k], p[k], slope[k], lo, pack)
        if value > peak:
            peak, peak_t = value, float(t[k] + lo)
    return theta + oil_temperature, peak + oil_temperature, peak_t


@dataclass(frozen=True)
class ThermalResult:
    """Temperatures [degC] of every element over ``time`` [s], their peaks and peak times."""

    time: np.ndarray
    temperatures: dict
    peaks: dict
    peak_times: dict
    packs: dict
    oil_temperature: float

    def summary(self) -> dict:
        """Per element: ``peak`` [degC], ``peak_time`` [s], ``final`` [degC], and its pack."""
        return {"oil_temperature": self.oil_temperature,
                "elements": {e: {"peak": self.peaks[e], "peak_time": self.peak_times[e],
                                 "final": float(self.temperatures[e][-1]), "pack": self.packs[e].to_dict()}
                             for e in self.temperatures}}


_LOSS_SIGNALS = frozenset({"P_spin", "P_pump", "P_mesh", "P_losses"})
"""The simulation's loss powers of :mod:`transgen.sim.model.losses` (no shift elements)."""


def clutch_temperatures(result, packs: dict | None = None,
                        oil_temperature: float = DEFAULT_OIL_TEMPERATURE) -> ThermalResult:
    """:class:`ThermalResult` of a simulation ``result`` (its ``P_<element>`` signals). ``packs``:
    element -> :class:`ClutchPack` (default :func:`default_packs` of the result's static
    capacities, ``meta["static_capacity"]``). A run with drag losses heats a pack with its drag
    power ``P_drag_<element>`` too (the loss signals themselves are no elements)."""
    elements = [k[2:] for k in result.signals if k.startswith("P_") and not k.startswith("P_drag_")
                and k not in _LOSS_SIGNALS]
    if packs is None:
        caps = dict((result.meta or {}).get("static_capacity") or {})
        packs = default_packs({e: caps.get(e) for e in elements})
    temps, peaks, times = {}, {}, {}
    for e in elements:
        if e not in packs:
            continue
        power = result.signals[f"P_{e}"]
        if f"P_drag_{e}" in result.signals:
            power = power + result.signals[f"P_drag_{e}"]
        temps[e], peaks[e], times[e] = temperature_response(result.time, power, packs[e], oil_temperature)
    return ThermalResult(np.asarray(result.time), temps, peaks, times, {e: packs[e] for e in temps}, oil_temperature)


def shift_temperatures(thermal: ThermalResult, t_start: float, t_end: float) -> dict:
    """Per element over ``[t_start, t_end]`` [s]: ``(temperature at the start, peak, rise)``
    [degC, degC, K]; the peak from the samples in the window."""
    t = thermal.time
    window = (t >= t_start) & (t <= t_end)
    out = {}
    for e, temp in thermal.temperatures.items():
        start = float(np.interp(t_start, t, temp))
        peak = max(start, float(np.max(temp[window]))) if window.any() else start
        out[e] = (start, peak, peak - start)
    return out


@dataclass(frozen=True)
class TwoNodePack:
    """Two nodes: the separator steel (``steel``: heat capacity [J/K]) and the friction lining
    (``lining``); the friction heat splits ``partition`` to the steel, ``1 - partition`` to the
    lining; conductances [W/K] between them (``between``) and from each to the oil (``steel_oil``,
    ``lining_oil``). ``C theta' = -K theta + b P`` with ``C = diag(steel, lining)``."""

    steel: float
    lining: float
    partition: float
    between: float
    steel_oil: float
    lining_oil: float = 0.0

    def system(self) -> tuple[np.ndarray, np.ndarray]:
        """``A``, ``B`` of ``theta' = A theta + B P`` (theta = steel, lining over the oil)."""
        k = np.array([[self.between + self.steel_oil, -self.between],
                      [-self.between, self.between + self.lining_oil]])
        c = np.array([self.steel, self.lining])
        return -k / c[:, None], np.array([self.partition, 1.0 - self.partition]) / c


def two_node_response(time, power, pack: TwoNodePack, oil_temperature: float = DEFAULT_OIL_TEMPERATURE) -> np.ndarray:
    """Steel and lining temperatures [degC], shape ``(samples, 2)``, for the dissipated ``power``
    [W] linear between samples: exact, in the modal coordinates of ``A`` (symmetrisable, so its
    eigenvalues are real and <= 0), each a one-node step of the module docstring."""
    t = np.asarray(time, dtype=float)
    p = np.abs(np.asarray(power, dtype=float))
    a_mat, b_vec = pack.system()
    lam, vec = np.linalg.eig(a_mat)
    lam, vec = lam.real, vec.real
    beta = np.linalg.solve(vec, b_vec)
    z = np.zeros((len(t), 2))
    for k in range(len(t) - 1):
        h = t[k + 1] - t[k]
        if h <= 0.0:
            z[k + 1] = z[k]
            continue
        slope = (p[k + 1] - p[k]) / h
        a = -lam * h
        phi1, phi2 = _phis(a)
        z[k + 1] = z[k] * np.exp(-a) + beta * (p[k] * h * phi1 + slope * h * h * phi2)
    return z @ vec.T + oil_temperature
