/*
 * stochastic.h -- Boore's stochastic method in the time domain (as his SMSIM
 * program does it), with the Atkinson & Silva (2000) point-source model for
 * California (every parameter as in pycolfrag/data/as00.json; docs/stochastic.md).
 *
 * Recipe (one record): n_w Gaussian white-noise samples of unit variance over the
 * Saragoni-Hart window (length t_eta = 2 T_gm) -> times the window -> zero padded
 * to a power of two nfft -> real FFT Z -> Z / sqrt(mean |Z_k|^2 over 0 < k < nfft/2)
 * -> times the target Fourier amplitude A(f) (A(0) = 0) -> inverse FFT / dt.
 * The output is in m/s^2 and trimmed to [window start - pre_s, window end + tail_s].
 *
 * Use: cf_stochastic_create -> cf_stochastic_setup(def) -> cf_stochastic_info ->
 * cf_stochastic_run(seed, acc, n_out) as often as needed (each run depends only on
 * its seed) -> cf_stochastic_free. Setup caches the FFT plan, the window and the
 * target spectrum, so records of one scenario cost only noise + two FFTs.
 *
 * A record is a pure function of its n_window standard normals (the white noise):
 * cf_stochastic_run(seed) is cf_stochastic_draw_normals(seed) followed by
 * cf_stochastic_run_normals of those normals, bit for bit. Samplers that move in the
 * space of the normals (subset simulation) give them directly. The record is
 * unchanged by a positive factor on all the normals (step 3 divides by their RMS
 * spectral amplitude), so only their direction matters.
 * A generator is not thread-safe (it owns work buffers); use one per thread.
 * Every fallible call returns a cf_status and leaves a message on the object.
 */
#ifndef CF_STOCHASTIC_H
#define CF_STOCHASTIC_H

#include <stdint.h>
#include "cf_common.h"

#define CF_STOCHASTIC_MW_MIN 4.0      /* accepted magnitude range (docs/stochastic.md) */
#define CF_STOCHASTIC_MW_MAX 8.0
#define CF_STOCHASTIC_DIST_MAX_KM 200.0   /* accepted closest distance: (0, 200] km */
#define CF_STOCHASTIC_DT_MIN 1e-4     /* accepted time step: [1e-4, 0.02] s */
#define CF_STOCHASTIC_DT_MAX 0.02

/* cffi:begin */
typedef struct {
    double mw;          /* moment magnitude, [4, 8]; default 6.5 */
    double dist_km;     /* closest distance to the fault d, km, (0, 200]; default 10 */
    double dt;          /* time step, s, [1e-4, 0.02]; default 0.005 */
    double pre_s;       /* kept before the window start, s, >= 0; default 1.0 */
    double tail_s;      /* kept after the window end, s, >= 0; default 3.0 */
    double pad_s;       /* minimum zero padding on each side of the window, s; the padding
                           used is max(pad_s, 0.5/fa, pre_s, tail_s); default 10.0 */
} cf_stochastic_def;

typedef struct {
    double m0_dyne_cm;      /* seismic moment, dyne-cm */
    double fa_hz;           /* AS00 lower corner frequency, Hz */
    double fb_hz;           /* AS00 upper corner frequency, Hz */
    double eps_source;      /* AS00 weight of the upper corner */
    double h_km;            /* pseudo-depth, km */
    double r_km;            /* R = sqrt(d^2 + h^2), km */
    double duration_s;      /* T_gm = 0.5/fa + 0.05 R, s */
    double window_s;        /* Saragoni-Hart window length t_eta = 2 T_gm, s */
    double window_start_s;  /* time of the window start in the returned record, s */
    double pad_s;           /* zero padding used before the window, s */
    int n_window;           /* noise samples (window from t = 0 to t_eta) */
    int nfft;               /* padded FFT length (power of two) */
    int i_window;           /* index of the window start in the padded array */
    int n_out;              /* samples of the returned record */
} cf_stochastic_info;

typedef struct cf_stochastic cf_stochastic;

void cf_stochastic_def_default(cf_stochastic_def *def);
cf_stochastic *cf_stochastic_create(void);
void cf_stochastic_free(cf_stochastic *g);
const char *cf_stochastic_message(const cf_stochastic *g);

/* Validate def (CF_ERANGE for Mw / distance outside the model's range or
 * non-finite, CF_EINVAL for dt or the trim lengths), size and fill the caches. */
int cf_stochastic_setup(cf_stochastic *g, const cf_stochastic_def *def);
/* Sizes and source/path quantities of the set-up scenario (CF_ESTATE before setup). */
int cf_stochastic_get_info(const cf_stochastic *g, cf_stochastic_info *info);
/* One record for seed into acc (n must equal info.n_out), m/s^2. */
int cf_stochastic_run(cf_stochastic *g, uint64_t seed, double *acc, int n);
/* The n_window standard normals cf_stochastic_run draws for seed, in order, into z
 * (nz must equal info.n_window): xoshiro256** seeded by splitmix64, polar-method
 * normals (rng.h). CF_ESTATE before setup, CF_EINVAL for a wrong length. */
int cf_stochastic_draw_normals(cf_stochastic *g, uint64_t seed, double *z, int nz);
/* One record from the given standard normals z (nz must equal info.n_window, every
 * value finite) into acc (n must equal info.n_out), m/s^2: with the normals of
 * cf_stochastic_draw_normals(seed), bitwise the record of cf_stochastic_run(seed).
 * CF_ESTATE before setup, CF_EINVAL for a wrong length or a non-finite normal (the
 * message names its index), CF_EUNSTABLE when every normal is zero. */
int cf_stochastic_run_normals(cf_stochastic *g, const double *z, int nz, double *acc, int n);

/* Scenario check alone: CF_OK, or CF_ERANGE with a message in msg (CF_MSG_LEN
 * bytes, may be NULL) naming the bad value. */
int cf_stochastic_check_scenario(double mw, double dist_km, char *msg);
/* Target Fourier amplitude of acceleration A(f) at n frequencies f_hz (>= 0),
 * in m/s (SI; the model's cm/s divided by 100); A(0) = 0. */
int cf_stochastic_fas(double mw, double dist_km, const double *f_hz, int n, double *out_m_s, char *msg);
/* Ground-motion duration T_gm = 0.5/fa + 0.05 R, s. */
int cf_stochastic_duration(double mw, double dist_km, double *duration_s, char *msg);
/* The accepted ranges above (cffi cannot read floating-point #defines). */
void cf_stochastic_limits(double *mw_min, double *mw_max, double *dist_max_km, double *dt_min, double *dt_max);
/* Saragoni-Hart window w(t) (peak 1 at t = eps t_eta, eta at t = t_eta) for t >= 0. */
double cf_stochastic_window(double t, double t_eta);
/* cffi:end */

#endif
