/*
 * solver.c -- the public API of the rigid-drum soft-contact solver (solver.h): the
 * definition's defaults and checks, set-up, and the time loop of a run. The work is
 * done by the files named in solver_internal.h; docs/solver.md and
 * docs/architecture.md describe the method and the layout.
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cf_math.h"
#include "solver_internal.h"

void cf_solver_def_default(cf_solver_def *d)
{
    if (!d) return;
    cf_solver_options_default(d);   /* the defaults of the option tables (solver_options.c) */
    d->foundation_tilt_rad = 0.0;
    d->foundation_tilt_azimuth_rad = 0.0;
}

/* Gravity and the ground's rotation in the foundation's frame (R: rotation by the tilt about the
 * horizontal axis k = (-sin az, cos az, 0), which takes the world's vertical to the foundation's
 * normal; the solver's vectors are R^T times the world's). Untilted: gravity exactly def.g. */
static void foundation_frame(cf_solver *s)
{
    double th = s->def.foundation_tilt_rad, az = s->def.foundation_tilt_azimuth_rad;
    s->tilted = th != 0.0;
    s->g_normal = s->def.g; s->g_x = 0.0; s->g_y = 0.0;
    if (s->tilted) {
        double c = cf_math_cos(th), sn = cf_math_sin(th), k[3], K[9], R[9];
        int i, j;
        k[0] = -cf_math_sin(az); k[1] = cf_math_cos(az); k[2] = 0.0;
        K[0] = 0; K[1] = -k[2]; K[2] = k[1]; K[3] = k[2]; K[4] = 0; K[5] = -k[0]; K[6] = -k[1]; K[7] = k[0]; K[8] = 0;
        for (i = 0; i < 3; i++)
            for (j = 0; j < 3; j++) R[3 * i + j] = (i == j ? c : 0.0) + sn * K[3 * i + j] + (1.0 - c) * k[i] * k[j];
        for (i = 0; i < 3; i++)
            for (j = 0; j < 3; j++) s->ground_rt[3 * i + j] = R[3 * j + i];
        /* R^T (0, 0, -g): the downhill pull g sin(th) along the surface, the normal g cos(th) */
        s->g_x = -s->def.g * s->ground_rt[2]; s->g_y = -s->def.g * s->ground_rt[5];
        s->g_normal = s->def.g * s->ground_rt[8];
    }
}

static void release(cf_solver *s)
{
    char msg[CF_MSG_LEN];
    if (s->model && s->model->free && s->contact) s->model->free(s->contact);   /* the model's own state */
    s->contact = NULL;
    cf_solver_connectors_free(s->conn);
    s->conn = NULL;
    cf_solver_scene_free(s->scene);
    s->scene = NULL;
    cf_solver_state_release(s);
    cf_solver_stack_release(s);
    memcpy(msg, s->msg, CF_MSG_LEN);
    memset(s, 0, sizeof *s);
    memcpy(s->msg, msg, CF_MSG_LEN);
}

cf_solver *cf_solver_create(void)
{
    cf_solver *s = (cf_solver *)calloc(1, sizeof(cf_solver));
    if (s) cf_solver_def_default(&s->def);
    return s;
}

void cf_solver_free(cf_solver *s)
{
    if (!s) return;
    release(s);
    free(s);
}

int cf_solver_set_check(cf_solver *s, cf_solver_check_fn fn, void *user)
{
    if (!s) return CF_EINVAL;
    s->check = fn;
    s->check_user = user;
    return CF_OK;
}

const char *cf_solver_message(const cf_solver *s) { return s ? s->msg : "no solver"; }
double cf_solver_dt_crit(const cf_solver *s) { return s && s->ready ? s->dt_crit : NAN; }
double cf_solver_dt(const cf_solver *s) { return s && s->ready ? s->dt : NAN; }

/* ---- set-up --------------------------------------------------------------------- */

int cf_solver_check_def(cf_solver *s, const cf_solver_def *d)
{
    if (!s) return CF_EINVAL;
    if (!d) return cf_solver_fail(s, CF_EINVAL, "no solver definition");
    if (!(d->foundation_tilt_rad >= 0.0 && d->foundation_tilt_rad < 1.5707963267948966)
        || !isfinite(d->foundation_tilt_azimuth_rad))
        return cf_solver_fail(s, CF_EINVAL, "foundation_tilt_rad must be in [0, pi/2) and foundation_tilt_azimuth_rad "
                              "finite, got %g and %g", d->foundation_tilt_rad, d->foundation_tilt_azimuth_rad);
    return cf_solver_options_check(d, s->msg);   /* the ranges of the option tables (solver_options.c) */
}

int cf_solver_setup(cf_solver *s, const cf_solver_def *def, int nblk, const int *nseg,
                    const cf_geometry_segment *segs, double density, double kn, double ks, double mu)
{
    double *p;
    int i, st;
    if (!s) return CF_EINVAL;
    /* nblk is checked by cf_solver_setup_joints; a buffer of one keeps nblk < 1 to that check */
    p = (double *)malloc(sizeof(double) * 3 * (size_t)(nblk > 0 ? nblk : 1));
    if (!p) return cf_solver_fail(s, CF_ENOMEM, "out of memory");
    for (i = 0; i < nblk; i++) { p[i] = kn; p[nblk + i] = ks; p[2 * nblk + i] = mu; }
    st = cf_solver_setup_joints(s, def, nblk, nseg, segs, density, p, p + nblk, p + 2 * nblk);
    free(p);
    return st;
}

/* The checks of a column's blocks, segments, density and joints (n blocks, one joint under each). */
static int check_column(cf_solver *s, int nblk, const int *nseg, const cf_geometry_segment *segs, double density,
                        const double *kn, const double *ks, const double *mu)
{
    int i, nseg_tot = 0;
    if (nblk < 1 || !nseg || !segs) return cf_solver_fail(s, CF_EINVAL, "a column needs at least one block, got %d", nblk);
    for (i = 0; i < nblk; i++) {
        if (nseg[i] < 1) return cf_solver_fail(s, CF_EINVAL, "block %d has %d segments", i, nseg[i]);
        nseg_tot += nseg[i];
    }
    for (i = 0; i < nseg_tot; i++) {
        const cf_geometry_segment *g = &segs[i];
        if (!(g->height > 0) || !(g->r_bottom > 0) || !(g->r_top > 0) || !isfinite(g->height)
            || !isfinite(g->r_bottom) || !isfinite(g->r_top) || !isfinite(g->phase_rad))
            return cf_solver_fail(s, CF_EINVAL, "segment %d: height and radii must be finite and > 0 (got h=%g, r_bottom=%g, r_top=%g)",
                        i, g->height, g->r_bottom, g->r_top);
        if (g->n_sides < 3 || g->n_sides > CF_MAXS) return cf_solver_fail(s, CF_EINVAL, "segment %d: n_sides must be in [3, %d], got %d", i, CF_MAXS, g->n_sides);
        if (!isfinite(g->aspect) || g->aspect < 0.0)
            return cf_solver_fail(s, CF_EINVAL, "segment %d: aspect must be finite and > 0 (0: 1), got %g", i, g->aspect);
    }
    if (!(density > 0) || !isfinite(density)) return cf_solver_fail(s, CF_EINVAL, "density must be > 0, got %g", density);
    if (!kn || !ks || !mu) return cf_solver_fail(s, CF_EINVAL, "joint properties missing");
    for (i = 0; i < nblk; i++) {
        if (!(kn[i] > 0) || !isfinite(kn[i])) return cf_solver_fail(s, CF_EINVAL, "joint %d: kn must be > 0, got %g", i, kn[i]);
        if (!(ks[i] > 0) || !isfinite(ks[i])) return cf_solver_fail(s, CF_EINVAL, "joint %d: ks must be > 0, got %g", i, ks[i]);
        if (!(mu[i] > 0) || !isfinite(mu[i])) return cf_solver_fail(s, CF_EINVAL, "joint %d: mu must be > 0, got %g", i, mu[i]);
    }
    return CF_OK;
}

/* A fresh set-up: the old state released, the definition checked and taken. */
static int setup_begin(cf_solver *s, const cf_solver_def *def)
{
    int st;
    release(s);
    s->msg[0] = 0;
    if (!def) return cf_solver_fail(s, CF_EINVAL, "no solver definition");
    st = cf_solver_check_def(s, def);
    if (st) return st;
    s->def = *def;
    foundation_frame(s);
    s->model = cf_solver_contact_model_table[def->contact];
    s->lanes = cf_solver_points_lanes_widest();
    return CF_OK;
}

/* After the bodies and joints are built (untilted): the contact model's state, the connectors (whose
 * rest state is the untilted one), the initial tilt, the stability limit and the step. */
static int setup_finish(cf_solver *s, int nconn, const cf_solver_connector *conn)
{
    int st = CF_OK;
    if (s->model->create) {
        /* the contact model's own state, from the values of its options */
        double opt[CF_SOLVER_MAX_MODEL_OPTIONS];
        cf_solver_options_of_model(&s->def, s->def.contact, opt);
        st = s->model->create(s, opt, &s->contact);
    }
    if (!st) st = cf_solver_connectors_create(s, nconn, conn, &s->conn);
    if (!st) cf_solver_stack_tilt(s);
    if (!st) {
        /* the stiffness is assembled at the untilted rest state */
        double tilt = s->def.initial_tilt_rad;
        double *xs = (double *)malloc(sizeof(double) * 3 * (size_t)s->nbody);
        if (!xs) st = cf_solver_fail(s, CF_ENOMEM, "out of memory");
        else {
            memcpy(xs, s->x0, sizeof(double) * 3 * (size_t)s->nbody);
            s->def.initial_tilt_rad = 0;
            st = cf_solver_timestep_limit(s);
            s->def.initial_tilt_rad = tilt;
            memcpy(s->x0, xs, sizeof(double) * 3 * (size_t)s->nbody);
            free(xs);
        }
    }
    if (st) { release(s); return st; }
    s->dt = s->def.dt > 0 ? s->def.dt : s->def.dt_factor * s->dt_crit;
    s->ready = 1;
    return CF_OK;
}

int cf_solver_setup_joints(cf_solver *s, const cf_solver_def *def, int nblk, const int *nseg,
                           const cf_geometry_segment *segs, double density, const double *kn, const double *ks,
                           const double *mu)
{
    return cf_solver_setup_as_built(s, def, nblk, nseg, segs, density, kn, ks, mu, NULL);
}

/* An as-built placement's values: finite, not monolithic; NULL for one that places nothing. */
static int check_placement(cf_solver *s, int nblk, const double **place)
{
    int i, any = 0;
    if (!*place) return CF_OK;
    static const char *const what[CF_SOLVER_AS_BUILT] = {"offset", "offset", "rotation", "inner radius",
        "outer radius", "mass", "centre of mass", "centre of mass", "centre of mass", "inertia", "inertia", "inertia",
        "missing sector start", "missing sector end"};
    for (i = 0; i < CF_SOLVER_AS_BUILT * nblk; i++) {
        int k = i % CF_SOLVER_AS_BUILT, pos = k == 3 || k == 4 || k == 5;
        /* a block's own mass properties: inertias > 0 */
        int given = k >= 9 && k <= 11 && (*place)[i - k + 5] > 0.0;
        if (!isfinite((*place)[i]) || (pos && (*place)[i] < 0.0) || (given && !((*place)[i] > 0.0)))
            return cf_solver_fail(s, CF_EINVAL, "block %d: its as-built %s must be finite%s, got %g", i / CF_SOLVER_AS_BUILT,
                                  what[k], pos ? " and >= 0" : given ? " and > 0" : "", (*place)[i]);
        any |= (*place)[i] != 0.0;
    }
    if (!any) { *place = NULL; return CF_OK; }
    if (s->def.monolithic)
        return cf_solver_fail(s, CF_EINVAL, "a monolithic column is one body: it takes no as-built placement of its blocks");
    s->asb = 1;
    return CF_OK;
}

int cf_solver_setup_as_built(cf_solver *s, const cf_solver_def *def, int nblk, const int *nseg,
                             const cf_geometry_segment *segs, double density, const double *kn, const double *ks,
                             const double *mu, const double *place)
{
    int st;
    if (!s) return CF_EINVAL;
    st = setup_begin(s, def);
    if (!st) st = check_column(s, nblk, nseg, segs, density, kn, ks, mu);
    if (!st) st = check_placement(s, nblk, &place);
    if (st) { release(s); return st; }
    s->density = density;
    st = cf_solver_stack_build(s, nblk, nseg, segs, kn, ks, mu, place);
    if (st) { release(s); return st; }
    return setup_finish(s, 0, NULL);
}

int cf_solver_setup_scene(cf_solver *s, const cf_solver_def *def, const cf_solver_scene *sc)
{
    int st, c, nblk = 0;
    if (!s) return CF_EINVAL;
    st = setup_begin(s, def);
    if (!st && !sc) st = cf_solver_fail(s, CF_EINVAL, "no scene");
    if (!st && (sc->n_columns < 1 || !sc->columns))
        st = cf_solver_fail(s, CF_EINVAL, "a scene needs at least one column, got %d", sc->n_columns);
    for (c = 0; !st && c < sc->n_columns; c++) {
        if (sc->columns[c].n_blocks < 1)
            st = cf_solver_fail(s, CF_EINVAL, "column %d: a column needs at least one block, got %d", c,
                                sc->columns[c].n_blocks);
        nblk += sc->columns[c].n_blocks;
    }
    if (!st && sc->n_connectors < 0) st = cf_solver_fail(s, CF_EINVAL, "n_connectors must be >= 0, got %d", sc->n_connectors);
    if (!st && sc->n_columns == 1 && sc->n_beams == 0 && sc->n_bearings == 0) {
        /* one column: the single column's own set-up, bit for bit (its axis at the origin) */
        if (sc->columns[0].x != 0.0 || sc->columns[0].y != 0.0)
            st = cf_solver_fail(s, CF_EINVAL, "a scene of one column has it at (0, 0), got (%g, %g)",
                                sc->columns[0].x, sc->columns[0].y);
        if (!st) st = check_column(s, nblk, sc->n_segments, sc->segments, sc->density, sc->kn, sc->ks, sc->mu);
        if (!st) {
            s->density = sc->density;
            st = cf_solver_stack_build(s, nblk, sc->n_segments, sc->segments, sc->kn, sc->ks, sc->mu, NULL);
        }
    } else if (!st) {
        st = check_column(s, nblk, sc->n_segments, sc->segments, sc->density, sc->kn, sc->ks, sc->mu);
        if (!st) st = cf_solver_scene_build(s, sc);
    }
    if (st) { release(s); return st; }
    return setup_finish(s, sc->n_connectors, sc->connectors);
}

int cf_solver_set_outputs(cf_solver *s, double *columns, double *beams, double *connectors)
{
    if (!s) return CF_EINVAL;
    s->out_col = columns; s->out_beam = beams; s->out_conn = connectors;
    return CF_OK;
}

int cf_solver_counts(const cf_solver *s, int *n_columns, int *n_beams, int *n_connectors, int *n_blocks, int *n_joints)
{
    if (!s || !s->ready) return CF_ESTATE;
    if (n_columns) *n_columns = s->scene ? s->scene->ncol : 1;
    if (n_beams) *n_beams = s->scene ? s->scene->nbeam : 0;
    if (n_connectors) *n_connectors = s->conn ? s->conn->n : 0;
    if (n_blocks) *n_blocks = s->nblk;
    if (n_joints) *n_joints = s->nj;
    return CF_OK;
}

int cf_solver_set_history_connectors(cf_solver *s, double *energy, double *connectors)
{
    if (!s) return CF_EINVAL;
    s->h_conn_en = energy; s->h_conn = connectors;
    return CF_OK;
}

long cf_solver_history_capacity(const cf_solver *s, int n, double dt_rec)
{
    double t_final, cap;
    if (!s || !s->ready || n < 1 || !(dt_rec > 0)) return 0;
    if (s->state_resume) return cf_solver_state_history_capacity(s, n, dt_rec);
    t_final = (n - 1) * dt_rec + s->def.tail_s;
    cap = floor(t_final / s->def.history_dt + 1e-9) + 2;
    if (!(cap <= CF_SOLVER_MAX_HISTORY)) return -1;
    return (long)cap;
}

int cf_solver_set_history_normal(cf_solver *s, double *joint_normal)
{
    if (!s) return CF_EINVAL;
    s->h_fn = joint_normal;
    return CF_OK;
}

int cf_solver_set_history(cf_solver *s, long cap, double *t, double *top, double *pos, double *quat,
                          double *open, double *slip, double *en)
{
    if (!s) return CF_EINVAL;
    if (cap < 0 || cap > CF_SOLVER_MAX_HISTORY)
        return cf_solver_fail(s, CF_EINVAL, "history capacity must be in [0, %d], got %ld", CF_SOLVER_MAX_HISTORY, cap);
    s->h_cap = cap; s->h_t = t; s->h_top = top; s->h_pos = pos; s->h_quat = quat; s->h_open = open;
    s->h_slip = slip; s->h_en = en;
    return CF_OK;
}

/* ---- the run --------------------------------------------------------------------- */

/* The ground acceleration at t of a record of n samples at dtr whose first sample is sample i0 of
 * the time axis (0: at t = 0; a continued run's record later, the ground still before it): the
 * samples before i0 are 0.0, so that the values are those of one long record padded with zeros. */
static double ground_acc(const double *a, int n, long i0, double dtr, double t)
{
    double f, lo, hi;
    long i, nt = i0 + n;
    if (!a) return 0.0;
    f = t / dtr;
    if (f > (double)(nt - 1)) return 0.0;
    i = (long)f;
    if (i >= nt - 1) return a[n - 1];
    lo = i < i0 ? 0.0 : a[i - i0];
    hi = i + 1 < i0 ? 0.0 : a[i + 1 - i0];
    return lo + (f - (double)i) * (hi - lo);
}


/* The record and the step count of a run (its message on s when refused). */
int cf_solver_run_check(cf_solver *s, cf_run *r, const double *ax, const double *ay, const double *az, int nrec,
                        double dtr)
{
    int i;
    double t_final;
    memset(r, 0, sizeof *r);
    if (!s->ready) return cf_solver_fail(s, CF_ESTATE, "cf_solver_run before a successful cf_solver_setup");
    if (!ax || nrec < 1) return cf_solver_fail(s, CF_EINVAL, "acceleration record is empty");
    if (!(dtr > 0) || !isfinite(dtr)) return cf_solver_fail(s, CF_EINVAL, "record dt must be > 0, got %g", dtr);
    for (i = 0; i < nrec; i++) {
        if (!isfinite(ax[i]) || (ay && !isfinite(ay[i])) || (az && !isfinite(az[i])))
            return cf_solver_fail(s, CF_EINVAL, "non-finite ground acceleration at sample %d", i);
    }
    if (s->def.planar && ay) return cf_solver_fail(s, CF_EINVAL, "planar mode takes one horizontal component (acc_y given)");
    r->ax = ax; r->ay = ay; r->az = az; r->nrec = nrec; r->dtr = dtr;
    r->t_rec = (nrec - 1) * dtr;
    t_final = r->t_rec + s->def.tail_s;
    {
        /* in double first: a tiny dt must not overflow the step count */
        double ns = ceil(t_final / s->dt - 1e-9);
        if (!(ns <= CF_SOLVER_MAX_STEPS))
            return cf_solver_fail(s, CF_EINVAL, "the run needs %.4g steps (%.4g s of response at dt = %.4g s), more "
                                  "than the limit of %d: choose a longer solver step", ns, t_final, s->dt,
                                  CF_SOLVER_MAX_STEPS);
        r->nsteps = (long)ns;
    }
    r->ctime = NAN; r->cblk = -1;
    return CF_OK;
}

int cf_solver_run_begin(cf_solver *s, cf_run *r)
{
    s->msg[0] = 0;
    return cf_solver_monitor_begin(s, &r->m, r->t_rec);   /* reads the rest state */
}

void cf_solver_run_pre(const cf_solver *s, cf_run *r, cf_step_energy *e, double *ag)
{
    double dt = s->dt;
    long n = r->n;
    r->t = n * dt;
    r->hist_now = s->h_cap > 0 && r->m.hcount - r->m.h0 < s->h_cap && r->t + 0.5 * dt > r->m.hcount * s->def.history_dt;
    /* the ledger steps (every CF_LEDGER_STEPS-th), not the history's samples nor the run's last step: whether
     * a run keeps a history or is continued later must not change when its joints fall asleep */
    e->ledger = n % CF_LEDGER_STEPS == 0;
    /* the spring energies at the ledger steps, history samples and the last step; the rest of the
     * ledger every step */
    e->need = e->ledger || n == r->nsteps || r->hist_now;
    e->vc = 0.0; e->dconn = 0.0;
    ag[0] = ground_acc(r->ax, r->nrec, r->i0, r->dtr, r->t);
    ag[1] = ground_acc(r->ay, r->nrec, r->i0, r->dtr, r->t);
    ag[2] = ground_acc(r->az, r->nrec, r->i0, r->dtr, r->t);
    if (s->tilted) {
        /* the record's world axes into the foundation's frame */
        const double *M = s->ground_rt;
        double a0 = ag[0], a1 = ag[1], a2 = ag[2];
        ag[0] = M[0] * a0 + M[1] * a1 + M[2] * a2;
        ag[1] = M[3] * a0 + M[4] * a1 + M[5] * a2;
        ag[2] = M[6] * a0 + M[7] * a1 + M[8] * a2;
    }
}

/* collapse criteria every 4th step (a few ms: far finer than any collapse) */
static int collapse_due(long n) { return (n & 3) == 0; }

int cf_solver_run_reads_all(const cf_run *r)
{
    return cf_monitor_residual_due(&r->m, r->n) || collapse_due(r->n) || r->hist_now;
}

int cf_solver_run_post(cf_solver *s, cf_run *r, const cf_step_energy *e, double ke, double vg)
{
    cf_monitor *m = &r->m;
    double err, t = r->t, dt = s->dt;
    long n = r->n;
    m->Dslip += e->dslip;
    m->Dswitch += e->dswitch;
    if (m->conn) m->Dconn += e->dconn;
    err = cf_solver_monitor_energy(m, n, ke, vg, e);
    if (!isfinite(err) || !isfinite(ke)) {
        r->st = cf_solver_fail(s, CF_EUNSTABLE, "non-finite state at t = %.4f s (step %ld, dt = %.3g s, dt_crit = %.3g s)",
                               t, n, dt, s->dt_crit);
        return 1;
    }
    /* after a collapse (early_exit off) violent contacts of tumbling blocks are expected:
     * only a non-finite state aborts then */
    if (!r->collapsed && m->scale_max > 10.0 * m->scale_floor && m->err_max > s->def.unstable_tolerance * m->scale_max) {
        r->st = cf_solver_fail(s, CF_EUNSTABLE, "energy balance error %.3g of the energy scale at t = %.4f s: unstable "
                               "(dt = %.3g s, dt_crit = %.3g s)", m->err_max / m->scale_max, t, dt, s->dt_crit);
        return 1;
    }
    cf_solver_monitor_record(s, m, n, t, ke, vg, e, err, r->hist_now);
    if (!r->collapsed && collapse_due(n)) {
        r->creason = cf_solver_monitor_collapse(s, &r->cblk);
        if (r->creason) { r->collapsed = 1; r->ctime = t; if (s->def.early_exit) return 1; }
    }
    if (s->def.early_exit && t > r->t_rec && cf_solver_monitor_at_rest(m, t, ke)) { r->at_rest = 1; return 1; }
    return n == r->nsteps;
}

void cf_solver_run_finish(cf_solver *s, cf_run *r, double *resid, cf_solver_result *res)
{
    long n = r->n > r->nsteps ? r->nsteps : r->n;
    double dt = s->dt;
    memset(res, 0, sizeof *res);
    cf_solver_monitor_finish(s, &r->m, r->collapsed, resid, res);
    if (s->scene) cf_solver_monitor_scene_report(s, &r->m, r->collapsed, r->collapsed ? r->cblk : -1);
    if (s->conn && s->out_conn) cf_solver_connectors_report(s->conn, s->out_conn);
    cf_solver_monitor_end(&r->m);
    res->collapsed = r->collapsed;
    res->collapse_block = r->collapsed ? r->cblk : -1;
    res->collapse_reason = r->collapsed ? r->creason : 0;
    res->collapse_time = r->ctime;
    res->n_steps = n;
    res->t_end = n * dt;
    res->dt = dt;
    res->dt_crit = s->dt_crit;
    res->at_rest_exit = r->at_rest;
    if (r->st == CF_OK && res->energy_warning)
        snprintf(s->msg, CF_MSG_LEN, "energy balance error %.3g of the energy scale exceeds the tolerance %.3g "
                 "(dt = %.3g s, dt_crit = %.3g s)", res->energy_error, s->def.energy_tolerance, dt, s->dt_crit);
}

void cf_solver_result_none(cf_solver_result *res)
{
    memset(res, 0, sizeof *res);
    res->collapse_time = NAN; res->collapse_block = -1;
}

void cf_solver_run_stopped(cf_solver *s, cf_run *r)
{
    r->st = cf_solver_fail(s, CF_EINTR, "stopped by the caller at t = %.4f s (step %ld)", r->t, r->n);
}

int cf_solver_run(cf_solver *s, const double *ax, const double *ay, const double *az, int nrec, double dtr,
                  double *resid, cf_solver_result *res)
{
    int i, st;
    cf_run r;
    if (!s) return CF_EINVAL;
    if (!res) return cf_solver_fail(s, CF_EINVAL, "no result struct");
    cf_solver_result_none(res);
    st = cf_solver_run_check(s, &r, ax, ay, az, nrec, dtr);
    if (st) return st;
    cf_solver_stack_reset(s);
    if (s->model->reset) s->model->reset(s, s->contact);
    if (s->conn) cf_solver_connectors_reset(s->conn);
    for (i = 0; i < s->nbody; i++) quat_to_mat(s->q + 4 * i, s->R + 9 * i);
    st = cf_solver_run_begin(s, &r);   /* reads the rest state: after the reset */
    if (st) return st;
    if (s->state_resume) {
        /* a continued run: the state (positions at its step, velocities half a step on), then the
         * positions its run did not take (docs/sequences.md) */
        st = cf_solver_state_resume(s, &r);
        free(s->state_resume);
        s->state_resume = NULL;
        if (st) { cf_solver_monitor_end(&r.m); return st; }
        cf_solver_step_positions(s);
    }
    for (r.n = r.n_first;; r.n++) {
        cf_step_energy e;
        double ag[3], ke, vg;
        cf_solver_run_pre(s, &r, &e, ag);
        cf_solver_step_rotations(s);
        cf_solver_step_contacts(s, s->dt, &e);
        cf_solver_step_velocities(s, ag, s->def.damping_alpha > 0.0 && r.t >= s->def.damping_start_s, &r.m, &ke, &vg);
        if (cf_solver_run_post(s, &r, &e, ke, vg)) break;
        if (s->check && r.n % CF_SOLVER_CHECK_STEPS == CF_SOLVER_CHECK_STEPS - 1 && s->check(s->check_user)) {
            cf_solver_run_stopped(s, &r);
            break;
        }
        cf_solver_step_positions(s);
    }
    if (s->keep_state) {
        st = cf_solver_state_capture(s, &r);
        if (st && r.st == CF_OK) r.st = st;
    }
    cf_solver_run_finish(s, &r, resid, res);
    return r.st;
}
