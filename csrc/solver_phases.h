/*
 * solver_phases.h -- the body phases of one leapfrog step (1. rotations, 3. velocities,
 * 4. positions of solver_step.c), written once for any lane type. Included (several
 * times) with these defined:
 *   CF_PH_T          the lane type: double (one run) or a vector of runs, one per lane
 *   CF_PH_M          its condition type (int, or the vector's comparison mask)
 *   CF_PH_SEL(m,a,b) per lane: a where m holds, else b
 *   CF_PH_SQRT(x)    per lane correctly rounded square root
 *   CF_PH_STATE      a struct with CF_PH_T pointers x, v, q, w, R, F, T, ww, vold, wold,
 *                    fext_prev, fdamp_prev, tdamp_prev (indexed as in struct cf_solver)
 *   CF_PH_NAME(n)    the name of phase n
 * The constants (masses, inertias, dt, options) come from the set-up solver c. Every
 * lane evaluates the expressions below in their written order (contraction off), so a
 * run gets the same bits in any lane of any width as in the single-run path.
 * Included without CF_PH_T (as the Python build includes every header) it is empty.
 */
#ifdef CF_PH_T

/* 1. rotations: rotation matrices and world angular velocities of the moving bodies */
static inline void CF_PH_NAME(rotations)(const struct cf_solver *c, CF_PH_STATE *st)
{
    int i;
    for (i = 1; i < c->nbody; i++) {
        CF_QUAT_TO_MAT(CF_PH_T, st->q + 4 * i, st->R + 9 * i);
        CF_MAT_VEC(CF_PH_T, st->R + 9 * i, st->w + 3 * i, st->ww + 3 * i);
    }
}

/* 3. velocities: external forces, velocity update, work of the external forces
 * (trapezoidal in time, which is what the leapfrog conserves exactly) and damping
 * dissipation into the ledger sums W and Ddamp; kinetic (from the two half-step
 * velocities) and gravity energy at step n. ag: ground acceleration (x, y, z), m/s^2;
 * damp_on: damping acts at this step. */
static inline void CF_PH_NAME(velocities)(const struct cf_solver *c, CF_PH_STATE *st, const CF_PH_T *ag,
                                          CF_PH_M damp_on, CF_PH_T *W, CF_PH_T *Ddamp, CF_PH_T *ke_out,
                                          CF_PH_T *vg_out)
{
    int i, k, planar = c->def.planar;
    double dt = c->dt, g = c->g_normal, alpha = c->def.damping_alpha;
    const CF_PH_T zero = {0};
    CF_PH_T ke = zero, vg = zero;
    for (i = 1; i < c->nbody; i++) {
        double mi = c->m[i];
        const double *I = c->inertia + 3 * i;
        CF_PH_T fe[3], fd[3], td[3], tb[3], wn[3], Iw[3], gyr[3], dxv[3];
        CF_PH_T *w = st->w + 3 * i, *v = st->v + 3 * i, *vold = st->vold + 3 * i, *wold = st->wold + 3 * i;
        CF_PH_T *fp = st->fext_prev + 3 * i, *fdp = st->fdamp_prev + 3 * i, *tdp = st->tdamp_prev + 3 * i;
        const CF_PH_T *F = st->F + 3 * i;
        fe[0] = -mi * ag[0]; fe[1] = -mi * ag[1]; fe[2] = -mi * ag[2];
        for (k = 0; k < 3; k++) {
            fd[k] = CF_PH_SEL(damp_on, -alpha * mi * v[k], zero);
            td[k] = CF_PH_SEL(damp_on, -alpha * I[k] * w[k], zero);
        }
        /* displacement over the last step (x_n - x_{n-1} = dt v_{n-1/2}) */
        dxv[0] = dt * v[0]; dxv[1] = dt * v[1]; dxv[2] = dt * v[2];
        *W = *W + 0.5 * ((fp[0] + fe[0]) * dxv[0] + (fp[1] + fe[1]) * dxv[1] + (fp[2] + fe[2]) * dxv[2]);
        /* damping switches on once and stays on: before that its forces, now and at the
         * last step, are zero and its ledger term is exactly zero (skipped) */
        *Ddamp = CF_PH_SEL(damp_on, *Ddamp - 0.5 * ((fdp[0] + fd[0]) * dxv[0] + (fdp[1] + fd[1]) * dxv[1]
                                                   + (fdp[2] + fd[2]) * dxv[2]), *Ddamp);
        *Ddamp = CF_PH_SEL(damp_on, *Ddamp - 0.5 * dt * ((tdp[0] + td[0]) * w[0] + (tdp[1] + td[1]) * w[1]
                                                        + (tdp[2] + td[2]) * w[2]), *Ddamp);
        for (k = 0; k < 3; k++) {
            fdp[k] = CF_PH_SEL(damp_on, fd[k], fdp[k]);
            tdp[k] = CF_PH_SEL(damp_on, td[k], tdp[k]);
            fp[k] = fe[k];
            vold[k] = v[k];
            wold[k] = w[k];
        }
        v[0] = v[0] + dt * (F[0] + fe[0] + fd[0]) / mi;
        v[1] = v[1] + dt * (F[1] + fe[1] + fd[1]) / mi;
        v[2] = v[2] + dt * (F[2] + fe[2] + fd[2] - mi * g) / mi;
        if (c->tilted) { v[0] = v[0] + dt * c->g_x; v[1] = v[1] + dt * c->g_y; }   /* the downhill pull */
        CF_MAT_TVEC(CF_PH_T, st->R + 9 * i, st->T + 3 * i, tb);
        tb[0] = tb[0] + td[0]; tb[1] = tb[1] + td[1]; tb[2] = tb[2] + td[2];
        /* Euler: I dw/dt = tb - w x I w, the gyroscopic term at the mid-step estimate */
        Iw[0] = I[0] * w[0]; Iw[1] = I[1] * w[1]; Iw[2] = I[2] * w[2];
        CF_V3_CROSS(CF_PH_T, w, Iw, gyr);
        wn[0] = w[0] + 0.5 * dt * (tb[0] - gyr[0]) / I[0];
        wn[1] = w[1] + 0.5 * dt * (tb[1] - gyr[1]) / I[1];
        wn[2] = w[2] + 0.5 * dt * (tb[2] - gyr[2]) / I[2];
        Iw[0] = I[0] * wn[0]; Iw[1] = I[1] * wn[1]; Iw[2] = I[2] * wn[2];
        CF_V3_CROSS(CF_PH_T, wn, Iw, gyr);
        w[0] = w[0] + dt * (tb[0] - gyr[0]) / I[0];
        w[1] = w[1] + dt * (tb[1] - gyr[1]) / I[1];
        w[2] = w[2] + dt * (tb[2] - gyr[2]) / I[2];
        if (planar) { v[1] = zero; w[0] = zero; w[2] = zero; }
        ke = ke + (0.5 * mi * (vold[0] * v[0] + vold[1] * v[1] + vold[2] * v[2])
                   + 0.5 * (I[0] * wold[0] * w[0] + I[1] * wold[1] * w[1] + I[2] * wold[2] * w[2]));
        vg = vg + mi * g * st->x[3 * i + 2];
        if (c->tilted) vg = vg - mi * (c->g_x * st->x[3 * i] + c->g_y * st->x[3 * i + 1]);
    }
    *ke_out = ke;
    *vg_out = vg;
}

/* 4. positions and orientations to n + 1 */
static inline void CF_PH_NAME(positions)(const struct cf_solver *c, CF_PH_STATE *st)
{
    int i;
    double dt = c->dt;
    for (i = 1; i < c->nbody; i++) {
        CF_PH_T dq[4], *qq = st->q + 4 * i, *x = st->x + 3 * i, *v = st->v + 3 * i;
        x[0] = x[0] + dt * v[0]; x[1] = x[1] + dt * v[1]; x[2] = x[2] + dt * v[2];
        CF_QUAT_FROM_OMEGA_DT(CF_PH_T, st->w + 3 * i, dt, dq);
        CF_QUAT_MUL(CF_PH_T, qq, dq, qq);
        CF_QUAT_NORMALIZE(CF_PH_T, CF_PH_SQRT, qq);
    }
}

#endif
