/* The AS00 spectrum, duration and window against hand-evaluated values, the
 * generator's argument checks, determinism, normalisation, and records made from
 * given standard normals. */
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include "cf_test.h"
#include "cf_common.h"
#include "fft.h"
#include "rng.h"
#include "stochastic.h"

/* Expected values evaluated with plain Python floats from the formulas of
 * pycolfrag/data/as00.json, independently of this C code (M 6.5, d 10 km):
 *   f = 0.5 Hz: 0.2508919669049058 m/s;  1 Hz: 0.4028145756895959;  5 Hz: 0.46497373125817865
 *   T_gm = 6.173835098540148 s.
 * Tolerance 1e-13 relative: the same formula in another operation order
 * (pow/exp/log of libm) differs by a few ulp. */
static void test_fas_and_duration(void)
{
    double f[4] = {0.0, 0.5, 1.0, 5.0}, a[4];
    char msg[CF_MSG_LEN];
    CF_CHECK(cf_stochastic_fas(6.5, 10.0, f, 4, a, msg) == CF_OK);
    CF_CHECK(a[0] == 0.0);
    CF_CHECK_REL(a[1], 0.2508919669049058, 1e-13);
    CF_CHECK_REL(a[2], 0.4028145756895959, 1e-13);
    CF_CHECK_REL(a[3], 0.46497373125817865, 1e-13);
    double tgm = 0;
    CF_CHECK(cf_stochastic_duration(6.5, 10.0, &tgm, msg) == CF_OK);
    CF_CHECK_REL(tgm, 6.173835098540148, 1e-14);
    f[1] = -1.0;
    CF_CHECK(cf_stochastic_fas(6.5, 10.0, f, 4, a, msg) == CF_EINVAL);
    CF_CHECK(strstr(msg, "f_hz[1]") != NULL);
}

/* Low-frequency limit: for f << fa the source spectrum is flat (S = 1 - O((f/fa)^2)),
 * the site amplification is 1 below 0.01 Hz and fmax plays no role, so A(f) =
 * C M0 G(R) exp(-pi f^0.55 R / (180 cQ)) exp(-pi kappa f) (2 pi f)^2; at 1e-4 Hz the
 * neglected (f/fa)^2 terms are ~3e-6 relative: tolerance 1e-5. */
static void test_fas_low_frequency(void)
{
    double f = 1e-4, a;
    CF_CHECK(cf_stochastic_fas(7.0, 20.0, &f, 1, &a, NULL) == CF_OK);
    double m0 = pow(10.0, 1.5 * 7.0 + 16.05), h = pow(10.0, -0.05 + 0.15 * 7.0);
    double r = sqrt(400.0 + h * h);
    double c = 0.55 * 0.707 * 2.0 / (4.0 * CF_PI * 2.8 * 3.5 * 3.5 * 3.5) * 1e-20;
    double anel = exp(-CF_PI * pow(f, 0.55) * r / (180.0 * 3.5)), kap = exp(-CF_PI * 0.030 * f);
    CF_CHECK_REL(a, 0.01 * c * m0 / r * anel * kap * pow(2.0 * CF_PI * f, 2), 1e-5);
}

/* Saragoni-Hart: maximum 1 at t = eps t_eta (eps = 0.2), value eta = 0.05 at t_eta. */
static void test_window(void)
{
    const double te = 10.0;
    CF_CHECK_CLOSE(cf_stochastic_window(0.2 * te, te), 1.0, 1e-14);
    CF_CHECK_CLOSE(cf_stochastic_window(te, te), 0.05, 1e-14);
    CF_CHECK(cf_stochastic_window(0.19 * te, te) < 1.0);
    CF_CHECK(cf_stochastic_window(0.21 * te, te) < 1.0);
    CF_CHECK(cf_stochastic_window(0.0, te) == 0.0);
}

static void test_bad_arguments(void)
{
    char msg[CF_MSG_LEN];
    CF_CHECK(cf_stochastic_check_scenario(3.9, 10.0, msg) == CF_ERANGE && strstr(msg, "Mw = 3.9"));
    CF_CHECK(cf_stochastic_check_scenario(8.1, 10.0, msg) == CF_ERANGE);
    CF_CHECK(cf_stochastic_check_scenario(NAN, 10.0, msg) == CF_ERANGE);
    CF_CHECK(cf_stochastic_check_scenario(6.0, 0.0, msg) == CF_ERANGE && strstr(msg, "dist_km = 0"));
    CF_CHECK(cf_stochastic_check_scenario(6.0, 200.5, msg) == CF_ERANGE);
    CF_CHECK(cf_stochastic_check_scenario(6.0, INFINITY, msg) == CF_ERANGE);
    CF_CHECK(cf_stochastic_check_scenario(4.0, 200.0, msg) == CF_OK);
    cf_stochastic *g = cf_stochastic_create();
    cf_stochastic_def d;
    cf_stochastic_def_default(&d);
    double acc[4];
    CF_CHECK(cf_stochastic_run(g, 1, acc, 4) == CF_ESTATE);
    d.dt = 0.0;
    CF_CHECK(cf_stochastic_setup(g, &d) == CF_EINVAL && strstr(cf_stochastic_message(g), "dt = 0"));
    d.dt = 0.03;
    CF_CHECK(cf_stochastic_setup(g, &d) == CF_EINVAL);
    d.dt = NAN;
    CF_CHECK(cf_stochastic_setup(g, &d) == CF_EINVAL);
    cf_stochastic_def_default(&d);
    d.mw = 9.0;
    CF_CHECK(cf_stochastic_setup(g, &d) == CF_ERANGE);
    cf_stochastic_def_default(&d);
    CF_CHECK(cf_stochastic_setup(g, &d) == CF_OK);
    CF_CHECK(cf_stochastic_run(g, 1, acc, 4) == CF_EINVAL);   /* wrong length */
    cf_stochastic_free(g);
}

/* Sizes: window of floor(2 T_gm / dt) + 1 samples, 1 s before, 3 s after,
 * padding >= max(10 s, 0.5/fa) each side, nfft a power of two holding it all. */
static void test_info(void)
{
    cf_stochastic *g = cf_stochastic_create();
    cf_stochastic_def d;
    cf_stochastic_def_default(&d);
    d.mw = 7.5;
    d.dist_km = 5.0;
    CF_CHECK(cf_stochastic_setup(g, &d) == CF_OK);
    cf_stochastic_info in;
    CF_CHECK(cf_stochastic_get_info(g, &in) == CF_OK);
    CF_CHECK_REL(in.window_s, 2.0 * in.duration_s, 1e-15);
    CF_CHECK(in.n_window == (int)floor(in.window_s / d.dt) + 1);
    CF_CHECK(in.n_out == 200 + in.n_window + 600);
    CF_CHECK_CLOSE(in.window_start_s, 1.0, 1e-12);
    CF_CHECK(in.pad_s >= 0.5 / in.fa_hz && in.pad_s >= 10.0);
    CF_CHECK((in.nfft & (in.nfft - 1)) == 0 && in.nfft >= 2 * in.i_window + in.n_window);
    cf_stochastic_free(g);
}

/* Same seed -> bitwise the same record (also after another seed ran, and from a
 * second generator); another seed -> a different record. */
static void test_determinism(void)
{
    cf_stochastic *g1 = cf_stochastic_create(), *g2 = cf_stochastic_create();
    cf_stochastic_def d;
    cf_stochastic_def_default(&d);
    CF_CHECK(cf_stochastic_setup(g1, &d) == CF_OK && cf_stochastic_setup(g2, &d) == CF_OK);
    cf_stochastic_info in;
    cf_stochastic_get_info(g1, &in);
    int n = in.n_out;
    double *a = malloc(sizeof(double) * n), *b = malloc(sizeof(double) * n), *c = malloc(sizeof(double) * n);
    CF_CHECK(cf_stochastic_run(g1, 42, a, n) == CF_OK);
    CF_CHECK(cf_stochastic_run(g1, 43, c, n) == CF_OK);
    CF_CHECK(cf_stochastic_run(g2, 42, b, n) == CF_OK);
    CF_CHECK(memcmp(a, b, sizeof(double) * n) == 0);
    CF_CHECK(cf_stochastic_run(g1, 42, b, n) == CF_OK);
    CF_CHECK(memcmp(a, b, sizeof(double) * n) == 0);
    CF_CHECK(memcmp(a, c, sizeof(double) * n) != 0);
    free(a); free(b); free(c);
    cf_stochastic_free(g1);
    cf_stochastic_free(g2);
}

/* Normalisation: the ensemble mean of |dt * DFT(acc)|^2 over 40 records follows
 * A(f)^2 within 12 % in the 1-10 Hz band (about 40 records x 10 000 bins per band:
 * the statistical scatter is far below 1 %; the tolerance covers the windowing
 * leakage and the trim, which removes a little of the motion). */
static void test_spectrum_normalisation(void)
{
    cf_stochastic *g = cf_stochastic_create();
    cf_stochastic_def d;
    cf_stochastic_def_default(&d);
    d.mw = 6.0;
    d.dist_km = 10.0;
    CF_CHECK(cf_stochastic_setup(g, &d) == CF_OK);
    cf_stochastic_info in;
    cf_stochastic_get_info(g, &in);
    const int n = in.n_out, nf = cf_fft_next_pow2(n) * 2, nh = nf / 2;
    cf_fft_plan *plan = NULL;
    CF_CHECK(cf_fft_plan_create(nf, &plan) == CF_OK);
    double *x = calloc(nf + 2, sizeof(double)), *p2 = calloc(nh + 1, sizeof(double));
    double *f = malloc(sizeof(double) * (nh + 1)), *a = malloc(sizeof(double) * (nh + 1));
    const int nrec = 40;
    for (int r = 0; r < nrec; r++) {
        memset(x, 0, sizeof(double) * (nf + 2));
        cf_stochastic_run(g, 1000 + r, x, n);
        cf_fft_forward(plan, x, x);
        for (int k = 0; k <= nh; k++)
            p2[k] += d.dt * d.dt * (x[2 * k] * x[2 * k] + x[2 * k + 1] * x[2 * k + 1]) / nrec;
    }
    for (int k = 0; k <= nh; k++)
        f[k] = k / (nf * d.dt);
    CF_CHECK(cf_stochastic_fas(d.mw, d.dist_km, f, nh + 1, a, NULL) == CF_OK);
    double s_sim = 0, s_tgt = 0;
    for (int k = 0; k <= nh; k++) {
        if (f[k] >= 1.0 && f[k] <= 10.0) {
            s_sim += p2[k];
            s_tgt += a[k] * a[k];
        }
    }
    CF_CHECK_REL(sqrt(s_sim / s_tgt), 1.0, 0.12);
    free(x); free(p2); free(f); free(a);
    cf_fft_plan_free(plan);
    cf_stochastic_free(g);
}

static cf_stochastic *set_up(double mw, double dist_km, cf_stochastic_info *in)
{
    cf_stochastic *g = cf_stochastic_create();
    cf_stochastic_def d;
    cf_stochastic_def_default(&d);
    d.mw = mw;
    d.dist_km = dist_km;
    CF_CHECK(cf_stochastic_setup(g, &d) == CF_OK);
    CF_CHECK(cf_stochastic_get_info(g, in) == CF_OK);
    return g;
}

/* The split of a seeded run into "draw the normals" and "make the record from given
 * normals" is exact: the normals are n_window calls of cf_rng_normal after
 * cf_rng_seed(seed) (the polar method's spare of an odd count dropped), and the
 * record made from them equals cf_stochastic_run(seed) bit for bit. Scenarios with
 * an odd and an even n_window (checked), seeds at 0, small, the grid's and above 2^32. */
static void test_normals_reproduce_seeded_runs(void)
{
    const double scen[4][2] = {{5.5, 20.0}, {6.5, 10.0}, {7.5, 5.0}, {6.37, 3.2}};
    const uint64_t seeds[4] = {0, 1, 20160601, (UINT64_C(1) << 40) + 7};
    int parity[2] = {0, 0};
    for (int s = 0; s < 4; s++) {
        cf_stochastic_info in;
        cf_stochastic *g = set_up(scen[s][0], scen[s][1], &in);
        parity[in.n_window % 2] = 1;
        double *z = malloc(sizeof(double) * in.n_window), *zr = malloc(sizeof(double) * in.n_window);
        double *a = malloc(sizeof(double) * in.n_out), *b = malloc(sizeof(double) * in.n_out);
        for (int k = 0; k < 4; k++) {
            CF_CHECK(cf_stochastic_draw_normals(g, seeds[k], z, in.n_window) == CF_OK);
            cf_rng r;
            cf_rng_seed(&r, seeds[k]);
            for (int i = 0; i < in.n_window; i++)
                zr[i] = cf_rng_normal(&r);
            CF_CHECK(memcmp(z, zr, sizeof(double) * in.n_window) == 0);
            CF_CHECK(cf_stochastic_run(g, seeds[k], a, in.n_out) == CF_OK);
            CF_CHECK(cf_stochastic_run_normals(g, z, in.n_window, b, in.n_out) == CF_OK);
            CF_CHECK(memcmp(a, b, sizeof(double) * in.n_out) == 0);
        }
        free(z); free(zr); free(a); free(b);
        cf_stochastic_free(g);
    }
    CF_CHECK(parity[0] && parity[1]);
}

/* The record is invariant to a positive factor on all the normals (step 3 divides by
 * their RMS spectral amplitude). With the factor 2 every operation of the recipe
 * (products, FFT sums, the square root of 4 sum) is exact in binary, so the record is
 * bitwise the same; with 3.7 it agrees to rounding (1e-12 of the peak: a few ulp of
 * each FFT output summed over log2(nfft) stages). */
static void test_normals_scale_invariance(void)
{
    cf_stochastic_info in;
    cf_stochastic *g = set_up(6.5, 10.0, &in);
    const int nw = in.n_window, n = in.n_out;
    double *z = malloc(sizeof(double) * nw), *z2 = malloc(sizeof(double) * nw);
    double *a = malloc(sizeof(double) * n), *b = malloc(sizeof(double) * n);
    CF_CHECK(cf_stochastic_draw_normals(g, 7, z, nw) == CF_OK);
    CF_CHECK(cf_stochastic_run_normals(g, z, nw, a, n) == CF_OK);
    for (int i = 0; i < nw; i++)
        z2[i] = 2.0 * z[i];
    CF_CHECK(cf_stochastic_run_normals(g, z2, nw, b, n) == CF_OK);
    CF_CHECK(memcmp(a, b, sizeof(double) * n) == 0);
    for (int i = 0; i < nw; i++)
        z2[i] = 3.7 * z[i];
    CF_CHECK(cf_stochastic_run_normals(g, z2, nw, b, n) == CF_OK);
    double peak = 0.0, diff = 0.0;
    for (int i = 0; i < n; i++) {
        peak = fmax(peak, fabs(a[i]));
        diff = fmax(diff, fabs(a[i] - b[i]));
    }
    CF_CHECK(peak > 0.0 && diff <= 1e-12 * peak);
    free(z); free(z2); free(a); free(b);
    cf_stochastic_free(g);
}

/* Bad calls: before setup, wrong lengths, a non-finite normal (named by index), all
 * zeros (no spectrum to normalise); never a crash, always a status and a message. */
static void test_normals_bad_arguments(void)
{
    cf_stochastic *g = cf_stochastic_create();
    double z[8] = {0}, acc[8];
    CF_CHECK(cf_stochastic_draw_normals(g, 1, z, 8) == CF_ESTATE);
    CF_CHECK(strstr(cf_stochastic_message(g), "cf_stochastic_draw_normals") != NULL);
    CF_CHECK(cf_stochastic_run_normals(g, z, 8, acc, 8) == CF_ESTATE);
    CF_CHECK(cf_stochastic_draw_normals(NULL, 1, z, 8) == CF_EINVAL);
    CF_CHECK(cf_stochastic_run_normals(NULL, z, 8, acc, 8) == CF_EINVAL);
    cf_stochastic_free(g);

    cf_stochastic_info in;
    g = set_up(6.0, 10.0, &in);
    const int nw = in.n_window, n = in.n_out;
    double *zz = calloc(nw, sizeof(double)), *a = malloc(sizeof(double) * n);
    CF_CHECK(cf_stochastic_draw_normals(g, 1, zz, nw - 1) == CF_EINVAL);
    CF_CHECK(strstr(cf_stochastic_message(g), "n_window") != NULL);
    CF_CHECK(cf_stochastic_draw_normals(g, 1, NULL, nw) == CF_EINVAL);
    CF_CHECK(cf_stochastic_run_normals(g, zz, nw + 1, a, n) == CF_EINVAL);
    CF_CHECK(cf_stochastic_run_normals(g, zz, nw, a, n - 1) == CF_EINVAL);
    CF_CHECK(strstr(cf_stochastic_message(g), "output array") != NULL);
    CF_CHECK(cf_stochastic_run_normals(g, zz, nw, a, n) == CF_EUNSTABLE);   /* all zero */
    CF_CHECK(cf_stochastic_draw_normals(g, 1, zz, nw) == CF_OK);
    zz[7] = NAN;
    CF_CHECK(cf_stochastic_run_normals(g, zz, nw, a, n) == CF_EINVAL);
    CF_CHECK(strstr(cf_stochastic_message(g), "normals[7]") != NULL);
    zz[7] = INFINITY;
    CF_CHECK(cf_stochastic_run_normals(g, zz, nw, a, n) == CF_EINVAL);
    zz[7] = 0.5;
    CF_CHECK(cf_stochastic_run_normals(g, zz, nw, a, n) == CF_OK);
    CF_CHECK(cf_stochastic_message(g)[0] == 0);
    free(zz); free(a);
    cf_stochastic_free(g);
}

int main(void)
{
    CF_RUN(test_fas_and_duration);
    CF_RUN(test_fas_low_frequency);
    CF_RUN(test_window);
    CF_RUN(test_bad_arguments);
    CF_RUN(test_info);
    CF_RUN(test_determinism);
    CF_RUN(test_spectrum_normalisation);
    CF_RUN(test_normals_reproduce_seeded_runs);
    CF_RUN(test_normals_scale_invariance);
    CF_RUN(test_normals_bad_arguments);
    return CF_TEST_SUMMARY("test_stochastic");
}
