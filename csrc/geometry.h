/*
 * geometry.h -- exact mass properties of regular n-gon frustum segments and of
 * blocks made of segments stacked vertically (shaft drums, the Doric capital).
 *
 * A segment is a frustum whose cross-section is a regular n-gon of circumradius
 * r(z) varying linearly from r_bottom to r_top over its height. For n >= 3 the
 * second moment of area of a regular polygon is isotropic in its plane, so the
 * inertia tensor about the centroid is diag(ixx, ixx, izz) in a frame whose z axis
 * is the segment's axis, whatever the phase of the polygon.
 * Closed forms (c_n = (2 + cos(2 pi / n)) / 12, k_n = (n/2) sin(2 pi / n)):
 *   area A(z) = k_n r^2, in-plane second moment per axis = k_n c_n r^4,
 *   V = k_n int r^2 dz,  izz = rho 2 k_n c_n int r^4 dz,
 *   ixx = rho int (k_n c_n r^4 + k_n r^2 (z - zc)^2) dz,
 * the integrals of polynomials in z evaluated exactly (binomial expansion).
 *
 * A segment's `aspect` a scales its section along its body's y axis (the polygon is built at its
 * phase, then y -> a y): a = 4-gon at phase pi/4 of circumradius b / sqrt 2 with a = d / b is the
 * rectangle b x d (a wall). 0 (a zeroed struct) reads as 1: the regular polygon. The scaled section's
 * second moments are k c r^4 a (about y, int x^2 dA) and k c r^4 a^3 (about x, int y^2 dA), its area
 * k r^2 a: the inertia is diag(ixx, iyy, izz), iyy = ixx for a = 1.
 */
#ifndef CF_GEOMETRY_H
#define CF_GEOMETRY_H

/* cffi:begin */
typedef struct {
    double height;     /* m, > 0 */
    double r_bottom;   /* circumradius of the bottom polygon, m, > 0 */
    double r_top;      /* circumradius of the top polygon, m, > 0 */
    double phase_rad;  /* angle of the first vertex from +x, rad */
    int n_sides;       /* polygon sides, >= 3 */
    double aspect;     /* the section's scale along y (> 0; 0 reads as 1, the regular polygon) */
} cf_geometry_segment;

typedef struct {
    double mass;       /* kg */
    double volume;     /* m^3 */
    double height;     /* m */
    double com_z;      /* centre of mass above the bottom face, m */
    double ixx;        /* moment of inertia about the x axis through the COM, kg m^2 */
    double izz;        /* moment of inertia about the vertical axis through the COM, kg m^2 */
    double iyy;        /* moment of inertia about the y axis through the COM, kg m^2 (= ixx at aspect 1) */
} cf_geometry_massprops;

/* Area of a regular n-gon of circumradius r, m^2. */
double cf_geometry_polygon_area(int n_sides, double r);

/* The segment's aspect (0 read as 1). */
double cf_geometry_segment_aspect(const cf_geometry_segment *seg);

/* The circumradius of the segment's section whose unscaled circumradius is r (r itself at aspect 1). */
double cf_geometry_circumradius(const cf_geometry_segment *seg, double r);

/* The diameter of a section of unscaled circumradius r and aspect a (0 read as 1) that normalises u_top and
 * u_d: 2 r min(1, a), the narrower diameter of the corner ellipse (semi-axes r along x, r a along y) on
 * which the scaled polygon's vertices lie -- 2 r at a = 1 (the regular polygon's circumscribed diameter),
 * sqrt 2 times the thickness of a rectangle built from the 45-degree square (Segment.rectangle), and
 * continuous at a = 1. Python's Column.base_diameter and joint_diameters call this, never restate it. */
double cf_geometry_section_diameter(double r, double aspect);

/* The mean distance from its centre, (1/A) int |r| dA (m), of a regular n-gon of circumradius r, first vertex
 * at phase, scaled by aspect along y (0 read as 1): per edge, the triangle with its apex at the centre,
 * (h / 6) [t sqrt(t^2 + h^2) + h^2 asinh(t / h)] between the edge's ends (h the edge's distance from the
 * centre, t the place along it from the foot of the perpendicular). (2/3) r for a disc; the exact
 * model's torsional friction arm (solver_exact.c). */
double cf_geometry_section_mean_radius(int n_sides, double r, double phase_rad, double aspect);

/* Mass properties of one segment (density kg/m^3). CF_EINVAL on bad geometry. */
int cf_geometry_segment_props(const cf_geometry_segment *seg, double density, cf_geometry_massprops *out);

/* Mass properties of segments stacked from the bottom up, as one rigid body. */
int cf_geometry_block_props(const cf_geometry_segment *segs, int n_segs, double density,
                            cf_geometry_massprops *out);
/* cffi:end */

#endif
