"""Validation document: the paper's quantitative statements side by side with a results file.

``write_validation(results_path, out_path, sensitivity={name: path, ...})`` writes Markdown
(``docs/validation.md`` via ``scripts/make_validation.py``).  Every statement of the paper that
carries a number is evaluated on our results with its sample size and a 90 % interval
(Clopper-Pearson for counts, percentile bootstrap otherwise), and gets a verdict by a criterion
stated in the table ("agrees", "differs", "not testable" when the grid lacks the scenario).  The
sensitivity section recomputes a few key numbers on other results files (pulse amplitude through
``--vp-scale``, joint stiffness, contact discretisation) so that differences can be attributed.

Paper values are read from the text of Psycharis, Fragiadakis & Stefanou (section and figure
given for each); "about" values read off figures are compared with a stated tolerance band.

EDP statistics use the non-collapsed runs only (a collapse counts as exceeding every level in
Eq. (4)); the EDPs stored for collapsed rows are never read (``u_d`` is NaN for them).
"""
from __future__ import annotations

import json
import os
import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy import stats

from pycolfrag.analysis import fragility as fr
from pycolfrag.analysis.completeness import check_complete
from pycolfrag.analysis.data import ResultsData, read_results
from pycolfrag.analysis.figures import ROCKING_INITIATION_G
from pycolfrag.analysis.fragility import binomial_ci
from pycolfrag.analysis.record_figures import PAPER_FIG10_MEAN_U_TOP
from pycolfrag.analysis.report import fmt_ci
from pycolfrag.core.errors import ParameterError

__all__ = ["Claim", "claims", "key_numbers", "write_validation"]

CONF = 0.90
N_BOOT = 2000


@dataclass
class Claim:
    """One quantitative statement of the paper and our number."""

    key: str
    where: str
    statement: str
    paper: str
    ours: str
    n: str
    criterion: str
    verdict: str
    comment: str = ""
    sens_key: str | None = None     # key number of the sensitivity table that tracks this claim
    degenerate: str = ""            # the degenerate fits behind ``ours`` (their warnings), "" when none


def _sel(d: ResultsData, mw=None, dist=None):
    m = np.ones(d.n, bool)
    if mw is not None:
        m &= np.isclose(d["mw"], mw)
    if dist is not None:
        m &= np.isclose(d["dist_km"], dist)
    return m


def _overlap(ci, band):
    return bool(np.isfinite(ci[0]) and ci[0] <= band[1] and ci[1] >= band[0])


def _boot_mean(x, rng):
    if x.size < 2:
        return (np.nan, np.nan)
    return fr.bootstrap_interval(x, np.zeros(x.size, bool), statistic="mean", n_boot=N_BOOT, confidence=CONF,
                                 rng=rng)


class _Estimate(tuple):
    """``(value, (low, high), n)`` of a number, with ``degenerate``: why it is not an estimate ("" when it is)."""

    degenerate = ""


def _eq4(d, mask, edp, threshold, rng):
    """Eq. (4) on the samples of ``mask`` with bootstrap CI; (p, ci, n) or (nan, nan-ci, 0)."""
    n = int(mask.sum())
    if n == 0:
        return _Estimate((np.nan, (np.nan, np.nan), 0))
    p = fr.exceedance(d[edp][mask], d["collapsed"][mask], threshold)
    ci = fr.bootstrap_interval(d[edp][mask], d["collapsed"][mask], threshold, n_boot=N_BOOT, confidence=CONF,
                               rng=rng)
    out = _Estimate((p, ci, n))
    out.degenerate = fr.eq4_degenerate(d[edp][mask], d["collapsed"][mask])
    return out


class _Claims(list):
    """The claims of a group of statements. Each appended claim takes as its ``degenerate`` mark the
    degenerate-fit warnings raised since the claim before it: those of the fits behind its number."""

    def __init__(self, seen: list):
        super().__init__()
        self._seen, self._k = seen, len(seen)

    def append(self, claim) -> None:
        new = [str(w.message) for w in self._seen[self._k:] if issubclass(w.category, fr.DegenerateFitWarning)]
        self._k = len(self._seen)
        if new:
            claim.degenerate = f"{len(new)} degenerate fit(s), e.g. {new[0]}"
        super().append(claim)


def _ratio_ci(a, b, rng):
    """Percentile bootstrap CI of mean(b) / mean(a), the two groups resampled independently
    (``scipy.stats.bootstrap`` with ``paired=False``)."""
    if a.size < 2 or b.size < 2:
        return (np.nan, np.nan)
    res = stats.bootstrap((a, b), lambda x, y, axis=-1: np.mean(y, axis=axis) / np.mean(x, axis=axis),
                          paired=False, vectorized=True, n_resamples=N_BOOT, confidence_level=CONF,
                          method="percentile", random_state=rng)
    return float(res.confidence_interval.low), float(res.confidence_interval.high)


# --------------------------------------------------------------------------- key numbers

KEY_NUMBERS = {
    "pc_75_5": "P(collapse), Mw 7.5, R 5 km (paper 0.40)",
    "pc_65_5": "P(collapse), Mw 6.5, R 5 km",
    "ut_65_20": "mean u_top (non-collapsed), Mw 6.5, R 20 km (paper about 0.4)",
    "ut_75_20": "mean u_top (non-collapsed), Mw 7.5, R 20 km (paper about 0.2)",
    "ratio_20": "ratio of the two means above (paper about 0.5)",
    "p035_65_5": "P(u_top > 0.35), Eq. (4), Mw 6.5, R 5 km",
    "p035_75_5": "P(u_top > 0.35), Eq. (4), Mw 7.5, R 5 km",
    "pd005_65_20": "P(u_d > 0.005), Eq. (4), Mw 6.5, R 20 km",
    "p035_pga03": "P(u_top > 0.35 | 0.25 g <= PGA <= 0.35 g), Eq. (4) (paper about 0.10)",
    "pgv_75_5": "mean PGV, Mw 7.5, R 5 km (cm/s)",
    "pgv_65_20": "mean PGV, Mw 6.5, R 20 km (cm/s)",
    "wall_s": "median wall time per run (s)",
}


def key_numbers(d: ResultsData, rng=0) -> dict:
    """The few numbers compared across results files: key -> (value, (low, high), n)."""
    g = np.random.default_rng(rng)
    out = {}
    for key, mw, r in (("pc_75_5", 7.5, 5.0), ("pc_65_5", 6.5, 5.0)):
        m = _sel(d, mw, r)
        k, n = int(d["collapsed"][m].sum()), int(m.sum())
        out[key] = ((k / n if n else np.nan), binomial_ci(k, n), n)
    means = {}
    for key, mw in (("ut_65_20", 6.5), ("ut_75_20", 7.5)):
        m = _sel(d, mw, 20.0) & ~d["collapsed"]
        x = d["u_top"][m]
        means[key] = x
        out[key] = ((float(x.mean()) if x.size else np.nan), _boot_mean(x, g), int(x.size))
    a, b = means["ut_65_20"], means["ut_75_20"]
    out["ratio_20"] = ((b.mean() / a.mean()) if a.size and b.size else np.nan, _ratio_ci(a, b, g),
                       int(a.size + b.size))
    out["p035_65_5"] = _eq4(d, _sel(d, 6.5, 5.0), "u_top", 0.35, g)
    out["p035_75_5"] = _eq4(d, _sel(d, 7.5, 5.0), "u_top", 0.35, g)
    out["pd005_65_20"] = _eq4(d, _sel(d, 6.5, 20.0), "u_d", 0.005, g)
    out["p035_pga03"] = _eq4(d, (d["pga_g"] >= 0.25) & (d["pga_g"] <= 0.35), "u_top", 0.35, g)
    for key, mw, r in (("pgv_75_5", 7.5, 5.0), ("pgv_65_20", 6.5, 20.0)):
        x = d["pgv_cm_s"][_sel(d, mw, r)]
        out[key] = ((float(x.mean()) if x.size else np.nan), _boot_mean(x, g), int(x.size))
    w = d["wall_s"] if "wall_s" in d.samples else np.array([np.nan])
    out["wall_s"] = (float(np.nanmedian(w)), (np.nan, np.nan), int(np.isfinite(w).sum()))
    return out


# --------------------------------------------------------------------------- the paper's statements

#: Verdict of a statement about a scenario the grid does not have.
NOT_IN_GRID = "not testable (scenario not in this grid)"


def claims(d: ResultsData, rng=0) -> list[Claim]:
    """Evaluate every quantitative statement of the paper on ``d`` (one bootstrap stream, drawn from in
    the statements' order). A claim whose number rests on degenerate fits says so in ``degenerate``; the
    fits' warnings are not repeated."""
    g = np.random.default_rng(rng)
    with warnings.catch_warnings(record=True) as seen:    # the claims carry them as their marks
        warnings.simplefilter("always", fr.DegenerateFitWarning)
        return (_claims_collapse_and_means(d, g, seen) + _claims_levels(d, g, seen) + _claims_ims(d, g, seen)
                + _claims_pooled(d, g, seen))


def _claims_collapse_and_means(d: ResultsData, g, seen: list) -> list[Claim]:
    """Statements 1-7: collapse probabilities and mean u_top."""
    c = d["collapsed"]
    out = _Claims(seen)
    grid_mw = np.unique(d["mw"])
    grid_r = np.unique(d["dist_km"])
    nt = NOT_IN_GRID
    # 1. collapse probability at Mw 7.5, R 5 km
    m = _sel(d, 7.5, 5.0)
    k, n = int(c[m].sum()), int(m.sum())
    ci = binomial_ci(k, n)
    out.append(Claim("collapse_75_5", "Fragility curves, Fig. 8c",
                     "for Mw = 7.5 and R = 5 km 40 % of the simulations caused collapse", "0.40",
                     fmt_ci(k / n if n else np.nan, ci), f"{k}/{n}", "0.40 inside our 90 % Clopper-Pearson interval",
                     nt if n == 0 else ("agrees" if ci[0] <= 0.40 <= ci[1] else "differs"), sens_key="pc_75_5"))

    # 2. practically no collapses below Mw 6.5
    m = d["mw"] < 6.5 - 1e-9
    k, n = int(c[m].sum()), int(m.sum())
    ci = binomial_ci(k, n)
    out.append(Claim("no_collapse_below_65", "Fragility curves, Fig. 8c; Fig. 11 text",
                     "practically zero collapses occurred for magnitudes less than 6.5", "about 0",
                     fmt_ci(k / n if n else np.nan, ci, 3), f"{k}/{n}",
                     "our collapse rate for Mw < 6.5 at most 0.02",
                     nt if n == 0 else ("agrees" if k / n <= 0.02 else "differs")))

    # 3-5. mean u_top at R = 20 km
    vals = {}
    for mw, band in ((6.5, (0.3, 0.5)), (7.5, (0.15, 0.25))):
        paper = f"about {PAPER_FIG10_MEAN_U_TOP[mw]:g}"
        mm = _sel(d, mw, 20.0) & ~c
        x = d["u_top"][mm]
        vals[mw] = x
        ci = _boot_mean(x, g)
        out.append(Claim(f"mean_utop_{int(mw * 10)}_20", "Fragility curves, Fig. 8a, Fig. 10",
                         f"for R = 20 km the mean u_top is {paper} for Mw = {mw}", paper,
                         fmt_ci(x.mean() if x.size else np.nan, ci), f"{x.size} non-collapsed",
                         f"our 90 % bootstrap interval overlaps {band[0]}-{band[1]} (value read off a figure)",
                         nt if x.size == 0 else ("agrees" if _overlap(ci, band) else "differs"),
                         sens_key=f"ut_{int(mw * 10)}_20"))
    a, b = vals[6.5], vals[7.5]
    ci = _ratio_ci(a, b, g)
    r = b.mean() / a.mean() if a.size and b.size else np.nan
    verdict = nt if not (a.size and b.size) else (
        "agrees" if ci[1] < 1 else ("differs" if ci[0] > 1 else "differs (no decrease resolved)"))
    out.append(Claim("ratio_20", "Fragility curves, Fig. 8a",
                     "at R = 20 km u_top at Mw 7.5 is reduced to one half of that at Mw 6.5 (PGV saturation)",
                     "about 0.5", fmt_ci(r, ci), f"{a.size} + {b.size}",
                     "ratio mean(7.5)/mean(6.5) < 1 with 90 % confidence (decrease), value compared with 0.5",
                     verdict, sens_key="ratio_20"))

    # 6. monotonic increase with Mw at short distance
    rmin = grid_r.min() if grid_r.size else np.nan
    means = [(mw, d["u_top"][_sel(d, mw, rmin) & ~c]) for mw in grid_mw]
    means = [(mw, x.mean()) for mw, x in means if x.size]
    mono = all(b2 >= a2 - 0.02 for (_, a2), (_, b2) in zip(means, means[1:]))
    out.append(Claim("monotonic_short_r", "Fragility curves, Fig. 8a",
                     "for R up to about 7.5 km mean u_top increases monotonically with Mw", "increasing",
                     ", ".join(f"Mw {mw:g}: {v:.3g}" for mw, v in means) + f" (R = {rmin:g} km)",
                     f"{len(means)} scenarios", "each step in Mw changes the mean by more than -0.02",
                     nt if len(means) < 2 or rmin > 7.5 else ("agrees" if mono else "differs")))

    # 7. max u_top without collapse
    x = d["u_top"][~c]
    out.append(Claim("max_utop_no_collapse", "Performance-based assessment (EDPs)",
                     "the maximum u_top attained without collapse was about 1.15", "about 1.15",
                     f"{x.max():.3g} (99th percentile {np.percentile(x, 99):.3g})" if x.size else "n/a",
                     f"{x.size} non-collapsed", "within 0.9-1.4 (a sample maximum: depends on n and the grid)",
                     "agrees" if x.size and 0.9 <= x.max() <= 1.4 else "differs"))

    return out


def _claims_levels(d: ResultsData, g, seen: list) -> list[Claim]:
    """Statements 8-14: the performance levels of Tables III and IV, and rocking initiation."""
    c = d["collapsed"]
    out = _Claims(seen)
    grid_mw = np.unique(d["mw"])
    grid_r = np.unique(d["dist_km"])
    nt = NOT_IN_GRID
    # 8-9. u_top > 0.15 levels
    m6 = _sel(d, 6.0)
    p, ci, n = _eq4(d, m6, "u_top", 0.15, g)
    out.append(Claim("p015_mw6", "Fragility curves, Fig. 12a",
                     "P(u_top > 0.15) is of the order of 0.2 for Mw = 6", "about 0.2",
                     fmt_ci(p, ci) + " (all R pooled)", f"{n}", "interval overlaps 0.1-0.3",
                     nt if n == 0 else ("agrees" if _overlap(ci, (0.1, 0.3)) else "differs")))
    p, ci, n = _eq4(d, _sel(d, 7.5, 5.0), "u_top", 0.15, g)
    out.append(Claim("p015_75_5", "Fragility curves, Fig. 12a",
                     "for Mw = 7.5, R = 5 km P(u_top > 0.15) is equal to unity", "1.0", fmt_ci(p, ci), f"{n}",
                     "upper limit of our interval >= 0.95", nt if n == 0 else ("agrees" if ci[1] >= 0.95 else "differs")))

    # 10. u_top > 1 surface coincides with collapse surface
    diffs = []
    for mw in grid_mw:
        for rr in grid_r:
            mm = _sel(d, mw, rr)
            if mm.sum():
                diffs.append(fr.exceedance(d["u_top"][mm], c[mm], 1.0) - c[mm].mean())
    diffs = np.array(diffs)
    out.append(Claim("utop1_vs_collapse", "Fragility curves, Fig. 12c vs Fig. 8c",
                     "the u_top > 1.0 surface practically coincides with the probability of collapse", "about 0",
                     f"max difference {np.max(np.abs(diffs)):.3f}, mean {np.mean(diffs):.3f}",
                     f"{diffs.size} scenarios", "max |P(u_top > 1) - P(C)| <= 0.10 over scenarios",
                     "agrees" if np.max(np.abs(diffs)) <= 0.10 else "differs"))

    # 11-13. u_d levels
    p, ci, n = _eq4(d, m6, "u_d", 0.005, g)
    out.append(Claim("pd005_mw6", "Fragility curves, Fig. 13a",
                     "P(u_d > 0.005) around 0.3 for magnitudes close to 6", "about 0.3",
                     fmt_ci(p, ci) + " (Mw 6, all R pooled)", f"{n}", "interval overlaps 0.2-0.4",
                     nt if n == 0 else ("agrees" if _overlap(ci, (0.2, 0.4)) else "differs"), sens_key="pd005_65_20"))
    worst, where = -1.0, None
    for mw in grid_mw:
        for rr in grid_r[grid_r > 10]:
            mm = _sel(d, mw, rr)
            if mm.sum():
                v = fr.exceedance(d["u_d"][mm], c[mm], 0.01)
                if v > worst:
                    worst, where = v, (mw, rr)
    out.append(Claim("pd001_far", "Fragility curves, Fig. 13b",
                     "P(u_d > 0.01) is less than 0.2 for all magnitudes and R > 10 km", "< 0.2",
                     f"max {worst:.3f} at Mw {where[0]:g}, R {where[1]:g} km" if where else "n/a",
                     f"{int((d['dist_km'] > 10).sum())}", "largest Eq. (4) value over scenarios with R > 10 km below 0.2",
                     nt if where is None else ("agrees" if worst < 0.2 else "differs")))
    k = int(np.sum(~c & (np.nan_to_num(d["u_d"]) > 0.02)))
    ci = binomial_ci(k, int((~c).sum()))
    out.append(Claim("pd002_few", "Fragility curves, Fig. 13c; Tables III-IV text",
                     "u_d > 0.02 was exceeded only in a few cases", "a few cases",
                     f"{k} runs ({fmt_ci(k / max((~c).sum(), 1), ci, 3)})", f"{int((~c).sum())} non-collapsed",
                     "at most 5 % of the non-collapsed runs", "agrees" if k / max((~c).sum(), 1) <= 0.05 else "differs"))

    # 14. rocking initiation 0.17 g
    low = d["pga_g"] < ROCKING_INITIATION_G
    e = fr.exceeded(d["u_top"], c, 0.15)
    kl, nl = int(e[low].sum()), int(low.sum())
    kh, nh = int(e[~low].sum()), int((~low).sum())
    ap = d["ap_g"] if "ap_g" in d.samples else np.full(d.n, np.nan)
    n_coll_low_ap = int(np.sum(c & (ap < ROCKING_INITIATION_G)))
    min_pga_coll = float(d["pga_g"][c].min()) if c.any() else np.nan
    out.append(Claim("rocking_017", "Fig. 11c",
                     "a PGA of about 0.17 g is needed to initiate rocking at the base (rigid-block estimate); "
                     "pulses with Ap below it collapse the column only once the high-frequency part set it rocking",
                     "0.17 g",
                     f"P(u_top > 0.15 | PGA < 0.17 g) = {fmt_ci(kl / nl if nl else np.nan, binomial_ci(kl, nl))}, "
                     f"P(u_top > 0.15 | PGA >= 0.17 g) = {fmt_ci(kh / nh if nh else np.nan, binomial_ci(kh, nh))}; "
                     f"smallest PGA of a collapse {min_pga_coll:.3g} g; {n_coll_low_ap} collapses with Ap < 0.17 g",
                     f"{nl} below, {nh} above", "no collapse with PGA < 0.17 g, and rocking (u_top > 0.15) rarer "
                     "below 0.17 g than above",
                     "agrees" if (not np.isfinite(min_pga_coll) or min_pga_coll >= ROCKING_INITIATION_G)
                     and (nl == 0 or nh == 0 or kl / nl < kh / nh) else "differs"))

    return out


def _claims_ims(d: ResultsData, g, seen: list) -> list[Claim]:
    """Statements 15-20: the fragility against PGA and PGV."""
    c = d["collapsed"]
    out = _Claims(seen)
    # 15-18. P(u_top > 0.35) and P(u_d > 0.01) about 10 % for PGA about 0.3 g, PGV 40-50 cm/s
    groups = d.scenario_index()
    for im, lo, hi, unit, label in (("pga_g", 0.25, 0.35, "g", "PGA about 0.3 g"),
                                    ("pgv_cm_s", 40.0, 50.0, "cm/s", "PGV 40-50 cm/s")):
        for edp, t in (("u_top", 0.35), ("u_d", 0.01)):
            mm = (d[im] >= lo) & (d[im] <= hi)
            p, ci, n = _eq4(d, mm, edp, t, g)
            mle_txt = ""
            try:
                fit = fr.fit_lognormal_fragility(d[im], d[edp], c, t, groups=groups, n_boot=200, rng=g)
                x = 0.5 * (lo + hi)
                j = int(np.argmin(np.abs(fit.band_im - x)))
                mle_txt = (f"; MLE curve at {x:g} {unit}: {fit(x):.2f} [{fit.band_low[j]:.2f}, "
                           f"{fit.band_high[j]:.2f}]")
            except ParameterError:
                pass
            out.append(Claim(f"p_{edp}_{im}", "Fragility curves, Fig. 16; Conclusions",
                             f"{label}: about 10 % probability of {edp} > {t:g}", "about 0.10",
                             f"stripe {lo:g}-{hi:g} {unit}, Eq. (4): {fmt_ci(p, ci)}{mle_txt}", f"{n} in stripe",
                             "stripe interval overlaps 0.05-0.15",
                             "not testable (no samples in the stripe)" if n == 0 else
                             ("agrees" if _overlap(ci, (0.05, 0.15)) else "differs"),
                             sens_key="p035_pga03" if (im == "pga_g" and edp == "u_top") else None))

    # 19. PGV > 150 cm/s to approach collapse
    e1 = fr.exceeded(d["u_top"], c, 1.0)
    pgv = d["pgv_cm_s"]
    n1 = int(e1.sum())
    below = int(np.sum(e1 & (pgv < 150)))
    q10 = float(np.percentile(pgv[e1], 10)) if n1 else np.nan
    out.append(Claim("pgv150", "Fragility curves, Figs. 15, 16b; Conclusions",
                     "PGV above 150 cm/s is required to bring the column close to collapse (u_top > 1)", "> 150 cm/s",
                     f"{n1} runs with u_top > 1 or collapse; {below} of them with PGV < 150 cm/s; "
                     f"their 10th-percentile PGV {q10:.0f} cm/s" if n1 else "no run reached u_top > 1",
                     f"{d.n}", "at most 20 % of the u_top > 1 / collapse runs have PGV < 150 cm/s",
                     "not testable (no run reached u_top > 1)" if n1 == 0 else
                     ("agrees" if below / n1 <= 0.2 else "differs")))

    # 20. u_d > 0.02 for PGV > 40 cm/s
    e2 = ~c & (np.nan_to_num(d["u_d"]) > 0.02)
    n2 = int(e2.sum())
    out.append(Claim("ud002_pgv40", "Fragility curves, Fig. 15b",
                     "significant dislocations (u_d > 0.02) can occur for weaker earthquakes with PGV > 40 cm/s",
                     "PGV > 40 cm/s",
                     f"{n2} runs with u_d > 0.02; PGV of those: min {pgv[e2].min():.0f}, median "
                     f"{np.median(pgv[e2]):.0f} cm/s" if n2 else "no run with u_d > 0.02",
                     f"{int((~c).sum())} non-collapsed", "some u_d > 0.02 runs with PGV between 40 and 150 cm/s",
                     "not testable (no run with u_d > 0.02)" if n2 == 0 else
                     ("agrees" if np.any(e2 & (pgv > 40) & (pgv < 150)) else "differs")))

    return out


def _claims_pooled(d: ResultsData, g, seen: list) -> list[Claim]:
    """Statements 21-22: Eq. (4) against the empirical ratio, and long pulse periods."""
    c = d["collapsed"]
    out = _Claims(seen)
    grid_mw = np.unique(d["mw"])
    grid_r = np.unique(d["dist_km"])
    # 21. Eq. (2)/(4) vs empirical ratio
    dif = []
    for mw in grid_mw:
        for rr in grid_r:
            mm = _sel(d, mw, rr)
            if mm.sum():
                for lev in fr.PERFORMANCE_LEVELS:
                    dif.append(fr.exceedance(d[lev.edp][mm], c[mm], lev.threshold)
                               - fr.empirical_exceedance(d[lev.edp][mm], c[mm], lev.threshold))
    dif = np.abs(np.array(dif))
    out.append(Claim("lognormal_vs_empirical", "Fragility assessment, Eq. (2)",
                     "the lognormal formula and the ratio of simulations give results that are practically close",
                     "close", f"mean |difference| {dif.mean():.3f}, max {dif.max():.3f}",
                     f"{dif.size} scenario-levels", "mean absolute difference <= 0.03",
                     "agrees" if dif.mean() <= 0.03 else "differs"))

    # 22. u_top for Tp > 9 s below 0.35
    tp = 1.0 / d["fp_hz"]
    mm = (tp > 9) & ~c
    out.append(Claim("tp9", "Fig. 11a",
                     "u_top for pulse periods longer than 9 s is less than 0.35", "< 0.35",
                     f"max {d['u_top'][mm].max():.3g}" if mm.any() else "no run with Tp > 9 s",
                     f"{int(mm.sum())}", "largest u_top of non-collapsed runs with Tp > 9 s below 0.35",
                     "not testable (no Tp > 9 s)" if not mm.any() else
                     ("agrees" if d["u_top"][mm].max() < 0.35 else "differs")))
    return out


# --------------------------------------------------------------------------- the document

#: What drives each statement (used in the comments), keyed by claim key prefix.
DRIVERS = {
    "collapse_75_5": "Collapse near the fault is governed by the pulse acceleration amplitude (Vp x fp).",
    "mean_utop": "Mean u_top at 20 km is governed by the pulse amplitude Vp of Eq. (6) (saturated above Mw 7).",
    "ratio_20": "The decrease is the PGV saturation of Eq. (6) combined with the longer Tp of Eq. (7).",
    "p_u_top_pga_g": "A conditional on an IM depends less on the ground-motion model than scenario probabilities.",
}


def _describe(d: ResultsData) -> str:
    a = d.attrs
    parts = [f"{d.n} successful runs" + (f" ({d.n_failed} failed, excluded)" if d.n_failed else "")]
    parts.append(f"Mw {', '.join(f'{x:g}' for x in np.unique(d['mw']))}")
    parts.append(f"R {', '.join(f'{x:g}' for x in np.unique(d['dist_km']))} km")
    for key in ("vp_scale", "seed", "git_revision"):
        if key in a:
            parts.append(f"{key} {a[key]}")
    for key in ("solver", "column"):
        if key in a:
            try:
                obj = json.loads(a[key])
            except (TypeError, ValueError):
                continue
            if key == "solver" and isinstance(obj, dict):
                parts.append("solver " + ", ".join(f"{k}={obj[k]}" for k in sorted(obj)
                                                   if k in ("contact", "n_points", "dt_factor", "mode")))
            if key == "column" and isinstance(obj, dict):
                j = obj.get("joints") or {}
                if isinstance(j, dict) and j:
                    parts.append("joints " + ", ".join(f"{k}={j[k]:g} Pa/m" for k in ("kn", "ks") if k in j))
    return "; ".join(p for p in parts if p)


def _cell(text) -> str:
    """Escape a Markdown table cell (a literal '|' would split the cell)."""
    return str(text).replace("|", "\\|")


def _fmt_key(v):
    val, ci, n = v
    if not np.isfinite(val):
        return "n/a"
    digits = 1 if abs(val) >= 10 else 3
    s = f"{val:.{digits}f}"
    if np.all(np.isfinite(ci)):
        s += f" [{ci[0]:.{digits}f}, {ci[1]:.{digits}f}]"
    return s + f" (n={n})" + (" (degenerate)" if getattr(v, "degenerate", "") else "")


def _statement_lines(cl) -> list:
    """The table of statements, the marks of degenerate fits under it."""
    counts = {v: sum(1 for c in cl if c.verdict.startswith(v)) for v in ("agrees", "differs", "not testable")}
    L = [f"Summary: {counts['agrees']} statements agree, {counts['differs']} differ, "
         f"{counts['not testable']} not testable on this file.", "",
         "| # | paper statement (where) | paper | ours [90 % CI] | n | criterion | verdict |",
         "|---:|---|---|---|---|---|---|"]
    for i, c in enumerate(cl, 1):
        mark = " (degenerate)" if c.degenerate else ""
        L.append(f"| {i} | {_cell(c.statement)} ({c.where}) | {_cell(c.paper)} | {_cell(c.ours)}{mark} | {_cell(c.n)} | "
                 f"{_cell(c.criterion)} | **{c.verdict}** |")
    bad = [(i, c) for i, c in enumerate(cl, 1) if c.degenerate]
    if bad:
        L += ["", "Numbers marked (degenerate) rest on fits that are not estimates (what the formulas give):", ""]
        L += [f"- {i}. {c.key}: {_cell(c.degenerate)}" for i, c in bad]
    return L


def _comment_lines(cl, keys, sens) -> list:
    L = ["", "## Comments", ""]
    for i, c in enumerate(cl, 1):
        txt = []
        for prefix, drv in DRIVERS.items():
            if c.key.startswith(prefix):
                txt.append(drv)
        if c.sens_key and len(keys) > 1:
            txt.append("Same number in the sensitivity runs: " + "; ".join(
                f"{name}: {_fmt_key(k[c.sens_key])}" for name, k in keys.items()) + ".")
        if c.verdict.startswith("differs"):
            txt.append("Outside the paper's band by the stated criterion"
                       + ("; the sensitivity section shows what moves it." if sens else "."))
        if txt:
            L.append(f"{i}. **{c.key}** ({c.verdict}): " + " ".join(txt))
    return L


def _sensitivity_lines(d, sens, keys, notes) -> list:
    L = ["", "## Sensitivity", ""]
    if not sens:
        return L + ["No sensitivity files given (`--sensitivity NAME=FILE`)."]
    L += ["Key numbers recomputed on each results file (reduced grids; 90 % intervals; n = runs used).", ""]
    for name, sd in [("this file", d)] + list(sens.items()):
        L.append(f"- **{name}**: `{sd.path}`: {_describe(sd)}" + (f" **{notes[name]}.**" if notes.get(name) else ""))
    L += ["", "| key number | " + " | ".join(keys) + " |", "|---|" + "---|" * len(keys)]
    for k, label in KEY_NUMBERS.items():
        L.append(f"| {_cell(label)} | " + " | ".join(_fmt_key(v[k]) for v in keys.values()) + " |")
    return L


def write_validation(results_path, out_path, sensitivity: dict | None = None, rng=0,
                     allow_incomplete: bool = False) -> str:
    """Write the validation document; return its path.

    Parameters
    ----------
    results_path : str or path-like
        Main results file (the paper's grid, ``results/grid.h5``).
    out_path : str or path-like
        Markdown output (``docs/validation.md``).
    sensitivity : dict of str -> path, optional
        Further results files by name (e.g. ``{"vp_scale=2": "results/sensitivity/vp2.h5"}``).
    rng : int
        Seed of every bootstrap (the document is reproducible).
    allow_incomplete : bool
        Use results files whose run has not finished (refused otherwise,
        :mod:`pycolfrag.analysis.completeness`); the document then says so for each.
    """
    d = read_results(results_path)
    notes = {"this file": check_complete(d, allow_incomplete, "a validation document")}
    sens = {name: read_results(path) for name, path in (sensitivity or {}).items()}
    for name, sd in sens.items():
        notes[name] = check_complete(sd, allow_incomplete, f"a validation document (sensitivity {name!r})")
    cl = claims(d, rng=rng)
    with warnings.catch_warnings():   # the key numbers mark their degenerate fits themselves
        warnings.simplefilter("ignore", fr.DegenerateFitWarning)
        keys = {"this file": key_numbers(d, rng=rng)}
        for name, sd in sens.items():
            keys[name] = key_numbers(sd, rng=rng)
    L = ["# Validation against the paper", ""] + ([f"**{notes['this file']}.**", ""] if notes["this file"] else []) + [
         "Generated by `python scripts/make_validation.py " + os.fspath(results_path)
         + "".join(f" --sensitivity {n}={os.fspath(p)}" for n, p in (sensitivity or {}).items())
         + "` (do not edit by hand).", "",
         "Paper: Psycharis, Fragiadakis & Stefanou, *Seismic reliability assessment of classical columns subjected "
         "to near-fault ground motions*. Each row is a quantitative statement of the paper, our number from the "
         "results file, its sample size and two-sided 90 % interval (Clopper-Pearson for counts, percentile "
         "bootstrap within scenario/stripe otherwise), the criterion used for the verdict, and a comment. Paper "
         "values marked 'about' are read off figures or rounded in the text; the criterion states the band we "
         "accept.", "",
         f"Main results: `{d.path}`: {_describe(d)}.", ""]
    n_scen = np.unique(np.stack([d["mw"], d["dist_km"]]), axis=1).shape[1]
    if n_scen < 35:
        L += [f"**This is a reduced grid ({n_scen} scenarios, the paper has 35 with 100 samples each):** "
              "statements about scenarios outside it are 'not testable', and pooled statements "
              "(by IM, over Mw) are biased towards the scenarios present. Regenerate from the full grid with "
              "`python scripts/make_validation.py results/grid.h5`.", ""]
    L += _statement_lines(cl) + _comment_lines(cl, keys, sens) + _sensitivity_lines(d, sens, keys, notes)
    L.append("")
    out_path = Path(out_path)
    out_path.parent.mkdir(parents=True, exist_ok=True)
    out_path.write_text("\n".join(L) + "\n", encoding="utf-8")
    return str(out_path)
