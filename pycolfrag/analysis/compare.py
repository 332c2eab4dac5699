"""Compare two grid results files: are the rows bitwise equal, and where they are not, do the
per-scenario statistics agree within their sampling error?

Run as ``python -m pycolfrag.analysis.compare A.h5 B.h5`` (options: ``--alpha``, ``--quiet``), or call
:func:`compare_results`. A file in the documented layout that ``run_grid.py`` did not write (no
``grid_signature``) is compared too; a grid's file is verified against its checksums first. See docs/reproducibility.md for when two files should be bitwise equal
(same pycolfrag version and grid arguments on any x86-64 CPU) and when only statistically.

Rows are matched by their (scenario, sample) key (a record suite: (record_id, component, scale), statistics per
scale; a batch of events: (stage, stratum, index), statistics per stratum); every ``/samples`` field except ``wall_s``
(the only machine-dependent one) and both ``/spectra`` datasets are compared bit for bit
(NaN equals NaN of the same bits). For every scenario with a differing row, on the successful
rows of each file:

* collapse fraction: Fisher's exact test of the two proportions (the exact form of the
  two-proportion test, valid for small counts), with Clopper-Pearson 95 % intervals reported;
* mean ``u_top`` and mean ``u_d`` of the runs that did not collapse (collapse is the first
  test's business; a collapsed run's displacement is not a response): Welch's t-test.

A scenario "agrees" when no p-value is below ``alpha`` divided by the number of tests made
over all scenarios (Bonferroni: with 20 scenarios and 3 tests each, a 5 % test would flag one
scenario in 1.6 by chance alone). Exit status of the command: 0 every row bitwise equal; 1 rows
differ but every scenario agrees; 2 some scenario disagrees, or the files hold different rows;
3 a file could not be read.
"""
from __future__ import annotations

import argparse
import math
import sys
from dataclasses import dataclass, field

import numpy as np
from scipy import stats

from .. import results as _results
from ..errors import ParameterError, PycolfragError
from .data import Results, load

__all__ = ["compare_results", "Comparison", "ScenarioStats", "main"]

IGNORED_FIELDS = _results.TIMING_FIELDS


@dataclass
class ScenarioStats:
    """Per-scenario statistics of the two files (successful rows only)."""

    scenario: int                 # synthetic: the scenario index; record suite: index of the scale
    mw: float                     # NaN for a record-suite group
    dist_km: float                # record suite: NaN
    n_rows_differing: int
    n_ok: tuple                   # (a, b)
    collapses: tuple              # (a, b)
    collapse_ci95: tuple          # ((lo, hi) of a, (lo, hi) of b), Clopper-Pearson
    p_collapse: float             # Fisher's exact test, two-sided
    mean_u_top: tuple             # (a, b), runs without collapse
    p_u_top: float                # Welch's t-test, two-sided (nan if < 2 values in a file)
    mean_u_d: tuple
    p_u_d: float
    agree: bool = True
    label: str = ""               # what the group is ("Mw 7.5, 5 km" or "scale 2")


@dataclass
class Comparison:
    """Result of :func:`compare_results`."""

    n_a: int
    n_b: int
    n_common: int
    only_in_a: list               # (scenario, sample) keys
    only_in_b: list
    differing_fields: dict        # field -> number of matched rows whose bits differ
    n_rows_differing: int
    scenarios: list = field(default_factory=list)   # ScenarioStats of scenarios with differing rows
    alpha: float = 0.05
    threshold: float = 0.05       # alpha / number of tests (Bonferroni)

    @property
    def identical(self) -> bool:
        """At least one row matched, every row of both files present in the other and bitwise equal
        (but ``wall_s``). Two files without a finished row are not identical: nothing was compared."""
        return self.n_common > 0 and not self.only_in_a and not self.only_in_b and self.n_rows_differing == 0

    @property
    def statistically_consistent(self) -> bool:
        """Same rows (at least one), and every scenario with differing rows agrees within sampling error."""
        return (self.n_common > 0 and not self.only_in_a and not self.only_in_b
                and all(s.agree for s in self.scenarios))

    @property
    def exit_code(self) -> int:
        if self.identical:
            return 0
        return 1 if self.statistically_consistent else 2

    def summary(self) -> str:
        lines = [f"rows: {self.n_a} in A, {self.n_b} in B, {self.n_common} matched by their key"]
        if self.only_in_a or self.only_in_b:
            lines.append(f"rows only in A: {len(self.only_in_a)}, only in B: {len(self.only_in_b)} "
                         "(the files are not runs of the same grid, or one is unfinished)")
        if self.n_common == 0:
            lines.append("no rows matched: the files have no finished row in common, so nothing was compared")
            return "\n".join(lines)
        if self.identical:
            lines.append("bitwise identical: every matched row equal in every field (wall_s ignored)")
            return "\n".join(lines)
        lines.append(f"{self.n_rows_differing} of {self.n_common} matched rows differ; fields (rows): "
                     + ", ".join(f"{k} ({v})" for k, v in sorted(self.differing_fields.items())))
        lines.append(f"per scenario with differing rows (tests at alpha {self.alpha:g} / "
                     f"{round(self.alpha / self.threshold) if self.threshold else 0} = {self.threshold:.3g}):")
        for s in self.scenarios:
            lines.append(
                f"  {s.label}: {s.n_rows_differing} rows differ; "
                f"collapses {s.collapses[0]}/{s.n_ok[0]} vs {s.collapses[1]}/{s.n_ok[1]} (p = {s.p_collapse:.3g}); "
                f"mean u_top {s.mean_u_top[0]:.4g} vs {s.mean_u_top[1]:.4g} (p = {s.p_u_top:.3g}); "
                f"mean u_d {s.mean_u_d[0]:.4g} vs {s.mean_u_d[1]:.4g} (p = {s.p_u_d:.3g}) -> "
                + ("agree" if s.agree else "DISAGREE"))
        lines.append("statistics agree within sampling error" if self.statistically_consistent
                     else "statistics DISAGREE (or the rows do not match)")
        return "\n".join(lines)


def _same_bits(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Row mask: True where the rows of a and b are equal bit for bit (any trailing shape)."""
    if a.dtype.kind == "O" or b.dtype.kind == "O":
        eq = np.array([x == y for x, y in zip(a, b)], dtype=bool)
        return eq
    if a.dtype != b.dtype or a.shape[1:] != b.shape[1:]:
        return np.zeros(len(a), dtype=bool)
    av = np.ascontiguousarray(a).view(np.uint8).reshape(len(a), -1)
    bv = np.ascontiguousarray(b).view(np.uint8).reshape(len(b), -1)
    return np.all(av == bv, axis=1)


def _clopper_pearson(k: int, n: int, conf: float = 0.95) -> tuple:
    if n == 0:
        return (math.nan, math.nan)
    a = 1.0 - conf
    lo = 0.0 if k == 0 else float(stats.beta.ppf(a / 2, k, n - k + 1))
    hi = 1.0 if k == n else float(stats.beta.ppf(1 - a / 2, k + 1, n - k))
    return (lo, hi)


def _welch(x: np.ndarray, y: np.ndarray) -> float:
    if len(x) < 2 or len(y) < 2:
        return math.nan
    if np.array_equal(x, y):
        return 1.0
    if np.var(x) == 0 and np.var(y) == 0:
        return 1.0 if x[0] == y[0] else 0.0
    return float(stats.ttest_ind(x, y, equal_var=False).pvalue)


def _str(v) -> str:
    return v.decode("utf-8", "replace") if isinstance(v, bytes) else str(v)


def _row_keys(s) -> tuple:
    """{row key: index} and the group of each row: (scenario, sample) and the scenario for a
    synthetic grid; (record_id, component, scale) and the scale for a record suite."""
    if "scenario" in s:
        keys = {(int(a), int(b)): i for i, (a, b) in enumerate(zip(s["scenario"], s["sample"]))}
        return keys, np.asarray(s["scenario"]).astype(float)
    if "record_id" in s:
        keys = {(_str(r), _str(c), float(x)): i for i, (r, c, x) in enumerate(zip(s["record_id"], s["component"],
                                                                                  s["scale"]))}
        return keys, np.asarray(s["scale"], dtype=float)
    if "stratum" in s:  # a batch of events (a site simulation): (stage, stratum, index), statistics per stratum
        keys = {(int(a), int(b), int(c)): i for i, (a, b, c) in enumerate(zip(s["stage"], s["stratum"], s["index"]))}
        return keys, np.asarray(s["stratum"]).astype(float)
    raise ParameterError("a results file without (scenario, sample), (record_id, component, scale) or (stage, "
                         "stratum, index) rows")


def _scenario_stats(ra, rb, ia, ib, sc, n_diff, index=0) -> ScenarioStats:
    sa, sb = ra.samples, rb.samples
    out = {}
    for key, s, idx in (("a", sa, ia), ("b", sb, ib)):
        ok = idx[s["status"][idx] == _results.STATUS_OK]
        col = s["collapsed"][ok].astype(bool)
        stand = ok[~col]
        ut, ud = s["u_top"][stand], s["u_d"][stand]
        out[key] = (len(ok), int(col.sum()), ut[np.isfinite(ut)], ud[np.isfinite(ud)])
    (na, ka, uta, uda), (nb, kb, utb, udb) = out["a"], out["b"]
    if na and nb:
        p_col = float(stats.fisher_exact([[ka, na - ka], [kb, nb - kb]]).pvalue)
    else:
        p_col = math.nan
    i0 = ia[0] if len(ia) else ib[0]
    s0 = sa if len(ia) else sb
    if "scenario" in s0:
        mw, dist = float(s0["mw"][i0]), float(s0["dist_km"][i0])
        label = f"scenario {int(sc)} (Mw {mw:g}, {dist:g} km)"
    else:
        mw = dist = math.nan
        label = f"scale {float(sc):g}"
    return ScenarioStats(
        scenario=int(sc) if "scenario" in s0 else index, mw=mw, dist_km=dist, label=label, n_rows_differing=n_diff,
        n_ok=(na, nb), collapses=(ka, kb), collapse_ci95=(_clopper_pearson(ka, na), _clopper_pearson(kb, nb)),
        p_collapse=p_col,
        mean_u_top=(float(np.mean(uta)) if len(uta) else math.nan, float(np.mean(utb)) if len(utb) else math.nan),
        p_u_top=_welch(uta, utb),
        mean_u_d=(float(np.mean(uda)) if len(uda) else math.nan, float(np.mean(udb)) if len(udb) else math.nan),
        p_u_d=_welch(uda, udb))


def compare_results(a, b, alpha: float = 0.05) -> Comparison:
    """Compare two results files (paths or :class:`pycolfrag.analysis.data.Results`).

    Parameters
    ----------
    a, b : str, path-like or Results
        Finished rows are read with :func:`pycolfrag.analysis.data.load`.
    alpha : float
        Family-wise significance level of the statistical tests (default 0.05), shared among
        all tests by Bonferroni's correction.

    Returns
    -------
    Comparison
        ``identical``, ``statistically_consistent``, ``exit_code``, ``summary()``, the counts
        of differing rows per field and one :class:`ScenarioStats` per scenario with a
        differing row.
    """
    if not 0.0 < float(alpha) < 1.0:
        raise ParameterError(f"alpha must be in (0, 1), got {alpha!r}")
    ra, rb = (x if isinstance(x, Results) else load(x, any_layout=True) for x in (a, b))
    sa, sb = ra.samples, rb.samples
    keys_a, group_a = _row_keys(sa)
    keys_b, group_b = _row_keys(sb)
    common = sorted(set(keys_a) & set(keys_b))
    ia = np.array([keys_a[k] for k in common], dtype=int)
    ib = np.array([keys_b[k] for k in common], dtype=int)
    diff_rows = np.zeros(len(common), dtype=bool)
    differing = {}
    columns = [(f, sa[f], sb.get(f)) for f in sa if f not in IGNORED_FIELDS]
    columns += [(f, None, sb[f]) for f in sb if f not in IGNORED_FIELDS and f not in sa]
    columns += [(f"spectra/{f}", ra.spectra.get(f), rb.spectra.get(f))
                for f in sorted(set(ra.spectra) | set(rb.spectra))]
    for name, ca, cb in columns:
        if ca is None or cb is None:        # a field only one file has: every row differs in it, unless
            # it is NaN in every row (an EDP newer than the other file's code that does not exist in these
            # runs: the dowels' of a column without dowels): absent and NaN say the same
            only = np.asarray(cb if ca is None else ca)
            neq = np.ones(len(common), dtype=bool)
            if only.dtype.kind == "f" and np.isnan(only).all():
                neq[:] = False
        else:
            neq = ~_same_bits(np.asarray(ca)[ia], np.asarray(cb)[ib]) if len(common) else np.zeros(0, bool)
        if neq.any():
            differing[name] = int(neq.sum())
            diff_rows |= neq
    cmp = Comparison(n_a=len(keys_a), n_b=len(keys_b), n_common=len(common),
                     only_in_a=sorted(set(keys_a) - set(keys_b)), only_in_b=sorted(set(keys_b) - set(keys_a)),
                     differing_fields=differing, n_rows_differing=int(diff_rows.sum()), alpha=float(alpha))
    row_group = group_a[ia] if len(common) else np.zeros(0)
    diff_scen = sorted({float(row_group[i]) for i in np.flatnonzero(diff_rows)})
    stats_list = []
    for gi, sc in enumerate(diff_scen):
        ja = np.flatnonzero(group_a == sc)
        jb = np.flatnonzero(group_b == sc)
        n_diff = int(np.count_nonzero(diff_rows & (row_group == sc)))
        st = _scenario_stats(ra, rb, ja, jb, sc, n_diff, index=gi)   # record suite: scenario = scale group index
        stats_list.append(st)
    n_tests = sum(sum(1 for p in (s.p_collapse, s.p_u_top, s.p_u_d) if not math.isnan(p)) for s in stats_list)
    cmp.threshold = float(alpha) / max(n_tests, 1)
    for s in stats_list:
        s.agree = all(math.isnan(p) or p >= cmp.threshold for p in (s.p_collapse, s.p_u_top, s.p_u_d))
    cmp.scenarios = stats_list
    return cmp


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="pycolfrag compare",
                                 description="Compare two pycolfrag grid results files row by row and, "
                                             "where rows differ, by per-scenario statistics.")
    ap.add_argument("a", help="first results file (HDF5)")
    ap.add_argument("b", help="second results file (HDF5)")
    ap.add_argument("--alpha", type=float, default=0.05, help="family-wise significance level (default 0.05)")
    ap.add_argument("--quiet", action="store_true", help="print nothing; the exit status says it all")
    args = ap.parse_args(argv)
    try:
        cmp = compare_results(args.a, args.b, alpha=args.alpha)
    except (PycolfragError, OSError, ValueError) as exc:
        print(f"compare: {exc}", file=sys.stderr)
        return 3
    except Exception as exc:  # noqa: BLE001 -- any other failure must not read as exit 1 ("consistent")
        print(f"compare: could not compare the files: {type(exc).__name__}: {exc}", file=sys.stderr)
        return 3
    if not args.quiet:
        print(cmp.summary())
    return cmp.exit_code


if __name__ == "__main__":  # pragma: no cover - exercised through a subprocess in the tests
    sys.exit(main())
