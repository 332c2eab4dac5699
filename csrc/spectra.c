/* spectra.c -- intensity measures: peaks, Arias, D5-95, Nigam-Jennings spectra. */
#include <math.h>
#include <stddef.h>

#include "cf_math.h"
#include "cf_common.h"
#include "spectra.h"

int cf_spectra_integrate(const double *acc, int n, double dt, double *vel, double *disp)
{
    double v = 0.0, d = 0.0;
    int i;
    if (acc == NULL || n < 1 || !(dt > 0.0) || !isfinite(dt))
        return CF_EINVAL;
    if (vel) vel[0] = 0.0;
    if (disp) disp[0] = 0.0;
    for (i = 1; i < n; i++) {
        double v1 = v + 0.5 * dt * (acc[i - 1] + acc[i]);
        d += 0.5 * dt * (v + v1);
        v = v1;
        if (vel) vel[i] = v;
        if (disp) disp[i] = d;
    }
    return CF_OK;
}

/* Times (s) at which the cumulative trapezoidal integral of a^2, c[i] at t = i dt,
 * first reaches lo and hi (lo <= hi), in one pass; c rises linearly between samples
 * in this interpolation. A level never reached gives the last sample's time. */
static void level_times(const double *acc, int n, double dt, double lo, double hi, double *t_lo,
                        double *t_hi)
{
    double c = 0.0;
    int i, found_lo = 0;
    *t_lo = *t_hi = dt * (n - 1);
    for (i = 1; i < n; i++) {
        double inc = 0.5 * dt * (acc[i - 1] * acc[i - 1] + acc[i] * acc[i]);
        if (!found_lo && c + inc >= lo && inc > 0.0) {
            *t_lo = dt * ((i - 1) + (lo - c) / inc);
            found_lo = 1;
        }
        if (c + inc >= hi && inc > 0.0) {
            *t_hi = dt * ((i - 1) + (hi - c) / inc);
            return;
        }
        c += inc;
    }
}

int cf_spectra_peaks(const double *acc, int n, double dt, double g, cf_spectra_ims *out)
{
    double v = 0.0, d = 0.0, pga = 0.0, pgv = 0.0, pgd = 0.0, ia = 0.0;
    int i;
    if (acc == NULL || out == NULL || n < 1 || !(dt > 0.0) || !isfinite(dt) || !(g > 0.0))
        return CF_EINVAL;
    pga = fabs(acc[0]);
    for (i = 1; i < n; i++) {
        double v1 = v + 0.5 * dt * (acc[i - 1] + acc[i]);
        d += 0.5 * dt * (v + v1);
        v = v1;
        ia += 0.5 * dt * (acc[i - 1] * acc[i - 1] + acc[i] * acc[i]);
        if (fabs(acc[i]) > pga) pga = fabs(acc[i]);
        if (fabs(v) > pgv) pgv = fabs(v);
        if (fabs(d) > pgd) pgd = fabs(d);
    }
    out->pga = pga;
    out->pgv = pgv;
    out->pgd = pgd;
    out->arias = CF_PI / (2.0 * g) * ia;
    if (ia > 0.0) {
        level_times(acc, n, dt, 0.05 * ia, 0.95 * ia, &out->t5, &out->t95);
    } else {
        out->t5 = out->t95 = 0.0;
    }
    out->d5_95 = out->t95 - out->t5;
    return CF_OK;
}

/* Nigam & Jennings (1969), Eqs. for a piecewise-linear ground acceleration and
 * x'' + 2 zeta w x' + w^2 x = -a_g. Written with E = exp(-zeta w dt),
 * S = sin(wd dt), C = cos(wd dt), wd = w sqrt(1 - zeta^2). */
int cf_spectra_nj_coefficients(double period, double damping, double dt, double *coef)
{
    double w, z, wd, sq, E, S, C, w2, w3, t1, t2, t3, c1, c2;
    if (coef == NULL || !(period > 0.0) || !isfinite(period) || !(damping >= 0.0) || !(damping < 1.0)
        || !(dt > 0.0) || !isfinite(dt))
        return CF_EINVAL;
    z = damping;
    w = 2.0 * CF_PI / period;
    sq = sqrt(1.0 - z * z);
    wd = w * sq;
    E = cf_math_exp(-z * w * dt);
    S = cf_math_sin(wd * dt);
    C = cf_math_cos(wd * dt);
    w2 = w * w;
    w3 = w2 * w;
    coef[0] = E * (z / sq * S + C);                 /* a11 */
    coef[1] = E * S / wd;                           /* a12 */
    coef[2] = -w / sq * E * S;                      /* a21 */
    coef[3] = E * (C - z / sq * S);                 /* a22 */
    t1 = (2.0 * z * z - 1.0) / (w2 * dt);
    t2 = 2.0 * z / (w3 * dt);
    t3 = z / w;
    c1 = C - z / sq * S;                            /* = a22 / E */
    c2 = wd * S + z * w * C;
    coef[4] = E * ((t1 + t3) * S / wd + (t2 + 1.0 / w2) * C) - t2;            /* b11 */
    coef[5] = -E * (t1 * S / wd + t2 * C) - 1.0 / w2 + t2;                    /* b12 */
    coef[6] = E * ((t1 + t3) * c1 - (t2 + 1.0 / w2) * c2) + 1.0 / (w2 * dt);  /* b21 */
    coef[7] = -E * (t1 * c1 - t2 * c2) - 1.0 / (w2 * dt);                     /* b22 */
    return CF_OK;
}

/* One step of the recurrence: the state (x, v) at sample i - 1 -> at sample i, for the
 * ground accelerations a0 = acc[i - 1] and a1 = acc[i]. The one text of the step, shared by
 * the spectra and the displacement history, so that max |x| of the history is SD bit for bit. */
static void nj_step(const double *c, double a0, double a1, double *x, double *v)
{
    double x1 = c[0] * *x + c[1] * *v + c[4] * a0 + c[5] * a1;
    double v1 = c[2] * *x + c[3] * *v + c[6] * a0 + c[7] * a1;
    *x = x1;
    *v = v1;
}

int cf_spectra_response(const double *acc, int n, double dt, const double *periods, int n_periods,
                        double damping, double *sd, double *sv, double *sa)
{
    int j, i;
    if (acc == NULL || periods == NULL || n < 1 || n_periods < 0 || !(dt > 0.0) || !isfinite(dt)
        || !(damping >= 0.0) || !(damping < 1.0))
        return CF_EINVAL;
    for (j = 0; j < n_periods; j++)
        if (!(periods[j] > 0.0) || !isfinite(periods[j]))
            return CF_EINVAL;
    for (j = 0; j < n_periods; j++) {
        double c[8], x = 0.0, v = 0.0, xm = 0.0, vm = 0.0, am = 0.0;
        double w = 2.0 * CF_PI / periods[j], k2 = w * w, k1 = 2.0 * damping * w;
        cf_spectra_nj_coefficients(periods[j], damping, dt, c);
        for (i = 1; i < n; i++) {
            double aa;
            nj_step(c, acc[i - 1], acc[i], &x, &v);
            aa = fabs(k1 * v + k2 * x);             /* |x'' + a_g| */
            if (fabs(x) > xm) xm = fabs(x);
            if (fabs(v) > vm) vm = fabs(v);
            if (aa > am) am = aa;
        }
        if (sd) sd[j] = xm;
        if (sv) sv[j] = vm;
        if (sa) sa[j] = am;
    }
    return CF_OK;
}

int cf_spectra_displacement(const double *acc, int n, double dt, double period, double damping, double *x)
{
    double c[8], xi = 0.0, vi = 0.0;
    int i;
    if (acc == NULL || x == NULL || n < 1 || !(dt > 0.0) || !isfinite(dt) || !(period > 0.0)
        || !isfinite(period) || !(damping >= 0.0) || !(damping < 1.0))
        return CF_EINVAL;
    cf_spectra_nj_coefficients(period, damping, dt, c);
    x[0] = 0.0;
    for (i = 1; i < n; i++) {
        nj_step(c, acc[i - 1], acc[i], &xi, &vi);
        x[i] = xi;
    }
    return CF_OK;
}
