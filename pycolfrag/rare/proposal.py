"""Importance sampling of the pulse quantiles: a defensive mixture, its weights, the cross-entropy step.

Inside the strata with a pulse, the pulse amplitude and period quantiles z = (z_vp, z_fp) -- standard
normal under the site's model -- are drawn from a *defensive mixture* (Hesterberg 1995)

    q(z) = alpha_0 phi_2(z) + sum_c alpha_c phi_2(z - mu_c),

whose nominal component bounds every weight: phi_2 / q <= 1 / alpha_0, so Kong's relative effective
sample size of the pulse factor is at least alpha_0 whatever the shifts. The other pulse normals
(phase, gamma) and the record's noise keep the site's density. A row weighs phi_2(z) / q(z), q the whole
mixture of its stage and not the component that drew it: the *balance heuristic* over the mixture's
components (Veach & Guibas 1995; Owen & Zhou 2000). The pilot's rows keep the pilot's mixture: pooling
them with the production rows under one mixture of both would re-weight the rows that placed the
production mixture by the mixture they placed (a bias, measured in docs/rare_events.md).

The shifts mu_c come from a cross-entropy step (Rubinstein 1999; de Boer et al. 2005) on the pilot:
for the Gaussian-mean family its program has the closed form mu = sum_i c_i z_i / sum_i c_i over the
pilot rows of an *elite* set, c_i a row's contribution to the rate (W_h w_i / n_h). One shift per
family of levels (the top displacement's levels with collapse; the dislocation's), the elite set being
the rarest level of the family that the pilot exceeded often enough, else the rows above the weighted
quantile of the family's continuous EDP (at least the ``min_hits`` highest: an elite of one run made the shift
that run's normals). Where no level of a family was exceeded by ``min_hits`` runs (:func:`thin_families`), the driver takes a *second step* after the first production batch: the same
program on every row so far, each weighted under its own stage's mixture, places the proposal of the
batches from stage 2 on (:attr:`Design.second`).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from pycolfrag.core import names as _names
from pycolfrag.core.errors import ParameterError

__all__ = ["Mixture", "Design", "PILOT_MIXTURE", "production_mixture", "FAMILIES", "COLLAPSE_FAMILY", "family_of",
           "families_of", "score",
           "cross_entropy_means", "thin_families", "MEAN_DECIMALS"]

#: The shifts are rounded to 1e-6 before they are stored and used (a replay compares them as stored).
MEAN_DECIMALS = 6
#: Families of levels that share a shift: the EDP a level reads, any EDP a results file stores (the one EDP
#: table, :data:`pycolfrag.core.names.EDPS`, in its order: a level on a new stored EDP is a family with no
#: edit here). Collapse counts as the top displacement's extreme (:data:`COLLAPSE_FAMILY`), and as every
#: level's exceedance.
FAMILIES = tuple(_names.EDPS)
#: The family of collapse: the top displacement's (a collapse is its extreme).
COLLAPSE_FAMILY = "u_top"


@dataclass(frozen=True)
class Mixture:
    """q(z) = alphas[0] phi_2(z) + sum_c alphas[c] phi_2(z - means[c - 1]) over z = (z_vp, z_fp)."""

    alphas: tuple
    means: tuple

    def __post_init__(self):
        a = tuple(float(x) for x in self.alphas)
        m = tuple(tuple(float(v) for v in mu) for mu in self.means)
        if len(a) != len(m) + 1 or any(not math.isfinite(x) or x < 0 for x in a) or abs(sum(a) - 1.0) > 1e-12:
            raise ParameterError(f"mixture weights must be >= 0, one more than the shifts, and sum to 1: {a}, {m}")
        if a[0] <= 0 or any(len(mu) != 2 or not all(map(math.isfinite, mu)) for mu in m):
            raise ParameterError(f"a defensive mixture needs alpha_0 > 0 and finite 2-D shifts: {a}, {m}")
        object.__setattr__(self, "alphas", a)
        object.__setattr__(self, "means", m)

    @property
    def bound(self) -> float:
        """The largest phi_2 / q: 1 / alpha_0."""
        return 1.0 / self.alphas[0]

    def component(self, u: float) -> int:
        """The component whose share of [0, 1) holds ``u`` (components in order, 0 the nominal one)."""
        acc = 0.0
        for k, a in enumerate(self.alphas[:-1]):
            acc += a
            if u < acc:
                return k
        return len(self.alphas) - 1

    def shift(self, k: int) -> tuple:
        return (0.0, 0.0) if k == 0 else self.means[k - 1]

    def q_over_phi(self, z) -> np.ndarray:
        """q(z) / phi_2(z) = alpha_0 + sum_c alpha_c exp(mu_c . z - |mu_c|^2 / 2), rows of ``z`` (n, 2)."""
        z = np.atleast_2d(np.asarray(z, dtype=float))
        out = np.full(z.shape[0], self.alphas[0])
        with np.errstate(over="ignore"):
            for a, mu in zip(self.alphas[1:], self.means):
                mu = np.asarray(mu)
                out = out + a * np.exp(z @ mu - 0.5 * float(mu @ mu))
        return out

    def ratio(self, z) -> np.ndarray:
        """phi_2(z) / q(z) of rows of ``z`` (n, 2): at most :attr:`bound`."""
        return 1.0 / self.q_over_phi(z)

    def as_dict(self) -> dict:
        return {"alphas": list(self.alphas), "means": [list(m) for m in self.means]}

    @classmethod
    def from_dict(cls, d) -> "Mixture":
        return cls(tuple(d["alphas"]), tuple(tuple(m) for m in d["means"]))


#: The pilot's proposal: half nominal, half shifted one standard deviation up in Vp (a motion must be
#: strong for the rare levels, and the pilot must see some of them to place the production shifts).
PILOT_MIXTURE = Mixture((0.5, 0.5), ((1.0, 0.0),))


def production_mixture(alpha0: float, means) -> Mixture:
    """alpha_0 phi_2 + the shifts with equal shares of 1 - alpha_0."""
    means = tuple(means)
    if not means:
        return Mixture((1.0,), ())
    rest = (1.0 - alpha0) / len(means)
    return Mixture((alpha0,) + (rest,) * len(means), means)


def family_of(q) -> str:
    """The family of a level: its EDP (collapse: :data:`COLLAPSE_FAMILY`); ParameterError for an EDP that
    results files do not store."""
    fam = q.edp or COLLAPSE_FAMILY
    if fam not in _names.EDPS:
        raise ParameterError(f"level {q.label!r} reads {fam!r}, which is not an EDP of the results files "
                             f"(pycolfrag.core.names.EDPS: {', '.join(_names.EDPS)})")
    return fam


def families_of(levels) -> tuple:
    """The families of ``levels``, each once, in :data:`FAMILIES` order."""
    mine = {family_of(q) for q in levels}
    return tuple(f for f in FAMILIES if f in mine)


def score(cols: dict, family: str) -> np.ndarray:
    """A family's continuous EDP of every row, +inf for a collapse (collapse exceeds every level)."""
    s = np.asarray(cols[family], dtype=float).copy()
    s[np.asarray(cols["collapsed"], dtype=bool)] = np.inf
    return s


def _weighted_quantile(x, c, q: float) -> float:
    order = np.argsort(x, kind="stable")
    cum = np.cumsum(c[order])
    return float(x[order][min(int(np.searchsorted(cum, q * cum[-1])), x.size - 1)])


def _elite(fam, z, contrib, y, scores, levels, min_hits: int, quantile: float):
    """(the elite rows of family ``fam``, the line saying how they were chosen, whether a level made it): the
    rows exceeding the rarest
    level of the family that at least ``min_hits`` rows exceed; else those at or above the family's weighted
    ``quantile`` of its EDP, widened to the ``min_hits`` highest scores where that holds fewer rows (an elite
    of one run would make the shift that run's normals)."""
    mine = [q for q in levels if family_of(q) == fam]
    rated = sorted(mine, key=lambda q: (float(np.sum(contrib * y[q.label])), q.label))
    pick = next((q for q in rated if int(np.sum(y[q.label])) >= min_hits), None)
    if pick is not None:
        elite = np.asarray(y[pick.label], dtype=bool)
        return elite, f"{pick.label} ({int(elite.sum())} runs exceed it)", True
    ok = np.isfinite(scores[fam]) | (scores[fam] == np.inf)
    sc = np.where(ok, scores[fam], -np.inf)
    cut = _weighted_quantile(sc, contrib, quantile)
    if int(np.sum(ok & (sc >= cut))) < min_hits and np.any(ok):
        cut = min(cut, float(np.sort(sc[ok])[::-1][min(min_hits, int(np.sum(ok))) - 1]))
    elite = ok & (sc >= cut)
    what = "collapse" if cut == np.inf else f"{fam} >= {cut:.4g}"
    return elite, (f"{what}, the family's weighted {quantile:g} quantile or its {min_hits} highest runs "
                   f"({int(elite.sum())} runs; no level of the family has {min_hits} exceeding runs)"), False


def thin_families(z, contrib, y, scores, levels, *, min_hits: int, quantile: float) -> tuple:
    """The families of ``levels`` whose elite set (:func:`cross_entropy_means`) is thin: no level of the family
    exceeded by ``min_hits`` rows (the shift aims at a quantile of the EDP, not at the levels), or fewer than
    ``min_hits`` rows with weight in it. The driver takes a second step for them."""
    out = []
    for fam in families_of(levels):
        elite, _, level = _elite(fam, z, contrib, y, scores, levels, min_hits, quantile)
        if not level or int(np.sum(elite & (contrib > 0))) < min_hits:
            out.append(fam)
    return tuple(out)


def cross_entropy_means(z, contrib, y, scores, levels, *, min_hits: int, quantile: float):
    """One cross-entropy step: a shift per family of the requested levels.

    Parameters
    ----------
    z : (n, 2) -- pulse quantiles of the rows with a pulse
    contrib : (n,) -- each row's contribution to the rate per unit outcome, W_h w_i / n_h
    y : dict label -> (n,) bool -- exceedances of each level
    scores : dict family -> (n,) -- the family's continuous EDP (+inf for collapse)
    levels : sequence of RiskQuantity-like (label, edp) -- the requested levels
    min_hits, quantile -- elite set: the rarest level of the family with at least ``min_hits``
        exceeding rows, else the rows at or above the family's weighted ``quantile`` of its EDP (at least
        the ``min_hits`` highest, :func:`_elite`)

    Returns
    -------
    (means, notes): the shifts (rounded to :data:`MEAN_DECIMALS`) in :data:`FAMILIES` order, one per
    family with a requested level, and one line per family saying how its shift was found.
    """
    means, notes = [], []
    for fam in families_of(levels):
        elite, why, _ = _elite(fam, z, contrib, y, scores, levels, min_hits, quantile)
        c = contrib * elite
        if not np.any(c > 0):
            mu = PILOT_MIXTURE.means[0]
            why += "; no weight in the elite set: the pilot's shift kept"
        else:
            mu = tuple(float(math.fsum(c * z[:, k]) / math.fsum(c)) for k in range(2))
        mu = tuple(round(v, MEAN_DECIMALS) + 0.0 for v in mu)
        means.append(mu)
        notes.append(f"{fam} family: shift (z_vp, z_fp) = ({mu[0]:+.3f}, {mu[1]:+.3f}) from {why}")
    return means, notes


@dataclass(frozen=True)
class Design:
    """The proposals of a site simulation: the pilot's (stage 0), the production batches' (stage 1, and every
    later stage without a second step; None until the cross-entropy step has placed it), the second step's
    (stages 2 on, when the first step's elite was thin), with the lines saying how."""

    pilot: Mixture = PILOT_MIXTURE
    production: Mixture | None = None
    notes: tuple = ()
    second: Mixture | None = None

    def proposal_of(self, stage: int) -> int:
        """0: the pilot's proposal; 1: the production batches'; 2: the second step's (stages 2 on)."""
        return 0 if int(stage) == 0 else 2 if (self.second is not None and int(stage) >= 2) else 1

    @property
    def latest(self) -> Mixture | None:
        """The proposal of the batches still to come: the second step's, else the production one."""
        return self.second if self.second is not None else self.production

    def mixture(self, k: int) -> Mixture:
        m = self.pilot if k == 0 else self.production if k == 1 else self.second
        if m is None:
            raise ParameterError("the production proposal is not placed yet (no cross-entropy step)")
        return m

    def as_dict(self) -> dict:
        d = {"pilot": self.pilot.as_dict(),
             "production": None if self.production is None else self.production.as_dict(),
             "notes": list(self.notes)}
        if self.second is not None:
            d["second"] = self.second.as_dict()
        return d

    @classmethod
    def from_dict(cls, d) -> "Design":
        return cls(Mixture.from_dict(d["pilot"]),
                   None if d.get("production") is None else Mixture.from_dict(d["production"]), tuple(d.get("notes", ())),
                   None if d.get("second") is None else Mixture.from_dict(d["second"]))
