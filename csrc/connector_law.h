/*
 * connector_law.h -- THE law of a connector (a dowel across a joint), written once: the solver's
 * connectors (solver_connectors.c) and the driver of a prescribed displacement history
 * (cf_solver_connectors_drive, how the tests reach the law) run this text. Its kinds of shear law are
 * a registry (solver_connector_law.c), each kind its own file defining its cf_connector_law entry; a
 * new kind is its file and one line there.
 *
 * A connector joins the two blocks of a joint at one point of the joint plane. Its deformation is
 * the displacement u of its upper end relative to its lower end since the rest state, in the lower
 * face's frame: (ux, uy) shear in the joint plane, uz the opening of the joint there (> 0 apart).
 * The force F it puts on the upper block (the opposite on the lower one) is, in the same frame:
 *
 * shear, one of the registry's kinds (today's two: connector_elastoplastic.c, connector_clearance.c):
 *   ELASTOPLASTIC (a metal dowel: titanium)  F = -k (u - p), |F| <= F_y: elastic-perfectly plastic
 *       in the joint plane; beyond F_y the plastic offset p moves along the trial force until
 *       |F| = F_y (radial return), so after yielding the dowel unloads elastically about p;
 *   CLEARANCE (a wooden empolion and polos in their sockets)  F = -k (|u| - c)+ u / |u|: nothing
 *       inside the clearance c, linear beyond it; where k (|u| - c) would exceed F_y the seat
 *       crushes: c grows to |u| - F_y / k (the slack a crushed timber seat leaves, in every
 *       direction alike);
 *   both break when |u| reaches u_ult (measured from the rest state, clearance included): from
 *   then on the connector carries nothing, in shear or axially;
 * axial, in tension only (the connector resists the joint's opening; compression is the joint's):
 *   Fz = -ka (uz - a)+, capped at N_y by a growing slack a (pull-out slip), and breaking the
 *   connector when uz reaches d_ult.
 * The clearance kind's shear and the axial law are one spring beyond a growing slack
 * (cf_connector_slack_spring), each on its own displacement, stiffness, cap and slack.
 *
 * Energy: stored V = |Fs|^2 / (2 k) + Fz^2 / (2 ka) (|Fs| = k (|u| - c)+ for the clearance kind);
 * an inelastic step (yield, crushing, axial slip, break) dissipates the trapezoidal work the
 * connector takes over the step minus the change of V -- the rule of the contact law
 * (contact_law.h), which the leapfrog integrator conserves exactly -- and an elastic step nothing.
 * A break dissipates the energy stored at that moment.
 */
#ifndef CF_CONNECTOR_LAW_H
#define CF_CONNECTOR_LAW_H

#include <math.h>

#include "solver.h"

/* The per-run state of one connector, from the rest state (all zero but the law's own) on. */
typedef struct {
    double w[3];        /* the shear law's own state (the elastoplastic law: its plastic offset w[0], w[1], m;
                         * the clearance law: its clearance now, w[2], m), kept in a carried-over state */
    double a;           /* axial slack (pull-out slip), m */
    double u[3];        /* displacement at the last step, m */
    double f[3];        /* force on the upper block at the last step (lower face frame), N */
    double v;           /* energy stored at the last step, J */
    int yielded;        /* 1 once it yielded, crushed its seat or slipped axially */
    int broken;         /* 1 once it broke (shear or axial ultimate reached) */
} cf_connector_state;

/* A kind of shear law: the registry's entry (solver_connector_law.c), defined in the law's own file
 * (connector_elastoplastic.c, connector_clearance.c). */
typedef struct cf_connector_law {
    const char *name;
    const char *doc;                 /* one sentence, exported (cf_solver_connector_law_doc) */
    const cf_solver_option *values;  /* its own values (cf_solver_connector.law[k]), declared as data */
    int n_values;
    /* its own checks of d (beyond the common values'), the message into msg (CF_MSG_LEN); NULL: none */
    int (*check)(const cf_solver_connector *d, char *msg);
    /* its own state at rest (st->w, which comes zeroed); NULL: all zero */
    void (*rest)(const cf_solver_connector *d, cf_connector_state *st);
    /* the shear force (fx, fy) and its stored energy at shear displacement (ux, uy) (k_shear > 0;
     * fx, fy, v come zeroed); updates its state where it yields; returns 1 on an inelastic step */
    int (*shear)(const cf_solver_connector *d, cf_connector_state *st, double ux, double uy, double *fx,
                 double *fy, double *v);
    /* the shear displacement |u| at which it yields, m (k_shear > 0) */
    double (*u_yield)(const cf_solver_connector *d);
} cf_connector_law;

/* the registry (solver_connector_law.c): cf_solver_connector_law_table[d->kind], kind checked at set-up */
extern const cf_connector_law *const cf_solver_connector_law_table[];

/* The state at rest: no force, no slack beyond the law's own. */
static inline void cf_connector_rest(const cf_solver_connector *d, cf_connector_state *st)
{
    const cf_connector_law *law = cf_solver_connector_law_table[d->kind];
    st->w[0] = st->w[1] = st->w[2] = 0.0;
    if (law->rest) law->rest(d, st);
    st->a = 0.0;
    st->u[0] = st->u[1] = st->u[2] = 0.0;
    st->f[0] = st->f[1] = st->f[2] = 0.0;
    st->v = 0.0;
    st->yielded = st->broken = 0;
}

/* The one text of a spring of stiffness k beyond a slack s that grows to cap its force at f_cap: the
 * clearance kind's shear (s the clearance, growing as the seat crushes) and the axial law (s the
 * pull-out slip). At displacement u (>= 0, along the force): the force's magnitude into *n and its
 * stored energy into *v, the slack grown and *yielded set on a capped step; returns 1 on a capped
 * step, 0 on an elastic one, -1 inside the slack (no force; *n and *v untouched). */
static inline int cf_connector_slack_spring(double k, double f_cap, double u, double *s, int *yielded, double *n,
                                            double *v)
{
    double e = u - *s;
    int plastic;
    if (!(e > 0.0)) return -1;
    *n = k * e;
    plastic = *n > f_cap;
    if (plastic) {
        *s = u - f_cap / k;
        *n = f_cap;
        *yielded = 1;
    }
    *v = *n * *n / (2.0 * k);
    return plastic;
}

/* The shear force (fx, fy) and its stored energy at shear displacement (ux, uy): the law's own; returns
 * 1 on an inelastic step. */
static inline int cf_connector_shear(const cf_solver_connector *d, cf_connector_state *st, double ux, double uy,
                                     double *fx, double *fy, double *v)
{
    *fx = 0.0; *fy = 0.0; *v = 0.0;
    if (!(d->k_shear > 0.0)) return 0;
    return cf_solver_connector_law_table[d->kind]->shear(d, st, ux, uy, fx, fy, v);
}

/* The axial force at opening uz (tension only) and its stored energy; returns 1 on a slip step. */
static inline int cf_connector_axial(const cf_solver_connector *d, cf_connector_state *st, double uz, double *fz,
                                     double *v)
{
    double ka = d->k_axial, n;
    int plastic;
    *fz = 0.0; *v = 0.0;
    if (!(ka > 0.0)) return 0;
    plastic = cf_connector_slack_spring(ka, d->n_yield, uz, &st->a, &st->yielded, &n, v);
    if (plastic < 0) return 0;
    *fz = -n;
    return plastic;
}

/* One step of the law at displacement u[3] (m): the force on the upper block into st->f, the stored
 * energy into st->v; returns the energy dissipated over the step, J (0 on an elastic step). */
static inline double cf_connector_update(const cf_solver_connector *d, cf_connector_state *st, const double *u)
{
    double f[3] = {0.0, 0.0, 0.0}, v = 0.0, vs, va, diss = 0.0;
    int inelastic = 0, k;
    if (!st->broken) {
        double um2 = u[0] * u[0] + u[1] * u[1];
        if (um2 >= d->u_ultimate * d->u_ultimate || (d->k_axial > 0.0 && u[2] >= d->d_ultimate)) {
            st->broken = 1;    /* the force drops to nothing at this step */
            inelastic = 1;
        } else {
            inelastic |= cf_connector_shear(d, st, u[0], u[1], f, f + 1, &vs);
            inelastic |= cf_connector_axial(d, st, u[2], f + 2, &va);
            v = vs + va;
        }
    }
    if (inelastic)
        diss = -0.5 * ((st->f[0] + f[0]) * (u[0] - st->u[0]) + (st->f[1] + f[1]) * (u[1] - st->u[1])
                       + (st->f[2] + f[2]) * (u[2] - st->u[2])) - (v - st->v);
    for (k = 0; k < 3; k++) { st->u[k] = u[k]; st->f[k] = f[k]; }
    st->v = v;
    return diss;
}

#endif
