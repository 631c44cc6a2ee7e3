"""Turbocharger map files: the manufacturer-like format, its reader and its writer.

A compressor or turbine map as a manufacturer gives it (speed lines of flow, pressure or
expansion ratio and efficiency; for the compressor also its surge and stall lines), read into
frozen dataclasses that validate their data (:class:`CompressorMap`, :class:`TurbineMap`).  The
pre-processor (:mod:`transgen.sim.engine.preprocessor`, thesis 4.4) turns them into causal tables.

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

Every problem found in a file is listed in one :class:`MapError`.  :data:`DATA_DIR` is the folder
of the shipped maps and converter table (``sim/data/``).
"""
from __future__ import annotations

import math
import re
import tomllib
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from transgen.errors import TransgenError
from transgen.outputs import note_input
from transgen.outputs import note_input

from .gas import RPM

__all__ = [
    "DATA_DIR",
    "MapError",
    "MapLine",
    "CompressorSpeedLine",
    "TurbineSpeedLine",
    "CompressorMap",
    "TurbineMap",
    "load_map",
    "parse_map",
    "save_map",
]

DATA_DIR = Path(__file__).resolve().parent.parent / "data"
"""Folder of the shipped example maps and tables (``sim/data/``, installed as ``transgen/sim/data``)."""


class MapError(TransgenError, ValueError):
    """A map file or map data is invalid; the message lists every problem found."""


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
        problems = _map_problems(self, ("mass_flow", "pressure_ratio", "efficiency"))
        for label, line in (("surge line", self.surge_line), ("stall line", self.stall_line)):
            _check_lengths(label, problems, speed=line.speed, mass_flow=line.mass_flow,
                           pressure_ratio=line.pressure_ratio)
            if any(b <= a for a, b in zip(line.speed, line.speed[1:])):
                problems.append(f"{label}: speeds must be strictly increasing")
        _raise_problems(problems, f"compressor map '{self.name}'")

    @staticmethod
    def _line_problems(s: CompressorSpeedLine):
        if not _efficiencies_valid(s):
            yield _EFFICIENCY_RANGE
        if any(m < 0.0 for m in s.mass_flow) or any(p <= 0.0 for p in s.pressure_ratio):
            yield "mass flow must be >= 0 and pressure ratio > 0"


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
        problems = _map_problems(self, ("expansion_ratio", "mass_flow", "efficiency"))
        _raise_problems(problems, f"turbine map '{self.name}'")

    @staticmethod
    def _line_problems(s: TurbineSpeedLine):
        if any(b <= a for a, b in zip(s.expansion_ratio, s.expansion_ratio[1:])):
            yield "expansion ratios must be strictly increasing"
        if any(e < 1.0 for e in s.expansion_ratio):
            yield "expansion ratios must be >= 1"
        if not all(0.0 <= e <= 1.0 for e in s.efficiency):
            yield "efficiency must be in [0, 1] (0 where the turbine does no work: ER = 1, standstill)"
        if any(m < 0.0 for m in s.mass_flow):
            yield "mass flow must be >= 0"


_EFFICIENCY_RANGE = "efficiency must be in (0, 1]"


def _efficiencies_valid(s) -> bool:
    return all(0.0 < e <= 1.0 for e in s.efficiency)


def _map_problems(m: CompressorMap | TurbineMap, columns: tuple[str, ...]) -> list[str]:
    """The problems of a map's reference state and speed lines: the speeds, the lengths of the
    ``columns`` of each line, and what the map's ``_line_problems(line)`` finds on it."""
    problems: list[str] = []
    if not (m.T_ref > 0.0 and m.p_ref > 0.0):
        problems.append(f"reference state must be positive (T_ref={m.T_ref}, p_ref={m.p_ref})")
    speeds = [s.speed for s in m.speed_lines]
    if len(speeds) < 2 or any(b <= a for a, b in zip(speeds, speeds[1:])):
        problems.append("speed lines: need at least 2, in strictly increasing speed")
    for s in m.speed_lines:
        what = f"speed line {s.speed / RPM:.6g} rpm"
        _check_lengths(what, problems, **{c: getattr(s, c) for c in columns})
        problems += [f"{what}: {p}" for p in m._line_problems(s)]
    return problems


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
        note_input(path)
    except (OSError, UnicodeDecodeError) as exc:
        raise MapError(f"{path}:1:1: error: cannot read map file ({exc})") from None
    return parse_map(text, path)


def parse_map(text: str, path: str | Path = "<map>") -> CompressorMap | TurbineMap:
    """A compressor or turbine map from the text of a map file; ``path`` names it in messages
    (and its stem is the default name). Raises :class:`MapError` as :func:`load_map` does."""
    path = Path(path)
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
    from transgen.export import write_text  # lazy: transgen.export imports the symbolic core

    write_text(path, "\n".join(out) + "\n")
    return path
