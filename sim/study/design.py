"""Designs of a parameter study: a full-factorial grid or a Latin-hypercube sample of overrides.

A *variant* is a dict of dotted keys -> values (TOML data: numbers, strings, booleans, lists,
tables), the ``overrides`` of :func:`transgen.sim.load_scenario`. Its row key
(:func:`row_key`) is a hash of the scenario name and the canonical JSON of the variant, so that a
rerun finds the rows it already has whatever the order of the keys or of the runs.
"""
from __future__ import annotations

import hashlib
import itertools
import json
import math
from collections.abc import Mapping, Sequence

import numpy as np

__all__ = ["full_grid", "latin_hypercube", "linspace_values", "row_key", "plain", "design_size", "check_design",
           "RUN_MEMORY"]

RUN_MEMORY = 3e3
"""Memory of one run of a design [bytes]: its variant and its results row (about 60 columns), held
until the sweep ends (measured: 2.4 kB a row of a bundled scenario's sweep)."""


def plain(value):
    """``value`` as plain JSON/TOML data (numpy scalars as Python numbers, tuples as lists)."""
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, Mapping):
        return {str(k): plain(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [plain(v) for v in value]
    return value


def design_size(grid: Mapping[str, Sequence], samples: int | None = None) -> int:
    """The number of runs of a design, counted without making it: ``samples``, or the product of
    the number of values of every key of a full grid."""
    if samples is not None:
        return samples
    return math.prod(len(v) if isinstance(v, Sequence) and not isinstance(v, (str, bytes)) else 1
                     for v in grid.values())


def check_design(grid: Mapping[str, Sequence], samples: int | None = None, force: bool | None = False) -> int:
    """The number of runs of the design, refused (:class:`~transgen.limits.LimitExceeded`) over
    the limits ``runs`` (``force`` passes it) and ``design_memory`` before anything is made."""
    from transgen.limits import check_limit, human_bytes

    what = f"--samples {samples}" if samples is not None else "--grid"
    if samples is not None and (isinstance(samples, bool) or not isinstance(samples, int) or samples < 1):
        raise ValueError(f"--samples: error: need at least one sample, not {samples!r}")
    n = design_size(grid, samples)
    memory = f"about {human_bytes(n * RUN_MEMORY)} for the design and its results"
    check_limit("design_memory", n * RUN_MEMORY, f"{what} ({n:.4g} runs)")
    check_limit("runs", n, what, memory, force)
    return n


def full_grid(grid: Mapping[str, Sequence]) -> list[dict]:
    """Every combination of the values (the first key varies slowest), each a variant dict.

    Raises ValueError for a key without values."""
    keys = list(grid)
    values = []
    for key in keys:
        vals = grid[key]
        if isinstance(vals, (str, bytes)) or not isinstance(vals, Sequence):
            raise ValueError(f"--grid {key}: error: expected a list of values, not {vals!r}")
        if not vals:
            raise ValueError(f"--grid {key}: error: no values")
        values.append([plain(v) for v in vals])
    return [dict(zip(keys, combo)) for combo in itertools.product(*values)]


def latin_hypercube(ranges: Mapping[str, Sequence[float]], samples: int, seed: int = 0) -> list[dict]:
    """``samples`` variants from a Latin-hypercube sample of the ranges ``key -> (lo, hi)``
    (scipy.stats.qmc.LatinHypercube with ``seed``): each range is cut into ``samples`` equal
    strata and every stratum is sampled once. Where both bounds are integers the values are
    rounded to integers (tooth counts)."""
    from scipy.stats import qmc

    if samples < 1:
        raise ValueError(f"--samples: error: need at least one sample, not {samples}")
    keys = list(ranges)
    if not keys:
        raise ValueError("--samples: error: give the ranges to sample as --grid KEY=LO:HI")
    bounds = []
    for key in keys:
        r = ranges[key]
        if not (isinstance(r, Sequence) and len(r) == 2 and all(_number(x) for x in r)):
            raise ValueError(f"--grid {key}: error: a sampled range is LO:HI (two finite numbers), not {r!r}")
        lo, hi = (plain(x) for x in r)
        if not hi > lo:
            raise ValueError(f"--grid {key}: error: the range {lo}:{hi} is empty (HI must be above LO)")
        bounds.append((lo, hi))
    unit = qmc.LatinHypercube(d=len(keys), rng=np.random.default_rng(seed)).random(samples)
    out = []
    for point in unit:
        variant = {}
        for key, (lo, hi), u in zip(keys, bounds, point):
            x = lo + float(u) * (hi - lo)
            variant[key] = int(round(x)) if isinstance(lo, int) and isinstance(hi, int) else float(x)
        out.append(variant)
    return out


def _number(x) -> bool:
    return isinstance(x, (int, float, np.integer, np.floating)) and not isinstance(x, bool) and math.isfinite(x)


def linspace_values(lo, hi, n: int) -> list:
    """``n`` values from ``lo`` to ``hi`` inclusive; integers where both bounds and every value
    are whole numbers (20000:36000:3 gives 20000, 28000, 36000). ``n`` is bounded by the limit
    ``grid_values`` (:class:`~transgen.limits.LimitExceeded`)."""
    from transgen.limits import check_limit

    if n < 1:
        raise ValueError(f"need at least one value, not {n}")
    check_limit("grid_values", n, f"LO:HI:{n}")
    values = np.linspace(lo, hi, n) if n > 1 else np.array([lo], dtype=float)
    if isinstance(lo, int) and isinstance(hi, int) and all(float(v).is_integer() for v in values):
        return [int(v) for v in values]
    return [float(v) for v in values]


def row_key(scenario: str, overrides: Mapping[str, object]) -> str:
    """The row key of a run: 16 hex digits of the SHA-256 of the scenario name and the canonical
    JSON of its overrides (sorted keys; 20000 and 20000.0 are different TOML values and keys)."""
    doc = json.dumps({"scenario": scenario, "overrides": plain(dict(overrides))}, sort_keys=True,
                     separators=(",", ":"), ensure_ascii=True, allow_nan=False)
    return hashlib.sha256(doc.encode("ascii")).hexdigest()[:16]
