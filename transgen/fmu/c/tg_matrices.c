/* transgen FMU runtime: the mode matrices from the tunable link inertias. Written for transgen
 * (MIT licence); included by tg_model.c. */
/* Every mode's B and D from the link inertias J (transgen.fmu.data.mode_matrices, the
 * simulator's matrices): with w = C q, dq/dt = (C^T J C)^-1 C^T F u = B u and the locked torques
 * t = E (F - J C B) u = D u, the columns of the mode's locked elements zeroed in F. 0, or 1 with
 * the message when the inertias leave a mode's accelerations undetermined. */
static int tg_matrices(TG *m) {
    for (unsigned mask = 0; mask < (1u << TG_NE); mask++) {
        if (!TG_MODE_VALID[mask]) continue;
        int dof = TG_MODE_DOF[mask], nrow = TG_MODE_NROW[mask];
        const double *C = MODE_C(mask), *E = TG_E + TG_MODE_E_OFF[mask];
        double *B = m->B + TG_MODE_B_OFF[mask], *D = m->D + TG_MODE_D_OFF[mask];
        static double F[TG_NL * TG_NU + 1], JCB[TG_NL * TG_NU + 1];
        double M[(TG_NL + 1) * (TG_NL + 1)], scale = 0.0;
        memcpy(F, TG_F, sizeof(double) * TG_NL * TG_NU);
        for (int e = 0; e < TG_NE; e++)
            if ((mask >> e) & 1u)
                for (int k = 0; k < TG_NL; k++) F[k * TG_NU + TG_UCOL[e]] = 0.0;
        for (int r = 0; r < dof; r++) {
            for (int c = 0; c < dof; c++) {
                double s = 0.0;
                for (int k = 0; k < TG_NL; k++) s += C[k * dof + r] * m->J[k] * C[k * dof + c];
                M[r * dof + c] = s;
                scale = fmax(scale, fabs(s));
            }
            for (int j = 0; j < TG_NU; j++) {
                double s = 0.0;
                for (int k = 0; k < TG_NL; k++) s += C[k * dof + r] * F[k * TG_NU + j];
                B[r * TG_NU + j] = s;
            }
        }
        /* Gaussian elimination with partial pivoting: M B = C^T F */
        for (int c = 0; c < dof; c++) {
            int p = c;
            for (int r = c + 1; r < dof; r++)
                if (fabs(M[r * dof + c]) > fabs(M[p * dof + c])) p = r;
            if (!(fabs(M[p * dof + c]) > 1e-12 * scale)) {
                char names[512] = "";
                for (int e = 0; e < TG_NE; e++)
                    if ((mask >> e) & 1u) {
                        if (names[0]) strncat(names, "+", sizeof names - strlen(names) - 1);
                        strncat(names, TG_ELEMENT_NAMES[e], sizeof names - strlen(names) - 1);
                    }
                snprintf(m->msg, sizeof m->msg, "the link inertias leave the accelerations of the mode with %s "
                         "locked undetermined (a degree of freedom without inertia)", names[0] ? names : "none");
                return 1;
            }
            if (p != c) {
                for (int k = 0; k < dof; k++) { double x = M[c * dof + k]; M[c * dof + k] = M[p * dof + k]; M[p * dof + k] = x; }
                for (int j = 0; j < TG_NU; j++) { double x = B[c * TG_NU + j]; B[c * TG_NU + j] = B[p * TG_NU + j]; B[p * TG_NU + j] = x; }
            }
            for (int r = c + 1; r < dof; r++) {
                double f = M[r * dof + c] / M[c * dof + c];
                if (f == 0.0) continue;
                for (int k = c; k < dof; k++) M[r * dof + k] -= f * M[c * dof + k];
                for (int j = 0; j < TG_NU; j++) B[r * TG_NU + j] -= f * B[c * TG_NU + j];
            }
        }
        for (int c = dof - 1; c >= 0; c--)
            for (int j = 0; j < TG_NU; j++) {
                double s = B[c * TG_NU + j];
                for (int k = c + 1; k < dof; k++) s -= M[c * dof + k] * B[k * TG_NU + j];
                B[c * TG_NU + j] = s / M[c * dof + c];
            }
        /* D = E (F - J C B) */
        for (int k = 0; k < TG_NL; k++)
            for (int j = 0; j < TG_NU; j++) {
                double s = 0.0;
                for (int r = 0; r < dof; r++) s += C[k * dof + r] * B[r * TG_NU + j];
                JCB[k * TG_NU + j] = F[k * TG_NU + j] - m->J[k] * s;
            }
        for (int r = 0; r < nrow; r++)
            for (int j = 0; j < TG_NU; j++) {
                double s = 0.0;
                for (int k = 0; k < TG_NL; k++) s += E[r * TG_NL + k] * JCB[k * TG_NU + j];
                D[r * TG_NU + j] = s;
            }
    }
    return 0;
}
