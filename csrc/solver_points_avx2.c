/*
 * solver_points_avx2.c -- the "points" contact model, four points per AVX2 instruction
 * on the sticking path; compiled for AVX2 by a function attribute (no -m flag: the
 * library still runs on any x86-64) and chosen at run time on CPUs that have AVX2
 * (cf_solver_points_sse2_run). No FMA is enabled and contraction is off.
 *
 * The same scheme as solver_points_sse2.c, on four lanes: a block of four points in
 * contact at the last step and now, inside the cheap polygon tests and sticking runs
 * CF_LAW_TRIAL and CF_LAW_TERMS of contact_law.h instantiated with the AVX2 operators
 * (each lane the operations of the scalar law, in its order), and the terms join the
 * face sums point by point in point order; a block with any other point takes its
 * points one at a time (cf_point_law for the hard ones). The last one to three points
 * of a face run as a block whose extra lanes (the next points in the arrays) are never
 * active; at the very end of the arrays they go to the SSE2 pairs. So the results are bitwise those of the scalar
 * runner; scripts/check_result_hashes.sh compares this build with the SSE2-only
 * (-DCF_FORCE_SSE2) and scalar (-DCF_NO_SIMD) builds.
 */
#include "solver_internal.h"

#ifdef CF_SOLVER_SIMD
#include "solver_points_internal.h"

#ifdef CF_SOLVER_AVX2
#include <immintrin.h>

#define AVX2 __attribute__((target("avx2")))

/* the face sums as the SSE2 runner keeps them: (fx, fy) (fz, mx) (my, mz) (vs, jfn) */

/* add the terms of four points, (a, b) pair by pair, in point order */
static inline AVX2 __m128d add4(__m128d acc, __m256d a, __m256d b)
{
    __m256d lo = _mm256_unpacklo_pd(a, b), hi = _mm256_unpackhi_pd(a, b);   /* (a0 b0 a2 b2) (a1 b1 a3 b3) */
    acc = _mm_add_pd(acc, _mm256_castpd256_pd128(lo));
    acc = _mm_add_pd(acc, _mm256_castpd256_pd128(hi));
    acc = _mm_add_pd(acc, _mm256_extractf128_pd(lo, 1));
    return _mm_add_pd(acc, _mm256_extractf128_pd(hi, 1));
}

AVX2 void cf_solver_points_avx2_run(cf_solver *s, const cf_face_pass *P, int k0, int k1, cf_face_sums *S, int need)
{
    int k = k0;
    cf_simd_sums V;
    const double *lx = s->p_lx, *ly = s->p_ly, *hx = s->p_hx, *hy = s->p_hy, *fast = s->p_fast;
    const double *knw = s->p_knw, *ksw = s->p_ksw, *ihkw = s->p_ihkw, *state = s->p_state;
    double *fsx = s->p_fsx, *fsy = s->p_fsy;
    const __m256d M0 = _mm256_set1_pd(P->M[0]), M1 = _mm256_set1_pd(P->M[1]), M3 = _mm256_set1_pd(P->M[3]);
    const __m256d M4 = _mm256_set1_pd(P->M[4]), M6 = _mm256_set1_pd(P->M[6]), M7 = _mm256_set1_pd(P->M[7]);
    const __m256d z0 = _mm256_set1_pd(P->mz[0]), z1 = _mm256_set1_pd(P->mz[1]), z2 = _mm256_set1_pd(P->mz[2]);
    const __m256d t0 = _mm256_set1_pd(P->t[0]), t1 = _mm256_set1_pd(P->t[1]), t2 = _mm256_set1_pd(P->t[2]);
    const __m256d A0 = _mm256_set1_pd(P->A[0]), A1 = _mm256_set1_pd(P->A[1]);
    const __m256d W0 = _mm256_set1_pd(P->W[0]), W1 = _mm256_set1_pd(P->W[1]), W2 = _mm256_set1_pd(P->W[2]);
    const __m256d sgn = _mm256_set1_pd(P->sgn), pmax = _mm256_set1_pd(P->pmax), mu = _mm256_set1_pd(P->mu);
    const __m256d one = _mm256_set1_pd(1.0), half = _mm256_set1_pd(0.5), zero = _mm256_setzero_pd();
    const __m256d apo2 = _mm256_set1_pd(P->ff->apo * P->ff->apo), apotol = _mm256_set1_pd(P->ff->apo + P->tol);
    const __m256d unb = _mm256_castsi256_pd(_mm256_set1_epi64x(P->unbounded ? -1 : 0));
    const __m256d all = _mm256_castsi256_pd(_mm256_set1_epi64x(-1));
    cf_simd_sums_load(&V, S);
    for (; k < k1; k += 4) {
        /* the last one to three points of the face: a block whose extra lanes are the
         * next points of the arrays (read, never active, counted open, their shear
         * rewritten unchanged at most), unless the arrays end there */
        __m256d valid = all;
        int inval = 0;
        if (k + 3 >= k1) {
            if (k + 4 > s->np) break;
            inval = 15 & ~((1 << (k1 - k)) - 1);
            valid = _mm256_castsi256_pd(_mm256_set_epi64x(inval & 8 ? 0 : -1, inval & 4 ? 0 : -1, inval & 2 ? 0 : -1, -1));
        }
        __m256d vlx = _mm256_loadu_pd(lx + k), vly = _mm256_loadu_pd(ly + k);
        __m256d X = _mm256_add_pd(_mm256_add_pd(_mm256_add_pd(_mm256_mul_pd(M0, vlx), _mm256_mul_pd(M1, vly)), z0), t0);
        __m256d Y = _mm256_add_pd(_mm256_add_pd(_mm256_add_pd(_mm256_mul_pd(M3, vlx), _mm256_mul_pd(M4, vly)), z1), t1);
        __m256d Z = _mm256_add_pd(_mm256_add_pd(_mm256_add_pd(_mm256_mul_pd(M6, vlx), _mm256_mul_pd(M7, vly)), z2), t2);
        __m256d pen = _mm256_mul_pd(sgn, Z);
        __m256d dhx = _mm256_sub_pd(X, _mm256_loadu_pd(hx + k)), dhy = _mm256_sub_pd(Y, _mm256_loadu_pd(hy + k));
        __m256d d2 = _mm256_add_pd(_mm256_mul_pd(dhx, dhx), _mm256_mul_pd(dhy, dhy));
        __m256d dux = _mm256_sub_pd(_mm256_add_pd(A0, _mm256_mul_pd(W1, Z)), _mm256_mul_pd(W2, Y));
        __m256d duy = _mm256_sub_pd(_mm256_add_pd(A1, _mm256_mul_pd(W2, X)), _mm256_mul_pd(W0, Z));
        __m256d f, lim, fx, fy, m2, mx, my, mz, vs, in, ok;
        __m256d act = _mm256_and_pd(_mm256_cmp_pd(pen, zero, _CMP_GT_OQ), _mm256_cmp_pd(pen, pmax, _CMP_NGT_UQ));
        __m256d st = _mm256_loadu_pd(state + k), st1 = _mm256_cmp_pd(st, one, _CMP_EQ_OQ);
        int bits, open;
        act = _mm256_and_pd(act, valid);
        CF_LAW_TRIAL(_mm256_add_pd, _mm256_sub_pd, _mm256_mul_pd, pen, dux, duy, _mm256_loadu_pd(knw + k),
                     _mm256_loadu_pd(ksw + k), mu, _mm256_loadu_pd(fsx + k), _mm256_loadu_pd(fsy + k),
                     f, lim, fx, fy, m2);
        /* inside: the cheap test around the point's rest position, or the face's
         * inscribed circle (face_inside_hint's first test, which leaves the hint alone) */
        in = _mm256_or_pd(_mm256_cmp_pd(d2, _mm256_loadu_pd(fast + k), _CMP_LE_OQ),
                          _mm256_cmp_pd(_mm256_add_pd(_mm256_mul_pd(X, X), _mm256_mul_pd(Y, Y)), apo2, _CMP_LE_OQ));
        in = _mm256_or_pd(unb, in);
        if (_mm256_movemask_pd(_mm256_and_pd(_mm256_andnot_pd(in, act), st1)) != 0) {
            /* the polygon test: if the point's hint edge is still its most distant edge
             * (face_inside_hint's walk would stay there), inside iff within apo + tol of
             * it; else (the walk moves) leave the point to cf_point_law */
            const cf_face *ff = P->ff;
            const int *h = s->p_hint + k;
            __m256d ex = _mm256_set_pd(ff->ecw[h[3] + 1], ff->ecw[h[2] + 1], ff->ecw[h[1] + 1], ff->ecw[h[0] + 1]);
            __m256d ey = _mm256_set_pd(ff->esw[h[3] + 1], ff->esw[h[2] + 1], ff->esw[h[1] + 1], ff->esw[h[0] + 1]);
            __m256d best = _mm256_add_pd(_mm256_mul_pd(X, ex), _mm256_mul_pd(Y, ey)), pp, pm, stay;
            ex = _mm256_set_pd(ff->ecw[h[3] + 2], ff->ecw[h[2] + 2], ff->ecw[h[1] + 2], ff->ecw[h[0] + 2]);
            ey = _mm256_set_pd(ff->esw[h[3] + 2], ff->esw[h[2] + 2], ff->esw[h[1] + 2], ff->esw[h[0] + 2]);
            pp = _mm256_add_pd(_mm256_mul_pd(X, ex), _mm256_mul_pd(Y, ey));
            ex = _mm256_set_pd(ff->ecw[h[3]], ff->ecw[h[2]], ff->ecw[h[1]], ff->ecw[h[0]]);
            ey = _mm256_set_pd(ff->esw[h[3]], ff->esw[h[2]], ff->esw[h[1]], ff->esw[h[0]]);
            pm = _mm256_add_pd(_mm256_mul_pd(X, ex), _mm256_mul_pd(Y, ey));
            stay = _mm256_and_pd(_mm256_cmp_pd(pp, best, _CMP_NGT_UQ), _mm256_cmp_pd(pm, best, _CMP_NGT_UQ));
            in = _mm256_or_pd(in, _mm256_and_pd(stay, _mm256_cmp_pd(best, apotol, _CMP_LE_OQ)));
        }
        ok = _mm256_and_pd(_mm256_and_pd(act, in), st1);
        ok = _mm256_and_pd(ok, _mm256_cmp_pd(m2, CF_LAW_CAP2(_mm256_mul_pd, lim), _CMP_NGT_UQ));
        bits = _mm256_movemask_pd(ok);
        /* open before and now, not overlapping the plane (state 0 keeps no shear force; a
         * point of state 0 deeper than pmax goes to state 3 in cf_point_law): nothing to do */
        open = _mm256_movemask_pd(_mm256_andnot_pd(_mm256_cmp_pd(pen, zero, _CMP_GT_OQ),
                                                   _mm256_cmp_pd(st, zero, _CMP_EQ_OQ))) | inval;
        if (open == 15) continue;
        CF_LAW_TERMS(_mm256_add_pd, _mm256_sub_pd, _mm256_mul_pd, half, X, Y, Z, pen, f, fx, fy, m2,
                     _mm256_loadu_pd(ihkw + k), mx, my, mz, vs);
        if (bits == 15) {
            _mm256_storeu_pd(fsx + k, fx); _mm256_storeu_pd(fsy + k, fy);
            V.s01 = add4(V.s01, fx, fy);
            V.s23 = add4(V.s23, f, mx);
            V.s45 = add4(V.s45, my, mz);
            if (need) V.s67 = add4(V.s67, vs, f);
        } else if ((bits | open) == 15) {
            /* sticking points and points that stay open (a rocking face): the open ones
             * keep their (zero) shear and add exact +0.0 terms, which leave the sums
             * unchanged (a sum that starts at +0.0 is never -0.0) */
            _mm256_storeu_pd(fsx + k, _mm256_blendv_pd(_mm256_loadu_pd(fsx + k), fx, ok));
            _mm256_storeu_pd(fsy + k, _mm256_blendv_pd(_mm256_loadu_pd(fsy + k), fy, ok));
            fx = _mm256_and_pd(fx, ok); fy = _mm256_and_pd(fy, ok); f = _mm256_and_pd(f, ok);
            mx = _mm256_and_pd(mx, ok); my = _mm256_and_pd(my, ok); mz = _mm256_and_pd(mz, ok);
            V.s01 = add4(V.s01, fx, fy);
            V.s23 = add4(V.s23, f, mx);
            V.s45 = add4(V.s45, my, mz);
            if (need) V.s67 = add4(V.s67, _mm256_and_pd(vs, ok), f);
        } else {
            /* one point at a time, in order: the easy ones from the vectors, the others
             * through the full law */
            double vx[4], vy[4], vf[4], vmx[4], vmy[4], vmz[4], vvs[4];
            _mm256_storeu_pd(vx, fx); _mm256_storeu_pd(vy, fy); _mm256_storeu_pd(vf, f);
            _mm256_storeu_pd(vmx, mx); _mm256_storeu_pd(vmy, my); _mm256_storeu_pd(vmz, mz);
            _mm256_storeu_pd(vvs, vs);
            cf_simd_lanes_in_order(s, P, S, &V, k, 4, open, bits, vx, vy, vf, vmx, vmy, vmz, vvs, need);
        }
    }
    cf_simd_sums_store(&V, S);
    /* the last one to three points of the arrays: two at a time */
    if (k < k1) cf_solver_points_sse2_pairs(s, P, k, k1, S, need);
}

#else
typedef int cf_solver_points_avx2_unused;
#endif
#else
/* ISO C forbids an empty translation unit */
typedef int cf_solver_points_avx2_unused;
#endif
