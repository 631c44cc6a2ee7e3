"""The scenario text of a launch for a gearbox that models its own torque converter.

For a mechanism with its own converter (:func:`transgen.own_converter.own_converter`:
``mechanisms/ht740_tc.mech``) ``transgen scenario new`` writes the engine map on the pump link (the
mechanism's input, whose inertia is the engine's: no ``J_engine`` is added), the ``[converter]``
between pump and turbine, the lock-up open through the launch and the initial state with the
engine at idle and the vehicle at rest (first gear in converter drive). The rest of the scenario
is :func:`~transgen.sim.derive.launch.launch_scenario`'s.
"""
from __future__ import annotations

from pathlib import Path

from transgen.own_converter import OwnConverter, converter_drive

__all__ = ["initial_lines", "input_head_lines", "converter_lines"]


def initial_lines(mech, vc, first, own: OwnConverter, num) -> list[str]:
    """``[initial]``: gear ``first`` (a ForwardGear) locked without the lock-up, the output (and
    any idle member) at rest, the pump (engine) at the class's idle speed."""
    rest = ", ".join(f"{x} = 0.0" for x in (mech.output,) + first.idle)
    return ["[initial]",
            f"locked = [{', '.join(repr(e).replace(chr(39), chr(34)) for e in converter_drive(first.engaged, own))}]"
            f"   # gear {first.name} in converter drive: the lock-up {own.lockup} open",
            f"speeds = {{ {rest} }}      # vehicle at rest" + (f" (idle member {', '.join(first.idle)} too)" if first.idle else ""),
            f"speeds_rpm = {{ {own.pump} = {num(vc.idle_rpm)} }}   # the engine (pump link) at idle"]


def input_head_lines(mech, vc, own: OwnConverter, num) -> list[str]:
    """The first lines of ``[input]``: the engine map on the pump link with the idle governor."""
    return ["[input]                 # engine (torque map) on the mechanism's pump link; the converter is the .mech's",
            'type = "engine_map"',
            f"# the engine's inertia is link {own.pump}'s, J = {num(mech.link(own.pump).inertia)} kg*m^2 in the .mech "
            "(none added here)",
            f"idle_rpm = {num(vc.idle_rpm)}          # idle governor: below it the throttle rises to hold idle"]


def converter_lines(vc, own: OwnConverter) -> list[str]:
    """``[converter]`` between the pump and turbine links and the lock-up held open."""
    lines = ["", f"[converter]             # the .mech's converter: {own.pump} pump, {own.turbine} turbine "
                 "(the gearbox input)",
             f'pump = "{own.pump}"', f'turbine = "{own.turbine}"',
             f'pump_torque = "{own.pump_torque}"', f'turbine_torque = "{own.turbine_torque}"']
    if vc.converter:
        lines.append(f'file = "{Path(vc.converter).stem}"   # transgen\'s bundled {vc.name} converter, by its name')
    else:
        lines.append("# file: the bundled heavy-truck three-element converter (transgen/sim/data)")
    lines += ["", f"[elements.{own.lockup}]          # the lock-up clutch: open through the launch (no shift element)",
              "apply = 0.0"]
    return lines
