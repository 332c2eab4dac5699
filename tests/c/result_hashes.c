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
 * a collapse and stiff joints (kn = ks = 1e10). After them (their lines unchanged): the
 * default column with a titanium dowel in every joint, and a two-column portal of it with an
 * epistyle (cf_solver_setup_scene: their own outputs and connector histories hashed too), each
 * alone and as batches of every width the build and CPU run (the dowelled column in lanes, the
 * portal one run after the other), whose every job, outputs and connector histories included,
 * must equal its run alone. Last, with sleeping joints on (option sleep): six configurations alone
 * and as batches, and the two scenes.
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cf_common.h"
#include "geometry.h"
#include "solver.h"
#include "solver_batch.h"
#include "parthenon_column.h"

enum { NB = PARTHENON_NB, NREC = 1201 };

static unsigned long long hash_bytes(unsigned long long h, const void *p, size_t n)
{
    const unsigned char *c = (const unsigned char *)p;
    size_t i;
    for (i = 0; i < n; i++) { h ^= c[i]; h *= 1099511628211ULL; }   /* FNV-1a */
    return h;
}

typedef struct {
    const char *name;
    int contact, ppe, planar, mono, two, damp;
    double amp_g, dtf;
    double kn;             /* joint stiffness kn = ks, Pa/m; 0 = the default 1e9 */
    int sleep;             /* option sleep (sleeping joints) */
} config;

/* The burst of a configuration: amplitude factor f on the config's amplitude. */
static void record(const config *c, double f, double *ax, double *ay, double *az)
{
    int i;
    double dtr = 0.005;
    for (i = 0; i < NREC; i++) {
        double t = i * dtr, env = t < 3.0 ? 1.0 : 0.0;
        /* polynomial burst (no libm in the input: the hashes must not depend on it) */
        double ph = 4.0 * t - floor(4.0 * t), tri = 4.0 * fabs(ph - 0.5) - 1.0;
        ax[i] = f * c->amp_g * 9.81 * env * tri;
        ay[i] = 0.6 * f * c->amp_g * 9.81 * env * (1.0 - 2.0 * fabs(2.0 * (2.6 * t - floor(2.6 * t)) - 1.0));
        az[i] = 0.3 * f * c->amp_g * 9.81 * env * tri * tri;
    }
}

static cf_solver *setup(const config *c, int early_exit)
{
    cf_geometry_segment seg[NB + 1] = {{0}};
    int nseg[NB], st;
    cf_solver_def def;
    cf_solver *s = cf_solver_create();
    double kn = c->kn > 0 ? c->kn : 1e9;
    if (!s) return NULL;
    parthenon_column(seg, nseg);
    cf_solver_def_default(&def);
    def.contact = c->contact; cf_solver_options_set(&def, "points_per_edge", c->ppe); def.planar = c->planar;
    def.monolithic = c->mono; def.dt_factor = c->dtf; def.early_exit = early_exit;
    def.tail_s = 2.0;
    cf_solver_options_set(&def, "sleep", c->sleep);
    if (c->damp) { def.damping_alpha = 0.5; def.damping_start_s = 3.0; }
    st = cf_solver_setup(s, &def, NB, nseg, seg, 2700.0, kn, kn, 0.7535540501027942);
    if (st) { printf("%-14s setup failed: %s\n", c->name, cf_solver_message(s)); cf_solver_free(s); return NULL; }
    return s;
}

/* One job: its record (amplitude factor f, the first n samples) and its output buffers. */
typedef struct {
    double ax[NREC], ay[NREC], az[NREC], resid[NB];
    double *buf;
    size_t nbuf;
    long cap;
} job;

static int job_make(const config *c, const cf_solver *s, double f, int n, job *jb, cf_solver_batch_job *bj)
{
    long cap = cf_solver_history_capacity(s, n, 0.005);
    double *p;
    record(c, f, jb->ax, jb->ay, jb->az);
    jb->cap = cap;
    /* t, top (2), pos (3 NB), quat (4 NB), open (NB), slip (2 NB), energy (8), normal (NB) */
    jb->nbuf = (size_t)cap * (1 + 2 + 11 * NB + 8 + NB);
    jb->buf = (double *)calloc(jb->nbuf, sizeof(double));
    if (!jb->buf) return 1;
    memset(bj, 0, sizeof *bj);
    bj->acc_x = jb->ax; bj->acc_y = c->two ? jb->ay : NULL; bj->acc_z = c->two ? jb->az : NULL;
    bj->n = n; bj->dt_rec = 0.005; bj->residual_dislocation = jb->resid; bj->history_capacity = cap;
    p = jb->buf;
    bj->h_t = p; p += cap;
    bj->h_top = p; p += 2 * (size_t)cap;
    bj->h_pos = p; p += 3 * (size_t)cap * NB;
    bj->h_quat = p; p += 4 * (size_t)cap * NB;
    bj->h_open = p; p += (size_t)cap * NB;
    bj->h_slip = p; p += 2 * (size_t)cap * NB;
    bj->h_energy = p; p += 8 * (size_t)cap;
    bj->h_normal = p;
    return 0;
}

/* every bit of a job's outputs: result, residual dislocations, histories, status, message */
static unsigned long long job_hash(const job *jb, const cf_solver_batch_out *o)
{
    unsigned long long h = 1469598103934665603ULL;
    const cf_solver_result *res = &o->result;
    h = hash_bytes(h, &res->u_top, sizeof res->u_top);
    h = hash_bytes(h, &res->u_d, sizeof res->u_d);
    h = hash_bytes(h, &res->energy_error, sizeof res->energy_error);
    h = hash_bytes(h, &res->n_steps, sizeof res->n_steps);
    h = hash_bytes(h, &res->collapsed, sizeof res->collapsed);
    h = hash_bytes(h, &res->collapse_block, sizeof res->collapse_block);
    h = hash_bytes(h, jb->resid, sizeof jb->resid);
    h = hash_bytes(h, jb->buf, jb->nbuf * sizeof(double));
    return h;
}

/* ... and its status, message and every field of its result (set after a memset in both
 * paths, so the padding is zero too) */
static unsigned long long job_hash_all(const job *jb, const cf_solver_batch_out *o)
{
    unsigned long long h = job_hash(jb, o);
    h = hash_bytes(h, &o->status, sizeof o->status);
    h = hash_bytes(h, o->message, strlen(o->message));
    return hash_bytes(h, &o->result, sizeof o->result);
}

/* A configuration run alone (cf_solver_run on a fresh solver): one line. */
static int run(const config *c)
{
    cf_solver *s = setup(c, 0);
    job *jb;
    cf_solver_batch_job bj;
    cf_solver_batch_out o;
    if (!s) return 1;
    jb = (job *)calloc(1, sizeof *jb);
    if (!jb || job_make(c, s, 1.0, NREC, jb, &bj)) { free(jb); cf_solver_free(s); return 1; }
    cf_solver_set_history(s, jb->cap, bj.h_t, bj.h_top, bj.h_pos, bj.h_quat, bj.h_open, bj.h_slip, bj.h_energy);
    cf_solver_set_history_normal(s, bj.h_normal);
    memset(&o, 0, sizeof o);
    o.status = cf_solver_run(s, bj.acc_x, bj.acc_y, bj.acc_z, NREC, 0.005, jb->resid, &o.result);
    printf("%-14s status %d steps %ld u_top %.12g u_d %.6g err %.3g collapsed %d/%d | hash %016llx\n", c->name,
           o.status, o.result.n_steps, o.result.u_top, o.result.u_d, o.result.energy_error, o.result.collapsed,
           o.result.collapse_block, job_hash(jb, &o));
    free(jb->buf); free(jb);
    cf_solver_free(s);
    return 0;
}

/* A batch of NJOB runs of one configuration -- amplitudes and record lengths that end at
 * different steps (so lanes are refilled), with early exit (collapse, at rest) or not, and
 * one job refused by cf_solver_run's checks -- on a fresh solver for each job alone, then as
 * batches of every width this CPU and build run: every job's outputs must be bitwise the same.
 * Prints one line per configuration (the same in every build), and MISMATCH lines on failure. */
enum { NJOB = 11 };

static int batch(const config *c, int early_exit)
{
    static const double amp[NJOB] = {1.0, 0.5, 1.4, 0.8, 2.5, 0.3, 1.2, 4.0, 0.9, 0.0, 1.1};
    static const int len[NJOB] = {NREC, 700, NREC, 300, NREC, 1000, 500, NREC, 900, NREC, 200};
    job *jb = (job *)calloc(NJOB, sizeof *jb);
    cf_solver_batch_job bj[NJOB];
    cf_solver_batch_out *o = (cf_solver_batch_out *)calloc(NJOB, sizeof *o);
    unsigned long long ref[NJOB], all = 1469598103934665603ULL;
    cf_solver *s = setup(c, early_exit);
    int i, w, bad = 0, ncol = 0, widths[4] = {1, 2, 4, 8};
    if (!s || !jb || !o) { free(jb); free(o); cf_solver_free(s); return 1; }
    for (i = 0; i < NJOB; i++)
        if (job_make(c, s, amp[i], len[i], &jb[i], &bj[i])) bad = 1;
    if (!bad) bj[NJOB - 2].dt_rec = -1.0;   /* refused: its status and message must come through */
    for (i = 0; i < NJOB && !bad; i++) {
        /* alone, on a freshly set-up solver */
        cf_solver *s1 = setup(c, early_exit);
        if (!s1) { bad = 1; break; }
        memset(&o[i], 0, sizeof o[i]);
        cf_solver_set_history(s1, bj[i].history_capacity, bj[i].h_t, bj[i].h_top, bj[i].h_pos, bj[i].h_quat,
                              bj[i].h_open, bj[i].h_slip, bj[i].h_energy);
        cf_solver_set_history_normal(s1, bj[i].h_normal);
        o[i].status = cf_solver_run(s1, bj[i].acc_x, bj[i].acc_y, bj[i].acc_z, bj[i].n, bj[i].dt_rec,
                                    bj[i].residual_dislocation, &o[i].result);
        memcpy(o[i].message, cf_solver_message(s1), CF_MSG_LEN);
        ref[i] = job_hash_all(&jb[i], &o[i]);
        all = hash_bytes(all, &ref[i], sizeof ref[i]);
        ncol += o[i].result.collapsed;
        cf_solver_free(s1);
    }
    for (w = 0; w < 4 && !bad; w++) {
        if (widths[w] > cf_solver_batch_max_width(s)) continue;
        for (i = 0; i < NJOB; i++) { memset(jb[i].buf, 0, jb[i].nbuf * sizeof(double)); memset(jb[i].resid, 0, sizeof jb[i].resid); }
        memset(o, 0xff, NJOB * sizeof *o);
        if (cf_solver_batch_run(s, widths[w], NJOB, bj, o)) { printf("%s: batch failed: %s\n", c->name, cf_solver_message(s)); bad = 1; break; }
        for (i = 0; i < NJOB; i++)
            if (job_hash_all(&jb[i], &o[i]) != ref[i]) {
                printf("MISMATCH %s%s: job %d, batch width %d\n", c->name, early_exit ? "+exit" : "", i, widths[w]);
                bad = 1;
            }
    }
    printf("%-14s batch of %d (%s, %d collapsed) | hash %016llx\n", c->name, NJOB, early_exit ? "early exit" : "full",
           ncol, all);
    for (i = 0; i < NJOB; i++) free(jb[i].buf);
    free(jb); free(o);
    cf_solver_free(s);
    return bad;
}

/* ---- connectors and scenes: after the single column's lines, which stay as they were ---- */

/* 0: the default column with one titanium-like dowel at the centre of every joint (a one-column
 * scene); 1: two default columns 4 m apart with an epistyle 5.73 x 1.73 x 1.35 m bearing on both
 * abaci whole (the example portal of pycolfrag.structure.scene.Colonnade.portal(2)) */
typedef struct {
    cf_geometry_segment seg[2 * (NB + 1)];
    int nseg[2 * NB];
    double kn[2 * NB], ks[2 * NB], mu[2 * NB];
    cf_solver_scene_column col[2];
    cf_solver_scene_beam beam;
    cf_solver_scene_bearing bear[2];
    cf_solver_connector conn[NB];
    cf_solver_scene sc;
} scene_def;

static const char *const SCENE_NAMES_AWAKE[2] = {"dowels-ti", "portal-2"};
static const char *const SCENE_NAMES_SLEEP[2] = {"dowels+sleep", "portal+sleep"};
static int scene_sleep = 0;   /* the scenes' option sleep (their lines with it come last) */
#define SCENE_NAMES (scene_sleep ? SCENE_NAMES_SLEEP : SCENE_NAMES_AWAKE)

static void scene_make(int which, scene_def *p)
{
    int c, i, ncol = which == 0 ? 1 : 2;
    memset(p, 0, sizeof *p);
    for (c = 0; c < ncol; c++) {
        parthenon_column(p->seg + c * (NB + 1), p->nseg + c * NB);
        p->col[c].x = ncol == 1 ? 0.0 : (c == 0 ? -2.0 : 2.0); p->col[c].n_blocks = NB;
    }
    for (i = 0; i < ncol * NB; i++) { p->kn[i] = 1e9; p->ks[i] = 1e9; p->mu[i] = 0.7535540501027942; }
    p->sc.n_columns = ncol; p->sc.columns = p->col; p->sc.n_segments = p->nseg; p->sc.segments = p->seg;
    p->sc.density = 2700.0; p->sc.kn = p->kn; p->sc.ks = p->ks; p->sc.mu = p->mu;
    if (which == 0) {
        for (i = 0; i < NB; i++) {
            cf_solver_connector *d = &p->conn[i];
            d->joint = i; d->kind = CF_SOLVER_CONNECTOR_ELASTOPLASTIC; d->k_shear = 5e7; d->f_yield = 5e4;
            d->u_ultimate = 0.01; d->n_yield = INFINITY; d->d_ultimate = INFINITY;
        }
        p->sc.n_connectors = NB; p->sc.connectors = p->conn;
    } else {
        p->beam.length = 5.73; p->beam.width = 1.73; p->beam.height = 1.35; p->beam.density = 2700.0;
        for (c = 0; c < 2; c++) {
            p->bear[c].beam = 0; p->bear[c].column = c; p->bear[c].x = p->col[c].x; p->bear[c].side = 1.73;
            p->bear[c].kn = 1e9; p->bear[c].ks = 1e9; p->bear[c].mu = 0.7535540501027942;
        }
        p->sc.n_beams = 1; p->sc.beams = &p->beam; p->sc.n_bearings = 2; p->sc.bearings = p->bear;
    }
}

static cf_solver *scene_setup(int which, scene_def *p)
{
    cf_solver_def def;
    cf_solver *s = cf_solver_create();
    if (!s) return NULL;
    scene_make(which, p);
    cf_solver_def_default(&def);
    def.early_exit = 0; def.tail_s = 2.0;
    cf_solver_options_set(&def, "sleep", scene_sleep);
    if (cf_solver_setup_scene(s, &def, &p->sc)) {
        printf("%-14s setup failed: %s\n", SCENE_NAMES[which], cf_solver_message(s));
        cf_solver_free(s);
        return NULL;
    }
    return s;
}

/* One scene job: its record (amplitude f on 0.4 g, two components and a vertical one, the first n
 * samples), its histories and outputs, in one buffer sized for the set-up solver s. */
typedef struct {
    double ax[NREC], ay[NREC], az[NREC];
    double *buf;
    size_t nbuf;
} scene_job;

static int scene_job_make(const cf_solver *s, double f, int n, scene_job *jb, cf_solver_batch_job *bj, double **out)
{
    static const config c = {"scene", 0, 1, 0, 0, 1, 0, 0.4, 0.8, 0, 0};
    int nc, nb, nd, nbl, nj;
    long cap = cf_solver_history_capacity(s, n, 0.005);
    double *p;
    cf_solver_counts(s, &nc, &nb, &nd, &nbl, &nj);
    record(&c, f, jb->ax, jb->ay, jb->az);
    /* resid (nj), t, top (2), pos (3 nbl), quat (4 nbl), open, slip (2), normal (nj each), energy (8),
     * connector energy (2) and connectors (3 nd), then the outputs of columns, beams, connectors */
    jb->nbuf = (size_t)nj + (size_t)cap * (1 + 2 + 7 * (size_t)nbl + 4 * (size_t)nj + 8 + 2 + 3 * (size_t)nd)
               + (size_t)CF_SOLVER_COLUMN_OUT * nc + (size_t)CF_SOLVER_BEAM_OUT * (nb + 1)
               + (size_t)CF_SOLVER_CONNECTOR_OUT * (nd + 1);
    jb->buf = (double *)calloc(jb->nbuf, sizeof(double));
    if (!jb->buf) return 1;
    memset(bj, 0, sizeof *bj);
    bj->acc_x = jb->ax; bj->acc_y = jb->ay; bj->acc_z = jb->az; bj->n = n; bj->dt_rec = 0.005;
    p = jb->buf;
    bj->residual_dislocation = p; p += nj;
    bj->history_capacity = cap;
    bj->h_t = p; p += cap;
    bj->h_top = p; p += 2 * (size_t)cap;
    bj->h_pos = p; p += 3 * (size_t)cap * nbl;
    bj->h_quat = p; p += 4 * (size_t)cap * nbl;
    bj->h_open = p; p += (size_t)cap * nj;
    bj->h_slip = p; p += 2 * (size_t)cap * nj;
    bj->h_normal = p; p += (size_t)cap * nj;
    bj->h_energy = p; p += 8 * (size_t)cap;
    out[0] = p; p += 2 * (size_t)cap;                       /* connector energy */
    out[1] = p; p += 3 * (size_t)cap * nd;                  /* connectors' history */
    out[2] = p; p += (size_t)CF_SOLVER_COLUMN_OUT * nc;     /* outputs */
    out[3] = p; p += (size_t)CF_SOLVER_BEAM_OUT * (nb + 1);
    out[4] = p;
    bj->h_conn_energy = out[0]; bj->h_conn = out[1];
    bj->out_columns = out[2]; bj->out_beams = out[3]; bj->out_connectors = out[4];
    return 0;
}

/* A scene job alone on a fresh solver (its outputs attached): status and result into o. */
static cf_solver_batch_out scene_alone(int which, const cf_solver_batch_job *bj, double **out)
{
    scene_def p;
    cf_solver_batch_out o;
    cf_solver *s = scene_setup(which, &p);
    memset(&o, 0, sizeof o);
    o.status = -1;
    if (!s) return o;
    cf_solver_set_history(s, bj->history_capacity, bj->h_t, bj->h_top, bj->h_pos, bj->h_quat, bj->h_open,
                          bj->h_slip, bj->h_energy);
    cf_solver_set_history_normal(s, bj->h_normal);
    cf_solver_set_history_connectors(s, out[0], out[1]);
    cf_solver_set_outputs(s, out[2], out[3], out[4]);
    o.status = cf_solver_run(s, bj->acc_x, bj->acc_y, bj->acc_z, bj->n, bj->dt_rec, bj->residual_dislocation,
                             &o.result);
    memcpy(o.message, cf_solver_message(s), CF_MSG_LEN);
    cf_solver_free(s);
    return o;
}

static unsigned long long scene_hash(const scene_job *jb, const cf_solver_batch_out *o, int with_outputs,
                                     size_t n_without)
{
    unsigned long long h = 1469598103934665603ULL;
    h = hash_bytes(h, &o->status, sizeof o->status);
    h = hash_bytes(h, o->message, strlen(o->message));
    h = hash_bytes(h, &o->result, sizeof o->result);
    return hash_bytes(h, jb->buf, (with_outputs ? jb->nbuf : n_without) * sizeof(double));
}

/* A scene alone (one line), then batches of 4 runs of it through cf_solver_batch_run at every width
 * the build and CPU run for it, every job bitwise its run alone in all it carries (result, residual
 * dislocations, histories, the scene's outputs and connector histories). The line's hash is that of
 * the runs alone without their outputs (as it was when the batch did not carry them). */
static int scene_case(int which)
{
    static const double amp[4] = {1.0, 0.6, 1.6, 0.3};
    static const int len[4] = {NREC, 700, 1000, 300};
    scene_job *jb = (scene_job *)calloc(4, sizeof *jb);
    cf_solver_batch_job bj[4];
    cf_solver_batch_out o[4], a;
    double *out[4][5];
    unsigned long long ref[4], full[4], all = 1469598103934665603ULL;
    size_t n_job[4];
    scene_def p;
    cf_solver *s = scene_setup(which, &p);
    int i, bad = 0, w, widths[4] = {1, 2, 4, 8};
    if (!s || !jb) { free(jb); cf_solver_free(s); return 1; }
    for (i = 0; i < 4; i++) {
        if (scene_job_make(s, amp[i], len[i], &jb[i], &bj[i], out[i])) { bad = 1; break; }
        n_job[i] = (size_t)(out[i][0] - jb[i].buf);   /* what a batch job carries: up to the connector energy */
    }
    for (i = 0; i < 4 && !bad; i++) {
        a = scene_alone(which, &bj[i], out[i]);
        if (a.status < 0) { bad = 1; break; }
        if (i == 0)
            printf("%-14s status %d steps %ld u_top %.12g u_d %.6g err %.3g collapsed %d/%d | hash %016llx\n",
                   SCENE_NAMES[which], a.status, a.result.n_steps, a.result.u_top, a.result.u_d, a.result.energy_error,
                   a.result.collapsed, a.result.collapse_block, scene_hash(&jb[i], &a, 1, n_job[i]));
        ref[i] = scene_hash(&jb[i], &a, 0, n_job[i]);
        full[i] = scene_hash(&jb[i], &a, 1, n_job[i]);
        all = hash_bytes(all, &ref[i], sizeof ref[i]);
    }
    for (w = 0; w < 4 && !bad; w++) {
        if (widths[w] > cf_solver_batch_max_width(s)) continue;
        for (i = 0; i < 4; i++) memset(jb[i].buf, 0, jb[i].nbuf * sizeof(double));
        memset(o, 0, sizeof o);
        if (cf_solver_batch_run(s, widths[w], 4, bj, o)) {
            printf("%s: batch failed: %s\n", SCENE_NAMES[which], cf_solver_message(s));
            bad = 1;
        }
        for (i = 0; i < 4 && !bad; i++)
            if (scene_hash(&jb[i], &o[i], 1, n_job[i]) != full[i]) {
                printf("MISMATCH %s: job %d, batch width %d\n", SCENE_NAMES[which], i, widths[w]);
                bad = 1;
            }
    }
    printf("%-14s batch of 4 (every width) | hash %016llx\n", SCENE_NAMES[which], all);
    for (i = 0; i < 4; i++) free(jb[i].buf);
    free(jb);
    cf_solver_free(s);
    return bad;
}

int main(void)
{
    static const config cs[] = {
        {"vertex", CF_SOLVER_CONTACT_VERTEX, 1, 0, 0, 0, 0, 0.25, 0.8, 0, 0},
        {"vertex-2c", CF_SOLVER_CONTACT_VERTEX, 1, 0, 0, 1, 0, 0.25, 0.8, 0, 0},
        {"vertex-damp", CF_SOLVER_CONTACT_VERTEX, 1, 0, 0, 0, 1, 0.25, 0.8, 0, 0},
        {"vertex-strong", CF_SOLVER_CONTACT_VERTEX, 1, 0, 0, 1, 0, 0.6, 0.8, 0, 0},
        {"perimeter2", CF_SOLVER_CONTACT_PERIMETER, 2, 0, 0, 0, 0, 0.25, 0.8, 0, 0},
        {"perimeter3-2c", CF_SOLVER_CONTACT_PERIMETER, 3, 0, 0, 1, 0, 0.25, 0.8, 0, 0},
        {"exact", CF_SOLVER_CONTACT_EXACT, 1, 0, 0, 0, 0, 0.25, 0.8, 0, 0},
        {"exact-2c", CF_SOLVER_CONTACT_EXACT, 1, 0, 0, 1, 0, 0.4, 0.8, 0, 0},
        {"planar", CF_SOLVER_CONTACT_VERTEX, 1, 1, 0, 0, 0, 0.25, 0.8, 0, 0},
        {"mono", CF_SOLVER_CONTACT_VERTEX, 1, 0, 1, 0, 0, 0.25, 0.8, 0, 0},
        {"collapse", CF_SOLVER_CONTACT_VERTEX, 1, 0, 0, 1, 0, 1.6, 0.8, 0, 0},
        {"vertex-dt04", CF_SOLVER_CONTACT_VERTEX, 1, 0, 0, 1, 0, 0.3, 0.4, 0, 0},
        /* stiff joints: impacts last fewer steps (the hard case of docs/accuracy.md) */
        {"stiff-2c", CF_SOLVER_CONTACT_VERTEX, 1, 0, 0, 1, 0, 0.5, 0.8, 1e10, 0},
        {"stiff-exact", CF_SOLVER_CONTACT_EXACT, 1, 0, 0, 1, 0, 0.5, 0.8, 1e10, 0},
    };
    static const config sl[] = {
        {"vertex+sleep", CF_SOLVER_CONTACT_VERTEX, 1, 0, 0, 0, 0, 0.25, 0.8, 0, 1},
        {"weak-2c+sleep", CF_SOLVER_CONTACT_VERTEX, 1, 0, 0, 1, 0, 0.03, 0.8, 0, 1},
        {"perim2+sleep", CF_SOLVER_CONTACT_PERIMETER, 2, 0, 0, 0, 0, 0.25, 0.8, 0, 1},
        {"mono+sleep", CF_SOLVER_CONTACT_VERTEX, 1, 0, 1, 0, 0, 0.25, 0.8, 0, 1},
        {"collapse+sleep", CF_SOLVER_CONTACT_VERTEX, 1, 0, 0, 1, 0, 1.6, 0.8, 0, 1},
        {"stiff-2c+sleep", CF_SOLVER_CONTACT_VERTEX, 1, 0, 0, 1, 0, 0.5, 0.8, 1e10, 1},
    };
    size_t i;
    int bad = 0;
    for (i = 0; i < sizeof cs / sizeof cs[0]; i++) bad |= run(&cs[i]);
    /* batches: the default options (early exit) on the default scene, then every configuration */
    bad |= batch(&cs[0], 1);
    bad |= batch(&cs[3], 1);
    for (i = 0; i < sizeof cs / sizeof cs[0]; i++) bad |= batch(&cs[i], 0);
    bad |= scene_case(0);
    bad |= scene_case(1);
    /* sleeping joints (option sleep; their lines after all the others, which stay as they were): every
     * width and the batch must give the single run's bits with it too */
    for (i = 0; i < sizeof sl / sizeof sl[0]; i++) bad |= run(&sl[i]);
    bad |= batch(&sl[0], 1);
    for (i = 0; i < sizeof sl / sizeof sl[0]; i++) bad |= batch(&sl[i], 0);
    scene_sleep = 1;
    bad |= scene_case(0);
    bad |= scene_case(1);
    return bad;
}
