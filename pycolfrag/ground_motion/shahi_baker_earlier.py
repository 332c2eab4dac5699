"""The earlier Shahi & Baker pulse-occurrence model: an epistemic alternative to Shahi & Baker (2014).

Same logistic form as :mod:`pycolfrag.ground_motion.shahi_baker_2014`, fitted before the NGA-West2
reclassification of Shahi & Baker (2014)::

    non-strike-slip:  P(pulse | r, d, phi) = 1 / (1 + exp(1.483 + 0.124 r - 0.688 sqrt(d) + 0.022 phi))

(r: closest distance to the rupture, km; d: rupture length up dip between hypocentre and site, km;
phi: angle between the dip direction and the path to the site, degrees in [0, 90].) At the example
site's geometry (r 17.5 km, d 5 km, phi 30 degrees) it gives P = 0.059 against 0.151 from the 2014
model: the two are a real epistemic spread, and a site risk can be computed with either
(``model = "shahi_baker_earlier"`` in a site file's pulse table), each output naming the one used.

Provenance, stated as far as it is known here: the four coefficients are those an independent
check of this project's risk outputs quoted for the earlier Shahi & Baker model, found by it in two
public implementations. Neither those implementations nor the paper could be read where this
module was written, so the year and equation number of the publication are not given, and the
strike-slip coefficients of the same fit are not known: only ``non-strike-slip`` is offered, and a
strike-slip source asking for this model is refused (:data:`MECHANISMS`). The test reproduces the
formula with these numbers, not a figure of a paper.
"""
from __future__ import annotations

from pycolfrag.core.errors import ParameterError
from pycolfrag.ground_motion import shahi_baker_2014 as _sb14

__all__ = ["NAME", "KIND", "CITATION", "PROVENANCE", "PARAMETERS", "COEFFICIENTS", "MECHANISMS",
           "pulse_probability"]

#: Name in the registry (:mod:`pycolfrag.ground_motion.registry`).
NAME = "shahi_baker_earlier"
#: The probability that a near-fault motion carries a pulse (weights a site's pulse branch).
KIND = "pulse_occurrence"
#: How the outputs of a site risk cite the model.
CITATION = "earlier Shahi & Baker model"
#: Where the coefficients come from (printed with every site risk that uses them).
PROVENANCE = ("coefficients quoted by an independent check of pycolfrag's risk from two public "
              "implementations of the earlier Shahi & Baker model; not checked against the paper; "
              "non-strike-slip only")
#: The same inputs and ranges as the 2014 model.
PARAMETERS = _sb14.PARAMETERS
#: (c0, c1, c2, c3) by mechanism; only the non-strike-slip fit is known here (module docstring).
COEFFICIENTS = {"non-strike-slip": (1.483, 0.124, 0.688, 0.022)}
MECHANISMS = tuple(COEFFICIENTS)


def pulse_probability(r_km, s_km, angle_deg, mechanism="non-strike-slip"):
    """Probability of a pulse-like motion by the earlier model (arguments as
    :func:`pycolfrag.ground_motion.shahi_baker_2014.pulse_probability`; ``s_km`` is d, ``angle_deg`` phi)."""
    try:
        coefficients = COEFFICIENTS[mechanism]
    except (KeyError, TypeError):
        raise ParameterError(f"mechanism must be one of {', '.join(MECHANISMS)} for the earlier Shahi & Baker "
                             f"model (its strike-slip coefficients are not known here), got {mechanism!r}") from None
    return _sb14.logistic_probability(coefficients, r_km, s_km, angle_deg)
