"""Restoration alternatives on the same events through the rare-event estimator (pycolfrag/risk/restoration_rare.py,
restoration_rare_report.py, paired_difference.py; docs/restoration.md, "On the same events").

* the paired difference on the surrogate column of tests/rare_surrogate.py (outcomes in closed form): the
  alternative is the surrogate with pulse motions twice as strong (:class:`Scaled` of tests/test_logic_tree_rare.py),
  whose exact rates are the surrogate's with A_TOP[pulse] + ln 2 (u_top x 2: the closed form of
  rare_surrogate.exact_rates, scipy quadrature, independent of the strata and weights), so the exact difference is
  known; the point difference is lambda_B - lambda_A of the two estimates (the same rows and weights: round-off);
* the command with real runs on the tiny site of tests/test_rare_site_plumbing.py (four strata, records cut to 3 s),
  the free Parthenon column, titanium dowels and the 2-column portal: every alternative's stored event inputs and
  rows' event fields identical, the portal's responses its own;
* bad input refused, naming the value.
"""
from __future__ import annotations

import json
import math
from pathlib import Path

import h5py
import numpy as np
import pytest

import rare_surrogate
from pycolfrag.core.errors import ParameterError, ResultsFileError
from pycolfrag.rare.paired import simulate_paired
from pycolfrag.risk import restoration_rare as rr
from pycolfrag.risk import restoration_rare_report as report
from pycolfrag.risk.paired_difference import EVENT_FIELDS, check_same_events, paired_differences
from pycolfrag.risk.site_risk import QUANTITIES
from pycolfrag.site.sources import site_from_dict
from pycolfrag.structure.column import Column
from test_logic_tree_rare import SETTINGS, SMALL, STOP, Scaled, site_dict
from test_report_json import strict_loads

ROOT = Path(__file__).resolve().parents[1]
EX = ROOT / "examples"


def _pair(seed=7, scale=2.0, fail_at=math.inf):
    from pycolfrag.rare.driver import SiteSettings
    site = site_from_dict(site_dict(), "small")
    settings = SETTINGS if seed == 7 else SiteSettings(seed=seed, batch=200, **SMALL)
    return simulate_paired(site, settings, STOP, [Scaled(1.0), Scaled(scale, fail_at)], QUANTITIES,
                           log=lambda s: None)


def _exact(monkeypatch, scale: float) -> dict:
    site = site_from_dict(site_dict(), "small")
    base = rare_surrogate.exact_rates(site, QUANTITIES)
    with monkeypatch.context() as m:
        m.setitem(rare_surrogate.A_TOP, True, rare_surrogate.A_TOP[True] + math.log(scale))
        scaled = rare_surrogate.exact_rates(site, QUANTITIES)
    return {k: scaled[k] - base[k] for k in base}


def test_the_paired_difference_is_the_difference_of_the_estimates():
    """The same rows and weights, no failed run: D = lambda_B - lambda_A to round-off; the alternative's stronger
    pulses raise every level (D >= 0); pairing beats two independent simulations where the outcomes are correlated
    (u_top > 0.15: most exceedances are the same runs' in both)."""
    a, b = _pair()
    diffs = paired_differences(a, b)
    for q in QUANTITIES:
        d = diffs[q.label]
        assert d.difference == pytest.approx(b.estimate.levels[q.label].rate - a.estimate.levels[q.label].rate,
                                             rel=1e-12, abs=1e-18)
        assert d.difference >= 0 and d.pairs == a.runs and d.failed == 0
    assert diffs["u_top > 0.15"].pairing_gain > 1.2      # measured 1.48 at seed 7


def test_a_paired_difference_on_a_surrogate_with_a_known_answer(monkeypatch):
    """12 paired simulations (seeds 100-111, 670 runs each): for every level the mean difference lies within 3
    standard errors of the exact one (scipy quadrature of the surrogate with and without the doubled pulses), the
    stated sd is within a factor 2 of the spread over the seeds, and at least 8 of 12 of the 90 % intervals hold
    the exact difference (binomial(12, 0.9): P(at most 7) = 0.004)."""
    exact = _exact(monkeypatch, 2.0)
    reps = [paired_differences(*_pair(seed=100 + i)) for i in range(12)]
    for q in QUANTITIES:
        d = np.array([r[q.label].difference for r in reps])
        sd = np.array([r[q.label].sd for r in reps])
        se = d.std(ddof=1) / math.sqrt(d.size)
        assert abs(d.mean() - exact[q.label]) <= 3 * se, q.label
        assert 0.5 <= np.mean(sd) / d.std(ddof=1) <= 2.0, q.label
        assert sum(r[q.label].low <= exact[q.label] <= r[q.label].high for r in reps) >= 8, q.label


def test_a_stratum_none_of_whose_rows_differ_adds_its_floor():
    """Two strata (tests/test_rare_floor.py's: A 1 /yr, B 9 /yr, no pulse): in A 4 of 20 rows differ (B exceeds where
    A does not), in B neither setting exceeds in 5 rows. Before the floor B added nothing to V_D, as if 5 alike rows
    proved the settings alike there; now it adds 81 x min(Jeffreys' m2 p0 - p0^2, the two settings' floors there) / 5
    (both settings' floors are Jeffreys' here: the minimum is that, p0 = 0.5 / 6, m2 = 1), by hand below."""
    from types import SimpleNamespace

    from pycolfrag.rare.estimate import estimate, jeffreys_floor
    from pycolfrag.rare.proposal import Design
    from test_rare_floor import _Q, _cols, _Strata

    def run(y_a):
        cols = _cols(y_a, 5)
        floor = jeffreys_floor(cols, _Strata(), Design(), [_Q()])
        est = estimate(cols, _Strata(), Design(), [_Q()], floor=floor)
        return SimpleNamespace(cols=cols, strata=_Strata(), design=Design(), quantities=[_Q()], estimate=est,
                               floor=floor)
    y_a = np.zeros(20)
    y_b = np.zeros(20)
    y_b[[1, 6, 11, 16]] = 1
    d = paired_differences(run(y_a), run(y_b))["collapse"]
    var_a = float(np.var(y_b - y_a, ddof=1)) / 20           # 4 of 20 differ by 1: (4 x 0.8^2 + 16 x 0.2^2) / 19
    p0 = 0.5 / 6
    assert d.difference == pytest.approx(0.2, rel=1e-14)
    assert d.sd ** 2 == pytest.approx(var_a + 81 * (p0 - p0 * p0) / 5, rel=1e-12)


def test_failed_runs_bound_the_difference():
    """The alternative fails its strongest motions (u_top >= 2): the failed runs are counted and bound D."""
    a, b = _pair(scale=3.0, fail_at=2.0)
    d = paired_differences(a, b)["collapse"]
    assert d.failed > 0 and d.failed_low < d.difference < d.failed_high


def test_rows_of_other_events_are_refused_naming_the_row_and_field():
    a, b = _pair()
    cols = {k: np.array(v, copy=True) for k, v in b.cols.items()}
    cols["hf_seed"][3] += 1
    with pytest.raises(ParameterError, match=r"hf_seed is .* in free and .* in portal: not the same events"):
        check_same_events(a.cols, cols, ("free", "portal"))
    cols = {k: np.asarray(v)[1:] for k, v in b.cols.items()}
    with pytest.raises(ParameterError, match="finished runs"):
        check_same_events(a.cols, cols)


# --------------------------------------------------------------------------- the command, real runs

SITE = ROOT / "tests" / "data" / "site_rare_tiny.toml"
ALTS = [f"free={EX / 'column_parthenon.toml'}", f"titanium={EX / 'column_parthenon_titanium.toml'}",
        f"portal={EX / 'portal_2.toml'}"]
QUICK = ["--max-record-s", "3", "--pilot", "2", "--max-runs", "16", "--batch", "8", "--seed", "3", "--no-progress"]


@pytest.fixture(scope="module")
def folder(tmp_path_factory):
    out = tmp_path_factory.mktemp("restoration") / "rare"
    args = [str(SITE)] + [x for a in ALTS for x in ("--alternative", a)] + ["--simulate", str(out)] + QUICK
    code = rr.main(args)
    assert code in (0, 6), code          # 6: the budget (16 runs) before the target CoV, as asked
    return out


def test_the_alternatives_see_the_same_events(folder):
    """Every batch's plan (its purpose and every run's inputs: Mw, R, noise seed, pulse parameters, tags) is the
    same file content in every alternative's folder, and so are the rows' event fields; the structures differ
    (the portal's rows record its epistyle, the free column's none)."""
    keys = ["free", "titanium", "portal"]
    plans = sorted(p.name for p in (folder / "free").glob("batch_*.plan.json"))
    assert len(plans) == 2            # the pilot (8 runs) and a production batch (4)
    for name in plans:
        texts = {k: json.loads((folder / k / name).read_text()) for k in keys}
        assert texts["free"]["inputs"] == texts["titanium"]["inputs"] == texts["portal"]["inputs"]
        assert texts["free"]["purpose"] == texts["portal"]["purpose"]
        h5 = name.replace(".plan.json", ".h5")
        rows = {}
        for k in keys:
            with h5py.File(folder / k / h5, "r") as f:
                rows[k] = {x: f["samples"][x][()] for x in EVENT_FIELDS + ("epistyle_slip_mm",) if x in f["samples"]}
        for x in EVENT_FIELDS:
            if x in rows["free"]:
                np.testing.assert_array_equal(rows["free"][x], rows["portal"][x], err_msg=f"{h5} {x}")
                np.testing.assert_array_equal(rows["free"][x], rows["titanium"][x], err_msg=f"{h5} {x}")
        assert np.all(np.isnan(rows["free"]["epistyle_slip_mm"]))
        assert np.all(np.isfinite(rows["portal"]["epistyle_slip_mm"]))
    js = strict_loads((folder / "restoration.json").read_text())      # no NaN or Infinity: strict JSON
    assert [a["key"] for a in js["alternatives"]] == keys and js["reference"] == "free"
    assert sorted(js["differences"]) == ["portal", "titanium"]
    assert all(a["runs"] == 16 for a in js["alternatives"])
    assert "restoration-rare" not in (folder / "restoration.md").read_text()     # the block's text alone
    assert (folder / report.FIGURE).read_bytes().startswith(b"\x89PNG")


def test_a_folder_begun_with_other_alternatives_is_refused(folder, capsys):
    args = [str(SITE), "--alternative", ALTS[0], "--alternative", f"titanium={EX / 'column_parthenon_wood.toml'}",
            "--alternative", ALTS[2], "--simulate", str(folder)] + QUICK
    assert rr.main(args) == 2
    assert "begun with other alternatives (titanium: another structure)" in capsys.readouterr().out
    alts = rr.load_alternatives(ALTS[::-1])
    with pytest.raises(ResultsFileError, match="another order"):
        rr.check_folder(folder, alts)


@pytest.mark.parametrize("items, match", [
    ([ALTS[0]], r"at least two --alternative .*'free="),
    (["free", ALTS[1]], r"expects KEY=FILE .* got 'free'"),
    ([ALTS[0], "a b=x.toml"], r"the key 'a b' names a folder"),
    ([ALTS[0], ALTS[0].replace("free=", "titanium=")], r"'titanium=.*' is the same structure as 'free'"),
    ([ALTS[0], ALTS[1].replace("titanium=", "free=")], r"the key 'free' is given twice"),
    ([ALTS[0], "wood=no_such_column.toml"], r"'wood=no_such_column.toml'.*'no_such_column.toml' is not a file"),
    ([ALTS[0], f"site={SITE}"], r"--alternative 'site=.*site_rare_tiny.toml'"),
])
def test_bad_alternatives_are_refused_naming_the_value(items, match):
    with pytest.raises(ParameterError, match=match):
        rr.load_alternatives(items)


def test_the_command_refuses_a_column_option_before_any_run(tmp_path, capsys):
    out = tmp_path / "r"
    args = [str(SITE), "--alternative", ALTS[0], "--alternative", ALTS[1], "--simulate", str(out),
            "--column", str(EX / "column_parthenon.toml")] + QUICK
    assert rr.main(args) == 2
    assert "--column" in capsys.readouterr().out and not out.exists()


def test_the_figure_says_what_it_shows():
    """Rates on a linear axis from 0 and differences about 0, each with its interval; the title says it is the
    model's rate at the example site per alternative, not the monument's real risk."""
    a, b = _pair()
    alts = [rr.Alternative("free", "free.toml", Column.parthenon()), rr.Alternative("stronger", "s.toml", Column.parthenon())]
    result = {"alternatives": alts, "runs": [a, b], "differences": {"stronger": paired_differences(a, b)}}
    fig = report.figure(result)
    title = fig.get_suptitle()
    assert title.startswith(report.TITLE) and "the model's rate, not the monument's real risk" in title
    axes = np.array(fig.axes).reshape(len(QUANTITIES), 2)
    for ax in axes.ravel():
        assert ax.get_xscale() == "linear"
    assert all(ax.get_xlim()[0] == 0 for ax in axes[:, 0])
    lo, hi = axes[0, 1].get_xlim()
    assert lo < paired_differences(a, b)["u_top > 0.15"].difference < hi
    md = report.markdown(result)
    assert "not the monument's real risk" in md and "| u_top > 0.15 |" in md
