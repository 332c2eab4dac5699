/*
 * solver_points_internal.h -- what the scalar and the SIMD point paths share: the
 * constants of one face's pass, its sums, the polygon test with a hint, and the full
 * per-point state logic around the contact law of contact_law.h (never in a cffi
 * region).
 */
#ifndef CF_SOLVER_POINTS_INTERNAL_H
#define CF_SOLVER_POINTS_INTERNAL_H

#include <string.h>

#include "contact_law.h"
#include "solver_internal.h"

/* The state of the points models ("vertex", "perimeter": solver_points.c), theirs alone: created
 * at set-up, reset at the start of a run, freed with the solver. Per joint, its points' range and
 * the body-frame z of each side's face; per point, in structure-of-arrays form: the fixed data
 * (face side, body-frame position, area share w, 1 / (2 ks w), the hot loop's body-frame x and y,
 * rest position in the other face's frame, the squared radius of the cheap inside test around it
 * (-1: none), kn w and ks w) and the per-run state (polygon-test hint, shear force in the face
 * frame, contact state: cf_point_state, the offset depth of state CF_POINT_OFFSET); the model's
 * options. */
typedef struct {
    int p0, np, n0;                 /* its points [p0, p0 + np), the first n0 on the upper face */
    double lz[2];                   /* body-frame z of the points of side 0 (upper face) and side 1 (lower face) */
    double sq[2][6], sqs[2][6], srho[2];   /* per side the moments of a sleeping joint (solver_sleep.h) */
} cf_points_joint;

typedef struct {
    int np, nj;
    cf_points_joint *jt;            /* one per joint */
    int *side, *hint;
    double *loc, *w, *ihkw;
    double *lx, *ly, *hx, *hy, *fast, *knw, *ksw;
    double *fsx, *fsy, *state, *pen0;
    double contact_tolerance;       /* the option: overhang that still bears / the face's circumradius */
    double reentry_depth;           /* the option: deepest stretched re-entry / the face's circumradius */
    int sleep;                      /* the option: sleeping joints (solver_sleep.h) */
    double sleep_margin;            /* the option: their margin m */
    double *sleep_state;            /* nj x CF_SLEEP_ND: each joint's sleep state (the single run's) */
    long slept;                     /* joint-steps taken asleep since the run began (single run; the C tests read it) */
} cf_points;

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

/* the chunk's lane work before and after the points, n lanes; the functions of a width (`lanes`) */
typedef void (*cf_chunk_before_fn)(cf_joint_chunk *C, int n, double dt);
typedef void (*cf_chunk_after_fn)(cf_joint_chunk *C, int n);
void cf_solver_points_chunk_fns(int lanes, cf_chunk_before_fn *before, cf_chunk_after_fn *after);

/* The face's part of a pass (side 0: the upper body's points against the lower face,
 * side 1: the lower body's points against the upper face): thresholds and joint law. */
static inline void cf_face_pass_set(const cf_points *pts, const cf_joint *J, int side, cf_face_pass *P)
{
    const cf_face *ff = side == 0 ? &J->fl : &J->fu;
    /* a point deeper than a tenth of the face's radius is not in contact with it:
     * it has passed beside or through the face (a tumbling block after a collapse) */
    P->pmax = 0.1 * ff->rc;
    /* a point coming back onto the face deeper than this starts unstretched (reentry_depth) */
    P->pent = pts->reentry_depth * ff->rc;
    P->tol = pts->contact_tolerance * ff->rc;
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

/* The wide face runners: the points [k0, k1) against the face of P, adding to S in point order,
 * CF_BW points per instruction (solver_points_wide.h, one per width the build has:
 * solver_points_w2.c, _w4.c, _w8.c); the scalar one is cf_points_run_scalar below. */
void cf_solver_points_w2_run(cf_points *pts, const cf_face_pass *P, int k0, int k1, cf_face_sums *S, int need);
void cf_solver_points_w4_run(cf_points *pts, const cf_face_pass *P, int k0, int k1, cf_face_sums *S, int need);
void cf_solver_points_w8_run(cf_points *pts, const cf_face_pass *P, int k0, int k1, cf_face_sums *S, int need);

/* The squared radius of the hot loop's cheap inside test of a point whose home lies inside face f (within
 * 1e-9 rc of it, cf_face_inside), contact tolerance tol (m): every point that near its home is inside f grown
 * by tol -- the polygon test's answer, never more. A face scaled along y by a grows by tol a along y (its
 * test runs on (X, Y / a)): for a < 1 the radius shrinks by a. -1: none (the polygon test decides). */
static inline double cf_points_quick_r2(const cf_face *f, double tol)
{
    double r = tol - 1e-9 * f->rc;
    if (!(tol > 2e-9 * f->rc)) return -1.0;
    if (f->asp < 1.0) r *= f->asp;
    return r * r;
}

/* Regular polygon test with a hint: the projection of (X, Y) on the edge normals is
 * unimodal around the polygon, so walking from the last maximising edge finds the
 * maximum in a few steps. Inside iff that maximum <= apothem + tol. */
static inline int cf_face_inside_hint(const cf_face *f, double X, double Y, double tol, int *hint)
{
    int n = f->n, k = *hint, kp, km;
    double best, pp, pm;
    if (X * X + Y * Y <= f->apoc * f->apoc) return 1;
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

/* The contact state of a sub-contact point. It is stored as a double (cf_points.state, the
 * batch's lanes) so that the wide runners compare it in lane vectors: cf_point_state_is. */
typedef enum {
    CF_POINT_OPEN = 0,      /* not overlapping the face's plane */
    CF_POINT_CONTACT = 1,   /* in contact: force kn w pen */
    CF_POINT_OFF_FACE = 2,  /* overlapping the plane but outside the face polygon */
    CF_POINT_TOO_DEEP = 3,  /* deeper than pmax: beside or through the face */
    CF_POINT_OFFSET = 4     /* in contact with its normal spring unstretched at depth pen0
                             * (it came back onto the face deeper than pent): force kn w (pen - pen0) */
} cf_point_state;

/* Is the stored state st (a double, or a lane vector of them: a lane mask) the state named? */
#define cf_point_state_is(st, name) ((st) == (double)(name))

/* The state a point goes to over a step, from its state st and where it is now: depth pen
 * (overlap with the face's plane, m), inside the face polygon (read only when
 * 0 < pen <= pmax), the face's pmax and pent (cf_face_pass). The transition rules, once:
 * not overlapping -> open; deeper than pmax -> too deep; off the polygon -> off the face;
 * back on the face from off the face or too deep -> offset when deeper than pent (a corner
 * that went below the lower face beside it cannot bring a compressed spring back: that
 * energy would come from nothing), else contact; open -> contact; in contact stays. */
static inline cf_point_state cf_point_next(cf_point_state st, double pen, int inside, double pmax, double pent)
{
    if (!(pen > 0.0)) return CF_POINT_OPEN;
    if (pen > pmax) return CF_POINT_TOO_DEEP;
    if (!inside) return CF_POINT_OFF_FACE;
    if (st == CF_POINT_OFF_FACE || st == CF_POINT_TOO_DEEP) return pen > pent ? CF_POINT_OFFSET : CF_POINT_CONTACT;
    if (st == CF_POINT_OPEN) return CF_POINT_CONTACT;
    return st;
}

/* Does a point of state st carry force (its normal spring compressed)? */
static inline int cf_point_loaded(cf_point_state st)
{
    return st == CF_POINT_CONTACT || st == CF_POINT_OFFSET;
}

/* the energy of a normal spring kn w compressed by pe, J */
static inline double cf_point_spring_energy(double kn, double w, double pe)
{
    return 0.5 * kn * w * pe * pe;
}

/* Sub-contact (lx, ly) of its face in the frame of the face it is tested against, (X, Y, Z) =
 * M (lx, ly) + mz + t (cf_face_pass: the frame map's first two columns, the points' shared z, the
 * translation), and the tangential displacement of the upper body there over the step, (dux, duy)
 * of A + W x (X, Y, Z). One text for the full law, the wide runner and the batch: the plain
 * operators are the per-lane IEEE operations for double and for GCC vector types alike. */
#define CF_POINT_AT(M0, M1, M3, M4, M6, M7, z0, z1, z2, t0, t1, t2, lx, ly, X, Y, Z) \
    do {                                                                          \
        (X) = (M0) * (lx) + (M1) * (ly) + (z0) + (t0);                            \
        (Y) = (M3) * (lx) + (M4) * (ly) + (z1) + (t1);                            \
        (Z) = (M6) * (lx) + (M7) * (ly) + (z2) + (t2);                            \
    } while (0)
#define CF_POINT_DU(A0, A1, W0, W1, W2, X, Y, Z, dux, duy) \
    do {                                                 \
        (dux) = (A0) + (W1) * (Z) - (W2) * (Y);          \
        (duy) = (A1) + (W2) * (X) - (W0) * (Z);          \
    } while (0)

/* The lanes' face tests, for the wide runner and the batch (lane masks from the plain
 * comparisons of GCC vector types). Quick: inside where the point is within sqrt(fast) of its
 * rest position (dh) or within the face's inscribed circle (cf_face_inside_hint's first test).
 * Hint edge: with the edge normals (c, s) of the point's hint edge (h + 1), the next (h + 2) and
 * the previous (h), best is the point's distance along the hint edge's normal, and stay holds
 * where that edge is still the most distant (cf_face_inside_hint's walk would stay there): there
 * the point is inside iff best <= apo + tol; elsewhere the walk decides (cf_point_law_at). */
#define CF_LANES_QUICK_IN(dhx, dhy, fast, X, Y, apo2) \
    (((dhx) * (dhx) + (dhy) * (dhy) <= (fast)) | ((X) * (X) + (Y) * (Y) <= (apo2)))
#define CF_LANES_HINT_EDGE(X, Y, c0, s0, c1, s1, c2, s2, best, stay)                      \
    do {                                                                                  \
        (best) = (X) * (c0) + (Y) * (s0);                                                 \
        (stay) = ~((X) * (c1) + (Y) * (s1) > (best)) & ~((X) * (c2) + (Y) * (s2) > (best)); \
    } while (0)

/* One sub-contact k against the face of P, any state: position in the face frame, the
 * state's transition (cf_point_next) with its energy bookkeeping, then the contact law.
 * Returns 1 and its terms in t (fx, fy, fn, mx, my, mz, vs, fn) when it carries force, 0
 * when it is open, too deep or off the face. The point's fixed data are those of pts; its
 * state (shear force, contact state, offset depth, polygon hint) is where the pointers
 * say: pts's own arrays for one run, a lane of the batch's arrays for a run of a batch
 * (solver_batch.c). Every transition keeps the energy ledger closed. */
static inline int cf_point_law_at(const cf_points *pts, const cf_face_pass *P, int k, double *fsx, double *fsy,
                                  double *state, double *pen0, int *hint, cf_face_sums *S, double *t)
{
    double lx = pts->lx[k], ly = pts->ly[k], w = pts->w[k], fs[2], fn, dux, duy, fs2, pe, X, Y, Z, pen, dhx, dhy;
    cf_point_state st = (cf_point_state)(int)*state, nx;
    int slipping, inside;
    CF_POINT_AT(P->M[0], P->M[1], P->M[3], P->M[4], P->M[6], P->M[7], P->mz[0], P->mz[1], P->mz[2], P->t[0], P->t[1],
                P->t[2], lx, ly, X, Y, Z);
    pen = P->sgn * Z; dhx = X - pts->hx[k]; dhy = Y - pts->hy[k];
    inside = pen > 0.0 && !(pen > P->pmax)
                 && (P->unbounded || dhx * dhx + dhy * dhy <= pts->fast[k]
                     || cf_face_inside_hint(P->ff, X, Y, P->tol, hint));
    nx = cf_point_next(st, pen, inside, P->pmax, P->pent);
    *state = (double)nx;
    if (!cf_point_loaded(nx)) {
        /* too deep or slid off the face while compressed: its normal spring energy leaves
         * the model (booked as contact_switch, not as a balance error) */
        if (nx != CF_POINT_OPEN && cf_point_loaded(st))
            S->dswitch += cf_point_spring_energy(P->kn, w, st == CF_POINT_OFFSET ? pen - *pen0 : pen);
        S->dslip += cf_law_release(fsx, fsy, pts->ihkw[k]);
        return 0;
    }
    if (nx == CF_POINT_OFFSET && st != CF_POINT_OFFSET) *pen0 = pen;
    /* back on the face shallower than pent: its spring energy comes in as contact_switch */
    if (nx == CF_POINT_CONTACT && st != CF_POINT_CONTACT && st != CF_POINT_OPEN)
        S->dswitch -= cf_point_spring_energy(P->kn, w, pen);
    pe = pen;
    if (nx == CF_POINT_OFFSET) {
        if (pen < *pen0) *pen0 = pen;   /* no tension: the offset follows the point up */
        pe = pen - *pen0;
    }
    CF_POINT_DU(P->A[0], P->A[1], P->W[0], P->W[1], P->W[2], X, Y, Z, dux, duy);
    fs[0] = *fsx; fs[1] = *fsy;
    S->dslip += cf_law_update(pe, dux, duy, pts->knw[k], pts->ksw[k], P->mu, fs, &fn, &slipping);
    *fsx = fs[0]; *fsy = fs[1];
    fs2 = fs[0] * fs[0] + fs[1] * fs[1];
    /* on both sides the force on the upper body is +fn along the frame's z */
    t[0] = fs[0]; t[1] = fs[1]; t[2] = fn;
    CF_LAW_TERMS(CF_LAW_SADD, CF_LAW_SSUB, CF_LAW_SMUL, 0.5, X, Y, Z, pe, fn, fs[0], fs[1], fs2, pts->ihkw[k],
                 t[3], t[4], t[5], t[6]);
    t[7] = fn;
    return 1;
}

/* cf_point_law_at on pts's own state of point k */
static inline int cf_point_law(cf_points *pts, const cf_face_pass *P, int k, cf_face_sums *S, int *hint, double *t)
{
    return cf_point_law_at(pts, P, k, pts->fsx + k, pts->fsy + k, pts->state + k, pts->pen0 + k, hint, S, t);
}

/* add the terms t[0..7] of one point (same order as cf_face_sums) */
static inline void cf_sums_add(cf_face_sums *S, const double *t, int need)
{
    S->sm[0] += t[0]; S->sm[1] += t[1]; S->sm[2] += t[2]; S->sm[3] += t[3]; S->sm[4] += t[4]; S->sm[5] += t[5];
    if (need) { S->sm[6] += t[6]; S->sm[7] += t[7]; }
}

/* The scalar face runner: every point of [k0, k1) through the full law, in order (the reference
 * the wide runners equal bit for bit, and the last points of the arrays after them). */
static inline void cf_points_run_scalar(cf_points *pts, const cf_face_pass *P, int k0, int k1, cf_face_sums *S,
                                        int need)
{
    int k;
    double t[8];
    for (k = k0; k < k1; k++)
        if (cf_point_law(pts, P, k, S, pts->hint + k, t)) cf_sums_add(S, t, need);
}

#ifdef CF_SOLVER_SIMD
/* What every SIMD width of the points runner shares. */

/* The face sums as pairs: (fx, fy) (fz, mx) (my, mz) (vs, jfn), each lane a sequential sum
 * in point order, as the scalar cf_face_sums. */
typedef double cf_v2 __attribute__((vector_size(16)));
typedef struct {
    cf_v2 s01, s23, s45, s67;
} cf_simd_sums;

static inline void cf_simd_sums_load(cf_simd_sums *V, const cf_face_sums *S)
{
    memcpy(&V->s01, S->sm, sizeof V->s01); memcpy(&V->s23, S->sm + 2, sizeof V->s23);
    memcpy(&V->s45, S->sm + 4, sizeof V->s45); memcpy(&V->s67, S->sm + 6, sizeof V->s67);
}

static inline void cf_simd_sums_store(const cf_simd_sums *V, cf_face_sums *S)
{
    memcpy(S->sm, &V->s01, sizeof V->s01); memcpy(S->sm + 2, &V->s23, sizeof V->s23);
    memcpy(S->sm + 4, &V->s45, sizeof V->s45); memcpy(S->sm + 6, &V->s67, sizeof V->s67);
}

/* add the terms t[0..7] of one point */
static inline void cf_simd_sums_add(cf_simd_sums *V, const double *t, int need)
{
    V->s01 = V->s01 + (cf_v2){t[0], t[1]};
    V->s23 = V->s23 + (cf_v2){t[2], t[3]};
    V->s45 = V->s45 + (cf_v2){t[4], t[5]};
    if (need) V->s67 = V->s67 + (cf_v2){t[6], t[7]};
}

/* A block of nl lanes (points k .. k + nl - 1) that cannot take the vector sums: one point at a
 * time, in order -- a sticking lane (bit set in bits) from its vector results (vx ... vvs, the
 * lanes stored to memory), an open lane (bit set in open) skipped, any other through the full
 * law. */
static inline void cf_simd_lanes_in_order(cf_points *pts, const cf_face_pass *P, cf_face_sums *S, cf_simd_sums *V,
                                          int k, int nl, int open, int bits, const double *vx, const double *vy,
                                          const double *vf, const double *vmx, const double *vmy,
                                          const double *vmz, const double *vvs, int need)
{
    double t[8];
    int l;
    for (l = 0; l < nl; l++) {
        if (open & (1 << l)) continue;
        if (bits & (1 << l)) {
            pts->fsx[k + l] = vx[l]; pts->fsy[k + l] = vy[l];
            t[0] = vx[l]; t[1] = vy[l]; t[2] = vf[l]; t[3] = vmx[l]; t[4] = vmy[l]; t[5] = vmz[l];
            t[6] = vvs[l]; t[7] = vf[l];
            cf_simd_sums_add(V, t, need);
        } else if (cf_point_law(pts, P, k + l, S, pts->hint + k + l, t)) {
            cf_simd_sums_add(V, t, need);
        }
    }
}
#endif

#endif
