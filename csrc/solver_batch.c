/*
 * solver_batch.c -- many runs of one column, one run per SIMD lane (solver_batch.h).
 *
 * The integrator of solver_batch_lanes.h is instantiated for 2 lanes (SSE2, part of every
 * x86-64 CPU), 4 (AVX2) and 8 (AVX-512F), the wider ones compiled for their instruction
 * set by a target region (no -m flag: the library still runs on any x86-64) and chosen at
 * run time from CPUID, as the point runners are. No FMA is enabled and contraction is
 * off, so every lane rounds as the single run does. Width 1 -- the exact-interface
 * model, whose work is the polygon clipping of contact.c, and builds without GCC vector
 * extensions or with -DCF_NO_SIMD -- runs the jobs one after the other with
 * cf_solver_run.
 */
#include <math.h>
#include <stdio.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "solver_batch.h"
#include "solver_internal.h"
#include "solver_points_internal.h"
#include "solver_sleep.h"

/* A job's history buffers (NULL / capacity 0: none) as the solver (or a lane's view) writes them */
static void batch_job_history(cf_solver *v, const cf_solver_batch_job *jb)
{
    v->h_cap = jb->history_capacity > 0 ? jb->history_capacity : 0;
    v->h_t = jb->h_t; v->h_top = jb->h_top; v->h_pos = jb->h_pos; v->h_quat = jb->h_quat;
    v->h_open = jb->h_open; v->h_slip = jb->h_slip; v->h_en = jb->h_energy; v->h_fn = jb->h_normal;
    v->out_col = jb->out_columns; v->out_beam = jb->out_beams; v->out_conn = jb->out_connectors;
    v->h_conn_en = jb->h_conn_energy; v->h_conn = jb->h_conn;
}

/* Jobs order[from..n_jobs-1] (from..n_jobs-1 without an order) not run because the caller's
 * check asked the batch to stop (CF_EINTR). */
static void batch_not_started(int from, int n_jobs, const int *order, cf_solver_batch_out *out)
{
    int i;
    for (i = from; i < n_jobs; i++) {
        int j = order ? order[i] : i;
        cf_solver_result_none(&out[j].result);
        out[j].status = CF_EINTR;
        snprintf(out[j].message, CF_MSG_LEN, "stopped by the caller before this run started");
    }
}

#ifdef CF_SOLVER_SIMD
/* The order in which the lanes take the jobs: longest record first (ties in job order). A
 * lane idles from the end of its last run to the end of the batch's longest; taking the long
 * runs first leaves the short ones to fill the lanes at the end (longest processing time
 * first). The order of the runs changes no run: each starts from the rest state. */
typedef struct { double len; int j; } batch_key;

static int batch_key_cmp(const void *a, const void *b)
{
    const batch_key *x = (const batch_key *)a, *y = (const batch_key *)b;
    if (x->len != y->len) return x->len > y->len ? -1 : 1;
    return (x->j > y->j) - (x->j < y->j);
}

/* order[0..n_jobs-1]: a permutation of the jobs; NULL when out of memory */
static int *batch_order(int n_jobs, const cf_solver_batch_job *jobs)
{
    int *order = (int *)malloc((size_t)n_jobs * sizeof(int));
    batch_key *k = (batch_key *)malloc((size_t)n_jobs * sizeof(batch_key));
    int j;
    if (!order || !k) { free(order); free(k); return NULL; }
    for (j = 0; j < n_jobs; j++) {
        /* a job the checks refuse may have any n and dt: it only needs a place */
        double len = jobs[j].n > 0 && jobs[j].dt_rec > 0.0 ? jobs[j].n * jobs[j].dt_rec : 0.0;
        k[j].len = len;
        k[j].j = j;
    }
    qsort(k, (size_t)n_jobs, sizeof *k, batch_key_cmp);
    for (j = 0; j < n_jobs; j++) order[j] = k[j].j;
    free(k);
    return order;
}

/* one instance of the integrator per width the build has (solver_internal.h) */
#define CF_BW 2
#include "solver_lanes.h"
#include "solver_batch_lanes.h"
#include "solver_lanes_end.h"
#endif
#ifdef CF_SOLVER_AVX2
#define CF_BW 4
#include "solver_lanes.h"
#include "solver_batch_lanes.h"
#include "solver_lanes_end.h"
#endif
#ifdef CF_SOLVER_AVX512
#define CF_BW 8
#include "solver_lanes.h"
#include "solver_batch_lanes.h"
#include "solver_lanes_end.h"
#endif

/* The widest lane count this CPU and build run for the column of s. */
static int widest(const cf_solver *s)
{
    /* a column's connectors and a scene of several columns run in lanes as a column does: the
     * connectors by CF_BN(connectors), a scene's monitor on a lane's view of every body */
    return s->model->batch_lanes ? s->lanes : 1;   /* chosen from CPUID at set-up */
}

int cf_solver_batch_max_width(const cf_solver *s)
{
    if (!s || !s->ready) return 0;
    return widest(s);
}

/* The width that pays, measured (docs/performance.md): a lane costs 0.53 of a single run at
 * width 8 and 0.71 at width 4 when every lane is busy, and a batch pays for its idle lanes,
 * so 8 from 5 jobs on, 4 from 3 jobs on; two lanes of SSE2 cost 1.05 of a single run (SSE2
 * points): never by default. */
int cf_solver_batch_width(const cf_solver *s, int n_jobs)
{
    int w;
    if (!s || !s->ready) return 0;
    w = widest(s);
    if (w >= 8 && n_jobs >= 5) return 8;
    if (w >= 4 && n_jobs >= 3) return 4;
    return 1;
}

/* Width 1: the jobs one after the other, each a run of a freshly reset solver. */
static int one_by_one(cf_solver *s, int n_jobs, const cf_solver_batch_job *jobs, cf_solver_batch_out *out)
{
    int j;
    long cap = s->h_cap;
    double *h[13];
    h[0] = s->h_t; h[1] = s->h_top; h[2] = s->h_pos; h[3] = s->h_quat; h[4] = s->h_open; h[5] = s->h_slip;
    h[6] = s->h_en; h[7] = s->h_fn; h[8] = s->out_col; h[9] = s->out_beam; h[10] = s->out_conn;
    h[11] = s->h_conn_en; h[12] = s->h_conn;
    for (j = 0; j < n_jobs; j++) {
        const cf_solver_batch_job *jb = &jobs[j];
        batch_job_history(s, jb);
        s->msg[0] = 0;
        out[j].status = cf_solver_run(s, jb->acc_x, jb->acc_y, jb->acc_z, jb->n, jb->dt_rec,
                                      jb->residual_dislocation, &out[j].result);
        memcpy(out[j].message, s->msg, CF_MSG_LEN);
        if (out[j].status == CF_EINTR) {   /* the caller's check stopped this run: stop the batch */
            batch_not_started(j + 1, n_jobs, NULL, out);
            break;
        }
    }
    s->h_cap = cap; s->h_t = h[0]; s->h_top = h[1]; s->h_pos = h[2]; s->h_quat = h[3]; s->h_open = h[4];
    s->h_slip = h[5]; s->h_en = h[6]; s->h_fn = h[7]; s->out_col = h[8]; s->out_beam = h[9]; s->out_conn = h[10];
    s->h_conn_en = h[11]; s->h_conn = h[12];
    s->msg[0] = 0;
    return CF_OK;
}

int cf_solver_batch_run(cf_solver *s, int width, int n_jobs, const cf_solver_batch_job *jobs,
                        cf_solver_batch_out *out)
{
    int w;
    if (!s) return CF_EINVAL;
    if (!s->ready) return cf_solver_fail(s, CF_ESTATE, "cf_solver_batch_run before a successful cf_solver_setup");
    if (n_jobs < 0) return cf_solver_fail(s, CF_EINVAL, "n_jobs must be >= 0, got %d", n_jobs);
    if (n_jobs > 0 && (!jobs || !out)) return cf_solver_fail(s, CF_EINVAL, "no jobs or no outputs");
    w = widest(s);
    if (width != 0 && width != 1 && width != 2 && width != 4 && width != 8)
        return cf_solver_fail(s, CF_EINVAL, "width must be 0 (automatic), 1, 2, 4 or 8, got %d", width);
    if (width > w)
        return cf_solver_fail(s, CF_EINVAL, "width %d: this CPU and build run at most %d runs side by side for "
                              "this column", width, w);
    if (width == 0) width = cf_solver_batch_width(s, n_jobs);
    if (n_jobs == 0) return CF_OK;
    s->msg[0] = 0;
#ifdef CF_SOLVER_AVX512
    if (width == 8) return run_w8(s, n_jobs, jobs, out);
#endif
#ifdef CF_SOLVER_AVX2
    if (width == 4) return run_w4(s, n_jobs, jobs, out);
#endif
#ifdef CF_SOLVER_SIMD
    if (width == 2) return run_w2(s, n_jobs, jobs, out);
#endif
    return one_by_one(s, n_jobs, jobs, out);
}
