"""The OpenQuake route's inputs checked like the grid's: hazard-curve CSV and NRML files read by the
project's file policy, damage inputs that would give a silent wrong number refused or warned, and
OpenQuake's own settings (continuous_fragility_discretization, minIML = 0) followed.

Expected numbers: OpenQuake's QA case classical_damage/case_1 (tests/data/README.md) and OpenQuake's
documented algorithm, re-implemented here from its description in a few lines of numpy
(``openquake/risklib/scientific.py``: ``build_imls`` gives a continuous function ``numpy.linspace(minIML,
maxIML, continuous_fragility_discretization)`` levels when ``steps_per_interval > 1``;
``classical_damage`` clips them to the hazard curve's range and interpolates its poes linearly); and,
when the optional extra is installed, OpenQuake itself.
"""
import math
import os
import re
import sys
import warnings
from pathlib import Path

import numpy as np
import pytest
from scipy import stats

from pycolfrag.analysis import openquake as oq
from pycolfrag.cli import openquake as oq_cli
from pycolfrag.core import input_files
from pycolfrag.core.errors import HazardFileError, ParameterError

sys.path.insert(0, os.path.dirname(__file__))
CASE1 = Path(__file__).resolve().parent / "data" / "oq_classical_damage_case_1"
HEAD = "# investigation_time=50.0, imt=\"PGA\"\n"


def _csv(tmp_path, body, name="hz.csv", head=HEAD):
    p = tmp_path / name
    p.write_text(head + body)
    return p


# ---------------------------------------------------------------- hazard-curve files
@pytest.mark.parametrize("body, head, words", [
    ("lon,lat,poe-0.1\n1,2,0.1\n", HEAD, "one level ('poe-0.1'); at least two"),
    ("lon,lat,lon,poe-0.1,poe-0.2\n1,2,3,0.1,0.01\n", HEAD, "names column(s) ['lon'] more than once"),
    ("lon,lat,poe-0.1,poe-0.2\n1,2,0.1,0.01\n", HEAD + "# investigation_time=1.0\n",
     "comment lines disagree on investigation_time: '50.0' and '1.0'"),
    ("lon,lat,poe-0.1,poe-0.2\n1,2,0.1,0.01\n", HEAD + "# imt='SA(1.0)'\n", "disagree on imt: 'PGA' and 'SA(1.0)'"),
])
def test_hazard_files_that_would_give_a_silent_number_are_refused(tmp_path, body, head, words):
    with pytest.raises(HazardFileError, match=re.escape(words)):
        oq.read_hazard_curves(_csv(tmp_path, body, head=head))


def test_repeated_metadata_that_agrees_is_read(tmp_path):
    """50 and 50.0 are the same investigation time."""
    hc = oq.read_hazard_curves(_csv(tmp_path, "lon,lat,poe-0.1,poe-0.2\n1,2,0.1,0.01\n",
                                    head=HEAD + "# investigation_time=50\n"))
    assert hc.investigation_time == 50.0


def test_latin1_and_binary_hazard_files_are_refused_by_the_file_policy(tmp_path):
    p = tmp_path / "latin1.csv"
    p.write_bytes((HEAD + "lon,lat,poe-0.1,poe-0.2\n1,2,0.1,0.01\n# Fl\xe4che\n").encode("latin-1"))
    with pytest.raises(HazardFileError, match=r"not UTF-8 text \(byte \d+ is 0xe4\)"):
        oq.read_hazard_curves(p)
    b = tmp_path / "binary.csv"
    b.write_bytes(HEAD.encode() + b"lon,lat,poe-0.1\x00\x00\x01,poe-0.2\n")
    with pytest.raises(HazardFileError, match="line 2 holds a NUL byte"):
        oq.read_hazard_curves(b)


def test_hazard_and_nrml_files_must_be_regular_and_bounded(tmp_path, monkeypatch):
    fifo = tmp_path / "fifo.csv"
    os.mkfifo(fifo)                   # a reader that opened it would block forever
    with pytest.raises(HazardFileError, match="is a FIFO"):
        oq.read_hazard_curves(fifo)
    with pytest.raises(HazardFileError, match="is a FIFO"):
        oq.read_nrml(fifo)
    with pytest.raises(HazardFileError, match="is a character device"):
        oq.read_hazard_curves("/dev/zero")
    with pytest.raises(HazardFileError, match="is a folder"):
        oq.read_nrml(tmp_path)
    monkeypatch.setitem(input_files.LIMITS, "hazard-curve file", 100)
    with pytest.raises(HazardFileError, match="more than the 100 a hazard-curve file may have"):
        oq.read_hazard_curves(CASE1 / "hazard_curves_continuous.csv")
    with pytest.raises(FileNotFoundError):
        oq.read_hazard_curves(tmp_path / "missing.csv")


# ---------------------------------------------------------------- damage inputs
def _two_states(theta_b, beta_b, lo=0.05, hi=2.0):
    fa = oq.ContinuousFragility.from_lognormal(0.3, 0.6, lo, hi)
    fb = oq.ContinuousFragility.from_lognormal(theta_b, beta_b, lo, hi)
    return oq.FragilityModel("PGA", ("slight", "heavy"), [fa, fb])


HAZ_X = np.array([0.05, 0.1, 0.2, 0.4, 0.8, 1.6])
HAZ_P = np.array([0.6, 0.3, 0.1, 0.02, 0.003, 0.0002])


def test_crossing_limit_states_are_refused_by_damage():
    """heavy (median 0.35, beta 0.1) is more probable than slight (0.3, 0.6) above about 0.4 g: the damage
    state between them would be negative, so classical_damage refuses, naming both and where."""
    with pytest.raises(ParameterError, match=r"cross: P\(heavy\) exceeds P\(slight\) by 0\.\d+ at 0\.4"):
        oq.classical_damage(_two_states(0.35, 0.1), HAZ_X, HAZ_P, 50.0)
    got = oq.classical_damage(_two_states(0.6, 0.6), HAZ_X, HAZ_P, 50.0)["damage"]   # parallel: fine
    assert np.all(got >= 0) and got.sum() == pytest.approx(1.0, abs=1e-15)


def test_hazard_levels_all_below_min_iml_warn():
    """With every hazard level under minIML OpenQuake holds P(minIML) for all of them: steps_per_interval 1
    gives P(minIML) times the curve's rate range, 4 gives 0 -- the number rests on the floor and the
    settings, and a warning says so (the value OpenQuake computes is still returned)."""
    model = _two_states(0.6, 0.6, lo=1.0, hi=3.0)
    x, p = np.array([0.05, 0.1, 0.2, 0.4]), np.array([0.5, 0.2, 0.05, 0.01])
    with pytest.warns(oq.HazardRangeWarning, match=r"every hazard level \(0.05 to 0.4\) lies below the fragility's "
                                                    r"range 1-3: OpenQuake holds .* at minIML"):
        one = oq.classical_damage(model, x, p, 50.0)
    rate = -np.log1p(-p) / 50.0
    assert one["rates"][0] == pytest.approx(stats.lognorm.cdf(1.0, 0.6, scale=0.3) * (rate[0] - rate[-1]), rel=1e-12)
    with pytest.warns(oq.HazardRangeWarning):
        assert oq.classical_damage(model, x, p, 50.0, steps_per_interval=4)["rates"][0] == 0.0
    with warnings.catch_warnings():
        warnings.simplefilter("error", oq.HazardRangeWarning)
        oq.classical_damage(_two_states(0.6, 0.6), HAZ_X, HAZ_P, 50.0)     # levels inside the range: no warning
    # (against ``model``, minIML 1 g, 5 of these 6 levels lie below: warned, next test)


@pytest.mark.parametrize("kw, words", [
    (dict(imls=[0.1], poes=[0.2]), "at least two increasing levels"),
    (dict(risk_investigation_time=0.0), r"must be > 0 years, got 50.0 \(hazard\) and 0.0 \(risk\)"),
    (dict(steps_per_interval=0), "steps_per_interval must be >= 1, got 0"),
    (dict(steps_per_interval=2, continuous_fragility_discretization=1), "continuous_fragility_discretization must be >= 2"),
    (dict(continuous_fragility_discretization=True), "got the bool True"),
])
def test_bad_damage_arguments_are_named(kw, words):
    args = dict(imls=HAZ_X, poes=HAZ_P, investigation_time=50.0)
    args.update(kw)
    with pytest.raises(ParameterError, match=words):
        oq.classical_damage(_two_states(0.6, 0.6), **args)


def test_command_line_refuses_risk_time_zero_and_an_unknown_taxonomy(tmp_path, capsys):
    hz = CASE1 / "hazard_curves_continuous.csv"
    xml = CASE1 / "fragility_model_continuous.xml"
    assert oq_cli.main(["damage", str(hz), str(xml), "--risk-time", "0"]) == 2
    assert "0.0 (risk)" in capsys.readouterr().err
    assert oq_cli.main(["damage", str(hz), str(xml), "--taxonomy", "nope"]) == 2
    err = capsys.readouterr().err
    assert "--taxonomy 'nope' is not in" in err and "(it holds ['W'])" in err
    latin = tmp_path / "latin1.csv"
    latin.write_bytes(b"# investigation_time=50.0, imt=\"PGA\"\nlon,lat,poe-0.1,poe-0.2\n1,2,0.1,0.01\n\xe9\n")
    assert oq_cli.main(["damage", str(latin), str(xml)]) == 2
    assert "is not UTF-8 text" in capsys.readouterr().err


# ---------------------------------------------------------------- OpenQuake's settings
def _oq_fine_levels_damage(model, imls, poes, t, tr, n):
    """OpenQuake's classical damage with steps_per_interval > 1 on a continuous model, from its description:
    n levels linspace(minIML, maxIML), clipped to the hazard's range, the hazard's poes interpolated
    linearly there; rates of occurrence are the differences of the midpoint rates (a different code path
    from pycolfrag's: explicit loops)."""
    f0 = model.functions[0]
    x = np.clip(np.linspace(f0.min_iml, f0.max_iml, n), imls[0], imls[-1])
    p = np.interp(x, imls, poes)
    lam = -np.log(1 - p) / t
    mids = [lam[0]] + [(lam[i] + lam[i + 1]) / 2 for i in range(len(lam) - 1)] + [lam[-1]]
    occ = [mids[i] - mids[i + 1] for i in range(len(lam))]
    ls = [1 - math.exp(-tr * sum(o * float(f(xi)) for o, xi in zip(occ, x))) for f in model.functions]
    return np.diff([1.0] + ls + [0.0]) * -1


@pytest.mark.parametrize("n", [20, 40])
def test_continuous_fragility_discretization_is_openquakes(n, capsys):
    hc = oq.read_hazard_curves(CASE1 / "hazard_curves_continuous.csv")
    [model] = oq.read_nrml(CASE1 / "fragility_model_continuous.xml").values()
    got = oq.classical_damage(model, hc.imls, hc.poes[0], 50.0, 100.0, steps_per_interval=4,
                              continuous_fragility_discretization=n)["damage"]
    want = _oq_fine_levels_damage(model, hc.imls, hc.poes[0], 50.0, 100.0, n)
    np.testing.assert_allclose(got, want, rtol=1e-12, atol=1e-15)       # the same sums in another order
    assert oq_cli.main(["damage", str(CASE1 / "hazard_curves_continuous.csv"),
                    str(CASE1 / "fragility_model_continuous.xml"), "--risk-time", "100", "--steps-per-interval",
                    "4", "--continuous-fragility-discretization", str(n)]) == 0
    line = [ln for ln in capsys.readouterr().out.splitlines() if "damage states" in ln][0]
    printed = [float(v.rstrip(",")) for v in line.split()[3::2]]
    np.testing.assert_allclose(printed, got, rtol=1e-4)       # printed with 5 significant digits
    if n == 40:      # the option reaches the computation: 20 and 40 levels differ
        other = oq.classical_damage(model, hc.imls, hc.poes[0], 50.0, 100.0, steps_per_interval=4)["damage"]
        assert abs(other[1] - got[1]) > 1e-4


def test_min_iml_zero_means_no_lower_clip(tmp_path):
    """OpenQuake reads minIML="0" as its 1e-10 cutoff (``ffconvert``), so nothing is clipped below: the file
    equals the same file with minIML="1e-10" exactly, and at 0.01 g the function is the plain lognormal CDF
    (with minIML 0.05 it would be held at its value at 0.05 g)."""
    text = (CASE1 / "fragility_model_continuous.xml").read_text()
    (tmp_path / "zero.xml").write_text(text.replace('minIML="0.05"', 'minIML="0"'))
    (tmp_path / "tiny.xml").write_text(text.replace('minIML="0.05"', 'minIML="1e-10"').replace(
        'noDamageLimit="5.0000000E-02"', ""))
    [zero] = oq.read_nrml(tmp_path / "zero.xml").values()
    assert zero.functions[0].min_iml == oq.MIN_IML
    f = oq.ContinuousFragility(0.16, 0.104, 0.0, 1.4)          # min_iml 0 in Python: no clip either
    dist = stats.lognorm(math.sqrt(math.log1p((0.104 / 0.16) ** 2)), scale=0.16 / math.sqrt(1 + (0.104 / 0.16) ** 2))
    assert f(np.array([0.01]))[0] == pytest.approx(dist.cdf(0.01), rel=1e-12)
    hc = oq.read_hazard_curves(CASE1 / "hazard_curves_continuous.csv")
    [tiny] = oq.read_nrml(tmp_path / "tiny.xml").values()
    nodl = oq.FragilityModel("PGA", zero.limit_states, [oq.ContinuousFragility(g.mean, g.stddev, g.min_iml, g.max_iml)
                                                       for g in zero.functions])
    np.testing.assert_array_equal(oq.classical_damage(nodl, hc.imls, hc.poes[0], 50.0, 100.0)["damage"],
                                  oq.classical_damage(tiny, hc.imls, hc.poes[0], 50.0, 100.0)["damage"])


def test_openquake_agrees_on_min_iml_zero_and_the_discretization(tmp_path):
    """With the optional extra: OpenQuake's own reader and ``scientific.classical_damage`` on the QA case with
    minIML="0", steps_per_interval 4 and continuous_fragility_discretization 40 give ours to 1e-12."""
    pytest.importorskip("openquake.risklib.read_nrml")
    from openquake.hazardlib import nrml
    from openquake.risklib import read_nrml, scientific  # noqa: F401  (registers the fragility converter)
    text = (CASE1 / "fragility_model_continuous.xml").read_text()
    path = tmp_path / "zero.xml"
    path.write_text(text.replace('minIML="0.05"', 'minIML="0"'))
    fmodel = nrml.to_python(str(path))
    ffl = fmodel["PGA", "W"].build(fmodel.limitStates, 40, 4)
    hc = oq.read_hazard_curves(CASE1 / "hazard_curves_continuous.csv")
    theirs = scientific.classical_damage(ffl, hc.imls, hc.poes[0], 50.0, 100.0, steps_per_interval=4)
    [ours] = oq.read_nrml(path).values()
    got = oq.classical_damage(ours, hc.imls, hc.poes[0], 50.0, 100.0, steps_per_interval=4,
                              continuous_fragility_discretization=40)["damage"]
    np.testing.assert_allclose(got, theirs, rtol=1e-12, atol=1e-15)


# ---------------------------------------------------------------- large hazard files
def _many_sites(path, n, ids=True, crlf=False):
    """A hazard-curve CSV of ``n`` sites (OpenQuake's current header), poes decreasing along each row."""
    imls = np.geomspace(0.005, 3.0, 20)
    scale = np.random.default_rng(1).uniform(0.02, 0.5, n)[:, None]
    poes = np.minimum(-np.expm1(-0.05 * (imls[None, :] / scale) ** -2.5), 0.999)
    nl = "\r\n" if crlf else "\n"
    head = (f"#,,,,\"generated_by='OpenQuake engine 3.16', investigation_time=50.0, imt='PGA'\"{nl}"
            + ("custom_site_id," if ids else "") + "lon,lat,depth," + ",".join(f"poe-{x:g}" for x in imls) + nl)
    rows = [(f"s{i}," if ids else "") + f"{i * 1e-3:.5f},40.0,0.0," + ",".join(f"{p:.6E}" for p in poes[i])
            for i in range(n)]
    path.write_bytes((head + nl.join(rows) + nl + nl).encode())       # a blank line at the end, as editors leave
    return poes


@pytest.mark.parametrize("ids, crlf", [(True, False), (False, True)])
def test_a_large_hazard_file_is_read_in_a_few_times_its_size(tmp_path, ids, crlf):
    """A 100 MB file took 1.3 GB and 50 s (bench/hazard_csv_read.py: 1326 MB and 16 s on the shared machine,
    370 MB and 5 s now): every value was a Python string in a list of lists, then a Python float. Numpy's
    parser reads the numbers; the Python-level peak (tracemalloc, which numpy reports to) of a 4 MB file
    stays under 4 times its size (the text, its lines and the arrays; it was 12 times), and the values are
    those of the row-by-row reader, which still names a bad row."""
    import tracemalloc
    path = tmp_path / "big.csv"
    want = _many_sites(path, 14000, ids=ids, crlf=crlf)
    size = path.stat().st_size
    tracemalloc.start()
    try:
        hc = oq.read_hazard_curves(path)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak < 4 * size, f"peak {peak / 1e6:.1f} MB for a {size / 1e6:.1f} MB file"
    np.testing.assert_allclose(hc.poes, want, rtol=1e-6)          # written with 7 significant digits
    assert hc.site_ids[:2] == (["s0", "s1"] if ids else ["", ""]) and len(hc.site_ids) == 14000
    assert hc.lon[3] == 0.003 and np.all(hc.depth == 0.0) and hc.poes.flags.c_contiguous
    text = path.read_text()
    path.write_text(text.replace(",40.0,", ",40.0 ,", 1))     # spaces around a value: read as before
    assert oq.read_hazard_curves(path).lat[0] == 40.0
    path.write_text(text.replace("\n", "\n\n", 3))            # blank lines between rows: skipped as before
    assert len(oq.read_hazard_curves(path).lon) == 14000
    for bad, words in ((",40.0,", ",nan,"), (",40.0,", ",4x,"), (",40.0,0.0,", ",40.0,")):
        path.write_text(text.replace(bad, words, 1))
        with pytest.raises(HazardFileError, match=r"data row 1(,| has)"):
            oq.read_hazard_curves(path)


def test_hazard_levels_partly_below_min_iml_warn_where_the_held_value_counts():
    """Levels below minIML get the function's value at minIML (OpenQuake's clip), so their share of the rate
    rests on that held value. The QA case's hazard (0.05-1.4 g) against a fragility of median 0.3 g (beta 0.6)
    with minIML 0.2 g: the 3 levels below hold P(0.2) = Phi(ln(2/3)/0.6) = 0.25 and carry (by the sums below)
    over half of the rate: warned, with the share. The same fits over 0.01-10 g (the hazard wholly inside)
    and with minIML 0.2 and a noDamageLimit of 0.2 (the held value is 0) pass without a warning."""
    hc = oq.read_hazard_curves(CASE1 / "hazard_curves_continuous.csv")
    mk = lambda lo, ndl=None: oq.FragilityModel("PGA", ("ls",), [oq.ContinuousFragility.from_lognormal(
        0.3, 0.6, lo, 10.0, ndl)])
    occ = oq.occurrence_rates(oq.annual_rates(hc.poes[0], 50.0))
    f = mk(0.2).functions[0]
    share = occ[:3] @ f(hc.imls[:3]) / (occ @ f(hc.imls))
    assert f(0.05) == pytest.approx(stats.norm.cdf(math.log(2 / 3) / 0.6), rel=1e-12) and share > 0.5
    with pytest.warns(oq.HazardRangeWarning, match=rf"3 of the 28 hazard levels \(0.05 to 0.15\) lie below the "
                                                   rf"fragility's minIML 0.2.*carry {100 * share:.1f}% of the rate of ls"):
        oq.classical_damage(mk(0.2), hc.imls, hc.poes, 50.0)
    with warnings.catch_warnings():
        warnings.simplefilter("error", oq.HazardRangeWarning)
        oq.classical_damage(mk(0.01), hc.imls, hc.poes, 50.0)
        oq.classical_damage(mk(0.2, 0.2), hc.imls, hc.poes, 50.0)
