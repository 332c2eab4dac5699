"""Work-precision benchmark of the solver's fidelity options (results in docs/accuracy.md).

After the first impact a rocking column is chaotic, so the error of one setting is measured as
(a) the deterministic error before the first impact against a much finer step, with its order;
(b) the bias of ensemble means of u_top and u_d (perturbed-input ensemble and a set of near-fault
records) against a reference setting, with standard errors so bias is told from noise;
(c) collapse probability and exceedance of the Table III/IV levels against the reference;
plus wall time and microseconds per step.

    nice .venv/bin/python bench/work_precision.py            # default (~5-8 CPU-minutes)
    nice .venv/bin/python bench/work_precision.py --quick    # smoke run (~1 CPU-minute)
    nice .venv/bin/python bench/work_precision.py --full     # larger ensembles

Writes docs/work_precision.md and docs/work_precision.png (unless --no-write).
"""
from __future__ import annotations

import argparse
import math
import os
import sys
import time
import warnings
from multiprocessing import Pool

import numpy as np

import pycolfrag as pcf
from pycolfrag.analysis.fragility import PERFORMANCE_LEVELS

G = 9.81
HERE = os.path.dirname(os.path.abspath(__file__))
DOCS = os.path.join(HERE, "..", "docs")
#: docs/work_precision.md from this line on is kept when the table above it is written again
KEEP_MARK = "<!-- kept by bench/work_precision.py: the sections below are written by hand or by other benches -->"

# name, simulate() keywords, column overrides, the reference the row is compared with
REF_V = "vertex dt0.25"
REF_X = "exact dt0.25"
SETTINGS = [
    (REF_X, dict(contact="exact", dt_factor=0.25), {}, REF_X),
    (REF_V, dict(contact="vertex", dt_factor=0.25), {}, REF_X),
    ("vertex dt0.5", dict(contact="vertex", dt_factor=0.5), {}, REF_V),
    ("vertex dt0.8", dict(contact="vertex", dt_factor=0.8), {}, REF_V),
    ("vertex dt0.9", dict(contact="vertex", dt_factor=0.9), {}, REF_V),
    ("vertex dt1.0", dict(contact="vertex", dt_factor=1.0), {}, REF_V),
    ("perimeter2 dt0.8", dict(contact="perimeter", points_per_edge=2, dt_factor=0.8), {}, REF_X),
    ("perimeter4 dt0.8", dict(contact="perimeter", points_per_edge=4, dt_factor=0.8), {}, REF_X),
    ("exact dt0.5", dict(contact="exact", dt_factor=0.5), {}, REF_X),
    ("exact dt0.8", dict(contact="exact", dt_factor=0.8), {}, REF_X),
    ("exact dt1.0", dict(contact="exact", dt_factor=1.0), {}, REF_X),
    ("vertex dt0.8 planar", dict(contact="vertex", dt_factor=0.8, planar=True), {}, REF_V),
    ("vertex dt0.8 20-gon", dict(contact="vertex", dt_factor=0.8), {"n_sides": 20}, REF_V),
    ("vertex dt0.8 monolithic", dict(contact="vertex", dt_factor=0.8, monolithic=True), {}, REF_V),
]


def mp_pulse(t, Ap, fp, gamma, nu, t0):
    """Mavroeidis & Papageorgiou (2003) velocity-pulse acceleration (m/s^2), peak ~ Ap."""
    x = t - t0
    env = np.where(np.abs(x) <= gamma / (2 * fp), 0.5 * (1 + np.cos(2 * np.pi * fp * x / gamma)), 0.0)
    return Ap * env * np.cos(2 * np.pi * fp * x + nu)


def records(n, seed=6):
    """n near-fault records spanning the grid: pulse period 0.5-2.5 s, pulse amplitude 0.15-0.5 g,
    plus band-limited noise. Uses pcf.ground_motion.synthesize when it exists."""
    gm = pcf.ground_motion
    out = []
    rng = np.random.default_rng(seed)
    if hasattr(gm, "synthesize"):
        mws = np.linspace(5.5, 7.0, n)
        for i, mw in enumerate(mws):
            rec = gm.synthesize(float(mw), float(5 + 15 * (i % 3)), seed + i)
            out.append((np.asarray(rec.acc, float), float(rec.dt), f"Mw{mw:.1f}"))
        return out
    dt = 0.005
    u = (np.arange(n) + rng.random(n)) / n
    for i in range(n):
        Tp = 0.5 + 2.0 * u[i]
        Ap = G * (0.15 + 0.35 * rng.permutation(u)[i])
        t = np.arange(0, 8 + 2 * Tp, dt)
        acc = mp_pulse(t, Ap, 1 / Tp, 1.5 + 1.5 * rng.random(), 2 * np.pi * rng.random(), 3 + Tp)
        noise = np.convolve(rng.normal(size=t.size), np.ones(8) / 8, "same")
        acc += 0.05 * G * noise * np.exp(-((t - 3 - Tp) / 3) ** 2)
        out.append((acc, dt, f"Tp{Tp:.2f} Ap{Ap / G:.2f}g"))
    return out


_COLS = {}


def _col(over):
    key = tuple(sorted(over.items()))
    if key not in _COLS:
        _COLS[key] = pcf.Column.parthenon(**over)
    return _COLS[key]


def run_one(job):
    """One simulate() call: returns (setting name, group, u_top, u_d, collapsed, n_steps, wall s, nan)."""
    name, kw, over, group, acc, dt = job
    group, idx = group if isinstance(group, tuple) else (group, -1)
    col = _col(over)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        t0 = time.perf_counter()
        try:
            r = pcf.simulate(col, acc, dt, **kw)
        except pcf.errors.SolverError if hasattr(pcf, "errors") else Exception as e:  # noqa: B030 (a conditional class: older trees lack pycolfrag.core.errors)
            return (name, group, math.nan, math.nan, True, 0, time.perf_counter() - t0, str(e), idx)
        wall = time.perf_counter() - t0
    # u_d is NaN by definition after a collapse (no residual): only a standing run's NaN is bad
    bad = "" if (math.isfinite(r.u_top) and (r.collapsed or math.isfinite(r.u_d))) else "NaN"
    return (name, group, r.u_top, r.u_d, bool(r.collapsed), r.n_steps, wall, bad, idx)


def deterministic_error(settings_names=("vertex", "exact")):
    """(a) top displacement over the pre-impact window of a 0.25 g, 2 Hz sine (uplift starts at
    ~0.15 g, first impact after ~0.45 s): max error against dt_factor 0.05, and its order."""
    col = pcf.Column.parthenon()
    dt = 0.001
    t = np.arange(0, 0.6, dt)
    acc = 0.25 * G * np.sin(2 * np.pi * 2.0 * t)
    T_pre = 0.40
    out = {}
    for contact in settings_names:
        def top(f):
            r = pcf.simulate(col, acc, dt, history=True, history_dt=0.005, contact=contact, dt_factor=f,  # noqa: B023 (top runs only within this contact's iteration)
                             tail_s=0.0, early_exit=False)
            h = r.history
            m = h.t <= T_pre + 1e-12
            return h.t[m], h.top_disp[m, 0]
        tr, ur = top(0.05)
        errs = {}
        for f in (0.25, 0.5, 1.0):
            tf, uf = top(f)
            n = min(len(ur), len(uf))
            errs[f] = float(np.max(np.abs(uf[:n] - ur[:n])))
        order = math.log(errs[1.0] / errs[0.25]) / math.log(4.0) if errs[0.25] > 0 else math.nan
        out[contact] = (errs, order, float(np.max(np.abs(ur))))
    return out


def stats(rows):
    ut = np.array([r[2] for r in rows], float)
    ud = np.array([r[3] for r in rows], float)
    col = np.array([r[4] for r in rows], bool)
    ok = np.isfinite(ut) & ~col  # EDPs of surviving runs
    n = len(rows)
    d = {"n": n, "p_col": col.mean(), "se_p_col": math.sqrt(max(col.mean() * (1 - col.mean()), 1e-12) / n)}
    for key, v in (("u_top", ut[ok]), ("u_d", ud[ok])):
        d[key] = v.mean() if v.size else math.nan
        d["se_" + key] = v.std(ddof=1) / math.sqrt(v.size) if v.size > 1 else math.nan
        d[key + "_q"] = np.quantile(v, [0.16, 0.5, 0.84]) if v.size else [math.nan] * 3
    # exceedance of the Table III/IV levels (collapse counts as exceeding every level)
    for lev in PERFORMANCE_LEVELS:
        v = ut if lev.edp == "u_top" else ud
        e = (col | (np.nan_to_num(v, nan=np.inf) > lev.threshold)).mean()
        d["P " + lev.label] = e
    d["steps"] = sum(r[5] for r in rows)
    d["wall"] = sum(r[6] for r in rows)
    d["nan"] = sum(1 for r in rows if r[7])
    return d


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--full", action="store_true")
    ap.add_argument("--procs", type=int, default=2)
    ap.add_argument("--no-write", action="store_true")
    args = ap.parse_args(argv)
    n_pert, n_rec, n_rec_pert = (100, 12, 10) if args.full else (12, 4, 2) if args.quick else (60, 10, 6)
    settings = SETTINGS if not args.quick else [s for s in SETTINGS if "perimeter4" not in s[0]]

    t_start = time.time()
    det = deterministic_error()

    # (b1) perturbation ensemble: one moderate near-fault pulse, input scaled by 1 + eps
    rng = np.random.default_rng(1)
    dt = 0.005
    t = np.arange(0, 10, dt)
    base = mp_pulse(t, 0.3 * G, 1.0, 2.0, 0.3, 3.0)
    eps = rng.choice([-1, 1], n_pert) * 10 ** rng.uniform(-6, -4, n_pert)
    recs = records(n_rec)
    jobs = []
    for name, kw, over, _ in settings:
        for e in eps:
            jobs.append((name, kw, over, "pert", base * (1 + e), dt))
        for i, (acc, rdt, _lab) in enumerate(recs):
            for j in range(n_rec_pert):
                s = 1 + (1e-5 * (j - (n_rec_pert - 1) / 2) if n_rec_pert > 1 else 0)
                jobs.append((name, kw, over, ("rec", i), acc * s, rdt))
    with Pool(args.procs) as pool:
        res = pool.map(run_one, jobs, chunksize=4)
    S = {}
    for name, _, _, ref in settings:
        S[name] = {g: stats([r for r in res if r[0] == name and r[1] == g]) for g in ("pert", "rec")}
        allr = [r for r in res if r[0] == name]
        S[name]["us_step"] = 1e6 * sum(r[6] for r in allr) / max(sum(r[5] for r in allr), 1)
        S[name]["wall_run"] = sum(r[6] for r in allr) / len(allr)
        S[name]["ref"] = ref
        S[name]["nan"] = sum(1 for r in allr if r[7])
    total = time.time() - t_start

    def bias(name, group, key):
        a, b = S[name][group], S[S[name]["ref"]][group]
        if name == S[name]["ref"]:
            return "ref"
        if group == "rec":  # paired by record: per-record means (over perturbations, survivors only)
            k = 2 if key == "u_top" else 3
            diffs, refs = [], []
            for i in range(n_rec):
                x = [r[k] for r in res if r[0] == name and r[1] == "rec" and r[8] == i and not r[4]]
                y = [r[k] for r in res if r[0] == S[name]["ref"] and r[1] == "rec" and r[8] == i and not r[4]]
                if x and y:
                    diffs.append(np.mean(x) - np.mean(y))
                    refs.append(np.mean(y))
            if len(diffs) < 2:
                return "n/a"
            m = np.mean(refs)
            return f"{100 * np.mean(diffs) / m:+.2f} ± {100 * np.std(diffs, ddof=1) / math.sqrt(len(diffs)) / m:.2f}"
        d = a[key] - b[key]
        se = math.hypot(a["se_" + key], b["se_" + key])
        return f"{100 * d / b[key]:+.2f} ± {100 * se / b[key]:.2f}"

    def pbias(name, group, key):
        a, b = S[name][group], S[S[name]["ref"]][group]
        if name == S[name]["ref"]:
            return f"{a[key]:.2f}"
        n = a["n"]
        se = math.sqrt(max(a[key] * (1 - a[key]), b[key] * (1 - b[key]), 1 / n) / n) * math.sqrt(2)
        return f"{a[key]:.2f} ({a[key] - b[key]:+.2f} ± {se:.2f})"

    lines = ["# Work–precision table (generated by bench/work_precision.py)", "",
             f"Mode: {'full' if args.full else 'quick' if args.quick else 'default'}; perturbation ensemble "
             f"{n_pert} runs (input × (1 ± 1e-6…1e-4), one 0.3 g, 1 s Mavroeidis–Papageorgiou pulse); "
             f"record ensemble {n_rec} near-fault records × {n_rec_pert} perturbations "
             f"({'pcf.ground_motion.synthesize' if hasattr(pcf.ground_motion, 'synthesize') else 'stand-in MP pulses + noise: ground_motion.synthesize was not available'}). "
             f"Total wall {total:.0f} s on {args.procs} processes of a shared 2-core machine (timings ±30 % noise).",
             "",
             "Bias = (mean − reference mean) / reference mean, ± its standard error, in %, over runs that did "
             "not collapse; perturbation ensemble: both ensembles' SE combined; records: paired by record "
             "(per-record mean over its perturbations, SE of the mean paired difference). A bias is significant when it exceeds about "
             "2 SE. The reference of each row is given; `vertex dt0.25` is itself compared with `exact dt0.25`.",
             "",
             "## (a) Deterministic error before the first impact", "",
             "| contact | max error dt0.25 (m) | dt0.5 | dt1.0 | observed order | peak response (m) |",
             "|---|---|---|---|---|---|"]
    for c, (errs, order, peak) in det.items():
        lines.append(f"| {c} | {errs[0.25]:.2e} | {errs[0.5]:.2e} | {errs[1.0]:.2e} | {order:.2f} | {peak:.3e} |")
    lines += ["", "## (b) Ensemble means (bias %, ± SE %)", "",
              "| setting | ref | µs/step | s/run | u_top pert | u_d pert | u_top records | u_d records | mean u_top pert | mean u_top rec | NaN |",
              "|---|---|---|---|---|---|---|---|---|---|---|"]
    for name, *_ in settings:
        s = S[name]
        lines.append(f"| {name} | {s['ref']} | {s['us_step']:.2f} | {s['wall_run']:.3f} | "
                     f"{bias(name, 'pert', 'u_top')} | {bias(name, 'pert', 'u_d')} | "
                     f"{bias(name, 'rec', 'u_top')} | {bias(name, 'rec', 'u_d')} | "
                     f"{s['pert']['u_top']:.4f} | {s['rec']['u_top']:.4f} | {s['nan']} |")
    lines += ["", "## (c) Collapse and exceedance probabilities on the record ensemble (value (difference ± SE))", "",
              "| setting | P(collapse) | " + " | ".join(f"P({lev.label})" for lev in PERFORMANCE_LEVELS) + " |",
              "|---|---|" + "---|" * len(PERFORMANCE_LEVELS)]
    for name, *_ in settings:
        lines.append(f"| {name} | {pbias(name, 'rec', 'p_col')} | "
                     + " | ".join(pbias(name, 'rec', 'P ' + lev.label) for lev in PERFORMANCE_LEVELS) + " |")
    lines += ["", "## Quantiles (16/50/84 %) of u_top, perturbation ensemble", "",
              "| setting | u_top q16 | q50 | q84 | u_d q16 | q50 | q84 |", "|---|---|---|---|---|---|---|"]
    for name, *_ in settings:
        q, qd = S[name]["pert"]["u_top_q"], S[name]["pert"]["u_d_q"]
        lines.append(f"| {name} | {q[0]:.4f} | {q[1]:.4f} | {q[2]:.4f} | {qd[0]:.5f} | {qd[1]:.5f} | {qd[2]:.5f} |")
    text = "\n".join(lines) + "\n"
    print(text)
    if not args.no_write:
        write_keeping(os.path.join(DOCS, "work_precision.md"), text)
        plot(S, settings, os.path.join(DOCS, "work_precision.png"))
    return 0


def write_keeping(path, text):
    """Write the generated text to path, keeping the file's part from KEEP_MARK on (the sections after it,
    bench/equivalence.py's evidence among them, are not this bench's to rewrite)."""
    kept = ""
    if os.path.exists(path):
        with open(path, encoding="utf-8") as fh:
            old = fh.read()
        kept = old[old.index(KEEP_MARK):] if KEEP_MARK in old else ""
    with open(path, "w", encoding="utf-8") as fh:
        fh.write(text + ("\n" + kept if kept else ""))


def plot(S, settings, path):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.5))
    for ax, key in zip(axes, ("u_top", "u_d")):
        for name, *_ in settings:
            s = S[name]
            ref = S[s["ref"]]
            if name == s["ref"]:
                continue
            b = 100 * abs(s["pert"][key] - ref["pert"][key]) / ref["pert"][key]
            se = 100 * math.hypot(s["pert"]["se_" + key], ref["pert"]["se_" + key]) / ref["pert"][key]
            ax.errorbar(s["us_step"] * 0 + s["wall_run"], max(b, 1e-2), yerr=se, fmt="o", capsize=3)
            ax.annotate(name, (s["wall_run"], max(b, 1e-2)), fontsize=7, xytext=(3, 3), textcoords="offset points")
        ax.axhline(2.0, color="grey", ls="--", lw=0.8)
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel("wall time per run (s, one core)")
        ax.set_ylabel(f"|bias| of ensemble mean {key} (%), ±1 SE")
        ax.set_title(f"{key}: perturbation ensemble")
    fig.tight_layout()
    fig.savefig(path, dpi=120)


if __name__ == "__main__":
    sys.exit(main())
