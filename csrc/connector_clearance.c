/*
 * connector_clearance.c -- the clearance shear law of a connector (a wooden empolion and polos in their
 * sockets), an entry of the registry of connector laws (solver_connector_law.c; the common text:
 * connector_law.h).
 *
 *   F = -k (|u| - c)+ u / |u|: nothing inside the clearance c, linear beyond it; where k (|u| - c)
 *   would exceed F_y the seat crushes: c grows to |u| - F_y / k (the slack a crushed timber seat
 *   leaves, in every direction alike). The spring beyond a growing slack is the axial law's own
 *   text (cf_connector_slack_spring). Its value: the initial clearance (law[0], m); its state: the
 *   clearance now (w[2]).
 */
#include <math.h>

#include "solver_internal.h"

static const cf_solver_option values[] = {
    {"clearance", CF_SOLVER_OPTION_REAL, 0.0, INFINITY, 0, 1, 0.0, "m",
     "the initial clearance: no force while |u| is inside it (grows as the seat crushes); below u_ultimate"},
};

static int check(const cf_solver_connector *d, char *msg)
{
    double c = d->law[0];
    if (!(c >= 0.0) || !isfinite(c))
        return cf_common_fail(msg, CF_EINVAL, "connector clearance must be finite and >= 0 m, got %g", c);
    if (!(c < d->u_ultimate))
        return cf_common_fail(msg, CF_EINVAL, "connector clearance %g m must be below u_ultimate %g m", c,
                              d->u_ultimate);
    return CF_OK;
}

static void rest(const cf_solver_connector *d, cf_connector_state *st)
{
    st->w[2] = d->law[0];
}

static int shear(const cf_solver_connector *d, cf_connector_state *st, double ux, double uy, double *fx, double *fy,
                 double *v)
{
    double um = sqrt(ux * ux + uy * uy), fm;
    int plastic = cf_connector_slack_spring(d->k_shear, d->f_yield, um, &st->w[2], &st->yielded, &fm, v);
    if (plastic < 0) return 0;
    *fx = -fm * ux / um; *fy = -fm * uy / um;
    return plastic;
}

static double u_yield(const cf_solver_connector *d)
{
    return d->f_yield / d->k_shear + d->law[0];
}

const cf_connector_law cf_connector_clearance_law = {
    "clearance",
    "a clearance, then linear (a wooden empolion and polos): F = -k (|u| - c)+, the seat crushing (c growing) "
    "at f_yield; breaks at u_ultimate, clearance included",
    values, (int)(sizeof values / sizeof values[0]), check, rest, shear, u_yield,
};
