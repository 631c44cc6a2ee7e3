"""The ``[losses]`` table of a scenario: drag, spin, pump and mesh losses in the simulation
(:mod:`transgen.sim.model.losses`, :mod:`transgen.sim.model.mesh`).

Keys (all optional; an empty ``[losses]`` turns every kind on with the documented defaults of
:mod:`transgen.losses.lossfile`)::

    [losses]
    file = "my.losses.toml"          # a loss file (the format of `transgen powerflow --losses`),
                                     # relative to the scenario; default: the defaults
    kinds = ["drag", "spin", "pump", "mesh"]   # the kinds on (default all four; [] none)
    eta0 = 0.98                      # mesh: planetary sets without eta0= in the .mech (power flow's default)
    eta_pair = 0.99                  # mesh: gear pairs without eta= (default eta0, else the power flow's)
    pump_link = "E"                  # the link that drives the pump (default the input link)
    oil_temperature = 90.0           # or, instead of file, the loss file's keys here:
    [losses.drag.elements.C1]        # oil_temperature, [losses.drag...], [losses.spin...],
    c = 0.05                         # [losses.pump]

Without ``[losses]`` the simulation has no such losses (and is what it was before them).
"""
from __future__ import annotations

from dataclasses import dataclass

from transgen.losses import LossFileError, LossModel, parse_losses
from transgen.losses.lossfile import LOSS_KEYS, LossDataError, loss_model

from ..model.losses import LOSS_KINDS, loss_links, with_loss_torques
from . import schema as S

__all__ = ["LossSettings", "read_losses"]


@dataclass(frozen=True)
class LossSettings:
    """What ``[losses]`` asks for: the loss model, the kinds on, the pump's link."""

    model: LossModel
    kinds: tuple[str, ...]
    pump_link: str
    eta0: float | None = None
    eta_pair: float | None = None

    def mechanism(self, mech):
        """``mech`` with the link torques the spin and pump losses act through."""
        return with_loss_torques(mech, loss_links(mech, self.model, self.kinds, self.pump_link))


def read_losses(r, data: dict, mech, model_name: str = "switching") -> LossSettings | None:
    """The :class:`LossSettings` of the scenario's ``[losses]`` (None when it has none); errors
    located at the key (a bad loss file's own location is in the message)."""
    if "losses" not in data:
        return None
    keys = ("losses",)
    table = r.table(data, keys, S.LOSSES_KEYS)
    model = LossModel()
    inline = {k: v for k, v in table.items() if k in LOSS_KEYS}
    if inline and "file" in table:
        raise r.error(keys + (next(iter(inline)),), "give the loss parameters in the loss file or in [losses], not both")
    if inline:
        try:
            model = loss_model(inline, str(r.source.locate(keys)[0].path), mech)
        except LossDataError as exc:
            raise r.error(keys + exc.path, exc.message) from None
    if "file" in table:
        path = r.file_path(keys + ("file",), r.text(table, keys, "file"))
        text = r.read_text(keys + ("file",), path, "loss file")
        try:
            model = parse_losses(text, str(path), mech)
        except LossFileError as exc:
            raise r.error(keys + ("file",), f"bad loss file: {exc}") from None
    kinds = tuple(r.names(table, keys, "kinds")) if "kinds" in table else LOSS_KINDS
    for k, kind in enumerate(kinds):
        if kind not in LOSS_KINDS:
            raise r.error(keys + ("kinds", k), f"unknown loss kind {kind!r} (kinds: {', '.join(LOSS_KINDS)})")
    if len(set(kinds)) != len(kinds):
        raise r.error(keys + ("kinds",), "a loss kind is named twice")
    pump_link = r.text(table, keys, "pump_link", mech.input)
    if pump_link not in mech.link_names:
        raise r.error(keys + ("pump_link",), f"pump_link {pump_link!r} is not a link of the mechanism "
                                             f"(links: {', '.join(mech.link_names)})")
    if "pump" in kinds and model.pump.pressure_per_torque != 0.0:
        raise r.error(keys + ("file",), "the simulation's pump works at the constant line pressure: "
                                        "pressure_per_torque must be 0 in the loss file")
    eta = {}
    for key in ("eta0", "eta_pair"):
        if key in table:
            eta[key] = r.number(table, keys, key, positive=True)
            if eta[key] > 1.0:
                raise r.error(keys + (key,), f"'{key}' must be in (0, 1], not {eta[key]:g}")
    if "mesh" in kinds:
        if model_name != "switching":
            raise r.error(keys + ("kinds",), "mesh losses are simulated with the mode-switching model only "
                                             "([simulation] model = \"switching\")")
        if mech.stepped:
            raise r.error(keys + ("kinds",), "mesh losses in the simulation do not model stepped-pinion sets "
                                             f"({', '.join(s.name for s in mech.stepped)})")
    if not kinds:
        return None  # every kind off: the run without losses
    return LossSettings(model, kinds, pump_link, eta.get("eta0"), eta.get("eta_pair"))
