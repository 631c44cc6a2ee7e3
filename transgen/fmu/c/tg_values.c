/* transgen FMU runtime: the variables by value reference (see model_data.h). Written for
 * transgen (MIT licence); included by tg_model.c. */
/* value references, see model_data.h */
static int tg_get_real(TG *m, unsigned vr, double *value) {
    if (vr < TG_VR_DER) { *value = m->w[vr]; return 0; }
    if (tg_start(m)) return 1;
    if (vr < TG_VR_SLIP) {
        double dw[TG_NX + 1];
        tg_derivatives(m, m->t, m->w, dw);
        *value = dw[vr - TG_VR_DER];
        return 0;
    }
    if (vr < TG_VR_TORQUE) {
        double s[TG_NE + 1];
        tg_slips(m->w, s);
        *value = s[vr - TG_VR_SLIP];
        return 0;
    }
    if (vr < TG_VR_IN) {
        double t[TG_NE + 1];
        tg_element_torques(m, t);
        *value = t[vr - TG_VR_TORQUE];
        return 0;
    }
    if (vr < TG_VR_STATIC) { *value = tg_input(m, vr - TG_VR_IN, tg_seg_time(m, m->t)); return 0; }
    if (vr < TG_VR_DYNAMIC) { *value = m->stat[vr - TG_VR_STATIC]; return 0; }
    if (vr < TG_VR_J) { *value = m->dyn[vr - TG_VR_DYNAMIC]; return 0; }
    if (vr < TG_VR_SLIPTOL) { *value = m->J[vr - TG_VR_J]; return 0; }
    if (vr >= TG_VR_PAR && vr < TG_VR_PAR + TG_NPAR) { *value = m->par[vr - TG_VR_PAR]; return 0; }
    if (vr == TG_VR_SLIPTOL) { *value = m->slip_tol_rel; return 0; }
    if (vr == TG_VR_CSSTEP) { *value = m->cs_step; return 0; }
    if (vr == TG_VR_TIME) { *value = m->t; return 0; }
    if (vr == TG_VR_TEVENT) { *value = m->t_change; return 0; }
#if TG_ENGINE
    if (vr == TG_VR_ENG) { *value = tg_engine_input(m, tg_seg_time(m, m->t), m->w); return 0; }
    if (vr == TG_VR_ENG + 1) {
        *value = tg_engine_torque(m, tg_seg_time(m, m->t), TG_ENGINE == 2 ? m->w[TG_ENG_X] : m->w[TG_ENG_LINK]);
        return 0;
    }
#endif
#if TG_DRIVELINE
    if (vr == TG_VR_DL) { *value = tg_shaft_torque(m, m->w); return 0; }
    if (vr == TG_VR_DL + 1) { *value = m->w[TG_DL_X + 1] * TG_DL_RADIUS / TG_DL_FINAL; return 0; }
#endif
    if (vr >= TG_VR_Z && vr < TG_VR_Z + TG_NZ) {
        double z[TG_NZ + 1];
        tg_indicators(m, m->t, m->w, z);
        *value = z[vr - TG_VR_Z];
        return 0;
    }
    snprintf(m->msg, sizeof m->msg, "unknown value reference %u", vr);
    return 1;
}

static int tg_set_real(TG *m, unsigned vr, double value) {
    if (!isfinite(value)) {
        snprintf(m->msg, sizeof m->msg, "value reference %u: %g is not a finite number", vr, value);
        return 1;
    }
    if (vr < TG_VR_DER) { m->w[vr] = value; m->fresh = 0; return 0; }
    if (vr >= TG_VR_IN && vr < TG_VR_STATIC) {
        int k = vr - TG_VR_IN;
        if (!m->in_set[k] || m->in[k] != value) m->in_changed = 1;
        m->in[k] = value;
        m->in_set[k] = 1;
        return 0;
    }
    if (vr >= TG_VR_STATIC && vr < TG_VR_J) {
        if (value < 0.0) {
            snprintf(m->msg, sizeof m->msg, "value reference %u: a capacity must not be negative (%g)", vr, value);
            return 1;
        }
        if (vr < TG_VR_DYNAMIC) m->stat[vr - TG_VR_STATIC] = value; else m->dyn[vr - TG_VR_DYNAMIC] = value;
        m->in_changed = 1;
        return 0;
    }
    if (vr >= TG_VR_J && vr < TG_VR_SLIPTOL) {
        if (value < 0.0) {
            snprintf(m->msg, sizeof m->msg, "value reference %u: an inertia must not be negative (%g)", vr, value);
            return 1;
        }
        double old = m->J[vr - TG_VR_J];
        m->J[vr - TG_VR_J] = value;
        if (tg_matrices(m)) {
            m->J[vr - TG_VR_J] = old;
            char why[1024];
            snprintf(why, sizeof why, "%s", m->msg);
            (void)tg_matrices(m);
            snprintf(m->msg, sizeof m->msg, "value reference %u = %g: %s", vr, value, why);
            return 1;
        }
        m->in_changed = 1;
        return 0;
    }
    if (vr >= TG_VR_PAR && vr < TG_VR_PAR + TG_NPAR) {
        int k = vr - TG_VR_PAR, bound = TG_PAR_BOUND[k];
        if ((bound == 0 && !(value > 0.0)) || (bound == 1 && value < 0.0) || (bound == 2 && !(fabs(value) < 1.5707963267948966))) {
            snprintf(m->msg, sizeof m->msg, "value reference %u: %g is out of range (%s)", vr, value,
                     bound == 0 ? "must be > 0" : bound == 1 ? "must be >= 0" : "a grade angle within +-pi/2");
            return 1;
        }
        m->par[k] = value;
        m->in_changed = 1;
        return 0;
    }
    if (vr == TG_VR_SLIPTOL && value > 0.0 && value < 1e-2) { m->slip_tol_rel = value; return 0; }
    if (vr == TG_VR_CSSTEP && value > 0.0 && value <= 1.0) { m->cs_step = value; return 0; }
    snprintf(m->msg, sizeof m->msg, "value reference %u cannot be set to %g", vr, value);
    return 1;
}

static int tg_get_integer(TG *m, unsigned vr, int *value) {
    if (tg_start(m)) return 1;
    if (vr == TG_VR_INT) { *value = tg_mode_index(m); return 0; }
    if (vr == TG_VR_INT + 1) { *value = tg_gear(m); return 0; }
    if (vr == TG_VR_INT + 2) { *value = (int)m->locked; return 0; }
    snprintf(m->msg, sizeof m->msg, "unknown integer value reference %u", vr);
    return 1;
}

static int tg_get_boolean(TG *m, unsigned vr, int *value) {
    if (tg_start(m)) return 1;
    if (vr >= TG_VR_BOOL && vr < TG_VR_BOOL + TG_NE) { *value = (m->locked >> (vr - TG_VR_BOOL)) & 1u; return 0; }
    snprintf(m->msg, sizeof m->msg, "unknown boolean value reference %u", vr);
    return 1;
}
