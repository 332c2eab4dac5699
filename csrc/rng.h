/*
 * rng.h -- portable seeded random numbers for the stochastic ground motions.
 *
 * Generator: xoshiro256** 1.0 (Blackman & Vigna 2018, public domain reference
 * code at https://prng.di.unimi.it/xoshiro256starstar.c), its 256-bit state
 * filled from one uint64 seed by splitmix64 as the authors recommend.
 * Standard normals: Marsaglia's polar method; the second normal of each pair is
 * cached in the struct, so the sequence of normals depends only on the seed and
 * the number of draws (no global state, bitwise identical on every platform with
 * IEEE doubles and a correctly rounded sqrt; log comes from libm).
 */
#ifndef CF_RNG_H
#define CF_RNG_H

#include <stdint.h>

/* cffi:begin */
typedef struct {
    uint64_t s[4];      /* xoshiro256** state (never all zero) */
    double spare;       /* cached second normal of the polar method */
    int has_spare;      /* 1 when spare holds an unused normal */
} cf_rng;

/* Fill the state from seed by splitmix64 (any seed, including 0, is valid). */
void cf_rng_seed(cf_rng *r, uint64_t seed);
/* Next raw 64-bit output of xoshiro256**. */
uint64_t cf_rng_next(cf_rng *r);
/* Uniform double in [0, 1) with 53 random bits: (next >> 11) * 2^-53. */
double cf_rng_uniform(cf_rng *r);
/* Standard normal (mean 0, variance 1), Marsaglia polar method. */
double cf_rng_normal(cf_rng *r);
/* n standard normals into out (same sequence as n calls of cf_rng_normal). */
void cf_rng_normals(cf_rng *r, double *out, int n);
/* The splitmix64 output for state x (advances *x); exported for tests. */
uint64_t cf_rng_splitmix64(uint64_t *x);
/* cffi:end */

#endif
