"""The one-page summary a committee reads, at the top of ``logic_tree.md`` (both routes; docs/logic_tree.md,
"The committee's summary"): the tree's weighted mean of lambda(collapse) and of P(collapse in 50 years), their
16-84 % band, the branch set that matters most -- the largest share of the variance split (its main effect) and
the largest tornado swing, each named, and said when they differ -- and which measurement would narrow the band
most: the knowledge that settles the set with the largest share (:data:`MEASUREMENTS`, by the set's choice).

Takes the tree's result of either route (``TreeRisk`` or ``TreeRare``: ``tree``, ``stats``, ``prob_stats``,
``years``)."""
from __future__ import annotations

import math

__all__ = ["MEASUREMENTS", "summary", "summary_lines"]

#: Per choice (docs/logic_tree.md's table): what the choice is, and the measurement or study that would settle it.
MEASUREMENTS = {
    "vp_scale": ("the pulse amplitude (the scale of Eq. (6)'s Vp)",
                 "near-fault pulse records at the site's magnitudes and distances (their PGV and Vp), or a "
                 "site-specific study of the pulse amplitude"),
    "vp_model": ("the pulse-amplitude relation (Eq. (6) or another published one)",
                 "near-fault pulse records at the site's magnitudes and distances (their PGV and Vp), or a "
                 "site-specific study of the pulse amplitude"),
    "tp_model": ("the pulse-period relation", "the periods of pulses recorded near faults like the site's"),
    "pulse_model": ("the pulse-occurrence model",
                    "the share of pulse-like motions in records near faults of the site's mechanism and geometry"),
    "contact": ("the contact model of the drums' joints",
                "the joints' real bearing surfaces (a survey of the drums' contact faces) or a shaking-table test "
                "of a column of the same form"),
    "joint_kn": ("the joints' normal stiffness",
                 "the column's measured natural frequencies (ambient vibration) or a test of a joint"),
    "joint_ks": ("the joints' shear stiffness",
                 "the column's measured natural frequencies (ambient vibration) or a test of a joint"),
    "joint_friction_deg": ("the joints' friction angle", "tilt or direct-shear tests of the stone's contact faces"),
    "connectors": ("the dowels (connectors)",
                   "a survey of the dowels: whether they are there, their material, section and state"),
    "rate": ("a source's annual rate", "the source's slip rate or its paleoseismic record"),
    "rate_factor": ("a source's annual rate", "the source's slip rate or its paleoseismic record"),
    "b": ("the Gutenberg-Richter b-value", "a longer or better-located earthquake catalogue of the region"),
    "m_max": ("the largest magnitude", "the lengths and segmentation of the region's faults"),
}


def _year(tr) -> float:
    return 50.0 if 50.0 in tr.prob_stats else float(tr.years[0])


def summary(tr, level: str = "collapse") -> dict:
    """The summary's numbers: the mean and 16-84 % band of the rate and of P in 50 years (the first horizon when 50
    is not computed), each set's share of the variance split (main effect / (over the tree + estimation); the
    estimation's share; NaN where a branch's estimate has no sd), the set of the largest share, of the largest
    swing, and what the first is and the measurement that would settle it."""
    s = tr.stats[level]
    t = _year(tr)
    p = tr.prob_stats[t][level]
    sp = s["split"]
    est = sp["estimation"]
    total = sp["epistemic"] + (0.0 if not math.isfinite(est) else est)
    share = {k: (v / total if total > 0 else 0.0) for k, v in sp["per_set"].items()}
    top_share = max(share, key=lambda k: share[k]) if share else None
    choice = {bs.name: bs.choice.name for bs in tr.tree.branch_sets}
    what, measure = MEASUREMENTS.get(choice.get(top_share, ""), (top_share, "a study of this choice"))
    top_swing = s["tornado"][0] if s["tornado"] else None
    return {"level": level, "years": t, "mean": s["mean"], "band": [s["quantiles"][0.16], s["quantiles"][0.84]],
            "p_mean": p["mean"], "p_band": [p["quantiles"][0.16], p["quantiles"][0.84]],
            "shares": share, "estimation_share": est / total if total > 0 and math.isfinite(est) else math.nan,
            "top_share": top_share, "top_swing": None if top_swing is None else top_swing["set"],
            "swing": None if top_swing is None else [top_swing["low"], top_swing["high"]],
            "what": what, "measurement": measure}


def _e(x: float) -> str:
    return f"{x:.3g}"


def summary_lines(tr, level: str = "collapse") -> list:
    """The summary as markdown lines (a heading, the numbers, the sentences)."""
    d = summary(tr, level)
    t = f"{d['years']:g}"
    lines = ["## Summary", "",
             f"* **Annual rate of {level}**: mean {_e(d['mean'])} /yr; 16-84 % band {_e(d['band'][0])} - "
             f"{_e(d['band'][1])} /yr (over the tree's branches, by their weights).",
             f"* **P({level} in {t} years)**: mean {_e(d['p_mean'])}; 16-84 % band {_e(d['p_band'][0])} - "
             f"{_e(d['p_band'][1])}."]
    if d["top_share"] is None or d["shares"][d["top_share"]] <= 0:
        lines += ["* No branch set moves this rate: every branch gives the same value.", ""]
        return lines
    k = d["top_share"]
    lines.append(f"* **The branch set that matters most**: {k} ({d['what']}), {100 * d['shares'][k]:.0f} % of the "
                 f"variance of the rate (its main effect, estimation included in the total)"
                 + (f"; it also swings the rate most, {_e(d['swing'][0])} to {_e(d['swing'][1])} /yr."
                    if d["top_swing"] == k else
                    f"; the largest swing is {d['top_swing']}'s, {_e(d['swing'][0])} to {_e(d['swing'][1])} /yr."))
    lines.append(f"* **The measurement that would narrow the band most**: {d['measurement']} -- it settles {k}.")
    es = d["estimation_share"]
    if math.isfinite(es) and es > d["shares"][k]:
        lines.append(f"* But the estimation (the runs' own error) holds more, {100 * es:.0f} %: more runs narrow the "
                     "answer before any measurement does.")
    return lines + [""]
