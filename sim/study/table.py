"""The result table of a study: one row per run, CSV in and out, units of the columns.

Columns: ``key`` (the row key, :func:`~.design.row_key`), the parameters (their dotted keys),
``success``, ``message``, ``wall_time`` [s], then the scalars of the run (``energy.*``,
``shift.<name>.*`` - ``shift.1-2.torque_hole``, a shift by its name, :func:`shift_columns` -,
``turbo.*``, see :mod:`.task`) in the order they first appear. A run that lacks a column (a
failed run, fewer shifts) has an empty cell. Units are those of :func:`column_unit`. Tables
written before shifts were named by gear number them (``shift1.torque_hole``): they are read as
they are, and :func:`column_shift` knows both.

The CSV is plain (header = column names, so that pandas and spreadsheets read it as it is);
numbers are written with Python's shortest round-trip repr, so :meth:`SweepTable.from_csv` reads
back the very numbers; booleans are ``True``/``False``; a list or table parameter is its JSON text.
"""
from __future__ import annotations

import csv
import io
import json
import re
from collections.abc import Iterable, Mapping
from pathlib import Path

__all__ = ["SweepTable", "column_unit", "shift_columns", "column_shift", "FIRST_COLUMNS"]

FIRST_COLUMNS = ("success", "message", "wall_time")

_INT = re.compile(r"[+-]?\d+")
_FLOAT = re.compile(r"[+-]?(\d+\.?\d*|\.\d+)([eE][+-]?\d+)?")

# unit of a column by its last name part: exact names, then suffixes (SI; see the report modules)
_EXACT = {
    "wall_time": "s", "t_start": "s", "shift_end": "s", "dissipation_end": "s", "flare_time": "s",
    "offgoing_unlock": "s", "oncoming_lock": "s", "speed_phase_overrun": "s", "offgoing_drag_after_lock": "s",
    "fuel_step": "s", "window_end": "s", "time_to_90_boost": "s", "forced_duration": "s",
    "torque_hole": "N*m", "bindup_torque": "N*m", "flare_max": "rad/s", "compressor_flow_max": "kg/s",
    "offgoing_energy_after_lock": "J", "energy_total": "J", "work_in": "J", "stored_change": "J",
    "dissipated": "J", "work_to_load": "J", "residual": "J", "tolerance": "J",
    "ratio_before": "1", "ratio_after": "1", "oncoming_apply_final": "1", "relative_residual": "1",
    "tolerance_relative": "1", "boost_start": "1", "boost_peak": "1", "chi_min": "1", "chi_max": "1",
    "accel_before": "m/s^2", "accel_after": "m/s^2", "jerk_max": "m/s^3", "jerk_peak_to_peak": "m/s^3",
    "jerk_filtered_max": "m/s^3",
    "vdv": "m/s^1.75", "torque_overshoot": "%", "output_torque_final": "N*m",
}
_SUFFIX = (("_time", "s"), ("_start", "s"), ("_end", "s"), ("_duration", "s"), ("_rpm", "rpm"),
           ("_krpm", "krpm"), ("_pct", "%"), ("_share", "%"), ("_torque_before", "N*m"),
           ("_torque_at_unlock", "N*m"), ("_torque_min", "N*m"), ("_torque_max", "N*m"))


def shift_columns(names: Iterable[str]) -> list[str]:
    """The column prefix of each shift of a run, from the shifts' names in order: ``shift.1-2``,
    a name that repeats numbered (``shift.2-3#2``, :func:`transgen.names.numbered`)."""
    from transgen.names import numbered

    return [f"shift.{name}" for name in numbered(names)]


def column_shift(column: str) -> tuple[str, list[str]] | None:
    """``(shift, rest)`` of a shift's column: ``shift.1-2.energy.C4`` -> ``("1-2", ["energy", "C4"])``;
    an old table's numbered column ``shift1.energy.C4`` -> ``("1", [...])``; None for any other."""
    head, _, tail = column.partition(".")
    if head == "shift" and "." in tail:
        name, _, rest = tail.partition(".")
        return name, rest.split(".")
    if head.startswith("shift") and head[5:].isdigit() and tail:
        return head[5:], tail.split(".")
    return None


def column_unit(column: str) -> str:
    """The unit of a result column (``"s"``, ``"N*m"``, ``"J"``, ``"W"``, ``"rad/s"``, ``"rpm"``,
    ``"%"``, ``"m/s^2"``, ``"m/s^3"``, ``"m/s^1.75"``, ``"1"`` for ratios and counts); ``""`` for texts, flags, parameters and unknown columns."""
    parts = column.split(".")
    shift = column_shift(column)
    if shift is not None and len(shift[1]) == 2 and shift[1][0] in ("energy", "peak_power"):
        return "J" if shift[1][0] == "energy" else "W"  # per-element dicts of a shift
    if shift is not None and len(shift[1]) == 2 and shift[1][0] in ("temperature_start", "temperature_peak",
                                                                     "temperature_rise"):
        return "K" if shift[1][0] == "temperature_rise" else "degC"  # pack temperatures per element
    if shift is not None and len(shift[1]) == 2 and shift[1][0] in ("lock_counts", "unlock_counts"):
        return "1"
    name = parts[-1]
    if name in _EXACT:
        return _EXACT[name]
    return next((unit for suffix, unit in _SUFFIX if name.endswith(suffix)), "")


def _cell(value) -> str:
    if value is None:
        return ""
    if isinstance(value, bool):
        return "True" if value else "False"
    if isinstance(value, float):
        return repr(value)
    if isinstance(value, (list, dict)):
        return json.dumps(value, sort_keys=True)
    return str(value)


def _parse(text: str):
    if text == "":
        return None
    if text in ("True", "False"):
        return text == "True"
    if _INT.fullmatch(text):
        return int(text)
    if _FLOAT.fullmatch(text):
        return float(text)
    return text


class SweepTable:
    """Rows of a study (dicts column -> value) with the names of its ``parameters``.

    ``rows`` are in the order of the study's design (then rows of an earlier results file that
    the design does not contain). ``columns`` is the union of the rows' columns, see the module
    docstring for the order."""

    def __init__(self, rows: Iterable[Mapping], parameters: Iterable[str] = ()):
        self.rows = [dict(r) for r in rows]
        self.parameters = list(parameters)

    @property
    def columns(self) -> list[str]:
        first = ["key", *self.parameters, *FIRST_COLUMNS]
        seen = dict.fromkeys(first)
        for row in self.rows:
            seen.update(dict.fromkeys(row))
        return list(seen)

    def __len__(self) -> int:
        return len(self.rows)

    def __iter__(self):
        return iter(self.rows)

    def __getitem__(self, column: str) -> list:
        """The values of ``column`` (None where a row has none)."""
        return [row.get(column) for row in self.rows]

    @property
    def failed(self) -> list[dict]:
        """The rows of the runs that failed."""
        return [row for row in self.rows if not row.get("success")]

    def units(self) -> dict[str, str]:
        """Column -> unit for the columns that have one (see :func:`column_unit`)."""
        return {c: u for c in self.columns if (u := column_unit(c))}

    def csv_text(self) -> str:
        columns = self.columns
        buf = io.StringIO()
        writer = csv.writer(buf, lineterminator="\n")
        writer.writerow(columns)
        for row in self.rows:
            writer.writerow([_cell(row.get(c)) for c in columns])
        return buf.getvalue()

    def to_csv(self, path: str | Path) -> Path:
        """Write the table as CSV, atomically (a temporary file renamed over ``path``)."""
        from transgen.export import write_text

        write_text(path, self.csv_text())
        return Path(path)

    @classmethod
    def from_csv(cls, path: str | Path) -> "SweepTable":
        """Read a table written by :meth:`to_csv` (the parameters are the columns between
        ``key`` and ``success``). Raises ValueError for a file that is not one."""
        text = Path(path).read_text(encoding="utf-8")
        return cls.from_csv_text(text, str(path))

    @classmethod
    def from_csv_text(cls, text: str, name: str = "results.csv") -> "SweepTable":
        reader = csv.reader(io.StringIO(text))
        header = next(reader, None)
        if not header or header[0] != "key" or "success" not in header:
            raise ValueError(f"{name}:1:1: error: not a sweep results file (the header must start with "
                             f"'key' and have a 'success' column)")
        parameters = header[1:header.index("success")]
        rows = []
        for number, cells in enumerate(reader, start=2):
            if len(cells) != len(header):
                raise ValueError(f"{name}:{number}:1: error: {len(cells)} cells, the header has {len(header)}")
            row = dict(zip(header, map(_parse, cells)))
            row["key"], row["message"] = cells[0], cells[header.index("message")] if "message" in header else ""
            rows.append(row)  # the key and the message are text, even if all digits
        return cls(rows, parameters)

    def to_pandas(self):
        """The table as a :class:`pandas.DataFrame` (pandas is optional: ImportError without it)."""
        try:
            import pandas as pd
        except ImportError as exc:
            raise ImportError("SweepTable.to_pandas needs pandas (pip install pandas)") from exc
        return pd.DataFrame(self.rows, columns=self.columns)

    def to_dict(self) -> dict:
        """JSON-ready: parameters, columns, units and rows."""
        return {"parameters": self.parameters, "columns": self.columns, "units": self.units(), "rows": self.rows}

    def __repr__(self) -> str:
        return f"SweepTable({len(self.rows)} rows, {len(self.failed)} failed, parameters {self.parameters})"
