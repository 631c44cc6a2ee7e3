"""Causality kinds and the algebraic-loop check (thesis 2.4.2-2.4.6)."""
import pytest

from transgen.sim.core.causality import AlgebraicLoopError, Block, Causality, CausalityError, \
    check_connections
from transgen.sim.engine import TurbochargedDiesel, default_compressor_table
from transgen.sim.engine.compressor import Compressor
from transgen.sim.engine.torque_converter import TorqueConverter
from transgen.sim.engine.turbocharger import BasicTurbo, IterativeTurbo, TurboShaft

I, R, K, CV, F = (Causality.INERTIAL, Causality.RESISTIVE, Causality.COMPLIANT,
                  Causality.CONTROL_VOLUME, Causality.FLOW)


def test_alternating_structure_passes():
    blocks = [Block("engine_crank", {"s": I}), Block("damper", {"a": R, "b": R}),
              Block("flywheel", {"s": I}), Block("shaft", {"a": K, "b": K}),
              Block("wheel", {"s": I})]
    check_connections(blocks, [("engine_crank", "damper.a"), ("damper.b", "flywheel"),
                               ("flywheel", "shaft.a"), ("shaft.b", "wheel")])


@pytest.mark.parametrize("ka, kb", [(I, I), (R, R), (K, R), (CV, CV), (F, F)])
def test_same_kind_joined_directly_is_an_algebraic_loop(ka, kb):
    blocks = [Block("first_block", {"p": ka}), Block("second_block", {"p": kb})]
    with pytest.raises(AlgebraicLoopError) as err:
        check_connections(blocks, [("first_block", "second_block")])
    msg = str(err.value)
    assert "'first_block'" in msg and "'second_block'" in msg and "thesis 2.4.3" in msg
    assert err.value.pairs == [("first_block", "second_block")]


def test_all_loops_reported_and_other_errors():
    blocks = [Block("im", {"a": CV, "b": CV}), Block("em", {"a": CV}), Block("c", {"o": F}),
              Block("t", {"o": F}), Block("j", {"s": I})]
    with pytest.raises(AlgebraicLoopError) as err:
        check_connections(blocks, [("im.b", "em"), ("c", "t"), ("c", "im.a")])
    assert err.value.pairs == [("im", "em"), ("c", "t")]
    with pytest.raises(CausalityError, match="cannot be joined"):
        check_connections(blocks, [("j", "c")])
    with pytest.raises(CausalityError, match="unknown block 'nope'"):
        check_connections(blocks, [("nope", "c")])
    with pytest.raises(CausalityError, match="say which one"):
        check_connections(blocks, [("im", "c")])


def test_components_declare_their_causality():
    assert Compressor(default_compressor_table()).causality["shaft"] is R
    assert Compressor.causality["inlet"] is F
    assert TurboShaft.causality["shaft"] is I
    assert BasicTurbo.causality == IterativeTurbo.causality
    assert TurbochargedDiesel.causality["crank"] is R
    assert TorqueConverter.causality["turbine"] is R
    assert (I.domain, I.takes, I.gives) == ("mechanical", "torque", "speed")
    assert (CV.takes, CV.gives) == ("flow", "state")


def test_two_manifolds_joined_without_a_restriction():
    blocks, joints = TurbochargedDiesel().causal_structure()
    joints = [j for j in joints if j != ("exhaust_manifold.port_b", "turbine.inlet")]
    joints.append(("exhaust_manifold.port_b", "ambient_out"))
    with pytest.raises(AlgebraicLoopError, match="'exhaust_manifold'.*'ambient_out'"):
        check_connections(blocks, joints)
