/* geometry.c -- exact mass properties of polygonal frusta and stacks of them. */
#include <math.h>
#include "cf_math.h"
#include "cf_common.h"
#include "geometry.h"

double cf_geometry_polygon_area(int n, double r)
{
    return 0.5 * n * cf_math_sin(2.0 * CF_PI / n) * r * r;
}

/* int_0^h r(z)^p z^q dz with r = r0 + (r1 - r0) z / h, exactly (binomial expansion). */
static double poly_int(double r0, double r1, double h, int p, int q)
{
    double d = r1 - r0, sum = 0.0, binom = 1.0;
    int j;
    for (j = 0; j <= p; j++) {
        sum += binom * cf_math_pow(r0, p - j) * cf_math_pow(d, j) / (double)(j + q + 1);
        binom = binom * (p - j) / (j + 1);
    }
    return sum * cf_math_pow(h, q + 1);
}

double cf_geometry_segment_aspect(const cf_geometry_segment *s)
{
    return s->aspect == 0.0 ? 1.0 : s->aspect;
}

double cf_geometry_circumradius(const cf_geometry_segment *s, double r)
{
    double a = cf_geometry_segment_aspect(s), best = 0.0;
    int k;
    if (a == 1.0) return r;
    for (k = 0; k < s->n_sides; k++) {
        double ph = s->phase_rad + 2.0 * CF_PI * k / s->n_sides;
        double x = r * cf_math_cos(ph), y = a * r * cf_math_sin(ph);
        if (x * x + y * y > best) best = x * x + y * y;
    }
    return sqrt(best);
}

double cf_geometry_section_diameter(double r, double aspect)
{
    if (aspect == 0.0 || aspect >= 1.0) return 2.0 * r;   /* a = 1: 2 r, the regular polygon's */
    return 2.0 * r * aspect;
}

/* asinh(x) = ln(x + sqrt(x^2 + 1)), odd: taken for |x| (no cancellation for x < 0) */
static double asinh_odd(double x)
{
    double ax = x < 0.0 ? -x : x, v = cf_math_log(ax + sqrt(ax * ax + 1.0));
    return x < 0.0 ? -v : v;
}

double cf_geometry_section_mean_radius(int n, double r, double phase, double aspect)
{
    double a = aspect == 0.0 ? 1.0 : aspect, sum = 0.0, area = 0.0;
    int k;
    for (k = 0; k < n; k++) {
        double p0 = phase + 2.0 * CF_PI * k / n, p1 = phase + 2.0 * CF_PI * (k + 1) / n;
        double x0 = r * cf_math_cos(p0), y0 = a * r * cf_math_sin(p0);
        double x1 = r * cf_math_cos(p1), y1 = a * r * cf_math_sin(p1);
        double ex = x1 - x0, ey = y1 - y0, len = sqrt(ex * ex + ey * ey);
        double h = (x0 * y1 - x1 * y0) / len;           /* the edge's distance from the centre (CCW: > 0) */
        double t0 = (x0 * ex + y0 * ey) / len, t1 = (x1 * ex + y1 * ey) / len;
        double s0 = sqrt(t0 * t0 + h * h), s1 = sqrt(t1 * t1 + h * h);
        sum += h / 6.0 * (t1 * s1 - t0 * s0 + h * h * (asinh_odd(t1 / h) - asinh_odd(t0 / h)));
        area += 0.5 * h * len;
    }
    return sum / area;
}

static int seg_ok(const cf_geometry_segment *s)
{
    return s && isfinite(s->height) && s->height > 0 && isfinite(s->r_bottom) && s->r_bottom > 0
        && isfinite(s->r_top) && s->r_top > 0 && s->n_sides >= 3 && isfinite(s->phase_rad)
        && isfinite(s->aspect) && s->aspect >= 0.0;
}

int cf_geometry_segment_props(const cf_geometry_segment *s, double rho, cf_geometry_massprops *out)
{
    double k, c, v, zc, i4, i22, a;
    if (!seg_ok(s) || !out || !(rho > 0) || !isfinite(rho)) return CF_EINVAL;
    a = cf_geometry_segment_aspect(s);   /* a = 1: every product below by 1.0, exact */
    k = 0.5 * s->n_sides * cf_math_sin(2.0 * CF_PI / s->n_sides) * a;
    c = (2.0 + cf_math_cos(2.0 * CF_PI / s->n_sides)) / 12.0;
    v = k * poly_int(s->r_bottom, s->r_top, s->height, 2, 0);
    zc = k * poly_int(s->r_bottom, s->r_top, s->height, 2, 1) / v;
    i4 = poly_int(s->r_bottom, s->r_top, s->height, 4, 0);
    i22 = poly_int(s->r_bottom, s->r_top, s->height, 2, 2);
    out->volume = v;
    out->mass = rho * v;
    out->height = s->height;
    out->com_z = zc;
    /* k holds a: about y int x^2 dA = k c r^4, about x int y^2 dA = k c r^4 a^2 */
    out->izz = a == 1.0 ? rho * 2.0 * k * c * i4 : rho * k * c * i4 * (1.0 + a * a);
    out->ixx = rho * (k * c * i4 * (a * a) + k * i22) - out->mass * zc * zc;
    out->iyy = rho * (k * c * i4 + k * i22) - out->mass * zc * zc;
    return CF_OK;
}

int cf_geometry_block_props(const cf_geometry_segment *segs, int n, double rho, cf_geometry_massprops *out)
{
    cf_geometry_massprops p;
    double m = 0, mz = 0, z0 = 0, ixx = 0, iyy = 0, izz = 0, v = 0;
    int i, st;
    if (!segs || n < 1 || !out) return CF_EINVAL;
    for (i = 0; i < n; i++) {
        st = cf_geometry_segment_props(&segs[i], rho, &p);
        if (st) return st;
        m += p.mass; v += p.volume;
        mz += p.mass * (z0 + p.com_z);
        z0 += p.height;
    }
    out->mass = m; out->volume = v; out->height = z0;
    out->com_z = mz / m;
    z0 = 0;
    for (i = 0; i < n; i++) {
        double dz;
        cf_geometry_segment_props(&segs[i], rho, &p);
        dz = z0 + p.com_z - out->com_z;
        ixx += p.ixx + p.mass * dz * dz;
        iyy += p.iyy + p.mass * dz * dz;
        izz += p.izz;
        z0 += p.height;
    }
    out->ixx = ixx; out->iyy = iyy; out->izz = izz;
    return CF_OK;
}
