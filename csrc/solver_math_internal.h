/*
 * solver_math_internal.h -- small vector / quaternion helpers of the solver
 * (static inline, never in a cffi region). Quaternions are (w, x, y, z), unit,
 * mapping body to world coordinates; rotation matrices are row-major 3x3.
 *
 * Each helper is written once, as a macro over a lane type T that has + - * / (the
 * operand order of every expression is fixed by the text): the functions below
 * instantiate it for one run (T = double), the batch integrator (solver_batch.c) for
 * a vector of runs, one run per lane -- so every lane does the operations of the
 * single run, in its order, and gets its bits.
 */
#ifndef CF_SOLVER_MATH_INTERNAL_H
#define CF_SOLVER_MATH_INTERNAL_H
#include <math.h>

/* c = a x b (c may be a or b) */
#define CF_V3_CROSS(T, a, b, c)                                                               \
    do {                                                                                      \
        T cx_ = (a)[1]*(b)[2] - (a)[2]*(b)[1], cy_ = (a)[2]*(b)[0] - (a)[0]*(b)[2];           \
        T cz_ = (a)[0]*(b)[1] - (a)[1]*(b)[0];                                                \
        (c)[0] = cx_; (c)[1] = cy_; (c)[2] = cz_;                                             \
    } while (0)

/* c = a (x) b (Hamilton product; c may be a or b) */
#define CF_QUAT_MUL(T, a, b, c)                                                               \
    do {                                                                                      \
        T qw_ = (a)[0]*(b)[0] - (a)[1]*(b)[1] - (a)[2]*(b)[2] - (a)[3]*(b)[3];                \
        T qx_ = (a)[0]*(b)[1] + (a)[1]*(b)[0] + (a)[2]*(b)[3] - (a)[3]*(b)[2];                \
        T qy_ = (a)[0]*(b)[2] - (a)[1]*(b)[3] + (a)[2]*(b)[0] + (a)[3]*(b)[1];                \
        T qz_ = (a)[0]*(b)[3] + (a)[1]*(b)[2] - (a)[2]*(b)[1] + (a)[3]*(b)[0];                \
        (c)[0] = qw_; (c)[1] = qx_; (c)[2] = qy_; (c)[3] = qz_;                               \
    } while (0)

/* q /= |q|; SQRT the lane type's correctly rounded square root */
#define CF_QUAT_NORMALIZE(T, SQRT, q)                                                         \
    do {                                                                                      \
        T ns_ = 1.0 / SQRT((q)[0]*(q)[0] + (q)[1]*(q)[1] + (q)[2]*(q)[2] + (q)[3]*(q)[3]);    \
        (q)[0] = (q)[0] * ns_; (q)[1] = (q)[1] * ns_; (q)[2] = (q)[2] * ns_; (q)[3] = (q)[3] * ns_; \
    } while (0)

/* Row-major rotation matrix of a unit quaternion: world = R body. */
#define CF_QUAT_TO_MAT(T, q, R)                                                               \
    do {                                                                                      \
        T w_ = (q)[0], x_ = (q)[1], y_ = (q)[2], z_ = (q)[3];                                 \
        (R)[0] = 1 - 2*(y_*y_ + z_*z_); (R)[1] = 2*(x_*y_ - w_*z_); (R)[2] = 2*(x_*z_ + w_*y_); \
        (R)[3] = 2*(x_*y_ + w_*z_); (R)[4] = 1 - 2*(x_*x_ + z_*z_); (R)[5] = 2*(y_*z_ - w_*x_); \
        (R)[6] = 2*(x_*z_ - w_*y_); (R)[7] = 2*(y_*z_ + w_*x_); (R)[8] = 1 - 2*(x_*x_ + y_*y_); \
    } while (0)

/* o = A v with A's entry (r, c) at R[rs r + cs c] (o may be v): R v (rs 3, cs 1) or R^T v (rs 1, cs 3) */
#define CF_MAT_VEC_STRIDED(T, R, rs, cs, v, o)                                                \
    do {                                                                                      \
        T ma_ = (R)[0]*(v)[0] + (R)[cs]*(v)[1] + (R)[2*(cs)]*(v)[2];                          \
        T mb_ = (R)[rs]*(v)[0] + (R)[(rs)+(cs)]*(v)[1] + (R)[(rs)+2*(cs)]*(v)[2];             \
        T mc_ = (R)[2*(rs)]*(v)[0] + (R)[2*(rs)+(cs)]*(v)[1] + (R)[2*(rs)+2*(cs)]*(v)[2];     \
        (o)[0] = ma_; (o)[1] = mb_; (o)[2] = mc_;                                             \
    } while (0)
/* o = R v, o = R^T v (o may be v) */
#define CF_MAT_VEC(T, R, v, o) CF_MAT_VEC_STRIDED(T, R, 3, 1, v, o)
#define CF_MAT_TVEC(T, R, v, o) CF_MAT_VEC_STRIDED(T, R, 1, 3, v, o)

/* Rotation quaternion for a body-frame angular velocity w held over dt (a double):
 * exp(w dt / 2) with 4th-order Taylor series of cos and sin (no trigonometry in the
 * hot loop; the truncation error is below 1e-14 for |w| dt < 1e-2). */
#define CF_QUAT_FROM_OMEGA_DT(T, w, dt, dq)                                                   \
    do {                                                                                      \
        double h_ = 0.5 * (dt);                                                               \
        T s2_ = ((w)[0]*(w)[0] + (w)[1]*(w)[1] + (w)[2]*(w)[2]) * h_ * h_;                    \
        T c_ = 1.0 - s2_ * (0.5 - s2_ * (1.0 / 24.0 - s2_ / 720.0));                          \
        T sc_ = h_ * (1.0 - s2_ * (1.0 / 6.0 - s2_ * (1.0 / 120.0 - s2_ / 5040.0)));          \
        (dq)[0] = c_; (dq)[1] = sc_ * (w)[0]; (dq)[2] = sc_ * (w)[1]; (dq)[3] = sc_ * (w)[2]; \
    } while (0)

static inline double v3_dot(const double *a, const double *b) { return a[0]*b[0] + a[1]*b[1] + a[2]*b[2]; }
static inline void v3_cross(const double *a, const double *b, double *c) { CF_V3_CROSS(double, a, b, c); }
static inline void quat_mul(const double *a, const double *b, double *c) { CF_QUAT_MUL(double, a, b, c); }
static inline void quat_normalize(double *q) { CF_QUAT_NORMALIZE(double, sqrt, q); }
static inline void quat_to_mat(const double *q, double *R) { CF_QUAT_TO_MAT(double, q, R); }
static inline void mat_vec(const double *R, const double *v, double *o) { CF_MAT_VEC(double, R, v, o); }
static inline void mat_tvec(const double *R, const double *v, double *o) { CF_MAT_TVEC(double, R, v, o); }
static inline void quat_from_omega_dt(const double *w, double dt, double *dq) { CF_QUAT_FROM_OMEGA_DT(double, w, dt, dq); }

#endif
