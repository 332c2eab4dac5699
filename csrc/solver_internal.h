/*
 * solver_internal.h -- the solver's state and the functions its files share
 * (never in a cffi region; see docs/architecture.md for the map of the files).
 *
 *   solver.c            public API: definition defaults and checks, set-up, the run loop
 *   solver_stack.c      bodies, mass properties, joints, faces, contact points, equilibrium
 *   solver_timestep.c   stability limit of the whole linearised stack -> time step
 *   solver_step.c       the integrator step, as named phases
 *   solver_contact_model.c  the registry of contact models (cf_solver_contact_model)
 *   solver_points.c     contact models: sub-contact points (vertex / perimeter), scalar
 *                       runner, the SIMD width from CPUID
 *   solver_points_wide.h  the same models' runner written once over the lane operators of
 *                       solver_lanes.h, instantiated by solver_points_w2.c, _w4.c, _w8.c (two,
 *                       four, eight points per instruction); every width gives the same bits
 *   solver_exact.c      contact model: exact interface integral
 *   solver_monitor.c    energy ledger, EDPs, collapse criteria, histories
 *   contact_law.h       the contact law itself, one text for every path above
 *
 * Bodies: index 0 is the ground (fixed in the frame that moves with the ground),
 * 1.. are the moving rigid bodies (one per block, or one for a monolithic column).
 * Joint j has a lower body and an upper body; its sub-contacts are kept in
 * structure-of-arrays form with their persistent shear forces.
 */
#ifndef CF_SOLVER_INTERNAL_H
#define CF_SOLVER_INTERNAL_H

#include "cf_common.h"
#include "geometry.h"
#include "solver.h"
#include "solver_math_internal.h"

#define CF_MAXS CF_SOLVER_MAX_SIDES

/* The SIMD widths this build has (every width gives the same bits; solver_lanes.h):
 *   CF_SOLVER_SIMD    2 lanes (SSE2, part of every x86-64 CPU; no -m flag needed), with
 *                     GCC vector extensions; elsewhere, or with -DCF_NO_SIMD, the scalar paths run
 *   CF_SOLVER_AVX2    4 lanes on x86-64 (-DCF_FORCE_SSE2 leaves it out)
 *   CF_SOLVER_AVX512  8 lanes (-DCF_FORCE_AVX2 leaves it out)
 * the wider ones compiled for their instruction set by a target region and run where
 * CPUID says the CPU has it (cf_solver_points_lanes_widest, solver_points.c). */
#if defined(__SSE2__) && defined(__GNUC__) && !defined(CF_NO_SIMD)
#define CF_SOLVER_SIMD 1
#if defined(__x86_64__) && !defined(CF_FORCE_SSE2)
#define CF_SOLVER_AVX2 1
#if !defined(CF_FORCE_AVX2)
#define CF_SOLVER_AVX512 1
#endif
#endif
#endif

/* The widest lanes this CPU and build run: 8, 4, 2, or 1 (no SIMD); a pure function of CPUID. */
int cf_solver_points_lanes_widest(void);

typedef struct {
    double c[3];                 /* face centre in the body frame, m */
    int n;                       /* sides */
    double apo, rc, area;        /* apothem, circumradius (m), area (m^2) */
    double ec[CF_MAXS], es[CF_MAXS];   /* outward in-plane edge normals */
    double vx[CF_MAXS], vy[CF_MAXS];   /* vertices relative to the centre, CCW */
    double poly[2 * CF_MAXS];          /* the same, interleaved (x, y) */
    double ecw[CF_MAXS + 2], esw[CF_MAXS + 2];   /* edge normals with wrap-around: ecw[k + 1] = ec[k mod n] */
} cf_face;

typedef struct {
    int bl, bu;             /* lower and upper body */
    int logical;            /* index of the logical joint (= block above) */
    cf_face fl, fu;         /* lower body's top face, upper body's bottom face */
    double area;            /* joint area, m^2 */
    double kn, ks, mu;      /* normal and shear stiffness (Pa/m), friction coefficient of this joint */
    int p0, np, n0;         /* its sub-contacts: [p0, p0 + np), the first n0 on the upper face */
    double fs[2], mt;       /* exact mode: joint shear force (N, lower face frame), torsional moment (N m) */
    double polar;           /* exact mode: polar moment of the joint area about its centre, m^4 */
    double lz[2];           /* body-frame z of the points of side 0 (upper face) and side 1 (lower face) */
} cf_joint;

/* What the contacts of one step add to the energy ledger. */
typedef struct {
    double vs;       /* spring energy, J (only when need) */
    double dslip;    /* slip dissipation this step, J */
    double dswitch;  /* spring energy removed by points leaving/entering a face polygon, J */
    int need;        /* 1: the energy balance is evaluated at this step */
} cf_step_energy;

struct cf_solver;

/* The stiffness of the stack at rest, for the stability limit (solver_timestep.c): a contact
 * model adds its springs with cf_solver_timestep_add_spring. */
struct cf_stiffness;
/* a spring of stiffness k (N/m) along the unit vector e at world point p (at rest) between bodies bl, bu */
void cf_solver_timestep_add_spring(const struct cf_solver *s, struct cf_stiffness *S, int bl, int bu, const double *p,
                             const double *e, double k);
/* the three springs of a contact of area share w (m^2) of joint J at world point p (at rest):
 * normal kn w along z, shear ks w along x and along y */
void cf_solver_timestep_add_contact(const struct cf_solver *s, struct cf_stiffness *S, const cf_joint *J, const double *p,
                              double w);

/* A contact model: one entry of the registry (solver_contact_model.c, the way REBOUND keeps
 * its integrators, gravity and collision modules: a table of entries, each owning its
 * functions). The definition's `contact` field is the entry's index; its name is the
 * option's value in Python (read through cf_solver_contact_model_name). */
typedef struct {
    const char *name;
    const char *doc;                /* one sentence, exported (cf_solver_contact_model_doc) */
    /* optional: set-up, once the bodies and joints are built (cf_solver_setup): the
     * model's contact points or joint data and its per-run state, in the solver's own
     * arrays (s->p_*, the joints), which cf_solver_stack_release frees; an entry has no
     * release hook, so a model must not allocate memory of its own */
    int (*setup)(struct cf_solver *s);
    /* optional: the model's per-run state to its rest value (the start of every run) */
    void (*reset)(struct cf_solver *s);
    /* the springs joint J contributes to the stiffness of the stability limit */
    void (*stiffness)(const struct cf_solver *s, const cf_joint *J, struct cf_stiffness *K);
    /* the step hook: the forces of one joint */
    void (*joint)(struct cf_solver *s, cf_joint *J, const double *ww, double dt, cf_step_energy *e);
    /* optional: the forces of every joint at once (NULL: joint by joint); the same bits */
    void (*all)(struct cf_solver *s, const double *ww, double dt, cf_step_energy *e);
    /* 1: the batch integrator (solver_batch_lanes.h, which writes the points law in lanes)
     * runs this model's runs side by side; 0: one after the other */
    int batch_lanes;
} cf_solver_contact_model;

/* the registry (solver_contact_model.c): cf_solver_contact_model_table[def.contact] */
extern const cf_solver_contact_model *const cf_solver_contact_model_table[];

struct cf_solver {
    char msg[CF_MSG_LEN];
    int ready;
    cf_solver_check_fn check;       /* the caller's check (cf_solver_set_check), NULL: none */
    void *check_user;
    cf_solver_def def;
    const cf_solver_contact_model *model;
    int lanes;                      /* SIMD lanes of the points runner and the joint chunks (set-up) */
    double density;
    int nblk, nbody, nj;
    /* bodies (nbody) */
    double *m, *inertia;            /* mass (kg), principal inertia (3 per body) */
    double *x, *v, *q, *w, *R;      /* position, velocity (world), quaternion, omega (body), rotation */
    double *F, *T;                  /* force, torque (world) */
    double *x0, *q0;                /* initial state */
    double *fext_prev, *fdamp_prev, *tdamp_prev;
    /* logical blocks (nblk) */
    int *blk_body;
    double *blk_off, *blk_top, *blk_bot, *blk_h, *blk_m, *joint_diam;
    double *blk_rc;                 /* largest circumradius of each block's faces, m */
    double base_diam, total_mass, total_h, com_h;
    /* joints */
    cf_joint *jt;
    /* sub-contacts */
    int np;
    int *p_side, *p_hint;
    double *p_loc, *p_w, *p_ihkw;   /* body-frame position (3), area share (m^2), 1 / (2 ks w) */
    /* the hot loop's view of the same points, structure of arrays (one entry per point):
     * body-frame x, y (z is that of the face, shared), rest position in the other
     * face's frame, the squared radius of the cheap inside test around it (-1: none),
     * kn w and ks w, and the persistent state: shear force (N, face frame) and contact
     * state (0 open, 1 in contact, 2 over the plane but off the polygon, 3 too deep,
     * 4 in contact with an offset; see cf_point_law) */
    double *p_lx, *p_ly, *p_hx, *p_hy, *p_fast, *p_knw, *p_ksw;
    double *p_fsx, *p_fsy, *p_state;
    double *p_pen0;                 /* state 4: depth at which the point's normal spring is unstretched, m */
    double dt_crit, dt;
    /* scratch of the time loop (nbody): world omegas, velocities of the last half step */
    double *ww, *vold, *wold;
    /* history (caller-owned buffers) */
    long h_cap;
    double *h_t, *h_top, *h_pos, *h_quat, *h_open, *h_slip, *h_en, *h_fn;
    double *jfn;                    /* normal force of each joint this step, N */
};

int cf_solver_fail(struct cf_solver *s, int status, const char *fmt, ...);

/* solver_stack.c */
int cf_solver_stack_build(struct cf_solver *s, int nblk, const int *nseg, const cf_geometry_segment *segs,
                          const double *kn, const double *ks, const double *mu);
void cf_solver_stack_release(struct cf_solver *s);
void cf_solver_stack_reset(struct cf_solver *s);
/* the sub-contact points of every joint, mm per edge (0: the polygon vertices) */
int cf_solver_stack_points(struct cf_solver *s, int mm);

/* solver_timestep.c */
int cf_solver_timestep_limit(struct cf_solver *s);
/* Largest eigenvalue of a symmetric n x n matrix (row-major, destroyed); exported for the C tests. */
double cf_solver_timestep_sym_max_eig(double *a, int n);

/* solver_band.c: largest eigenvalue of a symmetric band matrix (n x n, half-bandwidth b <= n - 1,
 * else NaN; ab[i * (b + 1) + d] = A[i][i - d]), O(n b^2) per bisection step; exported for the C tests. */
double cf_solver_band_max_eig(const double *ab, int n, int b);

/* (X, Y) inside the face polygon grown by tol (m)? */
static inline int cf_face_inside(const cf_face *f, double X, double Y, double tol)
{
    int k;
    double lim = f->apo + tol;
    if (X * X + Y * Y <= f->apo * f->apo) return 1;
    for (k = 0; k < f->n; k++)
        if (X * f->ec[k] + Y * f->es[k] > lim) return 0;
    return 1;
}

/* The monitor of one run: energy ledger (J), EDP accumulators, history count, rest
 * detection (solver_monitor.c). */
typedef struct {
    double vg0, vs0;                   /* gravity and spring energy at step 0 */
    double W, Dslip, Ddamp, Dswitch;   /* ground work, slip, damping and contact_switch energy */
    double err_max, scale_max, scale_floor;
    double top0[3], max_top;           /* top-face centre at rest (world), max horizontal displacement (m) */
    long kres, ring_len, ring_count, ring_pos;   /* residual window: every kres steps, ring of ring_len */
    double *ring;                      /* (ring_len x nblk x 2) joint dislocations, m */
    long hcount;                       /* history samples written */
    double ke_win, rest_ke, next_rest; /* at-rest detection after the record */
} cf_monitor;

/* The spring energies (a sum over every sub-contact) enter the ledger every CF_LEDGER_STEPS steps
 * of a run, at history samples and at its last step (cf_solver_run_pre). The batch starts its runs
 * at multiples of it, so that its lanes share these steps and it sums the energies only then. */
enum { CF_LEDGER_STEPS = 4 };

/* a residual-dislocation sample is due at step n (cf_solver_monitor_record reads every body then) */
static inline int cf_monitor_residual_due(const cf_monitor *m, long n) { return n % m->kres == 0; }

/* solver_monitor.c */
int cf_solver_monitor_begin(struct cf_solver *s, cf_monitor *m, double t_rec);
void cf_solver_monitor_end(cf_monitor *m);
double cf_solver_monitor_energy(cf_monitor *m, long n, double ke, double vg, const cf_step_energy *e);
void cf_solver_monitor_record(struct cf_solver *s, cf_monitor *m, long n, double t, double ke, double vg,
                              const cf_step_energy *e, double err, int hist_now);
int cf_solver_monitor_collapse(const struct cf_solver *s, int *blk);
int cf_solver_monitor_at_rest(cf_monitor *m, double t, double ke);
void cf_solver_monitor_finish(struct cf_solver *s, cf_monitor *m, int collapsed, double *resid,
                              cf_solver_result *res);

/* One run's progress through its record (solver.c): what the time loop of cf_solver_run
 * keeps between steps, so that a batch of runs (solver_batch.c) steps each run with the
 * same text. */
typedef struct {
    const double *ax, *ay, *az;        /* the record: nrec samples at dtr, ay and az may be NULL */
    int nrec;
    double dtr, t_rec;                 /* record interval, record duration (s) */
    long n, nsteps;                    /* this step, the last step */
    double t, ctime;                   /* time of this step, collapse time (s) */
    int collapsed, cblk, creason, at_rest, st, hist_now;
    cf_monitor m;
} cf_run;

/* solver.c: a run, step by step. check: the record and the step count (a failed check
 * leaves its message on s); begin: the monitor, on the rest state in s->x, s->R; pre: the
 * time of step r->n, whether its energy and history are due, the ground acceleration;
 * post: after the velocities, the ledger, the checks, the EDPs and the exits -- returns 1
 * when the run ends at this step (else the positions follow and r->n advances); finish:
 * the result. */
int cf_solver_run_check(struct cf_solver *s, cf_run *r, const double *ax, const double *ay, const double *az,
                        int nrec, double dtr);
int cf_solver_run_begin(struct cf_solver *s, cf_run *r);
void cf_solver_run_pre(const struct cf_solver *s, cf_run *r, cf_step_energy *e, double *ag);
int cf_solver_run_post(struct cf_solver *s, cf_run *r, const cf_step_energy *e, double ke, double vg);
/* 1 when cf_solver_run_post reads every body's pose at this step (residual sample, collapse
 * criteria, history), else only the top block's: the batch fills a lane's view accordingly */
int cf_solver_run_reads_all(const cf_run *r);
/* the result of a run that did not run: zeros, no collapse time, no collapse block */
void cf_solver_result_none(cf_solver_result *res);
/* the caller's check asked to stop: the run ends with CF_EINTR and says where */
void cf_solver_run_stopped(struct cf_solver *s, cf_run *r);
void cf_solver_run_finish(struct cf_solver *s, cf_run *r, double *resid, cf_solver_result *res);

/* solver_step.c: the phases of one leapfrog step */
void cf_solver_step_rotations(struct cf_solver *s);
void cf_solver_step_contacts(struct cf_solver *s, double dt, cf_step_energy *e);
void cf_solver_step_velocities(struct cf_solver *s, const double *ag, int damp_on, cf_monitor *m, double *ke,
                               double *vg);
void cf_solver_step_positions(struct cf_solver *s);

/* face centre and normal (world) of face f of body b */
static inline void cf_face_world(const struct cf_solver *s, int b, const cf_face *f, double *c, double *n)
{
    const double *R = s->R + 9 * b;
    mat_vec(R, f->c, c);
    c[0] += s->x[3 * b]; c[1] += s->x[3 * b + 1]; c[2] += s->x[3 * b + 2];
    n[0] = R[2]; n[1] = R[5]; n[2] = R[8];
}

#endif
