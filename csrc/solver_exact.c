/*
 * solver_exact.c -- contact model "exact": the limit of infinitely many contact points.
 * The normal pressure kn * overlap is integrated exactly over the compressed part of
 * the overlap polygon of the two faces (cf_contact_exact, contact.c); shear and
 * torsion are joint-level springs (see joint_exact); the shear follows the contact
 * law of contact_law.h, kept in the lower face's frame like every point's.
 */
#include <math.h>
#include <stddef.h>
#include <stdlib.h>
#include <string.h>

#include "cf_math.h"
#include "contact.h"
#include "contact_law.h"
#include "solver_internal.h"
#include "solver_math_internal.h"

/* The model's own state, one entry per joint: the joint-level shear force (N, lower face frame)
 * and torsional moment (N m) carried from step to step, and the polar moment of the joint area
 * about its centre (m^4; fixed at set-up). */
typedef struct {
    double fs[2], mt;
    double polar;
} exact_joint;

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

/* A chipped joint (solver_as_built.c): the upper face (up, its vertices in the lower face's frame) bears on
 * the annulus between its polygon scaled by cout and by cout * chole (0: no hole) about its centre; the pressure being
 * linear, the annulus's integrals are the outer polygon's less the inner one's (each clipped by the lower
 * face, or on the ground unbounded). Returns the outer region's vertex count, 0 when nothing presses. */
static int exact_annulus(const cf_solver *s, const cf_joint *J, const double *cL, const double *up, double p0,
                         double px, double py, cf_contact_exact_result *r)
{
    const double *RL = s->R + 9 * J->bl, *RU = s->R + 9 * J->bu;
    double uo[2 * CF_MAXS], uh[2 * CF_MAXS], pw[3], uc[3], F, Fh;
    cf_contact_exact_result h;
    int k, n = J->fu.n, nv;
    mat_vec(RU, J->fu.c, pw);
    pw[0] += s->x[3 * J->bu] - cL[0]; pw[1] += s->x[3 * J->bu + 1] - cL[1]; pw[2] += s->x[3 * J->bu + 2] - cL[2];
    mat_tvec(RL, pw, uc);
    for (k = 0; k < n; k++) {
        double dx = up[2 * k] - uc[0], dy = up[2 * k + 1] - uc[1];
        uo[2 * k] = uc[0] + J->cout * dx; uo[2 * k + 1] = uc[1] + J->cout * dy;
        uh[2 * k] = uc[0] + J->cout * J->chole * dx; uh[2 * k + 1] = uc[1] + J->cout * J->chole * dy;
    }
    nv = J->bl == 0 ? cf_contact_exact(uo, n, uo, n, p0, px, py, J->kn, r)
                    : cf_contact_exact(J->fl.poly, J->fl.n, uo, n, p0, px, py, J->kn, r);
    if (nv == 0) return 0;
    if (J->bl == 0) cf_contact_exact(uh, n, uh, n, p0, px, py, J->kn, &h);
    else cf_contact_exact(J->fl.poly, J->fl.n, uh, n, p0, px, py, J->kn, &h);
    F = r->force; Fh = h.force;
    r->force = F - Fh;
    if (!(r->force > 0.0)) return 0;
    r->xc = (F * r->xc - Fh * h.xc) / r->force; r->yc = (F * r->yc - Fh * h.yc) / r->force;
    r->cx = (r->area * r->cx - h.area * h.cx) / (r->area - h.area);
    r->cy = (r->area * r->cy - h.area * h.cy) / (r->area - h.area);
    r->area -= h.area;
    r->energy -= h.energy;
    r->polar = 0.0;   /* not read by the model */
    return nv;
}

/* A chipped joint missing a sector (solver_as_built.c): the upper face bears on its convex pieces (each the
 * face centre and the chain within an angle <= pi), less each scaled by chole about the face centre (the
 * hole); the pressure being linear, the region's integrals are the sum of the pieces' (each clipped by the
 * lower face, or on the ground unbounded). Returns the pieces' vertex count, 0 when nothing presses. */
static int exact_sector(const cf_solver *s, const cf_joint *J, const double *cL, double p0, double px, double py,
                        cf_contact_exact_result *r)
{
    const double *RL = s->R + 9 * J->bl, *RU = s->R + 9 * J->bu;
    double q[2][2 * (CF_MAXS + 3)], F = 0.0, Fx = 0.0, Fy = 0.0, A = 0.0, Ax = 0.0, Ay = 0.0, E = 0.0;
    cf_contact_exact_result a;
    int i, k, e, nv = 0;
    for (i = 0; i < 2 && J->csn[i] > 0; i++) {
        int n = J->csn[i];
        for (e = 0; e < (J->chole > 0.0 ? 2 : 1); e++) {   /* the piece, then its hole */
            double f = e ? J->chole : 1.0, sg = e ? -1.0 : 1.0;
            int m;
            for (k = 0; k < n; k++) {
                double loc[3], pw[3], X[3];
                loc[0] = J->fu.c[0] + f * J->csp[i][2 * k]; loc[1] = J->fu.c[1] + f * J->csp[i][2 * k + 1];
                loc[2] = J->fu.c[2];
                mat_vec(RU, loc, pw);
                pw[0] += s->x[3 * J->bu] - cL[0]; pw[1] += s->x[3 * J->bu + 1] - cL[1]; pw[2] += s->x[3 * J->bu + 2] - cL[2];
                mat_tvec(RL, pw, X);
                q[e][2 * k] = X[0]; q[e][2 * k + 1] = X[1];
            }
            m = J->bl == 0 ? cf_contact_exact(q[e], n, q[e], n, p0, px, py, J->kn, &a)
                           : cf_contact_exact(J->fl.poly, J->fl.n, q[e], n, p0, px, py, J->kn, &a);
            if (m == 0) continue;
            if (!e) nv += m;
            F += sg * a.force; Fx += sg * a.force * a.xc; Fy += sg * a.force * a.yc;
            A += sg * a.area; Ax += sg * a.area * a.cx; Ay += sg * a.area * a.cy;
            E += sg * a.energy;
        }
    }
    memset(r, 0, sizeof *r);
    if (nv == 0 || !(F > 0.0) || !(A > 0.0)) return 0;
    r->force = F; r->xc = Fx / F; r->yc = Fy / F;
    r->area = A; r->cx = Ax / A; r->cy = Ay / A;
    r->energy = E;
    return nv;
}

/* The compressed overlap of joint J's faces at this step (cf_contact_exact: force, centre of
 * pressure, area, energy into r), with the lower face's centre cL and normal nL (world); returns
 * the overlap polygon's vertex count, 0 when the faces do not press on each other. */
static int exact_overlap(const cf_solver *s, const cf_joint *J, double *cL, double *nL, cf_contact_exact_result *r)
{
    int bl = J->bl, bu = J->bu, k;
    const double *RL = s->R + 9 * bl, *RU = s->R + 9 * bu;
    double cU[3], nU[3], up[2 * CF_MAXS], m[3], X0[3], d[3], p0, px, py;
    cf_face_world(s, bl, &J->fl, cL, nL);
    cf_face_world(s, bu, &J->fu, cU, nU);
    mat_tvec(RL, nU, m);
    d[0] = cU[0] - cL[0]; d[1] = cU[1] - cL[1]; d[2] = cU[2] - cL[2];
    mat_tvec(RL, d, X0);
    if (!(m[2] > 0.1)) return 0;
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
        if (p0 + px * up[2 * k] + py * up[2 * k + 1] > 0.1 * J->fl.rc) return 0;
    if (J->csec) return exact_sector(s, J, cL, p0, px, py, r);               /* chipped, missing a sector */
    if (J->cout > 0.0) return exact_annulus(s, J, cL, up, p0, px, py, r);   /* chipped */
    /* the ground is unbounded: the overlap is the upper face itself */
    if (bl == 0) return cf_contact_exact(up, J->fu.n, up, J->fu.n, p0, px, py, J->kn, r);
    return cf_contact_exact(J->fl.poly, J->fl.n, up, J->fu.n, p0, px, py, J->kn, r);
}

/* Exact interface: normal pressure integrated over the compressed overlap polygon;
 * shear as one joint-level incremental spring acting at the centre of the lower
 * face (so that its lever arms, hence the stability limit, do not change as the
 * centre of pressure moves to a rocking toe), capped by mu N; torsion as an incremental spring about the joint normal, capped by
 * mu N (2/3) r_eq (uniform pressure on a disc of the compressed area). The shear and
 * torsional stiffnesses are those of the whole joint face (ks A, ks J_polar): with a
 * stiffness that followed the compressed area the stored force would carry an energy
 * that jumps without work as the joint opens; the cap mu N governs an open joint. */
static void joint_exact(cf_solver *s, void *state, const cf_joint *J, const double *ww, double dt,
                        cf_step_energy *e)
{
    exact_joint *ej = (exact_joint *)state + (J - s->jt);
    int bl = J->bl, bu = J->bu, sl, nv;
    const double *RL = s->R + 9 * bl;
    double cL[3], nL[3], fn, kn = J->kn, ks = J->ks, mu = J->mu;
    cf_contact_exact_result r;
    s->jfn[J - s->jt] = 0.0;
    nv = exact_overlap(s, J, cL, nL, &r);
    if (nv == 0 || !(r.force > 0.0)) {
        /* released: stored shear and torsion energy counted as dissipated */
        e->dslip += cf_law_release(&ej->fs[0], &ej->fs[1], 0.5 / (ks * J->area));
        if (ej->mt != 0.0) {
            e->dslip += 0.5 * ej->mt * ej->mt / (ks * ej->polar);
            ej->mt = 0.0;
        }
        return;
    }
    {
        double P[3], loc[3], du[3], duf[3], fsf[3], Fs[3], Fw[3], pen_eq, wr, mt_trial, lim, kt, req, cS[3];
        loc[0] = r.xc; loc[1] = r.yc; loc[2] = 0.0;
        mat_vec(RL, loc, P);
        P[0] += cL[0]; P[1] += cL[1]; P[2] += cL[2];
        /* the shear spring's point: the lower face's centre, or as built the overlap's centroid at rest */
        cS[0] = cL[0]; cS[1] = cL[1]; cS[2] = cL[2];
        if (J->asb) {
            double oc[3], ow[3];
            oc[0] = J->ccen[0]; oc[1] = J->ccen[1]; oc[2] = 0.0;
            mat_vec(RL, oc, ow);
            cS[0] += ow[0]; cS[1] += ow[1]; cS[2] += ow[2];
        }
        rel_vel(s, bl, bu, ww + 3 * bl, ww + 3 * bu, cS, du);
        du[0] *= dt; du[1] *= dt; du[2] *= dt;
        /* the joint as one contact of contact_law.h in the lower face's frame: the
         * equivalent uniform overlap carries the integrated normal force */
        mat_tvec(RL, du, duf);
        pen_eq = r.force / (kn * J->area);
        e->dslip += cf_law_update(pen_eq, duf[0], duf[1], kn * J->area, ks * J->area, mu, ej->fs, &fn, &sl);
        s->jfn[J - s->jt] = fn;
        Fw[0] = fn * nL[0]; Fw[1] = fn * nL[1]; Fw[2] = fn * nL[2];
        apply_pair(s, bl, bu, P, Fw);
        fsf[0] = ej->fs[0]; fsf[1] = ej->fs[1]; fsf[2] = 0.0;
        mat_vec(RL, fsf, Fs);
        apply_pair(s, bl, bu, cS, Fs);
        /* torsion about the joint normal */
        kt = ks * ej->polar;
        wr = v3_dot(ww + 3 * bu, nL) - (bl ? v3_dot(ww + 3 * bl, nL) : 0.0);
        mt_trial = ej->mt - kt * wr * dt;
        req = sqrt(r.area / CF_PI);
        lim = mu * fn * (2.0 / 3.0) * req;
        if (J->fl.tarm != 1.0 || J->fu.tarm != 1.0)   /* a scaled face: its shape's arm (cf_face.tarm) */
            lim *= (J->fl.area < J->fu.area ? &J->fl : &J->fu)->tarm;
        if (fabs(mt_trial) > lim) {
            double capped = mt_trial > 0 ? lim : -lim;
            /* trapezoidal work on the torsional spring minus its elastic energy change */
            e->dslip += -0.5 * (ej->mt + capped) * wr * dt - 0.5 * (capped * capped - ej->mt * ej->mt) / kt;
            mt_trial = capped;
        }
        ej->mt = mt_trial;
        s->T[3 * bu] += ej->mt * nL[0]; s->T[3 * bu + 1] += ej->mt * nL[1]; s->T[3 * bu + 2] += ej->mt * nL[2];
        if (bl) { s->T[3 * bl] -= ej->mt * nL[0]; s->T[3 * bl + 1] -= ej->mt * nL[1]; s->T[3 * bl + 2] -= ej->mt * nL[2]; }
        e->vs += r.energy + 0.5 * (ej->fs[0] * ej->fs[0] + ej->fs[1] * ej->fs[1]) / (ks * J->area)
               + 0.5 * ej->mt * ej->mt / kt;
    }
}

/* The state: the joints' polar moments (of the smaller face, the joint area), no shear or torsion. */
static int exact_create(cf_solver *s, const double *opt, void **state)
{
    exact_joint *ej = (exact_joint *)calloc((size_t)(s->nj > 0 ? s->nj : 1), sizeof *ej);
    int j;
    (void)opt;   /* no options */
    if (!ej) return cf_solver_fail(s, CF_ENOMEM, "out of memory");
    for (j = 0; j < s->nj; j++) {
        const cf_joint *J = &s->jt[j];
        const cf_face *fa = J->fl.area < J->fu.area ? &J->fl : &J->fu;
        ej[j].polar = fa->polar;
        if (J->asb) ej[j].polar = J->cpolar;   /* as built: the overlap's about its centroid */
    }
    *state = ej;
    return CF_OK;
}

/* The joints' shear force and torsional moment at the start of a run: none. */
static void exact_reset(const cf_solver *s, void *state)
{
    exact_joint *ej = (exact_joint *)state;
    int j;
    for (j = 0; j < s->nj; j++) { ej[j].fs[0] = ej[j].fs[1] = 0; ej[j].mt = 0; }
}

static void exact_free(void *state) { free(state); }

/* The state that carries over (solver_state.c): each joint's shear force and torsional moment. */
static long exact_state_doubles(const cf_solver *s, const void *state)
{
    (void)state;
    return 3 * (long)s->nj;
}

static void exact_state_copy(const cf_solver *s, void *state, double *buf, int to_buf)
{
    exact_joint *ej = (exact_joint *)state;
    int j;
    for (j = 0; j < s->nj; j++) {
        if (to_buf) { buf[3 * j] = ej[j].fs[0]; buf[3 * j + 1] = ej[j].fs[1]; buf[3 * j + 2] = ej[j].mt; }
        else { ej[j].fs[0] = buf[3 * j]; ej[j].fs[1] = buf[3 * j + 1]; ej[j].mt = buf[3 * j + 2]; }
    }
}

/* The same over an as-built joint's overlap (its fan triangles from its centroid, lower face frame). */
static void exact_stiffness_overlap(const cf_solver *s, const cf_joint *J, cf_springs *K)
{
    int k, t, n = J->cn;
    double cx = J->ccen[0], cy = J->ccen[1];
    for (k = 0; k < n; k++) {
        int k1 = k + 1 == n ? 0 : k + 1;
        double ax = J->cpoly[2 * k], ay = J->cpoly[2 * k + 1], bx = J->cpoly[2 * k1], by = J->cpoly[2 * k1 + 1];
        double wq = 0.5 * ((ax - cx) * (by - cy) - (ay - cy) * (bx - cx)) / 3.0, mids[3][2];
        mids[0][0] = 0.5 * (cx + ax); mids[0][1] = 0.5 * (cy + ay);
        mids[1][0] = 0.5 * (cx + bx); mids[1][1] = 0.5 * (cy + by);
        mids[2][0] = 0.5 * (ax + bx); mids[2][1] = 0.5 * (ay + by);
        for (t = 0; t < 3; t++) {
            double p[3];
            p[0] = s->x0[3 * J->bl] + J->fl.c[0] + mids[t][0];
            p[1] = s->x0[3 * J->bl + 1] + J->fl.c[1] + mids[t][1];
            p[2] = s->x0[3 * J->bl + 2] + J->fl.c[2];
            cf_springs_add_contact(K, J, p, wq);
        }
    }
}

/* The same over a chipped joint missing a sector: the band of each triangle of its open fan about the face
 * centre between the scales chole and 1, as two triangles (upper face frame). */
static void exact_stiffness_sector(const cf_solver *s, const cf_joint *J, cf_springs *K)
{
    int k, e, t;
    double h = J->chole;
    for (k = 0; k + 1 < J->cn; k++) {
        const double *a = J->cpoly + 2 * k, *b = a + 2;
        for (e = 0; e < (h > 0.0 ? 2 : 1); e++) {   /* (h a, a, b), then (h a, b, h b) */
            double P[3][2], wq;
            P[0][0] = h * a[0]; P[0][1] = h * a[1];
            P[1][0] = e ? b[0] : a[0]; P[1][1] = e ? b[1] : a[1];
            P[2][0] = e ? h * b[0] : b[0]; P[2][1] = e ? h * b[1] : b[1];
            wq = 0.5 * ((P[1][0] - P[0][0]) * (P[2][1] - P[0][1]) - (P[1][1] - P[0][1]) * (P[2][0] - P[0][0])) / 3.0;
            for (t = 0; t < 3; t++) {
                int t1 = t + 1 == 3 ? 0 : t + 1;
                double p[3];
                p[0] = s->x0[3 * J->bu] + J->fu.c[0] + 0.5 * (P[t][0] + P[t1][0]);
                p[1] = s->x0[3 * J->bu + 1] + J->fu.c[1] + 0.5 * (P[t][1] + P[t1][1]);
                p[2] = s->x0[3 * J->bu + 2] + J->fu.c[2];
                cf_springs_add_contact(K, J, p, wq);
            }
        }
    }
}

/* For the stability limit: the face integral by the edge-midpoint rule on the fan
 * triangles (exact for the quadratic integrands of the stiffness). */
static void exact_stiffness(const cf_solver *s, const void *state, const cf_joint *J, cf_springs *K)
{
    const cf_face *f = &J->fu;
    double wq = J->area / f->n / 3.0;
    int k, t;
    (void)state;
    if (J->csec) { exact_stiffness_sector(s, J, K); return; }
    if (J->asb) { exact_stiffness_overlap(s, J, K); return; }
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
            cf_springs_add_contact(K, J, p, wq);
        }
    }
}

/* Its state is the joints' shear, torsion and polar moments (the polygons are the stack's); run one
 * after the other by the batch (its work is the polygon clipping of contact.c). */
const cf_solver_contact_model cf_solver_exact_model = {
    "exact",
    "Exact interface: kn * overlap integrated over the compressed part of the face overlap "
    "polygon; one joint-level shear spring with the law of contact_law.h and a torsional "
    "spring, both capped by Coulomb friction.",
    NULL, 0,
    exact_create, exact_reset, exact_free, exact_stiffness, joint_exact, NULL, 0,
    exact_state_doubles, exact_state_copy,
};
