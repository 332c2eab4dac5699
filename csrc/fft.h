/*
 * fft.h -- real FFT of power-of-two length (own radix-2; why: see fft.c).
 *
 * A plan holds the bit-reversal table and the twiddle factors for one length n
 * (a power of two >= 2). Spectra are packed as n/2 + 1 complex values,
 * interleaved re, im (2*(n/2 + 1) doubles), in numpy.fft.rfft's convention:
 *   X[k] = sum_j x[j] exp(-2 pi i j k / n),   k = 0 .. n/2,
 * and the inverse includes the 1/n factor (numpy.fft.irfft), so
 * inverse(forward(x)) == x to rounding. A plan is read-only after creation and
 * can be shared; the transforms need no workspace beyond their output arrays.
 */
#ifndef CF_FFT_H
#define CF_FFT_H

/* cffi:begin */
typedef struct cf_fft_plan cf_fft_plan;

/* Create a plan for length n into *plan. CF_EINVAL if n is not a power of two
 * >= 2 (or > 2^30), CF_ENOMEM on allocation failure; *plan is NULL then. */
int cf_fft_plan_create(int n, cf_fft_plan **plan);
void cf_fft_plan_free(cf_fft_plan *plan);
int cf_fft_plan_size(const cf_fft_plan *plan);

/* Forward real FFT: x (n doubles) -> spec (n + 2 doubles: n/2 + 1 complex).
 * x and spec may be the same array if it holds n + 2 doubles. */
void cf_fft_forward(const cf_fft_plan *plan, const double *x, double *spec);
/* Inverse real FFT with the 1/n factor: spec (n + 2 doubles) -> x (n doubles).
 * The imaginary parts of the DC and Nyquist terms are ignored. spec is not
 * modified; x must not overlap spec. */
void cf_fft_inverse(const cf_fft_plan *plan, const double *spec, double *x);

/* Smallest power of two >= n (n >= 1), or -1 if above 2^30. */
int cf_fft_next_pow2(int n);
/* cffi:end */

#endif
