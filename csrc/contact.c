/* contact.c -- the sub-contact law's unit-test entry point (the law is contact_law.h) and the
 * exact-interface integration over clipped polygons. */
#include <math.h>
#include <string.h>
#include "contact.h"
#include "contact_law.h"

double cf_contact_point(double pen, const double du[2], double w, double kn, double ks, double mu, double fs[2],
                        double *fn, int *slipping)
{
    return cf_law_update(pen, du[0], du[1], kn * w, ks * w, mu, fs, fn, slipping);
}

void cf_contact_polygon_moments(const double *p, int n, double m[6])
{
    int i;
    double a = 0, sx = 0, sy = 0, sxx = 0, sxy = 0, syy = 0;
    for (i = 0; i < n; i++) {
        int j = (i + 1 == n) ? 0 : i + 1;
        double x0 = p[2 * i], y0 = p[2 * i + 1], x1 = p[2 * j], y1 = p[2 * j + 1];
        double cr = x0 * y1 - x1 * y0;
        a += cr;
        sx += (x0 + x1) * cr;
        sy += (y0 + y1) * cr;
        sxx += (x0 * x0 + x0 * x1 + x1 * x1) * cr;
        syy += (y0 * y0 + y0 * y1 + y1 * y1) * cr;
        sxy += (x0 * y1 + 2.0 * x0 * y0 + 2.0 * x1 * y1 + x1 * y0) * cr;
    }
    m[0] = a / 2.0; m[1] = sx / 6.0; m[2] = sy / 6.0;
    m[3] = sxx / 12.0; m[4] = sxy / 24.0; m[5] = syy / 12.0;
}

int cf_contact_clip_halfplane(const double *p, int n, double a, double b, double c, double *out)
{
    int i, k = 0;
    for (i = 0; i < n; i++) {
        int j = (i + 1 == n) ? 0 : i + 1;
        double x0 = p[2 * i], y0 = p[2 * i + 1], x1 = p[2 * j], y1 = p[2 * j + 1];
        double f0 = a + b * x0 + c * y0, f1 = a + b * x1 + c * y1;
        if (f0 >= 0.0) { out[2 * k] = x0; out[2 * k + 1] = y0; k++; }
        if ((f0 >= 0.0) != (f1 >= 0.0)) {
            double t = f0 / (f0 - f1);
            out[2 * k] = x0 + t * (x1 - x0); out[2 * k + 1] = y0 + t * (y1 - y0); k++;
        }
    }
    return k;
}

int cf_contact_clip_convex(const double *a, int na, const double *b, int nb, double *out, double *work)
{
    int i, n = na;
    const double *src = a;
    double *bufs[2];
    bufs[0] = work; bufs[1] = work + 2 * (na + nb);
    for (i = 0; i < nb && n > 0; i++) {
        int j = (i + 1 == nb) ? 0 : i + 1;
        double ex = b[2 * j] - b[2 * i], ey = b[2 * j + 1] - b[2 * i + 1];
        /* left of edge i->j: ex (y - yi) - ey (x - xi) >= 0 */
        double cst = -ex * b[2 * i + 1] + ey * b[2 * i];
        double *dst = bufs[i & 1];
        n = cf_contact_clip_halfplane(src, n, cst, -ey, ex, dst);
        src = dst;
    }
    if (n > 0) memcpy(out, src, sizeof(double) * 2 * (size_t)n);
    return n;
}

int cf_contact_exact(const double *lo, int nl, const double *up, int nu, double p0, double px, double py,
                     double kn, cf_contact_exact_result *r)
{
    double poly[2 * CF_CONTACT_MAXV], work[4 * CF_CONTACT_MAXV], comp[2 * CF_CONTACT_MAXV], m[6];
    int n;
    memset(r, 0, sizeof *r);
    if (nl + nu + 1 > CF_CONTACT_MAXV) return 0;
    /* lo == up means an unbounded lower face: the overlap is the upper face itself */
    if (lo == up) { memcpy(poly, up, sizeof(double) * 2 * (size_t)nu); n = nu; }
    else n = cf_contact_clip_convex(lo, nl, up, nu, poly, work);
    if (n < 3) return 0;
    {
        /* compressed everywhere: no clipping by the zero-overlap line */
        int i, all = 1;
        for (i = 0; i < n && all; i++) all = p0 + px * poly[2 * i] + py * poly[2 * i + 1] >= 0.0;
        if (all) memcpy(comp, poly, sizeof(double) * 2 * (size_t)n);
        else n = cf_contact_clip_halfplane(poly, n, p0, px, py, comp);
    }
    if (n < 3) return 0;
    cf_contact_polygon_moments(comp, n, m);
    if (!(m[0] > 0.0)) return 0;
    {
        double ip = p0 * m[0] + px * m[1] + py * m[2];
        double ipx = p0 * m[1] + px * m[3] + py * m[4];
        double ipy = p0 * m[2] + px * m[4] + py * m[5];
        double ip2 = p0 * p0 * m[0] + 2.0 * p0 * px * m[1] + 2.0 * p0 * py * m[2]
                   + px * px * m[3] + 2.0 * px * py * m[4] + py * py * m[5];
        if (!(ip > 0.0)) return 0;
        r->force = kn * ip;
        r->xc = ipx / ip; r->yc = ipy / ip;
        r->area = m[0];
        r->cx = m[1] / m[0]; r->cy = m[2] / m[0];
        r->polar = m[3] + m[5] - (m[1] * m[1] + m[2] * m[2]) / m[0];
        r->energy = 0.5 * kn * ip2;
    }
    return n;
}
