/* Fourier-amplitude combination (paper steps 3-6): exact cases and a synthetic
 * noise + sine-burst case. */
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include "cf_test.h"
#include "cf_common.h"
#include "combine.h"
#include "fft.h"
#include "rng.h"

#define N 3000

static double maxabs_diff(const double *a, const double *b, int n)
{
    double m = 0;
    for (int i = 0; i < n; i++)
        m = fmax(m, fabs(a[i] - b[i]));
    return m;
}

static void noise(double *x, int n, uint64_t seed)
{
    cf_rng r;
    cf_rng_seed(&r, seed);
    for (int i = 0; i < n; i++)
        x[i] = cf_rng_normal(&r);
}

/* pulse = 0: |HF| - 0 with HF's phase is HF, so the output is HF (to FFT rounding,
 * ~1e-15 of max|HF|; tolerance 1e-12 absolute for unit-variance noise). */
static void test_zero_pulse(void)
{
    static double hf[N], p[N], out[N];
    noise(hf, N, 1);
    memset(p, 0, sizeof p);
    CF_CHECK(cf_combine_subtract(hf, p, N, out, NULL) == CF_OK);
    CF_CHECK(maxabs_diff(out, hf, N) < 1e-12);
}

/* pulse = c HF: |P| = c |HF| in every bin, so
 *   c < 1: amplitude (1 - c)|HF| with HF's phase -> (1 - c) HF + c HF = HF;
 *   c > 1: amplitude clipped at 0 (never negative) -> 0 + c HF = c HF
 *          (without the clip the result would be HF again);
 *   pulse = -c HF, c < 1/2: (1 - c) HF - c HF = (1 - 2c) HF.
 * All exact up to rounding (1e-12 for unit-variance noise). */
static void test_proportional_pulse(void)
{
    static double hf[N], p[N], out[N], expect[N];
    noise(hf, N, 2);
    for (int i = 0; i < N; i++)
        p[i] = 0.3 * hf[i];
    CF_CHECK(cf_combine_subtract(hf, p, N, out, NULL) == CF_OK);
    CF_CHECK(maxabs_diff(out, hf, N) < 1e-12);
    for (int i = 0; i < N; i++)
        p[i] = 2.5 * hf[i];
    CF_CHECK(cf_combine_subtract(hf, p, N, out, NULL) == CF_OK);
    CF_CHECK(maxabs_diff(out, p, N) < 1e-12);
    for (int i = 0; i < N; i++) {
        p[i] = -0.2 * hf[i];
        expect[i] = 0.6 * hf[i];
    }
    CF_CHECK(cf_combine_subtract(hf, p, N, out, NULL) == CF_OK);
    CF_CHECK(maxabs_diff(out, expect, N) < 1e-12);
}

/* Smoothed Fourier amplitude sqrt(mean |X_k|^2) of x (n samples, zero padded to
 * nf) over bins [k0, k1]. */
static double band_amp(const cf_fft_plan *plan, const double *x, int n, int k0, int k1)
{
    int nf = cf_fft_plan_size(plan);
    double *s = calloc(nf + 2, sizeof(double));
    memcpy(s, x, sizeof(double) * n);
    cf_fft_forward(plan, s, s);
    double sum = 0;
    for (int k = k0; k <= k1; k++)
        sum += s[2 * k] * s[2 * k] + s[2 * k + 1] * s[2 * k + 1];
    free(s);
    return sqrt(sum / (k1 - k0 + 1));
}

/* White noise (sd 0.1) and a 4-cycle Hann-tapered sine burst at 0.5 Hz (amplitude 5),
 * dt 0.01 s. Near 0.5 Hz the burst's amplitude is ~20x the noise's: the result's
 * Fourier amplitude there follows the pulse (ratio within 10 %: the residual HF part
 * is clipped to ~0 in those bins, what is left is noise leaking from the truncation).
 * Far away (10-20 Hz) the burst's amplitude is < 1e-3 of the noise's: the result
 * follows HF (within 2 %). So the result's amplitude follows the larger part. */
static void test_sine_burst(void)
{
    static double hf[N], p[N], out[N];
    const double dt = 0.01, f0 = 0.5, t0 = 10.0, dur = 4.0 / f0;
    noise(hf, N, 3);
    for (int i = 0; i < N; i++) {
        hf[i] *= 0.1;
        double t = i * dt - t0;
        p[i] = (t >= 0 && t <= dur) ? 5.0 * sin(2 * CF_PI * f0 * t) * 0.5 * (1 - cos(2 * CF_PI * t / dur)) : 0.0;
    }
    CF_CHECK(cf_combine_subtract(hf, p, N, out, NULL) == CF_OK);
    const int nf = 4096;   /* 1 bin = 1/(nf dt) = 0.0244 Hz */
    cf_fft_plan *plan = NULL;
    CF_CHECK(cf_fft_plan_create(nf, &plan) == CF_OK);
    int k0 = (int)(0.45 * nf * dt), k1 = (int)(0.55 * nf * dt);
    double ap = band_amp(plan, p, N, k0, k1), ah = band_amp(plan, hf, N, k0, k1), ao = band_amp(plan, out, N, k0, k1);
    CF_CHECK(ap > 10 * ah);
    CF_CHECK_REL(ao, ap, 0.10);
    k0 = (int)(10.0 * nf * dt);
    k1 = (int)(20.0 * nf * dt);
    ap = band_amp(plan, p, N, k0, k1);
    ah = band_amp(plan, hf, N, k0, k1);
    ao = band_amp(plan, out, N, k0, k1);
    CF_CHECK(ap < 1e-3 * ah);
    CF_CHECK_REL(ao, ah, 0.02);
    cf_fft_plan_free(plan);
}

static void test_bad_input(void)
{
    double hf[4] = {0, 1, 2, 3}, p[4] = {0, 0, NAN, 0}, out[4];
    char msg[CF_MSG_LEN];
    CF_CHECK(cf_combine_subtract(hf, p, 4, out, msg) == CF_EINVAL && strstr(msg, "sample 2"));
    CF_CHECK(cf_combine_subtract(hf, hf, 0, out, msg) == CF_EINVAL);
    CF_CHECK(cf_combine_subtract(NULL, hf, 4, out, msg) == CF_EINVAL);
    /* n = 1 works (nfft 2) */
    CF_CHECK(cf_combine_subtract(hf + 1, hf, 1, out, msg) == CF_OK);
}

/* A caller's plan (what pycolfrag.ground_motion.combine caches per length) gives the
 * same bits as the call that builds its own: same plan values, same operations. A plan of
 * another length, or none, is refused. */
static void test_shared_plan(void)
{
    static double hf[N], p[N], out1[N], out2[N];
    char msg[CF_MSG_LEN];
    cf_fft_plan *plan = NULL, *small = NULL;
    noise(hf, N, 4);
    noise(p, N, 5);
    CF_CHECK(cf_combine_nfft(N) == 8192 && cf_combine_nfft(1) == 2 && cf_combine_nfft(0) == -1);
    CF_CHECK(cf_fft_plan_create(cf_combine_nfft(N), &plan) == CF_OK);
    CF_CHECK(cf_combine_subtract(hf, p, N, out1, msg) == CF_OK);
    CF_CHECK(cf_combine_subtract_plan(plan, hf, p, N, out2, msg) == CF_OK);
    CF_CHECK(memcmp(out1, out2, sizeof out1) == 0);
    /* the same plan again (read-only): same bits */
    CF_CHECK(cf_combine_subtract_plan(plan, hf, p, N, out2, msg) == CF_OK);
    CF_CHECK(memcmp(out1, out2, sizeof out1) == 0);
    CF_CHECK(cf_fft_plan_create(4096, &small) == CF_OK);
    CF_CHECK(cf_combine_subtract_plan(small, hf, p, N, out2, msg) == CF_EINVAL && strstr(msg, "needs 8192"));
    CF_CHECK(cf_combine_subtract_plan(NULL, hf, p, N, out2, msg) == CF_EINVAL);
    cf_fft_plan_free(plan);
    cf_fft_plan_free(small);
}

int main(void)
{
    CF_RUN(test_zero_pulse);
    CF_RUN(test_proportional_pulse);
    CF_RUN(test_sine_burst);
    CF_RUN(test_bad_input);
    CF_RUN(test_shared_plan);
    return CF_TEST_SUMMARY("test_combine");
}
