"""The shift template as the optimizer sees it: the tuned parameters and their search box, the
template <-> vector conversion, and the fit of a template to a run's apply signals (the starting
calibration of a shift)."""
from __future__ import annotations

import math
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import asdict, dataclass, field, fields, replace

import numpy as np

from transgen.errors import ScenarioError

__all__ = ["PARAMETERS", "TORQUE_PARAMETERS", "EASE_PARAMETERS", "BOUNDS", "fit_template", "has_engine", "intervention_text"]


#: the tuned parameters, in the order of the optimizer's vector (the fields of ShiftTemplate)
PARAMETERS = ("fill_time", "fill_level", "ramp_time", "ramp_end", "hold_time", "final_time", "offgoing_delay",
              "offgoing_level", "offgoing_ramp")

#: the engine torque intervention's parameters (ShiftTemplate; factors [-] and times [s]), tuned after
#: PARAMETERS where the input is an engine
TORQUE_PARAMETERS = ("torque_boost", "boost_delay", "boost_time", "torque_cut", "cut_delay", "cut_time", "torque_ramp")

#: the easing of the inertia phase's end (ShiftTemplate; a slip fraction [-], a time [s], a level [-]),
#: tuned with PARAMETERS where an automatic schedule commands the shift (easing needs its measured slip)
EASE_PARAMETERS = ("ease_slip", "ease_time", "ease_level")

#: the search box of each parameter [s, apply fraction or torque factor]; widened to hold the starting
#: calibration. The increase goes up to 1.6 times the engine's torque (the engine gives no more than
#: its full-load torque at the current speed anyway), the reduction down to 0.3 times.
BOUNDS = {"fill_time": (0.0, 0.3), "fill_level": (0.0, 0.5), "ramp_time": (0.05, 1.5), "ramp_end": (0.05, 1.0),
          "hold_time": (0.0, 1.5), "final_time": (0.02, 0.5), "offgoing_delay": (0.0, 1.5),
          "offgoing_level": (0.0, 1.0), "offgoing_ramp": (0.01, 1.0),
          "torque_boost": (1.0, 1.6), "boost_delay": (0.0, 0.5), "boost_time": (0.0, 1.0), "torque_cut": (0.3, 1.0),
          "cut_delay": (0.0, 0.5), "cut_time": (0.0, 1.0), "torque_ramp": (0.02, 0.2),
          "ease_slip": (0.0, 0.9), "ease_time": (0.0, 1.0), "ease_level": (0.0, 1.0)}


# --------------------------------------------------------------------------------- templates


def _template(x: Sequence[float], names: Sequence[str] = PARAMETERS, base=None):
    """The template with the parameters ``names`` set to ``x`` (the others from ``base``, default
    the ShiftTemplate defaults)."""
    from transgen.sim.control.schedule import ShiftTemplate

    return replace(base or ShiftTemplate(), **{k: float(v) for k, v in zip(names, x)})


def _vector(template, names: Sequence[str] = PARAMETERS) -> np.ndarray:
    return np.array([getattr(template, k) for k in names], dtype=float)


def _span(template) -> float:
    """How long after the shift command the template's trajectories end [s] (the apply
    trajectories and the engine torque request)."""
    on = template.fill_time + template.ramp_time + template.hold_time + template.final_time
    if template.eases:  # the eased apply ends 2 ease_time + final_time after its event at the latest
        on += 2.0 * template.ease_time
    off = template.fill_time + template.offgoing_delay + template.offgoing_ramp
    request = template.torque_request(0.0)
    return max(on, off, request[-1][0] if request else 0.0)


def has_engine(scenario) -> bool:
    """Whether the scenario's input is an engine that takes a torque request (map engine, engine
    with converter, turbodiesel)."""
    from transgen.sim.model.components import EngineOnLink, EngineWithConverter
    from transgen.sim.model.turbodiesel import TurbodieselSource

    return any(isinstance(c, (EngineOnLink, EngineWithConverter, TurbodieselSource))
               for c in scenario.powertrain.components)


def intervention_text(template, own_request: bool = False) -> str:
    """How a template asks the engine for torque, in words: ``none`` or the increase and the
    reduction with their factors and times (``own_request``: the scenario's own ``[input]
    torque_request`` stays where the template asks for nothing)."""
    if not template.torque_intervention:
        return "none tuned: the scenario's own [input] torque_request kept" if own_request else "none"
    parts = []
    if template.torque_boost != 1.0:
        parts.append(f"x{template.torque_boost:.3f} for {template.boost_time:.3f} s from {template.boost_delay:.3f} s "
                     f"after the offgoing release starts")
    if template.torque_cut != 1.0:
        parts.append(f"x{template.torque_cut:.3f} for {template.cut_time:.3f} s from {template.cut_delay:.3f} s "
                     f"after the offgoing release ends")
    return "; ".join(parts) + f" (ramps {template.torque_ramp:.3f} s)"


def _curve(points, before: float):
    from transgen.sim.control.schedule import _merge

    t0 = points[0][0]
    return _merge([(t0 - 1.0, before)] + list(points))


def fit_template(oncoming, offgoing, t0: float, t1: float, samples: int = 400):
    """The :class:`~transgen.sim.control.schedule.ShiftTemplate` closest to the raw apply signals
    ``oncoming`` and ``offgoing`` (piecewise-linear :class:`~transgen.sim.core.signals.Signal` s)
    over the shift ``[t0, t1]`` [s], and the root-mean-square difference of the fitted applies
    from the raw ones over the shift (apply fraction; a fast raw drop that the template makes a
    jump differs for a few ms only, which a largest difference would overstate).

    The template's corners are read off the raw corners first (the fill: a jump and a flat piece
    at the start; the hold: the longest flat piece below full apply; the offgoing drop: where it
    leaves its level, the level just after, the time it reaches zero), then refined by least
    squares on ``samples`` points, the oncoming and the offgoing parameters each on their own
    curve."""
    from scipy.optimize import least_squares

    ts = np.linspace(t0, t1, samples)
    a_on = oncoming.sample(ts)
    a_off = offgoing.sample(ts)
    guess = {**_guess_oncoming(_points(oncoming, t0, t1), t0), **_guess_offgoing(_points(offgoing, t0, t1), t0)}
    guess["offgoing_delay"] = max(guess.pop("release") - t0 - guess["fill_time"], 0.0)
    lo = {k: BOUNDS[k][0] for k in PARAMETERS}
    hi = {k: (max(BOUNDS[k][1], 2.0 * (t1 - t0)) if k.endswith(("_time", "_delay", "_ramp")) else BOUNDS[k][1])
          for k in PARAMETERS}
    x = {k: float(np.clip(guess[k], lo[k], hi[k])) for k in PARAMETERS}

    def refine(names, curve, target):
        def residual(v):
            tmpl = _template([{**x, **dict(zip(names, v))}[k] for k in PARAMETERS])
            return curve(tmpl).sample(ts) - target

        v0 = [x[k] for k in names]
        fit = least_squares(residual, v0, bounds=([lo[k] for k in names], [hi[k] for k in names]), diff_step=1e-4,
                            max_nfev=200)
        if np.max(np.abs(residual(fit.x))) < np.max(np.abs(residual(v0))):
            x.update(zip(names, map(float, fit.x)))

    refine(PARAMETERS[:6], lambda tm: _curve(tm.oncoming(t0), 0.0), a_on)
    refine(PARAMETERS[6:], lambda tm: _curve(tm.offgoing(t0), float(a_off[0])), a_off)
    tmpl = _template([x[k] for k in PARAMETERS])
    fine = np.linspace(t0, t1, 20 * samples)
    diff = np.concatenate([_curve(tmpl.oncoming(t0), 0.0).sample(fine) - oncoming.sample(fine),
                           _curve(tmpl.offgoing(t0), float(a_off[0])).sample(fine) - offgoing.sample(fine)])
    return tmpl, float(np.sqrt(np.mean(diff ** 2)))


_JUMP = 1e-5  # s: a rise or fall this fast is a jump (the template's own jumps take 1e-6 s)


def _guess_oncoming(corners, t0: float) -> dict:
    """Template parameters of the oncoming apply read off its corners ``[(t, value), ...]``."""
    ts = [t for t, _ in corners]
    vs = [v for _, v in corners]
    top = max(vs)
    k_full = next(i for i, v in enumerate(vs) if v >= top - 1e-9)
    t_full = ts[k_full]
    k = 0
    while k + 1 < len(ts) and ts[k + 1] <= t0 + _JUMP and vs[k + 1] > vs[k]:  # a jump at the command
        k += 1
    fill_level, fill_end = vs[k], ts[k]
    if k + 1 < len(ts) and abs(vs[k + 1] - vs[k]) < 1e-9 and ts[k + 1] < t_full:  # a flat fill piece
        fill_end = ts[k + 1]
        k += 1
    flats = [(ts[i + 1] - ts[i], i) for i in range(k, k_full) if abs(vs[i + 1] - vs[i]) < 1e-9 and vs[i] < top - 1e-9
             and ts[i + 1] > ts[i]]
    if flats:
        _, i = max(flats)
        ramp_end, hold_start, hold_end = vs[i], ts[i], ts[i + 1]
    else:
        before = [i for i in range(k + 1, k_full)]
        i = before[-1] if before else None
        if i is None:
            hold_start = hold_end = fill_end + 0.5 * (t_full - fill_end)
            ramp_end = fill_level + 0.5 * (top - fill_level)
        else:
            ramp_end, hold_start, hold_end = vs[i], ts[i], ts[i]
    return {"fill_time": fill_end - t0, "fill_level": fill_level, "ramp_time": max(hold_start - fill_end, 1e-3),
            "ramp_end": ramp_end, "hold_time": hold_end - hold_start, "final_time": max(t_full - hold_end, 1e-3)}


def _guess_offgoing(corners, t0: float) -> dict:
    """The offgoing release read off its corners: its start, the level just after, its length."""
    ts = [t for t, _ in corners]
    vs = [v for _, v in corners]
    k = 0
    while k + 1 < len(ts) and vs[k + 1] >= vs[0] - 1e-9:
        k += 1
    release = ts[k]
    zero = next((t for t, v in zip(ts, vs) if t >= release and v <= 1e-9), ts[-1])
    after = [v for t, v in zip(ts, vs) if release <= t <= release + _JUMP and v < vs[0] - 1e-9]
    if after:
        level = after[0]
    else:  # no jump: the level the first piece of the release would start from
        level = vs[k + 1] if k + 1 < len(vs) else 0.0
        if k + 1 < len(ts) and ts[k + 1] > release and zero > release:
            slope = (vs[k + 1] - vs[k]) / (ts[k + 1] - ts[k])
            level = vs[k] if ts[k + 1] - ts[k] >= 0.5 * (zero - release) else vs[k + 1] - slope * 0.0
    return {"release": release, "offgoing_level": min(max(level, 0.0), 1.0), "offgoing_ramp": max(zero - release, 0.01)}


def _points(signal, t_a: float, t_b: float) -> list[tuple[float, float]]:
    """The corner points of a piecewise-linear ``signal`` on ``[t_a, t_b]`` (jumps as two points
    at one time)."""
    if not getattr(signal, "piecewise_linear", False):
        raise ScenarioError("the apply signal is not piecewise linear: give it as a table to calibrate it")
    out = []
    for t in sorted({t_a, t_b, *signal.breakpoints(t_a, t_b)}):
        left = signal.value(math.nextafter(t, -math.inf))
        if out and abs(left - signal.value(t)) > 1e-12:
            out.append((t, left))
        out.append((t, signal.value(t)))
    return out
