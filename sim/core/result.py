"""The result of a simulation: time, named signals, mode history, events, energy balance."""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

__all__ = ["ModeSpan", "Event", "Result"]


@dataclass(frozen=True)
class ModeSpan:
    """The transmission was in mode ``name`` (locked elements ``locked``) from ``t0`` to ``t1``;
    ``gear``: the declared gear (or neutral) it is, else None. The name is the user's
    (:class:`transgen.names.ModeNames`: the gear, a declared mode's name, or the locked set)."""

    t0: float
    t1: float
    name: str
    locked: tuple[str, ...]
    gear: str | None = None

    def to_dict(self) -> dict:
        """JSON-ready: ``name``, ``gear``, ``locked``, ``t0``, ``t1`` (s)."""
        return {"t0": self.t0, "t1": self.t1, "name": self.name, "gear": self.gear, "locked": list(self.locked)}


@dataclass(frozen=True)
class Event:
    """A mode change at time ``t``: ``kind`` is ``lock``, ``unlock``, ``switch``, ``reverse`` (a
    slipping element's slip changed sign) or ``start``; ``elements`` those that changed. A
    controller's events: ``command`` (a shift commanded, a speed-phase-first shift applied at
    synchronism) and ``ease`` (an oncoming element eased near its lock); ``detail`` describes them."""

    t: float
    kind: str
    elements: tuple[str, ...]
    source: str
    target: str
    detail: str = ""


@dataclass
class Result:
    """A simulation result (SI units; see ``units``).

    ``signals`` holds one array per named signal over ``time`` (at a mode change the time
    appears twice, once for each side; :mod:`transgen.sim.analysis.result_files` writes files with one row
    per time on request). ``success`` is False when the run stopped early;
    ``message`` says why (time, mode, reason). ``state``: the run's state at its end
    (:class:`~transgen.sim.solve.restart.SimState`, mode-switching runs), from which another run can
    start.
    """

    time: np.ndarray
    signals: dict[str, np.ndarray]
    units: dict[str, str]
    modes: list[ModeSpan]
    events: list[Event]
    success: bool
    message: str
    energy: dict[str, float] = field(default_factory=dict)
    stats: dict[str, float] = field(default_factory=dict)
    meta: dict = field(default_factory=dict)
    state: object = None

    def __getitem__(self, name: str) -> np.ndarray:
        return self.signals[name]

    def summary(self) -> dict:
        """JSON-ready summary: success, message, modes, events, energy balance, run statistics."""
        return {
            "success": self.success,
            "message": self.message,
            "t_end": float(self.time[-1]) if len(self.time) else 0.0,
            "modes": [m.to_dict() for m in self.modes],
            "events": [{"t": e.t, "kind": e.kind, "elements": list(e.elements), "from": e.source, "to": e.target,
                        "detail": e.detail} for e in self.events],
            "energy": self.energy,
            "stats": self.stats,
            "meta": self.meta,
        }
