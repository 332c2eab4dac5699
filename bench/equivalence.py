#!/usr/bin/env python3
"""Did the model move? Two versions of the solver, paired on the same inputs (never a test).

A change meant to alter results only at round-off or linearisation level (sleeping joints, sums in a
tree order) cannot be checked bit for bit: after the first impact a rocking column is chaotic, so each
run's answer moves. What must not move is what the project reports -- ensemble means and exceedance
probabilities -- beyond their sampling error. This bench runs an OLD and a NEW version on the same
inputs and compares them input by input (paired), on

* the work-precision ensembles of bench/contact_convergence.py (``ensembles``: ``pert``, one near-fault
  pulse with its input x (1 +- 1e-6...1e-4); ``rec``, near-fault records; ``strong``, records strong
  enough to collapse the column some of the time, standing in for the FEMA P695 set, which is not
  installed here), and
* ``grid``: rows of the default grid (``pycolfrag grid`` with no options: its 35 scenarios, samples
  0..GRID-1 of each, the same records as the full grid's rows).

A version is a tree (a directory, built in place when its build is missing or stale) or a git revision
of this checkout (exported with ``git archive`` to a temporary folder and built there), and a set of
``simulate`` keywords (``--old-options`` / ``--new-options KEY=VALUE``, values read as JSON where they
parse, as ``pycolfrag grid --solver``). Each version runs in its own Python process with ``PYTHONPATH``
at its tree (as bench/grid_batch.py runs a baseline), on inputs made once by this tree.

Per ensemble it prints n; the ensemble means of u_top and u_d (runs that stand) of each version; their
paired mean difference new - old over the inputs where both stand, with its standard error (sd of the
differences / sqrt(n)) and diff / SE; the exceedance probability of each level of Tables III/IV
(pycolfrag.damage.PERFORMANCE_LEVELS: Eq. (1)'s event, a collapse exceeds every level) and of collapse,
old and new, with the paired difference's SE (McNemar's: from the discordant pairs,
sqrt(b + c - (b - c)^2 / n) / n); and the energy balance error (``Response.energy_error``, relative to
the run's energy scale) mean and max of each, its paired difference tested one-sided (only a worse
balance fails). Verdict: "equivalent" when every |diff| <= 2 SE (energy: diff <= 2 SE) and no version
fails runs the other does not; else the rows that fail. At 2 SE about 4.6 % of the tests of an unchanged
model fail by chance alone: the count expected is printed beside the verdict.

    nice -n 10 .venv/bin/python bench/equivalence.py --new-options sleep=true         # one tree, two settings
    nice -n 10 .venv/bin/python bench/equivalence.py --old main                       # main against this tree
    nice -n 10 .venv/bin/python bench/equivalence.py --old /tmp/base --new /tmp/new --sizes 100 60 60 4
    nice -n 10 .venv/bin/python bench/equivalence.py --quick --new-options dt_factor=0.5

On the full grid, the same question is ``pycolfrag compare OLD.h5 NEW.h5`` (per scenario, Fisher's and
Welch's tests; docs/work_precision.md, "Sleeping joints: the model did not move").

Writes bench/results/equivalence/NAME.json and NAME.md (the markdown table; unless --no-write).
"""
from __future__ import annotations

import argparse
import datetime
import json
import math
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
HERE = ROOT / "bench"
OUT = HERE / "results" / "equivalence"
Z = 2.0                       # a difference beyond Z standard errors fails
ENSEMBLES = ("pert", "rec", "strong", "grid")
DEFAULT_SIZES = (60, 40, 40, 2)       # pert, rec, strong inputs; grid samples per scenario (x 35)
QUICK_SIZES = (6, 4, 4, 1)
P_BEYOND = math.erfc(Z / math.sqrt(2))   # two-sided chance of |N(0,1)| > Z: 0.0455
# A mean's difference beyond Z SE but at most this fraction of the old mean is round-off, not a moved model:
# where the inputs barely differ and the EDP comes before the chaos (the pert ensemble's u_top: its peak is
# the pulse's first rocking), the pairs are nearly deterministic and a 1e-10 shift is many SE. 1e-6 is four
# orders below the step's own bias at the default dt_factor (docs/accuracy.md: 0.1-1 %).
ROUNDOFF = 1e-6


# --------------------------------------------------------------------------- paired statistics

def _z(diff: float, se: float) -> float:
    if se > 0:
        return diff / se
    return 0.0 if diff == 0 else math.copysign(math.inf, diff)


def paired_mean(old, new) -> dict:
    """Paired difference of two samples, input by input: n, both means, diff = mean(new - old), its
    standard error sd(new - old, ddof 1) / sqrt(n) and diff / SE (NaN SE below 2 pairs)."""
    old, new = np.asarray(old, float), np.asarray(new, float)
    if old.shape != new.shape:
        raise ValueError(f"paired samples differ in length: {old.size} and {new.size}")
    d = new - old
    n = d.size
    diff = float(d.mean()) if n else math.nan
    se = float(d.std(ddof=1) / math.sqrt(n)) if n > 1 else math.nan
    return {"n": n, "old": float(old.mean()) if n else math.nan, "new": float(new.mean()) if n else math.nan,
            "diff": diff, "se": se, "z": _z(diff, se) if n > 1 else math.nan}


def paired_proportion(old, new) -> dict:
    """Paired difference of two proportions (McNemar): b = old only, c = new only; diff = (c - b) / n,
    SE = sqrt(b + c - (c - b)^2 / n) / n (the sd of the differences over sqrt(n)); no discordant pair: 0."""
    old, new = np.asarray(old, bool), np.asarray(new, bool)
    if old.shape != new.shape:
        raise ValueError(f"paired samples differ in length: {old.size} and {new.size}")
    n = old.size
    b, c = int(np.sum(old & ~new)), int(np.sum(new & ~old))
    diff = (c - b) / n if n else math.nan
    se = math.sqrt(max(b + c - (c - b) ** 2 / n, 0.0)) / n if n else math.nan
    return {"n": n, "old": float(old.mean()) if n else math.nan, "new": float(new.mean()) if n else math.nan,
            "diff": diff, "se": se, "z": _z(diff, se) if n else math.nan, "old_only": b, "new_only": c,
            "p_exact": mcnemar_exact(b, c)}


def mcnemar_exact(b: int, c: int) -> float:
    """Two-sided exact McNemar p-value: of b + c discordant pairs, as few as min(b, c) on one side under
    Binomial(b + c, 1/2). Beside the 2 SE rule where the discordant pairs are few (the normal
    approximation is then liberal: 0 / 4 is 2.02 SE, exact p 0.125)."""
    m = b + c
    if m == 0:
        return 1.0
    return min(1.0, 2 * sum(math.comb(m, i) for i in range(min(b, c) + 1)) / 2 ** m)


def within(row: dict, one_sided: bool = False) -> bool:
    """Whether a row's difference is within Z standard errors (one-sided: only an increase fails). A row
    without an SE (fewer than 2 pairs) passes only with no difference."""
    diff, se = row["diff"], row["se"]
    if not math.isfinite(diff):
        return True                       # nothing paired: nothing to compare (n says so)
    if not math.isfinite(se):
        return diff == 0
    return diff <= Z * se if one_sided else abs(diff) <= Z * se


def _levels():
    from pycolfrag.damage import PERFORMANCE_LEVELS, exceedance_score
    return PERFORMANCE_LEVELS, exceedance_score


def compare_runs(old: list, new: list) -> dict:
    """One ensemble's rows of the table from the runs of the two versions (dicts with ``u_top``, ``u_d``,
    ``collapsed``, ``energy_error``, ``failed``, ``cpu_s``, in input order): {rows, failing, ...}."""
    if len(old) != len(new):
        raise ValueError(f"the versions ran {len(old)} and {len(new)} inputs")
    levels, score = _levels()
    ok = [not (a["failed"] or b["failed"]) for a, b in zip(old, new)]
    A = [a for a, k in zip(old, ok) if k]
    B = [b for b, k in zip(new, ok) if k]
    rows = []
    for key in ("u_top", "u_d"):
        both = [(a[key], b[key]) for a, b in zip(A, B) if not (a["collapsed"] or b["collapsed"])]
        r = paired_mean([x for x, _ in both], [y for _, y in both])
        r["old"] = _mean([a[key] for a in A if not a["collapsed"]])    # each version's own ensemble mean
        r["new"] = _mean([b[key] for b in B if not b["collapsed"]])
        rows.append({"quantity": f"mean {key}", **r})
    col_a = np.array([a["collapsed"] for a in A], bool)
    col_b = np.array([b["collapsed"] for b in B], bool)
    for lev in levels:
        ea = score(np.array([a[lev.edp] for a in A], float), col_a) >= lev.threshold
        eb = score(np.array([b[lev.edp] for b in B], float), col_b) >= lev.threshold
        rows.append({"quantity": f"P({lev.edp} >= {lev.threshold:g})", **paired_proportion(ea, eb)})
    rows.append({"quantity": "P(collapse)", **paired_proportion(col_a, col_b)})
    e = paired_mean([abs(a["energy_error"]) for a in A], [abs(b["energy_error"]) for b in B])
    rows.append({"quantity": "mean abs(energy error)", "one_sided": True, **e})
    for r in rows:
        r["ok"] = within(r, r.get("one_sided", False))
        r["roundoff"] = bool(not r["ok"] and "old_only" not in r and math.isfinite(r["old"])
                             and abs(r["diff"]) <= ROUNDOFF * abs(r["old"]))
    failed = (sum(a["failed"] for a in old), sum(b["failed"] for b in new))
    failing = [r["quantity"] for r in rows if not (r["ok"] or r["roundoff"])]
    if failed[1] > failed[0]:
        failing.append(f"failed runs {failed[0]} -> {failed[1]}")
    return {"n": len(old), "n_paired": len(A), "failed": failed, "rows": rows, "failing": failing,
            "roundoff": [r["quantity"] for r in rows if r["roundoff"]],
            "max_energy_error": (_max([abs(a["energy_error"]) for a in A]), _max([abs(b["energy_error"]) for b in B])),
            "cpu_s_per_run": (_mean([a["cpu_s"] for a in old]), _mean([b["cpu_s"] for b in new]))}


def _mean(v) -> float:
    return float(np.mean(v)) if len(v) else math.nan


def _max(v) -> float:
    return float(np.max(v)) if len(v) else math.nan


def verdict(ensembles: dict) -> tuple[bool, list, float, list]:
    """(every ensemble equivalent, the failing rows as "ensemble: quantity", tests expected to fail by
    chance at Z for an unchanged model, the rows beyond Z SE at round-off level (:data:`ROUNDOFF`): these
    do not fail)."""
    failing = [f"{e}: {q}" for e, d in ensembles.items() for q in d["failing"]]
    roundoff = [f"{e}: {q}" for e, d in ensembles.items() for q in d["roundoff"]]
    n_tests = sum(len(d["rows"]) for d in ensembles.values())
    return not failing, failing, n_tests * P_BEYOND, roundoff


# --------------------------------------------------------------------------- inputs

def grid_inputs(samples_per_scenario: int, first: int = 0) -> list:
    """Rows of the default grid (its 35 scenarios, samples first..first+k-1 of each): (acc, dt, label) as the
    grid makes them (the grid's seeds, its Latin hypercube of 100 samples, its record). Another ``first``
    gives rows independent of these: a flagged row is checked again on fresh inputs."""
    import pycolfrag as pcf
    from pycolfrag.grid.rows import SampleContext
    from pycolfrag.grid.spec import GridSpec
    from pycolfrag.solver.sample import _synthetic_record  # the grid's own record of a row (its probe's)
    spec = GridSpec(column=pcf.Column.parthenon().to_dict())
    ctx = SampleContext(spec)
    out = []
    for sc in range(len(spec.scenarios)):
        for k in range(first, min(first + samples_per_scenario, spec.samples)):
            _, _, mw, dist = ctx.locate(sc * spec.samples + k)
            row, acc, dt = _synthetic_record(mw, dist, ctx.hf_seed(sc, k), ctx.pulse(sc, k), spec.record_dt_s,
                                             spec.vp_scale, spec.max_record_s)
            if acc is None:
                raise SystemExit(f"the default grid's row {sc * spec.samples + k} has no record: {row['message']}")
            out.append((np.asarray(acc, float), float(dt), f"Mw{mw:g} R{dist:g} sample {k}"))
    return out


def make_inputs(sizes, grid_first: int = 0, seed_offset: int = 0) -> dict:
    """name -> [(acc m/s^2, dt s, label)] of every ensemble (an ensemble of size 0 left out)."""
    sys.path.insert(0, str(HERE))
    from contact_convergence import ensembles  # the work-precision ensembles, one text
    out = ensembles(*sizes[:3], seed_offset=seed_offset)
    out["grid"] = grid_inputs(sizes[3], grid_first)
    return {e: v for e, v in out.items() if v}


# --------------------------------------------------------------------------- versions

def _git(*args, cwd=ROOT) -> str:
    return subprocess.run(["git", *args], cwd=cwd, capture_output=True, text=True, check=True).stdout.strip()


def _stale(tree: Path) -> bool:
    """Whether the tree's extension is missing (an editable install elsewhere would then lend its own:
    the library loaded must be the tree's) or was built from other sources than those on disk."""
    code = ("import sys, pathlib, pycolfrag._libcolfrag as m\n"
            "assert pathlib.Path(m.__file__).resolve().parent == pathlib.Path(sys.argv[1], 'pycolfrag').resolve()\n"
            "from pycolfrag.core.ffi import ffi, lib\nfrom pycolfrag.core import source_digest as s\n"
            "b = ffi.string(lib.cf_common_source_digest()).decode()\n"
            "sys.exit(0 if b == s.UNSIGNED or b == s.source_digest(sys.argv[1]) else 1)")
    env = dict(os.environ, PYTHONPATH=str(tree))
    return subprocess.run([sys.executable, "-c", code, str(tree)], env=env, cwd=tree, capture_output=True).returncode != 0


def prepare(version: str | None, work: Path) -> dict:
    """A version's tree, built: this tree (None), a directory, or a git revision of this checkout
    (exported to ``work``). {tree, commit}."""
    if version is None or Path(version).is_dir():
        tree = ROOT if version is None else Path(version).resolve()
        try:
            commit = _git("rev-parse", "--short", "HEAD", cwd=tree)
            commit += "+changes" if _git("status", "--porcelain", "--untracked-files=no", cwd=tree) else ""
        except (OSError, subprocess.CalledProcessError):
            commit = "unknown"
    else:
        commit = _git("rev-parse", "--short", version)
        tree = work / f"tree_{commit}"
        if not tree.is_dir():
            tree.mkdir(parents=True)
            archive = subprocess.run(["git", "archive", commit], cwd=ROOT, capture_output=True, check=True).stdout
            subprocess.run(["tar", "-x", "-C", str(tree)], input=archive, check=True)
    if _stale(tree):
        print(f"building {tree} (build_ext --inplace) ...", flush=True)
        with open(tree / "equivalence_build.log", "w") as log:
            subprocess.run([sys.executable, "setup.py", "build_ext", "--inplace"], cwd=tree, stdout=log,
                           stderr=subprocess.STDOUT, check=True)
    return {"tree": str(tree), "commit": commit}


def run_version(tree: str, options: dict, inputs: Path, out: Path, procs: int) -> list:
    """Every input on one version, in its own process (PYTHONPATH at its tree): its runs in input order."""
    env = dict(os.environ, PYTHONPATH=tree, OMP_NUM_THREADS="1", OPENBLAS_NUM_THREADS="1")
    cmd = [sys.executable, str(Path(__file__).resolve()), "--worker", str(inputs), str(out),
           "--options", json.dumps(options), "--procs", str(procs)]
    p = subprocess.run(cmd, env=env, cwd=tree, capture_output=True, text=True)
    if p.returncode != 0:
        raise SystemExit(f"the version in {tree} failed ({p.returncode}):\n{p.stdout}\n{p.stderr}")
    with open(out, encoding="utf-8") as fh:
        got = json.load(fh)
    if Path(got["library"]).resolve().parent != (Path(tree) / "pycolfrag").resolve():
        raise SystemExit(f"the version in {tree} loaded another tree's library: {got['library']}")
    return got


# --------------------------------------------------------------------------- the worker (the version's own pycolfrag)

_W: dict = {}


def _one(job):
    """One run of the worker: its EDPs, energy error and CPU seconds (a raising run: ``failed``)."""
    import warnings

    import pycolfrag as pcf
    i, acc, dt = job
    if "col" not in _W:
        _W["col"] = pcf.Column.parthenon()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        c0 = time.process_time()
        try:
            r = pcf.simulate(_W["col"], acc, dt, **_W["options"])
        except Exception as exc:  # noqa: BLE001 (a failing run is counted, not fatal: the other version may not fail)
            return {"index": i, "failed": True, "message": f"{type(exc).__name__}: {exc}", "u_top": math.nan,
                    "u_d": math.nan, "collapsed": False, "energy_error": math.nan, "n_steps": 0,
                    "cpu_s": time.process_time() - c0}
    return {"index": i, "failed": False, "message": "", "u_top": float(r.u_top), "u_d": float(r.u_d),
            "collapsed": bool(r.collapsed), "energy_error": float(r.energy_error), "n_steps": int(r.n_steps),
            "cpu_s": time.process_time() - c0}


def _init(options):
    _W["options"] = options


def worker(inputs: str, out: str, options: dict, procs: int) -> int:
    from multiprocessing import Pool

    import pycolfrag._libcolfrag as lib

    import pycolfrag as pcf
    try:   # an option this version lacks, or a bad value, before any run
        opts = pcf.SolverOptions(**options).to_dict() if hasattr(pcf, "SolverOptions") else options
    except (TypeError, ValueError) as exc:
        raise SystemExit(f"bad options {options} for this version: {exc}") from None
    z = np.load(inputs)
    dts = z["dt"]
    jobs = sorted(((i, z[f"acc{i}"], float(dts[i])) for i in range(dts.size)), key=lambda j: -j[1].size)
    with Pool(procs, initializer=_init, initargs=(options,)) as pool:
        runs = list(pool.imap_unordered(_one, jobs, chunksize=1))
    with open(out, "w", encoding="utf-8") as fh:
        json.dump({"runs": sorted(runs, key=lambda r: r["index"]), "options": opts,
                   "version": getattr(pcf, "__version__", "?"), "library": lib.__file__}, fh)
    return 0


# --------------------------------------------------------------------------- the table

def _fmt(quantity: str, v: float) -> str:
    if not math.isfinite(v):
        return "n/a"
    return f"{v:.3f}" if quantity.startswith("P(") else f"{v:.3e}" if "energy" in quantity else f"{v:.4f}"


def _given(side: dict) -> str:
    kw = ", ".join(f"{k}={v!r}" for k, v in side["keywords"].items()) or "defaults"
    return f"`{side['commit']}` ({kw})"


def table(res: dict) -> str:
    """The markdown of a result: its header, the verdict, a summary per ensemble and every row."""
    v = res["verdict"]
    ok, failing, expected, roundoff = v["equivalent"], v["failing"], v["expected_by_chance"], v["roundoff"]
    word = "NOT equivalent" if not ok else "equivalent up to round-off" if roundoff else "equivalent"
    why = (f": beyond {Z:g} SE: " + "; ".join(failing) if failing else "") + \
        (f"; beyond {Z:g} SE at round-off level (|diff| <= {ROUNDOFF:g} of the mean): " + "; ".join(roundoff)
         if roundoff else "")
    how = f"{res['procs']} processes per version, niced, on a shared machine" if res["procs"] else "from results files"
    lines = [f"CPU: {res['cpu']}; {res['date']}; {how}; total CPU {res['cpu_total_s']:.0f} s.",
             f"Old: {_given(res['old'])}; new: {_given(res['new'])}; {res['inputs']}.", "",
             f"**Verdict: {word}** (equivalent: every paired |new - old| <= {Z:g} SE, the energy error one-sided, "
             f"or a mean's |diff| <= {ROUNDOFF:g} of it){why}. "
             f"Tests made {res['verdict']['n_tests']}; expected beyond {Z:g} SE by chance alone for an unchanged "
             f"model: {expected:.1f}.", "",
             "| ensemble | inputs | paired | failed old / new | max abs(energy error) old / new | CPU s/run old / new | verdict |",
             "|---|---|---|---|---|---|---|"]
    for e, d in res["ensembles"].items():
        me, cpu = d["max_energy_error"], d["cpu_s_per_run"]
        lines.append(f"| {e} | {d['n']} | {d['n_paired']} | {d['failed'][0]} / {d['failed'][1]} | "
                     f"{_fmt('energy', me[0])} / {_fmt('energy', me[1])} | {cpu[0]:.3f} / {cpu[1]:.3f} | "
                     f"{_ens_word(d)} |")
    lines += ["", "Means over the runs that stand (each version its own); the difference paired over the inputs "
              "where both stand (n), SE = sd of the differences / sqrt(n); probabilities over every input, the "
              "paired SE McNemar's (discordant pairs old-only / new-only, and the exact McNemar p, which says more "
              "than the 2 SE rule where they are few); energy: |energy_error| of every run, tested one-sided.", "",
              "| ensemble | quantity | n | old | new | new - old ± SE | diff / SE | within 2 SE |",
              "|---|---|---|---|---|---|---|---|"]
    for e, d in res["ensembles"].items():
        for r in d["rows"]:
            q = r["quantity"]
            disc = f" ({r['old_only']} / {r['new_only']}, exact p {r['p_exact']:.2g})" if "old_only" in r else ""
            diff = "n/a" if not math.isfinite(r["diff"]) else \
                f"{r['diff']:+.4g} ± {r['se']:.4g}" if math.isfinite(r["se"]) else f"{r['diff']:+.4g}"
            lines.append(f"| {e} | {q} | {r['n']} | {_fmt(q, r['old'])} | {_fmt(q, r['new'])} | {diff}{disc} | "
                         f"{r['z']:+.2f} | {_row_word(r)} |")
    return "\n".join(lines) + "\n"


def _ens_word(d: dict) -> str:
    if d["failing"]:
        return f"beyond {Z:g} SE: " + ", ".join(d["failing"])
    return "equivalent" + (" (round-off: " + ", ".join(d["roundoff"]) + ")" if d["roundoff"] else "")


def _row_word(r: dict) -> str:
    if r["ok"]:
        return "yes"
    if r["roundoff"]:
        return f"round-off ({abs(r['diff']) / abs(r['old']):.1e} of the mean)"
    return "**no**"


# --------------------------------------------------------------------------- main

def _cpu() -> str:
    from pycolfrag.grid.schedule import cpu_model  # here: --help needs nothing but numpy
    return cpu_model()


def _keywords(items) -> dict:
    from pycolfrag.risk.simulate import solver_options_of  # the one --solver KEY=VALUE parser
    return solver_options_of(items)


def _parser() -> argparse.ArgumentParser:
    ap = argparse.ArgumentParser(prog="bench/equivalence.py", description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--old", default=None, metavar="TREE|REV", help="old version: a tree or a git revision (default: this tree)")
    ap.add_argument("--new", default=None, metavar="TREE|REV", help="new version: a tree or a git revision (default: this tree)")
    ap.add_argument("--old-options", nargs="*", default=[], metavar="KEY=VALUE", help="simulate() keywords of the old version")
    ap.add_argument("--new-options", nargs="*", default=[], metavar="KEY=VALUE", help="simulate() keywords of the new version")
    ap.add_argument("--sizes", type=int, nargs=4, metavar=("PERT", "REC", "STRONG", "GRID"), default=DEFAULT_SIZES,
                    help="inputs of each ensemble; GRID: samples per scenario of the default grid (default: %(default)s)")
    ap.add_argument("--grid-from", type=int, default=0, metavar="K",
                    help="the grid's rows from sample K of each scenario (default 0): fresh inputs for a second look")
    ap.add_argument("--seed-offset", type=int, default=0, metavar="K",
                    help="other members of the pert, rec and strong ensembles (their seeds + K; default 0, the "
                         "work-precision ensembles themselves): fresh inputs for a second look")
    ap.add_argument("--quick", action="store_true", help=f"sizes {' '.join(map(str, QUICK_SIZES))} (a smoke run)")
    ap.add_argument("--procs", type=int, default=2, help="processes per version (default 2)")
    ap.add_argument("--name", default=None, help="name of the files written (default: equivalence[_quick])")
    ap.add_argument("--work", type=Path, default=None, help="folder of exported trees and inputs (default: a temporary one)")
    ap.add_argument("--no-write", action="store_true", help="print only")
    ap.add_argument("--files", nargs=2, metavar=("OLD.h5", "NEW.h5"),
                    help="no runs: the same table from two synthetic grid results files, rows paired by (Mw, R, sample)")
    ap.add_argument("--worker", nargs=2, metavar=("INPUTS", "OUT"), help=argparse.SUPPRESS)
    ap.add_argument("--options", default="{}", help=argparse.SUPPRESS)
    return ap


def main(argv=None) -> int:
    a = _parser().parse_args(argv)
    if a.worker:
        return worker(a.worker[0], a.worker[1], json.loads(a.options), a.procs)
    sys.path.insert(0, str(ROOT))
    if a.files:
        return compare_files(a.files[0], a.files[1], None if a.no_write else a.name or "equivalence_files")
    sizes = QUICK_SIZES if a.quick else tuple(a.sizes)
    work = a.work or Path(tempfile.mkdtemp(prefix="equivalence_"))
    work.mkdir(parents=True, exist_ok=True)
    sides = {"old": {**prepare(a.old, work), "keywords": _keywords(a.old_options)},
             "new": {**prepare(a.new, work), "keywords": _keywords(a.new_options)}}
    inputs = make_inputs(sizes, a.grid_from, a.seed_offset)
    flat = [(e, i, x) for e in ENSEMBLES for i, x in enumerate(inputs.get(e, ()))]
    path = work / "inputs.npz"
    np.savez(path, dt=np.array([x[1] for _, _, x in flat]), **{f"acc{k}": x[0] for k, (_, _, x) in enumerate(flat)})
    w0 = time.perf_counter()
    runs = {}
    for s, side in sides.items():
        print(f"running {s}: {side['tree']} {side['keywords']} on {len(flat)} inputs ...", flush=True)
        got = run_version(side["tree"], side["keywords"], path, work / f"{s}.json", a.procs)
        runs[s] = got["runs"]
        side.update(options=got["options"], version=got["version"], library=got["library"])
    for r in (*runs["old"], *runs["new"]):
        e, i, x = flat[r["index"]]
        r.update(ensemble=e, label=x[2])
    ens = {e: compare_runs([r for r in runs["old"] if r["ensemble"] == e], [r for r in runs["new"] if r["ensemble"] == e])
           for e in ENSEMBLES if e in inputs}
    res = {**_result(sides, ens, runs, a.procs), "sizes": dict(zip(ENSEMBLES, sizes)),
           "inputs": _inputs_text(sizes, a.grid_from, a.seed_offset),
           "wall_s": time.perf_counter() - w0}
    return _report(res, None if a.no_write else a.name or ("equivalence_quick" if a.quick else "equivalence"))


def _inputs_text(sizes, grid_from: int, seed_offset: int) -> str:
    parts = [f"{e} {k}" for e, k in zip(ENSEMBLES[:3], sizes[:3]) if k]
    if parts and seed_offset:
        parts[-1] += f" (their seeds + {seed_offset})"
    if sizes[3]:
        parts.append(f"grid {35 * sizes[3]} (35 scenarios x samples {grid_from}-{grid_from + sizes[3] - 1})")
    return "default column (`Column.parthenon()`), inputs: " + ", ".join(parts)


def _result(sides: dict, ens: dict, runs: dict, procs: int) -> dict:
    ok, failing, expected, roundoff = verdict(ens)
    return {"cpu": _cpu(), "date": datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d %H:%M UTC"),
            "procs": procs, "old": sides["old"], "new": sides["new"], "z": Z,
            "verdict": {"equivalent": ok, "failing": failing, "expected_by_chance": expected, "roundoff": roundoff,
                        "n_tests": sum(len(d["rows"]) for d in ens.values())},
            "ensembles": ens, "cpu_total_s": sum(r["cpu_s"] for r in (*runs["old"], *runs["new"])), "runs": runs}


def _report(res: dict, name: str | None) -> int:
    """Print the table; write NAME.json and NAME.md (name None: print only). Exit status 0 equivalent, else 1."""
    text = table(res)
    print(text)
    if name is not None:
        OUT.mkdir(parents=True, exist_ok=True)
        with open(OUT / f"{name}.json", "w", encoding="utf-8") as fh:
            json.dump(res, fh, separators=(",", ":"))   # compact: every run is in it
        (OUT / f"{name}.md").write_text(text, encoding="utf-8")
        print(f"wrote {OUT / name}.json and .md")
    return 0 if res["verdict"]["equivalent"] else 1


def _file_runs(path: str) -> dict:
    """A synthetic grid's results file as runs keyed by (Mw, R, sample) in thousandths (the grid's row key)."""
    from pycolfrag.analysis.data import load
    s = load(path).samples
    out = {}
    for i in range(len(s["u_top"])):
        key = (round(float(s["mw"][i]) * 1000), round(float(s["dist_km"][i]) * 1000), int(s["sample"][i]))
        out[key] = {"u_top": float(s["u_top"][i]), "u_d": float(s["u_d"][i]), "collapsed": bool(s["collapsed"][i]),
                    "energy_error": float(s["energy_error"][i]), "failed": int(s["status"][i]) != 0,
                    "cpu_s": float(s["wall_s"][i])}
    return out


def _solver_of(path: str) -> dict:
    """The solver options a grid results file was run with (its signature's)."""
    from pycolfrag.analysis.data import load
    return json.loads(load(path).attrs["grid_signature"]).get("solver", {})


def compare_files(old: str, new: str, name: str | None) -> int:
    """The same table from two synthetic grid results files, rows paired by their key (``--files``)."""
    A, B = _file_runs(old), _file_runs(new)
    keys = sorted(set(A) & set(B))
    if not keys:
        raise SystemExit(f"{old} and {new} have no row in common")
    ens = {"grid file": compare_runs([A[k] for k in keys], [B[k] for k in keys])}
    runs = {"old": [A[k] for k in keys], "new": [B[k] for k in keys]}
    sa, sb = _solver_of(old), _solver_of(new)
    differ = {k for k in set(sa) | set(sb) if sa.get(k) != sb.get(k)}
    sides = {s: {"commit": p, "keywords": {k: o.get(k) for k in sorted(differ)}, "tree": p}
             for s, p, o in (("old", old, sa), ("new", new, sb))}
    res = {**_result(sides, ens, runs, 0), "inputs": f"{len(keys)} rows in both files ({len(A)} and {len(B)} in each); "
           "CPU s/run: the rows' wall_s", "wall_s": 0.0}
    return _report(res, name)


if __name__ == "__main__":
    sys.exit(main())
