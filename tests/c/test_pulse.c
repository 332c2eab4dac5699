/* Mavroeidis & Papageorgiou (2003) pulse: closed-form acceleration against a
 * central difference of the velocity, displacement derivative against the
 * velocity, zero/constant outside the support, gamma = 1 continuity, bad input. */
#include <math.h>
#include "cf_test.h"
#include "cf_common.h"
#include "pulse.h"

static const cf_pulse_params P = {0.8, 0.45, 0.7, 2.1, 5.0}; /* A m/s, fp Hz, nu rad, gamma, t0 s */

/* Central difference with h = 1e-5 s: truncation h^2/6 |V'''| <= 1e-10 A W^3 ~ 2e-9,
 * rounding ~ 1e-16 A / h ~ 1e-11; compare against 1e-7 of the peak A W ~ 2.3 m/s^2. */
static void test_acc_is_derivative_of_vel(void)
{
    double h = 1e-5, W = 2 * CF_PI * P.fp;
    int i;
    for (i = 0; i < 400; i++) {
        double t = 5.0 - 2.3 + 4.6 * i / 399.0;     /* support is 5 -/+ 2.333 s: stay inside */
        double tt[3] = {t - h, t, t + h}, v[3], a[3];
        CF_CHECK(cf_pulse_eval(&P, tt, 3, v, a, NULL) == CF_OK);
        CF_CHECK_CLOSE(a[1], (v[2] - v[0]) / (2 * h), 1e-7 * P.amplitude * W);
    }
}

static void test_disp_derivative_is_vel(void)
{
    double h = 1e-5;
    int i;
    for (i = 0; i < 400; i++) {
        double t = 5.0 - 2.3 + 4.6 * i / 399.0;
        double tt[3] = {t - h, t, t + h}, v[3], d[3];
        CF_CHECK(cf_pulse_eval(&P, tt, 3, v, NULL, d) == CF_OK);
        CF_CHECK_CLOSE(v[1], (d[2] - d[0]) / (2 * h), 1e-8 * P.amplitude);
    }
}

/* Displacement at the end of the support against a composite Simpson integral of V
 * (20000 intervals: error ~ (L/n)^4 |V''''| L / 180 ~ 1e-15). */
static void test_disp_end_vs_simpson(void)
{
    double ts, te, t[1], d[1], v[1], s = 0.0;
    int i, n = 20000;
    CF_CHECK(cf_pulse_support(&P, &ts, &te) == CF_OK);
    for (i = 0; i <= n; i++) {
        double w = (i == 0 || i == n) ? 1.0 : (i % 2 ? 4.0 : 2.0);
        t[0] = ts + (te - ts) * i / n;
        cf_pulse_eval(&P, t, 1, v, NULL, NULL);
        s += w * v[0];
    }
    s *= (te - ts) / n / 3.0;
    t[0] = te;
    cf_pulse_eval(&P, t, 1, NULL, NULL, d);
    CF_CHECK_CLOSE(d[0], s, 1e-12);
}

static void test_outside_support(void)
{
    double ts, te, t[4], v[4], a[4], d[4], dend[1];
    CF_CHECK(cf_pulse_support(&P, &ts, &te) == CF_OK);
    CF_CHECK_REL(te - ts, P.gamma / P.fp, 1e-14);
    t[0] = ts - 1.0; t[1] = ts - 1e-9; t[2] = te + 1e-9; t[3] = te + 50.0;
    CF_CHECK(cf_pulse_eval(&P, t, 4, v, a, d) == CF_OK);
    cf_pulse_eval(&P, &te, 1, NULL, NULL, dend);
    CF_CHECK(v[0] == 0.0 && v[1] == 0.0 && v[2] == 0.0 && v[3] == 0.0);
    CF_CHECK(a[0] == 0.0 && a[1] == 0.0 && a[2] == 0.0 && a[3] == 0.0);
    CF_CHECK(d[0] == 0.0 && d[1] == 0.0);
    CF_CHECK(d[2] == dend[0] && d[3] == dend[0]);
    /* velocity and displacement are continuous at the support's ends (envelope 0 there) */
    t[0] = ts; t[1] = te;
    cf_pulse_eval(&P, t, 2, v, NULL, d);
    CF_CHECK_CLOSE(v[0], 0.0, 1e-15);
    CF_CHECK_CLOSE(v[1], 0.0, 1e-15);
    CF_CHECK_CLOSE(d[0], 0.0, 1e-15);
}

/* gamma = 1 makes W - W/gamma vanish: D must be continuous across it. */
static void test_gamma_one(void)
{
    cf_pulse_params p1 = {1.0, 1.0, 0.3, 1.0, 0.0}, p2 = p1;
    double t[1] = {0.2}, d1[1], d2[1];
    p2.gamma = 1.0 + 1e-9;
    CF_CHECK(cf_pulse_eval(&p1, t, 1, NULL, NULL, d1) == CF_OK);
    CF_CHECK(cf_pulse_eval(&p2, t, 1, NULL, NULL, d2) == CF_OK);
    CF_CHECK(isfinite(d1[0]));
    CF_CHECK_CLOSE(d1[0], d2[0], 1e-8);
}

static void test_bad_input(void)
{
    cf_pulse_params p = P;
    double t[1] = {0.0}, v[1], a, b;
    p.fp = 0.0;
    CF_CHECK(cf_pulse_eval(&p, t, 1, v, NULL, NULL) == CF_EINVAL);
    p = P; p.gamma = -1.0;
    CF_CHECK(cf_pulse_eval(&p, t, 1, v, NULL, NULL) == CF_EINVAL);
    p = P; p.nu = NAN;
    CF_CHECK(cf_pulse_eval(&p, t, 1, v, NULL, NULL) == CF_EINVAL);
    CF_CHECK(cf_pulse_eval(NULL, t, 1, v, NULL, NULL) == CF_EINVAL);
    CF_CHECK(cf_pulse_eval(&P, NULL, 1, v, NULL, NULL) == CF_EINVAL);
    CF_CHECK(cf_pulse_eval(&P, t, -1, v, NULL, NULL) == CF_EINVAL);
    t[0] = INFINITY;
    CF_CHECK(cf_pulse_eval(&P, t, 1, v, NULL, NULL) == CF_EINVAL);
    CF_CHECK(cf_pulse_support(&P, &a, NULL) == CF_EINVAL);
    (void)b;
}

int main(void)
{
    CF_RUN(test_acc_is_derivative_of_vel);
    CF_RUN(test_disp_derivative_is_vel);
    CF_RUN(test_disp_end_vs_simpson);
    CF_RUN(test_outside_support);
    CF_RUN(test_gamma_one);
    CF_RUN(test_bad_input);
    return CF_TEST_SUMMARY("test_pulse");
}
