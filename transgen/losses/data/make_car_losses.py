"""Write ``car_losses.toml``: an example loss file whose drag table is the aerated-film curve of
:func:`transgen.losses.drag.aerated_film_torque` for the reference car pack (8 faces, radii
64/85 mm, film 0.15 mm, 0.5 L/min of oil per pack) at two oil temperatures. Estimates, not
measurements; run ``python -m transgen.losses.data.make_car_losses`` to regenerate."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from transgen.losses.drag import RPM, aerated_film_torque

SLIP_RPM = [0, 100, 200, 300, 400, 500, 600, 800, 1000, 1250, 1500, 2000, 2500, 3000, 4000, 5000, 6000]
OIL = [(40.0, 0.025), (90.0, 0.0075)]  # degC, ATF dynamic viscosity [Pa*s] (estimates)
PACK = dict(faces=8, density=850.0, gap=0.15e-3, inner_radius=0.064, outer_radius=0.085, flow=0.5e-3 / 60)


def rows() -> list[list[float]]:
    w = np.asarray(SLIP_RPM, dtype=float) * RPM
    return [[round(float(t), 3) for t in aerated_film_torque(w, viscosity=mu, **PACK)] for _, mu in OIL]


def text() -> str:
    table = ",\n  ".join(str(r) for r in rows())
    return f"""# Example loss file (transgen powerflow FILE --losses car_losses.toml); see docs/losses.md.
# Drag: the aerated-film curve of the reference car pack (8 faces, 64/85 mm, film 0.15 mm,
# 0.5 L/min of ATF per pack; viscosity 0.025 Pa*s at 40 degC, 0.0075 Pa*s at 90 degC): a linear
# rise, a peak and a fall. Written by make_car_losses.py; estimates, not measurements.
oil_temperature = 90.0

[drag.default]
kind = "table"
slip_rpm = {SLIP_RPM}
oil_temperature = {[t for t, _ in OIL]}
torque = [
  {table},
]

[spin.default]
coefficients = [0.0]

[pump]
displacement = 12e-6
line_pressure = 1.0e6
pressure_per_torque = 0.0
efficiency = 0.85
speed_ratio = 1.0
"""


if __name__ == "__main__":
    (Path(__file__).resolve().parent / "car_losses.toml").write_text(text(), encoding="utf-8")
