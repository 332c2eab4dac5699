/*
 * contact.h -- the joint contact laws of the solver, as small kernels that the C
 * unit tests call directly (exported cf_contact_*, not part of the Python API).
 *
 * Sub-contact (vertex / refined points, 3DEC-like; the law is contact_law.h):
 * normal force kn*w*pen (pen = overlap, no tension), incremental shear force
 * updated by -ks*w*du and capped by Coulomb mu*N. Exact interface: the normal pressure kn*pen(X,Y), pen
 * linear over the joint plane, integrated exactly over the compressed part of the
 * overlap polygon of the two faces.
 */
#ifndef CF_CONTACT_H
#define CF_CONTACT_H

#define CF_CONTACT_MAXV 256  /* largest clipped polygon handled (vertices) */

/* One sub-contact update: the law of contact_law.h (the one text the solver runs),
 * exported for the C unit tests. In the frame of the face the contact presses on
 * (normal +z): pen = overlap (m, > 0 in contact); du = tangential displacement
 * increment (x, y) of the pressing body over the step (m); w = area share (m^2);
 * kn, ks: Pa/m; mu = tan(phi). fs (in/out): the stored shear force (x, y) in that
 * frame (N): incremented by -ks w du, capped at mu fn. *fn gets the normal force
 * (N, >= 0), *slipping 1 when the cap was active. Returns the energy dissipated by
 * slip in this update (J): the trapezoidal work on the contact minus the change of
 * its elastic shear energy |fs|^2/(2 ks w). With pen <= 0 the shear is released
 * (fs = 0) and its stored energy is returned as dissipated. Kept in the face frame,
 * the shear force turns with the face exactly. */
double cf_contact_point(double pen, const double du[2], double w, double kn, double ks, double mu, double fs[2],
                        double *fn, int *slipping);

/* Area moments of a simple polygon (x,y pairs, counter-clockwise, n vertices):
 * m[0] = A, m[1] = int x, m[2] = int y, m[3] = int x^2, m[4] = int xy, m[5] = int y^2. */
void cf_contact_polygon_moments(const double *xy, int n, double m[6]);

/* Keep the part of the convex polygon (xy, n) where a + b x + c y >= 0 (Sutherland-
 * Hodgman). Writes at most n + 1 vertices to out (may not alias xy); returns the count. */
int cf_contact_clip_halfplane(const double *xy, int n, double a, double b, double c, double *out);

/* Intersection of two convex counter-clockwise polygons; returns the vertex count
 * (0 when disjoint); out needs na + nb vertices; work needs 2*(na + nb) vertices. */
int cf_contact_clip_convex(const double *a, int na, const double *b, int nb, double *out, double *work);

typedef struct {
    double force;     /* kn * int pen dA over the compressed overlap, N */
    double xc, yc;    /* centre of pressure, m (joint-plane coordinates) */
    double area;      /* compressed area, m^2 */
    double polar;     /* polar moment of the compressed area about its centroid, m^4 */
    double energy;    /* kn/2 * int pen^2 dA, J */
    double cx, cy;    /* centroid of the compressed area, m */
} cf_contact_exact_result;

/* Exact interface: lower face polygon (lo, nl) and the upper face projected on the
 * joint plane (up, nu), both CCW (pass lo == up for an unbounded lower face, e.g.
 * the ground); overlap pen(X,Y) = p0 + px X + py Y. Returns the
 * number of vertices of the compressed region (0: no contact, result zeroed). */
int cf_contact_exact(const double *lo, int nl, const double *up, int nu, double p0, double px, double py,
                     double kn, cf_contact_exact_result *res);

#endif
