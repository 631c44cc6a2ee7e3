"""The run-time invariant monitor: a run is physically right, or it stops saying why.

After each integration segment the simulator samples it (:class:`~.integration.Recorder`) and
:meth:`InvariantMonitor.check` tests the samples, the segment's end included, for

``finite``
    every signal (link speeds, element torques, energies, component signals) is finite;
``oneway_free_sign``
    a one-way clutch that is not locked keeps its free sign: ``free * slip >= -tol``;
``dissipation``
    a slipping friction element dissipates ``t * slip >= 0`` (sign convention of
    :mod:`transgen.model`: slip ``w1 - w2``, torque from link1 to link2), and the dissipated
    energy integrated with the dynamics never decreases;
``holding_limit``
    a locked friction element holds ``|t| <= T_static * apply``, a locked one-way clutch only in
    its locking direction (``free * t <= 0``);
``energy_balance``
    over the segment, work in = change of stored energy + dissipated + work to the load;
``idle_speed``
    an idle hub of a gear (:mod:`transgen.idle`: a link no gearset touches, between open
    elements, e.g. the hub between a brake and a one-way clutch in series) turns only by its
    inertia and the torques of those open elements, which pull it toward the speeds of the links
    on their other sides: its speed never exceeds the larger of its speed at the segment's start
    and the largest of those speeds so far (``|w_hub| <= max(|w_hub(t0)|, max |w_other|)``).

The slip tolerance is the mode decision's (``SolverOptions.slip_tol`` relative to the largest link
speed); torques get a relative tolerance of 1e-6 of the element's capacity or of the largest
torque in the segment (the events locate lock and unlock to round-off, not to zero); the energy
residual of a segment is compared with ``energy_tol`` times the energy scale of the run so far
(the largest of work in, stored, dissipated and load work), at least ``energy_floor`` (the
recorder passes 1000 times the integrator's ``atol``: what its absolute tolerance leaves in the
energy integrals early in a run from rest).
A violation raises :class:`InvariantViolation` naming the invariant, the element (or signal),
the time and the mode; the run then stops with ``success = False``.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from transgen.errors import SimulationError
from transgen.idle import idle_hubs
from transgen.model import HOUSING

__all__ = ["INVARIANTS", "InvariantViolation", "InvariantMonitor"]

INVARIANTS = ("finite", "oneway_free_sign", "dissipation", "holding_limit", "energy_balance", "idle_speed")
_TORQUE_RTOL = 1e-6


class InvariantViolation(SimulationError):
    """A physical invariant failed: ``invariant``, ``element`` (or signal), time ``t`` [s], ``mode``."""

    def __init__(self, invariant: str, element: str, t: float, mode: str, detail: str):
        self.invariant, self.element, self.t, self.mode = invariant, element, t, mode
        super().__init__(f"t={t:.6g} s: invariant '{invariant}' violated by {element} in mode {mode}: {detail}")


@dataclass
class _Tally:
    samples: int = 0
    worst: float = 0.0  # the largest violation measure seen, relative to its tolerance (< 1 passes)


class InvariantMonitor:
    """Checks the invariants of the module docstring on the sampled segments of one run.

    ``slip_tol`` [rad/s] relative to the largest link speed (as ``SolverOptions.slip_tol``);
    ``energy_tol``: the largest energy residual of a segment, relative to the run's energy scale.
    """

    def __init__(self, transmission, slip_tol: float, energy_tol: float, energy_floor: float = 0.0):
        self.tr = transmission
        self.slip_tol = slip_tol
        self.energy_tol = energy_tol
        self.energy_floor = energy_floor
        self.tally = {name: _Tally() for name in INVARIANTS}
        self.segments = 0
        self.energy_scale = 0.0
        self._hubs: dict[frozenset, tuple] = {}  # lock set -> its idle hubs and their neighbours

    def check(self, ts: np.ndarray, block: dict[str, np.ndarray], locked: frozenset, mode: str) -> None:
        """Check one segment's samples ``block`` (signal name -> array over ``ts``), ``locked``: the
        indices of the elements locked (or stuck) in it. Raises :class:`InvariantViolation`."""
        self.segments += 1
        n = len(ts)
        self._finite(ts, block, mode)
        speeds = [v for k, v in block.items() if k.startswith("w_")]
        w_max = max((float(np.max(np.abs(v))) for v in speeds), default=0.0)
        slip_tol = max(1e-9, self.slip_tol * max(1.0, w_max))
        torque_scale = max((float(np.max(np.abs(block[f"t_{e.name}"]))) for e in self.tr.elements), default=0.0)
        for i, e in enumerate(self.tr.elements):
            slip, torque = block[f"slip_{e.name}"], block[f"t_{e.name}"]
            if i in locked:
                if e.kind == "dog" and not np.isfinite(e.static):
                    continue  # unlimited teeth: no holding limit to check
                if e.kind == "oneway":
                    excess = e.free * torque
                    limit = np.full(n, _TORQUE_RTOL * max(1.0, torque_scale))
                    what = "a locked one-way clutch transmits against its locking direction"
                else:
                    apply = block[f"apply_{e.name}"]
                    capacity = (np.where(apply > 0, e.static, 0.0) if e.kind == "dog"  # full teeth capacity
                                else e.static * apply)
                    excess = np.abs(torque) - capacity
                    limit = np.full(n, _TORQUE_RTOL * max(e.static, torque_scale))
                    what = "the locked torque exceeds the holding limit T_static*apply"
                self._verdict("holding_limit", excess, limit, ts, e.name, mode,
                              lambda k: f"{what} (t_{e.name} = {torque[k]:.6g} N*m)")
            elif e.kind == "oneway":
                self._verdict("oneway_free_sign", -e.free * slip, np.full(n, slip_tol), ts, e.name, mode,
                              lambda k: f"the one-way clutch slips in its locking direction (slip {slip[k]:.6g} rad/s)")
            else:
                power = torque * slip
                self._verdict("dissipation", -power, slip_tol * np.abs(torque) + 1e-12, ts, e.name, mode,
                              lambda k: f"the slipping element creates energy (t*slip = {power[k]:.6g} W)")
        self._idle(ts, block, locked, mode, slip_tol)
        # the dissipated energy, integrated with the dynamics, never decreases (this sees a friction
        # torque of the wrong sign in the right-hand side even where the samples are recomputed)
        e_diss = block["E_dissipated"]
        slipping = [e.name for i, e in enumerate(self.tr.elements) if i not in locked and e.kind != "oneway"]
        self._verdict("dissipation", np.maximum.accumulate(e_diss) - e_diss,  # the drawdown: solver noise stays small
                      np.full(n, self._energy_limit(float(np.max(np.abs(block["E_stored"]))))), ts,
                      f"the slipping elements ({', '.join(slipping) or 'none'}) and the components",
                      mode, lambda k: f"the dissipated energy decreases (to {e_diss[k]:.6g} J from {np.max(e_diss[:k + 1]):.6g} J)")
        self._energy(ts, block, mode)

    def summary(self) -> dict:
        """What was checked: per invariant the number of sample checks and the worst margin used
        (violation measure over its tolerance; below 1 passes)."""
        return {"segments": self.segments, "energy_tol": self.energy_tol,
                "invariants": {k: {"checks": v.samples, "worst": v.worst} for k, v in self.tally.items()}}

    # ------------------------------------------------------------------ checks
    def _idle(self, ts, block, locked, mode, slip_tol):
        """The ``idle_speed`` bound on the idle hubs of the segment's mode (:func:`transgen.idle.idle_hubs`,
        per lock set once; a transmission without a mechanism, as in unit tests, has none)."""
        if locked not in self._hubs:
            mech = getattr(self.tr, "mech", None)
            names = tuple(e.name for i, e in enumerate(self.tr.elements) if i in locked)
            self._hubs[locked] = idle_hubs(mech, names, self.tr.graph) if mech is not None else ()
        for hub, others in self._hubs[locked]:
            w = block[f"w_{hub}"]
            reach = np.full(len(ts), abs(float(w[0])))
            for other in others:
                if other != HOUSING:
                    reach = np.maximum(reach, np.abs(block[f"w_{other}"]))
            bound = np.maximum.accumulate(reach)
            self._verdict("idle_speed", np.abs(w) - bound, np.full(len(ts), slip_tol), ts, hub, mode,
                          lambda k: f"the idle hub turns faster ({w[k]:.6g} rad/s) than its start and the links "
                                    f"its open elements join it to allow ({bound[k]:.6g} rad/s)")

    def _finite(self, ts, block, mode):
        tally = self.tally["finite"]
        arrays = list(block.values())
        try:  # the common case in one test (a segment has few samples: the per-signal calls cost more)
            finite = bool(arrays) and bool(np.isfinite(np.concatenate(arrays)).all())
        except (ValueError, TypeError):  # signals of other shapes: the loop below
            finite = False
        if finite:
            tally.samples += sum(len(v) for v in arrays)
            return
        for name, values in block.items():  # the first non-finite signal, named
            tally.samples += len(values)
            bad = ~np.isfinite(values)
            if bad.any():
                k = int(np.argmax(bad))
                raise InvariantViolation("finite", name, float(ts[k]), mode, f"{name} = {values[k]}")

    def _verdict(self, invariant: str, excess: np.ndarray, limit: np.ndarray, ts, element: str, mode: str, detail):
        tally = self.tally[invariant]
        tally.samples += len(excess)
        ratio = excess / limit
        tally.worst = max(tally.worst, float(np.max(ratio)))
        violated = ratio > 1.0
        if violated.any():
            k = int(np.argmax(violated))  # the first violating sample
            raise InvariantViolation(invariant, element, float(ts[k]), mode, detail(k))

    def _energy_limit(self, scale: float = 0.0) -> float:
        """The energy [J] a segment may miss by: ``energy_tol`` of the run's energy scale, at least
        ``energy_floor`` (what the integrator's absolute tolerance leaves in the energy integrals,
        which dominates early in a run from rest)."""
        return max(self.energy_tol * max(self.energy_scale, scale), self.energy_floor, 1e-12)

    def _energy(self, ts, block, mode):
        tally = self.tally["energy_balance"]
        e_in, e_diss, e_load, e_st = (block[k] for k in ("E_in", "E_dissipated", "E_load", "E_stored"))
        self.energy_scale = max(self.energy_scale, float(np.max(np.abs(e_in))), float(np.max(np.abs(e_diss))),
                                float(np.max(np.abs(e_load))), float(np.max(np.abs(e_st))))
        residual = (e_in[-1] - e_in[0]) - (e_st[-1] - e_st[0]) - (e_diss[-1] - e_diss[0]) - (e_load[-1] - e_load[0])
        tally.samples += 1
        ratio = abs(residual) / self._energy_limit()
        tally.worst = max(tally.worst, ratio)
        if ratio > 1.0:
            raise InvariantViolation("energy_balance", "the powertrain", float(ts[-1]), mode,
                                     f"the segment from t={ts[0]:.6g} s does not close: residual {residual:.6g} J "
                                     f"(energy scale {self.energy_scale:.6g} J, tolerance {self.energy_tol:g}, floor {self.energy_floor:g} J)")

