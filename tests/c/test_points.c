/* The sub-contact point's states (cf_point_state) and their transitions: each transition of
 * cf_point_next from a constructed case, and the energy each one books through the full
 * point law (cf_point_law_at) on one point against a square face. The expected states are
 * the rules written beside cf_point_next (solver_points_internal.h) and docs/solver.md; the
 * expected energies are a linear spring's, E = k x^2 / 2 (k = kn w), and the stored shear
 * energy |fs|^2 / (2 ks w), computed here from their formulas. */
#include <math.h>
#include <string.h>
#include "cf_test.h"
#include "solver_points_internal.h"

enum { OPEN = CF_POINT_OPEN, CONTACT = CF_POINT_CONTACT, OFF = CF_POINT_OFF_FACE, DEEP = CF_POINT_TOO_DEEP,
       OFFSET = CF_POINT_OFFSET };

static const double PMAX = 0.1, PENT = 1e-3;

/* not overlapping the plane -> open, from every state (a NaN depth too: not > 0) */
static void test_next_open(void)
{
    int st;
    for (st = OPEN; st <= OFFSET; st++) {
        CF_CHECK(cf_point_next((cf_point_state)st, 0.0, 1, PMAX, PENT) == CF_POINT_OPEN);
        CF_CHECK(cf_point_next((cf_point_state)st, -1e-4, 1, PMAX, PENT) == CF_POINT_OPEN);
        CF_CHECK(cf_point_next((cf_point_state)st, NAN, 1, PMAX, PENT) == CF_POINT_OPEN);
    }
}

/* deeper than pmax -> too deep, off the polygon -> off the face, from every state */
static void test_next_too_deep_and_off_face(void)
{
    int st;
    for (st = OPEN; st <= OFFSET; st++) {
        CF_CHECK(cf_point_next((cf_point_state)st, 0.2, 1, PMAX, PENT) == CF_POINT_TOO_DEEP);
        CF_CHECK(cf_point_next((cf_point_state)st, 0.2, 0, PMAX, PENT) == CF_POINT_TOO_DEEP);
        CF_CHECK(cf_point_next((cf_point_state)st, 1e-4, 0, PMAX, PENT) == CF_POINT_OFF_FACE);
        CF_CHECK(cf_point_next((cf_point_state)st, PMAX, 0, PMAX, PENT) == CF_POINT_OFF_FACE);   /* pmax itself: within */
    }
}

/* on the face: open -> contact; contact and offset stay; back from off the face or too deep
 * -> offset deeper than pent, contact at pent or shallower */
static void test_next_on_face(void)
{
    CF_CHECK(cf_point_next(CF_POINT_OPEN, 0.05, 1, PMAX, PENT) == CF_POINT_CONTACT);
    CF_CHECK(cf_point_next(CF_POINT_CONTACT, 0.05, 1, PMAX, PENT) == CF_POINT_CONTACT);
    CF_CHECK(cf_point_next(CF_POINT_OFFSET, 1e-5, 1, PMAX, PENT) == CF_POINT_OFFSET);
    CF_CHECK(cf_point_next(CF_POINT_OFF_FACE, 2e-3, 1, PMAX, PENT) == CF_POINT_OFFSET);
    CF_CHECK(cf_point_next(CF_POINT_TOO_DEEP, 2e-3, 1, PMAX, PENT) == CF_POINT_OFFSET);
    CF_CHECK(cf_point_next(CF_POINT_OFF_FACE, PENT, 1, PMAX, PENT) == CF_POINT_CONTACT);
    CF_CHECK(cf_point_next(CF_POINT_TOO_DEEP, 5e-4, 1, PMAX, PENT) == CF_POINT_CONTACT);
}

/* the stored doubles compare as the states in a lane vector (the wide runners' test) */
static void test_state_is_in_lanes(void)
{
    typedef double v4 __attribute__((vector_size(32)));
    typedef long long m4 __attribute__((vector_size(32)));
    v4 st = {CF_POINT_CONTACT, CF_POINT_OPEN, CF_POINT_OFFSET, CF_POINT_CONTACT};
    m4 m = cf_point_state_is(st, CF_POINT_CONTACT);
    CF_CHECK(m[0] == -1 && m[1] == 0 && m[2] == 0 && m[3] == -1);
    CF_CHECK(cf_point_state_is(1.0, CF_POINT_CONTACT) && !cf_point_state_is(4.0, CF_POINT_CONTACT));
}

/* One point against a square face of apothem 1 m (the face frame is the world's: M = I,
 * pen = Z), kn = ks = 1e9 Pa/m, w = 0.01 m^2, mu = 0.75; pmax 0.1 m, pent 1e-3 m. */
typedef struct {
    cf_points s;
    cf_face f;
    cf_face_pass P;
    double lx, ly, w, hx, hy, fast, knw, ksw, ihkw;
    double fsx, fsy, state, pen0;
    int hint;
} one_point;

static void one_point_init(one_point *o, int state)
{
    static const double ec[4] = {1, 0, -1, 0}, es[4] = {0, 1, 0, -1};
    int i;
    memset(o, 0, sizeof *o);
    o->f.n = 4; o->f.apo = 1.0; o->f.rc = sqrt(2.0);
    for (i = 0; i < 4; i++) { o->f.ec[i] = ec[i]; o->f.es[i] = es[i]; }
    o->w = 0.01; o->knw = 1e9 * o->w; o->ksw = 1e9 * o->w; o->ihkw = 0.5 / o->ksw;
    o->fast = -1.0;   /* no cheap inside test: the polygon decides */
    o->s.np = 1;
    o->s.lx = &o->lx; o->s.ly = &o->ly; o->s.w = &o->w; o->s.hx = &o->hx; o->s.hy = &o->hy;
    o->s.fast = &o->fast; o->s.knw = &o->knw; o->s.ksw = &o->ksw; o->s.ihkw = &o->ihkw;
    o->P.M[0] = o->P.M[4] = o->P.M[8] = 1.0;
    o->P.sgn = 1.0; o->P.pmax = PMAX; o->P.pent = PENT; o->P.kn = 1e9; o->P.mu = 0.75; o->P.ff = &o->f;
    o->state = state;
}

/* the point at (X, 0) with depth pen, not moving: its state after the step, the terms and sums */
static int one_point_step(one_point *o, double X, double pen, cf_face_sums *S, double *t)
{
    memset(S, 0, sizeof *S);
    o->P.t[0] = X; o->P.t[2] = pen;
    return cf_point_law_at(&o->s, &o->P, 0, &o->fsx, &o->fsy, &o->state, &o->pen0, &o->hint, S, t);
}

static void test_law_transitions_book_energy(void)
{
    one_point o;
    cf_face_sums S;
    double t[8], k = 1e9 * 0.01, pen = 2e-4;
    /* open -> contact: force k pen, nothing booked */
    one_point_init(&o, OPEN);
    CF_CHECK(one_point_step(&o, 0.5, pen, &S, t) == 1);
    CF_CHECK(o.state == CONTACT);
    CF_CHECK_REL(t[2], k * pen, 1e-15);
    CF_CHECK(S.dswitch == 0.0 && S.dslip == 0.0);
    /* contact -> off the face (X beyond the apothem): the spring's energy k pen^2 / 2 leaves as
     * contact_switch, the stored shear's |fs|^2 / (2 ks w) is dissipated, the shear reset */
    one_point_init(&o, CONTACT);
    o.fsx = 300.0; o.fsy = -400.0;
    CF_CHECK(one_point_step(&o, 1.5, pen, &S, t) == 0);
    CF_CHECK(o.state == OFF);
    CF_CHECK_REL(S.dswitch, 0.5 * k * pen * pen, 1e-15);
    CF_CHECK_REL(S.dslip, 500.0 * 500.0 / (2.0 * o.ksw), 1e-15);
    CF_CHECK(o.fsx == 0.0 && o.fsy == 0.0);
    /* off the face -> contact at pent or shallower: the spring's energy comes in (negative) */
    one_point_init(&o, OFF);
    CF_CHECK(one_point_step(&o, 0.5, pen, &S, t) == 1);
    CF_CHECK(o.state == CONTACT);
    CF_CHECK_REL(S.dswitch, -0.5 * k * pen * pen, 1e-15);
    /* too deep -> offset deeper than pent: unstretched at that depth, no force, nothing booked;
     * 1e-4 m deeper the next step its force is k 1e-4 */
    one_point_init(&o, DEEP);
    CF_CHECK(one_point_step(&o, 0.5, 5e-3, &S, t) == 1);
    CF_CHECK(o.state == OFFSET && o.pen0 == 5e-3);
    CF_CHECK(t[2] == 0.0 && S.dswitch == 0.0);
    CF_CHECK(one_point_step(&o, 0.5, 5.1e-3, &S, t) == 1);
    CF_CHECK_REL(t[2], k * (5.1e-3 - 5e-3), 1e-12);
    /* offset, the point moving up: no tension, the offset follows it */
    CF_CHECK(one_point_step(&o, 0.5, 4e-3, &S, t) == 1);
    CF_CHECK(o.state == OFFSET && o.pen0 == 4e-3 && t[2] == 0.0);
    /* offset -> too deep: the compressed spring's energy k (pen - pen0)^2 / 2 leaves */
    CF_CHECK(one_point_step(&o, 0.5, 4.2e-3, &S, t) == 1);
    CF_CHECK(one_point_step(&o, 0.5, 0.2, &S, t) == 0);
    CF_CHECK(o.state == DEEP);
    CF_CHECK_REL(S.dswitch, 0.5 * k * (0.2 - 4e-3) * (0.2 - 4e-3), 1e-15);
    /* contact -> open (lifted): the shear released, no spring energy booked (it is zero) */
    one_point_init(&o, CONTACT);
    o.fsx = 300.0;
    CF_CHECK(one_point_step(&o, 0.5, -1e-5, &S, t) == 0);
    CF_CHECK(o.state == OPEN && S.dswitch == 0.0 && o.fsx == 0.0);
    CF_CHECK_REL(S.dslip, 300.0 * 300.0 / (2.0 * o.ksw), 1e-15);
}

/* A face scaled along y (geometry.h: the square of side b at phase pi/4, y -> a y, the rectangle b x a b):
 * cf_face_inside and cf_face_inside_hint (the walk from every start edge) agree with |x| <= b/2, |y| <= a b/2
 * on a grid of points around it (none within 1e-9 of the boundary), at a < 1 and a > 1; its area, reach
 * (rc), inscribed circle (apoc) and polar moment (b d (b^2 + d^2) / 12) are the rectangle's; at a = 1 the
 * square's polar moment is the regular polygon's A r^2 (2 + cos(2 pi / n)) / 6 = b^4 / 6. */
static void test_scaled_face_is_the_rectangle(void)
{
    const double b = 0.4, as[2] = {0.4, 2.5};
    int ia, i, j, h;
    {
        cf_face f;
        cf_solver_stack_face(&f, 4, b / sqrt(2.0), 0.25 * CF_PI, 0.0, 1.0);
        CF_CHECK_REL(f.polar, b * b * b * b / 6.0, 1e-13);
    }
    for (ia = 0; ia < 2; ia++) {
        double a = as[ia], d = a * b;
        cf_face f;
        cf_solver_stack_face(&f, 4, b / sqrt(2.0), 0.25 * CF_PI, 0.0, a);
        CF_CHECK_REL(f.area, b * d, 1e-13);
        CF_CHECK_REL(f.rc, 0.5 * sqrt(b * b + d * d), 1e-13);
        CF_CHECK_REL(f.apoc, 0.5 * (b < d ? b : d), 1e-13);
        CF_CHECK_REL(f.polar, b * d * (b * b + d * d) / 12.0, 1e-13);   /* the exact model's torsion */
        for (i = -60; i <= 60; i++)
            for (j = -60; j <= 60; j++) {
                double x = 0.00737 * i, y = 0.00737 * j * a;
                int in = fabs(x) <= 0.5 * b && fabs(y) <= 0.5 * d;
                if (fabs(fabs(x) - 0.5 * b) < 1e-9 || fabs(fabs(y) - 0.5 * d) < 1e-9) continue;
                CF_CHECK(cf_face_inside(&f, x, y, 0.0) == in);
                for (h = 0; h < 4; h++) {
                    int hint = h;
                    CF_CHECK(cf_face_inside_hint(&f, x, y, 0.0, &hint) == in);
                }
            }
    }
}

/* The cheap inside test (cf_points_quick_r2) never accepts what the polygon test refuses: homes inside a
 * face (a grid, and points within 1e-10 of its sides), each moved by the quick radius (less 1e-12) in 16
 * directions, are inside the face grown by tol -- at a = 0.4 (tol a along y: before, the radius was tol, and
 * a point tol along y from a home at the long side was refused by the polygon), 1 and 2.5. */
static void test_quick_inside_is_within_the_polygon_test(void)
{
    const double b = 0.4, as[3] = {0.4, 1.0, 2.5};
    int ia, i, j, k;
    for (ia = 0; ia < 3; ia++) {
        double a = as[ia], d = a * b, tol, r;
        cf_face f;
        cf_solver_stack_face(&f, 4, b / sqrt(2.0), 0.25 * CF_PI, 0.0, a);
        tol = 0.01 * f.rc;
        r = sqrt(cf_points_quick_r2(&f, tol)) - 1e-12;
        for (i = -10; i <= 10; i++)
            for (j = -10; j <= 10; j++) {
                double hx = (0.5 * b - 1e-10) * i / 10.0, hy = (0.5 * d - 1e-10) * j / 10.0;
                CF_CHECK(cf_face_inside(&f, hx, hy, 1e-9 * f.rc));
                for (k = 0; k < 16; k++) {
                    double ph = 2.0 * CF_PI * k / 16.0;
                    CF_CHECK(cf_face_inside(&f, hx + r * cos(ph), hy + r * sin(ph), tol));
                }
            }
    }
}

int main(void)
{
    CF_RUN(test_quick_inside_is_within_the_polygon_test);
    CF_RUN(test_scaled_face_is_the_rectangle);
    CF_RUN(test_next_open);
    CF_RUN(test_next_too_deep_and_off_face);
    CF_RUN(test_next_on_face);
    CF_RUN(test_state_is_in_lanes);
    CF_RUN(test_law_transitions_book_energy);
    return CF_TEST_SUMMARY("test_points");
}
