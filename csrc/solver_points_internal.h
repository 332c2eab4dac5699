/*
 * solver_points_internal.h -- what the scalar and the SIMD point paths share: the
 * constants of one face's pass, its sums, the polygon test with a hint, and the full
 * per-point state logic around the contact law of contact_law.h (never in a cffi
 * region).
 */
#ifndef CF_SOLVER_POINTS_INTERNAL_H
#define CF_SOLVER_POINTS_INTERNAL_H

#include "contact_law.h"
#include "solver_internal.h"

/* The constants of one face's pass over the points that touch it: the frame map and
 * the relative displacement field over the step (both in the face frame), the face's
 * thresholds. */
typedef struct {
    double M[9], t[3], mz[3];   /* X = M loc + t; mz = M[., 2] * (the points' shared body z) */
    double A[3], W[3];          /* relative displacement of the upper body over the step: A + W x X */
    double sgn;                 /* pen = sgn * Z */
    double pmax;                /* a point deeper than this has passed beside or through the face */
    double pent;                /* a point not in contact takes contact with its spring stretched only this deep or less */
    double tol;                 /* the polygon test's growth, m */
    double kn, mu;
    int unbounded;              /* the face is the (unbounded) ground */
    const cf_face *ff;          /* the face the points are tested against */
} cf_face_pass;

/* The sums of one face in the face frame, each component added in point order:
 * force (fx, fy, fz), moment about the face centre (mx, my, mz), and over the whole
 * joint the spring energy and normal force (vs, jfn; only at steps that evaluate the
 * energy); the slip dissipation and contact_switch energy (J). */
typedef struct {
    double sm[8];
    double dslip, dswitch;
} cf_face_sums;

/* The joints in lanes (solver_points.c): the per-joint work around the points for a
 * chunk of up to CF_JCH lanes at a time in structure-of-arrays form. A lane is a joint of
 * one run (the single-run path) or one joint of several runs (solver_batch.c). */
enum { CF_JCH = 16 };   /* lanes per chunk */

typedef struct {
    /* in: the two bodies' rotations, positions, velocities and world omegas; the face
     * centres (body frame) and the points' shared body z of each side; has a lower body */
    double RL[9][CF_JCH], RU[9][CF_JCH], xl[3][CF_JCH], xu[3][CF_JCH], vl[3][CF_JCH], vu[3][CF_JCH];
    double wl[3][CF_JCH], wu[3][CF_JCH];
    double fcl[3][CF_JCH], fcu[3][CF_JCH], lz[2][CF_JCH], gl[CF_JCH];
    /* out: M0 = RL^T RU; per side: face centre (world), A, W, t, mz (cf_face_pass) */
    double M0[9][CF_JCH], c[2][3][CF_JCH], A[2][3][CF_JCH], W[2][3][CF_JCH], t[2][3][CF_JCH], mz[2][3][CF_JCH];
    /* in: per side the face sums (force, moment; face frame), has points; out: force
     * (world) and the torques about the upper and lower body's centres, moment included */
    double sm[2][6][CF_JCH], has[2][CF_JCH], Fw[2][3][CF_JCH], Tu[2][3][CF_JCH], Tl[2][3][CF_JCH];
} cf_joint_chunk;

/* the chunk's lane work before and after the points, n lanes (the widest the CPU runs) */
typedef void (*cf_chunk_before_fn)(cf_joint_chunk *C, int n, double dt);
typedef void (*cf_chunk_after_fn)(cf_joint_chunk *C, int n);
void cf_solver_points_chunk_fns(cf_chunk_before_fn *before, cf_chunk_after_fn *after);

/* The face's part of a pass (side 0: the upper body's points against the lower face,
 * side 1: the lower body's points against the upper face): thresholds and joint law. */
static inline void cf_face_pass_set(const cf_solver *s, const cf_joint *J, int side, cf_face_pass *P)
{
    const cf_face *ff = side == 0 ? &J->fl : &J->fu;
    /* a point deeper than a tenth of the face's radius is not in contact with it:
     * it has passed beside or through the face (a tumbling block after a collapse) */
    P->pmax = 0.1 * ff->rc;
    /* a point coming back onto the face deeper than this starts unstretched (reentry_depth) */
    P->pent = s->def.reentry_depth * ff->rc;
    P->tol = s->def.contact_tolerance * ff->rc;
    P->sgn = side == 0 ? -1.0 : 1.0;
    P->kn = J->kn; P->mu = J->mu;
    P->unbounded = side == 0 && J->bl == 0;
    P->ff = ff;
}

/* The step's part of a pass, from lane l of a chunk: frame map (side 0 in the lower face's
 * frame: M0; side 1 in the upper face's: M0^T), displacement field, translation, z offset. */
static inline void cf_face_pass_lane(const cf_joint_chunk *C, int side, int l, cf_face_pass *P)
{
    int i, r;
    for (i = 0; i < 3; i++) {
        for (r = 0; r < 3; r++) P->M[3 * i + r] = side == 0 ? C->M0[3 * i + r][l] : C->M0[3 * r + i][l];
        P->A[i] = C->A[side][i][l]; P->W[i] = C->W[side][i][l]; P->t[i] = C->t[side][i][l];
        P->mz[i] = C->mz[side][i][l];
    }
}

/* Runs the points [k0, k1) against the face of P, adding to S in point order. */
typedef void (*cf_points_run_fn)(cf_solver *s, const cf_face_pass *P, int k0, int k1, cf_face_sums *S, int need);

/* solver_points.c: the forces of one joint's points, or of every joint (in joint
 * order; the per-joint work in lanes across joints), with the given face runner. */
void cf_solver_points_joint(cf_solver *s, cf_joint *J, const double *ww, double dt, cf_step_energy *e,
                            cf_points_run_fn run);
void cf_solver_points_all(cf_solver *s, const double *ww, double dt, cf_step_energy *e, cf_points_run_fn run);

/* the face runners: scalar (solver_points.c), SSE2 (solver_points_sse2.c) */
void cf_solver_points_run_scalar(cf_solver *s, const cf_face_pass *P, int k0, int k1, cf_face_sums *S, int need);
#ifdef CF_SOLVER_SIMD
void cf_solver_points_sse2_run(cf_solver *s, const cf_face_pass *P, int k0, int k1, cf_face_sums *S, int need);
void cf_solver_points_sse2_pairs(cf_solver *s, const cf_face_pass *P, int k0, int k1, cf_face_sums *S, int need);
/* four points per AVX2 instruction (solver_points_avx2.c; GCC-compatible x86-64
 * compilers, chosen at run time on CPUs with AVX2; -DCF_FORCE_SSE2 leaves it out) */
#if defined(__x86_64__) && defined(__GNUC__) && !defined(CF_FORCE_SSE2)
#define CF_SOLVER_AVX2 1
void cf_solver_points_avx2_run(cf_solver *s, const cf_face_pass *P, int k0, int k1, cf_face_sums *S, int need);
/* eight points per AVX-512F instruction (solver_points_avx512.c; on CPUs with AVX-512F;
 * -DCF_FORCE_AVX2 leaves it out) */
#if !defined(CF_FORCE_AVX2)
#define CF_SOLVER_AVX512 1
void cf_solver_points_avx512_run(cf_solver *s, const cf_face_pass *P, int k0, int k1, cf_face_sums *S, int need);
#endif
#endif
#endif

/* Regular polygon test with a hint: the projection of (X, Y) on the edge normals is
 * unimodal around the polygon, so walking from the last maximising edge finds the
 * maximum in a few steps. Inside iff that maximum <= apothem + tol. */
static inline int cf_face_inside_hint(const cf_face *f, double X, double Y, double tol, int *hint)
{
    int n = f->n, k = *hint, kp, km;
    double best, pp, pm;
    if (X * X + Y * Y <= f->apo * f->apo) return 1;
    best = X * f->ec[k] + Y * f->es[k];
    kp = k + 1 == n ? 0 : k + 1;
    pp = X * f->ec[kp] + Y * f->es[kp];
    if (pp > best) {
        do { k = kp; best = pp; kp = k + 1 == n ? 0 : k + 1; pp = X * f->ec[kp] + Y * f->es[kp]; } while (pp > best);
    } else {
        km = k == 0 ? n - 1 : k - 1;
        pm = X * f->ec[km] + Y * f->es[km];
        while (pm > best) { k = km; best = pm; km = k == 0 ? n - 1 : k - 1; pm = X * f->ec[km] + Y * f->es[km]; }
    }
    *hint = k;
    return best <= f->apo + tol;
}

/* One sub-contact k against the face of P, any state: position in the face frame,
 * open / off-the-face / in-contact transitions (with their energy bookkeeping), then
 * the contact law. Returns 1 and its terms in t (fx, fy, fn, mx, my, mz, vs, fn) when
 * it carries force, 0 when it is open, too deep or off the face. The point's fixed data
 * are those of s; its state (shear force, contact state, offset depth, polygon hint) is
 * where the pointers say: s's own arrays for one run, a lane of the batch's arrays for a
 * run of a batch (solver_batch.c). */
static inline int cf_point_law_at(const cf_solver *s, const cf_face_pass *P, int k, double *fsx, double *fsy,
                                  double *state, double *pen0, int *hint, cf_face_sums *S, double *t)
{
    double lx = s->p_lx[k], ly = s->p_ly[k], w = s->p_w[k], fs[2], fn, dux, duy, fs2, pe;
    double X = P->M[0] * lx + P->M[1] * ly + P->mz[0] + P->t[0];
    double Y = P->M[3] * lx + P->M[4] * ly + P->mz[1] + P->t[1];
    double Z = P->M[6] * lx + P->M[7] * ly + P->mz[2] + P->t[2];
    double pen = P->sgn * Z;
    int slipping;
    /* state: 0 open, 1 in contact, 2 overlapping the plane but outside the face polygon,
     * 3 deeper than pmax (beside or through the face), 4 in contact with its normal spring
     * unstretched at depth pen0 (it came onto the face from state 2 or 3 deeper than pent):
     * force kn w (pen - pen0). Every transition keeps the energy ledger closed. */
    if (!(pen > 0.0) || pen > P->pmax) {
        S->dslip += cf_law_release(fsx, fsy, s->p_ihkw[k]);
        if (pen > 0.0) {
            /* too deep while compressed: its normal spring energy leaves the model as when
             * it slides off the face (contact_switch) */
            pe = *state == 4.0 ? pen - *pen0 : pen;
            if (*state == 1.0 || *state == 4.0) S->dswitch += 0.5 * P->kn * w * pe * pe;
            *state = 3.0;
        } else *state = 0.0;
        return 0;
    }
    if (!(P->unbounded || (X - s->p_hx[k]) * (X - s->p_hx[k]) + (Y - s->p_hy[k]) * (Y - s->p_hy[k]) <= s->p_fast[k]
          || cf_face_inside_hint(P->ff, X, Y, P->tol, hint))) {
        /* slid off the face while compressed: its normal spring energy leaves the
         * model (booked as contact_switch, not as a balance error) */
        pe = *state == 4.0 ? pen - *pen0 : pen;
        if (*state == 1.0 || *state == 4.0) S->dswitch += 0.5 * P->kn * w * pe * pe;
        S->dslip += cf_law_release(fsx, fsy, s->p_ihkw[k]);
        *state = 2.0;
        return 0;
    }
    if (*state == 2.0 || *state == 3.0) {
        /* slid onto the face (from 2) or back within pmax (from 3): deeper than pent, the
         * point takes contact with its spring unstretched at that depth (state 4) -- a
         * corner that went below the lower face beside it cannot bring a compressed spring
         * back (that energy would come from nothing: it broke the ledger of two-component
         * runs, docs/accuracy.md); shallower, with its spring energy booked as
         * contact_switch */
        if (pen > P->pent) { *pen0 = pen; *state = 4.0; }
        else { S->dswitch -= 0.5 * P->kn * w * pen * pen; *state = 1.0; }
    } else if (*state == 0.0) *state = 1.0;
    pe = pen;
    if (*state == 4.0) {
        if (pen < *pen0) *pen0 = pen;   /* no tension: the offset follows the point up */
        pe = pen - *pen0;
    }
    dux = P->A[0] + P->W[1] * Z - P->W[2] * Y;
    duy = P->A[1] + P->W[2] * X - P->W[0] * Z;
    fs[0] = *fsx; fs[1] = *fsy;
    S->dslip += cf_law_update(pe, dux, duy, s->p_knw[k], s->p_ksw[k], P->mu, fs, &fn, &slipping);
    *fsx = fs[0]; *fsy = fs[1];
    fs2 = fs[0] * fs[0] + fs[1] * fs[1];
    /* on both sides the force on the upper body is +fn along the frame's z */
    t[0] = fs[0]; t[1] = fs[1]; t[2] = fn;
    CF_LAW_TERMS(CF_LAW_SADD, CF_LAW_SSUB, CF_LAW_SMUL, 0.5, X, Y, Z, pe, fn, fs[0], fs[1], fs2, s->p_ihkw[k],
                 t[3], t[4], t[5], t[6]);
    t[7] = fn;
    return 1;
}

/* cf_point_law_at on s's own state of point k */
static inline int cf_point_law(cf_solver *s, const cf_face_pass *P, int k, cf_face_sums *S, int *hint, double *t)
{
    return cf_point_law_at(s, P, k, s->p_fsx + k, s->p_fsy + k, s->p_state + k, s->p_pen0 + k, hint, S, t);
}

/* add the terms t[0..7] of one point (same order as cf_face_sums) */
static inline void cf_sums_add(cf_face_sums *S, const double *t, int need)
{
    S->sm[0] += t[0]; S->sm[1] += t[1]; S->sm[2] += t[2]; S->sm[3] += t[3]; S->sm[4] += t[4]; S->sm[5] += t[5];
    if (need) { S->sm[6] += t[6]; S->sm[7] += t[7]; }
}

#ifdef CF_SOLVER_SIMD
#include <emmintrin.h>

/* What every SIMD width of the points runner shares (SSE2 is part of every x86-64 CPU; these
 * inline functions are inlined into the AVX2 and AVX-512 runners, whose targets include it). */

/* The face sums on two lanes: (fx, fy) (fz, mx) (my, mz) (vs, jfn), each lane a sequential sum
 * in point order, as the scalar cf_face_sums. */
typedef struct {
    __m128d s01, s23, s45, s67;
} cf_simd_sums;

static inline void cf_simd_sums_load(cf_simd_sums *V, const cf_face_sums *S)
{
    V->s01 = _mm_loadu_pd(S->sm); V->s23 = _mm_loadu_pd(S->sm + 2);
    V->s45 = _mm_loadu_pd(S->sm + 4); V->s67 = _mm_loadu_pd(S->sm + 6);
}

static inline void cf_simd_sums_store(const cf_simd_sums *V, cf_face_sums *S)
{
    _mm_storeu_pd(S->sm, V->s01); _mm_storeu_pd(S->sm + 2, V->s23);
    _mm_storeu_pd(S->sm + 4, V->s45); _mm_storeu_pd(S->sm + 6, V->s67);
}

/* add the terms t[0..7] of one point */
static inline void cf_simd_sums_add(cf_simd_sums *V, const double *t, int need)
{
    V->s01 = _mm_add_pd(V->s01, _mm_loadu_pd(t));
    V->s23 = _mm_add_pd(V->s23, _mm_loadu_pd(t + 2));
    V->s45 = _mm_add_pd(V->s45, _mm_loadu_pd(t + 4));
    if (need) V->s67 = _mm_add_pd(V->s67, _mm_loadu_pd(t + 6));
}

/* A block of nl lanes (points k .. k + nl - 1) that cannot take the vector sums: one point at a
 * time, in order -- a sticking lane (bit set in bits) from its vector results (vx ... vvs, the
 * lanes stored to memory), an open lane (bit set in open) skipped, any other through the full
 * law. */
static inline void cf_simd_lanes_in_order(cf_solver *s, const cf_face_pass *P, cf_face_sums *S, cf_simd_sums *V,
                                          int k, int nl, int open, int bits, const double *vx, const double *vy,
                                          const double *vf, const double *vmx, const double *vmy,
                                          const double *vmz, const double *vvs, int need)
{
    double t[8];
    int l;
    for (l = 0; l < nl; l++) {
        if (open & (1 << l)) continue;
        if (bits & (1 << l)) {
            s->p_fsx[k + l] = vx[l]; s->p_fsy[k + l] = vy[l];
            t[0] = vx[l]; t[1] = vy[l]; t[2] = vf[l]; t[3] = vmx[l]; t[4] = vmy[l]; t[5] = vmz[l];
            t[6] = vvs[l]; t[7] = vf[l];
            cf_simd_sums_add(V, t, need);
        } else if (cf_point_law(s, P, k + l, S, s->p_hint + k + l, t)) {
            cf_simd_sums_add(V, t, need);
        }
    }
}
#endif

#endif
