"""Coverage of the site risk's default 90 % intervals, measured by subsampling the default grid.

The reference is the default grid of 100 runs per cell (tests/data/default_grid_edps.npz, its EDPs;
tests/data/README.md). Drawing 20 of each cell's 100 runs and computing the risk of the example site
(pulse branch alone: the default grid has no no-pulse twin) gives an interval; how often it contains
the 100-run value is its coverage (pycolfrag.risk.coverage). The 20 runs are part of the
100, so an exact 90 % interval contains the 100-run value about 93.4 % of the time
(risk_coverage.expected_coverage). With R = 150 repetitions the measured coverage has a standard
error of about sqrt(0.934 * 0.066 / 150) = 0.020; a method is called honest here when every level's
coverage is at least 0.88, under 0.934 by 2.7 standard errors. The percentile bootstrap, the default
before, stays under that for several levels (0.80-0.86 at 300 repetitions, docs/risk.md).
"""
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from pycolfrag.analysis.data import ResultsData
from pycolfrag.risk import site_risk as risk
from pycolfrag.risk.coverage import expected_coverage, subsample_coverage
from pycolfrag.risk.uncertainty import DEFAULT_UNCERTAINTY
from pycolfrag.site import sources as site_file

ROOT = Path(__file__).resolve().parents[1]
REPS, DRAWS = 150, 300


def _grid():
    g = dict(np.load(ROOT / "tests" / "data" / "default_grid_edps.npz"))
    assert g["mw"].size == 3500 and np.unique(np.stack([g["mw"], g["dist_km"]]), axis=1).shape[1] == 35
    return ResultsData(g, None, None, None, {"complete": True}, 3500, 0, {}, "default grid")


def _site():
    return replace(site_file.load_site(ROOT / "examples" / "site_athens.toml"), outside="zero")


def test_expected_coverage_of_an_exact_interval():
    """2 Phi(1.6449 / sqrt(0.8)) - 1 = 2 Phi(1.8390) - 1 = 0.93410 (by hand from the normal table)."""
    assert expected_coverage(0.90, 20, 100) == pytest.approx(0.93410, abs=5e-5)


def test_default_intervals_cover_at_20_runs_per_cell():
    cov, above, _, _ = subsample_coverage(_site(), _grid(), reps=REPS, n_draws=DRAWS,
                                          estimator=risk.DEFAULT_ESTIMATOR, uncertainty=DEFAULT_UNCERTAINTY)
    low = {k: v for k, v in cov.items() if v < 0.88}
    assert not low, f"coverage under 0.88: {low} (truth above the interval: {above})"


def test_the_percentile_bootstrap_under_covers_there():
    """The measurement can fail: the method the default replaced misses for some level."""
    cov, _, _, _ = subsample_coverage(_site(), _grid(), reps=REPS, n_draws=DRAWS,
                                      estimator=risk.DEFAULT_ESTIMATOR, uncertainty="bootstrap")
    assert min(cov.values()) < 0.88, cov


def test_zero_events_do_not_give_a_zero_interval(tmp_path):
    """No collapse in 20 runs: the estimate is 0, the upper limit is not. The gamma interval with
    y = 0 and v = 0 is the exponential of mean w_M = nu / n (one more event in the cell), whose
    95 % quantile is w_M (-ln 0.05) = 2.996 w_M: the exact Poisson upper limit of 0 events."""
    from test_risk import char_source, site, write_cells
    nu, n = 0.004, 20
    h5 = write_cells(tmp_path / "p.h5", {(7.0, 10.0): (n, 0, 0.05)})
    res = risk.site_risk(site([char_source(7.0, 10.0, rate=nu)]), h5, curves=False)
    lam, lo, hi = res.rate["collapse"]
    assert lam == 0.0 and lo == 0.0
    assert hi == pytest.approx(nu / n * -np.log(0.05), rel=1e-12)
    old = risk.site_risk(site([char_source(7.0, 10.0, rate=nu)]), h5, curves=False, uncertainty="bootstrap")
    assert old.rate["collapse"][1:] == (0.0, 0.0)          # what the percentile bootstrap said


def test_a_results_file_is_subsampled(tmp_path, capsys):
    """``bench/risk_coverage.py --results FILE`` refused every subsample, because the
    subset kept the file's ``samples`` attribute (30 runs per cell) and so read as an incomplete file
    of 2 x 30 rows holding 2 x 10. A complete file of 2 cells x 30 runs, 10 kept per cell: the bench
    prints its table, one row per estimator, method and level (each level a share in [0, 1])."""
    import importlib.util

    import h5py

    from test_risk import char_source, site, write_cells
    h5 = write_cells(tmp_path / "g.h5", {(6.5, 10.0): (30, 1, 0.1), (7.0, 10.0): (30, 2, 0.2)})
    with h5py.File(h5, "a") as f:   # the grid's own attributes, as run_grid writes them
        f.attrs["mw"] = [6.5, 7.0]
        f.attrs["dist_km"] = [10.0]
        f.attrs["samples"] = 30
    s = site([char_source(6.5, 10.0, rate=0.001, name="a"), char_source(7.0, 10.0, rate=0.001, name="b")])
    cov, _, _, truth = subsample_coverage(s, h5, n_sub=10, reps=3, n_draws=50)
    assert set(cov) == set(truth) and all(0.0 <= v <= 1.0 for v in cov.values())
    spec = importlib.util.spec_from_file_location("bench_risk_coverage", ROOT / "bench" / "risk_coverage.py")
    bench = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(bench)
    site_path = tmp_path / "site.toml"
    site_path.write_text(
        'name = "two faults"\n[pulse]\nmodel = "pulse-only"\n'
        + "".join(f'[[sources]]\nname = "f{m}"\nrate = 0.001\nmagnitude = {{ type = "characteristic", mw = {m} }}\n'
                  f'distance = {{ type = "fixed", r_km = 10.0 }}\n' for m in (6.5, 7.0)))
    assert bench.main(["--results", h5, "--site", str(site_path), "--runs", "10", "--reps", "2", "--draws", "50",
                       "--estimators", risk.DEFAULT_ESTIMATOR, "--methods", DEFAULT_UNCERTAINTY]) == 0
    rows = [r for r in capsys.readouterr().out.splitlines() if r.startswith(f"| {risk.DEFAULT_ESTIMATOR} |")]
    assert len(rows) == len(cov)
