/* transgen FMU runtime: the mode decision, a C port of transgen.sim.transmission.Transmission.decide
 * (and _consistent, _lock_sets, _without_implied, _choices): the same tests in the same order.
 * Written for transgen (MIT licence); included by tg_model.c. */
/* ----------------------------------------------------------------------- the mode decision */

typedef struct {
    int members[TG_NE + 1], signs[TG_NE + 1], n;
    unsigned capable;
    int choices[3], n_choices;
} TGZero;

typedef struct {
    unsigned locked, idle;
    int dirs[TG_NE + 1];
} TGCandidate;

static unsigned tg_group_mask(int g) {
    unsigned mask = 0;
    for (int k = TG_GROUP_START[g]; k < TG_GROUP_START[g + 1]; k++) mask |= 1u << TG_GROUP_MEMBERS[k];
    return mask;
}

/* Transmission._without_implied */
static unsigned tg_without_implied(unsigned locked, unsigned previous, int first) {
    int order[TG_NG + 1], n = 0;
    /* stable order by (g != first, any member in previous) */
    for (int pass = 0; pass < 4; pass++) {
        for (int g = 0; g < TG_NG; g++) {
            unsigned gm = tg_group_mask(g);
            if (!(gm & locked)) continue;
            int key = 2 * (g != first) + ((gm & previous) != 0);
            if (key == pass) order[n++] = g;
        }
    }
    unsigned current = locked;
    for (int k = 0; k < n; k++) {
        unsigned gm = tg_group_mask(order[k]);
        unsigned rest = current & ~gm;
        if (TG_IMPLIED[rest * TG_NG + order[k]]) current = rest;
    }
    return current;
}

/* Transmission._lock_sets: the lock sets that realise `wanted`; returns their number */
static int tg_lock_sets(unsigned wanted, unsigned previous, unsigned *out) {
    int n = 0;
    out[n++] = wanted;
    int groups[TG_NG + 2], ng = 0;
    groups[ng++] = -1;
    for (int g = 0; g < TG_NG; g++)
        if (tg_group_mask(g) & wanted) groups[ng++] = g;
    for (int k = 0; k < ng; k++) {
        unsigned reduced = tg_without_implied(wanted, previous, groups[k]);
        int seen = 0;
        for (int j = 0; j < n; j++) seen |= out[j] == reduced;
        if (!seen) out[n++] = reduced;
    }
    return n;
}

/* Transmission._choices */
static int tg_choices(const TGZero *z, const int *forced, int *out) {
    for (int k = 0; k < z->n; k++)
        if (forced[z->members[k]]) {
            out[0] = forced[z->members[k]] * z->signs[k];
            return 1;
        }
    int pos = 0, neg = 0; /* free directions of the one-way members */
    for (int k = 0; k < z->n; k++) {
        int e = z->members[k];
        if (TG_KIND[e] == TG_ONEWAY) {
            int f = TG_FREE[e] * z->signs[k];
            if (f != 1) pos = 1;  /* {f} <= {1} fails */
            if (f != -1) neg = 1;
        }
    }
    int n = 0;
    out[n++] = 0;
    if (!pos) out[n++] = 1;
    if (!neg) out[n++] = -1;
    return n;
}

/* Transmission._consistent: 1 consistent, 0 not, -1 None (an unforced group held at zero) */
static int tg_consistent(const TG *m, double t, const double *slips, const double *u_ext, const TGZero *zero,
                         int nz, const int *choice, unsigned locked, const int *forced, const int *released,
                         int nrel, const int *base_dir, const int *sliding, int share, TGCandidate *out) {
    (void)slips; /* the slipping torques do not depend on the slip (no friction tables) */
    int dirs[TG_NE + 1];
    for (int e = 0; e < TG_NE; e++) dirs[e] = base_dir[e];
    int implied[TG_NG + 1];
    int dof = TG_MODE_DOF[locked];
    const double *C = MODE_C(locked);
    int n_unforced = 0;
    unsigned free_mask = 0;
    for (int e = 0; e < TG_NE; e++)
        if (forced[e]) free_mask |= 1u << e;
    for (int z = 0; z < nz; z++) {
        for (int k = 0; k < zero[z].n; k++) dirs[zero[z].members[k]] = choice[z] * zero[z].signs[k];
        implied[z] = 0;
        if (choice[z] != 0) {
            int rep = zero[z].members[0], moves = 0;
            for (int r = 0; r < dof; r++) {
                double s = 0.0;
                for (int k = 0; k < TG_NL; k++) s += TG_P[rep * TG_NL + k] * C[k * dof + r];
                if (fabs(s) > 1e-12) moves = 1;
            }
            implied[z] = !moves;
        }
        if (implied[z]) {
            int any_forced = 0;
            for (int k = 0; k < zero[z].n; k++) any_forced |= forced[zero[z].members[k]] != 0;
            if (!any_forced) {
                n_unforced++;
                for (int k = 0; k < zero[z].n; k++) free_mask |= 1u << zero[z].members[k];
            }
        }
    }
    if (n_unforced && !share) return -1;
    if (share && !n_unforced) return 0;
    double u[TG_NU + 1];
    for (int j = 0; j < TG_NU; j++) u[j] = u_ext[j];
    double torques[TG_NE + 1];
    for (int e = 0; e < TG_NE; e++)
        torques[e] = (locked >> e) & 1u ? 0.0 : tg_slip_torque(m, e, t, dirs[e], 0);
    for (int z = 0; z < nz; z++) {
        if (choice[z] == 0 || implied[z]) continue;
        for (int k = 0; k < zero[z].n; k++) {
            int e = zero[z].members[k];
            if (forced[e] || (sliding && sliding[e] == dirs[e])) continue;
            if (!((locked >> e) & 1u)) torques[e] = tg_slip_torque(m, e, t, dirs[e], 1);
        }
    }
    for (int e = 0; e < TG_NE; e++) u[TG_UCOL[e]] += torques[e];
    double dw[TG_NL + 1], slip_acc[TG_NE + 1], t_locked[TG_NE + 1];
    tg_mode_rates(m, locked, u, dw);
    tg_slips(dw, slip_acc);
    tg_mode_torques(m, locked, u, t_locked);
    int nrow = TG_MODE_NROW[locked];
    for (int r = 0; r < nrow; r++)
        if (tg_holding_margin(m, locked, r, t, t_locked[r]) < 0.0) return 0;
    for (int z = 0; z < nz; z++) {
        if (choice[z] == 0) continue;
        int any_free = 0;
        for (int k = 0; k < zero[z].n; k++) any_free |= (free_mask >> zero[z].members[k]) & 1u;
        if (!any_free && !(choice[z] * slip_acc[zero[z].members[0]] > 0)) return 0;
    }
    for (int k = 0; k < nrel; k++) dirs[released[k]] = tg_sign(slip_acc[released[k]]);
    double umax = tg_max_abs(u, TG_NU);
    unsigned idle = 0;
    for (int r = 0; r < nrow; r++)
        if (fabs(t_locked[r]) <= 1e-9 * (1.0 + umax)) {
            int o = TG_MODE_ROW_OFF[locked] + r;
            for (int k = 0; k < TG_ROW_COUNT[o]; k++) idle |= 1u << TG_ROW_MEMBERS[TG_ROW_START[o] + k];
        }
    out->locked = locked;
    out->idle = idle;
    for (int e = 0; e < TG_NE; e++) out->dirs[e] = dirs[e];
    return 1;
}

static void tg_names(unsigned mask, char *buf, size_t size) {
    buf[0] = 0;
    for (int e = 0; e < TG_NE; e++)
        if ((mask >> e) & 1u) {
            if (buf[0]) strncat(buf, "+", size - strlen(buf) - 1);
            strncat(buf, TG_ELEMENT_NAMES[e], size - strlen(buf) - 1);
        }
    if (!buf[0]) snprintf(buf, size, "none");
}

/* Transmission.decide: returns 0 and sets *locked_out, dirs_out; nonzero with m->msg on failure */
static int tg_decide(TG *m, double t, const double *w, const double *u_ext, double slip_tol, const int *forced,
                     unsigned previous, const int *sliding, unsigned *locked_out, int *dirs_out) {
    for (int e = 0; e < TG_NE; e++)
        if (forced[e] && TG_KIND[e] == TG_DOG && tg_apply_at(m, e, t) > TG_APPLY_THRESHOLD) {
            snprintf(m->msg, sizeof m->msg, "t=%.6g s: dog element %s would have to hold more than its static "
                     "capacity %g N*m while engaged: a dog cannot slip under load", t, TG_ELEMENT_NAMES[e], m->stat[e]);
            return 1;
        }
    double slips[TG_NE + 1];
    tg_slips(w, slips);
    TGZero zero[TG_NG + 1];
    int nz = 0;
    unsigned deciding = 0;
    for (int g = 0; g < TG_NG; g++) {
        TGZero *z = &zero[nz];
        z->n = 0;
        z->capable = 0;
        int dog = 0;
        for (int k = TG_GROUP_START[g]; k < TG_GROUP_START[g + 1]; k++) {
            int e = TG_GROUP_MEMBERS[k];
            z->members[z->n] = e;
            z->signs[z->n++] = TG_GROUP_SIGNS[k];
            if (tg_applied_after(m, e, t)) {
                z->capable |= 1u << e;
                dog |= TG_KIND[e] == TG_DOG;
            }
        }
        if (z->capable && fabs(slips[z->members[0]]) <= slip_tol) {
            if (dog) {
                z->choices[0] = 0;
                z->n_choices = 1;
            } else {
                z->n_choices = tg_choices(z, forced, z->choices);
            }
            for (int k = 0; k < z->n; k++) deciding |= 1u << z->members[k];
            nz++;
        }
    }
    int released[TG_NE + 1], nrel = 0, base_dir[TG_NE + 1];
    for (int e = 0; e < TG_NE; e++) {
        if (fabs(slips[e]) <= slip_tol && !((deciding >> e) & 1u)) released[nrel++] = e;
        base_dir[e] = tg_sign(slips[e]);
    }
    TGCandidate cands[TG_MAX_CANDIDATES];
    int nc = 0, rejected = 0;
    for (int share = 0; share < 2; share++) {
        if (share && nc) break;
        int choice_index[TG_NG + 1], choice[TG_NG + 1];
        for (int z = 0; z < nz; z++) choice_index[z] = 0;
        for (;;) {
            unsigned wanted = 0;
            for (int z = 0; z < nz; z++) {
                choice[z] = zero[z].choices[choice_index[z]];
                if (choice[z] == 0) wanted |= zero[z].capable;
            }
            unsigned sets[TG_NG + 2];
            int ns = tg_lock_sets(wanted, previous, sets);
            int found = 0, refused = 0;
            for (int s = 0; s < ns; s++) {
                if (!TG_MODE_VALID[sets[s]]) {
                    refused = 1;
                    continue;
                }
                refused = 0;
                TGCandidate c;
                int passed = tg_consistent(m, t, slips, u_ext, zero, nz, choice, sets[s], forced, released, nrel,
                                           base_dir, sliding, share, &c);
                if (passed < 0) break;
                if (passed > 0) {
                    int dup = 0;
                    for (int j = 0; j < nc; j++)
                        if (cands[j].locked == c.locked && !memcmp(cands[j].dirs, c.dirs, sizeof(int) * TG_NE)) dup = 1;
                    if (!dup && nc < TG_MAX_CANDIDATES) cands[nc++] = c;
                    found = 1;
                    break;
                }
            }
            rejected += refused && !found && !share;
            /* next combination (itertools.product order: the last group varies fastest) */
            int z = nz - 1;
            while (z >= 0 && ++choice_index[z] == zero[z].n_choices) choice_index[z--] = 0;
            if (z < 0) break;
        }
        if (share && nc) nc = 1;
    }
    if (nc > 1) { /* the combination that needs no idle lock */
        int needed = 0, which = -1;
        for (int j = 0; j < nc; j++)
            if (!cands[j].idle) { needed++; which = j; }
        if (needed == 1) { cands[0] = cands[which]; nc = 1; }
    }
    if (nc > 1) { /* fewer locks where the extra ones hold only round-off */
        int keep[TG_MAX_CANDIDATES], nk = 0;
        for (int j = 0; j < nc; j++) {
            int covered = 0;
            for (int o = 0; o < nc; o++) {
                unsigned a = cands[o].locked, c = cands[j].locked;
                if ((a & c) == a && a != c && ((c & ~a) & ~cands[j].idle) == 0) covered = 1;
            }
            if (!covered) keep[nk++] = j;
        }
        if (nk == 1) { cands[0] = cands[keep[0]]; nc = 1; }
    }
    if (nc > 1 && sliding) { /* an element sliding at zero slip keeps sliding */
        int on = 0, which = -1;
        for (int j = 0; j < nc; j++) {
            int ok = 1;
            for (int e = 0; e < TG_NE; e++)
                if (!((previous >> e) & 1u) && sliding[e] != 0 && fabs(slips[e]) <= slip_tol && !forced[e]
                    && cands[j].dirs[e] != sliding[e]) ok = 0;
            if (ok) { on++; which = j; }
        }
        if (on == 1) { cands[0] = cands[which]; nc = 1; }
    }
    if (nc == 1) {
        *locked_out = cands[0].locked;
        for (int e = 0; e < TG_NE; e++) dirs_out[e] = cands[0].dirs[e];
        return 0;
    }
    char names[512] = "";
    for (int z = 0; z < nz; z++)
        for (int k = 0; k < zero[z].n; k++) {
            if (names[0]) strncat(names, ", ", sizeof names - strlen(names) - 1);
            strncat(names, TG_ELEMENT_NAMES[zero[z].members[k]], sizeof names - strlen(names) - 1);
        }
    if (!names[0]) snprintf(names, sizeof names, "none");
    if (!nc) {
        snprintf(m->msg, sizeof m->msg, "t=%.6g s: no consistent mode for the elements at zero slip (%s); "
                 "%d candidate mode(s) have non-unique locked torques or undetermined members", t, names, rejected);
        return 1;
    }
    char options[512] = "";
    for (int j = 0; j < nc; j++) {
        char one[256];
        tg_names(cands[j].locked, one, sizeof one);
        if (j) strncat(options, "; ", sizeof options - strlen(options) - 1);
        strncat(options, one, sizeof options - strlen(options) - 1);
    }
    snprintf(m->msg, sizeof m->msg, "t=%.6g s: several consistent modes for the elements at zero slip (%s): %s",
             t, names, options);
    return 1;
}

