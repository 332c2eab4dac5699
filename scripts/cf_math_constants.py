"""Print the constants of csrc/cf_math.c from exact integer arithmetic (no libm, no mpmath):
pi by Machin's formula, logarithms by the atanh series, square roots by math.isqrt, all in
fixed point with P bits. Run: python scripts/cf_math_constants.py"""
import math
from fractions import Fraction

P = 1600
ONE = 1 << P


def atan_inv(n):                       # atan(1/n) * 2^P
    s, term, k, sign = 0, ONE // n, 1, 1
    while term:
        s += sign * (term // k)
        term //= n * n
        k += 2
        sign = -sign
    return s


def atanh_frac(p, q):                  # atanh(p/q) * 2^P
    s, term, k = 0, ONE * p // q, 1
    while term:
        s += term // k
        term = term * p * p // (q * q)
        k += 2
    return s


PI = 16 * atan_inv(5) - 4 * atan_inv(239)
LN2 = 2 * atanh_frac(1, 3)
LN10 = 3 * LN2 + 2 * atanh_frac(1, 9)            # ln 10 = 3 ln 2 + ln(5/4), atanh(1/9) = ln(5/4)/2


def fx(v):
    return Fraction(v, ONE)


def split(v, bits):
    """Parts of v (Fraction); all but the last have at most `bits[i]` significant bits."""
    out = []
    for b in bits:
        if b == 53:
            d = float(v)
        else:
            e = math.floor(math.log2(abs(v)))
            scale = Fraction(2) ** (b - 1 - e)
            d = float(round(v * scale) / scale)
        out.append(d)
        v -= Fraction(d)
    return out, float(v)


for name, v, bits in [("PIO2", fx(PI) / 2, [33, 33, 33, 53]), ("LN2", fx(LN2), [32, 53, 53])]:
    parts, rem = split(v, bits)
    print(name, " ".join(p.hex() for p in parts), "remainder %.3g" % rem)
for name, v in [("INV_LN2", 1 / fx(LN2)), ("INV_PIO2", 2 / fx(PI)), ("INV_LN10", 1 / fx(LN10)),
                ("LN10", fx(LN10)), ("PIO2", fx(PI) / 2)]:
    hi = float(v)
    print(name, hi.hex(), float(v - Fraction(hi)).hex())
sqrtpi = Fraction(math.isqrt(PI << P), ONE)
print("ONE_OVER_SQRT_PI", float(1 / sqrtpi).hex(), "TWO_OVER_SQRT_PI", float(2 / sqrtpi).hex())
print("SQRT_HALF", float(Fraction(math.isqrt(ONE * ONE // 2), ONE)).hex())
x = 2 / fx(PI)                         # 2/pi in 24-bit words for the large-argument reduction
words = []
for _ in range(56):
    x *= 1 << 24
    w = math.floor(x)
    words.append(w)
    x -= w
print("TWO_OVER_PI_24:", ", ".join("0x%06X" % w for w in words))
