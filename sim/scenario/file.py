"""Reading scenario files: the TOML text with its includes, the position of every key, and typed
values checked as they are read.

:func:`read_source` reads a file and its ``include = [...]`` files (merged so that the including
file's own values win; cycles and missing files refused); :class:`Source` locates any key, table
or list entry in the file that supplies it (``FILE:LINE:COL: error:`` with the line and a caret);
:class:`Reader` reads numbers (NaN, infinity and out-of-range values refused), texts, names and
signals (:mod:`.signals`) from the tables, each error located. :mod:`.scenario.load` builds the
scenario from what this module reads.
"""
from __future__ import annotations

import copy
import difflib
import functools
import math
import re
import sys
import tomllib
from pathlib import Path

from transgen.errors import Diagnostic, ScenarioError
from transgen.limits import limit

from .file_access import FileAccess
from .schema import SIGNAL_KEYS
from ..core.signals import Constant, Periodic, Pulse, Ramp, Signal, Sine, Step, Table
from .tomlpos import key_positions

__all__ = ["Source", "Reader", "read_source", "is_file", "shown", "bounded", "as_float", "MAX_STEPS",
           "MAX_BREAKPOINTS"]


class Source:
    """A scenario file's text and the files it includes, for locating keys in error messages.

    ``includes`` are the sources of the included files in the order they are merged; a key's
    value comes from the last file that gives it, so errors about it are located there."""

    def __init__(self, path: Path, text: str, positions: dict | None = None):
        self.path = path
        self.lines = text.splitlines()
        self.positions = key_positions(text) if positions is None else positions  # read only
        self.includes: list[Source] = []
        self.overrides: dict[tuple, str] = {}  # key path set with --set -> its dotted key
        self.created: set[tuple] = set()  # tables that only --set made

    def override_of(self, keys: tuple) -> str | None:
        """The dotted key of the ``--set`` override that an error at ``keys`` is about: one that
        set ``keys`` or a value holding it, or one inside a table that only overrides made."""
        keys = tuple(keys)
        for path, key in self.overrides.items():
            if keys[:len(path)] == path or any(keys[:d] in self.created and path[:d] == keys[:d]
                                               for d in range(1, len(keys) + 1)):
                return key
        return None

    def _chain(self) -> list[Source]:
        """Sources in the order of precedence: this file, then its includes, last one first."""
        return [self] + [s for inc in reversed(self.includes) for s in inc._chain()]

    def _depth(self, keys: tuple) -> int:
        return next((d for d in range(len(keys), 0, -1) if keys[:d] in self.positions), 0)

    def locate(self, keys: tuple) -> tuple[Source, int, int]:
        """``(source, line, column)`` of the longest prefix of the key path ``keys`` that a file
        writes (this file or an included one); line 1, column 1 of this file if none does."""
        best, depth = self, 0
        for source in self._chain():
            d = source._depth(keys)
            if d > depth:
                best, depth = source, d
        if depth == 0:
            return self, 1, 1
        return (best, *best.positions[keys[:depth]])

    def error(self, keys, message: str) -> ScenarioError:
        key = self.override_of(tuple(keys))
        if key is not None:
            return ScenarioError(f"--set {key}: error: {bounded(message)} (a value given with --set)")
        keys = tuple(keys)
        inside = [k for path, k in self.overrides.items()
                  if keys and (path[:len(keys)] == keys or len(path) > 1 and keys[:len(path) - 1] == path[:-1])]
        if inside:  # a table of the file that holds a value given with --set, or a value beside one
            message += f" (with --set {', '.join(inside)})"
        source, line, col = self.locate(keys)
        return source.error_at(line, col, message)

    def error_at(self, line: int, col: int, message: str) -> ScenarioError:
        return located(self.path, self.lines, line, col, message)


def located(path: Path, lines: list[str], line: int, col: int, message: str) -> ScenarioError:
    """``FILE:LINE:COL: error: message``, the line and a caret (message and line bounded)."""
    text = lines[line - 1] if 0 < line <= len(lines) else ""
    return ScenarioError(Diagnostic(str(path), line, col, bounded(message), text[:_SHOWN]).format())


_SHOWN = 200  # characters of a source line or value shown in a message


def bounded(text: str, limit: int = 2000) -> str:
    return text if len(text) <= limit else text[:limit] + f"... ({len(text) - limit} more characters)"


def shown(value) -> str:
    """``repr`` of a value for a message, bounded."""
    return bounded(repr(value), _SHOWN)


def non_finite(node, path: tuple = ()):
    """The key path of the first NaN or infinite number in parsed TOML data, else None."""
    if isinstance(node, float) and not math.isfinite(node) or isinstance(node, int) and abs(node) > sys.float_info.max:
        return path
    items = node.items() if isinstance(node, dict) else enumerate(node) if isinstance(node, list) else ()
    for k, v in items:
        found = non_finite(v, path + (k,))
        if found is not None:
            return found
    return None


def read_source(path: Path, text: str | None = None, seen: tuple[Path, ...] = (),
                access: FileAccess | None = None) -> tuple[dict, Source]:
    """The data of a scenario file merged over its includes, and its source (with the includes');
    files are read through ``access`` (default: the disk)."""
    access = access or FileAccess()
    if text is None:
        try:
            text = access.read_text(path)
        except (OSError, UnicodeDecodeError) as exc:
            raise ScenarioError(f"{path}:1:1: error: cannot read scenario file ({exc})") from None
    try:
        parsed, positions, bad = _parsed(text)
        data = copy.deepcopy(parsed)  # the caller merges and overrides it in place
        source = Source(path, text, positions)
    except RecursionError:
        raise located(path, text.splitlines(), 1, 1, "arrays or tables nested too deeply") from None
    except tomllib.TOMLDecodeError as exc:
        m = re.search(r"\(at line (\d+), column (\d+)\)", str(exc))
        line, col = (int(m.group(1)), int(m.group(2))) if m else (1, 1)
        msg = re.sub(r"\s*\(at line \d+, column \d+\)", "", str(exc))
        raise located(path, text.splitlines(), line, col, f"TOML syntax: {msg}") from None
    if bad is not None:
        name = ".".join(str(k) for k in bad)
        raise source.error(bad, f"'{name}' is not a finite number (NaN and infinity are refused; "
                                f"a number too large for a float, such as 1e400, reads as infinity)")
    includes = data.pop("include", [])
    if isinstance(includes, str):
        includes = [includes]
    if not isinstance(includes, list) or not all(isinstance(x, str) for x in includes):
        raise source.error(("include",), "include must be a file name or a list of file names")
    merged: dict = {}
    for k, inc in enumerate(includes):
        inc_path = path.parent / inc
        if not access.is_file(inc_path):
            inc_path = bundled_include(inc)
        if inc_path is None or not access.is_file(inc_path):
            raise source.error(("include", k), f"included file '{inc}' not found (looked in {path.parent} and among the "
                                               f"bundled scenarios)")
        inc_path = inc_path.resolve()
        chain = seen + (path.resolve(),)
        if inc_path in chain:
            raise source.error(("include", k), f"include cycle: {' -> '.join(str(p) for p in chain + (inc_path,))}")
        inc_data, inc_source = read_source(inc_path, None, chain, access)
        mech = inc_data.get("mechanism")
        if isinstance(mech, str) and access.is_file(inc_path.parent / mech):
            inc_data["mechanism"] = str((inc_path.parent / mech).resolve())
        source.includes.append(inc_source)
        merge(merged, inc_data)
    merge(merged, data)
    return merged, source


@functools.lru_cache(maxsize=32)
def _parsed(text: str) -> tuple[dict, dict, tuple | None]:
    """The TOML data of a file's ``text``, the position of each key (:func:`key_positions`) and the
    key path of its first non-finite number (:func:`non_finite`), remembered for the last texts:
    the runs of a sweep and an optimizer's candidates read the same files, and parsing them is
    about a third of loading a scenario. Read only (:func:`read_source` copies the data)."""
    data = tomllib.loads(text)
    return data, key_positions(text), non_finite(data)


def bundled_include(name: str) -> Path | None:
    """The bundled scenario an ``include`` names by its bare name (``"ht740_original"`` or
    ``"ht740_original.toml"``, no folder) when no file of that name lies next to the including file
    (a file there wins); None otherwise. A tuned scenario includes a bundled original so, wherever
    it lies."""
    from .library import bundled_scenarios

    p = Path(name)
    if p.name != name or p.suffix not in ("", ".toml"):
        return None
    return bundled_scenarios().get(p.stem)


def is_file(path: Path) -> bool:
    """Whether ``path`` is a file (False, not an error, for a name the system refuses, e.g. too long)."""
    try:
        return path.is_file()
    except (OSError, ValueError):
        return False


def merge(base: dict, extra: dict) -> None:
    for k, v in extra.items():
        if isinstance(v, dict) and isinstance(base.get(k), dict):
            merge(base[k], v)
        else:
            base[k] = v


class Reader:
    """Typed access to the scenario data with located errors."""

    def __init__(self, source: Source, access: FileAccess | None = None):
        self.source = source
        self.access = access or FileAccess()
        self.window: tuple[float, float] | None = None  # the simulated interval, once known
        #: the periodic signals the file gives (sine, pulse train, square, periodic table) with the
        #: key path of each, for the limits of a run (:mod:`transgen.sim.scenario.run_limits`)
        self.periodic: list[tuple[tuple, Signal]] = []

    def error(self, keys, message):
        return self.source.error(keys, message)

    def file_path(self, keys, name: str) -> Path:
        """The path of a file named by the value at ``keys``: relative to the file that gives the
        value, or to the current folder for a value given with ``--set``."""
        if self.source.override_of(tuple(keys)) is not None:
            return Path(name)
        return self.source.locate(tuple(keys))[0].path.parent / name

    def data_path(self, keys, name: str) -> Path:
        """:meth:`file_path`, else (no such file) the bundled data file of that bare name
        (:func:`transgen.sim.scenario.library.bundled_data`: ``"torque_converter_car"``)."""
        path = self.file_path(keys, name)
        if not self.access.is_file(path):
            from .library import bundled_data

            return bundled_data(name) or path
        return path

    def read_text(self, keys, path: Path, what: str) -> str:
        """The text of the file ``path`` named at ``keys`` (through :attr:`access`), errors located."""
        try:
            return self.access.read_text(path)
        except (OSError, UnicodeDecodeError) as exc:
            raise self.error(keys, f"cannot read the {what} '{path}' ({exc})") from None

    def table(self, data, keys, allowed: set[str] | None = None) -> dict:
        node = data
        for k in keys:
            if isinstance(node, list) and isinstance(k, int) and k < len(node):
                node = node[k]
            else:
                node = node.get(k, {}) if isinstance(node, dict) else {}
        return self.checked(node, keys, allowed)

    def subtable(self, table: dict, keys, name: str, allowed: set[str]) -> dict:
        """The table ``name`` of ``table`` (which is at ``keys``), empty when absent."""
        return self.checked(table.get(name, {}), tuple(keys) + (name,), allowed)

    def checked(self, node, keys, allowed: set[str] | None) -> dict:
        """``node`` (at ``keys``) if it is a table of ``allowed`` keys only (any keys: None)."""
        if not isinstance(node, dict):
            raise self.error(keys, f"[{'.'.join(map(str, keys))}] must be a table, not {shown(node)}")
        if allowed is not None:
            for k in node:
                if k not in allowed:
                    close = difflib.get_close_matches(k, sorted(allowed), n=1)
                    hint = f"; did you mean '{close[0]}'?" if close else f" (known: {', '.join(sorted(allowed))})"
                    raise self.error(keys + (k,), f"unknown key '{k}' in [{'.'.join(map(str, keys)) or 'top level'}]{hint}")
        return node

    def number(self, table: dict, keys, name: str, default=None, minimum=None, positive=False) -> float:
        if name not in table:
            if default is None:
                raise self.error(keys, f"missing '{name}' in [{'.'.join(map(str, keys))}]")
            return default
        v = as_float(table[name])
        if v is None:
            raise self.error(keys + (name,), f"'{name}' must be a finite number, not {shown(table[name])}")
        if positive and v <= 0:
            raise self.error(keys + (name,), f"'{name}' must be positive, not {v:g}")
        if minimum is not None and v < minimum:
            raise self.error(keys + (name,), f"'{name}' must be >= {minimum:g}, not {v:g}")
        return v

    def numbers(self, table, keys, name, length=None) -> list[float]:
        v = table.get(name)
        if not isinstance(v, list) or not v:
            raise self.error(keys + (name,), f"'{name}' must be a non-empty list of numbers, not {shown(v)}")
        out = []
        for k, x in enumerate(v):
            f = as_float(x)
            if f is None:
                raise self.error(keys + (name, k), f"'{name}' must be a list of finite numbers: entry {k + 1} is {shown(x)}")
            out.append(f)
        if length is not None and len(v) != length:
            raise self.error(keys + (name,), f"'{name}' must have {length} entries, not {len(v)}")
        return out

    def text(self, table: dict, keys, name: str, default: str | None = None) -> str:
        """A string value (``default`` when absent; required when ``default`` is None)."""
        if name not in table:
            if default is None:
                raise self.error(keys, f"missing '{name}' in [{'.'.join(map(str, keys))}]")
            return default
        v = table[name]
        if not isinstance(v, str):
            raise self.error(keys + (name,), f"'{name}' must be a string, not {shown(v)}")
        return v

    def names(self, table: dict, keys, name: str) -> list[str]:
        """A list of names (strings or numbers, as gear names often are); empty when absent."""
        v = table.get(name, [])
        if not isinstance(v, list) or not all(isinstance(x, (str, int)) and not isinstance(x, bool) for x in v):
            raise self.error(keys + (name,), f"'{name}' must be a list of names, not {shown(v)}")
        return [str(x) for x in v]

    def signal(self, spec, keys) -> Signal:
        """A signal from a number (constant) or a table ``{type = ..., ...}``."""
        if as_float(spec) is not None:
            return Constant(as_float(spec))
        if not isinstance(spec, dict):
            raise self.error(keys, "a signal is a finite number or a table like "
                                   "{ type = \"ramp\", t0 = 1, t1 = 2, v0 = 0, v1 = 1 }, not " + shown(spec))
        kind = spec.get("type")
        if not isinstance(kind, str) or kind not in SIGNAL_KEYS:
            raise self.error(keys, f"signal type must be one of {', '.join(SIGNAL_KEYS)}, not {shown(kind)}")
        known = SIGNAL_KEYS[kind]
        for k in spec:
            if k != "type" and k not in known:
                close = difflib.get_close_matches(k, sorted(known), n=1)
                hint = f"; did you mean '{close[0]}'?" if close else f" (known: {', '.join(sorted(known))})"
                raise self.error(keys + (k,), f"unknown key '{k}' for a {kind} signal{hint}")
        num = lambda name, default=None, **kw: self.number(spec, keys, name, default, **kw)  # noqa: E731
        if kind == "constant":
            return Constant(num("value"))
        if kind == "step":
            return Step(num("t"), num("before"), num("after"))
        if kind == "ramp":
            t0, t1 = num("t0"), num("t1")
            if t1 <= t0:
                raise self.error(keys, f"ramp needs t1 > t0 (t0={t0:g}, t1={t1:g})")
            return Ramp(t0, t1, num("v0"), num("v1"))
        if kind == "sine":
            sine = Sine(num("offset", 0.0), num("amplitude"), num("frequency", positive=True), num("phase", 0.0))
            self.periodic.append((tuple(keys) + ("frequency",), sine))
            return sine
        if kind in ("pulse", "square"):
            if kind == "square":
                period = num("period", positive=True)
                duty = num("duty", 0.5)
                if not 0 < duty < 1:
                    raise self.error(keys + ("duty",), f"duty must be between 0 and 1 (exclusive), not {duty:g}")
                t0, width = num("t0", 0.0), duty * period
            else:
                t0, width = num("t0"), num("width", positive=True)
                period = num("period", positive=True) if "period" in spec else None
                if period is not None and period <= width:
                    raise self.error(keys + ("period",), f"a pulse train needs period > width ({period:g} <= {width:g})")
            self._check_edges(keys, period, 2)
            pulse = Pulse(t0, width, num("low", 0.0), num("high", 1.0), period)
            if period is not None:
                self.periodic.append((tuple(keys) + ("period",), pulse))
            return pulse
        table = self._table(spec, keys)
        if kind == "table":
            return table
        span = table.times[-1] - table.times[0]
        period = num("period", span if span > 0 else None, positive=True)
        if period < span:
            raise self.error(keys + ("period",), f"period {period:g} s is shorter than the table's span {span:g} s")
        self._check_edges(keys, period, len(table.times) + 1)
        periodic = Periodic(table, period)
        self.periodic.append((tuple(keys) + ("period",), periodic))
        return periodic

    def _table(self, spec: dict, keys) -> Table:
        ts = self.numbers(spec, keys, "t")
        vs = self.numbers(spec, keys, "value", len(ts))
        for k in range(1, len(ts)):
            if ts[k] < ts[k - 1]:
                raise self.error(keys + ("t", k), f"table times 't' must not decrease ({ts[k]:g} after {ts[k - 1]:g}); "
                                                  f"two equal times are a jump")
        return Table(tuple(ts), tuple(vs))

    def _check_edges(self, keys, period: float | None, per_period: int) -> None:
        """Refuse a periodic signal with more than :data:`MAX_BREAKPOINTS` breakpoints in the
        simulated interval (each one restarts the integrator)."""
        if period is None or self.window is None:
            return
        count = (self.window[1] - self.window[0]) / period * per_period
        if count > MAX_BREAKPOINTS:
            raise self.error(keys + ("period",), f"period {period:g} s gives about {count:.3g} breakpoints in the "
                                                 f"simulated {self.window[1] - self.window[0]:g} s (at most {MAX_BREAKPOINTS})")


MAX_BREAKPOINTS = int(limit("breakpoints"))
"""Most breakpoints a periodic signal may have in a scenario's simulated interval
(:mod:`transgen.limits`, ``breakpoints``)."""

MAX_STEPS = int(limit("output_samples"))
"""Most output samples (``output_dt``) and smallest steps (``max_step``) in the simulated interval
(:mod:`transgen.limits`, ``output_samples``)."""

def as_float(v) -> float | None:
    """``v`` as a finite float, or None if it is not a finite number (bools are not numbers)."""
    if isinstance(v, bool) or not isinstance(v, (int, float)):
        return None
    try:
        f = float(v)
    except OverflowError:  # an integer beyond the float range
        return None
    return f if math.isfinite(f) else None
