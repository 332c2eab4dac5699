/*
 * test_batch.c -- cf_solver_batch_run (solver_batch.h): its argument checks, a refused job,
 * short runs of every width equal to cf_solver_run, and the order in which the lanes take the
 * jobs (longest record first, seen through which runs a stop of the caller leaves unstarted).
 * Small enough for the AddressSanitizer build of CI (make ctest-asan), which checks the batch's
 * memory handling; scripts/check_result_hashes.sh compares every bit of long batches with
 * single runs in every SIMD build.
 *
 * The reference of each equality is cf_solver_run on a freshly set-up solver, so the tolerance is
 * zero: the batch must do each run's operations in the single run's order.
 */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "cf_test.h"
#include "solver.h"
#include "solver_batch.h"

enum { NB = 3, NREC = 301, NJ = 6 };

/* three drums of 0.5 m radius, 1 m high, on the ground */
static cf_solver *column(int contact, int early_exit)
{
    cf_geometry_segment seg[NB] = {{0}};
    int nseg[NB], i;
    cf_solver_def def;
    cf_solver *s = cf_solver_create();
    for (i = 0; i < NB; i++) {
        seg[i].height = 1.0; seg[i].r_bottom = 0.5; seg[i].r_top = 0.5; seg[i].phase_rad = 0.0;
        seg[i].n_sides = 8; nseg[i] = 1;
    }
    cf_solver_def_default(&def);
    def.contact = contact; def.early_exit = early_exit; def.tail_s = 0.5;
    if (!s || cf_solver_setup(s, &def, NB, nseg, seg, 2500.0, 1e9, 1e9, 0.7)) { cf_solver_free(s); return NULL; }
    return s;
}

/* a 2 Hz triangle burst of amplitude a (g); the record's samples past n are not used */
static void burst(double a, double *acc)
{
    int i;
    for (i = 0; i < NREC; i++) {
        double t = i * 0.01, ph = 2.0 * t - floor(2.0 * t);
        acc[i] = a * 9.81 * (4.0 * fabs(ph - 0.5) - 1.0);
    }
}

static void test_arguments(void)
{
    cf_solver *s = cf_solver_create(), *t = column(CF_SOLVER_CONTACT_VERTEX, 1);
    cf_solver_batch_job job;
    cf_solver_batch_out out;
    double acc[NREC];
    burst(0.1, acc);
    memset(&job, 0, sizeof job);
    job.acc_x = acc; job.n = NREC; job.dt_rec = 0.01;
    CF_CHECK(cf_solver_batch_run(NULL, 0, 1, &job, &out) == CF_EINVAL);
    CF_CHECK(cf_solver_batch_run(s, 0, 1, &job, &out) == CF_ESTATE);   /* not set up */
    CF_CHECK(cf_solver_batch_max_width(s) == 0 && cf_solver_batch_width(s, 10) == 0);
    CF_CHECK(t != NULL);
    if (t) {
        int w = cf_solver_batch_max_width(t);
        CF_CHECK(w == 1 || w == 2 || w == 4 || w == 8);
        CF_CHECK(cf_solver_batch_run(t, 3, 1, &job, &out) == CF_EINVAL);
        CF_CHECK(strstr(cf_solver_message(t), "width must be") != NULL);
        CF_CHECK(cf_solver_batch_run(t, 16, 1, &job, &out) == CF_EINVAL);
        CF_CHECK(cf_solver_batch_run(t, 0, -1, &job, &out) == CF_EINVAL);
        CF_CHECK(cf_solver_batch_run(t, 0, 1, NULL, &out) == CF_EINVAL);
        CF_CHECK(cf_solver_batch_run(t, 0, 0, NULL, NULL) == CF_OK);
        /* one or two runs: one after the other (idle lanes would cost more) */
        CF_CHECK(cf_solver_batch_width(t, 1) == 1 && cf_solver_batch_width(t, 2) == 1);
    }
    cf_solver_free(s);
    cf_solver_free(t);
}

/* jobs of different amplitudes and lengths (lanes refilled), one refused (dt_rec < 0); each run
 * of every width bitwise the single run */
static void check_equal(int contact, int early_exit)
{
    static const double amp[NJ] = {0.3, 0.05, 0.6, 0.2, 0.4, 0.1};
    static const int len[NJ] = {NREC, 120, NREC, 200, 60, NREC};
    double acc[NJ][NREC], resid[NJ][NB], ref_resid[NJ][NB];
    cf_solver_batch_job jobs[NJ];
    cf_solver_batch_out out[NJ], ref[NJ];
    cf_solver *s = column(contact, early_exit);
    int i, w;
    CF_CHECK(s != NULL);
    if (!s) return;
    for (i = 0; i < NJ; i++) {
        cf_solver *one = column(contact, early_exit);
        burst(amp[i], acc[i]);
        memset(&jobs[i], 0, sizeof jobs[i]);
        jobs[i].acc_x = acc[i]; jobs[i].n = len[i]; jobs[i].dt_rec = i == 3 ? -1.0 : 0.01;
        jobs[i].residual_dislocation = resid[i];
        memset(&ref[i], 0, sizeof ref[i]);
        ref[i].status = cf_solver_run(one, jobs[i].acc_x, NULL, NULL, jobs[i].n, jobs[i].dt_rec, ref_resid[i],
                                      &ref[i].result);
        strcpy(ref[i].message, cf_solver_message(one));
        cf_solver_free(one);
    }
    CF_CHECK(ref[3].status == CF_EINVAL && ref[0].status == CF_OK);
    for (w = 1; w <= cf_solver_batch_max_width(s); w *= 2) {
        memset(out, 0xff, sizeof out);
        memset(resid, 0, sizeof resid);
        CF_CHECK(cf_solver_batch_run(s, w, NJ, jobs, out) == CF_OK);
        for (i = 0; i < NJ; i++) {
            CF_CHECK(out[i].status == ref[i].status);
            CF_CHECK(strcmp(out[i].message, ref[i].message) == 0);
            CF_CHECK(memcmp(&out[i].result, &ref[i].result, sizeof ref[i].result) == 0);
            if (ref[i].status == CF_OK) CF_CHECK(memcmp(resid[i], ref_resid[i], sizeof resid[i]) == 0);
        }
    }
    cf_solver_free(s);
}

static int stop_now(void *user)
{
    ++*(int *)user;
    return 1;
}

/* The lanes take the jobs longest record first: a batch stopped by the caller's check at its
 * first call (after CF_SOLVER_CHECK_STEPS steps) has stopped the runs of the longest records,
 * one per lane, and not started the rest, the shortest -- here the first jobs, which are given
 * in the order of increasing length. */
static void test_stop_takes_longest_first(void)
{
    enum { NS = 10, NL = 3000 };
    static double acc[NL];
    double resid[NS][NB];
    cf_solver_batch_job jobs[NS];
    cf_solver_batch_out out[NS];
    cf_solver *s = column(CF_SOLVER_CONTACT_VERTEX, 0);
    int i, w, calls = 0;
    CF_CHECK(s != NULL);
    if (!s) return;
    w = cf_solver_batch_max_width(s);
    /* records of 10 to 28 s: every run is longer than CF_SOLVER_CHECK_STEPS steps of this column */
    for (i = 0; i < NL; i++) acc[i] = 0.5 * sin(12.0 * i * 0.01);
    for (i = 0; i < NS; i++) {
        memset(&jobs[i], 0, sizeof jobs[i]);
        jobs[i].acc_x = acc; jobs[i].n = 1000 + 200 * i; jobs[i].dt_rec = 0.01;
        jobs[i].residual_dislocation = resid[i];
    }
    cf_solver_set_check(s, stop_now, &calls);
    CF_CHECK(cf_solver_batch_run(s, w, NS, jobs, out) == CF_OK);
    CF_CHECK(calls == 1);
    for (i = 0; i < NS; i++) {
        int started = w == 1 ? i == 0 : i >= NS - w;   /* one at a time: in job order */
        CF_CHECK(out[i].status == CF_EINTR);
        CF_CHECK(strstr(out[i].message, started ? "stopped by the caller at" : "before this run started") != NULL);
    }
    cf_solver_free(s);
}

/* The column of column() with three connectors, one per law and both parts of the common law: an
 * elastoplastic dowel off the base joint's centre (its force has a moment about the drums' centres)
 * with an axial part, a clearance dowel in joint 1, an elastoplastic one in joint 2 that breaks. */
static cf_solver *dowelled(int early_exit)
{
    cf_geometry_segment seg[NB] = {{0}};
    int nseg[NB], i;
    double kn[NB], ks[NB], mu[NB];
    cf_solver_scene_column col;
    cf_solver_connector c[3];
    cf_solver_scene sc;
    cf_solver_def def;
    cf_solver *s = cf_solver_create();
    for (i = 0; i < NB; i++) {
        seg[i].height = 1.0; seg[i].r_bottom = 0.5; seg[i].r_top = 0.5; seg[i].phase_rad = 0.0;
        seg[i].n_sides = 8; nseg[i] = 1; kn[i] = 1e9; ks[i] = 1e9; mu[i] = 0.7;
    }
    memset(c, 0, sizeof c);
    for (i = 0; i < 3; i++) {
        c[i].joint = i; c[i].k_shear = 1e7; c[i].f_yield = 4e3; c[i].u_ultimate = 0.03;
        c[i].n_yield = INFINITY; c[i].d_ultimate = INFINITY;
    }
    c[0].kind = CF_SOLVER_CONNECTOR_ELASTOPLASTIC; c[0].x = 0.2; c[0].y = -0.1; c[0].k_axial = 5e6;
    c[0].n_yield = 2e3; c[0].d_ultimate = 0.05;
    c[1].kind = CF_SOLVER_CONNECTOR_CLEARANCE; c[1].law[0] = 0.0005;
    c[2].kind = CF_SOLVER_CONNECTOR_ELASTOPLASTIC; c[2].u_ultimate = 0.002;
    memset(&col, 0, sizeof col);
    col.n_blocks = NB;
    memset(&sc, 0, sizeof sc);
    sc.n_columns = 1; sc.columns = &col; sc.n_segments = nseg; sc.segments = seg; sc.density = 2500.0;
    sc.kn = kn; sc.ks = ks; sc.mu = mu; sc.n_connectors = 3; sc.connectors = c;
    cf_solver_def_default(&def);
    def.early_exit = early_exit; def.tail_s = 0.5;
    if (!s || cf_solver_setup_scene(s, &def, &sc)) { cf_solver_free(s); return NULL; }
    return s;
}

/* What a dowelled job writes besides its result: residual dislocations, its connectors' outputs,
 * the energy history and the connectors' histories (stored and dissipated energy, and per connector
 * |u|, |F| and the axial force) */
enum { DW_CAP = 64, DW_OUT = NB + 3 * CF_SOLVER_CONNECTOR_OUT + DW_CAP * (1 + CF_SOLVER_N_ENERGY + 2 + 9) };

static void dowelled_job(cf_solver_batch_job *jb, double *acc, int n, double *o)
{
    memset(jb, 0, sizeof *jb);
    jb->acc_x = acc; jb->n = n; jb->dt_rec = 0.01;
    jb->residual_dislocation = o;
    jb->out_connectors = o + NB;
    jb->history_capacity = DW_CAP;
    jb->h_t = o + NB + 3 * CF_SOLVER_CONNECTOR_OUT;
    jb->h_energy = jb->h_t + DW_CAP;
    jb->h_conn_energy = jb->h_energy + DW_CAP * CF_SOLVER_N_ENERGY;
    jb->h_conn = jb->h_conn_energy + 2 * DW_CAP;
}

/* A column with connectors runs in lanes (the widest of the CPU and build), and every run of every
 * width -- lanes refilled, connectors reset for each run -- is bitwise its single run in everything
 * it writes: the connectors' forces enter each lane's sums where the single run adds them (after the
 * contacts), so a lane whose connectors were skipped, stepped twice, stepped before the contacts or
 * not reset would differ. The connectors act (they yield and one breaks): the equality is not that
 * of connectors that carry nothing. */
/* Every width's batch of the NJ jobs against their single runs ``ref`` (status, message, result) and the
 * jobs' outputs ``o`` against ``ref_o``, bit for bit (arrays, so that sizeof gives their sizes). */
#define CHECK_EVERY_WIDTH(s, jobs, out, o, ref, ref_o) do {                                              \
        int w_, i_;                                                                                      \
        for (w_ = 1; w_ <= cf_solver_batch_max_width(s); w_ *= 2) {                                      \
            memset(out, 0xff, sizeof out);                                                               \
            memset(o, 0, sizeof o);                                                                      \
            CF_CHECK(cf_solver_batch_run(s, w_, NJ, jobs, out) == CF_OK);                                \
            for (i_ = 0; i_ < NJ; i_++) {                                                                \
                CF_CHECK(out[i_].status == ref[i_].status);                                              \
                CF_CHECK(strcmp(out[i_].message, ref[i_].message) == 0);                                 \
                CF_CHECK(memcmp(&out[i_].result, &ref[i_].result, sizeof ref[i_].result) == 0);          \
                CF_CHECK(memcmp(o[i_], ref_o[i_], sizeof o[i_]) == 0);                                   \
            }                                                                                            \
        }                                                                                                \
    } while (0)

static void test_dowelled_runs(void)
{
    static const double amp[NJ] = {0.6, 0.2, 0.9, 0.4, 0.7, 0.3};
    static const int len[NJ] = {NREC, 120, NREC, 200, 60, NREC};
    static double acc[NJ][NREC], o[NJ][DW_OUT], ref_o[NJ][DW_OUT];
    cf_solver_batch_job jobs[NJ];
    cf_solver_batch_out out[NJ], ref[NJ];
    cf_solver *s = dowelled(0);
    int i, yielded = 0, broken = 0;
    CF_CHECK(s != NULL);
    if (!s) return;
    {   /* in lanes as wide as the free column's */
        cf_solver *free_col = column(CF_SOLVER_CONTACT_VERTEX, 0);
        CF_CHECK(free_col && cf_solver_batch_max_width(s) == cf_solver_batch_max_width(free_col));
        cf_solver_free(free_col);
    }
    for (i = 0; i < NJ; i++) {
        cf_solver *one = dowelled(0);
        cf_solver_batch_job r;
        burst(amp[i], acc[i]);
        dowelled_job(&jobs[i], acc[i], len[i], o[i]);
        dowelled_job(&r, acc[i], len[i], ref_o[i]);
        memset(&ref[i], 0, sizeof ref[i]);
        CF_CHECK(one != NULL);
        if (!one) continue;
        cf_solver_set_history(one, DW_CAP, r.h_t, NULL, NULL, NULL, NULL, NULL, r.h_energy);
        cf_solver_set_history_connectors(one, r.h_conn_energy, r.h_conn);
        cf_solver_set_outputs(one, NULL, NULL, r.out_connectors);
        ref[i].status = cf_solver_run(one, acc[i], NULL, NULL, len[i], 0.01, r.residual_dislocation, &ref[i].result);
        strcpy(ref[i].message, cf_solver_message(one));
        yielded += ref_o[i][NB + 3] > 0.5 || ref_o[i][NB + CF_SOLVER_CONNECTOR_OUT + 3] > 0.5;
        broken += ref_o[i][NB + 2 * CF_SOLVER_CONNECTOR_OUT + 4] > 0.5;
        cf_solver_free(one);
    }
    CF_CHECK(ref[0].status == CF_OK && yielded > 0 && broken > 0);
    CHECK_EVERY_WIDTH(s, jobs, out, o, ref, ref_o);
    cf_solver_free(s);
}

/* Two columns of column()'s drums 3 m apart with a beam 4 x 1 x 0.8 m on both capitals: a scene of
 * several columns and a beam */
static cf_solver *portal(void)
{
    cf_geometry_segment seg[2 * NB] = {{0}};
    int nseg[2 * NB], i;
    double kn[2 * NB], ks[2 * NB], mu[2 * NB];
    cf_solver_scene_column col[2];
    cf_solver_scene_beam beam;
    cf_solver_scene_bearing bear[2];
    cf_solver_scene sc;
    cf_solver_def def;
    cf_solver *s = cf_solver_create();
    for (i = 0; i < 2 * NB; i++) {
        seg[i].height = 1.0; seg[i].r_bottom = 0.5; seg[i].r_top = 0.5; seg[i].phase_rad = 0.0;
        seg[i].n_sides = 8; nseg[i] = 1; kn[i] = 1e9; ks[i] = 1e9; mu[i] = 0.7;
    }
    memset(col, 0, sizeof col); memset(&beam, 0, sizeof beam); memset(bear, 0, sizeof bear); memset(&sc, 0, sizeof sc);
    beam.length = 4.0; beam.width = 1.0; beam.height = 0.8; beam.density = 2500.0;
    for (i = 0; i < 2; i++) {
        col[i].x = i == 0 ? -1.5 : 1.5; col[i].n_blocks = NB;
        bear[i].beam = 0; bear[i].column = i; bear[i].x = col[i].x; bear[i].side = 0.6;
        bear[i].kn = 1e9; bear[i].ks = 1e9; bear[i].mu = 0.7;
    }
    sc.n_columns = 2; sc.columns = col; sc.n_segments = nseg; sc.segments = seg; sc.density = 2500.0;
    sc.kn = kn; sc.ks = ks; sc.mu = mu; sc.n_beams = 1; sc.beams = &beam; sc.n_bearings = 2; sc.bearings = bear;
    cf_solver_def_default(&def);
    def.early_exit = 0; def.tail_s = 0.5;
    if (!s || cf_solver_setup_scene(s, &def, &sc)) { cf_solver_free(s); return NULL; }
    return s;
}

/* What a portal's job writes besides its result: residual dislocations, its columns' and beam's
 * outputs, the histories of every block and joint */
enum { PT_CAP = 48, PT_NBLK = 2 * NB + 1, PT_NJ = 2 * NB + 2,
       PT_OUT = PT_NJ + 2 * CF_SOLVER_COLUMN_OUT + CF_SOLVER_BEAM_OUT
                + PT_CAP * (1 + 2 + 7 * PT_NBLK + 4 * PT_NJ + CF_SOLVER_N_ENERGY) };

static void portal_job(cf_solver_batch_job *jb, double *acc, int n, double *o)
{
    memset(jb, 0, sizeof *jb);
    jb->acc_x = acc; jb->n = n; jb->dt_rec = 0.01;
    jb->residual_dislocation = o; o += PT_NJ;
    jb->out_columns = o; o += 2 * CF_SOLVER_COLUMN_OUT;
    jb->out_beams = o; o += CF_SOLVER_BEAM_OUT;
    jb->history_capacity = PT_CAP;
    jb->h_t = o; o += PT_CAP;
    jb->h_top = o; o += 2 * PT_CAP;
    jb->h_pos = o; o += 3 * PT_CAP * PT_NBLK;
    jb->h_quat = o; o += 4 * PT_CAP * PT_NBLK;
    jb->h_open = o; o += PT_CAP * PT_NJ;
    jb->h_slip = o; o += 2 * PT_CAP * PT_NJ;
    jb->h_normal = o; o += PT_CAP * PT_NJ;
    jb->h_energy = o;
}

/* A scene of several columns and a beam runs in lanes too (each lane's monitor on a view of every
 * body), every run of every width bitwise its single run in all it writes: a lane whose monitor read
 * only one column's top would differ in the other column's and the beam's outputs. */
static void test_portal_runs(void)
{
    static const double amp[NJ] = {0.6, 0.2, 0.9, 0.4, 0.7, 0.3};
    static const int len[NJ] = {NREC, 120, NREC, 200, 60, NREC};
    static double acc[NJ][NREC], o[NJ][PT_OUT], ref_o[NJ][PT_OUT];
    cf_solver_batch_job jobs[NJ];
    cf_solver_batch_out out[NJ], ref[NJ];
    cf_solver *s = portal();
    int i, nc, nb, nd, nblk, nj;
    CF_CHECK(s != NULL);
    if (!s) return;
    cf_solver_counts(s, &nc, &nb, &nd, &nblk, &nj);
    CF_CHECK(nc == 2 && nb == 1 && nblk == PT_NBLK && nj == PT_NJ);
    {   /* in lanes as wide as a column's */
        cf_solver *free_col = column(CF_SOLVER_CONTACT_VERTEX, 0);
        CF_CHECK(free_col && cf_solver_batch_max_width(s) == cf_solver_batch_max_width(free_col));
        cf_solver_free(free_col);
    }
    for (i = 0; i < NJ; i++) {
        cf_solver *one = portal();
        cf_solver_batch_job r;
        burst(amp[i], acc[i]);
        portal_job(&jobs[i], acc[i], len[i], o[i]);
        portal_job(&r, acc[i], len[i], ref_o[i]);
        memset(&ref[i], 0, sizeof ref[i]);
        CF_CHECK(one != NULL);
        if (!one) continue;
        cf_solver_set_history(one, PT_CAP, r.h_t, r.h_top, r.h_pos, r.h_quat, r.h_open, r.h_slip, r.h_energy);
        cf_solver_set_history_normal(one, r.h_normal);
        cf_solver_set_outputs(one, r.out_columns, r.out_beams, NULL);
        ref[i].status = cf_solver_run(one, acc[i], NULL, NULL, len[i], 0.01, r.residual_dislocation, &ref[i].result);
        strcpy(ref[i].message, cf_solver_message(one));
        cf_solver_free(one);
    }
    CF_CHECK(ref[0].status == CF_OK && ref_o[0][PT_NJ + 2 * CF_SOLVER_COLUMN_OUT] > 0.0);   /* the beam slid */
    CHECK_EVERY_WIDTH(s, jobs, out, o, ref, ref_o);
    cf_solver_free(s);
}

static void test_vertex_runs(void) { check_equal(CF_SOLVER_CONTACT_VERTEX, 1); }
static void test_vertex_full_runs(void) { check_equal(CF_SOLVER_CONTACT_VERTEX, 0); }
static void test_exact_runs(void) { check_equal(CF_SOLVER_CONTACT_EXACT, 1); }

int main(void)
{
    CF_RUN(test_arguments);
    CF_RUN(test_vertex_runs);
    CF_RUN(test_vertex_full_runs);
    CF_RUN(test_exact_runs);
    CF_RUN(test_dowelled_runs);
    CF_RUN(test_portal_runs);
    CF_RUN(test_stop_takes_longest_first);
    return CF_TEST_SUMMARY("batch");
}
