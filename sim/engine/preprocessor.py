"""The map pre-processor: causal look-up tables from a compressor or turbine map (thesis 4.4).

The thesis' compressor/turbine *pre-processor* (sections 2.3 and 4.4) turns a map in the
manufacturer-like format of :mod:`transgen.sim.engine.map_file` into look-up tables whose inputs
are what the simulation knows (pressures, temperatures, rotor speed) and whose outputs are what it
needs (mass flow, efficiency).  The scalar look-up itself (cell and bilinear weights) is
:func:`transgen.sim.engine.kernels.compressor_lookup` and
:func:`~transgen.sim.engine.kernels.turbine_lookup` (compiled, :mod:`~transgen.sim.engine.compiled`).

The pre-processor and the chi coordinate
----------------------------------------
:func:`preprocess_compressor` evaluates, on every speed line, the surge and stall pressure
ratios (interpolated in speed along the surge and stall lines) and the normalised pressure
coordinate of thesis eq. 4.25::

    chi = (PR - PR_stall) / (PR_surge - PR_stall)

so that chi = 0 on the stall (choke) line, chi = 1 on the surge line, chi > 1 is surge and
chi < 0 choked operation.  A speed line may carry points left of surge (its falling branch, two
flows per pressure ratio, as in Fig. 4.4): chi is built on the stable branch only, from the
line's peak (on the surge line) to larger flows.  The speed line's corrected flow and efficiency are resampled on a regular chi grid,
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
:func:`default_compressor_table` and :func:`default_turbine_table` are the tables of the shipped
maps (``sim/data/we_compressor.toml``, ``sim/data/we_turbine.toml``).

Out-of-data use
---------------
A look-up outside the tables clamps to the nearest edge (no extrapolation; the one exception is
the compressor's fan-law scaling below the lowest speed line, above) and issues one
:class:`MapRangeWarning` per table object, naming the operating point.  For the compressor,
chi > 1 (surge side) clamps to the surge flow: a mean-value model cannot represent surge cycles.
chi < 0 (PR below the stall line, e.g. p_im < p_amb at idle) clamps to the stall-line flow, which
is the saturation ``Pi_c = max(1, p_im/p_amb)`` of Wahlström & Eriksson.
"""
from __future__ import annotations

import warnings
from functools import lru_cache

import numpy as np

from . import kernels as _k
from .compiled import kernels
from .gas import RPM
from .map_file import DATA_DIR, CompressorMap, MapError, TurbineMap, _raise_problems, load_map

__all__ = [
    "MIN_CHI_SPAN",
    "MapRangeWarning",
    "chi_coordinate",
    "CompressorTable",
    "TurbineTable",
    "preprocess_compressor",
    "preprocess_turbine",
    "default_compressor_table",
    "default_turbine_table",
]

MIN_CHI_SPAN = 1e-4
"""Default smallest admissible ``PR_surge - PR_stall`` on a speed line (the chi 0/0 guard)."""


class MapRangeWarning(UserWarning):
    """A map was used outside its data and the look-up was clamped to the map edge."""


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


class _Table:
    """Common part of the causal tables: a grid, values, and the warn-once flag ``warned``
    (True once the table has issued its out-of-data warning; may be reset by the user)."""

    kind = "map"

    def __init__(self, name, speed, second, mass_flow, efficiency, T_ref, p_ref):
        self.name = name
        self.speed = np.ascontiguousarray(speed, dtype=float)
        self.mass_flow = np.ascontiguousarray(mass_flow, dtype=float)
        self.efficiency = np.ascontiguousarray(efficiency, dtype=float)
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
        self.warned = False

    def warn_range(self, code: int, N_corr: float, ratio: float, chi: float) -> None:
        """The out-of-data warning of a look-up with range code ``code`` (``kernels.IN_RANGE``:
        none) at a corrected speed [rad/s], ratio and (compressor) chi."""
        if code != _k.IN_RANGE and not self.warned:
            self._warn(self._range_message(int(code), N_corr, ratio, chi))

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
        self.chi = np.ascontiguousarray(chi, dtype=float)
        self.pr_stall = np.ascontiguousarray(pr_stall, dtype=float)
        self.pr_surge = np.ascontiguousarray(pr_surge, dtype=float)
        span = self.pr_surge - self.pr_stall
        if span.shape != self.speed.shape or np.any(~(span >= min_span)):
            raise MapError(f"compressor table '{name}': PR_surge - PR_stall must be >= "
                           f"{min_span:g} on every speed line (the chi 0/0 guard)")
        self.pr_span = span

    def _range_message(self, code: int, N_corr: float, PR: float, chi: float) -> str:
        if code == _k.BELOW_LOWEST_LINE:
            return (f"N_corr = {N_corr / RPM:.0f} rpm below the lowest speed line, PR = {PR:.4f}; "
                    "scaled from the lowest line by fan laws")
        return f"N_corr = {N_corr / RPM:.0f} rpm, PR = {PR:.4f}, chi = {chi:.3f}"

    def lookup(self, N_corr: float, PR: float) -> tuple[float, float, float]:
        """Corrected flow [kg/s], efficiency [-] and chi [-] at a corrected speed [rad/s] and a
        total pressure ratio [-].

        The returned chi is the unclamped eq.-4.25 value (chi > 1 surge side, < 0 stalled); the
        flow and efficiency are clamped to the table edge (one :class:`MapRangeWarning`).
        Below the lowest speed line the look-up uses the similar point of that line (fan laws:
        ``PR - 1`` scales with speed squared, flow with speed), so that the flow goes to zero
        with the speed instead of staying at the lowest line's value.
        """
        m, eta, chi, code = kernels().compressor_lookup(self.speed, self.chi, self.mass_flow, self.efficiency,
                                                        self.pr_stall, self.pr_span, N_corr, PR)
        self.warn_range(code, N_corr, PR, chi)
        return m, eta, chi


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
        self.expansion_ratio = np.ascontiguousarray(expansion_ratio, dtype=float)

    def _range_message(self, code: int, N_corr: float, ER: float, chi: float) -> str:
        return f"N_corr = {N_corr / RPM:.0f} rpm, ER = {ER:.4f}"

    def lookup(self, N_corr: float, ER: float) -> tuple[float, float]:
        """Corrected flow [kg/s] and efficiency [-] at a corrected speed [rad/s] and expansion
        ratio [-]; clamped to the table edge outside the data (one :class:`MapRangeWarning`)."""
        m, eta, code = kernels().turbine_lookup(self.speed, self.expansion_ratio, self.mass_flow,
                                                self.efficiency, N_corr, ER)
        self.warn_range(code, N_corr, ER, float("nan"))
        return m, eta


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
        pr, m, e = (np.asarray(v, dtype=float) for v in (s.pressure_ratio, s.mass_flow, s.efficiency))
        stable = _stable_branch(pr, m)
        chi = (pr[stable] - pr_st) / (pr_su - pr_st)
        order = np.argsort(chi)
        chi = chi[order]
        if np.any(np.diff(chi) <= 0):
            problems.append(f"{what}: pressure ratio must be strictly monotonic along the line "
                            "right of its peak (the stable branch)")
        if chi[0] > coverage_tol or chi[-1] < 1.0 - coverage_tol:
            problems.append(f"{what}: data cover chi {chi[0]:.3f} ... {chi[-1]:.3f}; they must "
                            f"reach the stall (0) and surge (1) lines within {coverage_tol}")
        m_tab.append(np.interp(grid, chi, m[stable][order]))
        e_tab.append(np.interp(grid, chi, e[stable][order]))
    _raise_problems(problems, f"compressor map '{cmap.name}'")
    return CompressorTable(cmap.name, [s.speed for s in cmap.speed_lines], grid, m_tab, e_tab,
                           stall, surge, cmap.T_ref, cmap.p_ref, min_span)


def _stable_branch(pr: np.ndarray, m: np.ndarray) -> np.ndarray:
    """Indices of the stable branch of a compressor speed line: from its highest pressure ratio
    (the peak, on the surge line) towards larger flow.  Points left of the peak (the falling
    branch left of surge, two flows per PR) are map data for the drawing only; chi indexes the
    stable branch, and chi > 1 at run time means the operating point is in surge."""
    order = np.argsort(m, kind="stable")
    peak = int(np.argmax(pr[order]))
    return order[peak:]


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
