"""The outputs of the restoration alternatives on the same events (:mod:`pycolfrag.risk.restoration_rare`):
``restoration.md`` (every alternative's rate per level with its CoV and 90 % interval, every other alternative's
paired difference from the reference with its own interval, what pairing saved, the runs), ``restoration.json``
(the same numbers, and P in T years) and ``restoration_rare.png`` (:func:`figure`: per level, the rates on a
linear axis from 0 and the differences about 0, each with its interval; no log floor), and, with ``docs``,
the block of docs/restoration.md between :data:`BEGIN` and :data:`END`."""
from __future__ import annotations

import math
from pathlib import Path

from pycolfrag.core import report_json
from pycolfrag.core.errors import OutputError
from pycolfrag.rare.driver import failures
from pycolfrag.rare.estimate import DEFAULT_MIN_NEFF
from pycolfrag.risk.report import _write_text

__all__ = ["BEGIN", "END", "FIGURE", "TITLE", "markdown", "to_json", "figure", "write_outputs", "summary"]

BEGIN, END = "<!-- restoration-rare:begin -->", "<!-- restoration-rare:end -->"
FIGURE = "restoration_rare.png"
#: The figure's title: what the numbers are -- the model's rate at the example site -- not the monument's risk.
TITLE = "The model's annual rate at the site, per restoration alternative (rare-event route, the same events)"


def _e(x: float) -> str:
    return "0" if x == 0 else f"{x:.2e}" if math.isfinite(x) else str(x)


def _rate_cell(e) -> str:
    if not math.isfinite(e.cov) or e.status == "refused":
        return f"{_e(e.rate)} refused ({e.n_eff:.1f} effective exceedances; <= {_e(e.bound)})"
    mark = "" if e.status == "converged" else f" {e.status.upper()}"
    return f"{_e(e.rate)} [{_e(e.low)}, {_e(e.high)}] ({e.cov:.2f}){mark}"


def _diff_cell(d) -> str:
    if d.status == "no differing run":
        return f"0: no run of {d.pairs} differs (abs <= {_e(d.bound)})"
    gain = f"x{d.pairing_gain:.1f}" if math.isfinite(d.pairing_gain) else "-"
    text = f"{d.difference:+.2e} [{d.low:+.2e}, {d.high:+.2e}]; {d.differing} runs differ; pairing {gain}"
    return text + ("" if d.status in ("differs", "not distinguished") else f" **{d.status.upper()}**")


def _head(result) -> list:
    alts, runs = result["alternatives"], result["runs"]
    r0 = runs[0]
    s = r0.settings
    return [f"Site `{r0.site.path}` ({r0.site.name}); {len(alts)} alternatives, each {r0.runs} runs on the same events "
            f"(seed {s.seed}, pilot {s.pilot_for(len(r0.strata))} per stratum over {len(r0.strata)} strata, batches of at most "
            f"{s.batch}; stopped: {r0.stopped}, target CoV {r0.stop.target_cov:g}, budget {r0.stop.max_runs} runs each): "
            + "; ".join(f"**{a.key}** `{a.path}` ({a.name})" for a in alts) + ".", "",
            "The model's annual rate of each level at this site (the paper's model choices, one site file), with its "
            "90 % interval -- not the monument's real risk: the model choices' own spread is the logic tree's "
            "([logic_tree.md](logic_tree.md)). CoV in parentheses; a level resting on too few effective exceedances "
            "is refused: its rate is no estimate to act on, no interval is stated, only the estimator's upper bound.", ""]


def markdown(result, years=(50.0,)) -> str:
    """The Markdown of the comparison (the docs block)."""
    alts, runs, diffs = result["alternatives"], result["runs"], result["differences"]
    labels = [q.label for q in runs[0].quantities]
    keys = [a.key for a in alts]
    L = _head(result) + ["**Rate per level** (1/yr, 90 % interval, CoV):", "",
                         "| level | " + " | ".join(keys) + " |", "|---|" + "---|" * len(keys)]
    for lb in labels:
        L.append(f"| {lb} | " + " | ".join(_rate_cell(r.estimate.levels[lb]) for r in runs) + " |")
    others = keys[1:]
    L += ["", f"**Paired difference from {keys[0]}** (lambda_alternative - lambda_{keys[0]}, 1/yr, 90 % interval "
          "D +- 1.645 sd; the runs whose outcome differs; pairing: the variance two independent simulations of as many "
          "runs would give the difference, over the paired one):", "",
          "| level | " + " | ".join(others) + " |", "|---|" + "---|" * len(others)]
    for lb in labels:
        L.append(f"| {lb} | " + " | ".join(_diff_cell(diffs[k][lb]) for k in others) + " |")
    bad = [(a.key, f) for a, f in ((a, failures(r.cols)) for a, r in zip(alts, runs)) if f[0]]
    L += ["", "A difference whose interval excludes 0 is a finding of this model at this site; one that includes 0 "
          f"is not distinguished by these runs. FEW DIFFERING RUNS: fewer than {DEFAULT_MIN_NEFF:g} effective runs separate the two, "
          "its interval is not to be trusted."]
    if bad:
        L += ["", "**Failed runs**: " + "; ".join(f"{k}: {f[0]} of {f[1]} ({f[2]})" for k, f in bad)
              + " -- a failed run is not a non-exceedance (restoration.json bounds every difference)."]
    L += ["", f"![restoration, the same events](figures/{FIGURE})", "",
          "*Per level (rows): left, each alternative's annual rate with its 90 % interval on a linear axis from 0 "
          "(a refused level: a hollow point at its rate, no interval); right, each alternative's paired difference from "
          f"{keys[0]} with its own 90 % interval, about 0 (a cross: few differing runs; a dotted bar: no run differs, "
          "the bound on the difference). The model's rate at this site, not the monument's risk.*"]
    return "\n".join(L)


def to_json(result, years=(50.0,)) -> dict:
    alts, runs = result["alternatives"], result["runs"]
    return {"kind": "pycolfrag-restoration-rare", "version": 1, "site": str(runs[0].site.path),
            "reference": alts[0].key,
            "alternatives": [{"key": a.key, "file": str(a.path), "name": a.name, "runs": r.runs,
                              "failed": failures(r.cols)[0], "stopped": r.stopped,
                              "levels": {k: v.as_dict() for k, v in r.estimate.levels.items()},
                              "probability": {f"{t:g}": {k: -math.expm1(-v.rate * t)
                                                         for k, v in r.estimate.levels.items()} for t in years}}
                             for a, r in zip(alts, runs)],
            "differences": {k: {lb: d.as_dict() for lb, d in v.items()} for k, v in result["differences"].items()}}


def _rates_panel(ax, runs, keys, lb):
    right = 0.0
    for j, r in enumerate(runs):
        e = r.estimate.levels[lb]
        y = len(runs) - 1 - j
        if e.status == "refused" or not math.isfinite(e.cov):    # no interval: a hollow point at its rate, said
            ax.plot([e.rate], [y], "o", color=f"C{j}", mfc="none")
            ax.annotate(f"refused ({e.n_eff:.1f} eff. exceedances)", (e.rate, y), xytext=(6, 0),
                        textcoords="offset points", va="center", fontsize=7, color=f"C{j}")
            right = max(right, e.rate)
        else:
            ax.plot([e.low, e.high], [y, y], "-", color=f"C{j}", lw=2)
            ax.plot([e.rate], [y], "o", color=f"C{j}")
            right = max(right, e.high)
    ax.set_xlim(0, 1.35 * right if right > 0 else 1.0)
    ax.set_ylim(-0.5, len(runs) - 0.5)
    ax.set_yticks(range(len(runs)), keys[::-1], fontsize=8)


def _diffs_panel(ax, diffs, keys, lb):
    for j, k in enumerate(keys[1:], start=1):
        d = diffs[k][lb]
        y = len(keys) - 1 - j
        if d.status == "no differing run":           # D = 0 on every run: only |D| <= bound is known
            ax.plot([-d.bound, d.bound], [y, y], ":", color=f"C{j}")
            ax.plot([0.0], [y], "|", color=f"C{j}", ms=10)
            continue
        ax.plot([d.low, d.high], [y, y], "-", color=f"C{j}", lw=2)
        ax.plot([d.difference], [y], "o" if d.status in ("differs", "not distinguished") else "x", color=f"C{j}")
    ax.axvline(0.0, color="k", lw=0.8)
    ax.set_yticks(range(len(keys) - 1), keys[1:][::-1], fontsize=8)
    ax.set_ylim(-0.5, len(keys) - 1.5)


def figure(result):
    """The comparison's Figure (module docstring): one row per level, rates left, paired differences right."""
    from matplotlib.figure import Figure
    alts, runs, diffs = result["alternatives"], result["runs"], result["differences"]
    keys = [a.key for a in alts]
    labels = [q.label for q in runs[0].quantities]
    fig = Figure(figsize=(11, 1.5 + 1.45 * len(labels)), layout="constrained")
    axes = fig.subplots(len(labels), 2, squeeze=False)
    for i, lb in enumerate(labels):
        _rates_panel(axes[i, 0], runs, keys, lb)
        _diffs_panel(axes[i, 1], diffs, keys, lb)
        axes[i, 0].set_ylabel(lb, fontsize=9)
        for ax in axes[i]:
            ax.grid(alpha=0.3, axis="x")
            ax.ticklabel_format(axis="x", style="sci", scilimits=(-2, 2))
    axes[0, 0].set_title("annual rate (1/yr), 90 % interval", fontsize=9)
    axes[0, 1].set_title(f"paired difference from {keys[0]} (1/yr), 90 % interval", fontsize=9)
    axes[-1, 0].set_xlabel("1/yr")
    axes[-1, 1].set_xlabel("1/yr")
    fig.suptitle(f"{TITLE}\nsite: {runs[0].site.name}; {runs[0].runs} runs per alternative; the model's rate, not "
                 "the monument's real risk", fontsize=10)
    return fig


def _replace_block(page: Path, block: str) -> None:
    text = page.read_text(encoding="utf-8")
    if BEGIN not in text or END not in text:
        raise OutputError(f"{page} has no block {BEGIN} ... {END} to replace")
    i, j = text.index(BEGIN), text.index(END)
    _write_text(page, text[:i + len(BEGIN)] + "\n" + block + "\n" + text[j:])


def write_outputs(result, outdir, years=(50.0,), *, figures=True, docs=None, docs_figures=None) -> dict:
    """Write restoration.md, restoration.json and the figure into ``outdir`` (and the docs page's block and
    figure when ``docs`` is given); the paths written."""
    out = Path(outdir)
    md = markdown(result, years)
    paths = {"markdown": out / "restoration.md", "json": out / "restoration.json"}
    _write_text(paths["markdown"], "# Restoration alternatives on the same events\n\n" + md + "\n")
    _write_text(paths["json"], report_json.dumps(to_json(result, years), indent=1, default=float) + "\n")
    if figures or docs is not None:
        fig = figure(result)
        fig.savefig(out / FIGURE, dpi=110)
        paths["figure"] = out / FIGURE
        if docs is not None:
            folder = Path(docs_figures) if docs_figures is not None else Path(docs).parent / "figures"
            folder.mkdir(parents=True, exist_ok=True)
            fig.savefig(folder / FIGURE, dpi=110)
    if docs is not None:
        _replace_block(Path(docs), md)
        paths["docs"] = Path(docs)
    return paths


def summary(result) -> str:
    """A few lines for the terminal: collapse and u_d > 0.005, each alternative's rate and difference."""
    keys = [a.key for a in result["alternatives"]]
    lines = []
    for lb in [q.label for q in result["runs"][0].quantities]:
        cells = [f"{k} {_rate_cell(r.estimate.levels[lb])}" for k, r in zip(keys, result["runs"])]
        cells += [f"{k}-{keys[0]} {_diff_cell(result['differences'][k][lb])}" for k in keys[1:]]
        lines.append(f"{lb}: " + "; ".join(cells))
    return "\n".join(lines)

