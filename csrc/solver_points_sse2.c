/*
 * solver_points_sse2.c -- the "points" contact model, two points per SSE2 instruction
 * (SSE2 is part of every x86-64 CPU; no -m flag needed).
 *
 * The common path -- a point in contact at the last step and now, inside the cheap
 * polygon test, sticking -- runs on two lanes with the very operations of the scalar
 * law (CF_LAW_TRIAL and CF_LAW_TERMS of contact_law.h, instantiated with the SSE2
 * operators; each a correctly rounded IEEE operation, no contraction), and the terms
 * join the sums in point order; a pair with any other point takes cf_point_law one
 * point at a time. So the results are bitwise those of the scalar runner
 * (solver_points.c); scripts/check_result_hashes.sh checks it against a -DCF_NO_SIMD build.
 */
#include "solver_internal.h"

#ifdef CF_SOLVER_SIMD
#include <emmintrin.h>

#include "solver_points_internal.h"

/* The points [k0, k1) against the face of P, in point order, two at a time. */
void cf_solver_points_sse2_pairs(cf_solver *s, const cf_face_pass *P, int k0, int k1, cf_face_sums *S, int need)
{
    int k = k0;
    double t[8];
    cf_simd_sums V;
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
    cf_simd_sums_load(&V, S);
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
        __m128d f, lim, fx, fy, m2;
        __m128d act = _mm_and_pd(_mm_cmpgt_pd(pen, _mm_setzero_pd()), _mm_cmpngt_pd(pen, pmax));
        __m128d st = _mm_loadu_pd(state + k), ok, mx, my, mz, vs;
        int bits, open;
        CF_LAW_TRIAL(_mm_add_pd, _mm_sub_pd, _mm_mul_pd, pen, dux, duy, _mm_loadu_pd(knw + k), _mm_loadu_pd(ksw + k),
                     mu, _mm_loadu_pd(fsx + k), _mm_loadu_pd(fsy + k), f, lim, fx, fy, m2);
        /* inside: the cheap test around the point's rest position, or the face's
         * inscribed circle (face_inside_hint's first test, which leaves the hint alone) */
        __m128d in = _mm_or_pd(_mm_cmple_pd(d2, _mm_loadu_pd(fast + k)),
                               _mm_cmple_pd(_mm_add_pd(_mm_mul_pd(X, X), _mm_mul_pd(Y, Y)), apo2));
        in = _mm_or_pd(unb, in);
        if ((_mm_movemask_pd(_mm_andnot_pd(in, act)) & _mm_movemask_pd(_mm_cmpeq_pd(st, one))) != 0) {
            /* the polygon test: if the point's hint edge is still its most distant edge
             * (face_inside_hint's walk would stay there), inside iff within apo + tol of
             * it; else (the walk moves) leave the point to cf_point_law */
            const cf_face *ff = P->ff;
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
        ok = _mm_and_pd(ok, _mm_cmpngt_pd(m2, CF_LAW_CAP2(_mm_mul_pd, lim)));
        bits = _mm_movemask_pd(ok);
        /* open before and now, not overlapping the plane (state 0 keeps no shear force; a
         * point of state 0 deeper than pmax goes to state 3 in cf_point_law): nothing to do */
        open = _mm_movemask_pd(_mm_andnot_pd(_mm_cmpgt_pd(pen, _mm_setzero_pd()), _mm_cmpeq_pd(st, _mm_setzero_pd())));
        if (open == 3) continue;
        CF_LAW_TERMS(_mm_add_pd, _mm_sub_pd, _mm_mul_pd, half, X, Y, Z, pen, f, fx, fy, m2, _mm_loadu_pd(ihkw + k),
                     mx, my, mz, vs);
        if (bits == 3) {
            _mm_storeu_pd(fsx + k, fx); _mm_storeu_pd(fsy + k, fy);
            V.s01 = _mm_add_pd(_mm_add_pd(V.s01, _mm_unpacklo_pd(fx, fy)), _mm_unpackhi_pd(fx, fy));
            V.s23 = _mm_add_pd(_mm_add_pd(V.s23, _mm_unpacklo_pd(f, mx)), _mm_unpackhi_pd(f, mx));
            V.s45 = _mm_add_pd(_mm_add_pd(V.s45, _mm_unpacklo_pd(my, mz)), _mm_unpackhi_pd(my, mz));
            if (need) {
                V.s67 = _mm_add_pd(_mm_add_pd(V.s67, _mm_unpacklo_pd(vs, f)), _mm_unpackhi_pd(vs, f));
            }
        } else {
            /* one point at a time, in order: the easy one from the vectors, the other
             * through the full law */
            double vx[2], vy[2], vf[2], vmx[2], vmy[2], vmz[2], vvs[2];
            _mm_storeu_pd(vx, fx); _mm_storeu_pd(vy, fy); _mm_storeu_pd(vf, f); _mm_storeu_pd(vmx, mx);
            _mm_storeu_pd(vmy, my); _mm_storeu_pd(vmz, mz); _mm_storeu_pd(vvs, vs);
            cf_simd_lanes_in_order(s, P, S, &V, k, 2, open, bits, vx, vy, vf, vmx, vmy, vmz, vvs, need);
        }
    }
    for (; k < k1; k++)
        if (cf_point_law(s, P, k, S, s->p_hint + k, t)) cf_simd_sums_add(&V, t, need);
    cf_simd_sums_store(&V, S);
}


/* The face runner of the SIMD build: four points per AVX2 instruction where the CPU
 * has AVX2 (solver_points_avx2.c, the pairs of this file for the rest), else two per
 * SSE2 instruction; the same bits either way. -DCF_FORCE_SSE2 keeps SSE2. */
void cf_solver_points_sse2_run(cf_solver *s, const cf_face_pass *P, int k0, int k1, cf_face_sums *S, int need)
{
#ifdef CF_SOLVER_AVX2
    static int width = -1;   /* chosen once; a racing first call stores the same value */
    if (width < 0) {
        width = __builtin_cpu_supports("avx2") ? 4 : 2;
#ifdef CF_SOLVER_AVX512
        if (__builtin_cpu_supports("avx512f")) width = 8;
#endif
    }
#ifdef CF_SOLVER_AVX512
    /* eight lanes pay off on long faces only: a 10-point face runs 8 + 2 lanes as two
     * 512-bit blocks, slower than three 256-bit ones where AVX-512 executes as two
     * halves (measured on an AMD EPYC, Zen 4) */
    if (width == 8 && k1 - k0 >= 16) { cf_solver_points_avx512_run(s, P, k0, k1, S, need); return; }
    if (width == 8) { cf_solver_points_avx2_run(s, P, k0, k1, S, need); return; }
#endif
    if (width == 4) { cf_solver_points_avx2_run(s, P, k0, k1, S, need); return; }
#endif
    cf_solver_points_sse2_pairs(s, P, k0, k1, S, need);
}

static void all_simd(cf_solver *s, const double *ww, double dt, cf_step_energy *e)
{
    cf_solver_points_all(s, ww, dt, e, cf_solver_points_sse2_run);
}

static void joint_sse2(cf_solver *s, cf_joint *J, const double *ww, double dt, cf_step_energy *e)
{
    cf_solver_points_joint(s, J, ww, dt, e, cf_solver_points_sse2_run);
}

const cf_solver_contact_model cf_solver_points_sse2_model = {
    "points-simd",
    "The points model with two, four or eight sub-contacts per SSE2, AVX2 or AVX-512 "
    "instruction on the sticking path (the widest the CPU has); bitwise the results of the "
    "scalar points model.",
    joint_sse2,
    all_simd,
};

#else
/* ISO C forbids an empty translation unit */
typedef int cf_solver_points_sse2_unused;
#endif
