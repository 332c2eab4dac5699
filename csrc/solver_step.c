/*
 * solver_step.c -- one step of the integrator, as named phases (leapfrog / central
 * difference: positions at whole steps, velocities at half steps), called in this
 * order by cf_solver_run:
 *   1. rotations   rotation matrices of all bodies from their quaternions, and the
 *                  world angular velocities;
 *   2. contacts    contact forces and torques at the positions of step n, shear
 *                  increments from the velocities of step n-1/2 (the contact model);
 *   3. velocities  gravity, ground inertia -m a_g(t_n), mass-proportional damping;
 *                  velocities to n+1/2 (Euler's equations in body axes for rotation);
 *                  work of the external forces and the kinetic energy at step n;
 *      (the monitor reads the state at step n here)
 *   4. positions   positions and unit quaternions to n+1.
 */
#include <string.h>

#include "solver_internal.h"

/* 1. rotations */
void cf_solver_step_rotations(cf_solver *s)
{
    int i;
    for (i = 1; i < s->nbody; i++) {
        quat_to_mat(s->q + 4 * i, s->R + 9 * i);
        mat_vec(s->R + 9 * i, s->w + 3 * i, s->ww + 3 * i);
    }
}

/* 2. contacts: every joint through the contact model (the points models take all
 * joints at once, their per-joint work in lanes across joints: the same bits as joint
 * by joint) */
void cf_solver_step_contacts(cf_solver *s, double dt, cf_step_energy *e)
{
    int j;
    memset(s->F, 0, sizeof(double) * 3 * (size_t)s->nbody);
    memset(s->T, 0, sizeof(double) * 3 * (size_t)s->nbody);
    e->vs = 0; e->dslip = 0; e->dswitch = 0;
    if (s->model->all) { s->model->all(s, s->ww, dt, e); return; }
    for (j = 0; j < s->nj; j++) s->model->joint(s, &s->jt[j], s->ww, dt, e);
}

/* 3. velocities: external forces, velocity update, work of the external forces
 * (trapezoidal in time, which is what the leapfrog conserves exactly) and damping
 * dissipation into the monitor's ledger; kinetic (from the two half-step velocities)
 * and gravity energy at step n. ag: ground acceleration (x, y, z), m/s^2. */
void cf_solver_step_velocities(cf_solver *s, const double *ag, int damp_on, cf_monitor *m, double *ke_out,
                               double *vg_out)
{
    int i, planar = s->def.planar;
    double dt = s->dt, g = s->def.g, alpha = s->def.damping_alpha, ke = 0, vg = 0;
    double *vold = s->vold, *wold = s->wold;
    for (i = 1; i < s->nbody; i++) {
        double mi = s->m[i], *I = s->inertia + 3 * i, fe[3], fd[3] = {0, 0, 0}, td[3] = {0, 0, 0};
        double tb[3], *w = s->w + 3 * i, *v = s->v + 3 * i, wn[3], Iw[3], gyr[3], dxv[3];
        fe[0] = -mi * ag[0]; fe[1] = -mi * ag[1]; fe[2] = -mi * ag[2];
        if (damp_on) {
            fd[0] = -alpha * mi * v[0]; fd[1] = -alpha * mi * v[1]; fd[2] = -alpha * mi * v[2];
            td[0] = -alpha * I[0] * w[0]; td[1] = -alpha * I[1] * w[1]; td[2] = -alpha * I[2] * w[2];
        }
        /* displacement over the last step (x_n - x_{n-1} = dt v_{n-1/2}) */
        dxv[0] = dt * v[0]; dxv[1] = dt * v[1]; dxv[2] = dt * v[2];
        m->W += 0.5 * ((s->fext_prev[3 * i] + fe[0]) * dxv[0] + (s->fext_prev[3 * i + 1] + fe[1]) * dxv[1]
                       + (s->fext_prev[3 * i + 2] + fe[2]) * dxv[2]);
        /* damping switches on once and stays on: before that its forces, now and at the
         * last step, are zero and its ledger term is exactly zero (skipped) */
        if (damp_on) {
            m->Ddamp -= 0.5 * ((s->fdamp_prev[3 * i] + fd[0]) * dxv[0] + (s->fdamp_prev[3 * i + 1] + fd[1]) * dxv[1]
                               + (s->fdamp_prev[3 * i + 2] + fd[2]) * dxv[2]);
            m->Ddamp -= 0.5 * dt * ((s->tdamp_prev[3 * i] + td[0]) * w[0] + (s->tdamp_prev[3 * i + 1] + td[1]) * w[1]
                                    + (s->tdamp_prev[3 * i + 2] + td[2]) * w[2]);
            memcpy(s->fdamp_prev + 3 * i, fd, sizeof fd);
            memcpy(s->tdamp_prev + 3 * i, td, sizeof td);
        }
        memcpy(s->fext_prev + 3 * i, fe, sizeof fe);
        memcpy(vold + 3 * i, v, 3 * sizeof(double));
        memcpy(wold + 3 * i, w, 3 * sizeof(double));
        v[0] += dt * (s->F[3 * i] + fe[0] + fd[0]) / mi;
        v[1] += dt * (s->F[3 * i + 1] + fe[1] + fd[1]) / mi;
        v[2] += dt * (s->F[3 * i + 2] + fe[2] + fd[2] - mi * g) / mi;
        mat_tvec(s->R + 9 * i, s->T + 3 * i, tb);
        tb[0] += td[0]; tb[1] += td[1]; tb[2] += td[2];
        /* Euler: I dw/dt = tb - w x I w, the gyroscopic term at the mid-step estimate */
        Iw[0] = I[0] * w[0]; Iw[1] = I[1] * w[1]; Iw[2] = I[2] * w[2];
        v3_cross(w, Iw, gyr);
        wn[0] = w[0] + 0.5 * dt * (tb[0] - gyr[0]) / I[0];
        wn[1] = w[1] + 0.5 * dt * (tb[1] - gyr[1]) / I[1];
        wn[2] = w[2] + 0.5 * dt * (tb[2] - gyr[2]) / I[2];
        Iw[0] = I[0] * wn[0]; Iw[1] = I[1] * wn[1]; Iw[2] = I[2] * wn[2];
        v3_cross(wn, Iw, gyr);
        w[0] += dt * (tb[0] - gyr[0]) / I[0];
        w[1] += dt * (tb[1] - gyr[1]) / I[1];
        w[2] += dt * (tb[2] - gyr[2]) / I[2];
        if (planar) { v[1] = 0.0; w[0] = 0.0; w[2] = 0.0; }
        ke += 0.5 * mi * (vold[3 * i] * v[0] + vold[3 * i + 1] * v[1] + vold[3 * i + 2] * v[2])
            + 0.5 * (I[0] * wold[3 * i] * w[0] + I[1] * wold[3 * i + 1] * w[1] + I[2] * wold[3 * i + 2] * w[2]);
        vg += mi * g * s->x[3 * i + 2];
    }
    *ke_out = ke;
    *vg_out = vg;
}

/* 4. positions and orientations to n + 1 */
void cf_solver_step_positions(cf_solver *s, double dt)
{
    int i;
    for (i = 1; i < s->nbody; i++) {
        double dq[4], *qq = s->q + 4 * i;
        s->x[3 * i] += dt * s->v[3 * i];
        s->x[3 * i + 1] += dt * s->v[3 * i + 1];
        s->x[3 * i + 2] += dt * s->v[3 * i + 2];
        quat_from_omega_dt(s->w + 3 * i, dt, dq);
        quat_mul(qq, dq, qq);
        quat_normalize(qq);
    }
}
