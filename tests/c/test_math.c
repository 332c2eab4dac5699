/*
 * test_math.c -- cf_math's exp, log, log10, pow, sin, cos against the C library.
 *
 * Where the expected numbers come from: glibc's libm (linked with -lm), whose exp, log,
 * log10, pow, sin and cos are documented within 1 ulp of the true value (glibc manual,
 * "Known Maximum Errors in Math Functions": 1 for log10, 0-1 for the others on x86-64;
 * the exp/log/pow/sin/cos variants it picks differ from each other in the last bit only).
 * cf_math rounds a result carried to about 2^-60 relative (double-double for log and pow),
 * so it is within ~0.6 ulp of the truth; two results each within 1 ulp of the truth and
 * both doubles are at most 1 ulp apart in practice, so 1 ulp is the tolerance: a
 * truncated series, a wrong constant or a lost low part costs many ulps and fails it.
 * Exact values (exp(0) = 1, log(1) = 0, sin(0) = 0, pow special cases, ...) come from
 * the functions' definitions and C99 Annex F, and are checked bit for bit. log10 is the
 * exception: glibc documents 2 ulp for it (and is 2 ulp off at about 1 argument in 10^4
 * near 1), so its tolerance is 2 ulp and two such points are checked against the
 * correctly rounded value instead.
 * Arguments: a fixed splitmix64 stream (no dependence on the library's RNG) over the
 * ranges the library uses (stochastic.c: pow(10, 16..28), pow(f, 0.45), Saragoni-Hart
 * window; pulse.c and fft.c: sin/cos of |x| < 100; spectra.c: exp of -0.3..0) and the
 * whole double range, plus the hard cases: arguments next to multiples of pi/2, near 1
 * for log, huge arguments for sin/cos (exact Payne-Hanek reduction), subnormals.
 */
#include <float.h>
#include <math.h>
#include <stdint.h>
#include <string.h>
#include "cf_math.h"
#include "cf_test.h"

static uint64_t state = 0x9E3779B97F4A7C15ULL;

static uint64_t splitmix(void)
{
    uint64_t z = (state += 0x9E3779B97F4A7C15ULL);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ULL;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBULL;
    return z ^ (z >> 31);
}

static double uniform(double lo, double hi)
{
    return lo + (hi - lo) * ((double)(splitmix() >> 11) * 0x1.0p-53);
}

/* Distance in ulps between two finite doubles of the same sign (ordered bit patterns). */
static double ulps(double a, double b)
{
    if (a == b)
        return 0.0;
    if (isnan(a) || isnan(b) || isinf(a) || isinf(b))
        return INFINITY;
    int64_t ia, ib;
    memcpy(&ia, &a, 8);
    memcpy(&ib, &b, 8);
    if (ia < 0)
        ia = INT64_MIN - ia;
    if (ib < 0)
        ib = INT64_MIN - ib;
    return fabs((double)(ia - ib));
}

static int same_bits(double a, double b)
{
    return memcmp(&a, &b, sizeof a) == 0 || (isnan(a) && isnan(b));
}

#define N_RANDOM 200000

static double worst;
#define CHECK_ULP(mine, ref, arg) CHECK_ULPS(mine, ref, arg, 1.0)
#define CHECK_ULPS(mine, ref, arg, tol) do { double m_ = (mine), r_ = (ref), u_ = ulps(m_, r_); \
    if (u_ > worst) worst = u_; \
    if (u_ > (tol)) { fprintf(stderr, "  FAIL %s:%d: %s at %a (%.17g): %.17g vs libm %.17g, %.0f ulp\n", \
        __FILE__, __LINE__, #mine, (double)(arg), (double)(arg), m_, r_, u_); cf_test_cur_failed_ = 1; } } while (0)

static void test_exp(void)
{
    worst = 0;
    for (int i = 0; i < N_RANDOM; i++) {
        double x = uniform(-745.0, 709.7);
        CHECK_ULP(cf_math_exp(x), exp(x), x);
        x = uniform(-1.0, 1.0);
        CHECK_ULP(cf_math_exp(x), exp(x), x);
        x = uniform(-40.0, 5.0);                  /* stochastic window, spectra, anelastic */
        CHECK_ULP(cf_math_exp(x), exp(x), x);
    }
    for (int k = -60; k <= 60; k++) {             /* near the reduction's breakpoints k ln2 / 2 */
        double x = k * 0.34657359027997264;
        CHECK_ULP(cf_math_exp(x), exp(x), x);
        CHECK_ULP(cf_math_exp(nextafter(x, 1e9)), exp(nextafter(x, 1e9)), x);
    }
    CF_CHECK(same_bits(cf_math_exp(0.0), 1.0));
    CF_CHECK(same_bits(cf_math_exp(-0.0), 1.0));
    CF_CHECK(same_bits(cf_math_exp(INFINITY), INFINITY));
    CF_CHECK(same_bits(cf_math_exp(-INFINITY), 0.0));
    CF_CHECK(isnan(cf_math_exp(NAN)));
    CF_CHECK(same_bits(cf_math_exp(710.0), INFINITY));
    CF_CHECK(same_bits(cf_math_exp(-746.0), 0.0));
    CF_CHECK(same_bits(cf_math_exp(1e-300), 1.0));
    CHECK_ULP(cf_math_exp(709.78), exp(709.78), 709.78);            /* near overflow */
    CHECK_ULP(cf_math_exp(-708.5), exp(-708.5), -708.5);            /* smallest normals */
    CHECK_ULP(cf_math_exp(-740.0), exp(-740.0), -740.0);            /* subnormal result */
    CHECK_ULP(cf_math_exp(1.0), 2.718281828459045, 1.0);            /* e, decimal literal */
    fprintf(stderr, "  exp: worst %.0f ulp\n", worst);
}

static void test_log(void)
{
    worst = 0;
    for (int i = 0; i < N_RANDOM; i++) {
        uint64_t u = splitmix() & 0x7fefffffffffffffULL;          /* any positive finite double */
        double x;
        memcpy(&x, &u, 8);
        if (x == 0.0)
            continue;
        CHECK_ULP(cf_math_log(x), log(x), x);
        CHECK_ULPS(cf_math_log10(x), log10(x), x, 2.0);
        x = uniform(0.5, 2.0);                                      /* near 1: the hard part */
        CHECK_ULP(cf_math_log(x), log(x), x);
        CHECK_ULPS(cf_math_log10(x), log10(x), x, 2.0);
        x = uniform(1e-6, 1.0);                                     /* polar normals: log(s) */
        CHECK_ULP(cf_math_log(x), log(x), x);
    }
    double near1[] = {nextafter(1.0, 0.0), nextafter(1.0, 2.0), 1.0 + 1e-10, 1.0 - 1e-10, 0x1.6a09e667f3bcdp+0,
                      0x1.6a09e667f3bcep+0, 0x1.6a09e667f3bccp-1, 5e-324, 2.2250738585072014e-308, DBL_MAX};
    for (size_t i = 0; i < sizeof near1 / sizeof near1[0]; i++) {
        CHECK_ULP(cf_math_log(near1[i]), log(near1[i]), near1[i]);
        CHECK_ULPS(cf_math_log10(near1[i]), log10(near1[i]), near1[i], 2.0);
    }
    /* glibc's log10 is documented to 2 ulp (above); these two, where it is 2 ulp off, are
     * checked against the correctly rounded value (Python decimal, 50 digits):
     * Decimal(x).log10() */
    CF_CHECK(same_bits(cf_math_log10(0x1.ef4842535d4bap-1), -0.014417186460344067));
    CF_CHECK(same_bits(cf_math_log10(0x1.c6039a5374463p+0), 0.24882935006163145));
    CF_CHECK(same_bits(cf_math_log(1.0), 0.0));
    CF_CHECK(same_bits(cf_math_log10(1.0), 0.0));
    CF_CHECK(same_bits(cf_math_log10(10.0), 1.0));
    CF_CHECK(same_bits(cf_math_log10(1e22), 22.0));     /* exact powers of ten give integers */
    CF_CHECK(same_bits(cf_math_log10(0.001), -3.0) || ulps(cf_math_log10(0.001), -3.0) <= 1);
    CF_CHECK(same_bits(cf_math_log(0.0), -INFINITY));
    CF_CHECK(same_bits(cf_math_log(-0.0), -INFINITY));
    CF_CHECK(isnan(cf_math_log(-1.0)));
    CF_CHECK(isnan(cf_math_log(NAN)));
    CF_CHECK(same_bits(cf_math_log(INFINITY), INFINITY));
    CF_CHECK(same_bits(cf_math_log(2.0), 0x1.62e42fefa39efp-1));   /* ln 2 rounded (scripts/cf_math_constants.py) */
    fprintf(stderr, "  log, log10: worst %.0f ulp\n", worst);
}

static void test_pow(void)
{
    worst = 0;
    for (int i = 0; i < N_RANDOM; i++) {
        double y = uniform(-30.0, 30.0);                             /* stochastic.c: 10^(1.5 Mw + 16.05) */
        CHECK_ULP(cf_math_pow(10.0, y), pow(10.0, y), y);
        double f = uniform(1e-3, 250.0);                             /* Q(f) = 180 f^0.45 */
        CHECK_ULP(cf_math_pow(f, 0.45), pow(f, 0.45), f);
        double x = uniform(0.0, 6.0), b = 1.2545;                    /* window x^b */
        CHECK_ULP(cf_math_pow(x, b), pow(x, b), x);
        x = exp(uniform(-700.0, 700.0));                             /* the whole range */
        y = uniform(-1.0, 1.0);
        CHECK_ULP(cf_math_pow(x, y), pow(x, y), x);
        x = uniform(0.9, 1.1);                                       /* large y near x = 1 */
        y = uniform(-5000.0, 5000.0);
        CHECK_ULP(cf_math_pow(x, y), pow(x, y), y);
        x = uniform(-4.0, 4.0);                                      /* negative bases, integer y */
        y = floor(uniform(-40.0, 40.0));
        CHECK_ULP(cf_math_pow(x, y), pow(x, y), x);
    }
    /* C99 Annex F table (F.9.4.4) */
    CF_CHECK(same_bits(cf_math_pow(NAN, 0.0), 1.0));
    CF_CHECK(same_bits(cf_math_pow(1.0, NAN), 1.0));
    CF_CHECK(isnan(cf_math_pow(NAN, 1.0)));
    CF_CHECK(isnan(cf_math_pow(2.0, NAN)));
    CF_CHECK(isnan(cf_math_pow(-2.0, 0.5)));
    CF_CHECK(same_bits(cf_math_pow(-0.0, -3.0), -INFINITY));
    CF_CHECK(same_bits(cf_math_pow(0.0, -3.0), INFINITY));
    CF_CHECK(same_bits(cf_math_pow(-0.0, -2.0), INFINITY));
    CF_CHECK(same_bits(cf_math_pow(-0.0, 3.0), -0.0));
    CF_CHECK(same_bits(cf_math_pow(-0.0, 2.0), 0.0));
    CF_CHECK(same_bits(cf_math_pow(0.0, 1.25), 0.0));
    CF_CHECK(same_bits(cf_math_pow(-1.0, INFINITY), 1.0));
    CF_CHECK(same_bits(cf_math_pow(0.5, -INFINITY), INFINITY));
    CF_CHECK(same_bits(cf_math_pow(2.0, -INFINITY), 0.0));
    CF_CHECK(same_bits(cf_math_pow(0.5, INFINITY), 0.0));
    CF_CHECK(same_bits(cf_math_pow(2.0, INFINITY), INFINITY));
    CF_CHECK(same_bits(cf_math_pow(-INFINITY, -3.0), -0.0));
    CF_CHECK(same_bits(cf_math_pow(-INFINITY, -2.0), 0.0));
    CF_CHECK(same_bits(cf_math_pow(-INFINITY, 3.0), -INFINITY));
    CF_CHECK(same_bits(cf_math_pow(-INFINITY, 2.5), INFINITY));
    CF_CHECK(same_bits(cf_math_pow(INFINITY, -1.0), 0.0));
    CF_CHECK(same_bits(cf_math_pow(INFINITY, 0.1), INFINITY));
    CF_CHECK(same_bits(cf_math_pow(10.0, 400.0), INFINITY));
    CF_CHECK(same_bits(cf_math_pow(10.0, -400.0), 0.0));
    CF_CHECK(same_bits(cf_math_pow(-10.0, 401.0), -INFINITY));
    /* exact results: small integer powers and powers of two */
    CF_CHECK(same_bits(cf_math_pow(10.0, 2.0), 100.0));
    CF_CHECK(same_bits(cf_math_pow(10.0, 22.0), 1e22));
    CF_CHECK(same_bits(cf_math_pow(2.0, -1074.0), 5e-324));
    CF_CHECK(same_bits(cf_math_pow(-3.0, 3.0), -27.0));
    CF_CHECK(same_bits(cf_math_pow(4.0, 0.5), 2.0));
    CHECK_ULP(cf_math_pow(2.0, 0.5), sqrt(2.0), 0.5);              /* sqrt is correctly rounded */
    fprintf(stderr, "  pow: worst %.0f ulp\n", worst);
}

static void test_sin_cos(void)
{
    worst = 0;
    for (int i = 0; i < N_RANDOM; i++) {
        double x = uniform(-100.0, 100.0);                           /* pulse.c, fft.c, spectra.c */
        CHECK_ULP(cf_math_sin(x), sin(x), x);
        CHECK_ULP(cf_math_cos(x), cos(x), x);
        double s, c;
        cf_math_sincos(x, &s, &c);
        CF_CHECK(same_bits(s, cf_math_sin(x)) && same_bits(c, cf_math_cos(x)));
        x = uniform(-1e6, 1e6);
        CHECK_ULP(cf_math_sin(x), sin(x), x);
        CHECK_ULP(cf_math_cos(x), cos(x), x);
        x = ldexp(uniform(1.0, 2.0), 20 + (int)(splitmix() % 1003));   /* 2^20 .. DBL_MAX */
        CHECK_ULP(cf_math_sin(x), sin(x), x);                        /* exact large reduction */
        CHECK_ULP(cf_math_cos(x), cos(x), x);
    }
    /* next to multiples of pi/2, where the reduction cancels most bits */
    for (int k = -2000; k <= 2000; k++) {
        double x = k * 1.5707963267948966;
        for (int j = 0; j < 3; j++) {
            CHECK_ULP(cf_math_sin(x), sin(x), x);
            CHECK_ULP(cf_math_cos(x), cos(x), x);
            x = nextafter(x, INFINITY);
        }
    }
    double hard[] = {0x1.921fb54442d18p+0, 0x1.921fb54442d18p+1, 0x1.921fb54442d18p+2, 1e22,
                     1e300, DBL_MAX,
                     0x1p20, nextafter(0x1p20, 0.0), 1e-300, 5e-324};
    for (size_t i = 0; i < sizeof hard / sizeof hard[0]; i++) {
        CHECK_ULP(cf_math_sin(hard[i]), sin(hard[i]), hard[i]);
        CHECK_ULP(cf_math_cos(hard[i]), cos(hard[i]), hard[i]);
        CHECK_ULP(cf_math_sin(-hard[i]), sin(-hard[i]), -hard[i]);
    }
    /* 0x1.6ac5b262ca1ffp+849 lies within 2^-61 of a multiple of pi/2 (the worst case among
     * doubles): exact values from scripts/cf_math_constants.py's pi in 1600-bit integer
     * arithmetic (n = 1 mod 4, r = 4.687e-19: cos x = -sin r, sin x = cos r = 1). Not libm: at
     * -O3 gcc merges sin and cos into glibc's sincos, which is 8 ulp off here. */
    CF_CHECK(same_bits(cf_math_cos(0x1.6ac5b262ca1ffp+849), -0x1.14ae72e6ba22fp-61));
    CF_CHECK(same_bits(cf_math_sin(0x1.6ac5b262ca1ffp+849), 1.0));
    CF_CHECK(same_bits(cf_math_sin(-0x1.6ac5b262ca1ffp+849), -1.0));
    CF_CHECK(same_bits(cf_math_sin(0.0), 0.0));
    CF_CHECK(same_bits(cf_math_sin(-0.0), -0.0));
    CF_CHECK(same_bits(cf_math_cos(0.0), 1.0));
    CF_CHECK(same_bits(cf_math_cos(-0.0), 1.0));
    CF_CHECK(isnan(cf_math_sin(INFINITY)) && isnan(cf_math_cos(-INFINITY)) && isnan(cf_math_sin(NAN)));
    fprintf(stderr, "  sin, cos: worst %.0f ulp\n", worst);
}

int main(void)
{
    CF_RUN(test_exp);
    CF_RUN(test_log);
    CF_RUN(test_pow);
    CF_RUN(test_sin_cos);
    return CF_TEST_SUMMARY("test_math");
}
