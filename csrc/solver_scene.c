/*
 * solver_scene.c -- a scene of several columns on one ground, with beams (epistyles) resting on
 * their top blocks: its checks, its bodies and joints, its initial state and the map of its parts
 * the monitor reports on (cf_scene_info). The contacts are a graph: a column's joints form a stack,
 * a beam rests on the top blocks of two columns through bearings, square patches of its underside
 * pressed on the capitals' tops with the soft Coulomb law of every joint. A scene of one column
 * without beams is not built here but by the single column's own set-up (solver_stack.c), so it
 * gives that column's results bit for bit.
 *
 * Initial state, exact static equilibrium: every joint pre-compressed uniformly by the load it
 * carries (a column's blocks above it and the shares of the beams on its top; a beam's weight shared
 * by its two supporting columns by the lever rule between the stiffness-weighted centres of its
 * bearings on each), beams level, nothing sheared. Two columns carrying different loads settle
 * differently; so that their beams lie level, each column stands on a levelling course of its own
 * (its ground face raised by a shim, at most the difference of the settlements: 0.8 mm under the
 * inner columns of the default column's 4-column portal) -- the stylobate levelled as it was built.
 *
 * Set-up only; like solver_stack.c, nothing here runs in the time loop.
 */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "cf_math.h"
#include "solver_internal.h"

void cf_solver_scene_free(cf_scene_info *info)
{
    if (!info) return;
    free(info->col_blk0); free(info->col_nblk); free(info->col_j0); free(info->col_nj); free(info->col_base_diam);
    free(info->beam_j0); free(info->beam_nj); free(info->beam_seat); free(info->col_top); free(info->bear_col);
    free(info->bear_gc);
    free(info);
}

static cf_scene_info *info_alloc(int ncol, int nbeam, int nbear)
{
    cf_scene_info *p = (cf_scene_info *)calloc(1, sizeof *p);
    size_t nc = (size_t)(ncol > 0 ? ncol : 1), nb = (size_t)(nbeam > 0 ? nbeam : 1), ng = (size_t)(nbear > 0 ? nbear : 1);
    if (!p) return NULL;
    p->ncol = ncol; p->nbeam = nbeam;
    p->col_blk0 = (int *)calloc(nc, sizeof(int)); p->col_nblk = (int *)calloc(nc, sizeof(int));
    p->col_j0 = (int *)calloc(nc, sizeof(int)); p->col_nj = (int *)calloc(nc, sizeof(int));
    p->col_base_diam = (double *)calloc(nc, sizeof(double));
    p->beam_j0 = (int *)calloc(nb, sizeof(int)); p->beam_nj = (int *)calloc(nb, sizeof(int));
    p->beam_seat = (double *)calloc(nb, sizeof(double));
    p->col_top = (cf_face *)calloc(nc, sizeof(cf_face));
    p->nbear = nbear;
    p->bear_col = (int *)calloc(ng, sizeof(int));
    p->bear_gc = (double *)calloc(3 * ng, sizeof(double));
    if (!p->col_blk0 || !p->col_nblk || !p->col_j0 || !p->col_nj || !p->col_base_diam || !p->beam_j0 || !p->beam_nj
        || !p->beam_seat || !p->col_top || !p->bear_col || !p->bear_gc) {
        cf_solver_scene_free(p);
        return NULL;
    }
    return p;
}

/* ---- checks ------------------------------------------------------------------------- */

static int finite_pos(double v) { return v > 0.0 && isfinite(v); }

/* The largest circumradius of column c's blocks (first segment at seg0), m. */
static double column_radius(const cf_solver_scene *sc, int c, int blk0, int seg0)
{
    int i, k, off = seg0;
    double r = 0.0;
    for (i = 0; i < sc->columns[c].n_blocks; i++) {
        for (k = 0; k < sc->n_segments[blk0 + i]; k++) {
            const cf_geometry_segment *g = &sc->segments[off + k];
            if (g->r_bottom > r) r = g->r_bottom;
            if (g->r_top > r) r = g->r_top;
        }
        off += sc->n_segments[blk0 + i];
    }
    return r;
}

/* Beams, bearings and the columns' places: CF_OK or CF_EINVAL naming the bad value. */
static int check_parts(cf_solver *s, const cf_solver_scene *sc, const double *col_r)
{
    int c, d, b, r;
    if (s->def.monolithic || s->def.initial_tilt_rad != 0.0)
        return cf_solver_fail(s, CF_EINVAL, "a scene of several columns or with beams takes neither monolithic nor "
                              "initial_tilt_rad (got monolithic = %d, initial_tilt_rad = %g)", s->def.monolithic,
                              s->def.initial_tilt_rad);
    if (sc->n_beams < 0 || sc->n_bearings < 0 || (sc->n_beams > 0 && !sc->beams) || (sc->n_bearings > 0 && !sc->bearings))
        return cf_solver_fail(s, CF_EINVAL, "scene: %d beams and %d bearings without their definitions", sc->n_beams,
                              sc->n_bearings);
    for (c = 0; c < sc->n_columns; c++) {
        if (!isfinite(sc->columns[c].x) || !isfinite(sc->columns[c].y))
            return cf_solver_fail(s, CF_EINVAL, "column %d: its place (%g, %g) m must be finite", c, sc->columns[c].x,
                                  sc->columns[c].y);
        for (d = 0; d < c; d++) {
            double dx = sc->columns[c].x - sc->columns[d].x, dy = sc->columns[c].y - sc->columns[d].y;
            if (sqrt(dx * dx + dy * dy) <= col_r[c] + col_r[d])
                return cf_solver_fail(s, CF_EINVAL, "columns %d and %d overlap: their axes are %g m apart, closer than "
                                      "their radii %g + %g m", d, c, sqrt(dx * dx + dy * dy), col_r[d], col_r[c]);
        }
    }
    for (b = 0; b < sc->n_beams; b++) {
        const cf_solver_scene_beam *B = &sc->beams[b];
        if (!isfinite(B->x) || !isfinite(B->y) || !finite_pos(B->length) || !finite_pos(B->width)
            || !finite_pos(B->height) || !finite_pos(B->density))
            return cf_solver_fail(s, CF_EINVAL, "beam %d: place (%g, %g) m must be finite, length %g, width %g, height %g m "
                                  "and density %g kg/m^3 finite and > 0", b, B->x, B->y, B->length, B->width, B->height,
                                  B->density);
    }
    for (r = 0; r < sc->n_bearings; r++) {
        const cf_solver_scene_bearing *G = &sc->bearings[r];
        if (G->beam < 0 || G->beam >= sc->n_beams || G->column < 0 || G->column >= sc->n_columns)
            return cf_solver_fail(s, CF_EINVAL, "bearing %d: beam %d or column %d does not exist", r, G->beam, G->column);
        if (r > 0 && G->beam < sc->bearings[r - 1].beam)
            return cf_solver_fail(s, CF_EINVAL, "bearing %d: bearings must be listed beam by beam (beam %d after %d)", r,
                                  G->beam, sc->bearings[r - 1].beam);
        if (!isfinite(G->x) || !isfinite(G->y) || !finite_pos(G->side) || !finite_pos(G->kn) || !finite_pos(G->ks)
            || !finite_pos(G->mu))
            return cf_solver_fail(s, CF_EINVAL, "bearing %d: place (%g, %g) m must be finite, side %g m, kn %g, ks %g Pa/m "
                                  "and mu %g finite and > 0", r, G->x, G->y, G->side, G->kn, G->ks, G->mu);
    }
    return CF_OK;
}

/* ---- columns ------------------------------------------------------------------------ */

/* Column c's blocks and joints at its place, untilted, on its ground face at height 0 (the levelling
 * course raises it later): masses, faces, joint laws; blk0, j0, seg0 its first block, joint, segment. */
static void column_build(cf_solver *s, const cf_solver_scene *sc, int c, int blk0, int j0, int seg0,
                         cf_geometry_massprops *bp)
{
    int i, nb = sc->columns[c].n_blocks, off = seg0, above = blk0 + nb + 1;
    double X = sc->columns[c].x, Y = sc->columns[c].y;
    for (i = 0; i < nb; i++) {
        int kb = blk0 + i, b = kb + 1, k, ns = sc->n_segments[kb];
        const cf_geometry_segment *bot = &sc->segments[off], *top;
        cf_joint *J = &s->jt[j0 + i];
        cf_geometry_block_props(sc->segments + off, ns, s->density, &bp[kb]);
        s->m[b] = bp[kb].mass;
        s->inertia[3 * b] = bp[kb].ixx; s->inertia[3 * b + 1] = bp[kb].iyy; s->inertia[3 * b + 2] = bp[kb].izz;
        s->blk_body[kb] = b;
        s->blk_bot[3 * kb + 2] = -bp[kb].com_z;
        s->blk_top[3 * kb + 2] = bp[kb].height - bp[kb].com_z;
        s->blk_h[kb] = bp[kb].height; s->blk_m[kb] = bp[kb].mass;
        s->joint_diam[kb] = cf_geometry_section_diameter(bot->r_bottom, bot->aspect);
        s->blk_rc[kb] = 0.0;
        for (k = off; k < off + ns; k++) {
            const cf_geometry_segment *g = &sc->segments[k];
            if (cf_geometry_circumradius(g, g->r_bottom) > s->blk_rc[kb]) s->blk_rc[kb] = cf_geometry_circumradius(g, g->r_bottom);
            if (cf_geometry_circumradius(g, g->r_top) > s->blk_rc[kb]) s->blk_rc[kb] = cf_geometry_circumradius(g, g->r_top);
        }
        s->x0[3 * b] = X; s->x0[3 * b + 1] = Y;
        J->logical = kb;
        J->bl = i == 0 ? 0 : b - 1;
        J->bu = b;
        cf_solver_stack_face(&J->fu, bot->n_sides, bot->r_bottom, bot->phase_rad, s->blk_bot[3 * kb + 2], cf_geometry_segment_aspect(bot));
        if (i == 0) {
            cf_solver_stack_face(&J->fl, bot->n_sides, bot->r_bottom, bot->phase_rad, 0.0, cf_geometry_segment_aspect(bot));
            J->fl.c[0] = X; J->fl.c[1] = Y;   /* the ground's face under the column */
        } else {
            top = &sc->segments[off - 1];      /* the last segment of the block below */
            cf_solver_stack_face(&J->fl, top->n_sides, top->r_top, top->phase_rad, s->blk_top[3 * (kb - 1) + 2],
                                 cf_geometry_segment_aspect(top));
        }
        J->area = J->fl.area < J->fu.area ? J->fl.area : J->fu.area;
        J->kn = sc->kn[j0 + i]; J->ks = sc->ks[j0 + i]; J->mu = sc->mu[j0 + i];
        J->above = above; J->bearing = 0;
        off += ns;
        if (i == nb - 1) {   /* the column's top: the polygon its top block carries */
            top = &sc->segments[off - 1];
            cf_solver_stack_face(&s->scene->col_top[c], top->n_sides, top->r_top, top->phase_rad, s->blk_top[3 * kb + 2],
                                 cf_geometry_segment_aspect(top));
        }
    }
}

/* ---- beams and bearings ------------------------------------------------------------ */

/* Beam b's body (a rectangular block; centre of mass at its centre) at its place, height unset. */
static void beam_build(cf_solver *s, const cf_solver_scene *sc, int b, int kb)
{
    const cf_solver_scene_beam *B = &sc->beams[b];
    int i = kb + 1;
    double m = B->density * B->length * B->width * B->height, L2 = B->length * B->length;
    double W2 = B->width * B->width, H2 = B->height * B->height;
    s->m[i] = m;
    s->inertia[3 * i] = m * (W2 + H2) / 12.0; s->inertia[3 * i + 1] = m * (L2 + H2) / 12.0;
    s->inertia[3 * i + 2] = m * (L2 + W2) / 12.0;
    s->blk_body[kb] = i;
    s->blk_bot[3 * kb + 2] = -0.5 * B->height;
    s->blk_top[3 * kb + 2] = 0.5 * B->height;
    s->blk_h[kb] = B->height; s->blk_m[kb] = m;
    s->joint_diam[kb] = B->width;
    s->blk_rc[kb] = 0.5 * sqrt(L2 + W2);
    s->x0[3 * i] = B->x; s->x0[3 * i + 1] = B->y;
}

/* Bearing r as joint j: the square patch on the capital's top face and the same square on the
 * beam's underside, each centred at the patch's centre; it must lie on both. */
static int bearing_build(cf_solver *s, const cf_solver_scene *sc, cf_scene_info *info, int r, int j)
{
    const cf_solver_scene_bearing *G = &sc->bearings[r];
    const cf_solver_scene_beam *B = &sc->beams[G->beam];
    int c = G->column, cap = info->col_blk0[c] + info->col_nblk[c] - 1, kb = s->nblk - sc->n_beams + G->beam;
    double X = sc->columns[c].x, Y = sc->columns[c].y, h = 0.5 * G->side, rad = h * sqrt(2.0), tol;
    const cf_face *capf = &info->col_top[c];
    cf_joint *J = &s->jt[j];
    int k;
    tol = 1e-9 * capf->rc;
    for (k = 0; k < 4; k++) {
        double px = G->x + (k & 1 ? h : -h), py = G->y + (k & 2 ? h : -h);
        if (!cf_face_inside(capf, px - X, py - Y, tol))
            return cf_solver_fail(s, CF_EINVAL, "bearing %d: its corner (%g, %g) m lies off the top of column %d", r, px,
                                  py, c);
        if (fabs(px - B->x) > 0.5 * B->length * (1.0 + 1e-9) || fabs(py - B->y) > 0.5 * B->width * (1.0 + 1e-9))
            return cf_solver_fail(s, CF_EINVAL, "bearing %d: its corner (%g, %g) m lies off the underside of beam %d", r,
                                  px, py, G->beam);
    }
    J->logical = kb;
    J->bl = s->blk_body[cap];
    J->bu = s->blk_body[kb];
    cf_solver_stack_face(&J->fl, 4, rad, 0.25 * CF_PI, s->blk_top[3 * cap + 2], 1.0);
    J->fl.c[0] = G->x - X; J->fl.c[1] = G->y - Y;
    cf_solver_stack_face(&J->fu, 4, rad, 0.25 * CF_PI, -0.5 * B->height, 1.0);
    J->fu.c[0] = G->x - B->x; J->fu.c[1] = G->y - B->y;
    J->area = J->fl.area;
    J->kn = G->kn; J->ks = G->ks; J->mu = G->mu;
    J->above = J->bu + 1; J->bearing = 1;
    info->bear_col[r] = c;
    return CF_OK;
}

/* ---- loads, settlements and the levelling courses ------------------------------------ */

/* Each bearing's load (N) from its beam's weight: the beam's two supporting columns share it by the
 * lever rule between the centres of their bearings (each weighted by kn x area, the stiffness that
 * takes it), a column's share split among its bearings by kn x area, so that their overlaps are
 * equal. A beam must rest on exactly two columns, on either side of its centre of mass. */
static int bearing_loads(cf_solver *s, const cf_solver_scene *sc, const cf_scene_info *info, double *load)
{
    int b, r, jb0 = s->nj - sc->n_bearings;
    for (b = 0; b < sc->n_beams; b++) {
        int j0 = info->beam_j0[b], n = info->beam_nj[b], col[2] = {-1, -1};
        double kw[2] = {0, 0}, cx[2] = {0, 0}, cy[2] = {0, 0}, W = s->blk_m[s->nblk - sc->n_beams + b] * s->def.g;
        double ax, ay, bx, by, L2, t;
        for (r = j0; r < j0 + n; r++) {
            const cf_solver_scene_bearing *G = &sc->bearings[r - jb0];
            int side = G->column == col[0] ? 0 : G->column == col[1] ? 1 : col[0] < 0 ? 0 : col[1] < 0 ? 1 : 2;
            double w = G->kn * G->side * G->side;
            if (side == 2)
                return cf_solver_fail(s, CF_EINVAL, "beam %d rests on more than two columns (%d, %d and %d): a beam spans "
                                      "two neighbouring capitals", b, col[0], col[1], G->column);
            col[side] = G->column;
            kw[side] += w; cx[side] += w * G->x; cy[side] += w * G->y;
        }
        if (col[1] < 0)
            return cf_solver_fail(s, CF_EINVAL, "beam %d does not reach two capitals (it rests on %s): a beam spans two "
                                  "neighbouring columns", b, col[0] < 0 ? "nothing" : "one column only");
        ax = cx[0] / kw[0]; ay = cy[0] / kw[0]; bx = cx[1] / kw[1]; by = cy[1] / kw[1];
        L2 = (bx - ax) * (bx - ax) + (by - ay) * (by - ay);
        /* the centre of mass projected on the line between the two supports, as a fraction from the first */
        t = ((sc->beams[b].x - ax) * (bx - ax) + (sc->beams[b].y - ay) * (by - ay)) / L2;
        if (!(t > 0.0 && t < 1.0))
            return cf_solver_fail(s, CF_EINVAL, "beam %d: its centre of mass does not lie between its two supporting "
                                  "columns %d and %d", b, col[0], col[1]);
        for (r = j0; r < j0 + n; r++) {
            const cf_solver_scene_bearing *G = &sc->bearings[r - jb0];
            int side = G->column == col[0] ? 0 : 1;
            load[r] = (side == 0 ? 1.0 - t : t) * W * (G->kn * G->side * G->side) / kw[side];
        }
    }
    return CF_OK;
}

/* The rest state: the columns' settlements under their loads, the levelling courses that put every
 * beam's supports level, the columns' and beams' heights. */
static int rest_state(cf_solver *s, const cf_solver_scene *sc, const cf_scene_info *info,
                      const cf_geometry_massprops *bp, const double *load)
{
    int ncol = sc->n_columns, c, b, r, i, changed, pass, nb0 = s->nblk - sc->n_beams, jb0 = s->nj - sc->n_bearings;
    double *top = (double *)calloc((size_t)ncol, sizeof(double));    /* settled top of each column from its base, m */
    double *shim = (double *)calloc((size_t)ncol, sizeof(double));
    int *set = (int *)calloc((size_t)ncol, sizeof(int));
    double *under = (double *)calloc((size_t)(sc->n_beams > 0 ? sc->n_beams : 1), sizeof(double));
    double *hgt = (double *)calloc((size_t)ncol, sizeof(double));     /* each column's height at rest, m */
    double *held = (double *)calloc((size_t)ncol, sizeof(double));    /* the beams' load on each column's top, N */
    int st = CF_OK;
    if (!top || !shim || !set || !under || !hgt || !held) {
        free(top); free(shim); free(set); free(under); free(hgt); free(held);
        return cf_solver_fail(s, CF_ENOMEM, "out of memory (scene)");
    }
    /* each column: its blocks bottom up, every joint pre-compressed by what it carries */
    for (c = 0; c < ncol; c++) {
        int k0 = info->col_blk0[c], nb = info->col_nblk[c], j0 = info->col_j0[c];
        double topload = 0.0, settle = 0.0, z = 0.0;
        for (r = 0; r < sc->n_bearings; r++) if (sc->bearings[r].column == c) topload += load[jb0 + r];
        for (i = 0; i < nb; i++) {
            double w = topload;
            int k;
            for (k = i; k < nb; k++) w += s->blk_m[k0 + k] * s->def.g;
            settle += w / (s->jt[j0 + i].kn * s->jt[j0 + i].area);
            s->x0[3 * (k0 + i + 1) + 2] = z + bp[k0 + i].com_z - settle;
            z += bp[k0 + i].height;
        }
        top[c] = z - settle;
        hgt[c] = z; held[c] = topload;
        /* a settlement of a hundredth of the column's height is no longer a joint's small overlap: the
         * soft contacts cannot carry such a load (a beam of absurd weight, joints of absurd softness) */
        if (!st && !(settle <= 0.01 * z))
            st = cf_solver_fail(s, CF_EINVAL, "column %d settles by %.6g m under its blocks and %.6g N of beams, over "
                                "1/100 of its height %.6g m (base kn %.6g Pa/m): lighter beams or stiffer joints", c,
                                settle, topload, z, s->jt[j0].kn);
    }
    /* the levelling courses: a beam's two supports at one height, propagated over the beams' graph
     * from a first column of each connected part, the lowest course then set to 0 */
    for (pass = 0; pass < ncol && !st; pass++) {   /* (after a refused settlement: nothing) */
        int root = -1;
        for (c = 0; c < ncol; c++) if (!set[c]) { root = c; break; }
        if (root < 0) break;
        set[root] = 1;
        do {
            changed = 0;
            for (b = 0; b < sc->n_beams && !st; b++) {
                int j0 = info->beam_j0[b], n = info->beam_nj[b], ca = sc->bearings[j0 - jb0].column, cb = -1;
                double ova = load[j0] / (s->jt[j0].kn * s->jt[j0].area), ovb = 0.0;
                for (r = j0; r < j0 + n; r++)
                    if (sc->bearings[r - jb0].column != ca) { cb = sc->bearings[r - jb0].column; ovb = load[r] / (s->jt[r].kn * s->jt[r].area); break; }
                /* underside: top[c] + shim[c] - ov at either support */
                if (set[ca] && !set[cb]) { shim[cb] = top[ca] + shim[ca] - ova - top[cb] + ovb; set[cb] = 1; changed = 1; }
                else if (set[cb] && !set[ca]) { shim[ca] = top[cb] + shim[cb] - ovb - top[ca] + ova; set[ca] = 1; changed = 1; }
                else if (set[ca] && set[cb]) {
                    double d = (top[ca] + shim[ca] - ova) - (top[cb] + shim[cb] - ovb);
                    if (fabs(d) > 1e-9 * (fabs(top[ca]) + fabs(top[cb])))
                        st = cf_solver_fail(s, CF_EINVAL, "beam %d: its supports cannot both be level (the beams form a "
                                            "loop whose settlements differ by %g m)", b, d);
                }
            }
        } while (changed && !st);
    }
    if (!st) {
        double lo = INFINITY;
        for (c = 0; c < ncol; c++) if (shim[c] < lo) lo = shim[c];
        for (c = 0; c < ncol; c++) {
            int k0 = info->col_blk0[c], i;
            shim[c] -= lo;
            /* a course of more than a hundredth of the column's height is a difference of geometry, not of settlement */
            if (!st && shim[c] > 0.01 * top[c])
                st = cf_solver_fail(s, CF_EINVAL, "column %d: a levelling course of %.6g m, over 1/100 of its settled "
                                    "height %.6g m (%.6g m, settling %.6g m under %.6g N of beams): columns under one "
                                    "beam must be of like height and settlement", c, shim[c], top[c], hgt[c],
                                    hgt[c] - top[c], held[c]);
            for (i = 0; i < info->col_nblk[c]; i++) s->x0[3 * (k0 + i + 1) + 2] += shim[c];
            s->jt[info->col_j0[c]].fl.c[2] = shim[c];
        }
    }
    for (b = 0; !st && b < sc->n_beams; b++) {
        int j0 = info->beam_j0[b], ca = sc->bearings[j0 - jb0].column, i = nb0 + b + 1;
        under[b] = top[ca] + shim[ca] - load[j0] / (s->jt[j0].kn * s->jt[j0].area);
        s->x0[3 * i + 2] = under[b] + 0.5 * sc->beams[b].height;
    }
    free(top); free(shim); free(set); free(under); free(hgt); free(held);
    return st;
}

/* The totals the monitor's scales read: mass, height, height of the centre of mass. */
static void totals(cf_solver *s)
{
    int i;
    double mz = 0.0;
    s->total_mass = 0.0; s->total_h = 0.0;
    for (i = 0; i < s->nblk; i++) {
        int b = s->blk_body[i];
        double ztop = s->x0[3 * b + 2] + s->blk_top[3 * i + 2];
        s->total_mass += s->blk_m[i];
        mz += s->blk_m[i] * s->x0[3 * b + 2];
        if (ztop > s->total_h) s->total_h = ztop;
    }
    s->com_h = mz / s->total_mass;
    s->base_diam = s->scene->col_base_diam[0];
}

/* The map of the scene's parts (columns' blocks and joints, beams' bearings and seats). */
static int scene_map(cf_solver *s, const cf_solver_scene *sc, int nj_col)
{
    int c, r, blk = 0, seg = 0;
    cf_scene_info *info = info_alloc(sc->n_columns, sc->n_beams, sc->n_bearings);
    if (!info) return cf_solver_fail(s, CF_ENOMEM, "out of memory (scene)");
    s->scene = info;
    for (c = 0; c < sc->n_columns; c++) {
        info->col_blk0[c] = blk; info->col_nblk[c] = sc->columns[c].n_blocks;
        info->col_j0[c] = blk; info->col_nj[c] = sc->columns[c].n_blocks;
        info->col_base_diam[c] = cf_geometry_section_diameter(sc->segments[seg].r_bottom, sc->segments[seg].aspect);
        for (r = 0; r < sc->columns[c].n_blocks; r++) seg += sc->n_segments[blk + r];
        blk += sc->columns[c].n_blocks;
    }
    for (r = 0; r < sc->n_beams; r++) { info->beam_j0[r] = -1; info->beam_seat[r] = INFINITY; }
    for (r = 0; r < sc->n_bearings; r++) {
        int b = sc->bearings[r].beam;
        if (info->beam_j0[b] < 0) info->beam_j0[b] = nj_col + r;
        info->beam_nj[b]++;
    }
    for (r = 0; r < sc->n_beams; r++) {
        /* the seat at each supporting column: the extent of its bearings along x and along y, the
         * shorter of the two; the beam's seat is the shortest over its two columns */
        int k, j0 = info->beam_j0[r];
        for (k = 0; j0 >= 0 && k < info->beam_nj[r]; k++) {
            const cf_solver_scene_bearing *G = &sc->bearings[j0 - nj_col + k];
            double x0 = INFINITY, x1 = -INFINITY, y0 = INFINITY, y1 = -INFINITY, ext;
            int q;
            for (q = 0; q < info->beam_nj[r]; q++) {
                const cf_solver_scene_bearing *H = &sc->bearings[j0 - nj_col + q];
                if (H->column != G->column) continue;
                if (H->x - 0.5 * H->side < x0) x0 = H->x - 0.5 * H->side;
                if (H->x + 0.5 * H->side > x1) x1 = H->x + 0.5 * H->side;
                if (H->y - 0.5 * H->side < y0) y0 = H->y - 0.5 * H->side;
                if (H->y + 0.5 * H->side > y1) y1 = H->y + 0.5 * H->side;
            }
            ext = 0.5 * (x1 - x0 < y1 - y0 ? x1 - x0 : y1 - y0);
            if (ext < info->beam_seat[r]) info->beam_seat[r] = ext;
            /* the seat's centre on this column (its bearings' stiffness-weighted centre), in the beam's frame */
            {
                double wx = 0.0, wy = 0.0, ws = 0.0, *gc = info->bear_gc + 3 * (j0 - nj_col + k);
                for (q = 0; q < info->beam_nj[r]; q++) {
                    const cf_solver_scene_bearing *H = &sc->bearings[j0 - nj_col + q];
                    double w = H->kn * H->side * H->side;
                    if (H->column != G->column) continue;
                    wx += w * H->x; wy += w * H->y; ws += w;
                }
                gc[0] = wx / ws - sc->beams[r].x; gc[1] = wy / ws - sc->beams[r].y; gc[2] = -0.5 * sc->beams[r].height;
            }
        }
    }
    return CF_OK;
}

int cf_solver_scene_build(cf_solver *s, const cf_solver_scene *sc)
{
    int c, b, r, st, nblk_col = 0, nj_col, seg = 0;
    double *col_r, *load;
    cf_geometry_massprops *bp;
    if (s->tilted)
        return cf_solver_fail(s, CF_EINVAL, "a scene (beams, several columns or connectors) stands on level ground: "
                              "foundation_tilt_rad must be 0, got %g", s->def.foundation_tilt_rad);
    for (c = 0; c < sc->n_columns; c++) nblk_col += sc->columns[c].n_blocks;
    nj_col = nblk_col;
    col_r = (double *)calloc((size_t)(sc->n_columns > 0 ? sc->n_columns : 1), sizeof(double));
    if (!col_r) return cf_solver_fail(s, CF_ENOMEM, "out of memory (scene)");
    for (c = 0, r = 0; c < sc->n_columns; c++) {
        col_r[c] = column_radius(sc, c, r, seg);
        for (b = 0; b < sc->columns[c].n_blocks; b++) seg += sc->n_segments[r + b];
        r += sc->columns[c].n_blocks;
    }
    st = check_parts(s, sc, col_r);
    free(col_r);
    if (st) return st;
    s->density = sc->density;
    s->nblk = nblk_col + sc->n_beams;
    s->nbody = s->nblk + 1;
    s->nj = nj_col + sc->n_bearings;
    st = cf_solver_stack_alloc(s, s->nblk, s->nbody, s->nj);
    if (st) return st;
    st = scene_map(s, sc, nj_col);
    if (st) return st;
    for (b = 0; b < sc->n_beams; b++)
        if (s->scene->beam_nj[b] == 0)
            return cf_solver_fail(s, CF_EINVAL, "beam %d does not reach two capitals (it rests on nothing): a beam spans two "
                                  "neighbouring columns", b);
    bp = (cf_geometry_massprops *)calloc((size_t)s->nblk, sizeof *bp);
    load = (double *)calloc((size_t)s->nj, sizeof(double));
    if (!bp || !load) { free(bp); free(load); return cf_solver_fail(s, CF_ENOMEM, "out of memory (scene)"); }
    s->m[0] = INFINITY;
    for (r = 0; r < 4 * s->nbody; r += 4) s->q0[r] = 1.0;
    for (c = 0, seg = 0; c < sc->n_columns; c++) {
        int k;
        column_build(s, sc, c, s->scene->col_blk0[c], s->scene->col_j0[c], seg, bp);
        for (k = 0; k < sc->columns[c].n_blocks; k++) seg += sc->n_segments[s->scene->col_blk0[c] + k];
    }
    for (b = 0; b < sc->n_beams; b++) beam_build(s, sc, b, nblk_col + b);
    for (r = 0; r < sc->n_bearings && !st; r++) st = bearing_build(s, sc, s->scene, r, nj_col + r);
    if (!st) st = bearing_loads(s, sc, s->scene, load);
    if (!st) st = rest_state(s, sc, s->scene, bp, load);
    if (!st) totals(s);
    free(bp); free(load);
    return st;
}
