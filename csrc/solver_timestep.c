/*
 * solver_timestep.c -- the time step: the stability limit of the whole linearised
 * stack (translations and rotations of all blocks together, every contact spring
 * closed), dt_crit = 2 / omega_max, from the largest eigenvalue of M^-1/2 K M^-1/2.
 * A per-block estimate is too long for a stack (about 1.3 ms against 1.0 ms for the
 * default column) and was seen to run unstable while Coulomb slip hid the runaway
 * energy; the whole-stack limit times dt_factor (default 0.8) does not.
 *
 * Up to 99 moving bodies the matrix is dense and its eigenvalue found by Householder
 * reduction (O(n^3): 0.5 ms for the default column); from 100 bodies on, by band LDL^T
 * Sturm counts (solver_band.c, O(n b^2)): 800 drums took 114 s of set-up on the dense path.
 */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "solver_internal.h"
#include "solver_math_internal.h"

/* Largest eigenvalue of a symmetric n x n matrix (row-major; a is destroyed):
 * Householder reduction to tridiagonal form (eigenvalues only), then bisection on
 * the Sturm sequence count to full double precision. O(n^3) with a small constant:
 * about 1 ms for the 78 x 78 stack of the default column (cyclic Jacobi took ~20 ms). */
double cf_solver_timestep_sym_max_eig(double *a, int n)
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

/* The stiffness matrix of the stack (6 DOFs per moving body), dense (band < 0: K[i * nd + j]) or,
 * for tall stacks, as its lower band (K[i * (band + 1) + i - j], j <= i): a joint couples only a
 * body and the one below, so every entry lies within 11 of the diagonal. */
typedef struct cf_stiffness {
    double *K;
    int nd, band;
} stiffness;

#define BAND 11             /* half-bandwidth of the stack's stiffness: two neighbouring bodies */
#define BAND_MIN_DOF 600    /* from 100 moving bodies on, the O(n b^2) band path (solver_band.c) */

static inline void stiff_add(stiffness *S, int i, int j, double v)
{
    if (S->band < 0) S->K[(size_t)i * S->nd + j] += v;
    else if (i >= j) S->K[(size_t)i * (S->band + 1) + (i - j)] += v;
}

/* Add a spring of stiffness k along e at world point p between bodies bl, bu (at rest). */
static void add_spring(const cf_solver *s, stiffness *S, int bl, int bu, const double *p, const double *e, double k)
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
        for (j = 0; j < nb; j++) stiff_add(S, idx[i], idx[j], k * b[i] * b[j]);
}

/* The contact model's springs, joint by joint, in the order its stiffness hook gives them, then the
 * connectors'. */
static int add_model_springs(cf_solver *s, stiffness *S)
{
    cf_springs K = {NULL, 0, 0, 0};
    int j, i;
    for (j = 0; j < s->nj && !K.nomem; j++) {
        const cf_joint *J = &s->jt[j];
        K.n = 0;
        s->model->stiffness(s, s->contact, J, &K);
        for (i = 0; i < K.n; i++) add_spring(s, S, J->bl, J->bu, K.v[i].p, K.v[i].e, K.v[i].k);
    }
    /* the connectors' springs (engaged), each between its joint's bodies */
    for (i = 0; s->conn && i < s->conn->n && !K.nomem; i++) {
        const cf_joint *J = &s->jt[s->conn->d[i].joint];
        int k;
        K.n = 0;
        cf_solver_connectors_springs(s, s->conn, i, &K);
        for (k = 0; k < K.n; k++) add_spring(s, S, J->bl, J->bu, K.v[k].p, K.v[k].e, K.v[k].k);
    }
    free(K.v);
    return K.nomem ? cf_solver_fail(s, CF_ENOMEM, "out of memory (contact springs)") : CF_OK;
}

int cf_solver_timestep_limit(cf_solver *s)
{
    int nd = 6 * (s->nbody - 1), j, i, nsel, band = nd >= BAND_MIN_DOF ? BAND : -1;
    size_t nK = band < 0 ? (size_t)nd * nd : (size_t)nd * (BAND + 1);
    double *K = (double *)calloc(nK, sizeof(double));
    double *A;
    int *sel;
    double lam;
    stiffness S;
    if (!K) return cf_solver_fail(s, CF_ENOMEM, "out of memory (stiffness matrix)");
    S.K = K; S.nd = nd; S.band = band;
    if (add_model_springs(s, &S)) { free(K); return CF_ENOMEM; }
    sel = (int *)malloc(sizeof(int) * (size_t)nd);
    A = (double *)malloc(sizeof(double) * nK);
    if (!sel || !A) { free(K); free(sel); free(A); return cf_solver_fail(s, CF_ENOMEM, "out of memory (eigen)"); }
    nsel = 0;
    for (i = 0; i < nd; i++) {
        int d = i % 6;
        if (s->def.planar && !(d == 0 || d == 2 || d == 4)) continue;
        sel[nsel++] = i;
    }
    if (band < 0) {
        for (i = 0; i < nsel; i++) {
            int bi = sel[i] / 6 + 1, di = sel[i] % 6;
            double mi = di < 3 ? s->m[bi] : s->inertia[3 * bi + di - 3];
            for (j = 0; j < nsel; j++) {
                int bj = sel[j] / 6 + 1, dj = sel[j] % 6;
                double mj = dj < 3 ? s->m[bj] : s->inertia[3 * bj + dj - 3];
                A[i * nsel + j] = K[sel[i] * nd + sel[j]] / sqrt(mi * mj);
            }
        }
        lam = cf_solver_timestep_sym_max_eig(A, nsel);
    } else {
        /* the selected DOFs keep their order, so the scaled matrix keeps the band */
        memset(A, 0, sizeof(double) * nK);
        for (i = 0; i < nsel; i++) {
            int bi = sel[i] / 6 + 1, di = sel[i] % 6;
            double mi = di < 3 ? s->m[bi] : s->inertia[3 * bi + di - 3];
            for (j = i - BAND > 0 ? i - BAND : 0; j <= i; j++) {
                int bj = sel[j] / 6 + 1, dj = sel[j] % 6, off = sel[i] - sel[j];
                double mj = dj < 3 ? s->m[bj] : s->inertia[3 * bj + dj - 3];
                if (off <= BAND) A[(size_t)i * (BAND + 1) + (i - j)] = K[(size_t)sel[i] * (BAND + 1) + off] / sqrt(mi * mj);
            }
        }
        lam = cf_solver_band_max_eig(A, nsel, BAND);
    }
    free(K); free(sel); free(A);
    if (!(lam > 0.0) || !isfinite(lam)) return cf_solver_fail(s, CF_EINVAL, "stability limit: stiffness matrix has no positive eigenvalue");
    s->dt_crit = 2.0 / sqrt(lam);
    return CF_OK;
}

