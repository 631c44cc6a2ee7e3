/* transgen FMU runtime: the transmission's hybrid dynamics, independent of the FMI version.
 *
 * Written for transgen (MIT licence). The model data (per-mode matrices, elements, groups,
 * signals) come from the generated "model_data.h"; the rules here are those of the simulator
 * (transgen.sim.transmission.Transmission.decide, transgen.sim.switching): the same tests in the
 * same order, so that the FMU takes the same decisions on the same states (tested from Python
 * through tg_test_decide).
 *
 * States: the speeds w [rad/s] of every link (a fixed vector over all modes). In a mode (a set of
 * locked elements) the speeds are w = C q with dq/dt = B u, so dw/dt = C B u; u = the external
 * torques (T_in, T_out, named loads) plus the torques of the slipping elements, whose slip
 * direction is a discrete state changed only at events.
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "model_data.h"

#define TG_APPLY_THRESHOLD 1e-12
#define TG_APPLY_LOOKAHEAD 1e-9
#define TG_APPLY_HYSTERESIS 1e-9
#define TG_FRICTION 0
#define TG_ONEWAY 1
#define TG_DOG 2
#define TG_MAX_CANDIDATES 64
#define TG_MAX_SAME_TIME 50
#define TG_SPLICE_MAX 8
#ifndef TG_SCHEDULE
#define TG_SCHEDULE 0
#endif
#define TG_NZ (2 * TG_NE + 3 * TG_SCHEDULE) /* event indicators */

typedef struct {
    double t;
    double w[TG_NX];            /* link speeds, then the driveline's twist and vehicle-side speed */
    double in[TG_NIN];          /* the inputs as set by the importer */
    int in_set[TG_NIN];         /* set at least once: the built-in signal is no longer used */
    int in_changed;             /* an input changed since the last decision (co-simulation) */
    double stat[TG_NE + 1];     /* static capacities [N*m] (tunable) */
    double dyn[TG_NE + 1];      /* dynamic capacities [N*m] (tunable) */
    double slip_tol_rel;        /* the simulator's slip_tol (relative) */
    double cs_step;             /* the largest internal step of co-simulation [s] */
    unsigned locked;            /* bit i: element i locked */
    int dirs[TG_NE + 1];        /* slip direction of each element (+1/-1/0), a discrete state */
    int apply_dir[TG_NE + 1];   /* +1: applied just after the segment start, -1: released */
    int started;                /* the first decision is made */
    int fresh;                  /* decided at this time and state, nothing integrated since */
    double tol;                 /* slip tolerance of the segment [rad/s] */
    double t_sig, t_stop;       /* where the segment evaluates its signals: [t_sig, left_of(t_stop)] */
    double t_change;            /* time of the last change of the locked elements [s] */
    double t_decided;           /* time of the last decision [s] */
    int last_forced[TG_NE + 1]; /* the forced slip directions of that decision */
    double same_time;
    int same_count;
    long n_events;
    int gear_k;                 /* the schedule's gear (position in its order) */
    double last_shift;          /* when it commanded the last shift [s] */
    unsigned ease_mask;         /* the oncoming elements of a shift waiting for its ease slip (0: none) */
    int ease_template;          /* that shift's template */
    double ease_band, ease_t0;  /* its ease slip [rad/s] and command time [s] */
    double J[TG_NL + 1];        /* link inertias [kg*m^2] (tunable) */
    double par[TG_NPAR + 1];    /* driveline and engine parameters (tunable, see model_data.h) */
    double B[TG_NB];            /* every mode's dq/dt = B u, from the inertias (tg_matrices) */
    double D[TG_ND];            /* every mode's locked torques = D u */
    double ov_t0[TG_NE + 1];    /* an element's apply replaced by a shift from this time on */
    int ov_n[TG_NE + 1];
    double ov_t[TG_NE + 1][TG_SPLICE_MAX], ov_v[TG_NE + 1][TG_SPLICE_MAX];
    char msg[1024];
} TG;

/* ----------------------------------------------------------------------- small helpers */

static double tg_left_of(double t) { return isfinite(t) ? nextafter(t, -INFINITY) : t; }

static double tg_max_abs(const double *x, int n) {
    double m = 0.0;
    for (int i = 0; i < n; i++) m = fmax(m, fabs(x[i]));
    return m;
}

static int tg_sign(double x) { return (x > 0) - (x < 0); }

/* Python's bisect_right: the first index with xs[i] > x */
static int tg_bisect_right(const double *xs, int n, double x) {
    int lo = 0, hi = n;
    while (lo < hi) {
        int mid = (lo + hi) / 2;
        if (x < xs[mid]) hi = mid; else lo = mid + 1;
    }
    return lo;
}

static double tg_table(double t, const double *ts, const double *vs, int n) {
    if (t < ts[0]) return vs[0];
    if (t >= ts[n - 1]) return vs[n - 1];
    int i = tg_bisect_right(ts, n, t) - 1;
    return vs[i] + (vs[i + 1] - vs[i]) * (t - ts[i]) / (ts[i + 1] - ts[i]);
}

static double tg_ramp(double t, double t0, double t1, double v0, double v1) {
    if (t <= t0) return v0;
    if (t >= t1) return v1;
    return v0 + (v1 - v0) * (t - t0) / (t1 - t0);
}

/* the periodic signals (simulator: signals._period_start, pulse_value, periodic_phase): the
 * k of the period [first + k*period, first + (k+1)*period) holding t, corrected for round-off;
 * every period start is computed as first + k*period, as the simulator's breakpoints are */
static double tg_period_k(double t, double first, double period) {
    double k = floor((t - first) / period);
    while (first + k * period > t) k -= 1.0;
    while (first + (k + 1.0) * period <= t) k += 1.0;
    return k;
}

static double tg_period_start(double t, double first, double period) {
    return first + tg_period_k(t, first, period) * period;
}

static double tg_pulse(double t, double t0, double width, double low, double high, double period) {
    double start = (period == 0.0 || t < t0) ? t0 : tg_period_start(t, t0, period);
    return (start <= t && t < start + width) ? high : low;
}

/* the first edge of a pulse (train) after t (signals.Pulse.breakpoints: s and s + width) */
static double tg_pulse_next_edge(double t, double t0, double width, double period) {
    if (t < t0) return t0;
    if (period == 0.0) return t < t0 + width ? t0 + width : INFINITY;
    double k = tg_period_k(t, t0, period);
    if (t < t0 + k * period + width) return t0 + k * period + width;
    return t0 + (k + 1.0) * period;
}

static int tg_bisect_left(const double *xs, int n, double x) {
    int lo = 0, hi = n;
    while (lo < hi) {
        int mid = (lo + hi) / 2;
        if (xs[mid] < x) lo = mid + 1; else hi = mid;
    }
    return lo;
}

static double tg_periodic(double t, const double *ts, const double *vs, int n, double period) {
    double first = ts[0], u = first + (t - tg_period_start(t, first, period));
    double big = fmax(fabs(t), fabs(first) + period), tol = 8.0 * (nextafter(big, INFINITY) - big);
    int j = tg_bisect_left(ts, n, u - tol);
    if (j < n && fabs(ts[j] - u) <= tol) u = ts[j];
    return tg_table(u, ts, vs, n);
}

/* the first breakpoint of a periodic table after t: a table time (as an offset from its first
 * time, within the period) or the next period's start (signals.Periodic.breakpoints) */
static double tg_periodic_next_edge(double t, const double *ts, const double *offsets, int n_off, double period) {
    double k = tg_period_k(t, ts[0], period);
    for (int j = 0; j < n_off; j++)
        if (ts[0] + k * period + offsets[j] > t) return ts[0] + k * period + offsets[j];
    return ts[0] + (k + 1.0) * period;
}

/* the built-in signals: tg_signal(k, t), generated */
#include "model_signals.h"

/* ----------------------------------------------------------------------- inputs and elements */

static double tg_input(const TG *m, int k, double t) {
    if (m->in_set[k] || TG_IN_SIG[k] < 0) return m->in[k];
    return tg_signal(TG_IN_SIG[k], t);
}

static double tg_apply_raw(const TG *m, int e, double t) {
    int k = TG_APPLY_IN[e];
    if (k < 0) return 0.0;
    if (m->ov_n[e] && t >= m->ov_t0[e] && !m->in_set[k]) return tg_table(t, m->ov_t[e], m->ov_v[e], m->ov_n[e]);
    return tg_input(m, k, t);
}

static double tg_apply_at(const TG *m, int e, double t) {
    return TG_KIND[e] == TG_ONEWAY ? 1.0 : fmax(0.0, tg_apply_raw(m, e, t));
}

static int tg_applied_just_after(const TG *m, int e, double t) {
    return tg_apply_raw(m, e, t + TG_APPLY_LOOKAHEAD * fmax(1.0, fabs(t))) > TG_APPLY_THRESHOLD;
}

static int tg_applied_after(const TG *m, int e, double t) {
    return TG_KIND[e] == TG_ONEWAY || tg_apply_at(m, e, t) > 0.0 || tg_applied_just_after(m, e, t);
}

static double tg_static_capacity(const TG *m, int e, double t) {
    double a = tg_apply_at(m, e, t);
    if (TG_KIND[e] == TG_DOG) return a > TG_APPLY_THRESHOLD ? m->stat[e] : 0.0;
    return TG_KIND[e] == TG_ONEWAY ? INFINITY : m->stat[e] * a;
}

/* signed capacity of a slipping element (0 for one-way, dog, no direction); stat: static */
static double tg_signed_capacity(const TG *m, int e, int direction, int stat) {
    if (TG_KIND[e] != TG_FRICTION || direction == 0) return 0.0;
    double base = stat ? m->stat[e] : m->dyn[e];
    if (TG_ENERGIZING[e] && direction == TG_ENERGIZING[e]) base *= TG_GAIN[e];
    return base * direction;
}

static double tg_slip_torque(const TG *m, int e, double t, int direction, int stat) {
    double scale = tg_signed_capacity(m, e, direction, stat);
    double a = tg_apply_at(m, e, t);
    if (scale == 0.0 || a <= 0.0) return 0.0;
    return scale * a;
}

static void tg_slips(const double *w, double *slips) {
    for (int e = 0; e < TG_NE; e++) {
        double s = 0.0;
        for (int k = 0; k < TG_NL; k++) s += TG_P[e * TG_NL + k] * w[k];
        slips[e] = s;
    }
}

/* the driveline and the engine map with its converter */
#include "tg_components.c"
#include "tg_schedule.c"

/* the external torques at (t, w): the inputs, and the driveline's shaft torque as T_out */
static void tg_external(const TG *m, double t, const double *w, double *u) {
    for (int j = 0; j < TG_NU; j++) u[j] = 0.0;
    for (int k = 0; k < TG_NIN; k++)
        if (TG_IN_UCOL[k] >= 0) u[TG_IN_UCOL[k]] += tg_input(m, k, t);
#if TG_DRIVELINE
    u[TG_DL_UCOL] += tg_shaft_torque(m, w);
#endif
#if TG_ENGINE
    u[TG_ENG_UCOL] += tg_engine_input(m, t, w);
#endif
    (void)w;
}

/* ----------------------------------------------------------------------- modes */

#define MODE_C(mask) (TG_C + TG_MODE_C_OFF[mask])

/* every mode's B and D from the link inertias: tg_matrices */
#include "tg_matrices.c"

/* rates dq/dt = B u, slip accelerations P C B u, link accelerations C B u */
static void tg_mode_rates(const TG *m, unsigned mask, const double *u, double *dw) {
    int dof = TG_MODE_DOF[mask];
    double dq[TG_NL + 1];
    const double *B = m->B + TG_MODE_B_OFF[mask], *C = MODE_C(mask);
    for (int r = 0; r < dof; r++) {
        double s = 0.0;
        for (int j = 0; j < TG_NU; j++) s += B[r * TG_NU + j] * u[j];
        dq[r] = s;
    }
    for (int k = 0; k < TG_NL; k++) {
        double s = 0.0;
        for (int r = 0; r < dof; r++) s += C[k * dof + r] * dq[r];
        dw[k] = s;
    }
}

static void tg_mode_torques(const TG *m, unsigned mask, const double *u, double *torques) {
    int n = TG_MODE_NROW[mask];
    const double *D = m->D + TG_MODE_D_OFF[mask];
    for (int r = 0; r < n; r++) {
        double s = 0.0;
        for (int j = 0; j < TG_NU; j++) s += D[r * TG_NU + j] * u[j];
        torques[r] = s;
    }
}

static double tg_group_margin(double lo, double hi, double friction, double torque) {
    return fmin(hi - torque, torque - lo) + 1e-9 * (1.0 + friction + fabs(torque));
}

static void tg_holding_limits(const TG *m, unsigned mask, int row, double t, double *lo, double *hi) {
    int o = TG_MODE_ROW_OFF[mask] + row;
    *lo = *hi = 0.0;
    for (int k = 0; k < TG_ROW_COUNT[o]; k++) {
        int e = TG_ROW_MEMBERS[TG_ROW_START[o] + k], sign = TG_ROW_SIGNS[TG_ROW_START[o] + k];
        if (TG_KIND[e] == TG_ONEWAY) {
            if (-TG_FREE[e] * sign > 0) *hi = INFINITY; else *lo = -INFINITY;
        } else {
            double c = tg_static_capacity(m, e, t);
            *lo -= c;
            *hi += c;
        }
    }
}

/* how far row `row` of the mode `mask` is inside its holding range (>= 0: it holds) */
static double tg_holding_margin(const TG *m, unsigned mask, int row, double t, double torque) {
    int o = TG_MODE_ROW_OFF[mask] + row;
    if (TG_ROW_COUNT[o] == 1) {
        int e = TG_ROW_MEMBERS[TG_ROW_START[o]];
        double capacity = tg_static_capacity(m, e, t);
        if (TG_KIND[e] == TG_DOG && isinf(capacity)) return 1.0;
        if (TG_KIND[e] == TG_ONEWAY) return 1e-9 * (1.0 + fabs(torque)) - TG_FREE[e] * torque;
        return capacity * (1.0 + 1e-9) + 1e-9 - fabs(torque);
    }
    double lo, hi, friction = 0.0;
    tg_holding_limits(m, mask, row, t, &lo, &hi);
    for (int k = 0; k < TG_ROW_COUNT[o]; k++) {
        int e = TG_ROW_MEMBERS[TG_ROW_START[o] + k];
        if (TG_KIND[e] != TG_ONEWAY) friction += tg_static_capacity(m, e, t);
    }
    return tg_group_margin(lo, hi, friction, torque);
}

#include "tg_decide.c"

/* ----------------------------------------------------------------------- segments */

/* where a segment starting at t evaluates its signals at its start (simulator: signal_time) */
static double tg_signal_time(const TG *m, double t) {
    double after = t + 1e-12 * fmax(1.0, fabs(t)), best = t;
    for (int k = 0; k < TG_NBP; k++)
        if (TG_BP[k] > t && TG_BP[k] <= after) best = TG_BP[k];
    for (double edge = tg_signal_next_edge(t); edge <= after; edge = tg_signal_next_edge(edge)) best = fmax(best, edge);
    /* (each edge is after the one before: tg_signal_next_edge(x) > x) */
    for (int e = 0; e < TG_NE; e++) /* the breakpoints of the applies a shift replaced */
        for (int k = 0; k < m->ov_n[e]; k++)
            if (m->ov_t[e][k] > t && m->ov_t[e][k] <= after) best = fmax(best, m->ov_t[e][k]);
    return best;
}

static double tg_next_stop(const TG *m, double t) {
    double after = t + 1e-12 * fmax(1.0, fabs(t)), stop = INFINITY;
    for (int k = 0; k < TG_NBP; k++)
        if (TG_BP[k] > after) { stop = TG_BP[k]; break; }
    stop = fmin(stop, tg_signal_next_edge(after)); /* the periodic signals' edges, without end */
    for (int e = 0; e < TG_NE; e++)
        for (int k = 0; k < m->ov_n[e]; k++)
            if (m->ov_t[e][k] > after && m->ov_t[e][k] < stop) stop = m->ov_t[e][k];
    return stop;
}

/* the signals' time of a point of the current segment */
static double tg_seg_time(const TG *m, double t) {
    double left = tg_left_of(m->t_stop);
    if (t > left) t = left;
    if (t < m->t_sig) t = m->t_sig;
    return t;
}

/* the input vector of the current mode at (t, w): external torques plus slipping elements */
static void tg_inputs(const TG *m, double t, const double *w, double *u) {
    double ts = tg_seg_time(m, t);
    tg_external(m, ts, w, u);
    for (int e = 0; e < TG_NE; e++)
        if (!((m->locked >> e) & 1u) && TG_KIND[e] == TG_FRICTION && m->dirs[e] != 0)
            u[TG_UCOL[e]] += tg_slip_torque(m, e, ts, m->dirs[e], 0);
}

static void tg_derivatives(const TG *m, double t, const double *w, double *dw) {
    double u[TG_NU + 1];
    tg_inputs(m, t, w, u);
    tg_mode_rates(m, m->locked, u, dw);
#if TG_ENGINE == 2
    {
        double pump, turbine;
        tg_converter(w[TG_ENG_X], w[TG_ENG_LINK], &pump, &turbine);
        dw[TG_ENG_X] = (tg_engine_torque(m, tg_seg_time(m, t), w[TG_ENG_X]) - pump) / TG_ENG_J;
    }
#endif
#if TG_DRIVELINE
    dw[TG_DL_X] = w[TG_DL_OUTPUT] - w[TG_DL_X + 1];
    dw[TG_DL_X + 1] = (tg_shaft_torque(m, w) - tg_road_torque(m, w[TG_DL_X + 1])) / tg_vehicle_inertia(m);
#endif
}

/* two indicators per element: [2e] slip (slipping) or holding margin (locked, the row's
 * representative), [2e+1] its apply crossing the threshold (slipping friction elements) */
static void tg_indicators(const TG *m, double t, const double *w, double *z) {
    double u[TG_NU + 1], rows[TG_NE + 1], slips[TG_NE + 1];
    double ts = tg_seg_time(m, t);
    tg_inputs(m, t, w, u);
    tg_mode_torques(m, m->locked, u, rows);
    tg_slips(w, slips);
    for (int e = 0; e < TG_NE; e++) {
        z[2 * e] = 1.0;
        z[2 * e + 1] = 1.0;
        if ((m->locked >> e) & 1u) {
            int nrow = TG_MODE_NROW[m->locked];
            for (int r = 0; r < nrow; r++)
                if (TG_ROW_REP[TG_MODE_ROW_OFF[m->locked] + r] == e) z[2 * e] = tg_holding_margin(m, m->locked, r, ts, rows[r]);
        } else {
            if (m->dirs[e] != 0) z[2 * e] = m->dirs[e] * slips[e] + 1e-3 * m->tol;
            if (TG_KIND[e] != TG_ONEWAY && TG_APPLY_IN[e] >= 0)
                z[2 * e + 1] = m->apply_dir[e] * (tg_apply_raw(m, e, ts) - TG_APPLY_THRESHOLD) + TG_APPLY_HYSTERESIS;
        }
    }
#if TG_SCHEDULE
    tg_sched_indicators(m, t, w, z + 2 * TG_NE);
#endif
}

/* The decision at an event or a breakpoint at time m->t (simulate_switching's loop body): the
 * torque events that fired give the forced slip directions, the new mode is decided, the speeds
 * are projected onto it. Returns 0, or nonzero with m->msg. */
static int tg_event(TG *m) {
    int forced[TG_NE + 1];
    memset(forced, 0, sizeof forced);
    if (m->started) {
        double u[TG_NU + 1], rows[TG_NE + 1];
        double ts = tg_seg_time(m, m->t);
        tg_inputs(m, m->t, m->w, u);
        tg_mode_torques(m, m->locked, u, rows);
        int nrow = TG_MODE_NROW[m->locked];
        for (int r = 0; r < nrow; r++) {
            if (tg_holding_margin(m, m->locked, r, ts, rows[r]) > 0.0) continue;
            double lo, hi;
            tg_holding_limits(m, m->locked, r, ts, &lo, &hi);
            int side = hi - rows[r] <= rows[r] - lo ? 1 : -1;
            int o = TG_MODE_ROW_OFF[m->locked] + r;
            for (int k = 0; k < TG_ROW_COUNT[o]; k++)
                forced[TG_ROW_MEMBERS[TG_ROW_START[o] + k]] = side * TG_ROW_SIGNS[TG_ROW_START[o] + k];
        }
    }
#if TG_SCHEDULE
    if (m->started) tg_sched_event(m);
#endif
    double t = m->t;
    /* decided again at the same instant (an input changed; the importer's time may differ from the
     * located event's by round-off): the torque events that fired then still decide their elements */
    if (m->started && fabs(t - m->t_decided) <= 1e-12 * fmax(1.0, fabs(t)))
        for (int e = 0; e < TG_NE; e++)
            if (!forced[e]) forced[e] = m->last_forced[e];
    if (fabs(t - m->same_time) < 1e-9 * fmax(1.0, fabs(t))) {
        if (++m->same_count > TG_MAX_SAME_TIME) {
            char names[256];
            tg_names(m->locked, names, sizeof names);
            snprintf(m->msg, sizeof m->msg, "t=%.9g s: mode chattering (Zeno behaviour) in mode %s", t, names);
            return 1;
        }
    } else {
        m->same_time = t;
        m->same_count = 0;
    }
    double t_sig = tg_signal_time(m, t);
    double u_ext[TG_NU + 1];
    tg_external(m, t_sig, m->w, u_ext);
    double tol = fmax(1e-9, m->slip_tol_rel * fmax(1.0, tg_max_abs(m->w, TG_NL)));
    unsigned locked;
    int dirs[TG_NE + 1];
    if (tg_decide(m, t_sig, m->w, u_ext, tol, forced, m->started ? m->locked : 0u, m->started ? m->dirs : NULL,
                  &locked, dirs))
        return 1;
    /* project onto the mode, and the slips at zero onto exactly zero */
    int dof = TG_MODE_DOF[locked];
    const double *C = MODE_C(locked);
    const int *coords = TG_COORDS + TG_MODE_COORD_OFF[locked];
    double q[TG_NL + 1], basis[TG_NE + 1][TG_NL + 1];
    for (int r = 0; r < dof; r++) q[r] = m->w[coords[r]];
    double cmax = fmax(1.0, tg_max_abs(C, TG_NL * dof));
    int nb = 0;
    for (int e = 0; e < TG_NE; e++) {
        if ((locked >> e) & 1u) continue;
        double s = 0.0;
        for (int k = 0; k < TG_NL; k++) s += TG_P[e * TG_NL + k] * m->w[k];
        if (fabs(s) > tol) continue;
        double a[TG_NL + 1], norm = 0.0;
        for (int r = 0; r < dof; r++) {
            a[r] = 0.0;
            for (int k = 0; k < TG_NL; k++) a[r] += TG_P[e * TG_NL + k] * C[k * dof + r];
            norm += a[r] * a[r];
        }
        if (sqrt(norm) <= 1e-9 * cmax) continue;
        for (int b = 0; b < nb; b++) { /* Gram-Schmidt: the row space of the rows at zero */
            double dot = 0.0;
            for (int r = 0; r < dof; r++) dot += a[r] * basis[b][r];
            for (int r = 0; r < dof; r++) a[r] -= dot * basis[b][r];
        }
        norm = 0.0;
        for (int r = 0; r < dof; r++) norm += a[r] * a[r];
        norm = sqrt(norm);
        if (norm <= 1e-9 * cmax) continue;
        for (int r = 0; r < dof; r++) basis[nb][r] = a[r] / norm;
        nb++;
    }
    for (int b = 0; b < nb; b++) {
        double dot = 0.0;
        for (int r = 0; r < dof; r++) dot += q[r] * basis[b][r];
        for (int r = 0; r < dof; r++) q[r] -= dot * basis[b][r];
    }
    for (int k = 0; k < TG_NL; k++) {
        double s = 0.0;
        for (int r = 0; r < dof; r++) s += C[k * dof + r] * q[r];
        m->w[k] = s;
    }
    if (!m->started || locked != m->locked) m->t_change = t;
    m->t_decided = t;
    memcpy(m->last_forced, forced, sizeof m->last_forced);
    m->locked = locked;
    for (int e = 0; e < TG_NE; e++) {
        m->dirs[e] = dirs[e];
        m->apply_dir[e] = tg_applied_just_after(m, e, t_sig) ? 1 : -1;
    }
    m->tol = tol;
    m->t_sig = t_sig;
    m->t_stop = tg_next_stop(m, t);
    m->started = 1;
    m->fresh = 1;
    m->in_changed = 0;
    m->n_events++;
    return 0;
}

static int tg_start(TG *m) { return m->started ? 0 : tg_event(m); }

/* a saved state (FMI's get/set/serialize FMU state) is the plain struct TG, copied */
static void *tg_state_save(const TG *m, void *old) {
    TG *copy = old ? (TG *)old : (TG *)malloc(sizeof(TG));
    if (copy) *copy = *m;
    return copy;
}

static void *tg_state_from_bytes(const void *bytes, size_t size) {
    TG *copy = size == sizeof(TG) ? (TG *)malloc(sizeof(TG)) : NULL;
    if (copy) memcpy(copy, bytes, sizeof(TG));
    return copy;
}

/* After the importer changed an input or a parameter between steps: whether the current mode
 * must be decided anew (as at an event), i.e. whether a locked row's torque is now outside its
 * holding range or a slipping element's apply crossed zero. Otherwise the segment goes on, as the
 * simulator's does between breakpoints (the speeds, hence the slips, do not jump). */
static int tg_input_event_needed(const TG *m) {
    double u[TG_NU + 1], rows[TG_NE + 1];
    double ts = tg_seg_time(m, m->t);
    tg_inputs(m, m->t, m->w, u);
    tg_mode_torques(m, m->locked, u, rows);
    for (int r = 0; r < TG_MODE_NROW[m->locked]; r++)
        if (tg_holding_margin(m, m->locked, r, ts, rows[r]) <= 0.0) return 1;
    for (int e = 0; e < TG_NE; e++)
        if (!((m->locked >> e) & 1u) && TG_KIND[e] != TG_ONEWAY
            && (tg_apply_raw(m, e, ts) > TG_APPLY_THRESHOLD) != (m->apply_dir[e] > 0)) return 1;
    return 0;
}

/* ----------------------------------------------------------------------- outputs */

/* each element's torque [N*m] in its own direction (simulator: the split rule of locked groups) */
static void tg_element_torques(const TG *m, double *out) {
    double u[TG_NU + 1], rows[TG_NE + 1];
    double ts = tg_seg_time(m, m->t);
    tg_inputs(m, m->t, m->w, u);
    tg_mode_torques(m, m->locked, u, rows);
    for (int e = 0; e < TG_NE; e++)
        out[e] = (m->locked >> e) & 1u ? 0.0 : tg_slip_torque(m, e, ts, m->dirs[e], 0);
    int nrow = TG_MODE_NROW[m->locked];
    for (int r = 0; r < nrow; r++) {
        int o = TG_MODE_ROW_OFF[m->locked] + r, n = TG_ROW_COUNT[o];
        const int *mem = TG_ROW_MEMBERS + TG_ROW_START[o], *sg = TG_ROW_SIGNS + TG_ROW_START[o];
        double tau = rows[r];
        if (n == 1) {
            out[mem[0]] = tau;
            continue;
        }
        double total = 0.0;
        int nfr = 0;
        for (int k = 0; k < n; k++)
            if (TG_KIND[mem[k]] == TG_FRICTION) {
                total += m->stat[mem[k]] * tg_apply_at(m, mem[k], ts);
                nfr++;
            }
        double carried = fmax(-total, fmin(total, tau)), rest = tau - carried;
        for (int direction = 1; direction >= -1; direction -= 2) {
            int carriers = 0;
            for (int k = 0; k < n; k++)
                carriers += (TG_KIND[mem[k]] == TG_ONEWAY && -TG_FREE[mem[k]] * sg[k] == direction) || TG_KIND[mem[k]] == TG_DOG;
            double part = rest * direction > 0 ? rest : 0.0;
            for (int k = 0; k < n; k++)
                if ((TG_KIND[mem[k]] == TG_ONEWAY && -TG_FREE[mem[k]] * sg[k] == direction) || TG_KIND[mem[k]] == TG_DOG)
                    out[mem[k]] += sg[k] * part / carriers;
            if (!carriers) carried += part;
        }
        if (nfr) {
            for (int k = 0; k < n; k++)
                if (TG_KIND[mem[k]] == TG_FRICTION) {
                    double c = m->stat[mem[k]] * tg_apply_at(m, mem[k], ts);
                    double share = total > 0 ? c / total : 1.0 / nfr;
                    out[mem[k]] += sg[k] * carried * share;
                }
        } else {
            out[mem[0]] += carried;
        }
    }
}

/* ----------------------------------------------------------------------- co-simulation */

static void tg_rk4(const TG *m, double t, const double *w, double h, double *out) {
    double k1[TG_NX + 1], k2[TG_NX + 1], k3[TG_NX + 1], k4[TG_NX + 1], y[TG_NX + 1];
    tg_derivatives(m, t, w, k1);
    for (int k = 0; k < TG_NX; k++) y[k] = w[k] + 0.5 * h * k1[k];
    tg_derivatives(m, t + 0.5 * h, y, k2);
    for (int k = 0; k < TG_NX; k++) y[k] = w[k] + 0.5 * h * k2[k];
    tg_derivatives(m, t + 0.5 * h, y, k3);
    for (int k = 0; k < TG_NX; k++) y[k] = w[k] + h * k3[k];
    tg_derivatives(m, t + h, y, k4);
    for (int k = 0; k < TG_NX; k++) out[k] = w[k] + h / 6.0 * (k1[k] + 2 * k2[k] + 2 * k3[k] + k4[k]);
}

static int tg_crossed(const double *z0, const double *z1) {
    for (int k = 0; k < TG_NZ; k++)
        if (z0[k] > 0.0 && z1[k] <= 0.0) return 1;
    return 0;
}

/* Integrate from m->t to t_end: fourth-order steps of at most m->cs_step between the segment's
 * stops, each event located by bisection on the step (the indicators of the step's end); at each
 * event and breakpoint the mode decision. Returns 0, or nonzero with m->msg. */
static int tg_cs_step(TG *m, double t_end) {
    if (tg_start(m)) return 1;
    if (m->in_changed) {
        m->in_changed = 0;
        if (tg_input_event_needed(m) && tg_event(m)) return 1;
    }
    while (m->t < t_end - 1e-13 * fmax(1.0, fabs(t_end))) {
        double t1 = fmin(t_end, m->t_stop);
        int at_stop = m->t_stop <= t_end;
        int event = 0;
        while (m->t < t1 && !event) {
            double h = fmin(m->cs_step, t1 - m->t);
            if (t1 - (m->t + h) < 1e-12 * fmax(1.0, fabs(t1))) h = t1 - m->t;
            double z0[TG_NZ + 1], z1[TG_NZ + 1], w1[TG_NX + 1];
            tg_indicators(m, m->t, m->w, z0);
            tg_rk4(m, m->t, m->w, h, w1);
            double tn = m->t + h >= t1 ? t1 : m->t + h;
            tg_indicators(m, tn, w1, z1);
            if (tg_crossed(z0, z1)) {
                double lo = 0.0, hi = h;
                double wh[TG_NX + 1];
                memcpy(wh, w1, sizeof wh);
                for (int it = 0; it < 200 && hi - lo > 1e-14 * fmax(1.0, fabs(m->t)); it++) {
                    double mid = 0.5 * (lo + hi), wm[TG_NX + 1], zm[TG_NZ + 1];
                    tg_rk4(m, m->t, m->w, mid, wm);
                    tg_indicators(m, m->t + mid, wm, zm);
                    if (tg_crossed(z0, zm)) {
                        hi = mid;
                        memcpy(wh, wm, sizeof wh);
                    } else {
                        lo = mid;
                    }
                }
                m->t = hi >= h ? tn : m->t + hi;
                memcpy(m->w, wh, sizeof m->w);
                event = 1;
            } else {
                m->t = tn;
                memcpy(m->w, w1, sizeof m->w);
            }
        }
        if (event || (at_stop && m->t >= m->t_stop)) {
            if (tg_event(m)) return 1;
        }
    }
    m->t = t_end;
    return 0;
}

/* ----------------------------------------------------------------------- instance */

static void tg_reset(TG *m) {
    memset(m, 0, sizeof *m);
    for (int k = 0; k < TG_NX; k++) m->w[k] = TG_W0[k];
    for (int k = 0; k < TG_NIN; k++) m->in[k] = TG_IN_START[k];
    for (int e = 0; e < TG_NE; e++) {
        m->stat[e] = TG_STATIC0[e];
        m->dyn[e] = TG_DYNAMIC0[e];
    }
    for (int k = 0; k < TG_NL; k++) m->J[k] = TG_J0[k];
    for (int k = 0; k < TG_NPAR; k++) m->par[k] = TG_PAR0[k];
    (void)tg_matrices(m); /* the exported inertias: the simulator's own modes */
    m->slip_tol_rel = TG_SLIP_TOL;
    m->cs_step = TG_CS_STEP;
    m->t_stop = INFINITY;
    m->same_time = -INFINITY;
#if TG_SCHEDULE
    m->gear_k = TG_SCHED_GEAR0;
#endif
    m->last_shift = -1e9;
}

static int tg_mode_index(const TG *m) { return TG_MODE_INDEX[m->locked]; }

static int tg_gear(const TG *m) { return TG_GEAR_OF_MODE[m->locked]; }

/* the values by value reference: tg_get_real, tg_set_real, ... */
#include "tg_values.c"

/* ----------------------------------------------------------------------- test entry point */

/* The decision alone, for the tests: at (t, w) with every input at its built-in signal or its
 * start value; previous < 0: the first decision (no previous mode, no sliding directions).
 * Returns 0 with *locked and dirs[], or 1 (no unique mode). */
#ifdef _WIN32
__declspec(dllexport)
#else
__attribute__((visibility("default")))
#endif
int tg_test_decide(double t, const double *w, const double *inputs, int previous, const int *sliding,
                   const int *forced, double slip_tol, unsigned *locked, int *dirs) {
    static TG m;
    tg_reset(&m);
    for (int k = 0; k < TG_NIN; k++) {
        m.in[k] = inputs[k];
        m.in_set[k] = 1;
    }
    double u_ext[TG_NU + 1];
    for (int k = 0; k < TG_NL; k++) m.w[k] = w[k];
    tg_external(&m, t, m.w, u_ext);
    return tg_decide(&m, t, w, u_ext, slip_tol, forced, previous < 0 ? 0u : (unsigned)previous,
                     previous < 0 ? NULL : sliding, locked, dirs);
}
