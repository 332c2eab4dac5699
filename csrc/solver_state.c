/*
 * solver_state.c -- the state that carries over from one run to the next (docs/sequences.md):
 * a flat array of doubles, each value exact (an int as a double), holding everything the time loop
 * of cf_solver_run reads from one step to the next -- the step, the bodies (positions, quaternions,
 * velocities, the external and damping forces of the last step), the contact model's joint state
 * (its state_doubles / state_copy hooks), the connectors' law state, peaks and break times -- and
 * the monitor's running values (energy ledger, top displacement and slip peaks, the residual
 * window, the history count, the collapse), so that a run continued from the state at the end of a
 * run gives the bits of one long run over both records with the ground still between them.
 *
 * Layout: CF_ST_HEAD header values (the shape the state belongs to, then the run's counters), the
 * monitor's CF_ST_MON scalars, CF_ST_BODY per body, the residual ring, a scene's column and beam
 * peaks, the contact model's doubles, CF_ST_CONN per connector.
 */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "solver_internal.h"

#define CF_ST_VERSION 1.0
enum { CF_ST_HEAD = 22, CF_ST_MON = 12, CF_ST_BODY = 22, CF_ST_CONN = 18 };

/* the header's shape entries, checked against the set-up solver (name: for the message) */
static const char *const shape_name[] = {"format version", "contact model", "bodies", "joints", "blocks", "connectors",
                                         "columns", "epistyles", "residual window samples", "residual window width",
                                         "contact model values", "solver step dt"};
enum { CF_ST_SHAPE = 12 };

static long ring_len(const cf_solver *s, long *kres)
{
    long k = (long)floor(0.005 / s->dt);
    if (k < 1) k = 1;
    *kres = k;
    return (long)ceil(s->def.residual_window_s / (k * s->dt)) + 1;   /* cf_solver_monitor_begin's */
}

static long model_doubles(const cf_solver *s)
{
    return s->model && s->model->state_doubles ? s->model->state_doubles(s, s->contact) : 0;
}

/* the shape of the set-up solver, as the header's first CF_ST_SHAPE values */
static void shape(const cf_solver *s, double *h)
{
    long kres;
    h[0] = CF_ST_VERSION;
    h[1] = s->def.contact;
    h[2] = s->nbody;
    h[3] = s->nj;
    h[4] = s->nblk;
    h[5] = s->conn ? s->conn->n : 0;
    h[6] = s->scene ? s->scene->ncol : 0;
    h[7] = s->scene ? s->scene->nbeam : 0;
    h[8] = (double)ring_len(s, &kres);
    h[9] = 2.0 * (s->scene ? s->nj : s->nblk);
    h[10] = (double)model_doubles(s);
    h[11] = s->dt;
}

long cf_solver_state_size(const cf_solver *s)
{
    double h[CF_ST_SHAPE];
    if (!s || !s->ready) return 0;
    shape(s, h);
    return CF_ST_HEAD + CF_ST_MON + CF_ST_BODY * (long)s->nbody + (long)(h[8] * h[9]) + (long)(h[6] + h[7])
           + (long)h[10] + CF_ST_CONN * (long)h[5];
}

int cf_solver_state_keep(cf_solver *s, int keep)
{
    if (!s) return CF_EINVAL;
    s->keep_state = keep != 0;
    return CF_OK;
}

void cf_solver_state_release(cf_solver *s)
{
    free(s->state_final); free(s->state_resume);
    s->state_final = s->state_resume = NULL;
    s->state_len = 0;
}

int cf_solver_state_get(const cf_solver *s, double *out, long n)
{
    if (!s) return CF_EINVAL;
    if (!s->state_final) return CF_ESTATE;
    if (!out || n != s->state_len) return CF_EINVAL;
    memcpy(out, s->state_final, sizeof(double) * (size_t)n);
    return CF_OK;
}

int cf_solver_state_set(cf_solver *s, const double *state, long n)
{
    double h[CF_ST_SHAPE];
    long want;
    int k;
    if (!s) return CF_EINVAL;
    free(s->state_resume);
    s->state_resume = NULL;
    if (!state) return CF_OK;
    if (!s->ready) return cf_solver_fail(s, CF_ESTATE, "cf_solver_state_set before a successful cf_solver_setup");
    want = cf_solver_state_size(s);
    shape(s, h);
    for (k = 0; k < CF_ST_SHAPE && k < n; k++)
        if (!(state[k] == h[k]))   /* the step bit for bit */
            return cf_solver_fail(s, CF_EINVAL, "the state belongs to another solver: its %s is %.17g, this one's %.17g",
                                  shape_name[k], state[k], h[k]);
    if (n != want) return cf_solver_fail(s, CF_EINVAL, "the state has %ld values, this solver's has %ld", n, want);
    s->state_resume = (double *)malloc(sizeof(double) * (size_t)n);
    if (!s->state_resume) return cf_solver_fail(s, CF_ENOMEM, "out of memory");
    memcpy(s->state_resume, state, sizeof(double) * (size_t)n);
    return CF_OK;
}

/* copy the arrays of n doubles between the solver (to_buf 1: out of it) and the state at *p */
static void move(double *mine, long n, double **p, int to_buf)
{
    if (to_buf) memcpy(*p, mine, sizeof(double) * (size_t)n);
    else memcpy(mine, *p, sizeof(double) * (size_t)n);
    *p += n;
}

/* everything after the header, both ways */
static void body(cf_solver *s, cf_monitor *m, double *p, int to_buf)
{
    double mon[CF_ST_MON];
    long nb = s->nbody, i;
    if (to_buf) {
        mon[0] = m->vg0; mon[1] = m->vs0; mon[2] = m->vc0; mon[3] = m->W; mon[4] = m->Dslip; mon[5] = m->Ddamp;
        mon[6] = m->Dswitch; mon[7] = m->Dconn; mon[8] = m->err_max; mon[9] = m->scale_max; mon[10] = m->max_top;
        mon[11] = (double)m->kres;
    }
    move(mon, CF_ST_MON, &p, to_buf);
    if (!to_buf) {
        m->vg0 = mon[0]; m->vs0 = mon[1]; m->vc0 = mon[2]; m->W = mon[3]; m->Dslip = mon[4]; m->Ddamp = mon[5];
        m->Dswitch = mon[6]; m->Dconn = mon[7]; m->err_max = mon[8]; m->scale_max = mon[9]; m->max_top = mon[10];
    }
    move(s->x, 3 * nb, &p, to_buf); move(s->v, 3 * nb, &p, to_buf); move(s->q, 4 * nb, &p, to_buf);
    move(s->w, 3 * nb, &p, to_buf); move(s->fext_prev, 3 * nb, &p, to_buf);
    move(s->fdamp_prev, 3 * nb, &p, to_buf); move(s->tdamp_prev, 3 * nb, &p, to_buf);
    move(m->ring, m->ring_len * 2 * (s->scene ? s->nj : s->nblk), &p, to_buf);
    if (s->scene) { move(m->col_max, s->scene->ncol, &p, to_buf); move(m->beam_slip, s->scene->nbeam, &p, to_buf); }
    if (s->model->state_copy) s->model->state_copy(s, s->contact, p, to_buf);
    p += model_doubles(s);
    for (i = 0; s->conn && i < s->conn->n; i++) {
        cf_connector_state *c = &s->conn->st[i];
        double b[CF_ST_CONN];
        if (to_buf) {
            b[0] = c->w[0]; b[1] = c->w[1]; b[2] = c->w[2]; b[3] = c->a; memcpy(b + 4, c->u, 3 * sizeof(double));
            memcpy(b + 7, c->f, 3 * sizeof(double)); b[10] = c->v; b[11] = c->yielded; b[12] = c->broken;
            memcpy(b + 13, s->conn->peak + 3 * i, 3 * sizeof(double)); b[16] = s->conn->t_break[i];
            b[17] = s->conn->diss[i];
        }
        move(b, CF_ST_CONN, &p, to_buf);
        if (!to_buf) {
            c->w[0] = b[0]; c->w[1] = b[1]; c->w[2] = b[2]; c->a = b[3]; memcpy(c->u, b + 4, 3 * sizeof(double));
            memcpy(c->f, b + 7, 3 * sizeof(double)); c->v = b[10]; c->yielded = (int)b[11]; c->broken = (int)b[12];
            memcpy(s->conn->peak + 3 * i, b + 13, 3 * sizeof(double)); s->conn->t_break[i] = b[16];
            s->conn->diss[i] = b[17];
        }
    }
}

int cf_solver_state_capture(cf_solver *s, const cf_run *r)
{
    long n = cf_solver_state_size(s);
    double *h;
    cf_monitor m = r->m;   /* read only (body() reads it when to_buf) */
    if (!s->state_final || s->state_len != n) {
        free(s->state_final);
        s->state_final = (double *)malloc(sizeof(double) * (size_t)n);
        s->state_len = 0;
        if (!s->state_final) return cf_solver_fail(s, CF_ENOMEM, "out of memory");
        s->state_len = n;
    }
    h = s->state_final;
    shape(s, h);
    h[12] = (double)r->n;   /* the step whose positions the state holds (velocities half a step on) */
    h[13] = (double)r->m.hcount;
    h[14] = r->collapsed; h[15] = r->cblk; h[16] = r->creason; h[17] = r->ctime;
    h[18] = (double)r->m.ring_count; h[19] = (double)r->m.ring_pos;
    h[20] = s->conn ? (double)s->conn->steps : 0.0;
    h[21] = r->at_rest;
    body(s, &m, h + CF_ST_HEAD, 1);
    return CF_OK;
}

/* the time axis of a continued run's record of n samples at dtr: its first sample's index i0, the
 * record's duration on that axis t_rec; the state's step k */
static long first_sample(const cf_solver *s, long k, double dtr)
{
    /* ground_acc's f at the state's time, floored: the sample at or before it is f0, the ground is
     * still at f0 + 1 too (the state's run saw it still at its time), the record starts at f0 + 2 */
    return (long)((double)k * s->dt / dtr) + 2;
}

long cf_solver_state_history_capacity(const cf_solver *s, int n, double dtr)
{
    const double *h = s->state_resume;
    long i0 = first_sample(s, (long)h[12], dtr);
    double t_final = (double)(i0 + n - 1) * dtr + s->def.tail_s;
    double cap = floor(t_final / s->def.history_dt + 1e-9) + 2 - h[13];
    if (!(cap <= CF_SOLVER_MAX_HISTORY)) return -1;
    return cap > 0 ? (long)cap : 0;
}

int cf_solver_state_resume(cf_solver *s, cf_run *r)
{
    const double *h = s->state_resume;
    long k = (long)h[12], nt;
    double ns;
    r->i0 = first_sample(s, k, r->dtr);
    nt = r->i0 + r->nrec;
    r->t_rec = (double)(nt - 1) * r->dtr;   /* cf_solver_run_check's of one record of nt samples */
    ns = ceil((r->t_rec + s->def.tail_s) / s->dt - 1e-9);
    if (!(ns <= CF_SOLVER_MAX_STEPS))
        return cf_solver_fail(s, CF_EINVAL, "the continued run needs %.4g steps, more than the limit of %d", ns,
                              CF_SOLVER_MAX_STEPS);
    r->nsteps = (long)ns;
    r->n_first = k + 1;
    r->collapsed = (int)h[14]; r->cblk = (int)h[15]; r->creason = (int)h[16]; r->ctime = h[17];
    r->m.hcount = r->m.h0 = (long)h[13];
    r->m.ring_count = (long)h[18]; r->m.ring_pos = (long)h[19];
    r->m.next_rest = r->t_rec + 0.5;
    if (s->conn) s->conn->steps = (long)h[20];
    body(s, &r->m, (double *)h + CF_ST_HEAD, 0);
    return CF_OK;
}
