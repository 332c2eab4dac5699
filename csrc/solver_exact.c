/*
 * solver_exact.c -- contact model "exact": the limit of infinitely many contact points.
 * The normal pressure kn * overlap is integrated exactly over the compressed part of
 * the overlap polygon of the two faces (cf_contact_exact, contact.c); shear and
 * torsion are joint-level springs (see joint_exact); the shear follows the contact
 * law of contact_law.h, kept in the lower face's frame like every point's.
 */
#include <math.h>
#include <stddef.h>

#include "contact.h"
#include "contact_law.h"
#include "solver_internal.h"
#include "solver_math_internal.h"

static inline void apply_pair(cf_solver *s, int bl, int bu, const double *p, const double *Fw)
{
    double r[3], tq[3];
    double *F = s->F, *T = s->T;
    F[3 * bu] += Fw[0]; F[3 * bu + 1] += Fw[1]; F[3 * bu + 2] += Fw[2];
    r[0] = p[0] - s->x[3 * bu]; r[1] = p[1] - s->x[3 * bu + 1]; r[2] = p[2] - s->x[3 * bu + 2];
    v3_cross(r, Fw, tq);
    T[3 * bu] += tq[0]; T[3 * bu + 1] += tq[1]; T[3 * bu + 2] += tq[2];
    if (bl != 0) {
        F[3 * bl] -= Fw[0]; F[3 * bl + 1] -= Fw[1]; F[3 * bl + 2] -= Fw[2];
        r[0] = p[0] - s->x[3 * bl]; r[1] = p[1] - s->x[3 * bl + 1]; r[2] = p[2] - s->x[3 * bl + 2];
        v3_cross(r, Fw, tq);
        T[3 * bl] -= tq[0]; T[3 * bl + 1] -= tq[1]; T[3 * bl + 2] -= tq[2];
    }
}

/* relative velocity of body bu w.r.t. bl at world point p; wwl, wwu: world omegas */
static inline void rel_vel(const cf_solver *s, int bl, int bu, const double *wwl, const double *wwu,
                           const double *p, double *vr)
{
    double r[3], c[3];
    r[0] = p[0] - s->x[3 * bu]; r[1] = p[1] - s->x[3 * bu + 1]; r[2] = p[2] - s->x[3 * bu + 2];
    v3_cross(wwu, r, c);
    vr[0] = s->v[3 * bu] + c[0]; vr[1] = s->v[3 * bu + 1] + c[1]; vr[2] = s->v[3 * bu + 2] + c[2];
    if (bl != 0) {
        r[0] = p[0] - s->x[3 * bl]; r[1] = p[1] - s->x[3 * bl + 1]; r[2] = p[2] - s->x[3 * bl + 2];
        v3_cross(wwl, r, c);
        vr[0] -= s->v[3 * bl] + c[0]; vr[1] -= s->v[3 * bl + 1] + c[1]; vr[2] -= s->v[3 * bl + 2] + c[2];
    }
}

/* Exact interface: normal pressure integrated over the compressed overlap polygon;
 * shear as one joint-level incremental spring acting at the centre of the lower
 * face (so that its lever arms, hence the stability limit, do not change as the
 * centre of pressure moves to a rocking toe), capped by mu N; torsion as an incremental spring about the joint normal, capped by
 * mu N (2/3) r_eq (uniform pressure on a disc of the compressed area). The shear and
 * torsional stiffnesses are those of the whole joint face (ks A, ks J_polar): with a
 * stiffness that followed the compressed area the stored force would carry an energy
 * that jumps without work as the joint opens; the cap mu N governs an open joint. */
static void joint_exact(cf_solver *s, cf_joint *J, const double *ww, double dt, cf_step_energy *e)
{
    int bl = J->bl, bu = J->bu, k, sl, nv;
    const double *RL = s->R + 9 * bl, *RU = s->R + 9 * bu;
    double cL[3], nL[3], cU[3], nU[3], up[2 * CF_MAXS], m[3], X0[3], d[3];
    double p0, px, py, fn, kn = J->kn, ks = J->ks, mu = J->mu;
    cf_contact_exact_result r;
    s->jfn[J - s->jt] = 0.0;
    cf_face_world(s, bl, &J->fl, cL, nL);
    cf_face_world(s, bu, &J->fu, cU, nU);
    mat_tvec(RL, nU, m);
    d[0] = cU[0] - cL[0]; d[1] = cU[1] - cL[1]; d[2] = cU[2] - cL[2];
    mat_tvec(RL, d, X0);
    nv = 0;
    if (m[2] > 0.1) {
        for (k = 0; k < J->fu.n; k++) {
            double loc[3], pw[3], X[3];
            loc[0] = J->fu.c[0] + J->fu.vx[k]; loc[1] = J->fu.c[1] + J->fu.vy[k]; loc[2] = J->fu.c[2];
            mat_vec(RU, loc, pw);
            pw[0] += s->x[3 * bu] - cL[0]; pw[1] += s->x[3 * bu + 1] - cL[1]; pw[2] += s->x[3 * bu + 2] - cL[2];
            mat_tvec(RL, pw, X);
            up[2 * k] = X[0]; up[2 * k + 1] = X[1];
        }
        px = m[0] / m[2]; py = m[1] / m[2];
        p0 = -X0[2] - px * X0[0] - py * X0[1];
        /* as for sub-contacts: a face sunk deeper than a tenth of its radius has passed
         * beside or through the other one (tumbling blocks after a collapse) */
        for (k = 0; k < J->fu.n; k++)
            if (p0 + px * up[2 * k] + py * up[2 * k + 1] > 0.1 * J->fl.rc) m[2] = -1.0;
        /* the ground is unbounded: the overlap is the upper face itself */
        if (m[2] <= 0.0) nv = 0;
        else if (bl == 0) nv = cf_contact_exact(up, J->fu.n, up, J->fu.n, p0, px, py, kn, &r);
        else nv = cf_contact_exact(J->fl.poly, J->fl.n, up, J->fu.n, p0, px, py, kn, &r);
    }
    if (nv == 0 || !(r.force > 0.0)) {
        /* released: stored shear and torsion energy counted as dissipated */
        e->dslip += cf_law_release(&J->fs[0], &J->fs[1], 0.5 / (ks * J->area));
        if (J->mt != 0.0) {
            e->dslip += 0.5 * J->mt * J->mt / (ks * J->polar);
            J->mt = 0.0;
        }
        return;
    }
    {
        double P[3], loc[3], du[3], duf[3], fsf[3], Fs[3], Fw[3], pen_eq, wr, mt_trial, lim, kt, req;
        loc[0] = r.xc; loc[1] = r.yc; loc[2] = 0.0;
        mat_vec(RL, loc, P);
        P[0] += cL[0]; P[1] += cL[1]; P[2] += cL[2];
        rel_vel(s, bl, bu, ww + 3 * bl, ww + 3 * bu, cL, du);
        du[0] *= dt; du[1] *= dt; du[2] *= dt;
        /* the joint as one contact of contact_law.h in the lower face's frame: the
         * equivalent uniform overlap carries the integrated normal force */
        mat_tvec(RL, du, duf);
        pen_eq = r.force / (kn * J->area);
        e->dslip += cf_law_update(pen_eq, duf[0], duf[1], kn * J->area, ks * J->area, mu, J->fs, &fn, &sl);
        s->jfn[J - s->jt] = fn;
        Fw[0] = fn * nL[0]; Fw[1] = fn * nL[1]; Fw[2] = fn * nL[2];
        apply_pair(s, bl, bu, P, Fw);
        fsf[0] = J->fs[0]; fsf[1] = J->fs[1]; fsf[2] = 0.0;
        mat_vec(RL, fsf, Fs);
        apply_pair(s, bl, bu, cL, Fs);
        /* torsion about the joint normal */
        kt = ks * J->polar;
        wr = v3_dot(ww + 3 * bu, nL) - (bl ? v3_dot(ww + 3 * bl, nL) : 0.0);
        mt_trial = J->mt - kt * wr * dt;
        req = sqrt(r.area / CF_PI);
        lim = mu * fn * (2.0 / 3.0) * req;
        if (fabs(mt_trial) > lim) {
            double capped = mt_trial > 0 ? lim : -lim;
            /* trapezoidal work on the torsional spring minus its elastic energy change */
            e->dslip += -0.5 * (J->mt + capped) * wr * dt - 0.5 * (capped * capped - J->mt * J->mt) / kt;
            mt_trial = capped;
        }
        J->mt = mt_trial;
        s->T[3 * bu] += J->mt * nL[0]; s->T[3 * bu + 1] += J->mt * nL[1]; s->T[3 * bu + 2] += J->mt * nL[2];
        if (bl) { s->T[3 * bl] -= J->mt * nL[0]; s->T[3 * bl + 1] -= J->mt * nL[1]; s->T[3 * bl + 2] -= J->mt * nL[2]; }
        e->vs += r.energy + 0.5 * (J->fs[0] * J->fs[0] + J->fs[1] * J->fs[1]) / (ks * J->area)
               + 0.5 * J->mt * J->mt / kt;
    }
}

/* The joints' shear force and torsional moment at the start of a run: none. */
static void exact_reset(cf_solver *s)
{
    int j;
    for (j = 0; j < s->nj; j++) { s->jt[j].fs[0] = s->jt[j].fs[1] = 0; s->jt[j].mt = 0; }
}

/* For the stability limit: the face integral by the edge-midpoint rule on the fan
 * triangles (exact for the quadratic integrands of the stiffness). */
static void exact_stiffness(const cf_solver *s, const cf_joint *J, struct cf_stiffness *K)
{
    const cf_face *f = &J->fu;
    double wq = J->area / f->n / 3.0;
    int k, t;
    for (k = 0; k < f->n; k++) {
        int k1 = (k + 1) % f->n;
        double mids[3][2];
        mids[0][0] = 0.5 * f->vx[k]; mids[0][1] = 0.5 * f->vy[k];
        mids[1][0] = 0.5 * f->vx[k1]; mids[1][1] = 0.5 * f->vy[k1];
        mids[2][0] = 0.5 * (f->vx[k] + f->vx[k1]); mids[2][1] = 0.5 * (f->vy[k] + f->vy[k1]);
        for (t = 0; t < 3; t++) {
            double p[3];
            p[0] = s->x0[3 * J->bu] + f->c[0] + mids[t][0];
            p[1] = s->x0[3 * J->bu + 1] + f->c[1] + mids[t][1];
            p[2] = s->x0[3 * J->bu + 2] + f->c[2];
            cf_solver_timestep_add_contact(s, K, J, p, wq);
        }
    }
}

/* No set-up of its own (the joints' polygons and polar moments are the stack's); run one
 * after the other by the batch (its work is the polygon clipping of contact.c). */
const cf_solver_contact_model cf_solver_exact_model = {
    "exact",
    "Exact interface: kn * overlap integrated over the compressed part of the face overlap "
    "polygon; one joint-level shear spring with the law of contact_law.h and a torsional "
    "spring, both capped by Coulomb friction.",
    NULL, exact_reset, exact_stiffness, joint_exact, NULL, 0,
};
