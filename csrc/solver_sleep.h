/*
 * solver_sleep.h -- sleeping joints of the points models (option `sleep`, margin `sleep_margin`):
 * "model only what a scene needs". Included by solver_points.c (the single run) and
 * solver_batch.c (a lane of the batch), so that both evaluate the same operations.
 *
 * A joint falls asleep at a ledger step of its run (every CF_LEDGER_STEPS: cf_step_energy.ledger) when every
 * point of both its faces is in sticking contact with a margin m = sleep_margin: state
 * CF_POINT_CONTACT, depth pen_k >= CF_SLEEP_PEN_FLOOR rc and below pmax, |fs_k| <= (1 - m) mu fn_k,
 * and inside the cheap polygon test (within sqrt(fast) of its rest position, or within the face's
 * inscribed circle). While every point sticks, the law of contact_law.h is linear in the pose:
 * per side, a point's position is X_k = gX . l_k (likewise Y, Z) with l_k = (lx, ly, 1) and
 * g = (M0, M1, mz0 + t0; M3, M4, mz1 + t1; M6, M7, mz2 + t2) the side's frame map (cf_face_pass),
 * so its normal force is kn w sgn gZ . l_k, and its shear fs_k = fs_k(sleep) - ks w (Ux . l_k,
 * Uy . l_k) with Ux = sum over the steps of (0, 0, A0) + W1 gZ - W2 gY and Uy = sum of
 * (0, 0, A1) + W2 gX - W0 gZ (the increments dux = A0 + W1 Z - W2 Y, duy = A1 + W2 X - W0 Z of the
 * law, summed: exact, the points' positions being linear in g). The face sums (force, moment about
 * the face centre, spring energy, normal force) are then bilinear forms in g and U with the
 * sleep-time sums Fx = sum l_k fsx_k, Fy, E0 = sum |fs_k|^2 / (2 ks w) and the fixed moments
 * Q = sum kn w l l^T, Qs = sum ks w l l^T: the sleeping joint costs O(1) per step instead of
 * O(points), and its forces are the full law's in exact arithmetic (they differ by round-off only).
 *
 * The criterion that wakes it, each step before the step is taken, from the bounds over every point
 * (rho = max |lx|, |ly| of the side's points): depth change D = rho (|dg6| + |dg7|) + |dg8|,
 * tangential move T = rho (|dg0| + |dg1| + |dg3| + |dg4|) + |dg2| + |dg5| (dg = g - g(sleep)),
 * shear displacement U = rho (|Ux0| + |Ux1| + |Uy0| + |Uy1|) + |Ux2| + |Uy2|. It stays asleep while
 *   D <= m min_k pen_k (and <= m (pmax - max_k pen_k)): no point opens or goes too deep,
 *   ks U + mu kn D <= m min_k (mu kn pen_k - |fs_k| / w_k): no point reaches the Coulomb cap,
 *   T <= m min_k (inside slack of point k): no point leaves the polygon (nor changes its hint);
 * so every point of a sleeping joint is a point the full law would have kept sticking: sleeping
 * changes results by round-off only, whatever m. On waking (before the step), every point's stored
 * shear is set from the linear map, fs_k = fs_k(sleep) - ks w (Ux . l_k, Uy . l_k), and the full law
 * takes the step. No slip, release or switch happens while asleep: no dissipation is booked.
 *
 * The state saved per joint (CF_SLEEP_ND doubles, in the model's state copy when `sleep` is on):
 * asleep flag, the tries' back-off (cf_sleep_try), and per side Ux, Uy, Fx, Fy, E0, g(sleep) and the three budgets. The points' own
 * state keeps its sleep-time values while the joint sleeps.
 */
#ifndef CF_SOLVER_SLEEP_H
#define CF_SOLVER_SLEEP_H

#include <math.h>

#include "solver_points_internal.h"

/* a point falls asleep only at least this fraction of its face's circumradius deep (far above the
 * round-off of its depth) */
#define CF_SLEEP_PEN_FLOOR 1e-9

enum {
    CF_SL_UX = 0, CF_SL_UY = 3, CF_SL_FX = 6, CF_SL_FY = 9, CF_SL_E0 = 12, CF_SL_GS = 13, CF_SL_BN = 22,
    CF_SL_BT = 23, CF_SL_BI = 24, CF_SL_SIDE = 25,
    /* [0]: asleep (0 or 1), [1]: tries still to skip, [2]: tries skipped after the last failure, then
     * side 0's, side 1's */
    CF_SL_S0 = 3, CF_SLEEP_ND = CF_SL_S0 + 2 * CF_SL_SIDE
};

/* after a failed try, a joint skips 1, 3, 7, 15 of its next tries (at most 15: a try every 64 steps) */
#define CF_SLEEP_BACKOFF_MAX 15.0

/* the side's g from its pass (see the top) */
static inline void cf_sleep_g(const cf_face_pass *P, double *g)
{
    g[0] = P->M[0]; g[1] = P->M[1]; g[2] = P->mz[0] + P->t[0];
    g[3] = P->M[3]; g[4] = P->M[4]; g[5] = P->mz[1] + P->t[1];
    g[6] = P->M[6]; g[7] = P->M[7]; g[8] = P->mz[2] + P->t[2];
}

/* a^T Q b (Q symmetric 3 x 3 stored as (00, 01, 02, 11, 12, 22), doubles) and a . b, for a and b of any
 * lane type: one text for the single run and the batch's lanes */
#define CF_SLEEP_QF(q, a, b)                                                                         \
    ((a)[0] * ((q)[0] * (b)[0] + (q)[1] * (b)[1] + (q)[2] * (b)[2])                                  \
     + (a)[1] * ((q)[1] * (b)[0] + (q)[3] * (b)[1] + (q)[4] * (b)[2])                                \
     + (a)[2] * ((q)[2] * (b)[0] + (q)[4] * (b)[1] + (q)[5] * (b)[2]))
#define CF_SLEEP_DOT(a, b) ((a)[0] * (b)[0] + (a)[1] * (b)[1] + (a)[2] * (b)[2])

/* The fixed moments of side `side` of joint PJ's points: Q, Qs (6 each) and rho. */
static inline void cf_sleep_moments(const cf_points *pts, const cf_points_joint *PJ, int side, double *q, double *qs,
                                    double *rho)
{
    int k, k0 = side == 0 ? PJ->p0 : PJ->p0 + PJ->n0, k1 = side == 0 ? PJ->p0 + PJ->n0 : PJ->p0 + PJ->np, i;
    for (i = 0; i < 6; i++) q[i] = qs[i] = 0.0;
    *rho = 0.0;
    for (k = k0; k < k1; k++) {
        double l[3] = {pts->lx[k], pts->ly[k], 1.0}, a = pts->knw[k], b = pts->ksw[k];
        q[0] += a * l[0] * l[0]; q[1] += a * l[0] * l[1]; q[2] += a * l[0]; q[3] += a * l[1] * l[1];
        q[4] += a * l[1]; q[5] += a;
        qs[0] += b * l[0] * l[0]; qs[1] += b * l[0] * l[1]; qs[2] += b * l[0]; qs[3] += b * l[1] * l[1];
        qs[4] += b * l[1]; qs[5] += b;
        if (fabs(l[0]) > *rho) *rho = fabs(l[0]);
        if (fabs(l[1]) > *rho) *rho = fabs(l[1]);
    }
}

/* One side of a sleeping joint at this step, on any lane type T (double, or a lane vector: ZERO its
 * zero, ABS its absolute value): the accumulated U advanced by the step's field into u (6: Ux, Uy); ok
 * (an int, or a lane mask) where every bound is within its budget (else the joint wakes); the side's
 * sums sm[0..5] (force, moment: face frame) and, where need, its spring energy and normal force added
 * to vs and fn. sd: the side's sleep state (CF_SL_SIDE values of T); q, qs, rho: its moments
 * (cf_sleep_moments); g: its frame map (cf_sleep_g); A0 ... W2: the step's field. */
#define CF_SLEEP_SIDE(T, ZERO, ABS, sd, q, qs, rho, kn, ks, mu, sgn, g, A0, A1, W0, W1, W2, u, sm, vs, fn, need, ok) \
    do {                                                                                                         \
        T dg_[9], D_, T_, U_, fz_;                                                                               \
        const T *gx_ = (g), *gy_ = (g) + 3, *gz_ = (g) + 6, *Fx_ = (sd) + CF_SL_FX, *Fy_ = (sd) + CF_SL_FY;      \
        T *ux_ = (u), *uy_ = (u) + 3;                                                                            \
        int i_;                                                                                                  \
        for (i_ = 0; i_ < 3; i_++) {                                                                             \
            ux_[i_] = (sd)[CF_SL_UX + i_] + ((W1) * gz_[i_] - (W2) * gy_[i_] + (i_ == 2 ? (A0) : (ZERO)));      \
            uy_[i_] = (sd)[CF_SL_UY + i_] + ((W2) * gx_[i_] - (W0) * gz_[i_] + (i_ == 2 ? (A1) : (ZERO)));      \
        }                                                                                                        \
        for (i_ = 0; i_ < 9; i_++) dg_[i_] = (g)[i_] - (sd)[CF_SL_GS + i_];                                     \
        D_ = (rho) * (ABS(dg_[6]) + ABS(dg_[7])) + ABS(dg_[8]);                                                  \
        T_ = (rho) * (ABS(dg_[0]) + ABS(dg_[1]) + ABS(dg_[3]) + ABS(dg_[4])) + ABS(dg_[2]) + ABS(dg_[5]);       \
        U_ = (rho) * (ABS(ux_[0]) + ABS(ux_[1]) + ABS(uy_[0]) + ABS(uy_[1])) + ABS(ux_[2]) + ABS(uy_[2]);       \
        (ok) = (D_ <= (sd)[CF_SL_BN]) & ((ks) * U_ + (mu) * (kn) * D_ <= (sd)[CF_SL_BT]) & (T_ <= (sd)[CF_SL_BI]); \
        /* sum fn_k, sum fs_k, and the moments sum (Y fn - Z fy, Z fx - X fn, X fy - Y fx) */                  \
        fz_ = (sgn) * ((q)[2] * gz_[0] + (q)[4] * gz_[1] + (q)[5] * gz_[2]);                                   \
        (sm)[0] = Fx_[2] - ((qs)[2] * ux_[0] + (qs)[4] * ux_[1] + (qs)[5] * ux_[2]);                           \
        (sm)[1] = Fy_[2] - ((qs)[2] * uy_[0] + (qs)[4] * uy_[1] + (qs)[5] * uy_[2]);                           \
        (sm)[2] = fz_;                                                                                           \
        (sm)[3] = (sgn) * CF_SLEEP_QF(q, gy_, gz_) - (CF_SLEEP_DOT(gz_, Fy_) - CF_SLEEP_QF(qs, gz_, uy_));       \
        (sm)[4] = (CF_SLEEP_DOT(gz_, Fx_) - CF_SLEEP_QF(qs, gz_, ux_)) - (sgn) * CF_SLEEP_QF(q, gx_, gz_);       \
        (sm)[5] = (CF_SLEEP_DOT(gx_, Fy_) - CF_SLEEP_QF(qs, gx_, uy_))                                           \
                  - (CF_SLEEP_DOT(gy_, Fx_) - CF_SLEEP_QF(qs, gy_, ux_));                                        \
        if (need) {                                                                                              \
            /* sum kn w pen^2 / 2 + |fs|^2 / (2 ks w) */                                                         \
            (vs) = (vs) + (0.5 * CF_SLEEP_QF(q, gz_, gz_) + (sd)[CF_SL_E0]                                       \
                           - (CF_SLEEP_DOT(Fx_, ux_) + CF_SLEEP_DOT(Fy_, uy_))                                   \
                           + 0.5 * (CF_SLEEP_QF(qs, ux_, ux_) + CF_SLEEP_QF(qs, uy_, uy_)));                     \
            (fn) = (fn) + fz_;                                                                                   \
        }                                                                                                        \
    } while (0)

/* CF_SLEEP_SIDE on one joint of one run (sd: the state of that joint's side, read in place) */
static inline int cf_sleep_side(const double *sd, const double *q, const double *qs, double rho,
                                const cf_joint *J, const cf_face_pass *P, double *u, double *sm, double *vs,
                                double *fn, int need)
{
    double g[9];
    int ok;
    cf_sleep_g(P, g);
    CF_SLEEP_SIDE(double, 0.0, fabs, sd, q, qs, rho, J->kn, J->ks, P->mu, P->sgn, g, P->A[0], P->A[1], P->W[0],
                  P->W[1], P->W[2], u, sm, *vs, *fn, need, ok);
    return ok;
}

/* A sleeping joint's step: both sides (P[side], has[side]: the side has points; q, qs, rho per
 * side). 1: it stays asleep, its sums in sm[side][0..5], its spring energy and normal force in *vs,
 * *fn (zero unless need), its U advanced in sl; 0: it wakes, sl untouched. */
static inline int cf_sleep_joint(double *sl, const double (*q)[6], const double (*qs)[6], const double *rho,
                                 const cf_joint *J, const cf_face_pass *P, const int *has, double (*sm)[6],
                                 double *vs, double *fn, int need)
{
    double u[2][6];
    int side, i;
    *vs = 0.0; *fn = 0.0;
    for (side = 0; side < 2; side++) {
        for (i = 0; i < 6; i++) sm[side][i] = 0.0;
        if (has[side] && !cf_sleep_side(sl + CF_SL_S0 + side * CF_SL_SIDE, q[side], qs[side], rho[side], J,
                                        &P[side], u[side], sm[side], vs, fn, need))
            return 0;
    }
    for (side = 0; side < 2; side++)
        if (has[side])
            for (i = 0; i < 6; i++) sl[CF_SL_S0 + side * CF_SL_SIDE + i] = u[side][i];
    return 1;
}

/* Wake the joint of points [p0, p0 + np) (the first n0 on side 0): every point's stored shear
 * from the linear map (its state is stride apart: the batch's lanes), the flag cleared. */
static inline void cf_sleep_wake(const cf_points *pts, const cf_points_joint *PJ, double *sl, int sls, double *fsx,
                                 double *fsy, int stride)
{
    int k, i, side;
    double u[2][6];
    for (side = 0; side < 2; side++)
        for (i = 0; i < 6; i++) u[side][i] = sl[(size_t)(CF_SL_S0 + side * CF_SL_SIDE + CF_SL_UX + i) * (size_t)sls];
    for (k = PJ->p0; k < PJ->p0 + PJ->np; k++) {
        const double *ux = u[k < PJ->p0 + PJ->n0 ? 0 : 1], *uy = ux + 3;
        const double lx = pts->lx[k], ly = pts->ly[k], ksw = pts->ksw[k];
        size_t o = (size_t)k * (size_t)stride;
        fsx[o] = fsx[o] - ksw * (ux[0] * lx + ux[1] * ly + ux[2]);
        fsy[o] = fsy[o] - ksw * (uy[0] * lx + uy[1] * ly + uy[2]);
    }
    sl[0] = 0.0;
}

/* Try to put the joint to sleep after the full law's step (the points' state as the step left it,
 * stride apart; P[side]: the step's passes, has[side]: the side has points; m: sleep_margin).
 * Returns 1 (asleep, its sleep state in sl) when every point sticks with the margin, else 0. */
static inline int cf_sleep_try_points(const cf_points *pts, const cf_points_joint *PJ, const cf_joint *J,
                                      const cf_face_pass *P, const int *has, double m, double *sl, int sls,
                                      const double *fsx, const double *fsy, const double *pst, int stride)
{
    int side, k, i;
    for (side = 0; side < 2; side++) {
        int k0 = side == 0 ? PJ->p0 : PJ->p0 + PJ->n0, k1 = side == 0 ? PJ->p0 + PJ->n0 : PJ->p0 + PJ->np;
        const cf_face_pass *Q = &P[side];
        double sd[CF_SL_SIDE], g[9], pmin = INFINITY, pmx = 0.0, smin = INFINITY, imin = INFINITY;
        const double apo = Q->ff->apoc, floor = CF_SLEEP_PEN_FLOOR * Q->ff->rc;
        if (!has[side]) continue;
        cf_sleep_g(Q, g);
        for (i = 0; i < 12; i++) sd[i] = 0.0;   /* U, Fx, Fy */
        sd[CF_SL_E0] = 0.0;
        for (k = k0; k < k1; k++) {
            size_t o = (size_t)k * (size_t)stride;
            const double lx = pts->lx[k], ly = pts->ly[k], w = pts->w[k], fx = fsx[o], fy = fsy[o];
            double X, Y, pen, fs, sk, in;
            if (!cf_point_state_is(pst[o], CF_POINT_CONTACT)) return 0;
            X = g[0] * lx + g[1] * ly + g[2];
            Y = g[3] * lx + g[4] * ly + g[5];
            pen = Q->sgn * (g[6] * lx + g[7] * ly + g[8]);
            if (!(pen >= floor) || !(pen < Q->pmax)) return 0;
            fs = sqrt(fx * fx + fy * fy);
            sk = Q->mu * J->kn * pen - fs / w;   /* slip margin per unit area */
            if (!(fs <= (1.0 - m) * Q->mu * pts->knw[k] * pen)) return 0;
            if (Q->unbounded) in = INFINITY;
            else {
                double dx = X - pts->hx[k], dy = Y - pts->hy[k], r = sqrt(X * X + Y * Y);
                in = apo - r;
                if (pts->fast[k] >= 0.0) {
                    double a = sqrt(pts->fast[k]) - sqrt(dx * dx + dy * dy);
                    if (a > in) in = a;
                }
                if (!(in > 0.0)) return 0;
            }
            if (pen < pmin) pmin = pen;
            if (pen > pmx) pmx = pen;
            if (sk < smin) smin = sk;
            if (in < imin) imin = in;
            sd[CF_SL_FX] += fx * lx; sd[CF_SL_FX + 1] += fx * ly; sd[CF_SL_FX + 2] += fx;
            sd[CF_SL_FY] += fy * lx; sd[CF_SL_FY + 1] += fy * ly; sd[CF_SL_FY + 2] += fy;
            sd[CF_SL_E0] += (fx * fx + fy * fy) * pts->ihkw[k];
        }
        for (i = 0; i < 9; i++) sd[CF_SL_GS + i] = g[i];
        sd[CF_SL_BN] = m * (pmin < Q->pmax - pmx ? pmin : Q->pmax - pmx);
        sd[CF_SL_BT] = m * smin;
        sd[CF_SL_BI] = m * imin;
        for (i = 0; i < CF_SL_SIDE; i++) sl[(size_t)(CF_SL_S0 + side * CF_SL_SIDE + i) * (size_t)sls] = sd[i];
    }
    sl[0] = 1.0;
    return 1;
}

/* cf_sleep_try_points at the joint's tries, with a back-off: after a failed try the joint skips 1, 3,
 * 7, then 15 of its next tries (a joint of a strongly moving run is not checked point by point every
 * fourth step), a success clears it. */
static inline int cf_sleep_try(const cf_points *pts, const cf_points_joint *PJ, const cf_joint *J,
                               const cf_face_pass *P, const int *has, double m, double *sl, int sls,
                               const double *fsx, const double *fsy, const double *pst, int stride)
{
    double *wait = sl + sls, *level = sl + 2 * sls;
    if (*wait > 0.0) {
        *wait -= 1.0;
        return 0;
    }
    if (cf_sleep_try_points(pts, PJ, J, P, has, m, sl, sls, fsx, fsy, pst, stride)) {
        *level = 0.0;
        return 1;
    }
    *level = 2.0 * *level + 1.0 > CF_SLEEP_BACKOFF_MAX ? CF_SLEEP_BACKOFF_MAX : 2.0 * *level + 1.0;
    *wait = *level;
    return 0;
}

#endif
