"""The OpenQuake export's rules (pycolfrag.analysis.openquake.export): crossing fits fitted together, the
default IML range where the fits reach 1e-6 and 0.999, degenerate fits and incomplete files refused
unless asked for and then marked in the file and the printout.

Expected numbers: the cumulative probit fit itself (tests/test_fragility_ordered.py checks it against a
from-scratch likelihood) for the joint limit states, fit_lognormal_fragility for the others; the closed
form of a power-law hazard lambda(x) = k0 x^-k convolved with a lognormal fragility (theta, beta),
lambda_LS = lambda(theta) exp(k^2 beta^2 / 2), for the range rule -- OpenQuake's discretisation on 600
log-spaced levels reaches it within 0.3 % (tests/test_openquake.py), so 1 % is asserted.
"""
import math
import os
import sys
import warnings
from pathlib import Path

import numpy as np
import pytest

from pycolfrag.analysis import fragility as F
from pycolfrag.analysis import openquake as oq
from pycolfrag.analysis.fragility import U_TOP_LEVELS
from pycolfrag.cli import openquake as oq_cli
from pycolfrag.core.errors import ParameterError, ResultsFileError

sys.path.insert(0, os.path.dirname(__file__))
from test_figures import write_results  # noqa: E402

CASE1 = Path(__file__).resolve().parent / "data" / "oq_classical_damage_case_1"


def _crossing_table(n=600, seed=2):
    """Damage limitation (u_top > 0.15) with a wide curve (beta about 0.8) and collapse with a sharp one
    (about 0.2, overlapping outcomes): separately fitted, collapse is the more probable above about 0.6 g."""
    rng = np.random.default_rng(seed)
    pga = np.exp(rng.normal(np.log(0.3), 0.7, n))
    u = 0.5 * pga * np.exp(0.8 * rng.standard_normal(n))
    coll = pga > 0.45 * np.exp(0.2 * rng.standard_normal(n))
    return {"pga_g": pga, "u_top": np.where(coll, np.nan, u), "collapsed": coll.astype(int),
            "status": np.zeros(n, int)}


def test_crossing_fits_are_fitted_together_and_no_longer_cross():
    t = _crossing_table()
    x, coll = t["pga_g"], t["collapsed"] == 1
    sep = [F.fit_lognormal_fragility(x, t["u_top"], coll, 0.15), F.fit_lognormal_fragility(x, np.zeros(x.size), coll, 1.0)]
    grid = np.geomspace(0.01, 100, 2000)
    assert np.max(sep[1](grid) - sep[0](grid)) > 0.01          # the separate fits do cross
    m = oq.fragility_from_results(t, "pga_g", levels=U_TOP_LEVELS[:1])
    assert m.joint == (("damage_limitation", "collapse"),)
    ref = F.fit_ordered_fragility(x, np.array([F.exceeded(t["u_top"], coll, 0.15), coll]))
    for got, want in zip(m.fits, ref):     # other starts: L-BFGS-B stops at relative 1e-14 in the likelihood,
        # which leaves the parameters free to about its square root
        assert got.median == pytest.approx(want.median, rel=1e-6) and got.beta == pytest.approx(want.beta, rel=1e-6)
    lo, hi = m.domain
    assert m.crossing(np.geomspace(lo, hi, 5000)) == ""
    assert "damage_limitation, collapse crossed when fitted separately" in m.description
    hc = oq.read_hazard_curves(CASE1 / "hazard_curves_continuous.csv")
    assert np.all(oq.classical_damage(m, hc.imls, hc.poes[0], 50.0, 100.0)["damage"] >= 0)


def test_limit_states_that_do_not_cross_keep_their_own_fits(tmp_path, capsys):
    """The small synthetic grid's near collapse and collapse are nearly the same runs (u_top > 1.0 and
    > 1.1), as on the default grid, and cross: the documented export command works (the rule before
    refused it, exit 2) and fits them together; damage limitation stays its own fit."""
    h5 = write_results(tmp_path / "grid.h5", mws=(6.0, 6.5, 7.0, 7.5), dists=(5.0, 10.0), n=60, n_failed=0)
    out = tmp_path / "column_fragility.xml"
    assert oq_cli.main(["export", str(h5), str(out), "--im", "pga_g"]) == 0
    printed = capsys.readouterr().out
    assert "common beta with" in printed and "IML range" in printed
    [back] = oq.read_nrml(out).values()
    m = oq.fragility_from_results(h5, "pga_g")
    assert any("collapse" in g for g in m.joint) and "damage_limitation" not in sum(m.joint, ())
    from pycolfrag.analysis.data import read_table
    tab = read_table(h5)
    ok = tab["status"] == 0
    own = F.fit_lognormal_fragility(tab["pga_g"][ok], tab["u_top"][ok], tab["collapsed"][ok], 0.15)
    assert back.functions[0].median == pytest.approx(own.median, rel=1e-12)
    assert back.functions[0].beta == pytest.approx(own.beta, rel=1e-12)


def test_the_default_range_lets_the_fit_decide():
    """At minIML every fitted probability is at most 1e-8 (one of them equal), at maxIML at least 0.999; with a
    power-law hazard reaching far below the data (its weakest level exceeded ten times a year) the
    damage-limitation rate is then the closed form's, while the old default (the data's IM range) held the
    floor P(data's smallest IM) for every weaker motion."""
    t = _crossing_table()
    m = oq.fragility_from_results(t, "pga_g", levels=U_TOP_LEVELS[:1], collapse=False)
    lo, hi = m.domain
    (f,) = m.fits
    assert f(lo) == pytest.approx(1e-8, rel=1e-9)
    assert f(hi) == pytest.approx(0.999, rel=1e-9) or (f(hi) > 0.999 and hi == t["pga_g"].max())  # widened to the data
    assert "so the fits, not those limits, decide the damage rates" in m.description
    k = 2.5
    x = np.geomspace(f.median / 100, f.median * 1000, 600)     # lambda 10 /yr at the weakest level
    t_haz = 1.0
    poes = -np.expm1(-1e-4 * (x / f.median) ** -k * t_haz)       # lambda(theta) = 1e-4 /yr
    want = 1e-4 * math.exp(k * k * f.beta * f.beta / 2)
    assert oq.classical_damage(m, x, poes, t_haz)["rates"][0] == pytest.approx(want, rel=0.01)
    old = oq.fragility_from_results(t, "pga_g", levels=U_TOP_LEVELS[:1], collapse=False,
                                    iml_range=(t["pga_g"].min(), t["pga_g"].max()))
    assert oq.classical_damage(old, x, poes, t_haz)["rates"][0] > 10 * want      # the floor's share: 50 times
    assert "were given; there the limit states' fitted probabilities are" in old.description


def _separable_grid(tmp_path):
    """A grid file whose u_top is a power of PGA: every level's exceeding runs lie above the others in PGA
    (separable outcomes: no finite maximum, beta on its lower bound), nothing collapses."""
    import h5py
    h5 = write_results(tmp_path / "sep.h5", mws=(6.0, 6.5, 7.0, 7.5), dists=(5.0, 10.0), n=30, n_failed=0)
    with h5py.File(h5, "r+") as f:
        pga = f["samples/pga_g"][...]
        f["samples/u_top"][...] = 0.4 * (pga / np.median(pga)) ** 4
        f["samples/collapsed"][...] = 0
    return h5


def test_degenerate_fits_are_refused_unless_asked_for_and_then_marked(tmp_path, capsys):
    h5 = _separable_grid(tmp_path)
    with pytest.raises(ParameterError, match=r"degenerate fit\(s\) on PGA \(g\).*damage_limitation: every exceeding"):
        with pytest.warns(F.DegenerateFitWarning, match="3 limit-state fit"):
            oq.fragility_from_results(h5, "pga_g", collapse=False)
    out = tmp_path / "f.xml"
    argv = ["export", str(h5), str(out), "--im", "pga_g", "--no-collapse"]
    assert oq_cli.main(argv) == 2
    assert "--allow-degenerate" in capsys.readouterr().err and not out.exists()
    assert oq_cli.main(argv + ["--allow-degenerate"]) == 0
    io = capsys.readouterr()
    assert io.out.count("DEGENERATE") == 2 * 3        # each limit state's line and its note
    warned = [ln for ln in io.err.splitlines() if "warning:" in ln and "steps_per_interval > 1" not in ln]
    assert len(warned) == 2, warned                  # one per cause: separable, beta on its bound (and the
    # continuous export's steps_per_interval warning, test_the_wide_export_warns_of_openquakes_linear_levels)
    assert warned[0].startswith("pycolfrag openquake: warning: 3 limit-state fit(s): the exceeding runs")
    [back] = oq.read_nrml(out).values()
    assert back.description.count("DEGENERATE fit of") == 3
    assert len(back.notes) == 3 and back.notes[0].startswith("DEGENERATE fit of damage_limitation (not an estimate): "
                                                              "every exceeding run") and "[0.02, 5]" in back.notes[0]
    assert oq_cli.main(["damage", str(CASE1 / "hazard_curves_continuous.csv"), str(out)]) == 0   # an xml made so:
    assert capsys.readouterr().out.count("DEGENERATE fit of") == 3                          # its printout says so


def test_incomplete_files_are_refused_unless_asked_for_and_then_marked(tmp_path, capsys):
    h5 = write_results(tmp_path / "part.h5", mws=(6.0, 6.5, 7.0, 7.5), dists=(5.0, 10.0), n=60, n_failed=0,
                       complete=False, pending=60)
    with pytest.raises(ResultsFileError, match="holds 420 of the 480 rows"):
        oq.fragility_from_results(h5, "pga_g")
    out = tmp_path / "f.xml"
    assert oq_cli.main(["export", str(h5), str(out), "--im", "pga_g"]) == 2
    assert "--allow-incomplete" in capsys.readouterr().err and not out.exists()
    assert oq_cli.main(["export", str(h5), str(out), "--im", "pga_g", "--allow-incomplete"]) == 0
    assert "INCOMPLETE RESULTS: " in capsys.readouterr().out
    [back] = oq.read_nrml(out).values()
    assert "INCOMPLETE RESULTS: " in back.description and "holds 420 of the 480 rows" in back.description
    assert [n[:20] for n in back.notes] == ["INCOMPLETE RESULTS: "]
    hz = CASE1 / "hazard_curves_continuous.csv"
    assert oq_cli.main(["damage", str(hz), str(h5)]) == 2
    assert oq_cli.main(["damage", str(hz), str(h5), "--allow-incomplete"]) == 0
    assert capsys.readouterr().out.rstrip().splitlines()[-1].startswith("INCOMPLETE RESULTS: ")
    done = write_results(tmp_path / "done.h5", mws=(6.0, 6.5, 7.0, 7.5), dists=(5.0, 10.0), n=60, n_failed=0,
                         complete=True)
    assert "INCOMPLETE" not in oq.fragility_from_results(done, "pga_g").description


def _collapse_table(n=3000, seed=5):
    """Collapse fragility like the default grid's (median about 2.06 g, beta about 0.71) on PGAs spread
    like its records': the default range then spans about 0.01-20 g, as the default grid's 0.0104-18.5 g."""
    rng = np.random.default_rng(seed)
    pga = np.exp(rng.normal(np.log(0.6), 0.9, n))
    coll = pga > 2.061 * np.exp(0.710 * rng.standard_normal(n))
    return {"pga_g": pga, "u_top": np.where(coll, np.nan, 0.01), "collapsed": coll.astype(int),
            "status": np.zeros(n, int)}


def test_the_wide_export_warns_of_openquakes_linear_levels(tmp_path, capsys):
    """OpenQuake's steps_per_interval > 1 evaluates a continuous function at continuous_fragility_discretization
    levels spaced linearly over minIML-maxIML (its build_imls; our _levels, checked against the engine to 1e-12
    in tests/test_openquake_inputs.py). Over the export's wide range, with 20 levels every 1 g, the collapse rate
    on the QA case's hazard (0.05-1.4 g) comes out 104 times the fine answer (x 17 with 40 levels, x 1.8 with
    100; the fine answer: the same interpolation on 50 steps per hazard interval; the engine gave x 406 on the
    default grid's export against its hazard): `damage` warns,
    naming the rate, the ratio and a number of levels that is within 10 %; with that many levels, or with
    steps_per_interval 1, it does not. The export's printout warns as well."""
    m = oq.fragility_from_results(_collapse_table(), "pga_g", levels=())
    lo, hi = m.domain
    assert lo < 0.05 and hi > 10          # wider than the hazard curve's 0.05-1.4 g on both sides
    hc = oq.read_hazard_curves(CASE1 / "hazard_curves_continuous.csv")
    fine = oq.fine_rates(m, hc.imls, hc.poes[0], 50.0)[0]
    with pytest.warns(oq.DiscretisationWarning, match=r"steps_per_interval 4: .* 20 levels spaced linearly .* rate "
                                                      r"of collapse .* times the fine answer .* >= (\d+)") as rec:
        coarse = oq.classical_damage(m, hc.imls, hc.poes[0], 50.0, steps_per_interval=4)["rates"][0]
    assert coarse / fine > 10
    enough = int(str(rec[0].message).split(">= ")[1].split(",")[0])
    with warnings.catch_warnings():
        warnings.simplefilter("error", oq.DiscretisationWarning)
        ok = oq.classical_damage(m, hc.imls, hc.poes[0], 50.0, steps_per_interval=4,
                                 continuous_fragility_discretization=enough)["rates"][0]
        assert ok == pytest.approx(fine, rel=0.1)
        one = oq.classical_damage(m, hc.imls, hc.poes[0], 50.0)["rates"][0]      # the hazard's own levels
    assert one == pytest.approx(fine, rel=0.1)
    h5 = write_results(tmp_path / "grid.h5", mws=(6.0, 6.5, 7.0, 7.5), dists=(5.0, 10.0), n=60, n_failed=0)
    assert oq_cli.main(["export", str(h5), str(tmp_path / "m.xml"), "--im", "pga_g"]) == 0
    err = capsys.readouterr().err
    assert "warning: continuous functions over" in err and "x 406 with 20 levels" in err
    assert oq_cli.main(["export", str(h5), str(tmp_path / "d.xml"), "--im", "pga_g", "--format", "discrete"]) == 0
    assert "x 406" not in capsys.readouterr().err       # log-spaced IMLs, cut into steps each
