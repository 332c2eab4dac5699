"""Compare two grid results files: are the rows bitwise equal, and where they are not, do the
per-scenario statistics agree within their sampling error?

Run as ``python -m pycolfrag.analysis.compare A.h5 B.h5`` (options: ``--alpha``, ``--quiet``), or call
:func:`compare_results`. A file in the documented layout that ``run_grid.py`` did not write (no
``grid_signature``) is compared too; a grid's file is verified against its checksums first. See docs/reproducibility.md for when two files should be bitwise equal
(same pycolfrag version and grid arguments on any x86-64 CPU) and when only statistically.

Rows are matched by their key: a synthetic grid's (Mw, R km, sample) -- the key its seeds are drawn from
(thousandths of Mw and km, as :func:`pycolfrag.grid.rows.derive_seed` takes them), not the scenario index, which is
each grid's own numbering (a grid of Mw 6.5-7.5 numbers Mw 6.5 scenario 0, the default grid Mw 5.5); a record
suite's (record_id, component, scale), statistics per scale; a batch of events' (stage, stratum, index), statistics
per stratum. Files of two kinds, or whose rows have no key in common, are refused (ParameterError, exit 3): nothing
would be compared. Every ``/samples`` field except ``wall_s`` (the only machine-dependent one) and a synthetic grid's
``scenario`` (its numbering) and both ``/spectra`` datasets are compared bit for bit
(NaN equals NaN of the same bits). For every scenario with a differing row, on the successful
rows of each file:

* collapse fraction: Fisher's exact test of the two proportions (the exact form of the
  two-proportion test, valid for small counts), with Clopper-Pearson 95 % intervals reported;
* mean ``u_top`` and mean ``u_d`` of the runs that did not collapse (collapse is the first
  test's business; a collapsed run's displacement is not a response): Welch's t-test.

A scenario "agrees" when no p-value is below ``alpha`` divided by the number of tests made
over all scenarios (Bonferroni: with 20 scenarios and 3 tests each, a 5 % test would flag one
scenario in 1.6 by chance alone). Exit status of the command: 0 every row bitwise equal; 1 rows
differ but every scenario agrees; 2 some scenario disagrees, or the files hold different rows (the
rows in common are still compared, and their number said); 3 a file could not be read, or the files have
no row key in common.
"""
from __future__ import annotations

import argparse
import math
import sys
from dataclasses import dataclass, field

import numpy as np
from scipy import stats

from pycolfrag import results as _results
from pycolfrag.analysis.data import Results, load
from pycolfrag.core.errors import ParameterError, PycolfragError

__all__ = ["compare_results", "Comparison", "ScenarioStats", "main"]

IGNORED_FIELDS = _results.TIMING_FIELDS


@dataclass
class ScenarioStats:
    """Per-scenario statistics of the two files (successful rows only)."""

    scenario: int                 # synthetic: the scenario index in A (in B if A lacks it); record suite: index
                                  # of the scale
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
    only_in_a: list               # row keys: (Mw, R km, sample), (record_id, component, scale), (stage, stratum, index)
    only_in_b: list
    differing_fields: dict        # field -> number of matched rows whose bits differ
    n_rows_differing: int
    scenarios: list = field(default_factory=list)   # ScenarioStats of scenarios with differing rows
    alpha: float = 0.05
    threshold: float = 0.05       # alpha / number of tests (Bonferroni)
    key_names: str = "(Mw, R km, sample)"
    renumbered: int = 0           # matched synthetic rows whose scenario index differs (grids of other scenario sets)
    groups_only: tuple = ((), ())  # labels of the scenarios (groups) only in A, only in B

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
        lines = [f"rows: {self.n_a} in A, {self.n_b} in B, {self.n_common} in common, matched by their key "
                 f"{self.key_names}"]
        if self.only_in_a or self.only_in_b:
            lines.append(f"rows only in A: {len(self.only_in_a)}, only in B: {len(self.only_in_b)} "
                         "(the files are not runs of the same grid, or one is unfinished); only the "
                         f"{self.n_common} rows in common are compared")
            for name, labels in zip("AB", self.groups_only):
                if labels:
                    lines.append(f"  only in {name}: " + "; ".join(labels[:8])
                                 + (f" and {len(labels) - 8} more" if len(labels) > 8 else ""))
        if self.renumbered:
            lines.append(f"{self.renumbered} matched rows have another scenario index in B (the grids number other "
                         "scenario sets); rows are matched by (Mw, R, sample), the index is not compared")
        if self.n_common == 0:
            lines.append("no rows matched: the files have no finished row in common, so nothing was compared")
            return "\n".join(lines)
        if self.identical:
            lines.append("bitwise identical: every matched row equal in every field (wall_s ignored)")
            return "\n".join(lines)
        partial = bool(self.only_in_a or self.only_in_b)
        if self.n_rows_differing == 0:
            lines.append(f"the {self.n_common} rows in common are bitwise identical (wall_s ignored); the files hold "
                         "different rows")
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
        if all(s.agree for s in self.scenarios):
            lines.append("statistics agree within sampling error" + ("" if not partial else
                         " on the rows in common; the files hold different rows"))
        else:
            lines.append("statistics DISAGREE")
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


def _coord(x) -> float:
    """A grid coordinate (Mw, km) on the thousandths the grid's seeds are keyed by
    (:func:`pycolfrag.grid.rows.derive_seed`): 6.5 and 6.500000000000001 are one scenario."""
    return round(float(x) * 1000.0) / 1000.0


#: What the rows of each kind of file are keyed by, as the summary names it.
KEY_NAMES = {"synthetic": "(Mw, R km, sample)", "records": "(record_id, component, scale)",
             "events": "(stage, stratum, index)"}


def _kind(s) -> str:
    if "scenario" in s or ("mw" in s and "sample" in s and "record_id" not in s and "stratum" not in s):
        return "synthetic"
    if "record_id" in s:
        return "records"
    if "stratum" in s:
        return "events"
    raise ParameterError("a results file without (Mw, R, sample), (record_id, component, scale) or (stage, "
                         "stratum, index) rows")


def _row_keys(s) -> tuple:
    """{row key: index}, the group of each row (a list of hashable labels) and the kind of file: (Mw, R km,
    sample) and the scenario (Mw, R km) for a synthetic grid; (record_id, component, scale) and the scale for a
    record suite; (stage, stratum, index) and the stratum for a batch of events."""
    kind = _kind(s)
    if kind == "synthetic":
        bad = np.flatnonzero(~(np.isfinite(np.asarray(s["mw"], float)) & np.isfinite(np.asarray(s["dist_km"], float))))
        if bad.size:
            raise ParameterError(f"{bad.size} finished row(s) have no finite Mw or R (e.g. row {int(bad[0])}): a "
                                 "synthetic grid's rows are matched by (Mw, R, sample), and these cannot be")
        mw, dist = [_coord(x) for x in s["mw"]], [_coord(x) for x in s["dist_km"]]
        keys = {(m, d, int(k)): i for i, (m, d, k) in enumerate(zip(mw, dist, s["sample"]))}
        return keys, list(zip(mw, dist)), kind
    if kind == "records":
        keys = {(_str(r), _str(c), float(x)): i for i, (r, c, x) in enumerate(zip(s["record_id"], s["component"],
                                                                                  s["scale"]))}
        return keys, [float(x) for x in s["scale"]], kind
    keys = {(int(a), int(b), int(c)): i for i, (a, b, c) in enumerate(zip(s["stage"], s["stratum"], s["index"]))}
    return keys, [int(x) for x in s["stratum"]], kind


def _group_label(kind: str, g) -> str:
    if kind == "synthetic":
        return f"Mw {g[0]:g}, {g[1]:g} km"
    return f"scale {g:g}" if kind == "records" else f"stratum {g}"


def _no_common_keys(kind: str, names: tuple, groups_a: list, groups_b: list) -> ParameterError:
    def span(groups):
        labels = sorted(set(groups))
        return (f"{len(labels)} {'scenarios' if kind == 'synthetic' else 'groups'}: "
                + "; ".join(_group_label(kind, g) for g in labels[:4]) + (" ..." if len(labels) > 4 else ""))
    return ParameterError(f"{names[0]} and {names[1]} have no row key {KEY_NAMES[kind]} in common (A: {len(groups_a)} "
                          f"rows, {span(groups_a)}; B: {len(groups_b)} rows, {span(groups_b)}): nothing to compare. "
                          "Compare files of the same grid, or grids that share scenarios")


def _scenario_stats(ra, rb, ia, ib, n_diff, index=0, label="", kind="synthetic") -> ScenarioStats:
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
    if kind == "synthetic":
        mw, dist = float(s0["mw"][i0]), float(s0["dist_km"][i0])
        scenario = int(s0["scenario"][i0]) if "scenario" in s0 else index
    else:
        mw = dist = math.nan
        scenario = index
    return ScenarioStats(
        scenario=scenario, mw=mw, dist_km=dist, label=label, n_rows_differing=n_diff,
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
    names = tuple(name if isinstance(x, Results) else f"{name} ({x})" for name, x in zip("AB", (a, b)))
    sa, sb = ra.samples, rb.samples
    keys_a, group_a, kind = _row_keys(sa)
    keys_b, group_b, kind_b = _row_keys(sb)
    if kind != kind_b:
        raise ParameterError(f"{names[0]} holds the rows of a {kind} file and {names[1]} those of a {kind_b} file: "
                             f"their rows are keyed differently ({KEY_NAMES[kind]} against {KEY_NAMES[kind_b]}), "
                             "nothing to compare")
    common = sorted(set(keys_a) & set(keys_b))
    if not common and keys_a and keys_b:
        raise _no_common_keys(kind, names, group_a, group_b)
    ia = np.array([keys_a[k] for k in common], dtype=int)
    ib = np.array([keys_b[k] for k in common], dtype=int)
    ignored = IGNORED_FIELDS + (("scenario",) if kind == "synthetic" else ())
    differing, diff_rows = _differing_fields(ra, rb, ia, ib, ignored)
    only_a, only_b = sorted(set(keys_a) - set(keys_b)), sorted(set(keys_b) - set(keys_a))
    cmp = Comparison(n_a=len(keys_a), n_b=len(keys_b), n_common=len(common), only_in_a=only_a, only_in_b=only_b,
                     differing_fields=differing, n_rows_differing=int(diff_rows.sum()), alpha=float(alpha),
                     key_names=KEY_NAMES[kind])
    if kind == "synthetic" and "scenario" in sa and "scenario" in sb and len(common):
        cmp.renumbered = int(np.count_nonzero(np.asarray(sa["scenario"])[ia] != np.asarray(sb["scenario"])[ib]))
    in_common = set(group_a[i] for i in ia)
    cmp.groups_only = tuple([_group_label(kind, g) for g in sorted(set(groups) - in_common)]
                            for groups in (group_a, group_b))
    row_group = [group_a[i] for i in ia]
    diff_groups = sorted({row_group[i] for i in np.flatnonzero(diff_rows)})
    stats_list = []
    for gi, g in enumerate(diff_groups):     # every row of the group in each file, its differing rows counted
        ja = np.array([i for i, x in enumerate(group_a) if x == g], dtype=int)
        jb = np.array([i for i, x in enumerate(group_b) if x == g], dtype=int)
        n_diff = sum(1 for i in np.flatnonzero(diff_rows) if row_group[i] == g)
        stats_list.append(_scenario_stats(ra, rb, ja, jb, n_diff, index=gi, label=_group_label(kind, g), kind=kind))
    n_tests = sum(sum(1 for p in (s.p_collapse, s.p_u_top, s.p_u_d) if not math.isnan(p)) for s in stats_list)
    cmp.threshold = float(alpha) / max(n_tests, 1)
    for s in stats_list:
        s.agree = all(math.isnan(p) or p >= cmp.threshold for p in (s.p_collapse, s.p_u_top, s.p_u_d))
    cmp.scenarios = stats_list
    return cmp


def _differing_fields(ra, rb, ia, ib, ignored) -> tuple[dict, np.ndarray]:
    """{field: number of matched rows whose bits differ} and the mask of matched rows differing anywhere."""
    sa, sb = ra.samples, rb.samples
    n = len(ia)
    diff_rows = np.zeros(n, dtype=bool)
    differing = {}
    columns = [(f, sa[f], sb.get(f)) for f in sa if f not in ignored]
    columns += [(f, None, sb[f]) for f in sb if f not in ignored and f not in sa]
    columns += [(f"spectra/{f}", ra.spectra.get(f), rb.spectra.get(f))
                for f in sorted(set(ra.spectra) | set(rb.spectra))]
    for name, ca, cb in columns:
        if ca is None or cb is None:        # a field only one file has: every row differs in it, unless
            # it is NaN in every row (an EDP newer than the other file's code that does not exist in these
            # runs: the dowels' of a column without dowels): absent and NaN say the same
            only = np.asarray(cb if ca is None else ca)
            neq = np.ones(n, dtype=bool)
            if only.dtype.kind == "f" and np.isnan(only).all():
                neq[:] = False
        else:
            neq = ~_same_bits(np.asarray(ca)[ia], np.asarray(cb)[ib]) if n else np.zeros(0, bool)
        if neq.any():
            differing[name] = int(neq.sum())
            diff_rows |= neq
    return differing, diff_rows


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
