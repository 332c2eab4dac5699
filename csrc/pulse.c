/* pulse.c -- Mavroeidis & Papageorgiou (2003) pulse, Eq. 5, and its closed forms. */
#include <math.h>
#include <stddef.h>

#include "cf_math.h"
#include "cf_common.h"
#include "pulse.h"

static int valid(const cf_pulse_params *p)
{
    return p != NULL && isfinite(p->amplitude) && p->fp > 0.0 && isfinite(p->fp) && isfinite(p->nu)
           && p->gamma > 0.0 && isfinite(p->gamma) && isfinite(p->t0);
}

int cf_pulse_support(const cf_pulse_params *p, double *t_start, double *t_end)
{
    double half;
    if (!valid(p) || t_start == NULL || t_end == NULL)
        return CF_EINVAL;
    half = p->gamma / (2.0 * p->fp);
    *t_start = p->t0 - half;
    *t_end = p->t0 + half;
    return CF_OK;
}

/* sin(x) / x, accurate near 0 (the series is exact to rounding for |x| < 1e-4). */
static double sinc(double x)
{
    if (fabs(x) < 1e-4)
        return 1.0 - x * x / 6.0;
    return cf_math_sin(x) / x;
}

/* int_{s}^{tau} cos(k u + nu) du = (tau - s) cos(k (tau + s)/2 + nu) sinc(k (tau - s)/2),
 * which stays exact as k -> 0 (the gamma = 1 term of the displacement). */
static double cos_integral(double k, double nu, double s, double tau)
{
    return (tau - s) * cf_math_cos(0.5 * k * (tau + s) + nu) * sinc(0.5 * k * (tau - s));
}

/* Displacement at tau (inside the support, s = start of the support):
 * V = A/2 [cos(W u + nu) + 1/2 cos((W + We) u + nu) + 1/2 cos((W - We) u + nu)],
 * with We = W / gamma (product-to-sum), integrated term by term. */
static double disp_at(double A, double W, double We, double nu, double s, double tau)
{
    return 0.5 * A * (cos_integral(W, nu, s, tau) + 0.5 * cos_integral(W + We, nu, s, tau)
                      + 0.5 * cos_integral(W - We, nu, s, tau));
}

int cf_pulse_eval(const cf_pulse_params *p, const double *t, int n, double *vel, double *acc,
                  double *disp)
{
    double A, W, We, half, d_end;
    int i;
    if (!valid(p) || t == NULL || n < 0)
        return CF_EINVAL;
    A = p->amplitude;
    W = 2.0 * CF_PI * p->fp;
    We = W / p->gamma;
    half = p->gamma / (2.0 * p->fp);
    d_end = disp_at(A, W, We, p->nu, -half, half);
    for (i = 0; i < n; i++) {
        double tau = t[i] - p->t0;
        if (!isfinite(tau))
            return CF_EINVAL;
        if (tau < -half || tau > half) {
            if (vel) vel[i] = 0.0;
            if (acc) acc[i] = 0.0;
            if (disp) disp[i] = tau < 0.0 ? 0.0 : d_end;
            continue;
        }
        {
            double ce = cf_math_cos(We * tau), se = cf_math_sin(We * tau);
            double cc = cf_math_cos(W * tau + p->nu), sc = cf_math_sin(W * tau + p->nu);
            if (vel) vel[i] = 0.5 * A * (1.0 + ce) * cc;
            if (acc) acc[i] = -0.5 * A * (We * se * cc + (1.0 + ce) * W * sc);
            if (disp) disp[i] = disp_at(A, W, We, p->nu, -half, tau);
        }
    }
    return CF_OK;
}

int cf_pulse_unit_shape(double nu, double gamma, const double *u, int n, double *g)
{
    if (!isfinite(nu) || !(gamma > 0.0) || !isfinite(gamma) || n < 0 || (n > 0 && (u == NULL || g == NULL)))
        return CF_EINVAL;
    for (int i = 0; i < n; i++)
        g[i] = 0.5 * (1.0 + cf_math_cos(2.0 * CF_PI * u[i] / gamma)) * cf_math_cos(2.0 * CF_PI * u[i] + nu);
    return CF_OK;
}

int cf_pulse_sample_map(const cf_pulse_dist *d, const double *u, int n, double *vp_cm_s, double *fp_hz,
                        double *nu_rad, double *gamma)
{
    if (d == NULL || n < 0 || (n > 0 && (u == NULL || vp_cm_s == NULL || fp_hz == NULL || nu_rad == NULL
                                         || gamma == NULL)))
        return CF_EINVAL;
    if (!isfinite(d->log10_vp_mean) || !isfinite(d->log10_fp_mean) || !(d->log10_vp_sd >= 0.0)
        || !(d->log10_fp_sd >= 0.0) || !isfinite(d->log10_vp_sd) || !isfinite(d->log10_fp_sd)
        || !isfinite(d->nu_min) || !isfinite(d->nu_max) || !isfinite(d->gamma_mean)
        || !(d->gamma_sd > 0.0) || !isfinite(d->gamma_sd) || !isfinite(d->gamma_min))
        return CF_EINVAL;
    for (int i = 0; i < 4 * n; i++)
        if (!(u[i] >= 0.0 && u[i] <= 1.0))
            return CF_EINVAL;
    const double a = (d->gamma_min - d->gamma_mean) / d->gamma_sd;
    const double phi_a = cf_math_norm_cdf(a), q_a = cf_math_norm_cdf(-a);   /* Phi(a), 1 - Phi(a) */
    for (int i = 0; i < n; i++) {
        const double *ui = u + 4 * i;
        vp_cm_s[i] = cf_math_pow(10.0, d->log10_vp_mean + d->log10_vp_sd * cf_math_ndtri(ui[0]));
        fp_hz[i] = cf_math_pow(10.0, d->log10_fp_mean + d->log10_fp_sd * cf_math_ndtri(ui[1]));
        nu_rad[i] = d->nu_min + (d->nu_max - d->nu_min) * ui[2];
        double p = phi_a + ui[3] * q_a, z;
        if (p <= 0.5)
            z = cf_math_ndtri(p);
        else
            z = -cf_math_ndtri((1.0 - ui[3]) * q_a);        /* 1 - u3: exact for u3 >= 1/2 */
        double g = d->gamma_mean + d->gamma_sd * z;
        gamma[i] = g < d->gamma_min ? d->gamma_min : g;   /* rounding at u3 = 0 */
    }
    return CF_OK;
}
