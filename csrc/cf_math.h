/*
 * cf_math.h -- the transcendental functions libcolfrag needs, written once in the library
 * so that the same arguments give the same bits on every CPU (docs/reproducibility.md).
 *
 * Why: glibc's libm picks FMA/AVX2 variants of exp, log, pow, sin, cos at load time, and
 * they differ from the SSE2 ones in the last bit; numpy and scipy dispatch their loops by
 * CPU feature too. These functions use only IEEE-754 double operations (+ - * / and sqrt,
 * all correctly rounded) in a fixed order; the library is built with -ffp-contract=off, so
 * no fused multiply-add can enter. Accuracy: within 1 ulp of the true value over the whole
 * double range (tests/c/test_math.c checks them against glibc within 1 ulp); erfc to 4e-15
 * relative (against a 50-digit evaluation), ndtri to 2e-15 (against scipy.special.ndtri), the
 * normal CDF to 2e-14 for |x| <= 10 (tests/test_cf_math.py).
 *
 * Special values follow C99 Annex F (NaN in, NaN out; exp(-inf) = 0; log(0) = -inf;
 * log(x < 0) = NaN; sin(inf) = NaN; pow's table of special cases). No errno, no
 * floating-point exceptions relied upon; never prints or aborts.
 */
#ifndef CF_MATH_H
#define CF_MATH_H

/* cffi:begin */
double cf_math_exp(double x);
double cf_math_log(double x);
double cf_math_log10(double x);
double cf_math_pow(double x, double y);
double cf_math_sin(double x);
double cf_math_cos(double x);
/* sin and cos of x at once (one argument reduction); either pointer may be NULL. */
void cf_math_sincos(double x, double *s, double *c);
/* Complementary error function, 2/sqrt(pi) int_x^inf exp(-t^2) dt. */
double cf_math_erfc(double x);
/* Standard normal CDF Phi(x) = erfc(-x / sqrt 2) / 2. */
double cf_math_norm_cdf(double x);
/* Inverse of Phi (Wichura 1988, AS 241 PPND16): ndtri(0) = -inf, ndtri(1) = +inf, NaN
 * outside [0, 1]. */
double cf_math_ndtri(double p);
/* cffi:end */

#endif
