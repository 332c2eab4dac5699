/*
 * solver_options.c -- the solver's options as data: the table of the solver's own options (the
 * fields of cf_solver_def) and, through the registry, each contact model's table (its entry's
 * `options`). From these and nothing else: the defaults (cf_solver_def_default), the range checks
 * and their messages (cf_solver_check_def), the options Python's SolverOptions is built from
 * (cf_solver_options_count / _get) and their setting by name. A contact model's options travel in
 * cf_solver_def.model_options, one slot per different name over the whole registry (two models may
 * declare the same option: the points models share theirs), and reach the model's create hook as
 * the values of its own table, in its order (cf_solver_options_of_model).
 */
#include <math.h>
#include <stddef.h>
#include <stdio.h>
#include <string.h>

#include "solver_internal.h"

/* The default gravity is compiled in from pycolfrag/data/constants.json, the one home of the value that
   Python's intensity measures (in g) also read: csrc/flags.mk and pycolfrag/_build.py pass it. */
#ifndef CF_G_M_S2
#error "CF_G_M_S2 (gravity, m/s^2) is not defined: compile with the CFLAGS of csrc/flags.mk"
#endif

#define REAL CF_SOLVER_OPTION_REAL
#define FLAG CF_SOLVER_OPTION_FLAG

/* The solver's own options: declaration, and where the value lives in cf_solver_def (an int for the
 * kinds INT, FLAG and MODEL, a double for REAL and STEP). */
static const struct {
    cf_solver_option o;
    size_t at;
} OWN[] = {
    {{"contact", CF_SOLVER_OPTION_MODEL, 0, 0, 0, 0, CF_SOLVER_CONTACT_VERTEX, "-",
      "Joint discretisation: the contact model, by its name in the registry of contact models (each "
      "described by its own documentation)."}, offsetof(cf_solver_def, contact)},
    {{"dt", CF_SOLVER_OPTION_STEP, 0.0, INFINITY, 0, 1, 0.0, "s",
      "Explicit solver step; automatic (0 in C, None in Python): dt_factor times the whole-stack "
      "stability limit."}, offsetof(cf_solver_def, dt)},
    {{"dt_factor", REAL, 0.0, 4.0, 1, 0, 0.8, "-",
      "Fraction of the whole-stack stability limit taken as the automatic step."},
     offsetof(cf_solver_def, dt_factor)},
    {{"tail_s", REAL, 0.0, INFINITY, 0, 1, 3.0, "s", "Free response after the end of the record."},
     offsetof(cf_solver_def, tail_s)},
    {{"residual_window_s", REAL, 0.0, INFINITY, 1, 1, 2.0, "s",
      "u_d is the residual dislocation averaged over this last part of the response."},
     offsetof(cf_solver_def, residual_window_s)},
    {{"planar", FLAG, 0, 1, 0, 0, 0, "-", "Motion restricted to the x-z plane (one horizontal component only)."},
     offsetof(cf_solver_def, planar)},
    {{"monolithic", FLAG, 0, 1, 0, 0, 0, "-", "The whole column as one rigid body on its base joint."},
     offsetof(cf_solver_def, monolithic)},
    {{"early_exit", FLAG, 0, 1, 0, 0, 1, "-", "Stop at collapse, or once the column is at rest after the record."},
     offsetof(cf_solver_def, early_exit)},
    {{"damping_alpha", REAL, 0.0, INFINITY, 0, 1, 0.0, "1/s", "Mass-proportional damping (0: none, as in the paper)."},
     offsetof(cf_solver_def, damping_alpha)},
    {{"damping_start_s", REAL, -INFINITY, INFINITY, 1, 1, 0.0, "s", "Damping acts from this time on."},
     offsetof(cf_solver_def, damping_start_s)},
    {{"history_dt", REAL, 0.0, INFINITY, 1, 1, 0.01, "s", "History sampling interval."},
     offsetof(cf_solver_def, history_dt)},
    {{"g", REAL, 0.0, INFINITY, 1, 1, CF_G_M_S2, "m/s^2",
      "Acceleration of gravity (the blocks' weights and their potential energy)."}, offsetof(cf_solver_def, g)},
    {{"energy_tolerance", REAL, 0.0, INFINITY, 1, 0, 0.05, "-",
      "Relative energy-balance error above which a run warns (energy_warning)."},
     offsetof(cf_solver_def, energy_tolerance)},
    {{"unstable_tolerance", REAL, 0.0, INFINITY, 1, 0, 0.5, "-",
      "Relative energy-balance error above which a run stops as unstable (CF_EUNSTABLE; SolverError in Python)."},
     offsetof(cf_solver_def, unstable_tolerance)},
    {{"initial_tilt_rad", REAL, -1.0, 1.0, 0, 0, 0.0, "rad",
      "Rigid initial tilt of the whole column about its +x base edge."}, offsetof(cf_solver_def, initial_tilt_rad)},
};
#define N_OWN ((int)(sizeof OWN / sizeof OWN[0]))

/* The contact models' options, each name once, in the registry's order (the first declaration of a
 * name stands for it); returns their count, at most `max` written to out. */
static int model_options(const cf_solver_option **out, int max)
{
    int m, k, u, n = 0, nm = cf_solver_contact_model_count();
    for (m = 0; m < nm; m++) {
        for (k = 0; k < cf_solver_contact_model_n_options(m); k++) {
            const cf_solver_option *o = cf_solver_contact_model_option(m, k);
            for (u = 0; u < n && u < max; u++)
                if (!strcmp(out[u]->name, o->name)) break;
            if (u < n && u < max) continue;
            if (n < max) out[n] = o;
            n++;
        }
    }
    return n;
}

/* at most this many names are looked at: more than the definition holds, so an overfull registry
 * is seen (cf_solver_options_check) */
#define SEEN (2 * CF_SOLVER_MAX_MODEL_OPTIONS)

int cf_solver_options_count(void)
{
    const cf_solver_option *mo[SEEN];
    int n = model_options(mo, SEEN);
    return N_OWN + (n < SEEN ? n : SEEN);
}

const cf_solver_option *cf_solver_options_get(int i)
{
    const cf_solver_option *mo[SEEN];
    int n = model_options(mo, SEEN);
    if (i >= 0 && i < N_OWN) return &OWN[i].o;
    if (i >= N_OWN && i < N_OWN + n && i - N_OWN < SEEN) return mo[i - N_OWN];
    return NULL;
}

/* Where option `name` lives: its index in OWN (>= 0), or -1 - its model slot; -1 - SEEN when unknown. */
static int where(const char *name)
{
    const cf_solver_option *mo[SEEN];
    int i, n;
    if (!name) return -1 - SEEN;
    for (i = 0; i < N_OWN; i++)
        if (!strcmp(OWN[i].o.name, name)) return i;
    n = model_options(mo, SEEN);
    for (i = 0; i < n && i < SEEN; i++)
        if (!strcmp(mo[i]->name, name)) return -1 - i;
    return -1 - SEEN;
}

static int stored_as_int(int kind)
{
    return kind == CF_SOLVER_OPTION_INT || kind == CF_SOLVER_OPTION_FLAG || kind == CF_SOLVER_OPTION_MODEL;
}

static double own_value(const cf_solver_def *d, int i)
{
    const char *p = (const char *)d + OWN[i].at;
    if (stored_as_int(OWN[i].o.kind)) return (double)*(const int *)(const void *)p;
    return *(const double *)(const void *)p;
}

int cf_solver_options_set(cf_solver_def *d, const char *name, double value)
{
    int i = where(name);
    if (!d || i == -1 - SEEN) return CF_EINVAL;
    if (i < 0) {
        if (-1 - i >= CF_SOLVER_MAX_MODEL_OPTIONS) return CF_EINVAL;
        d->model_options[-1 - i] = value;
        return CF_OK;
    }
    if (stored_as_int(OWN[i].o.kind)) {
        if (!(value == floor(value)) || !(fabs(value) <= 2147483647.0)) return CF_EINVAL;
        *(int *)(void *)((char *)d + OWN[i].at) = (int)value;
    } else {
        *(double *)(void *)((char *)d + OWN[i].at) = value;
    }
    return CF_OK;
}

int cf_solver_options_value(const cf_solver_def *d, const char *name, double *value)
{
    int i = where(name);
    if (!d || !value || i == -1 - SEEN) return CF_EINVAL;
    if (i < 0) {
        if (-1 - i >= CF_SOLVER_MAX_MODEL_OPTIONS) return CF_EINVAL;
        *value = d->model_options[-1 - i];
    } else {
        *value = own_value(d, i);
    }
    return CF_OK;
}

void cf_solver_options_default(cf_solver_def *d)
{
    int i, n = cf_solver_options_count();
    memset(d, 0, sizeof *d);
    for (i = 0; i < n; i++) {
        const cf_solver_option *o = cf_solver_options_get(i);
        cf_solver_options_set(d, o->name, o->value);
    }
}

/* The values of contact model m's options in d, in the order of its table, into out. */
void cf_solver_options_of_model(const cf_solver_def *d, int m, double *out)
{
    int k;
    for (k = 0; k < cf_solver_contact_model_n_options(m); k++)
        if (cf_solver_options_value(d, cf_solver_contact_model_option(m, k)->name, &out[k])) out[k] = NAN;
}

/* ---- the range checks and their messages --------------------------------------- */

static int accepted(const cf_solver_option *o, double v)
{
    if (isnan(v)) return 0;
    if (o->kind == CF_SOLVER_OPTION_MODEL) return v >= 0 && v < cf_solver_contact_model_count() && v == floor(v);
    if (v < o->lo || (o->lo_open && v == o->lo)) return 0;
    if (v > o->hi || (o->hi_open && v == o->hi)) return 0;
    if (stored_as_int(o->kind) && v != floor(v)) return 0;
    return 1;
}

/* "0 (vertex), 1 (perimeter) or 2 (exact)": every model of the registry */
static void model_list(char *buf, size_t size)
{
    size_t u = 0;
    int i, n = cf_solver_contact_model_count();
    buf[0] = 0;
    for (i = 0; i < n && u < size; i++)
        u += (size_t)snprintf(buf + u, size - u, "%s%d (%s)", i == 0 ? "" : i == n - 1 ? " or " : ", ", i,
                              cf_solver_contact_model_name(i));
}

/* What the range says, as the messages write it: "in (0, 4]", ">= 0", "finite", "0 or 1", ... */
static void range_text(const cf_solver_option *o, char *buf, size_t size)
{
    int lo_inf = isinf(o->lo), hi_inf = isinf(o->hi);
    const char *integer = o->kind == CF_SOLVER_OPTION_INT ? "an integer " : "";
    if (o->kind == CF_SOLVER_OPTION_FLAG) snprintf(buf, size, "0 or 1");
    else if (o->kind == CF_SOLVER_OPTION_MODEL) model_list(buf, size);
    else if (lo_inf && hi_inf) snprintf(buf, size, "%sfinite", integer);
    else if (hi_inf) snprintf(buf, size, "%s%s %g", integer, o->lo_open ? ">" : ">=", o->lo);
    else if (lo_inf) snprintf(buf, size, "%s%s %g", integer, o->hi_open ? "<" : "<=", o->hi);
    else snprintf(buf, size, "%sin %c%g, %g%c", integer, o->lo_open ? '(' : '[', o->lo, o->hi, o->hi_open ? ')' : ']');
    if (o->kind == CF_SOLVER_OPTION_STEP) {
        size_t u = strlen(buf);
        snprintf(buf + u, size - u, " (0 = automatic)");
    }
}

/* CF_OK, or CF_EINVAL with a message in msg naming the first option out of its range and its value. */
int cf_solver_options_check(const cf_solver_def *d, char *msg)
{
    const cf_solver_option *mo[SEEN];
    int i, n = model_options(mo, SEEN);
    char text[CF_MSG_LEN];
    if (n > CF_SOLVER_MAX_MODEL_OPTIONS)
        return cf_common_fail(msg, CF_EINVAL, "the contact models declare %d different options, more than the %d "
                              "cf_solver_def holds (CF_SOLVER_MAX_MODEL_OPTIONS)", n, CF_SOLVER_MAX_MODEL_OPTIONS);
    for (i = 0; i < N_OWN + n; i++) {
        const cf_solver_option *o = cf_solver_options_get(i);
        double v = 0.0;
        cf_solver_options_value(d, o->name, &v);
        if (accepted(o, v)) continue;
        range_text(o, text, sizeof text);
        return cf_common_fail(msg, CF_EINVAL, "%s must be %s, got %g", o->name, text, v);
    }
    return CF_OK;
}
