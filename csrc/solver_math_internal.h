/*
 * solver_math_internal.h -- small vector / quaternion helpers of the solver
 * (static inline, never in a cffi region). Quaternions are (w, x, y, z), unit,
 * mapping body to world coordinates; rotation matrices are row-major 3x3.
 */
#ifndef CF_SOLVER_MATH_INTERNAL_H
#define CF_SOLVER_MATH_INTERNAL_H
#include <math.h>

static inline double v3_dot(const double *a, const double *b) { return a[0]*b[0] + a[1]*b[1] + a[2]*b[2]; }

static inline void v3_cross(const double *a, const double *b, double *c)
{
    double x = a[1]*b[2] - a[2]*b[1], y = a[2]*b[0] - a[0]*b[2], z = a[0]*b[1] - a[1]*b[0];
    c[0] = x; c[1] = y; c[2] = z;
}

/* c = a (x) b (Hamilton product) */
static inline void quat_mul(const double *a, const double *b, double *c)
{
    double w = a[0]*b[0] - a[1]*b[1] - a[2]*b[2] - a[3]*b[3];
    double x = a[0]*b[1] + a[1]*b[0] + a[2]*b[3] - a[3]*b[2];
    double y = a[0]*b[2] - a[1]*b[3] + a[2]*b[0] + a[3]*b[1];
    double z = a[0]*b[3] + a[1]*b[2] - a[2]*b[1] + a[3]*b[0];
    c[0] = w; c[1] = x; c[2] = y; c[3] = z;
}

static inline void quat_normalize(double *q)
{
    double s = 1.0 / sqrt(q[0]*q[0] + q[1]*q[1] + q[2]*q[2] + q[3]*q[3]);
    q[0] *= s; q[1] *= s; q[2] *= s; q[3] *= s;
}

/* Row-major rotation matrix of a unit quaternion: world = R body. */
static inline void quat_to_mat(const double *q, double *R)
{
    double w = q[0], x = q[1], y = q[2], z = q[3];
    R[0] = 1 - 2*(y*y + z*z); R[1] = 2*(x*y - w*z);     R[2] = 2*(x*z + w*y);
    R[3] = 2*(x*y + w*z);     R[4] = 1 - 2*(x*x + z*z); R[5] = 2*(y*z - w*x);
    R[6] = 2*(x*z - w*y);     R[7] = 2*(y*z + w*x);     R[8] = 1 - 2*(x*x + y*y);
}

/* out = R v */
static inline void mat_vec(const double *R, const double *v, double *o)
{
    double a = R[0]*v[0] + R[1]*v[1] + R[2]*v[2];
    double b = R[3]*v[0] + R[4]*v[1] + R[5]*v[2];
    double c = R[6]*v[0] + R[7]*v[1] + R[8]*v[2];
    o[0] = a; o[1] = b; o[2] = c;
}

/* out = R^T v */
static inline void mat_tvec(const double *R, const double *v, double *o)
{
    double a = R[0]*v[0] + R[3]*v[1] + R[6]*v[2];
    double b = R[1]*v[0] + R[4]*v[1] + R[7]*v[2];
    double c = R[2]*v[0] + R[5]*v[1] + R[8]*v[2];
    o[0] = a; o[1] = b; o[2] = c;
}

/* Rotation quaternion for a body-frame angular velocity w held over dt:
 * exp(w dt / 2) with 4th-order Taylor series of cos and sin (no trigonometry in the
 * hot loop; the truncation error is below 1e-14 for |w| dt < 1e-2). */
static inline void quat_from_omega_dt(const double *w, double dt, double *dq)
{
    double h = 0.5 * dt;
    double s2 = (w[0]*w[0] + w[1]*w[1] + w[2]*w[2]) * h * h;
    double c = 1.0 - s2 * (0.5 - s2 * (1.0 / 24.0 - s2 / 720.0));
    double sc = h * (1.0 - s2 * (1.0 / 6.0 - s2 * (1.0 / 120.0 - s2 / 5040.0)));
    dq[0] = c; dq[1] = sc * w[0]; dq[2] = sc * w[1]; dq[3] = sc * w[2];
}

#endif
