"""Figures from a small synthetic results file: each is produced without error and labelled.

The file is written here with plain h5py following docs/architecture.md ("Results file"); the
numbers are a made-up but plausible response model (only the plumbing is tested, not pixels).
"""
import json

import h5py
import numpy as np
import pytest

from pycolfrag.analysis import figures


def write_results(path, seed=0, mws=(6.0, 6.5, 7.0, 7.5), dists=(5.0, 10.0, 20.0), n=30, n_failed=3,
                  vp_scale=1.0, complete=None, pending=0):
    """A small results file in the documented layout; the first ``n_failed`` rows fail (status 3), the last
    ``pending`` are not computed yet (status -1); ``complete``: the root attribute a grid run writes
    (absent when None, as in a file written by other code)."""
    rng = np.random.default_rng(seed)
    mw = np.repeat(np.repeat(mws, len(dists)), n).astype(float)
    dist = np.tile(np.repeat(dists, n), len(mws)).astype(float)
    rows = mw.size
    scen = np.repeat(np.arange(len(mws) * len(dists)), n)
    sample = np.tile(np.arange(n), len(mws) * len(dists))
    vp = vp_scale * 10 ** (-5.17 + 1.98 * np.minimum(mw, 7) - 0.14 * np.minimum(mw, 7) ** 2
                           - 0.10 * np.log10(dist ** 2 + 0.562) + 0.16 * rng.standard_normal(rows))
    fp = 1 / 10 ** (-2.87 + 0.47 * mw + 0.18 * rng.standard_normal(rows))
    pgv = vp * np.exp(0.2 * rng.standard_normal(rows))
    pga = 0.02 * pgv ** 0.8 * np.exp(0.3 * rng.standard_normal(rows))
    ap = np.pi * fp * vp / 981
    u_top = 0.004 * pgv * np.exp(0.6 * rng.standard_normal(rows))
    collapsed = u_top > 1.1
    u_d = 0.01 * u_top * np.exp(0.8 * rng.standard_normal(rows))
    u_top[collapsed] = np.nan
    u_d[collapsed] = np.nan
    status = np.zeros(rows, dtype="i4")
    status[:n_failed] = 3
    if pending:
        status[-pending:] = -1
    periods = np.array([0.5, 1.0, 2.0])
    sa = pga[:, None] * np.array([2.0, 1.2, 0.5])
    sv = sa * 981 * periods / (2 * np.pi)
    cols = dict(mw=mw, dist_km=dist, scenario=scen.astype("i4"), sample=sample.astype("i4"), vp_cm_s=vp,
                fp_hz=fp, nu_rad=rng.uniform(-1.5, 1.5, rows), gamma=1.8 + 0.4 * rng.random(rows),
                pga_g=pga, pgv_cm_s=pgv, u_top=u_top, u_d=u_d, collapsed=collapsed.astype("u1"), status=status,
                wall_s=np.ones(rows), ap_g=ap, a_cm_s=vp, t0_s=np.full(rows, 10.0), pgd_cm=pgv,
                tp_s=1 / fp)
    with h5py.File(path, "w") as f:
        g = f.create_group("samples")
        for k, v in cols.items():
            g[k] = v
        g["message"] = np.array([b"synthetic failure" if s else b"" for s in status], dtype="S64")
        sp = f.create_group("spectra")
        sp["sa_g"] = sa
        sp["sv_cm_s"] = sv
        sp.attrs["periods_s"] = periods
        f.attrs["seed"] = seed
        f.attrs["n_ranks"] = 1
        f.attrs["version"] = "test"
        f.attrs["git_revision"] = "none"
        f.attrs["column"] = json.dumps({"name": "synthetic"})
        f.attrs["solver"] = json.dumps({"contact": "vertex"})
        f.attrs["created"] = "2026-01-01T00:00:00Z"
        f.attrs["vp_scale"] = vp_scale
        f.attrs["grid_signature"] = json.dumps({"synthetic": True, "seed": seed})
        if complete is not None:
            f.attrs["complete"] = bool(complete)
    return path


@pytest.fixture(scope="module")
def results_file(tmp_path_factory):
    return write_results(tmp_path_factory.mktemp("res") / "grid.h5")


def _check_labelled(fig):
    assert fig.axes, "figure has no axes"
    title = fig.get_suptitle() if hasattr(fig, "get_suptitle") else ""
    for ax in fig.axes:
        if ax.get_label() == "<colorbar>":
            continue
        assert ax.get_xlabel() and ax.get_ylabel(), f"unlabelled axes in {title!r}"
        assert ax.get_title() or title, "figure without a title"
        labels = ax.get_xlabel() + ax.get_ylabel() + (ax.get_zlabel() if ax.name == "3d" else "")
        assert "(" in labels and ")" in labels, f"no unit in {labels!r}"


def test_read_results_excludes_failed(results_file):
    d = figures.read_results(results_file)
    assert d.n_failed == 3 and d.n == d.n_total - 3 == 4 * 3 * 30 - 3
    assert d.failures == {3: 3}
    assert d["collapsed"].dtype == bool


@pytest.mark.parametrize("stem", sorted(figures.FIGURES))
def test_each_figure_labelled(results_file, stem):
    d = figures.read_results(results_file)
    fig = figures.FIGURES[stem](d, n_boot=30, rng=1)
    assert fig is not None
    _check_labelled(fig)
    # units expected on particular figures
    text = " ".join(a.get_xlabel() + " " + a.get_ylabel() for a in fig.axes)
    if stem.startswith(("fig08_", "fig12_", "fig13_")):
        assert "R (km)" in text and all(a.name == "3d" for a in fig.axes)
    if stem.startswith(("fig08m", "fig12m", "fig13m")):   # their 2-D maps (tests/test_report_readable.py)
        assert "R (km)" in text and any(a.get_label() == "<colorbar>" for a in fig.axes)
    if stem.startswith("fig11"):
        assert "Tp = 1/fp (s)" in text and "PGA (g)" in text
        lines = [ln for ln in fig.axes[2].get_lines() if "rocking" in ln.get_label()]
        assert lines and np.allclose(lines[0].get_ydata(), 0.17)
    if stem.startswith("fig16_"):
        assert "PGA (g)" in text and "PGV (cm/s)" in text
    if stem.startswith("fig09"):
        assert "Vp (cm/s)" in text and "(g" in text


def test_make_all_writes_png_and_pdf(results_file, tmp_path):
    paths = figures.make_all(results_file, tmp_path / "fig", n_boot=20)
    assert len(paths) == 2 * len(figures.FIGURES)
    for p in paths:
        with open(p, "rb") as fh:
            head = fh.read(8)
        assert head.startswith(b"\x89PNG") or head.startswith(b"%PDF")


def test_no_pulse_file_has_no_pulse_figures(tmp_path):
    """A no-pulse grid (run_grid.py --pulse none) has NaN pulse fields: Figs. 9 and 11 (pulse amplitude and
    period) are left out instead of drawn empty; every other figure is written."""
    import h5py
    path = write_results(tmp_path / "none.h5", mws=(6.5, 7.5), dists=(5.0, 20.0), n=20, n_failed=0)
    with h5py.File(path, "r+") as f:
        for k in ("vp_cm_s", "fp_hz", "nu_rad", "gamma", "t0_s", "tp_s", "a_cm_s", "ap_g"):
            f["samples"][k][...] = np.nan
        f.attrs["pulse"] = "none"
    paths = figures.make_all(path, tmp_path / "fig", n_boot=20, formats=("png",))
    stems = {p.rsplit("/", 1)[-1][:-4] for p in paths}
    assert stems == set(figures.FIGURES) - {"fig09_pulse_amplitudes", "fig11_pulse_period_collapse"}


def test_missing_file(tmp_path):
    with pytest.raises(ValueError):
        figures.read_results(tmp_path / "nope.h5")


def test_degenerate_fits_are_marked_in_the_figures(tmp_path):
    """Two runs per scenario: the Eq. (4) surfaces say in how many scenarios Eq. (4) is degenerate (fewer
    than 5 runs). 60 runs evenly spread in PGA and PGV, the top 3 collapsed: each of the 12 equal-width
    stripes holds 5 runs, the top one only 2 standing (fewer than 5 behind its lognormal part), and the
    Fig. 16 legends say so."""
    import warnings

    from pycolfrag.analysis.data import ResultsData, read_results
    from pycolfrag.analysis.fragility import DegenerateFitWarning
    d = read_results(write_results(tmp_path / "g.h5", mws=(6.0, 6.5, 7.0, 7.5), dists=(5.0, 20.0), n=2,
                                   n_failed=0))
    x = np.linspace(0.1, 1.0, 60)
    coll = np.arange(60) >= 57
    s = {"mw": np.full(60, 7.0), "dist_km": np.full(60, 5.0), "pga_g": x, "pgv_cm_s": 100 * x,
         "u_top": np.where(coll, np.nan, 0.5 * x), "u_d": np.where(coll, np.nan, 0.02 * x), "collapsed": coll}
    spread = ResultsData(s, None, None, None, {}, 60, 0)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DegenerateFitWarning)
        f12 = figures.fig_12(d, n_boot=20)
        f16 = figures.fig_16(spread, n_boot=20)
    assert all("Eq. (4) degenerate in 8 of 8 scenarios: only 2 runs in the group" in ax.get_title()
               for ax in f12.axes)
    legends = [t.get_text() for ax in f16.axes for t in ax.get_legend().get_texts()]
    assert "P(u_top \u2265 0.15 | PGA): stripes, Eq. (4) (1 degenerate)" in legends
