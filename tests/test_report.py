"""Report from a small synthetic results file (tests/test_figures.write_results).

Checks content, not numbers: the numbers are those of pycolfrag.analysis.fragility, tested in
tests/test_fragility.py; here the per-scenario rows, the failed-run count and the figure links.
"""
import numpy as np

from pycolfrag.analysis import report
from test_figures import write_results


def test_report_tables_and_links(tmp_path):
    res = write_results(tmp_path / "grid.h5", mws=(6.5, 7.5), dists=(5.0, 20.0), n=20, n_failed=2)
    (tmp_path / "figures").mkdir()
    (tmp_path / "figures" / "fig07_ud_vs_utop.png").write_bytes(b"\x89PNG")
    out = report.write_report(res, tmp_path / "report.md", n_boot=50)
    text = open(out).read()
    assert "failed (excluded from all statistics): 2" in text
    for row in ("| 6.5 | 5 |", "| 6.5 | 20 |", "| 7.5 | 5 |", "| 7.5 | 20 |"):
        assert text.count(row) == 3          # statistics table and the two exceedance tables
    assert "u_top > 0.35 (Significant damage)" in text and "u_d > 0.02 (Significant deformation)" in text
    assert "![fig07_ud_vs_utop](figures/fig07_ud_vs_utop.png)" in text
    assert "PGV (cm/s)" in text


def test_binomial_ci():
    # Clopper-Pearson 90 % for 0/100: upper limit 1 - 0.05**(1/100) = 0.0295 (closed form)
    lo, hi = report.binomial_ci(0, 100)
    assert lo == 0 and np.isclose(hi, 1 - 0.05 ** (1 / 100), rtol=1e-6)
    assert report.fmt_ci(np.nan) == "n/a"
