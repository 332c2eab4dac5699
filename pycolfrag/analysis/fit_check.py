"""Does a lognormal fragility fit its stripes? The stripes whose share lies outside its binomial interval.

A maximum-likelihood lognormal curve (:func:`pycolfrag.analysis.fragility.fit_lognormal_fragility`) is
fitted to every run at once; where the data do not follow a lognormal in the IM (a PGA fit of a pulse
grid, whose strongest stripes exceed less often than the curve says) it can miss whole stripes. A
stripe of n runs of which k exceed the level has the exact (Clopper-Pearson) interval of k/n
(:func:`~pycolfrag.analysis.fragility.binomial_ci`); a fitted curve that passes outside that interval at
the stripe's IM departs from the stripe beyond its sampling error. The figures (Fig. 16) ring those
stripes and the report's IM table names them.

The curve is read at the stripe's IM value (the mid-point of an equal-width stripe), not averaged over
the stripe: on a steep curve and a wide stripe this can flag a stripe the averaged curve would meet,
which is why the flag is a warning to look at the figure, not a test of the model.
"""
from __future__ import annotations

import numpy as np

from pycolfrag.analysis.fragility import binomial_ci

__all__ = ["stripe_departures", "departure_note"]


def stripe_departures(sc, mle, confidence: float = 0.90) -> np.ndarray:
    """Indices of the stripes of ``sc`` (a StripeCurve) whose empirical share k/n has a ``confidence``
    Clopper-Pearson interval that excludes the fitted curve ``mle`` at the stripe's IM; empty without a
    fit or without stripes holding runs."""
    if mle is None:
        return np.zeros(0, dtype=int)
    out = []
    for s in range(np.size(sc.im)):
        n = int(sc.n[s])
        if n <= 0 or not np.isfinite(sc.p_empirical[s]) or not np.isfinite(sc.im[s]):
            continue
        k = int(round(float(sc.p_empirical[s]) * n))
        lo, hi = binomial_ci(k, n, confidence)
        p = float(mle(np.array([sc.im[s]]))[0])
        if p < lo or p > hi:
            out.append(s)
    return np.asarray(out, dtype=int)


def departure_note(sc, bad, unit: str = "") -> str:
    """``"misses 3 of 10 stripes (IM 0.75-0.95 g)"`` for the stripes ``bad`` of ``sc``, ``""`` when none."""
    if np.size(bad) == 0:
        return ""
    used = int(np.sum((np.asarray(sc.n) > 0) & np.isfinite(sc.p_empirical)))
    ims = np.asarray(sc.im)[bad]
    u = f" {unit}" if unit else ""
    where = f"{ims.min():.3g}{u}" if ims.size == 1 else f"{ims.min():.3g}-{ims.max():.3g}{u}"
    return f"misses {np.size(bad)} of {used} stripes (at IM {where})"
