/* Sleeping joints (solver_sleep.h, option `sleep`): the options refused by name out of range; on a
 * firmly closed case (the default column under a weak sine) the joints sleep most of the steps and the
 * response is the full law's to round-off; a strong motion wakes the joint (a square block under a slow
 * ramp of ground acceleration lifts off at the quasi-static threshold a = g b / h of the Housner block,
 * at the same history sample with and without sleeping); a batch with sleeping on gives every run
 * bitwise its run alone at every width. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "cf_test.h"
#include "parthenon_column.h"
#include "solver.h"
#include "solver_batch.h"
#include "solver_internal.h"
#include "solver_points_internal.h"

#define CF_PI 3.14159265358979323846

enum { NB = PARTHENON_NB };

static int check_value(const char *name, double v, char *msg)
{
    cf_solver_def d;
    cf_solver *s = cf_solver_create();
    int st;
    cf_solver_def_default(&d);
    cf_solver_options_set(&d, name, v);
    st = cf_solver_check_def(s, &d);
    strcpy(msg, cf_solver_message(s));
    cf_solver_free(s);
    return st;
}

/* sleep_margin in (0, 1), sleep 0 or 1: out of range (negative, NaN, 0, 1, above 1) refused by name */
static void test_options_refused_by_name(void)
{
    static const double bad[] = {-0.1, 0.0, 1.0, 1.5, NAN, INFINITY};
    char msg[CF_MSG_LEN];
    size_t i;
    for (i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        CF_CHECK(check_value("sleep_margin", bad[i], msg) == CF_EINVAL);
        CF_CHECK(strstr(msg, "sleep_margin must be in (0, 1)") != NULL);
    }
    CF_CHECK(check_value("sleep", 2.0, msg) == CF_EINVAL && strstr(msg, "sleep must be 0 or 1") != NULL);
    CF_CHECK(check_value("sleep", -1.0, msg) == CF_EINVAL && strstr(msg, "sleep") != NULL);
    CF_CHECK(check_value("sleep_margin", 0.3, msg) == CF_OK);
    CF_CHECK(check_value("sleep", 1.0, msg) == CF_OK);
}

static cf_solver *column(int sleep, double margin, int contact)
{
    cf_geometry_segment seg[NB + 1] = {{0}};
    int nseg[NB];
    cf_solver_def def;
    cf_solver *s = cf_solver_create();
    parthenon_column(seg, nseg);
    cf_solver_def_default(&def);
    def.contact = contact;
    def.early_exit = 0; def.tail_s = 1.0;
    cf_solver_options_set(&def, "sleep", sleep);
    cf_solver_options_set(&def, "sleep_margin", margin);
    if (cf_solver_setup(s, &def, NB, nseg, seg, 2700.0, 1e9, 1e9, 0.7535540501027942)) {
        fprintf(stderr, "setup: %s\n", cf_solver_message(s));
        cf_solver_free(s);
        return NULL;
    }
    return s;
}

enum { NW = 801 };   /* 4 s at 0.005 s */

/* the top's displacement history (x) of the default column under a 0.02 g, 2 Hz sine; *slept: the
 * joint-steps taken asleep, *steps the run's steps */
static int weak_run(int sleep, int contact, double *top, long cap, long *slept, long *steps)
{
    cf_solver *s = column(sleep, 0.5, contact);
    static double ax[NW], t[4000], h2[8000];
    cf_solver_result res;
    int i, st;
    if (!s) return -1;
    for (i = 0; i < NW; i++) ax[i] = 0.02 * 9.81 * sin(2.0 * CF_PI * 2.0 * 0.005 * i);
    cf_solver_set_history(s, cap, t, h2, NULL, NULL, NULL, NULL, NULL);
    st = cf_solver_run(s, ax, NULL, NULL, NW, 0.005, NULL, &res);
    for (i = 0; i < cap; i++) top[i] = h2[2 * i];
    *slept = ((cf_points *)s->contact)->slept;
    *steps = res.n_steps;
    cf_solver_free(s);
    return st;
}

/* The weak sine keeps every joint closed and sticking: with sleeping on, most joint-steps are taken
 * asleep, and the top's history is the full law's within 1e-9 of its peak. The sleeping joint's law
 * is the full law in exact arithmetic (solver_sleep.h): only round-off differs (measured 2e-14 of the
 * peak), amplified by no instability in a closed column's elastic response; 1e-9 leaves room for
 * that and fails for any error of the law (a missing term is O(1) of the joint's force, a wrong
 * sign of the shear map O(ks/kn)). */
static void test_weak_sine_sleeps_and_agrees(void)
{
    static double a[4000], b[4000];
    long cap = 1000, sa = -1, sb = -1, na = -1, nb = -2, i;
    int model;
    for (model = 0; model < 2; model++) {
        double peak = 0.0, diff = 0.0;
        int contact = model == 0 ? CF_SOLVER_CONTACT_VERTEX : CF_SOLVER_CONTACT_PERIMETER;
        CF_CHECK(weak_run(0, contact, a, cap, &sa, &na) == CF_OK);
        CF_CHECK(weak_run(1, contact, b, cap, &sb, &nb) == CF_OK);
        CF_CHECK(sa == 0 && na == nb);
        /* asleep at least 90 % of the joint-steps (NB joints): it falls asleep at its first ledger step */
        CF_CHECK(sb > 0.9 * NB * nb);
        for (i = 0; i < 500; i++) {
            if (fabs(a[i]) > peak) peak = fabs(a[i]);
            if (fabs(a[i] - b[i]) > diff) diff = fabs(a[i] - b[i]);
        }
        CF_CHECK(peak > 1e-4);
        CF_CHECK(diff <= 1e-9 * peak);
        CF_CHECK(diff > 0.0);   /* the sleeping law was taken: its round-off differs */
    }
}

/* One square block, 0.4 m wide and 2 m tall (b / h = 0.2 / 1.0), on the ground, under a ramp of ground
 * acceleration a(t) = 0.3 g t / 4 s: returns the first history sample (1 ms) at which its joint opens
 * more than 1e-9 m. */
static long lift_off(int sleep, double *a_onset, long *slept)
{
    cf_geometry_segment seg = {2.0, 0.2 / cos(CF_PI / 4), 0.2 / cos(CF_PI / 4), CF_PI / 4, 4, 1.0};
    int nseg = 1;
    cf_solver_def def;
    cf_solver *s = cf_solver_create();
    static double ax[400], t[5000], top[10000], op[5000];
    long cap = 5000, i, k = -1;
    cf_solver_result res;
    cf_solver_def_default(&def);
    def.early_exit = 0; def.tail_s = 0.0; def.history_dt = 0.001;
    cf_solver_options_set(&def, "sleep", sleep);
    if (cf_solver_setup(s, &def, 1, &nseg, &seg, 2700.0, 1e9, 1e9, 0.7535540501027942)) { cf_solver_free(s); return -1; }
    for (i = 0; i < 400; i++) ax[i] = 0.3 * 9.81 * (0.01 * i) / 4.0;
    cap = cf_solver_history_capacity(s, 400, 0.01);
    if (cap > 5000) { cf_solver_free(s); return -1; }
    cf_solver_set_history(s, cap, t, top, NULL, NULL, op, NULL, NULL);
    cf_solver_run(s, ax, NULL, NULL, 400, 0.01, NULL, &res);
    for (i = 0; i < cap && i < res.n_steps; i++)
        if (op[i] > 1e-9) { k = i; break; }
    *a_onset = k >= 0 ? 0.3 * t[k] / 4.0 : NAN;
    *slept = ((cf_points *)s->contact)->slept;
    cf_solver_free(s);
    return k;
}

/* A strong motion wakes the joint: lift-off at the same sample with and without sleeping, and at the
 * Housner block's quasi-static threshold a / g = b / h = 0.2 (within 1 %: the ramp's dynamics and the
 * 1 ms sampling; the point supports make the threshold exact for the soft joint in statics). The
 * joint slept before (the ramp starts closed). */
static void test_strong_motion_wakes_at_lift_off(void)
{
    double a0, a1;
    long s0, s1, k0 = lift_off(0, &a0, &s0), k1 = lift_off(1, &a1, &s1);
    CF_CHECK(k0 > 0 && k0 == k1);
    CF_CHECK_REL(a0, 0.2, 0.01);
    CF_CHECK(s0 == 0 && s1 > 100);
}

/* A batch with sleeping on: every run bitwise its run alone, at every width (result and residuals). */
static void test_batch_equals_single_with_sleep(void)
{
    static const double amp[5] = {0.02, 0.25, 0.05, 0.6, 0.01};
    static const int len[5] = {NW, 500, NW, 600, 300};
    static double ax[5][NW], res_single[5][NB], res_batch[5][NB];
    cf_solver_result single[5];
    cf_solver_batch_job jobs[5];
    cf_solver_batch_out out[5];
    int i, w, n, widths[4] = {1, 2, 4, 8};
    cf_solver *s = column(1, 0.5, CF_SOLVER_CONTACT_VERTEX);
    if (!s) { CF_CHECK(0); return; }
    for (i = 0; i < 5; i++) {
        cf_solver *s1 = column(1, 0.5, CF_SOLVER_CONTACT_VERTEX);
        for (n = 0; n < NW; n++) ax[i][n] = amp[i] * 9.81 * sin(2.0 * CF_PI * 1.7 * 0.005 * n);
        CF_CHECK(cf_solver_run(s1, ax[i], NULL, NULL, len[i], 0.005, res_single[i], &single[i]) == CF_OK);
        cf_solver_free(s1);
        memset(&jobs[i], 0, sizeof jobs[i]);
        jobs[i].acc_x = ax[i]; jobs[i].n = len[i]; jobs[i].dt_rec = 0.005; jobs[i].residual_dislocation = res_batch[i];
    }
    for (w = 0; w < 4; w++) {
        if (widths[w] > cf_solver_batch_max_width(s)) continue;
        CF_CHECK(cf_solver_batch_run(s, widths[w], 5, jobs, out) == CF_OK);
        for (i = 0; i < 5; i++) {
            CF_CHECK(out[i].status == CF_OK);
            CF_CHECK(memcmp(&out[i].result.u_top, &single[i].u_top, sizeof(double)) == 0);
            CF_CHECK(memcmp(&out[i].result.u_d, &single[i].u_d, sizeof(double)) == 0);
            CF_CHECK(memcmp(&out[i].result.energy_error, &single[i].energy_error, sizeof(double)) == 0);
            CF_CHECK(out[i].result.n_steps == single[i].n_steps);
            CF_CHECK(memcmp(res_batch[i], res_single[i], sizeof res_single[i]) == 0);
        }
    }
    cf_solver_free(s);
}

int main(void)
{
    CF_RUN(test_options_refused_by_name);
    CF_RUN(test_weak_sine_sleeps_and_agrees);
    CF_RUN(test_strong_motion_wakes_at_lift_off);
    CF_RUN(test_batch_equals_single_with_sleep);
    return CF_TEST_SUMMARY("test_sleep");
}
