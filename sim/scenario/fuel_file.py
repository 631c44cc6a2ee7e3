"""Reading ``[input] fuel_map`` of a scenario (:mod:`.fuel` has the models and the method):
the table or the Willans estimate, with located errors."""
from __future__ import annotations

from ..engine.fuel import FUEL_KEYS, PETROL_DENSITY, PETROL_HEATING_VALUE, RPM, WILLANS_EFFICIENCY, FuelMap, WillansFuel
from .file import as_float, shown

__all__ = ["read_fuel_map"]


def read_fuel_map(r, spec, keys, engine):
    """The fuel map of ``[input] fuel_map`` (``spec`` at ``keys``) for the torque map ``engine``;
    errors located in the file (``r``: the scenario's reader)."""
    if isinstance(spec, str):
        spec = {"type": spec}
    if not isinstance(spec, dict):
        raise r.error(keys, f"fuel_map must be \"willans\" or a table {{ type = \"table\" | \"willans\", ... }}, "
                            f"not {shown(spec)}")
    spec = r.checked(spec, keys, FUEL_KEYS)
    kind = r.text(spec, keys, "type", "table")
    density = r.number(spec, keys, "density", PETROL_DENSITY, positive=True)
    if kind == "willans":
        for k in ("speed_rpm", "torque", "fuel_rate", "bsfc"):
            if k in spec:
                raise r.error(keys + (k,), f"'{k}' belongs to a fuel_map of type \"table\", not \"willans\"")
        return WillansFuel(engine, r.number(spec, keys, "efficiency", WILLANS_EFFICIENCY, positive=True),
                           r.number(spec, keys, "heating_value", PETROL_HEATING_VALUE, positive=True), density)
    if kind != "table":
        raise r.error(keys + ("type",), f"fuel_map type must be \"table\" or \"willans\", not {shown(kind)}")
    speeds = [x * RPM for x in r.numbers(spec, keys, "speed_rpm")]
    torques = r.numbers(spec, keys, "torque")
    for name, values in (("speed_rpm", speeds), ("torque", torques)):
        if any(b <= a for a, b in zip(values, values[1:])):
            raise r.error(keys + (name,), f"fuel_map {name} must be increasing")
    has = [k for k in ("fuel_rate", "bsfc") if k in spec]
    if len(has) != 1:
        raise r.error(keys, "a fuel_map table gives one of 'fuel_rate' [g/s] or 'bsfc' [g/kWh]")
    grid = _grid(r, spec, keys, has[0], len(torques), len(speeds))
    if has[0] == "fuel_rate":
        rate = [[g / 1000.0 for g in row] for row in grid]
    else:  # g/kWh x kW -> g/h; none at zero or negative power
        rate = [[b * max(tq, 0.0) * w / 3.6e9 for b, w in zip(row, speeds)] for row, tq in zip(grid, torques)]
    return FuelMap(tuple(speeds), tuple(torques), tuple(tuple(row) for row in rate), density)


def _grid(r, table, keys, name, rows, columns):
    v = table.get(name)
    if not isinstance(v, list) or len(v) != rows or not all(isinstance(row, list) and len(row) == columns for row in v):
        raise r.error(keys + (name,), f"{name} must be {rows} rows (one per torque) of {columns} numbers (one per speed)")
    out = []
    for k, row in enumerate(v):
        values = [as_float(x) for x in row]
        if None in values or any(x < 0 for x in values):
            j = next(i for i, x in enumerate(values) if x is None or x < 0)
            raise r.error(keys + (name, k, j), f"{name}: row {k + 1}, entry {j + 1} is {shown(row[j])}, "
                                               "not a finite number >= 0")
        out.append(values)
    return out
