/*
 * solver_points.c -- contact model "points": each joint carries sub-contact points
 * (the polygon vertices, or the nodes of a refined face mesh) with the law of
 * contact_law.h. Points of the upper face (side 0) are handled in the lower face's
 * frame, points of the lower face (side 1) in the upper face's frame; the forces are
 * summed per side in that frame (force and moment about the face centre, in point
 * order) and turned to world coordinates once per joint.
 *
 * This file holds the joint driver and the scalar runner over a face's points; the
 * SSE2 runner (solver_points_sse2.c) gives the same bits, two points at a time.
 */
#include <string.h>

#include "solver_math_internal.h"
#include "solver_points_internal.h"

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

void cf_solver_points_joint(cf_solver *s, cf_joint *J, const double *ww, double dt, cf_step_energy *e,
                            cf_points_run_fn run)
{
    int bl = J->bl, bu = J->bu, side;
    const double *RL = s->R + 9 * bl, *RU = s->R + 9 * bu;
    double cF[2][3], Fs[2][3], Ms[2][3], M0[9];
    int end = J->p0 + J->np, need = e->need;
    cf_face_sums S;
    S.dslip = 0.0; S.dswitch = 0.0;
    S.sm[6] = S.sm[7] = 0.0;
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
        const cf_face *ff = side == 0 ? &J->fl : &J->fu;
        int k0 = side == 0 ? J->p0 : J->p0 + J->n0, k1 = side == 0 ? J->p0 + J->n0 : end;
        double lz = J->lz[side], sm[6];
        cf_face_pass P;
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
        /* a point coming onto the face deeper than a hundredth of its radius starts unstretched */
        P.pent = 0.01 * ff->rc;
        P.tol = s->def.contact_tolerance * ff->rc;
        P.sgn = side == 0 ? -1.0 : 1.0;
        P.kn = J->kn; P.mu = J->mu;
        P.unbounded = side == 0 && bl == 0;
        P.ff = ff;
        S.sm[0] = S.sm[1] = S.sm[2] = S.sm[3] = S.sm[4] = S.sm[5] = 0.0;
        run(s, &P, k0, k1, &S, need);
        memcpy(sm, S.sm, sizeof sm);
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
    e->vs += S.sm[6];
    /* the joint's normal force: summed at energy/history steps only (read at history samples) */
    s->jfn[J - s->jt] = S.sm[7];
    e->dslip += S.dslip;
    e->dswitch += S.dswitch;
}

/* The scalar runner: every point through the full law, in order. */
static void run_scalar(cf_solver *s, const cf_face_pass *P, int k0, int k1, cf_face_sums *S, int need)
{
    int k;
    double t[8];
    for (k = k0; k < k1; k++)
        if (cf_point_law(s, P, k, S, s->p_hint + k, t)) cf_sums_add(S, t, need);
}

static void joint_scalar(cf_solver *s, cf_joint *J, const double *ww, double dt, cf_step_energy *e)
{
    cf_solver_points_joint(s, J, ww, dt, e, run_scalar);
}

const cf_solver_contact_model cf_solver_points_model = {
    "points",
    "Sub-contact points (polygon vertices, or a refined face mesh with lumped area "
    "weights), each with the soft Coulomb law of contact_law.h; scalar, one point at a time.",
    joint_scalar,
};
