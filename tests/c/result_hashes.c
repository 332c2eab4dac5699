/*
 * result_hashes.c -- one line per solver configuration: a hash of every bit of its
 * result (EDPs, residual dislocations, energy ledger, full histories).
 *
 * Not a unit test (it asserts nothing by itself): scripts/check_result_hashes.sh builds
 * it twice, with the SIMD paths and with -DCF_NO_SIMD, and requires the two outputs to
 * be identical; the same output before and after a refactor shows that the refactor
 * kept results bit-identical.
 *
 * The scene is the default column (the numbers of Column.parthenon(): 12 ten-sided
 * drums and the capital) under a 2 Hz sine burst strong enough to rock, slide and
 * impact, run to 8 s with histories at every 10 ms; configurations cover each contact
 * model, planar, monolithic, two horizontal components plus a vertical one, damping,
 * a collapse and stiff joints (kn = ks = 1e10).
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cf_common.h"
#include "geometry.h"
#include "solver.h"

enum { NB = 13, NREC = 1201 };

static unsigned long long hash_bytes(unsigned long long h, const void *p, size_t n)
{
    const unsigned char *c = (const unsigned char *)p;
    size_t i;
    for (i = 0; i < n; i++) { h ^= c[i]; h *= 1099511628211ULL; }   /* FNV-1a */
    return h;
}

static void column(cf_geometry_segment *seg, int *nseg)
{
    static const double r[13] = {0.825, 0.8095833333333333, 0.7941666666666666, 0.7787499999999999,
                                 0.7633333333333333, 0.7479166666666667, 0.7324999999999999,
                                 0.7170833333333333, 0.7016666666666667, 0.68625, 0.6708333333333333,
                                 0.6554166666666666, 0.64};
    int i;
    for (i = 0; i < 12; i++) {
        seg[i].height = 0.7816666666666667;
        seg[i].r_bottom = r[i]; seg[i].r_top = r[i + 1];
        seg[i].phase_rad = 0.0; seg[i].n_sides = 10;
        nseg[i] = 1;
    }
    seg[12].height = 0.4; seg[12].r_bottom = 0.64; seg[12].r_top = 0.83; seg[12].phase_rad = 0.0;
    seg[12].n_sides = 10;
    seg[13].height = 0.3; seg[13].r_bottom = 1.2232947314527272; seg[13].r_top = 1.2232947314527272;
    seg[13].phase_rad = 0.7853981633974483; seg[13].n_sides = 4;
    nseg[12] = 2;
}

typedef struct {
    const char *name;
    int contact, ppe, planar, mono, two, damp;
    double amp_g, dtf;
    double kn;             /* joint stiffness kn = ks, Pa/m; 0 = the default 1e9 */
} config;

static int run(const config *c)
{
    cf_geometry_segment seg[NB + 1];
    int nseg[NB], i, cap, st;
    double ax[NREC], ay[NREC], az[NREC], resid[NB], dtr = 0.005;
    double *buf;
    size_t nbuf;
    cf_solver_def def;
    cf_solver_result res;
    cf_solver *s = cf_solver_create();
    unsigned long long h = 1469598103934665603ULL;
    if (!s) return 1;
    column(seg, nseg);
    for (i = 0; i < NREC; i++) {
        double t = i * dtr, env = t < 3.0 ? 1.0 : 0.0;
        /* polynomial burst (no libm in the input: the hashes must not depend on it) */
        double ph = 4.0 * t - floor(4.0 * t), tri = 4.0 * fabs(ph - 0.5) - 1.0;
        ax[i] = c->amp_g * 9.81 * env * tri;
        ay[i] = 0.6 * c->amp_g * 9.81 * env * (1.0 - 2.0 * fabs(2.0 * (2.6 * t - floor(2.6 * t)) - 1.0));
        az[i] = 0.3 * c->amp_g * 9.81 * env * tri * tri;
    }
    cf_solver_def_default(&def);
    def.contact = c->contact; def.points_per_edge = c->ppe; def.planar = c->planar;
    def.monolithic = c->mono; def.dt_factor = c->dtf; def.early_exit = 0;
    def.tail_s = 2.0;
    if (c->damp) { def.damping_alpha = 0.5; def.damping_start_s = 3.0; }
    {
        double kn = c->kn > 0 ? c->kn : 1e9;
        st = cf_solver_setup(s, &def, NB, nseg, seg, 2700.0, kn, kn, 0.7535540501027942);
    }
    if (st) { printf("%-14s setup failed: %s\n", c->name, cf_solver_message(s)); cf_solver_free(s); return 1; }
    cap = cf_solver_history_capacity(s, NREC, dtr);
    /* t, top (2), pos (3 NB), quat (4 NB), open (NB), slip (2 NB), energy (8), normal (NB) */
    nbuf = (size_t)cap * (1 + 2 + 11 * NB + 8 + NB);
    buf = (double *)calloc(nbuf, sizeof(double));
    if (!buf) { cf_solver_free(s); return 1; }
    {
        double *p = buf;
        double *t = p; p += cap;
        double *top = p; p += 2 * (size_t)cap;
        double *pos = p; p += 3 * (size_t)cap * NB;
        double *quat = p; p += 4 * (size_t)cap * NB;
        double *open = p; p += (size_t)cap * NB;
        double *slip = p; p += 2 * (size_t)cap * NB;
        double *en = p; p += 8 * (size_t)cap;
        cf_solver_set_history(s, cap, t, top, pos, quat, open, slip, en);
        cf_solver_set_history_normal(s, p);
    }
    st = cf_solver_run(s, ax, c->two ? ay : NULL, c->two ? az : NULL, NREC, dtr, resid, &res);
    h = hash_bytes(h, &res.u_top, sizeof res.u_top);
    h = hash_bytes(h, &res.u_d, sizeof res.u_d);
    h = hash_bytes(h, &res.energy_error, sizeof res.energy_error);
    h = hash_bytes(h, &res.n_steps, sizeof res.n_steps);
    h = hash_bytes(h, &res.collapsed, sizeof res.collapsed);
    h = hash_bytes(h, &res.collapse_block, sizeof res.collapse_block);
    h = hash_bytes(h, resid, sizeof resid);
    h = hash_bytes(h, buf, nbuf * sizeof(double));
    printf("%-14s status %d steps %ld u_top %.12g u_d %.6g err %.3g collapsed %d/%d | hash %016llx\n", c->name, st,
           res.n_steps, res.u_top, res.u_d, res.energy_error, res.collapsed, res.collapse_block, h);
    free(buf);
    cf_solver_free(s);
    return 0;
}

int main(void)
{
    static const config cs[] = {
        {"vertex", CF_SOLVER_CONTACT_VERTEX, 1, 0, 0, 0, 0, 0.25, 0.8, 0},
        {"vertex-2c", CF_SOLVER_CONTACT_VERTEX, 1, 0, 0, 1, 0, 0.25, 0.8, 0},
        {"vertex-damp", CF_SOLVER_CONTACT_VERTEX, 1, 0, 0, 0, 1, 0.25, 0.8, 0},
        {"vertex-strong", CF_SOLVER_CONTACT_VERTEX, 1, 0, 0, 1, 0, 0.6, 0.8, 0},
        {"perimeter2", CF_SOLVER_CONTACT_PERIMETER, 2, 0, 0, 0, 0, 0.25, 0.8, 0},
        {"perimeter3-2c", CF_SOLVER_CONTACT_PERIMETER, 3, 0, 0, 1, 0, 0.25, 0.8, 0},
        {"exact", CF_SOLVER_CONTACT_EXACT, 1, 0, 0, 0, 0, 0.25, 0.8, 0},
        {"exact-2c", CF_SOLVER_CONTACT_EXACT, 1, 0, 0, 1, 0, 0.4, 0.8, 0},
        {"planar", CF_SOLVER_CONTACT_VERTEX, 1, 1, 0, 0, 0, 0.25, 0.8, 0},
        {"mono", CF_SOLVER_CONTACT_VERTEX, 1, 0, 1, 0, 0, 0.25, 0.8, 0},
        {"collapse", CF_SOLVER_CONTACT_VERTEX, 1, 0, 0, 1, 0, 1.6, 0.8, 0},
        {"vertex-dt04", CF_SOLVER_CONTACT_VERTEX, 1, 0, 0, 1, 0, 0.3, 0.4, 0},
        /* stiff joints: impacts last fewer steps (the hard case of docs/accuracy.md) */
        {"stiff-2c", CF_SOLVER_CONTACT_VERTEX, 1, 0, 0, 1, 0, 0.5, 0.8, 1e10},
        {"stiff-exact", CF_SOLVER_CONTACT_EXACT, 1, 0, 0, 1, 0, 0.5, 0.8, 1e10},
    };
    size_t i;
    int bad = 0;
    for (i = 0; i < sizeof cs / sizeof cs[0]; i++) bad |= run(&cs[i]);
    return bad;
}
