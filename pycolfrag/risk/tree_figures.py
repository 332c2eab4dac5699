"""Figures of a logic tree's site risk (docs/logic_tree.md, "Figures"), written beside ``logic_tree.md`` by both
routes (the grid route's :mod:`pycolfrag.risk.tree_report`, the rare-event route's
:mod:`pycolfrag.risk.tree_rare_report`) unless ``--no-figures``:

* ``logic_tree_tornado.png``: per level, each branch set's swing -- its alternatives' conditional means with the
  other sets at their weights, lowest to highest (:func:`pycolfrag.risk.tree_stats.tornado`) -- as a horizontal
  bar, largest swing on top, the tree's mean as a vertical line;
* ``logic_tree_bands.png``: per level, the tree's weighted mean, median and OpenQuake's 16-84 % and 5-95 %
  fractiles of the annual rate;
* ``logic_tree_figures.json``: the numbers both figures are drawn from (:func:`figure_data`), nothing else: the
  tree's statistics as computed (``tr.stats``), so that a figure can be checked against them.

Takes the tree's result of either route (``TreeRisk`` or ``TreeRare``: ``labels`` and ``stats``, each level's
``mean``, ``quantiles`` and ``tornado``). Object-oriented matplotlib with no pyplot state (the Agg canvas of
:func:`pycolfrag.analysis.figures.Figure`), imported on the first figure.
"""
from __future__ import annotations

import math
from pathlib import Path

from pycolfrag.core import report_json
from pycolfrag.core.errors import OutputError

__all__ = ["FILES", "figure_data", "fig_tornado", "fig_bands", "write_figures"]

#: The files written (stem -> file name).
FILES = {"tornado": "logic_tree_tornado.png", "bands": "logic_tree_bands.png", "data": "logic_tree_figures.json"}
#: The floor of a log axis: a rate of 0 (a level no branch reaches) is drawn there.
_FLOOR = 1e-12


def figure_data(tr) -> dict:
    """The numbers drawn: per level the tornado's bars (set, low, high, swing, the alternatives at each end) in
    the order drawn (largest swing first), the mean, median and the 5, 16, 84, 95 % quantiles of lambda."""
    out: dict = {"levels": list(tr.labels), "tornado": {}, "bands": {}}
    for lb in tr.labels:
        s = tr.stats[lb]
        out["tornado"][lb] = {"mean": float(s["mean"]),
                              "bars": [{k: b[k] for k in ("set", "low", "low_branch", "high", "high_branch", "swing")}
                                       for b in s["tornado"]]}
        out["bands"][lb] = {"mean": float(s["mean"]), **{str(q): float(x) for q, x in s["quantiles"].items()}}
    return out


def _grid(n: int):
    cols = 1 if n == 1 else 2
    return cols, math.ceil(n / cols)


def fig_tornado(data: dict):
    """One panel per level: a bar per branch set from its lowest to its highest conditional mean (linear axis,
    each panel its own scale), largest swing on top; the tree's mean dashed. The bars are ``ax.patches`` in the
    order of ``data["tornado"][level]["bars"]``."""
    from pycolfrag.analysis.figures import Figure
    levels = data["levels"]
    cols, rows = _grid(len(levels))
    n_sets = max((len(data["tornado"][lb]["bars"]) for lb in levels), default=1)
    fig = Figure(figsize=(6 * cols, 0.5 + rows * (0.9 + 0.45 * n_sets)), layout="constrained")
    for i, lb in enumerate(levels):
        ax = fig.add_subplot(rows, cols, i + 1)
        t = data["tornado"][lb]
        bars = t["bars"]
        y = list(range(len(bars)))[::-1]                   # the largest swing on top
        ax.barh(y, [b["swing"] for b in bars], left=[b["low"] for b in bars], height=0.6, color="C0", alpha=0.8)
        for yy, b in zip(y, bars):
            ax.annotate(str(b["low_branch"]), (b["low"], yy), xytext=(-3, 0), textcoords="offset points",
                        ha="right", va="center", fontsize=7)
            ax.annotate(str(b["high_branch"]), (b["high"], yy), xytext=(3, 0), textcoords="offset points",
                        ha="left", va="center", fontsize=7)
        ax.axvline(t["mean"], color="k", ls="--", lw=1, label=f"tree mean {t['mean']:.3g}/yr")
        ax.set_yticks(y, [b["set"] for b in bars], fontsize=8)
        ax.use_sticky_edges = False                         # room for the end labels on both sides
        ax.margins(x=0.2)
        ax.ticklabel_format(axis="x", style="sci", scilimits=(0, 0))
        ax.locator_params(axis="x", nbins=5)
        ax.set_xlabel("annual rate, the set's alternative fixed (others at their weights), 1/yr", fontsize=8)
        ax.set_title(f"{lb}", fontsize=9)
        ax.legend(fontsize=7, loc="lower right")
        ax.grid(True, axis="x", alpha=0.3)
    fig.suptitle("Logic tree: each branch set's swing of the annual rate (tornado)", fontsize=10)
    return fig


def fig_bands(data: dict):
    """The levels along x; per level the 5-95 % band (light), the 16-84 % band (dark), the median (bar) and the
    weighted mean (dot) of the annual rate, log axis (a rate of 0 at 1e-12)."""
    from pycolfrag.analysis.figures import Figure
    levels = data["levels"]
    fig = Figure(figsize=(max(6.0, 1.1 * len(levels) + 2), 4.8), layout="constrained")
    ax = fig.add_subplot(1, 1, 1)
    x = list(range(len(levels)))
    b = [data["bands"][lb] for lb in levels]

    def f(key):
        return [max(d[key], _FLOOR) for d in b]

    ax.vlines(x, f("0.05"), f("0.95"), lw=14, color="C0", alpha=0.25, label="5-95 %")
    ax.vlines(x, f("0.16"), f("0.84"), lw=14, color="C0", alpha=0.6, label="16-84 %")
    ax.scatter(x, f("0.5"), marker="_", s=250, color="k", label="median", zorder=3)
    ax.scatter(x, f("mean"), marker="o", color="C3", label="weighted mean", zorder=4)
    ax.set_yscale("log")
    ax.set_xticks(x, levels, rotation=30, ha="right", fontsize=8)
    ax.set_ylabel("annual rate of exceedance, 1/yr")
    ax.grid(True, which="both", axis="y", alpha=0.3)
    ax.legend(fontsize=8)
    ax.set_title("Logic tree: mean and fractiles (OpenQuake's weighted quantiles) per level", fontsize=10)
    return fig


def write_figures(tr, outdir) -> dict:
    """Write the two figures and the JSON they are drawn from into ``outdir``; return {stem: path}."""
    from pycolfrag.risk.report import _write_text  # the risk outputs' atomic write
    out = Path(outdir)
    data = figure_data(tr)
    paths = {k: out / name for k, name in FILES.items()}
    try:
        _write_text(paths["data"], report_json.dumps(data, indent=1))
        fig_tornado(data).savefig(paths["tornado"], dpi=110)
        fig_bands(data).savefig(paths["bands"], dpi=110)
    except OSError as exc:
        raise OutputError(f"cannot write the logic tree's figures into {out}: {exc.strerror or exc}") from None
    return {k: str(p) for k, p in paths.items()}
