"""Summary of a turbocharger map and of its causal tables: what ``transgen maps`` prints.

:func:`load_named_map` finds a map file by path or a bundled map by name (``we_compressor``,
``we_turbine`` in ``sim/data``); :func:`map_summary` gives a JSON-ready summary of the map (speed
lines, surge and stall lines, reference state, provenance) and of the tables the pre-processor
makes of it (thesis 4.4: speed grid, chi or expansion-ratio grid, ranges); speeds in rpm,
flows in kg/s; :func:`map_summary_text` is its human-readable form.
"""
from __future__ import annotations

import difflib
from pathlib import Path

import numpy as np

from .gas import RPM
from .map_file import DATA_DIR, CompressorMap, MapError, TurbineMap, load_map
from .preprocessor import preprocess_compressor, preprocess_turbine

__all__ = ["bundled_maps", "load_named_map", "map_summary", "map_summary_text"]


def bundled_maps() -> dict[str, Path]:
    """Name -> path of the map files shipped in ``sim/data`` (``we_compressor``, ``we_turbine``)."""
    out = {}
    for p in sorted(DATA_DIR.glob("*.toml")):
        head = p.read_text(encoding="utf-8")[:4000]
        if "transgen-compressor-map" in head or "transgen-turbine-map" in head:
            out[p.stem] = p
    return out


def load_named_map(ref: str | Path) -> tuple[Path, CompressorMap | TurbineMap]:
    """A map file by path, or a bundled map by name (``we_compressor``); raises
    :class:`~transgen.sim.engine.map_file.MapError` naming the bundled maps if neither exists."""
    path = Path(ref)
    if not path.exists():
        bundled = bundled_maps()
        stem = path.stem if path.suffix in ("", ".toml") else str(ref)
        if stem not in bundled:
            close = difflib.get_close_matches(stem, list(bundled), n=1, cutoff=0.5)
            hint = f"; did you mean '{close[0]}'?" if close else ""
            raise MapError(f"{ref}:1:1: error: no such map file and no bundled map of that name "
                           f"(bundled: {', '.join(bundled)}){hint}")
        path = bundled[stem]
    return path, load_map(path)


def _range(values) -> list[float]:
    v = np.asarray(values, dtype=float)
    return [float(np.min(v)), float(np.max(v))]


MAP_UNITS = {"T_ref": "K", "p_ref": "Pa", "speed_rpm": "rpm", "points": "1", "mass_flow": "kg/s",
             "pressure_ratio": "1", "efficiency": "1", "expansion_ratio": "1", "chi": "1", "step": "1",
             "pr_stall": "1", "pr_surge": "1"}
"""Units of the numeric fields of :func:`map_summary` (mass flows and speeds corrected to the
reference state)."""


def map_summary(path: Path, m: CompressorMap | TurbineMap) -> dict:
    """JSON-ready summary of a map and of its pre-processed causal tables."""
    out = {"file": str(path), "name": m.name, "reference": {"T_ref": m.T_ref, "p_ref": m.p_ref},
           "provenance": dict(m.provenance)}
    if isinstance(m, CompressorMap):
        tab = preprocess_compressor(m)
        out["kind"] = "compressor"
        out["speed_lines"] = [{"speed_rpm": s.speed / RPM, "points": len(s.mass_flow),
                               "mass_flow": _range(s.mass_flow), "pressure_ratio": _range(s.pressure_ratio),
                               "efficiency": _range(s.efficiency)} for s in m.speed_lines]
        out["surge_line"] = {"speed_rpm": _range(np.asarray(m.surge_line.speed) / RPM),
                             "mass_flow": _range(m.surge_line.mass_flow),
                             "pressure_ratio": _range(m.surge_line.pressure_ratio)}
        out["stall_line"] = {"speed_rpm": _range(np.asarray(m.stall_line.speed) / RPM),
                             "mass_flow": _range(m.stall_line.mass_flow),
                             "pressure_ratio": _range(m.stall_line.pressure_ratio)}
        out["table"] = {"inputs": ["N_corr [rpm]", "chi [-]"], "outputs": ["m_corr [kg/s]", "eta [-]"],
                        "speed_rpm": [float(x) for x in tab.speed / RPM],
                        "chi": {"points": int(tab.chi.size), "range": _range(tab.chi),
                                "step": float(tab.chi[1] - tab.chi[0])},
                        "pr_stall": [float(x) for x in tab.pr_stall], "pr_surge": [float(x) for x in tab.pr_surge],
                        "mass_flow": _range(tab.mass_flow), "efficiency": _range(tab.efficiency)}
    else:
        tab = preprocess_turbine(m)
        out["kind"] = "turbine"
        out["speed_lines"] = [{"speed_rpm": s.speed / RPM, "points": len(s.mass_flow),
                               "expansion_ratio": _range(s.expansion_ratio), "mass_flow": _range(s.mass_flow),
                               "efficiency": _range(s.efficiency)} for s in m.speed_lines]
        out["table"] = {"inputs": ["N_corr [rpm]", "ER [-]"], "outputs": ["m_corr [kg/s]", "eta [-]"],
                        "speed_rpm": [float(x) for x in tab.speed / RPM],
                        "expansion_ratio": {"points": int(tab.expansion_ratio.size),
                                            "range": _range(tab.expansion_ratio)},
                        "mass_flow": _range(tab.mass_flow), "efficiency": _range(tab.efficiency)}
    return out


def map_summary_text(s: dict) -> str:
    """Human-readable form of :func:`map_summary`."""
    lines = [f"{s['kind']} map '{s['name']}' ({s['file']})",
             f"  reference state T_ref = {s['reference']['T_ref']:g} K, p_ref = {s['reference']['p_ref']:g} Pa",
             f"  {len(s['speed_lines'])} speed lines, {s['speed_lines'][0]['speed_rpm']:.0f} .. "
             f"{s['speed_lines'][-1]['speed_rpm']:.0f} rpm (corrected)"]
    for ln in s["speed_lines"]:
        second = (f"PR {ln['pressure_ratio'][0]:.3f}..{ln['pressure_ratio'][1]:.3f}" if s["kind"] == "compressor"
                  else f"ER {ln['expansion_ratio'][0]:.3f}..{ln['expansion_ratio'][1]:.3f}")
        lines.append(f"    {ln['speed_rpm']:9.0f} rpm  {ln['points']:3d} points  flow {ln['mass_flow'][0]:.4f}.."
                     f"{ln['mass_flow'][1]:.4f} kg/s  {second}  eta {ln['efficiency'][0]:.3f}..{ln['efficiency'][1]:.3f}")
    t = s["table"]
    if s["kind"] == "compressor":
        lines.append(f"  surge line PR {s['surge_line']['pressure_ratio'][0]:.3f}..{s['surge_line']['pressure_ratio'][1]:.3f},"
                     f" stall line PR {s['stall_line']['pressure_ratio'][0]:.3f}..{s['stall_line']['pressure_ratio'][1]:.3f}")
        lines.append(f"  causal tables m_corr(N_corr, chi), eta(N_corr, chi): {len(t['speed_rpm'])} speeds x "
                     f"{t['chi']['points']} chi values ({t['chi']['range'][0]:g}..{t['chi']['range'][1]:g}, step "
                     f"{t['chi']['step']:g}); flow {t['mass_flow'][0]:.4f}..{t['mass_flow'][1]:.4f} kg/s, eta "
                     f"{t['efficiency'][0]:.3f}..{t['efficiency'][1]:.3f}")
    else:
        e = t["expansion_ratio"]
        lines.append(f"  causal tables m_corr(N_corr, ER), eta(N_corr, ER): {len(t['speed_rpm'])} speeds x "
                     f"{e['points']} expansion ratios ({e['range'][0]:g}..{e['range'][1]:g}); flow "
                     f"{t['mass_flow'][0]:.4f}..{t['mass_flow'][1]:.4f} kg/s, eta {t['efficiency'][0]:.3f}.."
                     f"{t['efficiency'][1]:.3f}")
    return "\n".join(lines)
