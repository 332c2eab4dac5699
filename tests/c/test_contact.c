/* The joint contact laws: one sub-contact's normal force and Coulomb shear
 * (stick, slip, reversal), and the exact-interface integration. */
#include <math.h>
#include "cf_test.h"
#include "cf_common.h"
#include "contact.h"

/* Normal force kn w pen; no tension (pen <= 0 gives 0 and releases the shear). */
static void test_normal_force(void)
{
    double fs[2] = {0, 0}, du[2] = {0, 0}, fn; int sl;
    double d = cf_contact_point(2e-4, du, 0.1, 1e9, 1e9, 0.75, fs, &fn, &sl);
    CF_CHECK_REL(fn, 1e9 * 0.1 * 2e-4, 1e-15);
    CF_CHECK(d == 0.0 && sl == 0);
    fs[0] = 1000.0;
    d = cf_contact_point(-1e-5, du, 0.1, 1e9, 1e9, 0.75, fs, &fn, &sl);
    CF_CHECK(fn == 0.0 && fs[0] == 0.0);
    CF_CHECK_REL(d, 0.5 * 1000.0 * 1000.0 / (1e9 * 0.1), 1e-15);   /* stored energy released */
}

/* Stick: fs = -ks w du accumulates elastically; slip: |fs| capped at mu N with the
 * friction work mu N |slip| dissipated (exactly, for a steady slip); reversal: the
 * contact sticks again and unloads elastically at the full stiffness. */
static void test_stick_slip_transitions(void)
{
    double kn = 1e9, ks = 1e10, w = 0.05, mu = 0.75, pen = 1e-4, N = kn * w * pen, lim = mu * N;
    double fs[2] = {0, 0}, du[2] = {1e-6, 0}, fn, diss = 0, d; int sl, i;
    /* stick: 1e-6 m per step (500 N), elastic until ks w u = mu N = 3750 N (u = 7.5e-6 m) */
    for (i = 0; i < 7; i++) {
        d = cf_contact_point(pen, du, w, kn, ks, mu, fs, &fn, &sl);
        CF_CHECK(sl == 0 && d == 0.0);
    }
    CF_CHECK_REL(fs[0], -ks * w * 7e-6, 1e-12);
    /* step 8 reaches the cap: slips */
    d = cf_contact_point(pen, du, w, kn, ks, mu, fs, &fn, &sl);
    CF_CHECK(sl == 1);
    CF_CHECK_REL(fs[0], -lim, 1e-14);
    diss += d;
    /* steady slip of 1e-6 m per step: dissipation = mu N * 1e-6 each step */
    for (i = 0; i < 10; i++) {
        d = cf_contact_point(pen, du, w, kn, ks, mu, fs, &fn, &sl);
        CF_CHECK(sl == 1);
        CF_CHECK_REL(d, lim * 1e-6, 1e-9);
    }
    /* reversal: sticks, force changes by ks w du */
    du[0] = -1e-6;
    d = cf_contact_point(pen, du, w, kn, ks, mu, fs, &fn, &sl);
    CF_CHECK(sl == 0 && d == 0.0);
    CF_CHECK_REL(fs[0], -lim + ks * w * 1e-6, 1e-12);
}

/* Coulomb's cap acts on the magnitude of the 2D shear force: an oblique slip at 30 deg
 * to a stored force along x is capped to |fs| = mu N (a circle, not a box), and the
 * energy dissipated in the capping step is the trapezoidal work minus the elastic
 * energy change (computed here independently from the two forces). */
static void test_coulomb_circle(void)
{
    double kn = 1e9, ks = 1e9, w = 0.1, mu = 0.75, pen = 1e-4, N = kn * w * pen, lim = mu * N, fn, d;
    double fs[2], f0[2], du[2] = {-2e-5 * cos(CF_PI / 6), -2e-5 * sin(CF_PI / 6)}, work, de; int sl;
    fs[0] = 0.9 * lim; fs[1] = 0.0; f0[0] = fs[0]; f0[1] = fs[1];
    d = cf_contact_point(pen, du, w, kn, ks, mu, fs, &fn, &sl);
    CF_CHECK(sl == 1);
    CF_CHECK_REL(sqrt(fs[0] * fs[0] + fs[1] * fs[1]), lim, 1e-14);
    work = -0.5 * ((f0[0] + fs[0]) * du[0] + (f0[1] + fs[1]) * du[1]);
    de = 0.5 * ((fs[0] * fs[0] + fs[1] * fs[1]) - (f0[0] * f0[0] + f0[1] * f0[1])) / (ks * w);
    CF_CHECK_REL(d, work - de, 1e-12);
    CF_CHECK(d > 0.0);
}

static void test_polygon_moments_and_clipping(void)
{
    /* unit square [0,1]^2: A = 1, int x = 1/2, int x^2 = 1/3, int xy = 1/4 */
    double sq[8] = {0, 0, 1, 0, 1, 1, 0, 1}, m[6], out[16], work[64];
    double sq2[8] = {0.5, 0.5, 1.5, 0.5, 1.5, 1.5, 0.5, 1.5};
    int n;
    cf_contact_polygon_moments(sq, 4, m);
    CF_CHECK_CLOSE(m[0], 1.0, 1e-15); CF_CHECK_CLOSE(m[1], 0.5, 1e-15); CF_CHECK_CLOSE(m[2], 0.5, 1e-15);
    CF_CHECK_CLOSE(m[3], 1.0 / 3, 1e-15); CF_CHECK_CLOSE(m[4], 0.25, 1e-15); CF_CHECK_CLOSE(m[5], 1.0 / 3, 1e-15);
    n = cf_contact_clip_convex(sq, 4, sq2, 4, out, work);
    cf_contact_polygon_moments(out, n, m);
    CF_CHECK_CLOSE(m[0], 0.25, 1e-15);
    CF_CHECK_CLOSE(m[1] / m[0], 0.75, 1e-15);
    n = cf_contact_clip_halfplane(sq, 4, 0.5, -1.0, 0.0, out);   /* x <= 0.5 */
    cf_contact_polygon_moments(out, n, m);
    CF_CHECK_CLOSE(m[0], 0.5, 1e-15);
}

/* Exact interface on a square of side 2 centred at 0: uniform overlap p gives
 * kn A p at the centre; a linear overlap p = x (compressed for x > 0) gives the
 * wedge: force kn int_0^1 x * 2 dx = kn, centre of pressure at x = 2/3. */
static void test_exact_interface(void)
{
    double sq[8] = {-1, -1, 1, -1, 1, 1, -1, 1};
    cf_contact_exact_result r;
    CF_CHECK(cf_contact_exact(sq, 4, sq, 4, 1e-4, 0, 0, 1e9, &r) >= 3);
    CF_CHECK_REL(r.force, 1e9 * 4 * 1e-4, 1e-14);
    CF_CHECK_CLOSE(r.xc, 0.0, 1e-15);
    CF_CHECK_REL(r.energy, 0.5 * 1e9 * 4 * 1e-8, 1e-14);
    CF_CHECK(cf_contact_exact(sq, 4, sq, 4, 0.0, 1.0, 0.0, 1e9, &r) >= 3);
    CF_CHECK_REL(r.force, 1e9, 1e-14);
    CF_CHECK_REL(r.xc, 2.0 / 3.0, 1e-14);
    CF_CHECK_REL(r.area, 2.0, 1e-14);
    CF_CHECK(cf_contact_exact(sq, 4, sq, 4, -1e-3, 0, 0, 1e9, &r) == 0);   /* open joint */
}

int main(void)
{
    CF_RUN(test_normal_force);
    CF_RUN(test_stick_slip_transitions);
    CF_RUN(test_coulomb_circle);
    CF_RUN(test_polygon_moments_and_clipping);
    CF_RUN(test_exact_interface);
    return CF_TEST_SUMMARY("test_contact");
}
