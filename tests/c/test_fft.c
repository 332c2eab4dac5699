/* Real FFT against a naive DFT (long double sums), round trip, and plan errors. */
#include <math.h>
#include <stdlib.h>
#include "cf_test.h"
#include "cf_common.h"
#include "fft.h"
#include "rng.h"

/* Naive DFT X_k = sum_j x_j exp(-2 pi i jk/n) in long double, argument reduced
 * exactly (jk mod n) so the reference error is ~1e-16 relative to sum |x|. */
static void naive_dft(const double *x, int n, double *spec)
{
    const long double pi = 3.141592653589793238462643383279503L;
    for (int k = 0; k <= n / 2; k++) {
        long double re = 0, im = 0;
        for (int j = 0; j < n; j++) {
            long long jk = ((long long)j * k) % n;
            long double a = -2.0L * pi * (long double)jk / (long double)n;
            re += x[j] * cosl(a);
            im += x[j] * sinl(a);
        }
        spec[2 * k] = (double)re;
        spec[2 * k + 1] = (double)im;
    }
}

/* Error measure: max_k |X_k - X_ref_k| / max_k |X_ref_k|. A radix-2 FFT's rounding
 * error grows like eps * log2(n) * ||x||, i.e. ~1e-15 relative here, so 1e-12 has
 * a thousand-fold margin while any wrong twiddle or index gives O(1). */
static double rel_error(const double *a, const double *b, int n)
{
    double emax = 0, bmax = 0;
    for (int k = 0; k <= n / 2; k++) {
        double dr = a[2 * k] - b[2 * k], di = a[2 * k + 1] - b[2 * k + 1];
        double e = sqrt(dr * dr + di * di), m = sqrt(b[2 * k] * b[2 * k] + b[2 * k + 1] * b[2 * k + 1]);
        emax = e > emax ? e : emax;
        bmax = m > bmax ? m : bmax;
    }
    return emax / bmax;
}

static void test_against_naive_dft(void)
{
    static const int sizes[] = {2, 4, 8, 16, 32, 256, 1024, 4096};
    cf_rng r;
    cf_rng_seed(&r, 2024);
    for (size_t s = 0; s < sizeof sizes / sizeof sizes[0]; s++) {
        int n = sizes[s];
        double *x = malloc(sizeof(double) * n), *spec = malloc(sizeof(double) * (n + 2));
        double *ref = malloc(sizeof(double) * (n + 2)), *back = malloc(sizeof(double) * n);
        for (int i = 0; i < n; i++)
            x[i] = cf_rng_normal(&r) + 0.3;   /* non-zero mean: exercises the DC term */
        cf_fft_plan *p = NULL;
        CF_CHECK(cf_fft_plan_create(n, &p) == CF_OK);
        if (p) {
            CF_CHECK(cf_fft_plan_size(p) == n);
            cf_fft_forward(p, x, spec);
            naive_dft(x, n, ref);
            double e = rel_error(spec, ref, n);
            if (!(e < 1e-12))
                fprintf(stderr, "  n = %d: rel error %.3g\n", n, e);
            CF_CHECK(e < 1e-12);
            CF_CHECK(spec[1] == 0.0 && spec[n + 1] == 0.0);   /* DC, Nyquist real */
            /* round trip: inverse(forward(x)) == x to 1e-13 * max|x| */
            cf_fft_inverse(p, spec, back);
            double emax = 0, xmax = 0;
            for (int i = 0; i < n; i++) {
                emax = fmax(emax, fabs(back[i] - x[i]));
                xmax = fmax(xmax, fabs(x[i]));
            }
            CF_CHECK(emax <= 1e-13 * xmax);
            cf_fft_plan_free(p);
        }
        free(x); free(spec); free(ref); free(back);
    }
}

/* Inverse against the naive inverse DFT for a Hermitian spectrum given directly
 * (not produced by forward), including a single cosine at bin k0. */
static void test_inverse_cosine(void)
{
    const int n = 64, k0 = 5;
    double spec[66] = {0}, x[64];
    spec[2 * k0] = n / 2.0;   /* x_j = cos(2 pi k0 j / n) */
    cf_fft_plan *p = NULL;
    CF_CHECK(cf_fft_plan_create(n, &p) == CF_OK);
    if (!p)
        return;
    cf_fft_inverse(p, spec, x);
    for (int j = 0; j < n; j++)
        CF_CHECK_CLOSE(x[j], cos(2.0 * CF_PI * k0 * j / n), 1e-14);
    cf_fft_plan_free(p);
}

/* In-place forward (x and spec the same array of n + 2 doubles). */
static void test_in_place(void)
{
    const int n = 128;
    double a[130], b[130];
    cf_rng r;
    cf_rng_seed(&r, 5);
    for (int i = 0; i < n; i++)
        a[i] = b[i] = cf_rng_uniform(&r);
    cf_fft_plan *p = NULL;
    CF_CHECK(cf_fft_plan_create(n, &p) == CF_OK);
    if (!p)
        return;
    double out[130];
    cf_fft_forward(p, a, out);
    cf_fft_forward(p, b, b);
    int same = 1;
    for (int i = 0; i < n + 2; i++)
        same &= out[i] == b[i];
    CF_CHECK(same);
    cf_fft_plan_free(p);
}

static void test_bad_sizes(void)
{
    cf_fft_plan *p = (cf_fft_plan *)&p;
    CF_CHECK(cf_fft_plan_create(0, &p) == CF_EINVAL && p == NULL);
    CF_CHECK(cf_fft_plan_create(1, &p) == CF_EINVAL);
    CF_CHECK(cf_fft_plan_create(12, &p) == CF_EINVAL);
    CF_CHECK(cf_fft_plan_create(-8, &p) == CF_EINVAL);
    CF_CHECK(cf_fft_plan_create(8, NULL) == CF_EINVAL);
    CF_CHECK(cf_fft_next_pow2(1) == 1);
    CF_CHECK(cf_fft_next_pow2(5) == 8);
    CF_CHECK(cf_fft_next_pow2(4096) == 4096);
    CF_CHECK(cf_fft_next_pow2(4097) == 8192);
    CF_CHECK(cf_fft_next_pow2((1 << 30) + 1) == -1);
}

int main(void)
{
    CF_RUN(test_against_naive_dft);
    CF_RUN(test_inverse_cosine);
    CF_RUN(test_in_place);
    CF_RUN(test_bad_sizes);
    return CF_TEST_SUMMARY("test_fft");
}
