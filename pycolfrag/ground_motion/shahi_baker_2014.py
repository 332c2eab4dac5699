"""Shahi & Baker (2014): probability that a near-fault ground motion carries a velocity pulse.

Shahi, S. K., and Baker, J. W. (2014). "An efficient algorithm to identify strong-velocity pulses
in multicomponent ground motions." Bulletin of the Seismological Society of America 104(5),
2456-2466, doi:10.1785/0120130191. The paper classifies the NGA-West2 records with its
multicomponent algorithm and refits the logistic pulse-occurrence models of Shahi & Baker (2011)
to them, one for strike-slip and one for non-strike-slip (normal, reverse, oblique) ruptures::

    strike-slip:      P(pulse | r, s, theta) = 1 / (1 + exp(c0 + c1 r - c2 sqrt(s) + c3 theta))
    non-strike-slip:  P(pulse | r, d, phi)   = 1 / (1 + exp(c0 + c1 r - c2 sqrt(d) + c3 phi))

with r the closest distance to the rupture (km), s (d) the length of rupture between the
epicentre (hypocentre) and the site measured along strike (up dip), km, and theta (phi) the angle
between the strike (dip) direction and the path to the site, degrees, in [0, 90] -- the
directivity geometry of Somerville et al. (1997). Coefficients (:data:`COEFFICIENTS`):

================  =====  =====  =====  =====
mechanism          c0     c1     c2     c3
================  =====  =====  =====  =====
strike-slip       0.457  0.126  0.244  0.013
non-strike-slip   0.304  0.072  0.208  0.021
================  =====  =====  =====  =====

Provenance: transcribed from NHERI SimCenter's ground-motion simulator smelt
(``src/dabaghi_der_kiureghian.cc``, ``simulate_pulse_type``, documented in its header as following
the pulse probability model of this paper). No second public copy of the numbers was found
(OpenQuake's hazard library and Baker's own repositories, whose ``PulseClassification`` implements
the paper's classification algorithm, not this model), and the paper itself could not be read
here: the coefficients are checked against that one secondary implementation, not against the
paper (``tests/test_risk.py``).

pycolfrag uses the model to weight the pulse and no-pulse branches of a site's risk
(:mod:`pycolfrag.risk.site_risk`, ``docs/risk.md``).
"""
from __future__ import annotations

import math

import numpy as np

from pycolfrag.core.errors import ParameterError
from pycolfrag.core.names import Parameter

__all__ = ["NAME", "KIND", "CITATION", "PROVENANCE", "PARAMETERS", "COEFFICIENTS", "MECHANISMS",
           "pulse_probability", "logistic_probability"]

#: Name in the registry (:mod:`pycolfrag.ground_motion.registry`).
NAME = "shahi_baker_2014"
#: How the outputs of a site risk cite the model.
CITATION = "Shahi & Baker (2014)"
#: Where the coefficients come from (printed with every site risk that uses them).
PROVENANCE = ("coefficients transcribed from NHERI SimCenter smelt (src/dabaghi_der_kiureghian.cc, "
              "simulate_pulse_type), not checked against the paper")
#: The probability that a near-fault motion carries a pulse (weights a site's pulse branch).
KIND = "pulse_occurrence"
#: The inputs of the logistic model, with the ranges of its directivity geometry (Somerville et al.
#: 1997, as the paper uses it): distances >= 0, the angle in [0, 90] degrees.
PARAMETERS = (
    Parameter("r", "km", (0.0, math.inf), "closest distance from the site to the rupture"),
    Parameter("s (d)", "km", (0.0, math.inf),
              "rupture length between epicentre (hypocentre) and site along strike (up dip)"),
    Parameter("theta (phi)", "deg", (0.0, 90.0), "angle between strike (dip) and the path to the site"),
)

#: (c0, c1, c2, c3) of the logistic model by mechanism (see the module docstring).
COEFFICIENTS = {
    "strike-slip": (0.457, 0.126, 0.244, 0.013),
    "non-strike-slip": (0.304, 0.072, 0.208, 0.021),
}
MECHANISMS = tuple(COEFFICIENTS)


def pulse_probability(r_km, s_km, angle_deg, mechanism="strike-slip"):
    """Probability of a pulse-like ground motion at a site (Shahi & Baker 2014).

    Parameters
    ----------
    r_km : float or array_like
        Closest distance from the site to the rupture, km (>= 0).
    s_km : float or array_like
        Directivity length, km (>= 0): ``s`` along strike for strike-slip ruptures, ``d`` up dip
        for the others.
    angle_deg : float or array_like
        Directivity angle, degrees in [0, 90]: ``theta`` (strike-slip) or ``phi`` (others).
    mechanism : {"strike-slip", "non-strike-slip"}

    Returns
    -------
    float or ndarray
        P(pulse) in (0, 1), broadcast over the inputs.
    """
    try:
        coefficients = COEFFICIENTS[mechanism]
    except (KeyError, TypeError):
        raise ParameterError(f"mechanism must be one of {', '.join(MECHANISMS)}, got {mechanism!r}") from None
    return logistic_probability(coefficients, r_km, s_km, angle_deg)


def logistic_probability(coefficients, r_km, s_km, angle_deg):
    """1 / (1 + exp(c0 + c1 r - c2 sqrt(s) + c3 angle)) for ``coefficients`` (c0, c1, c2, c3), after the
    range checks of :data:`PARAMETERS`: the form every model of this family shares (the earlier one,
    :mod:`pycolfrag.ground_motion.shahi_baker_earlier`, too)."""
    c0, c1, c2, c3 = coefficients
    r, s, a = (np.asarray(v, dtype=float) for v in (r_km, s_km, angle_deg))
    for name, v, p in zip(("r_km", "s_km", "angle_deg"), (r, s, a), PARAMETERS):
        lo, hi = p.range
        if not np.all(np.isfinite(v)):
            raise ParameterError(f"{name} must be finite, got {v!r}")
        if np.any(v < lo):
            raise ParameterError(f"{name} must be >= {lo:g}, got {v!r}")
        if np.any(v > hi):
            raise ParameterError(f"{name} must be in [{lo:g}, {hi:g}] {p.unit}, got {v!r}")
    p = 1.0 / (1.0 + np.exp(c0 + c1 * r - c2 * np.sqrt(s) + c3 * a))
    return float(p) if p.ndim == 0 else p
