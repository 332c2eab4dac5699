/*
 * solver_points_wide.h -- the "points" contact model's face runner on CF_BW points per
 * instruction, written once over the lane operators of solver_lanes.h and instantiated per
 * width by solver_points_w2.c (SSE2), solver_points_w4.c (AVX2) and solver_points_w8.c
 * (AVX-512F), each of which defines CF_BW and includes this text. solver_points.c chooses
 * the width from CPUID at set-up.
 *
 * The common path -- a block of points in contact at the last step and now, inside the
 * cheap polygon tests, sticking -- runs CF_LAW_TRIAL and CF_LAW_TERMS of contact_law.h on
 * the lanes (each lane the operations of the scalar law, in its order), and the terms join
 * the face sums point by point in point order; points that stay open add exact +0.0 (a sum
 * that starts at +0.0 is never -0.0, so this leaves it unchanged); a block with any other
 * point takes its points one at a time (cf_point_law for the hard ones). A face's last
 * points run as a block whose extra lanes (the next points of the arrays) are never active;
 * at the very end of the arrays the next narrower runner takes them. So the results are
 * bitwise those of the scalar runner (cf_points_run_scalar, solver_points_internal.h); scripts/check_result_hashes.sh
 * compares the default build with the AVX2-capped, SSE2-only and scalar builds.
 */
#include "solver_internal.h"

#if defined(CF_SOLVER_SIMD) && (CF_BW == 2 || (CF_BW == 4 && defined(CF_SOLVER_AVX2)) || (CF_BW == 8 && defined(CF_SOLVER_AVX512)))
#include "solver_points_internal.h"
#include "solver_lanes.h"

/* this width's runner, and the next narrower one */
#if CF_BW == 8
#define CF_POINTS_RUN cf_solver_points_w8_run
#define CF_NARROWER cf_solver_points_w4_run
#elif CF_BW == 4
#define CF_POINTS_RUN cf_solver_points_w4_run
#define CF_NARROWER cf_solver_points_w2_run
#else
#define CF_POINTS_RUN cf_solver_points_w2_run
#define CF_NARROWER cf_points_run_scalar
#endif

/* add the terms of the block's points to a pair of face sums, (a, b) point by point, in point order */
static inline cf_v2 CF_BN(add_pairs)(cf_v2 acc, VD a, VD b)
{
    int l;
    for (l = 0; l < CF_BW; l++) acc = acc + (cf_v2){a[l], b[l]};
    return acc;
}

void CF_POINTS_RUN(cf_points *pts, const cf_face_pass *P, int k0, int k1, cf_face_sums *S, int need)
{
    int k = k0, l;
    cf_simd_sums V;
    const double *lx = pts->lx, *ly = pts->ly, *hx = pts->hx, *hy = pts->hy, *fast = pts->fast;
    const double *knw = pts->knw, *ksw = pts->ksw, *ihkw = pts->ihkw, *state = pts->state;
    double *fsx = pts->fsx, *fsy = pts->fsy;
    const double M0 = P->M[0], M1 = P->M[1], M3 = P->M[3], M4 = P->M[4], M6 = P->M[6], M7 = P->M[7];
    const double apo2 = P->ff->apoc * P->ff->apoc, apotol = P->ff->apo + P->tol;
    const VD zero = {0}, half = zero + 0.5, mu = zero + P->mu;
    const VM all = ~(VM)zero, unb = P->unbounded ? all : (VM)zero;
    const int full = (1 << CF_BW) - 1;
    cf_simd_sums_load(&V, S);
    for (; k < k1; k += CF_BW) {
        /* the last points of the face: a block whose extra lanes are the next points of the
         * arrays (read, never active, counted open, their shear rewritten unchanged at
         * most), unless the arrays end there */
        VM valid = all, act, st1, in, ok;
        VD X, Y, Z, pen, dhx, dhy, dux, duy, st, f, lim, fx, fy, m2, mx, my, mz, vs;
        VD vlx, vly;
        int inval = 0, bits, open;
        if (k + CF_BW - 1 >= k1) {
            if (k + CF_BW > pts->np) break;   /* before any load: the block would read past the arrays */
            inval = full & ~((1 << (k1 - k)) - 1);
            for (l = k1 - k; l < CF_BW; l++) valid[l] = 0;
        }
        vlx = CF_BN(ld)(lx + k); vly = CF_BN(ld)(ly + k);
        CF_POINT_AT(M0, M1, M3, M4, M6, M7, P->mz[0], P->mz[1], P->mz[2], P->t[0], P->t[1], P->t[2], vlx, vly, X, Y, Z);
        pen = P->sgn * Z;
        dhx = X - CF_BN(ld)(hx + k); dhy = Y - CF_BN(ld)(hy + k);
        CF_POINT_DU(P->A[0], P->A[1], P->W[0], P->W[1], P->W[2], X, Y, Z, dux, duy);
        act = (pen > 0.0) & ~(pen > P->pmax) & valid;
        st = CF_BN(ld)(state + k);
        st1 = cf_point_state_is(st, CF_POINT_CONTACT);
        CF_LAW_TRIAL(CF_LAW_SADD, CF_LAW_SSUB, CF_LAW_SMUL, pen, dux, duy, CF_BN(ld)(knw + k), CF_BN(ld)(ksw + k),
                     mu, CF_BN(ld)(fsx + k), CF_BN(ld)(fsy + k), f, lim, fx, fy, m2);
        /* inside: the cheap test around the point's rest position, or the face's
         * inscribed circle (face_inside_hint's first test, which leaves the hint alone) */
        in = CF_LANES_QUICK_IN(dhx, dhy, CF_BN(ld)(fast + k), X, Y, apo2) | unb;
        if (CF_BW_BITS(act & ~in & st1)) {
            /* the polygon test: if the point's hint edge is still its most distant edge
             * (face_inside_hint's walk would stay there), inside iff within apo + tol of
             * it; else (the walk moves) leave the point to cf_point_law */
            const cf_face *ff = P->ff;
            const int *h = pts->hint + k;
            VD c0, s0, c1, s1, c2, s2, best;
            VM stay;
            for (l = 0; l < CF_BW; l++) {
                c0[l] = ff->ecw[h[l] + 1]; s0[l] = ff->esw[h[l] + 1];
                c1[l] = ff->ecw[h[l] + 2]; s1[l] = ff->esw[h[l] + 2];
                c2[l] = ff->ecw[h[l]]; s2[l] = ff->esw[h[l]];
            }
            CF_LANES_HINT_EDGE(X, Y, c0, s0, c1, s1, c2, s2, best, stay);
            in = in | (stay & (best <= apotol));
        }
        ok = act & in & st1 & ~(m2 > CF_LAW_CAP2(CF_LAW_SMUL, lim));
        bits = CF_BW_BITS(ok);
        /* open before and now, not overlapping the plane (an open point keeps no shear
         * force; an open point deeper than pmax goes too deep in cf_point_law): nothing to do */
        open = CF_BW_BITS(~(pen > 0.0) & cf_point_state_is(st, CF_POINT_OPEN)) | inval;
        if (open == full) continue;
        CF_LAW_TERMS(CF_LAW_SADD, CF_LAW_SSUB, CF_LAW_SMUL, half, X, Y, Z, pen, f, fx, fy, m2, CF_BN(ld)(ihkw + k),
                     mx, my, mz, vs);
        if ((bits | open) == full) {
            /* sticking points, and points that stay open (a rocking face), which keep their
             * (zero) shear and add exact +0.0 terms */
            if (bits != full) {
                fx = CF_BW_SEL(ok, fx, CF_BN(ld)(fsx + k)); fy = CF_BW_SEL(ok, fy, CF_BN(ld)(fsy + k));
            }
            CF_BN(st)(fsx + k, fx); CF_BN(st)(fsy + k, fy);
            if (bits != full) {
                fx = CF_BN(mask)(fx, ok); fy = CF_BN(mask)(fy, ok); f = CF_BN(mask)(f, ok);
                mx = CF_BN(mask)(mx, ok); my = CF_BN(mask)(my, ok); mz = CF_BN(mask)(mz, ok);
                vs = CF_BN(mask)(vs, ok);
            }
            V.s01 = CF_BN(add_pairs)(V.s01, fx, fy);
            V.s23 = CF_BN(add_pairs)(V.s23, f, mx);
            V.s45 = CF_BN(add_pairs)(V.s45, my, mz);
            if (need) V.s67 = CF_BN(add_pairs)(V.s67, vs, f);
        } else {
            /* one point at a time, in order: the easy ones from the vectors, the others
             * through the full law */
            double vx[CF_BW], vy[CF_BW], vf[CF_BW], vmx[CF_BW], vmy[CF_BW], vmz[CF_BW], vvs[CF_BW];
            CF_BN(st)(vx, fx); CF_BN(st)(vy, fy); CF_BN(st)(vf, f); CF_BN(st)(vmx, mx);
            CF_BN(st)(vmy, my); CF_BN(st)(vmz, mz); CF_BN(st)(vvs, vs);
            cf_simd_lanes_in_order(pts, P, S, &V, k, CF_BW, open, bits, vx, vy, vf, vmx, vmy, vmz, vvs, need);
        }
    }
    cf_simd_sums_store(&V, S);
    /* the last points of the arrays: the next narrower runner */
    if (k < k1) CF_NARROWER(pts, P, k, k1, S, need);
}

#undef CF_POINTS_RUN
#undef CF_NARROWER
#include "solver_lanes_end.h"
#else
/* ISO C forbids an empty translation unit (a width this build leaves out) */
typedef int CF_POINTS_UNUSED;
#endif
