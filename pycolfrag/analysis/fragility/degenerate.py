"""Fits that are not estimates: the warning they raise, its causes, and one warning per cause for a
command that makes many fits.

A degenerate fit keeps its value (it is what the formula gives) and says why in its ``degenerate``
text; the warning it raises carries the causes as keys of :data:`CAUSES`, so that a command fitting
hundreds of groups can say once per cause how many fits it concerns (:func:`one_warning_per_cause`)
instead of once per fit.
"""
from __future__ import annotations

import contextlib
import warnings

#: Fewest values a fit is called well-posed on: the standing runs with EDP > 0 behind the lognormal
#: part of Eq. (4), or the runs of a maximum-likelihood fragility curve (two parameters). The stripe
#: curves' ``min_count`` default is the same number.
MIN_FIT_POINTS = 5

#: Every cause of a degenerate fit, by key: what one summary line says of all fits with that cause.
CAUSES = {
    "few_runs": f"fewer than {MIN_FIT_POINTS} runs behind the fit",
    "few_standing": f"fewer than {MIN_FIT_POINTS} standing runs with EDP > 0 behind Eq. (4)'s lognormal part",
    "equal_edps": "the standing EDPs are all equal (beta = 0: Eq. (4)'s lognormal part is a step)",
    "one_im_level": "every run at one IM level: the median and beta cannot be told apart",
    "separable": "the exceeding runs lie on one side of the others in IM: the likelihood has no finite maximum",
    "on_bound": "a parameter on the optimiser's bound",
    "one_per_stratum": "one run per bootstrap stratum: the resamples cannot vary, no interval",
}


class DegenerateFitWarning(UserWarning):
    """A fit that rests on too few values, sits on a bound of its optimiser, or has no interior
    maximum: the number is returned (it is what the formula gives) but it is not an estimate.

    ``causes``: keys of :data:`CAUSES` (empty for a warning raised by other code with a message only)."""

    def __init__(self, message: str = "", causes=()):
        super().__init__(message)
        self.causes = tuple(causes)


def warn(message: str, causes, stacklevel: int = 2) -> None:
    """Raise a :class:`DegenerateFitWarning` with its causes (``stacklevel`` counted from the caller)."""
    warnings.warn(DegenerateFitWarning(message, causes), stacklevel=stacklevel + 1)


@contextlib.contextmanager
def one_warning_per_cause(what: str):
    """Collect the :class:`DegenerateFitWarning`\\ s raised inside and, on leaving, raise one per cause:
    how many of ``what`` (e.g. "limit-state fits") it concerns, what the cause is, and the first fit's
    own message as an example (also when the block ends in an exception). Other warnings pass through
    unchanged."""
    caught: list = []
    try:
        with warnings.catch_warnings(record=True) as seen:
            warnings.simplefilter("always", DegenerateFitWarning)
            try:
                yield
            finally:
                caught = list(seen)
    finally:
        _summarise(caught, what)   # after the recording ends, so that the summaries reach the caller's filters


def _summarise(seen, what: str) -> None:
    counts: dict = {}
    for w in seen:
        if not issubclass(w.category, DegenerateFitWarning):
            warnings.warn_explicit(w.message, w.category, w.filename, w.lineno)
            continue
        for cause in getattr(w.message, "causes", ()) or ("other",):
            n, example = counts.get(cause, (0, str(w.message)))
            counts[cause] = (n + 1, example)
    for cause, (n, example) in counts.items():
        text = CAUSES.get(cause, "degenerate")
        warnings.warn(DegenerateFitWarning(f"{n} {what}: {text} (e.g. {example})", (cause,)), stacklevel=4)
