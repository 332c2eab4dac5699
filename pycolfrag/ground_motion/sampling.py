"""Two numerical tools of the pulse sampling, bit for bit those of scipy, without scipy.

* :func:`latin_hypercube` -- ``scipy.stats.qmc.LatinHypercube(d, rng=numpy.random.default_rng(seed))
  .random(n)`` (scipy 1.17: the defaults ``scramble=True``, ``strength=1``, no optimization);
* :func:`minimize_bounded` -- ``scipy.optimize.minimize_scalar(f, bounds=(lo, hi), method="bounded",
  options={"xatol": xatol})``: Brent's bounded search (golden sections and parabolic steps; Brent 1973,
  "Algorithms for Minimization without Derivatives", ch. 5, as scipy's ``_minimize_scalar_bounded``).

Why not scipy itself: every rank of a grid draws its scenarios' hypercubes and searches each pulse's
peak, and importing ``scipy.stats`` and ``scipy.optimize`` took 0.9 s of a rank's 1.1 s start-up --
on many ranks, the largest fixed cost of a run. Both are short loops of numpy draws and float
arithmetic; written here in scipy's order of operations and of random draws, they give the same bits
(``tests/test_sampling.py`` compares them with scipy over many sizes, seeds and functions).
scipy is BSD-licensed (Copyright (c) 2001-2002 Enthought, Inc. 2003, SciPy Developers); the search
below follows its text line by line.
"""
from __future__ import annotations

import math
from typing import Callable

import numpy as np

__all__ = ["latin_hypercube", "minimize_bounded"]


def latin_hypercube(d: int, n: int, seed: int) -> np.ndarray:
    """``n`` points of a Latin hypercube of the unit ``d``-cube (shape (n, d)): every one of the ``n``
    strata of every dimension holds one point, uniformly placed in it; the same numbers as scipy's
    ``qmc.LatinHypercube(d=d, rng=np.random.default_rng(seed)).random(n)``.

    scipy's engine draws from a child of the generator it is given (``SeedSequence.spawn``), then the
    uniform offsets of all points, then a permutation of the strata per dimension (``shuffle``)."""
    child = np.random.SeedSequence(seed).spawn(1)[0]
    rng = np.random.Generator(np.random.PCG64(child))
    samples = rng.uniform(size=(n, d))
    perms = np.tile(np.arange(1, n + 1), (d, 1))
    for i in range(d):
        rng.shuffle(perms[i, :])
    return (perms.T - samples) / n


def minimize_bounded(f: Callable[[float], float], lo: float, hi: float, xatol: float = 1e-5,
                     maxiter: int = 500) -> tuple[float, float]:
    """The minimum of ``f`` on [lo, hi] by Brent's bounded search: ``(x, f(x))``, the same floats as
    scipy's ``minimize_scalar(f, bounds=(lo, hi), method="bounded", options={"xatol": xatol})``
    returns in ``res.x`` and ``res.fun`` (its ``maxiter`` evaluations at most, as there)."""
    if not (math.isfinite(lo) and math.isfinite(hi)) or lo > hi:
        raise ValueError(f"bounds must be finite with lo <= hi, got ({lo}, {hi})")
    sqrt_eps = math.sqrt(2.2e-16)
    golden_mean = 0.5 * (3.0 - math.sqrt(5.0))
    a, b = lo, hi
    fulc = a + golden_mean * (b - a)
    nfc, xf = fulc, fulc
    rat = e = 0.0
    x = xf
    fx = f(x)
    num = 1
    ffulc = fnfc = fx
    xm = 0.5 * (a + b)
    tol1 = sqrt_eps * abs(xf) + xatol / 3.0
    tol2 = 2.0 * tol1
    while abs(xf - xm) > (tol2 - 0.5 * (b - a)):
        golden = 1
        if abs(e) > tol1:   # a parabola through the three best points
            golden = 0
            r = (xf - nfc) * (fx - ffulc)
            q = (xf - fulc) * (fx - fnfc)
            p = (xf - fulc) * q - (xf - nfc) * r
            q = 2.0 * (q - r)
            if q > 0.0:
                p = -p
            q = abs(q)
            r = e
            e = rat
            if (abs(p) < abs(0.5 * q * r)) and (p > q * (a - xf)) and (p < q * (b - xf)):
                rat = (p + 0.0) / q
                x = xf + rat
                if ((x - a) < tol2) or ((b - x) < tol2):
                    rat = tol1 * _sign_or_one(xm - xf)
            else:
                golden = 1
        if golden:          # a golden-section step into the larger part
            e = (a - xf) if xf >= xm else (b - xf)
            rat = golden_mean * e
        x = xf + _sign_or_one(rat) * max(abs(rat), tol1)
        fu = f(x)
        num += 1
        if fu <= fx:
            if x >= xf:
                a = xf
            else:
                b = xf
            fulc, ffulc = nfc, fnfc
            nfc, fnfc = xf, fx
            xf, fx = x, fu
        else:
            if x < xf:
                a = x
            else:
                b = x
            if (fu <= fnfc) or (nfc == xf):
                fulc, ffulc = nfc, fnfc
                nfc, fnfc = x, fu
            elif (fu <= ffulc) or (fulc == xf) or (fulc == nfc):
                fulc, ffulc = x, fu
        xm = 0.5 * (a + b)
        tol1 = sqrt_eps * abs(xf) + xatol / 3.0
        tol2 = 2.0 * tol1
        if num >= maxiter:
            break
    return xf, fx


def _sign_or_one(v: float) -> float:
    """scipy's ``np.sign(v) + (v == 0)``: the sign of ``v``, and 1 for zero."""
    return 1.0 if v >= 0.0 else -1.0
