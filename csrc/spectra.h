/*
 * spectra.h -- intensity measures of an acceleration record (docs/ground_motion.md):
 * PGA, PGV, PGD, Arias intensity, significant duration D5-95, and elastic SDOF
 * response spectra by the exact piecewise-linear recurrence of Nigam & Jennings
 * (1969).
 *
 * Conventions: the record a[0..n-1] (m/s^2) is sampled at dt (s) and taken as
 * piecewise linear between samples. Velocity and displacement are trapezoidal
 * integrals starting at rest (v[0] = d[0] = 0), with no baseline correction (the
 * peaks of the record as given; a synthetic record ends at rest by construction,
 * and a natural record's processing is its provider's choice). The Arias
 * integral is trapezoidal too, and D5-95 interpolates linearly in time between
 * samples of the cumulative (Husid) integral.
 *
 * Stateless functions: no object holds a message, so they return CF_EINVAL for a
 * bad argument and the Python layer (pycolfrag/ground_motion/intensity.py) names the value
 * before calling. Nothing prints, exits or aborts.
 */
#ifndef CF_SPECTRA_H
#define CF_SPECTRA_H

/* cffi:begin */
typedef struct {
    double pga;       /* max |a|, m/s^2 */
    double pgv;       /* max |v| of the trapezoidal velocity, m/s */
    double pgd;       /* max |d| of the trapezoidal displacement, m */
    double arias;     /* Arias intensity pi/(2g) int a^2 dt (trapezoidal), m/s */
    double t5;        /* time at which the Husid integral reaches 5 %, s (0 for a null record) */
    double t95;       /* time at which it reaches 95 %, s (0 for a null record) */
    double d5_95;     /* significant duration t95 - t5, s */
} cf_spectra_ims;

/* Trapezoidal velocity (m/s) and displacement (m) of acc (n >= 1 samples, m/s^2)
 * from rest; vel and disp (n entries each) may be NULL. CF_EINVAL for n < 1, dt <= 0. */
int cf_spectra_integrate(const double *acc, int n, double dt, double *vel, double *disp);

/* Peak ground motion, Arias intensity (g: gravity, m/s^2) and D5-95 of acc. */
int cf_spectra_peaks(const double *acc, int n, double dt, double g, cf_spectra_ims *out);

/* Elastic SDOF response (x'' + 2 zeta w x' + w^2 x = -a, from rest, over the
 * record only: no free-vibration tail) at n_periods periods (s, > 0), damping
 * ratio zeta in [0, 1). Outputs, each n_periods entries or NULL:
 * sd = max |x| (m), sv = max |x'| (relative velocity, m/s),
 * sa = max |x'' + a| (absolute acceleration, m/s^2). Pseudo-spectral values are
 * w sd and w^2 sd. */
int cf_spectra_response(const double *acc, int n, double dt, const double *periods, int n_periods,
                        double damping, double *sd, double *sv, double *sa);

/* Relative displacement history x[0..n-1] (m) of one oscillator (period s > 0, damping ratio
 * in [0, 1)) under acc, from rest: x[0] = 0, then the steps of cf_spectra_response, so that
 * max |x| is its sd bit for bit. What RotD of SA needs: the pair's histories, rotated. */
int cf_spectra_displacement(const double *acc, int n, double dt, double period, double damping, double *x);

/* Nigam & Jennings (1969) step matrices for one period: state (x, x') advances as
 * x1 = a11 x0 + a12 v0 + b11 ag0 + b12 ag1, v1 = a21 x0 + a22 v0 + b21 ag0 + b22 ag1.
 * coef = {a11, a12, a21, a22, b11, b12, b21, b22}. Exposed for the tests. */
int cf_spectra_nj_coefficients(double period, double damping, double dt, double *coef);
/* cffi:end */

#endif
