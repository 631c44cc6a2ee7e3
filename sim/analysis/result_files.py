"""Result files of a simulation: the signals as CSV, MATLAB ``.mat``, NumPy ``.npz`` or JSON.

Every format holds the same columns, in the same order (see :func:`result_columns`):

* ``time`` [s];
* ``mode``: the name of the mode the transmission is in (as ``transgen modes`` and the
  state-transition diagram name it, e.g. ``M3``; a combination outside the diagram is named by its
  locked elements, ``C1+C4``, or ``none``);
* the signals (``[output] signals`` of the scenario, default all), each with its SI unit
  (``w_L1`` [rad/s], ``t_C4`` [N*m], ``apply_C4`` [1], ...).

The CSV header is ``time [s],mode,w_L1 [rad/s],...``: every numeric column is ``NAME [UNIT]``
(``1`` for a pure number), the text column ``mode`` has no unit. The time is written with every
digit (shortest round trip), the signals with 9 significant digits, every number as a float
(``0.0``, not ``0``: :func:`csv_float`). The CSV's mode column holds each mode's *name*, as
the other formats, ``transgen modes`` and the matrices files name it (``M3``, ``1L``, ``R``,
``C1+C4``, ``none``), except a name that a reader guessing column types (``pandas.read_csv``,
MATLAB ``readtable``) takes for a number, a boolean or a missing value whatever the quoting
(``1``, ``10``, ``NA``, ``True``): such a name is written ``gear 1`` where the mode is that gear
(``mode_gears`` of the other formats, ``gear`` of the matrices files) and ``mode 1`` otherwise
(:func:`csv_mode_text`), so that the column is text in every reader and still joins the other
files: by the name, or by the gear after ``gear ``. The other formats hold the names and,
beside ``mode_names``, ``mode_fields`` (the same order): the field names of the ``.mat``/``.npz``
matrices files (:func:`transgen.export.field_names`, ``m_1`` for ``1``).

At an event (a mode change) and at a jump of an input signal a run records the instant twice:
the state before and after it, so the time column repeats that value. ``unique_times=True``
keeps only the last row of each repeated time (the state after the event): the time is then
strictly increasing, as ``pandas`` reindexing and MATLAB ``interp1`` need.
"""
from __future__ import annotations

import csv
import io
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from transgen.names import locked_text

if TYPE_CHECKING:
    from ..core.result import Result

__all__ = ["RESULT_FORMATS", "SIGNALS_SCHEMA", "result_format", "result_columns", "write_result", "csv_float",
           "csv_mode_text", "reads_as_text"]

RESULT_FORMATS = {".csv": "csv", ".mat": "mat", ".npz": "npz", ".json": "json"}
"""Result file formats by file-name suffix."""

SIGNALS_SCHEMA = "transgen.signals/1"


def result_format(path: str | Path) -> str:
    """The format of the result file ``path`` from its suffix; ValueError for any other suffix
    (checked before a run, so that nothing runs for a file that cannot be written)."""
    from transgen.outputs import is_stream

    fmt = RESULT_FORMATS.get(Path(path).suffix.lower())
    if fmt is None and not Path(path).suffix and is_stream(path):  # -o -, a FIFO or device without suffix
        return "csv"
    if fmt is None:
        raise ValueError(f"unknown result file format {Path(path).name!r}: name a "
                         f"{', '.join(RESULT_FORMATS)} file")
    return fmt


def _mode_column(result: Result) -> np.ndarray:
    """The mode name of every sample (the ``mode`` signal numbers the modes in order of appearance,
    ``meta["mode_names"]`` names them)."""
    codes = np.asarray(result.signals.get("mode", np.zeros(len(result.time))), dtype=float)
    names = list(result.meta.get("mode_names", ()))
    out = [names[int(c) - 1] if 1 <= int(c) <= len(names) else f"{c:g}" for c in codes]
    return np.array(out, dtype=str) if out else np.zeros(0, dtype=str)


def result_columns(result: Result, names: list[str] | None = None,
                   unique_times: bool = False) -> tuple[dict[str, np.ndarray], dict[str, str]]:
    """The columns of a result file (``time``, ``mode``, then ``names``, default every signal) and
    the unit of each numeric column. With ``unique_times`` only the last row of each repeated time
    is kept (the state after an event)."""
    names = [n for n in (list(result.signals) if names is None else names) if n not in ("time", "mode")]
    columns = {"time": np.asarray(result.time, dtype=float), "mode": _mode_column(result)}
    columns.update({n: np.asarray(result.signals[n], dtype=float) for n in names})
    if unique_times and len(result.time):
        keep = np.r_[np.diff(columns["time"]) != 0, True]
        columns = {k: v[keep] for k, v in columns.items()}
    units = {"time": "s"} | {n: result.units.get(n, "") for n in names}
    return columns, units


def csv_float(x: float, digits: int = 9) -> str:
    """``x`` with ``digits`` significant digits, always written as a float (``0.0``, ``12.0``,
    ``1e+20``, never ``0`` or ``12``): a column of whole values stays a float column in pandas,
    MATLAB ``readtable`` and every other reader that guesses the type of a column."""
    text = f"{x:.{digits}g}"
    return text if any(c in text for c in ".eEn") else text + ".0"  # n: nan, inf


NOT_TEXT = frozenset({
    "", "#N/A", "#N/A N/A", "#NA", "-1.#IND", "-1.#QNAN", "-NaN", "-nan", "1.#IND", "1.#QNAN", "<NA>", "N/A", "NA",
    "NULL", "NaN", "None", "n/a", "nan", "null", "True", "TRUE", "true", "False", "FALSE", "false"})
"""Words pandas reads as a missing value (its default ``na_values``) or a boolean."""


def reads_as_text(name: str) -> bool:
    """Whether a column holding ``name`` stays text in a reader that guesses column types: not a
    number in any spelling Python or pandas accepts (``1``, ``1e3``, ``inf``, ``1_0``), not one of
    :data:`NOT_TEXT`."""
    if name.strip() in NOT_TEXT:
        return False
    try:
        float(name)
    except ValueError:
        return True
    return False


def csv_mode_text(name: str, gear: str | None = None) -> str:
    """The text of the mode ``name`` in the CSV's mode column: the name itself where it reads as
    text (:func:`reads_as_text`); else ``gear NAME`` where the mode is the gear ``gear`` of that
    name, ``mode NAME`` otherwise (a declared mode or a combination named like a number)."""
    if reads_as_text(name):
        return name
    return f"gear {name}" if gear == name else f"mode {name}"


def _csv_text(columns: dict[str, np.ndarray], units: dict[str, str], modes) -> str:
    """The CSV text: ``modes`` the text of the mode column (:func:`csv_mode_text`)."""
    buf = io.StringIO()
    writer = csv.writer(buf, lineterminator="\n")
    writer.writerow([f"{n} [{units[n]}]" if n in units else n for n in columns])
    time = columns["time"]
    signals = [v for k, v in columns.items() if k not in ("time", "mode")]
    for i, (t, mode) in enumerate(zip(time, modes)):
        writer.writerow([repr(float(t)), mode] + [csv_float(v[i]) for v in signals])
    return buf.getvalue()


def _header(columns, units, result: Result, unique_times: bool) -> dict:
    from transgen import __version__

    from transgen.export import field_names

    mode_names = list(dict.fromkeys(columns["mode"].tolist()))
    spans = {m.name: m for m in result.modes}
    return {"names": list(columns), "units": [units.get(n, "") for n in columns],
            "mode_names": mode_names, "mode_fields": field_names(mode_names), "unique_times": unique_times,
            # what joins the modes to the matrices' (transgen matrices): the gear and the locked set
            "mode_gears": [(spans[n].gear or "") if n in spans else "" for n in mode_names],
            "mode_locked": [locked_text(spans[n].locked) if n in spans else "" for n in mode_names],
            "mechanism": result.meta.get("mechanism", ""), "transgen_version": __version__}


def write_result(result: Result, path: str | Path, names: list[str] | None = None,
                 unique_times: bool = False) -> None:
    """Write the columns of ``result`` (:func:`result_columns`) to ``path``, atomically, in the
    format of its suffix (:data:`RESULT_FORMATS`):

    * ``.csv``: header ``time [s],mode,NAME [UNIT],...``, one row per sample;
    * ``.mat`` (MATLAB/Octave ``R = load('r.mat')``): one column vector per numeric column, named
      by :func:`transgen.export.matlab_name` (``R.time``, ``R.w_L1``), ``R.mode`` a cell array of
      the mode names, and the cell arrays ``names``, ``units``, ``mode_names`` (the modes in order
      of appearance, named by gear: :mod:`transgen.names`), ``mode_gears`` (the gear of each, or
      empty), ``mode_locked`` (its locked elements, ``C1+C5``), ``mechanism``, ``transgen_version``;
    * ``.npz`` (``numpy.load``): the same, the arrays keyed by the column names, ``mode`` a string
      array;
    * ``.json``: a ``transgen.signals/1`` document: ``names``, ``units`` (name -> unit),
      ``columns`` (name -> list of values), ``mode_names``, ``mode_gears``, ``mode_locked``,
      ``unique_times``, ``mechanism``.
    """
    from transgen.export import atomic_path, matlab_name, write_json, write_text

    fmt = result_format(path)
    columns, units = result_columns(result, names, unique_times)
    header = _header(columns, units, result, unique_times)
    if fmt == "csv":  # the mode by its name, text in every reader (a name like 1 is written gear 1)
        text = {m: csv_mode_text(m, g) for m, g in zip(header["mode_names"], header["mode_gears"])}
        write_text(path, _csv_text(columns, units, [text[m] for m in columns["mode"].tolist()]))
    elif fmt == "json":
        from transgen.schemas import json_document

        body = {k: v for k, v in header.items() if k not in ("units", "transgen_version")}
        body["columns"] = {k: v.tolist() for k, v in columns.items()}
        write_json(path, json_document(SIGNALS_SCHEMA, body, units))
    elif fmt == "npz":
        arrays = {k: np.array(v) for k, v in header.items()}
        arrays.update(columns)
        with atomic_path(path) as tmp, open(tmp, "wb") as f:
            np.savez(f, **arrays)
    else:
        import scipy.io

        data = {k: (np.array(v, dtype=object) if isinstance(v, list) else v) for k, v in header.items()}
        data.update({matlab_name(k): (np.array(v.tolist(), dtype=object) if k == "mode" else v)
                     for k, v in columns.items()})
        with atomic_path(path) as tmp:
            scipy.io.savemat(str(tmp), data, oned_as="column")
