"""Causality kinds of simulation blocks and the algebraic-loop check (thesis section 2.4).

A simulation built as a state block diagram has no algebraic loop when blocks of two
complementary kinds alternate (thesis 2.4.5-2.4.6):

* mechanical: **inertial** blocks take torques and give speeds; **compliant** and **resistive**
  blocks take speeds and give torques;
* thermal-fluid: **control volumes** take mass and energy flows and give states (pressure,
  temperature); **flow** blocks take states and give flows.

Joining two blocks that give the same quantity (two inertias, a spring to a damper, two control
volumes, two flow blocks) forms an algebraic loop (or derivative causality) that the integrator
cannot resolve; :func:`check_connections` finds such joints and raises
:class:`AlgebraicLoopError` naming both blocks.  A joint that is meant to be there must be
"hidden" by solving the loop inside one block (thesis 2.4.3), as the transmission does for rigid
connections between inertias.

Every component of ``transgen.sim`` has a ``causality`` attribute: a read-only mapping from its
port names to a :class:`Causality` (a compressor is a flow block on its air ports and resistive on
its shaft port).

Examples
--------
>>> blocks = [Block("crank", {"shaft": Causality.INERTIAL}),
...           Block("damper", {"a": Causality.RESISTIVE, "b": Causality.RESISTIVE}),
...           Block("wheel", {"shaft": Causality.INERTIAL})]
>>> check_connections(blocks, [("crank", "damper.a"), ("damper.b", "wheel")])
"""
from __future__ import annotations

import enum
from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from types import MappingProxyType

from transgen.errors import TransgenError

__all__ = ["Causality", "Block", "AlgebraicLoopError", "CausalityError", "check_connections",
           "ports"]


class Causality(enum.Enum):
    """Causality kind of a block port; ``domain``, ``takes`` and ``gives`` describe it."""

    INERTIAL = "inertial"
    COMPLIANT = "compliant"
    RESISTIVE = "resistive"
    CONTROL_VOLUME = "control volume"
    FLOW = "flow"

    @property
    def domain(self) -> str:
        """``'mechanical'`` or ``'thermal-fluid'``."""
        return _KINDS[self][0]

    @property
    def takes(self) -> str:
        """The input quantity: torque, speed, flow or state."""
        return _KINDS[self][1]

    @property
    def gives(self) -> str:
        """The output quantity: speed, torque, state or flow."""
        return _KINDS[self][2]


_KINDS = {
    Causality.INERTIAL: ("mechanical", "torque", "speed"),
    Causality.COMPLIANT: ("mechanical", "speed", "torque"),
    Causality.RESISTIVE: ("mechanical", "speed", "torque"),
    Causality.CONTROL_VOLUME: ("thermal-fluid", "flow", "state"),
    Causality.FLOW: ("thermal-fluid", "state", "flow"),
}


def ports(**kinds: Causality) -> Mapping[str, Causality]:
    """A read-only port -> kind mapping, for a component's ``causality`` attribute."""
    return MappingProxyType(dict(kinds))


class CausalityError(TransgenError, ValueError):
    """A connection list is malformed: unknown block or port, or a joint across domains."""


class AlgebraicLoopError(CausalityError):
    """Two blocks of the same causality group are joined directly (an algebraic loop).

    ``pairs`` lists every offending joint as ``(block_a, block_b)``.
    """

    def __init__(self, message: str, pairs: list[tuple[str, str]]):
        super().__init__(message)
        self.pairs = pairs


@dataclass(frozen=True)
class Block:
    """A block of the simulation: a name and its ports' causality kinds.

    Parameters
    ----------
    name : str
        Unique block name (no dots).
    ports : mapping of str to Causality
        Port name -> kind.  A block with a single port can be referred to by its name alone.
    """

    name: str
    ports: Mapping[str, Causality]

    def __post_init__(self):
        object.__setattr__(self, "ports", MappingProxyType(dict(self.ports)))

    @classmethod
    def of(cls, name: str, component) -> "Block":
        """A block for a component that has a ``causality`` attribute."""
        return cls(name, component.causality)


def _endpoint(ep, blocks: dict[str, Block], problems: list[str]):
    name, _, port = str(ep).partition(".")
    block = blocks.get(name)
    if block is None:
        problems.append(f"unknown block '{name}' in connection endpoint '{ep}'")
        return None
    if not port:
        if len(block.ports) != 1:
            problems.append(f"block '{name}' has ports {sorted(block.ports)}; say which one "
                            f"('{name}.<port>')")
            return None
        port = next(iter(block.ports))
    if port not in block.ports:
        problems.append(f"block '{name}' has no port '{port}' (ports: {sorted(block.ports)})")
        return None
    return name, port, block.ports[port]


def check_connections(blocks: Iterable[Block], connections: Iterable[tuple[str, str]]) -> None:
    """Check that every joint links complementary causality kinds (thesis 2.4.5-2.4.6).

    Parameters
    ----------
    blocks : iterable of Block
    connections : iterable of (endpoint, endpoint)
        An endpoint is ``"block"`` (single-port block) or ``"block.port"``.

    Raises
    ------
    AlgebraicLoopError
        If two ports that give the same quantity are joined (inertial-inertial,
        compliant/resistive-compliant/resistive, control volume-control volume, flow-flow).  The
        message names both blocks of every such joint and suggests the fix.
    CausalityError
        For unknown blocks or ports, duplicate block names, or a joint across domains.
    """
    table: dict[str, Block] = {}
    problems: list[str] = []
    for b in blocks:
        if b.name in table or "." in b.name:
            problems.append(f"block name '{b.name}' is duplicated or contains a dot")
        table[b.name] = b
    loops: list[str] = []
    pairs: list[tuple[str, str]] = []
    for a, b in connections:
        ea, eb = _endpoint(a, table, problems), _endpoint(b, table, problems)
        if ea is None or eb is None:
            continue
        (na, pa, ka), (nb, pb, kb) = ea, eb
        if ka.domain != kb.domain:
            problems.append(f"'{na}.{pa}' ({ka.domain}) cannot be joined to '{nb}.{pb}' "
                            f"({kb.domain})")
        elif ka.gives == kb.gives:
            other = "an inertial" if ka.gives == "torque" else (
                "a compliant or resistive" if ka.gives == "speed" else (
                    "a flow" if ka.gives == "state" else "a control-volume"))
            pairs.append((na, nb))
            loops.append(f"algebraic loop between '{na}' ({ka.value}, port '{pa}') and '{nb}' "
                         f"({kb.value}, port '{pb}'): both take {ka.takes} and give {ka.gives}; "
                         f"put {other} block between them, or solve the loop inside one block "
                         "(thesis 2.4.3)")
    if problems:
        raise CausalityError("\n".join(problems))
    if loops:
        raise AlgebraicLoopError("\n".join(loops), pairs)
