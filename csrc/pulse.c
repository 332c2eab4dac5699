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
