"""Turbocharger maps: file format, the causal-table pre-processor, gas helpers, map generator.

This module is the thesis' compressor/turbine *pre-processor* (sections 2.3 and 4.4): it reads a
turbocharger map in a manufacturer-like format and turns it into look-up tables whose inputs are
what the simulation knows (pressures, temperatures, rotor speed) and whose outputs are what it
needs (mass flow, efficiency).

Map file format (TOML, read with the standard library's ``tomllib``)
--------------------------------------------------------------------
A compressor map file::

    # free-text provenance comment lines
    format = "transgen-compressor-map"     # or "transgen-turbine-map"
    version = 1
    name = "..."
    speed_unit = "rpm"                     # unit of every `speed` value: "rpm" or "rad/s"

    [reference]                            # reference state of the corrected quantities
    temperature = 298.46                   # T_std [K]   (thesis eqs 4.21-4.22 / 4.28-4.29)
    pressure = 101111.34                   # p_std [Pa]

    [provenance]                           # machine-readable provenance (strings)
    source = "..."

    [[speed_line]]                         # one table per speed line (compressor)
    speed = 60000.0                        # corrected speed N_corr
    mass_flow = [...]                      # corrected mass flow [kg/s]
    pressure_ratio = [...]                 # total-to-total p02/p01 [-]
    efficiency = [...]                     # isentropic efficiency [-]

    [surge_line]                           # points on the surge line (high-PR, low-flow end)
    speed = [...]
    mass_flow = [...]
    pressure_ratio = [...]

    [stall_line]                           # points on the stall/choke line (low-PR end)
    speed = [...]
    mass_flow = [...]
    pressure_ratio = [...]

A turbine map file has ``format = "transgen-turbine-map"`` and speed lines with ``speed``,
``expansion_ratio`` (p01/p02 [-]), ``mass_flow`` (corrected [kg/s]) and ``efficiency``.

Corrected quantities follow the thesis: ``N_corr = N*sqrt(T_std/T01)`` and
``m_corr = m*(p_std/p01)*sqrt(T01/T_std)``.  Inside the code every speed is in rad/s.

The pre-processor and the chi coordinate
----------------------------------------
:func:`preprocess_compressor` evaluates, on every speed line, the surge and stall pressure
ratios (interpolated in speed along the surge and stall lines) and the normalised pressure
coordinate of thesis eq. 4.25::

    chi = (PR - PR_stall) / (PR_surge - PR_stall)

so that chi = 0 on the stall line, chi = 1 on the surge line, chi > 1 is surge and chi < 0 stalled
operation.  The speed line's corrected flow and efficiency are resampled on a regular chi grid,
giving the causal tables ``m_corr(N_corr, chi)`` and ``eta(N_corr, chi)`` (eqs 4.23-4.24).

*The 0/0 guard.*  At low speed the surge and stall lines meet (both tend to PR = 1) and eq. 4.25
becomes 0/0.  The pre-processor therefore refuses any speed line whose span
``PR_surge - PR_stall`` is below ``min_span`` (:class:`MapError` naming the line).  At run time
chi is only ever evaluated within the tabulated speed range, where the span is interpolated
between lines that each have at least ``min_span``.  Below the lowest speed line the compressor
look-up moves to the *similar point* on that line (fan laws: ``PR - 1`` scales with the speed
squared, the flow with the speed), so chi keeps the lowest line's span and the flow goes to zero
with the speed (an out-of-data warning is issued).

:func:`preprocess_turbine` resamples the turbine speed lines on a common expansion-ratio grid,
giving ``m_corr(N_corr, ER)`` and ``eta(N_corr, ER)`` (eqs 4.30-4.31).

Out-of-data use
---------------
A look-up outside the tables clamps to the nearest edge (no extrapolation; the one exception is
the compressor's fan-law scaling below the lowest speed line, above) and issues one
:class:`MapRangeWarning` per table object, naming the operating point.  For the compressor,
chi > 1 (surge side) clamps to the surge flow: a mean-value model cannot represent surge cycles.
chi < 0 (PR below the stall line, e.g. p_im < p_amb at idle) clamps to the stall-line flow, which
is the saturation ``Pi_c = max(1, p_im/p_amb)`` of Wahlström & Eriksson.

Map generation
--------------
No open heavy-duty map tables exist (see the project's research note), so the shipped maps
``data/we_compressor.toml`` and ``data/we_turbine.toml`` are *regenerated from the published
analytic fits* of Wahlström & Eriksson (:class:`WECompressorFit`, :class:`WETurbineFit`) by
``data/make_maps.py`` (which calls :func:`generate_compressor_map` and
:func:`generate_turbine_map`).  Each file carries its provenance.
"""
from __future__ import annotations

import bisect
import math
import re
import tomllib
import warnings
from dataclasses import dataclass
from functools import cached_property, lru_cache
from pathlib import Path

import numpy as np

from transgen.errors import TransgenError

__all__ = [
    "RPM",
    "OMEGA_FLOOR",
    "Gas",
    "AIR",
    "EXHAUST",
    "MapError",
    "MapRangeWarning",
    "corrected_speed",
    "corrected_flow",
    "actual_flow",
    "chi_coordinate",
    "compression_outlet_temperature",
    "expansion_outlet_temperature",
    "torque_from_power",
    "MapLine",
    "CompressorSpeedLine",
    "TurbineSpeedLine",
    "CompressorMap",
    "TurbineMap",
    "load_map",
    "save_map",
    "CompressorTable",
    "TurbineTable",
    "preprocess_compressor",
    "preprocess_turbine",
    "WECompressorFit",
    "WETurbineFit",
    "generate_compressor_map",
    "generate_turbine_map",
    "DATA_DIR",
    "DEFAULT_VGT_POSITION",
    "default_compressor_table",
    "default_turbine_table",
]

RPM = math.pi / 30.0
"""One revolution per minute in rad/s."""

OMEGA_FLOOR = 100.0 * RPM
"""Lowest turbo speed [rad/s] used to turn power into torque (``torque = P/max(omega, floor)``).

Wahlström & Eriksson clamp their turbo-speed integrator at 100 rpm for the same reason: the
turbine still delivers power at zero speed, so ``P/omega`` would be unbounded.
"""

DATA_DIR = Path(__file__).resolve().parent / "data"
"""Folder of the shipped example maps and tables."""

MIN_CHI_SPAN = 1e-4
"""Default smallest admissible ``PR_surge - PR_stall`` on a speed line (the chi 0/0 guard)."""


class MapError(TransgenError, ValueError):
    """A map file or map data is invalid; the message lists every problem found."""


class MapRangeWarning(UserWarning):
    """A map was used outside its data and the look-up was clamped to the map edge."""


# --------------------------------------------------------------------------------------------
# Gas and thermodynamic helpers shared by compressor.py, turbine.py and turbocharger.py
# --------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class Gas:
    """Ideal gas with constant specific heats.

    Parameters
    ----------
    cp : float
        Specific heat at constant pressure [J/(kg*K)].
    R : float
        Specific gas constant [J/(kg*K)].
    """

    cp: float
    R: float

    @cached_property  # read in every turbocharger evaluation
    def gamma(self) -> float:
        """Ratio of specific heats cp/cv [-]."""
        return self.cp / (self.cp - self.R)

    @cached_property
    def kappa(self) -> float:
        """Isentropic exponent (gamma-1)/gamma = R/cp [-] used in eqs 4.4 and 4.13."""
        return self.R / self.cp


AIR = Gas(cp=1011.0, R=287.0)
"""Air, c_pa and R_a of Wahlström & Eriksson (gamma = 1.3964)."""
EXHAUST = Gas(cp=1332.0, R=286.0)
"""Exhaust gas, c_pe and R_e of Wahlström & Eriksson (gamma = 1.2734)."""


def corrected_speed(omega: float, T0: float, T_ref: float) -> float:
    """Corrected speed ``N*sqrt(T_std/T01)`` (eqs 4.21, 4.28); same unit as ``omega``."""
    return omega * math.sqrt(T_ref / T0)


def corrected_flow(m_dot: float, p0: float, T0: float, p_ref: float, T_ref: float) -> float:
    """Corrected mass flow ``m*(p_std/p01)*sqrt(T01/T_std)`` [kg/s] (eqs 4.22, 4.29)."""
    return m_dot * (p_ref / p0) * math.sqrt(T0 / T_ref)


def actual_flow(m_corr: float, p0: float, T0: float, p_ref: float, T_ref: float) -> float:
    """Mass flow [kg/s] from a corrected flow: the inverse of :func:`corrected_flow`."""
    return m_corr * (p0 / p_ref) * math.sqrt(T_ref / T0)


def chi_coordinate(PR: float, PR_stall: float, PR_surge: float,
                   min_span: float = MIN_CHI_SPAN) -> float:
    """Normalised pressure coordinate of thesis eq. 4.25.

    ``chi = (PR - PR_stall)/(PR_surge - PR_stall)``: 0 on the stall line, 1 on the surge line.

    Raises
    ------
    MapError
        If ``PR_surge - PR_stall < min_span``: there the surge and stall lines meet and chi is
        0/0 (see the module docstring).

    Examples
    --------
    >>> chi_coordinate(1.5, 1.0, 2.0)
    0.5
    """
    span = PR_surge - PR_stall
    if not span >= min_span:
        raise MapError(f"chi is undefined: PR_surge - PR_stall = {span:.3g} < {min_span:g} "
                       f"(PR_stall = {PR_stall:.6g}, PR_surge = {PR_surge:.6g}); the surge and "
                       "stall lines meet here (0/0)")
    return (PR - PR_stall) / span


def compression_outlet_temperature(T_in: float, PR: float, eta: float, gas: Gas) -> float:
    """Compressor outlet temperature [K], thesis eq. 4.7: ``T1*(1 + (PR^kappa - 1)/eta)``."""
    return T_in * (1.0 + (PR ** gas.kappa - 1.0) / eta)


def expansion_outlet_temperature(T_in: float, ER: float, eta: float, gas: Gas) -> float:
    """Turbine outlet temperature [K], thesis eq. 4.16 with ``P2/P1 = 1/ER``.

    ``T2 = T1*(1 + eta*((1/ER)^kappa - 1)) = T1*(1 - eta*(1 - ER^-kappa))``.
    """
    return T_in * (1.0 - eta * (1.0 - ER ** -gas.kappa))


def torque_from_power(power: float, omega: float, omega_floor: float = OMEGA_FLOOR) -> float:
    """Shaft torque [N*m] from shaft power [W] (eqs 4.8-4.9, 4.17-4.18).

    ``torque = power / max(omega, omega_floor)``: the floor keeps the torque finite at a standing
    rotor (the turbine delivers power at zero speed); see :data:`OMEGA_FLOOR`.
    """
    return power / max(omega, omega_floor)


# --------------------------------------------------------------------------------------------
# Raw (manufacturer-format) maps
# --------------------------------------------------------------------------------------------
def _floats(values, what: str, problems: list[str]) -> tuple[float, ...]:
    try:
        out = tuple(float(v) for v in values)
    except (TypeError, ValueError):
        problems.append(f"{what}: expected a list of numbers, got {repr(values)[:60]}")
        return ()
    if not all(math.isfinite(v) for v in out):
        problems.append(f"{what}: values must be finite")
    return out


def _check_lengths(what: str, problems: list[str], **columns) -> None:
    lengths = {k: len(v) for k, v in columns.items()}
    if len(set(lengths.values())) != 1:
        problems.append(f"{what}: columns have different lengths {lengths}")
    elif min(lengths.values()) < 2:
        problems.append(f"{what}: needs at least 2 points")


def _raise_problems(problems: list[str], where: str) -> None:
    if problems:
        raise MapError(f"{where}: " + ("\n  ".join(["invalid map data:"] + problems)))


@dataclass(frozen=True)
class MapLine:
    """A line in the compressor map (surge or stall line): one point per speed.

    ``speed`` corrected speed [rad/s], ``mass_flow`` corrected [kg/s], ``pressure_ratio`` [-].
    """

    speed: tuple[float, ...]
    mass_flow: tuple[float, ...]
    pressure_ratio: tuple[float, ...]

    def pressure_ratio_at(self, speed: float) -> float:
        """Pressure ratio of the line at a corrected speed [rad/s] (linear, clamped)."""
        return float(np.interp(speed, self.speed, self.pressure_ratio))


@dataclass(frozen=True)
class CompressorSpeedLine:
    """One compressor speed line: corrected speed [rad/s]; per point corrected flow [kg/s],
    total pressure ratio p02/p01 [-] and isentropic efficiency [-]."""

    speed: float
    mass_flow: tuple[float, ...]
    pressure_ratio: tuple[float, ...]
    efficiency: tuple[float, ...]


@dataclass(frozen=True)
class TurbineSpeedLine:
    """One turbine speed line: corrected speed [rad/s]; per point expansion ratio p01/p02 [-],
    corrected flow [kg/s] and efficiency [-]."""

    speed: float
    expansion_ratio: tuple[float, ...]
    mass_flow: tuple[float, ...]
    efficiency: tuple[float, ...]


@dataclass(frozen=True)
class CompressorMap:
    """A compressor map in manufacturer format (speed lines plus surge and stall lines).

    ``T_ref`` [K] and ``p_ref`` [Pa] are the reference state of the corrected quantities;
    ``provenance`` maps keys to free text.  The constructor validates the data and raises
    :class:`MapError` listing every problem.
    """

    name: str
    speed_lines: tuple[CompressorSpeedLine, ...]
    surge_line: MapLine
    stall_line: MapLine
    T_ref: float
    p_ref: float
    provenance: tuple[tuple[str, str], ...] = ()

    def __post_init__(self):
        problems: list[str] = []
        _check_reference(self, problems)
        _check_speed_lines(self.speed_lines, problems)
        for s in self.speed_lines:
            what = f"speed line {s.speed / RPM:.6g} rpm"
            _check_lengths(what, problems, mass_flow=s.mass_flow,
                           pressure_ratio=s.pressure_ratio, efficiency=s.efficiency)
            if any(not 0.0 < e <= 1.0 for e in s.efficiency):
                problems.append(f"{what}: efficiency must be in (0, 1]")
            if any(m < 0.0 for m in s.mass_flow) or any(p <= 0.0 for p in s.pressure_ratio):
                problems.append(f"{what}: mass flow must be >= 0 and pressure ratio > 0")
        for label, line in (("surge line", self.surge_line), ("stall line", self.stall_line)):
            _check_lengths(label, problems, speed=line.speed, mass_flow=line.mass_flow,
                           pressure_ratio=line.pressure_ratio)
            if any(b <= a for a, b in zip(line.speed, line.speed[1:])):
                problems.append(f"{label}: speeds must be strictly increasing")
        _raise_problems(problems, f"compressor map '{self.name}'")


@dataclass(frozen=True)
class TurbineMap:
    """A turbine map in manufacturer format (speed lines of expansion ratio, flow, efficiency).

    ``T_ref`` [K] and ``p_ref`` [Pa] are the reference state of the corrected quantities.
    """

    name: str
    speed_lines: tuple[TurbineSpeedLine, ...]
    T_ref: float
    p_ref: float
    provenance: tuple[tuple[str, str], ...] = ()

    def __post_init__(self):
        problems: list[str] = []
        _check_reference(self, problems)
        _check_speed_lines(self.speed_lines, problems)
        for s in self.speed_lines:
            what = f"speed line {s.speed / RPM:.6g} rpm"
            _check_lengths(what, problems, expansion_ratio=s.expansion_ratio,
                           mass_flow=s.mass_flow, efficiency=s.efficiency)
            if any(b <= a for a, b in zip(s.expansion_ratio, s.expansion_ratio[1:])):
                problems.append(f"{what}: expansion ratios must be strictly increasing")
            if any(e < 1.0 for e in s.expansion_ratio):
                problems.append(f"{what}: expansion ratios must be >= 1")
            if any(not 0.0 < e <= 1.0 for e in s.efficiency):
                problems.append(f"{what}: efficiency must be in (0, 1]")
            if any(m < 0.0 for m in s.mass_flow):
                problems.append(f"{what}: mass flow must be >= 0")
        _raise_problems(problems, f"turbine map '{self.name}'")


def _check_speed_lines(lines, problems: list[str]) -> None:
    speeds = [s.speed for s in lines]
    if len(speeds) < 2 or any(b <= a for a, b in zip(speeds, speeds[1:])):
        problems.append("speed lines: need at least 2, in strictly increasing speed")


def _check_reference(m, problems: list[str]) -> None:
    if not (m.T_ref > 0.0 and m.p_ref > 0.0):
        problems.append(f"reference state must be positive (T_ref={m.T_ref}, p_ref={m.p_ref})")


_FORMATS = {"transgen-compressor-map": "compressor", "transgen-turbine-map": "turbine"}
_SPEED_UNITS = {"rpm": RPM, "rad/s": 1.0}


def load_map(path: str | Path) -> CompressorMap | TurbineMap:
    """Read a compressor or turbine map file (format in the module docstring).

    Raises
    ------
    MapError
        If the file is not valid TOML or the data are incomplete or invalid (all problems).
    """
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise MapError(f"{path}:1:1: error: cannot read map file ({exc})") from None
    try:
        doc = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        at = re.search(r"\(at line (\d+), column (\d+)\)", str(exc))
        line, col = (int(at.group(1)), int(at.group(2))) if at else (
            (text.count("\n") + 1, 1) if "end of document" in str(exc) else (1, 1))
        message = re.sub(r"\s*\(at line \d+, column \d+\)", "", str(exc))
        raise MapError(f"{path}:{line}:{col}: error: not valid TOML: {message}") from None
    problems: list[str] = []
    kind = _FORMATS.get(doc.get("format")) if isinstance(doc.get("format"), str) else None
    if kind is None:
        raise MapError(f"{path}:{_key_line(text, 'format')}:1: error: 'format' must be one of {sorted(_FORMATS)}, "
                       f"got {str(doc.get('format'))[:40]!r}")
    if doc.get("version") != 1:
        problems.append(f"unsupported version {doc.get('version')!r} (expected 1)")
    unit = _SPEED_UNITS.get(doc.get("speed_unit", "rpm"))
    if unit is None:
        problems.append(f"speed_unit must be one of {sorted(_SPEED_UNITS)}")
        unit = 1.0
    ref = doc.get("reference", {})
    ref = ref if isinstance(ref, dict) else {}
    T_ref, p_ref = ref.get("temperature"), ref.get("pressure")
    if not isinstance(T_ref, (int, float)) or not isinstance(p_ref, (int, float)):
        problems.append("[reference] needs numeric 'temperature' [K] and 'pressure' [Pa]")
    provenance = doc.get("provenance", {})
    provenance = tuple((str(k), str(v)) for k, v in provenance.items()) if isinstance(provenance, dict) else ()
    lines = doc.get("speed_line", [])
    if not isinstance(lines, list) or not all(isinstance(t, dict) for t in lines):
        problems.append("speed_line must be an array of tables ([[speed_line]])")
        lines = []
    elif not lines:
        problems.append("no [[speed_line]] tables")

    def col(table: dict, key: str, what: str) -> tuple[float, ...]:
        if key not in table:
            problems.append(f"{what}: missing '{key}'")
            return ()
        return _floats(table[key], f"{what}.{key}", problems)

    def speed_of(table: dict, i: int) -> float:
        v = table.get("speed")
        if not isinstance(v, (int, float)):
            problems.append(f"speed_line[{i}]: 'speed' must be a number")
            return float("nan")
        return float(v) * unit

    if kind == "compressor":
        speed_lines = tuple(
            CompressorSpeedLine(speed_of(t, i), col(t, "mass_flow", f"speed_line[{i}]"),
                                col(t, "pressure_ratio", f"speed_line[{i}]"),
                                col(t, "efficiency", f"speed_line[{i}]"))
            for i, t in enumerate(lines))
        mlines = []
        for label in ("surge_line", "stall_line"):
            t = doc.get(label)
            if not isinstance(t, dict):
                problems.append(f"missing [{label}] table")
                t = {}
            mlines.append(MapLine(tuple(v * unit for v in col(t, "speed", label)),
                                  col(t, "mass_flow", label), col(t, "pressure_ratio", label)))
        _raise_problems(problems, _where(path, text, problems))
        try:
            return CompressorMap(str(doc.get("name", path.stem)), speed_lines, mlines[0],
                                 mlines[1], float(T_ref), float(p_ref), provenance)
        except MapError as exc:
            raise MapError(f"{path}:1:1: error: {exc}") from None
    speed_lines = tuple(
        TurbineSpeedLine(speed_of(t, i), col(t, "expansion_ratio", f"speed_line[{i}]"),
                         col(t, "mass_flow", f"speed_line[{i}]"),
                         col(t, "efficiency", f"speed_line[{i}]"))
        for i, t in enumerate(lines))
    _raise_problems(problems, _where(path, text, problems))
    try:
        return TurbineMap(str(doc.get("name", path.stem)), speed_lines, float(T_ref),
                          float(p_ref), provenance)
    except MapError as exc:
        raise MapError(f"{path}:1:1: error: {exc}") from None


def _key_line(text: str, key: str, after: int = 0) -> int:
    """1-based line of ``key = ...`` or of the table ``[key]`` / ``[[key]]`` at or after line
    ``after`` (0-based), else 1."""
    pattern = re.compile(r"^\s*(\[\[?\s*" + re.escape(key) + r"\s*\]|" + re.escape(key) + r"\s*=)")
    lines = text.split("\n")
    for i in range(after, len(lines)):
        if pattern.match(lines[i]):
            return i + 1
    return 1


def _where(path: Path, text: str, problems: list[str]) -> str:
    """``FILE:LINE:1: error`` at the table (and key) of the first problem."""
    if not problems:
        return str(path)
    first = problems[0]
    line = 1
    m = re.match(r"speed_line\[(\d+)\](?:\.(\w+))?", first)
    if m:
        starts = [i for i, t in enumerate(text.split("\n")) if re.match(r"^\s*\[\[\s*speed_line\s*\]\]", t)]
        if int(m.group(1)) < len(starts):
            line = starts[int(m.group(1))] + 1
            key_line = _key_line(text, m.group(2), line - 1) if m.group(2) else 1
            line = key_line if key_line > 1 else line
    else:
        m = re.match(r"\[?(\w+)", first)
        if m:
            line = _key_line(text, m.group(1))
    return f"{path}:{line}:1: error"


def _toml_str(s: str) -> str:
    return '"' + s.replace("\\", "\\\\").replace('"', '\\"').replace("\n", "\\n") + '"'


def _toml_list(values, scale: float = 1.0) -> str:
    return "[" + ", ".join(repr(float(v) / scale) for v in values) + "]"


def save_map(cmap: CompressorMap | TurbineMap, path: str | Path) -> Path:
    """Write a map in the TOML format of the module docstring (speeds in rpm); returns the path.

    Float values are written with ``repr`` so that :func:`load_map` gives back equal data (up to
    the rad/s -> rpm -> rad/s conversion of the speeds).
    """
    path = Path(path)
    is_comp = isinstance(cmap, CompressorMap)
    out = [f"# {'Compressor' if is_comp else 'Turbine'} map '{cmap.name}'"]
    out += [f"# {k}: {line}" for k, v in cmap.provenance for line in v.splitlines()]
    out += [f'format = "transgen-{"compressor" if is_comp else "turbine"}-map"', "version = 1",
            f"name = {_toml_str(cmap.name)}", 'speed_unit = "rpm"', "",
            "[reference]", f"temperature = {cmap.T_ref!r}  # K",
            f"pressure = {cmap.p_ref!r}  # Pa", "", "[provenance]"]
    out += [f"{k} = {_toml_str(v)}" for k, v in cmap.provenance]
    for s in cmap.speed_lines:
        out += ["", "[[speed_line]]", f"speed = {s.speed / RPM!r}"]
        if is_comp:
            out += [f"mass_flow = {_toml_list(s.mass_flow)}",
                    f"pressure_ratio = {_toml_list(s.pressure_ratio)}"]
        else:
            out += [f"expansion_ratio = {_toml_list(s.expansion_ratio)}",
                    f"mass_flow = {_toml_list(s.mass_flow)}"]
        out.append(f"efficiency = {_toml_list(s.efficiency)}")
    if is_comp:
        for label, line in (("surge_line", cmap.surge_line), ("stall_line", cmap.stall_line)):
            out += ["", f"[{label}]", f"speed = {_toml_list(line.speed, RPM)}",
                    f"mass_flow = {_toml_list(line.mass_flow)}",
                    f"pressure_ratio = {_toml_list(line.pressure_ratio)}"]
    path.write_text("\n".join(out) + "\n", encoding="utf-8")
    return path


# --------------------------------------------------------------------------------------------
# Causal tables (the pre-processor's output) and their fast scalar look-up
# --------------------------------------------------------------------------------------------
def _locate(grid: list[float], v: float) -> tuple[int, float, bool]:
    """Cell index, weight in [0, 1], and whether ``v`` was outside the grid (clamped)."""
    if v <= grid[0]:
        return 0, 0.0, v < grid[0]
    if v >= grid[-1]:
        return len(grid) - 2, 1.0, v > grid[-1]
    i = bisect.bisect_right(grid, v) - 1
    return i, (v - grid[i]) / (grid[i + 1] - grid[i]), False


def _bilinear(z: list[list[float]], i: int, wx: float, j: int, wy: float) -> float:
    r0, r1 = z[i], z[i + 1]
    return ((1.0 - wx) * ((1.0 - wy) * r0[j] + wy * r0[j + 1])
            + wx * ((1.0 - wy) * r1[j] + wy * r1[j + 1]))


class _Table:
    """Common part of the causal tables: a grid, values, and the warn-once flag ``warned``
    (True once the table has issued its out-of-data warning; may be reset by the user)."""

    kind = "map"

    def __init__(self, name, speed, second, mass_flow, efficiency, T_ref, p_ref):
        self.name = name
        self.speed = np.asarray(speed, dtype=float)
        self.mass_flow = np.asarray(mass_flow, dtype=float)
        self.efficiency = np.asarray(efficiency, dtype=float)
        self.T_ref = float(T_ref)
        self.p_ref = float(p_ref)
        shape = (self.speed.size, np.asarray(second).size)
        problems = []
        if self.mass_flow.shape != shape or self.efficiency.shape != shape:
            problems.append(f"table shape must be {shape}")
        for label, g in (("speed", self.speed), ("second axis", np.asarray(second))):
            if g.size < 2 or np.any(np.diff(g) <= 0):
                problems.append(f"{label} grid must be strictly increasing with >= 2 points")
        _raise_problems(problems, f"{self.kind} table '{name}'")
        self._speed = self.speed.tolist()
        self._m = self.mass_flow.tolist()
        self._eta = self.efficiency.tolist()
        self.warned = False

    def _warn(self, message: str) -> None:
        if not self.warned:
            self.warned = True
            warnings.warn(f"{self.kind} map '{self.name}': operating point outside the data "
                          f"({message}); clamped to the map edge (warned once per map)",
                          MapRangeWarning, stacklevel=4)


class CompressorTable(_Table):
    """Causal compressor tables ``m_corr(N_corr, chi)``, ``eta(N_corr, chi)`` (eqs 4.23-4.25).

    Parameters
    ----------
    name : str
    speed : array (n,)
        Corrected speed grid [rad/s], strictly increasing.
    chi : array (k,)
        chi grid [-], strictly increasing (normally 0 ... 1).
    mass_flow, efficiency : array (n, k)
        Corrected mass flow [kg/s] and isentropic efficiency [-] on the grid.
    pr_stall, pr_surge : array (n,)
        Stall- and surge-line pressure ratios on each speed line.
    T_ref, p_ref : float
        Reference state of the corrected quantities [K], [Pa].
    """

    kind = "compressor"

    def __init__(self, name, speed, chi, mass_flow, efficiency, pr_stall, pr_surge, T_ref,
                 p_ref, min_span: float = MIN_CHI_SPAN):
        super().__init__(name, speed, chi, mass_flow, efficiency, T_ref, p_ref)
        self.chi = np.asarray(chi, dtype=float)
        self.pr_stall = np.asarray(pr_stall, dtype=float)
        self.pr_surge = np.asarray(pr_surge, dtype=float)
        span = self.pr_surge - self.pr_stall
        if span.shape != self.speed.shape or np.any(~(span >= min_span)):
            raise MapError(f"compressor table '{name}': PR_surge - PR_stall must be >= "
                           f"{min_span:g} on every speed line (the chi 0/0 guard)")
        self._chi = self.chi.tolist()
        self._stall = self.pr_stall.tolist()
        self._span = span.tolist()

    def lookup(self, N_corr: float, PR: float) -> tuple[float, float, float]:
        """Corrected flow [kg/s], efficiency [-] and chi [-] at a corrected speed [rad/s] and a
        total pressure ratio [-].

        The returned chi is the unclamped eq.-4.25 value (chi > 1 surge side, < 0 stalled); the
        flow and efficiency are clamped to the table edge (one :class:`MapRangeWarning`).
        Below the lowest speed line the look-up uses the similar point of that line (fan laws:
        ``PR - 1`` scales with speed squared, flow with speed), so that the flow goes to zero
        with the speed instead of staying at the lowest line's value.
        """
        n0 = self._speed[0]
        if N_corr < n0:
            self._warn(f"N_corr = {N_corr / RPM:.0f} rpm below the lowest speed line, "
                       f"PR = {PR:.4f}; scaled from the lowest line by fan laws")
            r = max(N_corr, 0.0) / n0
            m, eta, chi = self._lookup(n0, 1.0 + (PR - 1.0) / max(r * r, 1e-12))
            return r * m, eta, chi
        return self._lookup(N_corr, PR)

    def _lookup(self, N_corr: float, PR: float) -> tuple[float, float, float]:
        i, wx, out_n = _locate(self._speed, N_corr)
        stall = self._stall[i] + wx * (self._stall[i + 1] - self._stall[i])
        span = self._span[i] + wx * (self._span[i + 1] - self._span[i])
        chi = (PR - stall) / span  # span >= min_span > 0: never 0/0 (module docstring)
        j, wy, out_c = _locate(self._chi, chi)
        if out_n or out_c:
            self._warn(f"N_corr = {N_corr / RPM:.0f} rpm, PR = {PR:.4f}, chi = {chi:.3f}")
        return _bilinear(self._m, i, wx, j, wy), _bilinear(self._eta, i, wx, j, wy), chi


class TurbineTable(_Table):
    """Causal turbine tables ``m_corr(N_corr, ER)``, ``eta(N_corr, ER)`` (eqs 4.30-4.31).

    Parameters
    ----------
    name : str
    speed : array (n,)
        Corrected speed grid [rad/s].
    expansion_ratio : array (k,)
        Expansion-ratio grid p01/p02 [-].
    mass_flow, efficiency : array (n, k)
        Corrected mass flow [kg/s] and efficiency [-].
    T_ref, p_ref : float
        Reference state of the corrected quantities [K], [Pa].
    """

    kind = "turbine"

    def __init__(self, name, speed, expansion_ratio, mass_flow, efficiency, T_ref, p_ref):
        super().__init__(name, speed, expansion_ratio, mass_flow, efficiency, T_ref, p_ref)
        self.expansion_ratio = np.asarray(expansion_ratio, dtype=float)
        self._er = self.expansion_ratio.tolist()

    def lookup(self, N_corr: float, ER: float) -> tuple[float, float]:
        """Corrected flow [kg/s] and efficiency [-] at a corrected speed [rad/s] and expansion
        ratio [-]; clamped to the table edge outside the data (one :class:`MapRangeWarning`)."""
        i, wx, out_n = _locate(self._speed, N_corr)
        j, wy, out_e = _locate(self._er, ER)
        if out_n or out_e:
            self._warn(f"N_corr = {N_corr / RPM:.0f} rpm, ER = {ER:.4f}")
        return _bilinear(self._m, i, wx, j, wy), _bilinear(self._eta, i, wx, j, wy)


def preprocess_compressor(cmap: CompressorMap, n_chi: int = 21, min_span: float = MIN_CHI_SPAN,
                          coverage_tol: float = 0.02) -> CompressorTable:
    """Turn a compressor map into the causal tables over (corrected speed, chi).

    For each speed line, PR_stall and PR_surge are interpolated (in speed) on the stall and surge
    lines, every point gets its chi (eq. 4.25), and flow and efficiency are resampled linearly on
    ``n_chi`` equally spaced chi values in [0, 1].

    Raises
    ------
    MapError
        If a speed line's span ``PR_surge - PR_stall`` is below ``min_span`` (chi 0/0 where the
        surge and stall lines meet), if PR is not strictly monotonic along a line, or if a line
        does not reach the stall or surge line within ``coverage_tol`` in chi.
    """
    grid = np.linspace(0.0, 1.0, n_chi)
    problems: list[str] = []
    m_tab, e_tab, stall, surge = [], [], [], []
    for s in cmap.speed_lines:
        what = f"speed line {s.speed / RPM:.6g} rpm"
        pr_st = cmap.stall_line.pressure_ratio_at(s.speed)
        pr_su = cmap.surge_line.pressure_ratio_at(s.speed)
        stall.append(pr_st)
        surge.append(pr_su)
        if not pr_su - pr_st >= min_span:
            problems.append(f"{what}: PR_surge - PR_stall = {pr_su - pr_st:.3g} < {min_span:g}; "
                            "the surge and stall lines meet here and chi would be 0/0 - drop "
                            "this speed line (run-time look-ups below the lowest line clamp)")
            m_tab.append(np.zeros(n_chi))
            e_tab.append(np.zeros(n_chi))
            continue
        chi = (np.asarray(s.pressure_ratio) - pr_st) / (pr_su - pr_st)
        order = np.argsort(chi)
        chi = chi[order]
        if np.any(np.diff(chi) <= 0):
            problems.append(f"{what}: pressure ratio must be strictly monotonic along the line")
        if chi[0] > coverage_tol or chi[-1] < 1.0 - coverage_tol:
            problems.append(f"{what}: data cover chi {chi[0]:.3f} ... {chi[-1]:.3f}; they must "
                            f"reach the stall (0) and surge (1) lines within {coverage_tol}")
        m_tab.append(np.interp(grid, chi, np.asarray(s.mass_flow)[order]))
        e_tab.append(np.interp(grid, chi, np.asarray(s.efficiency)[order]))
    _raise_problems(problems, f"compressor map '{cmap.name}'")
    return CompressorTable(cmap.name, [s.speed for s in cmap.speed_lines], grid, m_tab, e_tab,
                           stall, surge, cmap.T_ref, cmap.p_ref, min_span)


def preprocess_turbine(tmap: TurbineMap, expansion_ratio=None) -> TurbineTable:
    """Turn a turbine map into the causal tables over (corrected speed, expansion ratio).

    ``expansion_ratio`` is the common grid; by default the union of the lines' expansion ratios
    within the range that every line covers.  Each line is resampled linearly on it.
    """
    lo = max(s.expansion_ratio[0] for s in tmap.speed_lines)
    hi = min(s.expansion_ratio[-1] for s in tmap.speed_lines)
    if expansion_ratio is None:
        allv = np.unique(np.concatenate([s.expansion_ratio for s in tmap.speed_lines]))
        expansion_ratio = allv[(allv >= lo) & (allv <= hi)]
    er = np.asarray(expansion_ratio, dtype=float)
    if er.size < 2 or er[0] < lo - 1e-12 or er[-1] > hi + 1e-12:
        raise MapError(f"turbine map '{tmap.name}': the expansion-ratio grid must lie in "
                       f"[{lo:g}, {hi:g}], the range every speed line covers")
    m = [np.interp(er, s.expansion_ratio, s.mass_flow) for s in tmap.speed_lines]
    e = [np.interp(er, s.expansion_ratio, s.efficiency) for s in tmap.speed_lines]
    return TurbineTable(tmap.name, [s.speed for s in tmap.speed_lines], er, m, e, tmap.T_ref,
                        tmap.p_ref)


# --------------------------------------------------------------------------------------------
# Published analytic fits (Wahlström & Eriksson) and map generation
# --------------------------------------------------------------------------------------------
_WE_SOURCE = ("J. Wahlstrom, L. Eriksson, 'Modelling diesel engines with a variable-geometry "
              "turbocharger and exhaust gas recirculation by optimization of model parameters "
              "for capturing non-linear system dynamics', Proc. IMechE Part D 225(7):960-986, "
              "2011; parameter values of the TCDI_EGR_VGT package (parameterData.mat, LGPL-3) "
              "as listed in shared/reference/turbo_engine.md section 1.1")


def _poly2(c: tuple[float, float, float], x: float) -> float:
    return c[0] * x * x + c[1] * x + c[2]


@dataclass(frozen=True)
class WECompressorFit:
    """Wahlström & Eriksson compressor fit: ellipse flow model and quadratic efficiency.

    All numbers are the published parameters [WE-pkg].  The fit is written at the fit's ambient
    state (``p_amb``, ``T_amb``), which is therefore used as the reference state of the
    corrected quantities: at that state corrected and actual quantities coincide.
    """

    R_c: float = 0.04                                                   # m
    c_wpsi: tuple[float, float, float] = (1.08820511e-08, -1.73197604e-04, 1.02861648)
    c_wphi: tuple[float, float, float] = (-1.42977827e-08, -1.54988141e-03, 29.6461722)
    c_psi2: float = 0.0
    c_phi2: float = 0.0
    eta_max: float = 0.73636079
    W_opt: float = 0.27533757                                           # kg/s
    pi_opt: float = 1.04551775
    c_pi: float = 0.27075947
    Q: tuple[float, float, float] = (3.09189777, -2.48232014, 2.14785596)  # Q11, Q12, Q22
    p_amb: float = 101111.34                                            # Pa
    T_amb: float = 298.46                                               # K
    gas: Gas = AIR

    def _coeffs(self, omega: float) -> tuple[float, float]:
        return max(0.0, _poly2(self.c_wpsi, omega)), max(0.1, _poly2(self.c_wphi, omega))

    def head(self, omega: float, PR: float) -> float:
        """Dimensionless head Psi_c at turbo speed [rad/s] and pressure ratio [-]."""
        return (2.0 * self.gas.cp * self.T_amb * (max(PR, 1.0) ** self.gas.kappa - 1.0)
                / (self.R_c * omega) ** 2)

    def pressure_ratio(self, omega: float, psi: float) -> float:
        """Pressure ratio [-] of a head Psi_c at turbo speed [rad/s] (inverse of :meth:`head`)."""
        return (1.0 + psi * (self.R_c * omega) ** 2 / (2.0 * self.gas.cp * self.T_amb)) \
            ** (1.0 / self.gas.kappa)

    def zero_flow_head(self, omega: float) -> float:
        """Head where the ellipse gives zero flow, ``c_psi2 + 1/sqrt(c_psi1)``."""
        return self.c_psi2 + 1.0 / math.sqrt(self._coeffs(omega)[0])

    def mass_flow(self, omega: float, PR: float) -> float:
        """Mass flow [kg/s] at the fit's ambient state (the ellipse model)."""
        c_psi1, c_phi1 = self._coeffs(omega)
        psi = self.head(omega, PR)
        phi = max(0.0, self.c_phi2 + math.sqrt(max(0.0, 1.0 - c_psi1 * (psi - self.c_psi2) ** 2)
                                               / c_phi1))
        return self.p_amb * math.pi * self.R_c ** 3 * omega * phi / (self.gas.R * self.T_amb)

    def efficiency(self, mass_flow: float, PR: float) -> float:
        """Isentropic efficiency [-]: ``max(0.2, eta_max - d'Q d)``."""
        d1 = mass_flow - self.W_opt
        d2 = (max(PR, 1.0) - 1.0) ** self.c_pi - self.pi_opt
        q11, q12, q22 = self.Q
        return max(0.2, self.eta_max - (q11 * d1 * d1 + 2.0 * q12 * d1 * d2 + q22 * d2 * d2))


@dataclass(frozen=True)
class WETurbineFit:
    """Wahlström & Eriksson turbine fit (VGT frozen at ``vgt_position``): restriction-type flow
    ``W_t = A_vgtmax*f_vgt*p*sqrt(1 - ER^-K_t)/sqrt(T*R_e)`` and the BSR-parabola efficiency
    ``eta_tm`` (which lumps the mechanical losses of the shaft).  Published parameters [WE-pkg];
    ``vgt_position`` [%] is the fixed-geometry choice of this project.
    """

    R_t: float = 0.04                                                   # m
    A_vgtmax: float = 8.4558e-4                                         # m^2
    K_t: float = 2.89019266
    c_f1: float = 1.9479627
    c_f2: float = -0.77631189
    c_vgt1: float = 126.87193572
    c_vgt2: float = 117.14474688
    eta_max: float = 0.81800273
    BSR_opt: float = 0.97552032
    c_m: tuple[float, float, float] = (1.35634407, 2769.2092, 0.0100000987)
    w_tlin: float = 2796.90                                             # rad/s
    c_mlin: float = 1.40214708
    vgt_position: float = 100.0                                         # %
    gas: Gas = EXHAUST

    @property
    def f_vgt(self) -> float:
        """Effective-area factor of the frozen vane position [-]."""
        u = min(max(self.vgt_position, 20.0), 100.0)
        return max(0.0, self.c_f2 + self.c_f1 * math.sqrt(
            max(0.0, 1.0 - ((u - self.c_vgt2) / self.c_vgt1) ** 2)))

    def mass_flow(self, p_in: float, T_in: float, ER: float) -> float:
        """Mass flow [kg/s] at inlet pressure [Pa], inlet temperature [K], expansion ratio."""
        pi_t = min(1.0 / ER, 1.0)
        return (self.A_vgtmax * self.f_vgt * p_in * math.sqrt(1.0 - pi_t ** self.K_t)
                / math.sqrt(T_in * self.gas.R))

    def efficiency(self, omega: float, T_in: float, ER: float) -> float:
        """Turbine-mechanical efficiency eta_tm [-] at turbo speed [rad/s], inlet temperature
        [K] and expansion ratio [-] (BSR clamped to [0, 2*BSR_opt], eta to [0.2, 1])."""
        c1, c2, c3 = self.c_m
        if omega > self.w_tlin:
            c_m = c1 * (omega - c2) ** c3
        else:
            c_m = self.c_mlin * max(0.0, omega - c2) / (self.w_tlin - c2)
        dh = 2.0 * self.gas.cp * T_in * (1.0 - min(1.0 / ER, 1.0) ** self.gas.kappa)
        bsr = 2.0 * self.BSR_opt if dh <= 0.0 else min(self.R_t * omega / math.sqrt(dh),
                                                        2.0 * self.BSR_opt)
        return min(max(self.eta_max - c_m * (bsr - self.BSR_opt) ** 2, 0.2), 1.0)


DEFAULT_VGT_POSITION = 55.0
"""Frozen vane position [%] of the shipped fixed-geometry turbine map (chosen so that the engine
of :mod:`transgen.sim.engine` reaches a boost pressure ratio of about 2.7 at 2100 rpm)."""


def generate_compressor_map(fit: WECompressorFit = WECompressorFit(),
                            speeds_rpm=tuple(range(10_000, 140_001, 10_000)),
                            n_points: int = 13,
                            surge_flow_fraction: float = 0.25) -> CompressorMap:
    """Regenerate a compressor map in manufacturer format from the W&E fit.

    On each speed line the points are equally spaced in pressure ratio from the stall line to the
    surge line.  Definitions (documented choices, not part of the fit):

    * stall/choke line: PR = 1, where the ellipse gives its largest flow;
    * surge line: the flow is ``surge_flow_fraction`` of that largest flow.  The W&E ellipse has
      no rising part left of its peak, so a constant-margin rule is used.

    Speeds are corrected speeds at the fit's ambient state, which is also the map's reference.
    """
    lines, surge, stall = [], [], []
    for n in speeds_rpm:
        w = n * RPM
        psi_s = fit.zero_flow_head(w) * math.sqrt(1.0 - surge_flow_fraction ** 2)
        pr = np.linspace(1.0, fit.pressure_ratio(w, psi_s), n_points)
        m = [fit.mass_flow(w, p) for p in pr]
        lines.append(CompressorSpeedLine(w, tuple(m), tuple(float(p) for p in pr),
                                         tuple(fit.efficiency(mi, p) for mi, p in zip(m, pr))))
        surge.append((w, m[-1], float(pr[-1])))
        stall.append((w, m[0], 1.0))
    prov = (("source", _WE_SOURCE),
            ("generator", "transgen.sim.maps.generate_compressor_map (sim/data/make_maps.py)"),
            ("definitions", f"stall line PR = 1 (largest flow of the ellipse); surge line at "
                            f"{surge_flow_fraction} of that flow (constant-margin rule); "
                            "reference state = the fit's ambient state"),
            ("validity", "the fit was identified in the engine's operating range; lines above "
                         "about 110 krpm are extrapolation of the fit (efficiency at its 0.2 "
                         "floor over much of the line)"),
            ("licence", "numbers computed from published model parameters; no proprietary data"))
    return CompressorMap("W&E 12.7 L heavy-duty compressor (regenerated fit)", tuple(lines),
                         MapLine(*map(tuple, zip(*surge))), MapLine(*map(tuple, zip(*stall))),
                         fit.T_amb, fit.p_amb, prov)


_TURBINE_ER = (1.0, 1.005, 1.01, 1.02, 1.04, 1.07, 1.1, 1.15, 1.2, 1.3, 1.4, 1.5, 1.65, 1.8, 2.0,
               2.25, 2.5, 2.75, 3.0, 3.5, 4.0, 4.5, 5.0, 6.0)


def generate_turbine_map(fit: WETurbineFit = WETurbineFit(vgt_position=DEFAULT_VGT_POSITION),
                         speeds_rpm=tuple(range(10_000, 140_001, 10_000)),
                         expansion_ratio=_TURBINE_ER, T_ref: float = 873.15,
                         p_ref: float = 101325.0) -> TurbineMap:
    """Regenerate a fixed-geometry turbine map in manufacturer format from the W&E fit.

    The fit's efficiency depends on the blade-speed ratio, a function of ``omega/sqrt(T)`` and
    the expansion ratio, hence of (corrected speed, ER).  Its speed-dependent coefficient
    ``c_m(omega)`` is evaluated at ``omega = N_corr`` (i.e. at the reference temperature).
    The point ER = 1 (zero flow) is included so that the table linearises the flow function
    near ER = 1, where its slope is infinite.
    """
    lines = []
    for n in speeds_rpm:
        w = n * RPM
        m = tuple(fit.mass_flow(p_ref, T_ref, er) for er in expansion_ratio)
        e = tuple(fit.efficiency(w, T_ref, er) for er in expansion_ratio)
        lines.append(TurbineSpeedLine(w, tuple(map(float, expansion_ratio)), m, e))
    prov = (("source", _WE_SOURCE),
            ("generator", "transgen.sim.maps.generate_turbine_map (sim/data/make_maps.py)"),
            ("definitions", f"VGT frozen at {fit.vgt_position:g} % (f_vgt = {fit.f_vgt:.5f}): "
                            "treated as a fixed-geometry turbine; efficiency is W&E's eta_tm, "
                            "which includes the mechanical (bearing) losses; c_m(omega) taken "
                            "at omega = N_corr"),
            ("licence", "numbers computed from published model parameters; no proprietary data"))
    return TurbineMap("W&E 12.7 L heavy-duty turbine, fixed geometry (regenerated fit)",
                      tuple(lines), T_ref, p_ref, prov)


@lru_cache(maxsize=None)
def _load_cached(path: str) -> CompressorMap | TurbineMap:
    return load_map(path)


def default_compressor_table() -> CompressorTable:
    """A fresh causal table of the shipped compressor map ``data/we_compressor.toml``."""
    cmap = _load_cached(str(DATA_DIR / "we_compressor.toml"))
    assert isinstance(cmap, CompressorMap)
    return preprocess_compressor(cmap)


def default_turbine_table() -> TurbineTable:
    """A fresh causal table of the shipped turbine map ``data/we_turbine.toml``."""
    tmap = _load_cached(str(DATA_DIR / "we_turbine.toml"))
    assert isinstance(tmap, TurbineMap)
    return preprocess_turbine(tmap)
