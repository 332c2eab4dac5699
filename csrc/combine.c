/* combine.c -- Fourier-amplitude subtraction of the pulse from the HF record (combine.h). */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "cf_common.h"
#include "combine.h"
#include "fft.h"

int cf_combine_nfft(int n)
{
    if (n < 1 || n > (1 << 28))
        return -1;
    const int nfft = cf_fft_next_pow2(2 * n);
    return nfft < 2 ? 2 : nfft;
}

int cf_combine_subtract(const double *hf, const double *pulse, int n, double *out, char *msg)
{
    const int nfft = cf_combine_nfft(n);
    cf_fft_plan *plan = NULL;
    if (nfft > 0) {
        int st = cf_fft_plan_create(nfft, &plan);
        if (st != CF_OK) {
            if (msg)
                snprintf(msg, CF_MSG_LEN, "FFT plan for n = %d failed (%s)", nfft, cf_common_status_name(st));
            return st;
        }
    }
    /* a bad n is reported by the call below (plan NULL only then) */
    int st = cf_combine_subtract_plan(plan, hf, pulse, n, out, msg);
    cf_fft_plan_free(plan);
    return st;
}

int cf_combine_subtract_plan(const cf_fft_plan *plan, const double *hf, const double *pulse, int n,
                             double *out, char *msg)
{
    if (msg)
        msg[0] = 0;
    if (!hf || !pulse || !out || n < 1 || n > (1 << 28)) {
        if (msg)
            snprintf(msg, CF_MSG_LEN, "bad arguments (n = %d, or a NULL array)", n);
        return CF_EINVAL;
    }
    const int nf = cf_combine_nfft(n);
    if (!plan || cf_fft_plan_size(plan) != nf) {
        if (msg)
            snprintf(msg, CF_MSG_LEN, "FFT plan of length %d for n = %d samples, the combination needs %d",
                     cf_fft_plan_size(plan), n, nf);
        return CF_EINVAL;
    }
    for (int i = 0; i < n; i++) {
        if (!isfinite(hf[i]) || !isfinite(pulse[i])) {
            if (msg)
                snprintf(msg, CF_MSG_LEN, "non-finite input at sample %d (hf %g, pulse %g)", i, hf[i], pulse[i]);
            return CF_EINVAL;
        }
    }
    double *h = calloc((size_t)nf + 2, sizeof(double));
    double *p = calloc((size_t)nf + 2, sizeof(double));
    if (!h || !p) {
        free(h);
        free(p);
        if (msg)
            snprintf(msg, CF_MSG_LEN, "out of memory (nfft = %d)", nf);
        return CF_ENOMEM;
    }
    /* step 3: Fourier transforms of both (zero padded) */
    memcpy(h, hf, sizeof(double) * (size_t)n);
    memcpy(p, pulse, sizeof(double) * (size_t)n);
    cf_fft_forward(plan, h, h);
    cf_fft_forward(plan, p, p);
    /* steps 4-5: amplitude |HF| - |P| (not below 0) with the phase of HF */
    for (int k = 0; k <= nf / 2; k++) {
        const double hr = h[2 * k], hi = h[2 * k + 1];
        /* sqrt(x^2 + y^2), not hypot (5x slower in glibc); accelerations never overflow */
        const double ah = sqrt(hr * hr + hi * hi), ap = sqrt(p[2 * k] * p[2 * k] + p[2 * k + 1] * p[2 * k + 1]);
        const double a = ah - ap;
        const double scale = (a > 0.0 && ah > 0.0) ? a / ah : 0.0;
        h[2 * k] = hr * scale;
        h[2 * k + 1] = hi * scale;
    }
    /* inverse into p (work), keep n samples; step 6: add the pulse */
    cf_fft_inverse(plan, h, p);
    for (int i = 0; i < n; i++)
        out[i] = p[i] + pulse[i];
    free(h);
    free(p);
    return CF_OK;
}
