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
/* cffi:end */

#endif
