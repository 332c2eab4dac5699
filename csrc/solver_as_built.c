/*
 * solver_as_built.c -- a joint of a column placed as built (docs/sequences.md, "As-built geometry:
 * offset and turned drums"): the stack (solver_stack.c) places each block's axis at its offset and
 * turns its faces by its rotation; a joint whose two faces are then offset or turned against each
 * other gets here its contact region, the overlap of its faces at rest, which the contact models
 * carry (solver_face_points.c: the points on it; solver_exact.c: its shear point, polar moment and
 * stiffness; the exact overlap of a step is computed from the bodies' poses anyway). Set-up only.
 */
#include <math.h>

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

int cf_solver_as_built_chipped(cf_solver *s, cf_joint *J, double inner, double outer)
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
    return CF_OK;
}
