"""The analysis of a record-suite file (pycolfrag.analysis.record_report, ``record_checks.py analyse``) and the
closing outputs of ``run_grid.py --records`` on the demo suite (3 records x h1/h2 x 4 scales = 24
runs, about a second)."""
import os
import sys

import numpy as np
import pytest

sys.path.insert(0, os.path.dirname(__file__))
import record_suite as rs  # noqa: E402
from pycolfrag import results as R  # noqa: E402
from pycolfrag.analysis import record_report  # noqa: E402
from test_figures import write_results  # noqa: E402
from test_grid import _ok, _serial  # noqa: E402

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


@pytest.fixture(scope="module")
def suite_file(tmp_path_factory):
    d = tmp_path_factory.mktemp("rr")
    suite = rs.write_suite(d / "suite")
    out = d / "records.h5"
    syn = write_results(d / "grid.h5", mws=(6.0, 7.0), dists=(10.0, 20.0), n=10, n_failed=0)
    p = _ok(_serial(["--records", str(suite), "--scale", "0.5", "1", "2", "4", "--no-progress",
                     "--synthetic", str(syn), "--out", str(out)]))
    return out, syn, p


def test_run_grid_records_writes_the_analysis(suite_file):
    """At the end of a --records run: report.md and the figures in <out>_analysis/ (no synthetic-grid
    figures, which need scenarios)."""
    out, syn, p = suite_file
    d = out.parent / "records_analysis"
    assert "record_report.write_record_report" in p.stdout
    for name in ("report.md", "stripes.png", "stripes.csv", "cloud.png", "msa.png", "fig10_records.png"):
        assert (d / name).exists(), name
    text = (d / "report.md").read_text()
    for heading in ("## Runs per record", "## Cloud analysis", "## Multiple-stripe fragility", "## Stripes"):
        assert heading in text
    assert f"against `{syn}`" in text


def test_analysis_numbers(suite_file):
    """The cloud slope on PGA is the OLS of ln u_top on ln PGA over the standing successful runs
    (numpy.polyfit gives the same line); the MSA fit has one stripe per scale factor (4) with all
    24 runs; the stripes CSV has a row per stripe, IM and level."""
    out, _, _ = suite_file
    t = record_report.suite_table(out)
    a = record_report.analyse(t)
    ok = (t["status"] == 0) & ~t["collapsed"]
    b, a0 = np.polyfit(np.log(t["pga_g"][ok]), np.log(t["u_top"][ok]), 1)
    fit = a["cloud"][("pga_g", "u_top")]
    assert fit.b == pytest.approx(b, rel=1e-9) and fit.a == pytest.approx(a0, rel=1e-9)
    assert fit.n == int(ok.sum()) and fit.n_collapsed == int(t["collapsed"].sum())
    assert a["scales"] == [0.5, 1.0, 2.0, 4.0]
    msa = a["msa"][("pga_g", "u_top > 0.15")]
    assert len(msa.im_levels) == 4 and int(msa.n_trials.sum()) == 24
    rows = (out.parent / "records_analysis" / "stripes.csv").read_text().splitlines()
    assert rows[0].startswith("im,period_s,level") and len(rows) > 1 + 4 * 6


def test_analysis_refuses_a_synthetic_file(tmp_path):
    syn = write_results(tmp_path / "grid.h5", mws=(6.0,), dists=(20.0,), n=5, n_failed=0)
    with pytest.raises(R.ResultsFileError, match="not a record-suite results file"):
        record_report.suite_table(syn)
    assert record_report.main([str(syn), str(tmp_path / "x")]) == 2


def test_synthetic_grid_outputs_refuse_a_record_suite_file(suite_file, tmp_path, capsys):
    """The converse: the scenario report and the paper's figures pool rows by (Mw, R) scenario, which
    for a suite would mix the four scale factors into one probability. Each refuses the file and names
    the command that analyses it; the command line exits 2 with that message, not a traceback."""
    from pycolfrag.analysis import figures, report
    out, _, _ = suite_file
    with pytest.raises(R.ResultsFileError, match="record-suite results file.*pycolfrag record-report"):
        report.write_report(out, tmp_path / "report.md")
    assert not (tmp_path / "report.md").exists()
    assert report.main([str(out), str(tmp_path / "report.md")]) == 2
    assert "pycolfrag record-report" in capsys.readouterr().err
    with pytest.raises(R.ResultsFileError, match="record-suite"):
        figures.make_all(out, tmp_path / "figs")


def test_degenerate_msa_fits_are_marked_in_the_report(suite_file, tmp_path, monkeypatch):
    """The report prints a fit's own degenerate reason beside its median, for exactly the fits that
    carry one (the demo suite's stripes overlap, so one fit is made to carry one here), and the stripes
    CSV has the stripes' flags."""
    from pycolfrag.analysis.fragility import suites
    out, _, _ = suite_file
    real = suites.msa_fragility
    seen = []

    def flag_first(*a, **kw):
        f = real(*a, **kw)
        if not seen:
            f.degenerate = "beta = 5 is on the optimiser's bound [0.02, 5]"
        seen.append(f)
        return f

    monkeypatch.setattr(suites, "msa_fragility", flag_first)   # the name msa_from_table calls
    text = open(record_report.write_record_report(out, tmp_path / "a", figures=False)).read()
    assert text.count("(degenerate: beta = 5 is on the optimiser's bound [0.02, 5])") == 1
    header = (tmp_path / "a" / "stripes.csv").read_text().splitlines()[0]
    assert header.endswith(",degenerate")
