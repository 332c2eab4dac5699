"""Aftershocks of a sequence's mainshocks: the Reasenberg & Jones (1989) rate, with the generic parameters of
Reasenberg & Jones (1989) for California or of Page et al. (2016) by tectonic region (docs/sequences.md,
"Aftershocks").

Reasenberg, P. A. & Jones, L. M. (1989), "Earthquake hazard after a mainshock in California", Science 243
(4895): 1173-1176, doi:10.1126/science.243.4895.1173. The rate of aftershocks of magnitude M or larger t days
after a mainshock of magnitude Mm is the modified Omori law (Utsu 1961) times the Gutenberg-Richter law::

    lambda(t, M) = 10 ** (a + b (Mm - M)) (t + c) ** -p

with the paper's *generic California* parameters a = -1.67, b = 0.91, p = 1.08, c = 0.05 days (the values the
USGS's aftershock forecasts used for three decades; their provenance is restated by Hardebeck et al. 2018,
"Updated California aftershock parameters", Seismol. Res. Lett. 90(1): 262-270, doi:10.1785/0220180240, whose
abstract says the generic productivity is higher than the sequences since 1980 give: these parameters are, if
anything, productive): :data:`REASENBERG_JONES_1989`, the fields' defaults.

Page, M. T., van der Elst, N., Hardebeck, J., Felzer, K. & Michael, A. J. (2016), "Three ingredients for improved
global aftershock forecasts: tectonic region, time-dependent catalog incompleteness, and intersequence
variability", Bull. Seismol. Soc. Am. 106(5): 2290-2301, doi:10.1785/0120160073, fit the same rate, per tectonic
region, to the NEIC catalogue 1990-2015 (mainshocks M >= 6 shallower than 50 km, aftershocks M >= 4.5 within 10
days, with a time-dependent completeness: the authors' code, github mtpage/Aftershocks, RunAftershockCodes.m),
b = 1 and c = 0.018 days held for every region. :data:`PAGE_2016` is their table as the USGS's operational
forecasts read it (opensha/opensha-oaf, src/main/resources/org/opensha/oaf/rj/PageEtAlGenericParams_032116.csv,
which GenericRJ_Parameters.java calls "the Generic Reasenberg-Jones parameters defined by Page et al. (2016,
BSSA)"). Page's a goes with b = 1: it is not interchangeable with Reasenberg & Jones's a, which goes with
b = 0.91 (the two give different counts below the mainshock's magnitude even at one a).

Which a of Page's: the maximum-likelihood a of the region's sequences pooled (with its p), the one fixed a that
keeps the sequences' mean count; the spread of a between sequences (Page's intersequence variability) is not
modelled, and Page's 10-day fit is extended to the window here (docs/sequences.md, "Aftershocks", says why and by
how much).

No Greece-specific parameters of this form were found (the search is in docs/sequences.md, which also says which
Page region Greek places fall in); every parameter is a field, and :data:`AFTERSHOCK_MODELS` names the published
sets (:func:`aftershock_model`).

The expected number of aftershocks of magnitude >= M in [t1, t2] days is the closed form

    N = 10 ** (a + b (Mm - M)) [ (t1 + c) ** (1 - p) - (t2 + c) ** (1 - p) ] / (p - 1)     (p != 1)

(``ln((t2 + c) / (t1 + c))`` at p = 1). A mainshock's aftershocks are drawn as that Poisson process over
``window_days`` with magnitudes >= ``m_min``: their count Poisson(N), their times by the inverse of the Omori
law's distribution over the window, their magnitudes by Gutenberg-Richter's exponential of slope b above
``m_min`` (no upper bound: the model does not bound an aftershock by its mainshock; one larger than the
mainshock occurs with the paper's probability, and the ground-motion models' range drops what lies beyond it).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from pycolfrag.core.errors import ParameterError

#: Days in a (Julian) year: the aftershocks' clock (days) against the sequences' (years).
DAYS_PER_YEAR = 365.25

__all__ = ["Aftershocks", "REASENBERG_JONES_1989", "DAYS_PER_YEAR", "PAGE_2016", "PAGE_2016_B", "PAGE_2016_C_DAYS",
           "AFTERSHOCK_MODELS", "DEFAULT_AFTERSHOCK_MODEL", "aftershock_model"]


@dataclass(frozen=True)
class Aftershocks:
    """The Reasenberg & Jones (1989) aftershock rate (see the module's text): ``a``, ``b``, ``p``, ``c_days``, the
    smallest aftershock drawn ``m_min`` and the window after each mainshock ``window_days``. The defaults are the
    generic California parameters (:data:`REASENBERG_JONES_1989`); :data:`AFTERSHOCK_MODELS` holds the others."""

    a: float = -1.67
    b: float = 0.91
    p: float = 1.08
    c_days: float = 0.05
    m_min: float = 5.0
    window_days: float = DAYS_PER_YEAR

    def __post_init__(self):
        for name in ("a", "b", "p", "c_days", "m_min", "window_days"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
                raise ParameterError(f"aftershocks: {name} must be a finite number, got {v!r}")
        for name in ("b", "p", "c_days", "window_days"):
            if getattr(self, name) <= 0:
                raise ParameterError(f"aftershocks: {name} must be > 0, got {getattr(self, name)!r}")

    def _omori(self, t1: float, t2: float) -> float:
        """The integral of (t + c) ** -p over [t1, t2] days."""
        c, p = self.c_days, self.p
        if p == 1.0:
            return math.log((t2 + c) / (t1 + c))
        return ((t1 + c) ** (1.0 - p) - (t2 + c) ** (1.0 - p)) / (p - 1.0)

    def expected(self, mw_main: float, t1_days: float = 0.0, t2_days: float | None = None,
                 m: float | None = None) -> float:
        """The expected number of aftershocks of magnitude >= ``m`` (default ``m_min``) in [t1, t2] days (default:
        the window) after a mainshock of ``mw_main``: the closed form of the module's text."""
        t2 = self.window_days if t2_days is None else t2_days
        if not 0.0 <= t1_days <= t2:
            raise ParameterError(f"aftershocks: the window [{t1_days!r}, {t2!r}] days is not 0 <= t1 <= t2")
        m = self.m_min if m is None else m
        return 10.0 ** (self.a + self.b * (mw_main - m)) * self._omori(t1_days, t2)

    def sample(self, mw_main: float, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
        """(times in days after the mainshock, sorted; magnitudes) of one mainshock's aftershocks >= ``m_min``."""
        n = int(rng.poisson(self.expected(mw_main)))
        u, v = rng.uniform(size=n), rng.uniform(size=n)
        c, p, w = self.c_days, self.p, self.window_days
        if p == 1.0:
            t = c * ((w + c) / c) ** u - c
        else:
            lo, hi = c ** (1.0 - p), (w + c) ** (1.0 - p)
            t = (lo + u * (hi - lo)) ** (1.0 / (1.0 - p)) - c
        mags = self.m_min - np.log10(1.0 - v) / self.b
        order = np.argsort(t, kind="stable")
        return np.clip(t[order], 0.0, w), mags[order]


#: The paper's generic California parameters, aftershocks of Mw >= 5 within a year.
REASENBERG_JONES_1989 = Aftershocks()


#: Page et al. (2016)'s generic parameters by tectonic region, region -> (a, p): the maximum-likelihood a and p of
#: the region's sequences pooled, columns aValue_MaxLike and pValue_MaxLike of PageEtAlGenericParams_032116.csv
#: (opensha/opensha-oaf, last changed by commit 20431f4; the names as there, trailing spaces stripped), every row.
#: Every region has b = :data:`PAGE_2016_B` and c = :data:`PAGE_2016_C_DAYS` (columns bValue, cValue).
PAGE_2016 = {
    "ANSR-ABSLDEC": (-2.04, 1.01),
    "ANSR-ABSLOCB": (-2.00, 0.64),
    "ANSR-ABSLSHC": (-2.44, 1.06),
    "ANSR-DEEPCON": (-2.01, 0.98),
    "ANSR-HOTSPOT": (-2.84, 1.12),
    "ANSR-OCEANBD": (-2.69, 1.08),
    "ANSR-SHALCON": (-2.16, 0.98),
    "SCR-GENERIC": (-2.28, 0.73),
    "SOR-GENERIC": (-2.98, 0.97),
    "SZ-GENERIC": (-2.09, 0.88),
    "SZ-INLBACK": (-2.09, 0.86),
    "SZ-ONSHORE": (-2.02, 0.81),
    "SZ-OUTERTR": (-1.97, 0.92),
    "SCR-ABVSLAB": (-2.28, 0.73),
    "SOR-ABVSLAB": (-2.98, 0.97),
}
PAGE_2016_B = 1.0
PAGE_2016_C_DAYS = 0.018

#: The published parameter sets by name (``pycolfrag sequences --aftershocks NAME``): "rj1989" and, for every
#: region of :data:`PAGE_2016`, "page2016-" and the region in lower case; aftershocks of Mw >= 5 within a year.
AFTERSHOCK_MODELS = {
    "rj1989": REASENBERG_JONES_1989,
    **{"page2016-" + region.lower(): Aftershocks(a=a, b=PAGE_2016_B, p=p, c_days=PAGE_2016_C_DAYS)
       for region, (a, p) in PAGE_2016.items()},
}
#: The model a bare ``--aftershocks`` means.
DEFAULT_AFTERSHOCK_MODEL = "rj1989"


def aftershock_model(name: str) -> Aftershocks:
    """The parameter set of :data:`AFTERSHOCK_MODELS` called ``name``, or ParameterError naming it and the known
    names."""
    try:
        return AFTERSHOCK_MODELS[name]
    except (KeyError, TypeError):
        raise ParameterError(f"unknown aftershock model {name!r} (known: {', '.join(AFTERSHOCK_MODELS)})") from None
