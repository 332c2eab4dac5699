"""Baker (2007): pulse period of near-fault velocity pulses against magnitude -- an alternative to
the paper's Eq. (7) for the pulse-period branch of the grid (``run_grid.py --tp-model baker_2007``).

J. W. Baker, "Quantitative classification of near-fault ground motions using wavelet analysis",
Bulletin of the Seismological Society of America 97(5), 1486-1501 (2007), doi:10.1785/0120060255.
Regression of the pulse periods of the 91 pulses the wavelet classification found in the
fault-normal NGA records, natural logarithm, Tp in s::

    ln(Tp) = -6.45 + 1.11 Mw,        standard deviation of ln(Tp) = 0.56

Against Eq. (7) of the paper (``log10 Tp = -2.87 + 0.47 Mw``, sigma of log10 = 0.18, i.e. 0.41 in
ln): about the same magnitude scaling (1.11 against 0.47 ln 10 = 1.08 per unit Mw), a 1.36 to 1.44
times longer median period over the paper's grid (Mw 5.5 / 6.5 / 7.5: 0.71 / 2.15 / 6.52 s against
0.52 / 1.53 / 4.52 s) and a wider scatter (0.56 against 0.41 in ln). Only the pulse period changes;
Vp (Eq. 6), nu and gamma stay as in the paper.

Provenance: the two coefficients and the standard deviation were transcribed without access to
the paper's text here (no public copy was reachable from this project's machines); they are the
values this relation is usually quoted with, but check them against the paper before a decision
rests on this branch (docs/ground_motion.md says the same).

The sampling uses base-10 logarithms of fp (:func:`log10_fp_mean`, :data:`SIGMA_LOG10_FP`), the
same uniform column of the Latin hypercube as the default model, so that a grid with this model
pairs row by row with the default grid.
"""
from __future__ import annotations

import math

from pycolfrag.ground_motion import rupakhety_2011 as _r11

__all__ = ["NAME", "KIND", "PARAMETERS", "C0", "C1", "SIGMA_LN_TP", "SIGMA_LOG10_FP", "mean_tp_s", "log10_fp_mean"]

#: Name in the registry (:mod:`pycolfrag.ground_motion.registry`) and in ``--tp-model``.
NAME = "baker_2007"
#: A pulse-period relation: ``log10_fp_mean(Mw)`` and ``SIGMA_LOG10_FP`` (the grid's ``--tp-model``).
KIND = "pulse_period"
#: Its one input: the magnitude, over the pulse model's range (that of Eq. 7, the declaration of
#: :mod:`pycolfrag.ground_motion.rupakhety_2011`: this relation replaces Eq. 7 on the same scenarios).
PARAMETERS = (_r11.PARAMETERS[0],)
_MW, = PARAMETERS

#: ln(Tp) = C0 + C1 Mw (Baker 2007).
C0, C1 = -6.45, 1.11
#: Standard deviation of ln(Tp) (Baker 2007).
SIGMA_LN_TP = 0.56
#: The same scatter in log10 of fp (ln -> log10 divides by ln 10; fp = 1/Tp keeps the spread).
SIGMA_LOG10_FP = SIGMA_LN_TP / math.log(10.0)


def log10_fp_mean(Mw) -> float:
    """Mean of log10(fp), fp = 1/Tp in Hz: ``-(C0 + C1 Mw) / ln 10``. Magnitudes outside the
    declared range (that of Eq. 7) are refused (ModelRangeError)."""
    m = _MW.check(Mw, "Mw", owner="the pulse model's")
    return -(C0 + C1 * m) / math.log(10.0)


def mean_tp_s(Mw) -> float:
    """Median pulse period, s: ``exp(-6.45 + 1.11 Mw)``."""
    from pycolfrag.core.ffi import lib  # C on first use: the declaration above is read without the C library
    return lib.cf_math_pow(10.0, -log10_fp_mean(Mw))
