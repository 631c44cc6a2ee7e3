"""Causality of a powertrain's assembly, checked before a run (thesis 2.4).

:func:`causal_assembly` lists the blocks of a :class:`~transgen.sim.solve.simulate.Powertrain` (engine
air path: control volumes and flow blocks; engine torque: an effort source on the input link;
converter: resistive between two links; links of the mechanism: inertial; slipping shift
elements: resistive; driveshaft: compliant; vehicle: inertial) and how they are joined;
:func:`check_powertrain` runs :func:`~transgen.sim.core.causality.check_connections` on it and
:func:`check_scenario_causality` turns a refusal into a located scenario error. The rigid
connections between links (gearsets, locked elements) are the algebraic loops the mode-switching
method solves inside the transmission block (thesis 2.4.3), so they are not joints here.
"""
from __future__ import annotations

from dataclasses import dataclass, field

from ..core.causality import AlgebraicLoopError, Block, Causality, CausalityError, check_connections
from .components import Driveline, EngineOnLink, EngineWithConverter, InputTorque, LinkLoad
from ..engine.torque_converter import TorqueConverter

__all__ = ["Assembly", "causal_assembly", "check_powertrain", "check_scenario_causality"]

_I, _K, _R = Causality.INERTIAL, Causality.COMPLIANT, Causality.RESISTIVE



@dataclass
class Assembly:
    """Blocks and joints of a powertrain for :func:`~transgen.sim.core.causality.check_connections`;
    ``origin`` maps a block name to the scenario keys that put it there (for located errors)."""

    blocks: list[Block] = field(default_factory=list)
    joints: list[tuple[str, str]] = field(default_factory=list)
    origin: dict[str, tuple[str, ...]] = field(default_factory=dict)

    def add(self, blocks, joints, origin: tuple[str, ...]):
        for b in blocks:
            self.blocks.append(b)
            self.origin[b.name] = origin
        self.joints.extend(joints)


def _link_block_name(name: str) -> str:
    return f"link {name}"


def causal_assembly(pt) -> Assembly:
    """The blocks of a :class:`~transgen.sim.solve.simulate.Powertrain` and their joints.

    Mechanism links are inertial blocks (``link NAME``); each shift element is a resistive block
    on its link(s) (its causality while slipping; locked, it is a rigid connection whose loop the
    mode solution hides, thesis 2.4.3, as are the gearsets). Components: a turbodiesel's air path
    and torque (:meth:`~transgen.sim.model.turbodiesel.TurbodieselSource.causal_structure`), the converter (resistive between
    two links), an input torque or engine map (an effort source, resistive), an engine with its
    own inertia behind a converter (inertial crank, resistive converter), loads (resistive), the
    driveline (compliant driveshaft and inertial vehicle). A component with a
    ``causal_structure(link_block)`` method gives its own blocks and joints, and with
    ``causal_keys`` the scenario keys an error about them names (else its name).
    """
    tr = pt.transmission
    asm = Assembly()

    def link_block(i: int) -> str:
        return _link_block_name(tr.links[i])

    asm.add([Block(link_block(i), {"shaft": _I}) for i in range(len(tr.links))], [], ("mechanism",))
    for e in tr.elements:
        name = f"element {e.name}"
        if e.link2 is None:
            asm.add([Block(name, {"link1": _R})], [(f"{name}.link1", link_block(e.link1))], ("elements", e.name))
        else:
            asm.add([Block(name, {"link1": _R, "link2": _R})],
                    [(f"{name}.link1", link_block(e.link1)), (f"{name}.link2", link_block(e.link2))],
                    ("elements", e.name))
    for c in pt.components:
        if hasattr(c, "causal_structure") and callable(c.causal_structure):
            blocks, joints = c.causal_structure(link_block)
            origin = getattr(c, "causal_keys", None) or (getattr(c, "name", "") or type(c).__name__,)
            asm.add(blocks, joints, tuple(origin))
        elif isinstance(c, Driveline):
            asm.add([Block("driveshaft", {"a": _K, "b": _K}), Block("vehicle", {"shaft": _I})],
                    [("driveshaft.a", link_block(c.output)), ("driveshaft.b", "vehicle")], ("driveline",))
        elif isinstance(c, EngineWithConverter):
            asm.add([Block("engine", {"crank": _I}), Block("converter", TorqueConverter.causality)],
                    [("engine.crank", "converter.pump"), ("converter.turbine", link_block(c.link))], ("input",))
        elif isinstance(c, (InputTorque, EngineOnLink)):
            name = "engine" if isinstance(c, EngineOnLink) else "input torque"
            asm.add([Block(name, {"crank": _R})], [(f"{name}.crank", link_block(c.link))], ("input",))
        elif isinstance(c, LinkLoad):
            name = f"load {c.input_name}"
            keys = ("driveline",) if c.input_name == "T_out" else ("load",)
            asm.add([Block(name, {"shaft": _R})], [(f"{name}.shaft", link_block(c.link))], keys)
        # any other component: unknown causality, not checked
    return asm


def check_powertrain(pt) -> Assembly:
    """Check the causality of a powertrain's assembly before running it (thesis 2.4).

    Returns the :class:`Assembly`; raises :class:`~transgen.sim.core.causality.AlgebraicLoopError`
    naming both blocks of every joint of two blocks of the same kind (e.g. an inertial engine
    model on the inertial input link) or :class:`~transgen.sim.core.causality.CausalityError`.
    """
    asm = causal_assembly(pt)
    check_connections(asm.blocks, asm.joints)
    return asm


def check_scenario_causality(r, pt) -> Assembly:
    """:func:`check_powertrain` for a scenario being read: a refused assembly is a located
    :class:`~transgen.errors.ScenarioError` at the scenario key that put the offending block there."""
    asm = causal_assembly(pt)
    try:
        check_connections(asm.blocks, asm.joints)
    except AlgebraicLoopError as exc:
        a, b = exc.pairs[0]
        keys = next((asm.origin[n] for n in (a, b) if asm.origin.get(n, ("mechanism",)) != ("mechanism",)),
                    ("mechanism",))
        hint = ""
        if keys == ("input", "crank_model"):
            hint = ("\n  the input link already carries the crank, flywheel and impeller inertia: use "
                    "crank_model = \"torque\" (the engine then gives a torque to the link)")
        raise r.error(keys, f"invalid model assembly (thesis 2.4), refused before the run: {exc}{hint}") from None
    except CausalityError as exc:
        raise r.error(("mechanism",), f"invalid model assembly: {exc}") from None
    return asm
