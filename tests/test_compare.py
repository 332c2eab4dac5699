"""``pycolfrag.analysis.compare``: row-level equality of two results files and, where rows differ, the
per-scenario statistics (collapse fraction: Fisher's exact test; mean u_top, u_d: Welch's t).

The files are written by hand here in the layout of docs/results_format.md (h5py, every
``/samples`` field of ``pycolfrag.results.SAMPLE_FIELDS``, ``/spectra``, a few root attributes; as
other code would write them: no ``grid_signature``, so no checksums are due), so the tool is tested on
the format, not on the grid driver.
Expected numbers come from closed forms, not from the code under test:
* Fisher's exact test of 0/40 against 40/40: the only tables as extreme are the two
  corners, each with hypergeometric probability 1 / C(80, 40), so p = 2 / C(80, 40);
* Clopper-Pearson 95 % upper limit of 0 in n: 1 - 0.025^(1/n) (the beta quantile in closed form);
* Welch's t: t = (m1 - m2) / sqrt(v1/n1 + v2/n2) with the Welch-Satterthwaite degrees of
  freedom, computed below from the data with NumPy.
"""
from __future__ import annotations

import math
import subprocess
import sys

import numpy as np
import pytest

from pycolfrag import results
from pycolfrag.analysis.compare import compare_results

h5py = pytest.importorskip("h5py")

N_SC, N_S, PERIODS = 2, 40, np.array([0.5, 1.0])


def _rows(seed=0):
    """Plausible rows: scenario 0 rarely collapses, scenario 1 half the time."""
    rng = np.random.default_rng(seed)
    n = N_SC * N_S
    cols, _ = results.empty_columns(n, PERIODS.size)
    sc = np.repeat(np.arange(N_SC), N_S)
    cols["scenario"], cols["sample"] = sc.astype("i4"), np.tile(np.arange(N_S), N_SC).astype("i4")
    cols["mw"] = np.where(sc == 0, 6.5, 7.5)
    cols["dist_km"] = np.full(n, 10.0)
    cols["status"] = np.zeros(n, dtype="i4")
    cols["u_top"] = rng.lognormal(-3, 0.5, n)
    cols["u_d"] = rng.lognormal(-6, 0.5, n)
    cols["collapsed"] = ((sc == 1) & (rng.random(n) < 0.5)).astype("u1")
    cols["wall_s"] = rng.random(n)
    spectra = {"sa_g": rng.random((n, PERIODS.size)), "sv_cm_s": rng.random((n, PERIODS.size))}
    return cols, spectra


def _write(path, cols, spectra):
    with h5py.File(path, "w") as f:
        g = f.create_group("samples")
        for name, v in cols.items():
            g.create_dataset(name, data=v)
        sp = f.create_group("spectra")
        sp.attrs["periods_s"] = PERIODS
        for name, v in spectra.items():
            sp.create_dataset(name, data=v)
        f.attrs["format_version"] = results.FORMAT_VERSION
        f.attrs["complete"] = True
    return path


@pytest.fixture
def base(tmp_path):
    cols, spectra = _rows()
    return tmp_path, cols, spectra, _write(tmp_path / "a.h5", cols, spectra)


def test_identical_but_wall_time(base):
    tmp, cols, spectra, a = base
    cols = dict(cols, wall_s=cols["wall_s"] + 1.0)
    b = _write(tmp / "b.h5", cols, spectra)
    c = compare_results(a, b)
    assert c.identical and c.exit_code == 0 and c.n_common == N_SC * N_S
    assert c.differing_fields == {} and c.scenarios == []


def test_last_bit_differences_agree_statistically(base):
    tmp, cols, spectra, a = base
    cols = {k: v.copy() for k, v in cols.items()}
    cols["u_top"][[1, 5, 7]] = np.nextafter(cols["u_top"][[1, 5, 7]], 1.0)   # 1 ulp, scenario 0
    spectra = {k: v.copy() for k, v in spectra.items()}
    spectra["sa_g"][5, 1] = np.nextafter(spectra["sa_g"][5, 1], 0.0)
    c = compare_results(a, _write(tmp / "b.h5", cols, spectra))
    assert not c.identical and c.statistically_consistent and c.exit_code == 1
    assert c.differing_fields == {"u_top": 3, "spectra/sa_g": 1} and c.n_rows_differing == 3
    [s] = c.scenarios
    assert s.scenario == 0 and s.n_rows_differing == 3 and s.agree
    assert s.p_collapse == 1.0 and s.p_u_top > 0.9


def test_different_statistics_are_flagged(base):
    tmp, cols, spectra, a = base
    cols = {k: v.copy() for k, v in cols.items()}
    m0 = cols["scenario"] == 0
    cols["collapsed"][m0] = 1                   # 0/40 -> 40/40 collapses in scenario 0
    m1 = (cols["scenario"] == 1) & (cols["collapsed"] == 0)
    cols["u_top"][m1] *= 3.0                    # scenario 1: three times the displacement
    c = compare_results(a, _write(tmp / "b.h5", cols, spectra))
    assert c.exit_code == 2 and not c.statistically_consistent
    s0, s1 = c.scenarios
    assert s0.collapses == (0, 40) and s0.p_collapse == pytest.approx(2 / math.comb(80, 40), rel=1e-9)
    assert s0.collapse_ci95[0][1] == pytest.approx(1 - 0.025 ** (1 / 40), rel=1e-9)
    assert not s0.agree and not s1.agree and s1.p_collapse == 1.0
    x = base[1]["u_top"][m1]
    y = cols["u_top"][m1]
    vx, vy = x.var(ddof=1) / x.size, y.var(ddof=1) / y.size
    t = (x.mean() - y.mean()) / math.sqrt(vx + vy)
    df = (vx + vy) ** 2 / (vx ** 2 / (x.size - 1) + vy ** 2 / (y.size - 1))
    from scipy import stats
    assert s1.p_u_top == pytest.approx(2 * stats.t.sf(abs(t), df), rel=1e-9)
    # 4 tests made: scenario 0 has no standing run left in B (no u_top/u_d test), scenario 1 all 3
    assert s1.p_u_top < c.threshold and c.threshold == pytest.approx(0.05 / 4)


def test_missing_rows_are_reported(base):
    tmp, cols, spectra, a = base
    cols = {k: v.copy() for k, v in cols.items()}
    cols["status"][[3, 50]] = results.STATUS_PENDING     # not computed in B: load drops them
    c = compare_results(a, _write(tmp / "b.h5", cols, spectra))
    assert c.only_in_a == [(6.5, 10.0, 3), (7.5, 10.0, 10)] and c.only_in_b == [] and c.exit_code == 2


def test_files_without_rows_are_not_called_identical(base):
    """Two files whose rows are all pending (a grid killed before its first row) hold nothing to compare:
    0 matched rows must not read as "bitwise identical" (exit 0) nor as "consistent" (exit 1)."""
    tmp, cols, spectra, _ = base
    cols = dict(cols, status=np.full_like(cols["status"], results.STATUS_PENDING))  # load drops every row
    a = _write(tmp / "empty_a.h5", cols, spectra)
    b = _write(tmp / "empty_b.h5", cols, spectra)
    c = compare_results(a, b)
    assert c.n_common == 0 and not c.identical and not c.statistically_consistent and c.exit_code == 2
    p = subprocess.run([sys.executable, "-m", "pycolfrag.analysis.compare", str(a), str(b)],
                       capture_output=True, text=True)
    assert p.returncode == 2 and "no rows matched" in p.stdout and "identical" not in p.stdout


def test_command_line(base):
    tmp, cols, spectra, a = base
    cols = {k: v.copy() for k, v in cols.items()}
    cols["u_d"][0] = np.nextafter(cols["u_d"][0], 1.0)
    b = _write(tmp / "b.h5", cols, spectra)
    run = [sys.executable, "-m", "pycolfrag.analysis.compare"]
    p = subprocess.run(run + [str(a), str(a)], capture_output=True, text=True)
    assert p.returncode == 0 and "bitwise identical" in p.stdout
    p = subprocess.run(run + [str(a), str(b)], capture_output=True, text=True)
    assert p.returncode == 1 and "1 of 80 matched rows differ" in p.stdout and "u_d (1)" in p.stdout
    p = subprocess.run(run + [str(a), str(tmp / "missing.h5")], capture_output=True, text=True)
    assert p.returncode == 3 and "missing.h5" in p.stderr


def test_bad_alpha_is_refused(base):
    from pycolfrag.core.errors import ParameterError
    a = base[3]
    with pytest.raises(ParameterError, match="alpha"):
        compare_results(a, a, alpha=1.5)


def _record_rows(seed=0, n_rec=20):
    """A record-suite file: 20 records x h1/h2 x scales 1 and 2 (80 rows)."""
    rng = np.random.default_rng(seed)
    keys = [(f"RSN{i}", c, s) for s in (1.0, 2.0) for i in range(n_rec) for c in ("h1", "h2")]
    n = len(keys)
    cols, _ = results.empty_columns(n, PERIODS.size, "records")
    cols["record_id"] = np.array([k[0].encode() for k in keys], dtype=cols["record_id"].dtype)
    cols["component"] = np.array([k[1].encode() for k in keys], dtype=cols["component"].dtype)
    cols["scale"] = np.array([k[2] for k in keys])
    # every row the grid writes carries its record's index (a done row without it reads as damaged)
    cols["record"] = np.array([int(k[0][3:]) for k in keys], dtype=cols["record"].dtype)
    cols["status"] = np.zeros(n, dtype=cols["status"].dtype)
    cols["u_top"] = rng.lognormal(-3, 0.5, n) * cols["scale"]
    cols["u_d"] = rng.lognormal(-6, 0.5, n)
    cols["collapsed"] = ((cols["scale"] == 2.0) & (rng.random(n) < 0.3)).astype("u1")
    spectra = {"sa_g": rng.random((n, PERIODS.size)), "sv_cm_s": rng.random((n, PERIODS.size))}
    return cols, spectra


def test_record_suite_files_match_by_record_component_scale(tmp_path):
    """Record-suite rows have no (scenario, sample): they are matched by (record_id, component,
    scale) whatever their order, and the statistics are made per scale (a stripe). Rows written
    in reverse order match; one ulp of u_top in two scale-2 rows gives one group, 'scale 2',
    with 2 differing rows and agreeing statistics; all u_top of scale 2 doubled disagree (Welch's
    t on 40 lognormal values with sigma 0.5: |t| about 7, far beyond any Bonferroni threshold)."""
    cols, spectra = _record_rows()
    a = _write(tmp_path / "a.h5", cols, spectra)
    with h5py.File(a, "a") as f:
        f.attrs["layout"] = "records"
    rev = {k: v[::-1].copy() for k, v in cols.items()}
    b = _write(tmp_path / "b.h5", rev, {k: v[::-1].copy() for k, v in spectra.items()})
    with h5py.File(b, "a") as f:
        f.attrs["layout"] = "records"
    c = compare_results(a, b)
    assert c.identical and c.n_common == 80, c.summary()
    one = {k: v.copy() for k, v in cols.items()}
    i2 = np.flatnonzero(one["scale"] == 2.0)[:2]
    one["u_top"][i2] = np.nextafter(one["u_top"][i2], 1.0)
    d = _write(tmp_path / "d.h5", one, spectra)
    with h5py.File(d, "a") as f:
        f.attrs["layout"] = "records"
    c = compare_results(a, d)
    assert c.exit_code == 1 and c.n_rows_differing == 2 and [s.label for s in c.scenarios] == ["scale 2"]
    two = {k: v.copy() for k, v in cols.items()}
    two["u_top"] = np.where(two["scale"] == 2.0, 2 * two["u_top"], two["u_top"])
    e = _write(tmp_path / "e.h5", two, spectra)
    with h5py.File(e, "a") as f:
        f.attrs["layout"] = "records"
    c = compare_results(a, e)
    assert c.exit_code == 2 and not c.scenarios[0].agree


def _scenarios(cols, spectra, mws):
    """The rows of ``cols`` renumbered as a grid of the scenarios ``mws`` (R 10 km) would: row block j (40
    samples) becomes Mw mws[j], scenario j. The values stay: a block keeps its numbers whatever its index."""
    out = {k: v.copy() for k, v in cols.items()}
    n = len(mws) * N_S
    out = {k: v[:n].copy() for k, v in out.items()}
    out["mw"] = np.repeat(np.asarray(mws, float), N_S)
    out["scenario"] = np.repeat(np.arange(len(mws)), N_S).astype("i4")
    return out, {k: v[:n].copy() for k, v in spectra.items()}


def test_grids_of_other_scenario_sets_are_matched_by_mw_r_sample(tmp_path):
    """A small grid (Mw 6.5, 7.5) against a larger one (Mw 5.5, 6.5, 7.5) whose Mw 6.5 and 7.5
    rows are the same runs (the seeds are keyed by Mw, R and sample, not by the scenario index: a grid with
    more magnitudes numbers them 1 and 2). Matched by (Mw, R, sample) the 80 common rows are bitwise equal (no
    statistics, no DISAGREE) and the Mw 5.5 rows are said to be only in B; matched by scenario index, as
    before, Mw 6.5 was compared with Mw 5.5 and Mw 7.5 with Mw 6.5."""
    cols, spectra = _rows()
    a = _write(tmp_path / "small.h5", cols, spectra)                        # Mw 6.5, 7.5 as scenarios 0, 1
    big = {k: np.concatenate([v[N_S:], v]) for k, v in cols.items()}     # a block (Mw 5.5), then A's two
    big["mw"] = np.repeat([5.5, 6.5, 7.5], N_S)
    big["scenario"] = np.repeat(np.arange(3), N_S).astype("i4")
    big["sample"] = np.tile(np.arange(N_S), 3).astype("i4")
    big["collapsed"][:N_S] = 1                                               # Mw 5.5: other numbers entirely
    big_sp = {k: np.concatenate([v[N_S:] + 1.0, v]) for k, v in spectra.items()}
    b = _write(tmp_path / "default.h5", big, big_sp)
    c = compare_results(a, b)
    assert (c.n_a, c.n_b, c.n_common) == (80, 120, 80), c.summary()
    assert c.n_rows_differing == 0 and c.scenarios == [] and c.renumbered == 80
    assert c.only_in_a == [] and len(c.only_in_b) == N_S and {k[0] for k in c.only_in_b} == {5.5}
    assert c.groups_only == ([], ["Mw 5.5, 10 km"])
    assert c.exit_code == 2                       # the files hold different rows: said, not "identical"
    text = c.summary()
    assert "80 in common" in text and "only in B: Mw 5.5, 10 km" in text and "DISAGREE" not in text
    # B's Mw 6.5 collapses changed: the statistics are of Mw 6.5 in both files, labelled so
    big["collapsed"][N_S:2 * N_S] = 1
    c = compare_results(a, _write(tmp_path / "default2.h5", big, big_sp))
    [s] = c.scenarios
    assert s.label == "Mw 6.5, 10 km" and s.collapses == (0, 40) and s.scenario == 0 and not s.agree


def test_grids_without_a_common_key_are_refused(tmp_path):
    """Mw 6.5 alone against Mw 7.5 alone: no (Mw, R, sample) in common -- refused, naming both sets (before,
    both were scenario 0 and their rows were compared as one scenario)."""
    from pycolfrag.core.errors import ParameterError
    cols, spectra = _rows()
    a = _write(tmp_path / "a.h5", *_scenarios(cols, spectra, [6.5]))
    b = _write(tmp_path / "b.h5", *_scenarios(cols, spectra, [7.5]))
    with pytest.raises(ParameterError, match=r"no row key \(Mw, R km, sample\) in common.*Mw 6.5, 10 km.*Mw 7.5"):
        compare_results(a, b)
    p = subprocess.run([sys.executable, "-m", "pycolfrag.analysis.compare", str(a), str(b)],
                       capture_output=True, text=True)
    assert p.returncode == 3 and "in common" in p.stderr


def test_a_grid_and_a_record_suite_are_refused(tmp_path):
    from pycolfrag.core.errors import ParameterError
    cols, spectra = _rows()
    a = _write(tmp_path / "a.h5", cols, spectra)
    rc, rs = _record_rows()
    r = _write(tmp_path / "r.h5", rc, rs)
    with h5py.File(r, "a") as f:
        f.attrs["layout"] = "records"
    with pytest.raises(ParameterError, match="keyed differently"):
        compare_results(a, r)


def test_small_grid_against_a_larger_fake_grid_from_the_command(tmp_path):
    """The issue's case with files the grid writes (tests/grid_fakes.py: rows from each row's own seeds, keyed
    by Mw, R and sample): Mw 6.5 alone against Mw 5.5, 6.5, 7.5, 3 samples at 10 km. The 3 common rows are the
    same runs, bit for bit; before, Mw 6.5 (scenario 0 of A) was compared with Mw 5.5 (scenario 0 of B)."""
    from test_commands import _pycolfrag
    base = ["--dist", "10", "--samples", "3", "--sample-function", "grid_fakes:fake", "--no-figures",
            "--no-progress"]
    for name, mws in (("small", ["6.5"]), ("big", ["5.5", "6.5", "7.5"])):
        p = _pycolfrag("grid", "--mw", *mws, *base, "--out", str(tmp_path / f"{name}.h5"))
        assert p.returncode == 0, p.stdout + p.stderr
    p = _pycolfrag("compare", str(tmp_path / "small.h5"), str(tmp_path / "big.h5"))
    assert p.returncode == 2, p.stdout + p.stderr
    assert "rows: 3 in A, 9 in B, 3 in common" in p.stdout and "0 of 3" not in p.stdout
    assert "only in B: Mw 5.5, 10 km; Mw 7.5, 10 km" in p.stdout and "DISAGREE" not in p.stdout
    assert "matched rows differ" not in p.stdout


def test_a_row_without_mw_cannot_be_matched_and_says_so(base):
    from pycolfrag.core.errors import ParameterError
    tmp, cols, spectra, a = base
    cols = {k: v.copy() for k, v in cols.items()}
    cols["mw"][7] = np.nan
    with pytest.raises(ParameterError, match="no finite Mw or R"):
        compare_results(a, _write(tmp / "b.h5", cols, spectra))
