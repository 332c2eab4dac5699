/*
 * fft.c -- real FFT of power-of-two length: a complex radix-2 FFT of length n/2
 * on the even/odd samples packed as re/im, followed by the usual split step.
 *
 * Why our own FFT and not a library:
 *  - licence: FFTW (libfftw3) is GPL-2+, which a permissively licensed (MIT)
 *    library cannot link; kissfft (BSD) would do, but it is one more system
 *    dependency for the ~150 lines below;
 *  - the lengths are always powers of two (we zero-pad), so radix-2 suffices;
 *  - speed, measured on this machine (AMD EPYC, 2 shared cores, gcc 12 -O3
 *    -ffp-contract=off; best of 2000 calls through cffi, the medians are noisy):
 *      n       C forward / inverse     numpy.fft.rfft / irfft (pocketfft)
 *      8192    46 / 47 us              49 / 53 us
 *      16384   148 / 107 us            97 / 105 us
 *    i.e. on par with numpy (within 1.5x). A record at dt 0.005 s needs two
 *    transforms of 8192-16384 points, about half of its cost (the rest is the
 *    polar-method normals), and the whole C record is not slower than the NumPy
 *    twin (bench/ground_motion_speed.py), so a faster FFT would not pay for a
 *    dependency. Errors against numpy: < 1e-15 relative.
 *  - reproducibility: the same code and the same operation order on every
 *    machine, with the twiddles from cos/sin of exact arguments.
 */
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include "cf_math.h"
#include "cf_common.h"
#include "fft.h"

struct cf_fft_plan {
    int n;          /* real length */
    int m;          /* complex length n/2 */
    int *bitrev;    /* m entries: bit-reversed index */
    double *twst;   /* per stage, contiguous: the stage with half-length h (len = 2h) holds
                       exp(-2 pi i j / len), j < h, at complex offset h - 1 (m - 1 in all),
                       for unit-stride access */
    double *tws;    /* m/2 + 1 complex: exp(-2 pi i k / n), k <= m/2 (split step) */
};

int cf_fft_next_pow2(int n)
{
    int p = 1;
    while (p < n) {
        if (p >= (1 << 30))
            return -1;
        p <<= 1;
    }
    return p;
}

void cf_fft_plan_free(cf_fft_plan *p)
{
    if (!p)
        return;
    free(p->bitrev);
    free(p->twst);
    free(p->tws);
    free(p);
}

int cf_fft_plan_size(const cf_fft_plan *p) { return p ? p->n : 0; }

int cf_fft_plan_create(int n, cf_fft_plan **plan)
{
    if (!plan)
        return CF_EINVAL;
    *plan = NULL;
    if (n < 2 || n > (1 << 30) || (n & (n - 1)) != 0)
        return CF_EINVAL;
    cf_fft_plan *p = calloc(1, sizeof *p);
    if (!p)
        return CF_ENOMEM;
    p->n = n;
    p->m = n / 2;
    int m = p->m;
    p->bitrev = malloc(sizeof(int) * (size_t)m);
    p->tws = malloc(sizeof(double) * 2 * (size_t)(m / 2 + 1));
    p->twst = malloc(sizeof(double) * 2 * (size_t)m);
    if (!p->bitrev || !p->tws || !p->twst) {
        cf_fft_plan_free(p);
        return CF_ENOMEM;
    }
    int bits = 0;
    while ((1 << bits) < m)
        bits++;
    for (int i = 0; i < m; i++) {
        int r = 0;
        for (int b = 0; b < bits; b++)
            r |= ((i >> b) & 1) << (bits - 1 - b);
        p->bitrev[i] = r;
    }
    /* the last stage (len = m) holds exp(-2 pi i k / m), k < m/2; every earlier stage
     * reads it with stride m / len (the same bits at every stage) */
    double *wl = p->twst + (m >= 2 ? 2 * (m / 2 - 1) : 0);   /* (m = 1: no stage) */
    for (int k = 0; k < m / 2; k++) {
        double a = -2.0 * CF_PI * (double)k / (double)m;
        wl[2 * k] = cf_math_cos(a);
        wl[2 * k + 1] = cf_math_sin(a);
        if (4 * k == m) {   /* exactly -i (cos(-pi/2) would leave 6e-17) */
            wl[2 * k] = 0.0;
            wl[2 * k + 1] = -1.0;
        }
    }
    for (int half = 1; half < m / 2; half <<= 1) {
        const int step = m / (2 * half);
        for (int j = 0; j < half; j++) {
            p->twst[2 * (half - 1 + j)] = wl[2 * j * step];
            p->twst[2 * (half - 1 + j) + 1] = wl[2 * j * step + 1];
        }
    }
    for (int k = 0; k <= m / 2; k++) {
        double a = -2.0 * CF_PI * (double)k / (double)n;
        p->tws[2 * k] = cf_math_cos(a);
        p->tws[2 * k + 1] = cf_math_sin(a);
        if (4 * k == n) {
            p->tws[2 * k] = 0.0;
            p->tws[2 * k + 1] = -1.0;
        }
    }
    *plan = p;
    return CF_OK;
}

/* In-place complex FFT of length m (interleaved z), sign -1 forward, +1 backward
 * (unscaled). Iterative decimation in time: bit-reversal, then log2(m) stages. */
static void complex_fft(const cf_fft_plan *p, double *z, int sign)
{
    const int m = p->m;
    for (int i = 0; i < m; i++) {
        int j = p->bitrev[i];
        if (j > i) {
            double tr = z[2 * i], ti = z[2 * i + 1];
            z[2 * i] = z[2 * j];
            z[2 * i + 1] = z[2 * j + 1];
            z[2 * j] = tr;
            z[2 * j + 1] = ti;
        }
    }
    /* first stage (length 2): twiddle 1 */
    for (int i = 0; i + 1 < m; i += 2) {
        double ar = z[2 * i], ai = z[2 * i + 1], br = z[2 * i + 2], bi = z[2 * i + 3];
        z[2 * i] = ar + br;
        z[2 * i + 1] = ai + bi;
        z[2 * i + 2] = ar - br;
        z[2 * i + 3] = ai - bi;
    }
    const double s = (double)sign;
    for (int len = 4; len <= m; len <<= 1) {
        const int half = len >> 1;
        const double *w = p->twst + 2 * (half - 1);
        for (int i = 0; i < m; i += len) {
            double *a = z + 2 * i, *b = z + 2 * (i + half);
            for (int j = 0; j < half; j++) {
                /* forward: w = exp(-2 pi i j/len) as stored; backward: its conjugate */
                const double wr = w[2 * j], wi = -s * w[2 * j + 1];
                const double br = b[2 * j] * wr - b[2 * j + 1] * wi;
                const double bi = b[2 * j] * wi + b[2 * j + 1] * wr;
                const double ar = a[2 * j], ai = a[2 * j + 1];
                a[2 * j] = ar + br;
                a[2 * j + 1] = ai + bi;
                b[2 * j] = ar - br;
                b[2 * j + 1] = ai - bi;
            }
        }
    }
}

/* Split step. With z[j] = x[2j] + i x[2j+1], Z = FFT_m(z), W = exp(-2 pi i / n):
 *   Fe_k = (Z_k + conj Z_{m-k}) / 2,  Fo_k = (Z_k - conj Z_{m-k}) / (2i),
 *   X_k = Fe_k + W^k Fo_k,  X_{m-k} = conj(Fe_k - W^k Fo_k). */
void cf_fft_forward(const cf_fft_plan *p, const double *x, double *spec)
{
    const int n = p->n, m = p->m;
    if (x != spec)
        memcpy(spec, x, sizeof(double) * (size_t)n);
    complex_fft(p, spec, -1);
    double z0r = spec[0], z0i = spec[1];
    spec[0] = z0r + z0i;
    spec[1] = 0.0;
    spec[2 * m] = z0r - z0i;
    spec[2 * m + 1] = 0.0;
    for (int k = 1; k <= m / 2; k++) {
        const int j = m - k;
        const double zkr = spec[2 * k], zki = spec[2 * k + 1];
        const double zjr = spec[2 * j], zji = spec[2 * j + 1];
        const double fer = 0.5 * (zkr + zjr), fei = 0.5 * (zki - zji);
        /* (Z_k - conj Z_j) / (2i): (a + ib)/(2i) = (b - ia)/2 with a = zkr - zjr, b = zki + zji */
        const double for_ = 0.5 * (zki + zji), foi = -0.5 * (zkr - zjr);
        const double wr = p->tws[2 * k], wi = p->tws[2 * k + 1];
        const double tr = wr * for_ - wi * foi, ti = wr * foi + wi * for_;
        spec[2 * k] = fer + tr;
        spec[2 * k + 1] = fei + ti;
        spec[2 * j] = fer - tr;
        spec[2 * j + 1] = -(fei - ti);
    }
}

/* Inverse split: Fe_k = (X_k + conj X_{m-k}) / 2, Fo_k = (X_k - conj X_{m-k}) conj(W^k) / 2,
 * Z_k = Fe_k + i Fo_k, Z_{m-k} = conj Fe_k + i conj Fo_k; then z = IFFT_m(Z) / m. */
void cf_fft_inverse(const cf_fft_plan *p, const double *spec, double *x)
{
    const int n = p->n, m = p->m;
    const double x0 = spec[0], xm = spec[2 * m];
    x[0] = 0.5 * (x0 + xm);
    x[1] = 0.5 * (x0 - xm);
    for (int k = 1; k <= m / 2; k++) {
        const int j = m - k;
        const double xkr = spec[2 * k], xki = spec[2 * k + 1];
        const double xjr = spec[2 * j], xji = spec[2 * j + 1];
        const double fer = 0.5 * (xkr + xjr), fei = 0.5 * (xki - xji);
        const double dr = 0.5 * (xkr - xjr), di = 0.5 * (xki + xji);
        const double wr = p->tws[2 * k], wi = -p->tws[2 * k + 1];   /* conj(W^k) */
        const double for_ = dr * wr - di * wi, foi = dr * wi + di * wr;
        /* Z_k = Fe + i Fo = (fer - foi) + i (fei + for_) */
        x[2 * k] = fer - foi;
        x[2 * k + 1] = fei + for_;
        /* Z_j = conj Fe + i conj Fo = (fer + foi) + i (for_ - fei) */
        x[2 * j] = fer + foi;
        x[2 * j + 1] = for_ - fei;
    }
    complex_fft(p, x, +1);
    const double scale = 1.0 / (double)m;
    for (int i = 0; i < n; i++)
        x[i] *= scale;
}
