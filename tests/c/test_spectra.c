/* Intensity measures against closed forms: trapezoidal integrals of a ramp,
 * Arias and D5-95 of a constant record, Nigam-Jennings step and ramp responses
 * and the displacement history against the exact SDOF solutions, bad input. */
#include <math.h>
#include <stdlib.h>
#include "cf_test.h"
#include "cf_common.h"
#include "spectra.h"

/* The trapezoidal rule is exact for linear integrands: a = c gives v = c t exactly,
 * and v linear gives d = c t^2 / 2 exactly (up to rounding, ~1e-15 relative). */
static void test_integrate_constant(void)
{
    double acc[101], vel[101], disp[101], c = 1.7, dt = 0.01;
    int i;
    for (i = 0; i < 101; i++) acc[i] = c;
    CF_CHECK(cf_spectra_integrate(acc, 101, dt, vel, disp) == CF_OK);
    for (i = 0; i < 101; i++) {
        CF_CHECK_CLOSE(vel[i], c * i * dt, 1e-13);
        CF_CHECK_CLOSE(disp[i], 0.5 * c * (i * dt) * (i * dt), 1e-13);
    }
    CF_CHECK(cf_spectra_integrate(acc, 101, dt, NULL, NULL) == CF_OK);
}

/* Constant record of amplitude c over T = (n-1) dt: Arias = pi c^2 T / (2 g);
 * the Husid integral grows linearly, so t5 = 0.05 T, t95 = 0.95 T, D = 0.9 T. */
static void test_peaks_constant(void)
{
    int n = 2001, i;
    double dt = 0.005, c = -2.0, g = 9.81, T = (n - 1) * dt;
    double *acc = malloc(sizeof(double) * n);
    cf_spectra_ims r;
    for (i = 0; i < n; i++) acc[i] = c;
    CF_CHECK(cf_spectra_peaks(acc, n, dt, g, &r) == CF_OK);
    CF_CHECK_REL(r.pga, 2.0, 1e-15);
    CF_CHECK_REL(r.pgv, 2.0 * T, 1e-12);
    CF_CHECK_REL(r.pgd, T * T, 1e-12);
    CF_CHECK_REL(r.arias, CF_PI * c * c * T / (2 * g), 1e-12);
    CF_CHECK_REL(r.t5, 0.05 * T, 1e-12);
    CF_CHECK_REL(r.t95, 0.95 * T, 1e-12);
    CF_CHECK_REL(r.d5_95, 0.9 * T, 1e-12);
    for (i = 0; i < n; i++) acc[i] = 0.0;
    CF_CHECK(cf_spectra_peaks(acc, n, dt, g, &r) == CF_OK);
    CF_CHECK(r.arias == 0.0 && r.d5_95 == 0.0 && r.pga == 0.0);
    free(acc);
}

/* Exact SDOF response from rest to a_g = c (step at t = 0+, constant after):
 * x(t) = -(c / w^2) [1 - e^{-z w t} (cos wd t + z / sqrt(1 - z^2) sin wd t)]
 * (any structural-dynamics text, e.g. Chopra Eq. 4.3.x for a step force).
 * The recurrence is exact for piecewise-linear input, so only rounding remains;
 * checked for short, medium and long periods and zero damping. */
static void test_nj_step(void)
{
    double periods[4] = {0.05, 0.5, 3.0, 10.0}, damps[3] = {0.0, 0.05, 0.4}, dt = 0.005, c = 1.3;
    int ip, iz, i;
    for (ip = 0; ip < 4; ip++)
        for (iz = 0; iz < 3; iz++) {
            double T = periods[ip], z = damps[iz], w = 2 * CF_PI / T, wd = w * sqrt(1 - z * z);
            double k[8], x = 0.0, v = 0.0;
            CF_CHECK(cf_spectra_nj_coefficients(T, z, dt, k) == CF_OK);
            for (i = 1; i <= 4000; i++) {
                double x1 = k[0] * x + k[1] * v + (k[4] + k[5]) * c;
                double v1 = k[2] * x + k[3] * v + (k[6] + k[7]) * c;
                double t = i * dt, e = exp(-z * w * t);
                double xe = -(c / (w * w)) * (1 - e * (cos(wd * t) + z / sqrt(1 - z * z) * sin(wd * t)));
                double ve = -(c / (w * w)) * e * (w * w / wd) * sin(wd * t);
                x = x1; v = v1;
                if (i % 97 == 0 || i == 1) {
                    /* rounding grows with the step count and with 1/(w dt) cancellation in b */
                    CF_CHECK_CLOSE(x, xe, 1e-9 * c / (w * w));
                    CF_CHECK_CLOSE(v, ve, 1e-9 * c / w);
                }
            }
        }
}

/* Undamped ramp a_g = r t from rest: x = -(r / w^2)(t - sin(w t) / w), exact for the
 * recurrence (linear input); tests b11 and b12 separately from the step test. */
static void test_nj_ramp_response(void)
{
    int n = 3001, i;
    double dt = 0.004, r = 0.9, T = 0.7, w = 2 * CF_PI / T, per[1] = {T}, sd[1], sv[1], sa[1];
    double xmax = 0.0, vmax = 0.0, amax = 0.0;
    double *acc = malloc(sizeof(double) * n);
    for (i = 0; i < n; i++) {
        double t = i * dt;
        double x = -(r / (w * w)) * (t - sin(w * t) / w), v = -(r / (w * w)) * (1 - cos(w * t));
        acc[i] = r * t;
        if (fabs(x) > xmax) xmax = fabs(x);
        if (fabs(v) > vmax) vmax = fabs(v);
        if (fabs(w * w * x) > amax) amax = fabs(w * w * x);
    }
    CF_CHECK(cf_spectra_response(acc, n, dt, per, 1, 0.0, sd, sv, sa) == CF_OK);
    CF_CHECK_REL(sd[0], xmax, 1e-10);
    CF_CHECK_REL(sv[0], vmax, 1e-10);
    CF_CHECK_REL(sa[0], amax, 1e-10);
    free(acc);
}

/* The displacement history of the step record a_g = c (from rest; the record's first sample is
 * c too, so the input is constant: the step test's closed form), sample by sample; and its
 * max |x| is the SD of cf_spectra_response bit for bit on an irregular record (the same steps). */
static void test_displacement_history(void)
{
    int n = 2001, i;
    double dt = 0.005, c = 1.3, T = 0.5, z = 0.05, w = 2 * CF_PI / T, wd = w * sqrt(1 - z * z);
    double *acc = malloc(sizeof(double) * n), *x = malloc(sizeof(double) * n);
    double per[1] = {T}, sd[1], xm = 0.0;
    for (i = 0; i < n; i++) acc[i] = c;
    CF_CHECK(cf_spectra_displacement(acc, n, dt, T, z, x) == CF_OK);
    CF_CHECK(x[0] == 0.0);
    for (i = 1; i < n; i++) {
        double t = i * dt, e = exp(-z * w * t);
        double xe = -(c / (w * w)) * (1 - e * (cos(wd * t) + z / sqrt(1 - z * z) * sin(wd * t)));
        CF_CHECK_CLOSE(x[i], xe, 1e-9 * c / (w * w));     /* rounding only, as in the step test */
    }
    for (i = 0; i < n; i++) acc[i] = sin(0.37 * i) + 0.5 * cos(1.91 * i) * (i % 7 == 0 ? 3.0 : 1.0);
    CF_CHECK(cf_spectra_displacement(acc, n, dt, T, z, x) == CF_OK);
    CF_CHECK(cf_spectra_response(acc, n, dt, per, 1, z, sd, NULL, NULL) == CF_OK);
    for (i = 0; i < n; i++)
        if (fabs(x[i]) > xm) xm = fabs(x[i]);
    CF_CHECK(xm == sd[0]);
    free(acc);
    free(x);
}

static void test_bad_input(void)
{
    double a[3] = {0, 1, 0}, per[2] = {1.0, -1.0}, out[2], k[8];
    cf_spectra_ims r;
    CF_CHECK(cf_spectra_integrate(a, 3, 0.0, out, NULL) == CF_EINVAL);
    CF_CHECK(cf_spectra_integrate(a, 0, 0.01, NULL, NULL) == CF_EINVAL);
    CF_CHECK(cf_spectra_peaks(a, 3, -0.01, 9.81, &r) == CF_EINVAL);
    CF_CHECK(cf_spectra_peaks(a, 3, 0.01, 9.81, NULL) == CF_EINVAL);
    CF_CHECK(cf_spectra_response(a, 3, 0.01, per, 2, 0.05, out, NULL, NULL) == CF_EINVAL);
    CF_CHECK(cf_spectra_response(a, 3, 0.01, per, 1, 1.0, out, NULL, NULL) == CF_EINVAL);
    CF_CHECK(cf_spectra_response(a, 3, 0.01, per, 1, -0.1, out, NULL, NULL) == CF_EINVAL);
    CF_CHECK(cf_spectra_response(a, 3, NAN, per, 1, 0.05, out, NULL, NULL) == CF_EINVAL);
    CF_CHECK(cf_spectra_nj_coefficients(0.0, 0.05, 0.01, k) == CF_EINVAL);
    CF_CHECK(cf_spectra_displacement(a, 3, 0.01, 0.0, 0.05, out) == CF_EINVAL);
    CF_CHECK(cf_spectra_displacement(a, 3, 0.01, 1.0, 1.0, out) == CF_EINVAL);
    CF_CHECK(cf_spectra_displacement(a, 0, 0.01, 1.0, 0.05, out) == CF_EINVAL);
    CF_CHECK(cf_spectra_displacement(a, 3, 0.01, 1.0, 0.05, NULL) == CF_EINVAL);
}

int main(void)
{
    CF_RUN(test_integrate_constant);
    CF_RUN(test_peaks_constant);
    CF_RUN(test_nj_step);
    CF_RUN(test_nj_ramp_response);
    CF_RUN(test_displacement_history);
    CF_RUN(test_bad_input);
    return CF_TEST_SUMMARY("test_spectra");
}
