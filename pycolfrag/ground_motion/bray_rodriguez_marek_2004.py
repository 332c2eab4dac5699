"""Bray & Rodriguez-Marek (2004): the peak ground velocity of forward-directivity records -- an alternative
pulse amplitude to the paper's Eq. (6) (Rupakhety et al. 2011), for a logic tree's ``vp_model`` set.

J. D. Bray and A. Rodriguez-Marek, "Characterization of forward-directivity ground motions in the
near-fault region", Soil Dynamics and Earthquake Engineering 24(11), 815-828 (2004),
doi:10.1016/j.soildyn.2004.05.001. A regression of the PGV of the fault-normal components of the
forward-directivity records of their near-fault data set on magnitude and closest distance to the
rupture, natural logarithm, PGV in cm/s, R in km (their PGV regression table)::

    ln(PGV) = a + b Mw + c ln(R^2 + d^2),     a = 4.58, b = 0.34, c = -0.58, d = 7 km

Against Eq. (6): at Mw 7, R 5 km, 86.8 cm/s against 48.9 cm/s (1.78x);
at Mw 5.5, R 10 km 34.7 against 19.3 cm/s (1.80x); at Mw 7.5, R 5 km 103 against 48.9 (2.1x: no magnitude
saturation here, Eq. (6) caps Mw at 7.0).

Used as the *median* of Vp only: the scatter stays Eq. (6)'s (sigma of log10 Vp 0.16) and the pulse's
other parameters the paper's, so that a run's normal z_vp gives in this branch the same quantile of Vp as
in the Eq. (6) branch (common random numbers: the two branches differ by the median's ratio alone). PGV
of a record is not the Vp of its extracted pulse: the relation stands for the alternative view that the
pulse amplitude of forward-directivity motions is as large as their PGV.

Provenance: the coefficients are those this relation is usually quoted with (the rock-and-soil set, no
site term); they are NOT verified against the paper's text: no copy of the paper, nor a secondary source
quoting its PGV table (or its pulse-period relation), was found from this project's machines (searched again
for issue 33: the paper's title, "Bray and Rodriguez-Marek", "Rodriguez-Marek 2004", the equation's terms
and coefficients, in public repositories, documentation, issue threads and stored web pages, GMPE compendia
among them), the same caveat as :mod:`~pycolfrag.ground_motion.baker_2007`'s. Check them -- and whether the
paper's regression carries a site (soil) term -- against the paper before a decision rests on this branch
(docs/ground_motion.md says the same).
"""
from __future__ import annotations

from pycolfrag.core.errors import ParameterError
from pycolfrag.ground_motion import rupakhety_2011 as _r11

__all__ = ["NAME", "KIND", "PARAMETERS", "A", "B", "C", "D_KM", "mean_vp_cm_s"]

#: Name in the registry (:mod:`pycolfrag.ground_motion.registry`) and of a tree's ``vp_model`` choice.
NAME = "bray_rodriguez_marek_2004"
#: A pulse-amplitude relation: ``mean_vp_cm_s(Mw, dist_km, vp_scale)`` (a tree's ``vp_model``).
KIND = "pulse_amplitude"
#: Its inputs: the scenario over the pulse model's accepted range and the factor on the median (the
#: declaration of :mod:`~pycolfrag.ground_motion.rupakhety_2011`: this relation replaces Eq. (6) on the
#: same scenarios).
PARAMETERS = _r11.PARAMETERS
_VP_SCALE = PARAMETERS[2]

#: ln(PGV) = A + B Mw + C ln(R^2 + D_KM^2), PGV cm/s, R km (Bray & Rodriguez-Marek 2004).
A, B, C, D_KM = 4.58, 0.34, -0.58, 7.0


def mean_vp_cm_s(Mw, dist_km, vp_scale=1.0):
    """Median pulse peak velocity, cm/s: ``exp(A + B Mw + C ln(R^2 + D_KM^2))`` times ``vp_scale``
    (no magnitude cap). Scenarios outside the pulse model's range are refused (ModelRangeError)."""
    m, r = _r11.check_scenario(Mw, dist_km)
    s = _VP_SCALE.check(vp_scale, "vp_scale", error=ParameterError)
    from pycolfrag.core.ffi import lib  # C on first use: the declaration above is read without the C library
    # through the library's own exp and log (csrc/cf_math.c), as Eq. (6) is: the same bits on every CPU
    return s * lib.cf_math_exp(A + B * m + C * lib.cf_math_log(r * r + D_KM * D_KM))
