"""The turbocharged diesel's numerical core: every formula of one engine evaluation, once.

The functions here are written in the subset of Python that numba compiles (floats, ints, numpy
arrays, tuples of those; no objects, no exceptions, no dictionaries). The classes keep their
interface and call them: :mod:`~transgen.sim.engine.gas` (isentropic relations),
:mod:`~transgen.sim.engine.preprocessor` (the causal-table look-ups),
:mod:`~transgen.sim.engine.turbomachine` (a device's operating point),
:mod:`~transgen.sim.engine.turbocharger` (compressible-flow relations, the shaft, the iterative
mass-flow solve) and :mod:`~transgen.sim.engine.diesel` (cylinders, exhaust temperature, one full
evaluation of the engine). :mod:`~transgen.sim.engine.compiled` compiles them with numba (lazily,
cached on disk); this module imports no numba, and its functions run by the interpreter are the
reference the compiled ones are tested against (tests/test_sim_engine_kernels.py).

Errors: a kernel cannot raise an exception with a message. It returns a status code (``ST_*``
below, ``OK`` = 0) and leaves the numbers the message needs where the caller finds them; the
calling class raises the error it always raised (choked flow, non-convergence, NaN guard) with
element, time and reason. The same holds for the maps' out-of-data warnings: a look-up returns
an out-of-range code (``IN_RANGE``, ``BELOW_LOWEST_LINE``, ``OUTSIDE``) and the table warns.

Data layout
-----------
* a *device* (compressor or turbine) is the tuple :data:`DEVICE_FIELDS` inside the kernels,
  and one float array between Python and the kernels (:func:`pack_device`, built once per
  device by :meth:`~transgen.sim.engine.turbomachine.Turbomachine.kernel_device`; a call with
  tuples of arrays costs numba's dispatcher microseconds, a call with one array a tenth);
* a device's *flow* (one operating point) is the tuple :data:`FLOW_FIELDS`;
* the engine parameters are the float array of :data:`ENGINE_FIELDS`, the turbocharger's the
  float array of :data:`TURBO_FIELDS`;
* one engine evaluation fills the float array of :data:`OUT_FIELDS`.
"""
from __future__ import annotations

import math

import numpy as np

RPM = math.pi / 30.0  # the value of gas.RPM (gas.py imports this module)

# --------------------------------------------------------------------------- layouts
DEVICE_FIELDS = ("compresses", "speed", "grid", "mass_flow", "efficiency", "pr_stall", "pr_span",
                 "T_ref", "p_ref", "kappa", "cp", "gamma", "R", "omega_floor")
"""A device tuple: compressor (True) or turbine, the causal table (corrected-speed grid, chi or
expansion-ratio grid, 2-D corrected flow and efficiency, the stall PR and surge-stall span per
speed line - empty for a turbine), the reference state, the gas and the torque speed floor."""
FLOW_FIELDS = ("m_dot", "T_out", "power", "torque", "eta", "ratio", "chi", "corrected_speed",
               "corrected_flow", "range_code")
"""A device's operating point as :func:`machine_flow` returns it (``chi`` NaN for a turbine;
``range_code`` the look-up's out-of-range code, as a float: the tuple is all floats)."""
ENGINE_FIELDS = ("p_amb", "T_amb", "T_im", "T_w", "V_im", "V_em", "V_d", "n_cyl", "r_c",
                 "c_vol0", "c_vol1", "c_vol2", "q_HV", "AFs", "eta_igch", "gamma_cyl",
                 "c_fric0", "c_fric1", "c_fric2", "eta_sc", "x_cv", "h_tot", "d_pipe", "l_pipe",
                 "n_pipe", "cp_air", "R_air", "cp_exhaust", "R_exhaust", "friction_blend_speed")
TURBO_FIELDS = ("iterative", "compressor_inlet", "compressor_outlet", "turbine_inlet",
                "turbine_outlet", "xtol", "maxiter", "inner_tol", "inner_maxiter",
                "secant_iterations", "inertia", "c1", "c2", "omega_floor")
RANGE_FIELDS = ("range_code", "range_speed", "range_ratio", "range_chi")
"""The first out-of-range look-up of a device in an evaluation: its code and the corrected
speed, ratio and chi it was made at (what the table's warning names)."""
DEVICE_OUT = FLOW_FIELDS[:-1] + RANGE_FIELDS
OUT_FIELDS = ("dp_im", "dp_em", "domega_tc", "torque", "eta_vol", "W_ei", "W_f", "W_eo", "lambda",
              "T_em", "T_e", "x_r", "T_1") + tuple(f"c_{f}" for f in DEVICE_OUT) \
    + tuple(f"t_{f}" for f in DEVICE_OUT) + ("mach_c_in", "mach_c_out", "mach_t_in", "mach_t_out",
                                             "omega_dot", "damping", "info0", "info1", "fuel_air")
"""One engine evaluation: the state derivatives, the crank torque, the cylinder and exhaust
quantities, the compressor's and the turbine's points (``c_*``, ``t_*``: :data:`FLOW_FIELDS`
and :data:`RANGE_FIELDS`), the port Mach numbers, the shaft, and two numbers an error message
needs (``info0``, ``info1``), the charge's fuel/air ratio."""

(P_AMB, T_AMB, T_IM, T_W, V_IM, V_EM, V_D, N_CYL, R_C, C_VOL0, C_VOL1, C_VOL2, Q_HV, AFS, ETA_IGCH,
 GAMMA_CYL, C_FRIC0, C_FRIC1, C_FRIC2, ETA_SC, X_CV, H_TOT, D_PIPE, L_PIPE, N_PIPE, CP_AIR, R_AIR,
 CP_EXH, R_EXH, BLEND_SPEED) = range(len(ENGINE_FIELDS))
(TB_ITERATIVE, TB_C_IN, TB_C_OUT, TB_T_IN, TB_T_OUT, TB_XTOL, TB_MAXITER, TB_INNER_TOL,
 TB_INNER_MAXITER, TB_SECANT, TB_INERTIA, TB_C1, TB_C2, TB_FLOOR) = range(len(TURBO_FIELDS))
O_DX, O_TORQUE, O_ETA_VOL, O_W_EI, O_W_F, O_W_EO, O_LAMBDA, O_T_EM, O_T_E, O_X_R, O_T_1 = (
    0, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12)
O_C = 13                       # the compressor's FLOW_FIELDS
O_T = O_C + len(DEVICE_OUT)    # the turbine's
O_MACH = O_T + len(DEVICE_OUT)
N_FLOW = len(FLOW_FIELDS)
O_RANGE = N_FLOW - 1  # offset of RANGE_FIELDS in a device's block
O_OMEGA_DOT, O_DAMPING, O_INFO0, O_INFO1, O_FUEL_AIR = range(O_MACH + 4, O_MACH + 9)
N_OUT = len(OUT_FIELDS)

# look-up range codes
IN_RANGE, BELOW_LOWEST_LINE, OUTSIDE = 0, 1, 2

# status codes of a device solve and of an engine evaluation
OK = 0
ST_CHOKED = 1          # map flow above the ports' choked flow (info0 map flow, info1 choked flow)
ST_BRACKET_CHOKED = 2  # no subsonic solution below the bracket bound (info0 the bound)
ST_NO_BRACKET = 3      # no bracket found
ST_NOT_CONVERGED = 4   # Brent's method did not converge within maxiter
ST_INNER = 5           # the outlet total-temperature fixed point did not converge
ST_SUPERSONIC = 6      # the solution is not subsonic (info0, info1: the port Mach numbers)
ST_CYLINDERS = 10      # a non-finite cylinder quantity
ST_EXHAUST = 11        # the exhaust-temperature fixed point did not converge
ST_EXHAUST_NONFINITE = 12
ST_COMPRESSOR = 20     # + a device status above: the compressor's solve failed
ST_TURBINE = 30        # + a device status: the turbine's
ST_COMPRESSOR_NONFINITE = 40
ST_TURBINE_NONFINITE = 41
ST_DERIVATIVES_NONFINITE = 42

# the state of an iterative device solve (a float array, see :func:`solve_device`)
S_M, S_T02, S_SETTLED, S_M1, S_M2, S_SLOPE, S_INFO0, S_INFO1 = range(8)
S_POINT = 8                          # FLOW_FIELDS of the last evaluation
S_RANGE = S_POINT + len(FLOW_FIELDS)  # first out-of-range look-up: code, N_corr, ratio, chi
N_SOLVE = S_RANGE + 4

EXHAUST_TOL, EXHAUST_MAXITER = 1e-13, 60  # the exhaust-temperature fixed point's bounds
BRENT_RTOL = 4.0 * 2.220446049250313e-16  # scipy.optimize.brentq's default rtol


# --------------------------------------------------------------------------- gas relations
def corrected_speed(omega, T0, T_ref):
    """Corrected speed ``N*sqrt(T_std/T01)`` (eqs 4.21, 4.28); same unit as ``omega``."""
    return omega * math.sqrt(T_ref / T0)


def actual_flow(m_corr, p0, T0, p_ref, T_ref):
    """Mass flow [kg/s] from a corrected flow ``m_corr`` (inverse of eqs 4.22, 4.29)."""
    return m_corr * (p0 / p_ref) * math.sqrt(T_ref / T0)


def compression_outlet_temperature(T_in, PR, eta, kappa):
    """Compressor outlet temperature [K], eq. 4.7: ``T1*(1 + (PR^kappa - 1)/eta)``."""
    return T_in * (1.0 + (PR ** kappa - 1.0) / eta)


def expansion_outlet_temperature(T_in, ER, eta, kappa):
    """Turbine outlet temperature [K], eq. 4.16: ``T1*(1 - eta*(1 - ER^-kappa))``."""
    return T_in * (1.0 - eta * (1.0 - ER ** -kappa))


def torque_from_power(power, omega, omega_floor):
    """Shaft torque [N*m] ``power/max(omega, omega_floor)`` (eqs 4.8-4.9, 4.17-4.18)."""
    return power / max(omega, omega_floor)


# --------------------------------------------------------------------------- compressible flow
def total_temperature(T, M, gamma):
    """Total temperature [K] from static temperature and Mach number (eq. 4.34)."""
    return T * (1.0 + 0.5 * (gamma - 1.0) * M * M)


def total_pressure(p, M, gamma, kappa):
    """Total pressure [Pa] from static pressure and Mach number (eq. 4.35)."""
    return p * (1.0 + 0.5 * (gamma - 1.0) * M * M) ** (1.0 / kappa)


def mach_number(m_dot, p, T, area, R, gamma):
    """Mach number from mass flow, static pressure, static temperature and area (eq. 4.36)."""
    return m_dot / (p * area) * math.sqrt(R * T / gamma)


def mach_from_total_temperature(m_dot, p, T0, area, R, gamma):
    """Mach number from mass flow, static pressure, *total* temperature and area: eq. 4.36 with
    eq. 4.34, a quadratic in ``M^2`` solved in closed form (the numerically stable root)."""
    q2 = (m_dot / (p * area)) ** 2 * R * T0 / gamma
    return math.sqrt(2.0 * q2 / (1.0 + math.sqrt(1.0 + 2.0 * (gamma - 1.0) * q2)))


# --------------------------------------------------------------------------- shaft (eqs 4.32-4.33)
def shaft_damping(c1, c2, omega):
    """``c(omega) = c1*omega + c2*omega*|omega|`` [N*m]."""
    return c1 * omega + c2 * omega * abs(omega)


def shaft_acceleration(inertia, c1, c2, omega_floor, torque_turbine, torque_compressor, omega):
    """``domega/dt`` [rad/s^2]; held at zero while the rotor at or below the floor would slow."""
    a = (torque_turbine - torque_compressor - shaft_damping(c1, c2, omega)) / inertia
    return 0.0 if (omega <= omega_floor and a < 0.0) else a


# --------------------------------------------------------------------------- causal tables
def locate(grid, v):
    """Cell ``i`` (``grid[i] <= v <= grid[i+1]``), weight in [0, 1], and whether ``v`` was outside
    (then clamped to the edge): :func:`transgen.sim.core.interp.locate` on an array (numba compiles no
    ``bisect``); a NaN ``v`` gives the last cell and a NaN weight, as there."""
    n = grid.shape[0]
    if v <= grid[0]:
        return 0, 0.0, v < grid[0]
    if v >= grid[n - 1]:
        return n - 2, 1.0, v > grid[n - 1]
    lo, hi = 0, n
    while lo < hi:  # bisect_right
        mid = (lo + hi) // 2
        if v < grid[mid]:
            hi = mid
        else:
            lo = mid + 1
    i = min(lo - 1, n - 2)
    return i, (v - grid[i]) / (grid[i + 1] - grid[i]), False


def bilinear(z, i, wx, j, wy):
    """Bilinear value in the cell ``(i, j)`` of ``z[i_x, i_y]`` at the weights of :func:`locate`."""
    return ((1.0 - wx) * ((1.0 - wy) * z[i, j] + wy * z[i, j + 1])
            + wx * ((1.0 - wy) * z[i + 1, j] + wy * z[i + 1, j + 1]))


def compressor_lookup_in_range(speed, chi_grid, mass_flow, efficiency, pr_stall, pr_span, N_corr, PR):
    """``(m_corr, eta, chi, range_code)`` at a corrected speed within or above the speed grid."""
    i, wx, out_n = locate(speed, N_corr)
    stall = pr_stall[i] + wx * (pr_stall[i + 1] - pr_stall[i])
    span = pr_span[i] + wx * (pr_span[i + 1] - pr_span[i])
    chi = (PR - stall) / span  # span >= min_span > 0: never 0/0 (preprocessor docstring)
    j, wy, out_c = locate(chi_grid, chi)
    return (bilinear(mass_flow, i, wx, j, wy), bilinear(efficiency, i, wx, j, wy), chi,
            OUTSIDE if (out_n or out_c) else IN_RANGE)


def compressor_lookup(speed, chi_grid, mass_flow, efficiency, pr_stall, pr_span, N_corr, PR):
    """``(m_corr, eta, chi, range_code)`` of the compressor table (the rules of
    :meth:`~transgen.sim.engine.preprocessor.CompressorTable.lookup`): below the lowest speed
    line the similar point of that line by fan laws (``PR - 1`` with speed squared, flow with
    speed), code ``BELOW_LOWEST_LINE``."""
    n0 = speed[0]
    if N_corr < n0:
        r = max(N_corr, 0.0) / n0
        m, eta, chi, _ = compressor_lookup_in_range(speed, chi_grid, mass_flow, efficiency, pr_stall,
                                                    pr_span, n0, 1.0 + (PR - 1.0) / max(r * r, 1e-12))
        return r * m, eta, chi, BELOW_LOWEST_LINE
    return compressor_lookup_in_range(speed, chi_grid, mass_flow, efficiency, pr_stall, pr_span, N_corr, PR)


def turbine_lookup(speed, er_grid, mass_flow, efficiency, N_corr, ER):
    """``(m_corr, eta, range_code)`` of the turbine table, clamped to its edges."""
    i, wx, out_n = locate(speed, N_corr)
    j, wy, out_e = locate(er_grid, ER)
    return (bilinear(mass_flow, i, wx, j, wy), bilinear(efficiency, i, wx, j, wy),
            OUTSIDE if (out_n or out_e) else IN_RANGE)


# --------------------------------------------------------------------------- one device
def machine_flow(dev, p_in, T_in, p_out, omega):
    """A device's operating point (:data:`FLOW_FIELDS`) at inlet total pressure [Pa] and
    temperature [K], outlet total pressure [Pa] and rotor speed [rad/s] (thesis Figures 4.8 and
    4.12): table look-up at the corrected speed and the pressure (compressor, p02/p01) or
    expansion (turbine, p01/p02) ratio, actual flow, isentropic outlet temperature, power and
    torque (absorbed by a compressor, delivered by a turbine)."""
    (compresses, speed, grid, mass_flow, efficiency, pr_stall, pr_span, T_ref, p_ref, kappa, cp,
     _gamma, _R, omega_floor) = dev
    n_corr = corrected_speed(omega, T_in, T_ref)
    if compresses:
        ratio = p_out / p_in
        m_corr, eta, chi, code = compressor_lookup(speed, grid, mass_flow, efficiency, pr_stall, pr_span,
                                                   n_corr, ratio)
    else:
        ratio = p_in / p_out
        m_corr, eta, code = turbine_lookup(speed, grid, mass_flow, efficiency, n_corr, ratio)
        chi = math.nan
    m_dot = actual_flow(m_corr, p_in, T_in, p_ref, T_ref)
    if compresses:
        T_out = compression_outlet_temperature(T_in, max(ratio, 1.0), eta, kappa)
        power = m_dot * cp * (T_out - T_in)
    else:
        T_out = expansion_outlet_temperature(T_in, max(ratio, 1.0), eta, kappa)
        power = m_dot * cp * (T_in - T_out)
    return (m_dot, T_out, power, torque_from_power(power, omega, omega_floor), eta, ratio, chi,
            n_corr, m_corr, float(code))


def pack_device(compresses, speed, grid, mass_flow, efficiency, pr_stall, pr_span, T_ref, p_ref, kappa,
                cp, gamma, R, omega_floor):
    """A device (:data:`DEVICE_FIELDS`) as one float array: a header (compresses, the two grid
    sizes, the scalars) and the arrays one after the other (interpreter only, once per device;
    :func:`unpack_device` is its inverse)."""
    head = [1.0 if compresses else 0.0, speed.size, grid.size, T_ref, p_ref, kappa, cp, gamma, R, omega_floor]
    parts = [np.asarray(head, dtype=float), speed, grid, mass_flow.ravel(), efficiency.ravel()]
    if compresses:
        parts += [pr_stall, pr_span]
    return np.ascontiguousarray(np.concatenate(parts), dtype=float)


def unpack_device(d):
    """The device tuple (:data:`DEVICE_FIELDS`) of :func:`pack_device`'s array (views, no copies)."""
    compresses = d[0] != 0.0
    n, k = int(d[1]), int(d[2])
    o = 10
    speed = d[o:o + n]
    grid = d[o + n:o + n + k]
    o += n + k
    mass_flow = d[o:o + n * k].reshape((n, k))
    efficiency = d[o + n * k:o + 2 * n * k].reshape((n, k))
    o += 2 * n * k
    ns = n if compresses else 0
    return (compresses, speed, grid, mass_flow, efficiency, d[o:o + ns], d[o + ns:o + 2 * ns], d[3], d[4],
            d[5], d[6], d[7], d[8], d[9])


def device_flow(d, p_in, T_in, p_out, omega):
    """:func:`machine_flow` of the packed device ``d``."""
    return machine_flow(unpack_device(d), p_in, T_in, p_out, omega)


def _note_range(st, flow):
    """Keep the first out-of-range look-up of a solve in ``st[S_RANGE:]``."""
    if flow[9] != IN_RANGE and st[S_RANGE] == IN_RANGE:
        st[S_RANGE] = flow[9]
        st[S_RANGE + 1] = flow[7]
        st[S_RANGE + 2] = flow[5]
        st[S_RANGE + 3] = flow[6]


def _keep_point(st, flow):
    for k in range(N_FLOW):
        st[S_POINT + k] = flow[k]


# --------------------------------------------------------------------------- iterative solve (4.5)
def device_residual(dev, p1, T1, p2, omega, area_in, area_out, m, inner, inner_tol, st):
    """``m - m_map(m)`` of the kinetic-energy algorithm (eqs 4.34-4.41) between the static
    states (p1, T1) and p2: the inlet Mach number and totals from ``m``, the outlet Mach number
    from ``m`` and the outlet total temperature ``st[S_T02]``, iterated up to ``inner`` times
    (converged: ``st[S_SETTLED]`` = 1). The point, the Mach numbers and ``m`` are left in ``st``."""
    gamma, R, kappa = dev[11], dev[12], dev[9]
    M1 = mach_number(m, p1, T1, area_in, R, gamma)
    p01, T01 = total_pressure(p1, M1, gamma, kappa), total_temperature(T1, M1, gamma)
    T02 = st[S_T02]
    k = 0
    while True:
        M2 = mach_from_total_temperature(m, p2, T02, area_out, R, gamma)
        pt = machine_flow(dev, p01, T01, total_pressure(p2, M2, gamma, kappa), omega)
        _note_range(st, pt)
        k += 1
        settled = abs(pt[1] - T02) <= inner_tol * T02
        if settled or k >= inner:
            break
        T02 = pt[1]
    st[S_M] = m
    st[S_T02] = pt[1]
    st[S_SETTLED] = 1.0 if settled else 0.0
    st[S_M1] = M1
    st[S_M2] = M2
    _keep_point(st, pt)
    return m - pt[0]


def _secant(dev, p1, T1, p2, omega, area_in, area_out, inner_tol, st, m0, m_basic, hi, slope,
            iterations, xtol):
    """Secant iteration on the residual from the warm start ``m0``, the first step with the
    previous solve's ``slope`` (``1 - dm_map/dm``, near 1); one outlet-temperature update per
    evaluation (a joint iteration). Accepted when the step is below ``xtol`` and the temperature
    has settled. Returns ``(root, slope)``, the root NaN when an iterate leaves ``(0, hi)`` or it
    has not converged (the caller then brackets)."""
    if not 0.0 < m0 < hi:
        m0 = m_basic
    r0 = device_residual(dev, p1, T1, p2, omega, area_in, area_out, m0, 1, inner_tol, st)
    m1 = m0 - r0 / slope
    for _ in range(iterations):
        if not 0.0 < m1 < hi:
            return math.nan, 1.0
        r1 = device_residual(dev, p1, T1, p2, omega, area_in, area_out, m1, 1, inner_tol, st)
        if (abs(r1) <= xtol * slope or abs(m1 - m0) <= xtol) and st[S_SETTLED] == 1.0:
            return m1, slope  # within xtol of the root; the last evaluation is at m1
        secant = (r1 - r0) / (m1 - m0) if m1 != m0 else slope
        # a secant through two nearly equal points with the outlet temperature still moving is
        # noise: keep the last good slope
        if 0.25 <= secant <= 4.0:
            slope = secant
        m0, r0, m1 = m1, r1, m1 - r1 / slope
    return math.nan, 1.0


def _full_residual(dev, p1, T1, p2, omega, area_in, area_out, inner_maxiter, inner_tol, st, m):
    """The residual with the outlet temperature converged (``st[S_SETTLED]`` 0: it did not)."""
    return device_residual(dev, p1, T1, p2, omega, area_in, area_out, m, inner_maxiter, inner_tol, st)


def _bracket(dev, p1, T1, p2, omega, area_in, area_out, inner_maxiter, inner_tol, st, guess, hi, m_basic):
    """``(status, a, b)``: a bracket with residual(a) < 0 < residual(b), grown from +-2 % around
    the guess towards [0, hi] (residual(0) = -m_basic < 0); evaluations stay near the root."""
    guess = min(max(guess, 1e-6 * hi), 0.99 * hi)
    a, b = 0.98 * guess, min(1.02 * guess, hi)
    ra = _full_residual(dev, p1, T1, p2, omega, area_in, area_out, inner_maxiter, inner_tol, st, a)
    if st[S_SETTLED] == 0.0:
        return ST_INNER, a, b
    rb = _full_residual(dev, p1, T1, p2, omega, area_in, area_out, inner_maxiter, inner_tol, st, b)
    if st[S_SETTLED] == 0.0:
        return ST_INNER, a, b
    for _ in range(40):
        if ra < 0.0 < rb:
            return OK, a, b
        w = 2.0 * (b - a)
        if ra >= 0.0:
            a = max(0.0, a - w)
            if a > 0.0:
                ra = _full_residual(dev, p1, T1, p2, omega, area_in, area_out, inner_maxiter, inner_tol, st, a)
                if st[S_SETTLED] == 0.0:
                    return ST_INNER, a, b
            else:
                ra = -m_basic
        if rb <= 0.0:
            if b >= hi:
                st[S_INFO0] = hi
                return ST_BRACKET_CHOKED, a, b
            b = min(hi, b + w)
            rb = _full_residual(dev, p1, T1, p2, omega, area_in, area_out, inner_maxiter, inner_tol, st, b)
            if st[S_SETTLED] == 0.0:
                return ST_INNER, a, b
    return ST_NO_BRACKET, a, b


def _brentq(dev, p1, T1, p2, omega, area_in, area_out, inner_maxiter, inner_tol, st, xa, xb, xtol, maxiter):
    """``(status, root)``: Brent's method on the full residual, step for step scipy's
    ``brentq`` (scipy/optimize/Zeros/brentq.c) with its default ``rtol``."""
    xpre, xcur = xa, xb
    xblk, fblk, spre, scur = 0.0, 0.0, 0.0, 0.0
    fpre = _full_residual(dev, p1, T1, p2, omega, area_in, area_out, inner_maxiter, inner_tol, st, xpre)
    if st[S_SETTLED] == 0.0:
        return ST_INNER, xpre
    fcur = _full_residual(dev, p1, T1, p2, omega, area_in, area_out, inner_maxiter, inner_tol, st, xcur)
    if st[S_SETTLED] == 0.0:
        return ST_INNER, xcur
    if fpre == 0.0:
        return OK, xpre
    if fcur == 0.0:
        return OK, xcur
    for _ in range(maxiter):
        if fpre != 0.0 and fcur != 0.0 and (fpre < 0.0) != (fcur < 0.0):
            xblk, fblk = xpre, fpre
            spre = scur = xcur - xpre
        if abs(fblk) < abs(fcur):
            xpre, xcur, xblk = xcur, xblk, xcur
            fpre, fcur, fblk = fcur, fblk, fcur
        delta = (xtol + BRENT_RTOL * abs(xcur)) / 2.0
        sbis = (xblk - xcur) / 2.0
        if fcur == 0.0 or abs(sbis) < delta:
            return OK, xcur
        if abs(spre) > delta and abs(fcur) < abs(fpre):
            if xpre == xblk:
                stry = -fcur * (xcur - xpre) / (fcur - fpre)  # interpolate
            else:
                dpre = (fpre - fcur) / (xpre - xcur)          # extrapolate
                dblk = (fblk - fcur) / (xblk - xcur)
                stry = -fcur * (fblk * dblk - fpre * dpre) / (dblk * dpre * (fblk - fpre))
            if 2.0 * abs(stry) < min(abs(spre), 3.0 * abs(sbis) - delta):
                spre, scur = scur, stry  # good short step
            else:
                spre, scur = sbis, sbis  # bisect
        else:
            spre, scur = sbis, sbis
        xpre, fpre = xcur, fcur
        if abs(scur) > delta:
            xcur += scur
        else:
            xcur += delta if sbis > 0.0 else -delta
        fcur = _full_residual(dev, p1, T1, p2, omega, area_in, area_out, inner_maxiter, inner_tol, st, xcur)
        if st[S_SETTLED] == 0.0:
            return ST_INNER, xcur
    return ST_NOT_CONVERGED, xcur


def solve_device(d, p1, T1, p2, omega, area_in, area_out, warm, xtol, maxiter, inner_tol,
                 inner_maxiter, secant_iterations, st):
    """Solve ``m = m_map(m)`` for one device between static states (p1, T1) and p2 (thesis 4.5).

    A choke check first (static-state choking of the port ducts), then a secant iteration from
    the warm start ``warm`` = (m/m_basic, T02/T_basic, slope) of the previous solve (at most
    ``secant_iterations`` steps), and if that fails Brent's method on a bracket grown from the
    warm start with the outlet temperature converged at every evaluation. Returns a status
    (``OK`` or ``ST_*``); the point (:data:`FLOW_FIELDS`), the Mach numbers and the numbers of an
    error message are in ``st`` (``S_*``), the warm start is updated on success. ``d`` is the
    packed device (:func:`pack_device`)."""
    dev = unpack_device(d)
    gamma, R = dev[11], dev[12]
    for k in range(N_SOLVE):
        st[k] = 0.0
    st[S_M] = math.nan
    basic = machine_flow(dev, p1, T1, p2, omega)
    _note_range(st, basic)
    _keep_point(st, basic)
    if basic[0] <= 0.0:
        return OK
    basic_m, basic_T = basic[0], basic[1]
    m_star = min(p1 * area_in * math.sqrt(gamma / (R * T1)),
                 p2 * area_out * math.sqrt(gamma * (gamma + 1.0) / (2.0 * R * basic_T)))
    if basic_m >= m_star:
        st[S_INFO0] = basic_m
        st[S_INFO1] = m_star
        return ST_CHOKED
    m_warm = basic_m * warm[0]
    st[S_T02] = basic_T * warm[1]
    slope = warm[2]
    hi = 0.999 * m_star
    m = math.nan
    if secant_iterations > 0:
        m, slope = _secant(dev, p1, T1, p2, omega, area_in, area_out, inner_tol, st, m_warm, basic_m,
                           hi, slope, min(secant_iterations, maxiter), xtol)
    else:
        slope = 1.0
    if m != m:  # the fast path left its bounds or stalled: bracket and Brent
        status, a, b = _bracket(dev, p1, T1, p2, omega, area_in, area_out, inner_maxiter, inner_tol,
                                st, m_warm, hi, basic_m)
        if status != OK:
            return status
        status, m = _brentq(dev, p1, T1, p2, omega, area_in, area_out, inner_maxiter, inner_tol, st,
                            a, b, xtol, maxiter)
        if status != OK:
            return status
    if st[S_M] != m or st[S_SETTLED] == 0.0:
        _full_residual(dev, p1, T1, p2, omega, area_in, area_out, inner_maxiter, inner_tol, st, m)
        if st[S_SETTLED] == 0.0:
            return ST_INNER
    if not (st[S_M1] < 1.0 and st[S_M2] < 1.0):
        st[S_INFO0] = st[S_M1]
        st[S_INFO1] = st[S_M2]
        return ST_SUPERSONIC
    warm[0] = m / basic_m
    warm[1] = st[S_T02] / basic_T
    warm[2] = slope
    return OK


# --------------------------------------------------------------------------- the engine
def cylinders(P, p_im, p_em, omega_e, u_f):
    """The cylinders' flow and torque (mean-value model, see :mod:`~transgen.sim.engine.diesel`):
    ``(eta_vol, m_air, m_fuel, W_ei, W_f, W_eo, lambda, torque)`` at the manifold pressures
    [Pa], engine speed [rad/s] and fuel [kg per cycle per cylinder]."""
    n_e = abs(omega_e) / RPM
    eta_vol = P[C_VOL0] * math.sqrt(p_im) + P[C_VOL1] * math.sqrt(n_e) + P[C_VOL2]
    m_air = eta_vol * p_im * P[V_D] / (P[R_AIR] * P[T_IM])       # kg per cycle
    m_fuel = u_f * P[N_CYL]                                      # kg per cycle
    W_ei, W_f = m_air * n_e / 120.0, m_fuel * n_e / 120.0
    W_eo = W_ei + W_f
    lam = m_air / (m_fuel * P[AFS]) if m_fuel > 0.0 else math.inf
    blend = min(max(omega_e / P[BLEND_SPEED], -1.0), 1.0)
    W_ig = (P[ETA_IGCH] * min(1.0, lam) * (1.0 - P[R_C] ** (1.0 - P[GAMMA_CYL])) * m_fuel * P[Q_HV])
    n_k = n_e / 1000.0
    fmep = P[C_FRIC0] * n_k * n_k + P[C_FRIC1] * n_k + P[C_FRIC2]
    torque = (W_ig - blend * (P[V_D] * (p_em - p_im) + P[V_D] * 1e5 * fmep)) / (4.0 * math.pi)
    return eta_vol, m_air, m_fuel, W_ei, W_f, W_eo, lam, torque


def exhaust_temperature(P, p_im, p_em, fuel_air, W_eo, tol, maxiter):
    """W&E's exhaust-temperature model: ``(T_em, T_e, x_r, T_1, converged)``; the fixed point on
    the residual gas fraction and the charge temperature starts from ``x_r = 0``, ``T_1 = T_im``
    (see :func:`transgen.sim.engine.diesel.exhaust_temperature`)."""
    cp, R = P[CP_AIR], P[R_AIR]
    g = cp / (cp - R)
    cv = cp - R
    r_c, x_cv, T_im = P[R_C], P[X_CV], P[T_IM]
    rcg = r_c ** (g - 1.0)
    pi_e = p_em / p_im
    # loop invariants of the fixed point
    q_fuel = P[Q_HV] * fuel_air / (1.0 + fuel_air)
    pi_g = pi_e ** (1.0 / g) / r_c
    t_scale = P[ETA_SC] * pi_e ** (1.0 - 1.0 / g) * r_c ** (1.0 - g)
    c_v, c_p, c_mix = x_cv / cv, (1.0 - x_cv) / cp, (1.0 - x_cv) / cp + x_cv / cv
    e_r, e_t = -1.0 / g, 1.0 / g - 1.0
    x_r, T_1, T_e = 0.0, T_im, math.nan
    converged = False
    for _ in range(maxiter):
        q_in = q_fuel * (1.0 - x_r)
        a = T_1 * rcg
        x_p = 1.0 + q_in * c_v / a
        x_v = 1.0 + q_in * c_p / (q_in * c_v + a)
        x_r_new = pi_g * x_p ** e_r / x_v
        x_r_new = 0.0 if x_r_new <= 0.0 else (1.0 if x_r_new >= 1.0 else x_r_new)
        T_e = t_scale * x_p ** e_t * (q_in * c_mix + a)
        T_1_new = x_r_new * T_e + (1.0 - x_r_new) * T_im
        if not T_1_new >= 273.0:
            T_1_new = 273.0
        done = abs(T_1_new - T_1) <= tol * T_1 and abs(x_r_new - x_r) <= tol
        x_r, T_1 = x_r_new, T_1_new
        if done:
            converged = True
            break
    if W_eo > 0.0:
        hA = P[H_TOT] * math.pi * P[D_PIPE] * P[L_PIPE] * P[N_PIPE]
        T_em = P[T_W] + (T_e - P[T_W]) * math.exp(-hA / (W_eo * P[CP_EXH]))
    else:
        T_em = P[T_W]
    return T_em, T_e, x_r, T_1, converged


def _finite(*values):
    for v in values:
        if not math.isfinite(v):
            return False
    return True


def _put_flow(out, at, flow):
    """A device's point and its own look-up's range record into its block of ``out``."""
    for k in range(O_RANGE):
        out[at + k] = flow[k]
    out[at + O_RANGE] = flow[9]
    out[at + O_RANGE + 1] = flow[7]
    out[at + O_RANGE + 2] = flow[5]
    out[at + O_RANGE + 3] = flow[6]


def _put_solve(out, at, st):
    """A solve's final point and first out-of-range look-up into a device's block of ``out``."""
    for k in range(O_RANGE):
        out[at + k] = st[S_POINT + k]
    for k in range(4):
        out[at + O_RANGE + k] = st[S_RANGE + k]


def engine_evaluate(P, cdev, tdev, TB, warm, p_im, p_em, w_tc, omega_e, u_f, out, st):
    """One evaluation of the mean-value turbodiesel (:mod:`~transgen.sim.engine.diesel`):
    cylinders, exhaust temperature, turbocharger (basic or iterative algorithm, ``TB``),
    manifolds and shaft. Fills ``out`` (:data:`OUT_FIELDS`) and returns ``OK`` or the status of
    the first failing stage (the checks come in the order of the stages).

    ``out``'s flow fields of a device hold its final point except for ``range_code`` and, when
    that is not ``IN_RANGE``, the corrected speed, ratio and chi of the first out-of-range look-up
    (what the table's warning names); ``warm`` (2 x 3) is the iterative solves' warm start;
    ``cdev``, ``tdev`` are the packed compressor and turbine (:func:`pack_device`)."""
    eta_vol, m_air, m_fuel, W_ei, W_f, W_eo, lam, torque = cylinders(P, p_im, p_em, omega_e, u_f)
    out[O_TORQUE], out[O_ETA_VOL], out[O_W_EI], out[O_W_F], out[O_W_EO], out[O_LAMBDA] = (
        torque, eta_vol, W_ei, W_f, W_eo, lam)
    if not _finite(eta_vol, W_ei, W_f, torque):
        return ST_CYLINDERS
    # exhaust temperature (algebraic loop hidden inside the block, thesis 2.4.3)
    fuel_air = m_fuel / m_air
    out[O_FUEL_AIR] = fuel_air
    T_em, T_e, x_r, T_1, converged = exhaust_temperature(P, p_im, p_em, fuel_air, W_eo, EXHAUST_TOL, EXHAUST_MAXITER)
    out[O_T_EM], out[O_T_E], out[O_X_R], out[O_T_1] = T_em, T_e, x_r, T_1
    if not converged:
        return ST_EXHAUST
    if not _finite(T_em, T_e, x_r, T_1):
        return ST_EXHAUST_NONFINITE
    # turbocharger (flow blocks + shaft)
    p_amb, T_amb = P[P_AMB], P[T_AMB]
    if TB[TB_ITERATIVE] != 0.0:
        xtol, maxiter, secant = TB[TB_XTOL], int(TB[TB_MAXITER]), int(TB[TB_SECANT])
        inner_tol, inner_maxiter = TB[TB_INNER_TOL], int(TB[TB_INNER_MAXITER])
        status = solve_device(cdev, p_amb, T_amb, p_im, w_tc, TB[TB_C_IN], TB[TB_C_OUT], warm[0], xtol,
                              maxiter, inner_tol, inner_maxiter, secant, st)
        _put_solve(out, O_C, st)
        out[O_MACH], out[O_MACH + 1] = (st[S_M1], st[S_M2]) if st[S_M] == st[S_M] else (0.0, 0.0)
        out[O_INFO0], out[O_INFO1] = st[S_INFO0], st[S_INFO1]
        if status != OK:
            return ST_COMPRESSOR + status
        status = solve_device(tdev, p_em, T_em, p_amb, w_tc, TB[TB_T_IN], TB[TB_T_OUT], warm[1], xtol,
                              maxiter, inner_tol, inner_maxiter, secant, st)
        _put_solve(out, O_T, st)
        out[O_MACH + 2], out[O_MACH + 3] = (st[S_M1], st[S_M2]) if st[S_M] == st[S_M] else (0.0, 0.0)
        out[O_INFO0], out[O_INFO1] = st[S_INFO0], st[S_INFO1]
        if status != OK:
            return ST_TURBINE + status
    else:
        _put_flow(out, O_C, device_flow(cdev, p_amb, T_amb, p_im, w_tc))
        _put_flow(out, O_T, device_flow(tdev, p_em, T_em, p_amb, w_tc))
        for k in range(4):
            out[O_MACH + k] = 0.0
    m_c, m_t = out[O_C], out[O_T]
    if not _finite(m_c, out[O_C + 1], out[O_C + 3], out[O_C + 6]):
        return ST_COMPRESSOR_NONFINITE
    if not _finite(m_t, out[O_T + 1], out[O_T + 3]):
        return ST_TURBINE_NONFINITE
    c1, c2 = TB[TB_C1], TB[TB_C2]
    omega_dot = shaft_acceleration(TB[TB_INERTIA], c1, c2, TB[TB_FLOOR], out[O_T + 3], out[O_C + 3], w_tc)
    out[O_OMEGA_DOT], out[O_DAMPING] = omega_dot, shaft_damping(c1, c2, w_tc)
    # manifolds (control volumes)
    out[0] = P[R_AIR] * P[T_IM] * (m_c - W_ei) / P[V_IM]
    out[1] = P[R_EXH] * T_em * (W_eo - m_t) / P[V_EM]
    out[2] = omega_dot
    if not _finite(out[0], out[1], out[2]):
        return ST_DERIVATIVES_NONFINITE
    return OK


COMPILED = ("corrected_speed", "actual_flow", "compression_outlet_temperature",
            "expansion_outlet_temperature", "torque_from_power", "total_temperature", "total_pressure",
            "mach_number", "mach_from_total_temperature", "shaft_damping", "shaft_acceleration",
            "locate", "bilinear", "compressor_lookup_in_range", "compressor_lookup", "turbine_lookup",
            "machine_flow", "unpack_device", "device_flow", "_note_range", "_keep_point", "device_residual", "_secant", "_full_residual",
            "_bracket", "_brentq", "solve_device", "cylinders", "exhaust_temperature", "_finite",
            "_put_flow", "_put_solve", "engine_evaluate")
"""The functions :mod:`~transgen.sim.engine.compiled` compiles (all of them: a compiled function
calls compiled ones only)."""
