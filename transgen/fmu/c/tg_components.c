/* transgen FMU runtime: the components of a scenario (the driveline, the engine map and the torque
 * converter), the simulator's formulas (transgen.sim.components, transgen.sim.interp,
 * transgen.sim.engine.torque_converter). Written for transgen (MIT licence); included by tg_model.c. */
#if TG_DRIVELINE
/* the driveline (simulator: components.driveline_rates, road_torque): shaft torque [N*m] */
static double tg_shaft_torque(const TG *m, const double *w) {
    return TG_DL_STIFFNESS * w[TG_DL_X] + TG_DL_DAMPING * (w[TG_DL_OUTPUT] - w[TG_DL_X + 1]);
}

static double tg_road_torque(const TG *m, double omega_v) {
    double v = omega_v * TG_DL_RADIUS / TG_DL_FINAL;
    double mg = TG_DL_MASS * 9.81;
    double rolling = TG_DL_ROLLING * mg * cos(TG_DL_GRADE) * tanh(v / 0.1);
    double force = rolling + 0.5 * TG_DL_AIR * TG_DL_CDA * v * fabs(v) + mg * sin(TG_DL_GRADE);
    return force * TG_DL_RADIUS / TG_DL_FINAL;
}

/* the vehicle-side inertia referred to the driveshaft [kg*m^2] (simulator: Driveline.J_v) */
static double tg_vehicle_inertia(const TG *m) {
    return TG_DL_JOUT + TG_DL_MASS * TG_DL_RADIUS * TG_DL_RADIUS / (TG_DL_FINAL * TG_DL_FINAL);
}
#endif

#if TG_ENGINE
/* the engine map (simulator: interp.interp2, components.governed_throttle, requested_torque) */
static int tg_locate(const double *grid, int n, double v, double *frac) {
    if (v <= grid[0]) { *frac = 0.0; return 0; }
    if (v >= grid[n - 1]) { *frac = 1.0; return n - 2; }
    int i = tg_bisect_right(grid, n, v) - 1;
    if (i > n - 2) i = n - 2;
    *frac = (v - grid[i]) / (grid[i + 1] - grid[i]);
    return i;
}

static double tg_interp2(double x, double y) {
    double fx, fy;
    int i = tg_locate(TG_ENG_SPEEDS, TG_ENG_NS, x, &fx);
    if (TG_ENG_NT == 1) return TG_ENG_TABLE[i] + (TG_ENG_TABLE[i + 1] - TG_ENG_TABLE[i]) * fx;
    int j = tg_locate(TG_ENG_THROTTLES, TG_ENG_NT, y, &fy);
    const double *r0 = TG_ENG_TABLE + j * TG_ENG_NS, *r1 = TG_ENG_TABLE + (j + 1) * TG_ENG_NS;
    double lo = r0[i] + (r0[i + 1] - r0[i]) * fx;
    double hi = r1[i] + (r1[i + 1] - r1[i]) * fx;
    return lo + (hi - lo) * fy;
}

/* the engine torque [N*m] at engine speed omega [rad/s] and the signals' time t */
static double tg_engine_torque(const TG *m, double t, double omega) {
    double throttle = tg_input(m, TG_ENG_THROTTLE_IN, t);
    if (TG_ENG_IDLE > 0 && omega < TG_ENG_IDLE)
        throttle = fmax(throttle, fmin(1.0, (TG_ENG_IDLE - omega) / (0.1 * TG_ENG_IDLE)));
    double torque = tg_interp2(omega, throttle);
    if (TG_ENG_REQUEST_IN < 0) return torque;
    double factor = tg_input(m, TG_ENG_REQUEST_IN, t);
    if (torque <= 0.0 || factor == 1.0) return torque;
    if (factor < 1.0) return torque * factor;
    return fmin(torque * factor, fmax(torque, tg_interp2(omega, TG_ENG_THROTTLES[TG_ENG_NT - 1])));
}

#if TG_ENGINE == 2
static double tg_interp1(double x, const double *xs, const double *ys, int n) {
    if (x <= xs[0]) return ys[0];
    if (x >= xs[n - 1]) return ys[n - 1];
    int i = tg_bisect_right(xs, n, x) - 1;
    return ys[i] + (ys[i + 1] - ys[i]) * (x - xs[i]) / (xs[i + 1] - xs[i]);
}

/* the torque converter (simulator: engine.torque_converter.converter_torques) */
static void tg_converter(double omega_pump, double omega_turbine, double *pump, double *turbine) {
    double s = (omega_pump > 0.0 || (omega_pump == 0.0 && omega_turbine >= 0.0)) ? 1.0 : -1.0;
    double wp = s * omega_pump, wt = s * omega_turbine;
    if (wt <= wp) {
        if (wp == 0.0) { *pump = *turbine = 0.0; return; }
        double x = fmax(wt / wp, 0.0), capacity, ratio;
        if (x <= TG_TC_SR[0]) { capacity = TG_TC_C[0]; ratio = TG_TC_TR[0]; }
        else if (x >= TG_TC_SR[TG_TC_N - 1]) { capacity = TG_TC_C[TG_TC_N - 1]; ratio = TG_TC_TR[TG_TC_N - 1]; }
        else {
            int i = tg_bisect_right(TG_TC_SR, TG_TC_N, x) - 1;
            double dx = x - TG_TC_SR[i], span = TG_TC_SR[i + 1] - TG_TC_SR[i];
            capacity = TG_TC_C[i] + (TG_TC_C[i + 1] - TG_TC_C[i]) * dx / span;
            ratio = TG_TC_TR[i] + (TG_TC_TR[i + 1] - TG_TC_TR[i]) * dx / span;
        }
        double tp = wp * wp * capacity;
        *pump = s * tp;
        *turbine = s * tp * ratio;
        return;
    }
    double t = wt * wt * tg_interp1(wp / wt, TG_TC_CSR, TG_TC_CC, TG_TC_NC);
    *pump = -s * t;
    *turbine = -s * t;
}
#endif

/* the engine's torque on the input link (T_in): the map itself, or the converter's turbine */
static double tg_engine_input(const TG *m, double t, const double *w) {
#if TG_ENGINE == 2
    double pump, turbine;
    (void)t; (void)m;
    tg_converter(w[TG_ENG_X], w[TG_ENG_LINK], &pump, &turbine);
    return turbine;
#else
    return tg_engine_torque(m, t, w[TG_ENG_LINK]);
#endif
}
#endif

