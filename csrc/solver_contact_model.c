/*
 * solver_contact_model.c -- the registry of contact models: the definition's `contact`
 * field is an index into this table, and the range check of cf_solver_check_def, the
 * contact option's names in Python (pycolfrag/solver/options.py) and their documentation are read
 * from it, as are each model's own options (solver_options.c). Each entry owns its options,
 * its state (create, reset, free), its stiffness for the stability limit and its step hook
 * (cf_solver_contact_model, solver_internal.h). A new model is its own .c file defining its
 * entry, and one line in CF_CONTACT_MODELS here. The order is that of CF_SOLVER_CONTACT_* (solver.h).
 */
#include <stddef.h>

#include "solver_internal.h"

/* The registry, one line per model: the name of its entry (defined in the model's own file), from
 * which the entries' declarations and the table below are written. */
#define CF_CONTACT_MODELS(X)                                    \
    X(cf_solver_points_vertex)      /* solver_points.c */       \
    X(cf_solver_points_perimeter)   /* solver_points.c */       \
    X(cf_solver_exact_model)        /* solver_exact.c */        \
    /* a new model: its line above this one */

#define CF_DECLARE(entry) extern const cf_solver_contact_model entry;
#define CF_ADDRESS(entry) &entry,
CF_CONTACT_MODELS(CF_DECLARE)

const cf_solver_contact_model *const cf_solver_contact_model_table[] = {CF_CONTACT_MODELS(CF_ADDRESS)};

int cf_solver_contact_model_count(void)
{
    return (int)(sizeof cf_solver_contact_model_table / sizeof cf_solver_contact_model_table[0]);
}

const char *cf_solver_contact_model_name(int i)
{
    return i >= 0 && i < cf_solver_contact_model_count() ? cf_solver_contact_model_table[i]->name : NULL;
}

const char *cf_solver_contact_model_doc(int i)
{
    return i >= 0 && i < cf_solver_contact_model_count() ? cf_solver_contact_model_table[i]->doc : NULL;
}

int cf_solver_contact_model_n_options(int i)
{
    return i >= 0 && i < cf_solver_contact_model_count() ? cf_solver_contact_model_table[i]->n_options : 0;
}

const cf_solver_option *cf_solver_contact_model_option(int i, int k)
{
    if (k < 0 || k >= cf_solver_contact_model_n_options(i)) return NULL;
    return &cf_solver_contact_model_table[i]->options[k];
}
