"""Turbocharger report of a simulated run (thesis section 4.6).

:func:`turbo_report` summarises the turbocharger of one run (time to 90 % boost, peak turbo
speed, chi range) and compares two runs (basic vs iterative algorithm) binned by compressor mass
flow, as thesis section 4.6 discusses Figs. 4.17-4.24; :func:`algorithm_difference` evaluates both
turbocharger algorithms on the same states of one run, without the engine's feedback.  A run is
a :class:`~transgen.sim.core.result.Result` with the signals of
:class:`~transgen.sim.model.turbodiesel.TurbodieselSource`.  Times in s, speeds in rpm, flows in kg/s.
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .diesel import TurbochargedDiesel
from .gas import RPM
from .turbocharger import BasicTurbo, IterativeTurbo, PortAreas, TurboSolveError

__all__ = ["TurboReport", "turbo_report", "algorithm_difference", "unique_times", "TURBO_UNITS"]

TURBO_UNITS = {"fuel_step": "s", "window_end": "s", "boost_start": "1", "boost_peak": "1", "time_to_90_boost": "s",
               "peak_turbo_speed_krpm": "krpm", "peak_turbo_speed_time": "s", "chi_min": "1", "chi_max": "1",
               "compressor_flow_max": "kg/s", "flow_lo": "kg/s", "flow_hi": "kg/s", "d_turbo_krpm": "krpm",
               "d_turbo_percent": "%", "d_chi": "1", "surge_time": "s", "surge_first": "s",
               "choke_time": "s"}
"""Units of the numeric fields of :meth:`TurboReport.to_dict` (boost: compressor pressure ratio)."""

def unique_times(t: np.ndarray, *ys: np.ndarray):
    """Drop the repeated times at mode changes (keep the later sample)."""
    t = np.asarray(t, dtype=float)
    keep = np.ones(len(t), dtype=bool)
    keep[:-1] = np.diff(t) > 0
    return (t[keep],) + tuple(np.asarray(y, dtype=float)[keep] for y in ys)


def _fuel_step(t: np.ndarray, rack: np.ndarray) -> float:
    """Start of the first rise of the rack by more than half of its total rise; the run's start
    if the rack never rises."""
    if len(t) == 0:
        return 0.0
    rise = float(np.max(rack) - rack[0])
    if rise <= 1e-6:
        return float(t[0])
    k = int(np.argmax(rack >= rack[0] + 0.5 * rise))
    j = k
    while j > 0 and rack[j - 1] < rack[j] - 1e-12:
        j -= 1
    return float(t[j])


def _window_end(result, t_step: float) -> float:
    """End of the boost-build window after the fuel step: the first shift (an element other than
    a lock-up clutch changing state, or its apply starting to move) after the step, else the end."""
    t_end = float(result.time[-1])
    for e in result.events:
        if e.kind != "start" and e.t > t_step + 1e-6 and any(not n.startswith("LU") for n in e.elements):
            return min(t_end, e.t)
    # shifts start when an oncoming element's apply rises
    for key, values in result.signals.items():
        if key.startswith("apply_") and not key.startswith("apply_LU"):
            t, a = unique_times(result.time, values)
            rising = np.nonzero((a[1:] > a[:-1] + 1e-9) & (t[1:] > t_step + 1e-6))[0]
            if len(rising):
                t_end = min(t_end, float(t[rising[0]]))
    return t_end


@dataclass
class TurboReport:
    """Turbocharger summary of one run, and optionally its comparison with a second run.

    Times in s, speeds in rpm (``*_krpm`` in 1000 rpm), mass flows in kg/s. ``comparison``:
    ``bins`` of compressor mass flow (of the first run) with the mean turbo-speed difference
    (second - first) [krpm and %] and the mean chi difference, and the verdicts
    ``second_lower`` (turbo speed lower in every bin with flow) and ``difference_grows_with_flow``.
    """

    title: str
    fuel_step: float
    window_end: float
    boost_start: float
    boost_peak: float
    time_to_90_boost: float | None
    peak_turbo_speed_krpm: float
    peak_turbo_speed_time: float
    chi_min: float
    chi_max: float
    compressor_flow_max: float
    surge_time: float = 0.0
    surge_first: float | None = None
    choke_time: float = 0.0
    comparison: dict | None = None
    decoupled: dict | None = None

    def to_dict(self) -> dict:
        return {k: getattr(self, k) for k in self.__dataclass_fields__}

    def text(self) -> str:
        t90 = f"{self.time_to_90_boost:.2f} s" if self.time_to_90_boost is not None else "not reached"
        lines = [f"turbocharger: {self.title}",
                 f"  fuel step at t = {self.fuel_step:.2f} s: boost PR {self.boost_start:.2f} -> peak "
                 f"{self.boost_peak:.2f} before t = {self.window_end:.2f} s; time to 90 % boost {t90}",
                 f"  peak turbo speed {self.peak_turbo_speed_krpm:.1f} krpm at t = {self.peak_turbo_speed_time:.2f} s;"
                 f" chi {self.chi_min:.3f} .. {self.chi_max:.3f}; compressor flow up to "
                 f"{self.compressor_flow_max:.3f} kg/s",
                 "  surge (chi > 1, left of the surge line; the flow is held at the surge flow): "
                 + (f"{self.surge_time:.3f} s, first at t = {self.surge_first:.2f} s" if self.surge_first is not None
                    else "never") + f"; choked (chi < 0): {self.choke_time:.3f} s"]
        c = self.comparison
        if c:
            lines.append(f"  {c['second']} vs {c['first']} (time-aligned differences, second - first, "
                         "binned by compressor mass flow of the first):")
            lines.append(f"    {'flow [kg/s]':>15} {'samples':>8} {'d turbo [krpm]':>15} {'d turbo [%]':>12} {'d chi':>9}")
            for b in c["bins"]:
                lines.append(f"    {b['flow_lo']:6.3f}-{b['flow_hi']:6.3f}  {b['samples']:8d} {b['d_turbo_krpm']:15.3f} "
                             f"{b['d_turbo_percent']:12.2f} {b['d_chi']:9.4f}")
            lines.append(f"    low flow: d turbo {c['low']['d_turbo_krpm']:.3f} krpm, d chi {c['low']['d_chi']:.4f};"
                         f" high flow: d turbo {c['high']['d_turbo_krpm']:.3f} krpm, d chi {c['high']['d_chi']:.4f}")
            lines.append(f"    {c['second']} lower: {'yes' if c['second_lower'] else 'no'}; difference grows with "
                         f"flow: {'yes' if c['difference_grows_with_flow'] else 'no'}")
        d = self.decoupled
        if d:
            lines.append(f"  iterative vs basic algorithm on the same states (decoupled from the engine's feedback; "
                         f"{d['points']} points of this run, {d['skipped']} skipped), binned by compressor mass flow:")
            lines.append(f"    {'flow [kg/s]':>15} {'points':>7} {'d chi':>9} {'d m_c [%]':>10} {'d m_t [%]':>10} "
                         f"{'M_c,in':>7} {'M_c,out':>7}")
            for b in d["bins"]:
                lines.append(f"    {b['flow_lo']:6.3f}-{b['flow_hi']:6.3f}  {b['points']:7d} {b['d_chi']:9.4f} "
                             f"{b['d_flow_c_percent']:10.2f} {b['d_flow_t_percent']:10.2f} {b['mach_c_in']:7.3f} "
                             f"{b['mach_c_out']:7.3f}")
            lines.append(f"    iterative chi lower in every bin: {'yes' if d['chi_lower'] else 'no'}; |d chi| grows with "
                         f"flow: {'yes' if d['grows_with_flow'] else 'no'}")
            lines.append("    the sign of d chi depends on the compressor's outlet/inlet port areas (ports "
                         + ", ".join(f"{k} {v:g} mm" for k, v in d["ports_mm"].items()) + ")")
            a = d.get("alternative")
            if a:
                lines.append(f"    same with a {a['ports_mm']['compressor_outlet']:g} mm compressor outlet: d chi per bin "
                             + ", ".join(f"{b['d_chi']:+.4f}" for b in a["bins"])
                             + f"; iterative chi lower in every bin: {'yes' if a['chi_lower'] else 'no'}")
        return "\n".join(lines)

    __str__ = text


_CHI_TOL = 1e-6
"""chi beyond [0, 1] by more than this counts as surge (above) or choked (below)."""


def _time_where(t: np.ndarray, flag: np.ndarray) -> tuple[float, float | None]:
    """Total time [s] of the samples where ``flag`` holds (each sample owns the interval to the
    next one) and the first such time, or None."""
    if len(t) < 2 or not np.any(flag):
        return 0.0, None
    dt = np.diff(t)
    return float(np.sum(dt[flag[:-1]])), float(t[int(np.argmax(flag))])


def _title(result) -> str:
    """A short name of a run: its scenario file's stem, else its title."""
    meta = result.meta or {}
    if meta.get("scenario"):
        return Path(str(meta["scenario"])).stem
    return str(meta.get("title") or "run")


def turbo_report(result, other=None, bins: int = 5, engine: TurbochargedDiesel | None = None) -> TurboReport:
    """Turbocharger report of a run (a :class:`~transgen.sim.core.result.Result` with the signals of
    :class:`TurbodieselSource`), optionally compared with a second run ``other`` (e.g. basic
    vs iterative algorithm on the same scenario).

    * time to 90 % boost: from the fuel step (start of the first rise of the rack, or the start
      of the run) to the first time the boost pressure ratio has covered 90 % of its rise to the
      peak it reaches before the first shift;
    * peak turbo speed and when; chi range; largest compressor mass flow;
    * time in surge (chi > 1: the operating point left of the surge line, where the table holds
      the surge flow - a mean-value model has no surge cycle) and choked (chi < 0), and the first
      time in surge;
    * comparison: the second run's signals are interpolated onto the first's times; the
      differences (second - first) of turbo speed and chi are averaged in ``bins`` equal-width
      bins of the first run's compressor mass flow. ``low`` and ``high`` are the lowest and
      highest bin with samples;
    * with ``engine`` (the run's :class:`TurbochargedDiesel`): :func:`algorithm_difference` along
      the run.
    """
    for key in ("omega_tc", "chi", "boost_pressure_ratio", "m_dot_c"):
        if key not in result.signals:
            raise ValueError(f"turbo_report: the result has no '{key}' signal (not a turbodiesel run)")
    rack = result.signals.get("rack", np.ones(len(result.time)))
    t, w, chi, boost, flow, rack = unique_times(result.time, result["omega_tc"], result["chi"],
                                           result["boost_pressure_ratio"], result["m_dot_c"], rack)
    t_step = _fuel_step(t, rack)
    t_win = _window_end(result, t_step)
    sel = (t >= t_step) & (t <= t_win)
    if not np.any(sel):
        sel = t >= t_step
    b0 = float(np.interp(t_step, t, boost))
    b_peak = float(np.max(boost[sel]))
    t90 = None
    if b_peak > b0 + 1e-6:
        reached = np.nonzero(sel & (boost >= b0 + 0.9 * (b_peak - b0)))[0]
        if len(reached):
            t90 = float(t[reached[0]] - t_step)
    k = int(np.argmax(w))
    surge_t, surge_first = _time_where(t, chi > 1.0 + _CHI_TOL)
    choke_t, _ = _time_where(t, chi < -_CHI_TOL)
    rep = TurboReport(_title(result), t_step, t_win, b0, b_peak, t90, float(w[k] / RPM / 1e3), float(t[k]),
                      float(np.min(chi)), float(np.max(chi)), float(np.max(flow)), surge_time=surge_t,
                      surge_first=surge_first, choke_time=choke_t)
    if other is not None:
        rep.comparison = _compare(t, w, chi, flow, other, _title(result), bins)
    if engine is not None:
        rep.decoupled = algorithm_difference(result, engine, bins)
    return rep


def _diameters_mm(ports: PortAreas) -> dict:
    """Port diameters [mm] of circular ducts with the port areas."""
    return {k: round(1e3 * (4.0 * getattr(ports, k) / np.pi) ** 0.5, 1)
            for k in ("compressor_inlet", "compressor_outlet", "turbine_inlet", "turbine_outlet")}


ALTERNATIVE_COMPRESSOR_OUTLET = np.pi / 4 * 0.076 ** 2
"""Compressor outlet area [m^2] (76 mm duct) of the second chi comparison: the sign of the
iterative algorithm's chi shift depends on the compressor's outlet/inlet area ratio
(:class:`~transgen.sim.engine.turbocharger.PortAreas`), so the report shows both."""


def algorithm_difference(result, engine: TurbochargedDiesel, bins: int = 5, points: int = 400,
                         ports: PortAreas | None = None, alternative: bool = True) -> dict:
    """Both turbocharger algorithms evaluated on the same states: up to ``points`` samples of
    ``result`` (intake and exhaust manifold pressures, exhaust temperature, turbo speed) are fed
    to the basic and to the iterative algorithm with the maps, shaft and port areas of
    ``engine``'s turbocharger, so the difference is the algorithm's alone, without the feedback
    through the engine that obscures it in a coupled run (the decoupling the thesis asks for in
    4.6 and 5.2).

    Returns, per bin of the basic algorithm's compressor mass flow: the mean differences
    (iterative - basic) of chi and of the compressor and turbine mass flows [%], and the mean
    compressor port Mach numbers; ``chi_lower``: iterative chi lower in every bin;
    ``grows_with_flow``: ``|d chi|`` larger in the highest bin than in the lowest. Points where
    the iterative algorithm has no solution (choked ports) are skipped and counted.
    """
    own = engine.turbo
    ports = ports or getattr(own, "ports", PortAreas())
    basic = BasicTurbo(own.compressor, own.turbine, own.shaft)
    iterative = IterativeTurbo(own.compressor, own.turbine, own.shaft, ports)
    p = engine.params
    t, p_im, p_em, T_em, w = unique_times(result.time, result["p_im"], result["p_em"], result["T_em"], result["omega_tc"])
    rows, skipped = [], 0
    for k in np.unique(np.linspace(0, len(t) - 1, min(points, len(t))).astype(int)):
        a = basic.evaluate(p.p_amb, p.T_amb, p_im[k], p_em[k], T_em[k], p.p_amb, w[k])
        try:
            b = iterative.evaluate(p.p_amb, p.T_amb, p_im[k], p_em[k], T_em[k], p.p_amb, w[k])
        except TurboSolveError:
            skipped += 1
            continue
        if a.compressor.m_dot <= 1e-6 or a.turbine.m_dot <= 1e-6:
            continue
        rows.append((a.compressor.m_dot, b.compressor.chi - a.compressor.chi,
                     100.0 * (b.compressor.m_dot / a.compressor.m_dot - 1.0),
                     100.0 * (b.turbine.m_dot / a.turbine.m_dot - 1.0), b.mach[0], b.mach[1]))
    data = np.array(rows).reshape(-1, 6)
    flow = data[:, 0]
    out_bins = []
    if len(flow):
        edges = np.linspace(float(np.min(flow)), float(np.max(flow)), bins + 1)
        for i in range(bins):
            m = (flow >= edges[i]) & ((flow < edges[i + 1]) if i < bins - 1 else (flow <= edges[i + 1]))
            if np.any(m):
                mean = data[m].mean(axis=0)
                out_bins.append({"flow_lo": float(edges[i]), "flow_hi": float(edges[i + 1]), "points": int(np.sum(m)),
                                 "d_chi": float(mean[1]), "d_flow_c_percent": float(mean[2]),
                                 "d_flow_t_percent": float(mean[3]), "mach_c_in": float(mean[4]),
                                 "mach_c_out": float(mean[5])})
    out = {"points": len(rows), "skipped": skipped, "bins": out_bins, "ports_mm": _diameters_mm(ports),
           "chi_lower": bool(out_bins) and all(b["d_chi"] < 0 for b in out_bins),
           "grows_with_flow": bool(out_bins) and abs(out_bins[-1]["d_chi"]) > abs(out_bins[0]["d_chi"])}
    if alternative:
        alt = PortAreas(ports.compressor_inlet, ALTERNATIVE_COMPRESSOR_OUTLET, ports.turbine_inlet, ports.turbine_outlet)
        out["alternative"] = algorithm_difference(result, engine, bins, points, alt, alternative=False)
    return out


def _compare(t, w, chi, flow, other, first: str, bins: int) -> dict:
    t2, w2, chi2 = unique_times(other.time, other["omega_tc"], other["chi"])
    inside = (t >= t2[0]) & (t <= t2[-1])
    t, w, chi, flow = t[inside], w[inside], chi[inside], flow[inside]
    dw = (np.interp(t, t2, w2) - w) / RPM / 1e3
    dpct = 100.0 * (np.interp(t, t2, w2) - w) / np.maximum(w, 1e-9)
    dchi = np.interp(t, t2, chi2) - chi
    edges = np.linspace(float(np.min(flow)), float(np.max(flow)), bins + 1)
    rows = []
    for i in range(bins):
        m = (flow >= edges[i]) & ((flow < edges[i + 1]) if i < bins - 1 else (flow <= edges[i + 1]))
        if not np.any(m):
            continue
        rows.append({"flow_lo": float(edges[i]), "flow_hi": float(edges[i + 1]), "samples": int(np.sum(m)),
                     "d_turbo_krpm": float(np.mean(dw[m])), "d_turbo_percent": float(np.mean(dpct[m])),
                     "d_chi": float(np.mean(dchi[m]))})
    low, high = rows[0], rows[-1]
    # "lower" judged where the flow is not negligible (the lowest bin may sit at the floor)
    flowing = rows[1:] if len(rows) > 1 else rows
    return {"first": first, "second": _title(other), "bins": rows, "low": low, "high": high,
            "second_lower": all(r["d_turbo_krpm"] < 0 for r in flowing),
            "difference_grows_with_flow": abs(high["d_turbo_krpm"]) > abs(low["d_turbo_krpm"]),
            "mean_d_turbo_krpm": float(np.mean(dw)), "mean_d_chi": float(np.mean(dchi))}
