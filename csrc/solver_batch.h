/*
 * solver_batch.h -- many runs of one column at once, one run per SIMD lane
 * (docs/performance.md, "Runs in lanes").
 *
 * A set-up cf_solver (cf_solver_setup / cf_solver_setup_joints) and a list of jobs,
 * each a record with its own output buffers: cf_solver_batch_run integrates W runs
 * side by side (W = 8 with AVX-512, 4 with AVX2, 2 with SSE2, chosen at run time),
 * every lane doing the operations of cf_solver_run in its order, and refills a lane
 * with the next job when its run ends (the jobs are taken longest record first, which
 * leaves fewer idle lanes at the end; each job's output stays at its index). Every job's result, residual dislocations,
 * histories, status and message are bitwise those of cf_solver_run on a freshly set-up
 * solver, at every width (scripts/check_result_hashes.sh checks it).
 */
#ifndef CF_SOLVER_BATCH_H
#define CF_SOLVER_BATCH_H

#include "cf_common.h"
#include "solver.h"

/* cffi:begin */
/* One run of a batch: the record (as for cf_solver_run) and where its outputs go. */
typedef struct {
    const double *acc_x;          /* n samples, m/s^2 */
    const double *acc_y, *acc_z;  /* n samples each, or NULL */
    int n;
    double dt_rec;                /* s */
    double *residual_dislocation; /* n_blocks entries (m), or NULL */
    /* histories as cf_solver_set_history / cf_solver_set_history_normal (capacity 0: none;
     * any buffer may be NULL) */
    long history_capacity;
    double *h_t, *h_top, *h_pos, *h_quat, *h_open, *h_slip, *h_energy, *h_normal;
    /* a scene's outputs as cf_solver_set_outputs (columns, beams, connectors) and its connectors'
     * histories as cf_solver_set_history_connectors (energy, connectors): this job's own (NULL:
     * none; the solver's own settings are not used by a batch) */
    double *out_columns, *out_beams, *out_connectors;
    double *h_conn_energy, *h_conn;
} cf_solver_batch_job;

/* What cf_solver_run returned for the job, its message, its result. */
typedef struct {
    int status;
    char message[CF_MSG_LEN];
    cf_solver_result result;
} cf_solver_batch_out;

/* The widest batch the set-up solver s runs on this CPU and build: 8 (AVX-512), 4 (AVX2),
 * 2 (SSE2), or 1 (one run after the other: the exact-interface contact model, or a build
 * without SIMD); 0 before set-up. A column with connectors and a scene of several columns and
 * beams run in lanes as a column does (solver_batch_lanes.h). */
int cf_solver_batch_max_width(const cf_solver *s);
/* The width cf_solver_batch_run takes for n_jobs jobs when asked for 0: the widest that is
 * faster than one run after the other for that many jobs (8 from 5 jobs on, 4 from 3 on,
 * else 1; 2 lanes of SSE2 are slower than one SSE2 run, so never 2). */
int cf_solver_batch_width(const cf_solver *s, int n_jobs);

/* Runs n_jobs jobs on the column of s (set up), width runs at a time: 0 = automatic
 * (cf_solver_batch_width), else 1, 2, 4 or 8 up to cf_solver_batch_max_width. Returns CF_OK when every
 * job was attempted (each job's own status is in out[i].status), CF_EINVAL for bad
 * arguments, CF_ESTATE before set-up, CF_ENOMEM; the message is on s. Uses s's time
 * step and options; s's own state is left as after a run. */
int cf_solver_batch_run(cf_solver *s, int width, int n_jobs, const cf_solver_batch_job *jobs,
                        cf_solver_batch_out *out);
/* cffi:end */

#endif
