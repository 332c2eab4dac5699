"""OpenQuake interchange and the IM route (pycolfrag.analysis.openquake).

Expected numbers: OpenQuake's own QA case classical_damage/case_1 (its hazard curves, fragility
models and expected damage distributions, copied into tests/data/oq_classical_damage_case_1, see
tests/data/README.md), the closed form of a power-law hazard convolved with a lognormal fragility,
the moments of a lognormal variable (scipy), and -- when the optional extra is installed -- OpenQuake
reading our NRML export and running its own classical damage on it.
"""
import csv
import math
from pathlib import Path

import numpy as np
import pytest
from scipy import stats

from pycolfrag.analysis import openquake as oq
from pycolfrag.cli import openquake as oq_cli
from pycolfrag.core.errors import HazardFileError, ParameterError

CASE1 = Path(__file__).resolve().parent / "data" / "oq_classical_damage_case_1"


def _expected(kind):
    """The damage-state fractions OpenQuake 3.22 wrote for case_1 (7 significant digits)."""
    with open(CASE1 / "expected" / f"damage_{kind}.csv") as f:
        rows = [r for r in csv.reader(f) if r and not r[0].startswith("#")]
    header, row = rows[0], rows[1]
    return [h.split("-", 1)[1] for h in header[4:]], np.array([float(v) for v in row[4:]])


# ---------------------------------------------------------------- the published QA case
@pytest.mark.parametrize("kind, steps", [("continuous", 1), ("discrete", 1), ("interpolation", 4)])
def test_openquake_qa_classical_damage_case_1(kind, steps):
    """OpenQuake's classical_damage QA case_1 (job_<kind>.ini: investigation_time 50, risk investigation
    time 100, steps_per_interval 4 in the interpolation job), computed without OpenQuake: every
    damage-state probability equals the published one to 2e-6 relative. The file prints 7 significant
    digits and OpenQuake reads the hazard CSV in single precision (relative 6e-8), so 5 digits are
    asserted with a margin: our results agree to about 1e-8."""
    hc = oq.read_hazard_curves(CASE1 / f"hazard_curves_{kind}.csv")
    [model] = oq.read_nrml(CASE1 / f"fragility_model_{kind}.xml").values()
    states, want = _expected(kind)
    assert (hc.investigation_time, hc.imt) == (50.0, "PGA")
    assert list(model.limit_states) == states[1:]
    got = oq.classical_damage(model, hc.imls, hc.poes, hc.investigation_time, 100.0,
                              steps_per_interval=steps)
    np.testing.assert_allclose(got["damage"][0], want, rtol=2e-6)
    assert got["damage"][0].sum() == pytest.approx(1.0, abs=1e-15)


def test_both_header_lines_are_read():
    """The older comment line (``# ..., investigation_time=50.0, imt="PGA"``, case_1 discrete), the
    current padded one (``#,,,,"..., imt='PGA'"``, case_1 continuous) and a current engine's line with
    generated_by/checksum/kind give the same investigation time and IMT."""
    old = oq.read_hazard_curves(CASE1 / "hazard_curves_discrete.csv")
    padded = oq.read_hazard_curves(CASE1 / "hazard_curves_continuous.csv")
    assert (old.investigation_time, old.imt) == (padded.investigation_time, padded.imt) == (50.0, "PGA")
    assert old.poes.shape == (1, 7) and padded.poes.shape == (1, 28)
    assert old.imls[0] == 0.2 and padded.imls[7] == pytest.approx(0.4)
    assert old.depth[0] == 1.0 and old.lon[0] == pytest.approx(83.31382)


def test_current_engine_header_and_sa_imt(tmp_path):
    p = tmp_path / "hazard_curve-mean-SA(1.0)_1.csv"
    p.write_text("#,,,,,\"generated_by='OpenQuake engine 3.16.0', start_date='2023-01-01T00:00:00', "
                 "checksum=1234, kind='mean', investigation_time=1.0, imt='SA(1.0)'\"\n"
                 "custom_site_id,lon,lat,depth,poe-0.1000000,poe-0.2000000,poe-0.4000000\n"
                 "athens1,23.7,37.97,0.0,0.02,0.005,0.001\nathens2,23.8,38.0,0.0,0.03,0.006,0.0\n")
    hc = oq.read_hazard_curves(p)
    assert hc.site_ids == ["athens1", "athens2"] and hc.lat[1] == 38.0
    assert (hc.imt, hc.investigation_time) == ("SA(1.0)", 1.0) and hc.poes.shape == (2, 3)
    assert oq.im_of_imt(hc.imt) == ("sa_g", 1.0)
    # poes in 1 year -> annual rates -ln(1 - p): 0.02 -> 0.0202027
    assert hc.annual_rates()[0, 0] == pytest.approx(-math.log(0.98), rel=1e-14)


BAD = [
    ("lat,depth,poe-0.1\n1,0,0.1\n", "'lon'"),
    ("lon,lat,depth\n1,2,0\n", "poe-<IML>"),
    ("lon,lat,poe-abc\n1,2,0.1\n", "'poe-abc'"),
    ("lon,lat,poe-0.2,poe-0.1\n1,2,0.1,0.05\n", "increasing levels"),
    ("lon,lat,poe-0.1,poe-0.2\n1,2,0.1,x\n", "'x'"),
    ("lon,lat,poe-0.1,poe-0.2\n1,2,0.1\n", "3 values"),
    ("lon,lat,poe-0.1,poe-0.2\n1,2,1.2,0.1\n", "1.2"),
    ("lon,lat,poe-0.1,poe-0.2\n1,2,1.0,0.1\n", "infinite annual rate"),
    ("lon,lat,poe-0.1,poe-0.2\n1,2,0.1,0.3\n", "increases"),
    ("lon,lat,speed,poe-0.1\n1,2,3,0.1\n", "'speed'"),
    ("lon,lat,poe-0.1,poe-0.2\n", "no site rows"),
]


@pytest.mark.parametrize("body, words", BAD)
def test_bad_hazard_csv_is_refused_naming_the_problem(tmp_path, body, words):
    p = tmp_path / "bad.csv"
    p.write_text("# investigation_time=50.0, imt=\"PGA\"\n" + body)
    with pytest.raises(HazardFileError, match=r".*" + __import__("re").escape(words)) as e:
        oq.read_hazard_curves(p)
    assert "bad.csv" in str(e.value)


def test_missing_or_conflicting_metadata(tmp_path):
    p = tmp_path / "nometa.csv"
    p.write_text("lon,lat,poe-0.1,poe-0.2\n1,2,0.1,0.01\n")
    with pytest.raises(HazardFileError, match="investigation_time"):
        oq.read_hazard_curves(p, imt="PGA")
    assert oq.read_hazard_curves(p, investigation_time=50, imt="PGA").investigation_time == 50.0
    with pytest.raises(HazardFileError, match="50.0.*1.0"):
        oq.read_hazard_curves(CASE1 / "hazard_curves_discrete.csv", investigation_time=1.0)
    with pytest.raises(ParameterError, match="'MMI'"):
        oq.read_hazard_curves(p, investigation_time=50, imt="MMI")


# ---------------------------------------------------------------- closed form
@pytest.mark.parametrize("k, theta, beta", [(2.5, 0.3, 0.5), (3.0, 0.15, 0.3), (1.8, 40.0, 0.6)])
def test_power_law_hazard_with_lognormal_fragility(k, theta, beta):
    """lambda_IM(x) = k0 x^-k and P(LS | x) = Phi(ln(x / theta) / beta) give
    lambda_LS = lambda_IM(theta) exp(k^2 beta^2 / 2) exactly (the integral of a lognormal CDF against
    a power law). OpenQuake's discretisation on 300 log-spaced levels from theta/30 to 1000 theta
    (fragility below 1e-8 at the bottom, hazard below 1e-7 of lambda(theta) at the top; poes in one
    year, all below 1) must be within 1 %."""
    k0, t_haz = 1e-4 * theta ** k, 1.0                        # lambda_IM(theta) = 1e-4 /yr
    x = np.geomspace(theta / 30, theta * 1000, 300)
    poes = -np.expm1(-k0 * x ** -k * t_haz)
    model = oq.FragilityModel("PGA", ("ls",), [oq.ContinuousFragility.from_lognormal(theta, beta, x[0], x[-1])])
    got = oq.classical_damage(model, x, poes, t_haz)["rates"][0]
    want = 1e-4 * math.exp(k * k * beta * beta / 2)
    assert got == pytest.approx(want, rel=0.01)


def test_occurrence_rates_are_centred_differences():
    """Rates 8, 4, 2, 1: occurrence (8-4)/2, (8-2)/2, (4-1)/2, (2-1)/2 = 2, 3, 1.5, 0.5; their sum is
    rate[0] - rate[-1] = 7 (the rate above the last level is not counted)."""
    np.testing.assert_array_equal(oq.occurrence_rates([8.0, 4.0, 2.0, 1.0]), [2.0, 3.0, 1.5, 0.5])


# ---------------------------------------------------------------- fragility functions and NRML
def test_continuous_mean_and_stddev_are_those_of_the_iml():
    """A lognormal variable of median theta and dispersion beta has mean theta exp(beta^2/2) and
    standard deviation mean sqrt(exp(beta^2) - 1) (scipy's lognorm moments); the function is scipy's
    lognormal CDF inside [minIML, maxIML], constant outside it, 0 at and below noDamageLimit."""
    theta, beta = 0.4, 0.55
    f = oq.ContinuousFragility.from_lognormal(theta, beta, 0.05, 2.0, no_damage_limit=0.08)
    dist = stats.lognorm(beta, scale=theta)
    assert f.mean == pytest.approx(dist.mean(), rel=1e-14) and f.stddev == pytest.approx(dist.std(), rel=1e-12)
    assert (f.median, f.beta) == (pytest.approx(theta, rel=1e-14), pytest.approx(beta, rel=1e-14))
    x = np.array([0.01, 0.08, 0.1, 0.4, 1.5, 2.0, 5.0])
    np.testing.assert_allclose(f(x), [0, 0, dist.cdf(0.1), 0.5, dist.cdf(1.5), dist.cdf(2.0), dist.cdf(2.0)],
                               rtol=1e-13, atol=0)


def test_discrete_function_follows_openquake():
    """Linear between the IMLs, the last value beyond; below the first IML linear down to 0 at the
    no-damage limit (OpenQuake adds that point), 0 below the limit."""
    f = oq.DiscreteFragility((0.2, 0.4, 0.8), (0.1, 0.5, 0.9), no_damage_limit=0.1)
    np.testing.assert_allclose(f([0.05, 0.1, 0.15, 0.2, 0.3, 0.8, 3.0]), [0, 0, 0.05, 0.1, 0.3, 0.9, 0.9])


def _model(fmt):
    fs = [(0.2, 0.5), (0.5, 0.45), (1.1, 0.4)]
    if fmt == "continuous":
        funcs = [oq.ContinuousFragility.from_lognormal(t, b, 0.02, 3.0, no_damage_limit=0.03) for t, b in fs]
    else:
        x = tuple(np.geomspace(0.02, 3.0, 15))
        funcs = [oq.DiscreteFragility(x, tuple(stats.lognorm.cdf(x, b, scale=t)), 0.03) for t, b in fs]
    return oq.FragilityModel("SA(1.0)", ("damage_limitation", "significant_damage", "collapse"), funcs,
                             taxonomy="parthenon_column", description="test")


@pytest.mark.parametrize("fmt", ["continuous", "discrete"])
def test_nrml_round_trip(tmp_path, fmt):
    """write_nrml then read_nrml gives back the same functions (values repr-exact in the file)."""
    m = _model(fmt)
    path = oq.write_nrml(m, tmp_path / f"{fmt}.xml")
    [back] = oq.read_nrml(path).values()
    assert (back.imt, back.limit_states, back.taxonomy, back.format) == (m.imt, m.limit_states, m.taxonomy, fmt)
    x = np.geomspace(0.01, 5, 50)
    for a, b in zip(m.functions, back.functions):
        np.testing.assert_array_equal(a(x), b(x))


@pytest.mark.parametrize("fmt", ["continuous", "discrete"])
def test_openquake_reads_the_export_and_agrees(tmp_path, fmt):
    """With the optional extra (pip install -e '.[oq]'): openquake.hazardlib.nrml parses our NRML 0.5
    into its FragilityModel with our limit states, IMT, mean/stddev (or poes), and OpenQuake's own
    scientific.classical_damage on the QA hazard curve equals ours to 1e-12."""
    pytest.importorskip("openquake.hazardlib.nrml")
    from openquake.hazardlib import nrml
    from openquake.risklib import read_nrml, scientific  # noqa: F401  (registers the fragility converter)
    m = _model(fmt)
    path = oq.write_nrml(m, tmp_path / f"{fmt}.xml")
    fmodel = nrml.to_python(path)
    assert list(fmodel.limitStates) == list(m.limit_states)
    ffl = fmodel["SA(1.0)", "parthenon_column"]
    assert ffl.format == fmt and ffl.nodamage == 0.03
    if fmt == "continuous":
        np.testing.assert_allclose(ffl.array, [[f.mean, f.stddev] for f in m.functions], rtol=1e-15)
    built = ffl.build(fmodel.limitStates)
    hc = oq.read_hazard_curves(CASE1 / "hazard_curves_continuous.csv")
    theirs = scientific.classical_damage(built, hc.imls, hc.poes[0], 50.0, 100.0)
    ours = oq.classical_damage(m, hc.imls, hc.poes[0], 50.0, 100.0)["damage"]
    np.testing.assert_allclose(ours, theirs, rtol=1e-12, atol=1e-15)


# ---------------------------------------------------------------- from a results file
def test_fragility_from_results_is_the_mle_fit(tmp_path):
    """The exported limit states are fragility.fit_lognormal_fragility of the same rows (median and
    beta recovered from mean/stddev to 1e-12); collapse is fitted on the collapse flags alone."""
    from pycolfrag.analysis import fragility as F
    rng = np.random.default_rng(1)
    n = 600
    pgv = np.exp(rng.normal(np.log(60), 0.6, n))
    u = 0.003 * pgv * np.exp(0.5 * rng.standard_normal(n))
    coll = (u > 0.9).astype(int)
    table = {"pgv_cm_s": pgv, "u_top": np.where(coll, np.nan, u), "collapsed": coll, "status": np.zeros(n, int)}
    m = oq.fragility_from_results(table, "pgv_cm_s", iml_range=(10.0, 400.0))
    assert m.imt == "PGV" and m.limit_states == ("damage_limitation", "significant_damage", "near_collapse",
                                                 "collapse")
    ref = F.fit_lognormal_fragility(pgv, np.where(coll, np.nan, u), coll == 1, 0.35)
    f = m.functions[1]
    assert f.median == pytest.approx(ref.median, rel=1e-12) and f.beta == pytest.approx(ref.beta, rel=1e-12)
    refc = F.fit_lognormal_fragility(pgv, np.zeros(n), coll == 1, 1.0)
    assert m.functions[3].median == pytest.approx(refc.median, rel=1e-12)
    assert (m.functions[0].min_iml, m.functions[0].max_iml) == (10.0, 400.0)
    d = oq.fragility_from_results(table, "pgv_cm_s", fmt="discrete", n_imls=12, collapse=False)
    assert len(d.functions[0].imls) == 12
    np.testing.assert_allclose(d.functions[2].poes, m.fits[2](np.array(d.functions[2].imls)), rtol=1e-14)


def test_command_line_export_and_damage(tmp_path, capsys):
    """``export`` then ``damage`` on the written file: the printed damage states sum to 1; a bad
    hazard file exits 2 with one line naming it."""
    import sys
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    from test_figures import write_results
    h5 = write_results(tmp_path / "grid.h5", mws=(6.0, 6.5, 7.0, 7.5), dists=(5.0, 10.0), n=60, n_failed=0)
    out = tmp_path / "frag.xml"
    assert oq_cli.main(["export", str(h5), str(out), "--im", "pga_g", "--no-collapse"]) == 0
    hz = tmp_path / "hz.csv"
    hz.write_text("# investigation_time=50.0, imt=\"PGA\"\nlon,lat,poe-0.05,poe-0.1,poe-0.2,poe-0.4,poe-0.8\n"
                  "23.7,37.9,0.5,0.2,0.05,0.01,0.001\n")
    capsys.readouterr()
    assert oq_cli.main(["damage", str(hz), str(out)]) == 0
    line = [ln for ln in capsys.readouterr().out.splitlines() if "damage states" in ln][0]
    probs = [float(t.rstrip(",")) for t in line.split()[3::2]]
    assert sum(probs) == pytest.approx(1.0, abs=1e-3) and len(probs) == 4
    hz.write_text("lon,lat,poe-0.05,poe-0.1\n1,2,0.1,0.01\n")
    assert oq_cli.main(["damage", str(hz), str(out)]) == 2
    assert "investigation_time" in capsys.readouterr().err


def test_export_formats_come_from_the_registry(tmp_path, monkeypatch, capsys):
    """The export command offers every writer of ``pycolfrag.analysis.outputs.WRITERS`` (its ``--to``
    choices are read from the registry): a format registered here is accepted by the command line
    and gets the model the NRML export gets -- its medians, one per limit state, are those of the
    NRML file read back (continuous NRML stores mean and stddev, whose lognormal median is exact to
    rounding: 1e-12). An unknown format is refused with the registered names."""
    import sys
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    from pycolfrag.analysis import outputs
    from test_figures import write_results

    def toy(model, path):
        Path(path).write_text("\n".join(f"{ls} {f.median!r}" for ls, f in zip(model.limit_states, model.fits)))
        return str(path)

    monkeypatch.setitem(outputs.WRITERS, "toy", outputs.Writer("toy", ".txt", "limit state and median", toy))
    h5 = write_results(tmp_path / "grid.h5", mws=(6.0, 6.5, 7.0, 7.5), dists=(5.0, 10.0), n=60, n_failed=0)
    assert oq_cli.main(["export", str(h5), str(tmp_path / "f.txt"), "--to", "toy", "--im", "pga_g", "--no-collapse"]) == 0
    assert oq_cli.main(["export", str(h5), str(tmp_path / "f.xml"), "--im", "pga_g", "--no-collapse"]) == 0
    [nrml] = oq.read_nrml(tmp_path / "f.xml").values()
    got = dict(line.split() for line in (tmp_path / "f.txt").read_text().splitlines())
    assert list(got) == list(nrml.limit_states)
    for ls, f in zip(nrml.limit_states, nrml.functions):
        assert float(got[ls]) == pytest.approx(f.median, rel=1e-12)
    with pytest.raises(ParameterError, match="'no-such-format' is not one of .*'nrml'"):
        outputs.write_fragility(nrml, tmp_path / "x.txt", "no-such-format")
    monkeypatch.delitem(outputs.WRITERS, "toy")
    with pytest.raises(SystemExit):
        oq_cli.main(["export", str(h5), str(tmp_path / "g.txt"), "--to", "toy"])
    assert "invalid choice: 'toy'" in capsys.readouterr().err
