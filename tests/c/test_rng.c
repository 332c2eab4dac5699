/* xoshiro256** / splitmix64 against reference outputs, and the moments of the
 * polar-method normals.
 *
 * Reference values: splitmix64 from state 0 gives 0xe220a8397b1dcdaf (the value
 * quoted with Vigna's reference splitmix64.c). The xoshiro256** outputs were
 * computed independently with this Python transcription of the reference C code:
 *
 *   M = (1 << 64) - 1
 *   def splitmix(x):
 *       x = (x + 0x9E3779B97F4A7C15) & M; z = x
 *       z = ((z ^ (z >> 30)) * 0xBF58476D1CE4E5B9) & M
 *       z = ((z ^ (z >> 27)) * 0x94D049BB133111EB) & M
 *       return x, z ^ (z >> 31)
 *   rotl = lambda x, k: ((x << k) | (x >> (64 - k))) & M
 *   def xoshiro(seed, n):
 *       s = []; x = seed
 *       for _ in range(4): x, z = splitmix(x); s.append(z)
 *       out = []
 *       for _ in range(n):
 *           out.append((rotl((s[1] * 5) & M, 7) * 9) & M); t = (s[1] << 17) & M
 *           s[2] ^= s[0]; s[3] ^= s[1]; s[1] ^= s[2]; s[0] ^= s[3]; s[2] ^= t; s[3] = rotl(s[3], 45)
 *       return out
 */
#include <math.h>
#include <stdint.h>
#include "cf_test.h"
#include "cf_common.h"
#include "rng.h"

static void test_splitmix64(void)
{
    uint64_t x = 0;
    CF_CHECK(cf_rng_splitmix64(&x) == UINT64_C(0xe220a8397b1dcdaf));
    CF_CHECK(x == UINT64_C(0x9E3779B97F4A7C15));
}

static void check_seq(uint64_t seed, const uint64_t *expected)
{
    cf_rng r;
    cf_rng_seed(&r, seed);
    for (int i = 0; i < 4; i++)
        CF_CHECK(cf_rng_next(&r) == expected[i]);
}

static void test_xoshiro_reference(void)
{
    static const uint64_t s0[4] = {UINT64_C(0x99ec5f36cb75f2b4), UINT64_C(0xbf6e1f784956452a),
                                   UINT64_C(0x1a5f849d4933e6e0), UINT64_C(0x6aa594f1262d2d2c)};
    static const uint64_t s42[4] = {UINT64_C(0x15780b2e0c2ec716), UINT64_C(0x6104d9866d113a7e),
                                    UINT64_C(0xae17533239e499a1), UINT64_C(0xecb8ad4703b360a1)};
    static const uint64_t smax[4] = {UINT64_C(0x8f5520d52a7ead08), UINT64_C(0xc476a018caa1802d),
                                     UINT64_C(0x81de31c0d260469e), UINT64_C(0xbf658d7e065f3c2f)};
    check_seq(0, s0);
    check_seq(42, s42);
    check_seq(UINT64_MAX, smax);
}

static void test_uniform_range(void)
{
    cf_rng r;
    cf_rng_seed(&r, 7);
    double lo = 1.0, hi = 0.0;
    for (int i = 0; i < 100000; i++) {
        double u = cf_rng_uniform(&r);
        lo = u < lo ? u : lo;
        hi = u > hi ? u : hi;
    }
    CF_CHECK(lo >= 0.0 && lo < 1e-3);
    CF_CHECK(hi < 1.0 && hi > 1.0 - 1e-3);
}

/* 1e6 normals: the sample mean has sd 1/sqrt(N) = 1e-3, the sample variance has
 * sd sqrt(2/N) = 1.41e-3 (normal fourth moment 3); 5 sigma bands. Also the
 * fourth moment (3, sd sqrt(96/N) ~ 9.8e-3) to catch a wrong shape. */
static void test_normal_moments(void)
{
    cf_rng r;
    cf_rng_seed(&r, 12345);
    const int n = 1000000;
    double s1 = 0, s2 = 0, s4 = 0;
    for (int i = 0; i < n; i++) {
        double z = cf_rng_normal(&r);
        s1 += z;
        s2 += z * z;
        s4 += z * z * z * z;
    }
    double mean = s1 / n, var = s2 / n - mean * mean, m4 = s4 / n;
    CF_CHECK_CLOSE(mean, 0.0, 5.0 / sqrt((double)n));
    CF_CHECK_CLOSE(var, 1.0, 5.0 * sqrt(2.0 / n));
    CF_CHECK_CLOSE(m4, 3.0, 5.0 * sqrt(96.0 / n));
}

/* Same seed, same sequence; the batch call equals single calls (spare cache). */
static void test_reproducible(void)
{
    cf_rng a, b;
    cf_rng_seed(&a, 99);
    cf_rng_seed(&b, 99);
    double buf[7];
    cf_rng_normals(&a, buf, 7);
    int same = 1;
    for (int i = 0; i < 7; i++)
        same &= (buf[i] == cf_rng_normal(&b));
    CF_CHECK(same);
    cf_rng_seed(&b, 100);
    CF_CHECK(cf_rng_normal(&b) != buf[0]);
}

int main(void)
{
    CF_RUN(test_splitmix64);
    CF_RUN(test_xoshiro_reference);
    CF_RUN(test_uniform_range);
    CF_RUN(test_normal_moments);
    CF_RUN(test_reproducible);
    return CF_TEST_SUMMARY("test_rng");
}
