/*
 * solver_step.c -- one step of the integrator, as named phases (leapfrog / central
 * difference: positions at whole steps, velocities at half steps), called in this
 * order by cf_solver_run:
 *   1. rotations   rotation matrices of all bodies from their quaternions, and the
 *                  world angular velocities;
 *   2. contacts    contact forces and torques at the positions of step n, shear
 *                  increments from the velocities of step n-1/2 (the contact model),
 *                  then the connectors' forces at the positions of step n;
 *   3. velocities  gravity, ground inertia -m a_g(t_n), mass-proportional damping;
 *                  velocities to n+1/2 (Euler's equations in body axes for rotation);
 *                  work of the external forces and the kinetic energy at step n;
 *      (the monitor reads the state at step n here)
 *   4. positions   positions and unit quaternions to n+1.
 */
#include <string.h>

#include "solver_internal.h"

/* the phases of solver_phases.h for one run: lanes of type double, the solver's own state */
#define CF_PH_T double
#define CF_PH_M int
#define CF_PH_SEL(m, a, b) ((m) ? (a) : (b))
#define CF_PH_SQRT sqrt
#define CF_PH_STATE struct cf_solver
#define CF_PH_NAME(n) phase_##n
#include "solver_phases.h"

/* 1. rotations */
void cf_solver_step_rotations(cf_solver *s)
{
    phase_rotations(s, s);
}

/* 2. contacts: every joint through the contact model (the points models take all
 * joints at once, their per-joint work in lanes across joints: the same bits as joint
 * by joint) */
void cf_solver_step_contacts(cf_solver *s, double dt, cf_step_energy *e)
{
    int j;
    memset(s->F, 0, sizeof(double) * 3 * (size_t)s->nbody);
    memset(s->T, 0, sizeof(double) * 3 * (size_t)s->nbody);
    e->vs = 0; e->dslip = 0; e->dswitch = 0; e->vc = 0; e->dconn = 0;
    if (s->model->all) s->model->all(s, s->contact, s->ww, dt, e);
    else for (j = 0; j < s->nj; j++) s->model->joint(s, s->contact, &s->jt[j], s->ww, dt, e);
    /* the connectors after the joints' contacts (solver_connectors.c) */
    if (s->conn) cf_solver_connectors_step(s, s->conn, e);
}

/* 3. velocities (solver_phases.h), the ledger terms into the monitor */
void cf_solver_step_velocities(cf_solver *s, const double *ag, int damp_on, cf_monitor *m, double *ke_out,
                               double *vg_out)
{
    phase_velocities(s, s, ag, damp_on, &m->W, &m->Ddamp, ke_out, vg_out);
}

/* 4. positions and orientations to n + 1 */
void cf_solver_step_positions(cf_solver *s)
{
    phase_positions(s, s);
}
