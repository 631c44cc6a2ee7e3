"""``transgen powerflow FILE --losses [LOSSES.toml]``: the loss budget per gear at one operating
point, and with ``--map`` the efficiency map per gear and the neutral parasitic loss; text, JSON
(``transgen.losses/1``) and, with ``-o DIR``, the figures and the JSON file."""
from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from .budget import LOSS_UNITS, efficiency_map, loss_budget, neutral_losses
from .drag import RPM
from .lossfile import load_losses

__all__ = ["run_losses", "DEFAULT_SPEED", "DEFAULT_TORQUE", "parse_grid"]

DEFAULT_SPEED = 2000.0
"""Input speed [rpm] of the operating point without ``--speed`` (or ``--input-rpm``)."""
DEFAULT_TORQUE = 200.0
"""Input torque [N*m] of the operating point without ``--torque``."""


def parse_grid(text: str | None, default: tuple[float, float, int], option: str) -> np.ndarray:
    """``MIN:MAX:N`` -> ``N`` equally spaced values (ValueError with the option's name)."""
    lo, hi, n = default
    if text:
        parts = text.split(":")
        try:
            if len(parts) != 3:
                raise ValueError
            lo, hi, n = float(parts[0]), float(parts[1]), int(parts[2])
        except ValueError:
            raise ValueError(f"{option} must be MIN:MAX:N (e.g. 500:6000:23), not {text!r}") from None
        if not (np.isfinite(lo) and np.isfinite(hi)) or not 0 < lo < hi or not 2 <= n <= 500:
            raise ValueError(f"{option}: need 0 < MIN < MAX and 2 <= N <= 500, not {text!r}")
    return np.linspace(lo, hi, n)


def _neutrals(mech):
    declared = [(g.name, tuple(g.engaged)) for g in mech.gears if g.kind == "neutral"]
    return declared or [("all open", ())]


def _text(mech, model, losses, neutrals, speed, torque, coast) -> str:
    out = [f"{mech.name}: losses per gear in {'coast' if coast else 'drive'} at {speed:g} rpm, "
           f"{torque:g} N*m input ({abs(torque) * speed * RPM / 1000:.2f} kW); loss parameters: {model.source}, "
           f"oil {model.oil_temperature:g} degC",
           "  mesh: Müller's carrier-frame rule (transgen powerflow); drag: open elements, slip from the "
           "kinematics; spin: links; pump: from the input"]
    for g in losses:
        drag = ", ".join(f"{e} {s / RPM:+.0f} rpm {t:+.2f} N*m {p:.0f} W" for e, (s, t, p) in g.drag.items())
        out.append("")
        out.append(f"gear {g.gear} ({' '.join(g.engaged)}): efficiency {100 * g.efficiency:.2f} % "
                   f"(mesh only {100 * g.mesh_efficiency:.2f} %), output {g.output_power / 1000:.2f} kW")
        out.append(f"    losses [W]   mesh {g.mesh:.0f}  drag {g.drag_total:.0f}  spin {g.spin_total:.0f}  "
                   f"pump {g.pump:.0f}  total {g.total:.0f}")
        out.append(f"    open ({len(g.drag)})     {drag or '(none)'}")
        if g.unknown:
            out.append(f"    not fixed by the input speed (loss left out): {' '.join(g.unknown)}")
    for n in neutrals:
        k = int(np.argmin(np.abs(n.speeds_rpm - speed)))
        out.append("")
        out.append(f"neutral {n.name} ({' '.join(n.engaged) or 'nothing engaged'}, output held) at "
                   f"{n.speeds_rpm[k]:g} rpm: drag {n.drag[k]:.0f} W, spin {n.spin[k]:.0f} W, pump {n.pump[k]:.0f} W, "
                   f"total {n.total[k]:.0f} W" + (f"; unknown: {' '.join(n.unknown)}" if n.unknown else ""))
    return "\n".join(out)


def run_losses(args, mech, flow) -> int:
    """The ``--losses`` part of ``transgen powerflow`` (``args`` from its parser)."""
    from ..schemas import dumps, json_document

    from ..outputs import note_input

    if args.losses:
        note_input(args.losses)
    model = load_losses(args.losses, mech)
    speed = args.speed if args.speed is not None else (args.input_rpm or DEFAULT_SPEED)
    torque = args.torque if args.torque is not None else DEFAULT_TORQUE
    losses = loss_budget(flow, model, speed, torque)
    speeds = parse_grid(args.map_speed, (500.0, 6000.0, 23), "--map-speed")
    torques = parse_grid(args.map_torque, (torque / 20.0, 2.0 * torque, 40), "--map-torque")
    neutrals = [neutral_losses(mech, model, speeds if args.map else [speed], engaged, name)
                for name, engaged in _neutrals(mech)]
    emap = efficiency_map(flow, model, speeds, torques) if args.map else None
    doc = json_document("transgen.losses/1", {
        "mechanism": mech.name, "input": mech.input, "output": mech.output,
        "direction": "coast" if flow.coast else "drive", "loss_model": model.to_dict(),
        "operating_point": {"input_rpm": speed, "input_torque": torque},
        "gears": [g.to_dict() for g in losses], "neutral": [n.to_dict() for n in neutrals],
        "map": None if emap is None else emap.to_dict()}, LOSS_UNITS)
    stem = re.sub(r"[^A-Za-z0-9_.-]+", "_", Path(args.file).stem) or "mechanism"
    if args.output:
        _write(Path(args.output), stem, mech, losses, emap, neutrals, doc, speed, torque)
    if args.json:
        print(dumps(doc))
    else:
        print(_text(mech, model, losses, neutrals, speed, torque, flow.coast))
        if args.output:
            print(f"\nwritten to {args.output}: {stem}_losses.json, {stem}_loss_breakdown.png"
                  + (f", {stem}_efficiency_map.png, {stem}_neutral_losses.png" if emap is not None else ""))
    return 0


def _write(folder: Path, stem: str, mech, losses, emap, neutrals, doc, speed, torque) -> None:
    """The JSON and the figures into ``folder``, together or not at all (:mod:`transgen.outputs`)."""
    import matplotlib

    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt

    from ..outputs import atomic_path, output_set
    from ..schemas import dumps
    from .plots import plot_breakdown, plot_efficiency_map, plot_neutral

    if folder.exists() and not folder.is_dir():
        raise ValueError(f"-o {folder}: not a folder")
    figures = [(plot_breakdown(losses, f"{mech.name}: losses per gear at {speed:g} rpm, {torque:g} N*m"),
                "loss_breakdown")]
    if emap is not None:
        figures.append((plot_efficiency_map(emap, f"{mech.name}: efficiency with mesh, drag, spin and pump losses"),
                        "efficiency_map"))
        figures.append((plot_neutral(neutrals, f"{mech.name}: neutral parasitic loss (output held)"),
                        "neutral_losses"))
    try:
        with output_set():
            with atomic_path(folder / f"{stem}_losses.json") as tmp:
                Path(tmp).write_text(dumps(doc) + "\n", encoding="utf-8")
            for fig, name in figures:
                with atomic_path(folder / f"{stem}_{name}.png") as tmp:
                    fig.savefig(tmp, dpi=120, format="png")
    finally:
        for fig, _ in figures:
            plt.close(fig)
