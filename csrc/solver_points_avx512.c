/*
 * solver_points_avx512.c -- the "points" contact model, eight points per AVX-512
 * instruction on the sticking path; compiled for AVX-512F by a function attribute (no
 * -m flag) and chosen at run time on CPUs that have it (cf_solver_points_sse2_run).
 * No FMA is enabled and contraction is off.
 *
 * The scheme of solver_points_avx2.c on eight lanes: a block of points in contact at
 * the last step and now, inside the cheap polygon tests and sticking runs CF_LAW_TRIAL
 * and CF_LAW_TERMS of contact_law.h instantiated with the AVX-512 operators, and the
 * terms join the face sums point by point in point order; points that stay open add
 * exact +0.0; a block with any other point takes its points one at a time
 * (cf_point_law for the hard ones). A face's last points run as a block whose extra
 * lanes (the next points of the arrays) are never active; at the very end of the
 * arrays the AVX2 runner takes them. scripts/check_result_hashes.sh compares this build
 * with the AVX2-capped, SSE2-only and scalar builds.
 */
#include "solver_internal.h"

#ifdef CF_SOLVER_SIMD
#include "solver_points_internal.h"

#ifdef CF_SOLVER_AVX512
#include <immintrin.h>

#define AVX512 __attribute__((target("avx512f")))


/* add the terms of four points, (a, b) pair by pair, in point order */
static inline AVX512 __m128d add4(__m128d acc, __m256d a, __m256d b)
{
    __m256d lo = _mm256_unpacklo_pd(a, b), hi = _mm256_unpackhi_pd(a, b);   /* (a0 b0 a2 b2) (a1 b1 a3 b3) */
    acc = _mm_add_pd(acc, _mm256_castpd256_pd128(lo));
    acc = _mm_add_pd(acc, _mm256_castpd256_pd128(hi));
    acc = _mm_add_pd(acc, _mm256_extractf128_pd(lo, 1));
    return _mm_add_pd(acc, _mm256_extractf128_pd(hi, 1));
}

/* add the terms of eight points: points 0-3, then 4-7 */
static inline AVX512 __m128d add8(__m128d acc, __m512d a, __m512d b)
{
    acc = add4(acc, _mm512_castpd512_pd256(a), _mm512_castpd512_pd256(b));
    return add4(acc, _mm512_extractf64x4_pd(a, 1), _mm512_extractf64x4_pd(b, 1));
}

#define CMP(a, b, op) _mm512_cmp_pd_mask((a), (b), (op))

AVX512 void cf_solver_points_avx512_run(cf_solver *s, const cf_face_pass *P, int k0, int k1, cf_face_sums *S, int need)
{
    int k = k0;
    cf_simd_sums V;
    const double *lx = s->p_lx, *ly = s->p_ly, *hx = s->p_hx, *hy = s->p_hy, *fast = s->p_fast;
    const double *knw = s->p_knw, *ksw = s->p_ksw, *ihkw = s->p_ihkw, *state = s->p_state;
    double *fsx = s->p_fsx, *fsy = s->p_fsy;
    const __m512d M0 = _mm512_set1_pd(P->M[0]), M1 = _mm512_set1_pd(P->M[1]), M3 = _mm512_set1_pd(P->M[3]);
    const __m512d M4 = _mm512_set1_pd(P->M[4]), M6 = _mm512_set1_pd(P->M[6]), M7 = _mm512_set1_pd(P->M[7]);
    const __m512d z0 = _mm512_set1_pd(P->mz[0]), z1 = _mm512_set1_pd(P->mz[1]), z2 = _mm512_set1_pd(P->mz[2]);
    const __m512d t0 = _mm512_set1_pd(P->t[0]), t1 = _mm512_set1_pd(P->t[1]), t2 = _mm512_set1_pd(P->t[2]);
    const __m512d A0 = _mm512_set1_pd(P->A[0]), A1 = _mm512_set1_pd(P->A[1]);
    const __m512d W0 = _mm512_set1_pd(P->W[0]), W1 = _mm512_set1_pd(P->W[1]), W2 = _mm512_set1_pd(P->W[2]);
    const __m512d sgn = _mm512_set1_pd(P->sgn), pmax = _mm512_set1_pd(P->pmax), mu = _mm512_set1_pd(P->mu);
    const __m512d one = _mm512_set1_pd(1.0), half = _mm512_set1_pd(0.5), zero = _mm512_setzero_pd();
    const __m512d apo2 = _mm512_set1_pd(P->ff->apo * P->ff->apo), apotol = _mm512_set1_pd(P->ff->apo + P->tol);
    const __mmask8 unb = P->unbounded ? 0xFF : 0;
    cf_simd_sums_load(&V, S);
    for (; k < k1; k += 8) {
        /* the last one to seven points of the face: a block whose extra lanes are the
         * next points of the arrays (read, never active, counted open, never written),
         * unless the arrays end there */
        __mmask8 valid = 0xFF, act, st1, in, ok;
        int inval = 0, bits, open;
        __m512d vlx, vly, X, Y, Z, pen, dhx, dhy, d2, dux, duy, st, f, lim, fx, fy, m2, mx, my, mz, vs;
        if (k + 7 >= k1) {
            if (k + 8 > s->np) break;
            valid = (__mmask8)((1 << (k1 - k)) - 1);
            inval = 0xFF & ~valid;
        }
        vlx = _mm512_loadu_pd(lx + k); vly = _mm512_loadu_pd(ly + k);
        X = _mm512_add_pd(_mm512_add_pd(_mm512_add_pd(_mm512_mul_pd(M0, vlx), _mm512_mul_pd(M1, vly)), z0), t0);
        Y = _mm512_add_pd(_mm512_add_pd(_mm512_add_pd(_mm512_mul_pd(M3, vlx), _mm512_mul_pd(M4, vly)), z1), t1);
        Z = _mm512_add_pd(_mm512_add_pd(_mm512_add_pd(_mm512_mul_pd(M6, vlx), _mm512_mul_pd(M7, vly)), z2), t2);
        pen = _mm512_mul_pd(sgn, Z);
        dhx = _mm512_sub_pd(X, _mm512_loadu_pd(hx + k)); dhy = _mm512_sub_pd(Y, _mm512_loadu_pd(hy + k));
        d2 = _mm512_add_pd(_mm512_mul_pd(dhx, dhx), _mm512_mul_pd(dhy, dhy));
        dux = _mm512_sub_pd(_mm512_add_pd(A0, _mm512_mul_pd(W1, Z)), _mm512_mul_pd(W2, Y));
        duy = _mm512_sub_pd(_mm512_add_pd(A1, _mm512_mul_pd(W2, X)), _mm512_mul_pd(W0, Z));
        act = (__mmask8)(CMP(pen, zero, _CMP_GT_OQ) & CMP(pen, pmax, _CMP_NGT_UQ) & valid);
        st = _mm512_loadu_pd(state + k);
        st1 = CMP(st, one, _CMP_EQ_OQ);
        CF_LAW_TRIAL(_mm512_add_pd, _mm512_sub_pd, _mm512_mul_pd, pen, dux, duy, _mm512_loadu_pd(knw + k),
                     _mm512_loadu_pd(ksw + k), mu, _mm512_loadu_pd(fsx + k), _mm512_loadu_pd(fsy + k),
                     f, lim, fx, fy, m2);
        /* inside: the cheap test around the point's rest position, or the face's
         * inscribed circle (face_inside_hint's first test, which leaves the hint alone) */
        in = (__mmask8)(CMP(d2, _mm512_loadu_pd(fast + k), _CMP_LE_OQ)
                        | CMP(_mm512_add_pd(_mm512_mul_pd(X, X), _mm512_mul_pd(Y, Y)), apo2, _CMP_LE_OQ) | unb);
        if ((act & ~in & st1) != 0) {
            /* the polygon test: if the point's hint edge is still its most distant edge
             * (face_inside_hint's walk would stay there), inside iff within apo + tol of
             * it; else (the walk moves) leave the point to cf_point_law */
            const cf_face *ff = P->ff;
            const int *h = s->p_hint + k;
            __m512d ex = _mm512_set_pd(ff->ecw[h[7] + 1], ff->ecw[h[6] + 1], ff->ecw[h[5] + 1], ff->ecw[h[4] + 1],
                                       ff->ecw[h[3] + 1], ff->ecw[h[2] + 1], ff->ecw[h[1] + 1], ff->ecw[h[0] + 1]);
            __m512d ey = _mm512_set_pd(ff->esw[h[7] + 1], ff->esw[h[6] + 1], ff->esw[h[5] + 1], ff->esw[h[4] + 1],
                                       ff->esw[h[3] + 1], ff->esw[h[2] + 1], ff->esw[h[1] + 1], ff->esw[h[0] + 1]);
            __m512d best = _mm512_add_pd(_mm512_mul_pd(X, ex), _mm512_mul_pd(Y, ey)), pp, pm;
            __mmask8 stay;
            ex = _mm512_set_pd(ff->ecw[h[7] + 2], ff->ecw[h[6] + 2], ff->ecw[h[5] + 2], ff->ecw[h[4] + 2],
                               ff->ecw[h[3] + 2], ff->ecw[h[2] + 2], ff->ecw[h[1] + 2], ff->ecw[h[0] + 2]);
            ey = _mm512_set_pd(ff->esw[h[7] + 2], ff->esw[h[6] + 2], ff->esw[h[5] + 2], ff->esw[h[4] + 2],
                               ff->esw[h[3] + 2], ff->esw[h[2] + 2], ff->esw[h[1] + 2], ff->esw[h[0] + 2]);
            pp = _mm512_add_pd(_mm512_mul_pd(X, ex), _mm512_mul_pd(Y, ey));
            ex = _mm512_set_pd(ff->ecw[h[7]], ff->ecw[h[6]], ff->ecw[h[5]], ff->ecw[h[4]],
                               ff->ecw[h[3]], ff->ecw[h[2]], ff->ecw[h[1]], ff->ecw[h[0]]);
            ey = _mm512_set_pd(ff->esw[h[7]], ff->esw[h[6]], ff->esw[h[5]], ff->esw[h[4]],
                               ff->esw[h[3]], ff->esw[h[2]], ff->esw[h[1]], ff->esw[h[0]]);
            pm = _mm512_add_pd(_mm512_mul_pd(X, ex), _mm512_mul_pd(Y, ey));
            stay = (__mmask8)(CMP(pp, best, _CMP_NGT_UQ) & CMP(pm, best, _CMP_NGT_UQ));
            in = (__mmask8)(in | (stay & CMP(best, apotol, _CMP_LE_OQ)));
        }
        ok = (__mmask8)(act & in & st1 & CMP(m2, CF_LAW_CAP2(_mm512_mul_pd, lim), _CMP_NGT_UQ));
        bits = ok;
        /* open before and now, not overlapping the plane (state 0 keeps no shear force; a
         * point of state 0 deeper than pmax goes to state 3 in cf_point_law): nothing to do */
        open = ((~CMP(pen, zero, _CMP_GT_OQ) & CMP(st, zero, _CMP_EQ_OQ)) | inval) & 0xFF;
        if (open == 0xFF) continue;
        CF_LAW_TERMS(_mm512_add_pd, _mm512_sub_pd, _mm512_mul_pd, half, X, Y, Z, pen, f, fx, fy, m2,
                     _mm512_loadu_pd(ihkw + k), mx, my, mz, vs);
        if ((bits | open) == 0xFF) {
            /* sticking points, and points that stay open (a rocking face), which keep
             * their (zero) shear and add exact +0.0 terms: they leave the sums unchanged
             * (a sum that starts at +0.0 is never -0.0) */
            _mm512_mask_storeu_pd(fsx + k, ok, fx); _mm512_mask_storeu_pd(fsy + k, ok, fy);
            if (bits != 0xFF) {
                fx = _mm512_maskz_mov_pd(ok, fx); fy = _mm512_maskz_mov_pd(ok, fy); f = _mm512_maskz_mov_pd(ok, f);
                mx = _mm512_maskz_mov_pd(ok, mx); my = _mm512_maskz_mov_pd(ok, my); mz = _mm512_maskz_mov_pd(ok, mz);
                vs = _mm512_maskz_mov_pd(ok, vs);
            }
            V.s01 = add8(V.s01, fx, fy);
            V.s23 = add8(V.s23, f, mx);
            V.s45 = add8(V.s45, my, mz);
            if (need) V.s67 = add8(V.s67, vs, f);
        } else {
            /* one point at a time, in order: the easy ones from the vectors, the others
             * through the full law */
            double vx[8], vy[8], vf[8], vmx[8], vmy[8], vmz[8], vvs[8];
            _mm512_storeu_pd(vx, fx); _mm512_storeu_pd(vy, fy); _mm512_storeu_pd(vf, f);
            _mm512_storeu_pd(vmx, mx); _mm512_storeu_pd(vmy, my); _mm512_storeu_pd(vmz, mz);
            _mm512_storeu_pd(vvs, vs);
            cf_simd_lanes_in_order(s, P, S, &V, k, 8, open, bits, vx, vy, vf, vmx, vmy, vmz, vvs, need);
        }
    }
    cf_simd_sums_store(&V, S);
    /* the last points of the arrays: four (then two) at a time */
    if (k < k1) cf_solver_points_avx2_run(s, P, k, k1, S, need);
}

#else
typedef int cf_solver_points_avx512_unused;
#endif
#else
/* ISO C forbids an empty translation unit */
typedef int cf_solver_points_avx512_unused;
#endif
