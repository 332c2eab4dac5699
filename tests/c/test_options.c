/* The solver's options as data (solver_options.c and each contact model's table): every default
 * passes the range check, every declared range is the one the check enforces (values just outside
 * each bound refused with a message naming the option, the closed bounds accepted), options set and
 * read by name, and the models' tables agree with each other. Every expectation is read from the
 * tables themselves, so a model or option added to them is tested without an edit here. */
#include <math.h>
#include <stdio.h>
#include <string.h>
#include "cf_test.h"
#include "cf_common.h"
#include "solver.h"

/* Is value v of option o accepted by the check of a default definition? With its message in msg. */
static int accepted(cf_solver *s, const cf_solver_option *o, double v)
{
    cf_solver_def d;
    cf_solver_def_default(&d);
    if (cf_solver_options_set(&d, o->name, v) != CF_OK) return 0;   /* an int field refuses a fraction */
    return cf_solver_check_def(s, &d) == CF_OK;
}

/* The message of a refusal starts with the option's name and shows the value. */
static int names_it(cf_solver *s, const cf_solver_option *o)
{
    const char *m = cf_solver_message(s);
    return strncmp(m, o->name, strlen(o->name)) == 0 && strstr(m, " must be ") != NULL && strstr(m, "got ") != NULL;
}

static void test_defaults_are_the_tables_and_pass(void)
{
    cf_solver_def d;
    cf_solver *s = cf_solver_create();
    int i, n = cf_solver_options_count();
    CF_CHECK(n > 0 && cf_solver_options_get(n) == NULL && cf_solver_options_get(-1) == NULL);
    cf_solver_def_default(&d);
    CF_CHECK(cf_solver_check_def(s, &d) == CF_OK);
    for (i = 0; i < n; i++) {
        const cf_solver_option *o = cf_solver_options_get(i);
        double v = NAN;
        CF_CHECK(cf_solver_options_value(&d, o->name, &v) == CF_OK);
        CF_CHECK(v == o->value);
        CF_CHECK(o->unit && o->unit[0] && o->doc && strlen(o->doc) > 10);
    }
    cf_solver_free(s);
}

/* Every bound: the value just outside refused (the bound itself when it is open), the bound itself
 * accepted when it is closed; NaN refused everywhere; a fraction refused by the integer kinds. */
static void test_each_declared_range_is_the_check(void)
{
    cf_solver *s = cf_solver_create();
    int i, n = cf_solver_options_count(), nm = cf_solver_contact_model_count();
    for (i = 0; i < n; i++) {
        const cf_solver_option *o = cf_solver_options_get(i);
        int integer = o->kind == CF_SOLVER_OPTION_INT || o->kind == CF_SOLVER_OPTION_FLAG;
        CF_CHECK(!accepted(s, o, NAN));
        if (o->kind == CF_SOLVER_OPTION_MODEL) {
            CF_CHECK(!accepted(s, o, -1) && names_it(s, o));
            CF_CHECK(!accepted(s, o, nm) && names_it(s, o));
            CF_CHECK(accepted(s, o, 0) && accepted(s, o, nm - 1));
            continue;
        }
        if (isinf(o->lo) && o->lo_open) CF_CHECK(!accepted(s, o, -INFINITY) && names_it(s, o));
        if (isinf(o->hi) && o->hi_open) CF_CHECK(!accepted(s, o, INFINITY) && names_it(s, o));
        if (isinf(o->hi) && !o->hi_open && !integer) CF_CHECK(accepted(s, o, INFINITY));
        if (!isinf(o->lo)) {
            double out = o->lo_open ? o->lo : integer ? o->lo - 1 : nextafter(o->lo, -INFINITY);
            CF_CHECK(!accepted(s, o, out) && names_it(s, o));
            if (!o->lo_open) CF_CHECK(accepted(s, o, o->lo));
        }
        if (!isinf(o->hi)) {
            double out = o->hi_open ? o->hi : integer ? o->hi + 1 : nextafter(o->hi, INFINITY);
            CF_CHECK(!accepted(s, o, out) && names_it(s, o));
            if (!o->hi_open) CF_CHECK(accepted(s, o, o->hi));
        }
        if (integer) CF_CHECK(!accepted(s, o, o->value + 0.5));
    }
    cf_solver_free(s);
}

static void test_options_by_name(void)
{
    cf_solver_def d;
    double v;
    int i, n = cf_solver_options_count();
    cf_solver_def_default(&d);
    CF_CHECK(cf_solver_options_set(&d, "no_such_option", 1.0) == CF_EINVAL);
    CF_CHECK(cf_solver_options_value(&d, "no_such_option", &v) == CF_EINVAL);
    CF_CHECK(cf_solver_options_set(&d, NULL, 1.0) == CF_EINVAL);
    CF_CHECK(cf_solver_options_set(&d, "contact", 0.5) == CF_EINVAL);   /* an int field takes no fraction */
    for (i = 0; i < n; i++) {   /* every option holds its own value: no two share a place */
        const cf_solver_option *o = cf_solver_options_get(i);
        CF_CHECK(cf_solver_options_set(&d, o->name, 100 + i) == CF_OK);
    }
    for (i = 0; i < n; i++) {
        CF_CHECK(cf_solver_options_value(&d, cf_solver_options_get(i)->name, &v) == CF_OK);
        CF_CHECK(v == 100 + i);
    }
    /* the field and the name are one place */
    cf_solver_def_default(&d);
    CF_CHECK(cf_solver_options_set(&d, "dt_factor", 0.25) == CF_OK && d.dt_factor == 0.25);
    d.tail_s = 7.5;
    CF_CHECK(cf_solver_options_value(&d, "tail_s", &v) == CF_OK && v == 7.5);
}

/* Names are unique over all options; a model's option is the one the whole list declares under its
 * name (two models that share an option declare it alike); the distinct model options fit the
 * definition. */
static void test_model_tables_agree(void)
{
    int i, j, m, k, n = cf_solver_options_count(), nm = cf_solver_contact_model_count(), nmodel = 0;
    for (i = 0; i < n; i++)
        for (j = i + 1; j < n; j++) CF_CHECK(strcmp(cf_solver_options_get(i)->name, cf_solver_options_get(j)->name));
    for (m = 0; m < nm; m++) {
        CF_CHECK(cf_solver_contact_model_option(m, cf_solver_contact_model_n_options(m)) == NULL);
        for (k = 0; k < cf_solver_contact_model_n_options(m); k++) {
            const cf_solver_option *o = cf_solver_contact_model_option(m, k), *g = NULL;
            for (i = 0; i < n; i++)
                if (!strcmp(cf_solver_options_get(i)->name, o->name)) g = cf_solver_options_get(i);
            CF_CHECK(g != NULL);
            if (!g) continue;
            CF_CHECK(g->kind == o->kind && g->value == o->value && !strcmp(g->unit, o->unit) && !strcmp(g->doc, o->doc));
            CF_CHECK(g->lo == o->lo && g->hi == o->hi);
            CF_CHECK(g->lo_open == o->lo_open && g->hi_open == o->hi_open);
            CF_CHECK(o->kind != CF_SOLVER_OPTION_MODEL);
        }
    }
    for (i = 0; i < n; i++) {   /* the options some model declares */
        for (m = 0; m < nm; m++)
            for (k = 0; k < cf_solver_contact_model_n_options(m); k++)
                if (!strcmp(cf_solver_contact_model_option(m, k)->name, cf_solver_options_get(i)->name)) goto found;
        continue;
    found:
        nmodel++;
    }
    CF_CHECK(nmodel <= CF_SOLVER_MAX_MODEL_OPTIONS);
}

int main(void)
{
    CF_RUN(test_defaults_are_the_tables_and_pass);
    CF_RUN(test_each_declared_range_is_the_check);
    CF_RUN(test_options_by_name);
    CF_RUN(test_model_tables_agree);
    return CF_TEST_SUMMARY("test_options");
}
