/*
 * solver_points.c -- contact model "points": each joint carries sub-contact points
 * (the polygon vertices, or the nodes of a refined face mesh) with the law of
 * contact_law.h. Points of the upper face (side 0) are handled in the lower face's
 * frame, points of the lower face (side 1) in the upper face's frame; the forces are
 * summed per side in that frame (force and moment about the face centre, in point
 * order) and turned to world coordinates once per joint.
 *
 * This file holds the models' registry entries ("vertex", "perimeter"), the joint driver,
 * the scalar runner over a face's points and the choice of the SIMD width (CPUID); the
 * wide runner (solver_points_wide.h, one instance per width) gives the same bits, two,
 * four or eight points at a time.
 */
#include <stdlib.h>
#include <string.h>

#include "solver_math_internal.h"
#include "solver_points_internal.h"
#include "solver_sleep.h"

/* The joints in lanes. The per-joint work around the points -- the frame map of the
 * upper body in the lower face's frame, the relative displacement field over the step
 * in each face's frame, and at the end each face's sums turned to world force and
 * torque -- runs for a chunk of joints at a time in structure-of-arrays form: plain
 * loops over the joints that the compiler vectorizes (SSE2, or AVX2 / AVX-512 chosen
 * at run time). Each lane evaluates the scalar expressions written here, operation for
 * operation (contraction off, no reassociation), so every width gives the same bits;
 * the forces then join the bodies' sums in joint order, as before. */
/* CF_MAT_VEC_STRIDED (R v, R^T v) and v3_cross of solver_math_internal.h, lane j of the chunk */
#define LANE_MAT_VEC(R, rs, cs, a0, a1, a2, o0, o1, o2)                                           \
    do {                                                                                          \
        o0 = R[0][j] * (a0) + R[cs][j] * (a1) + R[2 * (cs)][j] * (a2);                            \
        o1 = R[rs][j] * (a0) + R[(rs) + (cs)][j] * (a1) + R[(rs) + 2 * (cs)][j] * (a2);           \
        o2 = R[2 * (rs)][j] * (a0) + R[2 * (rs) + (cs)][j] * (a1) + R[2 * (rs) + 2 * (cs)][j] * (a2); \
    } while (0)
#define TVEC(R, a0, a1, a2, o0, o1, o2) LANE_MAT_VEC(R, 1, 3, a0, a1, a2, o0, o1, o2)
#define MVEC(R, a0, a1, a2, o0, o1, o2) LANE_MAT_VEC(R, 3, 1, a0, a1, a2, o0, o1, o2)
#define CROSS(a0, a1, a2, b0, b1, b2, o0, o1, o2)                              \
    do {                                                                       \
        o0 = (a1) * (b2) - (a2) * (b1);                                        \
        o1 = (a2) * (b0) - (a0) * (b2);                                        \
        o2 = (a0) * (b1) - (a1) * (b0);                                        \
    } while (0)

/* The relative displacement field over the step (A, W) in the frame Rf of the face
 * centred at c (world), and the translation t of the other body into that frame
 * (the upper body's origin for side 0, the lower body's for side 1): the relative
 * velocity of the upper body at the face centre, in the face frame, times dt. With no
 * lower body (the ground) its terms are exact zeros. */
#define FACE_FIELD(Rf, side)                                                                          \
    do {                                                                                              \
        double vU0, vU1, vU2, wU0, wU1, wU2, xu0, xu1, xu2, c10, c11, c12;                              \
        double vL0, vL1, vL2, wL0, wL1, wL2, xl0, xl1, xl2, c20, c21, c22, g = C->gl[j];                \
        const double cf0 = C->c[side][0][j], cf1 = C->c[side][1][j], cf2 = C->c[side][2][j];          \
        TVEC(Rf, C->vu[0][j], C->vu[1][j], C->vu[2][j], vU0, vU1, vU2);                              \
        TVEC(Rf, C->wu[0][j], C->wu[1][j], C->wu[2][j], wU0, wU1, wU2);                              \
        TVEC(Rf, C->xu[0][j] - cf0, C->xu[1][j] - cf1, C->xu[2][j] - cf2, xu0, xu1, xu2);             \
        CROSS(wU0, wU1, wU2, xu0, xu1, xu2, c10, c11, c12);                                          \
        TVEC(Rf, C->vl[0][j], C->vl[1][j], C->vl[2][j], vL0, vL1, vL2);                              \
        TVEC(Rf, C->wl[0][j], C->wl[1][j], C->wl[2][j], wL0, wL1, wL2);                              \
        TVEC(Rf, C->xl[0][j] - cf0, C->xl[1][j] - cf1, C->xl[2][j] - cf2, xl0, xl1, xl2);             \
        CROSS(wL0, wL1, wL2, xl0, xl1, xl2, c20, c21, c22);                                          \
        vL0 = g != 0.0 ? vL0 : 0.0; vL1 = g != 0.0 ? vL1 : 0.0; vL2 = g != 0.0 ? vL2 : 0.0;            \
        wL0 = g != 0.0 ? wL0 : 0.0; wL1 = g != 0.0 ? wL1 : 0.0; wL2 = g != 0.0 ? wL2 : 0.0;            \
        xl0 = g != 0.0 ? xl0 : 0.0; xl1 = g != 0.0 ? xl1 : 0.0; xl2 = g != 0.0 ? xl2 : 0.0;            \
        c20 = g != 0.0 ? c20 : 0.0; c21 = g != 0.0 ? c21 : 0.0; c22 = g != 0.0 ? c22 : 0.0;            \
        C->A[side][0][j] = (vU0 - vL0 - c10 + c20) * dt;                                              \
        C->A[side][1][j] = (vU1 - vL1 - c11 + c21) * dt;                                              \
        C->A[side][2][j] = (vU2 - vL2 - c12 + c22) * dt;                                              \
        C->W[side][0][j] = (wU0 - wL0) * dt; C->W[side][1][j] = (wU1 - wL1) * dt;                     \
        C->W[side][2][j] = (wU2 - wL2) * dt;                                                          \
        if (side == 0) { C->t[side][0][j] = xu0; C->t[side][1][j] = xu1; C->t[side][2][j] = xu2; }   \
        else { C->t[side][0][j] = xl0; C->t[side][1][j] = xl1; C->t[side][2][j] = xl2; }              \
    } while (0)

/* The chunk loops below select exact zeros for a side without a body or points (x = g != 0.0 ? x : 0.0).
 * Under GCC's default -ftrapping-math its if-conversion keeps such a select of a floating-point compare as
 * a branch except on AVX-512 (masked operations), so the SSE2 and AVX2 loops ran scalar (measured: the
 * joints' lanes 30 % of a 4-lane batch's time, 8x an 8-lane one's per lane). The compare cannot trap (!= is
 * quiet) and no value changes: the loops are compiled without trapping math, and vectorize at every width. */
#pragma GCC push_options
#pragma GCC optimize("no-trapping-math")
/* Lanes before the points: M0 = RL^T RU (the lower body in the upper face's frame is
 * its transpose), per side the face centre, the field and the points' z offset. */
static inline __attribute__((always_inline)) void chunk_before_body(cf_joint_chunk *restrict C, int n, double dt)
{
    int j;
#pragma GCC ivdep
    for (j = 0; j < n; j++) {
        double a0, a1, a2;
        int i, k;
        for (i = 0; i < 3; i++)
            for (k = 0; k < 3; k++)
                C->M0[3 * i + k][j] = C->RL[i][j] * C->RU[k][j] + C->RL[3 + i][j] * C->RU[3 + k][j]
                                      + C->RL[6 + i][j] * C->RU[6 + k][j];
        MVEC(C->RL, C->fcl[0][j], C->fcl[1][j], C->fcl[2][j], a0, a1, a2);
        C->c[0][0][j] = a0 + C->xl[0][j]; C->c[0][1][j] = a1 + C->xl[1][j]; C->c[0][2][j] = a2 + C->xl[2][j];
        MVEC(C->RU, C->fcu[0][j], C->fcu[1][j], C->fcu[2][j], a0, a1, a2);
        C->c[1][0][j] = a0 + C->xu[0][j]; C->c[1][1][j] = a1 + C->xu[1][j]; C->c[1][2][j] = a2 + C->xu[2][j];
        FACE_FIELD(C->RL, 0);
        FACE_FIELD(C->RU, 1);
        /* side 0 in the lower face's frame: M0; side 1 in the upper face's: M0^T */
        C->mz[0][0][j] = C->M0[2][j] * C->lz[0][j]; C->mz[0][1][j] = C->M0[5][j] * C->lz[0][j];
        C->mz[0][2][j] = C->M0[8][j] * C->lz[0][j];
        C->mz[1][0][j] = C->M0[6][j] * C->lz[1][j]; C->mz[1][1][j] = C->M0[7][j] * C->lz[1][j];
        C->mz[1][2][j] = C->M0[8][j] * C->lz[1][j];
    }
}

#define SIDE_AFTER(Rf, side)                                                                        \
    do {                                                                                            \
        double F0, F1, F2, M0, M1, M2, c0, c1, c2, r0, r1, r2, q0, q1, q2, h = C->has[side][j];      \
        MVEC(Rf, C->sm[side][0][j], C->sm[side][1][j], C->sm[side][2][j], F0, F1, F2);              \
        MVEC(Rf, C->sm[side][3][j], C->sm[side][4][j], C->sm[side][5][j], M0, M1, M2);              \
        F0 = h != 0.0 ? F0 : 0.0; F1 = h != 0.0 ? F1 : 0.0; F2 = h != 0.0 ? F2 : 0.0;                \
        M0 = h != 0.0 ? M0 : 0.0; M1 = h != 0.0 ? M1 : 0.0; M2 = h != 0.0 ? M2 : 0.0;                \
        c0 = C->c[side][0][j]; c1 = C->c[side][1][j]; c2 = C->c[side][2][j];                         \
        c0 = h != 0.0 ? c0 : 0.0; c1 = h != 0.0 ? c1 : 0.0; c2 = h != 0.0 ? c2 : 0.0;                \
        C->Fw[side][0][j] = F0; C->Fw[side][1][j] = F1; C->Fw[side][2][j] = F2;                     \
        r0 = c0 - C->xu[0][j]; r1 = c1 - C->xu[1][j]; r2 = c2 - C->xu[2][j];                        \
        CROSS(r0, r1, r2, F0, F1, F2, q0, q1, q2);                                                  \
        C->Tu[side][0][j] = q0 + M0; C->Tu[side][1][j] = q1 + M1; C->Tu[side][2][j] = q2 + M2;      \
        r0 = c0 - C->xl[0][j]; r1 = c1 - C->xl[1][j]; r2 = c2 - C->xl[2][j];                        \
        CROSS(r0, r1, r2, F0, F1, F2, q0, q1, q2);                                                  \
        C->Tl[side][0][j] = q0 + M0; C->Tl[side][1][j] = q1 + M1; C->Tl[side][2][j] = q2 + M2;      \
    } while (0)

/* Lanes after the points: each side's sums (face frame) to world force F and moment M,
 * and the torques r x F + M about the upper and lower bodies' centres; a side without
 * points gives exact zeros. */
static inline __attribute__((always_inline)) void chunk_after_body(cf_joint_chunk *restrict C, int n)
{
    int j;
#pragma GCC ivdep
    for (j = 0; j < n; j++) {
        SIDE_AFTER(C->RL, 0);
        SIDE_AFTER(C->RU, 1);
    }
}

/* A whole chunk, or the lane counts of the batches of runs (solver_batch.c: one joint of
 * 8, 4 or 2 runs), as loops of fixed length that compile to whole vectors; else n lanes. */
#define CHUNK_FIXED(full, n8, n4, n2, any)                                              \
    do {                                                                              \
        if (n == CF_JCH) full;                                                        \
        else if (n == 8) n8;                                                          \
        else if (n == 4) n4;                                                          \
        else if (n == 2) n2;                                                          \
        else any;                                                                     \
    } while (0)

/* The chunk functions of one target (attr: its target attribute, empty for the base one) */
#define CHUNK_FNS(name, attr)                                                                              \
    attr static void chunk_before_##name(cf_joint_chunk *C, int n, double dt)                               \
    {                                                                                                      \
        CHUNK_FIXED(chunk_before_body(C, CF_JCH, dt), chunk_before_body(C, 8, dt), chunk_before_body(C, 4, dt), \
                    chunk_before_body(C, 2, dt), chunk_before_body(C, n, dt));                             \
    }                                                                                                      \
    attr static void chunk_after_##name(cf_joint_chunk *C, int n)                                           \
    {                                                                                                      \
        CHUNK_FIXED(chunk_after_body(C, CF_JCH), chunk_after_body(C, 8), chunk_after_body(C, 4),           \
                    chunk_after_body(C, 2), chunk_after_body(C, n));                                       \
    }
CHUNK_FNS(base, )
#ifdef CF_SOLVER_AVX2
CHUNK_FNS(avx2, __attribute__((target("avx2"))))
#ifdef CF_SOLVER_AVX512
CHUNK_FNS(avx512, __attribute__((target("avx512f"))))
#endif
#endif
#pragma GCC pop_options

/* The widest lanes this CPU and build run (every width gives the same bits), from CPUID
 * each call: no state. -DCF_FORCE_SSE2 / -DCF_FORCE_AVX2 cap the width and -DCF_NO_SIMD
 * leaves SIMD out (scripts/check_result_hashes.sh builds each). */
int cf_solver_points_lanes_widest(void)
{
#ifdef CF_SOLVER_AVX512
    if (__builtin_cpu_supports("avx512f")) return 8;
#endif
#ifdef CF_SOLVER_AVX2
    if (__builtin_cpu_supports("avx2")) return 4;
#endif
#ifdef CF_SOLVER_SIMD
    return 2;
#else
    return 1;
#endif
}

/* The chunk lane functions of a width (the compiler's vectors of 2 lanes are the base ones). */
static void chunk_fns(int lanes, cf_chunk_before_fn *before, cf_chunk_after_fn *after)
{
    (void)lanes;
#ifdef CF_SOLVER_AVX512
    if (lanes == 8) { *before = chunk_before_avx512; *after = chunk_after_avx512; return; }
#endif
#ifdef CF_SOLVER_AVX2
    if (lanes == 4) { *before = chunk_before_avx2; *after = chunk_after_avx2; return; }
#endif
    *before = chunk_before_base; *after = chunk_after_base;
}

void cf_solver_points_chunk_fns(int lanes, cf_chunk_before_fn *before, cf_chunk_after_fn *after)
{
    chunk_fns(lanes, before, after);
}

/* The face runner of the solver's width (s->lanes, chosen at set-up); every width gives
 * the same bits. */
static void points_run(const cf_solver *s, cf_points *pts, const cf_face_pass *P, int k0, int k1, cf_face_sums *S,
                       int need)
{
    switch (s->lanes) {
#ifdef CF_SOLVER_AVX512
    case 8:
        /* eight lanes pay off on long faces only: a 10-point face runs 8 + 2 lanes as two
         * 512-bit blocks, slower than three 256-bit ones where AVX-512 executes as two
         * halves (measured on an AMD EPYC, Zen 4) */
        if (k1 - k0 >= 16) cf_solver_points_w8_run(pts, P, k0, k1, S, need);
        else cf_solver_points_w4_run(pts, P, k0, k1, S, need);
        return;
#endif
#ifdef CF_SOLVER_AVX2
    case 4: cf_solver_points_w4_run(pts, P, k0, k1, S, need); return;
#endif
#ifdef CF_SOLVER_SIMD
    case 2: cf_solver_points_w2_run(pts, P, k0, k1, S, need); return;
#endif
    default: cf_points_run_scalar(pts, P, k0, k1, S, need);
    }
}

/* Gather joints [c0, c0 + lanes) of s into the chunk's lanes (the lanes past the m joints copy the
 * last one and are ignored). */
static void chunk_gather(const cf_solver *s, const cf_points *pts, const double *ww, int c0, int m, int lanes,
                         cf_joint_chunk *C)
{
    int l, i;
    for (l = 0; l < lanes; l++) {
        int j = c0 + (l < m ? l : m - 1);
        const cf_joint *J = &s->jt[j];
        int bl = J->bl, bu = J->bu;
        for (i = 0; i < 9; i++) { C->RL[i][l] = s->R[9 * bl + i]; C->RU[i][l] = s->R[9 * bu + i]; }
        for (i = 0; i < 3; i++) {
            C->xl[i][l] = s->x[3 * bl + i]; C->xu[i][l] = s->x[3 * bu + i];
            C->vl[i][l] = s->v[3 * bl + i]; C->vu[i][l] = s->v[3 * bu + i];
            C->wl[i][l] = ww[3 * bl + i]; C->wu[i][l] = ww[3 * bu + i];
            C->fcl[i][l] = J->fl.c[i]; C->fcu[i][l] = J->fu.c[i];
        }
        C->lz[0][l] = pts->jt[j].lz[0]; C->lz[1][l] = pts->jt[j].lz[1];
        C->gl[l] = bl != 0 ? 1.0 : 0.0;
    }
}

/* The passes of joint j's two sides from lane l of the chunk (has[side]: the side has points). */
static void joint_passes(const cf_points *pts, const cf_joint *J, const cf_points_joint *PJ, const cf_joint_chunk *C,
                         int l, cf_face_pass *P, int *has)
{
    int side;
    for (side = 0; side < 2; side++) {
        has[side] = side == 0 ? PJ->n0 > 0 : PJ->np > PJ->n0;
        cf_face_pass_set(pts, J, side, &P[side]);
        cf_face_pass_lane(C, side, l, &P[side]);
    }
}

/* A sleeping joint j (solver_sleep.h): 1 when it stays asleep this step (its sums in lane l, its
 * spring energy into e, its normal force into s->jfn); 0 when it wakes (every point's shear set
 * from the linear map: the full law takes the step). */
static int joint_sleeping(cf_solver *s, cf_points *pts, int j, cf_joint_chunk *C, int l, cf_step_energy *e, double *sl)
{
    const cf_joint *J = &s->jt[j];
    const cf_points_joint *PJ = &pts->jt[j];
    cf_face_pass P[2];
    double sm[2][6], vs, fn;
    int has[2], side, i;
    joint_passes(pts, J, PJ, C, l, P, has);
    if (!cf_sleep_joint(sl, PJ->sq, PJ->sqs, PJ->srho, J, P, has, sm, &vs, &fn, e->need)) {
        cf_sleep_wake(pts, PJ, sl, 1, pts->fsx, pts->fsy, 1);
        return 0;
    }
    for (side = 0; side < 2; side++) {
        C->has[side][l] = has[side] ? 1.0 : 0.0;
        for (i = 0; i < 6; i++) C->sm[side][i][l] = sm[side][i];
    }
    e->vs += vs;
    s->jfn[j] = fn;
    pts->slept++;
    return 1;
}

/* The points of joint j, side by side, in order, through the face runner: the sums of each side
 * into lane l of the chunk, the energies into e, the joint's normal force into s->jfn. With
 * `sleep` on, a sleeping joint takes its linear law instead, and an awake one tries to fall asleep
 * at the run's ledger steps (every CF_LEDGER_STEPS: cf_step_energy.ledger). */
static void joint_points(cf_solver *s, cf_points *pts, int j, cf_joint_chunk *C, int l, cf_step_energy *e)
{
    const cf_joint *J = &s->jt[j];
    const cf_points_joint *PJ = &pts->jt[j];
    int side, i, end = PJ->p0 + PJ->np;
    cf_face_sums S;
    double *sl = pts->sleep ? pts->sleep_state + (size_t)j * CF_SLEEP_ND : NULL;
    if (sl && sl[0] != 0.0 && joint_sleeping(s, pts, j, C, l, e, sl)) return;
    S.dslip = 0.0; S.dswitch = 0.0;
    S.sm[6] = S.sm[7] = 0.0;
    for (side = 0; side < 2; side++) {
        int k0 = side == 0 ? PJ->p0 : PJ->p0 + PJ->n0, k1 = side == 0 ? PJ->p0 + PJ->n0 : end;
        cf_face_pass P;
        C->has[side][l] = k1 > k0 ? 1.0 : 0.0;
        if (k1 <= k0) {
            for (i = 0; i < 6; i++) C->sm[side][i][l] = 0.0;
            continue;
        }
        cf_face_pass_set(pts, J, side, &P);
        cf_face_pass_lane(C, side, l, &P);
        S.sm[0] = S.sm[1] = S.sm[2] = S.sm[3] = S.sm[4] = S.sm[5] = 0.0;
        points_run(s, pts, &P, k0, k1, &S, e->need);
        for (i = 0; i < 6; i++) C->sm[side][i][l] = S.sm[i];
    }
    e->vs += S.sm[6];
    /* the joint's normal force: summed at energy/history steps only (read at history samples) */
    s->jfn[j] = S.sm[7];
    e->dslip += S.dslip;
    e->dswitch += S.dswitch;
    if (sl && e->ledger) {
        cf_face_pass P[2];
        int has[2];
        joint_passes(pts, J, PJ, C, l, P, has);
        cf_sleep_try(pts, PJ, J, P, has, pts->sleep_margin, sl, 1, pts->fsx, pts->fsy, pts->state, 1);
    }
}

/* Apply joint j's forces from lane l of the chunk, as the single run does: force F at the face
 * centre with moment M, on the upper body; the opposite on the lower body. */
static void joint_apply(cf_solver *s, int j, const cf_joint_chunk *C, int l)
{
    const cf_joint *J = &s->jt[j];
    int bl = J->bl, bu = J->bu, side;
    for (side = 0; side < 2; side++) {
        s->F[3 * bu] += C->Fw[side][0][l]; s->F[3 * bu + 1] += C->Fw[side][1][l];
        s->F[3 * bu + 2] += C->Fw[side][2][l];
        s->T[3 * bu] += C->Tu[side][0][l]; s->T[3 * bu + 1] += C->Tu[side][1][l];
        s->T[3 * bu + 2] += C->Tu[side][2][l];
        if (bl != 0) {
            s->F[3 * bl] -= C->Fw[side][0][l]; s->F[3 * bl + 1] -= C->Fw[side][1][l];
            s->F[3 * bl + 2] -= C->Fw[side][2][l];
            s->T[3 * bl] -= C->Tl[side][0][l]; s->T[3 * bl + 1] -= C->Tl[side][1][l];
            s->T[3 * bl + 2] -= C->Tl[side][2][l];
        }
    }
}

/* Joints [j0, j0 + n) through the face runner, in chunks of CF_JCH. */
static void points_joints(cf_solver *s, cf_points *pts, int j0, int n, const double *ww, double dt,
                          cf_step_energy *e)
{
    cf_chunk_before_fn before;
    cf_chunk_after_fn after;
    cf_joint_chunk C;
    int c0;
    chunk_fns(s->lanes, &before, &after);
    for (c0 = j0; c0 < j0 + n; c0 += CF_JCH) {
        int m = j0 + n - c0 < CF_JCH ? j0 + n - c0 : CF_JCH, l, i;
        /* from 8 joints on, a whole chunk (a fixed trip count, no remainder loop) */
        int lanes = m >= 8 ? CF_JCH : m;
        chunk_gather(s, pts, ww, c0, m, lanes, &C);
        before(&C, lanes, dt);
        for (l = 0; l < m; l++) joint_points(s, pts, c0 + l, &C, l, e);
        for (l = m; l < lanes; l++) {   /* lanes past the last joint: defined values */
            C.has[0][l] = C.has[1][l] = 0.0;
            for (i = 0; i < 6; i++) C.sm[0][i][l] = C.sm[1][i][l] = 0.0;
        }
        after(&C, lanes);
        for (l = 0; l < m; l++) joint_apply(s, c0 + l, &C, l);   /* in joint order */
    }
}

static void points_joint(cf_solver *s, void *state, const cf_joint *J, const double *ww, double dt,
                         cf_step_energy *e)
{
    points_joints(s, (cf_points *)state, (int)(J - s->jt), 1, ww, dt, e);
}

static void points_all(cf_solver *s, void *state, const double *ww, double dt, cf_step_energy *e)
{
    points_joints(s, (cf_points *)state, 0, s->nj, ww, dt, e);
}

/* ---- the points' state: create, reset, free --------------------------------------- */

static void points_free(void *state)
{
    cf_points *p = (cf_points *)state;
    if (!p) return;
    free(p->jt); free(p->side); free(p->hint); free(p->loc); free(p->w); free(p->ihkw);
    free(p->lx); free(p->ly); free(p->hx); free(p->hy); free(p->fast); free(p->knw); free(p->ksw);
    free(p->fsx); free(p->fsy); free(p->state); free(p->pen0); free(p->sleep_state);
    free(p);
}

/* The arrays of np points and nj joints (zeroed); NULL when out of memory. */
static cf_points *points_alloc(int np, int nj)
{
    cf_points *p = (cf_points *)calloc(1, sizeof *p);
    size_t n = (size_t)(np > 0 ? np : 1);
    int bad;
    if (!p) return NULL;
    p->np = np;
    p->nj = nj;
    p->jt = (cf_points_joint *)calloc((size_t)(nj > 0 ? nj : 1), sizeof *p->jt);
    p->side = (int *)calloc(n, sizeof(int)); p->hint = (int *)calloc(n, sizeof(int));
    p->loc = (double *)calloc(3 * n, sizeof(double));
    p->sleep_state = (double *)calloc((size_t)(nj > 0 ? nj : 1) * CF_SLEEP_ND, sizeof(double));
    bad = !p->jt || !p->side || !p->hint || !p->loc || !p->sleep_state;
#define POINTS_ARRAY(a) do { p->a = (double *)calloc(n, sizeof(double)); bad |= !p->a; } while (0)
    POINTS_ARRAY(w); POINTS_ARRAY(ihkw); POINTS_ARRAY(lx); POINTS_ARRAY(ly); POINTS_ARRAY(hx); POINTS_ARRAY(hy);
    POINTS_ARRAY(fast); POINTS_ARRAY(knw); POINTS_ARRAY(ksw); POINTS_ARRAY(fsx); POINTS_ARRAY(fsy);
    POINTS_ARRAY(state); POINTS_ARRAY(pen0);
#undef POINTS_ARRAY
    if (bad) { points_free(p); return NULL; }
    return p;
}

/* The hot loop's view of the points of joint j: rest position of each point in the frame of the
 * face it touches (the face centres aligned, or d0 apart as built); a point within contact_tolerance of a home that lies
 * inside that face is inside the grown polygon: the cheap test of the hot loop. */
static void points_derived(const cf_joint *J, cf_points *p, int j)
{
    const cf_points_joint *PJ = &p->jt[j];
    int k;
    for (k = PJ->p0; k < PJ->p0 + PJ->np; k++) {
        const cf_face *own = p->side[k] == 0 ? &J->fu : &J->fl, *oth = p->side[k] == 0 ? &J->fl : &J->fu;
        double hx = p->loc[3 * k] - own->c[0], hy = p->loc[3 * k + 1] - own->c[1];
        double tol = p->contact_tolerance * oth->rc;
        if (J->asb) {   /* as built: the faces' centres d0 apart at rest (lower face frame) */
            double sg = p->side[k] == 0 ? 1.0 : -1.0;
            hx += sg * J->d0[0]; hy += sg * J->d0[1];
        }
        int homein = cf_face_inside(oth, hx, hy, 1e-9 * oth->rc);
        p->lx[k] = p->loc[3 * k]; p->ly[k] = p->loc[3 * k + 1];
        p->hx[k] = hx; p->hy[k] = hy;
        /* squared radius of the cheap test (-1: none; the point then takes the polygon test) */
        p->fast[k] = homein ? cf_points_quick_r2(oth, tol) : -1.0;
        p->knw[k] = J->kn * p->w[k]; p->ksw[k] = J->ks * p->w[k];
        p->ihkw[k] = 0.5 / (J->ks * p->w[k]);
    }
}

/* The state of a points model: the face points at the polygon vertices (mm = 0) or mm per edge of
 * a refined face mesh (solver_face_points.c), what the hot loop reads of each, its options. */
static int points_create(cf_solver *s, int mm, const double *opt, void **state)
{
    cf_face_points fp;
    cf_points *p;
    int j, k, st = cf_solver_face_points_make(s, mm, &fp);
    if (st) return st;
    p = points_alloc(fp.np, s->nj);
    if (!p) { cf_solver_face_points_free(&fp); return cf_solver_fail(s, CF_ENOMEM, "out of memory"); }
    p->contact_tolerance = opt[0];
    p->reentry_depth = opt[1];
    p->sleep = opt[2] != 0.0;
    p->sleep_margin = opt[3];
    memcpy(p->side, fp.side, sizeof(int) * (size_t)fp.np);
    memcpy(p->loc, fp.loc, sizeof(double) * 3 * (size_t)fp.np);
    memcpy(p->w, fp.w, sizeof(double) * (size_t)fp.np);
    for (j = 0; j < s->nj; j++) {
        const cf_joint *J = &s->jt[j];
        cf_points_joint *PJ = &p->jt[j];
        PJ->p0 = fp.p0[j]; PJ->np = fp.n[j]; PJ->n0 = fp.n0[j];
        points_derived(J, p, j);
        /* every point of a face lies in that face's plane: one body-frame z per face */
        PJ->lz[0] = J->fu.c[2]; PJ->lz[1] = J->fl.c[2];
        cf_sleep_moments(p, PJ, 0, PJ->sq[0], PJ->sqs[0], &PJ->srho[0]);
        cf_sleep_moments(p, PJ, 1, PJ->sq[1], PJ->sqs[1], &PJ->srho[1]);
        for (k = PJ->p0; k < PJ->p0 + PJ->np; k++)
            if (p->loc[3 * k + 2] != PJ->lz[p->side[k]]) st = cf_solver_fail(s, CF_EINVAL, "internal: point off its face plane");
    }
    cf_solver_face_points_free(&fp);
    if (st) { points_free(p); return st; }
    *state = p;
    return CF_OK;
}

/* The points models' options: the two they share first, then perimeter's mesh (the order of opt
 * in their create hooks). */
#define POINTS_OPTIONS                                                                                        \
    {"contact_tolerance", CF_SOLVER_OPTION_REAL, 0.0, 0.1, 0, 1, 1e-2, "-",                                  \
     "A sub-contact overhanging the other face by less than this fraction of the face's circumradius still " \
     "bears."},                                                                                              \
    {"reentry_depth", CF_SOLVER_OPTION_REAL, 0.0, 0.1, 0, 0, 0.0, "-",                                       \
     "A point that was off the face (beside it, below its plane) and comes back onto it at most this "       \
     "fraction of the face's circumradius deep takes contact with its spring compressed to that depth (the " \
     "energy it brings is booked as contact_switch); a deeper one takes contact with its spring "            \
     "unstretched. 0: every re-entry unstretched (docs/accuracy.md, \"Two-component motion\")."},             \
    {"sleep", CF_SOLVER_OPTION_FLAG, 0, 1, 0, 0, 0, "-",                                                    \
     "Sleeping joints: a joint whose points all stick with the margin sleep_margin is advanced by its "     \
     "linear law (O(1) per step) until a bound on its motion says a point could open, slip or leave the "    \
     "face (docs/performance.md, \"Sleeping joints\"); results change by round-off only."},                  \
    {"sleep_margin", CF_SOLVER_OPTION_REAL, 0.0, 1.0, 1, 1, 0.5, "-",                                        \
     "Margin of the sleeping joints: a joint falls asleep when every point's shear is at most 1 - m of "    \
     "its Coulomb cap, and wakes when its motion could use m of the points' smallest depth, slip margin "    \
     "or distance to the face's edge."}
static const cf_solver_option vertex_options[] = {POINTS_OPTIONS};
static const cf_solver_option perimeter_options[] = {
    POINTS_OPTIONS,
    {"points_per_edge", CF_SOLVER_OPTION_INT, 1, 64, 0, 0, 1, "-",
     "Points per polygon edge of the refined face mesh (its interior nodes too)."},
};

/* Set-up of the two points models: the points at the polygon vertices, or points_per_edge per
 * edge of a refined face mesh. */
static int vertex_create(cf_solver *s, const double *opt, void **state)
{
    return points_create(s, 0, opt, state);
}

static int perimeter_create(cf_solver *s, const double *opt, void **state)
{
    return points_create(s, (int)opt[4], opt, state);
}

/* The points' state at the start of a run: no shear, open, no offset; the polygon tests'
 * starting edges too (a run does not depend on the runs before it). */
static void points_reset(const cf_solver *s, void *state)
{
    cf_points *p = (cf_points *)state;
    size_t n = (size_t)p->np;
    (void)s;
    memset(p->sleep_state, 0, sizeof(double) * (size_t)(p->nj > 0 ? p->nj : 1) * CF_SLEEP_ND);
    p->slept = 0;
    if (n == 0) return;
    memset(p->fsx, 0, sizeof(double) * n);
    memset(p->fsy, 0, sizeof(double) * n);
    memset(p->state, 0, sizeof(double) * n);   /* 0.0 is CF_POINT_OPEN */
    memset(p->pen0, 0, sizeof(double) * n);
    memset(p->hint, 0, sizeof(int) * n);
}

/* The state that carries over (solver_state.c): per point its shear spring (x, y), contact state,
 * offset and the polygon test's starting edge (an int, exact as a double); with `sleep` on, each
 * joint's sleep state after them (solver_sleep.h). */
static long points_state_doubles(const cf_solver *s, const void *state)
{
    const cf_points *p = (const cf_points *)state;
    (void)s;
    return 5 * (long)p->np + (p->sleep ? (long)p->nj * CF_SLEEP_ND : 0);
}

static void points_state_copy(const cf_solver *s, void *state, double *buf, int to_buf)
{
    cf_points *p = (cf_points *)state;
    size_t n = (size_t)p->np, k, sz = sizeof(double) * n;
    (void)s;
    if (to_buf) {
        memcpy(buf, p->fsx, sz); memcpy(buf + n, p->fsy, sz); memcpy(buf + 2 * n, p->state, sz);
        memcpy(buf + 3 * n, p->pen0, sz);
        for (k = 0; k < n; k++) buf[4 * n + k] = p->hint[k];
        if (p->sleep) memcpy(buf + 5 * n, p->sleep_state, sizeof(double) * (size_t)p->nj * CF_SLEEP_ND);
    } else {
        memcpy(p->fsx, buf, sz); memcpy(p->fsy, buf + n, sz); memcpy(p->state, buf + 2 * n, sz);
        memcpy(p->pen0, buf + 3 * n, sz);
        for (k = 0; k < n; k++) p->hint[k] = (int)buf[4 * n + k];
        if (p->sleep) memcpy(p->sleep_state, buf + 5 * n, sizeof(double) * (size_t)p->nj * CF_SLEEP_ND);
    }
}

/* For the stability limit: every point's springs at its rest position. */
static void points_stiffness(const cf_solver *s, const void *state, const cf_joint *J, cf_springs *K)
{
    const cf_points *p = (const cf_points *)state;
    const cf_points_joint *PJ = &p->jt[J - s->jt];
    int k;
    for (k = PJ->p0; k < PJ->p0 + PJ->np; k++) {
        int b = p->side[k] == 0 ? J->bu : J->bl;
        double q[3];
        q[0] = s->x0[3 * b] + p->loc[3 * k];
        q[1] = s->x0[3 * b + 1] + p->loc[3 * k + 1];
        q[2] = s->x0[3 * b + 2] + p->loc[3 * k + 2];
        cf_springs_add_contact(K, J, q, p->w[k]);
    }
}

/* The face runners give the same bits at every width: two, four or eight points per
 * SSE2, AVX2 or AVX-512 instruction on the sticking path (the widest the CPU has), else
 * one point at a time. */
const cf_solver_contact_model cf_solver_points_vertex = {
    "vertex",
    "Sub-contact points at the polygon vertices of both faces (3DEC-like), each with the soft "
    "Coulomb law of contact_law.h.",
    vertex_options, (int)(sizeof vertex_options / sizeof vertex_options[0]),
    vertex_create, points_reset, points_free, points_stiffness, points_joint, points_all, 1,
    points_state_doubles, points_state_copy,
};

const cf_solver_contact_model cf_solver_points_perimeter = {
    "perimeter",
    "Sub-contact points on a refined face mesh (points_per_edge per polygon edge, interior "
    "nodes too) with lumped area weights, each with the soft Coulomb law of contact_law.h; "
    "converges to the exact interface as points_per_edge grows.",
    perimeter_options, (int)(sizeof perimeter_options / sizeof perimeter_options[0]),
    perimeter_create, points_reset, points_free, points_stiffness, points_joint, points_all, 1,
    points_state_doubles, points_state_copy,
};
