"""Fits that are not estimates: the warning they raise and the smallest sample a fit is called
well-posed on."""
from __future__ import annotations


#: Fewest values a fit is called well-posed on: the standing runs with EDP > 0 behind the lognormal
#: part of Eq. (4), or the runs of a maximum-likelihood fragility curve (two parameters). The stripe
#: curves' ``min_count`` default is the same number.
MIN_FIT_POINTS = 5


class DegenerateFitWarning(UserWarning):
    """A fit that rests on too few values, sits on a bound of its optimiser, or has no interior
    maximum: the number is returned (it is what the formula gives) but it is not an estimate."""


