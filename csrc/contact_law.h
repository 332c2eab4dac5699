/*
 * contact_law.h -- THE sub-contact law of the soft joints, written once.
 *
 * One contact carries a normal spring and an incremental elastic shear spring capped
 * by Coulomb friction, in the frame of the face it presses on (normal = +z of that
 * frame). Because the stored shear force (fsx, fsy) is kept in that face's frame, it
 * turns with the face exactly (a rotation keeps its magnitude and keeps it in the
 * current tangent plane). Per step:
 *   normal    fn = kn w pen for pen > 0 (overlap, m; w the contact's area share, m^2);
 *             no tension: pen <= 0 releases the contact (fn = 0, shear reset, its
 *             stored elastic energy |fs|^2 / (2 ks w) booked as dissipated);
 *   shear     trial fs = fs_old - ks w du_t (du_t: tangential relative displacement of
 *             the upper body over the step, m);
 *   Coulomb   |fs| <= mu fn: beyond, fs is scaled back onto the cone (slip) and the
 *             dissipation is the trapezoidal work on the contact minus the change of
 *             its elastic energy (zero for an elastic update), the rule the leapfrog
 *             integrator conserves exactly.
 *
 * Who uses this text: the scalar point path (solver_points.c), the SIMD path
 * (solver_points_wide.h: the same trial and terms on 2, 4 or 8 lanes; a lane that slips
 * takes the scalar law), the batch (solver_batch_lanes.h), the exact interface
 * (solver_exact.c: one joint-level contact), and the C unit tests through
 * cf_contact_point (contact.c).
 *
 * The lane-generic parts are macros over the operators of a lane type, so the scalar
 * and SIMD paths evaluate the same operations in the same order (each a correctly
 * rounded IEEE operation; the build has contraction off): bitwise the same results.
 */
#ifndef CF_CONTACT_LAW_H
#define CF_CONTACT_LAW_H
#include <math.h>

/* Elastic trial, any lane type: ADD, SUB, MUL are the lane's operators.
 * In: pen, dux, duy, knw = kn w, ksw = ks w, mu, fsx0, fsy0 (stored shear).
 * Out: fn (normal force), lim = mu fn, (fx, fy) trial shear, m2 = |trial|^2. */
#define CF_LAW_TRIAL(ADD, SUB, MUL, pen, dux, duy, knw, ksw, mu, fsx0, fsy0, fn, lim, fx, fy, m2) \
    do {                                                                                      \
        (fn) = MUL((knw), (pen));                                                             \
        (lim) = MUL((mu), (fn));                                                              \
        (fx) = SUB((fsx0), MUL((ksw), (dux)));                                                \
        (fy) = SUB((fsy0), MUL((ksw), (duy)));                                                \
        (m2) = ADD(MUL((fx), (fx)), MUL((fy), (fy)));                                         \
    } while (0)

/* The squared Coulomb cap of a trial: the contact sticks while m2 <= CF_LAW_CAP2(MUL, lim) and
 * slips (is scaled back onto the cone by cf_law_update) when m2 is greater. */
#define CF_LAW_CAP2(MUL, lim) MUL((lim), (lim))

/* What one loaded contact at (X, Y, Z) of the face frame adds to its face's sums:
 * moment about the face centre (mx, my, mz) of the force (fx, fy, fn), and its
 * spring energy vs = fn pen / 2 + |fs|^2 / (2 ks w) (ihkw = 1 / (2 ks w)). */
#define CF_LAW_TERMS(ADD, SUB, MUL, half, X, Y, Z, pen, fn, fx, fy, fs2, ihkw, mx, my, mz, vs) \
    do {                                                                                       \
        (mx) = SUB(MUL((Y), (fn)), MUL((Z), (fy)));                                            \
        (my) = SUB(MUL((Z), (fx)), MUL((X), (fn)));                                            \
        (mz) = SUB(MUL((X), (fy)), MUL((Y), (fx)));                                            \
        (vs) = ADD(MUL(MUL((half), (fn)), (pen)), MUL((fs2), (ihkw)));                         \
    } while (0)

/* Slip: a trial (fx, fy) beyond the cap (m2 > CF_LAW_CAP2) scaled back onto the cone,
 * (fxs, fys) = (fx, fy) lim / |f|, and the slip dissipation over the step: the trapezoidal work
 * on the contact minus the change of its elastic energy (fsx0, fsy0: the stored shear before
 * the step). sc receives the scale lim / |f| (a variable of the caller's lane type: C99 has no
 * typeof for a local of the macro's own). SQRT is the lane's square root; the rest are the plain
 * operators, which are the per-lane IEEE operations for double and for GCC vector types alike. */
#define CF_LAW_SLIP(SQRT, lim, m2, fx, fy, fsx0, fsy0, dux, duy, ksw, sc, fxs, fys, diss)                 \
    do {                                                                                              \
        (sc) = (lim) / SQRT(m2);                                                                      \
        (fxs) = (fx) * (sc);                                                                          \
        (fys) = (fy) * (sc);                                                                          \
        (diss) = -0.5 * (((fsx0) + (fxs)) * (dux) + ((fsy0) + (fys)) * (duy))                         \
                 - 0.5 * ((fxs) * (fxs) + (fys) * (fys) - (fsx0) * (fsx0) - (fsy0) * (fsy0)) / (ksw); \
    } while (0)

/* The stored shear energy |fs|^2 / (2 ks w) of a contact (ihkw = 1 / (2 ks w)), J: what a
 * release dissipates. */
#define CF_LAW_SHEAR_ENERGY(fsx, fsy, ihkw) (((fsx) * (fsx) + (fsy) * (fsy)) * (ihkw))

#define CF_LAW_SADD(a, b) ((a) + (b))
#define CF_LAW_SSUB(a, b) ((a) - (b))
#define CF_LAW_SMUL(a, b) ((a) * (b))

/* Release of a contact that stops carrying force: its stored shear energy (J) is
 * dissipated and the shear reset. ihkw = 1 / (2 ks w). */
static inline double cf_law_release(double *fsx, double *fsy, double ihkw)
{
    double d = 0.0;
    if (*fsx != 0.0 || *fsy != 0.0) {
        d = CF_LAW_SHEAR_ENERGY(*fsx, *fsy, ihkw);
        *fsx = *fsy = 0.0;
    }
    return d;
}

/* The whole law for one contact, scalar: pen (m), tangential increment (dux, duy)
 * (m), knw = kn w (N/m), ksw = ks w (N/m), mu; updates the stored shear fs[2] (N),
 * sets *fn (N) and *slipping; returns the slip dissipation over the step (J). */
static inline double cf_law_update(double pen, double dux, double duy, double knw, double ksw, double mu,
                                   double *fs, double *fn, int *slipping)
{
    double f, lim, fx, fy, m2;
    *slipping = 0;
    if (!(pen > 0.0)) {
        *fn = 0.0;
        return cf_law_release(fs, fs + 1, 0.5 / ksw);
    }
    CF_LAW_TRIAL(CF_LAW_SADD, CF_LAW_SSUB, CF_LAW_SMUL, pen, dux, duy, knw, ksw, mu, fs[0], fs[1], f, lim, fx, fy, m2);
    *fn = f;
    if (m2 > CF_LAW_CAP2(CF_LAW_SMUL, lim)) {
        double sc, diss, fxs, fys;
        CF_LAW_SLIP(sqrt, lim, m2, fx, fy, fs[0], fs[1], dux, duy, ksw, sc, fxs, fys, diss);
        fs[0] = fxs; fs[1] = fys;
        *slipping = 1;
        return diss;
    }
    fs[0] = fx; fs[1] = fy;
    return 0.0;
}

#endif
