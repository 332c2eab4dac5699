"""A logic tree's figures and committee summary (pycolfrag/risk/tree_figures.py, tree_summary.py; docs/logic_tree.md).

Expected numbers:

* the tornado's bars are the statistics' own numbers: each bar drawn from ``tree_stats.tornado`` of the branches'
  rates recomputed here, read back from the plotted rectangles (x = low exactly; x + width = high to 1e-12
  relative: matplotlib stores the width as its own difference of the bar's ends, one rounding off the
  statistics' swing) and from the JSON the figures are drawn from (exactly);
* the summary on an additive surrogate of two sets (no runs): rates x = 1e-5 + A_i + B_j /yr, A = (0, 2e-5) with
  weights (0.6, 0.4) ("pulse amplitude", vp_scale), B = (0, 0.5e-5) with weights (0.5, 0.5) ("friction"). Worked
  by hand: mean 1e-5 + 0.4 x 2e-5 + 0.5 x 0.5e-5 = 2.05e-5; the sorted values 1, 1.5, 3, 3.5 (e-5) with
  cumulative weights 0.3, 0.6, 0.8, 1: 16 % below 0.3 holds 1e-5, 84 % = 3e-5 + (0.04 / 0.2) 0.5e-5 = 3.1e-5;
  main effects 0.6 x 0.4 x (2e-5)^2 = 9.6e-11 and 0.25 x (0.5e-5)^2 = 6.25e-12, no interaction (additive), so
  the amplitude's share is 9.6 / 10.225 = 0.93888 with no estimation error. Tolerance 1e-12 relative: a few
  roundings of sums of four terms.
"""
from __future__ import annotations

import json
import math
from types import SimpleNamespace

import h5py
import numpy as np
import pytest

from pycolfrag.risk import site_risk as risk
from pycolfrag.risk import tree_figures, tree_grid
from pycolfrag.risk import tree_stats as ts
from pycolfrag.risk.logic_tree import tree_from_dict
from pycolfrag.risk.tree_summary import summary, summary_lines
from test_logic_tree_grid import CELLS, SITE, write_cells

TWO_SETS = """[[branch_sets]]
name = "rate"
choice = "rate_factor"
branches = [{value = 0.5, weight = 0.25}, {value = 1.0, weight = 0.5}, {value = 2.0, weight = 0.25}]

[[branch_sets]]
name = "pulse occurrence"
choice = "pulse_model"
branches = [{value = {model = "probability", probability = 0.5}, weight = 0.7, name = "p 0.5"},
            {value = {model = "probability", probability = 0.2}, weight = 0.3, name = "p 0.2"}]
"""


@pytest.fixture
def files(tmp_path):
    h5 = write_cells(tmp_path / "p.h5", CELLS)
    nop = write_cells(tmp_path / "n.h5", {k: (n, c // 3, med / 2) for k, (n, c, med) in CELLS.items()}, seed=1)
    with h5py.File(nop, "a") as f:             # the no-pulse branch of the same grid, as the grid writes it
        f.attrs["pulse"] = "none"
    site = tmp_path / "site.toml"
    site.write_text(SITE.replace('model = "pulse-only"', 'model = "probability"\nprobability = 0.5'))
    tree = tmp_path / "tree.toml"
    tree.write_text(TWO_SETS)
    return site, tree, h5, nop


def _bars(ax):
    return [(p.get_x(), p.get_width()) for p in ax.patches]


def test_tornado_bars_are_the_tree_statistics(files):
    """Per level, the bars drawn are tree_stats.tornado of the branches' rates (recomputed here), in its order,
    on top the largest swing; the JSON the figure is drawn from holds the same numbers."""
    site, tree, h5, nop = files
    tr = tree_grid.tree_risk(site, tree, h5, nop, n_draws=50, rng=0)
    data = tree_figures.figure_data(tr)
    fig = tree_figures.fig_tornado(data)
    names = [[b.name for b in s.branches] for s in tr.tree.branch_sets]
    for ax, lb in zip(fig.axes, tr.labels):
        rates = [r.rate[lb][0] for r in tr.branch_risk]
        expect = ts.tornado(rates, tr.weights, tr.index, tr.sets, names)
        assert ax.get_title() == lb
        drawn = _bars(ax)
        assert [x for x, _ in drawn] == [b["low"] for b in expect], lb
        assert [x + wd for x, wd in drawn] == pytest.approx([b["high"] for b in expect], rel=1e-12), lb
        assert [t.get_text() for t in ax.get_yticklabels()] == [b["set"] for b in expect]
        ys = [p.get_y() for p in ax.patches]
        assert ys == sorted(ys, reverse=True)           # the largest swing on top
        assert [(b["low"], b["high"], b["set"]) for b in data["tornado"][lb]["bars"]] == [
            (b["low"], b["high"], b["set"]) for b in expect]
    assert {b["set"] for b in data["tornado"]["collapse"]["bars"]} == {"rate", "pulse occurrence"}


def test_command_writes_the_figures_and_the_summary_on_top(files, tmp_path):
    site, tree, h5, nop = files
    out = tmp_path / "out"
    assert risk.main([str(site), h5, str(out), "--no-pulse", nop, "--logic-tree", str(tree), "--draws", "50"]) == 0
    for name in tree_figures.FILES.values():
        assert (out / name).is_file() and (out / name).stat().st_size > 0, name
    data = json.loads((out / "logic_tree_figures.json").read_text())
    js = json.loads((out / "logic_tree.json").read_text())
    for lb, s in js["levels"].items():
        assert [b["swing"] for b in data["tornado"][lb]["bars"]] == [b["swing"] for b in s["tornado"]], lb
        assert data["bands"][lb]["0.16"] == s["quantiles"]["0.16"] and data["bands"][lb]["mean"] == s["mean"]
    md = (out / "logic_tree.md").read_text()
    assert md.index("## Summary") < md.index("## Annual rates over the tree")
    assert js["summary"]["mean"] == js["levels"]["collapse"]["mean"]
    # every quantile's estimation error is stated (tree_quantile_error; its numbers: test_logic_tree_quantile_error)
    assert all(js["levels"]["collapse"]["quantile_error"]["sd"][q] > 0 for q in ("0.05", "0.16", "0.5", "0.84", "0.95"))
    assert "+- " in md.split("## Annual rates over the tree")[1].split("## Probability")[0]
    out2 = tmp_path / "out2"
    assert risk.main([str(site), h5, str(out2), "--no-pulse", nop, "--logic-tree", str(tree), "--draws", "50",
                      "--no-figures"]) == 0
    assert not any((out2 / name).exists() for name in tree_figures.FILES.values())


def _surrogate(sd: float):
    tree = tree_from_dict({"branch_sets": [
        {"name": "pulse amplitude", "choice": "vp_scale",
         "branches": [{"value": 1.0, "weight": 0.6}, {"value": 2.0, "weight": 0.4}]},
        {"name": "friction", "choice": "joint_friction_deg",
         "branches": [{"value": 30.0, "weight": 0.5}, {"value": 40.0, "weight": 0.5}]}]})
    ends = tree.end_branches()
    a, b = (0.0, 2e-5), (0.0, 0.5e-5)
    x = np.array([1e-5 + a[e.index[0]] + b[e.index[1]] for e in ends])
    w = np.array([e.weight for e in ends])
    idx = np.array([e.index for e in ends])
    sets = [(s.name, len(s.branches)) for s in tree.branch_sets]
    names = [[br.name for br in s.branches] for s in tree.branch_sets]
    st = tree_grid.level_stats(x, np.full(len(x), sd), w, idx, sets, names)
    p = -np.expm1(-50 * x)
    prob = {"mean": float(ts.weighted_mean(p, w)), "quantiles": {q: float(v) for q, v in ts.quantiles(p, w).items()}}
    return SimpleNamespace(tree=tree, ends=ends, labels=("collapse",), years=(50.0,), stats={"collapse": st},
                           prob_stats={50.0: {"collapse": prob}}), x, w


def test_summary_on_a_surrogate_of_known_numbers():
    tr, x, w = _surrogate(sd=0.0)
    d = summary(tr)
    assert d["mean"] == pytest.approx(2.05e-5, rel=1e-12)
    assert d["band"] == pytest.approx([1e-5, 3.1e-5], rel=1e-12)
    assert d["shares"]["pulse amplitude"] == pytest.approx(9.6 / 10.225, rel=1e-12)
    assert d["shares"]["friction"] == pytest.approx(0.625 / 10.225, rel=1e-12)
    assert d["top_share"] == d["top_swing"] == "pulse amplitude"
    assert d["swing"] == pytest.approx([1e-5 + 0.25e-5, 3e-5 + 0.25e-5], rel=1e-12)
    p = [-math.expm1(-50 * v) for v in x]
    assert d["p_mean"] == pytest.approx(float(np.dot(w, p)), rel=1e-12)
    text = "\n".join(summary_lines(tr))
    assert "mean 2.05e-05 /yr; 16-84 % band 1e-05 - 3.1e-05 /yr" in text
    assert "The branch set that matters most**: pulse amplitude (the pulse amplitude" in text and "94 %" in text
    assert "near-fault pulse records" in text and "more runs" not in text


def test_summary_says_when_the_runs_matter_more_than_any_choice():
    """Each branch's sd 2e-5: estimation variance 4e-10 against 1.0225e-10 over the tree, share 0.796."""
    tr, _, _ = _surrogate(sd=2e-5)
    d = summary(tr)
    assert d["estimation_share"] == pytest.approx(4 / 5.0225, rel=1e-12)
    assert d["top_share"] == "pulse amplitude"
    assert "more runs narrow the answer" in "\n".join(summary_lines(tr))


def test_rare_route_tree_figures_and_summary_from_its_statistics(tmp_path):
    """The rare-event route's tree (the surrogate of tests/test_logic_tree_rare.py, vp_scale 1 and 2 on the same
    events): the figures' JSON holds its statistics as computed, and the summary names the amplitude (the only
    set) with the measurement that settles it."""
    from test_logic_tree_rare import SETTINGS, STOP, Scaled, _paired, _tree, site_dict
    tree = _tree([{"name": "pulse amplitude", "choice": "vp_scale",
                   "branches": [{"value": 1.0, "weight": 0.6}, {"value": 2.0, "weight": 0.4}]}])
    tr, _ = _paired(tree, site_dict(), [Scaled(1.0), Scaled(2.0)], SETTINGS, STOP)
    paths = tree_figures.write_figures(tr, tmp_path)
    data = json.loads((tmp_path / "logic_tree_figures.json").read_text())
    assert set(paths) == {"tornado", "bands", "data"} and all((tmp_path / n).is_file() for n in tree_figures.FILES.values())
    s = tr.stats["collapse"]
    assert data["tornado"]["collapse"]["bars"][0]["swing"] == s["tornado"][0]["swing"] > 0
    assert data["bands"]["collapse"]["0.84"] == s["quantiles"][0.84]
    d = summary(tr)
    assert d["top_share"] == "pulse amplitude" and d["mean"] == s["mean"]
    from pycolfrag.risk import tree_rare_report
    md = tree_rare_report.markdown(tr)
    assert md.index("## Summary") < md.index("## Annual rates") and "near-fault pulse records" in md


def test_rare_route_command_writes_the_tree_figures(tmp_path):
    """The command with real runs (tests/test_rare_site_plumbing.py's tiny site, 40 runs per run setting) and
    without --no-figures writes the tree's figures beside logic_tree.md."""
    from test_rare_site_plumbing import BASE, _run
    tree = tmp_path / "tree.toml"
    tree.write_text('[[branch_sets]]\nchoice = "vp_scale"\nbranches = [{value = 1.0, weight = 0.6}, '
                    '{value = 1.5, weight = 0.4}]\n')
    args = [a for a in BASE if a != "--no-figures"] + ["--batch", "20", "--max-runs", "40"]
    p = _run(args + ["--simulate", str(tmp_path / "out"), "--logic-tree", str(tree)])
    assert p.returncode in (0, 6), p.stdout + p.stderr
    for name in ("logic_tree.md", *tree_figures.FILES.values()):
        assert (tmp_path / "out" / name).is_file(), name
    assert (tmp_path / "out" / "logic_tree.md").read_text().index("## Summary") < 200
