/*
 * solver_internal.h -- the solver's state and the functions its files share
 * (never in a cffi region; see docs/architecture.md for the map of the files).
 *
 *   solver.c            public API: definition defaults and checks, set-up, the run loop
 *   solver_options.c    the options as data: the solver's own table and the models' (defaults,
 *                       ranges, messages, options by name)
 *   solver_stack.c      bodies, mass properties, joints, faces, equilibrium
 *   solver_as_built.c   a joint of blocks placed as built: the overlap of its faces at rest
 *   solver_face_points.c  the sub-contact points of the faces, for the models that carry points
 *   solver_timestep.c   stability limit of the whole linearised stack -> time step
 *   solver_step.c       the integrator step, as named phases
 *   solver_contact_model.c  the registry of contact models (cf_solver_contact_model)
 *   solver_points.c     contact models: sub-contact points (vertex / perimeter), their state
 *                       cf_points, the SIMD width from CPUID
 *   solver_points_wide.h  the same models' runner written once over the lane operators of
 *                       solver_lanes.h, instantiated by solver_points_w2.c, _w4.c, _w8.c (two,
 *                       four, eight points per instruction); every width gives the same bits
 *   solver_exact.c      contact model: exact interface integral
 *   solver_monitor.c    energy ledger, EDPs, collapse criteria, histories
 *   solver_connectors.c connectors (dowels) across joints: their state, springs, forces, reports
 *   solver_scene.c      a scene's bodies and joints: several columns, beams on bearings
 *   solver_state.c      the state that carries over from one run to the next (docs/sequences.md)
 *   connector_law.h     the connectors' law, one text
 *   solver_connector_law.c  the registry of connector laws (cf_connector_law); each law its own
 *                       file: connector_elastoplastic.c, connector_clearance.c
 *   contact_law.h       the contact law itself, one text for every path above
 *
 * Bodies: index 0 is the ground (fixed in the frame that moves with the ground),
 * 1.. are the moving rigid bodies (one per block, or one for a monolithic column).
 * Joint j has a lower body and an upper body and their faces; what a contact model keeps on
 * it (points, shear forces) is the model's own state (s->contact).
 */
#ifndef CF_SOLVER_INTERNAL_H
#define CF_SOLVER_INTERNAL_H

#include <stdlib.h>

#include "cf_common.h"
#include "connector_law.h"
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
    double apo, rc, area;        /* apothem of the unscaled polygon, circumradius (m), area (m^2) */
    /* aspect (the section's scale along y, geometry.h) and the radius of a circle inside the face (m):
     * apo at aspect 1, apo min(1, asp) else. The face tests run on the unscaled polygon: (X, Y) is
     * inside iff (X, Y / asp) is within apo of every edge, so es holds the normals' y parts / asp
     * (unit normals at aspect 1; the tolerance then grows the face by tol asp along y) */
    double asp, apoc;
    double polar;                /* the face's polar moment of area about its centre, m^4 */
    /* the exact model's torsional friction arm over its regular one, (2/3) sqrt(A_c / pi): 1 at aspect 1;
     * scaled, rbar(a) / (rbar(1) sqrt(a)), rbar the face's mean distance from its centre (geometry.h) */
    double tarm;
    double ec[CF_MAXS], es[CF_MAXS];   /* outward in-plane edge normals (the y parts / asp) */
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
    /* the collapse criteria: the bodies [bu, above) are everything this joint carries (for a single
     * column every body from bu on); a bearing (a beam on a column's top block) is not tested for
     * overturning, the beam's centre of mass lying over neither of its bearings */
    int above, bearing;
    /* an as-built joint (asb 1: its faces offset or turned against each other at rest, solver_as_built.c):
     * its contact region is the overlap of its faces at rest, cn vertices cpoly (counter-clockwise, in the
     * lower face's frame from its centre), of area `area`, centroid ccen and polar moment cpolar about it
     * (m^4); d0 the upper face's centre from the lower one's at rest (lower face frame). 0: aligned.
     * Chipped (chole > 0, an aligned joint): the region is cpoly (the upper face at its outer radius) less
     * cpoly scaled by chole about ccen (the face at its inner radius); area and cpolar are the annulus's. */
    int asb, cn;
    double d0[2], ccen[2], cpolar, chole, cout;   /* cout: chipped, the outer radius / the upper face's */
    double cpoly[4 * CF_MAXS];
    /* A chipped face missing a sector (csec 1, solver_as_built.c): the region above less the wedge of the
     * missing angles about the face centre. cpoly is then the open chain of its outer boundary (cn vertices,
     * from the wedge's end edge counter-clockwise round to its start edge), fanned from the face centre with
     * no closing edge, each fan triangle's band between the scales chole and 1; csp its convex pieces (csn[i]
     * vertices each, at most two: the face centre and the chain within an angle <= pi), the hole's the same
     * scaled by chole; ccen, area and cpolar are the region's. */
    int csec, csn[2];
    double csp[2][2 * (CF_MAXS + 3)];
} cf_joint;

/* What the contacts of one step add to the energy ledger. */
typedef struct {
    double vs;       /* spring energy, J (only when need) */
    double dslip;    /* slip dissipation this step, J */
    double dswitch;  /* spring energy removed by points leaving/entering a face polygon, J */
    int need;        /* 1: the energy balance is evaluated at this step */
    int ledger;      /* 1: a step of the run's CF_LEDGER_STEPS (n % CF_LEDGER_STEPS == 0): awake joints try to sleep */
    double vc;       /* connectors' stored energy, J (only when need; 0 without connectors) */
    double dconn;    /* connectors' dissipation this step, J (0 without connectors) */
} cf_step_energy;

struct cf_solver;

/* The springs a contact model puts into the stiffness of the stability limit (solver_timestep.c),
 * joint by joint: its stiffness hook appends them here (cf_springs_add, cf_springs_add_contact),
 * the time step assembles them in that order. A spring of stiffness k (N/m) along the unit vector
 * e at world point p (at rest) between the joint's bodies. */
typedef struct {
    double p[3], e[3], k;
} cf_spring;

typedef struct {
    cf_spring *v;
    int n, cap;
    int nomem;                      /* 1: a spring did not fit in memory (the limit fails with CF_ENOMEM) */
} cf_springs;

static inline void cf_springs_add(cf_springs *K, const double *p, const double *e, double k)
{
    cf_spring *sp;
    if (K->n == K->cap) {
        int cap = K->cap > 0 ? 2 * K->cap : 64;
        cf_spring *v = (cf_spring *)realloc(K->v, sizeof(cf_spring) * (size_t)cap);
        if (!v) { K->nomem = 1; return; }
        K->v = v; K->cap = cap;
    }
    sp = &K->v[K->n++];
    sp->p[0] = p[0]; sp->p[1] = p[1]; sp->p[2] = p[2];
    sp->e[0] = e[0]; sp->e[1] = e[1]; sp->e[2] = e[2];
    sp->k = k;
}

/* the three springs of a contact of area share w (m^2) of joint J at world point p (at rest):
 * normal kn w along z, shear ks w along x and along y */
static inline void cf_springs_add_contact(cf_springs *K, const cf_joint *J, const double *p, double w)
{
    static const double ex[3] = {1, 0, 0}, ey[3] = {0, 1, 0}, ez[3] = {0, 0, 1};
    cf_springs_add(K, p, ez, J->kn * w);
    cf_springs_add(K, p, ex, J->ks * w);
    cf_springs_add(K, p, ey, J->ks * w);
}

/* A contact model: one entry of the registry (solver_contact_model.c, the way REBOUND keeps
 * its integrators, gravity and collision modules: a table of entries, each owning its
 * functions and its state). The definition's `contact` field is the entry's index; its name is
 * the option's value in Python (read through cf_solver_contact_model_name). The solver calls the
 * hooks; a model calls nothing of the files that call it (the stack, the time step, the step,
 * solver.c): what it needs is in the solver's state it is handed (bodies, joints and their faces,
 * the definition) or comes from the files below it (solver_face_points.c: the sub-contact points
 * of the faces; contact.c, cf_math.c). scripts/check_c_calls.py checks that no call goes up. */
typedef struct cf_solver_contact_model {
    const char *name;
    const char *doc;                /* one sentence, exported (cf_solver_contact_model_doc) */
    /* its options, declared as data (name, kind, range, default, unit, doc): the range checks,
     * Python's SolverOptions and the docs take them from here (solver_options.c) */
    const cf_solver_option *options;
    int n_options;
    /* its own state: created once the bodies and joints are built (cf_solver_setup) from the
     * values of its options (opt, in the order of `options`), allocated by the model and freed by
     * free through cf_solver_free (or a new set-up); NULL create: none */
    int (*create)(struct cf_solver *s, const double *opt, void **state);
    /* optional: the state to its value at the start of every run */
    void (*reset)(const struct cf_solver *s, void *state);
    void (*free)(void *state);
    /* the springs joint J contributes to the stiffness of the stability limit */
    void (*stiffness)(const struct cf_solver *s, const void *state, const cf_joint *J, cf_springs *K);
    /* the step hook: the forces of one joint */
    void (*joint)(struct cf_solver *s, void *state, const cf_joint *J, const double *ww, double dt,
                  cf_step_energy *e);
    /* optional: the forces of every joint at once (NULL: joint by joint); the same bits */
    void (*all)(struct cf_solver *s, void *state, const double *ww, double dt, cf_step_energy *e);
    /* 1: the batch integrator (solver_batch_lanes.h, which writes the points law in lanes over
     * the points' state, cf_points of solver_points_internal.h) runs this model's runs side by
     * side; 0: one after the other */
    int batch_lanes;
    /* optional (NULL: no state that carries over): the doubles of its state that a run continued
     * from a cf_solver_state needs (solver_state.c), and their copy out of (to_buf 1) or into
     * (to_buf 0) the model's state, each value exact (an int as a double) */
    long (*state_doubles)(const struct cf_solver *s, const void *state);
    void (*state_copy)(const struct cf_solver *s, void *state, double *buf, int to_buf);
} cf_solver_contact_model;

/* the registry (solver_contact_model.c): cf_solver_contact_model_table[def.contact] */
extern const cf_solver_contact_model *const cf_solver_contact_model_table[];

/* solver_options.c: the option tables read (cf_solver_def_default and cf_solver_check_def of
 * solver.c; the check's message into msg), and the values of contact model m's options in d, in
 * the order of its table (n_options of them). */
void cf_solver_options_default(cf_solver_def *d);
int cf_solver_options_check(const cf_solver_def *d, char *msg);
void cf_solver_options_of_model(const cf_solver_def *d, int m, double *out);

/* The connectors of a solver (solver_connectors.c): their definitions, their ends in the lower and
 * the upper body's frames, the upper end relative to the lower one at rest (lower face frame), and
 * per run their law's state, peaks (|F| shear, |u| shear, axial force), break times and dissipation. */
typedef struct cf_connectors {
    int n;
    cf_solver_connector *d;
    double *al, *au, *rest;         /* 3 per connector, m */
    cf_connector_state *st;
    double *peak, *t_break, *diss;  /* 3, 1, 1 per connector */
    long steps;                     /* steps of this run so far */
} cf_connectors;

/* The parts of a scene the monitor reports on (solver_scene.c): per column its blocks, joints and
 * base diameter, per beam its bearings. NULL in a solver set up for a single column. */
typedef struct {
    int ncol, nbeam;
    int *col_blk0, *col_nblk;       /* per column: first block, blocks */
    int *col_j0, *col_nj;           /* per column: first joint, joints */
    double *col_base_diam;          /* per column, m */
    int *beam_j0, *beam_nj;         /* per beam: first bearing joint, bearings */
    double *beam_seat;              /* per beam: half its shortest seat (bearings on one column) along x or y, m */
    cf_face *col_top;               /* per column: its top block's top face (its body frame) */
    int nbear, *bear_col;           /* per bearing: the column carrying it */
    double *bear_gc;                /* per bearing: the centre of its beam's seat on that column, in the beam's frame (3) */
} cf_scene_info;

struct cf_solver {
    char msg[CF_MSG_LEN];
    int ready;
    cf_solver_check_fn check;       /* the caller's check (cf_solver_set_check), NULL: none */
    void *check_user;
    cf_solver_def def;
    /* the foundation's frame (def.foundation_tilt_*; set-up): tilted = tilt != 0; gravity's
     * components there (pull along x and y, normal magnitude: def.g untilted); ground_rt the
     * world-to-foundation rotation of the record (read when tilted) */
    int tilted;
    double g_x, g_y, g_normal, ground_rt[9];
    int asb;                        /* the column is placed as built (cf_solver_setup_as_built) */
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
    void *contact;                  /* the contact model's own state (its create / free) */
    double dt_crit, dt;
    /* scratch of the time loop (nbody): world omegas, velocities of the last half step */
    double *ww, *vold, *wold;
    /* history (caller-owned buffers) */
    long h_cap;
    double *h_t, *h_top, *h_pos, *h_quat, *h_open, *h_slip, *h_en, *h_fn;
    double *jfn;                    /* normal force of each joint this step, N */
    /* connectors and scenes (NULL: none) */
    cf_connectors *conn;
    cf_scene_info *scene;
    double *out_col, *out_beam, *out_conn;          /* caller-owned per-run outputs (cf_solver_set_outputs) */
    double *h_conn_en, *h_conn;                     /* caller-owned connector histories */
    /* the state that carries over (solver_state.c): kept at the end of every run when keep_state,
     * and the state the next run continues from (NULL: from rest), both owned */
    int keep_state;
    long state_len;
    double *state_final, *state_resume;
};

/* Fail with a message on the solver s (its msg buffer) and return status: cf_common_fail, the
 * library's one failure writer at the bottom of the layering, so that every solver file reports
 * a failure without calling up into solver.c. */
#define cf_solver_fail(s, status, ...) cf_common_fail((s)->msg, (status), __VA_ARGS__)

/* solver_stack.c */
int cf_solver_stack_build(struct cf_solver *s, int nblk, const int *nseg, const cf_geometry_segment *segs,
                          const double *kn, const double *ks, const double *mu, const double *place);

/* solver_as_built.c: joint J's contact region as the overlap of its faces, the upper face's centre at
 * (dx, dy) from the lower one's (lower face frame, at rest); CF_EINVAL naming the joint when they do
 * not overlap */
int cf_solver_as_built_joint(struct cf_solver *s, cf_joint *J, double dx, double dy);
/* joint J's contact region as the annulus of its upper face between circumradii inner and outer (its faces
 * aligned; outer within the lower face), less the sector of the angles [s0, s1) (rad from +x, counter-clockwise;
 * s0 = s1 = 0: none): CF_EINVAL naming the joint otherwise (a sector empty or the whole face) */
int cf_solver_as_built_chipped(struct cf_solver *s, cf_joint *J, double inner, double outer, double s0, double s1);
/* a chipped joint missing a sector: how far its region reaches along +x from the face centre, m */
double cf_solver_as_built_reach(const cf_joint *J);
/* the initial tilt of the definition applied to the built (untilted) column: a rigid rotation of
 * every moving body about the +x base edge (after the connectors have taken the untilted rest) */
void cf_solver_stack_tilt(struct cf_solver *s);
int cf_solver_stack_alloc(struct cf_solver *s, int nblk, int nbody, int nj);
void cf_solver_stack_face(cf_face *f, int n, double r, double phase, double cz, double asp);

/* solver_scene.c: the bodies and joints of a scene of several columns or with beams (its checks
 * included; the columns' blocks and joints are checked by the caller), and its monitor's map */
int cf_solver_scene_build(struct cf_solver *s, const cf_solver_scene *sc);
void cf_solver_scene_free(cf_scene_info *info);
void cf_solver_stack_release(struct cf_solver *s);
void cf_solver_stack_reset(struct cf_solver *s);

/* solver_face_points.c: the sub-contact points of every joint's faces, for the contact models that
 * carry points. The upper face's points are tested against the lower face (side 0), the lower
 * face's against the upper face (side 1), each set carrying half of the joint area (the ground's
 * joint: the upper face's alone, all of it); m per edge (0: the polygon vertices). In planar mode
 * with faces symmetric about the x-z plane one of each mirrored pair is kept with twice its
 * weight; a face none of whose points lies on the other face at rest is dropped (its half of the
 * area to the other face's points). */
typedef struct {
    int np;                         /* points in all */
    int *side;                      /* np: 0 on the upper face, 1 on the lower face */
    double *loc, *w;                /* np: body-frame position (3 each), m; area share, m^2 */
    int *p0, *n, *n0;               /* per joint: its points [p0, p0 + n), the first n0 on the upper face */
} cf_face_points;
int cf_solver_face_points_make(struct cf_solver *s, int mm, cf_face_points *fp);
void cf_solver_face_points_free(cf_face_points *fp);

/* solver_connectors.c */
int cf_solver_connectors_create(struct cf_solver *s, int n, const cf_solver_connector *defs, cf_connectors **out);
void cf_solver_connectors_reset(cf_connectors *c);
void cf_solver_connectors_free(cf_connectors *c);
cf_connectors *cf_solver_connectors_clone(const cf_connectors *c);
void cf_solver_connectors_springs(const struct cf_solver *s, const cf_connectors *c, int i, cf_springs *K);
void cf_solver_connectors_step(struct cf_solver *s, cf_connectors *c, cf_step_energy *e);
int cf_solver_connectors_law_step(cf_connectors *c, int i, const double *u, double t, cf_step_energy *e);
void cf_solver_connectors_report(const cf_connectors *c, double *out);
void cf_solver_connectors_sample(const cf_connectors *c, double *out);

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
    if (X * X + Y * Y <= f->apoc * f->apoc) return 1;
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
    int conn;                          /* the solver has connectors: their energies enter the ledger */
    double vc0, Dconn;                 /* connectors' stored energy at step 0, their dissipation so far */
    /* a scene's (NULL for a single column): per column its top-face centre at rest (3 each) and its
     * largest top displacement (m), per beam its largest slip at a bearing (m); the ring then holds
     * every joint's dislocation */
    double *col_top0, *col_max, *beam_slip;
    long h0;                           /* history samples of the runs before (a continued run): written at hcount - h0 */
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
/* a scene's per-column and per-beam outputs (s->out_col, s->out_beam), collapse_block the block
 * whose joint fired a collapse criterion (-1: none) */
void cf_solver_monitor_scene_report(const struct cf_solver *s, const cf_monitor *m, int collapsed, int collapse_block);

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
    long i0;                           /* the record's first sample is sample i0 of the time axis (a continued run; 0) */
    long n_first;                      /* the first step of this run (0; a continued run: its state's step + 1) */
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

/* solver_state.c: the state that carries over. resume: a continued run's state into the solver,
 * the monitor and the run (after cf_solver_run_begin on the rest state; r's record set by
 * cf_solver_run_check), CF_EINVAL when its record does not fit; capture: the state at the end of the
 * run into s->state_final (before cf_solver_run_finish); release: both buffers freed. */
int cf_solver_state_resume(struct cf_solver *s, cf_run *r);
int cf_solver_state_capture(struct cf_solver *s, const cf_run *r);
void cf_solver_state_release(struct cf_solver *s);
/* history samples of a continued run's record of n samples at dtr (cf_solver_history_capacity) */
long cf_solver_state_history_capacity(const struct cf_solver *s, int n, double dtr);

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
