/*
 * solver_as_built.c -- a joint of a column placed as built (docs/sequences.md, "As-built geometry:
 * offset and turned drums"): the stack (solver_stack.c) places each block's axis at its offset and
 * turns its faces by its rotation; a joint whose two faces are then offset or turned against each
 * other gets here its contact region, the overlap of its faces at rest, which the contact models
 * carry (solver_face_points.c: the points on it; solver_exact.c: its shear point, polar moment and
 * stiffness; the exact overlap of a step is computed from the bodies' poses anyway); a chipped joint its
 * annulus, less a missing sector (its chain, convex pieces and moments). Set-up only.
 */
#include <math.h>

#include "cf_math.h"
#include "contact.h"
#include "solver_internal.h"

int cf_solver_as_built_joint(cf_solver *s, cf_joint *J, double dx, double dy)
{
    double up[2 * CF_MAXS], out[4 * CF_MAXS], work[8 * CF_MAXS], m[6];
    int k, n;
    for (k = 0; k < J->fu.n; k++) { up[2 * k] = J->fu.vx[k] + dx; up[2 * k + 1] = J->fu.vy[k] + dy; }
    n = cf_contact_clip_convex(J->fl.poly, J->fl.n, up, J->fu.n, out, work);
    {
        /* a vertex of one face on an edge of the other comes out twice: once is enough */
        int c = 0;
        double tol = 1e-12 * J->fl.rc;
        for (k = 0; k < n; k++) {
            const double *q = c > 0 ? out + 2 * (c - 1) : out + 2 * (n - 1);
            if (n > 1 && fabs(out[2 * k] - q[0]) <= tol && fabs(out[2 * k + 1] - q[1]) <= tol) continue;
            out[2 * c] = out[2 * k]; out[2 * c + 1] = out[2 * k + 1]; c++;
        }
        n = c;
    }
    if (n >= 3) cf_contact_polygon_moments(out, n, m);
    if (n < 3 || !(m[0] > 1e-12 * J->fl.area))
        return cf_solver_fail(s, CF_EINVAL, "joint %d: its faces do not overlap (the upper face's centre at "
                              "(%g, %g) m from the lower one's)", J->logical, dx, dy);
    J->asb = 1; J->cn = n;
    J->d0[0] = dx; J->d0[1] = dy;
    for (k = 0; k < 2 * n; k++) J->cpoly[k] = out[k];
    J->area = m[0];
    J->ccen[0] = m[1] / m[0]; J->ccen[1] = m[2] / m[0];
    J->cpolar = m[3] + m[5] - m[0] * (J->ccen[0] * J->ccen[0] + J->ccen[1] * J->ccen[1]);
    return CF_OK;
}

/* Where the ray from the centre of face f (its polygon scaled by sc) at angle a leaves it: the point into q, the
 * edge k (from vertex k to k + 1) returned; the ray through vertex k leaves on edge k. */
static int ray_exit(const cf_face *f, double sc, double a, double *q)
{
    double dx = cf_math_cos(a), dy = cf_math_sin(a);
    int k;
    for (k = 0; k < f->n; k++) {
        int k1 = k + 1 == f->n ? 0 : k + 1;
        double ca = dx * f->vy[k] - dy * f->vx[k], cb = dx * f->vy[k1] - dy * f->vx[k1];
        if (ca <= 0.0 && cb > 0.0) {
            double u = ca / (ca - cb);
            q[0] = sc * (f->vx[k] + u * (f->vx[k1] - f->vx[k])); q[1] = sc * (f->vy[k] + u * (f->vy[k1] - f->vy[k]));
            return k;
        }
    }
    q[0] = q[1] = 0.0;   /* not reached: the centre lies inside its own polygon */
    return 0;
}

/* The boundary of face f (scaled by sc) from angle a0 counter-clockwise over the angle w (0 < w < 2 pi): where
 * the ray at a0 leaves it, the vertices passed, where the ray at a0 + w leaves it (a point given twice kept
 * once) into out; returns the count (at most n + 2). */
static int chain(const cf_face *f, double sc, double a0, double w, double *out)
{
    double p1[2], tol = 1e-12 * f->rc;
    int k0 = ray_exit(f, sc, a0, out), k1 = ray_exit(f, sc, a0 + w, p1), n = 1, c, cnt;
    cnt = ((k1 - k0) % f->n + f->n) % f->n;
    if (k0 == k1 && w > CF_PI) cnt = f->n;   /* both rays leave by one side, the long way round */
    for (c = 1; c <= cnt + 1; c++) {
        int v = (k0 + c) % f->n;
        double x = c <= cnt ? sc * f->vx[v] : p1[0], y = c <= cnt ? sc * f->vy[v] : p1[1];
        if (fabs(x - out[2 * (n - 1)]) <= tol && fabs(y - out[2 * (n - 1) + 1]) <= tol) continue;
        out[2 * n] = x; out[2 * n + 1] = y; n++;
    }
    return n;
}

/* Joint J's chipped region less the sector [s0, s1) (rad): its open chain (cpoly, cn), its convex pieces
 * (csp, csn), area, centroid and polar moment (the pieces' moments less the hole's, scaled by chole). */
static int sector(cf_solver *s, cf_joint *J, double s0, double s1)
{
    const double tp = 2.0 * CF_PI;
    double w = s1 - s0, m[6], M[6] = {0, 0, 0, 0, 0, 0}, h = J->chole;
    int i, k;
    w -= tp * floor(w / tp);
    if (!(w > 0.0 && w < tp))
        return cf_solver_fail(s, CF_EINVAL, "joint %d: its chipped face's missing sector [%g, %g) deg is empty or "
                              "the whole face", J->logical, s0 * 180.0 / CF_PI, s1 * 180.0 / CF_PI);
    w = tp - w;   /* what bears: from s1 round to s0 */
    J->csec = 1;
    J->cn = chain(&J->fu, J->cout, s1, w, J->cpoly);
    for (i = 0; i < 2; i++) {
        double *p = J->csp[i];
        J->csn[i] = 0;
        if (i == 1 && w <= CF_PI) break;
        p[0] = p[1] = 0.0;
        J->csn[i] = 1 + chain(&J->fu, J->cout, s1 + (w > CF_PI ? 0.5 * w * i : 0.0), w > CF_PI ? 0.5 * w : w, p + 2);
        cf_contact_polygon_moments(p, J->csn[i], m);
        for (k = 0; k < 6; k++) M[k] += m[k] * (1.0 - (k == 0 ? h * h : k < 3 ? h * h * h : (h * h) * (h * h)));
        /* the hole's share: area ~ h^2, first moments ~ h^3, second ~ h^4 (products, not libm's pow:
         * the same bits on every CPU, docs/reproducibility.md) */
    }
    if (!(M[0] > 1e-12 * J->fu.area))
        return cf_solver_fail(s, CF_EINVAL, "joint %d: its chipped face less its missing sector bears on no area",
                              J->logical);
    J->area = M[0];
    J->ccen[0] = M[1] / M[0]; J->ccen[1] = M[2] / M[0];
    J->cpolar = M[3] + M[5] - M[0] * (J->ccen[0] * J->ccen[0] + J->ccen[1] * J->ccen[1]);
    return CF_OK;
}

double cf_solver_as_built_reach(const cf_joint *J)
{
    double xp = J->chole > 0.0 ? J->chole * J->cpoly[0] : 0.0;
    int k;
    for (k = 0; k < J->cn; k++) {
        if (J->cpoly[2 * k] > xp) xp = J->cpoly[2 * k];
        if (J->chole > 0.0 && J->chole * J->cpoly[2 * k] > xp) xp = J->chole * J->cpoly[2 * k];
    }
    return xp;
}

int cf_solver_as_built_chipped(cf_solver *s, cf_joint *J, double inner, double outer, double s0, double s1)
{
    const cf_face *f = &J->fu;
    double m[6], sc = outer / f->rc;
    int k;
    if (!(inner >= 0.0 && outer > inner && outer <= f->rc))
        return cf_solver_fail(s, CF_EINVAL, "joint %d: its chipped face bears on no area or beyond the face: inner "
                              "radius %g m, outer %g m (the face's circumradius %g m)", J->logical, inner, outer, f->rc);
    for (k = 0; k < f->n; k++) {
        J->cpoly[2 * k] = sc * f->vx[k]; J->cpoly[2 * k + 1] = sc * f->vy[k];
        /* on the face below (the ground is unbounded) */
        if (J->bl != 0 && !cf_face_inside(&J->fl, J->cpoly[2 * k], J->cpoly[2 * k + 1], 1e-9 * J->fl.rc))
            return cf_solver_fail(s, CF_EINVAL, "joint %d: its chipped face (outer radius %g m) reaches beyond the "
                                  "face below it", J->logical, outer);
    }
    cf_contact_polygon_moments(J->cpoly, f->n, m);
    J->asb = 1; J->cn = f->n;
    J->d0[0] = J->d0[1] = 0.0;
    J->ccen[0] = J->ccen[1] = 0.0;
    J->chole = inner / outer; J->cout = sc;
    J->area = m[0] * (1.0 - J->chole * J->chole);
    J->cpolar = (m[3] + m[5]) * (1.0 - J->chole * J->chole * J->chole * J->chole);
    return s0 != 0.0 || s1 != 0.0 ? sector(s, J, s0, s1) : CF_OK;
}
