/*
 * solver_lanes.h -- the lane operators of one SIMD width: the one family every wide text
 * of the solver is written over (the batch integrator, solver_batch_lanes.h; the wide
 * points runner, solver_points_wide.h). Included with
 *   CF_BW   lanes: 2 (SSE2, part of every x86-64 CPU), 4 (AVX2) or 8 (AVX-512F)
 * it opens a target region of that instruction set (no -m flag: the library still runs on
 * any x86-64; no FMA is enabled and the build has contraction off, so every lane rounds as
 * the scalar code does) and defines
 *   VD, VM            a lane vector of doubles, and a lane mask (-1 / 0 per lane): GCC vector
 *                     extensions, whose + - * / and comparisons are the per-lane IEEE operations
 *   CF_BN(n)          the width's name of n (n_w2, n_w4, n_w8)
 *   CF_BW_SQRT(x)     per lane square root
 *   CF_BW_BITS(m)     the lanes of a mask as the bits of an int (lane l: bit l)
 *   CF_BW_SEL(m,a,b)  per lane: a where m, else b
 *   CF_BN(ld), CF_BN(st), CF_BN(splat), CF_BN(mask)   load / store CF_BW doubles, a double in
 *                     every lane, a vector zeroed outside a mask
 * solver_lanes_end.h closes the region and the names. Included without CF_BW it is empty.
 */
#ifdef CF_BW
#include <string.h>
#include <immintrin.h>

#if CF_BW == 2
#define CF_BN(n) n##_w2
#define CF_BW_SQRT(x) ((VD)_mm_sqrt_pd((__m128d)(x)))
#define CF_BW_BITS(m) _mm_movemask_pd((__m128d)(m))
#elif CF_BW == 4
#pragma GCC push_options
#pragma GCC target("avx2")
#define CF_BN(n) n##_w4
#define CF_BW_SQRT(x) ((VD)_mm256_sqrt_pd((__m256d)(x)))
#define CF_BW_BITS(m) _mm256_movemask_pd((__m256d)(m))
#elif CF_BW == 8
#pragma GCC push_options
#pragma GCC target("avx512f")
#define CF_BN(n) n##_w8
#define CF_BW_SQRT(x) ((VD)_mm512_sqrt_pd((__m512d)(x)))
#define CF_BW_BITS(m) ((int)_mm512_test_epi64_mask((__m512i)(m), (__m512i)(m)))
#else
#error "CF_BW must be 2, 4 or 8"
#endif

#define VD CF_BN(vd)
#define VM CF_BN(vm)
typedef double VD __attribute__((vector_size(8 * CF_BW)));
typedef long long VM __attribute__((vector_size(8 * CF_BW)));

#define CF_BW_SEL(m, a, b) ((VD)(((VM)(a) & (m)) | ((VM)(b) & ~(m))))

static inline VD CF_BN(ld)(const double *p) { VD v; memcpy(&v, p, sizeof v); return v; }
static inline void CF_BN(st)(double *p, VD v) { memcpy(p, &v, sizeof v); }
static inline VD CF_BN(splat)(double x)
{
    VD v;
    int l;
    for (l = 0; l < CF_BW; l++) v[l] = x;
    return v;
}
static inline VD CF_BN(mask)(VD a, VM m) { return (VD)((VM)a & m); }
#endif
