"""The loss parameters of a transmission and the TOML loss file that gives them.

A :class:`LossModel` holds the drag model of every open shift element, the spin model of every
link and the pump; what the file does not give comes from the defaults (estimates, with their
sources in ``docs/losses.md``):

* drag of an open **clutch or brake**: :data:`DEFAULT_DRAG`, ``c * slip`` with ``c`` from
  :func:`~transgen.losses.drag.couette_coefficient` for a typical car pack (8 faces, radii
  64/85 mm, film 0.15 mm, ATF 0.015 Pa*s: 4.7 N*m, 0.49 kW at 1000 rpm slip); a **one-way
  clutch** or a **dog** drags nothing unless the file names it;
* spin of a link: none (no published per-link values were found; give them in the file);
* the pump: :data:`DEFAULT_PUMP`, 12 cm^3/rev at 1.0 MPa, efficiency 0.85.

The file (every key optional; units in the names' docs)::

    oil_temperature = 90.0            # degC: picks the row of a drag table
    [drag.default]                    # every open clutch and brake not named below
    kind = "viscous"                  # or "none"
    c = 0.0445                        # N*m*s/rad
    [drag.elements.C1]                # one element
    kind = "table"
    slip_rpm = [0, 500, 1000, 2000, 4000]
    torque = [[0, 3, 5, 3.5, 2.5], [0, 2, 3.5, 2.5, 2]]   # N*m, one row per oil temperature
    oil_temperature = [40.0, 90.0]    # degC, increasing (omit for one row)
    [spin.default]                    # every link not named below
    coefficients = [0.05, 0.0, 1e-6]  # T = a0 + a1 |w| + a2 w^2 [N*m], w in rad/s
    [spin.links.L2]
    kind = "table"
    speed_rpm = [0, 2000, 6000]
    torque = [0.0, 0.3, 0.9]          # N*m
    [pump]
    displacement = 12e-6              # m^3/rev
    line_pressure = 1.0e6             # Pa
    pressure_per_torque = 0.0         # Pa per N*m of input torque
    efficiency = 0.85
    speed_ratio = 1.0                 # pump speed / input speed

Errors are reported ``FILE:LINE:COL: error: message`` (:class:`LossFileError`, exit 2).
"""
from __future__ import annotations

import difflib
import math
import re
import tomllib
from dataclasses import dataclass, field
from pathlib import Path

from ..errors import Diagnostic, TransgenError
from .drag import TableDrag, ViscousDrag, couette_coefficient
from .pump import Pump
from .spin import PolynomialSpin, TableSpin

__all__ = ["LossModel", "LossFileError", "LossDataError", "LOSS_KEYS", "loss_model", "DEFAULT_DRAG", "DEFAULT_PUMP", "DEFAULT_SPIN", "NO_DRAG",
           "load_losses", "parse_losses"]

DEFAULT_DRAG = ViscousDrag(couette_coefficient(8, 0.015, 0.15e-3, 0.064, 0.085))
"""Full-film drag of a typical car pack (about 0.0445 N*m*s/rad): see the module docstring."""
NO_DRAG = ViscousDrag(0.0)
DEFAULT_SPIN = PolynomialSpin(())
"""No spin loss."""
DEFAULT_PUMP = Pump(displacement=12e-6, line_pressure=1.0e6, pressure_per_torque=0.0, efficiency=0.85)
"""A car transmission's fixed-displacement pump: 12 cm^3/rev at 1.0 MPa, efficiency 0.85 (estimates)."""
DRAGGING_KINDS = ("clutch", "brake")
"""Element kinds that drag by default when open."""


class LossFileError(TransgenError, ValueError):
    """A bad loss file or bad loss parameters; the message is located ``FILE:LINE:COL``."""


@dataclass(frozen=True)
class LossModel:
    """Drag, spin and pump parameters. ``drag``/``spin``: models by element/link name; the
    others take ``default_drag`` (clutches and brakes; none for one-way clutches and dogs) and
    ``default_spin``. ``oil_temperature`` [degC]; ``source``: the file or ``"defaults"``."""

    default_drag: object = DEFAULT_DRAG
    drag: dict = field(default_factory=dict)
    default_spin: object = DEFAULT_SPIN
    spin: dict = field(default_factory=dict)
    pump: Pump = DEFAULT_PUMP
    oil_temperature: float = 90.0
    source: str = "defaults"

    def drag_model(self, element):
        """The drag model of a :class:`~transgen.model.ShiftElement`: the file's model of it, else
        its ``drag=`` in the ``.mech`` (``c * slip``), else the default of its kind."""
        if element.name in self.drag:
            return self.drag[element.name]
        if getattr(element, "drag", None) is not None:
            return ViscousDrag(element.drag)
        return self.default_drag if element.kind in DRAGGING_KINDS else NO_DRAG

    def spin_model(self, link: str):
        return self.spin.get(link, self.default_spin)

    def to_dict(self) -> dict:
        return {"source": self.source, "oil_temperature": self.oil_temperature,
                "default_drag": self.default_drag.to_dict(), "drag": {k: v.to_dict() for k, v in self.drag.items()},
                "default_spin": self.default_spin.to_dict(), "spin": {k: v.to_dict() for k, v in self.spin.items()},
                "pump": self.pump.to_dict()}


# ---------------------------------------------------------------------------------------------

class LossDataError(ValueError):
    """A bad value in loss data (:func:`loss_model`): ``path``, the key path in the data, and
    ``message`` (without a location: the caller locates it in its file)."""

    def __init__(self, path: tuple, message: str):
        super().__init__(message)
        self.path, self.message = path, message


_Bad = LossDataError


def _locate(text: str, path: tuple) -> tuple[int, int]:
    """Line and column of the key ``path`` in ``text`` (the deepest part found; 1, 1 else)."""
    lines = text.splitlines()
    best = (1, 1)
    header = re.compile(r"^\s*\[\s*([^\]]+?)\s*\]")
    for depth in range(1, len(path) + 1):
        table, key = ".".join(str(p) for p in path[:depth - 1]), str(path[depth - 1])
        current = ""
        for n, line in enumerate(lines, 1):
            m = header.match(line)
            if m:
                current = m.group(1).replace(" ", "").replace('"', "")
                if current == ".".join(str(p) for p in path[:depth]):
                    best = (n, line.index("[") + 1)
                    break
                continue
            k = re.search(rf"(?:^|[{{,\s])({re.escape(key)})\s*=", line)
            if k and (current == table or (table and table.startswith(current))):
                best = (n, k.start(1) + 1)
                break
    return best


def _number(data: dict, key: str, path: tuple, low: float = -math.inf, high: float = math.inf,
            low_open: bool = False, default=None) -> float:
    if key not in data:
        if default is None:
            raise _Bad(path, f"missing '{key}'")
        return default
    v = data[key]
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
        raise _Bad(path + (key,), f"'{key}' must be a finite number, not {v!r}")
    if (v <= low if low_open else v < low) or v > high:
        raise _Bad(path + (key,), f"'{key}' = {v:g} is outside {'(' if low_open else '['}{low:g}, {high:g}]")
    return float(v)


def _numbers(data: dict, key: str, path: tuple, increasing: bool = False, nonnegative: bool = False) -> tuple:
    v = data.get(key)
    if not isinstance(v, list) or not v or not all(isinstance(x, (int, float)) and not isinstance(x, bool)
                                                    and math.isfinite(x) for x in v):
        raise _Bad(path + (key,), f"'{key}' must be a non-empty list of finite numbers")
    if nonnegative and min(v) < 0:
        raise _Bad(path + (key,), f"'{key}' must not be negative")
    if increasing and any(b <= a for a, b in zip(v, v[1:])):
        raise _Bad(path + (key,), f"'{key}' must increase strictly")
    return tuple(float(x) for x in v)


def _unknown_keys(data: dict, allowed: set, path: tuple) -> None:
    for k in data:
        if k not in allowed:
            raise _Bad(path + (k,), f"unknown key '{k}' (expected {', '.join(sorted(allowed))})")


def _drag(data, path: tuple):
    if not isinstance(data, dict):
        raise _Bad(path, "a drag model must be a table")
    kind = data.get("kind", "viscous")
    if kind == "none":
        _unknown_keys(data, {"kind"}, path)
        return NO_DRAG
    if kind == "viscous":
        _unknown_keys(data, {"kind", "c"}, path)
        return ViscousDrag(_number(data, "c", path, 0.0))
    if kind == "table":
        _unknown_keys(data, {"kind", "slip_rpm", "torque", "oil_temperature"}, path)
        slip = _numbers(data, "slip_rpm", path, increasing=True, nonnegative=True)
        temps = _numbers(data, "oil_temperature", path, increasing=True) if "oil_temperature" in data else ()
        rows = data.get("torque")
        if isinstance(rows, list) and rows and not isinstance(rows[0], list):
            rows = [rows]
        if not isinstance(rows, list) or not rows:
            raise _Bad(path + ("torque",), "'torque' must be a list of numbers or of rows")
        values = tuple(_numbers({"torque": r}, "torque", path, nonnegative=True) for r in rows)
        if any(len(r) != len(slip) for r in values):
            raise _Bad(path + ("torque",), f"every 'torque' row needs {len(slip)} values, one per slip_rpm")
        if len(values) != max(1, len(temps)):
            raise _Bad(path + ("torque",), f"'torque' needs {max(1, len(temps))} rows, one per oil_temperature")
        return TableDrag(slip, values, temps)
    raise _Bad(path + ("kind",), f"unknown drag kind {kind!r} (expected 'viscous', 'table' or 'none')")


def _spin(data, path: tuple):
    if not isinstance(data, dict):
        raise _Bad(path, "a spin model must be a table")
    kind = data.get("kind", "polynomial")
    if kind == "polynomial":
        _unknown_keys(data, {"kind", "coefficients"}, path)
        return PolynomialSpin(_numbers(data, "coefficients", path, nonnegative=True))
    if kind == "table":
        _unknown_keys(data, {"kind", "speed_rpm", "torque"}, path)
        speed = _numbers(data, "speed_rpm", path, increasing=True, nonnegative=True)
        torque = _numbers(data, "torque", path, nonnegative=True)
        if len(torque) != len(speed):
            raise _Bad(path + ("torque",), f"'torque' needs {len(speed)} values, one per speed_rpm")
        return TableSpin(speed, torque)
    raise _Bad(path + ("kind",), f"unknown spin kind {kind!r} (expected 'polynomial' or 'table')")


def _pump(data, path: tuple) -> Pump:
    if not isinstance(data, dict):
        raise _Bad(path, "[pump] must be a table")
    keys = {"displacement", "line_pressure", "pressure_per_torque", "efficiency", "speed_ratio"}
    _unknown_keys(data, keys, path)
    d = DEFAULT_PUMP
    return Pump(_number(data, "displacement", path, 0.0, 1.0, default=d.displacement),
                _number(data, "line_pressure", path, 0.0, 1e9, default=d.line_pressure),
                _number(data, "pressure_per_torque", path, 0.0, 1e9, default=d.pressure_per_torque),
                _number(data, "efficiency", path, 0.0, 1.0, low_open=True, default=d.efficiency),
                _number(data, "speed_ratio", path, 0.0, 100.0, default=d.speed_ratio))


def _models(data: dict, section: str, names_key: str, parse, default):
    table = data.get(section, {})
    if not isinstance(table, dict):
        raise _Bad((section,), f"[{section}] must be a table")
    _unknown_keys(table, {"default", names_key}, (section,))
    base = parse(table["default"], (section, "default")) if "default" in table else default
    named = table.get(names_key, {})
    if not isinstance(named, dict):
        raise _Bad((section, names_key), f"[{section}.{names_key}] must be a table of named models")
    return base, {k: parse(v, (section, names_key, k)) for k, v in named.items()}


def _check_names(model: LossModel, mech) -> None:
    elements, links = set(mech.element_names), set(mech.link_names)
    for name in model.drag:
        if name not in elements:
            raise _Bad(("drag", "elements", name), f"no shift element '{name}' in {mech.name}{_hint(name, elements)}")
    for name in model.spin:
        if name not in links:
            raise _Bad(("spin", "links", name), f"no link '{name}' in {mech.name}{_hint(name, links)}")


def _hint(name: str, names: set) -> str:
    close = difflib.get_close_matches(name, sorted(names), n=1)
    return f"; did you mean '{close[0]}'?" if close else f" (names: {', '.join(sorted(names)) or 'none'})"


def parse_losses(text: str, filename: str = "<losses>", mech=None) -> LossModel:
    """The :class:`LossModel` of a loss file's text; with ``mech`` the element and link names are
    checked. Raises :class:`LossFileError`."""
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        m = re.search(r"at line (\d+), column (\d+)", str(exc))
        line, col = (int(m.group(1)), int(m.group(2))) if m else (1, 1)
        msg = re.sub(r"\s*\(at line \d+, column \d+\)", "", str(exc))
        raise LossFileError(str(_diagnostic(text, filename, line, col, f"not valid TOML: {msg}"))) from None
    try:
        model = loss_model(data, filename, mech)
    except _Bad as bad:
        line, col = _locate(text, bad.path)
        raise LossFileError(str(_diagnostic(text, filename, line, col, bad.message))) from None
    return model


LOSS_KEYS = frozenset({"oil_temperature", "drag", "spin", "pump"})
"""The top-level keys of loss data."""


def loss_model(data: dict, source: str = "defaults", mech=None) -> LossModel:
    """The :class:`LossModel` of loss data (a loss file's parsed TOML, or a scenario's
    ``[losses]`` table: the keys :data:`LOSS_KEYS`); with ``mech`` the names are checked.
    Raises :class:`LossDataError` with the key path of the bad value."""
    _unknown_keys(data, set(LOSS_KEYS), ())
    oil = _number(data, "oil_temperature", (), -60.0, 300.0, default=90.0)
    default_drag, drag = _models(data, "drag", "elements", _drag, DEFAULT_DRAG)
    default_spin, spin = _models(data, "spin", "links", _spin, DEFAULT_SPIN)
    pump = _pump(data["pump"], ("pump",)) if "pump" in data else DEFAULT_PUMP
    model = LossModel(default_drag, drag, default_spin, spin, pump, oil, source)
    if mech is not None:
        _check_names(model, mech)
    return model


def _diagnostic(text: str, filename: str, line: int, col: int, message: str) -> Diagnostic:
    lines = text.splitlines()
    return Diagnostic(filename, line, col, message, lines[line - 1] if 0 < line <= len(lines) else "")


def load_losses(path: str | Path | None, mech=None) -> LossModel:
    """The :class:`LossModel` of the loss file ``path`` (``None`` or ``""``: the defaults)."""
    if not path:
        return LossModel()
    p = Path(path)
    try:
        text = p.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise LossFileError(f"{path}:1:1: error: cannot read the loss file: {exc}") from None
    return parse_losses(text, str(path), mech)
