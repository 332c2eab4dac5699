"""Rupakhety, Sigurdsson, Papageorgiou & Sigbjörnsson (2011): mean pulse amplitude and period
of near-fault forward-directivity pulses, as printed in the paper we reproduce (Psycharis et al.,
Eqs. 6 and 7).

Eq. (6), base-10 logarithms, Vp in cm/s, R in km (the paper's fault distance)::

    log10(Vp) = -5.17 + 1.98 M - 0.14 M^2 - 0.10 log10(R^2 + 0.562),   M = min(Mw, Msat), Msat = 7.0

The constant 0.562 is used *as printed*; it may be a typesetting of 0.56^2 = 0.3136 (a
fictitious depth of 0.56 km). The difference is below 0.0005 in log10(Vp) for R >= 5 km.

Eq. (7): ``log10(1/fp) = -2.87 + 0.47 Mw`` (no magnitude cap), fp in Hz, Tp = 1/fp in s.

Scatter (the paper, after Rupakhety et al.): sigma of log10(Vp) = 0.16, of log10(fp) = 0.18.

``vp_scale`` multiplies the Eq. (6) mean (a sensitivity knob, not part of the published model;
1 reproduces the paper).
"""
from __future__ import annotations

import math

from pycolfrag.core.errors import ParameterError
from pycolfrag.core.names import Parameter

__all__ = ["NAME", "KIND", "PARAMETERS", "M_SAT", "SIGMA_LOG10_VP", "SIGMA_LOG10_FP", "MW_RANGE", "DIST_RANGE_KM",
           "mean_vp_cm_s", "mean_fp_hz", "mean_tp_s", "log10_fp_mean", "check_scenario"]

#: Name in the registry (:mod:`pycolfrag.ground_motion.registry`) and in ``--tp-model``.
NAME = "rupakhety_2011"
#: A pulse-period relation: ``log10_fp_mean(Mw)`` and ``SIGMA_LOG10_FP`` (the grid's ``--tp-model``).
KIND = "pulse_period"

#: Saturation magnitude of Eq. (6).
M_SAT = 7.0
#: Standard deviation of log10(Vp) (the paper, after Rupakhety et al. 2011).
SIGMA_LOG10_VP = 0.16
#: Standard deviation of log10(fp).
SIGMA_LOG10_FP = 0.18

#: The inputs of Eqs. (6)-(7) and the values this module accepts. Magnitude: a validity guard around
#: the paper's grid 5.5-7.5, not a calibrated range quoted from Rupakhety et al.; fault distance: the
#: paper's grid is 5-20 km, near-fault only.
PARAMETERS = (
    Parameter("Mw", "", (5.0, 8.0), "moment magnitude", meta_key="Mw"),
    Parameter("R", "km", (0.0, 60.0), "fault distance", meta_key="dist_km"),
    Parameter("vp_scale", "-", (0.0, math.inf), "factor on the Eq. (6) mean Vp (1: the published model)",
              meta_key="vp_scale", low_open=True),
)
_MW, _R, _VP_SCALE = PARAMETERS
#: Magnitudes this module accepts (the declaration's range).
MW_RANGE = _MW.range
#: Fault distances this module accepts, km (the declaration's range).
DIST_RANGE_KM = _R.range


def check_scenario(Mw, dist_km):
    """``(Mw, dist_km)`` as floats, or :class:`ModelRangeError` naming the value outside
    ``MW_RANGE`` / ``DIST_RANGE_KM`` (``ParameterError`` for non-numbers and NaN/inf)."""
    return (_MW.check(Mw, "Mw", owner="the pulse model's"),
            _R.check(dist_km, "dist_km", owner="the pulse model's"))


def _lib():
    """The compiled library, loaded on first use rather than at import: the declarations above are
    read by the results layout, which must not need the C library."""
    from pycolfrag.core.ffi import lib  # loads C on first use (docstring)
    return lib


def mean_vp_cm_s(Mw, dist_km, vp_scale=1.0):
    """Mean (median) pulse peak velocity, cm/s: Eq. (6) with Mw capped at ``M_SAT``, times
    ``vp_scale``.

    Parameters
    ----------
    Mw : float, moment magnitude
    dist_km : float, fault distance R, km
    vp_scale : float (> 0), multiplies the mean (1 = the published model)
    """
    m, r = check_scenario(Mw, dist_km)
    s = _VP_SCALE.check(vp_scale, "vp_scale", error=ParameterError)
    m = min(m, M_SAT)
    lib = _lib()
    # Eq. (6); log10 and 10** through the library's own functions (csrc/cf_math.c): Python's
    # math module calls the C library, whose last bits depend on the CPU.
    log_vp = -5.17 + 1.98 * m - 0.14 * m * m - 0.10 * lib.cf_math_log10(r * r + 0.562)
    return s * lib.cf_math_pow(10.0, log_vp)


def mean_tp_s(Mw):
    """Mean pulse period 1/fp, s: Eq. (7), ``log10(Tp) = -2.87 + 0.47 Mw`` (no cap)."""
    m = _MW.check(Mw, "Mw", owner="the pulse model's")
    return _lib().cf_math_pow(10.0, -2.87 + 0.47 * m)                                   # Eq. (7)


def mean_fp_hz(Mw):
    """Mean pulse frequency fp, Hz (Eq. 7)."""
    return 1.0 / mean_tp_s(Mw)


def log10_fp_mean(Mw):
    """Mean of log10(fp), the centre of the sampled fp (Eq. 7; the interface every pulse-period
    model of :data:`pycolfrag.ground_motion.registry.TP_MODELS` offers)."""
    return _lib().cf_math_log10(mean_fp_hz(Mw))
