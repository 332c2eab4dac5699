/*
 * solver_connectors.c -- connectors (dowels) across joints: their state (created at set-up from the
 * scene's definitions, reset at the start of every run, freed with the solver), their springs in
 * the stability limit, their forces at every step (the law of connector_law.h on the displacement
 * of each connector's ends since the rest state), what a run reports of them, and the driver of a
 * prescribed displacement history (cf_solver_connectors_drive) through which the tests reach the
 * law. Like a contact model, this file reads the solver's state it is handed (bodies, joints and
 * their faces) and calls none of the files that call it.
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "solver_internal.h"

/* ---- the law's values -------------------------------------------------------------- */

int cf_solver_connectors_check(const cf_solver_connector *c, char *msg)
{
    char dummy[CF_MSG_LEN];
    const cf_connector_law *law;
    int k;
    if (!msg) msg = dummy;
    if (!c) return cf_common_fail(msg, CF_EINVAL, "no connector");
    if (c->kind < 0 || c->kind >= cf_solver_connector_law_count())
        return cf_common_fail(msg, CF_EINVAL, "connector kind must be a law of the registry, 0 to %d, got %d",
                              cf_solver_connector_law_count() - 1, c->kind);
    law = cf_solver_connector_law_table[c->kind];
    if (!(c->k_shear >= 0.0) || !isfinite(c->k_shear))
        return cf_common_fail(msg, CF_EINVAL, "connector k_shear must be finite and >= 0 N/m, got %g", c->k_shear);
    if (!(c->k_axial >= 0.0) || !isfinite(c->k_axial))
        return cf_common_fail(msg, CF_EINVAL, "connector k_axial must be finite and >= 0 N/m, got %g", c->k_axial);
    if (!(c->f_yield > 0.0))
        return cf_common_fail(msg, CF_EINVAL, "connector f_yield must be > 0 N (inf: never), got %g", c->f_yield);
    if (!(c->n_yield > 0.0))
        return cf_common_fail(msg, CF_EINVAL, "connector n_yield must be > 0 N (inf: never), got %g", c->n_yield);
    if (!(c->u_ultimate > 0.0))
        return cf_common_fail(msg, CF_EINVAL, "connector u_ultimate must be > 0 m (inf: never), got %g", c->u_ultimate);
    if (!(c->d_ultimate > 0.0))
        return cf_common_fail(msg, CF_EINVAL, "connector d_ultimate must be > 0 m (inf: never), got %g", c->d_ultimate);
    for (k = law->n_values; k < CF_SOLVER_CONNECTOR_LAW_VALUES; k++)
        if (c->law[k] != 0.0)
            return cf_common_fail(msg, CF_EINVAL, "a connector of the %s law has no value law[%d] (it has %d), got %g",
                                  law->name, k, law->n_values, c->law[k]);
    return law->check ? law->check(c, msg) : CF_OK;
}

int cf_solver_connectors_drive(const cf_solver_connector *c, int n, const double *u, double *force, double *stored,
                               double *dissipated, int *state, char *msg)
{
    cf_connector_state st;
    double d = 0.0;
    int i, rc = cf_solver_connectors_check(c, msg);
    if (rc) return rc;
    if (n < 0 || (n > 0 && !u)) return cf_common_fail(msg, CF_EINVAL, "no displacement history");
    cf_connector_rest(c, &st);
    for (i = 0; i < n; i++) {
        d += cf_connector_update(c, &st, u + 3 * i);
        if (force) { force[3 * i] = st.f[0]; force[3 * i + 1] = st.f[1]; force[3 * i + 2] = st.f[2]; }
        if (stored) stored[i] = st.v;
        if (dissipated) dissipated[i] = d;
        if (state) state[i] = st.broken ? 2 : st.yielded ? 1 : 0;
    }
    return CF_OK;
}

/* ---- the connectors of a solver: create, reset, free ---------------------------------- */

void cf_solver_connectors_free(cf_connectors *c)
{
    if (!c) return;
    free(c->d); free(c->al); free(c->au); free(c->rest); free(c->st); free(c->peak); free(c->t_break);
    free(c->diss);
    free(c);
}

/* The displacement of connector i's upper end relative to its lower end, in the lower face's
 * frame, from the positions x and rotations R of the bodies (m); without the rest offset. */
static void relative(const cf_solver *s, const cf_connectors *c, int i, const double *x, const double *R, double *d,
                     double *pu, double *pl)
{
    const cf_joint *J = &s->jt[c->d[i].joint];
    int bl = J->bl, bu = J->bu, k;
    double w[3];
    mat_vec(R + 9 * bu, c->au + 3 * i, pu);
    mat_vec(R + 9 * bl, c->al + 3 * i, pl);
    for (k = 0; k < 3; k++) {
        pu[k] += x[3 * bu + k];
        pl[k] += x[3 * bl + k];
        w[k] = pu[k] - pl[k];
    }
    mat_tvec(R + 9 * bl, w, d);
}

/* Connectors from their definitions, on the joints of the solver s (built, untilted: the rest
 * state in s->x0, s->q0 is where every connector is unstrained). A connector must lie on both faces
 * of its joint. */
int cf_solver_connectors_create(cf_solver *s, int n, const cf_solver_connector *defs, cf_connectors **out)
{
    cf_connectors *c;
    double *R;
    int i, b, st = CF_OK;
    *out = NULL;
    if (n <= 0) return CF_OK;
    if (!defs) return cf_solver_fail(s, CF_EINVAL, "%d connectors but no definitions", n);
    for (i = 0; i < n; i++) {
        const cf_solver_connector *d = &defs[i];
        const cf_joint *J;
        char msg[CF_MSG_LEN];
        if (d->joint < 0 || d->joint >= s->nj)
            return cf_solver_fail(s, CF_EINVAL, "connector %d: joint %d does not exist (the scene has joints 0 to %d)",
                                  i, d->joint, s->nj - 1);
        if (cf_solver_connectors_check(d, msg)) return cf_solver_fail(s, CF_EINVAL, "connector %d: %s", i, msg);
        J = &s->jt[d->joint];
        if (!isfinite(d->x) || !isfinite(d->y) || !cf_face_inside(&J->fl, d->x, d->y, 0.0)
            || !cf_face_inside(&J->fu, d->x, d->y, 0.0))
            return cf_solver_fail(s, CF_EINVAL, "connector %d at (%g, %g) m lies outside the faces of joint %d", i, d->x,
                                  d->y, d->joint);
    }
    c = (cf_connectors *)calloc(1, sizeof *c);
    R = (double *)malloc(sizeof(double) * 9 * (size_t)s->nbody);
    if (c) {
        c->n = n;
        c->d = (cf_solver_connector *)malloc(sizeof *c->d * (size_t)n);
        c->al = (double *)calloc(3 * (size_t)n, sizeof(double));
        c->au = (double *)calloc(3 * (size_t)n, sizeof(double));
        c->rest = (double *)calloc(3 * (size_t)n, sizeof(double));
        c->st = (cf_connector_state *)calloc((size_t)n, sizeof *c->st);
        c->peak = (double *)calloc(3 * (size_t)n, sizeof(double));
        c->t_break = (double *)calloc((size_t)n, sizeof(double));
        c->diss = (double *)calloc((size_t)n, sizeof(double));
    }
    if (!c || !R || !c->d || !c->al || !c->au || !c->rest || !c->st || !c->peak || !c->t_break || !c->diss) {
        cf_solver_connectors_free(c);
        free(R);
        return cf_solver_fail(s, CF_ENOMEM, "out of memory (connectors)");
    }
    memcpy(c->d, defs, sizeof *c->d * (size_t)n);
    for (b = 0; b < s->nbody; b++) quat_to_mat(s->q0 + 4 * b, R + 9 * b);
    for (i = 0; i < n; i++) {
        const cf_joint *J = &s->jt[defs[i].joint];
        double pu[3], pl[3];
        c->al[3 * i] = J->fl.c[0] + defs[i].x; c->al[3 * i + 1] = J->fl.c[1] + defs[i].y; c->al[3 * i + 2] = J->fl.c[2];
        c->au[3 * i] = J->fu.c[0] + defs[i].x; c->au[3 * i + 1] = J->fu.c[1] + defs[i].y; c->au[3 * i + 2] = J->fu.c[2];
        relative(s, c, i, s->x0, R, c->rest + 3 * i, pu, pl);
    }
    free(R);
    *out = c;
    cf_solver_connectors_reset(c);
    return st;
}

/* A copy of c (its definitions, ends and rest offsets, and its state as it is): the connectors of one
 * lane of a batch (solver_batch_lanes.h), whose runs step each lane's own. NULL when out of memory. */
cf_connectors *cf_solver_connectors_clone(const cf_connectors *c)
{
    cf_connectors *k = (cf_connectors *)calloc(1, sizeof *k);
    size_t n = (size_t)c->n;
    if (k) {
        *k = *c;
        k->d = (cf_solver_connector *)malloc(sizeof *k->d * n);
        k->al = (double *)malloc(3 * n * sizeof(double));
        k->au = (double *)malloc(3 * n * sizeof(double));
        k->rest = (double *)malloc(3 * n * sizeof(double));
        k->st = (cf_connector_state *)malloc(sizeof *k->st * n);
        k->peak = (double *)malloc(3 * n * sizeof(double));
        k->t_break = (double *)malloc(n * sizeof(double));
        k->diss = (double *)malloc(n * sizeof(double));
    }
    if (!k || !k->d || !k->al || !k->au || !k->rest || !k->st || !k->peak || !k->t_break || !k->diss) {
        cf_solver_connectors_free(k);
        return NULL;
    }
    memcpy(k->d, c->d, sizeof *k->d * n);
    memcpy(k->al, c->al, 3 * n * sizeof(double)); memcpy(k->au, c->au, 3 * n * sizeof(double));
    memcpy(k->rest, c->rest, 3 * n * sizeof(double)); memcpy(k->st, c->st, sizeof *k->st * n);
    memcpy(k->peak, c->peak, 3 * n * sizeof(double)); memcpy(k->t_break, c->t_break, n * sizeof(double));
    memcpy(k->diss, c->diss, n * sizeof(double));
    return k;
}

/* The state at the start of a run: every connector unstrained and whole. */
void cf_solver_connectors_reset(cf_connectors *c)
{
    int i;
    for (i = 0; i < c->n; i++) {
        cf_connector_rest(&c->d[i], &c->st[i]);
        c->peak[3 * i] = c->peak[3 * i + 1] = c->peak[3 * i + 2] = 0.0;
        c->t_break[i] = NAN;
        c->diss[i] = 0.0;
    }
    c->steps = 0;
}

/* ---- springs, forces, reports -------------------------------------------------------- */

/* For the stability limit: connector i's springs at its lower end at rest (world, untilted): shear k
 * along x and y (the clearance kind once engaged), axial k_axial along z. */
void cf_solver_connectors_springs(const cf_solver *s, const cf_connectors *c, int i, cf_springs *K)
{
    static const double ex[3] = {1, 0, 0}, ey[3] = {0, 1, 0}, ez[3] = {0, 0, 1};
    const cf_joint *J = &s->jt[c->d[i].joint];
    double p[3];
    int k;
    for (k = 0; k < 3; k++) p[k] = s->x0[3 * J->bl + k] + c->al[3 * i + k];
    if (c->d[i].k_shear > 0.0) {
        cf_springs_add(K, p, ex, c->d[i].k_shear);
        cf_springs_add(K, p, ey, c->d[i].k_shear);
    }
    if (c->d[i].k_axial > 0.0) cf_springs_add(K, p, ez, c->d[i].k_axial);
}

/* Connector i's law at this step's displacement u (m, from the rest state; t the step's time, s): its
 * force and stored energy (c->st[i]), the step's dissipation into e->dconn and its own, its break time,
 * its peaks, its stored energy into e->vc (when e->need). Returns 1 when its force is not zero (it
 * acts on the bodies), 0 when it is. The one text of a connector's step for a run (below) and for
 * each lane of a batch (solver_batch_lanes.h, which computes u and applies the force on lane vectors
 * with the operations of this file). */
int cf_solver_connectors_law_step(cf_connectors *c, int i, const double *u, double t, cf_step_energy *e)
{
    cf_connector_state *st = &c->st[i];
    int was_broken = st->broken;
    double fs, us, dd;
    dd = cf_connector_update(&c->d[i], st, u);
    e->dconn += dd;
    c->diss[i] += dd;
    if (st->broken && !was_broken) c->t_break[i] = t;
    fs = sqrt(st->f[0] * st->f[0] + st->f[1] * st->f[1]);
    us = sqrt(u[0] * u[0] + u[1] * u[1]);
    if (fs > c->peak[3 * i]) c->peak[3 * i] = fs;
    /* the dowel's slip, frozen at the break: a broken dowel no longer spans the joint, whose
     * slide after it is the joint's (history joint_slip), not the dowel's */
    if (!was_broken && us > c->peak[3 * i + 1]) c->peak[3 * i + 1] = us;
    if (-st->f[2] > c->peak[3 * i + 2]) c->peak[3 * i + 2] = -st->f[2];
    if (e->need) e->vc += st->v;
    return !(st->f[0] == 0.0 && st->f[1] == 0.0 && st->f[2] == 0.0);
}

/* The forces of every connector at this step's positions (s->x, s->R) into s->F, s->T (the force on
 * the upper block at its upper end, the opposite on the lower block at that same point); the energy stored (when
 * e->need) into e->vc and the energy dissipated over the step into e->dconn. */
void cf_solver_connectors_step(cf_solver *s, cf_connectors *c, cf_step_energy *e)
{
    int i, k;
    double t = (double)c->steps * s->dt;
    for (i = 0; i < c->n; i++) {
        const cf_joint *J = &s->jt[c->d[i].joint];
        int bl = J->bl, bu = J->bu;
        double d[3], u[3], pu[3], pl[3], F[3], r[3], q[3];
        relative(s, c, i, s->x, s->R, d, pu, pl);
        for (k = 0; k < 3; k++) u[k] = d[k] - c->rest[3 * i + k];
        if (!cf_solver_connectors_law_step(c, i, u, t, e)) continue;
        mat_vec(s->R + 9 * bl, c->st[i].f, F);
        for (k = 0; k < 3; k++) r[k] = pu[k] - s->x[3 * bu + k];
        v3_cross(r, F, q);
        for (k = 0; k < 3; k++) { s->F[3 * bu + k] += F[k]; s->T[3 * bu + k] += q[k]; }
        if (bl != 0) {
            /* the lower block takes -F at the upper end's point, not at its own end: then the pair is
             * exactly the gradient of the stored energy of u (measured in the turning lower face's
             * frame), so it neither makes nor takes energy nor angular momentum (with -F at the
             * lower end the frame's turn under a force across an open joint did work: the ledger
             * drifted by 0.5 % of the scale over a rocking run with titanium dowels) */
            for (k = 0; k < 3; k++) r[k] = pu[k] - s->x[3 * bl + k];
            v3_cross(r, F, q);
            for (k = 0; k < 3; k++) { s->F[3 * bl + k] -= F[k]; s->T[3 * bl + k] -= q[k]; }
        }
    }
    c->steps++;
}

/* What a run reports per connector (CF_SOLVER_CONNECTOR_OUT each, solver.h). */
void cf_solver_connectors_report(const cf_connectors *c, double *out)
{
    int i;
    for (i = 0; i < c->n; i++) {
        double *o = out + CF_SOLVER_CONNECTOR_OUT * i;
        o[0] = c->peak[3 * i]; o[1] = c->peak[3 * i + 1]; o[2] = c->peak[3 * i + 2];
        o[3] = c->st[i].yielded ? 1.0 : 0.0; o[4] = c->st[i].broken ? 1.0 : 0.0;
        o[5] = c->t_break[i]; o[6] = c->diss[i];
    }
}

/* The connectors' history sample: |u| shear, |F| shear, axial force of each (3 per connector). */
void cf_solver_connectors_sample(const cf_connectors *c, double *out)
{
    int i;
    for (i = 0; i < c->n; i++) {
        const cf_connector_state *st = &c->st[i];
        out[3 * i] = sqrt(st->u[0] * st->u[0] + st->u[1] * st->u[1]);
        out[3 * i + 1] = sqrt(st->f[0] * st->f[0] + st->f[1] * st->f[1]);
        out[3 * i + 2] = -st->f[2];
    }
}
