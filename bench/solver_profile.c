/*
 * solver_profile.c -- a plain C driver of the solver for profiling and timing the
 * hot loop without Python (a benchmark, never a test).
 *
 * The default column (the numbers of Column.parthenon(): 12 ten-sided drums and the
 * capital), 0.25 g 2 Hz sine for 3 s sampled at 5 ms, free response to 20 s
 * (early_exit off), exactly the case of bench/solver_speed.py. Prints steps, the
 * best and median wall time of the runs, microseconds per step, u_top, u_d and a
 * hash of the result bits (to check that a code change kept results bit-identical).
 *
 * Build (from the repository root; the same flags as csrc/flags.mk, whose CFLAGS also carry
 * -DCF_G_M_S2, the gravity of pycolfrag/data/constants.json): compile this file with the
 * csrc/ sources, e.g.
 *   gcc $(make -s -f csrc/flags.mk -f - p <<< 'p: ; @echo $(CFLAGS)') -g -Icsrc -o build/solver_profile
 *       bench/solver_profile.c $(ls csrc/[a-z]*.c) -lm
 * (bench/solver_compare.py builds it against this tree and a baseline tree and times both
 * alternately in one run.)
 * Run:
 *   build/solver_profile [vertex|perimeter1|perimeter2|exact] [planar] [mono] [dtf=0.8] [repeat=7] [setup] [sleep]
 *   perf record -g build/solver_profile vertex repeat=20 && perf report
 * "setup" times cf_solver_setup alone (geometry, sub-contacts, stability limit).
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

static double now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return ts.tv_sec + 1e-9 * ts.tv_nsec;
}

/* CPU time of this thread: on a shared machine it leaves out the time others held the core */
static double cpu_now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
    return ts.tv_sec + 1e-9 * ts.tv_nsec;
}

static int cmp_d(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

/* FNV-1a over the bytes of a few doubles */
static unsigned long long hash_bytes(unsigned long long h, const void *p, size_t n)
{
    const unsigned char *c = (const unsigned char *)p;
    size_t i;
    for (i = 0; i < n; i++) { h ^= c[i]; h *= 1099511628211ULL; }
    return h;
}

int main(int argc, char **argv)
{
    enum { NB = 13 };
    cf_geometry_segment seg[NB + 1] = {{0}};
    int nseg[NB], i, a, repeat = 7, setup_only = 0;
    double dtr = 0.005, density = 2700.0, kn = 1e9, ks = 1e9, mu = 0.7535540501027942;
    double *acc, *times, *cpu, resid[NB];
    int nrec = 601;
    cf_solver_def def;
    cf_solver_result res;
    cf_solver *s;
    unsigned long long h = 1469598103934665603ULL;

    cf_solver_def_default(&def);
    def.early_exit = 0;
    for (a = 1; a < argc; a++) {
        if (!strcmp(argv[a], "vertex")) def.contact = CF_SOLVER_CONTACT_VERTEX;
        else if (!strncmp(argv[a], "perimeter", 9)) { def.contact = CF_SOLVER_CONTACT_PERIMETER; cf_solver_options_set(&def, "points_per_edge", atoi(argv[a] + 9) > 0 ? atoi(argv[a] + 9) : 1); }
        else if (!strcmp(argv[a], "exact")) def.contact = CF_SOLVER_CONTACT_EXACT;
        else if (!strcmp(argv[a], "planar")) def.planar = 1;
        else if (!strcmp(argv[a], "mono")) def.monolithic = 1;
        else if (!strcmp(argv[a], "setup")) setup_only = 1;
        else if (!strcmp(argv[a], "sleep")) cf_solver_options_set(&def, "sleep", 1);
        else if (!strncmp(argv[a], "dtf=", 4)) def.dt_factor = atof(argv[a] + 4);
        else if (!strncmp(argv[a], "repeat=", 7)) repeat = atoi(argv[a] + 7);
        else { fprintf(stderr, "unknown argument %s\n", argv[a]); return 2; }
    }
    if (repeat < 1) repeat = 1;
    parthenon_column(seg, nseg);
    acc = (double *)malloc(sizeof(double) * (size_t)nrec);
    times = (double *)malloc(sizeof(double) * (size_t)repeat);
    cpu = (double *)malloc(sizeof(double) * (size_t)repeat);
    for (i = 0; i < nrec; i++) acc[i] = 0.25 * 9.81 * sin(2.0 * CF_PI * 2.0 * (i * dtr));   /* as NumPy evaluates it */
    def.tail_s = 20.0 - (nrec - 1) * dtr;
    s = cf_solver_create();
    for (a = 0; a < repeat; a++) {
        double t0 = now(), c0 = cpu_now();
        int st = cf_solver_setup(s, &def, NB, nseg, seg, density, kn, ks, mu);
        if (st) { fprintf(stderr, "setup: %s\n", cf_solver_message(s)); return 1; }
        if (!setup_only) {
            st = cf_solver_run(s, acc, NULL, NULL, nrec, dtr, resid, &res);
            if (st) { fprintf(stderr, "run: %s\n", cf_solver_message(s)); return 1; }
        }
        times[a] = now() - t0;
        cpu[a] = cpu_now() - c0;
    }
    qsort(times, (size_t)repeat, sizeof(double), cmp_d);
    qsort(cpu, (size_t)repeat, sizeof(double), cmp_d);
    if (setup_only) {
        printf("setup: best %.3f ms, median %.3f ms, dt_crit %.6g s\n", 1e3 * times[0], 1e3 * times[repeat / 2],
               cf_solver_dt_crit(s));
    } else {
        h = hash_bytes(h, &res.u_top, sizeof res.u_top);
        h = hash_bytes(h, &res.u_d, sizeof res.u_d);
        h = hash_bytes(h, &res.energy_error, sizeof res.energy_error);
        h = hash_bytes(h, resid, sizeof resid);
        printf("steps %ld dt %.4f ms | wall best %.4f s median %.4f s, cpu best %.4f s | %.3f us/step (cpu %.3f) | "
               "u_top %.10g u_d %.6g err %.3g | hash %016llx\n",
               res.n_steps, 1e3 * res.dt, times[0], times[repeat / 2], cpu[0], 1e6 * times[0] / res.n_steps,
               1e6 * cpu[0] / res.n_steps, res.u_top, res.u_d, res.energy_error, h);
    }
    cf_solver_free(s);
    free(acc); free(times); free(cpu);
    return 0;
}
