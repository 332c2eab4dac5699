/*
 * solver_stack.c -- the column as the solver sees it: rigid bodies and their mass
 * properties, joints and their polygonal faces, and the initial state (exact static
 * equilibrium). The contact models build what they carry on the joints themselves.
 * Everything here runs once per cf_solver_setup; nothing here runs in the time loop
 * except cf_solver_stack_reset.
 */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "cf_math.h"
#include "solver_internal.h"

#define ALLOC(ptr, type, count) do { (ptr) = (type *)calloc((size_t)(count) > 0 ? (size_t)(count) : 1, sizeof(type)); \
    if (!(ptr)) return cf_solver_fail(s, CF_ENOMEM, "out of memory"); } while (0)

void cf_solver_stack_release(cf_solver *s)
{
    free(s->m); free(s->inertia); free(s->x); free(s->v); free(s->q); free(s->w); free(s->R);
    free(s->F); free(s->T); free(s->x0); free(s->q0); free(s->fext_prev); free(s->fdamp_prev);
    free(s->tdamp_prev); free(s->blk_body); free(s->blk_off); free(s->blk_top); free(s->blk_bot);
    free(s->blk_h); free(s->blk_m); free(s->joint_diam); free(s->blk_rc); free(s->jt); free(s->jfn);
    free(s->ww); free(s->vold); free(s->wold);
    s->ww = s->vold = s->wold = NULL;
    s->m = s->inertia = s->x = s->v = s->q = s->w = s->R = s->F = s->T = s->x0 = s->q0 = NULL;
    s->fext_prev = s->fdamp_prev = s->tdamp_prev = NULL;
    s->blk_body = NULL;
    s->blk_off = s->blk_top = s->blk_bot = s->blk_h = s->blk_m = s->joint_diam = s->blk_rc = NULL;
    s->jt = NULL; s->jfn = NULL;
    s->nj = s->nbody = s->nblk = 0;
}

/* ---- faces ---------------------------------------------------------------------- */

/* A regular n-gon face of circumradius r, first vertex at angle phase, centred on the body's axis at
 * height cz of the body frame (a scene moves the centre off the axis afterwards). */
void cf_solver_stack_face(cf_face *f, int n, double r, double phase, double cz, double asp)
{
    int k;
    double a = CF_PI / n;
    f->c[0] = 0; f->c[1] = 0; f->c[2] = cz;
    f->n = n; f->rc = r; f->apo = r * cf_math_cos(a);
    f->area = cf_geometry_polygon_area(n, r);
    f->asp = asp; f->apoc = f->apo; f->tarm = 1.0;
    f->polar = f->area * r * r * (2.0 + cf_math_cos(2.0 * CF_PI / n)) / 6.0;
    for (k = 0; k < n; k++) {
        double ph = phase + 2.0 * CF_PI * k / n;
        f->vx[k] = r * cf_math_cos(ph); f->vy[k] = r * cf_math_sin(ph);
        f->ec[k] = cf_math_cos(ph + a); f->es[k] = cf_math_sin(ph + a);
        if (asp != 1.0) { f->vy[k] *= asp; f->es[k] /= asp; }   /* the section scaled along y (geometry.h) */
        f->poly[2 * k] = f->vx[k]; f->poly[2 * k + 1] = f->vy[k];
    }
    if (asp != 1.0) {
        double rc2 = 0.0;
        for (k = 0; k < n; k++) if (f->vx[k] * f->vx[k] + f->vy[k] * f->vy[k] > rc2) rc2 = f->vx[k] * f->vx[k] + f->vy[k] * f->vy[k];
        f->rc = sqrt(rc2); f->area *= asp;
        if (asp < 1.0) f->apoc = f->apo * asp;
        /* int (x^2 + y^2) dA = k c r^4 a (1 + a^2) (geometry.h), the area k r^2 a */
        f->polar = f->area * r * r * (2.0 + cf_math_cos(2.0 * CF_PI / n)) / 12.0 * (1.0 + asp * asp);
        f->tarm = cf_geometry_section_mean_radius(n, r, phase, asp)
                / (cf_geometry_section_mean_radius(n, r, phase, 1.0) * sqrt(asp));
    }
    for (k = 0; k < n + 2; k++) {
        int m = (k + n - 1) % n;
        f->ecw[k] = f->ec[m]; f->esw[k] = f->es[m];
    }
}

/* ---- bodies --------------------------------------------------------------------- */

/* The arrays of nbody bodies, nblk logical blocks and nj joints, zeroed. */
int cf_solver_stack_alloc(cf_solver *s, int nblk, int nbody, int nj)
{
    ALLOC(s->m, double, nbody); ALLOC(s->inertia, double, 3 * nbody);
    ALLOC(s->x, double, 3 * nbody); ALLOC(s->v, double, 3 * nbody); ALLOC(s->q, double, 4 * nbody);
    ALLOC(s->w, double, 3 * nbody); ALLOC(s->R, double, 9 * nbody); ALLOC(s->F, double, 3 * nbody);
    ALLOC(s->T, double, 3 * nbody); ALLOC(s->x0, double, 3 * nbody); ALLOC(s->q0, double, 4 * nbody);
    ALLOC(s->fext_prev, double, 3 * nbody); ALLOC(s->fdamp_prev, double, 3 * nbody);
    ALLOC(s->tdamp_prev, double, 3 * nbody);
    ALLOC(s->blk_body, int, nblk); ALLOC(s->blk_off, double, 3 * nblk); ALLOC(s->blk_top, double, 3 * nblk);
    ALLOC(s->blk_bot, double, 3 * nblk); ALLOC(s->blk_h, double, nblk); ALLOC(s->blk_m, double, nblk);
    ALLOC(s->joint_diam, double, nblk);
    ALLOC(s->jt, cf_joint, nj);
    ALLOC(s->jfn, double, nj);
    ALLOC(s->ww, double, 3 * nbody); ALLOC(s->vold, double, 3 * nbody); ALLOC(s->wold, double, 3 * nbody);

    ALLOC(s->blk_rc, double, nblk);
    return CF_OK;
}

/* Mass properties of each logical block (bp), bottom heights (zbot), totals. */
static void block_masses(cf_solver *s, int nblk, const int *nseg, const cf_geometry_segment *segs,
                         cf_geometry_massprops *bp, double *zbot, const double *place)
{
    int i, k;
    double density = s->density;
    {
        int off = 0;
        double mz = 0;
        s->total_mass = 0;
        for (i = 0; i < nblk; i++) {
            cf_geometry_block_props(segs + off, nseg[i], density, &bp[i]);
            if (place && place[CF_SOLVER_AS_BUILT * i + 5] > 0.0) {   /* as built, missing a part */
                bp[i].mass = place[CF_SOLVER_AS_BUILT * i + 5]; bp[i].com_z = place[CF_SOLVER_AS_BUILT * i + 8];
            }
            zbot[i + 1] = zbot[i] + bp[i].height;
            s->blk_h[i] = bp[i].height; s->blk_m[i] = bp[i].mass;
            s->joint_diam[i] = cf_geometry_section_diameter(segs[off].r_bottom, segs[off].aspect);
            s->blk_rc[i] = 0.0;
            for (k = off; k < off + nseg[i]; k++) {
                double rb = cf_geometry_circumradius(&segs[k], segs[k].r_bottom), rt = cf_geometry_circumradius(&segs[k], segs[k].r_top);
                if (rb > s->blk_rc[i]) s->blk_rc[i] = rb;
                if (rt > s->blk_rc[i]) s->blk_rc[i] = rt;
            }
            s->total_mass += bp[i].mass;
            mz += bp[i].mass * (zbot[i] + bp[i].com_z);
            off += nseg[i];
        }
        s->total_h = zbot[nblk];
        s->com_h = mz / s->total_mass;
        s->base_diam = cf_geometry_section_diameter(segs[0].r_bottom, segs[0].aspect);
    }
}

/* Bodies: frame origin at the body's centre of mass, axes along the column. */
static void bodies_place(cf_solver *s, int nblk, const cf_geometry_segment *segs, int nseg_tot,
                         const cf_geometry_massprops *bp, const double *zbot, const double *place)
{
    int i;
    const cf_solver_def *def = &s->def;
    double density = s->density;
    s->m[0] = INFINITY;
    if (def->monolithic) {
        cf_geometry_massprops all;
        cf_geometry_block_props(segs, nseg_tot, density, &all);
        s->m[1] = all.mass;
        s->inertia[3] = all.ixx; s->inertia[4] = all.iyy; s->inertia[5] = all.izz;
        for (i = 0; i < nblk; i++) {
            s->blk_body[i] = 1;
            s->blk_off[3 * i + 2] = zbot[i] + bp[i].com_z - all.com_z;
            s->blk_bot[3 * i + 2] = zbot[i] - all.com_z;
            s->blk_top[3 * i + 2] = zbot[i + 1] - all.com_z;
        }
    } else {
        for (i = 0; i < nblk; i++) {
            s->m[i + 1] = bp[i].mass;
            s->inertia[3 * (i + 1)] = bp[i].ixx; s->inertia[3 * (i + 1) + 1] = bp[i].iyy;
            s->inertia[3 * (i + 1) + 2] = bp[i].izz;
            s->blk_body[i] = i + 1;
            s->blk_bot[3 * i + 2] = -bp[i].com_z;
            s->blk_top[3 * i + 2] = bp[i].height - bp[i].com_z;
            if (place && place[CF_SOLVER_AS_BUILT * i + 5] > 0.0) {
                /* missing a part: its own principal inertia, its centre of mass off the axis (the faces' centres
                 * in its frame off the origin by as much) */
                const double *p = place + CF_SOLVER_AS_BUILT * i;
                s->inertia[3 * (i + 1)] = p[9]; s->inertia[3 * (i + 1) + 1] = p[10]; s->inertia[3 * (i + 1) + 2] = p[11];
                s->blk_bot[3 * i] = s->blk_top[3 * i] = -p[6];
                s->blk_bot[3 * i + 1] = s->blk_top[3 * i + 1] = -p[7];
            }
        }
    }
}

/* Joints and their faces: joint j carries block j on block j - 1 (or on the ground). As built (place:
 * CF_SOLVER_AS_BUILT values per block), each face turned by its block's rotation and centred off its
 * body's origin as its block's centre of mass moved; a joint whose faces are offset or turned against
 * each other carries their overlap, a chipped one its annulus (solver_as_built.c). */
static int joints_make(cf_solver *s, int nblk, const int *nseg, const cf_geometry_segment *segs, const double *place)
{
    int i, j, nj = s->nj, st = CF_OK;
    const cf_solver_def *def = &s->def;
    {
        int off = 0;
        int *first = (int *)calloc((size_t)nblk, sizeof(int)), *last = (int *)calloc((size_t)nblk, sizeof(int));
        if (!first || !last) { free(first); free(last); return cf_solver_fail(s, CF_ENOMEM, "out of memory"); }
        for (i = 0; i < nblk; i++) { first[i] = off; last[i] = off + nseg[i] - 1; off += nseg[i]; }
        for (j = 0; j < nj && !st; j++) {
            cf_joint *J = &s->jt[j];
            const cf_geometry_segment *bot = &segs[first[j]];
            /* the faces' phases, turned by their blocks' rotations as built (untouched otherwise) */
            const double *pu = place ? place + CF_SOLVER_AS_BUILT * j : NULL, *pl = pu && j > 0 ? pu - CF_SOLVER_AS_BUILT : pu;
            double ru = pu ? pu[2] : 0.0, rl = pl ? pl[2] : 0.0;
            double phu = place ? bot->phase_rad + ru : bot->phase_rad;
            J->logical = j;
            J->bl = def->monolithic ? 0 : j;
            J->bu = def->monolithic ? 1 : j + 1;
            cf_solver_stack_face(&J->fu, bot->n_sides, bot->r_bottom, phu, s->blk_bot[3 * j + 2], cf_geometry_segment_aspect(bot));
            if (j == 0) {
                cf_solver_stack_face(&J->fl, bot->n_sides, bot->r_bottom, phu, 0.0, cf_geometry_segment_aspect(bot));
            } else {
                const cf_geometry_segment *top = &segs[last[j - 1]];
                double phl = place ? top->phase_rad + rl : top->phase_rad;
                cf_solver_stack_face(&J->fl, top->n_sides, top->r_top, phl, s->blk_top[3 * (j - 1) + 2],
                                     cf_geometry_segment_aspect(top));
            }
            J->area = J->fl.area < J->fu.area ? J->fl.area : J->fu.area;
            if (pu && (J->fu.asp != 1.0 || J->fl.asp != 1.0)) {
                int v;
                for (v = 0; v < CF_SOLVER_AS_BUILT && !st; v++)
                    if (pu[v] != 0.0 || pl[v] != 0.0)
                        st = cf_solver_fail(s, CF_EINVAL, "joint %d: as-built values (offset, rotation, chipping, a missing "
                                            "part) are for regular sections; a face here has aspect %g", j,
                                            J->fu.asp != 1.0 ? J->fu.asp : J->fl.asp);
            }
            if (pu && !st) {
                double dx = j > 0 ? pu[0] - pl[0] : 0.0, dy = j > 0 ? pu[1] - pl[1] : 0.0;
                int turned = dx != 0.0 || dy != 0.0 || ru != rl;
                /* the faces' centres off the bodies' origins (a block missing a part) */
                J->fu.c[0] = s->blk_bot[3 * j]; J->fu.c[1] = s->blk_bot[3 * j + 1];
                if (j > 0) { J->fl.c[0] = s->blk_top[3 * (j - 1)]; J->fl.c[1] = s->blk_top[3 * (j - 1) + 1]; }
                if (pu[3] != 0.0 || pu[4] != 0.0 || pu[12] != 0.0 || pu[13] != 0.0) {   /* chipped: an annulus, a sector */
                    if (turned)
                        st = cf_solver_fail(s, CF_EINVAL, "joint %d: a chipped face is for a joint whose faces are "
                                            "aligned (not offset or turned against each other)", j);
                    else st = cf_solver_as_built_chipped(s, J, pu[3], pu[4] > 0.0 ? pu[4] : J->fu.rc, pu[12], pu[13]);
                } else if (turned) {
                    st = cf_solver_as_built_joint(s, J, dx, dy);
                }
            }
        }
        free(first); free(last);
    }
    return st;
}

/* Initial state: exact static equilibrium, joint j pre-compressed by the weight above
 * it (uniform overlap W / (kn A) over the face; W the weight's part normal to a tilted foundation),
 * shear zero (the tilt is cf_solver_stack_tilt's; a foundation's downhill pull loads the shear
 * springs in the first steps, a small transient: docs/sequences.md). */
static void equilibrium(cf_solver *s, int nblk, const cf_geometry_massprops *bp, const double *zbot,
                        const double *place)
{
    int i, j, k, nj = s->nj, nbody = s->nbody;
    const cf_solver_def *def = &s->def;
    {
        double settle = 0.0, wabove;
        for (i = 0; i < 4 * nbody; i += 4) s->q0[i] = 1.0;
        for (j = 0; j < nj; j++) {
            wabove = 0;
            for (k = (def->monolithic ? 0 : j); k < nblk; k++) wabove += s->blk_m[k] * s->g_normal;
            settle += wabove / (s->jt[j].kn * s->jt[j].area);
            if (def->monolithic) {
                /* the column's centre-of-mass height: bodies_place set blk_bot[2] = 0 - com_z */
                s->x0[3 * 1 + 2] = -s->blk_bot[2] - settle;
            } else {
                s->x0[3 * (j + 1) + 2] = zbot[j] + bp[j].com_z - settle;
                /* as built: the block's axis at its offset (its contact settles uniformly over the
                 * joint's overlap; the offset centre of mass tips it a little: docs/sequences.md) */
                if (place) {
                    s->x0[3 * (j + 1)] = place[CF_SOLVER_AS_BUILT * j] - s->blk_bot[3 * j];
                    s->x0[3 * (j + 1) + 1] = place[CF_SOLVER_AS_BUILT * j + 1] - s->blk_bot[3 * j + 1];
                }
            }
        }
    }
}

/* The definition's initial tilt applied to the built column (equilibrium leaves it untilted, so that
 * the connectors take their rest state there first): a rigid rotation of every moving body about
 * the line through the outermost +x base vertex, parallel to y. */
void cf_solver_stack_tilt(cf_solver *s)
{
    int i, k, nbody = s->nbody;
    const cf_solver_def *def = &s->def;
    if (def->initial_tilt_rad != 0.0) {
        const cf_face *f = &s->jt[0].fu;
        double xp = f->vx[0], th = def->initial_tilt_rad, c = cf_math_cos(th), sn = cf_math_sin(th);
        double zp = s->x0[3 * 1 + 2] + f->c[2];
        for (k = 1; k < f->n; k++) if (f->vx[k] > xp) xp = f->vx[k];
        if (s->asb && s->jt[0].csec) xp = cf_solver_as_built_reach(&s->jt[0]);   /* a base face missing a sector */
        else if (s->asb && s->jt[0].cout > 0.0) xp *= s->jt[0].cout;   /* ... chipped to an annulus */
        if (s->asb) xp += s->x0[3 * 1] + f->c[0];   /* the base block's axis at its offset */
        for (i = 1; i < nbody; i++) {
            double dx = s->x0[3 * i] - xp, dz = s->x0[3 * i + 2] - zp;
            s->x0[3 * i] = xp + c * dx + sn * dz;
            s->x0[3 * i + 2] = zp - sn * dx + c * dz;
            s->q0[4 * i] = cf_math_cos(0.5 * th); s->q0[4 * i + 1] = 0; s->q0[4 * i + 2] = cf_math_sin(0.5 * th);
            s->q0[4 * i + 3] = 0;
        }
    }
}

int cf_solver_stack_build(cf_solver *s, int nblk, const int *nseg, const cf_geometry_segment *segs,
                          const double *kn, const double *ks, const double *mu, const double *place)
{
    int i, st, nseg_tot = 0;
    cf_geometry_massprops *bp;
    double *zbot;
    for (i = 0; i < nblk; i++) nseg_tot += nseg[i];
    s->nblk = nblk;
    s->nbody = s->def.monolithic ? 2 : nblk + 1;
    s->nj = s->def.monolithic ? 1 : nblk;
    st = cf_solver_stack_alloc(s, nblk, s->nbody, s->nj);
    if (st) return st;
    bp = (cf_geometry_massprops *)calloc((size_t)nblk, sizeof *bp);
    zbot = (double *)calloc((size_t)nblk + 1, sizeof(double));
    if (!bp || !zbot) { free(bp); free(zbot); return cf_solver_fail(s, CF_ENOMEM, "out of memory"); }
    block_masses(s, nblk, nseg, segs, bp, zbot, place);
    bodies_place(s, nblk, segs, nseg_tot, bp, zbot, place);
    st = joints_make(s, nblk, nseg, segs, place);
    if (!st) {
        /* joint j (under block j) takes the j-th properties; a monolithic column has joint 0 only */
        int j;
        for (j = 0; j < s->nj; j++) {
            s->jt[j].kn = kn[j]; s->jt[j].ks = ks[j]; s->jt[j].mu = mu[j];
            s->jt[j].above = s->nbody; s->jt[j].bearing = 0;   /* a column carries everything above */
        }
    }
    if (!st) equilibrium(s, nblk, bp, zbot, place);
    free(bp); free(zbot);
    return st;
}

/* The bodies' state at the start of a run: the initial equilibrium, at rest, the state of a
 * freshly set-up solver (the contact model resets its own state: cf_solver_run). */
void cf_solver_stack_reset(cf_solver *s)
{
    int nb = s->nbody;
    memcpy(s->x, s->x0, sizeof(double) * 3 * (size_t)nb);
    memcpy(s->q, s->q0, sizeof(double) * 4 * (size_t)nb);
    memset(s->v, 0, sizeof(double) * 3 * (size_t)nb);
    memset(s->w, 0, sizeof(double) * 3 * (size_t)nb);
    memset(s->fext_prev, 0, sizeof(double) * 3 * (size_t)nb);
    memset(s->fdamp_prev, 0, sizeof(double) * 3 * (size_t)nb);
    memset(s->tdamp_prev, 0, sizeof(double) * 3 * (size_t)nb);
}
