/*
 * solver_face_points.c -- the sub-contact points of every joint's faces, for the contact models
 * that carry points (solver_points.c; declared in solver_internal.h): the polygon vertices or the
 * nodes of a refined face mesh, with their area weights, then the planar mirror and the dropping
 * of a face that lies off the other. Set-up only; the model that asks keeps what it needs in its
 * own state and frees the rest with cf_solver_face_points_free.
 */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "solver_internal.h"

/* Sub-contact points of one face (body frame), weights summing to wsum.
 * m = 0: the n vertices; m >= 1: nodes of the fan triangulation refined m times (m
 * points per polygon edge, interior nodes too), lumped (trapezoidal) area weights,
 * which converge to the exact interface as m grows.
 * Writes up to count_face_points() entries; returns the count. */
static int count_face_points(int n, int m)
{
    if (m == 0) return n;
    return 1 + n * m * (m + 1) / 2;
}

static int face_points(const cf_face *f, int m, double wsum, double *loc, double *wt)
{
    int k, c = 0, ring, t;
    if (m == 0) {
        for (k = 0; k < f->n; k++) {
            loc[3 * c] = f->c[0] + f->vx[k]; loc[3 * c + 1] = f->c[1] + f->vy[k]; loc[3 * c + 2] = f->c[2];
            wt[c++] = wsum / f->n;
        }
        return c;
    }
    {
        double at = wsum / f->n / ((double)m * m) / 3.0;   /* one third of a sub-triangle */
        loc[0] = f->c[0]; loc[1] = f->c[1]; loc[2] = f->c[2];
        wt[0] = at * f->n;
        c = 1;
        for (ring = 1; ring <= m; ring++) {
            double sc = (double)ring / m;
            for (k = 0; k < f->n; k++) {
                int k1 = (k + 1) % f->n;
                for (t = 0; t < ring; t++) {
                    double u = (double)t / ring;
                    int cnt;
                    loc[3 * c] = f->c[0] + sc * (f->vx[k] + u * (f->vx[k1] - f->vx[k]));
                    loc[3 * c + 1] = f->c[1] + sc * (f->vy[k] + u * (f->vy[k1] - f->vy[k]));
                    loc[3 * c + 2] = f->c[2];
                    if (ring < m) cnt = 6;
                    else cnt = (t == 0) ? 2 : 3;
                    wt[c++] = at * cnt;
                }
            }
        }
    }
    return c;
}

/* An as-built joint's points (solver_as_built.c): those of its contact region, the overlap polygon of
 * its faces at rest, on the body of side (0: the upper, 1: the lower), weights summing to wsum. The
 * polygon is fanned from its centroid; m = 0: its vertices, each with half the area of the two fan
 * triangles beside it (their centroid is the polygon's); m >= 1: the nodes of every fan triangle refined
 * m times (ring i, fan k, place t as face_points orders them), each with a third of the area of every
 * sub-triangle it is a corner of. Returns the count (count_face_points(cn, m)). */
static int node_of(int n, int i, int k, int t)
{
    if (i == 0) return 0;
    if (t == i) { k = k + 1 == n ? 0 : k + 1; t = 0; }
    return 1 + n * i * (i - 1) / 2 + k * i + t;
}

/* The points of a chipped joint's annulus (chole > 0): per fan sector the trapezoid between the
 * region scaled by chole and the region, as a grid of M = max(m, 1) steps each way (rings i from the
 * inner boundary out, places t along the sector), each quad split into two triangles whose thirds go to
 * their corners (the lumping keeps the area and its centroid). m = 0: the inner and outer vertices. */
static int count_annulus_points(int n, int m)
{
    int M = m > 0 ? m : 1;
    return (M + 1) * n * M;
}

static int annulus_node(int n, int M, int i, int k, int t)
{
    if (t == M) { k = k + 1 == n ? 0 : k + 1; t = 0; }
    return i * n * M + k * M + t;
}

static int annulus_points(const cf_joint *J, int m, int side, double wsum, double ox, double oy, double z,
                          double *loc, double *wt)
{
    int n = J->cn, M = m > 0 ? m : 1, k, i, t, c, np = count_annulus_points(n, m);
    double cx = J->ccen[0], cy = J->ccen[1], sc = wsum / J->area, h = J->chole;
    (void)side;
    for (c = 0; c < np; c++) wt[c] = 0.0;
    for (k = 0; k < n; k++) {
        int k1 = k + 1 == n ? 0 : k + 1;
        double ax = J->cpoly[2 * k] - cx, ay = J->cpoly[2 * k + 1] - cy;
        double bx = J->cpoly[2 * k1] - cx, by = J->cpoly[2 * k1 + 1] - cy;
        for (i = 0; i <= M; i++)
            for (t = 0; t < M; t++) {
                double f = h + (1.0 - h) * i / M, u = (double)t / M;
                c = annulus_node(n, M, i, k, t);
                loc[3 * c] = ox + cx + f * (ax + u * (bx - ax));
                loc[3 * c + 1] = oy + cy + f * (ay + u * (by - ay));
                loc[3 * c + 2] = z;
            }
    }
    for (k = 0; k < n; k++)   /* the weights, once every sector's nodes are placed */
        for (i = 0; i < M; i++)
            for (t = 0; t < M; t++) {
                int q[4], e;
                double P[4][2];
                q[0] = annulus_node(n, M, i, k, t); q[1] = annulus_node(n, M, i + 1, k, t);
                q[2] = annulus_node(n, M, i + 1, k, t + 1); q[3] = annulus_node(n, M, i, k, t + 1);
                for (e = 0; e < 4; e++) { P[e][0] = loc[3 * q[e]]; P[e][1] = loc[3 * q[e] + 1]; }
                for (e = 0; e < 2; e++) {   /* triangles (0, 1, 2) and (0, 2, 3) */
                    int a = 0, b = 1 + e, d = 2 + e;
                    double tri = 0.5 * ((P[b][0] - P[a][0]) * (P[d][1] - P[a][1]) - (P[b][1] - P[a][1]) * (P[d][0] - P[a][0]));
                    wt[q[a]] += sc * tri / 3.0; wt[q[b]] += sc * tri / 3.0; wt[q[d]] += sc * tri / 3.0;
                }
            }
    return np;
}

/* The points of a chipped joint missing a sector (csec): the open fan of its chain cpoly (cn vertices) about
 * the face centre, each fan triangle's band between the scales chole and 1 a grid of M = max(m, 1) steps each
 * way (ring i from the inner boundary out, place p along the chain), each quad split into two triangles whose
 * thirds go to their corners (the lumping keeps the region's area and centroid); without a hole the innermost
 * ring is the face centre, one point. m = 0: the centre (or the inner chain) and the chain's vertices. */
static int count_sector_points(int n, int m, int hole)
{
    int M = m > 0 ? m : 1, along = (n - 1) * M + 1;
    return hole ? (M + 1) * along : 1 + M * along;
}

static int sector_node(int along, int i, int p, int hole)
{
    if (hole) return i * along + p;
    return i == 0 ? 0 : 1 + (i - 1) * along + p;
}

static int sector_points(const cf_joint *J, int m, double wsum, double ox, double oy, double z, double *loc, double *wt)
{
    int n = J->cn, M = m > 0 ? m : 1, along = (n - 1) * M + 1, hole = J->chole > 0.0, i, p, c;
    int np = count_sector_points(n, m, hole);
    double sc = wsum / J->area, h = J->chole;
    for (c = 0; c < np; c++) wt[c] = 0.0;
    for (i = 0; i <= M; i++)
        for (p = 0; p < along; p++) {
            int k = p / M < n - 1 ? p / M : n - 2;
            double f = h + (1.0 - h) * i / M, u = (double)(p - k * M) / M;
            const double *a = J->cpoly + 2 * k, *b = a + 2;
            c = sector_node(along, i, p, hole);
            loc[3 * c] = ox + f * (a[0] + u * (b[0] - a[0]));
            loc[3 * c + 1] = oy + f * (a[1] + u * (b[1] - a[1]));
            loc[3 * c + 2] = z;
        }
    for (i = 0; i < M; i++)   /* the weights, once every node is placed */
        for (p = 0; p + 1 < along; p++) {
            int q[4], e;
            q[0] = sector_node(along, i, p, hole); q[1] = sector_node(along, i + 1, p, hole);
            q[2] = sector_node(along, i + 1, p + 1, hole); q[3] = sector_node(along, i, p + 1, hole);
            for (e = 0; e < 2; e++) {   /* triangles (0, 1, 2) and (0, 2, 3) */
                const double *A = loc + 3 * q[0], *B = loc + 3 * q[1 + e], *D = loc + 3 * q[2 + e];
                double tri = 0.5 * ((B[0] - A[0]) * (D[1] - A[1]) - (B[1] - A[1]) * (D[0] - A[0]));
                wt[q[0]] += sc * tri / 3.0; wt[q[1 + e]] += sc * tri / 3.0; wt[q[2 + e]] += sc * tri / 3.0;
            }
        }
    return np;
}

static int overlap_points(const cf_joint *J, int m, int side, double wsum, double *loc, double *wt)
{
    int n = J->cn, k, i, t, c, np = count_face_points(n, m);
    const cf_face *own = side == 0 ? &J->fu : &J->fl;
    double cx = J->ccen[0], cy = J->ccen[1], sc = wsum / J->area;
    /* the body frame of side's face: the lower face's frame shifted by -d0 on the upper body */
    double ox = own->c[0] - (side == 0 ? J->d0[0] : 0.0), oy = own->c[1] - (side == 0 ? J->d0[1] : 0.0);
    if (J->csec) return sector_points(J, m, wsum, ox, oy, own->c[2], loc, wt);
    if (J->chole > 0.0) return annulus_points(J, m, side, wsum, ox, oy, own->c[2], loc, wt);
    for (c = 0; c < np; c++) wt[c] = 0.0;
    for (k = 0; k < n; k++) {
        int k1 = k + 1 == n ? 0 : k + 1;
        double ax = J->cpoly[2 * k] - cx, ay = J->cpoly[2 * k + 1] - cy;
        double bx = J->cpoly[2 * k1] - cx, by = J->cpoly[2 * k1 + 1] - cy;
        double tri = 0.5 * (ax * by - ay * bx) * sc;   /* the fan triangle's share of wsum */
        if (m == 0) {
            wt[k] += 0.5 * tri; wt[k1] += 0.5 * tri;
            loc[3 * k] = ox + J->cpoly[2 * k]; loc[3 * k + 1] = oy + J->cpoly[2 * k + 1]; loc[3 * k + 2] = own->c[2];
            continue;
        }
        for (i = 1; i <= m; i++)
            for (t = 0; t < i; t++) {
                double f = (double)i / m, u = (double)t / i;
                c = node_of(n, i, k, t);
                loc[3 * c] = ox + cx + f * (ax + u * (bx - ax));
                loc[3 * c + 1] = oy + cy + f * (ay + u * (by - ay));
                loc[3 * c + 2] = own->c[2];
            }
        for (i = 0; i < m; i++) {   /* the m^2 sub-triangles between rings i and i + 1 */
            double a3 = tri / ((double)m * m) / 3.0;
            for (t = 0; t <= i; t++) {
                wt[node_of(n, i, k, t)] += a3; wt[node_of(n, i + 1, k, t)] += a3; wt[node_of(n, i + 1, k, t + 1)] += a3;
                if (t < i) { wt[node_of(n, i, k, t)] += a3; wt[node_of(n, i, k, t + 1)] += a3; wt[node_of(n, i + 1, k, t + 1)] += a3; }
            }
        }
    }
    if (m > 0) { loc[0] = ox + cx; loc[1] = oy + cy; loc[2] = own->c[2]; }
    return np;
}

/* Point k moves to place c (c <= k) with its weight times scale. */
static void keep_point(cf_face_points *fp, int c, int k, double scale)
{
    fp->side[c] = fp->side[k];
    memmove(fp->loc + 3 * c, fp->loc + 3 * k, 3 * sizeof(double));
    fp->w[c] = scale * fp->w[k];
}

/* Has every vertex of face f a mirror vertex about the x-z plane? */
static int face_symmetric(const cf_face *f)
{
    int k, m2;
    for (k = 0; k < f->n; k++) {
        for (m2 = 0; m2 < f->n; m2++)
            if (fabs(f->vx[m2] - f->vx[k]) < 1e-12 * f->rc && fabs(f->vy[m2] + f->vy[k]) < 1e-12 * f->rc) break;
        if (m2 == f->n) return 0;
    }
    return 1;
}

/* Planar mode with faces symmetric about the x-z plane: the motion is symmetric, so a point at
 * -y mirrors its twin at +y; keep one of each pair with twice its weight (the out-of-plane force
 * and moments they would cancel are discarded anyway). Returns the new count. */
static int planar_mirror(const cf_solver *s, cf_face_points *fp)
{
    int j, k, c = 0;
    for (j = 0; j < s->nj; j++)   /* an as-built joint's overlap, a face centred off its body's x-z plane: not mirrored */
        if (s->jt[j].asb || (s->asb && (s->jt[j].fl.c[1] != 0.0 || s->jt[j].fu.c[1] != 0.0)) || !face_symmetric(&s->jt[j].fl)
            || !face_symmetric(&s->jt[j].fu))
            return fp->np;
    for (j = 0; j < s->nj; j++) {
        int start = c, n0 = 0;
        double r = s->jt[j].fu.rc;
        for (k = fp->p0[j]; k < fp->p0[j] + fp->n[j]; k++) {
            double y = fp->loc[3 * k + 1], scale = 1.0;
            if (y < -1e-9 * r) continue;
            if (y > 1e-9 * r) scale = 2.0;
            keep_point(fp, c, k, scale);
            if (k < fp->p0[j] + fp->n0[j]) n0++;
            c++;
        }
        fp->p0[j] = start; fp->n[j] = c - start; fp->n0[j] = n0;
    }
    return c;
}

/* A joint whose faces differ much in size (a narrow block on a wide drum): when none
 * of one face's points lies on the other face at rest, those points would never bear
 * and their half of the joint area would be lost (halving the joint's stiffness: a
 * slender block then rocks on springs too soft to hold it up). They are dropped and
 * the other face's points carry the whole area. When both faces have points on the
 * other (every joint of the default column), nothing changes. Returns the new count. */
static int drop_faces_off_the_other(const cf_solver *s, cf_face_points *fp)
{
    int j, k, c = 0;
    for (j = 0; j < s->nj; j++) {
        const cf_joint *J = &s->jt[j];
        int in[2] = {0, 0}, drop = -1, start = c, n0 = 0;
        for (k = fp->p0[j]; k < fp->p0[j] + fp->n[j]; k++) {
            int side = fp->side[k];
            const cf_face *own = side == 0 ? &J->fu : &J->fl, *oth = side == 0 ? &J->fl : &J->fu;
            in[side] += cf_face_inside(oth, fp->loc[3 * k] - own->c[0], fp->loc[3 * k + 1] - own->c[1],
                                       1e-9 * oth->rc);
        }
        if (J->bl != 0 && !J->asb && fp->n0[j] > 0 && fp->n[j] > fp->n0[j]) {   /* an overlap's lie on both */
            if (in[1] == 0 && in[0] > 0) drop = 1;
            else if (in[0] == 0 && in[1] > 0) drop = 0;
        }
        for (k = fp->p0[j]; k < fp->p0[j] + fp->n[j]; k++) {
            if (fp->side[k] == drop) continue;
            keep_point(fp, c, k, drop >= 0 ? 2.0 : 1.0);
            if (fp->side[c] == 0) n0++;
            c++;
        }
        fp->p0[j] = start; fp->n[j] = c - start; fp->n0[j] = n0;
    }
    return c;
}

void cf_solver_face_points_free(cf_face_points *fp)
{
    free(fp->side); free(fp->loc); free(fp->w); free(fp->p0); free(fp->n); free(fp->n0);
    memset(fp, 0, sizeof *fp);
}

/* The points of every joint, mm per edge (0: the vertices); CF_ENOMEM with a message on s. */
int cf_solver_face_points_make(cf_solver *s, int mm, cf_face_points *fp)
{
    int j, k, np = 0, nj = s->nj, c = 0;
    size_t nja = (size_t)(nj > 0 ? nj : 1);
    memset(fp, 0, sizeof *fp);
    for (j = 0; j < nj; j++)
        np += s->jt[j].asb ? (s->jt[j].bl == 0 ? 1 : 2) * (s->jt[j].csec ? count_sector_points(s->jt[j].cn, mm, s->jt[j].chole > 0.0)
                                                           : s->jt[j].chole > 0.0 ? count_annulus_points(s->jt[j].cn, mm)
                                                                                  : count_face_points(s->jt[j].cn, mm))
                           : count_face_points(s->jt[j].fu.n, mm) + (s->jt[j].bl == 0 ? 0 : count_face_points(s->jt[j].fl.n, mm));
    fp->side = (int *)calloc((size_t)(np > 0 ? np : 1), sizeof(int));
    fp->loc = (double *)calloc((size_t)(np > 0 ? np : 1) * 3, sizeof(double));
    fp->w = (double *)calloc((size_t)(np > 0 ? np : 1), sizeof(double));
    fp->p0 = (int *)calloc(nja, sizeof(int));
    fp->n = (int *)calloc(nja, sizeof(int));
    fp->n0 = (int *)calloc(nja, sizeof(int));
    if (!fp->side || !fp->loc || !fp->w || !fp->p0 || !fp->n || !fp->n0) {
        cf_solver_face_points_free(fp);
        return cf_solver_fail(s, CF_ENOMEM, "out of memory");
    }
    for (j = 0; j < nj; j++) {
        const cf_joint *J = &s->jt[j];
        int n1, n2;
        fp->p0[j] = c;
        /* the ground (under a column, joint 0 of a single one) is unbounded: the block's own points carry the whole area */
        if (J->asb) n1 = overlap_points(J, mm, 0, (J->bl == 0 ? 1.0 : 0.5) * J->area, fp->loc + 3 * c, fp->w + c);
        else n1 = face_points(&J->fu, mm, (J->bl == 0 ? 1.0 : 0.5) * J->area, fp->loc + 3 * c, fp->w + c);
        for (k = 0; k < n1; k++) fp->side[c + k] = 0;
        c += n1;
        if (J->asb && J->bl != 0) n2 = overlap_points(J, mm, 1, 0.5 * J->area, fp->loc + 3 * c, fp->w + c);
        else n2 = J->bl == 0 ? 0 : face_points(&J->fl, mm, 0.5 * J->area, fp->loc + 3 * c, fp->w + c);
        for (k = 0; k < n2; k++) fp->side[c + k] = 1;
        c += n2;
        fp->n[j] = n1 + n2;
        fp->n0[j] = n1;
    }
    fp->np = c;
    if (s->def.planar) fp->np = planar_mirror(s, fp);
    fp->np = drop_faces_off_the_other(s, fp);
    return CF_OK;
}
