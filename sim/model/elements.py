"""The torque formulas of the shift elements (friction clutches and brakes, one-way clutches, dog
clutches): one implementation for the Python right-hand side (:mod:`.transmission`) and the
compiled one (:mod:`transgen.sim.solve.kernel`), compiled where numba is there (:mod:`..core.jit`)."""
from __future__ import annotations

import math

from ..core.interp import interp_like_numpy
from ..core.jit import compilable

__all__ = ["APPLY_THRESHOLD", "FRICTION", "ONEWAY", "DOG", "slipping_torque", "static_capacity", "element_margin",
           "add_holding_range", "group_margin"]

#: Codes of the element kinds in the compilable functions below (every other kind is a friction
#: element: a clutch or a brake).
FRICTION, ONEWAY, DOG = 0, 1, 2
#: An apply fraction at or below this counts as released. The simulator watches every apply signal
#: crossing it (a rise from zero or a fall to zero is a kink of the element torque and may change the
#: mode); slightly above zero so that an apply held at exactly zero never looks like a crossing.
APPLY_THRESHOLD = 1e-12


# ------------------------------------------------------- element formulas (one implementation)


@compilable
def slipping_torque(apply: float, slip: float, scale: float, friction_slips, friction_factors) -> float:
    """Torque [N*m] of a slipping friction element at the apply fraction ``apply`` (``apply_at``)
    and slip ``slip`` [rad/s]: ``scale * apply * friction(|slip|)`` with the signed capacity
    ``scale`` (:meth:`ElementConfig.signed_capacity`); no friction table when ``friction_slips``
    is empty; zero when released."""
    if scale == 0.0 or apply <= 0.0:
        return 0.0
    if len(friction_slips):
        apply *= interp_like_numpy(abs(slip), friction_slips, friction_factors)
    return scale * apply


@compilable
def static_capacity(code: int, static: float, apply: float) -> float:
    """Static capacity [N*m] of an element of kind ``code`` at the apply fraction ``apply``:
    ``T_static * apply`` (friction), unlimited (one-way clutch), ``T_static`` while engaged
    (dog: engaged teeth hold their full capacity; released, nothing)."""
    if code == DOG:
        return static if apply > APPLY_THRESHOLD else 0.0
    return math.inf if code == ONEWAY else static * apply


@compilable
def element_margin(code: int, capacity: float, free: int, torque: float) -> float:
    """How far the torque [N*m] of a lone locked element is inside its holding limit (>= 0: it
    holds): ``T_static * apply - |t|`` for a friction element (``capacity``: :func:`static_capacity`),
    ``-free * t`` for a one-way clutch, each with the round-off allowance that the mode decision
    accepts (so that a lock decided at its limit starts on the holding side of the unlock event);
    an engaged dog of unlimited capacity holds any torque."""
    if code == DOG and capacity == math.inf:
        return 1.0
    if code == ONEWAY:
        return 1e-9 * (1.0 + abs(torque)) - free * torque
    return capacity * (1.0 + 1e-9) + 1e-9 - abs(torque)


@compilable
def add_holding_range(lo: float, hi: float, code: int, free: int, sign: int, capacity: float) -> tuple[float, float]:
    """The holding range ``(lo, hi)`` of a locked group with one more member (kind ``code``,
    ``sign`` relative to the group's direction): ``+-capacity`` for a friction element, without
    limit in a one-way clutch's locking direction."""
    if code == ONEWAY:
        # free=+1 overruns with positive slip: locked it transmits t <= 0 (its own direction),
        # i.e. -free*sign in the row's direction
        if -free * sign > 0:
            return lo, math.inf
        return -math.inf, hi
    return lo - capacity, hi + capacity


@compilable
def group_margin(lo: float, hi: float, friction: float, torque: float) -> float:
    """How far a locked group's torque is inside its holding range ``(lo, hi)``, with a round-off
    allowance relative to its friction capacity ``friction`` and the torque."""
    return min(hi - torque, torque - lo) + 1e-9 * (1.0 + friction + abs(torque))
