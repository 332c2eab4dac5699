/*
 * cf_math.c -- exp, log, log10, pow, sin, cos, erfc, the normal CDF and its inverse, in
 * IEEE double arithmetic only, so they give the same bits on every CPU (cf_math.h).
 *
 * Method (every constant is derived in scripts/cf_math_constants.py from exact integer
 * arithmetic; every polynomial is a truncated Taylor series with coefficients 1/n! or
 * 1/(2n+1) rounded to double, truncated where the next term is below 2^-57 relative):
 *  - exp: x = k ln2 + r, |r| <= ln2/2, ln 2 in three parts (the first with 32 bits, so
 *    k * LN2_HI is exact); exp(r) = 1 + r + r^2 P(r), the 1 + r step done exactly
 *    (two_sum) and the low part of the reduced argument carried as a correction.
 *  - log: x = 2^k m, m in [sqrt(1/2), sqrt(2)), f = m - 1, s = f / (2 + f),
 *    log(1 + f) = 2 atanh(s) = 2s + 2s^3/3 + 2s^5/5 + ..., evaluated in double-double
 *    (about 100 bits), so log10 and pow round once at the end.
 *  - pow(x, y) = exp(y log|x|) with y log|x| in double-double; C99 Annex F special cases.
 *  - sin, cos: x = n pi/2 + r, |r| <= pi/4, pi/2 in four parts (33, 33, 33, 53 bits,
 *    exact products for |n| < 2^20); beyond |x| ~ 1.6e6 the reduction multiplies the
 *    53-bit significand by 240 bits of 2/pi chosen around the binary point (Payne-Hanek),
 *    exact for every double; then Taylor kernels on [-pi/4, pi/4] with the low part of r.
 *  - erfc: the series erf(x) = 2x/sqrt(pi) exp(-x^2) sum (2x^2)^n / (1 3 ... (2n+1)) for
 *    |x| < 1, the continued fraction of Laplace for x >= 1 (modified Lentz).
 *  - ndtri: Wichura (1988), Algorithm AS 241 (PPND16), about 1e-16 relative.
 * Double-double helpers (Dekker 1971, Knuth TAOCP 4.2.2) need round-to-nearest and no
 * contraction: the build uses -ffp-contract=off and no -march, so no FMA is emitted.
 */
#include <math.h>
#include <stdint.h>
#include <string.h>
#include "cf_math.h"

/* ---- bits and powers of two ---------------------------------------------- */

static uint64_t dbits(double x)
{
    uint64_t u;
    memcpy(&u, &x, sizeof u);
    return u;
}

static double from_bits(uint64_t u)
{
    double x;
    memcpy(&x, &u, sizeof x);
    return x;
}

/* 2^k for -1022 <= k <= 1023 (built from its bits: exact). */
static double pow2i(int k)
{
    return from_bits((uint64_t)(k + 1023) << 52);
}

/* x * 2^k for x in [0.5, 2], rounded once (also when the result is subnormal). */
static double scale2(double x, int k)
{
    if (k > 1023)
        return (x * pow2i(1023)) * pow2i(k - 1023 > 1023 ? 1023 : k - 1023);
    if (k >= -1022)
        return x * pow2i(k);
    if (k < -1076)
        return x * 0.0;
    return (x * pow2i(k + 54)) * pow2i(-54);   /* one rounding: the first product is exact */
}

/* ---- double-double arithmetic ---------------------------------------------- */

/* s + e == a + b exactly (Knuth). */
static void two_sum(double a, double b, double *s, double *e)
{
    double ss = a + b, bb = ss - a;
    *s = ss;
    *e = (a - (ss - bb)) + (b - bb);
}

/* s + e == a + b exactly, for |a| >= |b| or a == 0 (Dekker). */
static void fast_two_sum(double a, double b, double *s, double *e)
{
    double ss = a + b;
    *s = ss;
    *e = b - (ss - a);
}

/* p + e == a * b exactly (Dekker with Veltkamp's split; |a|, |b| < 2^996). */
static void two_prod(double a, double b, double *p, double *e)
{
    const double split = 134217729.0;   /* 2^27 + 1 */
    double ca = split * a, cb = split * b;
    double ah = ca - (ca - a), al = a - ah;
    double bh = cb - (cb - b), bl = b - bh;
    double pp = a * b;
    *p = pp;
    *e = ((ah * bh - pp) + ah * bl + al * bh) + al * bl;
}

/* ---- constants (scripts/cf_math_constants.py) -------------------------------- */

static const double LN2_HI = 0x1.62e42ff000000p-1;     /* 32 significant bits */
static const double LN2_MID = -0x1.718432a1b0e26p-35;
static const double LN2_LO = -0x1.9ff0342542fc3p-90;
static const double INV_LN2 = 0x1.71547652b82fep+0;
static const double INV_LN10_HI = 0x1.bcb7b1526e50ep-2;
static const double INV_LN10_LO = 0x1.95355baaafad3p-57;
static const double PIO2_1 = 0x1.921fb54400000p+0;     /* 33 significant bits */
static const double PIO2_2 = 0x1.0b4611a600000p-34;    /* 33 */
static const double PIO2_3 = 0x1.3198a2e000000p-69;    /* 33 */
static const double PIO2_4 = 0x1.b839a252049c1p-104;
static const double PIO2_HI = 0x1.921fb54442d18p+0;
static const double PIO2_LO = 0x1.1a62633145c07p-54;
static const double INV_PIO2 = 0x1.45f306dc9c883p-1;
static const double ONE_OVER_SQRT_PI = 0x1.20dd750429b6dp-1;
static const double SQRT_HALF = 0x1.6a09e667f3bcdp-1;
static const double SQRT2 = 0x1.6a09e667f3bcdp+0;

/* ---- exp --------------------------------------------------------------------- */

/* exp(r + c) for |r| <= 0.35, |c| <= 2^-40 |r|-ish: a value in [0.7, 1.42]. */
static double exp_core(double r, double c)
{
    /* r^2 (1/2! + r (1/3! + ... + r / 14!)): the next term is below 2^-57 of the result */
    double p = 0x1.93974a8c07c9dp-37;                     /* 1/14! */
    p = 0x1.6124613a86d09p-33 + r * p;                    /* 1/13! */
    p = 0x1.1eed8eff8d898p-29 + r * p;                    /* 1/12! */
    p = 0x1.ae64567f544e4p-26 + r * p;                    /* 1/11! */
    p = 0x1.27e4fb7789f5cp-22 + r * p;                    /* 1/10! */
    p = 0x1.71de3a556c734p-19 + r * p;                    /* 1/9! */
    p = 0x1.a01a01a01a01ap-16 + r * p;                    /* 1/8! */
    p = 0x1.a01a01a01a01ap-13 + r * p;                    /* 1/7! */
    p = 0x1.6c16c16c16c17p-10 + r * p;                    /* 1/6! */
    p = 0x1.1111111111111p-7 + r * p;                     /* 1/5! */
    p = 0x1.5555555555555p-5 + r * p;                     /* 1/4! */
    p = 0x1.5555555555555p-3 + r * p;                     /* 1/3! */
    p = 0.5 + r * p;                                      /* 1/2! */
    p = (r * r) * p;
    double s, e;
    two_sum(1.0, r, &s, &e);
    return s + ((p + c * (1.0 + r)) + e);
}

/* exp(hi + lo), |lo| <= ulp(hi): the shared back end of exp and pow. */
static double exp_dd(double hi, double lo)
{
    if (hi > 709.8)
        return INFINITY;
    if (hi < -745.2)
        return 0.0;
    double kd = floor(hi * INV_LN2 + 0.5);
    int k = (int)kd;
    double t = hi - kd * LN2_HI;                          /* exact: kd * LN2_HI has <= 43 bits */
    double m, me, r, re;
    two_prod(kd, LN2_MID, &m, &me);
    two_sum(t, -m, &r, &re);
    double c = ((re - me) - kd * LN2_LO) + lo;
    fast_two_sum(r, c, &r, &c);
    return scale2(exp_core(r, c), k);
}

double cf_math_exp(double x)
{
    if (isnan(x))
        return x + x;
    if (x > 0x1.62e42fefa39efp+9)                        /* ln(DBL_MAX) */
        return INFINITY;
    if (x < -0x1.74910d52d3051p+9)                       /* below ln(2^-1075): rounds to 0 */
        return 0.0;
    if (fabs(x) < 0x1p-54)
        return 1.0 + x;
    return exp_dd(x, 0.0);
}

/* ---- log --------------------------------------------------------------------- */

/* log(x) = *hi + *lo to about 2^-100 relative, for finite x > 0. */
static void log_dd(double x, double *hi, double *lo)
{
    int k = 0;
    if (x < 0x1p-1022) {                                  /* subnormal: make it normal */
        x *= 0x1p54;
        k = -54;
    }
    uint64_t u = dbits(x);
    k += (int)((u >> 52) & 0x7ff) - 1023;
    double m = from_bits((u & 0x000fffffffffffffULL) | 0x3ff0000000000000ULL);   /* [1, 2) */
    if (m > SQRT2) {
        m *= 0.5;
        k += 1;
    }
    double f = m - 1.0;                                   /* exact (Sterbenz) */
    /* s = f / (2 + f) as s_hi + s_lo */
    double d, dl;
    fast_two_sum(2.0, f, &d, &dl);
    double s_hi = f / d, ph, pl;
    two_prod(s_hi, d, &ph, &pl);
    double s_lo = (((f - ph) - pl) - s_hi * dl) / d;
    /* z = s^2 as z_hi + z_lo */
    double z_hi, z_lo;
    two_prod(s_hi, s_hi, &z_hi, &z_lo);
    z_lo += 2.0 * s_hi * s_lo;
    /* U = z/3 + z^2 (1/5 + z/7 + ... + z^11/27): z/3 in double-double, the rest (< 2e-4) in
     * double; the first term left out, z^13/29, is below 2^-66. */
    double q = 0x1.2f684bda12f68p-5;                      /* 1/27 */
    q = 0x1.47ae147ae147bp-5 + z_hi * q;                  /* 1/25 */
    q = 0x1.642c8590b2164p-5 + z_hi * q;                  /* 1/23 */
    q = 0x1.8618618618618p-5 + z_hi * q;                  /* 1/21 */
    q = 0x1.af286bca1af28p-5 + z_hi * q;                  /* 1/19 */
    q = 0x1.e1e1e1e1e1e1ep-5 + z_hi * q;                  /* 1/17 */
    q = 0x1.1111111111111p-4 + z_hi * q;                  /* 1/15 */
    q = 0x1.3b13b13b13b14p-4 + z_hi * q;                  /* 1/13 */
    q = 0x1.745d1745d1746p-4 + z_hi * q;                  /* 1/11 */
    q = 0x1.c71c71c71c71cp-4 + z_hi * q;                  /* 1/9 */
    q = 0x1.2492492492492p-3 + z_hi * q;                  /* 1/7 */
    q = 0x1.999999999999ap-3 + z_hi * q;                  /* 1/5 */
    q = (z_hi * z_hi) * q;
    double a_hi = z_hi / 3.0, tp, te;
    two_prod(a_hi, 3.0, &tp, &te);
    double a_lo = (((z_hi - tp) - te) + z_lo) / 3.0;
    double u_hi, u_lo;
    two_sum(a_hi, q, &u_hi, &u_lo);
    u_lo += a_lo;
    /* log(1 + f) = 2 s (1 + U) = 2 s + 2 s U */
    double t_hi, t_lo;
    two_prod(s_hi, u_hi, &t_hi, &t_lo);
    t_lo += s_hi * u_lo + s_lo * u_hi;
    double l_hi, l_lo;
    two_sum(2.0 * s_hi, 2.0 * t_hi, &l_hi, &l_lo);
    l_lo += 2.0 * s_lo + 2.0 * t_lo;
    /* + k ln 2 */
    double kd = (double)k, kh = kd * LN2_HI, km, kme;     /* kh exact */
    two_prod(kd, LN2_MID, &km, &kme);
    double h, e;
    two_sum(kh, l_hi, &h, &e);
    e += l_lo + (km + (kme + kd * LN2_LO));
    fast_two_sum(h, e, hi, lo);
}

/* The special values shared by log and log10 (C99 Annex F): 1 and the result in *r when x is
 * NaN, negative, zero, +inf or exactly 1; else 0. */
static int log_special(double x, double *r)
{
    if (isnan(x)) { *r = x + x; return 1; }
    if (x < 0.0) { *r = NAN; return 1; }
    if (x == 0.0) { *r = -INFINITY; return 1; }
    if (isinf(x)) { *r = x; return 1; }
    if (x == 1.0) { *r = 0.0; return 1; }
    return 0;
}

double cf_math_log(double x)
{
    double r;
    if (log_special(x, &r))
        return r;
    double hi, lo;
    log_dd(x, &hi, &lo);
    return hi;                                            /* hi = round(hi + lo) */
}

double cf_math_log10(double x)
{
    double r;
    if (log_special(x, &r))
        return r;
    double hi, lo, p, pe;
    log_dd(x, &hi, &lo);
    two_prod(hi, INV_LN10_HI, &p, &pe);
    return p + (pe + (hi * INV_LN10_LO + lo * INV_LN10_HI));
}

/* ---- pow --------------------------------------------------------------------- */

/* 0: y not an integer; 1: odd integer; 2: even integer (finite y). */
static int integer_kind(double y)
{
    if (floor(y) != y)
        return 0;
    if (fabs(y) >= 0x1p53)
        return 2;
    return fmod(y, 2.0) == 0.0 ? 2 : 1;                  /* fmod is exact */
}

double cf_math_pow(double x, double y)
{
    if (y == 0.0 || x == 1.0)
        return 1.0;
    if (isnan(x) || isnan(y))
        return x + y;
    int yk = isinf(y) ? 2 : integer_kind(y);
    if (isinf(y)) {
        double ax = fabs(x);
        if (ax == 1.0)
            return 1.0;
        return (ax < 1.0) == (y < 0.0) ? INFINITY : 0.0;
    }
    if (x == 0.0) {
        int neg = signbit(x) && yk == 1;
        if (y < 0.0)
            return neg ? -INFINITY : INFINITY;
        return neg ? -0.0 : 0.0;
    }
    if (isinf(x)) {
        int neg = x < 0.0 && yk == 1;
        if (y < 0.0)
            return neg ? -0.0 : 0.0;
        return neg ? -INFINITY : INFINITY;
    }
    double sign = 1.0;
    if (x < 0.0) {
        if (yk == 0)
            return NAN;
        if (yk == 1)
            sign = -1.0;
        x = -x;
    }
    double lh, ll;
    log_dd(x, &lh, &ll);
    double p = y * lh;
    if (p > 710.0)
        return sign * INFINITY;
    if (p < -746.0)
        return sign * 0.0;
    double ph, pe;
    two_prod(y, lh, &ph, &pe);
    fast_two_sum(ph, pe + y * ll, &ph, &pe);
    return sign * exp_dd(ph, pe);
}

/* ---- sin, cos ------------------------------------------------------------------ */

/* 2/pi in 24-bit words (scripts/cf_math_constants.py): enough for every double. */
static const int32_t TWO_OVER_PI[56] = {
    0xA2F983, 0x6E4E44, 0x1529FC, 0x2757D1, 0xF534DD, 0xC0DB62, 0x95993C, 0x439041,
    0xFE5163, 0xABDEBB, 0xC561B7, 0x246E3A, 0x424DD2, 0xE00649, 0x2EEA09, 0xD1921C,
    0xFE1DEB, 0x1CB129, 0xA73EE8, 0x8235F5, 0x2EBB44, 0x84E99C, 0x7026B4, 0x5F7E41,
    0x3991D6, 0x398353, 0x39F49C, 0x845F8B, 0xBDF928, 0x3B1FF8, 0x97FFDE, 0x05980F,
    0xEF2F11, 0x8B5A0A, 0x6D1F6D, 0x367ECF, 0x27CB09, 0xB74F46, 0x3F669E, 0x5FEA2D,
    0x7527BA, 0xC7EBE5, 0xF17B3D, 0x0739F7, 0x8A5292, 0xEA6BFB, 0x5FB11F, 0x8D5D08,
    0x560330, 0x46FC7B, 0x6BABF0, 0xCFBC20, 0x9AF436, 0x1DA9E3, 0x91615E, 0xE61B08,
};

#define RED_WORDS 10  /* 240 bits of 2/pi per reduction: 2^-160 absolute, enough for 61 cancelled bits */

/* ax = n pi/2 + (*y0 + *y1), |y| <= pi/4, for finite ax >= 2^20; returns n mod 4. */
static int reduce_large(double ax, double *y0, double *y1)
{
    uint64_t u = dbits(ax);
    int E = (int)((u >> 52) & 0x7ff) - 1023 - 52;         /* ax = M 2^E, M < 2^53 integer */
    uint64_t M = (u & 0x000fffffffffffffULL) | 0x0010000000000000ULL;
    /* words j with E - 24 (j + 1) >= 2 only add multiples of 4 to x 2/pi: skip them */
    int j0 = E - 2 >= 0 ? (E - 2) / 24 : 0;                /* floor((E - 2) / 24), >= 0 */
    uint64_t m[3] = {M & 0xffffff, (M >> 24) & 0xffffff, M >> 48};
    uint64_t w[RED_WORDS], p[RED_WORDS + 3];
    for (int k = 0; k < RED_WORDS; k++)
        w[k] = (uint64_t)TWO_OVER_PI[j0 + RED_WORDS - 1 - k];   /* little endian */
    memset(p, 0, sizeof p);
    for (int i = 0; i < 3; i++)
        for (int k = 0; k < RED_WORDS; k++)
            p[i + k] += m[i] * w[k];
    for (int i = 0; i < RED_WORDS + 2; i++) {
        p[i + 1] += p[i] >> 24;
        p[i] &= 0xffffff;
    }
    /* x 2/pi = P 2^-F (mod the skipped multiples of 4) */
    int F = 24 * (j0 + RED_WORDS) - E;
    int n = (int)((p[F / 24] >> (F % 24)) & 1) + 2 * (int)((p[(F + 1) / 24] >> ((F + 1) % 24)) & 1);
    /* the fraction: bits below F; if it is >= 1/2, take 1 - fraction (two's complement in
     * the integers, exact, so no bits are lost to the cancellation) and count one more n */
    int top = (F - 1) / 24;
    p[top] &= (((uint64_t)1) << (F - 24 * top)) - 1;
    double sign = 1.0;
    if ((p[top] >> ((F - 1) - 24 * top)) & 1) {
        uint64_t carry = 1;
        for (int i = 0; i <= top; i++) {
            uint64_t mask = i == top ? (((uint64_t)1) << (F - 24 * top)) - 1 : 0xffffff;
            uint64_t v = ((~p[i]) & mask) + carry;
            carry = v >> 24;
            p[i] = v & mask;
        }
        sign = -1.0;
        n++;
    }
    double fh = 0.0, fl = 0.0;
    for (int i = top; i >= 0; i--) {
        double t = (double)p[i] * pow2i(24 * i - F);       /* exact: 24 bits, power of two */
        double s, e;
        two_sum(fh, t, &s, &e);
        fh = s;
        fl += e;
    }
    fast_two_sum(fh, fl, &fh, &fl);
    fh *= sign;
    fl *= sign;
    double rh, re;
    two_prod(fh, PIO2_HI, &rh, &re);
    re += fh * PIO2_LO + fl * PIO2_HI;
    fast_two_sum(rh, re, y0, y1);
    return n & 3;
}

/* x = n pi/2 + (*y0 + *y1), |y| <= pi/4 (about); returns n mod 4. Finite x. */
static int reduce_pio2(double x, double *y0, double *y1)
{
    double ax = fabs(x);
    int n;
    if (ax <= 0x1.921fb54442d18p-1) {                     /* pi/4 */
        *y0 = x;
        *y1 = 0.0;
        return 0;
    }
    if (ax < 0x1p20) {
        double nd = floor(ax * INV_PIO2 + 0.5);
        double t = ax - nd * PIO2_1;                       /* exact: nd < 2^20, PIO2_1 33 bits */
        double s, e, s2, e2;
        two_sum(t, -(nd * PIO2_2), &s, &e);                /* the products are exact */
        two_sum(s, -(nd * PIO2_3), &s2, &e2);
        e = (e + e2) - nd * PIO2_4;
        fast_two_sum(s2, e, y0, y1);
        n = (int)fmod(nd, 4.0);
    } else {
        n = reduce_large(ax, y0, y1);
    }
    if (x < 0.0) {
        *y0 = -*y0;
        *y1 = -*y1;
        n = (4 - n) & 3;
    }
    return n;
}

/* sin(y0 + y1), |y0| <= pi/4 + tiny: Taylor to y^17 (y^19/19! < 2^-62 |y|). */
static double sin_kernel(double y0, double y1)
{
    double z = y0 * y0;
    double p = 0x1.952c77030ad4ap-49;                     /* 1/17! */
    p = -0x1.ae7f3e733b81fp-41 + z * p;                   /* -1/15! */
    p = 0x1.6124613a86d09p-33 + z * p;                    /* 1/13! */
    p = -0x1.ae64567f544e4p-26 + z * p;                   /* -1/11! */
    p = 0x1.71de3a556c734p-19 + z * p;                    /* 1/9! */
    p = -0x1.a01a01a01a01ap-13 + z * p;                   /* -1/7! */
    p = 0x1.1111111111111p-7 + z * p;                     /* 1/5! */
    p = -0x1.5555555555555p-3 + z * p;                    /* -1/3! */
    return y0 + ((z * y0) * p + y1 * (1.0 - 0.5 * z));
}

/* cos(y0 + y1): Taylor to y^18 (y^20/20! < 2^-66). */
static double cos_kernel(double y0, double y1)
{
    double z = y0 * y0;
    double p = -0x1.6827863b97d97p-53;                    /* -1/18! */
    p = 0x1.ae7f3e733b81fp-45 + z * p;                    /* 1/16! */
    p = -0x1.93974a8c07c9dp-37 + z * p;                   /* -1/14! */
    p = 0x1.1eed8eff8d898p-29 + z * p;                    /* 1/12! */
    p = -0x1.27e4fb7789f5cp-22 + z * p;                   /* -1/10! */
    p = 0x1.a01a01a01a01ap-16 + z * p;                    /* 1/8! */
    p = -0x1.6c16c16c16c17p-10 + z * p;                   /* -1/6! */
    p = 0x1.5555555555555p-5 + z * p;                     /* 1/4! */
    p = (z * z) * p;
    double hz = 0.5 * z, w = 1.0 - hz;
    return w + (((1.0 - w) - hz) + (p - y0 * y1));        /* (1 - w) - hz: the rounding of w */
}

void cf_math_sincos(double x, double *s, double *c)
{
    double sv, cv;
    if (!isfinite(x)) {
        sv = cv = x - x;                                   /* NaN */
    } else if (fabs(x) < 0x1p-27) {                       /* x^2/2 < 2^-55: exact roundings */
        sv = x;
        cv = 1.0;
    } else {
        double y0, y1;
        int n = reduce_pio2(x, &y0, &y1);
        double ks = sin_kernel(y0, y1), kc = cos_kernel(y0, y1);
        switch (n) {
        case 0: sv = ks; cv = kc; break;
        case 1: sv = kc; cv = -ks; break;
        case 2: sv = -ks; cv = -kc; break;
        default: sv = -kc; cv = ks; break;
        }
    }
    if (s)
        *s = sv;
    if (c)
        *c = cv;
}

double cf_math_sin(double x)
{
    if (!isfinite(x))
        return x - x;
    if (fabs(x) < 0x1p-27)
        return x;
    double y0, y1;
    int n = reduce_pio2(x, &y0, &y1);
    switch (n) {
    case 0: return sin_kernel(y0, y1);
    case 1: return cos_kernel(y0, y1);
    case 2: return -sin_kernel(y0, y1);
    default: return -cos_kernel(y0, y1);
    }
}

double cf_math_cos(double x)
{
    if (!isfinite(x))
        return x - x;
    if (fabs(x) < 0x1p-27)
        return 1.0;
    double y0, y1;
    int n = reduce_pio2(x, &y0, &y1);
    switch (n) {
    case 0: return cos_kernel(y0, y1);
    case 1: return -sin_kernel(y0, y1);
    case 2: return -cos_kernel(y0, y1);
    default: return sin_kernel(y0, y1);
    }
}

/* ---- erfc, normal CDF, inverse normal CDF -------------------------------------- */

/* exp(-x^2) with x^2 carried in double-double (x^2 rounded would cost 2 x^2 ulps). */
static double exp_minus_sq(double x)
{
    double h, l;
    two_prod(x, x, &h, &l);
    return exp_dd(-h, -l);
}

double cf_math_erfc(double x)
{
    if (isnan(x))
        return x + x;
    if (x <= -1.0)
        return 2.0 - cf_math_erfc(-x);                    /* in [1.84, 2]: no cancellation */
    if (x < 1.0) {
        /* erf(x) = 2x/sqrt(pi) exp(-x^2) sum_n (2x^2)^n / (1 3 5 ... (2n+1)), terms all > 0 */
        double t2 = 2.0 * x * x, term = 1.0, sum = 1.0;
        for (int n = 1; n < 200; n++) {
            term *= t2 / (double)(2 * n + 1);
            sum += term;
            if (term < 0x1p-60 * sum)
                break;
        }
        double erf = 2.0 * ONE_OVER_SQRT_PI * x * exp_minus_sq(x) * sum;
        return 1.0 - erf;
    }
    if (x > 27.3)                                          /* erfc(27.3) < 2^-1075 */
        return 0.0;
    /* erfc(x) = exp(-x^2)/sqrt(pi) / (x + (1/2)/(x + 1/(x + (3/2)/(x + ...)))), Lentz */
    const double tiny = 0x1p-1000;
    double f = x, C = x, D = 0.0;
    for (int n = 1; n < 5000; n++) {
        double a = 0.5 * (double)n;
        D = x + a * D;
        if (D == 0.0)
            D = tiny;
        C = x + a / C;
        if (C == 0.0)
            C = tiny;
        D = 1.0 / D;
        double delta = C * D;
        f *= delta;
        if (fabs(delta - 1.0) < 0x1p-56)
            break;
    }
    return exp_minus_sq(x) * ONE_OVER_SQRT_PI / f;
}

double cf_math_norm_cdf(double x)
{
    return 0.5 * cf_math_erfc(-x * SQRT_HALF);
}

/* Wichura (1988), Algorithm AS 241, PPND16: rational approximations in three ranges. */
double cf_math_ndtri(double p)
{
    if (isnan(p) || p < 0.0 || p > 1.0)
        return NAN;
    if (p == 0.0)
        return -INFINITY;
    if (p == 1.0)
        return INFINITY;
    double q = p - 0.5, r, val;
    if (fabs(q) <= 0.425) {
        r = 0.180625 - q * q;
        val = q * (((((((2509.0809287301226727 * r + 33430.575583588128105) * r
                        + 67265.770927008700853) * r + 45921.953931549871457) * r
                      + 13731.693765509461125) * r + 1971.5909503065514427) * r
                    + 133.14166789178437745) * r + 3.387132872796366608)
            / (((((((5226.495278852545925 * r + 28729.085735721942674) * r
                    + 39307.89580009271061) * r + 21213.794301586595867) * r
                  + 5394.1960214247511077) * r + 687.1870074920579083) * r
                + 42.313330701600911252) * r + 1.0);
        return val;
    }
    r = q < 0.0 ? p : 1.0 - p;
    r = sqrt(-cf_math_log(r));
    if (r <= 5.0) {
        r -= 1.6;
        val = (((((((7.7454501427834140764e-4 * r + 0.0227238449892691845833) * r
                    + 0.24178072517745061177) * r + 1.27045825245236838258) * r
                  + 3.64784832476320460504) * r + 5.7694972214606914055) * r
                + 4.6303378461565452959) * r + 1.42343711074968357734)
            / (((((((1.05075007164441684324e-9 * r + 5.475938084995344946e-4) * r
                    + 0.0151986665636164571966) * r + 0.14810397642748007459) * r
                  + 0.68976733498510000455) * r + 1.6763848301838038494) * r
                + 2.05319162663775882187) * r + 1.0);
    } else {
        r -= 5.0;
        val = (((((((2.01033439929228813265e-7 * r + 2.71155556874348757815e-5) * r
                    + 0.0012426609473880784386) * r + 0.026532189526576123093) * r
                  + 0.29656057182850489123) * r + 1.7848265399172913358) * r
                + 5.4637849111641143699) * r + 6.6579046435011037772)
            / (((((((2.04426310338993978564e-15 * r + 1.4215117583164458887e-7) * r
                    + 1.8463183175100546818e-5) * r + 7.868691311456132591e-4) * r
                  + 0.0148753612908506148525) * r + 0.13692988092273580531) * r
                + 0.59983220655588793769) * r + 1.0);
    }
    return q < 0.0 ? -val : val;
}
