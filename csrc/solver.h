/*
 * solver.h -- 3D rigid-drum soft-contact solver (docs/solver.md).
 *
 * A column of rigid blocks (each a stack of cf_geometry_segment) stands on a base
 * block that moves with a prescribed ground acceleration. The column is
 * integrated in the frame that translates with the ground (inertial force
 * -m a_g on every block), by a leapfrog (central-difference) scheme with unit
 * quaternions and Euler's equations in body axes. Joints carry sub-contacts
 * (polygon vertices or a refined face mesh) or the exact-interface integral.
 *
 * Use: cf_solver_create -> cf_solver_setup(def, geometry, joints) ->
 * [cf_solver_set_history] -> cf_solver_run(record) -> read cf_solver_result;
 * cf_solver_free. Every fallible call returns a cf_status and leaves a message
 * (cf_solver_message). No global state; never prints, exits or aborts.
 */
#ifndef CF_SOLVER_H
#define CF_SOLVER_H

#include "geometry.h"

/* cffi:begin */
/* The contact models (the `contact` field): indices into the registry of
 * solver_contact_model.c, whose names and documentation these functions give (NULL for
 * an index out of range); the C callers' names of the first three. */
int cf_solver_contact_model_count(void);
const char *cf_solver_contact_model_name(int i);
const char *cf_solver_contact_model_doc(int i);
#define CF_SOLVER_CONTACT_VERTEX 0
#define CF_SOLVER_CONTACT_PERIMETER 1
#define CF_SOLVER_CONTACT_EXACT 2

#define CF_SOLVER_COLLAPSE_NONE 0
#define CF_SOLVER_COLLAPSE_OVERTURNING 1
#define CF_SOLVER_COLLAPSE_OFF_FOOTPRINT 2
#define CF_SOLVER_COLLAPSE_FALLING 3

#define CF_SOLVER_MAX_SIDES 64
#define CF_SOLVER_MAX_STEPS 1000000000      /* a run needing more steps is refused before it starts */
#define CF_SOLVER_MAX_HISTORY 100000000     /* history samples at most */
#define CF_SOLVER_N_ENERGY 8

/* The options of the solver, declared as data: one table of the solver's own options
 * (solver_options.c) and one per contact model (its registry entry), read by the defaults, the
 * range checks and their messages, Python's SolverOptions and the docs. An option's kind: */
#define CF_SOLVER_OPTION_REAL 0      /* a real number in the range */
#define CF_SOLVER_OPTION_INT 1       /* an integer in the range */
#define CF_SOLVER_OPTION_FLAG 2      /* 0 or 1 */
#define CF_SOLVER_OPTION_STEP 3      /* a real number in the range, 0 meaning "automatic" */
#define CF_SOLVER_OPTION_MODEL 4     /* the index of a contact model of the registry */

typedef struct {
    const char *name;     /* a field of cf_solver_def, or a contact model's option (cf_solver_options_set) */
    int kind;             /* CF_SOLVER_OPTION_* */
    double lo, hi;        /* the accepted range (+-INFINITY: unbounded; not read for FLAG and MODEL) */
    int lo_open, hi_open; /* 1: the bound itself is refused (an infinite bound that is open: finite values only) */
    double value;         /* the default */
    const char *unit;     /* "s", "1/s", "m/s^2", "rad"; "-" for a number without unit */
    const char *doc;      /* what it does, one or two sentences */
} cf_solver_option;

/* The contact models' options travel in the definition by name (cf_solver_options_set), at
 * most this many different ones over the whole registry. */
#define CF_SOLVER_MAX_MODEL_OPTIONS 16

/* The definition of a run: the solver's own options as fields, the contact models' options in
 * model_options. Every option's unit, range, default and meaning are declared once, in the
 * option tables (cf_solver_options_get); cf_solver_def_default fills them in. */
typedef struct {
    int contact;               /* the contact model, an index of the registry */
    double dt;                 /* s */
    double dt_factor;          /* - */
    double tail_s;             /* s */
    double residual_window_s;  /* s */
    int planar;                /* flag */
    int monolithic;            /* flag */
    int early_exit;            /* flag */
    double damping_alpha;      /* 1/s */
    double damping_start_s;    /* s */
    double history_dt;         /* s */
    double g;                  /* m/s^2 (its default: CF_G_M_S2, from pycolfrag/data/constants.json) */
    double energy_tolerance;   /* - */
    double unstable_tolerance; /* - */
    double initial_tilt_rad;   /* rad */
    double model_options[CF_SOLVER_MAX_MODEL_OPTIONS];   /* the contact models' options, by name */
    /* The foundation's tilt (the column's, not an option of the tables; cf_solver_def_default sets 0):
     * the ground surface descends by foundation_tilt_rad (in [0, pi/2)) towards the horizontal
     * direction at foundation_tilt_azimuth_rad from +x towards +y. The solver's frame is the
     * foundation's: gravity rotated into it, the ground record (world axes) rotated into it
     * (docs/sequences.md). Exactly 0: the untilted solver, bit for bit. Not in a scene. */
    double foundation_tilt_rad;
    double foundation_tilt_azimuth_rad;
} cf_solver_def;

/* Every option (the solver's own, then each contact model's in the registry's order, an option
 * that two models declare counted once): how many, the i-th (NULL outside). */
int cf_solver_options_count(void);
const cf_solver_option *cf_solver_options_get(int i);
/* The options contact model m declares (its registry entry), k of them in its order. */
int cf_solver_contact_model_n_options(int m);
const cf_solver_option *cf_solver_contact_model_option(int m, int k);
/* Set or read an option of a definition by name: CF_EINVAL for an unknown name, or for a value
 * that an integer kind cannot hold. Ranges are cf_solver_check_def's. */
int cf_solver_options_set(cf_solver_def *d, const char *name, double value);
int cf_solver_options_value(const cf_solver_def *d, const char *name, double *value);

typedef struct {
    double u_top;             /* max horizontal top displacement / base diameter */
    double u_d;               /* max over joints of residual dislocation / joint diameter; NaN after a collapse */
    int collapsed;            /* 1 when a collapse criterion fired */
    int collapse_block;       /* 0-based block, -1 if none */
    int collapse_reason;      /* CF_SOLVER_COLLAPSE_* */
    double collapse_time;     /* s, NaN if none */
    long n_steps;             /* steps taken */
    double t_end;             /* time of the last computed state, s */
    double dt;                /* step used, s */
    double dt_crit;           /* whole-stack stability limit, s */
    double energy_error;      /* max |balance error| / energy_scale */
    double energy_scale;      /* J: max over time of KE + |dVg| + |dVs| + D + |W| (floored) */
    int energy_warning;       /* 1 when energy_error > energy_tolerance */
    int at_rest_exit;         /* 1 when the run stopped early at rest */
    int n_history;            /* history samples written */
    double max_top_disp;      /* m, max horizontal top displacement */
} cf_solver_result;

typedef struct cf_solver cf_solver;

void cf_solver_def_default(cf_solver_def *def);
/* Check a definition without setting anything up: CF_OK, or CF_EINVAL with a message
 * on s naming the bad field and value (cf_solver_setup runs the same check). */
int cf_solver_check_def(cf_solver *s, const cf_solver_def *def);
cf_solver *cf_solver_create(void);
void cf_solver_free(cf_solver *s);
const char *cf_solver_message(const cf_solver *s);

/* Geometry: n_blocks blocks, block i made of n_segments[i] consecutive entries of
 * segments (bottom up). density kg/m^3, kn and ks Pa/m, mu = tan(friction angle). */
int cf_solver_setup(cf_solver *s, const cf_solver_def *def, int n_blocks, const int *n_segments,
                    const cf_geometry_segment *segments, double density, double kn, double ks, double mu);

/* The same with properties per joint: kn[j], ks[j] (Pa/m) and mu[j] of joint j, the joint
 * under block j (n_blocks entries each; a monolithic column uses joint 0's). */
int cf_solver_setup_joints(cf_solver *s, const cf_solver_def *def, int n_blocks, const int *n_segments,
                           const cf_geometry_segment *segments, double density, const double *kn,
                           const double *ks, const double *mu);

/* The same with the column as built (docs/sequences.md, "As-built geometry"): placement
 * (n_blocks x CF_SOLVER_AS_BUILT) holds per block i: the horizontal offset dx, dy of its axis from
 * the column's (m) and its rotation about its axis (rad, counter-clockwise seen from above), at rest;
 * then its bottom face chipped to an annulus: the inner and outer circumradii (m) of the concentric
 * polygons (of the face's sides and phase) it bears between (0, 0: the whole face; outer 0: the face's
 * own). A joint whose two faces are offset or turned against each other carries their overlap at rest,
 * a chipped one its annulus (every contact model). Refused (CF_EINVAL, the joint or block named): faces
 * that do not overlap, an annulus with no area (inner >= outer) or wider than its face or than the face
 * below it, a chipped face on a joint that is offset or turned, a non-finite or negative value, a
 * monolithic definition. Then, for a block missing a part, its mass properties (mass 0: those of its
 * segments): mass (kg), centre of mass (x, y from its axis in the column's axes, z above its bottom
 * face, m) and principal moments of inertia about it along x, y, z (kg m^2, > 0; the body's axes stay
 * the column's). Then its bottom face's missing sector: the angles start and end (rad, from +x counter-clockwise
 * seen from above, in the column's axes; 0, 0: none) of the wedge [start, end) about the face's centre it
 * bears nowhere on (with an annulus, the annulus less the wedge; every contact model); refused (CF_EINVAL):
 * a sector empty or the whole face (end - start a multiple of 2 pi), one on an offset or turned joint.
 * NULL, or every value 0: cf_solver_setup_joints bit for bit. */
#define CF_SOLVER_AS_BUILT 14
int cf_solver_setup_as_built(cf_solver *s, const cf_solver_def *def, int n_blocks, const int *n_segments,
                             const cf_geometry_segment *segments, double density, const double *kn,
                             const double *ks, const double *mu, const double *placement);

/* Whole-stack stability limit of the set-up column, s (after setup). */
double cf_solver_dt_crit(const cf_solver *s);
/* Step the run will use, s (after setup). */
double cf_solver_dt(const cf_solver *s);
/* History samples needed for a record of n samples at dt_rec (after setup); -1 when
 * that is more than CF_SOLVER_MAX_HISTORY (history_dt too small for the record). */
long cf_solver_history_capacity(const cf_solver *s, int n, double dt_rec);

/* Caller-owned history buffers (any may be NULL), capacity samples each:
 * t (cap), top_disp (cap x 2), block_pos (cap x nb x 3), block_quat (cap x nb x 4),
 * joint_opening (cap x nj), joint_slip (cap x nj x 2), energy (cap x CF_SOLVER_N_ENERGY:
 * kinetic, gravity, spring, slip_dissipated, damping_dissipated, ground_work,
 * balance_error, contact_switch -- J, see docs/solver.md). */
int cf_solver_set_history(cf_solver *s, long capacity, double *t, double *top_disp, double *block_pos,
                          double *block_quat, double *joint_opening, double *joint_slip, double *energy);

/* Optional extra history buffer (capacity x n_blocks): the normal force carried by
 * each joint, N (NaN for the internal joints of a monolithic column). Call after
 * cf_solver_set_history, which sets the capacity. */
int cf_solver_set_history_normal(cf_solver *s, double *joint_normal);

/* Optional check of the caller, called by cf_solver_run every CF_SOLVER_CHECK_STEPS steps
 * with `user`; a nonzero return stops the run with CF_EINTR (the results are then not
 * valid). NULL (the default) for none. It does not change any computed number. Python
 * uses it to stop a run promptly on Ctrl-C. Set it after cf_solver_setup (which clears it). */
#define CF_SOLVER_CHECK_STEPS 4096
typedef int (*cf_solver_check_fn)(void *user);
int cf_solver_set_check(cf_solver *s, cf_solver_check_fn fn, void *user);

/* ---- connectors and scenes (docs/solver.md, "Connectors" and "Scenes") ---- */

/* A connector (a dowel) across a joint: its place and its law. The laws' common text (the break,
 * the axial part, the energy) is connector_law.h; each kind of shear law is its own file, listed in
 * the registry of connector laws (solver_connector_law.c), whose order is that of these indices: */
#define CF_SOLVER_CONNECTOR_ELASTOPLASTIC 0   /* a metal dowel: elastic-perfectly plastic, breaks at u_ultimate */
#define CF_SOLVER_CONNECTOR_CLEARANCE 1       /* a wooden empolion / polos: clearance, then linear; the seat
                                               * crushes at f_yield; breaks at u_ultimate */
#define CF_SOLVER_CONNECTOR_LAW_VALUES 4      /* a law's own values, at most */
typedef struct {
    int joint;            /* the joint it crosses (a scene's numbering: every column's joints, then the bearings) */
    double x, y;          /* its place in the joint plane from the joint's face centre, along the lower face's x and y, m */
    int kind;             /* its law: an index into the registry (cf_solver_connector_law_name) */
    double k_shear;       /* shear stiffness (once engaged), N/m, >= 0 */
    double f_yield;       /* shear force at yield (elastoplastic) or at which the seat crushes (clearance), N, > 0; INFINITY: never */
    double u_ultimate;    /* shear displacement |u| at which it breaks, m, > 0; INFINITY: never */
    double k_axial;       /* stiffness against the joint's opening at the connector (tension only), N/m, >= 0; 0: none */
    double n_yield;       /* axial force at which it slips out, N, > 0; INFINITY: never */
    double d_ultimate;    /* opening at which it pulls out (breaks), m, > 0; INFINITY: never */
    double law[CF_SOLVER_CONNECTOR_LAW_VALUES];   /* the law's own values, in the order of its table
                                                   * (cf_solver_connector_law_value; the clearance law's:
                                                   * its initial clearance, m); 0 beyond them */
} cf_solver_connector;

/* The registry of connector laws, read by Python (pycolfrag/structure/connector_laws.py) and the docs: how many,
 * each one's name and one-sentence doc, and its own values (name, range, default, unit, doc; the
 * range is checked by the law's own check, with its message). NULL / 0 out of range. */
int cf_solver_connector_law_count(void);
const char *cf_solver_connector_law_name(int i);
const char *cf_solver_connector_law_doc(int i);
int cf_solver_connector_law_n_values(int i);
const cf_solver_option *cf_solver_connector_law_value(int i, int k);
/* The shear displacement |u| at which a connector's law yields (or its seat starts to crush), m, from
 * the rest state; INFINITY without shear stiffness. NAN for a law out of the registry. */
double cf_solver_connector_law_u_yield(const cf_solver_connector *c);

/* Check one connector's law (not its place): CF_OK, or CF_EINVAL with the message in msg
 * (CF_MSG_LEN bytes) naming the bad value. */
int cf_solver_connectors_check(const cf_solver_connector *c, char *msg);
/* The law driven through a prescribed history of n displacements u (n x 3: shear x, y and the
 * opening, m; from the rest state): the force on the upper block (n x 3, N), the stored energy
 * (n, J), the energy dissipated so far (n, J) and the state (n: 0 elastic, 1 yielded, 2 broken)
 * after each. CF_EINVAL for a bad law (message in msg). */
int cf_solver_connectors_drive(const cf_solver_connector *c, int n, const double *u, double *force, double *stored,
                               double *dissipated, int *state, char *msg);

/* A scene: columns on one ground and beams (epistyles) resting on their top blocks through
 * bearings (square contact patches with the soft Coulomb law of the joints), and connectors.
 * Bodies: the ground, every column's blocks bottom up column by column, then the beams. Joints:
 * every column's (joint j of a column under its block j), column by column, then one per bearing.
 * Blocks (the EDPs' and collapse_block's numbering): every column's, then the beams. */
typedef struct {
    double x, y;          /* its axis on the ground, m */
    int n_blocks;         /* its blocks: the next n_blocks entries of n_segments (and of kn, ks, mu) */
} cf_solver_scene_column;

typedef struct {
    double x, y;          /* the centre of its underside (horizontal), m */
    double length, width, height;   /* along x, y, z, m: a rectangular block */
    double density;       /* kg/m^3 */
} cf_solver_scene_beam;

typedef struct {
    int beam, column;     /* the beam it carries and the column whose top block carries it */
    double x, y;          /* the centre of its square patch (horizontal), m */
    double side;          /* the square's side, m (sides along x and y) */
    double kn, ks, mu;    /* its joint law: Pa/m, Pa/m, - */
} cf_solver_scene_bearing;

typedef struct {
    int n_columns;
    const cf_solver_scene_column *columns;
    const int *n_segments;                  /* per block of every column */
    const cf_geometry_segment *segments;    /* every column's blocks' segments in order */
    double density;                         /* the columns', kg/m^3 */
    const double *kn, *ks, *mu;             /* per column joint, in the joints' order */
    int n_beams;
    const cf_solver_scene_beam *beams;
    int n_bearings;
    const cf_solver_scene_bearing *bearings;
    int n_connectors;
    const cf_solver_connector *connectors;
} cf_solver_scene;

/* Set up a scene (as cf_solver_setup_joints sets up one column, whose results a one-column scene
 * without connectors gives bit for bit). A scene of several columns or with beams takes neither
 * monolithic nor initial_tilt_rad. */
int cf_solver_setup_scene(cf_solver *s, const cf_solver_def *def, const cf_solver_scene *scene);

/* What a run reports per column, per beam and per connector of a scene (caller-owned, any may be
 * NULL, written when a run finishes; set after set-up, which clears them):
 *   columns    (n_columns x CF_SOLVER_COLUMN_OUT): u_top (its top displacement / its base diameter),
 *              u_d (its joints' residual dislocation / diameter, max; NaN after a collapse), peak top
 *              displacement (m), 1 when the scene's collapse was at this column's joints
 *   beams      (n_beams x CF_SOLVER_BEAM_OUT): peak horizontal slip at its bearings (m), residual slip
 *              (m, averaged over residual_window_s; NaN after a collapse), peak slip / its shortest
 *              bearing length along the slip (the unseating ratio), 1 when the collapse was at its bearings
 *   connectors (n_connectors x CF_SOLVER_CONNECTOR_OUT): peak shear force (N), peak shear
 *              displacement |u| (m), peak axial force (N), yielded (0/1), broken (0/1), time of the
 *              break (s, NaN), energy it dissipated (J) */
#define CF_SOLVER_COLUMN_OUT 4
#define CF_SOLVER_BEAM_OUT 4
#define CF_SOLVER_CONNECTOR_OUT 7
int cf_solver_set_outputs(cf_solver *s, double *columns, double *beams, double *connectors);
/* How many columns, beams, connectors, bodies and joints the set-up solver has (any pointer may be NULL). */
int cf_solver_counts(const cf_solver *s, int *n_columns, int *n_beams, int *n_connectors, int *n_blocks, int *n_joints);

/* Optional history buffers of the connectors (call after cf_solver_set_history, which sets the
 * capacity; NULL: none): energy (capacity x 2: stored since the start, dissipated so far, J) and
 * per connector (capacity x n_connectors x 3: shear displacement |u| (m), shear force |F| (N),
 * axial force (N)). The ledger's balance_error includes both energies. */
int cf_solver_set_history_connectors(cf_solver *s, double *energy, double *connectors);

/* Run one record: acc_x (n samples, m/s^2) at dt_rec; acc_y, acc_z may be NULL.
 * residual_dislocation (n_blocks entries, m) may be NULL; after a collapse it and
 * result.u_d are NaN. A run that would need more than CF_SOLVER_MAX_STEPS steps is
 * refused (CF_EINVAL) before it starts. */
int cf_solver_run(cf_solver *s, const double *acc_x, const double *acc_y, const double *acc_z, int n,
                  double dt_rec, double *residual_dislocation, cf_solver_result *res);

/* ---- the state that carries over (docs/sequences.md) ---- */
/* A state is a flat array of doubles (every value exact): the step and the bodies' positions,
 * rotations and velocities, the contact model's joint state, the connectors' law state, and the
 * monitor's running values (energy ledger, peaks, residual window, history count, collapse). Its
 * length for the set-up solver (0 before set-up): */
long cf_solver_state_size(const cf_solver *s);
/* keep 1: every later run keeps its final state (cf_solver_state_get); 0: none kept (the default). */
int cf_solver_state_keep(cf_solver *s, int keep);
/* The state kept at the end of the last run into out (n doubles, n = cf_solver_state_size):
 * CF_ESTATE when none was kept, CF_EINVAL for a wrong n. */
int cf_solver_state_get(const cf_solver *s, double *out, long n);
/* The next run continues from this state (n doubles) instead of rest: its record starts at the first
 * sample of its time axis after the state's time (the ground still before it), its steps, times,
 * EDPs and history continue those of the state's runs. Used by that run only. CF_EINVAL (message
 * naming the difference) for a state of another shape, contact model or step. NULL: from rest. */
int cf_solver_state_set(cf_solver *s, const double *state, long n);
/* cffi:end */



#endif
