/* transgen FMU runtime: the automatic shift schedule (a C port of transgen.sim.schedule.AutoShift):
 * upshift and downshift lines over the output speed and the throttle, min_interval between shifts,
 * and at a shift the apply signals of the oncoming and offgoing elements replaced from the command
 * time on by the template's trajectories (ShiftTemplate.oncoming/offgoing, as AutoShift.fire
 * splices them), and the ease event of a template that eases (AutoShift._ease_margin, _ease).
 * Written for transgen (MIT licence); included by tg_model.c. */
#define TG_SCHED_TSTRIDE 12 /* numbers per template (transgen.fmu.data._schedule) */
#if TG_SCHEDULE

/* numpy.interp's arithmetic (simulator: interp.interp_like_numpy) */
static double tg_interp_numpy(double x, const double *xs, const double *ys, int n) {
    if (x != x) return x;
    if (x < xs[0]) return ys[0];
    if (x >= xs[n - 1]) return ys[n - 1];
    int i = tg_bisect_right(xs, n, x) - 1;
    if (xs[i] == x) return ys[i];
    double slope = (ys[i + 1] - ys[i]) / (xs[i + 1] - xs[i]);
    return slope * (x - xs[i]) + ys[i];
}

static double tg_sched_throttle(const TG *m, double t) {
    return TG_SCHED_THROTTLE_IN >= 0 ? tg_input(m, TG_SCHED_THROTTLE_IN, t) : tg_signal(TG_SCHED_SIG, t);
}

/* the shift line `table` (0 up, 1 down) of shift k at the throttle of time t [rad/s] */
static double tg_sched_line(const TG *m, int table, int k, double t) {
    const double *row = (table ? TG_SCHED_DOWN : TG_SCHED_UP) + k * TG_SCHED_NTHR;
    return tg_interp_numpy(tg_sched_throttle(m, t), TG_SCHED_THR, row, TG_SCHED_NTHR);
}

/* the largest |slip| [rad/s] of the elements in `mask` at the speeds w */
static double tg_sched_slip(const double *w, unsigned mask) {
    double slips[TG_NE + 1], s = 0.0;
    tg_slips(w, slips);
    for (int e = 0; e < TG_NE; e++)
        if ((mask >> e) & 1u) s = fmax(s, fabs(slips[e]));
    return s;
}

/* the three indicators of AutoShift.event_functions (1 where there is no such shift or easing) */
static void tg_sched_indicators(const TG *m, double t, const double *w, double *z) {
    int k = m->gear_k;
    double wait = m->last_shift + TG_SCHED_MIN_INTERVAL - t;
    z[0] = k + 1 < TG_SCHED_NG ? fmax(tg_sched_line(m, 0, k, t) - w[TG_SCHED_OUTPUT], wait) : 1.0;
    z[1] = k > 0 ? fmax(w[TG_SCHED_OUTPUT] - tg_sched_line(m, 1, k - 1, t), wait) : 1.0;
    z[2] = m->ease_mask ? tg_sched_slip(w, m->ease_mask) - m->ease_band : 1.0;
}

/* the points of a spliced apply: (t, its value at t), then the template's points after the first
 * (simulator: schedule._merge, equal times moved 1e-9 s apart) */
static void tg_splice(TG *m, int e, double t, const double *pts, int npts) {
    double value = tg_apply_raw(m, e, t);
    double ts[TG_SPLICE_MAX], vs[TG_SPLICE_MAX];
    int n = 0;
    ts[n] = t;
    vs[n++] = value;
    for (int k = 1; k < npts && n < TG_SPLICE_MAX; k++) {
        ts[n] = pts[2 * k];
        vs[n++] = pts[2 * k + 1];
    }
    /* sorted (stable) as Python's sorted() of (t, v) pairs: by time, then value */
    for (int a = 1; a < n; a++)
        for (int b = a; b > 0 && (ts[b] < ts[b - 1] || (ts[b] == ts[b - 1] && vs[b] < vs[b - 1])); b--) {
            double x = ts[b]; ts[b] = ts[b - 1]; ts[b - 1] = x;
            x = vs[b]; vs[b] = vs[b - 1]; vs[b - 1] = x;
        }
    for (int k = 1; k < n; k++)
        if (ts[k] <= ts[k - 1]) ts[k] = ts[k - 1] + 1e-9;
    m->ov_t0[e] = t;
    m->ov_n[e] = n;
    memcpy(m->ov_t[e], ts, sizeof ts);
    memcpy(m->ov_v[e], vs, sizeof vs);
}

/* ShiftTemplate.oncoming / offgoing of template `s` commanded at t0, as (t, v) pairs */
static int tg_template_points(int s, int oncoming, double t0, double *pts) {
    const double *p = TG_SCHED_TEMPLATES + s * TG_SCHED_TSTRIDE; /* fill_time fill_level ramp_time ramp_end
        hold_time final_time offgoing_delay offgoing_level offgoing_ramp ease_slip ease_time ease_level */
    if (oncoming) {
        double t1 = t0 + p[0], t2 = t1 + p[2], t3 = t2 + p[4];
        double q[12] = {t0, 0.0, t0 + 1e-6, p[1], t1, p[1], t2, p[3], t3, p[3], t3 + p[5], 1.0};
        memcpy(pts, q, sizeof q);
        return 6;
    }
    double t1 = t0 + p[0] + p[6];
    double q[6] = {t1, 1.0, t1 + 1e-6, p[7], t1 + p[8], 0.0};
    memcpy(pts, q, sizeof q);
    return 3;
}

/* AutoShift.fire: the shift `kind` (0 up, 1 down) at t, when min_interval allows it */
static void tg_sched_fire(TG *m, int kind, double t) {
    if (m->last_shift + TG_SCHED_MIN_INTERVAL - t > 1e-9 * fmax(1.0, fabs(t))) return;
    int shift = kind == 0 ? m->gear_k : TG_SCHED_NG - 1 + m->gear_k - 1; /* index into the shift tables */
    double pts[12];
    for (int side = 0; side < 2; side++) { /* oncoming, then offgoing */
        int n = tg_template_points(TG_SCHED_TEMPLATE_OF[shift], side == 0, t, pts);
        unsigned mask = side == 0 ? TG_SCHED_ON[shift] : TG_SCHED_OFF[shift];
        for (int e = 0; e < TG_NE; e++)
            if ((mask >> e) & 1u) tg_splice(m, e, t, pts, n);
    }
    m->ease_mask = 0u; /* a shift still waiting for its ease slip is not eased */
    const double *p = TG_SCHED_TEMPLATES + TG_SCHED_TEMPLATE_OF[shift] * TG_SCHED_TSTRIDE;
    if (p[9] > 0.0 && TG_SCHED_ON[shift]) {
        double slip = tg_sched_slip(m->w, TG_SCHED_ON[shift]);
        if (slip > 0.0) {
            m->ease_mask = TG_SCHED_ON[shift];
            m->ease_template = TG_SCHED_TEMPLATE_OF[shift];
            m->ease_band = p[9] * slip;
            m->ease_t0 = t;
        }
    }
    m->gear_k += kind == 0 ? 1 : -1;
    m->last_shift = t;
}

/* AutoShift._ease (ShiftTemplate.eased): the waiting shift's oncoming apply from its value at t to
 * ease_level over ease_time, held until the template's hold ends (at least ease_time after), then
 * to full over final_time */
static void tg_sched_ease(TG *m, double t) {
    const double *p = TG_SCHED_TEMPLATES + m->ease_template * TG_SCHED_TSTRIDE;
    double ramp = fmax(p[10], 1e-6);
    double t_hold = fmax(m->ease_t0 + p[0] + p[2] + p[4], t + 2.0 * ramp);
    double pts[8] = {t, 0.0, t + ramp, p[11], t_hold, p[11], t_hold + fmax(p[5], 1e-6), 1.0};
    for (int e = 0; e < TG_NE; e++)
        if ((m->ease_mask >> e) & 1u) tg_splice(m, e, t, pts, 4);
    m->ease_mask = 0u;
}

/* at an event: the shift whose indicator reached zero is commanded */
static void tg_sched_event(TG *m) {
    double z[3];
    tg_sched_indicators(m, m->t, m->w, z);
    if (z[0] <= 0.0) tg_sched_fire(m, 0, m->t);
    else if (z[1] <= 0.0) tg_sched_fire(m, 1, m->t);
    else if (z[2] <= 0.0) tg_sched_ease(m, m->t);
}
#endif
