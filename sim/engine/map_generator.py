"""Map generator: compressor and turbine maps regenerated from published analytic fits.

No open heavy-duty map tables exist (see the project's research note), so the shipped maps
``sim/data/we_compressor.toml`` and ``sim/data/we_turbine.toml`` are *regenerated from
published analytic fits*: the compressor from the LiU-D-El fit of Sivertsson & Eriksson with its
published surge line (:class:`LiUCompressorFit`, scaled to the 12.7 L engine; the file keeps its
old name), the turbine from Wahlström & Eriksson (:class:`WETurbineFit`); the earlier W&E
compressor map is :func:`generate_we_compressor_map` (:class:`WECompressorFit`).  They are made by ``sim/data/make_maps.py`` (which calls :func:`generate_compressor_map`
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
    "LiUCompressorFit",
    "WECompressorFit",
    "WETurbineFit",
    "DEFAULT_VGT_POSITION",
    "generate_compressor_map",
    "generate_we_compressor_map",
    "DEFAULT_FLOW_SCALE",
    "CHOKE_EFFICIENCY",
    "DEFAULT_SPEED_SCALE",
    "generate_turbine_map",
]

_WE_SOURCE = ("J. Wahlstrom, L. Eriksson, 'Modelling diesel engines with a variable-geometry "
              "turbocharger and exhaust gas recirculation by optimization of model parameters "
              "for capturing non-linear system dynamics', Proc. IMechE Part D 225(7):960-986, "
              "2011; parameter values of the TCDI_EGR_VGT package (parameterData.mat, LGPL-3) "
              "as listed in shared/reference/turbo_engine.md section 1.1")


_LIU_SOURCE = ("M. Sivertsson, L. Eriksson, 'Modeling for optimal control: a validated "
               "diesel-electric powertrain model', SIMS 2014 (LiU-D-El); compressor ellipse, "
               "efficiency and surge-line parameters of gensetParameters.m as copied in "
               "yoptimization/yop (LGPL-3), listed in shared/reference/turbo_engine.md section 1.2; "
               "branch left of surge: the cubic characteristic of F. K. Moore, E. M. Greitzer, 'A "
               "theory of post-stall transients in axial compression systems', J. Eng. Gas "
               "Turbines Power 108:68-76, 1986")


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
class LiUCompressorFit:
    """LiU-D-El compressor fit (Sivertsson & Eriksson 2014) with its published surge line.

    Flow: the ellipse ``m_corr = m_max(w_n)*sqrt(1 - (PR/PR_max(w))^2)`` with
    ``PR_max = ((w*R_c)^2*Psi_max/(2*cp*T_ref) + 1)^(1/kappa)`` and ``m_max`` a quadratic in
    ``w_n = w/15000``; efficiency ``eta_max - (Q1*dPhi^2 + 2*Q3*dPhi*dN + Q2*dN^2)``; surge line
    ``PR = c_s1*m_corr + c_s2``.  Published parameters [LiU-D-El].  ``flow_scale`` = f sizes
    the compressor for a larger engine by geometric similarity: the wheel diameter grows by
    sqrt(f), so at equal tip speed (equal PR and efficiency) the flow is f times and the speed
    1/sqrt(f) times the published wheel's (``speed_scale``, default that 1/sqrt(f), may be set
    to match a given turbine); the surge line follows, ``PR = c_s1*m/f + c_s2``.
    Corrected quantities refer to the fit's ``T_ref``, ``p_ref``.  Speeds in rad/s, flows in kg/s.
    """

    R_c: float = 0.0328                                                 # m
    Psi_max: float = 1.6380
    c_m: tuple[float, float, float] = (0.0419, 0.3416, 0.1918)          # kg/s, of w_n
    eta_max: float = 0.7915
    Q: tuple[float, float, float] = (79.2671, 0.7985, -1.4358)          # Q1, Q2, Q3
    Phi_opt: float = 0.0598
    w_opt: float = 0.5106
    c_surge: tuple[float, float] = (12.3530, 0.6861)                    # PR = c1*m + c2
    T_ref: float = 295.53                                               # K
    p_ref: float = 99510.0                                              # Pa
    flow_scale: float = 1.0
    speed_scale: float | None = None
    gas: Gas = AIR

    def _fit_speed(self, omega: float) -> float:
        """Speed [rad/s] of the published wheel at the tip speed of this (scaled) one."""
        return omega / self._speed_scale

    @property
    def _speed_scale(self) -> float:
        return self.speed_scale if self.speed_scale is not None else 1.0 / math.sqrt(self.flow_scale)

    def max_pressure_ratio(self, omega: float) -> float:
        """Zero-flow pressure ratio of the ellipse [-] at corrected speed [rad/s]."""
        omega = self._fit_speed(omega)
        return ((omega * self.R_c) ** 2 * self.Psi_max / (2.0 * self.gas.cp * self.T_ref) + 1.0) \
            ** (1.0 / self.gas.kappa)

    def mass_flow(self, omega: float, PR: float) -> float:
        """Corrected mass flow [kg/s] of the ellipse at corrected speed [rad/s] and PR [-]."""
        m_max = _poly2(self.c_m, self._fit_speed(omega) / 15000.0) * self.flow_scale
        return m_max * math.sqrt(max(0.0, 1.0 - (PR / self.max_pressure_ratio(omega)) ** 2))

    def efficiency(self, omega: float, mass_flow: float) -> float:
        """Isentropic efficiency [-] at corrected speed [rad/s] and corrected flow [kg/s]."""
        omega = self._fit_speed(omega)
        phi = (mass_flow / self.flow_scale) * self.gas.R * self.T_ref / (
            omega * 8.0 * self.R_c ** 3 * self.p_ref)
        d_phi, d_n = phi - self.Phi_opt, omega / 15000.0 - self.w_opt
        q1, q2, q3 = self.Q
        return self.eta_max - (q1 * d_phi ** 2 + 2.0 * q3 * d_phi * d_n + q2 * d_n ** 2)

    def surge_point(self, omega: float) -> tuple[float, float]:
        """(corrected flow [kg/s], PR [-]) where the speed line meets the surge line (bisection
        on ``PR - c_s1*m(PR)/flow_scale - c_s2``, which rises from PR = 1 to PR_max)."""
        c1, c2 = self.c_surge

        def f(pr: float) -> float:
            return pr - (c1 * self.mass_flow(omega, pr) / self.flow_scale + c2)

        lo, hi = 1.0, self.max_pressure_ratio(omega)
        if f(lo) >= 0.0:
            raise ValueError(f"speed {omega / RPM:.0f} rpm: the surge line lies below PR = 1")
        for _ in range(200):
            mid = 0.5 * (lo + hi)
            lo, hi = (mid, hi) if f(mid) < 0.0 else (lo, mid)
        pr = 0.5 * (lo + hi)
        return self.mass_flow(omega, pr), pr

    def choke_point(self, omega: float, eta_choke: float) -> tuple[float, float]:
        """(flow, PR) on the ellipse right of surge where the efficiency has fallen to
        ``eta_choke`` (bisection in PR), or the PR = 1 point if it stays above."""
        m_s, pr_s = self.surge_point(omega)
        if self.efficiency(omega, self.mass_flow(omega, 1.0)) >= eta_choke:
            return self.mass_flow(omega, 1.0), 1.0
        lo, hi = 1.0, pr_s           # eta(lo) < eta_choke <= eta(hi) (hi: the surge point)
        for _ in range(200):
            mid = 0.5 * (lo + hi)
            lo, hi = (mid, hi) if self.efficiency(omega, self.mass_flow(omega, mid)) < eta_choke \
                else (lo, mid)
        return self.mass_flow(omega, hi), hi


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


    def c_m_at(self, omega: float) -> float:
        """The fit's curvature c_m(omega) [-], held at its value at ``w_tlin`` below it: W&E's
        linear patch takes it to 0 over the 28 rad/s below ``w_tlin`` (a step, with an
        exponent of 0.01 above), which would put the whole table below 26.7 krpm at eta_max."""
        c1, c2, c3 = self.c_m
        return c1 * (max(omega, self.w_tlin) - c2) ** c3

    def blade_speed_ratio(self, omega: float, T_in: float, ER: float) -> float:
        """Blade-speed ratio [-] ``R_t*omega/sqrt(2*cp*T_in*(1 - ER^-kappa))``; inf at ER <= 1."""
        dh = 2.0 * self.gas.cp * T_in * (1.0 - min(1.0 / ER, 1.0) ** self.gas.kappa)
        return math.inf if dh <= 0.0 else self.R_t * omega / math.sqrt(dh)

    def smooth_efficiency(self, omega: float, T_in: float, ER: float) -> float:
        """Turbine-mechanical efficiency [-] that stays physical over the whole map, C1 in BSR:

        * the published parabola ``eta_max - c_m*(BSR - BSR_opt)^2`` between its two tangent
          points ``BSR_opt -/+ d``, ``d = BSR_opt - sqrt(BSR_opt^2 - eta_max/c_m)``: the fit's own
          range around the optimum;
        * below, the tangent through the origin: eta = 0 at BSR = 0 (no shaft power at
          standstill, a finite stall torque) instead of the 0.2 floor;
        * above, an exponential tail with the parabola's value and slope at its tangent point,
          falling towards 0 as ER -> 1 (no expansion) instead of going negative and flooring.

        If ``c_m`` is too small for the tangent (``BSR_opt^2 <= eta_max/c_m``) the parabola is
        used from BSR = 0, with the same tail.
        """
        bsr = self.blade_speed_ratio(omega, T_in, ER)
        if not math.isfinite(bsr):
            return 0.0
        c, b0, e = self.c_m_at(omega), self.BSR_opt, self.eta_max
        root = b0 * b0 - e / c
        b_lo = math.sqrt(root) if root > 0.0 else 0.0
        b_hi = 2.0 * b0 - b_lo

        def parabola(b: float) -> float:
            return e - c * (b - b0) ** 2

        if bsr < b_lo:
            return parabola(b_lo) * bsr / b_lo
        if bsr <= b_hi:
            return parabola(bsr)
        eta_h, slope = parabola(b_hi), 2.0 * c * (b_hi - b0)
        return eta_h * math.exp(-slope * (bsr - b_hi) / eta_h)


DEFAULT_VGT_POSITION = 55.0
"""Frozen vane position [%] of the shipped fixed-geometry turbine map (chosen so that the engine
of :class:`~transgen.sim.engine.diesel.TurbochargedDiesel` reached a boost pressure ratio of about 2.7 at 2100 rpm with
the earlier W&E compressor map; with the shipped LiU-D-El compressor, matched by
geometric similarity (:data:`DEFAULT_SPEED_SCALE`) and the turbine efficiency without floor, 2.91)."""


DEFAULT_FLOW_SCALE = 12.74 / 6.7
"""Flow scale of the shipped compressor map: the displacement ratio of the W&E engine (12.74 L,
the engine of :class:`~transgen.sim.engine.diesel.TurbochargedDiesel`) to the LiU-D-El engine
(6.7 L) whose compressor the map is."""

DEFAULT_SPEED_SCALE = 1.0 / math.sqrt(DEFAULT_FLOW_SCALE)
"""Speed scale of the shipped compressor map (0.725): geometric similarity, the wheel diameter
sqrt(DEFAULT_FLOW_SCALE) times the published one.  With the shipped W&E turbine the engine then
rates 2.91 boost PR at 88.5 krpm at 2100 rpm (W&E model: 2.5-3.2 at 99-116 krpm at 1900 rpm,
research note 1.1 and 3); the scaled wheel radius, 0.0452 m, is close to W&E's 0.04 m."""

CHOKE_EFFICIENCY = 0.55
"""Efficiency [-] at which the shipped map's speed lines choke (the research note's recipe,
2.1 step 3: 'the PR where the efficiency falls to a floor such as 0.5-0.6')."""


def _left_branch(m_s: float, pr_s: float, kappa: float, shut_off: float, fractions) -> list:
    """Points (flow, PR) left of surge on the Moore-Greitzer cubic in the head ``PR^kappa - 1``:
    zero slope at the surge point (its peak), the head ``shut_off`` times the surge head at zero
    flow, falling monotonically in between."""
    h_s = pr_s ** kappa - 1.0
    h_0 = shut_off * h_s
    out = []
    for f in fractions:
        x = 2.0 * f                              # x = 2 at surge, 0 at zero flow
        h = h_0 + (h_s - h_0) * (1.0 + 1.5 * (x - 1.0) - 0.5 * (x - 1.0) ** 3) / 2.0
        out.append((f * m_s, (1.0 + h) ** (1.0 / kappa)))
    return out


def generate_compressor_map(fit: LiUCompressorFit = LiUCompressorFit(flow_scale=DEFAULT_FLOW_SCALE,
                                                                     speed_scale=DEFAULT_SPEED_SCALE),
                            speeds_rpm=tuple(range(15_000, 105_001, 7_500)),
                            n_points: int = 13, eta_choke: float = CHOKE_EFFICIENCY,
                            shut_off: float = 0.7,
                            left_fractions=(0.2, 0.4, 0.6, 0.8, 0.9)) -> CompressorMap:
    """The shipped compressor map (Fig. 4.4 with surge and choke lines) from the LiU-D-El fit.

    Each speed line, from low to high flow:

    * the branch left of surge (``left_fractions`` of the surge flow): the Moore-Greitzer cubic
      characteristic, flat at the surge line and falling to ``shut_off`` of the surge head at
      zero flow (two flows per pressure ratio; efficiency from the fit);
    * the surge point: the ellipse meets the published linear surge line;
    * ``n_points`` on the ellipse, equally spaced in PR from surge to choke;
    * the choke point: where the fit's efficiency has fallen to ``eta_choke`` (PR = 1 if it stays
      above); below it the flow stops growing: a vertical segment down to half the choke head,
      at constant specific work (efficiency proportional to the isentropic head).

    The surge line and the stall (choke) line of the file are the surge and choke points; chi
    (eq. 4.25) is 1 on the first and 0 on the second.
    """
    k = fit.gas.kappa
    lines, surge, choke = [], [], []
    for n in speeds_rpm:
        w = n * RPM
        m_s, pr_s = fit.surge_point(w)
        eta_s = fit.efficiency(w, m_s)
        if eta_s < eta_choke:
            raise ValueError(f"speed {n} rpm: efficiency {eta_s:.3f} at surge is below the choke "
                             f"efficiency {eta_choke}")
        m_c, pr_c = fit.choke_point(w, eta_choke)
        pts = [(m, p, fit.efficiency(w, m))
               for m, p in _left_branch(m_s, pr_s, k, shut_off, left_fractions)]
        pts += [(fit.mass_flow(w, p), float(p), fit.efficiency(w, fit.mass_flow(w, p)))
                for p in np.linspace(pr_s, pr_c, n_points)]
        h_c = pr_c ** k - 1.0
        if h_c > 1e-3:
            eta_c = fit.efficiency(w, m_c)
            for h in np.linspace(h_c, 0.5 * h_c, 4)[1:]:
                pts.append((m_c, float((1.0 + h) ** (1.0 / k)), eta_c * h / h_c))
        m, pr, eta = zip(*pts)
        lines.append(CompressorSpeedLine(w, tuple(map(float, m)), tuple(map(float, pr)),
                                         tuple(map(float, eta))))
        surge.append((w, m_s, pr_s))
        choke.append((w, m_c, pr_c))
    c1, c2 = fit.c_surge
    prov = (("source", _LIU_SOURCE),
            ("generator", "transgen.sim.engine.generate_compressor_map (sim/data/make_maps.py)"),
            ("definitions", f"surge line PR = {c1:g}*m_corr/{fit.flow_scale:.4g} + {c2:g} (published, "
                            f"flow scaled); choke (stall) line where the fit's efficiency falls to "
                            f"{eta_choke:g}, vertical below it (constant specific work) to half the "
                            f"choke head; left of surge the Moore-Greitzer cubic with shut-off head "
                            f"{shut_off:g} of the surge head; corrected flows of the LiU-D-El fit "
                            f"times {fit.flow_scale:.4f} (12.74 L / 6.7 L displacement), speeds times "
                            f"{fit._speed_scale:.4f} (geometric similarity gives "
                            f"{1 / math.sqrt(fit.flow_scale):.4f}); reference "
                            "state = the fit's (T_c_b, p_c_b)"),
            ("validity", "the ellipse and efficiency fit between surge and choke; the branch left "
                         "of surge and the choke segment are model choices (unstable and choked "
                         "operation), drawn for the map, not data"),
            ("licence", "numbers computed from published model parameters; no proprietary data"))
    return CompressorMap("LiU-D-El compressor scaled to 12.7 L (regenerated fit, surge and choke)",
                         tuple(lines), MapLine(*map(tuple, zip(*surge))),
                         MapLine(*map(tuple, zip(*choke))), fit.T_ref, fit.p_ref, prov)


def generate_we_compressor_map(fit: WECompressorFit = WECompressorFit(),
                            speeds_rpm=tuple(range(10_000, 140_001, 10_000)),
                            n_points: int = 13,
                            surge_flow_fraction: float = 0.25) -> CompressorMap:
    """The earlier shipped map: the W&E fit with a constant-margin surge rule (no real surge line).

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
        e = tuple(fit.smooth_efficiency(w, T_ref, er) for er in expansion_ratio)
        lines.append(TurbineSpeedLine(w, tuple(map(float, expansion_ratio)), m, e))
    prov = (("source", _WE_SOURCE),
            ("generator", "transgen.sim.engine.generate_turbine_map (sim/data/make_maps.py)"),
            ("definitions", f"VGT frozen at {fit.vgt_position:g} % (f_vgt = {fit.f_vgt:.5f}): "
                            "treated as a fixed-geometry turbine; efficiency is W&E's eta_tm "
                            "(mechanical losses included): the published BSR parabola between its "
                            "tangent points, the tangent through the origin below (0 at BSR = 0), "
                            "an exponential tail above (towards 0 at ER = 1): C1, no 0.2 floor; "
                            "c_m(omega) taken at omega = N_corr, held below w_tlin"),
            ("licence", "numbers computed from published model parameters; no proprietary data"))
    return TurbineMap("W&E 12.7 L heavy-duty turbine, fixed geometry (regenerated fit)",
                      tuple(lines), T_ref, p_ref, prov)
