/* Scenes and connectors through the C API (run under the sanitizers by make ctest-asan): a portal of
 * two prisms with a beam and dowels at rest and rocking, its outputs and histories, the refusal of bad
 * scenes and connectors, and the law's driver. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "cf_test.h"
#include "cf_common.h"
#include "solver.h"

/* Two square prisms 0.5 m x 2.5 m, 2 m apart, a beam 2.5 x 0.5 x 0.4 m bearing on both tops whole;
 * one titanium-like dowel at the centre of each base joint. */
typedef struct {
    cf_geometry_segment seg[2];
    int nseg[2];
    double kn[2], ks[2], mu[2];
    cf_solver_scene_column col[2];
    cf_solver_scene_beam beam;
    cf_solver_scene_bearing bear[2];
    cf_solver_connector conn[2];
    cf_solver_scene sc;
} portal;

static void portal_make(portal *p)
{
    int i;
    double r = 0.25 * sqrt(2.0);
    memset(p, 0, sizeof *p);
    for (i = 0; i < 2; i++) {
        cf_geometry_segment g = {2.5, r, r, 0.25 * CF_PI, 4, 1.0};
        p->seg[i] = g; p->nseg[i] = 1;
        p->kn[i] = 1e10; p->ks[i] = 1e10; p->mu[i] = 0.8;
        p->col[i].x = i == 0 ? -1.0 : 1.0; p->col[i].n_blocks = 1;
        p->bear[i].beam = 0; p->bear[i].column = i; p->bear[i].x = p->col[i].x; p->bear[i].side = 0.5;
        p->bear[i].kn = 1e10; p->bear[i].ks = 1e10; p->bear[i].mu = 0.8;
        p->conn[i].joint = i; p->conn[i].kind = CF_SOLVER_CONNECTOR_ELASTOPLASTIC; p->conn[i].k_shear = 5e7;
        p->conn[i].f_yield = 5e3; p->conn[i].u_ultimate = 0.01; p->conn[i].n_yield = INFINITY;
        p->conn[i].d_ultimate = INFINITY;
    }
    p->beam.length = 2.5; p->beam.width = 0.5; p->beam.height = 0.4; p->beam.density = 2700.0;
    p->sc.n_columns = 2; p->sc.columns = p->col; p->sc.n_segments = p->nseg; p->sc.segments = p->seg;
    p->sc.density = 2700.0; p->sc.kn = p->kn; p->sc.ks = p->ks; p->sc.mu = p->mu;
    p->sc.n_beams = 1; p->sc.beams = &p->beam; p->sc.n_bearings = 2; p->sc.bearings = p->bear;
    p->sc.n_connectors = 2; p->sc.connectors = p->conn;
}

/* At rest without ground motion: every body stays where it started (exact equilibrium). */
static void test_portal_at_rest(void)
{
    portal p;
    cf_solver_def d;
    cf_solver_result r;
    double acc[201] = {0}, pos[3 * 3 * 30], res[4], col[2 * CF_SOLVER_COLUMN_OUT], beam[CF_SOLVER_BEAM_OUT];
    int nc, nb, nd, nbl, nj, i;
    cf_solver *s = cf_solver_create();
    portal_make(&p);
    cf_solver_def_default(&d);
    d.tail_s = 0.0; d.history_dt = 0.1; d.early_exit = 0;
    CF_CHECK(cf_solver_setup_scene(s, &d, &p.sc) == CF_OK);
    CF_CHECK(cf_solver_counts(s, &nc, &nb, &nd, &nbl, &nj) == CF_OK);
    CF_CHECK(nc == 2 && nb == 1 && nd == 2 && nbl == 3 && nj == 4);
    CF_CHECK(cf_solver_set_history(s, 30, NULL, NULL, pos, NULL, NULL, NULL, NULL) == CF_OK);
    CF_CHECK(cf_solver_set_outputs(s, col, beam, NULL) == CF_OK);
    CF_CHECK(cf_solver_run(s, acc, NULL, NULL, 201, 0.01, res, &r) == CF_OK);
    CF_CHECK(r.n_history >= 20);
    for (i = 0; i < 9; i++) CF_CHECK_CLOSE(pos[9 * (r.n_history - 1) + i], pos[i], 1e-12);
    CF_CHECK(!r.collapsed && r.u_top < 1e-12 && col[0] < 1e-12 && beam[0] < 1e-12 && beam[3] == 0.0);
    cf_solver_free(s);
}

/* Rocking: dowels that yield report it, the connectors' energies in the history close the ledger. */
static void test_portal_rocks_with_dowels(void)
{
    portal p;
    cf_solver_def d;
    cf_solver_result r;
    enum { N = 301, CAP = 400 };
    double acc[N], res[4], col[2 * CF_SOLVER_COLUMN_OUT], beam[CF_SOLVER_BEAM_OUT], conn[2 * CF_SOLVER_CONNECTOR_OUT];
    double *en = (double *)calloc(CAP * 8, sizeof(double)), *cen = (double *)calloc(CAP * 2, sizeof(double));
    double *dow = (double *)calloc(CAP * 2 * 3, sizeof(double));
    int i;
    cf_solver *s = cf_solver_create();
    portal_make(&p);
    for (i = 0; i < N; i++) acc[i] = 4.0 * sin(2.0 * CF_PI * 1.5 * i * 0.01);
    cf_solver_def_default(&d);
    d.planar = 1; d.tail_s = 0.5; d.history_dt = 0.01; d.early_exit = 0;
    CF_CHECK(cf_solver_setup_scene(s, &d, &p.sc) == CF_OK);
    CF_CHECK(cf_solver_set_history(s, CAP, NULL, NULL, NULL, NULL, NULL, NULL, en) == CF_OK);
    CF_CHECK(cf_solver_set_history_connectors(s, cen, dow) == CF_OK);
    CF_CHECK(cf_solver_set_outputs(s, col, beam, conn) == CF_OK);
    CF_CHECK(cf_solver_run(s, acc, NULL, NULL, N, 0.01, res, &r) == CF_OK);
    CF_CHECK(r.u_top > 0.01 && r.energy_error < 0.05);
    CF_CHECK(conn[3] == 1.0 && conn[0] <= 5e3 * (1 + 1e-12) && conn[6] > 0.0);
    CF_CHECK_REL(cen[2 * (r.n_history - 1) + 1], conn[6] + conn[CF_SOLVER_CONNECTOR_OUT + 6], 1e-9);
    CF_CHECK(r.u_top == (col[0] > col[CF_SOLVER_COLUMN_OUT] ? col[0] : col[CF_SOLVER_COLUMN_OUT]));
    free(en); free(cen); free(dow);
    cf_solver_free(s);
}

static void test_bad_scenes(void)
{
    portal p;
    cf_solver_def d;
    cf_solver *s = cf_solver_create();
    cf_solver_def_default(&d);
    portal_make(&p);
    p.sc.n_bearings = 1;                              /* the beam rests on column 0 only */
    CF_CHECK(cf_solver_setup_scene(s, &d, &p.sc) == CF_EINVAL);
    CF_CHECK(strstr(cf_solver_message(s), "does not reach two capitals") != NULL);
    portal_make(&p);
    p.col[1].x = -0.5;                                /* the columns overlap */
    CF_CHECK(cf_solver_setup_scene(s, &d, &p.sc) == CF_EINVAL);
    CF_CHECK(strstr(cf_solver_message(s), "overlap") != NULL);
    portal_make(&p);
    p.conn[0].x = 0.3;                                /* a dowel off the face */
    CF_CHECK(cf_solver_setup_scene(s, &d, &p.sc) == CF_EINVAL);
    CF_CHECK(strstr(cf_solver_message(s), "lies outside the faces of joint 0") != NULL);
    portal_make(&p);
    p.conn[1].f_yield = NAN;
    CF_CHECK(cf_solver_setup_scene(s, &d, &p.sc) == CF_EINVAL);
    CF_CHECK(strstr(cf_solver_message(s), "f_yield must be > 0") != NULL);
    portal_make(&p);
    d.monolithic = 1;
    CF_CHECK(cf_solver_setup_scene(s, &d, &p.sc) == CF_EINVAL);
    CF_CHECK(cf_solver_dt(s) != cf_solver_dt(s));      /* nothing set up: NaN */
    cf_solver_free(s);
}

/* The law along 0 -> 3 mm -> 0: yield at F_y / k = 1 mm, unloading elastic about the offset 2 mm. */
static void test_drive(void)
{
    cf_solver_connector c;
    double u[3 * 61], f[3 * 61], v[61], ds[61];
    int st[61], i;
    char msg[CF_MSG_LEN];
    memset(&c, 0, sizeof c);
    c.kind = CF_SOLVER_CONNECTOR_ELASTOPLASTIC; c.k_shear = 1e7; c.f_yield = 1e4;
    c.u_ultimate = INFINITY; c.n_yield = INFINITY; c.d_ultimate = INFINITY;
    for (i = 0; i < 61; i++) { u[3 * i] = 1e-4 * (i <= 30 ? i : 60 - i); u[3 * i + 1] = 0; u[3 * i + 2] = 0; }
    CF_CHECK(cf_solver_connectors_drive(&c, 61, u, f, v, ds, st, msg) == CF_OK);
    CF_CHECK_REL(f[3 * 5], -5e3, 1e-9);
    CF_CHECK_REL(f[3 * 30], -1e4, 1e-12);
    CF_CHECK_REL(f[3 * 60], 1e4, 1e-9);               /* back at 0: the offset 2 mm, reverse yield reached */
    CF_CHECK(st[5] == 0 && st[30] == 1);
    CF_CHECK_REL(ds[30], 1e4 * 2e-3, 1e-9);
    c.law[0] = 0.001;   /* the elastoplastic law has no value of its own (a clearance) */
    CF_CHECK(cf_solver_connectors_drive(&c, 61, u, f, v, ds, st, msg) == CF_EINVAL);
    CF_CHECK(strstr(msg, "has no value law[0]") != NULL);
}

int main(void)
{
    CF_RUN(test_portal_at_rest);
    CF_RUN(test_portal_rocks_with_dowels);
    CF_RUN(test_bad_scenes);
    CF_RUN(test_drive);
    return CF_TEST_SUMMARY("test_scene");
}
