"""A logic tree of site choices on the grid route: ``pycolfrag risk SITE RESULTS OUT --logic-tree TREE``
(pycolfrag/risk/tree_grid.py, tree_report.py; docs/logic_tree.md).

The surrogate with exact per-branch rates: one characteristic source (Mw 7.5, R 10 km, rate nu) on a scenario
of a small results file written here, pulse-only, so that a branch's rate of collapse is its rate times the
cell's share of collapsed runs, 4/40, with no interpolation or quadrature (as tests/test_risk.py's first test
asserts exactly); the tree's rate_factor branches (0.5, 1, 2) with weights (0.25, 0.5, 0.25) give the rates
f nu p, whose mean and quantiles are worked out by hand in each test. Tolerance 1e-12 relative: the product
(f nu) p against f (nu p), one rounding each.
"""
import json
import math
from pathlib import Path

import h5py
import numpy as np
import pytest

from pycolfrag.core.errors import ParameterError
from pycolfrag.risk import grid_route, tree_grid
from pycolfrag.risk import site_risk as risk

NU = 0.002
P = 4 / 40


def write_cells(path, cells, seed=0):
    """A results file in the documented layout (as tests/test_risk.py's write_cells): cells {(mw, r):
    (n, n_collapsed, median u_top)}, u_top lognormal (beta 0.6), u_d = u_top / 50, collapsed rows NaN."""
    rng = np.random.default_rng(seed)
    cols = {k: [] for k in ("mw", "dist_km", "u_top", "u_d", "collapsed", "scenario", "sample")}
    for sc, ((m, r), (n, k, med)) in enumerate(sorted(cells.items())):
        u = med * np.exp(0.6 * rng.standard_normal(n))
        c = np.arange(n) < k
        u[c] = np.nan
        for key, vals in (("mw", [m] * n), ("dist_km", [r] * n), ("u_top", list(u)), ("u_d", list(u / 50)),
                          ("collapsed", list(c)), ("scenario", [sc] * n), ("sample", list(range(n)))):
            cols[key] += vals
    with h5py.File(path, "w") as f:
        g = f.create_group("samples")
        for key, v in cols.items():
            g[key] = np.asarray(v, dtype="u1" if key == "collapsed" else ("i4" if key in ("scenario", "sample")
                                                                          else float))
        g["status"] = np.zeros(len(cols["mw"]), dtype="i4")
        g["message"] = np.array([b""] * len(cols["mw"]), dtype="S64")
        f.attrs["column"] = json.dumps({"name": "test column"})
        f.attrs["grid_signature"] = json.dumps({"synthetic": True})
        f.attrs["complete"] = True
    return str(path)


CELLS = {(6.5, 5.0): (40, 3, 0.1), (6.5, 10.0): (40, 1, 0.05), (7.5, 5.0): (40, 9, 0.3), (7.5, 10.0): (40, 4, 0.2)}
SITE = f"""name = "tree test site"
outside = "zero"
[pulse]
model = "pulse-only"
[[sources]]
name = "fault"
rate = {NU}
magnitude = {{type = "characteristic", mw = 7.5}}
distance = {{type = "fixed", r_km = 10.0}}
"""
FACTORS = """[[branch_sets]]
name = "rate"
choice = "rate_factor"
branches = [{value = 0.5, weight = 0.25}, {value = 1.0, weight = 0.5}, {value = 2.0, weight = 0.25}]
"""


@pytest.fixture
def files(tmp_path):
    h5 = write_cells(tmp_path / "p.h5", CELLS)
    site = tmp_path / "site.toml"
    site.write_text(SITE)
    tree = tmp_path / "tree.toml"
    tree.write_text(FACTORS)
    return site, tree, h5


def test_surrogate_mean_and_quantiles_of_collapse_are_exact(files):
    """Rates (0.5, 1, 2) nu p with weights (0.25, 0.5, 0.25): mean (0.125 + 0.5 + 0.5) nu p = 1.125 nu p.
    Cumulative weights (0.25, 0.75, 1): 5 % and 16 % below 0.25 hold 0.5 nu p; 50 %: 0.5 + 0.5 x 0.25/0.5 =
    0.75; 84 %: 1 + 0.09/0.25 = 1.36; 95 %: 1 + 0.2/0.25 = 1.8 (times nu p). The single model (the site file
    as it is) is nu p exactly; P(50 yr) of the tree is the weighted mean of 1 - exp(-f nu p 50)."""
    site, tree, h5 = files
    tr = tree_grid.tree_risk(site, tree, h5, n_draws=50, rng=0)
    assert [e.path for e in tr.ends] == ["rate=0.5", "rate=1", "rate=2"]
    assert tr.base.rate["collapse"][0] == NU * P
    assert [r.rate["collapse"][0] for r in tr.branch_risk] == pytest.approx([f * NU * P for f in (0.5, 1, 2)], rel=1e-15)
    s = tr.stats["collapse"]
    assert s["mean"] == pytest.approx(1.125 * NU * P, rel=1e-12)
    expected = {0.05: 0.5, 0.16: 0.5, 0.5: 0.75, 0.84: 1.36, 0.95: 1.8}
    for q, x in expected.items():
        assert s["quantiles"][q] == pytest.approx(x * NU * P, rel=1e-12), q
    p50 = sum(w * -math.expm1(-f * NU * P * 50) for f, w in ((0.5, 0.25), (1, 0.5), (2, 0.25)))
    assert tr.prob_stats[50.0]["collapse"]["mean"] == pytest.approx(p50, rel=1e-12)
    # every branch has the same draws (common random numbers): the interval scales with the rate exactly
    lo = [r.rate["collapse"][1] / r.rate["collapse"][0] for r in tr.branch_risk]
    assert lo == pytest.approx([lo[1]] * 3, rel=1e-12)
    assert s["tornado"][0]["set"] == "rate" and s["tornado"][0]["swing"] == pytest.approx(1.5 * NU * P, rel=1e-12)


def test_a_tree_of_one_branch_equal_to_the_site_gives_the_single_model_exactly(files, tmp_path):
    """One set of one alternative that changes nothing (rate_factor 1, weight 1): every level's mean and every
    quantile equal the single model's rate bit for bit."""
    site, _, h5 = files
    tree = tmp_path / "one.toml"
    tree.write_text('[[branch_sets]]\nchoice = "rate_factor"\nbranches = [{value = 1.0, weight = 1.0}]\n')
    tr = tree_grid.tree_risk(site, tree, h5, n_draws=50, rng=0)
    for label in tr.labels:
        assert tr.stats[label]["mean"] == tr.base.rate[label][0], label
        assert all(x == tr.base.rate[label][0] for x in tr.stats[label]["quantiles"].values()), label


def test_command_writes_the_tree_outputs_beside_the_single_model(files, tmp_path, capsys):
    site, tree, h5 = files
    out = tmp_path / "out"
    assert risk.main([str(site), h5, str(out), "--logic-tree", str(tree), "--no-figures", "--draws", "50"]) == 0
    printed = capsys.readouterr().out
    assert "logic tree: 3 end branches" in printed and "matters most for collapse: rate" in printed
    for name in ("risk.md", "risk.json", "logic_tree.md", "logic_tree.json"):
        assert (out / name).is_file(), name
    js = json.loads((out / "logic_tree.json").read_text())
    assert js["levels"]["collapse"]["mean"] == pytest.approx(1.125 * NU * P, rel=1e-12)
    assert [e["weight"] for e in js["end_branches"]] == [0.25, 0.5, 0.25]
    md = (out / "logic_tree.md").read_text()
    assert "| collapse |" in md and "branch set that matters most for collapse: **rate**" in md


def test_the_tree_in_the_site_file_itself(files, tmp_path):
    _, _, h5 = files
    site = tmp_path / "with_tree.toml"
    site.write_text(SITE + "\n[logic_tree]\n" + FACTORS.replace("[[branch_sets]]", "[[logic_tree.branch_sets]]"))
    tr = tree_grid.tree_risk(site, site, h5, n_draws=50, rng=0)
    assert len(tr.ends) == 3 and tr.base.rate["collapse"][0] == NU * P


def test_sampled_trees_compute_each_path_once(files, tmp_path, monkeypatch):
    """samples = 20 of 3 paths: 20 end branches of weight 1/20, at most 3 site risks besides the single model."""
    site, _, h5 = files
    tree = tmp_path / "sampled.toml"
    tree.write_text("samples = 20\nseed = 5\n" + FACTORS)
    calls = []
    real = grid_route.site_risk
    monkeypatch.setattr(grid_route, "site_risk", lambda *a, **k: calls.append(1) or real(*a, **k))
    tr = tree_grid.tree_risk(site, tree, h5, n_draws=50, rng=0)
    assert len(tr.ends) == 20 and set(tr.weights.tolist()) == {1 / 20}
    assert len(calls) == 1 + len({e.index for e in tr.ends}) <= 4


@pytest.mark.parametrize("tree_text, match", [
    ('[[branch_sets]]\nchoice = "vp_scale"\nbranches = [{value = 1.0, weight = 0.5}, {value = 2.0, weight = 0.5}]\n',
     r"'vp_scale' \(vp_scale\) change the runs.*rare-event route.*--simulate OUTDIR --logic-tree"),
    ('[[branch_sets]]\nchoice = "rate_factor"\nbranches = [{value = 1.0, weight = 0.5}, {value = 2.0, weight = 0.6}]\n',
     "sum to 1.1"),
    ('[[branch_sets]]\nchoice = "b"\nbranches = [{value = 1.0, weight = 1.0}]\n',
     "applies to Gutenberg-Richter sources"),
])
def test_command_refuses_a_bad_tree_before_any_risk(files, tmp_path, capsys, tree_text, match, monkeypatch):
    site, _, h5 = files
    tree = tmp_path / "bad.toml"
    tree.write_text(tree_text)
    monkeypatch.setattr(grid_route, "site_risk", lambda *a, **k: pytest.fail("a risk was computed"))
    assert risk.main([str(site), h5, str(tmp_path / "out"), "--logic-tree", str(tree), "--no-figures"]) == 2
    import re
    assert re.search(match, capsys.readouterr().err)
    assert not (tmp_path / "out").exists()


def test_simulate_with_a_tree_and_grid_files_is_refused(files, tmp_path, capsys):
    """The tree on the rare-event route (tests/test_logic_tree_rare.py) takes no grid files beside it."""
    site, tree, h5 = files
    assert risk.main([str(site), h5, "--simulate", str(tmp_path / "x"), "--logic-tree", str(tree)]) == 2
    assert "takes no grid files" in capsys.readouterr().out
    assert not (tmp_path / "x").exists()


def test_pulse_model_override_and_a_pulse_model_set_are_refused_together(files, tmp_path):
    site, _, h5 = files
    tree = tmp_path / "pulse.toml"
    tree.write_text('[[branch_sets]]\nchoice = "pulse_model"\nbranches = [{value = {probability = 1.0}, weight = 1.0}]\n')
    with pytest.raises(ParameterError, match="would override the tree's pulse_model"):
        tree_grid.tree_risk(site, tree, h5, pulse_only=True, n_draws=50)
    assert Path(site).read_text() == SITE


def test_a_generator_instead_of_a_seed_is_refused(files):
    """A Generator would give each branch other draws (no common random numbers): an integer seed is needed."""
    site, tree, h5 = files
    with pytest.raises(ParameterError, match="integer seed"):
        tree_grid.tree_risk(site, tree, h5, n_draws=50, rng=np.random.default_rng(0))


def test_a_branch_the_grid_route_refuses_is_named(files, tmp_path):
    """The site (G-R Mw 6.5-7.5 inside the grid, outside = "refuse") is computed; a branch whose Mmax is 8.0 puts
    part of the rate beyond the grid, which the risk refuses: the message names that branch."""
    _, _, h5 = files
    site = tmp_path / "gr.toml"
    site.write_text(SITE.replace('outside = "zero"', 'outside = "refuse"').replace(
        '{type = "characteristic", mw = 7.5}', '{type = "gutenberg-richter", b = 1.0, m_min = 6.5, m_max = 7.5}'))
    tree = tmp_path / "t.toml"
    tree.write_text('[[branch_sets]]\nchoice = "m_max"\nbranches = [{value = 7.5, weight = 0.5}, {value = 8.0, weight = 0.5}]\n')
    with pytest.raises(ParameterError, match=r"logic tree branch 'm_max=8': source 'fault' lies partly outside"):
        tree_grid.tree_risk(site, tree, h5, n_draws=50)
