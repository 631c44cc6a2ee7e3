"""The parsed mechanism: immutable objects with their source positions.

A :class:`Mechanism` is what a ``.mech`` file describes. It knows nothing of how equations are
formed (see :mod:`transgen.constraints` and :mod:`transgen.equations`).

Sign conventions (used throughout transgen):

* Speeds are in rad/s, positive in the input's positive direction of rotation. The housing
  (:data:`HOUSING`) has speed 0.
* A shift element between ``link1`` and ``link2`` has slip speed ``w1 - w2`` and transmits the
  torque ``t`` from ``link1`` to ``link2``: it acts as ``-t`` on ``link1`` and ``+t`` on ``link2``.
  A brake is an element whose ``link2`` is the housing. A slipping element transmits
  ``t = T_dynamic * apply * sign(slip)`` and dissipates ``t * slip >= 0``.
* The input torque drives the input link (``+T_in``); the output torque is what the output link
  delivers to the driveline (it acts as ``-T_out`` on the output link). Named extra torques drive
  their link (``+T``).
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Literal

__all__ = [
    "HOUSING",
    "Span",
    "Link",
    "Planetary",
    "SteppedPlanetary",
    "STEPPED_MEMBERS",
    "Share",
    "share_members",
    "share_groups",
    "GearPair",
    "ShiftElement",
    "ExternalTorque",
    "Gear",
    "ModeDecl",
    "Mechanism",
]

HOUSING = "housing"
"""Name of the fixed transmission case (speed 0); usable wherever a link is expected."""


@dataclass(frozen=True)
class Span:
    """Where something stands in its source file (1-based line and column)."""

    line: int = 0
    column: int = 0


def _span() -> Span:
    return field(default=Span(), compare=False, repr=False)


@dataclass(frozen=True)
class Link:
    """A rigid rotating member with its inertia ``inertia`` [kg*m^2] (0 = massless)."""

    name: str
    inertia: float
    span: Span = _span()


@dataclass(frozen=True)
class Planetary:
    """A planetary gearset.

    ``pinions=1``: simple set, ``Ns*w_s + Nr*w_r = (Ns + Nr)*w_c`` (thesis eq. 3.37).
    ``pinions=2``: double-pinion set, ``Nr*w_r - Ns*w_s = (Nr - Ns)*w_c``.
    Members are link names or :data:`HOUSING`.

    A tooth count written ``?`` or ``a..b`` is unknown (``None``), to be found by
    :mod:`transgen.synthesis`; ``sun_bounds``/``ring_bounds`` keep a written range ``(a, b)``.
    Only ``parse_mechanism(..., unknown_teeth=True)`` builds such a set.
    """

    name: str
    sun: str
    ring: str
    carrier: str
    n_sun: int | None
    n_ring: int | None
    pinions: Literal[1, 2] = 1
    span: Span = _span()
    sun_bounds: tuple[int, int] | None = None
    ring_bounds: tuple[int, int] | None = None
    eta0: float | None = None
    """Standing (carrier-fixed) efficiency of the sun-ring train, 0 < eta0 <= 1; ``None``: the
    default of :func:`transgen.powerflow.power_flow`."""

    @property
    def teeth_known(self) -> bool:
        return self.n_sun is not None and self.n_ring is not None

    @property
    def members(self) -> tuple[str, str, str]:
        """(sun, ring, carrier)."""
        return (self.sun, self.ring, self.carrier)


def share_members(pinions: int) -> tuple[str, ...]:
    """The members a ``share`` statement can name on a planetary with ``pinions`` pinions: its
    sun, ring and carrier, and its pinion (a double-pinion set: the ``inner_pinion`` meshing the
    sun, the ``outer_pinion`` meshing the ring)."""
    return ("sun", "ring", "carrier") + (("pinion",) if pinions == 1 else ("inner_pinion", "outer_pinion"))


@dataclass(frozen=True)
class Share:
    """Two planetary statements that name one physical gear or pinion (``share A.ring B.ring``):
    a Ravigneaux set's one ring and long pinion. A shared sun or ring is one link with one tooth
    count, a shared carrier one link, a shared pinion one tooth count on one carrier at one
    centre distance (:mod:`transgen.synthesis.shares`)."""

    set1: str
    member1: str
    set2: str
    member2: str
    span: Span = _span()


def share_groups(shares) -> tuple[tuple[tuple[str, str], ...], ...]:
    """The physical gears the ``shares`` make: each a tuple of ``(set, member)`` named by two or
    more statements (the shares joined transitively), in the order first named."""
    parent: dict[tuple[str, str], tuple[str, str]] = {}

    def root(x):
        while parent.setdefault(x, x) != x:
            x = parent[x]
        return x

    for s in shares:
        a, b = root((s.set1, s.member1)), root((s.set2, s.member2))
        if a != b:
            parent[b] = a
    groups: dict[tuple[str, str], list] = {}
    for x in parent:
        groups.setdefault(root(x), []).append(x)
    return tuple(tuple(g) for g in groups.values())


STEPPED_MEMBERS = ("sun1", "sun2", "ring1", "ring2")
"""The members a stepped-pinion planetary can have: a sun or a ring on pinion step 1 or 2."""


@dataclass(frozen=True)
class SteppedPlanetary:
    """A planetary with stepped (or long) pinions: one carrier whose pinions have two steps of
    ``np1`` and ``np2`` teeth, and two to four central gears, each meshing one step: ``members``
    is a tuple of ``(role, link, teeth)`` with ``role`` in :data:`STEPPED_MEMBERS` (``sun2``: a
    sun meshing step 2; ``ring1``: a ring meshing step 1).

    Each member ``X`` on step ``k`` obeys ``(w_X - w_c) * N_X / Np_k = sigma_X * (w_p - w_c)``
    (``w_p`` the pinion speed, ``sigma`` -1 for a sun, +1 for a ring); eliminating ``w_p``
    between the first member ``A`` and each other member ``B`` gives the constraints
    ``sigma_A*N_A*Np_b*w_A - sigma_B*N_B*Np_a*w_B = (sigma_A*N_A*Np_b - sigma_B*N_B*Np_a)*w_c``.
    A sun on step 1 and a ring on step 2: ``Ns*Np2*w_s + Nr*Np1*w_r = (Ns*Np2 + Nr*Np1)*w_c``;
    with ``Np1 = Np2`` the simple planetary.
    """

    name: str
    carrier: str
    members: tuple[tuple[str, str, int], ...]
    np1: int | None = None
    np2: int | None = None
    span: Span = _span()
    eta0: float | None = None
    """Standing (carrier-fixed) efficiency between two of its central gears (two meshes, one on
    each of their pinion steps), as a planetary's ``eta0``: see :mod:`transgen.powerflow`;
    ``None``: the default of :func:`transgen.powerflow.power_flow`."""

    def step_teeth(self, role: str) -> int:
        """Teeth of the pinion step the member ``role`` meshes."""
        return self.np1 if role.endswith("1") else self.np2


@dataclass(frozen=True)
class GearPair:
    """A fixed gear mesh: size ``n1`` on ``link1`` meshes with size ``n2`` on ``link2``.

    Sizes are tooth counts (``by="teeth"``) or pitch radii in m (``by="radius"``).
    External mesh: ``n1*w1 = -n2*w2``; internal mesh (``link2`` carries the ring gear):
    ``n1*w1 = n2*w2``.
    """

    name: str
    link1: str
    link2: str
    n1: float
    n2: float
    by: Literal["teeth", "radius"] = "teeth"
    mesh: Literal["external", "internal"] = "external"
    span: Span = _span()
    eta: float | None = None
    """Mesh efficiency, 0 < eta <= 1; ``None``: the default of :func:`transgen.powerflow.power_flow`."""

    @property
    def sign(self) -> int:
        """-1 for an external mesh (direction reverses), +1 for an internal one."""
        return -1 if self.mesh == "external" else 1


@dataclass(frozen=True)
class ShiftElement:
    """A clutch, brake or one-way clutch between ``link1`` and ``link2``.

    ``kind`` is ``"clutch"``, ``"brake"`` (``link2`` is the housing), ``"oneway"`` or ``"dog"``
    (a dog clutch or, to the housing, a dog brake: open or locked only; it engages only at
    synchronous speed and transmits no torque while slipping, ``dynamic = 0``; ``static`` is its
    holding capacity, infinite unless given, beyond which the simulator stops).
    ``static`` and ``dynamic`` are torque capacities at full apply [N*m] (infinite static
    capacity for a one-way clutch). ``free`` is the sign of the slip ``w1 - w2`` in which a
    one-way clutch overruns (``"positive"`` or ``"negative"``); it locks against the other sign.
    """

    name: str
    kind: Literal["clutch", "brake", "oneway", "dog"]
    link1: str
    link2: str
    static: float
    dynamic: float
    free: Literal["positive", "negative"] | None = None
    brake_type: Literal["plate", "band"] | None = None
    span: Span = _span()
    max_slip_rpm: float | None = None
    """Highest admissible slip speed while open [rpm] (``None``: no limit given); see
    :func:`transgen.powerflow.power_flow`."""
    drag: float | None = None
    """Viscous drag coefficient of the open pack [N*m*s/rad] (``drag=`` in the file; ``None``: the
    loss model's default): the drag torque ``drag * slip`` of :mod:`transgen.losses`."""

    @property
    def links(self) -> tuple[str, str]:
        return (self.link1, self.link2)


@dataclass(frozen=True)
class ExternalTorque:
    """An external torque input on ``link``; ``role`` is ``"input"``, ``"output"`` or ``"load"``.

    The input and named loads drive their link (``+T``); the output torque is delivered by the
    output link to the driveline (``-T`` on the link).
    """

    name: str
    link: str
    role: Literal["input", "output", "load"]
    span: Span = _span()

    @property
    def sign(self) -> int:
        """Sign with which the torque acts on its link."""
        return -1 if self.role == "output" else 1


@dataclass(frozen=True)
class Gear:
    """A row of the gear table: a named gear (or neutral) and its engaged shift elements.

    ``ratio`` is the published input/output speed ratio as written in the file (a string, so
    that its precision is known), or ``None``. How it is compared with the computed ratio:
    ``tolerance`` (``tol=``, an absolute tolerance, as written) when given, else ``rounding``:
    ``"nearest"`` (the computed ratio rounds to it at its printed precision: within half a unit
    of its last digit) or ``"truncated"`` (the computed ratio, cut toward zero after its printed
    digits, gives it: ``|pub| <= |computed| < |pub| + one unit of the last digit``).
    """

    name: str
    engaged: tuple[str, ...]
    kind: Literal["gear", "neutral"] = "gear"
    ratio: str | None = None
    span: Span = _span()
    tolerance: str | None = None
    rounding: Literal["nearest", "truncated"] = "nearest"
    alternative: bool = False
    """An alternative gear (a manual low, a second reverse, a 10-speed's extra ratio): in the
    table, but outside the step sequence, the spread and the default speed-phase modes."""


@dataclass(frozen=True)
class ModeDecl:
    """An explicitly declared mode: its name and locked shift elements."""

    name: str
    locked: tuple[str, ...]
    span: Span = _span()


@dataclass(frozen=True)
class Mechanism:
    """A transmission mechanism as described by a ``.mech`` file."""

    name: str
    links: tuple[Link, ...]
    planetaries: tuple[Planetary, ...] = ()
    gear_pairs: tuple[GearPair, ...] = ()
    elements: tuple[ShiftElement, ...] = ()
    input: str = ""
    output: str = ""
    loads: tuple[ExternalTorque, ...] = ()
    gears: tuple[Gear, ...] = ()
    modes: tuple[ModeDecl, ...] = ()
    coordinates: tuple[str, ...] = ()
    stepped: tuple[SteppedPlanetary, ...] = ()
    shares: tuple[Share, ...] = ()
    source: str = field(default="<string>", compare=False)
    text: str = field(default="", compare=False, repr=False)

    def source_line(self, line: int) -> str:
        """Line ``line`` (1-based) of the source text, or ``""``."""
        lines = self.text.split("\n")
        return lines[line - 1] if 0 < line <= len(lines) else ""

    @property
    def link_names(self) -> tuple[str, ...]:
        return tuple(link.name for link in self.links)

    @property
    def element_names(self) -> tuple[str, ...]:
        return tuple(e.name for e in self.elements)

    @property
    def torques(self) -> tuple[ExternalTorque, ...]:
        """External torque inputs in order: T_in, T_out, then the named loads."""
        return (
            ExternalTorque("T_in", self.input, "input"),
            ExternalTorque("T_out", self.output, "output"),
        ) + self.loads

    def link(self, name: str) -> Link:
        for link in self.links:
            if link.name == name:
                return link
        raise KeyError(name)

    def element(self, name: str) -> ShiftElement:
        for e in self.elements:
            if e.name == name:
                return e
        raise KeyError(name)

    def gear(self, name: str) -> Gear:
        for g in self.gears:
            if g.name == name:
                return g
        raise KeyError(name)

    @property
    def neutrals(self) -> tuple[Gear, ...]:
        return tuple(g for g in self.gears if g.kind == "neutral")
