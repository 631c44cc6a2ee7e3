"""Map generator: compressor and turbine maps regenerated from published analytic fits.

No open heavy-duty map tables exist (see the project's research note), so the shipped maps
``sim/data/we_compressor.toml`` and ``sim/data/we_turbine.toml`` are *regenerated from the
published analytic fits* of Wahlström & Eriksson (:class:`WECompressorFit`,
:class:`WETurbineFit`) by ``sim/data/make_maps.py`` (which calls :func:`generate_compressor_map`
and :func:`generate_turbine_map` and writes them with
:func:`~transgen.sim.engine.map_file.save_map`).  Each file carries its provenance.
Speeds in rad/s, pressures in Pa, temperatures in K, mass flows in kg/s.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .gas import AIR, EXHAUST, RPM, Gas
from .map_file import CompressorMap, CompressorSpeedLine, MapLine, TurbineMap, TurbineSpeedLine

__all__ = [
    "WECompressorFit",
    "WETurbineFit",
    "DEFAULT_VGT_POSITION",
    "generate_compressor_map",
    "generate_turbine_map",
]

_WE_SOURCE = ("J. Wahlstrom, L. Eriksson, 'Modelling diesel engines with a variable-geometry "
              "turbocharger and exhaust gas recirculation by optimization of model parameters "
              "for capturing non-linear system dynamics', Proc. IMechE Part D 225(7):960-986, "
              "2011; parameter values of the TCDI_EGR_VGT package (parameterData.mat, LGPL-3) "
              "as listed in shared/reference/turbo_engine.md section 1.1")


def _poly2(c: tuple[float, float, float], x: float) -> float:
    return c[0] * x * x + c[1] * x + c[2]


@dataclass(frozen=True)
class WECompressorFit:
    """Wahlström & Eriksson compressor fit: ellipse flow model and quadratic efficiency.

    All numbers are the published parameters [WE-pkg].  The fit is written at the fit's ambient
    state (``p_amb``, ``T_amb``), which is therefore used as the reference state of the
    corrected quantities: at that state corrected and actual quantities coincide.
    """

    R_c: float = 0.04                                                   # m
    c_wpsi: tuple[float, float, float] = (1.08820511e-08, -1.73197604e-04, 1.02861648)
    c_wphi: tuple[float, float, float] = (-1.42977827e-08, -1.54988141e-03, 29.6461722)
    c_psi2: float = 0.0
    c_phi2: float = 0.0
    eta_max: float = 0.73636079
    W_opt: float = 0.27533757                                           # kg/s
    pi_opt: float = 1.04551775
    c_pi: float = 0.27075947
    Q: tuple[float, float, float] = (3.09189777, -2.48232014, 2.14785596)  # Q11, Q12, Q22
    p_amb: float = 101111.34                                            # Pa
    T_amb: float = 298.46                                               # K
    gas: Gas = AIR

    def _coeffs(self, omega: float) -> tuple[float, float]:
        return max(0.0, _poly2(self.c_wpsi, omega)), max(0.1, _poly2(self.c_wphi, omega))

    def head(self, omega: float, PR: float) -> float:
        """Dimensionless head Psi_c at turbo speed [rad/s] and pressure ratio [-]."""
        return (2.0 * self.gas.cp * self.T_amb * (max(PR, 1.0) ** self.gas.kappa - 1.0)
                / (self.R_c * omega) ** 2)

    def pressure_ratio(self, omega: float, psi: float) -> float:
        """Pressure ratio [-] of a head Psi_c at turbo speed [rad/s] (inverse of :meth:`head`)."""
        return (1.0 + psi * (self.R_c * omega) ** 2 / (2.0 * self.gas.cp * self.T_amb)) \
            ** (1.0 / self.gas.kappa)

    def zero_flow_head(self, omega: float) -> float:
        """Head where the ellipse gives zero flow, ``c_psi2 + 1/sqrt(c_psi1)``."""
        return self.c_psi2 + 1.0 / math.sqrt(self._coeffs(omega)[0])

    def mass_flow(self, omega: float, PR: float) -> float:
        """Mass flow [kg/s] at the fit's ambient state (the ellipse model)."""
        c_psi1, c_phi1 = self._coeffs(omega)
        psi = self.head(omega, PR)
        phi = max(0.0, self.c_phi2 + math.sqrt(max(0.0, 1.0 - c_psi1 * (psi - self.c_psi2) ** 2)
                                               / c_phi1))
        return self.p_amb * math.pi * self.R_c ** 3 * omega * phi / (self.gas.R * self.T_amb)

    def efficiency(self, mass_flow: float, PR: float) -> float:
        """Isentropic efficiency [-]: ``max(0.2, eta_max - d'Q d)``."""
        d1 = mass_flow - self.W_opt
        d2 = (max(PR, 1.0) - 1.0) ** self.c_pi - self.pi_opt
        q11, q12, q22 = self.Q
        return max(0.2, self.eta_max - (q11 * d1 * d1 + 2.0 * q12 * d1 * d2 + q22 * d2 * d2))


@dataclass(frozen=True)
class WETurbineFit:
    """Wahlström & Eriksson turbine fit (VGT frozen at ``vgt_position``): restriction-type flow
    ``W_t = A_vgtmax*f_vgt*p*sqrt(1 - ER^-K_t)/sqrt(T*R_e)`` and the BSR-parabola efficiency
    ``eta_tm`` (which lumps the mechanical losses of the shaft).  Published parameters [WE-pkg];
    ``vgt_position`` [%] is the fixed-geometry choice of this project.
    """

    R_t: float = 0.04                                                   # m
    A_vgtmax: float = 8.4558e-4                                         # m^2
    K_t: float = 2.89019266
    c_f1: float = 1.9479627
    c_f2: float = -0.77631189
    c_vgt1: float = 126.87193572
    c_vgt2: float = 117.14474688
    eta_max: float = 0.81800273
    BSR_opt: float = 0.97552032
    c_m: tuple[float, float, float] = (1.35634407, 2769.2092, 0.0100000987)
    w_tlin: float = 2796.90                                             # rad/s
    c_mlin: float = 1.40214708
    vgt_position: float = 100.0                                         # %
    gas: Gas = EXHAUST

    @property
    def f_vgt(self) -> float:
        """Effective-area factor of the frozen vane position [-]."""
        u = min(max(self.vgt_position, 20.0), 100.0)
        return max(0.0, self.c_f2 + self.c_f1 * math.sqrt(
            max(0.0, 1.0 - ((u - self.c_vgt2) / self.c_vgt1) ** 2)))

    def mass_flow(self, p_in: float, T_in: float, ER: float) -> float:
        """Mass flow [kg/s] at inlet pressure [Pa], inlet temperature [K], expansion ratio."""
        pi_t = min(1.0 / ER, 1.0)
        return (self.A_vgtmax * self.f_vgt * p_in * math.sqrt(1.0 - pi_t ** self.K_t)
                / math.sqrt(T_in * self.gas.R))

    def efficiency(self, omega: float, T_in: float, ER: float) -> float:
        """Turbine-mechanical efficiency eta_tm [-] at turbo speed [rad/s], inlet temperature
        [K] and expansion ratio [-] (BSR clamped to [0, 2*BSR_opt], eta to [0.2, 1])."""
        c1, c2, c3 = self.c_m
        if omega > self.w_tlin:
            c_m = c1 * (omega - c2) ** c3
        else:
            c_m = self.c_mlin * max(0.0, omega - c2) / (self.w_tlin - c2)
        dh = 2.0 * self.gas.cp * T_in * (1.0 - min(1.0 / ER, 1.0) ** self.gas.kappa)
        bsr = 2.0 * self.BSR_opt if dh <= 0.0 else min(self.R_t * omega / math.sqrt(dh),
                                                        2.0 * self.BSR_opt)
        return min(max(self.eta_max - c_m * (bsr - self.BSR_opt) ** 2, 0.2), 1.0)


DEFAULT_VGT_POSITION = 55.0
"""Frozen vane position [%] of the shipped fixed-geometry turbine map (chosen so that the engine
of :class:`~transgen.sim.engine.diesel.TurbochargedDiesel` reaches a boost pressure ratio of about 2.7 at 2100 rpm)."""


def generate_compressor_map(fit: WECompressorFit = WECompressorFit(),
                            speeds_rpm=tuple(range(10_000, 140_001, 10_000)),
                            n_points: int = 13,
                            surge_flow_fraction: float = 0.25) -> CompressorMap:
    """Regenerate a compressor map in manufacturer format from the W&E fit.

    On each speed line the points are equally spaced in pressure ratio from the stall line to the
    surge line.  Definitions (documented choices, not part of the fit):

    * stall/choke line: PR = 1, where the ellipse gives its largest flow;
    * surge line: the flow is ``surge_flow_fraction`` of that largest flow.  The W&E ellipse has
      no rising part left of its peak, so a constant-margin rule is used.

    Speeds are corrected speeds at the fit's ambient state, which is also the map's reference.
    """
    lines, surge, stall = [], [], []
    for n in speeds_rpm:
        w = n * RPM
        psi_s = fit.zero_flow_head(w) * math.sqrt(1.0 - surge_flow_fraction ** 2)
        pr = np.linspace(1.0, fit.pressure_ratio(w, psi_s), n_points)
        m = [fit.mass_flow(w, p) for p in pr]
        lines.append(CompressorSpeedLine(w, tuple(m), tuple(float(p) for p in pr),
                                         tuple(fit.efficiency(mi, p) for mi, p in zip(m, pr))))
        surge.append((w, m[-1], float(pr[-1])))
        stall.append((w, m[0], 1.0))
    prov = (("source", _WE_SOURCE),
            ("generator", "transgen.sim.engine.generate_compressor_map (sim/data/make_maps.py)"),
            ("definitions", f"stall line PR = 1 (largest flow of the ellipse); surge line at "
                            f"{surge_flow_fraction} of that flow (constant-margin rule); "
                            "reference state = the fit's ambient state"),
            ("validity", "the fit was identified in the engine's operating range; lines above "
                         "about 110 krpm are extrapolation of the fit (efficiency at its 0.2 "
                         "floor over much of the line)"),
            ("licence", "numbers computed from published model parameters; no proprietary data"))
    return CompressorMap("W&E 12.7 L heavy-duty compressor (regenerated fit)", tuple(lines),
                         MapLine(*map(tuple, zip(*surge))), MapLine(*map(tuple, zip(*stall))),
                         fit.T_amb, fit.p_amb, prov)


_TURBINE_ER = (1.0, 1.005, 1.01, 1.02, 1.04, 1.07, 1.1, 1.15, 1.2, 1.3, 1.4, 1.5, 1.65, 1.8, 2.0,
               2.25, 2.5, 2.75, 3.0, 3.5, 4.0, 4.5, 5.0, 6.0)


def generate_turbine_map(fit: WETurbineFit = WETurbineFit(vgt_position=DEFAULT_VGT_POSITION),
                         speeds_rpm=tuple(range(10_000, 140_001, 10_000)),
                         expansion_ratio=_TURBINE_ER, T_ref: float = 873.15,
                         p_ref: float = 101325.0) -> TurbineMap:
    """Regenerate a fixed-geometry turbine map in manufacturer format from the W&E fit.

    The fit's efficiency depends on the blade-speed ratio, a function of ``omega/sqrt(T)`` and
    the expansion ratio, hence of (corrected speed, ER).  Its speed-dependent coefficient
    ``c_m(omega)`` is evaluated at ``omega = N_corr`` (i.e. at the reference temperature).
    The point ER = 1 (zero flow) is included so that the table linearises the flow function
    near ER = 1, where its slope is infinite.
    """
    lines = []
    for n in speeds_rpm:
        w = n * RPM
        m = tuple(fit.mass_flow(p_ref, T_ref, er) for er in expansion_ratio)
        e = tuple(fit.efficiency(w, T_ref, er) for er in expansion_ratio)
        lines.append(TurbineSpeedLine(w, tuple(map(float, expansion_ratio)), m, e))
    prov = (("source", _WE_SOURCE),
            ("generator", "transgen.sim.engine.generate_turbine_map (sim/data/make_maps.py)"),
            ("definitions", f"VGT frozen at {fit.vgt_position:g} % (f_vgt = {fit.f_vgt:.5f}): "
                            "treated as a fixed-geometry turbine; efficiency is W&E's eta_tm, "
                            "which includes the mechanical (bearing) losses; c_m(omega) taken "
                            "at omega = N_corr"),
            ("licence", "numbers computed from published model parameters; no proprietary data"))
    return TurbineMap("W&E 12.7 L heavy-duty turbine, fixed geometry (regenerated fit)",
                      tuple(lines), T_ref, p_ref, prov)
