"""The torque converter as a component of the mode-switching simulator (thesis chapter 4.6), and
the scenario keys that make it.

:class:`ConverterComponent` - the hydrodynamic converter as a resistive block between two links
of the mechanism (pump and turbine; interface of :mod:`transgen.sim.model.components`): it drives
the mechanism's named external torques (``torque Tp E`` and ``torque Tt L1``) with ``-T_pump`` and
``+T_turbine``. The lock-up clutch is a clutch of the mechanism (``clutch LU E L1``), locked and
unlocked by the transmission's complementarity logic like every shift element; locked, the
converter runs at speed ratio 1 and carries no torque. :func:`converter_component` reads the
``[converter]`` table.

The turbodiesel that drives such a powertrain is :mod:`.turbodiesel`. The causality check of an assembly is :mod:`transgen.sim.model.assembly`;
the engine and converter models themselves are the package :mod:`transgen.sim.engine`.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..core.causality import Block
from .components import Component, converter_loss, elementwise, own_kernel_form
from ..engine.torque_converter import DEFAULT_TORQUE_CONVERTER, TorqueConverter, TorqueConverterError

__all__ = ["ConverterComponent", "converter_component", "read_converter"]

CONVERTER_SIGNAL_UNITS = {"converter_speed_ratio": "1", "converter_torque_ratio": "1", "T_pump": "N*m",
                          "T_turbine": "N*m", "P_converter": "W"}
"""Units of the signals of :class:`ConverterComponent`."""


@dataclass
class ConverterComponent(Component):
    """A torque converter between two links: pump (impeller) on ``pump``, turbine on ``turbine``.

    ``converter.torques(w_pump, w_turbine)`` gives (pump torque absorbed, turbine torque
    delivered); this component applies ``-T_pump`` to the mechanism's external torque named
    ``pump_torque`` and ``+T_turbine`` to ``turbine_torque``. It dissipates
    ``T_pump*w_pump - T_turbine*w_turbine >= 0`` (the converter's efficiency ``SR*TR <= 1``).
    With the lock-up clutch between the same links locked the speed ratio is 1 and both torques
    are zero.
    """

    converter: TorqueConverter
    pump: int
    turbine: int
    pump_torque: str = "Tp"
    turbine_torque: str = "Tt"
    name: str = "converter"
    signal_units = CONVERTER_SIGNAL_UNITS
    causal_keys = ("converter",)  # the scenario keys of its causality errors (.assembly)

    def _torques(self, w):
        return self.converter.torques(float(w[self.pump]), float(w[self.turbine]))

    def torques(self, t, x, w):
        tp, tt = self._torques(w)
        return {self.pump_torque: -tp, self.turbine_torque: tt}

    def dissipation(self, t, x, w):
        return self.evaluate(t, x, w)[3]

    def evaluate(self, t, x, w):
        wp, wt = float(w[self.pump]), float(w[self.turbine])
        tp, tt = self.converter.torques(wp, wt)
        return {self.pump_torque: -tp, self.turbine_torque: tt}, [], 0.0, converter_loss(tp, tt, wp, wt), 0.0

    def kernel_form(self):
        if not own_kernel_form(self.converter, "kernel_numbers"):
            return None
        sizes, numbers = self.converter.kernel_numbers()
        return "converter", (self.pump, self.turbine, *sizes), numbers, (), (self.pump_torque, self.turbine_torque)

    def sample(self, ts, X, W):
        """The signals at the output times: the converter's torques once per time."""
        wp, wt = W[self.pump], W[self.turbine]
        if own_kernel_form(self.converter, "kernel_numbers"):  # its own tables: the loop of its formula
            tp, tt = self.converter.torques_over(wp, wt)
        else:
            tp, tt = (a.astype(float) for a in elementwise(self.converter.torques, 2)(wp, wt))
        signals = {"converter_speed_ratio": np.divide(wt, wp, out=np.zeros(len(ts)), where=np.abs(wp) > 1e-9),
                   "converter_torque_ratio": np.divide(tt, tp, out=np.ones(len(ts)), where=np.abs(tp) > 1e-9),
                   "T_pump": tp, "T_turbine": tt, "P_converter": tp * wp - tt * wt}
        return {self.pump_torque: -tp, self.turbine_torque: tt}, signals, np.zeros(len(ts))

    def signals(self, t, x, w):
        wp, wt = float(w[self.pump]), float(w[self.turbine])
        tp, tt = self._torques(w)
        return {"converter_speed_ratio": wt / wp if abs(wp) > 1e-9 else 0.0,
                "converter_torque_ratio": tt / tp if abs(tp) > 1e-9 else 1.0,
                "T_pump": tp, "T_turbine": tt, "P_converter": tp * wp - tt * wt}

    def causal_structure(self, link_block) -> tuple[list[Block], list[tuple[str, str]]]:
        """A resistive block between the pump and turbine links."""
        return ([Block(self.name, TorqueConverter.causality)],
                [(f"{self.name}.pump", link_block(self.pump)),
                 (f"{self.name}.turbine", link_block(self.turbine))])


def read_converter(r, table: dict, keys: tuple, name: str) -> TorqueConverter:
    """The torque converter of the file named by ``table[name]`` (relative to the file that names
    it, or a bundled converter by its name, ``torque_converter_car``; default the bundled
    heavy-truck converter), read through the scenario's file access."""
    ref = r.text(table, keys, name, "") or None
    path = r.data_path(keys + (name,), ref) if ref else DEFAULT_TORQUE_CONVERTER
    try:
        return TorqueConverter.parse(r.read_text(keys + (name,), path, "torque converter"), str(path))
    except (TorqueConverterError, ValueError) as exc:
        raise r.error(keys + (name,), f"cannot load the torque converter: {exc}") from None


def converter_component(r, conv: dict, keys: tuple, mech, tr) -> ConverterComponent:
    """The ``[converter]`` table of a scenario: ``pump``/``turbine`` links, ``pump_torque``/
    ``turbine_torque`` (``torque NAME LINK`` statements of the mechanism on those links),
    optional ``file`` (converter table, relative to the scenario; default the bundled one)."""
    names = {}
    for key, default in (("pump", "E"), ("turbine", "L1")):
        link = r.text(conv, keys, key, default)
        if link not in tr.link_index:
            raise r.error(keys + (key,), f"{key} link {link!r} is not a link of the mechanism "
                                         f"(links: {', '.join(tr.links)})")
        names[key] = link
    declared = {t.name: t.link for t in mech.loads}
    for key, default, link in (("pump_torque", "Tp", names["pump"]), ("turbine_torque", "Tt", names["turbine"])):
        tname = r.text(conv, keys, key, default)
        if tname not in declared:
            raise r.error(keys + (key,), f"{key} {tname!r} is not a 'torque NAME LINK' of the mechanism "
                                         f"(declared: {', '.join(declared) or 'none'}); add 'torque {tname} {link}'")
        if declared[tname] != link:
            raise r.error(keys + (key,), f"{key} {tname!r} acts on link {declared[tname]}, not on the "
                                         f"{key.split('_')[0]} link {link}")
        names[key] = tname
    if names["pump"] == names["turbine"]:
        raise r.error(keys + ("turbine",), "the pump and the turbine must be different links")
    converter = read_converter(r, conv, keys, "file")
    return ConverterComponent(converter, tr.link_index[names["pump"]], tr.link_index[names["turbine"]],
                              names["pump_torque"], names["turbine_torque"])

