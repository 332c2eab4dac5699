/*
 * solver_connector_law.c -- the registry of connector laws (kinds of shear law): a connector's `kind`
 * is an index into this table, and the kind's check at set-up, the names, docs and values that Python
 * reads (pycolfrag/structure/connector_laws.py) and the law's text at every step are taken from it. Each entry
 * owns its values (declared as data), their checks, its state at rest, its shear force and its yield
 * displacement (cf_connector_law, connector_law.h). A new law is its own .c file defining its entry,
 * and one line in CF_CONNECTOR_LAWS here. The order is that of CF_SOLVER_CONNECTOR_* (solver.h).
 */
#include <math.h>
#include <stddef.h>

#include "solver_internal.h"

/* The registry, one line per law: the name of its entry (defined in the law's own file), from which
 * the entries' declarations and the table below are written. */
#define CF_CONNECTOR_LAWS(X)                                        \
    X(cf_connector_elastoplastic_law)   /* connector_elastoplastic.c */ \
    X(cf_connector_clearance_law)       /* connector_clearance.c */     \
    /* a new law: its line above this one */

#define CF_DECLARE(entry) extern const cf_connector_law entry;
#define CF_ADDRESS(entry) &entry,
CF_CONNECTOR_LAWS(CF_DECLARE)

const cf_connector_law *const cf_solver_connector_law_table[] = {CF_CONNECTOR_LAWS(CF_ADDRESS)};

int cf_solver_connector_law_count(void)
{
    return (int)(sizeof cf_solver_connector_law_table / sizeof cf_solver_connector_law_table[0]);
}

const char *cf_solver_connector_law_name(int i)
{
    return i >= 0 && i < cf_solver_connector_law_count() ? cf_solver_connector_law_table[i]->name : NULL;
}

const char *cf_solver_connector_law_doc(int i)
{
    return i >= 0 && i < cf_solver_connector_law_count() ? cf_solver_connector_law_table[i]->doc : NULL;
}

int cf_solver_connector_law_n_values(int i)
{
    return i >= 0 && i < cf_solver_connector_law_count() ? cf_solver_connector_law_table[i]->n_values : 0;
}

const cf_solver_option *cf_solver_connector_law_value(int i, int k)
{
    if (k < 0 || k >= cf_solver_connector_law_n_values(i)) return NULL;
    return &cf_solver_connector_law_table[i]->values[k];
}

double cf_solver_connector_law_u_yield(const cf_solver_connector *c)
{
    if (!c || c->kind < 0 || c->kind >= cf_solver_connector_law_count()) return NAN;
    if (!(c->k_shear > 0.0)) return INFINITY;
    return cf_solver_connector_law_table[c->kind]->u_yield(c);
}
