/*
 * solver.c -- the rigid-drum soft-contact integrator (see solver.h, docs/solver.md).
 *
 * Bodies: index 0 is the ground (fixed in the frame that moves with the ground),
 * 1.. are the moving rigid bodies (one per block, or one for the monolithic
 * column). Joint j has a lower body and an upper body; its sub-contacts are kept
 * in structure-of-arrays form with their persistent shear forces.
 *
 * One step (leapfrog / central difference; velocities at half steps):
 *   1. rotation matrices of all bodies from their quaternions;
 *   2. contact forces at the positions of step n, shear increments from the
 *      velocities of step n-1/2;
 *   3. gravity, ground inertia -m a_g(t_n), mass-proportional damping;
 *   4. velocities to n+1/2 (Euler's equations in body axes for rotation);
 *   5. energy balance, EDPs, histories and collapse checks at step n;
 *   6. positions and unit quaternions to n+1.
 */
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cf_common.h"
#include "contact.h"
#include "contact_internal.h"
#include "geometry.h"
#include "solver.h"
#include "solver_math_internal.h"

/* SSE2 is part of every x86-64 CPU (no -m flag needed); elsewhere, or with
 * -DCF_NO_SIMD, the same operations run one point at a time with identical results. */
#if defined(__SSE2__) && !defined(CF_NO_SIMD)
#define CF_SOLVER_SIMD 1
#include <emmintrin.h>
#endif

#define MAXS CF_SOLVER_MAX_SIDES

typedef struct {
    double c[3];            /* face centre in the body frame, m */
    int n;                  /* sides */
    double apo, rc, area;   /* apothem, circumradius (m), area (m^2) */
    double ec[MAXS], es[MAXS];   /* outward in-plane edge normals */
    double vx[MAXS], vy[MAXS];   /* vertices relative to the centre, CCW */
    double poly[2 * MAXS];       /* the same, interleaved (x, y) */
    double ecw[MAXS + 2], esw[MAXS + 2];   /* edge normals with wrap-around: ecw[k + 1] = ec[k mod n] */
} face_t;

typedef struct {
    int bl, bu;             /* lower and upper body */
    int logical;            /* index of the logical joint (= block above) */
    face_t fl, fu;          /* lower body's top face, upper body's bottom face */
    double area;            /* joint area, m^2 */
    int p0, np, n0;         /* its sub-contacts: [p0, p0 + np), the first n0 on the upper face */
    double fs[3], mt;       /* exact mode: joint shear force (N), torsional moment (N m) */
    double polar;           /* exact mode: polar moment of the joint area about its centre, m^4 */
    double lz[2];           /* body-frame z of the points of side 0 (upper face) and side 1 (lower face) */
} joint_t;

struct cf_solver {
    char msg[CF_MSG_LEN];
    int ready;
    cf_solver_def def;
    double kn, ks, mu, density;
    int nblk, nbody, nj;
    /* bodies (nbody) */
    double *m, *inertia;            /* mass (kg), principal inertia (3 per body) */
    double *x, *v, *q, *w, *R;      /* position, velocity (world), quaternion, omega (body), rotation */
    double *F, *T;                  /* force, torque (world) */
    double *x0, *q0;                /* initial state */
    double *fext_prev, *fdamp_prev, *tdamp_prev;
    /* logical blocks (nblk) */
    int *blk_body;
    double *blk_off, *blk_top, *blk_bot, *blk_h, *blk_m, *joint_diam;
    double base_diam, total_mass, total_h, com_h;
    /* joints */
    joint_t *jt;
    /* sub-contacts */
    int np;
    int *p_side, *p_hint, *p_homein;
    double *p_home;                 /* rest position in the other face's frame (x, y) */
    double *p_loc, *p_w, *p_ihkw;   /* body-frame position (3), area share (m^2), 1 / (2 ks w) */
    /* the hot loop's view of the same points, structure of arrays (one entry per point):
     * body-frame x, y (z is that of the face, shared), rest position in the other
     * face's frame, the squared radius of the cheap inside test around it (-1: none),
     * kn w and ks w, and the persistent state: shear force (N, face frame) and contact
     * state (0 open or too deep, 1 in contact, 2 over the plane but off the polygon) */
    double *p_lx, *p_ly, *p_hx, *p_hy, *p_fast, *p_knw, *p_ksw;
    double *p_fsx, *p_fsy, *p_state;
    double dt_crit, dt;
    /* history */
    int h_cap;
    double *h_t, *h_top, *h_pos, *h_quat, *h_open, *h_slip, *h_en, *h_fn;
    double *jfn;                    /* normal force of each joint this step, N */
};

static int fail(cf_solver *s, int st, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(s->msg, CF_MSG_LEN, fmt, ap);
    va_end(ap);
    return st;
}

void cf_solver_def_default(cf_solver_def *d)
{
    memset(d, 0, sizeof *d);
    d->contact = CF_SOLVER_CONTACT_VERTEX;
    d->points_per_edge = 1;
    d->dt = 0.0;
    d->dt_factor = 0.8;
    d->tail_s = 3.0;
    d->residual_window_s = 2.0;
    d->planar = 0;
    d->monolithic = 0;
    d->early_exit = 1;
    d->damping_alpha = 0.0;
    d->damping_start_s = 0.0;
    d->history_dt = 0.01;
    d->g = 9.81;
    d->energy_tolerance = 0.05;
    d->unstable_tolerance = 0.5;
    d->initial_tilt_rad = 0.0;
    d->contact_tolerance = 1e-2;
}

static void release(cf_solver *s)
{
    free(s->m); free(s->inertia); free(s->x); free(s->v); free(s->q); free(s->w); free(s->R);
    free(s->F); free(s->T); free(s->x0); free(s->q0); free(s->fext_prev); free(s->fdamp_prev);
    free(s->tdamp_prev); free(s->blk_body); free(s->blk_off); free(s->blk_top); free(s->blk_bot);
    free(s->blk_h); free(s->blk_m); free(s->joint_diam); free(s->jt); free(s->p_side); free(s->p_hint); free(s->p_ihkw); free(s->p_homein); free(s->p_home); free(s->p_loc);
    free(s->p_w); free(s->jfn);
    free(s->p_lx); free(s->p_ly); free(s->p_hx); free(s->p_hy); free(s->p_fast); free(s->p_knw); free(s->p_ksw);
    free(s->p_fsx); free(s->p_fsy); free(s->p_state);
    {
        char msg[CF_MSG_LEN];
        memcpy(msg, s->msg, CF_MSG_LEN);
        memset(s, 0, sizeof *s);
        memcpy(s->msg, msg, CF_MSG_LEN);
    }
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

const char *cf_solver_message(const cf_solver *s) { return s ? s->msg : "no solver"; }
double cf_solver_dt_crit(const cf_solver *s) { return s && s->ready ? s->dt_crit : NAN; }
double cf_solver_dt(const cf_solver *s) { return s && s->ready ? s->dt : NAN; }

/* ---- geometry helpers ------------------------------------------------------------ */

static void make_face(face_t *f, int n, double r, double phase, double cz)
{
    int k;
    double a = CF_PI / n;
    f->c[0] = 0; f->c[1] = 0; f->c[2] = cz;
    f->n = n; f->rc = r; f->apo = r * cos(a);
    f->area = cf_geometry_polygon_area(n, r);
    for (k = 0; k < n; k++) {
        double ph = phase + 2.0 * CF_PI * k / n;
        f->vx[k] = r * cos(ph); f->vy[k] = r * sin(ph);
        f->poly[2 * k] = f->vx[k]; f->poly[2 * k + 1] = f->vy[k];
        f->ec[k] = cos(ph + a); f->es[k] = sin(ph + a);
    }
    for (k = 0; k < n + 2; k++) {
        int m = (k + n - 1) % n;
        f->ecw[k] = f->ec[m]; f->esw[k] = f->es[m];
    }
}

/* (X, Y) inside the face polygon grown by tol (m)? */
static inline int face_inside(const face_t *f, double X, double Y, double tol)
{
    int k;
    double lim = f->apo + tol;
    if (X * X + Y * Y <= f->apo * f->apo) return 1;
    for (k = 0; k < f->n; k++)
        if (X * f->ec[k] + Y * f->es[k] > lim) return 0;
    return 1;
}

/* Sub-contact points of one face (body frame), weights summing to wsum.
 * mode VERTEX: the n vertices; PERIMETER: nodes of the fan triangulation refined
 * m times (m points per polygon edge, interior nodes too), lumped (trapezoidal)
 * area weights, which converge to the exact interface as m grows.
 * Writes up to count_face_points() entries; returns the count. */
static int count_face_points(int n, int mode, int m)
{
    if (mode == CF_SOLVER_CONTACT_VERTEX) return n;
    return 1 + n * m * (m + 1) / 2;
}

static int face_points(const face_t *f, int mode, int m, double wsum, double *loc, double *wt)
{
    int k, c = 0, ring, t;
    if (mode == CF_SOLVER_CONTACT_VERTEX) {
        for (k = 0; k < f->n; k++) {
            loc[3 * c] = f->c[0] + f->vx[k]; loc[3 * c + 1] = f->c[1] + f->vy[k]; loc[3 * c + 2] = f->c[2];
            wt[c++] = wsum / f->n;
        }
        return c;
    }
    {
        double at = wsum / f->n / ((double)m * m) / 3.0;   /* one third of a sub-triangle */
        loc[0] = f->c[0]; loc[1] = f->c[1]; loc[2] = f->c[2];
        wt[0] = at * f->n;
        c = 1;
        for (ring = 1; ring <= m; ring++) {
            double sc = (double)ring / m;
            for (k = 0; k < f->n; k++) {
                int k1 = (k + 1) % f->n;
                for (t = 0; t < ring; t++) {
                    double u = (double)t / ring;
                    int cnt;
                    loc[3 * c] = f->c[0] + sc * (f->vx[k] + u * (f->vx[k1] - f->vx[k]));
                    loc[3 * c + 1] = f->c[1] + sc * (f->vy[k] + u * (f->vy[k1] - f->vy[k]));
                    loc[3 * c + 2] = f->c[2];
                    if (ring < m) cnt = 6;
                    else cnt = (t == 0) ? 2 : 3;
                    wt[c++] = at * cnt;
                }
            }
        }
    }
    return c;
}

/* ---- stability limit of the whole linearised stack ------------------------------ */

/* Largest eigenvalue of a symmetric n x n matrix (row-major; a is destroyed):
 * Householder reduction to tridiagonal form (eigenvalues only), then bisection on
 * the Sturm sequence count to full double precision. O(n^3) with a small constant:
 * about 1 ms for the 78 x 78 stack of the default column (cyclic Jacobi took ~20 ms). */
double cf_solver_sym_max_eig(double *a, int n)
{
    int i, j, k, it;
    double *d, *e, *v, *pq, lo, hi;
    if (n < 1) return NAN;
    if (n == 1) return a[0];
    d = (double *)malloc(sizeof(double) * (size_t)n * 4);
    if (!d) return NAN;
    e = d + n; v = e + n; pq = v + n;
    for (k = 0; k + 2 < n; k++) {
        int m = n - k - 1;
        double nx = 0.0, alpha, nv = 0.0, K = 0.0;
        for (i = 0; i < m; i++) { v[i] = a[(k + 1 + i) * n + k]; nx += v[i] * v[i]; }
        nx = sqrt(nx);
        if (nx == 0.0) { e[k] = 0.0; continue; }
        alpha = v[0] > 0 ? -nx : nx;
        e[k] = alpha;
        v[0] -= alpha;
        for (i = 0; i < m; i++) nv += v[i] * v[i];
        nv = sqrt(nv);
        if (nv == 0.0) continue;
        for (i = 0; i < m; i++) v[i] /= nv;
        /* A22 <- H A22 H, H = I - 2 v v^T:  p = A22 v, q = p - (v.p) v, A22 -= 2 (v q^T + q v^T) */
        for (i = 0; i < m; i++) {
            double sum = 0.0;
            for (j = 0; j < m; j++) sum += a[(k + 1 + i) * n + k + 1 + j] * v[j];
            pq[i] = sum;
            K += v[i] * sum;
        }
        for (i = 0; i < m; i++) pq[i] -= K * v[i];
        for (i = 0; i < m; i++)
            for (j = 0; j < m; j++)
                a[(k + 1 + i) * n + k + 1 + j] -= 2.0 * (v[i] * pq[j] + pq[i] * v[j]);
    }
    for (i = 0; i < n; i++) d[i] = a[i * n + i];
    e[n - 2] = a[(n - 1) * n + n - 2];
    /* Gershgorin bounds of the tridiagonal matrix */
    lo = INFINITY; hi = -INFINITY;
    for (i = 0; i < n; i++) {
        double r = (i > 0 ? fabs(e[i - 1]) : 0.0) + (i < n - 1 ? fabs(e[i]) : 0.0);
        if (d[i] + r > hi) hi = d[i] + r;
        if (d[i] - r < lo) lo = d[i] - r;
    }
    /* bisection: the smallest x below which all n eigenvalues lie */
    for (it = 0; it < 200 && hi - lo > 1e-15 * (fabs(hi) + fabs(lo)); it++) {
        double x = 0.5 * (lo + hi), q = d[0] - x;
        int below = q < 0.0;
        for (i = 1; i < n; i++) {
            if (q == 0.0) q = 1e-300;
            q = d[i] - x - e[i - 1] * e[i - 1] / q;
            below += q < 0.0;
        }
        if (below == n) hi = x; else lo = x;
    }
    free(d);
    return hi;
}

/* Add a spring of stiffness k along e at world point p between bodies bl, bu (at rest). */
static void add_spring(const cf_solver *s, double *K, int nd, int bl, int bu, const double *p, const double *e,
                       double k)
{
    double b[12];
    int idx[12], nb = 0, i, j;
    int bodies[2], sgn[2], t;
    bodies[0] = bu; sgn[0] = 1; bodies[1] = bl; sgn[1] = -1;
    for (t = 0; t < 2; t++) {
        int bi = bodies[t];
        double r[3], rxe[3];
        if (bi == 0) continue;
        r[0] = p[0] - s->x0[3 * bi]; r[1] = p[1] - s->x0[3 * bi + 1]; r[2] = p[2] - s->x0[3 * bi + 2];
        v3_cross(r, e, rxe);
        for (i = 0; i < 3; i++) { idx[nb] = 6 * (bi - 1) + i; b[nb++] = sgn[t] * e[i]; }
        for (i = 0; i < 3; i++) { idx[nb] = 6 * (bi - 1) + 3 + i; b[nb++] = sgn[t] * rxe[i]; }
    }
    for (i = 0; i < nb; i++)
        for (j = 0; j < nb; j++) K[idx[i] * nd + idx[j]] += k * b[i] * b[j];
}

static int compute_dt_crit(cf_solver *s)
{
    int nd = 6 * (s->nbody - 1), j, k, i, nsel;
    double *K = (double *)calloc((size_t)nd * nd, sizeof(double));
    double *A;
    int *sel;
    double lam;
    static const double ex[3] = {1, 0, 0}, ey[3] = {0, 1, 0}, ez[3] = {0, 0, 1};
    if (!K) return fail(s, CF_ENOMEM, "out of memory (stiffness matrix)");
    for (j = 0; j < s->nj; j++) {
        joint_t *J = &s->jt[j];
        if (s->def.contact == CF_SOLVER_CONTACT_EXACT) {
            /* exact interface: the face integral by the edge-midpoint rule on the fan
             * triangles (exact for the quadratic integrands of K) */
            const face_t *f = &J->fu;
            double wq = J->area / f->n / 3.0;
            for (k = 0; k < f->n; k++) {
                int k1 = (k + 1) % f->n, t;
                double mids[3][2];
                mids[0][0] = 0.5 * f->vx[k]; mids[0][1] = 0.5 * f->vy[k];
                mids[1][0] = 0.5 * f->vx[k1]; mids[1][1] = 0.5 * f->vy[k1];
                mids[2][0] = 0.5 * (f->vx[k] + f->vx[k1]); mids[2][1] = 0.5 * (f->vy[k] + f->vy[k1]);
                for (t = 0; t < 3; t++) {
                    double p[3];
                    p[0] = s->x0[3 * J->bu] + f->c[0] + mids[t][0];
                    p[1] = s->x0[3 * J->bu + 1] + f->c[1] + mids[t][1];
                    p[2] = s->x0[3 * J->bu + 2] + f->c[2];
                    add_spring(s, K, nd, J->bl, J->bu, p, ez, s->kn * wq);
                    add_spring(s, K, nd, J->bl, J->bu, p, ex, s->ks * wq);
                    add_spring(s, K, nd, J->bl, J->bu, p, ey, s->ks * wq);
                }
            }
        } else {
            for (k = J->p0; k < J->p0 + J->np; k++) {
                int b = s->p_side[k] == 0 ? J->bu : J->bl;
                double p[3];
                p[0] = s->x0[3 * b] + s->p_loc[3 * k];
                p[1] = s->x0[3 * b + 1] + s->p_loc[3 * k + 1];
                p[2] = s->x0[3 * b + 2] + s->p_loc[3 * k + 2];
                add_spring(s, K, nd, J->bl, J->bu, p, ez, s->kn * s->p_w[k]);
                add_spring(s, K, nd, J->bl, J->bu, p, ex, s->ks * s->p_w[k]);
                add_spring(s, K, nd, J->bl, J->bu, p, ey, s->ks * s->p_w[k]);
            }
        }
    }
    sel = (int *)malloc(sizeof(int) * (size_t)nd);
    A = (double *)malloc(sizeof(double) * (size_t)nd * nd);
    if (!sel || !A) { free(K); free(sel); free(A); return fail(s, CF_ENOMEM, "out of memory (eigen)"); }
    nsel = 0;
    for (i = 0; i < nd; i++) {
        int d = i % 6;
        if (s->def.planar && !(d == 0 || d == 2 || d == 4)) continue;
        sel[nsel++] = i;
    }
    for (i = 0; i < nsel; i++) {
        int bi = sel[i] / 6 + 1, di = sel[i] % 6;
        double mi = di < 3 ? s->m[bi] : s->inertia[3 * bi + di - 3];
        for (j = 0; j < nsel; j++) {
            int bj = sel[j] / 6 + 1, dj = sel[j] % 6;
            double mj = dj < 3 ? s->m[bj] : s->inertia[3 * bj + dj - 3];
            A[i * nsel + j] = K[sel[i] * nd + sel[j]] / sqrt(mi * mj);
        }
    }
    lam = cf_solver_sym_max_eig(A, nsel);
    free(K); free(sel); free(A);
    if (!(lam > 0.0) || !isfinite(lam)) return fail(s, CF_EINVAL, "stability limit: stiffness matrix has no positive eigenvalue");
    s->dt_crit = 2.0 / sqrt(lam);
    return CF_OK;
}

/* ---- set-up --------------------------------------------------------------------- */

static int check_def(cf_solver *s, const cf_solver_def *d)
{
    if (d->contact < 0 || d->contact > 2) return fail(s, CF_EINVAL, "contact must be 0 (vertex), 1 (perimeter) or 2 (exact), got %d", d->contact);
    if (d->points_per_edge < 1 || d->points_per_edge > 64) return fail(s, CF_EINVAL, "points_per_edge must be in [1, 64], got %d", d->points_per_edge);
    if (!(d->dt >= 0.0) || !isfinite(d->dt)) return fail(s, CF_EINVAL, "dt must be >= 0 (0 = automatic), got %g", d->dt);
    if (!(d->dt_factor > 0.0) || !(d->dt_factor <= 4.0)) return fail(s, CF_EINVAL, "dt_factor must be in (0, 4], got %g", d->dt_factor);
    if (!(d->tail_s >= 0.0) || !isfinite(d->tail_s)) return fail(s, CF_EINVAL, "tail_s must be >= 0, got %g", d->tail_s);
    if (!(d->residual_window_s > 0.0) || !isfinite(d->residual_window_s)) return fail(s, CF_EINVAL, "residual_window_s must be > 0, got %g", d->residual_window_s);
    if (!(d->damping_alpha >= 0.0) || !isfinite(d->damping_alpha)) return fail(s, CF_EINVAL, "damping_alpha must be >= 0, got %g", d->damping_alpha);
    if (!isfinite(d->damping_start_s)) return fail(s, CF_EINVAL, "damping_start_s must be finite, got %g", d->damping_start_s);
    if (!(d->history_dt > 0.0) || !isfinite(d->history_dt)) return fail(s, CF_EINVAL, "history_dt must be > 0, got %g", d->history_dt);
    if (!(d->g > 0.0) || !isfinite(d->g)) return fail(s, CF_EINVAL, "g must be > 0, got %g", d->g);
    if (!(d->energy_tolerance > 0.0)) return fail(s, CF_EINVAL, "energy_tolerance must be > 0, got %g", d->energy_tolerance);
    if (!(d->unstable_tolerance > 0.0)) return fail(s, CF_EINVAL, "unstable_tolerance must be > 0, got %g", d->unstable_tolerance);
    if (!isfinite(d->initial_tilt_rad) || fabs(d->initial_tilt_rad) > 1.0) return fail(s, CF_EINVAL, "initial_tilt_rad must be in [-1, 1], got %g", d->initial_tilt_rad);
    if (!(d->contact_tolerance >= 0.0) || !(d->contact_tolerance < 0.1)) return fail(s, CF_EINVAL, "contact_tolerance must be in [0, 0.1), got %g", d->contact_tolerance);
    return CF_OK;
}

#define ALLOC(ptr, type, count) do { (ptr) = (type *)calloc((size_t)(count) > 0 ? (size_t)(count) : 1, sizeof(type)); \
    if (!(ptr)) { release(s); return fail(s, CF_ENOMEM, "out of memory"); } } while (0)

int cf_solver_setup(cf_solver *s, const cf_solver_def *def, int nblk, const int *nseg,
                    const cf_geometry_segment *segs, double density, double kn, double ks, double mu)
{
    int i, j, k, st, nseg_tot = 0, nbody, nj, np, mode, mm;
    cf_geometry_massprops *bp;
    double *zbot;
    if (!s) return CF_EINVAL;
    release(s);
    s->msg[0] = 0;
    if (!def) return fail(s, CF_EINVAL, "no solver definition");
    st = check_def(s, def);
    if (st) return st;
    if (nblk < 1 || !nseg || !segs) return fail(s, CF_EINVAL, "a column needs at least one block, got %d", nblk);
    for (i = 0; i < nblk; i++) {
        if (nseg[i] < 1) return fail(s, CF_EINVAL, "block %d has %d segments", i, nseg[i]);
        nseg_tot += nseg[i];
    }
    for (i = 0; i < nseg_tot; i++) {
        const cf_geometry_segment *g = &segs[i];
        if (!(g->height > 0) || !(g->r_bottom > 0) || !(g->r_top > 0) || !isfinite(g->height)
            || !isfinite(g->r_bottom) || !isfinite(g->r_top) || !isfinite(g->phase_rad))
            return fail(s, CF_EINVAL, "segment %d: height and radii must be finite and > 0 (got h=%g, r_bottom=%g, r_top=%g)",
                        i, g->height, g->r_bottom, g->r_top);
        if (g->n_sides < 3 || g->n_sides > MAXS) return fail(s, CF_EINVAL, "segment %d: n_sides must be in [3, %d], got %d", i, MAXS, g->n_sides);
    }
    if (!(density > 0) || !isfinite(density)) return fail(s, CF_EINVAL, "density must be > 0, got %g", density);
    if (!(kn > 0) || !isfinite(kn)) return fail(s, CF_EINVAL, "kn must be > 0, got %g", kn);
    if (!(ks > 0) || !isfinite(ks)) return fail(s, CF_EINVAL, "ks must be > 0, got %g", ks);
    if (!(mu > 0) || !isfinite(mu)) return fail(s, CF_EINVAL, "mu must be > 0, got %g", mu);

    s->def = *def;
    s->kn = kn; s->ks = ks; s->mu = mu; s->density = density;
    s->nblk = nblk;
    nbody = def->monolithic ? 2 : nblk + 1;
    nj = def->monolithic ? 1 : nblk;
    s->nbody = nbody; s->nj = nj;
    mode = def->contact; mm = def->points_per_edge;

    ALLOC(s->m, double, nbody); ALLOC(s->inertia, double, 3 * nbody);
    ALLOC(s->x, double, 3 * nbody); ALLOC(s->v, double, 3 * nbody); ALLOC(s->q, double, 4 * nbody);
    ALLOC(s->w, double, 3 * nbody); ALLOC(s->R, double, 9 * nbody); ALLOC(s->F, double, 3 * nbody);
    ALLOC(s->T, double, 3 * nbody); ALLOC(s->x0, double, 3 * nbody); ALLOC(s->q0, double, 4 * nbody);
    ALLOC(s->fext_prev, double, 3 * nbody); ALLOC(s->fdamp_prev, double, 3 * nbody);
    ALLOC(s->tdamp_prev, double, 3 * nbody);
    ALLOC(s->blk_body, int, nblk); ALLOC(s->blk_off, double, 3 * nblk); ALLOC(s->blk_top, double, 3 * nblk);
    ALLOC(s->blk_bot, double, 3 * nblk); ALLOC(s->blk_h, double, nblk); ALLOC(s->blk_m, double, nblk);
    ALLOC(s->joint_diam, double, nblk);
    ALLOC(s->jt, joint_t, nj);
    ALLOC(s->jfn, double, nj);

    bp = (cf_geometry_massprops *)calloc((size_t)nblk, sizeof *bp);
    zbot = (double *)calloc((size_t)nblk + 1, sizeof(double));
    if (!bp || !zbot) { free(bp); free(zbot); release(s); return fail(s, CF_ENOMEM, "out of memory"); }
    {
        int off = 0;
        double mz = 0;
        s->total_mass = 0;
        for (i = 0; i < nblk; i++) {
            cf_geometry_block_props(segs + off, nseg[i], density, &bp[i]);
            zbot[i + 1] = zbot[i] + bp[i].height;
            s->blk_h[i] = bp[i].height; s->blk_m[i] = bp[i].mass;
            s->joint_diam[i] = 2.0 * segs[off].r_bottom;
            s->total_mass += bp[i].mass;
            mz += bp[i].mass * (zbot[i] + bp[i].com_z);
            off += nseg[i];
        }
        s->total_h = zbot[nblk];
        s->com_h = mz / s->total_mass;
        s->base_diam = 2.0 * segs[0].r_bottom;
    }
    /* bodies; body frame origin at the body's centre of mass, axes along the column */
    s->m[0] = INFINITY;
    if (def->monolithic) {
        cf_geometry_massprops all;
        cf_geometry_block_props(segs, nseg_tot, density, &all);
        s->m[1] = all.mass;
        s->inertia[3] = all.ixx; s->inertia[4] = all.ixx; s->inertia[5] = all.izz;
        for (i = 0; i < nblk; i++) {
            s->blk_body[i] = 1;
            s->blk_off[3 * i + 2] = zbot[i] + bp[i].com_z - all.com_z;
            s->blk_bot[3 * i + 2] = zbot[i] - all.com_z;
            s->blk_top[3 * i + 2] = zbot[i + 1] - all.com_z;
        }
    } else {
        for (i = 0; i < nblk; i++) {
            s->m[i + 1] = bp[i].mass;
            s->inertia[3 * (i + 1)] = bp[i].ixx; s->inertia[3 * (i + 1) + 1] = bp[i].ixx;
            s->inertia[3 * (i + 1) + 2] = bp[i].izz;
            s->blk_body[i] = i + 1;
            s->blk_bot[3 * i + 2] = -bp[i].com_z;
            s->blk_top[3 * i + 2] = bp[i].height - bp[i].com_z;
        }
    }
    /* joints and their faces */
    {
        int off = 0;
        int *first = (int *)calloc((size_t)nblk, sizeof(int)), *last = (int *)calloc((size_t)nblk, sizeof(int));
        if (!first || !last) { free(first); free(last); free(bp); free(zbot); release(s); return fail(s, CF_ENOMEM, "out of memory"); }
        for (i = 0; i < nblk; i++) { first[i] = off; last[i] = off + nseg[i] - 1; off += nseg[i]; }
        for (j = 0; j < nj; j++) {
            joint_t *J = &s->jt[j];
            const cf_geometry_segment *bot = &segs[first[j]];
            J->logical = j;
            J->bl = def->monolithic ? 0 : j;
            J->bu = def->monolithic ? 1 : j + 1;
            make_face(&J->fu, bot->n_sides, bot->r_bottom, bot->phase_rad, s->blk_bot[3 * j + 2]);
            if (j == 0) {
                make_face(&J->fl, bot->n_sides, bot->r_bottom, bot->phase_rad, 0.0);
            } else {
                const cf_geometry_segment *top = &segs[last[j - 1]];
                make_face(&J->fl, top->n_sides, top->r_top, top->phase_rad, s->blk_top[3 * (j - 1) + 2]);
            }
            J->area = J->fl.area < J->fu.area ? J->fl.area : J->fu.area;
            {
                const face_t *fa = J->fl.area < J->fu.area ? &J->fl : &J->fu;
                J->polar = fa->area * fa->rc * fa->rc * (2.0 + cos(2.0 * CF_PI / fa->n)) / 6.0;
            }
        }
        free(first); free(last);
    }
    /* sub-contacts: the upper face's points tested against the lower face (side 0)
     * and the lower face's points tested against the upper face (side 1), each set
     * carrying half of the joint area */
    np = 0;
    if (mode != CF_SOLVER_CONTACT_EXACT)
        for (j = 0; j < nj; j++)
            np += count_face_points(s->jt[j].fu.n, mode, mm) + (j == 0 ? 0 : count_face_points(s->jt[j].fl.n, mode, mm));
    s->np = np;
    ALLOC(s->p_side, int, np); ALLOC(s->p_hint, int, np); ALLOC(s->p_ihkw, double, np);
    ALLOC(s->p_homein, int, np); ALLOC(s->p_home, double, 2 * np); ALLOC(s->p_loc, double, 3 * np); ALLOC(s->p_w, double, np);
    if (mode != CF_SOLVER_CONTACT_EXACT) {
        int c = 0, n1, n2;
        /* filled below, then 1 / (2 ks w) per point */
        for (j = 0; j < nj; j++) {
            joint_t *J = &s->jt[j];
            J->p0 = c;
            /* the ground (joint 0) is unbounded: the block's own points carry the whole area */
            n1 = face_points(&J->fu, mode, mm, (j == 0 ? 1.0 : 0.5) * J->area, s->p_loc + 3 * c, s->p_w + c);
            for (k = 0; k < n1; k++) s->p_side[c + k] = 0;
            c += n1;
            n2 = j == 0 ? 0 : face_points(&J->fl, mode, mm, 0.5 * J->area, s->p_loc + 3 * c, s->p_w + c);
            for (k = 0; k < n2; k++) s->p_side[c + k] = 1;
            c += n2;
            J->np = n1 + n2;
            J->n0 = n1;
        }
    }
    /* planar mode with faces symmetric about the x-z plane: the motion is symmetric, so
     * a point at -y mirrors its twin at +y; keep one of each pair with twice its weight
     * (the out-of-plane force and moments they would cancel are discarded anyway) */
    if (def->planar && mode != CF_SOLVER_CONTACT_EXACT) {
        int sym = 1;
        for (j = 0; j < nj && sym; j++) {
            const face_t *ff[2];
            int t;
            ff[0] = &s->jt[j].fl; ff[1] = &s->jt[j].fu;
            for (t = 0; t < 2; t++) {
                const face_t *f = ff[t];
                int m2;
                for (k = 0; k < f->n; k++) {   /* every vertex has a mirror vertex */
                    for (m2 = 0; m2 < f->n; m2++)
                        if (fabs(f->vx[m2] - f->vx[k]) < 1e-12 * f->rc && fabs(f->vy[m2] + f->vy[k]) < 1e-12 * f->rc) break;
                    if (m2 == f->n) { sym = 0; break; }
                }
            }
        }
        if (sym) {
            int c = 0;
            for (j = 0; j < nj; j++) {
                joint_t *J = &s->jt[j];
                int start = c, n0 = 0;
                for (k = J->p0; k < J->p0 + J->np; k++) {
                    double y = s->p_loc[3 * k + 1], scale = 1.0;
                    double r = J->fu.rc;
                    if (y < -1e-9 * r) continue;
                    if (y > 1e-9 * r) scale = 2.0;
                    s->p_side[c] = s->p_side[k];
                    memmove(s->p_loc + 3 * c, s->p_loc + 3 * k, 3 * sizeof(double));
                    s->p_w[c] = scale * s->p_w[k];
                    if (k < J->p0 + J->n0) n0++;
                    c++;
                }
                J->p0 = start; J->np = c - start; J->n0 = n0;
            }
            s->np = np = c;
        }
    }
    for (k = 0; k < np; k++) s->p_ihkw[k] = 0.5 / (ks * s->p_w[k]);
    ALLOC(s->p_lx, double, np); ALLOC(s->p_ly, double, np); ALLOC(s->p_hx, double, np);
    ALLOC(s->p_hy, double, np); ALLOC(s->p_fast, double, np); ALLOC(s->p_knw, double, np);
    ALLOC(s->p_ksw, double, np); ALLOC(s->p_fsx, double, np); ALLOC(s->p_fsy, double, np);
    ALLOC(s->p_state, double, np);
    /* rest position of each point in the frame of the face it touches (face centres
     * aligned); a point within contact_tolerance of a home that lies inside that face
     * is inside the grown polygon: the cheap test of the hot loop */
    for (j = 0; j < nj; j++) {
        joint_t *J = &s->jt[j];
        for (k = J->p0; k < J->p0 + J->np; k++) {
            const face_t *own = s->p_side[k] == 0 ? &J->fu : &J->fl, *oth = s->p_side[k] == 0 ? &J->fl : &J->fu;
            double hx = s->p_loc[3 * k] - own->c[0], hy = s->p_loc[3 * k + 1] - own->c[1];
            double tol = def->contact_tolerance * oth->rc;
            s->p_home[2 * k] = hx; s->p_home[2 * k + 1] = hy;
            s->p_homein[k] = face_inside(oth, hx, hy, 1e-9 * oth->rc);
            s->p_lx[k] = s->p_loc[3 * k]; s->p_ly[k] = s->p_loc[3 * k + 1];
            s->p_hx[k] = hx; s->p_hy[k] = hy;
            /* squared radius of the cheap test (-1: none; the point then takes the polygon test) */
            s->p_fast[k] = (s->p_homein[k] && tol > 2e-9 * oth->rc) ? (tol - 1e-9 * oth->rc) * (tol - 1e-9 * oth->rc) : -1.0;
            s->p_knw[k] = kn * s->p_w[k]; s->p_ksw[k] = ks * s->p_w[k];
        }
        /* every point of a face lies in that face's plane: one body-frame z per face */
        J->lz[0] = J->fu.c[2]; J->lz[1] = J->fl.c[2];
        for (k = J->p0; k < J->p0 + J->np; k++)
            if (s->p_loc[3 * k + 2] != J->lz[s->p_side[k]]) { release(s); return fail(s, CF_EINVAL, "internal: point off its face plane"); }
    }
    /* initial state: exact static equilibrium, joint j pre-compressed by the weight
     * above it (uniform overlap W / (kn A) over the face), shear zero */
    {
        double settle = 0.0, wabove;
        for (i = 0; i < 4 * nbody; i += 4) s->q0[i] = 1.0;
        for (j = 0; j < nj; j++) {
            wabove = 0;
            for (k = (def->monolithic ? 0 : j); k < nblk; k++) wabove += s->blk_m[k] * def->g;
            settle += wabove / (kn * s->jt[j].area);
            if (def->monolithic) {
                cf_geometry_massprops all;
                cf_geometry_block_props(segs, nseg_tot, density, &all);
                s->x0[3 * 1 + 2] = all.com_z - settle;
            } else {
                s->x0[3 * (j + 1) + 2] = zbot[j] + bp[j].com_z - settle;
            }
        }
        if (def->initial_tilt_rad != 0.0) {
            /* rigid rotation about the line through the outermost +x base vertex, parallel to y */
            const face_t *f = &s->jt[0].fu;
            double xp = f->vx[0], th = def->initial_tilt_rad, c = cos(th), sn = sin(th);
            double zp = s->x0[3 * 1 + 2] + f->c[2];
            for (k = 1; k < f->n; k++) if (f->vx[k] > xp) xp = f->vx[k];
            for (i = 1; i < nbody; i++) {
                double dx = s->x0[3 * i] - xp, dz = s->x0[3 * i + 2] - zp;
                s->x0[3 * i] = xp + c * dx + sn * dz;
                s->x0[3 * i + 2] = zp - sn * dx + c * dz;
                s->q0[4 * i] = cos(0.5 * th); s->q0[4 * i + 1] = 0; s->q0[4 * i + 2] = sin(0.5 * th);
                s->q0[4 * i + 3] = 0;
            }
        }
    }
    free(bp); free(zbot);
    {
        /* the stiffness is assembled at the untilted rest state */
        double tilt = s->def.initial_tilt_rad;
        double *xs = (double *)malloc(sizeof(double) * 3 * (size_t)nbody);
        if (!xs) { release(s); return fail(s, CF_ENOMEM, "out of memory"); }
        memcpy(xs, s->x0, sizeof(double) * 3 * (size_t)nbody);
        s->def.initial_tilt_rad = 0;
        st = compute_dt_crit(s);
        s->def.initial_tilt_rad = tilt;
        memcpy(s->x0, xs, sizeof(double) * 3 * (size_t)nbody);
        free(xs);
        if (st) { release(s); return st; }
    }
    s->dt = def->dt > 0 ? def->dt : def->dt_factor * s->dt_crit;
    s->ready = 1;
    return CF_OK;
}

int cf_solver_history_capacity(const cf_solver *s, int n, double dt_rec)
{
    double t_final;
    if (!s || !s->ready || n < 1 || !(dt_rec > 0)) return 0;
    t_final = (n - 1) * dt_rec + s->def.tail_s;
    return (int)floor(t_final / s->def.history_dt + 1e-9) + 2;
}

int cf_solver_set_history_normal(cf_solver *s, double *joint_normal)
{
    if (!s) return CF_EINVAL;
    s->h_fn = joint_normal;
    return CF_OK;
}

int cf_solver_set_history(cf_solver *s, int cap, double *t, double *top, double *pos, double *quat,
                          double *open, double *slip, double *en)
{
    if (!s) return CF_EINVAL;
    if (cap < 0) return fail(s, CF_EINVAL, "history capacity must be >= 0, got %d", cap);
    s->h_cap = cap; s->h_t = t; s->h_top = top; s->h_pos = pos; s->h_quat = quat; s->h_open = open;
    s->h_slip = slip; s->h_en = en;
    return CF_OK;
}

/* ---- the run --------------------------------------------------------------------- */

static inline double ground_acc(const double *a, int n, double dtr, double t)
{
    double f;
    long i;
    if (!a) return 0.0;
    f = t / dtr;
    if (f > (double)(n - 1)) return 0.0;
    i = (long)f;
    if (i >= n - 1) return a[n - 1];
    return a[i] + (f - (double)i) * (a[i + 1] - a[i]);
}

/* face centre and normal (world) of face f of body b */
static inline void face_world(const cf_solver *s, int b, const face_t *f, double *c, double *n)
{
    const double *R = s->R + 9 * b;
    mat_vec(R, f->c, c);
    c[0] += s->x[3 * b]; c[1] += s->x[3 * b + 1]; c[2] += s->x[3 * b + 2];
    n[0] = R[2]; n[1] = R[5]; n[2] = R[8];
}

typedef struct {
    double vs;       /* spring energy, J (only when need) */
    double dslip;    /* slip dissipation this step, J */
    double dswitch;  /* spring energy removed by points leaving/entering a face polygon, J */
    int need;        /* 1: the energy balance is evaluated at this step */
} step_energy;

static inline void apply_pair(cf_solver *s, int bl, int bu, const double *p, const double *Fw)
{
    double r[3], tq[3];
    double *F = s->F, *T = s->T;
    F[3 * bu] += Fw[0]; F[3 * bu + 1] += Fw[1]; F[3 * bu + 2] += Fw[2];
    r[0] = p[0] - s->x[3 * bu]; r[1] = p[1] - s->x[3 * bu + 1]; r[2] = p[2] - s->x[3 * bu + 2];
    v3_cross(r, Fw, tq);
    T[3 * bu] += tq[0]; T[3 * bu + 1] += tq[1]; T[3 * bu + 2] += tq[2];
    if (bl != 0) {
        F[3 * bl] -= Fw[0]; F[3 * bl + 1] -= Fw[1]; F[3 * bl + 2] -= Fw[2];
        r[0] = p[0] - s->x[3 * bl]; r[1] = p[1] - s->x[3 * bl + 1]; r[2] = p[2] - s->x[3 * bl + 2];
        v3_cross(r, Fw, tq);
        T[3 * bl] -= tq[0]; T[3 * bl + 1] -= tq[1]; T[3 * bl + 2] -= tq[2];
    }
}

/* relative velocity of body bu w.r.t. bl at world point p; wwl, wwu: world omegas */
static inline void rel_vel(const cf_solver *s, int bl, int bu, const double *wwl, const double *wwu,
                           const double *p, double *vr)
{
    double r[3], c[3];
    r[0] = p[0] - s->x[3 * bu]; r[1] = p[1] - s->x[3 * bu + 1]; r[2] = p[2] - s->x[3 * bu + 2];
    v3_cross(wwu, r, c);
    vr[0] = s->v[3 * bu] + c[0]; vr[1] = s->v[3 * bu + 1] + c[1]; vr[2] = s->v[3 * bu + 2] + c[2];
    if (bl != 0) {
        r[0] = p[0] - s->x[3 * bl]; r[1] = p[1] - s->x[3 * bl + 1]; r[2] = p[2] - s->x[3 * bl + 2];
        v3_cross(wwl, r, c);
        vr[0] -= s->v[3 * bl] + c[0]; vr[1] -= s->v[3 * bl + 1] + c[1]; vr[2] -= s->v[3 * bl + 2] + c[2];
    }
}

/* 2D sub-contact law in the frame of the face a point is tested against (normal +z):
 * normal force kn w pen, incremental shear (fs, 2 components, turning with that
 * face), Coulomb cap. Returns the slip dissipation: work done on the contact over
 * the increment (trapezoidal) minus the change of its elastic shear energy. */
static inline double law2d(double pen, double dux, double duy, double knw, double kw, double mu,
                           double *fs, double *fn)
{
    double f = knw * pen, lim = mu * f, fx0 = fs[0], fy0 = fs[1], fx, fy, m2;
    *fn = f;
    fx = fx0 - kw * dux; fy = fy0 - kw * duy;
    m2 = fx * fx + fy * fy;
    if (m2 > lim * lim) {
        double sc = lim / sqrt(m2), diss;
        fx *= sc; fy *= sc;
        diss = -0.5 * ((fx0 + fx) * dux + (fy0 + fy) * duy)
               - 0.5 * (fx * fx + fy * fy - fx0 * fx0 - fy0 * fy0) / kw;
        fs[0] = fx; fs[1] = fy;
        return diss;
    }
    fs[0] = fx; fs[1] = fy;
    return 0.0;
}

/* Regular polygon test with a hint: the projection of (X, Y) on the edge normals is
 * unimodal around the polygon, so walking from the last maximising edge finds the
 * maximum in a few steps. Inside iff that maximum <= apothem + tol. */
static inline int face_inside_hint(const face_t *f, double X, double Y, double tol, int *hint)
{
    int n = f->n, k = *hint, kp, km;
    double best, pp, pm;
    if (X * X + Y * Y <= f->apo * f->apo) return 1;
    best = X * f->ec[k] + Y * f->es[k];
    kp = k + 1 == n ? 0 : k + 1;
    pp = X * f->ec[kp] + Y * f->es[kp];
    if (pp > best) {
        do { k = kp; best = pp; kp = k + 1 == n ? 0 : k + 1; pp = X * f->ec[kp] + Y * f->es[kp]; } while (pp > best);
    } else {
        km = k == 0 ? n - 1 : k - 1;
        pm = X * f->ec[km] + Y * f->es[km];
        while (pm > best) { k = km; best = pm; km = k == 0 ? n - 1 : k - 1; pm = X * f->ec[km] + Y * f->es[km]; }
    }
    *hint = k;
    return best <= f->apo + tol;
}

/* The frame constants of one face's pass: relative displacement field over the step
 * (A, W, face frame) and the translation t of the other body into the face frame.
 * The same operations as rel_field + frame_map (t is rel_field's position of the
 * other body, computed once), so bitwise the same values. */
static inline void face_field(const cf_solver *s, int bl, int bu, int side, const double *Rf, const double *cf,
                              const double *ww, double dt, double *A, double *W, double *t)
{
    double vU[3], vL[3], wU[3], wL[3], d[3], xu[3], xl[3], c1[3], c2[3];
    mat_tvec(Rf, s->v + 3 * bu, vU);
    mat_tvec(Rf, ww + 3 * bu, wU);
    d[0] = s->x[3 * bu] - cf[0]; d[1] = s->x[3 * bu + 1] - cf[1]; d[2] = s->x[3 * bu + 2] - cf[2];
    mat_tvec(Rf, d, xu);
    v3_cross(wU, xu, c1);
    if (bl != 0) {
        mat_tvec(Rf, s->v + 3 * bl, vL);
        mat_tvec(Rf, ww + 3 * bl, wL);
        d[0] = s->x[3 * bl] - cf[0]; d[1] = s->x[3 * bl + 1] - cf[1]; d[2] = s->x[3 * bl + 2] - cf[2];
        mat_tvec(Rf, d, xl);
        v3_cross(wL, xl, c2);
    } else {
        vL[0] = vL[1] = vL[2] = 0; wL[0] = wL[1] = wL[2] = 0; c2[0] = c2[1] = c2[2] = 0;
        xl[0] = xl[1] = xl[2] = 0;   /* unused: the ground's face (side 1) has no points */
    }
    A[0] = (vU[0] - vL[0] - c1[0] + c2[0]) * dt;
    A[1] = (vU[1] - vL[1] - c1[1] + c2[1]) * dt;
    A[2] = (vU[2] - vL[2] - c1[2] + c2[2]) * dt;
    W[0] = (wU[0] - wL[0]) * dt; W[1] = (wU[1] - wL[1]) * dt; W[2] = (wU[2] - wL[2]) * dt;
    if (side == 0) { t[0] = xu[0]; t[1] = xu[1]; t[2] = xu[2]; }
    else { t[0] = xl[0]; t[1] = xl[1]; t[2] = xl[2]; }
}

/* The constants of one face's pass over the points that touch it: the frame map and
 * the relative displacement field over the step (both in the face frame), the face's
 * thresholds, and the solver's point arrays. */
typedef struct {
    double M[9], t[3], mz[3];   /* X = M loc + t; mz = M[., 2] * (the points' shared body z) */
    double A[3], W[3];          /* relative displacement of the upper body over the step: A + W x X */
    double sgn;                 /* pen = sgn * Z */
    double pmax;                /* a point deeper than this has passed beside or through the face */
    double tol;                 /* the polygon test's growth, m */
    double kn, ks, mu;
    int unbounded;              /* the face is the (unbounded) ground */
    const face_t *ff;           /* the face the points are tested against */
} face_pass;

/* The sums of one face in the face frame, each component added in point order:
 * force (fx, fy, fz), moment about the face centre (mx, my, mz), spring energy and
 * normal force (vs, jfn; only at steps that evaluate the energy). */
typedef struct {
    double dslip, dswitch;      /* slip dissipation, contact_switch energy (J) */
#ifdef CF_SOLVER_SIMD
    __m128d s01, s23, s45, s67; /* (fx, fy) (fz, mx) (my, mz) (vs, jfn): two sums per instruction */
#else
    double sm[8];
#endif
} face_sums;

/* add the terms t[0..7] of one point (same order as face_sums) */
static inline void sums_add(face_sums *S, const double *t, int need)
{
#ifdef CF_SOLVER_SIMD
    S->s01 = _mm_add_pd(S->s01, _mm_loadu_pd(t));
    S->s23 = _mm_add_pd(S->s23, _mm_loadu_pd(t + 2));
    S->s45 = _mm_add_pd(S->s45, _mm_loadu_pd(t + 4));
    if (need) S->s67 = _mm_add_pd(S->s67, _mm_loadu_pd(t + 6));
#else
    S->sm[0] += t[0]; S->sm[1] += t[1]; S->sm[2] += t[2]; S->sm[3] += t[3]; S->sm[4] += t[4]; S->sm[5] += t[5];
    if (need) { S->sm[6] += t[6]; S->sm[7] += t[7]; }
#endif
}

/* One sub-contact k against the face of P, the full law (any state). Returns 1 and
 * its terms in t when it carries force, 0 when it is open, too deep or off the face. */
static inline int point_law(const cf_solver *s, const face_pass *P, int k, face_sums *S, int *hint, double *t)
{
    double *fsx = s->p_fsx + k, *fsy = s->p_fsy + k, *state = s->p_state + k;
    double lx = s->p_lx[k], ly = s->p_ly[k], w = s->p_w[k], fs[2], fn, dux, duy;
    double X = P->M[0] * lx + P->M[1] * ly + P->mz[0] + P->t[0];
    double Y = P->M[3] * lx + P->M[4] * ly + P->mz[1] + P->t[1];
    double Z = P->M[6] * lx + P->M[7] * ly + P->mz[2] + P->t[2];
    double pen = P->sgn * Z;
    /* state: 0 open (or too deep), 1 in contact, 2 overlapping the plane but outside the
     * face polygon */
    if (!(pen > 0.0) || pen > P->pmax) {
        if (*fsx != 0.0 || *fsy != 0.0) {
            S->dslip += (*fsx * *fsx + *fsy * *fsy) * s->p_ihkw[k];
            *fsx = *fsy = 0.0;
        }
        *state = 0.0;
        return 0;
    }
    if (!(P->unbounded || (X - s->p_hx[k]) * (X - s->p_hx[k]) + (Y - s->p_hy[k]) * (Y - s->p_hy[k]) <= s->p_fast[k]
          || face_inside_hint(P->ff, X, Y, P->tol, hint))) {
        /* slid off the face while compressed: its normal spring energy leaves the
         * model (booked as contact_switch, not as a balance error) */
        if (*state == 1.0) S->dswitch += 0.5 * P->kn * w * pen * pen;
        if (*fsx != 0.0 || *fsy != 0.0) {
            S->dslip += (*fsx * *fsx + *fsy * *fsy) * s->p_ihkw[k];
            *fsx = *fsy = 0.0;
        }
        *state = 2.0;
        return 0;
    }
    if (*state == 2.0) S->dswitch -= 0.5 * P->kn * w * pen * pen;   /* slid onto the face */
    *state = 1.0;
    dux = P->A[0] + P->W[1] * Z - P->W[2] * Y;
    duy = P->A[1] + P->W[2] * X - P->W[0] * Z;
    fs[0] = *fsx; fs[1] = *fsy;
    S->dslip += law2d(pen, dux, duy, P->kn * w, P->ks * w, P->mu, fs, &fn);
    *fsx = fs[0]; *fsy = fs[1];
    /* on both sides the force on the upper body is +fn along the frame's z */
    t[0] = fs[0]; t[1] = fs[1]; t[2] = fn;
    t[3] = Y * fn - Z * fs[1]; t[4] = Z * fs[0] - X * fn; t[5] = X * fs[1] - Y * fs[0];
    t[6] = 0.5 * fn * pen + (fs[0] * fs[0] + fs[1] * fs[1]) * s->p_ihkw[k]; t[7] = fn;
    return 1;
}

/* The points [k0, k1) against the face of P, in point order. With SSE2 (part of every
 * x86-64 CPU) two points go through each instruction on the common path -- in contact
 * at the last step and now, inside the cheap polygon test, sticking -- with the very
 * operations of point_law (each a correctly rounded IEEE operation, no contraction),
 * and their terms join the sums in point order; a pair with any other point takes
 * point_law one point at a time. So the results are bitwise those of the scalar code
 * (build with -DCF_NO_SIMD to check: bench/solver_profile.c prints a result hash). */
static void face_points_run(cf_solver *s, const face_pass *P, int k0, int k1, face_sums *S, int need)
{
    int k = k0;
    double t[8];
#ifdef CF_SOLVER_SIMD
    const double *lx = s->p_lx, *ly = s->p_ly, *hx = s->p_hx, *hy = s->p_hy, *fast = s->p_fast;
    const double *knw = s->p_knw, *ksw = s->p_ksw, *ihkw = s->p_ihkw, *state = s->p_state;
    double *fsx = s->p_fsx, *fsy = s->p_fsy;
    const __m128d M0 = _mm_set1_pd(P->M[0]), M1 = _mm_set1_pd(P->M[1]), M3 = _mm_set1_pd(P->M[3]);
    const __m128d M4 = _mm_set1_pd(P->M[4]), M6 = _mm_set1_pd(P->M[6]), M7 = _mm_set1_pd(P->M[7]);
    const __m128d z0 = _mm_set1_pd(P->mz[0]), z1 = _mm_set1_pd(P->mz[1]), z2 = _mm_set1_pd(P->mz[2]);
    const __m128d t0 = _mm_set1_pd(P->t[0]), t1 = _mm_set1_pd(P->t[1]), t2 = _mm_set1_pd(P->t[2]);
    const __m128d A0 = _mm_set1_pd(P->A[0]), A1 = _mm_set1_pd(P->A[1]);
    const __m128d W0 = _mm_set1_pd(P->W[0]), W1 = _mm_set1_pd(P->W[1]), W2 = _mm_set1_pd(P->W[2]);
    const __m128d sgn = _mm_set1_pd(P->sgn), pmax = _mm_set1_pd(P->pmax), mu = _mm_set1_pd(P->mu);
    const __m128d one = _mm_set1_pd(1.0), half = _mm_set1_pd(0.5), apo2 = _mm_set1_pd(P->ff->apo * P->ff->apo);
    const __m128d apotol = _mm_set1_pd(P->ff->apo + P->tol);
    const __m128d unb = _mm_castsi128_pd(_mm_set1_epi32(P->unbounded ? -1 : 0));
    for (; k + 1 < k1; k += 2) {
        __m128d vlx = _mm_loadu_pd(lx + k), vly = _mm_loadu_pd(ly + k);
        __m128d X = _mm_add_pd(_mm_add_pd(_mm_add_pd(_mm_mul_pd(M0, vlx), _mm_mul_pd(M1, vly)), z0), t0);
        __m128d Y = _mm_add_pd(_mm_add_pd(_mm_add_pd(_mm_mul_pd(M3, vlx), _mm_mul_pd(M4, vly)), z1), t1);
        __m128d Z = _mm_add_pd(_mm_add_pd(_mm_add_pd(_mm_mul_pd(M6, vlx), _mm_mul_pd(M7, vly)), z2), t2);
        __m128d pen = _mm_mul_pd(sgn, Z);
        __m128d dhx = _mm_sub_pd(X, _mm_loadu_pd(hx + k)), dhy = _mm_sub_pd(Y, _mm_loadu_pd(hy + k));
        __m128d d2 = _mm_add_pd(_mm_mul_pd(dhx, dhx), _mm_mul_pd(dhy, dhy));
        __m128d dux = _mm_sub_pd(_mm_add_pd(A0, _mm_mul_pd(W1, Z)), _mm_mul_pd(W2, Y));
        __m128d duy = _mm_sub_pd(_mm_add_pd(A1, _mm_mul_pd(W2, X)), _mm_mul_pd(W0, Z));
        __m128d f = _mm_mul_pd(_mm_loadu_pd(knw + k), pen), lim = _mm_mul_pd(mu, f);
        __m128d kw = _mm_loadu_pd(ksw + k);
        __m128d fx = _mm_sub_pd(_mm_loadu_pd(fsx + k), _mm_mul_pd(kw, dux));
        __m128d fy = _mm_sub_pd(_mm_loadu_pd(fsy + k), _mm_mul_pd(kw, duy));
        __m128d m2 = _mm_add_pd(_mm_mul_pd(fx, fx), _mm_mul_pd(fy, fy));
        __m128d act = _mm_and_pd(_mm_cmpgt_pd(pen, _mm_setzero_pd()), _mm_cmpngt_pd(pen, pmax));
        __m128d st = _mm_loadu_pd(state + k), ok, mx, my, mz, vs;
        int bits, open;
        /* inside: the cheap test around the point's rest position, or the face's
         * inscribed circle (face_inside_hint's first test, which leaves the hint alone) */
        __m128d in = _mm_or_pd(_mm_cmple_pd(d2, _mm_loadu_pd(fast + k)),
                               _mm_cmple_pd(_mm_add_pd(_mm_mul_pd(X, X), _mm_mul_pd(Y, Y)), apo2));
        in = _mm_or_pd(unb, in);
        if ((_mm_movemask_pd(_mm_andnot_pd(in, act)) & _mm_movemask_pd(_mm_cmpeq_pd(st, one))) != 0) {
            /* the polygon test: if the point's hint edge is still its most distant edge
             * (face_inside_hint's walk would stay there), inside iff within apo + tol of
             * it; else (the walk moves) leave the point to point_law */
            const face_t *ff = P->ff;
            int h0 = s->p_hint[k], h1 = s->p_hint[k + 1];
            __m128d ex = _mm_set_pd(ff->ecw[h1 + 1], ff->ecw[h0 + 1]), ey = _mm_set_pd(ff->esw[h1 + 1], ff->esw[h0 + 1]);
            __m128d best = _mm_add_pd(_mm_mul_pd(X, ex), _mm_mul_pd(Y, ey));
            __m128d pp, pm, stay;
            ex = _mm_set_pd(ff->ecw[h1 + 2], ff->ecw[h0 + 2]); ey = _mm_set_pd(ff->esw[h1 + 2], ff->esw[h0 + 2]);
            pp = _mm_add_pd(_mm_mul_pd(X, ex), _mm_mul_pd(Y, ey));
            ex = _mm_set_pd(ff->ecw[h1], ff->ecw[h0]); ey = _mm_set_pd(ff->esw[h1], ff->esw[h0]);
            pm = _mm_add_pd(_mm_mul_pd(X, ex), _mm_mul_pd(Y, ey));
            stay = _mm_and_pd(_mm_cmpngt_pd(pp, best), _mm_cmpngt_pd(pm, best));
            in = _mm_or_pd(in, _mm_and_pd(stay, _mm_cmple_pd(best, apotol)));
        }
        ok = _mm_and_pd(act, in);
        ok = _mm_and_pd(ok, _mm_cmpeq_pd(st, one));
        ok = _mm_and_pd(ok, _mm_cmpngt_pd(m2, _mm_mul_pd(lim, lim)));
        bits = _mm_movemask_pd(ok);
        /* open before and now (state 0 keeps no shear force): nothing to do */
        open = _mm_movemask_pd(_mm_andnot_pd(act, _mm_cmpeq_pd(st, _mm_setzero_pd())));
        if (open == 3) continue;
        mx = _mm_sub_pd(_mm_mul_pd(Y, f), _mm_mul_pd(Z, fy));
        my = _mm_sub_pd(_mm_mul_pd(Z, fx), _mm_mul_pd(X, f));
        mz = _mm_sub_pd(_mm_mul_pd(X, fy), _mm_mul_pd(Y, fx));
        if (bits == 3) {
            _mm_storeu_pd(fsx + k, fx); _mm_storeu_pd(fsy + k, fy);
            S->s01 = _mm_add_pd(_mm_add_pd(S->s01, _mm_unpacklo_pd(fx, fy)), _mm_unpackhi_pd(fx, fy));
            S->s23 = _mm_add_pd(_mm_add_pd(S->s23, _mm_unpacklo_pd(f, mx)), _mm_unpackhi_pd(f, mx));
            S->s45 = _mm_add_pd(_mm_add_pd(S->s45, _mm_unpacklo_pd(my, mz)), _mm_unpackhi_pd(my, mz));
            if (need) {
                vs = _mm_add_pd(_mm_mul_pd(_mm_mul_pd(half, f), pen), _mm_mul_pd(m2, _mm_loadu_pd(ihkw + k)));
                S->s67 = _mm_add_pd(_mm_add_pd(S->s67, _mm_unpacklo_pd(vs, f)), _mm_unpackhi_pd(vs, f));
            }
        } else {
            /* one point at a time, in order: the easy one from the vectors, the other
             * through the full law */
            double vx[2], vy[2], vf[2], vmx[2], vmy[2], vmz[2], vvs[2];
            int l;
            vs = _mm_add_pd(_mm_mul_pd(_mm_mul_pd(half, f), pen), _mm_mul_pd(m2, _mm_loadu_pd(ihkw + k)));
            _mm_storeu_pd(vx, fx); _mm_storeu_pd(vy, fy); _mm_storeu_pd(vf, f); _mm_storeu_pd(vmx, mx);
            _mm_storeu_pd(vmy, my); _mm_storeu_pd(vmz, mz); _mm_storeu_pd(vvs, vs);
            for (l = 0; l < 2; l++) {
                if (open & (1 << l)) continue;
                if (bits & (1 << l)) {
                    fsx[k + l] = vx[l]; fsy[k + l] = vy[l];
                    t[0] = vx[l]; t[1] = vy[l]; t[2] = vf[l]; t[3] = vmx[l]; t[4] = vmy[l]; t[5] = vmz[l];
                    t[6] = vvs[l]; t[7] = vf[l];
                    sums_add(S, t, need);
                } else if (point_law(s, P, k + l, S, s->p_hint + k + l, t)) {
                    sums_add(S, t, need);
                }
            }
        }
    }
#endif
    for (; k < k1; k++)
        if (point_law(s, P, k, S, s->p_hint + k, t)) sums_add(S, t, need);
}

/* Sub-contacts of one joint. Points of the upper face (side 0) are handled in the
 * lower face's frame, points of the lower face (side 1) in the upper face's frame;
 * the forces are summed per side in that frame (force and moment about the face
 * centre, in point order) and turned to world coordinates once per joint. */
static void joint_points(cf_solver *s, joint_t *J, const double *ww, double dt, step_energy *e)
{
    int bl = J->bl, bu = J->bu, side;
    const double *RL = s->R + 9 * bl, *RU = s->R + 9 * bu;
    double cF[2][3], Fs[2][3], Ms[2][3], M0[9];
    int end = J->p0 + J->np, need = e->need;
    face_sums S;
    S.dslip = 0.0; S.dswitch = 0.0;
#ifdef CF_SOLVER_SIMD
    S.s67 = _mm_setzero_pd();
#else
    S.sm[6] = S.sm[7] = 0.0;
#endif
    /* the upper body in the lower face's frame: M0 = RL^T RU; the lower body in the
     * upper face's frame is its transpose (the same products and sums, bitwise) */
    {
        int i, j;
        for (i = 0; i < 3; i++)
            for (j = 0; j < 3; j++)
                M0[3 * i + j] = RL[i] * RU[j] + RL[3 + i] * RU[3 + j] + RL[6 + i] * RU[6 + j];
    }
    for (side = 0; side < 2; side++) {
        const double *Rf = side == 0 ? RL : RU;
        const face_t *ff = side == 0 ? &J->fl : &J->fu;
        int k0 = side == 0 ? J->p0 : J->p0 + J->n0, k1 = side == 0 ? J->p0 + J->n0 : end;
        double lz = J->lz[side], sm[6];
        face_pass P;
        double *c = cF[side];
        if (k1 <= k0) {
            Fs[side][0] = Fs[side][1] = Fs[side][2] = 0.0;
            Ms[side][0] = Ms[side][1] = Ms[side][2] = 0.0;
            c[0] = c[1] = c[2] = 0.0;
            continue;
        }
        mat_vec(Rf, ff->c, c);
        c[0] += s->x[3 * (side == 0 ? bl : bu)];
        c[1] += s->x[3 * (side == 0 ? bl : bu) + 1];
        c[2] += s->x[3 * (side == 0 ? bl : bu) + 2];
        if (side == 0) memcpy(P.M, M0, sizeof P.M);
        else {
            P.M[0] = M0[0]; P.M[1] = M0[3]; P.M[2] = M0[6];
            P.M[3] = M0[1]; P.M[4] = M0[4]; P.M[5] = M0[7];
            P.M[6] = M0[2]; P.M[7] = M0[5]; P.M[8] = M0[8];
        }
        /* relative displacement field over the step, and the other body's origin */
        face_field(s, bl, bu, side, Rf, c, ww, dt, P.A, P.W, P.t);
        P.mz[0] = P.M[2] * lz; P.mz[1] = P.M[5] * lz; P.mz[2] = P.M[8] * lz;
        /* a point deeper than a tenth of the face's radius is not in contact with it: it
         * has passed beside or through the face (a tumbling block after a collapse) */
        P.pmax = 0.1 * ff->rc;
        P.tol = s->def.contact_tolerance * ff->rc;
        P.sgn = side == 0 ? -1.0 : 1.0;
        P.kn = s->kn; P.ks = s->ks; P.mu = s->mu;
        P.unbounded = side == 0 && bl == 0;
        P.ff = ff;
#ifdef CF_SOLVER_SIMD
        S.s01 = S.s23 = S.s45 = _mm_setzero_pd();
        face_points_run(s, &P, k0, k1, &S, need);
        _mm_storeu_pd(sm, S.s01); _mm_storeu_pd(sm + 2, S.s23); _mm_storeu_pd(sm + 4, S.s45);
#else
        S.sm[0] = S.sm[1] = S.sm[2] = S.sm[3] = S.sm[4] = S.sm[5] = 0.0;
        face_points_run(s, &P, k0, k1, &S, need);
        memcpy(sm, S.sm, sizeof sm);
#endif
        mat_vec(Rf, sm, Fs[side]);
        mat_vec(Rf, sm + 3, Ms[side]);
    }
    /* apply: force F at face centre c with moment M about c, on the upper body; the
     * opposite on the lower body */
    for (side = 0; side < 2; side++) {
        double r[3], tq[3];
        const double *Fw = Fs[side], *Mw = Ms[side], *c = cF[side];
        s->F[3 * bu] += Fw[0]; s->F[3 * bu + 1] += Fw[1]; s->F[3 * bu + 2] += Fw[2];
        r[0] = c[0] - s->x[3 * bu]; r[1] = c[1] - s->x[3 * bu + 1]; r[2] = c[2] - s->x[3 * bu + 2];
        v3_cross(r, Fw, tq);
        s->T[3 * bu] += tq[0] + Mw[0]; s->T[3 * bu + 1] += tq[1] + Mw[1]; s->T[3 * bu + 2] += tq[2] + Mw[2];
        if (bl != 0) {
            s->F[3 * bl] -= Fw[0]; s->F[3 * bl + 1] -= Fw[1]; s->F[3 * bl + 2] -= Fw[2];
            r[0] = c[0] - s->x[3 * bl]; r[1] = c[1] - s->x[3 * bl + 1]; r[2] = c[2] - s->x[3 * bl + 2];
            v3_cross(r, Fw, tq);
            s->T[3 * bl] -= tq[0] + Mw[0]; s->T[3 * bl + 1] -= tq[1] + Mw[1]; s->T[3 * bl + 2] -= tq[2] + Mw[2];
        }
    }
    {
        double vj[2];
#ifdef CF_SOLVER_SIMD
        _mm_storeu_pd(vj, S.s67);
#else
        vj[0] = S.sm[6]; vj[1] = S.sm[7];
#endif
        e->vs += vj[0];
        /* the joint's normal force: summed at energy/history steps only (read at history samples) */
        s->jfn[J - s->jt] = vj[1];
    }
    e->dslip += S.dslip;
    e->dswitch += S.dswitch;
}

/* Exact interface: normal pressure integrated over the compressed overlap polygon;
 * shear as one joint-level incremental spring acting at the centre of the lower
 * face (so that its lever arms, hence the stability limit, do not change as the
 * centre of pressure moves to a rocking toe), capped by mu N; torsion as an incremental spring about the joint normal, capped by
 * mu N (2/3) r_eq (uniform pressure on a disc of the compressed area). The shear and
 * torsional stiffnesses are those of the whole joint face (ks A, ks J_polar): with a
 * stiffness that followed the compressed area the stored force would carry an energy
 * that jumps without work as the joint opens; the cap mu N governs an open joint. */
static void joint_exact(cf_solver *s, joint_t *J, const double *ww, double dt, step_energy *e)
{
    int bl = J->bl, bu = J->bu, k, sl, nv;
    const double *RL = s->R + 9 * bl, *RU = s->R + 9 * bu;
    double cL[3], nL[3], cU[3], nU[3], up[2 * MAXS], m[3], X0[3], d[3];
    double p0, px, py, fn, ks = s->ks;
    cf_contact_exact_result r;
    s->jfn[J - s->jt] = 0.0;
    face_world(s, bl, &J->fl, cL, nL);
    face_world(s, bu, &J->fu, cU, nU);
    mat_tvec(RL, nU, m);
    d[0] = cU[0] - cL[0]; d[1] = cU[1] - cL[1]; d[2] = cU[2] - cL[2];
    mat_tvec(RL, d, X0);
    nv = 0;
    if (m[2] > 0.1) {
        for (k = 0; k < J->fu.n; k++) {
            double loc[3], pw[3], X[3];
            loc[0] = J->fu.c[0] + J->fu.vx[k]; loc[1] = J->fu.c[1] + J->fu.vy[k]; loc[2] = J->fu.c[2];
            mat_vec(RU, loc, pw);
            pw[0] += s->x[3 * bu] - cL[0]; pw[1] += s->x[3 * bu + 1] - cL[1]; pw[2] += s->x[3 * bu + 2] - cL[2];
            mat_tvec(RL, pw, X);
            up[2 * k] = X[0]; up[2 * k + 1] = X[1];
        }
        px = m[0] / m[2]; py = m[1] / m[2];
        p0 = -X0[2] - px * X0[0] - py * X0[1];
        /* as for sub-contacts: a face sunk deeper than a tenth of its radius has passed
         * beside or through the other one (tumbling blocks after a collapse) */
        for (k = 0; k < J->fu.n; k++)
            if (p0 + px * up[2 * k] + py * up[2 * k + 1] > 0.1 * J->fl.rc) m[2] = -1.0;
        /* the ground is unbounded: the overlap is the upper face itself */
        if (m[2] <= 0.0) nv = 0;
        else if (bl == 0) nv = cf_contact_exact(up, J->fu.n, up, J->fu.n, p0, px, py, s->kn, &r);
        else nv = cf_contact_exact(J->fl.poly, J->fl.n, up, J->fu.n, p0, px, py, s->kn, &r);
    }
    if (nv == 0 || !(r.force > 0.0)) {
        double st = J->fs[0] * J->fs[0] + J->fs[1] * J->fs[1] + J->fs[2] * J->fs[2];
        if (st > 0.0 || J->mt != 0.0) {
            /* released: stored shear energy counted as dissipated */
            e->dslip += 0.5 * st / (ks * J->area) + 0.5 * J->mt * J->mt / (ks * J->polar);
            J->fs[0] = J->fs[1] = J->fs[2] = 0.0; J->mt = 0.0;
        }
        return;
    }
    {
        double P[3], loc[3], du[3], Fw[3], pen_eq, wr, mt_trial, lim, kt, req;
        loc[0] = r.xc; loc[1] = r.yc; loc[2] = 0.0;
        mat_vec(RL, loc, P);
        P[0] += cL[0]; P[1] += cL[1]; P[2] += cL[2];
        rel_vel(s, bl, bu, ww + 3 * bl, ww + 3 * bu, cL, du);
        du[0] *= dt; du[1] *= dt; du[2] *= dt;
        pen_eq = r.force / (s->kn * J->area);
        e->dslip += contact_point_law(pen_eq, nL, du, J->area, s->kn, ks, s->mu, J->fs, &fn, &sl);
        s->jfn[J - s->jt] = fn;
        Fw[0] = fn * nL[0]; Fw[1] = fn * nL[1]; Fw[2] = fn * nL[2];
        apply_pair(s, bl, bu, P, Fw);
        apply_pair(s, bl, bu, cL, J->fs);
        /* torsion about the joint normal */
        kt = ks * J->polar;
        wr = v3_dot(ww + 3 * bu, nL) - (bl ? v3_dot(ww + 3 * bl, nL) : 0.0);
        mt_trial = J->mt - kt * wr * dt;
        req = sqrt(r.area / CF_PI);
        lim = s->mu * fn * (2.0 / 3.0) * req;
        if (fabs(mt_trial) > lim) {
            double capped = mt_trial > 0 ? lim : -lim;
            /* trapezoidal work on the torsional spring minus its elastic energy change */
            e->dslip += -0.5 * (J->mt + capped) * wr * dt - 0.5 * (capped * capped - J->mt * J->mt) / kt;
            mt_trial = capped;
        }
        J->mt = mt_trial;
        s->T[3 * bu] += J->mt * nL[0]; s->T[3 * bu + 1] += J->mt * nL[1]; s->T[3 * bu + 2] += J->mt * nL[2];
        if (bl) { s->T[3 * bl] -= J->mt * nL[0]; s->T[3 * bl + 1] -= J->mt * nL[1]; s->T[3 * bl + 2] -= J->mt * nL[2]; }
        e->vs += r.energy + 0.5 * (J->fs[0] * J->fs[0] + J->fs[1] * J->fs[1] + J->fs[2] * J->fs[2]) / (ks * J->area)
               + 0.5 * J->mt * J->mt / kt;
    }
}

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

/* max normal gap (m) of the upper face's vertices over the lower face plane, >= 0 */
static double opening(const cf_solver *s, int j)
{
    const joint_t *J;
    double cL[3], nL[3], mx = 0.0;
    int k;
    if (s->def.monolithic && j > 0) return 0.0;
    J = &s->jt[s->def.monolithic ? 0 : j];
    face_world(s, J->bl, &J->fl, cL, nL);
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

/* collapse criteria at the current state; returns the reason, sets *blk */
static int collapse_check(const cf_solver *s, int *blk)
{
    int j, i, nj = s->nj;
    /* overturning: the centre of mass of everything above joint j lies horizontally
     * more than two circumradii from the centre of the supporting face -- past the
     * edge by a full radius, where no ground motion of the record can bring it back
     * (for a slender block this is a tilt of about twice its slenderness angle) */
    for (j = 0; j < nj; j++) {
        const joint_t *J = &s->jt[j];
        double cL[3], nL[3], mx = 0, my = 0, mt = 0, dx, dy;
        /* measured from the lower face's centre, or on the (unbounded) ground from the
         * centre of the block's own bottom face */
        if (J->bl == 0) face_world(s, J->bu, &J->fu, cL, nL);
        else face_world(s, J->bl, &J->fl, cL, nL);
        for (i = J->bu; i < s->nbody; i++) {
            mx += s->m[i] * s->x[3 * i]; my += s->m[i] * s->x[3 * i + 1]; mt += s->m[i];
        }
        dx = mx / mt - cL[0]; dy = my / mt - cL[1];
        if (dx * dx + dy * dy > 4.0 * J->fl.rc * J->fl.rc) { *blk = J->logical; return CF_SOLVER_COLLAPSE_OVERTURNING; }
    }
    /* off the footprint: the centre of a block's bottom face has slid outside the
     * polygon of the face below (in that face's plane): more than half of the
     * joint overhangs. Rocking alone moves this centre by b (1 - cos tilt) only. */
    for (j = 0; j < nj; j++) {
        const joint_t *J = &s->jt[j];
        double cL[3], nL[3], cU[3], nU[3], d[3], X[3];
        if (J->bl == 0) continue;     /* the ground is unbounded */
        face_world(s, J->bl, &J->fl, cL, nL);
        face_world(s, J->bu, &J->fu, cU, nU);
        d[0] = cU[0] - cL[0]; d[1] = cU[1] - cL[1]; d[2] = cU[2] - cL[2];
        mat_tvec(s->R + 9 * J->bl, d, X);
        if (!face_inside(&J->fl, X[0], X[1], 0.0)) { *blk = J->logical; return CF_SOLVER_COLLAPSE_OFF_FOOTPRINT; }
    }
    /* falling: a block's bottom-face centre a quarter of its height below the top
     * face centre of the block that should carry it */
    for (j = 0; j < nj; j++) {
        const joint_t *J = &s->jt[j];
        double cL[3], nL[3], cU[3], nU[3];
        face_world(s, J->bl, &J->fl, cL, nL);
        face_world(s, J->bu, &J->fu, cU, nU);
        if (cU[2] - cL[2] < -0.25 * s->blk_h[J->logical]) { *blk = J->logical; return CF_SOLVER_COLLAPSE_FALLING; }
    }
    *blk = -1;
    return CF_SOLVER_COLLAPSE_NONE;
}

int cf_solver_run(cf_solver *s, const double *ax, const double *ay, const double *az, int nrec, double dtr,
                  double *resid, cf_solver_result *res)
{
    int i, j, nb, nj, nblk, collapsed = 0, cblk = -1, creason = 0, hcount = 0, planar, top;
    long n, nsteps, kres, ring_len, ring_count = 0, ring_pos = 0;
    double dt, t_rec, t_final, vg0 = 0, vs0 = 0, W = 0, Dslip = 0, Ddamp = 0, Dswitch = 0, err_max = 0, scale_max = 0;
    double scale_floor, top0[3], max_top = 0, ctime = NAN, t = 0, g, alpha, tdamp;
    double *ww, *ring, *vold, *wold;
    double ke_win = 0, rest_ke, next_rest;
    int at_rest = 0, st = CF_OK;
    if (!s) return CF_EINVAL;
    if (!res) return fail(s, CF_EINVAL, "no result struct");
    memset(res, 0, sizeof *res);
    res->collapse_time = NAN; res->collapse_block = -1;
    if (!s->ready) return fail(s, CF_ESTATE, "cf_solver_run before a successful cf_solver_setup");
    if (!ax || nrec < 1) return fail(s, CF_EINVAL, "acceleration record is empty");
    if (!(dtr > 0) || !isfinite(dtr)) return fail(s, CF_EINVAL, "record dt must be > 0, got %g", dtr);
    for (i = 0; i < nrec; i++) {
        if (!isfinite(ax[i]) || (ay && !isfinite(ay[i])) || (az && !isfinite(az[i])))
            return fail(s, CF_EINVAL, "non-finite ground acceleration at sample %d", i);
    }
    if (s->def.planar && ay) return fail(s, CF_EINVAL, "planar mode takes one horizontal component (acc_y given)");
    nb = s->nbody; nj = s->nj; nblk = s->nblk; planar = s->def.planar;
    dt = s->dt; g = s->def.g; alpha = s->def.damping_alpha; tdamp = s->def.damping_start_s;
    t_rec = (nrec - 1) * dtr;
    t_final = t_rec + s->def.tail_s;
    nsteps = (long)ceil(t_final / dt - 1e-9);
    kres = (long)floor(0.005 / dt); if (kres < 1) kres = 1;
    ring_len = (long)ceil(s->def.residual_window_s / (kres * dt)) + 1;
    ww = (double *)calloc(3 * (size_t)nb, sizeof(double));
    vold = (double *)calloc(3 * (size_t)nb, sizeof(double));
    wold = (double *)calloc(3 * (size_t)nb, sizeof(double));
    ring = (double *)calloc((size_t)ring_len * 2 * (size_t)nblk, sizeof(double));
    if (!ww || !ring || !vold || !wold) { free(ww); free(ring); free(vold); free(wold); return fail(s, CF_ENOMEM, "out of memory"); }
    s->msg[0] = 0;
    /* reset state */
    memcpy(s->x, s->x0, sizeof(double) * 3 * (size_t)nb);
    memcpy(s->q, s->q0, sizeof(double) * 4 * (size_t)nb);
    memset(s->v, 0, sizeof(double) * 3 * (size_t)nb);
    memset(s->w, 0, sizeof(double) * 3 * (size_t)nb);
    if (s->np > 0) {
        memset(s->p_fsx, 0, sizeof(double) * (size_t)s->np);
        memset(s->p_fsy, 0, sizeof(double) * (size_t)s->np);
        memset(s->p_state, 0, sizeof(double) * (size_t)s->np);
    }
    memset(s->fext_prev, 0, sizeof(double) * 3 * (size_t)nb);
    memset(s->fdamp_prev, 0, sizeof(double) * 3 * (size_t)nb);
    memset(s->tdamp_prev, 0, sizeof(double) * 3 * (size_t)nb);
    for (j = 0; j < nj; j++) { s->jt[j].fs[0] = s->jt[j].fs[1] = s->jt[j].fs[2] = 0; s->jt[j].mt = 0; }
    for (i = 0; i < nb; i++) quat_to_mat(s->q + 4 * i, s->R + 9 * i);
    top = nblk - 1;
    block_point(s, top, s->blk_top + 3 * top, top0);
    scale_floor = 1e-6 * s->total_mass * g * s->total_h;
    rest_ke = 1e-9 * s->total_mass * g * s->com_h;
    next_rest = t_rec + 0.5;

    for (n = 0; n <= nsteps; n++) {
        step_energy e;
        double agx, agy, agz, ke = 0, vg = 0, err = 0.0, scale;
        int damp_on, hist_now;
        t = n * dt;
        hist_now = s->h_cap > 0 && hcount < s->h_cap && t + 0.5 * dt > hcount * s->def.history_dt;
        /* the spring energies (a sum over all sub-contacts) are evaluated every 4th step,
         * at history samples and at the last step; the rest of the ledger every step */
        e.need = (n & 3) == 0 || n == nsteps || hist_now;
        agx = ground_acc(ax, nrec, dtr, t);
        agy = ground_acc(ay, nrec, dtr, t);
        agz = ground_acc(az, nrec, dtr, t);
        damp_on = alpha > 0.0 && t >= tdamp;
        /* 1. rotations, world angular velocities */
        for (i = 1; i < nb; i++) {
            quat_to_mat(s->q + 4 * i, s->R + 9 * i);
            mat_vec(s->R + 9 * i, s->w + 3 * i, ww + 3 * i);
        }
        memset(s->F, 0, sizeof(double) * 3 * (size_t)nb);
        memset(s->T, 0, sizeof(double) * 3 * (size_t)nb);
        /* 2. contacts */
        e.vs = 0; e.dslip = 0; e.dswitch = 0;
        for (j = 0; j < nj; j++) {
            if (s->def.contact == CF_SOLVER_CONTACT_EXACT) joint_exact(s, &s->jt[j], ww, dt, &e);
            else joint_points(s, &s->jt[j], ww, dt, &e);
        }
        Dslip += e.dslip;
        Dswitch += e.dswitch;
        /* 3.-4. external forces, velocity update, work of the external forces
         * (trapezoidal in time, which is what the leapfrog conserves exactly) */
        for (i = 1; i < nb; i++) {
            double mi = s->m[i], *I = s->inertia + 3 * i, fe[3], fd[3] = {0, 0, 0}, td[3] = {0, 0, 0};
            double tb[3], *w = s->w + 3 * i, *v = s->v + 3 * i, wn[3], Iw[3], gyr[3], dxv[3];
            fe[0] = -mi * agx; fe[1] = -mi * agy; fe[2] = -mi * agz;
            if (damp_on) {
                fd[0] = -alpha * mi * v[0]; fd[1] = -alpha * mi * v[1]; fd[2] = -alpha * mi * v[2];
                td[0] = -alpha * I[0] * w[0]; td[1] = -alpha * I[1] * w[1]; td[2] = -alpha * I[2] * w[2];
            }
            /* displacement over the last step (x_n - x_{n-1} = dt v_{n-1/2}) */
            dxv[0] = dt * v[0]; dxv[1] = dt * v[1]; dxv[2] = dt * v[2];
            W += 0.5 * ((s->fext_prev[3 * i] + fe[0]) * dxv[0] + (s->fext_prev[3 * i + 1] + fe[1]) * dxv[1]
                        + (s->fext_prev[3 * i + 2] + fe[2]) * dxv[2]);
            /* damping switches on once and stays on: before that its forces, now and at the
             * last step, are zero and its ledger term is exactly zero (skipped) */
            if (damp_on) {
                Ddamp -= 0.5 * ((s->fdamp_prev[3 * i] + fd[0]) * dxv[0] + (s->fdamp_prev[3 * i + 1] + fd[1]) * dxv[1]
                                + (s->fdamp_prev[3 * i + 2] + fd[2]) * dxv[2]);
                Ddamp -= 0.5 * dt * ((s->tdamp_prev[3 * i] + td[0]) * w[0] + (s->tdamp_prev[3 * i + 1] + td[1]) * w[1]
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
            /* 5. energy at step n: kinetic from the two half-step velocities */
            ke += 0.5 * mi * (vold[3 * i] * v[0] + vold[3 * i + 1] * v[1] + vold[3 * i + 2] * v[2])
                + 0.5 * (I[0] * wold[3 * i] * w[0] + I[1] * wold[3 * i + 1] * w[1] + I[2] * wold[3 * i + 2] * w[2]);
            vg += mi * g * s->x[3 * i + 2];
        }
        if (n == 0) { vg0 = vg; vs0 = e.vs; }
        if (e.need) {
            err = ke + (vg - vg0) + (e.vs - vs0) + Dslip + Ddamp + Dswitch - W;
            scale = ke + fabs(vg - vg0) + fabs(e.vs - vs0) + Dslip + Ddamp + fabs(Dswitch) + fabs(W);
            if (scale > scale_max) scale_max = scale;
            if (fabs(err) > err_max) err_max = fabs(err);
        }
        if (!isfinite(err) || !isfinite(ke)) {
            st = fail(s, CF_EUNSTABLE, "non-finite state at t = %.4f s (step %ld, dt = %.3g s, dt_crit = %.3g s)", t, n, dt, s->dt_crit);
            break;
        }
        /* after a collapse (early_exit off) violent contacts of tumbling blocks are expected:
         * only a non-finite state aborts then */
        if (!collapsed && scale_max > 10.0 * scale_floor && err_max > s->def.unstable_tolerance * scale_max) {
            st = fail(s, CF_EUNSTABLE, "energy balance error %.3g of the energy scale at t = %.4f s: unstable "
                      "(dt = %.3g s, dt_crit = %.3g s)", err_max / scale_max, t, dt, s->dt_crit);
            break;
        }
        /* EDPs at step n */
        {
            double p[3], dx, dy, d2;
            block_point(s, top, s->blk_top + 3 * top, p);
            dx = p[0] - top0[0]; dy = p[1] - top0[1];
            d2 = sqrt(dx * dx + dy * dy);
            if (d2 > max_top) max_top = d2;
            if (n % kres == 0) {
                double *slot = ring + 2 * nblk * ring_pos;
                for (j = 0; j < nblk; j++) dislocation(s, j, slot + 2 * j, slot + 2 * j + 1);
                ring_pos = (ring_pos + 1) % ring_len;
                if (ring_count < ring_len) ring_count++;
            }
            if (hist_now) {
                int h = hcount++;
                if (s->h_t) s->h_t[h] = t;
                if (s->h_top) { s->h_top[2 * h] = dx; s->h_top[2 * h + 1] = dy; }
                for (j = 0; j < nblk; j++) {
                    int b = s->blk_body[j];
                    if (s->h_pos) block_point(s, j, s->blk_off + 3 * j, s->h_pos + 3 * ((size_t)h * nblk + j));
                    if (s->h_quat) memcpy(s->h_quat + 4 * ((size_t)h * nblk + j), s->q + 4 * b, 4 * sizeof(double));
                    if (s->h_open) s->h_open[(size_t)h * nblk + j] = opening(s, j);
                    if (s->h_fn) s->h_fn[(size_t)h * nblk + j] = (s->def.monolithic && j > 0) ? NAN : s->jfn[j];
                    if (s->h_slip) dislocation(s, j, s->h_slip + 2 * ((size_t)h * nblk + j), s->h_slip + 2 * ((size_t)h * nblk + j) + 1);
                }
                if (s->h_en) {
                    double *en = s->h_en + CF_SOLVER_N_ENERGY * (size_t)h;
                    en[0] = ke; en[1] = vg - vg0; en[2] = e.vs - vs0; en[3] = Dslip; en[4] = Ddamp; en[5] = W; en[6] = err;
                    en[7] = Dswitch;
                }
            }
        }
        /* collapse criteria every 4th step (a few ms: far finer than any collapse) */
        if (!collapsed && (n & 3) == 0) {
            creason = collapse_check(s, &cblk);
            if (creason) { collapsed = 1; ctime = t; if (s->def.early_exit) break; }
        }
        if (s->def.early_exit && t > t_rec) {
            if (ke > ke_win) ke_win = ke;
            if (t >= next_rest) {
                if (ke_win < rest_ke) { at_rest = 1; break; }
                ke_win = 0; next_rest += 0.5;
            }
        }
        if (n == nsteps) break;
        /* 6. positions and orientations to n + 1 */
        for (i = 1; i < nb; i++) {
            double dq[4], *qq = s->q + 4 * i;
            s->x[3 * i] += dt * s->v[3 * i];
            s->x[3 * i + 1] += dt * s->v[3 * i + 1];
            s->x[3 * i + 2] += dt * s->v[3 * i + 2];
            quat_from_omega_dt(s->w + 3 * i, dt, dq);
            quat_mul(qq, dq, qq);
            quat_normalize(qq);
        }
    }
    if (n > nsteps) n = nsteps;
    /* residual dislocations: average of the ring buffer over the last window */
    {
        double ud = 0.0;
        for (j = 0; j < nblk; j++) {
            double sx = 0, sy = 0, r;
            long c;
            for (c = 0; c < ring_count; c++) { sx += ring[2 * nblk * c + 2 * j]; sy += ring[2 * nblk * c + 2 * j + 1]; }
            if (ring_count > 0) { sx /= ring_count; sy /= ring_count; }
            r = sqrt(sx * sx + sy * sy);
            if (resid) resid[j] = r;
            if (r / s->joint_diam[j] > ud) ud = r / s->joint_diam[j];
        }
        res->u_d = ud;
    }
    if (scale_max < scale_floor) scale_max = scale_floor;
    res->u_top = max_top / s->base_diam;
    res->max_top_disp = max_top;
    res->collapsed = collapsed;
    res->collapse_block = collapsed ? cblk : -1;
    res->collapse_reason = collapsed ? creason : 0;
    res->collapse_time = ctime;
    res->n_steps = n;
    res->t_end = n * dt;
    res->dt = dt;
    res->dt_crit = s->dt_crit;
    res->energy_error = err_max / scale_max;
    res->energy_scale = scale_max;
    res->energy_warning = res->energy_error > s->def.energy_tolerance;
    res->at_rest_exit = at_rest;
    res->n_history = hcount;
    if (st == CF_OK && res->energy_warning)
        snprintf(s->msg, CF_MSG_LEN, "energy balance error %.3g of the energy scale exceeds the tolerance %.3g "
                 "(dt = %.3g s, dt_crit = %.3g s)", res->energy_error, s->def.energy_tolerance, dt, s->dt_crit);
    free(ww); free(ring); free(vold); free(wold);
    return st;
}
