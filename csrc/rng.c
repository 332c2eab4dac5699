/* rng.c -- xoshiro256** seeded by splitmix64, Marsaglia polar normals (rng.h). */
#include <math.h>
#include "cf_math.h"
#include "rng.h"

uint64_t cf_rng_splitmix64(uint64_t *x)
{
    uint64_t z = (*x += UINT64_C(0x9E3779B97F4A7C15));
    z = (z ^ (z >> 30)) * UINT64_C(0xBF58476D1CE4E5B9);
    z = (z ^ (z >> 27)) * UINT64_C(0x94D049BB133111EB);
    return z ^ (z >> 31);
}

void cf_rng_seed(cf_rng *r, uint64_t seed)
{
    uint64_t x = seed;
    for (int i = 0; i < 4; i++)
        r->s[i] = cf_rng_splitmix64(&x);
    /* splitmix64 is a bijection of its counter, so four consecutive outputs are
     * never all zero; keep the guard anyway (xoshiro's only forbidden state). */
    if ((r->s[0] | r->s[1] | r->s[2] | r->s[3]) == 0)
        r->s[0] = UINT64_C(0x9E3779B97F4A7C15);
    r->spare = 0.0;
    r->has_spare = 0;
}

static inline uint64_t rotl(uint64_t x, int k) { return (x << k) | (x >> (64 - k)); }

uint64_t cf_rng_next(cf_rng *r)
{
    uint64_t *s = r->s;
    const uint64_t result = rotl(s[1] * 5, 7) * 9;
    const uint64_t t = s[1] << 17;
    s[2] ^= s[0];
    s[3] ^= s[1];
    s[1] ^= s[2];
    s[0] ^= s[3];
    s[2] ^= t;
    s[3] = rotl(s[3], 45);
    return result;
}

double cf_rng_uniform(cf_rng *r)
{
    return (double)(cf_rng_next(r) >> 11) * 0x1.0p-53;
}

double cf_rng_normal(cf_rng *r)
{
    if (r->has_spare) {
        r->has_spare = 0;
        return r->spare;
    }
    double u, v, s;
    do {
        u = 2.0 * cf_rng_uniform(r) - 1.0;   /* exact in binary: [-1, 1) */
        v = 2.0 * cf_rng_uniform(r) - 1.0;
        s = u * u + v * v;
    } while (s >= 1.0 || s == 0.0);
    double m = sqrt(-2.0 * cf_math_log(s) / s);
    r->spare = v * m;
    r->has_spare = 1;
    return u * m;
}

void cf_rng_normals(cf_rng *r, double *out, int n)
{
    for (int i = 0; i < n; i++)
        out[i] = cf_rng_normal(r);
}
