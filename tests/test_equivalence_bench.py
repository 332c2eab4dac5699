"""bench/equivalence.py's paired statistics and verdict (docs/work_precision.md, "Sleeping joints: the model
did not move"), on synthetic numbers whose answer is known by construction -- no solver runs.

The differences are built as shift + s * z with z of mean 0 and sample sd 1 exactly (standardised normals),
so the paired mean difference is ``shift`` and its standard error s / sqrt(n) to round-off: a shift of 3 SE
must be flagged and one of 1.5 SE must pass, with the 2 SE rule. The proportions' SE is McNemar's,
sqrt(b + c - (c - b)^2 / n) / n for b old-only and c new-only pairs, which is the population sd of the
+-1/0 differences over sqrt(n): both are computed here and compared.
"""
from __future__ import annotations

import importlib.util
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parent.parent


@pytest.fixture(scope="module")
def eq():
    spec = importlib.util.spec_from_file_location("bench_equivalence", ROOT / "bench" / "equivalence.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def _unit(n, seed):
    z = np.random.default_rng(seed).normal(size=n)
    return (z - z.mean()) / z.std(ddof=1)


def _runs(u_top, u_d=None, collapsed=None, energy=None, failed=None):
    n = len(u_top)
    u_d = np.full(n, 0.001) if u_d is None else u_d                   # below every u_d level (0.005)
    collapsed = np.zeros(n, bool) if collapsed is None else collapsed
    energy = np.full(n, 0.01) if energy is None else energy
    failed = np.zeros(n, bool) if failed is None else failed
    return [{"u_top": float(a), "u_d": math.nan if c else float(b), "collapsed": bool(c), "energy_error": float(e),
             "failed": bool(f), "cpu_s": 0.1} for a, b, c, e, f in zip(u_top, u_d, collapsed, energy, failed)]


N, S = 50, 0.004
BASE = 0.08 + 0.01 * _unit(N, 1)          # u_top between 0.05 and 0.11: no u_top level (0.15) is near


def _shifted(k_se):
    return BASE + k_se * S / math.sqrt(N) + S * _unit(N, 2)


def test_identical_inputs_are_equivalent(eq):
    old = _runs(BASE)
    d = eq.compare_runs(old, [dict(r) for r in old])
    assert d["failing"] == []
    for r in d["rows"]:
        assert r["diff"] == 0 and r["se"] == 0 and r["ok"], r
    ok, failing, expected, roundoff = eq.verdict({"pert": d, "grid": d})
    assert ok and failing == [] and roundoff == []
    assert expected == pytest.approx(2 * len(d["rows"]) * 0.0455, rel=1e-2)


def test_paired_mean_known_answer(eq):
    r = eq.paired_mean(BASE, _shifted(3.0))
    assert r["n"] == N
    assert r["diff"] == pytest.approx(3 * S / math.sqrt(N), rel=1e-9)
    assert r["se"] == pytest.approx(S / math.sqrt(N), rel=1e-9)
    assert r["z"] == pytest.approx(3.0, rel=1e-9)
    assert not eq.within(r)
    assert eq.within(eq.paired_mean(BASE, _shifted(1.5)))
    assert eq.within(eq.paired_mean(BASE, _shifted(-1.9)))
    assert not eq.within(eq.paired_mean(BASE, _shifted(-2.1)))


@pytest.mark.parametrize("k_se, flagged", [(3.0, True), (-3.0, True), (1.5, False)])
def test_shift_of_u_top_flags_that_row_alone(eq, k_se, flagged):
    d = eq.compare_runs(_runs(BASE), _runs(_shifted(k_se)))
    row = next(r for r in d["rows"] if r["quantity"] == "mean u_top")
    assert row["z"] == pytest.approx(k_se, rel=1e-9)
    assert d["failing"] == (["mean u_top"] if flagged else [])
    ok, failing, _, _ = eq.verdict({"rec": d})
    assert ok is not flagged
    assert failing == (["rec: mean u_top"] if flagged else [])


def test_paired_proportion_is_mcnemar(eq):
    n = 100
    old = np.zeros(n, bool)
    new = np.zeros(n, bool)
    old[:2] = True                         # b = 2 old-only
    new[10:20] = True                      # c = 10 new-only
    old[50:70] = new[50:70] = True         # 20 concordant exceedances
    r = eq.paired_proportion(old, new)
    assert (r["old_only"], r["new_only"]) == (2, 10)
    assert r["diff"] == pytest.approx(0.08)
    assert r["se"] == pytest.approx(math.sqrt(12 - 64 / n) / n)
    d = new.astype(float) - old.astype(float)
    assert r["se"] == pytest.approx(d.std(ddof=0) / math.sqrt(n))
    assert r["z"] == pytest.approx(0.08 / (math.sqrt(11.36) / n))   # 2.37: beyond 2 SE
    assert not eq.within(r)
    new[10:14] = False                     # c = 6: 0.04 / 0.028 = 1.43 SE
    assert eq.within(eq.paired_proportion(old, new))
    assert r["p_exact"] == pytest.approx(2 * (1 + 12 + 66) / 2 ** 12)   # P(X <= 2), X ~ Binomial(12, 1/2), twice
    assert eq.mcnemar_exact(0, 4) == 0.125 and eq.mcnemar_exact(3, 3) == 1.0 and eq.mcnemar_exact(0, 0) == 1.0


def test_more_collapses_are_flagged(eq):
    col_new = np.zeros(N, bool)
    col_new[:12] = True
    d = eq.compare_runs(_runs(BASE), _runs(BASE, collapsed=col_new))
    assert "P(collapse)" in d["failing"]
    assert "P(u_top >= 0.15)" in d["failing"]      # a collapse exceeds every level
    assert "mean u_top" not in d["failing"]        # paired over the inputs where both stand: unchanged


def test_energy_error_fails_one_sided(eq):
    e = 0.01 + 0.002 * _unit(N, 3)
    worse = e + 3 * 0.001 / math.sqrt(N) + 0.001 * _unit(N, 4)
    better = e - 3 * 0.001 / math.sqrt(N) + 0.001 * _unit(N, 4)
    assert eq.compare_runs(_runs(BASE, energy=e), _runs(BASE, energy=worse))["failing"] == ["mean abs(energy error)"]
    assert eq.compare_runs(_runs(BASE, energy=e), _runs(BASE, energy=better))["failing"] == []


def test_new_failures_are_flagged(eq):
    failed = np.zeros(N, bool)
    failed[3] = True
    d = eq.compare_runs(_runs(BASE), _runs(BASE, failed=failed))
    assert d["n_paired"] == N - 1 and d["failed"] == (0, 1)
    assert d["failing"] == ["failed runs 0 -> 1"]


def test_unequal_lengths_refused(eq):
    with pytest.raises(ValueError, match="differ in length"):
        eq.paired_mean([1.0, 2.0], [1.0])
    with pytest.raises(ValueError, match="ran 2 and 1 inputs"):
        eq.compare_runs(_runs(BASE[:2]), _runs(BASE[:1]))


def test_help_runs_without_the_package(tmp_path):
    """``bench/equivalence.py --help`` from a fresh clone: nothing but numpy imported before the options."""
    p = subprocess.run([sys.executable, str(ROOT / "bench" / "equivalence.py"), "--help"], capture_output=True,
                       text=True, cwd=tmp_path, env={"PATH": "/usr/bin:/bin"})
    assert p.returncode == 0, p.stderr
    assert "--new-options" in p.stdout and "--old" in p.stdout


def test_work_precision_keeps_the_equivalence_section(tmp_path):
    """bench/work_precision.py rewrites docs/work_precision.md: the part from its KEEP_MARK on (this bench's
    evidence) survives, and a file without the mark is rewritten whole."""
    spec = importlib.util.spec_from_file_location("bench_work_precision", ROOT / "bench" / "work_precision.py")
    wp = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(wp)
    doc = tmp_path / "work_precision.md"
    kept = f"{wp.KEEP_MARK}\n\n## Sleeping joints: the model did not move\n\ntable\n"
    doc.write_text("# old table\n\nold rows\n\n" + kept)
    wp.write_keeping(doc, "# new table\n")
    assert doc.read_text() == "# new table\n\n" + kept
    doc.write_text("# old table only\n")
    wp.write_keeping(doc, "# new table\n")
    assert doc.read_text() == "# new table\n"
    assert wp.KEEP_MARK in (ROOT / "docs" / "work_precision.md").read_text()


def test_round_off_beyond_2_se_does_not_fail(eq):
    """Nearly deterministic pairs (the pert ensemble's u_top): a shift of 3 SE that is 1e-9 of the mean is
    round-off, reported as such, and passes; the same 3 SE at 1e-5 of the mean fails."""
    for rel, is_roundoff in ((1e-9, True), (1e-5, False)):
        s = rel * 0.08 * math.sqrt(N) / 3                   # so that 3 SE = rel x the mean (0.08)
        new = BASE + 3 * s / math.sqrt(N) + s * _unit(N, 2)
        d = eq.compare_runs(_runs(BASE), _runs(new))
        row = next(r for r in d["rows"] if r["quantity"] == "mean u_top")
        assert row["z"] == pytest.approx(3.0, rel=1e-6) and not row["ok"]
        assert row["roundoff"] is is_roundoff
        ok, failing, _, roundoff = eq.verdict({"pert": d})
        assert ok is is_roundoff
        assert (roundoff, failing) == ((["pert: mean u_top"], []) if is_roundoff else ([], ["pert: mean u_top"]))
