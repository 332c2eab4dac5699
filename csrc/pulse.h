/*
 * pulse.h -- the Mavroeidis & Papageorgiou (2003) near-fault velocity pulse
 * (paper Eq. 5; docs/ground_motion.md), its closed-form acceleration (analytic
 * derivative) and displacement (analytic integral), evaluated at given times.
 *
 * With tau = t - t0, W = 2 pi fp and support |tau| <= gamma / (2 fp):
 *   V(t) = A/2 [1 + cos(W tau / gamma)] cos(W tau + nu)
 *   a(t) = dV/dt = -A/2 [ (W/gamma) sin(W tau/gamma) cos(W tau + nu)
 *                        + (1 + cos(W tau/gamma)) W sin(W tau + nu) ]
 *   D(t) = int_{t0 - gamma/(2fp)}^{t} V dt'
 * V and a are zero outside the support; D is zero before it and constant (the
 * pulse's residual displacement) after it. Units follow A: A in m/s gives a in
 * m/s^2 and D in m. Valid for gamma > 0 (the model uses gamma > 1), fp > 0;
 * gamma = 1 (where two terms of the textbook D formula divide by zero) is handled.
 * Stateless; returns CF_EINVAL for a bad parameter; never prints or aborts.
 */
#ifndef CF_PULSE_H
#define CF_PULSE_H

/* cffi:begin */
typedef struct {
    double amplitude;  /* envelope amplitude A (velocity unit, e.g. m/s); any finite value */
    double fp;         /* prevailing frequency, Hz, > 0 */
    double nu;         /* phase angle, rad */
    double gamma;      /* oscillatory character (number of half cycles), > 0 */
    double t0;         /* epoch of the envelope peak, s */
} cf_pulse_params;

/* Velocity, acceleration and displacement at the n times t (s); any output
 * (n entries) may be NULL. */
int cf_pulse_eval(const cf_pulse_params *p, const double *t, int n, double *vel, double *acc,
                  double *disp);

/* First and last time of the pulse's support, s: t0 -/+ gamma / (2 fp). */
int cf_pulse_support(const cf_pulse_params *p, double *t_start, double *t_end);

/* The unit pulse g(u) = 0.5 (1 + cos(2 pi u / gamma)) cos(2 pi u + nu) at the n points u
 * (u = fp tau, cycles): the shape whose peak |g| gives the envelope amplitude A = Vp / |g|.
 * gamma > 0, nu finite; CF_EINVAL otherwise. */
int cf_pulse_unit_shape(double nu, double gamma, const double *u, int n, double *g);

/* Distributions of the pulse parameters for one scenario (the paper after Rupakhety et al.
 * 2011 and Mavroeidis & Papageorgiou 2003). */
typedef struct {
    double log10_vp_mean;   /* mean of log10(Vp / (cm/s)) */
    double log10_vp_sd;     /* its standard deviation */
    double log10_fp_mean;   /* mean of log10(fp / Hz) */
    double log10_fp_sd;     /* its standard deviation */
    double nu_min, nu_max;  /* nu ~ U[nu_min, nu_max], rad */
    double gamma_mean;      /* gamma ~ N(mean, sd) left-truncated at gamma_min */
    double gamma_sd;
    double gamma_min;
} cf_pulse_dist;

/* Maps n points u (row-major n x 4, each in [0, 1]) of the unit 4-cube to pulse parameters
 * by inverse CDFs: Vp = 10^(m + s ndtri(u0)) cm/s, fp = 10^(m + s ndtri(u1)) Hz,
 * nu = nu_min + (nu_max - nu_min) u2, gamma = mean + sd z with z the inverse CDF of the
 * truncated normal, ndtri(Phi(a) + u3 (1 - Phi(a))), a = (gamma_min - mean) / sd, evaluated
 * as -ndtri((1 - u3) Phi(-a)) above the median (no cancellation in the upper tail).
 * All through cf_math, so the same u give the same bits on every CPU. CF_EINVAL for a bad
 * distribution or a u outside [0, 1]. */
int cf_pulse_sample_map(const cf_pulse_dist *d, const double *u, int n, double *vp_cm_s, double *fp_hz,
                        double *nu_rad, double *gamma);
/* cffi:end */

#endif
