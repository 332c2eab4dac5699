"""The site risk's refusals and marks: branches that are not one pair, incomplete files, degenerate and
misfitting Eq. (4) fits, and the command's answers to bad folders and numbers.

Results files are written here in the documented layout (tests/test_risk.py's ``write_cells``);
expected numbers come from scipy's binomial test and by hand, as each test says.
"""
import errno
import json
import re
import warnings

import h5py
import numpy as np
import pytest
from scipy import stats

from pycolfrag.analysis import fragility as fr
from pycolfrag.core.errors import ParameterError, ResultsFileError
from pycolfrag.risk import report as risk_report
from pycolfrag.risk import site_risk as risk
from pycolfrag.risk.fit import two_sided_pvalue
from test_risk import char_source, site, write_cells

CELLS = {(7.0, 10.0): (40, 10, 0.3), (7.0, 20.0): (40, 2, 0.1)}
NOPULSE = {(7.0, 10.0): (40, 1, 0.05), (7.0, 20.0): (40, 0, 0.02)}


def _attrs(path, **kw):
    with h5py.File(path, "r+") as f:
        for k, v in kw.items():
            if v is None:
                del f.attrs[k]
            else:
                f.attrs[k] = v
    return path


def _pair(tmp_path):
    return (write_cells(tmp_path / "p.h5", CELLS), write_cells(tmp_path / "n.h5", NOPULSE, pulse="none", seed=1))


def _half(nu=0.004):
    return site([char_source(7.0, 10.0, rate=nu)], pulse={"probability": 0.3})


# --------------------------------------------------------------------------- branch pairing

def test_a_no_pulse_branch_with_another_seed_is_refused(tmp_path):
    pulse, nopulse = _pair(tmp_path)
    _attrs(pulse, seed=20160601)
    _attrs(nopulse, seed=7)
    with pytest.raises(ParameterError, match=r"p\.h5 was made with seed 20160601 and .*n\.h5 with seed 7"):
        risk.site_risk(_half(), pulse, nopulse, curves=False)
    _attrs(nopulse, seed=20160601)
    res = risk.site_risk(_half(), pulse, nopulse, curves=False, n_draws=20)
    assert res.identity["no-pulse"]["seed"] == "20160601"
    assert "seed 20160601" in risk.report_section(res)


def test_a_no_pulse_branch_of_other_code_is_refused(tmp_path):
    """code_digest where both files have one; else version and the signature's result_hash."""
    pulse, nopulse = _pair(tmp_path)
    _attrs(pulse, code_digest="a" * 16)
    _attrs(nopulse, code_digest="b" * 16)
    with pytest.raises(ParameterError, match=r"different code \(code_digest 'aaaa+' against 'bbbb+'\)"):
        risk.site_risk(_half(), pulse, nopulse, curves=False)
    build = lambda h: json.dumps({"synthetic": True, "build": {"version": "0.1.0", "result_hash": h}})
    _attrs(pulse, code_digest=None, grid_signature=build("9fcb3f0f8f9d44ae"))
    _attrs(nopulse, code_digest=None, grid_signature=build("0123456789abcdef"), pulse="none")
    with pytest.raises(ParameterError, match=r"different code \(version/result_hash \('0\.1\.0', '9fcb"):
        risk.site_risk(_half(), pulse, nopulse, curves=False)
    _attrs(nopulse, grid_signature=build("9fcb3f0f8f9d44ae"), code_digest="c" * 16)   # newer file, same build
    assert risk.site_risk(_half(), pulse, nopulse, curves=False, n_draws=20).rate


# --------------------------------------------------------------------------- incomplete files

def test_an_incomplete_file_is_refused_unless_asked_and_then_marked(tmp_path, capsys):
    pulse, nopulse = _pair(tmp_path)
    _attrs(pulse, mw=[6.0, 7.0], dist_km=[10.0, 20.0], samples=21)   # asks for 84 rows; 80 there
    with pytest.raises(ResultsFileError, match=r"p\.h5 holds 80 of the 84 rows .*--allow-incomplete"):
        risk.site_risk(_half(), pulse, nopulse, curves=False)
    res = risk.site_risk(_half(), pulse, nopulse, curves=False, n_draws=20, allow_incomplete=True)
    assert res.incomplete and "INCOMPLETE RESULTS" in risk.report_section(res)
    assert all("INCOMPLETE results" in risk_report.level_marks(res, q.label) for q in risk.QUANTITIES)
    sf = tmp_path / "site.toml"
    sf.write_text('[pulse]\nprobability = 0.3\n[[sources]]\nname = "f"\nrate = 0.004\n'
                  'magnitude = { type = "characteristic", mw = 7.0 }\ndistance = { type = "fixed", r_km = 10 }\n')
    args = [str(sf), pulse, str(tmp_path / "out"), "--no-pulse", nopulse, "--draws", "20", "--no-figures"]
    assert risk.main(args) == 2 and "holds 80 of the 84 rows" in capsys.readouterr().err
    assert risk.main(args + ["--allow-incomplete"]) == 0
    assert capsys.readouterr().out.startswith("INCOMPLETE results (asked for explicitly)")
    js = json.loads((tmp_path / "out" / "risk.json").read_text())
    assert js["incomplete"] and js["checks"]["collapse"]["marks"] == ["INCOMPLETE results"]


def test_missing_rows_make_a_file_incomplete_whatever_its_flag(tmp_path):
    """The grid asked for 2 Mw x 1 R x 40 samples = 80 rows (its mw, dist_km, samples attributes)."""
    pulse = write_cells(tmp_path / "p.h5", {(6.0, 10.0): (40, 1, 0.1), (7.0, 10.0): (39, 4, 0.3)})
    _attrs(pulse, mw=[6.0, 7.0], dist_km=[10.0], samples=40)
    with pytest.raises(ResultsFileError, match=r"holds 79 of the 80 rows"):
        risk.site_risk(site([char_source(7.0, 10.0)]), pulse, curves=False)


# --------------------------------------------------------------------------- degenerate fits

def test_degenerate_fits_warn_once_per_cause_and_are_marked(tmp_path):
    """Cells of 4 runs: Eq. (4) is not an estimate in any of them (fewer than MIN_FIT_POINTS = 5).
    One warning per cause, however many cells, levels, curve points and resamples: the old code
    warned once per call of exceedance (hundreds); the levels carry the mark in every output."""
    cells = {(m, r): (4, 0, 0.2) for m in (6.0, 6.5, 7.0) for r in (5.0, 10.0, 20.0)}
    h5 = write_cells(tmp_path / "p.h5", cells)
    src = {"name": "f", "rate": 0.01, "magnitude": {"type": "gutenberg-richter", "b": 1.0, "m_min": 6.0,
                                                    "m_max": 7.0}, "distance": {"type": "uniform", "min_km": 5.0,
                                                                                "max_km": 20.0}}
    with warnings.catch_warnings(record=True) as w:
        warnings.simplefilter("always")
        res = risk.site_risk(site([src]), h5, estimator="eq4", n_draws=50, curve_draws=20)
    deg = [x for x in w if issubclass(x.category, fr.DegenerateFitWarning)]
    causes = res.degeneracy.causes
    assert len(deg) == len(causes) == 1, [str(x.message) for x in deg]
    assert "only 4 runs in the group" in str(deg[0].message) and "18 cell(s)" in str(deg[0].message)
    assert res.checks["u_top > 0.15"]["degenerate"] == 9
    md = risk.report_section(res)
    assert "Eq. (4) not an estimate in 9 cell(s)" in md and "Eq. (4) not an estimate: only 4 runs" in md
    js = res.to_json()
    assert js["checks"]["u_d > 0.01"]["degenerate_cells"] == 9 and "only 4 runs in the group" in \
        next(iter(js["degenerate_eq4"]))


# --------------------------------------------------------------------------- fit of Eq. (4)

def _bimodal(path, n=40, k=10):
    """One cell: n - k standing runs with u_d near 1e-4, k near 0.05 (u_top = 50 u_d): no lognormal."""
    rng = np.random.default_rng(5)
    u_d = np.where(np.arange(n) < k, 0.05, 1e-4) * np.exp(0.1 * rng.standard_normal(n))
    h5 = write_cells(path, {(7.0, 10.0): (n, 0, 0.1)})
    with h5py.File(h5, "r+") as f:
        f["samples/u_d"][...] = u_d
        f["samples/u_top"][...] = 50 * u_d
    return h5, u_d


def test_eq4_failing_its_fit_test_falls_back_to_the_count(tmp_path):
    """Eq. (4) of the bimodal cell at u_d > 0.02 predicts n P = 40 x 0.08 exceedances where 10
    happened; scipy.stats.binomtest(10, 40, P) rejects it (p < 0.05). Under Eq. (4) the cell then takes
    the empirical ratio 10/40 (fallback) or keeps Eq. (4) and marks it (warn)."""
    h5, u_d = _bimodal(tmp_path / "p.h5")
    nu = 0.003
    P = fr.exceedance(u_d, np.zeros(40, bool), 0.02)
    ref = stats.binomtest(10, 40, P).pvalue
    assert 0.05 < P < 0.12 and ref < 0.05
    s = site([char_source(7.0, 10.0, rate=nu)])
    fb = risk.site_risk(s, h5, estimator="eq4", curves=False, n_draws=50)
    fit = fb.checks["u_d > 0.02"]["fits"][0]
    assert fit.expected[0, 0] == pytest.approx(40 * P, rel=1e-12) and fit.observed[0, 0] == 10
    assert fit.p_cell[0, 0] == pytest.approx(ref, rel=1e-9) and fit.failed[0, 0]
    assert fb.rate["u_d > 0.02"][0] == pytest.approx(nu * 10 / 40, rel=1e-14)
    assert "failed its fit test in 1 cell(s): empirical ratio there" in risk.report_section(fb)
    warn = risk.site_risk(s, h5, estimator="eq4", eq4_misfit="warn", curves=False, n_draws=50)
    assert warn.rate["u_d > 0.02"][0] == pytest.approx(nu * P, rel=1e-12)
    assert "kept (warn)" in "; ".join(risk_report.level_marks(warn, "u_d > 0.02"))
    assert fb.to_json()["checks"]["u_d > 0.02"]["eq4_fit"][0]["failed"] == [[True]]


def test_a_row_fails_where_no_single_cell_can(tmp_path):
    """Five cells of one magnitude, each the same 40 lognormal quantiles of u_d (median e^-5.112, beta
    0.6) with the one value above 0.02 lowered to 0.0199: Eq. (4) expects about 0.8 exceedances of
    u_d > 0.02 per cell and none happen. A cell alone cannot tell (scipy.stats.binomtest(0, 40, P)
    p 0.4), the row can: its total is Binomial(200, P) since the cells are equal, binomtest(0, 200, P)
    p < 0.05. The cells then fall back to the count (0) under Eq. (4)."""
    z = stats.norm.ppf((np.arange(40) + 0.5) / 40)
    u_d = np.minimum(np.exp(-5.112 + 0.6 * z), 0.0199)
    cells = {(7.0, r): (40, 0, 0.1) for r in (5.0, 7.5, 10.0, 15.0, 20.0)}
    h5 = write_cells(tmp_path / "p.h5", cells)
    with h5py.File(h5, "r+") as f:
        f["samples/u_d"][...] = np.tile(u_d, 5)
        f["samples/u_top"][...] = np.tile(50 * u_d, 5)
    P = fr.exceedance(u_d, np.zeros(40, bool), 0.02)
    assert stats.binomtest(0, 40, P).pvalue > 0.3 and stats.binomtest(0, 200, P).pvalue < 0.05
    res = risk.site_risk(site([char_source(7.0, 10.0)]), h5, estimator="eq4", curves=False, n_draws=50)
    fit = res.checks["u_d > 0.02"]["fits"][0]
    assert fit.p_row[0] == pytest.approx(stats.binomtest(0, 200, P).pvalue, rel=1e-9)
    assert np.all(fit.p_cell > 0.3) and np.all(fit.failed)
    assert res.rate["u_d > 0.02"][0] == 0.0


def test_row_p_value_is_the_exact_poisson_binomial_one():
    """Two cells of the same p: their total is Binomial(n1 + n2, p), so the row's p-value equals
    scipy.stats.binomtest's; a single cell is binomtest itself."""
    for o in (0, 3, 9, 17):
        assert two_sided_pvalue(o, [20, 30], [0.2, 0.2]) == pytest.approx(stats.binomtest(o, 50, 0.2).pvalue,
                                                                          rel=1e-9)
    assert two_sided_pvalue(4, [25], [0.05]) == pytest.approx(stats.binomtest(4, 25, 0.05).pvalue, rel=1e-9)


def test_row_p_value_of_a_vanishing_p():
    """A fit can put p at 6e-309 in a cell (measured on a tiny grid of dowelled columns; scipy's pmf
    overflowed there): 0 of 30 is then certain (p-value 1, binomtest's for p = 0) and 1 of 30 impossible
    (p-value 0), next to a cell of an ordinary p the row is that cell's binomtest."""
    assert two_sided_pvalue(0, [30], [6.1e-309]) == 1.0
    assert two_sided_pvalue(1, [30], [6.1e-309]) == 0.0
    assert two_sided_pvalue(3, [30, 20], [6.1e-309, 0.1]) == pytest.approx(stats.binomtest(3, 20, 0.1).pvalue,
                                                                           rel=1e-9)


# --------------------------------------------------------------------------- the command's answers

def _site_file(tmp_path):
    sf = tmp_path / "site.toml"
    sf.write_text('[pulse]\nprobability = 0.3\n[[sources]]\nname = "f"\nrate = 0.004\n'
                  'magnitude = { type = "characteristic", mw = 7.0 }\ndistance = { type = "fixed", r_km = 10 }\n')
    return str(sf)


def test_command_answers_bad_folders_and_numbers_with_a_message(tmp_path, capsys, monkeypatch):
    pulse, nopulse = _pair(tmp_path)
    base = [_site_file(tmp_path), pulse]
    tail = ["--no-pulse", nopulse, "--no-figures"]
    afile = tmp_path / "afile"
    afile.write_text("x")
    cases = [
        ([str(afile)] + tail, r"afile is a file, not a folder"),
        ([str(afile / "sub")] + tail, r"afile is a file, not a folder"),
        ([str(tmp_path / "o")] + tail + ["--seed", "-1"], r"seed must be >= 0, got -1"),
        ([str(tmp_path / "o")] + tail + ["--draws", "100000000"], r"n_draws = 100000000 would take 3\.0 GiB"),
    ]
    for args, match in cases:
        assert risk.main(base + args) == 2, args
        err = capsys.readouterr().err
        assert "error:" in err and re.search(match, err), err
    with pytest.raises(SystemExit) as e:                   # argparse: --draws takes a whole number
        risk.main(base + [str(tmp_path / "o"), "--draws", "1e8"])
    assert e.value.code == 2 and "invalid int value: '1e8'" in capsys.readouterr().err
    folder_site = [str(tmp_path), pulse, str(tmp_path / "o")] + tail
    assert risk.main(folder_site) == 2 and "is a folder, not a regular file" in capsys.readouterr().err
    monkeypatch.setattr(risk_report.os, "access", lambda p, mode: False)           # a read-only folder
    assert risk.main(base + [str(tmp_path / "ro")] + tail) == 2
    assert "cannot be written (permission denied)" in capsys.readouterr().err


def test_a_full_disk_leaves_no_half_file(tmp_path, capsys, monkeypatch):
    pulse, nopulse = _pair(tmp_path)
    out = tmp_path / "out"
    real = risk_report.os.fdopen

    def full(fd, *a, **k):
        fh = real(fd, *a, **k)
        fh.write = lambda text: (_ for _ in ()).throw(OSError(errno.ENOSPC, "No space left on device"))
        return fh
    monkeypatch.setattr(risk_report.os, "fdopen", full)
    assert risk.main([_site_file(tmp_path), pulse, str(out), "--no-pulse", nopulse, "--no-figures"]) == 2
    err = capsys.readouterr().err
    assert "cannot write the risk outputs into" in err and "No space left on device" in err
    assert sorted(p.name for p in out.iterdir()) == []        # no risk.md, no leftover temporary file


# --------------------------------------------------------------------------- the docs' example numbers

def test_example_numbers_are_written_from_the_risk_files(tmp_path):
    """scripts/risk_example.py builds docs/risk.md's example block from risk.json files: the collapse
    share of the top cell is the deaggregation's maximum (equal weights at R 10 and 20 km, p = 0.3:
    0.3 x 10/40 + 0.7 x 1/40 = 0.0925 at 10 km against 0.3 x 2/40 + 0.7 x 0 = 0.015 at 20 km, so 86 %),
    the pulse-alone ratio is the two files' rates' ratio,
    and --write replaces the block and nothing else. docs/risk.md carries exactly one block."""
    import importlib.util
    from pathlib import Path
    root = Path(__file__).resolve().parents[1]
    spec = importlib.util.spec_from_file_location("risk_example", root / "scripts" / "risk_example.py")
    ex = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(ex)
    pulse, nopulse = _pair(tmp_path)
    sf = tmp_path / "site.toml"
    sf.write_text('[pulse]\nprobability = 0.3\n[[sources]]\nname = "f"\nrate = 0.004\n'
                  'magnitude = { type = "characteristic", mw = 7.0 }\n'
                  'distance = { type = "discrete", r_km = [10.0, 20.0], weights = [0.5, 0.5] }\n')
    out = tmp_path / "risk"
    assert risk.main([str(sf), pulse, str(out), "--no-pulse", nopulse, "--no-figures", "--draws", "20"]) == 0
    assert risk.main([str(sf), pulse, str(out / "pulse_only"), "--pulse-only", "--no-figures", "--draws", "20"]) == 0
    text = ex.block(out)
    base = json.loads((out / "risk.json").read_text())
    alone = json.loads((out / "pulse_only" / "risk.json").read_text())
    assert "86 % of the collapse rate comes from Mw 7, R 10 km" in text
    ratio = alone["rate_per_year"]["collapse"][0] / base["rate_per_year"]["collapse"][0]
    assert f"(collapse {ratio:.2f})" in text and "Collapses: 12 in the 80 pulse runs, 1 in the 80 no-pulse" in text
    page = tmp_path / "page.md"
    page.write_text(f"before\n{ex.BEGIN}\nold\n{ex.END}\nafter\n")
    assert ex.main([str(out), "--write", str(page)]) == 0
    assert page.read_text() == "before\n" + text.rstrip("\n") + "\nafter\n"
    doc = (root / "docs" / "risk.md").read_text()
    assert doc.count(ex.BEGIN) == 1 and doc.count(ex.END) == 1


# --------------------------------------------------------------------------- scenarios not computed yet

def _half_grid(tmp_path):
    """A grid that asked for Mw 6, 6.5, 7 x R 10, 20 km x 40 samples and holds the Mw 6 and 6.5 rows only."""
    p = write_cells(tmp_path / "p.h5", {(6.0, 10.0): (40, 1, 0.1), (6.0, 20.0): (40, 0, 0.05),
                                        (6.5, 10.0): (40, 3, 0.2), (6.5, 20.0): (40, 1, 0.1)})
    return _attrs(p, mw=[6.0, 6.5, 7.0], dist_km=[10.0, 20.0], samples=40)


@pytest.mark.parametrize("outside", ["refuse", "clamp", "zero"])
def test_a_source_on_scenarios_not_computed_yet_is_not_outside_nor_zero(tmp_path, outside):
    """An Mw 7 source on a grid that asked for Mw 7 but has no Mw 7 row yet: it was called 'outside the
    simulated range' (refused), clamped onto the Mw 6.5 rows, or every rate 0 [0, 0] as if known. Its rate
    falls on scenarios not computed yet: refused as such, whatever the outside treatment."""
    with pytest.raises(ParameterError, match=r"none of the site's rate falls on the scenarios computed so far "
                                             r"\(Mw 6-6\.5, R 10-20 km of the grid asked for, Mw 6-7.*finish the run"):
        risk.site_risk(site([char_source(7.0, 10.0)], outside=outside), _half_grid(tmp_path), curves=False,
                       n_draws=20, allow_incomplete=True)


def test_rates_with_a_part_not_computed_yet_are_lower_bounds(tmp_path, capsys):
    """A truncated G-R source (b = 1, Mw 5.8-7) on that grid: the part above Mw 6.5 falls on the Mw 7
    scenarios not computed yet, (10^-0.7 - 10^-1.2) / (1 - 10^-1.2) = 0.1456 of its rate (by hand), and
    counts 0: every rate is a lower bound, said in the marks, the table ('>='), the printout and the JSON.
    The part below Mw 6, 0.3939 of the rate ((1 - 10^-0.2) / (1 - 10^-1.2)), is outside the grid asked for
    and treated as the site says; nothing above is called outside."""
    src = {"name": "f", "rate": 0.01, "magnitude": {"type": "gutenberg-richter", "b": 1.0, "m_min": 5.8,
                                                    "m_max": 7.0}, "distance": {"type": "uniform", "min_km": 10.0,
                                                                                "max_km": 20.0}}
    res = risk.site_risk(site([src], outside="zero"), _half_grid(tmp_path), curves=False, n_draws=20,
                         allow_incomplete=True)
    [o] = res.outside
    assert o.not_computed == pytest.approx((10 ** -0.7 - 10 ** -1.2) / (1 - 10 ** -1.2), rel=1e-9)
    assert o.mw_below == pytest.approx((1 - 10 ** -0.2) / (1 - 10 ** -1.2), rel=1e-9) and o.mw_above == 0.0
    assert all(res.rate[q.label][0] > 0 for q in risk.QUANTITIES)
    assert all("LOWER BOUND (14.6 % of the rate on scenarios not computed yet" in "; ".join(
        risk_report.level_marks(res, q.label)) for q in risk.QUANTITIES)
    text = risk.report_section(res)
    assert "| collapse | >= " in text and "every rate is a LOWER BOUND" in text
    risk_report.print_summary(res, 50.0)
    out = capsys.readouterr().out
    assert "14.6 % of its rate falls on scenarios of the grid asked for that are not computed yet" in out
    assert "collapse: lambda >= " in out and "outside the simulated range (Mw below 39.4 %, above 0.0 %" in out
    js = res.to_json()
    assert js["rates_are_lower_bounds"] and js["not_computed_share"] == pytest.approx(o.not_computed)
