/*
 * stochastic.c -- SMSIM-style time-domain stochastic simulation with the
 * Atkinson & Silva (2000) model (stochastic.h, docs/stochastic.md).
 *
 * Model numbers: pycolfrag/data/as00.json (Boore 2003, PAGEOPH 160, Tables 2-4).
 * They are repeated below as constants; a test checks that this C spectrum equals
 * the independent NumPy twin (pycolfrag/ground_motion/_numpy_reference.py, which
 * reads the JSON) to 1e-10, so the two cannot drift apart unnoticed.
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "cf_math.h"
#include "cf_common.h"
#include "fft.h"
#include "rng.h"
#include "stochastic.h"

/* ---- Atkinson & Silva (2000) as in as00.json ---------------------------- */
#define AS_RHO 2.8              /* g/cm^3 */
#define AS_BETA 3.5             /* km/s */
#define AS_V 0.707              /* partition onto two horizontal components */
#define AS_RAD 0.55             /* radiation pattern */
#define AS_F 2.0                /* free surface */
#define AS_R0 1.0               /* km */
#define AS_R_CROSS 40.0         /* km: 1/R spreading below, R^-0.5 beyond */
#define AS_Q0 180.0             /* Q(f) = 180 f^0.45 */
#define AS_QETA 0.45
#define AS_CQ 3.5               /* km/s */
#define AS_KAPPA 0.030          /* s */
#define AS_FMAX 100.0           /* Hz */
#define AS_WIN_EPS 0.2          /* Saragoni-Hart */
#define AS_WIN_ETA 0.05
#define AS_WIN_TETA_FACTOR 2.0  /* t_eta = 2 T_gm */

/* Boore & Joyner (1997) generic rock: linear in f, linear in ln(amp), constant outside. */
static const double bj97_f[11] = {0.01, 0.09, 0.16, 0.51, 0.84, 1.25, 2.26, 3.17, 6.05, 16.6, 61.2};
static const double bj97_amp[11] = {1.0, 1.1, 1.18, 1.42, 1.58, 1.74, 2.06, 2.25, 2.58, 3.13, 4.0};

typedef struct {
    double m0, fa, fb, eps, h, r, g, tgm, c_const;
} scenario;

static void fmt(char *msg, const char *text, double v)
{
    if (msg)
        snprintf(msg, CF_MSG_LEN, text, v);
}

int cf_stochastic_check_scenario(double mw, double dist_km, char *msg)
{
    if (msg)
        msg[0] = 0;
    if (!isfinite(mw) || mw < CF_STOCHASTIC_MW_MIN || mw > CF_STOCHASTIC_MW_MAX) {
        fmt(msg, "Mw = %.15g is outside the Atkinson & Silva (2000) range [4, 8] used here", mw);
        return CF_ERANGE;
    }
    if (!isfinite(dist_km) || dist_km <= 0.0 || dist_km > CF_STOCHASTIC_DIST_MAX_KM) {
        fmt(msg, "dist_km = %.15g is outside the Atkinson & Silva (2000) range (0, 200] km used here",
            dist_km);
        return CF_ERANGE;
    }
    return CF_OK;
}

static void scenario_compute(double mw, double d, scenario *s)
{
    s->m0 = cf_math_pow(10.0, 1.5 * mw + 16.05);            /* dyne-cm */
    s->fa = cf_math_pow(10.0, 2.181 - 0.496 * mw);          /* Hz */
    s->fb = cf_math_pow(10.0, 2.41 - 0.408 * mw);
    s->eps = cf_math_pow(10.0, 0.605 - 0.255 * mw);
    /* (the small-M branch of AS00, M <= 2.4, is outside the accepted range) */
    s->h = cf_math_pow(10.0, -0.05 + 0.15 * mw);            /* km */
    s->r = sqrt(d * d + s->h * s->h);
    s->g = s->r < AS_R_CROSS ? 1.0 / s->r : (1.0 / AS_R_CROSS) * sqrt(AS_R_CROSS / s->r);
    s->tgm = 0.5 / s->fa + 0.05 * s->r;                     /* s */
    /* C = R V F / (4 pi rho beta^3 R0) * 1e-20: cm/s for M0 in dyne-cm */
    s->c_const = AS_RAD * AS_V * AS_F / (4.0 * CF_PI * AS_RHO * AS_BETA * AS_BETA * AS_BETA * AS_R0) * 1e-20;
}

static double bj97(double f)
{
    if (f <= bj97_f[0])
        return bj97_amp[0];
    if (f >= bj97_f[10])
        return bj97_amp[10];
    int i = 0;
    while (f > bj97_f[i + 1])
        i++;
    double w = (f - bj97_f[i]) / (bj97_f[i + 1] - bj97_f[i]);
    return cf_math_exp((1.0 - w) * cf_math_log(bj97_amp[i]) + w * cf_math_log(bj97_amp[i + 1]));
}

/* A(f) in cm/s (as00.json "fas_acceleration"). */
static double fas_cm_s(const scenario *s, double f)
{
    if (!(f > 0.0))
        return 0.0;
    double src = (1.0 - s->eps) / (1.0 + (f / s->fa) * (f / s->fa)) + s->eps / (1.0 + (f / s->fb) * (f / s->fb));
    double q = AS_Q0 * cf_math_pow(f, AS_QETA);
    double anel = cf_math_exp(-CF_PI * f * s->r / (q * AS_CQ));
    double fr = f / AS_FMAX, fr2 = fr * fr, fr4 = fr2 * fr2;
    double dim = cf_math_exp(-CF_PI * AS_KAPPA * f) / sqrt(1.0 + fr4 * fr4);
    double w = 2.0 * CF_PI * f;
    return s->c_const * s->m0 * src * s->g * anel * bj97(f) * dim * w * w;
}

void cf_stochastic_limits(double *mw_min, double *mw_max, double *dist_max_km, double *dt_min, double *dt_max)
{
    if (mw_min) *mw_min = CF_STOCHASTIC_MW_MIN;
    if (mw_max) *mw_max = CF_STOCHASTIC_MW_MAX;
    if (dist_max_km) *dist_max_km = CF_STOCHASTIC_DIST_MAX_KM;
    if (dt_min) *dt_min = CF_STOCHASTIC_DT_MIN;
    if (dt_max) *dt_max = CF_STOCHASTIC_DT_MAX;
}

double cf_stochastic_window(double t, double t_eta)
{
    if (!(t > 0.0) || !(t_eta > 0.0))
        return 0.0;
    const double eps = AS_WIN_EPS, eta = AS_WIN_ETA;
    const double b = -eps * cf_math_log(eta) / (1.0 + eps * (cf_math_log(eps) - 1.0));
    const double c = b / eps;
    const double a = cf_math_pow(cf_math_exp(1.0) / eps, b);
    const double x = t / t_eta;
    return a * cf_math_pow(x, b) * cf_math_exp(-c * x);
}

int cf_stochastic_fas(double mw, double dist_km, const double *f_hz, int n, double *out_m_s, char *msg)
{
    int st = cf_stochastic_check_scenario(mw, dist_km, msg);
    if (st != CF_OK)
        return st;
    if (n < 0 || (n > 0 && (!f_hz || !out_m_s))) {
        fmt(msg, "bad frequency array (n = %g)", (double)n);
        return CF_EINVAL;
    }
    for (int i = 0; i < n; i++) {
        if (!isfinite(f_hz[i]) || f_hz[i] < 0.0) {
            if (msg)
                snprintf(msg, CF_MSG_LEN, "f_hz[%d] = %.17g must be finite and >= 0", i, f_hz[i]);
            return CF_EINVAL;
        }
    }
    scenario s;
    scenario_compute(mw, dist_km, &s);
    for (int i = 0; i < n; i++)
        out_m_s[i] = 0.01 * fas_cm_s(&s, f_hz[i]);
    return CF_OK;
}

int cf_stochastic_duration(double mw, double dist_km, double *duration_s, char *msg)
{
    int st = cf_stochastic_check_scenario(mw, dist_km, msg);
    if (st != CF_OK)
        return st;
    if (!duration_s)
        return CF_EINVAL;
    scenario s;
    scenario_compute(mw, dist_km, &s);
    *duration_s = s.tgm;
    return CF_OK;
}

/* ---- generator object --------------------------------------------------- */
struct cf_stochastic {
    char msg[CF_MSG_LEN];
    int ready;
    cf_stochastic_def def;
    cf_stochastic_info info;
    cf_fft_plan *plan;      /* for info.nfft, reused when the length does not change */
    double *window;         /* n_window: Saragoni-Hart weights */
    double *noise;          /* n_window: the standard normals of a seeded run */
    double *filt;           /* nfft/2 + 1: A(f_k) in m/s divided by dt (the 1/dt of the recipe) */
    double *spec;           /* nfft + 2: work */
    double *x;              /* nfft: work */
    int cap_window, cap_fft;
};

void cf_stochastic_def_default(cf_stochastic_def *def)
{
    def->mw = 6.5;
    def->dist_km = 10.0;
    def->dt = 0.005;
    def->pre_s = 1.0;
    def->tail_s = 3.0;
    def->pad_s = 10.0;
}

cf_stochastic *cf_stochastic_create(void)
{
    cf_stochastic *g = calloc(1, sizeof *g);
    return g;
}

void cf_stochastic_free(cf_stochastic *g)
{
    if (!g)
        return;
    cf_fft_plan_free(g->plan);
    free(g->window);
    free(g->noise);
    free(g->filt);
    free(g->spec);
    free(g->x);
    free(g);
}

const char *cf_stochastic_message(const cf_stochastic *g) { return g ? g->msg : "no generator"; }

/* The definition's checks beyond the scenario's: CF_OK, or CF_EINVAL with a message on msg. */
static int check_def(const cf_stochastic_def *def, char *msg)
{
    int st = cf_stochastic_check_scenario(def->mw, def->dist_km, msg);
    if (st != CF_OK)
        return st;
    if (!isfinite(def->dt) || def->dt < CF_STOCHASTIC_DT_MIN || def->dt > CF_STOCHASTIC_DT_MAX) {
        snprintf(msg, CF_MSG_LEN, "dt = %.17g s must be finite and in [1e-4, 0.02] s", def->dt);
        return CF_EINVAL;
    }
    if (!isfinite(def->pre_s) || def->pre_s < 0.0 || def->pre_s > 100.0 || !isfinite(def->tail_s) ||
        def->tail_s < 0.0 || def->tail_s > 100.0 || !isfinite(def->pad_s) || def->pad_s < 0.0 ||
        def->pad_s > 1000.0) {
        snprintf(msg, CF_MSG_LEN, "pre_s = %g, tail_s = %g, pad_s = %g must be finite, >= 0 (<= 100, 100, 1000 s)",
                 def->pre_s, def->tail_s, def->pad_s);
        return CF_EINVAL;
    }
    return CF_OK;
}

/* The record's layout for the scenario s: source and path values, window, padding, FFT size and output
 * length (in). CF_EINVAL with a message when the record would be too long. */
static int record_layout(const cf_stochastic_def *def, const scenario *s, cf_stochastic_info *in, char *msg)
{
    const double dt = def->dt;
    memset(in, 0, sizeof *in);
    in->m0_dyne_cm = s->m0;
    in->fa_hz = s->fa;
    in->fb_hz = s->fb;
    in->eps_source = s->eps;
    in->h_km = s->h;
    in->r_km = s->r;
    in->duration_s = s->tgm;
    in->window_s = AS_WIN_TETA_FACTOR * s->tgm;
    /* padding each side: at least pad_s, the source duration 0.5/fa (the zero-phase
     * filter A(f) spreads long periods around the window), and the trim lengths */
    double pad = fmax(fmax(def->pad_s, 0.5 / s->fa), fmax(def->pre_s, def->tail_s));
    in->n_window = (int)floor(in->window_s / dt) + 1;
    int n_pad = (int)ceil(pad / dt);
    in->pad_s = n_pad * dt;
    in->i_window = n_pad;
    double n_need = 2.0 * n_pad + in->n_window;
    if (n_need > (double)(1 << 28)) {
        snprintf(msg, CF_MSG_LEN, "record too long for dt = %g s (%.0f samples)", dt, n_need);
        return CF_EINVAL;
    }
    in->nfft = cf_fft_next_pow2((int)n_need);
    int n_pre = (int)lround(def->pre_s / dt), n_post = (int)lround(def->tail_s / dt);
    in->n_out = n_pre + in->n_window + n_post;
    in->window_start_s = n_pre * dt;
    return CF_OK;
}

/* *p grown to n doubles; on failure *p stays as it was (still owned by the generator); returns 0 then. */
static int grow_doubles(double **p, int n)
{
    double *q = realloc(*p, sizeof(double) * (size_t)n);
    if (q)
        *p = q;
    return q != NULL;
}

/* Buffers for the layout in (grown, never shrunk) and the FFT plan (rebuilt only when nfft changes). */
static int grow_buffers(cf_stochastic *g, const cf_stochastic_info *in)
{
    if (in->n_window > g->cap_window) {
        int ok = grow_doubles(&g->window, in->n_window);
        ok &= grow_doubles(&g->noise, in->n_window);
        if (!ok) {
            snprintf(g->msg, CF_MSG_LEN, "out of memory (window)");
            return CF_ENOMEM;
        }
        g->cap_window = in->n_window;
    }
    if (in->nfft > g->cap_fft) {
        int ok = grow_doubles(&g->filt, in->nfft / 2 + 1);
        ok &= grow_doubles(&g->spec, in->nfft + 2);
        ok &= grow_doubles(&g->x, in->nfft);
        if (!ok) {
            snprintf(g->msg, CF_MSG_LEN, "out of memory (nfft = %d)", in->nfft);
            return CF_ENOMEM;
        }
        g->cap_fft = in->nfft;
    }
    if (!g->plan || cf_fft_plan_size(g->plan) != in->nfft) {
        cf_fft_plan_free(g->plan);
        g->plan = NULL;
        int st = cf_fft_plan_create(in->nfft, &g->plan);
        if (st != CF_OK) {
            snprintf(g->msg, CF_MSG_LEN, "FFT plan for n = %d failed (%s)", in->nfft, cf_common_status_name(st));
            return st;
        }
    }
    return CF_OK;
}

int cf_stochastic_setup(cf_stochastic *g, const cf_stochastic_def *def)
{
    if (!g)
        return CF_EINVAL;
    g->msg[0] = 0;
    g->ready = 0;
    if (!def) {
        snprintf(g->msg, CF_MSG_LEN, "def is NULL");
        return CF_EINVAL;
    }
    int st = check_def(def, g->msg);
    if (st != CF_OK)
        return st;
    scenario s;
    scenario_compute(def->mw, def->dist_km, &s);
    const double dt = def->dt;
    cf_stochastic_info in;
    st = record_layout(def, &s, &in, g->msg);
    if (st != CF_OK)
        return st;
    st = grow_buffers(g, &in);
    if (st != CF_OK)
        return st;
    for (int i = 0; i < in.n_window; i++)
        g->window[i] = cf_stochastic_window(i * dt, in.window_s);
    /* A(f_k), f_k = k / (nfft dt), in m/s, times 1/dt (inverse FFT / dt) */
    const double df = 1.0 / (in.nfft * dt);
    for (int k = 0; k <= in.nfft / 2; k++)
        g->filt[k] = 0.01 * fas_cm_s(&s, k * df) / dt;
    g->def = *def;
    g->info = in;
    g->ready = 1;
    return CF_OK;
}

int cf_stochastic_get_info(const cf_stochastic *g, cf_stochastic_info *info)
{
    if (!g || !info)
        return CF_EINVAL;
    if (!g->ready)
        return CF_ESTATE;
    *info = g->info;
    return CF_OK;
}

/* CF_OK when g is set up, else CF_ESTATE with a message naming the call. */
static int check_ready(cf_stochastic *g, const char *call)
{
    g->msg[0] = 0;
    if (!g->ready) {
        snprintf(g->msg, CF_MSG_LEN, "%s before a successful cf_stochastic_setup", call);
        return CF_ESTATE;
    }
    return CF_OK;
}

static int check_output(cf_stochastic *g, const double *acc, int n)
{
    if (!acc || n != g->info.n_out) {
        snprintf(g->msg, CF_MSG_LEN, "output array has %d samples, the record needs %d", n, g->info.n_out);
        return CF_EINVAL;
    }
    return CF_OK;
}

static int check_normals_length(cf_stochastic *g, const double *z, int nz)
{
    if (!z || nz != g->info.n_window) {
        snprintf(g->msg, CF_MSG_LEN, "normals array has %d values, the scenario's noise needs %d (n_window)",
                 z ? nz : 0, g->info.n_window);
        return CF_EINVAL;
    }
    return CF_OK;
}

/* The normals of seed, in the order the record uses them (one call of cf_rng_normal
 * per noise sample, so the polar method's spare of an odd count is dropped). */
static void draw(uint64_t seed, double *z, int n)
{
    cf_rng rng;
    cf_rng_seed(&rng, seed);
    cf_rng_normals(&rng, z, n);
}

/* Steps 1-5 of the recipe from the n_window normals z into acc (info.n_out samples). */
static int make_record(cf_stochastic *g, const double *z, double *acc)
{
    const cf_stochastic_info *in = &g->info;
    const int nfft = in->nfft, nh = nfft / 2;
    double *x = g->x, *spec = g->spec;

    /* 1. windowed Gaussian white noise (unit variance), zero padded */
    memset(x, 0, sizeof(double) * (size_t)nfft);
    double *xw = x + in->i_window;
    for (int i = 0; i < in->n_window; i++)
        xw[i] = z[i] * g->window[i];

    /* 2. real FFT */
    cf_fft_forward(g->plan, x, spec);

    /* 3. RMS of |Z| over 0 < k < nfft/2 (DC and Nyquist excluded) */
    double sum = 0.0;
    for (int k = 1; k < nh; k++)
        sum += spec[2 * k] * spec[2 * k] + spec[2 * k + 1] * spec[2 * k + 1];
    if (!(sum > 0.0)) {
        snprintf(g->msg, CF_MSG_LEN, "zero noise spectrum (window of %d samples)", in->n_window);
        return CF_EUNSTABLE;
    }
    const double inv_rms = 1.0 / sqrt(sum / (double)(nh - 1));

    /* 4. times A(f) / dt (A(0) = 0) */
    for (int k = 0; k <= nh; k++) {
        const double a = g->filt[k] * inv_rms;
        spec[2 * k] *= a;
        spec[2 * k + 1] *= a;
    }

    /* 5. inverse FFT (includes 1/nfft), trim */
    cf_fft_inverse(g->plan, spec, x);
    const int n_pre = (int)lround(g->def.pre_s / g->def.dt);
    memcpy(acc, x + in->i_window - n_pre, sizeof(double) * (size_t)in->n_out);
    return CF_OK;
}

int cf_stochastic_run(cf_stochastic *g, uint64_t seed, double *acc, int n)
{
    if (!g)
        return CF_EINVAL;
    int st = check_ready(g, "cf_stochastic_run");
    if (st == CF_OK)
        st = check_output(g, acc, n);
    if (st != CF_OK)
        return st;
    draw(seed, g->noise, g->info.n_window);
    return make_record(g, g->noise, acc);
}

int cf_stochastic_draw_normals(cf_stochastic *g, uint64_t seed, double *z, int nz)
{
    if (!g)
        return CF_EINVAL;
    int st = check_ready(g, "cf_stochastic_draw_normals");
    if (st == CF_OK)
        st = check_normals_length(g, z, nz);
    if (st != CF_OK)
        return st;
    draw(seed, z, nz);
    return CF_OK;
}

int cf_stochastic_run_normals(cf_stochastic *g, const double *z, int nz, double *acc, int n)
{
    if (!g)
        return CF_EINVAL;
    int st = check_ready(g, "cf_stochastic_run_normals");
    if (st == CF_OK)
        st = check_output(g, acc, n);
    if (st == CF_OK)
        st = check_normals_length(g, z, nz);
    if (st != CF_OK)
        return st;
    for (int i = 0; i < nz; i++) {
        if (!isfinite(z[i])) {
            snprintf(g->msg, CF_MSG_LEN, "normals[%d] = %g is not finite", i, z[i]);
            return CF_EINVAL;
        }
    }
    return make_record(g, z, acc);
}
