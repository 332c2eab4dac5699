/*
 * contact_internal.h -- the sub-contact law as a static inline kernel, shared by
 * cf_contact_point (contact.c, unit-tested) and the solver's hot loop (solver.c),
 * so the tested code and the running code are the same text.
 */
#ifndef CF_CONTACT_INTERNAL_H
#define CF_CONTACT_INTERNAL_H
#include <math.h>

static inline double contact_point_law(double pen, const double *n, const double *du, double w, double kn,
                                       double ks, double mu, double *fs, double *fn, int *slipping)
{
    double f, old2, fsn, dun, lim, m2, kw = ks * w, diss = 0.0, f0[3], dt3[3];
    *slipping = 0;
    if (!(pen > 0.0)) {
        old2 = fs[0] * fs[0] + fs[1] * fs[1] + fs[2] * fs[2];
        *fn = 0.0;
        fs[0] = fs[1] = fs[2] = 0.0;
        return old2 > 0.0 ? 0.5 * old2 / kw : 0.0;
    }
    f = kn * w * pen;
    *fn = f;
    /* turn the stored shear force into the current tangent plane, keeping |fs| */
    fsn = fs[0] * n[0] + fs[1] * n[1] + fs[2] * n[2];
    old2 = fs[0] * fs[0] + fs[1] * fs[1] + fs[2] * fs[2];
    if (fsn != 0.0) {
        double new2;
        fs[0] -= fsn * n[0]; fs[1] -= fsn * n[1]; fs[2] -= fsn * n[2];
        new2 = fs[0] * fs[0] + fs[1] * fs[1] + fs[2] * fs[2];
        if (new2 > 0.0) {
            double s = sqrt(old2 / new2);
            fs[0] *= s; fs[1] *= s; fs[2] *= s;
        }
    }
    f0[0] = fs[0]; f0[1] = fs[1]; f0[2] = fs[2];
    /* elastic increment with the tangential part of du */
    dun = du[0] * n[0] + du[1] * n[1] + du[2] * n[2];
    dt3[0] = du[0] - dun * n[0]; dt3[1] = du[1] - dun * n[1]; dt3[2] = du[2] - dun * n[2];
    fs[0] -= kw * dt3[0]; fs[1] -= kw * dt3[1]; fs[2] -= kw * dt3[2];
    /* Coulomb cap */
    lim = mu * f;
    m2 = fs[0] * fs[0] + fs[1] * fs[1] + fs[2] * fs[2];
    if (m2 > lim * lim) {
        double s = lim / sqrt(m2), new2;
        fs[0] *= s; fs[1] *= s; fs[2] *= s;
        *slipping = 1;
        /* dissipated = work done on the contact over the increment (trapezoidal, the
         * rule the leapfrog integrator conserves exactly) minus the change of the
         * elastic shear energy |fs|^2 / (2 ks w); zero for an elastic update */
        new2 = fs[0] * fs[0] + fs[1] * fs[1] + fs[2] * fs[2];
        diss = -0.5 * ((f0[0] + fs[0]) * dt3[0] + (f0[1] + fs[1]) * dt3[1] + (f0[2] + fs[2]) * dt3[2])
               - 0.5 * (new2 - old2) / kw;
    }
    return diss;
}

#endif
