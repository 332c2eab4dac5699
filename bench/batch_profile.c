/*
 * batch_profile.c -- plain C timing of many runs of the default column, one run at a time
 * (cf_solver_run) or side by side in SIMD lanes (cf_solver_batch_run); a benchmark, never
 * a test. bench/batch_speed.py writes the records (grid samples) and drives it.
 *
 * Records file (native doubles): count, then per record: n, dt, n accelerations (m/s^2).
 * Run:
 *   build/batch_profile FILE single        every record alone, a fresh reset per run
 *   build/batch_profile FILE batch=W       cf_solver_batch_run at width W (0: automatic)
 * then optionally perimeterN (N points per edge), exact, planar, mono: else the grid's options
 * (SolverOptions defaults: vertex, dt_factor 0.8, early exit, tail 3 s).
 * Prints: runs, total steps, thread CPU seconds, CPU microseconds per run-step, and a hash of
 * every run's result bits (the same for every mode when the batch is bitwise the single run); one
 * run at a time with a points model, also the joint-steps taken asleep (option `sleep`) and all
 * joint-steps (bench/speed_ceiling.py reads them).
 * Built with -DNO_BATCH (a baseline tree without the batch API), only "single" exists.
 */
#define _POSIX_C_SOURCE 200809L
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "cf_common.h"
#include "geometry.h"
#include "solver.h"
#include "../tests/c/parthenon_column.h"
#ifndef NO_BATCH
#include "solver_batch.h"
#include "solver_points_internal.h"
#endif

static double cpu_now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
    return ts.tv_sec + 1e-9 * ts.tv_nsec;
}

static unsigned long long hash_bytes(unsigned long long h, const void *p, size_t n)
{
    const unsigned char *c = (const unsigned char *)p;
    size_t i;
    for (i = 0; i < n; i++) { h ^= c[i]; h *= 1099511628211ULL; }
    return h;
}

enum { NB = PARTHENON_NB };   /* blocks of the default column */

static unsigned long long hash_result(unsigned long long h, int st, const cf_solver_result *r, const double *resid)
{
    h = hash_bytes(h, &st, sizeof st);
    h = hash_bytes(h, &r->u_top, sizeof r->u_top);
    h = hash_bytes(h, &r->u_d, sizeof r->u_d);
    h = hash_bytes(h, &r->energy_error, sizeof r->energy_error);
    h = hash_bytes(h, &r->n_steps, sizeof r->n_steps);
    h = hash_bytes(h, &r->collapsed, sizeof r->collapsed);
    h = hash_bytes(h, &r->collapse_time, sizeof r->collapse_time);
    return hash_bytes(h, resid, NB * sizeof(double));
}

int main(int argc, char **argv)
{
    cf_geometry_segment seg[NB + 1] = {{0}};
    int nseg[NB], i, count, width = -1;
    double **acc, *dt, *resid;
    int *n;
    long steps = 0, slept = -1;
    cf_solver_def def;
    cf_solver *s;
    unsigned long long h = 1469598103934665603ULL;
    double c0, c1;
    FILE *f;
    if (argc < 3) { fprintf(stderr, "usage: %s FILE single|batch=W [perimeterN|exact|planar|mono|sleep]...\n", argv[0]); return 2; }
    if (!strncmp(argv[2], "batch=", 6)) width = atoi(argv[2] + 6);
    else if (strcmp(argv[2], "single")) { fprintf(stderr, "unknown mode %s\n", argv[2]); return 2; }
#ifdef NO_BATCH
    if (width >= 0) { fprintf(stderr, "built without the batch API\n"); return 2; }
#endif
    f = fopen(argv[1], "rb");
    if (!f || fread(&count, sizeof count, 1, f) != 1 || count < 1) { fprintf(stderr, "cannot read %s\n", argv[1]); return 1; }
    acc = (double **)calloc((size_t)count, sizeof *acc);
    dt = (double *)calloc((size_t)count, sizeof *dt);
    n = (int *)calloc((size_t)count, sizeof *n);
    resid = (double *)calloc((size_t)count * NB, sizeof *resid);
    for (i = 0; i < count; i++) {
        if (fread(&n[i], sizeof n[i], 1, f) != 1 || fread(&dt[i], sizeof dt[i], 1, f) != 1) return 1;
        acc[i] = (double *)malloc(sizeof(double) * (size_t)n[i]);
        if (fread(acc[i], sizeof(double), (size_t)n[i], f) != (size_t)n[i]) return 1;
    }
    fclose(f);
    parthenon_column(seg, nseg);
    cf_solver_def_default(&def);
    for (i = 3; i < argc; i++) {
        if (!strncmp(argv[i], "perimeter", 9)) {
            def.contact = CF_SOLVER_CONTACT_PERIMETER;
#ifdef NO_BATCH   /* a baseline without the batch API (0a54043) predates the options table too */
            def.points_per_edge = atoi(argv[i] + 9) > 0 ? atoi(argv[i] + 9) : 1;
#else
            cf_solver_options_set(&def, "points_per_edge", atoi(argv[i] + 9) > 0 ? atoi(argv[i] + 9) : 1);
#endif
        } else if (!strcmp(argv[i], "exact")) def.contact = CF_SOLVER_CONTACT_EXACT;
        else if (!strcmp(argv[i], "planar")) def.planar = 1;
        else if (!strcmp(argv[i], "mono")) def.monolithic = 1;
        else if (!strcmp(argv[i], "sleep")) cf_solver_options_set(&def, "sleep", 1);
        else { fprintf(stderr, "unknown option %s\n", argv[i]); return 2; }
    }
    s = cf_solver_create();
    if (cf_solver_setup(s, &def, NB, nseg, seg, 2700.0, 1e9, 1e9, 0.7535540501027942)) {
        fprintf(stderr, "setup: %s\n", cf_solver_message(s));
        return 1;
    }
    if (width < 0) {
        cf_solver_result res;
        c0 = cpu_now();
        for (i = 0; i < count; i++) {
            int st = cf_solver_run(s, acc[i], NULL, NULL, n[i], dt[i], resid + (size_t)i * NB, &res);
            steps += res.n_steps;
            h = hash_result(h, st, &res, resid + (size_t)i * NB);
#ifndef NO_BATCH
            if (def.contact != CF_SOLVER_CONTACT_EXACT && !def.monolithic)
                slept = (slept < 0 ? 0 : slept) + ((cf_points *)s->contact)->slept;
#endif
        }
        c1 = cpu_now();
    }
#ifndef NO_BATCH
    else {
        cf_solver_batch_job *jobs = (cf_solver_batch_job *)calloc((size_t)count, sizeof *jobs);
        cf_solver_batch_out *out = (cf_solver_batch_out *)calloc((size_t)count, sizeof *out);
        for (i = 0; i < count; i++) {
            jobs[i].acc_x = acc[i]; jobs[i].n = n[i]; jobs[i].dt_rec = dt[i];
            jobs[i].residual_dislocation = resid + (size_t)i * NB;
        }
        c0 = cpu_now();
        if (cf_solver_batch_run(s, width, count, jobs, out)) { fprintf(stderr, "batch: %s\n", cf_solver_message(s)); return 1; }
        c1 = cpu_now();
        for (i = 0; i < count; i++) {
            steps += out[i].result.n_steps;
            h = hash_result(h, out[i].status, &out[i].result, resid + (size_t)i * NB);
        }
        if (width == 0) width = cf_solver_batch_width(s, count);
        free(jobs); free(out);
    }
#endif
    printf("runs %d steps %ld cpu %.6f us/run-step %.4f width %d hash %016llx", count, steps, c1 - c0,
           1e6 * (c1 - c0) / (double)steps, width < 0 ? 0 : width, h);
    if (slept >= 0) printf(" slept %ld of %ld joint-steps", slept, steps * (long)s->nj);
    printf("\n");
    cf_solver_free(s);
    return 0;
}
