/* Mass properties of polygonal frusta against textbook closed forms, and the
 * quaternion algebra of the solver (solver_math_internal.h). */
#include <math.h>
#include "cf_test.h"
#include "cf_common.h"
#include "geometry.h"
#include "solver_math_internal.h"

/* Square prism, side a, height h (circumradius a/sqrt2, phase pi/4):
 * m = rho a^2 h, ixx = m (a^2 + h^2) / 12, izz = m a^2 / 6 (any solid-mechanics table). */
static void test_square_prism(void)
{
    double a = 0.7, h = 1.9, rho = 2700.0, m = rho * a * a * h;
    cf_geometry_segment s = {h, a / sqrt(2.0), a / sqrt(2.0), CF_PI / 4, 4, 1.0};
    cf_geometry_massprops p;
    CF_CHECK(cf_geometry_segment_props(&s, rho, &p) == CF_OK);
    CF_CHECK_REL(p.mass, m, 1e-13);
    CF_CHECK_REL(p.com_z, h / 2, 1e-13);
    CF_CHECK_REL(p.ixx, m * (a * a + h * h) / 12.0, 1e-12);
    CF_CHECK_REL(p.izz, m * a * a / 6.0, 1e-12);
}

/* Square pyramid (frustum with a vanishing top), base side a, height h:
 * V = a^2 h / 3, centroid h/4 above the base, izz = m a^2 / 10,
 * ixx about the centroid = m (a^2 / 20 + 3 h^2 / 80). */
static void test_square_pyramid(void)
{
    double a = 1.2, h = 2.0, rho = 1000.0, m = rho * a * a * h / 3.0;
    cf_geometry_segment s = {h, a / sqrt(2.0), 1e-9, 0.3, 4, 1.0};
    cf_geometry_massprops p;
    CF_CHECK(cf_geometry_segment_props(&s, rho, &p) == CF_OK);
    CF_CHECK_REL(p.mass, m, 1e-8);
    CF_CHECK_REL(p.com_z, h / 4.0, 1e-8);
    CF_CHECK_REL(p.izz, m * a * a / 10.0, 1e-8);
    CF_CHECK_REL(p.ixx, m * (a * a / 20.0 + 3.0 * h * h / 80.0), 1e-8);
}

/* Regular n-gon frustum against the circular cone frustum scaled by the polygon
 * factors: V_poly = V_circ k_n / pi, izz_poly = izz_circ (2 k_n c_n) / (pi / 2), with
 * V_circ = pi h (r0^2 + r0 r1 + r1^2) / 3 and izz_circ = (3 m / 10)(r1^5 - r0^5)/(r1^3 - r0^3). */
static void test_frustum_vs_cone_frustum(void)
{
    double r0 = 0.825, r1 = 0.64, h = 0.78, rho = 2700.0;
    int n = 10;
    double kn = 0.5 * n * sin(2 * CF_PI / n), cn = (2.0 + cos(2 * CF_PI / n)) / 12.0;
    double vc = CF_PI * h * (r0 * r0 + r0 * r1 + r1 * r1) / 3.0, mc = rho * vc;
    double izzc = 0.3 * mc * (pow(r1, 5) - pow(r0, 5)) / (pow(r1, 3) - pow(r0, 3));
    /* centroid of a cone frustum: h (r0^2 + 2 r0 r1 + 3 r1^2) / (4 (r0^2 + r0 r1 + r1^2)) */
    double zc = h * (r0 * r0 + 2 * r0 * r1 + 3 * r1 * r1) / (4.0 * (r0 * r0 + r0 * r1 + r1 * r1));
    cf_geometry_segment s = {h, r0, r1, 0.0, n, 1.0};
    cf_geometry_massprops p;
    CF_CHECK(cf_geometry_segment_props(&s, rho, &p) == CF_OK);
    CF_CHECK_REL(p.volume, vc * kn / CF_PI, 1e-13);
    CF_CHECK_REL(p.com_z, zc, 1e-13);
    CF_CHECK_REL(p.izz, izzc * 2.0 * kn * cn / (CF_PI / 2.0), 1e-12);
}

/* A prism cut into two stacked segments is the same rigid body (parallel axes). */
static void test_block_composite(void)
{
    double r = 0.8, rho = 2500.0;
    cf_geometry_segment whole = {2.0, r, r, 0.1, 7, 1.0};
    cf_geometry_segment two[2] = {{0.6, r, r, 0.1, 7, 1.0}, {1.4, r, r, 0.1, 7, 1.0}};
    cf_geometry_massprops a, b;
    CF_CHECK(cf_geometry_block_props(&whole, 1, rho, &a) == CF_OK);
    CF_CHECK(cf_geometry_block_props(two, 2, rho, &b) == CF_OK);
    CF_CHECK_REL(b.mass, a.mass, 1e-14);
    CF_CHECK_REL(b.com_z, a.com_z, 1e-14);
    CF_CHECK_REL(b.ixx, a.ixx, 1e-13);
    CF_CHECK_REL(b.izz, a.izz, 1e-13);
    CF_CHECK_REL(b.height, 2.0, 1e-15);
}

/* Rectangular prism, width b (x), depth d (y), height h: the square of side b at phase pi/4 scaled by
 * a = d / b along y (geometry.h). m = rho b d h, ixx = m (d^2 + h^2) / 12, iyy = m (b^2 + h^2) / 12,
 * izz = m (b^2 + d^2) / 12 (any solid-mechanics table); and a = 1 gives iyy = ixx bit for bit. */
static void test_rectangular_prism(void)
{
    double b = 0.6, d = 2.9, h = 1.7, rho = 2400.0, m = rho * b * d * h;
    cf_geometry_segment s = {h, b / sqrt(2.0), b / sqrt(2.0), CF_PI / 4, 4, d / b};
    cf_geometry_segment two[2] = {{0.5, b / sqrt(2.0), b / sqrt(2.0), CF_PI / 4, 4, d / b},
                                  {1.2, b / sqrt(2.0), b / sqrt(2.0), CF_PI / 4, 4, d / b}};
    cf_geometry_massprops p, q;
    CF_CHECK(cf_geometry_segment_props(&s, rho, &p) == CF_OK);
    CF_CHECK_REL(p.mass, m, 1e-13);
    CF_CHECK_REL(p.com_z, h / 2, 1e-13);
    CF_CHECK_REL(p.ixx, m * (d * d + h * h) / 12.0, 1e-12);
    CF_CHECK_REL(p.iyy, m * (b * b + h * h) / 12.0, 1e-12);
    CF_CHECK_REL(p.izz, m * (b * b + d * d) / 12.0, 1e-12);
    CF_CHECK_REL(cf_geometry_circumradius(&s, s.r_bottom), 0.5 * sqrt(b * b + d * d), 1e-13);
    CF_CHECK(cf_geometry_block_props(two, 2, rho, &q) == CF_OK);   /* the same body in two segments */
    CF_CHECK_REL(q.ixx, p.ixx, 1e-13);
    CF_CHECK_REL(q.iyy, p.iyy, 1e-13);
    CF_CHECK_REL(q.izz, p.izz, 1e-13);
    s.aspect = 1.0;
    CF_CHECK(cf_geometry_segment_props(&s, rho, &p) == CF_OK);
    CF_CHECK(p.iyy == p.ixx);
    s.aspect = 0.0;   /* a zeroed struct: the regular polygon */
    CF_CHECK(cf_geometry_segment_props(&s, rho, &q) == CF_OK);
    CF_CHECK(q.ixx == p.ixx && q.izz == p.izz && q.mass == p.mass);
    CF_CHECK(cf_geometry_circumradius(&s, 0.7) == 0.7);
}

static void test_bad_geometry(void)
{
    cf_geometry_massprops p;
    cf_geometry_segment s = {-1.0, 1.0, 1.0, 0.0, 10, 1.0};
    CF_CHECK(cf_geometry_segment_props(&s, 2700, &p) == CF_EINVAL);
    s.height = 1.0; s.n_sides = 2;
    CF_CHECK(cf_geometry_segment_props(&s, 2700, &p) == CF_EINVAL);
    s.n_sides = 10;
    CF_CHECK(cf_geometry_segment_props(&s, 0.0, &p) == CF_EINVAL);
    s.aspect = -0.5;
    CF_CHECK(cf_geometry_segment_props(&s, 2700, &p) == CF_EINVAL);
    s.aspect = NAN;
    CF_CHECK(cf_geometry_segment_props(&s, 2700, &p) == CF_EINVAL);
    s.aspect = 1.0;
    CF_CHECK(cf_geometry_block_props(&s, 0, 2700, &p) == CF_EINVAL);
}

/* Quaternion algebra: the identity, composition = matrix product, orthonormality,
 * and the Taylor exponential against the exact axis-angle rotation. */
static void test_quaternions(void)
{
    double a[4] = {0.9, 0.1, -0.3, 0.2}, b[4] = {0.4, -0.5, 0.1, 0.7}, id[4] = {1, 0, 0, 0}, c[4];
    double Ra[9], Rb[9], Rc[9], RaRb[9], v[3] = {0.3, -1.2, 2.0}, t1[3], t2[3];
    int i, j, k;
    quat_normalize(a); quat_normalize(b);
    quat_mul(a, id, c);
    for (i = 0; i < 4; i++) CF_CHECK_CLOSE(c[i], a[i], 1e-16);
    quat_mul(a, b, c);
    quat_to_mat(a, Ra); quat_to_mat(b, Rb); quat_to_mat(c, Rc);
    for (i = 0; i < 3; i++)
        for (j = 0; j < 3; j++) {
            double sum = 0, dot = 0;
            for (k = 0; k < 3; k++) { sum += Ra[3 * i + k] * Rb[3 * k + j]; dot += Rc[3 * k + i] * Rc[3 * k + j]; }
            RaRb[3 * i + j] = sum;
            CF_CHECK_CLOSE(Rc[3 * i + j], RaRb[3 * i + j], 1e-15);
            CF_CHECK_CLOSE(dot, i == j ? 1.0 : 0.0, 4e-15);
        }
    mat_vec(Rc, v, t1); mat_tvec(Rc, t1, t2);
    for (i = 0; i < 3; i++) CF_CHECK_CLOSE(t2[i], v[i], 1e-14);
    {
        /* exp of w dt/2 vs (cos(|w|dt/2), sin(|w|dt/2) w/|w|) */
        double w[3] = {3.0, -2.0, 1.0}, dt = 1e-3, dq[4], th, nw;
        nw = sqrt(14.0); th = 0.5 * nw * dt;
        quat_from_omega_dt(w, dt, dq);
        CF_CHECK_CLOSE(dq[0], cos(th), 1e-16);
        for (i = 0; i < 3; i++) CF_CHECK_CLOSE(dq[i + 1], sin(th) * w[i] / nw, 1e-16);
        /* a rotation by pi/2 about z in 1000 steps maps x to y */
        {
            double q[4] = {1, 0, 0, 0}, wz[3] = {0, 0, CF_PI / 2}, R[9], ex[3] = {1, 0, 0}, out[3];
            for (i = 0; i < 1000; i++) { quat_from_omega_dt(wz, 1e-3, dq); quat_mul(q, dq, q); quat_normalize(q); }
            quat_to_mat(q, R); mat_vec(R, ex, out);
            CF_CHECK_CLOSE(out[0], 0.0, 1e-12); CF_CHECK_CLOSE(out[1], 1.0, 1e-12);
        }
    }
}

int main(void)
{
    CF_RUN(test_square_prism);
    CF_RUN(test_square_pyramid);
    CF_RUN(test_frustum_vs_cone_frustum);
    CF_RUN(test_block_composite);
    CF_RUN(test_rectangular_prism);
    CF_RUN(test_bad_geometry);
    CF_RUN(test_quaternions);
    return CF_TEST_SUMMARY("test_geometry");
}
