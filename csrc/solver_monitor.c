/*
 * solver_monitor.c -- what a run reports, read off the state after each step: the
 * energy ledger, the EDPs (u_top, the residual joint dislocations of u_d), the
 * collapse criteria, the histories and the at-rest detection. Nothing here changes
 * the motion.
 *
 * Energy ledger (J), evaluated every CF_LEDGER_STEPS steps, at history samples and at the last
 * step: kinetic + (gravity - gravity_0) + (spring - spring_0) + slip + damping +
 * contact_switch (+ the connectors' stored change and dissipation, when there are connectors)
 * - ground_work = balance error; the error's maximum over the run,
 * divided by the largest energy scale seen, is result.energy_error.
 */
#include <float.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "solver_internal.h"

/* world position of logical block i's top-face centre */
static inline void block_point(const cf_solver *s, int i, const double *loc, double *out)
{
    int b = s->blk_body[i];
    mat_vec(s->R + 9 * b, loc, out);
    out[0] += s->x[3 * b]; out[1] += s->x[3 * b + 1]; out[2] += s->x[3 * b + 2];
}

/* horizontal dislocation of logical joint j: centre of the upper block's bottom face
 * minus centre of the lower block's top face (ground face centre for j = 0) */
static void dislocation(const cf_solver *s, int j, double *dx, double *dy)
{
    double cu[3], cl[3];
    if (s->def.monolithic && j > 0) { *dx = 0; *dy = 0; return; }
    block_point(s, j, s->blk_bot + 3 * j, cu);
    if (j == 0) { cl[0] = 0; cl[1] = 0; }
    else block_point(s, j - 1, s->blk_top + 3 * (j - 1), cl);
    *dx = cu[0] - cl[0]; *dy = cu[1] - cl[1];
}

/* horizontal dislocation of joint J of a scene: the centre of its upper face minus the centre of its
 * lower face (for a bearing, the beam's slip on the capital at that patch) */
static void joint_dislocation(const cf_solver *s, const cf_joint *J, double *dx, double *dy)
{
    double cu[3], cl[3], n[3];
    cf_face_world(s, J->bu, &J->fu, cu, n);
    cf_face_world(s, J->bl, &J->fl, cl, n);
    *dx = cu[0] - cl[0]; *dy = cu[1] - cl[1];
}

/* A scene's step: each column's top displacement, each beam's slip at its bearings, the residual
 * sample of every joint when due; (dx, dy): column 0's top displacement (the history's top_disp). */
static void scene_record(const cf_solver *s, cf_monitor *m, long n, double *dx0, double *dy0)
{
    const cf_scene_info *sc = s->scene;
    int c, b, j;
    for (c = 0; c < sc->ncol; c++) {
        int top = sc->col_blk0[c] + sc->col_nblk[c] - 1;
        double p[3], dx, dy, d;
        block_point(s, top, s->blk_top + 3 * top, p);
        dx = p[0] - m->col_top0[3 * c]; dy = p[1] - m->col_top0[3 * c + 1];
        d = sqrt(dx * dx + dy * dy);
        if (d > m->col_max[c]) m->col_max[c] = d;
        if (d > m->max_top) m->max_top = d;
        if (c == 0) { *dx0 = dx; *dy0 = dy; }
    }
    for (b = 0; b < sc->nbeam; b++)
        for (j = sc->beam_j0[b]; j < sc->beam_j0[b] + sc->beam_nj[b]; j++) {
            double dx, dy, d;
            joint_dislocation(s, &s->jt[j], &dx, &dy);
            d = sqrt(dx * dx + dy * dy);
            if (d > m->beam_slip[b]) m->beam_slip[b] = d;
        }
    if (cf_monitor_residual_due(m, n)) {
        double *slot = m->ring + 2 * s->nj * m->ring_pos;
        for (j = 0; j < s->nj; j++) joint_dislocation(s, &s->jt[j], slot + 2 * j, slot + 2 * j + 1);
        m->ring_pos = (m->ring_pos + 1) % m->ring_len;
        if (m->ring_count < m->ring_len) m->ring_count++;
    }
}

/* A scene's history sample h: every block's pose, every joint's opening, normal force, dislocation. */
static void scene_history(const cf_solver *s, size_t h);

/* max normal gap (m) of the upper face's vertices over the lower face plane, >= 0 */
static double opening(const cf_solver *s, int j)
{
    const cf_joint *J;
    double cL[3], nL[3], mx = 0.0;
    int k;
    if (s->def.monolithic && j > 0) return 0.0;
    J = &s->jt[s->def.monolithic ? 0 : j];
    cf_face_world(s, J->bl, &J->fl, cL, nL);
    for (k = 0; k < J->fu.n; k++) {
        double loc[3], p[3], gap;
        loc[0] = J->fu.c[0] + J->fu.vx[k]; loc[1] = J->fu.c[1] + J->fu.vy[k]; loc[2] = J->fu.c[2];
        mat_vec(s->R + 9 * J->bu, loc, p);
        p[0] += s->x[3 * J->bu] - cL[0]; p[1] += s->x[3 * J->bu + 1] - cL[1]; p[2] += s->x[3 * J->bu + 2] - cL[2];
        gap = v3_dot(p, nL);
        if (gap > mx) mx = gap;
    }
    return mx;
}

/* the larger of a and b (fmax is a library call here) */
static inline double larger(double a, double b) { return a > b ? a : b; }

/* 1 when every point of the box box[0..1] x box[2..3] (horizontal), widened by tol on
 * each side, lies closer than r to (c[0], c[1]) */
static inline int box_within(const double *box, double tol, const double *c, double r)
{
    double dx = larger(box[1] - c[0], c[0] - box[0]) + tol, dy = larger(box[3] - c[1], c[1] - box[2]) + tol;
    return dx * dx + dy * dy < r * r;
}

/* Is the centre of mass (dx, dy) (m, horizontal) from the centre of face f of body b well beyond the face,
 * more than two radii from its centre? A regular face: two circumradii rc, whichever way. A scaled face
 * (geometry.h) is the image of the regular polygon of circumradius R under y -> a y, its corners on the
 * ellipse of semi-axes R (x) and R a (y); the regular test "outside the circle of radius 2 R" maps under the
 * same y -> a y to "outside that ellipse doubled", i.e. more than twice the ellipse's radius in the
 * direction e of the centre of mass (e as body b holds the face now, its part in the face's plane):
 *   |d|^2 > 4 rho(e)^2,  rho^2 = R^2 a^2 |e|^2 / (a^2 ex^2 + ey^2).
 * That is the radius, not the support function R sqrt(ex^2 + a^2 ey^2) / |e|: the criterion asks where the
 * centre of mass lies (a point against the doubled face), and only the radius keeps it the affine image of
 * the regular one. Both give R along x and R a along y, so it tends to the regular test as a -> 1 (the
 * vertices' furthest projection did not: rc cos(pi / n) along an edge's normal), and a wall's block
 * toppling across its thickness is caught at twice R min(1, a). Squared, no square root. */
static int beyond(const cf_solver *s, int b, const cf_face *f, double dx, double dy)
{
    double d[3] = {dx, dy, 0.0}, e[3], a = f->asp, d2 = dx * dx + dy * dy, R2, q;
    if (a == 1.0) return d2 > 4.0 * f->rc * f->rc;
    mat_tvec(s->R + 9 * b, d, e);
    R2 = f->vx[0] * f->vx[0] + (f->vy[0] / a) * (f->vy[0] / a);   /* the unscaled circumradius, squared */
    q = e[0] * e[0] + e[1] * e[1];
    if (q == 0.0) return d2 > 0.0;   /* the face stands on edge to the horizontal: no reach that way */
    return d2 * (a * a * e[0] * e[0] + e[1] * e[1]) > 4.0 * R2 * a * a * q;
}

/* Bearing j of a scene: has its beam's seat on that column (the centre of the beam's bearings
 * there, moving with the beam) left the column's top face? More than half the seat then overhangs:
 * the beam is unseated (the off-footprint criterion of a beam). */
static int unseated(const cf_solver *s, int j)
{
    const cf_scene_info *sc = s->scene;
    const cf_joint *J = &s->jt[j];
    int r = j - (s->nj - sc->nbear), c = sc->bear_col[r];
    const cf_face *top = &sc->col_top[c];
    double g[3], ct[3], n[3], d[3], X[3];
    mat_vec(s->R + 9 * J->bu, sc->bear_gc + 3 * r, g);
    g[0] += s->x[3 * J->bu]; g[1] += s->x[3 * J->bu + 1]; g[2] += s->x[3 * J->bu + 2];
    cf_face_world(s, J->bl, top, ct, n);
    d[0] = g[0] - ct[0]; d[1] = g[1] - ct[1]; d[2] = g[2] - ct[2];
    mat_tvec(s->R + 9 * J->bl, d, X);
    return !cf_face_inside(top, X[0], X[1], 0.0);
}

/* collapse criteria at the current state; returns the reason, sets *blk.
 * Three criteria, in this order of precedence, each reporting its first joint from
 * the bottom:
 * - overturning: the centre of mass of everything above joint j lies horizontally
 *   more than two circumradii from the centre of a face it rests on -- past that
 *   face's edge by a full radius, where no ground motion of the record can bring it
 *   back (for a slender block this is a tilt of about twice its slenderness angle).
 *   Measured both from the supporting (lower) face, with its radius, and from the
 *   moving block's own bottom face, with its own radius: a narrow block on a wide
 *   drum can tip over far inside the drum's face (on the unbounded ground the two
 *   faces are the same). A scaled section (geometry.h): twice the radius, towards the
 *   centre of mass, of the ellipse through its corners, as the face lies now (beyond()).
 * - off the footprint: the centre of a block's bottom face has slid outside the
 *   polygon of the face below (in that face's plane): more than half of the joint
 *   overhangs. Rocking alone moves this centre by b (1 - cos tilt) only. A beam of a
 *   scene is off its footprint -- unseated -- when its seat on a column has left that
 *   column's top face (unseated()).
 * - falling: a block's bottom-face centre a quarter of its height below the top face
 *   centre of the block that should carry it.
 * One pass over the joints evaluates all three on the same two face centres (each
 * computed once: these checks run every few steps of every run), keeping the first
 * failing joint of each criterion; an overturning ends the pass, since it takes
 * precedence over the other two wherever they fail. */
int cf_solver_monitor_collapse(const cf_solver *s, int *blk)
{
    int j, i, nj = s->nj, nbody = s->nbody, foot = -1, fall = -1;
    double box[4], mmin = s->m[1], big, tol;
    /* An exact pre-test of overturning, without the sums: the mass-weighted mean of
     * the centres of mass above a joint lies in the box of all of them (horizontal), and
     * its computed value (at most k products, sums of k terms in order, a division) within
     * 2 k u (k = bodies, u = DBL_EPSILON / 2) of it relative to the largest coordinate,
     * plus an underflow term below 1e-100 m when no body is lighter than 1e-200 kg: tol
     * bounds both with room. A face whose centre lies less than one radius from every
     * point of that box, widened by tol, cannot see a computed mean more than two radii
     * away, so the test's answer is known; otherwise the sums decide. A NaN position is
     * left out of the box (or, the first one, makes the box NaN and the sums run), but a
     * NaN in the sums makes the test's comparisons false: no overturning either way. */
    box[0] = box[1] = s->x[3]; box[2] = box[3] = s->x[4];
    for (i = 2; i < nbody; i++) {
        double x = s->x[3 * i], y = s->x[3 * i + 1];
        if (x < box[0]) box[0] = x;
        if (x > box[1]) box[1] = x;
        if (y < box[2]) box[2] = y;
        if (y > box[3]) box[3] = y;
        if (s->m[i] < mmin) mmin = s->m[i];
    }
    big = larger(larger(-box[0], box[1]), larger(-box[2], box[3]));
    tol = mmin > 1e-200 ? 4.0 * nbody * DBL_EPSILON * big + 1e-100 : INFINITY;
    for (j = 0; j < nj; j++) {
        const cf_joint *J = &s->jt[j];
        double cL[3], nL[3], cU[3], nU[3];
        const double *cs;
        cf_face_world(s, J->bu, &J->fu, cU, nU);
        cf_face_world(s, J->bl, &J->fl, cL, nL);
        cs = J->bl == 0 ? cU : cL;   /* on the ground the supporting face is the block's own */
        if (!J->bearing && (J->fl.asp != 1.0 || J->fu.asp != 1.0 || !box_within(box, tol, cs, J->fl.rc)
                            || !box_within(box, tol, cU, J->fu.rc))) {
            double mx = 0, my = 0, mt = 0, gx, gy, dx, dy;
            for (i = J->bu; i < J->above; i++) {
                mx += s->m[i] * s->x[3 * i]; my += s->m[i] * s->x[3 * i + 1]; mt += s->m[i];
            }
            gx = mx / mt; gy = my / mt;
            dx = gx - cs[0]; dy = gy - cs[1];
            if (J->bl == 0 ? beyond(s, J->bu, &J->fu, dx, dy) : beyond(s, J->bl, &J->fl, dx, dy)) {
                *blk = J->logical; return CF_SOLVER_COLLAPSE_OVERTURNING;
            }
            dx = gx - cU[0]; dy = gy - cU[1];
            if (beyond(s, J->bu, &J->fu, dx, dy)) { *blk = J->logical; return CF_SOLVER_COLLAPSE_OVERTURNING; }
        }
        if (foot < 0 && J->bearing) {
            if (unseated(s, j)) foot = j;
        } else if (foot < 0 && J->bl != 0) {     /* the ground is unbounded */
            double d[3], X[3];
            d[0] = cU[0] - cL[0]; d[1] = cU[1] - cL[1]; d[2] = cU[2] - cL[2];
            mat_tvec(s->R + 9 * J->bl, d, X);
            if (!cf_face_inside(&J->fl, X[0], X[1], 0.0)) foot = j;
        }
        if (fall < 0 && cU[2] - cL[2] < -0.25 * s->blk_h[J->logical]) fall = j;
    }
    if (foot >= 0) { *blk = s->jt[foot].logical; return CF_SOLVER_COLLAPSE_OFF_FOOTPRINT; }
    if (fall >= 0) { *blk = s->jt[fall].logical; return CF_SOLVER_COLLAPSE_FALLING; }
    *blk = -1;
    return CF_SOLVER_COLLAPSE_NONE;
}


int cf_solver_monitor_begin(cf_solver *s, cf_monitor *m, double t_rec)
{
    double dt = s->dt, g = s->def.g;
    int top = s->nblk - 1;
    memset(m, 0, sizeof *m);
    m->kres = (long)floor(0.005 / dt); if (m->kres < 1) m->kres = 1;
    m->ring_len = (long)ceil(s->def.residual_window_s / (m->kres * dt)) + 1;
    m->ring = (double *)calloc((size_t)m->ring_len * 2 * (size_t)(s->scene ? s->nj : s->nblk), sizeof(double));
    if (!m->ring) return cf_solver_fail(s, CF_ENOMEM, "out of memory");
    if (s->scene) {
        int c, nc = s->scene->ncol;
        m->col_top0 = (double *)calloc(3 * (size_t)nc, sizeof(double));
        m->col_max = (double *)calloc((size_t)nc, sizeof(double));
        m->beam_slip = (double *)calloc((size_t)(s->scene->nbeam > 0 ? s->scene->nbeam : 1), sizeof(double));
        if (!m->col_top0 || !m->col_max || !m->beam_slip) {
            cf_solver_monitor_end(m);
            return cf_solver_fail(s, CF_ENOMEM, "out of memory");
        }
        for (c = 0; c < nc; c++) {
            int k = s->scene->col_blk0[c] + s->scene->col_nblk[c] - 1;
            block_point(s, k, s->blk_top + 3 * k, m->col_top0 + 3 * c);
        }
    } else block_point(s, top, s->blk_top + 3 * top, m->top0);
    m->scale_floor = 1e-6 * s->total_mass * g * s->total_h;
    m->rest_ke = 1e-9 * s->total_mass * g * s->com_h;
    m->next_rest = t_rec + 0.5;
    m->conn = s->conn != NULL;
    return CF_OK;
}

void cf_solver_monitor_end(cf_monitor *m)
{
    free(m->ring); free(m->col_top0); free(m->col_max); free(m->beam_slip);
    m->ring = NULL; m->col_top0 = m->col_max = m->beam_slip = NULL;
}

/* The balance error at step n (0 when the ledger is not evaluated at this step). */
double cf_solver_monitor_energy(cf_monitor *m, long n, double ke, double vg, const cf_step_energy *e)
{
    double err = 0.0, scale;
    if (n == 0) { m->vg0 = vg; m->vs0 = e->vs; m->vc0 = e->vc; }
    if (e->need) {
        err = ke + (vg - m->vg0) + (e->vs - m->vs0) + m->Dslip + m->Ddamp + m->Dswitch - m->W;
        scale = ke + fabs(vg - m->vg0) + fabs(e->vs - m->vs0) + m->Dslip + m->Ddamp + fabs(m->Dswitch) + fabs(m->W);
        if (m->conn) {   /* the connectors' stored and dissipated energy (a solver without them: these terms absent) */
            err += (e->vc - m->vc0) + m->Dconn;
            scale += fabs(e->vc - m->vc0) + m->Dconn;
        }
        if (scale > m->scale_max) m->scale_max = scale;
        if (fabs(err) > m->err_max) m->err_max = fabs(err);
    }
    return err;
}

/* EDP accumulators and history sample at step n. */
void cf_solver_monitor_record(cf_solver *s, cf_monitor *m, long n, double t, double ke, double vg,
                              const cf_step_energy *e, double err, int hist_now)
{
    int j, nblk = s->nblk, top = nblk - 1;
    double p[3], dx = 0.0, dy = 0.0, d2;
    if (s->scene) scene_record(s, m, n, &dx, &dy);
    else {
    block_point(s, top, s->blk_top + 3 * top, p);
    dx = p[0] - m->top0[0]; dy = p[1] - m->top0[1];
    d2 = sqrt(dx * dx + dy * dy);
    if (d2 > m->max_top) m->max_top = d2;
    if (cf_monitor_residual_due(m, n)) {
        double *slot = m->ring + 2 * nblk * m->ring_pos;
        for (j = 0; j < nblk; j++) dislocation(s, j, slot + 2 * j, slot + 2 * j + 1);
        m->ring_pos = (m->ring_pos + 1) % m->ring_len;
        if (m->ring_count < m->ring_len) m->ring_count++;
    }
    }
    if (hist_now) {
        size_t h = (size_t)(m->hcount++ - m->h0);
        if (s->h_t) s->h_t[h] = t;
        if (s->h_top) { s->h_top[2 * h] = dx; s->h_top[2 * h + 1] = dy; }
        if (s->scene) scene_history(s, h);
        else for (j = 0; j < nblk; j++) {
            int b = s->blk_body[j];
            if (s->h_pos) block_point(s, j, s->blk_off + 3 * j, s->h_pos + 3 * (h * nblk + j));
            if (s->h_quat) memcpy(s->h_quat + 4 * (h * nblk + j), s->q + 4 * b, 4 * sizeof(double));
            if (s->h_open) s->h_open[h * nblk + j] = opening(s, j);
            if (s->h_fn) s->h_fn[h * nblk + j] = (s->def.monolithic && j > 0) ? NAN : s->jfn[j];
            if (s->h_slip) dislocation(s, j, s->h_slip + 2 * (h * nblk + j), s->h_slip + 2 * (h * nblk + j) + 1);
        }
        if (s->h_en) {
            double *en = s->h_en + CF_SOLVER_N_ENERGY * h;
            en[0] = ke; en[1] = vg - m->vg0; en[2] = e->vs - m->vs0; en[3] = m->Dslip; en[4] = m->Ddamp; en[5] = m->W;
            en[6] = err; en[7] = m->Dswitch;
        }
        if (s->conn && s->h_conn_en) { s->h_conn_en[2 * h] = e->vc - m->vc0; s->h_conn_en[2 * h + 1] = m->Dconn; }
        if (s->conn && s->h_conn) cf_solver_connectors_sample(s->conn, s->h_conn + 3 * (size_t)s->conn->n * h);
    }
}

/* After the record: at rest when the kinetic energy stayed below rest_ke over a whole
 * half-second window. */
int cf_solver_monitor_at_rest(cf_monitor *m, double t, double ke)
{
    if (ke > m->ke_win) m->ke_win = ke;
    if (t >= m->next_rest) {
        if (m->ke_win < m->rest_ke) return 1;
        m->ke_win = 0; m->next_rest += 0.5;
    }
    return 0;
}

static void scene_history(const cf_solver *s, size_t h)
{
    int j, nblk = s->nblk, nj = s->nj;
    for (j = 0; j < nblk; j++) {
        if (s->h_pos) block_point(s, j, s->blk_off + 3 * j, s->h_pos + 3 * (h * nblk + j));
        if (s->h_quat) memcpy(s->h_quat + 4 * (h * nblk + j), s->q + 4 * s->blk_body[j], 4 * sizeof(double));
    }
    for (j = 0; j < nj; j++) {
        if (s->h_open) s->h_open[h * nj + j] = opening(s, j);
        if (s->h_fn) s->h_fn[h * nj + j] = s->jfn[j];
        if (s->h_slip) joint_dislocation(s, &s->jt[j], s->h_slip + 2 * (h * nj + j), s->h_slip + 2 * (h * nj + j) + 1);
    }
}

/* The residual dislocation of joint j of a scene: the mean of the ring, m (NaN after a collapse). */
static double scene_residual(const cf_solver *s, const cf_monitor *m, int j, int collapsed)
{
    double sx = 0, sy = 0;
    long c;
    if (collapsed) return NAN;
    for (c = 0; c < m->ring_count; c++) { sx += m->ring[2 * s->nj * c + 2 * j]; sy += m->ring[2 * s->nj * c + 2 * j + 1]; }
    if (m->ring_count > 0) { sx /= m->ring_count; sy /= m->ring_count; }
    return sqrt(sx * sx + sy * sy);
}

/* A scene's summary: u_d the largest over its columns' joints, u_top over its columns (each
 * normalised by its own diameters); resid per joint. */
static void scene_finish(const cf_solver *s, const cf_monitor *m, int collapsed, double *resid, cf_solver_result *res)
{
    const cf_scene_info *sc = s->scene;
    int c, j;
    double ud = 0.0, ut = 0.0;
    for (j = 0; j < s->nj; j++) {
        double r = scene_residual(s, m, j, collapsed);
        if (resid) resid[j] = r;
    }
    for (c = 0; c < sc->ncol; c++) {
        for (j = sc->col_j0[c]; j < sc->col_j0[c] + sc->col_nj[c]; j++) {
            double r = scene_residual(s, m, j, collapsed) / s->joint_diam[s->jt[j].logical];
            if (r > ud) ud = r;
        }
        if (m->col_max[c] / sc->col_base_diam[c] > ut) ut = m->col_max[c] / sc->col_base_diam[c];
    }
    res->u_d = collapsed ? NAN : ud;
    res->u_top = ut;
}

void cf_solver_monitor_scene_report(const cf_solver *s, const cf_monitor *m, int collapsed, int collapse_block)
{
    const cf_scene_info *sc = s->scene;
    int c, b, j;
    if (!sc) return;
    for (c = 0; s->out_col && c < sc->ncol; c++) {
        double *o = s->out_col + CF_SOLVER_COLUMN_OUT * c, ud = 0.0;
        for (j = sc->col_j0[c]; j < sc->col_j0[c] + sc->col_nj[c]; j++) {
            double r = scene_residual(s, m, j, collapsed) / s->joint_diam[s->jt[j].logical];
            if (r > ud) ud = r;
        }
        o[0] = m->col_max[c] / sc->col_base_diam[c];
        o[1] = collapsed ? NAN : ud;
        o[2] = m->col_max[c];
        o[3] = collapse_block >= sc->col_blk0[c] && collapse_block < sc->col_blk0[c] + sc->col_nblk[c] ? 1.0 : 0.0;
    }
    for (b = 0; s->out_beam && b < sc->nbeam; b++) {
        double *o = s->out_beam + CF_SOLVER_BEAM_OUT * b, rs = 0.0;
        for (j = sc->beam_j0[b]; j < sc->beam_j0[b] + sc->beam_nj[b]; j++) {
            double r = scene_residual(s, m, j, collapsed);
            if (r > rs) rs = r;
        }
        o[0] = m->beam_slip[b];
        o[1] = collapsed ? NAN : rs;
        o[2] = m->beam_slip[b] / sc->beam_seat[b];
        o[3] = collapse_block == s->nblk - sc->nbeam + b ? 1.0 : 0.0;
    }
}

/* Residual dislocations (average of the ring over the last window), u_d, u_top.
 * After a collapse the residual dislocations lose their meaning (the blocks are
 * falling or lying elsewhere): they and u_d are NaN. u_top stays the largest top
 * displacement reached up to the end of the run (the collapse, with early exit). */
void cf_solver_monitor_finish(cf_solver *s, cf_monitor *m, int collapsed, double *resid, cf_solver_result *res)
{
    int j, nblk = s->nblk;
    double ud = 0.0;
    if (s->scene) {
        scene_finish(s, m, collapsed, resid, res);
        nblk = 0;   /* the stack's loop below is not a scene's */
    }
    for (j = 0; j < nblk; j++) {
        double sx = 0, sy = 0, r;
        long c;
        for (c = 0; c < m->ring_count; c++) { sx += m->ring[2 * nblk * c + 2 * j]; sy += m->ring[2 * nblk * c + 2 * j + 1]; }
        if (m->ring_count > 0) { sx /= m->ring_count; sy /= m->ring_count; }
        r = collapsed ? NAN : sqrt(sx * sx + sy * sy);
        if (resid) resid[j] = r;
        if (r / s->joint_diam[j] > ud) ud = r / s->joint_diam[j];
    }
    if (!s->scene) {
        res->u_d = collapsed ? NAN : ud;
        res->u_top = m->max_top / s->base_diam;
    }
    if (m->scale_max < m->scale_floor) m->scale_max = m->scale_floor;
    res->max_top_disp = m->max_top;
    res->energy_error = m->err_max / m->scale_max;
    res->energy_scale = m->scale_max;
    res->energy_warning = res->energy_error > s->def.energy_tolerance;
    res->n_history = (int)(m->hcount - m->h0);
}
