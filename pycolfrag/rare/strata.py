"""Strata of a site's events: source x Mw bin x R bin x pulse occurrence, with exact rates.

The annual rate of every exceedance is a sum over strata, ``lambda = sum_h W_h E_h[y]``, where the
stratum rate is the quadrature

    W_h = nu_k * P(M in Mw bin) * int_{R bin} f_k(r) g(r) dr,   g = p(r) (pulse) or 1 - p(r) (no pulse)

(``nu_k`` the source's rate, ``f_k`` its distance density, ``p`` its pulse-occurrence model averaged
over the directivity geometry). Inside a stratum, Mw and R are drawn from the source's densities
restricted to the bins (inverse CDFs of uniforms ``Phi(z)``), and the pulse occurrence enters as the
*occurrence weight* ``g(R) / mean g`` of the bin, whose mean over the bin is 1. The bins end at the
limits of the ground-motion models (a stratum lies wholly inside or wholly outside them) and at the
grid's range (5 and 20 km, the magnitudes 5.5-7.5 are bin edges), so that the part of lambda inside a
grid's range is a sum over whole strata.

A site source gives its cells through the one interface of
:class:`pycolfrag.site.sources.SiteSource` (``cells``, :mod:`pycolfrag.site.cells`): exact bins of
independent magnitude and distance models, or any source's quadrature nodes grouped by the bins; this
module assumes nothing else about a source (its ``name``, ``rate`` and ``pulse`` model).
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from pycolfrag.core.errors import ParameterError
from pycolfrag.site.cells import phi

__all__ = ["DEFAULT_MW_STEP", "DEFAULT_R_EDGES_KM", "ModelRange", "model_ranges", "Stratum", "OutsideShare",
           "Strata", "build_strata", "phi"]

#: Width of the magnitude bins: the grid's nodes (5.5, 6.0, ...) and the midpoints between them are edges.
DEFAULT_MW_STEP = 0.25
#: Distance bin edges, km: log-spaced, with the grid's range 5-20 km and the pulse model's 60 km limit among them.
DEFAULT_R_EDGES_KM = (2.0, 3.5, 5.0, 7.5, 10.0, 15.0, 20.0, 30.0, 45.0, 60.0, 100.0, 200.0)
#: Tolerance of "on an edge", in Mw and km.
_EDGE_TOL = 1e-9


@dataclass(frozen=True)
class ModelRange:
    """Where the ground-motion models of one branch apply: Mw in [lo, hi], R in (0, r_max] km."""

    mw: tuple
    r_max_km: float
    models: str

    def holds(self, mw: tuple, r_km: tuple) -> bool:
        return (mw[0] >= self.mw[0] - _EDGE_TOL and mw[1] <= self.mw[1] + _EDGE_TOL
                and r_km[1] <= self.r_max_km + _EDGE_TOL)


def model_ranges() -> dict:
    """The model range of each branch: the stochastic record alone (Atkinson & Silva 2000's generator),
    and with a pulse (that generator and the pulse model's Eqs. 6-7, Rupakhety et al. 2011), both read
    from the models' own declarations."""
    from pycolfrag.ground_motion import atkinson_silva_2000 as as00  # loads C (its ranges are the C generator's)
    from pycolfrag.ground_motion import rupakhety_2011 as r11
    hf = ModelRange(tuple(as00.MW_RANGE), float(as00.DIST_MAX_KM), as00.NAME)
    pulse = ModelRange((max(hf.mw[0], r11.MW_RANGE[0]), min(hf.mw[1], r11.MW_RANGE[1])),
                       min(hf.r_max_km, r11.DIST_RANGE_KM[1]), f"{as00.NAME} and {r11.NAME}")
    return {False: hf, True: pulse}


@dataclass(frozen=True)
class Stratum:
    """One stratum: a source's events in a Mw bin and an R bin, with or without a pulse.

    ``mw`` and ``r_km`` are (lo, hi); lo == hi is one value (a characteristic magnitude, a fixed or
    discrete distance). ``rate`` is W_h (1/yr); ``mean_g`` the bin's mean of p(R) (pulse) or 1 - p(R)."""

    index: int
    source: int
    source_name: str
    pulse: bool
    mw: tuple
    r_km: tuple
    rate: float
    mean_g: float
    #: the source's cell it was cut from (:class:`pycolfrag.site.cells.Cell`): how its events are placed
    cell: object = field(default=None, compare=False, repr=False)

    def as_dict(self) -> dict:
        return {"index": self.index, "source": self.source, "source_name": self.source_name,
                "pulse": int(self.pulse), "mw": list(self.mw), "r_km": list(self.r_km), "rate_per_yr": self.rate,
                "mean_g": self.mean_g}

    def inside(self, mw_range, r_range) -> bool:
        """Whether the stratum lies inside the box Mw in ``mw_range`` x R in ``r_range`` (km)."""
        return (self.mw[0] >= mw_range[0] - _EDGE_TOL and self.mw[1] <= mw_range[1] + _EDGE_TOL
                and self.r_km[0] >= r_range[0] - _EDGE_TOL and self.r_km[1] <= r_range[1] + _EDGE_TOL)

    def straddles(self, mw_range, r_range) -> bool:
        """Whether the stratum lies partly inside and partly outside the box (a box edge cuts one of its
        bins): its part inside is then not a sum over whole strata."""
        def cuts(lo, hi, edge):
            return lo + _EDGE_TOL < edge < hi - _EDGE_TOL
        m, r = self.mw, self.r_km
        overlaps = (m[1] >= mw_range[0] - _EDGE_TOL and m[0] <= mw_range[1] + _EDGE_TOL
                    and r[1] >= r_range[0] - _EDGE_TOL and r[0] <= r_range[1] + _EDGE_TOL)
        return overlaps and any(cuts(lo, hi, e) for (lo, hi), box in ((m, mw_range), (r, r_range)) for e in box)


@dataclass(frozen=True)
class OutsideShare:
    """The part of one source's rate where the branch's models do not apply, as fractions of its rate."""

    source: str
    rate: float
    pulse: float
    no_pulse: float
    mw_below: float
    mw_above: float
    r_above: float

    @property
    def outside(self) -> float:
        return self.pulse + self.no_pulse

    def as_dict(self) -> dict:
        return {**self.__dict__, "outside": self.outside}

    def text(self) -> str:
        return (f"{self.source!r}: {self.outside:.3g} of its rate (pulse branch {self.pulse:.3g}, no-pulse "
                f"{self.no_pulse:.3g}; Mw below the models {self.mw_below:.3g}, above {self.mw_above:.3g}, R beyond "
                f"{self.r_above:.3g})")


@dataclass(frozen=True)
class Strata:
    """The strata of a site (those of positive rate where the models apply), the part of each source
    outside the models' ranges, and the site's total event rate."""

    strata: tuple
    outside: tuple
    total_rate: float
    sources: tuple
    ranges: dict

    def __len__(self) -> int:
        return len(self.strata)

    def __getitem__(self, h: int) -> Stratum:
        return self.strata[h]

    @property
    def rates(self) -> np.ndarray:
        return np.array([s.rate for s in self.strata])

    def place(self, h: int, z_mw: float, z_dist: float) -> tuple[float, float]:
        """(Mw, R km) of an event of stratum ``h`` from two standard normals, as its source's cell places it
        (independent models: Mw and R at CDF fractions Phi(z) of the densities restricted to the bins)."""
        return self.strata[h].cell.place(z_mw, z_dist)

    def occurrence_weight(self, h: int, r_km):
        """g(R) / the bin's mean g: the pulse occurrence of an event of stratum ``h`` at distance R."""
        st = self.strata[h]
        p = np.asarray(self.sources[st.source].pulse.mean_probability(np.asarray(r_km, dtype=float)), dtype=float)
        g = p if st.pulse else 1.0 - p
        out = g / st.mean_g
        return float(out) if np.ndim(out) == 0 else out

    def as_dict(self) -> dict:
        return {"strata": [s.as_dict() for s in self.strata], "outside": [o.as_dict() for o in self.outside],
                "total_rate_per_yr": self.total_rate}


def build_strata(site, mw_step: float = DEFAULT_MW_STEP, r_edges_km=DEFAULT_R_EDGES_KM) -> Strata:
    """The strata of a site's sources (see the module docstring).

    Bins: magnitudes at multiples of ``mw_step`` and the models' magnitude limits; distances at
    ``r_edges_km`` and the models' distance limits; one bin per atom of a discrete model. A stratum of
    zero rate is left out. Where the models do not apply, the site file's ``outside`` decides: ``zero``
    drops that part (reported in :attr:`Strata.outside`); otherwise the site is refused with the
    fractions, as the grid route refuses a site beyond its grid. A site none of whose events lies where
    the models apply is always refused.
    """
    ranges = model_ranges()
    mw_inner = [ranges[b].mw[i] for b in (False, True) for i in (0, 1)]
    r_inner = list(r_edges_km) + [ranges[b].r_max_km for b in (False, True)]
    strata, outside, kept = [], [], 0.0
    for k, s in enumerate(site.sources):
        if not callable(getattr(s, "cells", None)):
            raise ParameterError(f"source {getattr(s, 'name', k)!r} ({type(s).__name__}) is not a site source "
                                 "(pycolfrag.site.sources.SiteSource): it gives no cells to stratify")
        lost = {"pulse": 0.0, "no_pulse": 0.0, "mw_below": 0.0, "mw_above": 0.0, "r_above": 0.0}
        for cell in s.cells(mw_step, mw_inner, r_inner):
            for branch in (False, True):
                rate = cell.rate[branch]
                if rate <= 0.0:
                    continue
                rg = ranges[branch]
                if rg.holds(cell.mw, cell.r_km):
                    strata.append(Stratum(len(strata), k, s.name, branch, cell.mw, cell.r_km, rate,
                                          cell.mean_g[branch], cell))
                    kept += rate
                    continue
                share = rate / s.rate
                lost["pulse" if branch else "no_pulse"] += share
                lost["mw_below" if cell.mw[1] <= rg.mw[0] + _EDGE_TOL else "mw_above" if cell.mw[0] >= rg.mw[1] - _EDGE_TOL
                     else "r_above"] += share
        outside.append(OutsideShare(s.name, s.rate, **lost))
    _refuse_outside(site, outside, kept, ranges)
    return Strata(tuple(strata), tuple(outside), float(sum(s.rate for s in site.sources)), tuple(site.sources),
                  ranges)


def _refuse_outside(site, outside, kept: float, ranges) -> None:
    where = (f"Mw {ranges[False].mw[0]:g}-{ranges[False].mw[1]:g}, R up to {ranges[False].r_max_km:g} km without "
             f"a pulse ({ranges[False].models}); Mw {ranges[True].mw[0]:g}-{ranges[True].mw[1]:g}, R up to "
             f"{ranges[True].r_max_km:g} km with one ({ranges[True].models})")
    shares = "; ".join(o.text() for o in outside if o.outside > 0)
    if kept <= 0.0:
        raise ParameterError(f"no event of the site's sources lies where the ground-motion models apply ({where}): "
                             f"{shares or 'every source has a rate of 0'}; nothing can be simulated")
    if shares and site.outside != "zero":
        raise ParameterError(
            f"sources lie partly where the ground-motion models do not apply ({where}): {shares}. Set outside = "
            "'zero' in the site file (that part then contributes nothing, reported in every output), or change "
            "the sources ('clamp' has no meaning here: the models' edge is not an estimate of what lies beyond it)")
