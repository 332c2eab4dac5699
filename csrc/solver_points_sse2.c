/*
 * solver_points_sse2.c -- the "points" contact model on SIMD lanes (the file keeps
 * its name and model symbol, cf_solver_points_sse2_model, which solver.c selects on
 * every x86-64 build; the widest instruction set of the CPU is chosen at run time).
 *
 * A face's points run in two passes (chunks of CHUNK points):
 *   A. lanes: for every point, its position in the face frame, the elastic trial and
 *      the terms of CF_LAW_TRIAL / CF_LAW_TERMS (contact_law.h, scalar operators), and
 *      a code of its state (active, inside the cheap polygon tests, state 1 or 0,
 *      sticking). A plain C loop with no dependence between points: the compiler
 *      turns it into SSE2, AVX2 or AVX-512 code; each lane evaluates the very IEEE
 *      operations of the scalar law in the same order (the build has contraction off
 *      and no reassociation), so every width gives the same bits.
 *   B. in point order, one point at a time: a sticking point in contact stores its
 *      trial shear and adds its terms to the face sums; an open point stays open;
 *      any other point (opening, closing, slipping, near the polygon edge) takes the
 *      full law cf_point_law. The sums are sequential in point order, as the scalar
 *      runner's (solver_points.c), whose results are bitwise these;
 *      scripts/check_result_hashes.sh compares every width with a -DCF_NO_SIMD build.
 *
 * Width: AVX-512F, else AVX2, else SSE2, by __builtin_cpu_supports; -DCF_FORCE_SSE2
 * or -DCF_FORCE_AVX2 caps it (the hash check builds each). No FMA is enabled (and
 * contraction is off): a CPU without AVX2 computes the same numbers.
 */
#include "solver_internal.h"

#ifdef CF_SOLVER_SIMD
#include "solver_points_internal.h"

enum { CHUNK = 16 };

/* the code of pass A */
#define PA_ACT 1.0     /* 0 < pen <= pmax */
#define PA_IN 2.0      /* inside: the unbounded ground, the cheap test around home or the inscribed circle (1-3 times) */
#define PA_ST1 8.0     /* in contact at the last step */
#define PA_ST0 16.0    /* open at the last step */
#define PA_STICK 32.0  /* the trial shear lies within the Coulomb cone */

typedef struct {
    double X[CHUNK], Y[CHUNK], Z[CHUNK], fn[CHUNK], fx[CHUNK], fy[CHUNK];
    double mx[CHUNK], my[CHUNK], mz[CHUNK], vs[CHUNK];
    double code[CHUNK];   /* the sum of the PA_ flags */
} pass_buf;

/* Pass A over the points [k0, k0 + n), n <= CHUNK: the operations of cf_point_law's
 * in-contact path (position, increment, CF_LAW_TRIAL, CF_LAW_TERMS), in its order. */
static inline __attribute__((always_inline)) void pass_a_body(const cf_solver *s, const cf_face_pass *P, int k0,
                                                              int n, pass_buf *B)
{
    const double *restrict lx = s->p_lx + k0, *restrict ly = s->p_ly + k0, *restrict hx = s->p_hx + k0;
    const double *restrict hy = s->p_hy + k0, *restrict fast = s->p_fast + k0, *restrict knw = s->p_knw + k0;
    const double *restrict ksw = s->p_ksw + k0, *restrict ihkw = s->p_ihkw + k0, *restrict st = s->p_state + k0;
    const double *restrict fsx = s->p_fsx + k0, *restrict fsy = s->p_fsy + k0;
    const double M0 = P->M[0], M1 = P->M[1], M3 = P->M[3], M4 = P->M[4], M6 = P->M[6], M7 = P->M[7];
    const double z0 = P->mz[0], z1 = P->mz[1], z2 = P->mz[2], t0 = P->t[0], t1 = P->t[1], t2 = P->t[2];
    const double A0 = P->A[0], A1 = P->A[1], W0 = P->W[0], W1 = P->W[1], W2 = P->W[2];
    const double sgn = P->sgn, pmax = P->pmax, mu = P->mu, apo2 = P->ff->apo * P->ff->apo;
    const double unb = P->unbounded ? PA_IN : 0.0;
    double *restrict oX = B->X, *restrict oY = B->Y, *restrict oZ = B->Z, *restrict ofn = B->fn;
    double *restrict ofx = B->fx, *restrict ofy = B->fy, *restrict omx = B->mx, *restrict omy = B->my;
    double *restrict omz = B->mz, *restrict ovs = B->vs;
    double *restrict code = B->code;
    int i;
    /* the point arrays and the buffer never overlap (restrict is not enough once inlined) */
#pragma GCC ivdep
    for (i = 0; i < n; i++) {
        double X = M0 * lx[i] + M1 * ly[i] + z0 + t0;
        double Y = M3 * lx[i] + M4 * ly[i] + z1 + t1;
        double Z = M6 * lx[i] + M7 * ly[i] + z2 + t2;
        double pen = sgn * Z;
        double dhx = X - hx[i], dhy = Y - hy[i];
        double dux = A0 + W1 * Z - W2 * Y;
        double duy = A1 + W2 * X - W0 * Z;
        double f, lim, fx, fy, m2, mx, my, mz, vs;
        double c;
        CF_LAW_TRIAL(CF_LAW_SADD, CF_LAW_SSUB, CF_LAW_SMUL, pen, dux, duy, knw[i], ksw[i], mu, fsx[i], fsy[i],
                     f, lim, fx, fy, m2);
        CF_LAW_TERMS(CF_LAW_SADD, CF_LAW_SSUB, CF_LAW_SMUL, 0.5, X, Y, Z, pen, f, fx, fy, m2, ihkw[i],
                     mx, my, mz, vs);
        /* the code as a small integer held in a double (flags that select between
         * constants): the loop then holds one element type and vectorizes */
        c = (pen > 0.0 ? PA_ACT : 0.0) + (pen > pmax ? -PA_ACT : 0.0);
        c += (dhx * dhx + dhy * dhy <= fast[i] ? PA_IN : 0.0);
        c += (X * X + Y * Y <= apo2 ? PA_IN : 0.0);
        c += unb;
        c += (st[i] == 1.0 ? PA_ST1 : 0.0) + (st[i] == 0.0 ? PA_ST0 : 0.0) + (m2 > lim * lim ? 0.0 : PA_STICK);
        oX[i] = X; oY[i] = Y; oZ[i] = Z; ofn[i] = f; ofx[i] = fx; ofy[i] = fy;
        omx[i] = mx; omy[i] = my; omz[i] = mz; ovs[i] = vs;
        code[i] = c;
    }
}

/* pass A over n points from k0; n < 0: a whole chunk (k0 + CHUNK <= np) */
typedef void (*pass_a_fn)(const cf_solver *s, const cf_face_pass *P, int k0, int n, pass_buf *B);

/* Each width in two forms: n points, or (when the arrays hold them) a whole chunk, a
 * fixed trip count the compiler vectorizes without a remainder loop; the lanes past
 * the face's points are computed and ignored. */
static void pass_a_sse2(const cf_solver *s, const cf_face_pass *P, int k0, int n, pass_buf *B)
{
    if (n < 0) pass_a_body(s, P, k0, CHUNK, B);
    else pass_a_body(s, P, k0, n, B);
}

#if defined(__x86_64__) && defined(__GNUC__) && !defined(CF_FORCE_SSE2)
#define CF_HAVE_AVX2 1
__attribute__((target("avx2")))
static void pass_a_avx2(const cf_solver *s, const cf_face_pass *P, int k0, int n, pass_buf *B)
{
    if (n < 0) pass_a_body(s, P, k0, CHUNK, B);
    else pass_a_body(s, P, k0, n, B);
}
#if !defined(CF_FORCE_AVX2)
#define CF_HAVE_AVX512 1
__attribute__((target("avx512f")))
static void pass_a_avx512(const cf_solver *s, const cf_face_pass *P, int k0, int n, pass_buf *B)
{
    if (n < 0) pass_a_body(s, P, k0, CHUNK, B);
    else pass_a_body(s, P, k0, n, B);
}
#endif
#endif

/* The widest pass A this CPU runs (every one gives the same bits). */
static pass_a_fn pass_a_select(void)
{
#ifdef CF_HAVE_AVX512
    if (__builtin_cpu_supports("avx512f")) return pass_a_avx512;
#endif
#ifdef CF_HAVE_AVX2
    if (__builtin_cpu_supports("avx2")) return pass_a_avx2;
#endif
    return pass_a_sse2;
}

/* The points [k0, k1) against the face of P, in point order. */
static void run_lanes(cf_solver *s, const cf_face_pass *P, int k0, int k1, cf_face_sums *S, int need)
{
    static pass_a_fn pass_a;   /* chosen once; a racing first call stores the same pointer */
    double s0 = S->sm[0], s1 = S->sm[1], s2 = S->sm[2], s3 = S->sm[3], s4 = S->sm[4], s5 = S->sm[5];
    double s6 = S->sm[6], s7 = S->sm[7], t[8];
    double *fsx = s->p_fsx, *fsy = s->p_fsy;
    pass_buf B;
    int c0;
    if (!pass_a) pass_a = pass_a_select();
    for (c0 = k0; c0 < k1; c0 += CHUNK) {
        int n = k1 - c0 < CHUNK ? k1 - c0 : CHUNK, i;
        pass_a(s, P, c0, c0 + CHUNK <= s->np ? -1 : n, &B);
        for (i = 0; i < n; i++) {
            int c = (int)B.code[i], k = c0 + i;
            /* active, in contact at the last step, sticking (1 + 8 + 32), and inside: one of the
             * cheap tests (c & 6), or the polygon test (which may move the point's hint) */
            if ((c & ~6) == 41 && ((c & 6) || cf_face_inside_hint(P->ff, B.X[i], B.Y[i], P->tol, s->p_hint + k))) {
                /* in contact, inside the face, sticking: the trial is the new shear */
                fsx[k] = B.fx[i]; fsy[k] = B.fy[i];
                s0 += B.fx[i]; s1 += B.fy[i]; s2 += B.fn[i]; s3 += B.mx[i]; s4 += B.my[i]; s5 += B.mz[i];
                if (need) { s6 += B.vs[i]; s7 += B.fn[i]; }
            } else if ((c & 17) == 16) {
                /* open before and now (state 0 keeps no shear force): nothing to do */
            } else if (cf_point_law(s, P, k, S, s->p_hint + k, t)) {
                s0 += t[0]; s1 += t[1]; s2 += t[2]; s3 += t[3]; s4 += t[4]; s5 += t[5];
                if (need) { s6 += t[6]; s7 += t[7]; }
            }
        }
    }
    S->sm[0] = s0; S->sm[1] = s1; S->sm[2] = s2; S->sm[3] = s3; S->sm[4] = s4; S->sm[5] = s5;
    S->sm[6] = s6; S->sm[7] = s7;
}

static void joint_lanes(cf_solver *s, cf_joint *J, const double *ww, double dt, cf_step_energy *e)
{
    cf_solver_points_joint(s, J, ww, dt, e, run_lanes);
}

const cf_solver_contact_model cf_solver_points_sse2_model = {
    "points-simd",
    "The points model with the per-point law on SIMD lanes (SSE2, AVX2 or AVX-512, chosen at "
    "run time); bitwise the results of the scalar points model.",
    joint_lanes,
};

#else
/* ISO C forbids an empty translation unit */
typedef int cf_solver_points_sse2_unused;
#endif
