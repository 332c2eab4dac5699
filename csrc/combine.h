/*
 * combine.h -- the paper's steps 3-6: combine a stochastic high-frequency record
 * with an (already time-aligned) velocity-pulse record of the same length.
 *
 * Both are zero padded to a power of two nfft >= 2n (so the circular transforms
 * do not wrap the records onto each other), Fourier transformed, and the result
 * gets the amplitude max(|HF_k| - |P_k|, 0) with the phase of HF_k (HF_k == 0
 * gives 0); it is transformed back, its first n samples are kept and the pulse
 * is added. Units are whatever the inputs share (the operation is linear in a
 * common scale). No global state; never prints, exits or aborts.
 */
#ifndef CF_COMBINE_H
#define CF_COMBINE_H

#include "fft.h"

/* cffi:begin */
/* hf, pulse: n samples each (n >= 1, finite); out: n samples (may alias hf, not
 * pulse). msg: CF_MSG_LEN bytes or NULL. CF_EINVAL for bad sizes or non-finite
 * input, CF_ENOMEM on allocation failure. Builds an FFT plan of cf_combine_nfft(n)
 * for the call (about a third of its time at n ~ 7000). */
int cf_combine_subtract(const double *hf, const double *pulse, int n, double *out, char *msg);
/* The same with the caller's plan, of length cf_combine_nfft(n) (CF_EINVAL for NULL
 * or another length): plans are read-only, so one serves every record of a length.
 * The result is bit-identical to cf_combine_subtract's. */
int cf_combine_subtract_plan(const struct cf_fft_plan *plan, const double *hf, const double *pulse, int n,
                             double *out, char *msg);
/* FFT length of the combination of n samples: the power of two >= max(2n, 2);
 * -1 if n < 1 or the length would exceed 2^29. */
int cf_combine_nfft(int n);
/* cffi:end */

#endif
