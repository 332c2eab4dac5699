/*
 * connector_elastoplastic.c -- the elastoplastic shear law of a connector (a metal dowel: titanium),
 * an entry of the registry of connector laws (solver_connector_law.c; the common text: connector_law.h).
 *
 *   F = -k (u - p), |F| <= F_y: elastic-perfectly plastic in the joint plane; beyond F_y the plastic
 *   offset p moves along the trial force until |F| = F_y (radial return), so after yielding the dowel
 *   unloads elastically about p. Its state: p = (w[0], w[1]). No values of its own.
 */
#include <math.h>

#include "solver_internal.h"

static int shear(const cf_solver_connector *d, cf_connector_state *st, double ux, double uy, double *fx, double *fy,
                 double *v)
{
    double k = d->k_shear;
    double tx = -k * (ux - st->w[0]), ty = -k * (uy - st->w[1]), m = sqrt(tx * tx + ty * ty);
    int plastic = m > d->f_yield;
    if (plastic) {
        double sc = d->f_yield / m;
        tx = tx * sc; ty = ty * sc;
        st->w[0] = ux + tx / k; st->w[1] = uy + ty / k;
        st->yielded = 1;
    }
    *fx = tx; *fy = ty;
    *v = (tx * tx + ty * ty) / (2.0 * k);
    return plastic;
}

static double u_yield(const cf_solver_connector *d)
{
    return d->f_yield / d->k_shear;
}

const cf_connector_law cf_connector_elastoplastic_law = {
    "elastoplastic",
    "elastic-perfectly plastic in the joint plane (a metal dowel): F = -k (u - p), |F| <= f_yield, the plastic "
    "offset p moving by radial return; breaks at u_ultimate",
    NULL, 0, NULL, NULL, shear, u_yield,
};
