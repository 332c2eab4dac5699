"""What a new reader of report.md and the figures needs: the EDPs defined, the column as
a table (not a cut JSON blob), a caption under every figure, medians to 3 significant digits, Eq. (4)
cells that contradict their runs marked, 2-D maps of Figs. 8/12/13 with colour bars, Fig. 16's axis
label and its fits that miss their stripes flagged.

The results files are the small synthetic ones of tests/test_figures.write_results; the numbers they
give are those of pycolfrag.analysis.fragility (tested in tests/test_fragility.py), so these tests
check what the outputs say and mark, not the statistics.
"""
import json
import re
import warnings
from types import SimpleNamespace

import h5py
import numpy as np
import pytest

import pycolfrag as pcf
from pycolfrag.analysis import figures, report
from pycolfrag.analysis import report_text as rt
from pycolfrag.analysis.data import ResultsData
from pycolfrag.analysis.fit_check import stripe_departures
from test_figures import write_results


@pytest.fixture(scope="module")
def report_text(tmp_path_factory):
    """A report of a file whose column attribute is the default column's (as a grid writes it), with
    every figure drawn beside it."""
    tmp = tmp_path_factory.mktemp("rep")
    res = write_results(tmp / "grid.h5", mws=(6.5, 7.5), dists=(5.0, 20.0), n=20, n_failed=2)
    with h5py.File(res, "a") as f:
        f.attrs["column"] = json.dumps(pcf.Column.parthenon().to_dict())
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        figures.make_all(res, tmp / "figures", n_boot=20, formats=("png",))
    return open(report.write_report(res, tmp / "report.md", n_boot=50), encoding="utf-8").read()


def test_edps_are_defined_at_the_top(report_text):
    head = report_text[:report_text.index("## Run")]
    assert "**u_top** (-): the largest horizontal displacement of the capital relative to the base" in head
    assert "divided by the base diameter" in head
    assert "**u_d** (-): the residual dislocation" in head and "averaged over the last 2 s" in head
    assert "divided by the diameter at that joint" in head


def test_the_column_is_a_table_not_a_cut_blob(report_text):
    """The default column: 12 drums and a capital (13 blocks), 10.08 m, base diameter 1.65 m, 2700 kg/m3,
    kn = 1e9 Pa/m, friction 37 degrees (pycolfrag.structure.column.Column.parthenon)."""
    col = report_text[report_text.index("### The column"):report_text.index("## Collapse")]
    assert "13 blocks, height 10.08 m, base diameter 1.650 m" in col and "density 2700 kg/m\u00b3" in col
    assert "kn = 1e+09 Pa/m" in col and "friction angle 37\u00b0" in col
    assert "| block | name | height (m) | bottom diameter (m) | top diameter (m) | sides |" in col
    assert "| 1 | drum 1 | 0.7817 | 1.650 | 1.619 | 10 |" in col
    assert '{"' not in col and "..." not in col


def test_a_scene_and_dowels_are_described():
    """The 2-column portal (examples/portal_2.toml: axes 4 m apart, a 1.35 m epistyle) and the wooden
    dowels (examples/column_parthenon_wood.toml: the `wood` law, 5e6 N/m, crushing at 10 kN, breaking at
    20 mm); a description that is not a model is listed key by key, not cut."""
    from pathlib import Path

    from pycolfrag.structure.scene import Colonnade
    ex = Path(__file__).resolve().parents[1] / "examples"
    portal = "\n".join(rt.model_lines(Colonnade.from_file(ex / "portal_2.toml").to_json()))
    assert "2 columns, axes 4.000 m apart; an epistyle 1.350 m high over every span" in portal
    assert "| 13 | " in portal
    wood = "\n".join(rt.model_lines(json.dumps(pcf.Column.from_file(ex / "column_parthenon_wood.toml").to_dict())))
    assert "law `wood` (clearance): shear stiffness 5e+06 N/m, yield 10.0 kN, breaks at 20.0 mm" in wood
    long = {"name": "x", "note": "y" * 600}
    listed = "\n".join(rt.model_lines(json.dumps(long)))
    assert "y" * 600 in listed and "could not be read as a model" in listed


def test_every_figure_has_a_caption(report_text):
    """Each embedded figure is followed by its caption (italic), which names what is drawn and a unit."""
    links = re.findall(r"!\[(\w+)\]\(figures/\1\.png\)\n\n\*(.+?)\*\n", report_text)
    assert {stem for stem, _ in links} == set(figures.FIGURES)
    for stem, caption in links:
        assert caption == rt.CAPTIONS[stem]
        assert re.search(r"\((g|cm/s|km|s|Hz|-)\b|dimensionless|\(-\)|, -\)", caption), (stem, caption)


def test_numbers_to_three_significant_digits(report_text):
    assert rt.sig(11286.634) == "11300"      # the median of the issue
    assert rt.sig(0.052345) == "0.0523" and rt.sig(1.0) == "1.00" and rt.sig(-7.0) == "-7.00"
    assert rt.sig(2.5e-6) == "2.50e-06" and rt.sig(0) == "0" and rt.sig(np.nan) == "n/a"
    table = report_text[report_text.index("| IM | level |"):report_text.index("## Figures")]
    medians = [row.split(" | ")[3] for row in table.splitlines()[2:] if row.startswith("| ") and "/" in row]
    assert medians
    for cell in medians:
        for num in re.findall(r"\d[\d.]*", cell.split(" (")[0]):
            digits = num.replace(".", "").lstrip("0")
            assert len(digits.rstrip("0") if "." not in num else digits) <= 3, (num, cell)


def test_eq4_cells_that_contradict_their_runs_are_marked():
    """The issue's cell: Eq. (4) 0.08 [0.06, 0.10] of 100 runs against 1 observed exceedance, whose
    exact 90 % interval is [0.0005, 0.046]: disjoint, marked. 0 of 20 observed against 0.001
    [0.0002, 0.003] is within the runs' sampling error ([0, 0.139]): not marked."""
    row = SimpleNamespace(ci={"L": (0.06, 0.10)}, empirical={"L": 0.01}, n=100)
    assert report._outside(row, "L")
    assert not report._outside(SimpleNamespace(ci={"L": (0.0002, 0.003)}, empirical={"L": 0.0}, n=20), "L")
    assert not report._outside(SimpleNamespace(ci={"L": (0.05, 0.12)}, empirical={"L": 0.08}, n=100), "L")


def test_a_marked_cell_in_the_report(tmp_path):
    """A scenario whose standing runs are two clusters (30 at u_top ~ 0.2, 30 at ~ 0.001): the lognormal
    of all 60 is wide. Eq. (4) (seed 3, 100 resamples) gives 0.19 [0.13, 0.23] for u_top > 0.15 against
    30 of 60 observed, and 0.11 [0.07, 0.16] for > 0.35 against 0 of 60 (exact interval [0, 0.049]):
    both marked, the note explains; for > 1, 0.05 [0.04, 0.08] against 0 of 60 meets [0, 0.049]: not
    marked."""
    path = write_results(tmp_path / "g.h5", mws=(7.0,), dists=(10.0,), n=60, n_failed=0)
    rng = np.random.default_rng(3)
    u = np.concatenate([0.2 * np.exp(0.05 * rng.standard_normal(30)), 0.001 * np.exp(0.05 * rng.standard_normal(30))])
    with h5py.File(path, "a") as f:
        f["samples"]["u_top"][...] = u
        f["samples"]["u_d"][...] = u / 50
        f["samples"]["collapsed"][...] = 0
    text = open(report.write_report(path, tmp_path / "r.md", n_boot=100), encoding="utf-8").read()
    row = next(ln for ln in text.splitlines() if ln.startswith("| 7 | 10 | 60 | ") and "(0.50)" in ln)
    cells = row.split(" | ")
    cells = row.split(" | ")
    assert cells[3].endswith("(0.50)" + rt.OUTSIDE_MARK)      # > 0.15: 30 of 60 observed
    assert cells[4].endswith("(0.00)" + rt.OUTSIDE_MARK)      # > 0.35: none observed
    assert cells[5].endswith("(0.00) |")                      # > 1: within the runs' sampling error
    assert rt.OUTSIDE_NOTE in text
    assert rt.OUTSIDE_NOTE in text


def _non_lognormal():
    """600 runs whose exceedance rises with PGA to 0.7 g and falls to 0.15 beyond (a lognormal curve
    cannot follow it: its stripes above 0.7 g lie below the curve)."""
    rng = np.random.default_rng(1)
    n = 600
    pga = rng.uniform(0.05, 1.0, n)
    exc = rng.random(n) < np.where(pga < 0.7, np.clip((pga - 0.1) / 0.5, 0, 1), 0.15)
    u = np.where(exc, 0.5, 0.05) * np.exp(0.1 * rng.standard_normal(n))
    s = {"mw": np.repeat([6.5, 7.0, 7.5], n // 3), "dist_km": np.full(n, 10.0), "pga_g": pga, "pgv_cm_s": 100 * pga,
         "u_top": u, "u_d": u / 50, "collapsed": np.zeros(n, bool)}
    return ResultsData(s, None, None, None, {}, n, 0)


def test_fig16_label_and_a_fit_that_misses_its_stripes():
    d = _non_lognormal()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        fig = figures.fig_16(d, n_boot=20)
        lines = report._im_table(d, 50, np.random.default_rng(0))
    ylabels = [a.get_ylabel() for a in fig.axes]
    assert ylabels == ["P(u_top \u2265 level | PGA) (-)", "P(u_d \u2265 level | PGA) (-)",
                       "P(u_top \u2265 level | PGV) (-)", "P(u_d \u2265 level | PGV) (-)"]
    legend = [t.get_text() for t in fig.axes[0].get_legend().get_texts()]
    assert "P(u_top \u2265 0.35 | PGA): stripes, Eq. (4)" in " ".join(legend)
    rings = [ln for ln in fig.axes[0].get_lines() if "MLE misses" in ln.get_label()]
    assert rings and all(np.all(ln.get_xdata() > 0) for ln in rings)
    pga_rows = [ln for ln in lines if ln.startswith("| PGA (g) | u_top > 0.35 |")]
    assert len(pga_rows) == 1 and "**misses" in pga_rows[0] and report.MISS_MARK.strip() in pga_rows[0]
    assert any(ln.startswith(report.MISS_MARK.strip() + " A lognormal curve") for ln in lines)


def test_a_fit_that_follows_its_stripes_is_not_flagged():
    """Exceedance drawn from the lognormal fragility itself (median 0.4 g, beta 0.5): no stripe departs
    beyond its binomial interval at 90 % in this draw (the check is per stripe, so a true model can be
    flagged at one stripe in about 1 draw of 10 x 12; this seed is one that is not)."""
    from scipy import stats

    from pycolfrag.analysis import fragility as fr
    rng = np.random.default_rng(5)
    pga = rng.uniform(0.05, 1.0, 2000)
    exc = rng.random(pga.size) < stats.norm.cdf(np.log(pga / 0.4) / 0.5)
    u = np.where(exc, 0.5, 0.05)
    coll = np.zeros(pga.size, bool)
    sc = fr.stripe_curve(pga, u, coll, 0.35, n_boot=20, rng=0)
    mle = fr.fit_lognormal_fragility(pga, u, coll, 0.35, n_boot=0)
    assert mle.median == pytest.approx(0.4, rel=0.1)
    assert stripe_departures(sc, mle).size == 0


@pytest.mark.parametrize("stem, surfaces, shared", [
    ("fig08m_mean_edp_collapse_map", "fig08_mean_edp_collapse", False),
    ("fig12m_fragility_utop_map", "fig12_fragility_utop", True),
    ("fig13m_fragility_ud_map", "fig13_fragility_ud", True)])
def test_maps_with_colour_bars(stem, surfaces, shared, tmp_path):
    """The 2-D maps beside the 3-D surfaces: Figs. 12/13 three probability maps on one 0-1 scale with one
    colour bar; Fig. 8 three different quantities, a colour bar each."""
    d = figures.read_results(write_results(tmp_path / "g.h5", n=20))
    fig = figures.FIGURES[stem](d, n_boot=20, rng=1)
    maps = [a for a in fig.axes if a.get_label() != "<colorbar>"]
    bars = [a for a in fig.axes if a.get_label() == "<colorbar>"]
    assert len(maps) == 3 and all(a.name == "rectilinear" for a in maps)
    assert len(bars) == (1 if shared else 3) and all(b.get_ylabel() for b in bars)
    for a in maps:
        assert a.get_xlabel() == "R (km)" and a.get_ylabel() == "Mw (-)" and a.collections
    if shared:
        norms = {(a.collections[0].norm.vmin, a.collections[0].norm.vmax) for a in maps}
        assert norms == {(0.0, 1.0)} and "P(exceedance)" in bars[0].get_ylabel()
    # the 3-D surfaces stay
    assert all(a.name == "3d" for a in figures.FIGURES[surfaces](d, n_boot=20, rng=1).axes)
