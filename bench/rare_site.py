"""Verification and targets of the event-based site simulation (docs/rare_events.md, "Site estimator").

Stages (each resumable: rerunning one resumes its runs; outputs in results/rare_site/, summaries in
bench/results/rare_site/):

* ``crude``     -- crude Monte Carlo of the verification site (bench/data/site_bench.toml) with the
                   verification column (bench/data/column_two_drums.toml): ``--events`` events drawn
                   from the site's own densities (default 1e5), k of N per level, Jeffreys 90 % intervals;
* ``reps``      -- ``--reps`` independent site simulations (seeds 1, 2, ...) of the same site and column to
                   the target CoV: the mean of each level against the crude interval, the stated CoV
                   against the observed spread, runs used;
* ``replay``    -- one simulation on 1 rank and on 2 ranks (rows bitwise equal), and one killed with
                   SIGKILL in its second batch and resumed (the same rows and estimate as uninterrupted);
* ``target``    -- the example site with the default column, both pulse branches, to CoV 0.2 from at most
                   20 000 runs, beside the grid route (the grids of ``make risk``);
* ``crude-example`` -- ``--events`` crude events of the example site with the default column (default 2000):
                   the frequent levels' probability measured, the cost of an event;
* ``summary``   -- the tables (crude runs for the same CoV, N = (1 - p) / (p CoV^2), and the efficiency per level).

``crude``, ``crude-example`` and ``reps`` run under MPI like the grid (the stage's runs spread over the
ranks): ``mpirun -n 2 python -m mpi4py bench/rare_site.py crude``. ``target`` and ``replay`` start
``mpirun`` themselves. Measured costs are in docs/rare_events.md.
"""
from __future__ import annotations

import argparse
import json
import math
import os
import platform
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
from scipy import stats

from pycolfrag import Column
from pycolfrag.grid import get_comm
from pycolfrag.rare.driver import SiteSettings, StopRule, simulate_site
from pycolfrag.rare.estimate import exceedances
from pycolfrag.rare.evaluator import GridEvaluator, RecordSettings
from pycolfrag.rare.plans import PulseMap, event_normals
from pycolfrag.rare.strata import phi
from pycolfrag.risk.site_risk import QUANTITIES
from pycolfrag.site.sources import load_site

ROOT = Path(__file__).resolve().parents[1]
WORK = ROOT / "results" / "rare_site"
SUMMARY = ROOT / "bench" / "results" / "rare_site"
BENCH_SITE = ROOT / "bench" / "data" / "site_bench.toml"
BENCH_COLUMN = ROOT / "bench" / "data" / "column_two_drums.toml"
EXAMPLE_SITE = ROOT / "examples" / "site_athens.toml"
#: Stream identifier of the crude events (the site simulation's is 3, its steering 4).
STREAM_CRUDE = 5
MPIENV = {"OMPI_ALLOW_RUN_AS_ROOT": "1", "OMPI_ALLOW_RUN_AS_ROOT_CONFIRM": "1", "OMP_NUM_THREADS": "1",
          "OPENBLAS_NUM_THREADS": "1"}


def _say(comm, *a):
    if comm is None or comm.Get_rank() == 0:
        print(*a, flush=True)


def _provenance() -> dict:
    """What made a stored result: the command, the git revision (``+dirty`` with uncommitted changes),
    the date and the CPU, so a number in the docs names the code it came from."""
    def git(*a):
        r = subprocess.run(["git", *a], cwd=ROOT, capture_output=True, text=True)
        return r.stdout.strip() if r.returncode == 0 else ""
    rev = git("rev-parse", "--short", "HEAD") or "unknown"
    cpu = next((ln.split(":", 1)[1].strip() for ln in Path("/proc/cpuinfo").read_text().splitlines()
                if ln.startswith("model name")), platform.processor()) if Path("/proc/cpuinfo").exists() \
        else platform.processor()
    return {"command": "python bench/rare_site.py " + " ".join(sys.argv[1:]),
            # dirty: code changed since the commit (this benchmark's own stored results do not count)
            "revision": rev + ("+dirty" if git("status", "--porcelain", "--untracked-files=no", "--", ".",
                                               ":(exclude)bench/results") else ""),
            "date": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()), "cpu": cpu}


def _made_by(**stored) -> str:
    """The line that says which code and command made each stored result (name=its JSON, or None)."""
    by_text: dict = {}
    for name, o in stored.items():
        if not o:
            continue
        pv = o.get("provenance")
        text = (f"`{pv['command']}` at {pv['revision']} ({pv['date']}, {pv['cpu']})" if pv else
                "runs stored before results carried their provenance (the rare-site branch, 8a44ca3 and before: "
                "pulses through the pulse shape's map of Phi(z), equal to today's parameters_from_normals to "
                "rounding)")
        by_text.setdefault(text, []).append(name)
    return "Made by -- " + "; ".join(f"{', '.join(n)}: {t}" for t, n in by_text.items()) + "."


def _save(name: str, obj) -> Path:
    SUMMARY.mkdir(parents=True, exist_ok=True)
    path = SUMMARY / f"{name}.json"
    path.write_text(json.dumps({**obj, "provenance": _provenance()}, indent=1, default=float))
    return path


def _load(name: str):
    path = SUMMARY / f"{name}.json"
    return json.loads(path.read_text()) if path.exists() else None


# --------------------------------------------------------------------------- crude Monte Carlo

def crude_input(site, pulse_map, seed: int, i: int) -> dict:
    """Event ``i`` drawn from the site's own densities: the source by its rate, Mw and R from the source's
    models, a pulse with the model's probability p(R), the pulse normals standard normal."""
    ss = np.random.SeedSequence(seed, spawn_key=(STREAM_CRUDE, i))
    a, hf = (int(v) for v in ss.generate_state(2, dtype=np.uint64))
    x = event_normals(a)
    rates = np.cumsum([s.rate for s in site.sources]) / sum(s.rate for s in site.sources)
    k = int(np.searchsorted(rates, phi(x[0]), side="right"))
    s = site.sources[min(k, len(site.sources) - 1)]

    def draw(model, u):
        if model.atoms is not None:
            vals, w = zip(*model.atoms)
            return float(vals[min(int(np.searchsorted(np.cumsum(w), u, side="right")), len(vals) - 1)])
        return model.draw_between(u, *model.support)
    mw, r = draw(s.magnitude, phi(x[1])), draw(s.distance, phi(x[2]))
    p = float(s.pulse.mean_probability(np.array([r]))[0])
    pulse = phi(x[3]) < p
    tags = {"stage": 0, "stratum": -1, "index": int(i), "source": int(k), "weight": 1.0}
    if pulse:
        z = (float(x[4]), float(x[5]), float(x[6]), float(x[7]))
        tags.update(component=0, z_vp=z[0], z_fp=z[1], z_nu=z[2], z_gamma=z[3])
    return {"mw": mw, "dist_km": r, "hf_seed": hf, "pulse": pulse_map(mw, r, z) if pulse else None, "tags": tags}


def run_crude(comm, site_path, column_path, n: int, seed: int, name: str, batch: int = 10000) -> dict | None:
    """``n`` crude events in batches of ``batch`` (files results/rare_site/<name>/crude_NNN.h5); rank 0 returns
    k and N per level, the Jeffreys 90 % interval of each rate, and the mean wall time of an event."""
    site = load_site(site_path)
    col = Column.from_file(column_path) if column_path else Column.parthenon()
    rec = RecordSettings(column=col.to_dict())
    ev = GridEvaluator(WORK / name, rec, comm, progress=False)
    if not ev.is_root:
        ev.serve()
        return None
    pm = PulseMap(rec.pulse_shape, rec.vp_scale, rec.tp_model, rec.vp_model)
    parts = []
    for b in range(math.ceil(n / batch)):
        ids = range(b * batch, min(n, (b + 1) * batch))
        stored = ev.stored(f"crude_{b:03d}")
        inputs = stored[1] if stored else [crude_input(site, pm, seed, i) for i in ids]
        t0 = time.perf_counter()
        parts.append(ev.evaluate(f"crude_{b:03d}", inputs, {"crude": name, "seed": seed, "batch": b}))
        _say(comm, f"{name}: batch {b} ({len(inputs)} events) in {time.perf_counter() - t0:.0f} s")
    ev.close()
    cols = {k: np.concatenate([p[k] for p in parts]) for k in parts[0]}
    ok = cols["status"] == 0
    total = sum(s.rate for s in site.sources)
    out = {"site": str(site_path), "column": str(column_path or "parthenon"), "events": int(ok.sum()),
           "failed": int((~ok).sum()), "seed": seed, "wall_s_per_event": float(np.mean(cols["wall_s"][ok])),
           "total_rate_per_yr": total, "levels": {}}
    sub = {k: v[ok] for k, v in cols.items()}
    for q in QUANTITIES:
        k = int(np.sum(exceedances(sub, q)))
        N = int(ok.sum())
        lo, hi = (float(stats.beta.ppf(c, k + 0.5, N - k + 0.5)) if 0 < k < N else (0.0 if c < 0.5 else 1.0)
                  for c in (0.05, 0.95))
        if k == 0:
            lo, hi = 0.0, float(stats.beta.ppf(0.95, 0.5, N + 0.5))
        out["levels"][q.label] = {"k": k, "N": N, "p": k / N, "p_low": lo, "p_high": hi,
                                  "rate": total * k / N, "rate_low": total * lo, "rate_high": total * hi}
    return out


# --------------------------------------------------------------------------- repetitions of the estimator

def run_reps(comm, reps: int, target: float, max_runs: int, batch: int) -> dict | None:
    """``reps`` simulations of the verification site (seeds 1..reps), each in its own folder."""
    site = load_site(BENCH_SITE)
    rec = RecordSettings(column=Column.from_file(BENCH_COLUMN).to_dict())
    rows = []
    for seed in range(1, reps + 1):
        ev = GridEvaluator(WORK / "reps" / f"seed_{seed:03d}", rec, comm, progress=False)
        if not ev.is_root:
            ev.serve()
            continue
        t0 = time.perf_counter()
        run = simulate_site(site, SiteSettings(seed=seed, batch=batch), StopRule(target_cov=target, max_runs=max_runs),
                            ev, QUANTITIES, log=lambda s: None)
        ev.close()
        rows.append({"seed": seed, "runs": run.runs, "stopped": run.stopped, "wall_s": time.perf_counter() - t0,
                     "levels": {k: v.as_dict() for k, v in run.estimate.levels.items()}})
        _say(comm, f"rep {seed}: {run.runs} runs, {run.stopped}, " + ", ".join(
            f"{k} {v.rate:.3g} ({v.cov:.2f})" for k, v in run.estimate.levels.items()))
    if comm is not None and comm.Get_rank() != 0:
        return None
    return {"site": str(BENCH_SITE), "column": str(BENCH_COLUMN), "target_cov": target, "max_runs": max_runs,
            "batch": batch, "reps": rows}


def judge_reps(reps: dict, crude: dict) -> list:
    """Per level: mean of the repetitions against the crude interval, stated CoV against the observed spread,
    and the 90 % band of stated / observed were the stated CoV the true one (chi-square with reps - 1 degrees
    of freedom for the observed variance: [0.79, 1.37] with 20 repetitions, [0.86, 1.20] with 50)."""
    out = []
    n = len(reps["reps"])
    for q in QUANTITIES:
        lv = [r["levels"][q.label] for r in reps["reps"]]
        rates = np.array([v["rate"] for v in lv])
        stated = np.array([v["cov"] for v in lv])
        c = crude["levels"][q.label]
        mean = float(np.mean(rates))
        obs = float(np.std(rates, ddof=1) / mean) if mean > 0 else math.nan
        st = float(np.sqrt(np.mean(stated[np.isfinite(stated)] ** 2))) if np.isfinite(stated).any() else math.nan
        chi = [math.sqrt((n - 1) / stats.chi2.ppf(p, n - 1)) for p in (0.95, 0.05)]
        # the difference in units of its standard error: the crude count's (binomial) and the mean's (observed spread)
        se = math.hypot(c["rate"] * math.sqrt((1 - c["p"]) / max(c["k"], 1)), float(np.std(rates, ddof=1)) / math.sqrt(n))
        out.append({"level": q.label, "crude_rate": c["rate"], "crude_low": c["rate_low"], "crude_high": c["rate_high"],
                    "crude_k": c["k"], "mean": mean, "inside": bool(c["rate_low"] <= mean <= c["rate_high"]),
                    "z": (mean - c["rate"]) / se if se > 0 else math.nan,
                    "observed_cov": obs, "stated_cov": st, "ratio": st / obs if obs > 0 else math.nan,
                    "within_25": bool(abs(st / obs - 1) <= 0.25) if obs > 0 else False, "chi2_band": chi,
                    "refused": int(sum(v["status"] == "refused" for v in lv)),
                    "mean_runs": float(np.mean([r["runs"] for r in reps["reps"]]))})
    return out


# --------------------------------------------------------------------------- command lines under mpirun

def _cli(args: list, ranks: int) -> list:
    py = [sys.executable, "-m", "mpi4py", "-m", "pycolfrag"] if ranks > 1 else [sys.executable, "-m", "pycolfrag"]
    pre = ["mpirun", "--allow-run-as-root", "-n", str(ranks)] if ranks > 1 else []
    return pre + py + args


def _env() -> dict:
    env = {k: v for k, v in os.environ.items() if not k.startswith(("OMPI_", "PMIX_"))}
    env.update(MPIENV)
    return env


def _run(args: list, ranks: int, log: Path, timeout: float | None = None) -> int:
    log.parent.mkdir(parents=True, exist_ok=True)
    with open(log, "a") as fh:
        fh.write(f"$ {' '.join(_cli(args, ranks))}\n")
        fh.flush()
        return subprocess.run(_cli(args, ranks), stdout=fh, stderr=subprocess.STDOUT, env=_env(),
                              timeout=timeout).returncode


def _levels(folder: Path) -> dict:
    return json.loads((folder / "risk.json").read_text())["levels"]


def _same_rows(a: Path, b: Path) -> bool:
    from pycolfrag.analysis.compare import compare_results
    names = sorted(p.name for p in a.glob("batch_*.h5"))
    return names == sorted(p.name for p in b.glob("batch_*.h5")) and all(
        compare_results(a / n, b / n).identical for n in names)


def run_replay(max_runs: int, batch: int) -> dict:
    """1 rank against 2 ranks, and a run killed (SIGKILL) in its second batch then resumed."""
    base = ["risk", str(BENCH_SITE), "--column", str(BENCH_COLUMN), "--max-runs", str(max_runs), "--batch", str(batch),
            "--seed", "7", "--no-progress", "--no-figures", "--simulate"]
    out, log = WORK / "replay", WORK / "replay" / "log.txt"
    t0 = time.perf_counter()
    codes = {"1": _run(base + [str(out / "ranks1")], 1, log)}
    t1 = time.perf_counter()
    codes["2"] = _run(base + [str(out / "ranks2")], 2, log)
    t2 = time.perf_counter()
    killed = out / "killed"
    proc = subprocess.Popen(_cli(base + [str(killed)], 2), stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                            env=_env(), start_new_session=True)
    journal = killed / "batch_001.h5.journal"
    while proc.poll() is None and not (journal.exists() and journal.read_text().count("\n") > batch // 4):
        time.sleep(0.2)
    kill_state = "killed" if proc.poll() is None else "ended before the kill"
    if proc.poll() is None:
        os.killpg(proc.pid, signal.SIGKILL)
    proc.wait()
    codes["resumed"] = _run(base + [str(killed)], 2, log)
    same = {"1 vs 2 ranks": _same_rows(out / "ranks1", out / "ranks2"),
            "killed+resumed vs uninterrupted": _same_rows(out / "ranks2", killed)}
    est_equal = _levels(out / "ranks2") == _levels(killed) and _levels(out / "ranks1") == _levels(out / "ranks2")
    return {"exit_codes": codes, "kill": kill_state, "rows_bitwise": same, "estimates_equal": est_equal,
            "wall_s": {"1 rank": t1 - t0, "2 ranks": t2 - t1}}


def run_target(max_runs: int) -> dict:
    """The example site, default column, both branches, beside the grid route of ``make risk``'s grids."""
    log, grids = WORK / "target_log.txt", WORK / "grids"
    grid = ["grid", "--mw", "5.5", "6", "6.5", "7", "7.5", "--dist", "5", "10", "15", "20", "--samples", "20",
            "--no-figures", "--no-progress"]
    for name, extra in (("pulse", []), ("nopulse", ["--pulse", "none"])):
        code = _run(grid + extra + ["--out", str(grids / f"{name}.h5")], 2, log)
        if code != 0:
            raise SystemExit(f"the {name} grid failed (exit {code}); see {log}")
    t0 = time.perf_counter()
    code = _run(["risk", str(EXAMPLE_SITE), str(grids / "pulse.h5"), "--no-pulse", str(grids / "nopulse.h5"),
                 "--simulate", str(WORK / "example"), "--max-runs", str(max_runs), "--no-progress"], 2, log)
    res = json.loads((WORK / "example" / "risk.json").read_text())
    return {"exit_code": code, "wall_s_last_session": time.perf_counter() - t0, "runs": res["runs"],
            "target_cov": res["stop_rule"]["target_cov"],
            "stopped": res["stopped"], "levels": res["levels"], "grid_route": res["grid_route"],
            "history": res["history"], "design": res["design"]}


# --------------------------------------------------------------------------- the tables

def _crude_needed(p: float, cov: float) -> float:
    return (1.0 - p) / (p * cov * cov) if p > 0 and cov > 0 and math.isfinite(cov) else math.inf


def target_table(target: dict, crude: dict | None) -> list:
    """Per level of the target run: its CoV, crude runs for that CoV, efficiency, whether >= 10x, and the
    crude subset's measured probability beside the simulation's."""
    from pycolfrag.rare.evaluator import read_columns
    folder = WORK / "example"
    walls = np.concatenate([read_columns(p)[0]["wall_s"] for p in sorted(folder.glob("batch_*.h5"))])
    cost_run = float(np.nanmean(walls))
    cost_crude = crude["wall_s_per_event"] if crude else math.nan
    goal = target.get("target_cov", 0.2)
    L = [f"Example site, default column, both pulse branches: {target['runs']} runs ({target['stopped']}); mean wall "
         f"time of a run {1e3 * cost_run:.0f} ms" + (f", of a crude event {1e3 * cost_crude:.0f} ms" if crude else "")
         + " (2 ranks; wall time per run, the target and the crude subset measured at their own times: see Made by)", "",
         f"| level | rate /yr [90 %] | CoV | n_eff | p per event | crude runs for this CoV | efficiency (runs) | "
         f"efficiency (CPU) | >= 10x | crude runs for CoV {goal:g} | crude subset: p [90 %] |",
         "|---|---|---:|---:|---:|---:|---:|---:|---|---:|---|"]
    worst = 0.0
    for q in QUANTITIES:
        v = target["levels"][q.label]
        n = _crude_needed(v["p_per_event"], v["cov"])
        n_goal = _crude_needed(v["p_per_event"], goal)
        worst = max(worst, n_goal)
        eff = n / target["runs"]
        cpu = eff * cost_crude / cost_run if crude else math.nan
        c = crude["levels"][q.label] if crude else None
        sub = f"{c['p']:.2e} [{c['p_low']:.2e}, {c['p_high']:.2e}] ({c['k']}/{c['N']})" if c else "-"
        L.append(f"| {q.label} | {v['rate']:.3g} [{v['low']:.3g}, {v['high']:.3g}] | {v['cov']:.3f} | {v['n_eff']:.0f} | "
                 f"{v['p_per_event']:.2e} | {n:.3g} | {eff:.3g} | {cpu:.3g} | {'yes' if eff >= 10 else 'no'} | "
                 f"{n_goal:.3g} | {sub} |")
    L += ["", f"Every level at CoV <= {goal:g}: crude Monte Carlo needs {worst:.3g} events (its rarest level), the "
              f"simulation used {target['runs']} runs: {worst / target['runs']:.3g} times fewer. Efficiency per level at "
              "the CoV each reached: N = (1 - p) / (p CoV^2) over the runs used (the frequent levels reached far lower "
              "CoVs than asked, because the rare ones set the budget)."]
    col = target["levels"].get("collapse", {}).get("probability_50_years")
    if col:
        L += ["", f"P(collapse in 50 years) at the example site: {col[0]:.2g} [{col[1]:.2g}, {col[2]:.2g}] (90 %)."]
    L += ["", _made_by(target=target, crude_example=crude)]
    g = target.get("grid_route")
    if g:
        L += ["", "| level | event-based, grid's range | grid route (zero) | agree |", "|---|---|---|---|"]
        for q in QUANTITIES:
            e, z = g["event_based_in_grid"][q.label], g["grid_route_zero"][q.label]
            L.append(f"| {q.label} | {e['rate']:.3g} [{e['low']:.3g}, {e['high']:.3g}] ({e['status']}) | "
                     f"{z[0]:.3g} [{z[1]:.3g}, {z[2]:.3g}] | {g['agree'][q.label]} |")
    return L


def verification_lines(crude: dict, reps: dict, replay: dict | None) -> list:
    """The verification block: the simulations against the crude reference, and the replay's identities."""
    L = [f"Verification column (bench/data/column_two_drums.toml) at the verification site "
         f"(bench/data/site_bench.toml): {crude['events']} crude events (seeds {crude['seed']}; "
         f"{1e3 * crude['wall_s_per_event']:.1f} ms each, {crude['failed']} failed) against {len(reps['reps'])} simulations to CoV {reps['target_cov']:g} "
         f"(seeds 1-{len(reps['reps'])}, batches of {reps['batch']}):", "",
         "| level | crude k | crude rate [90 %] | mean of the simulations | inside | difference / its SE | observed CoV | "
         "stated CoV | stated / observed | within 25 % | its 90 % band were the stated CoV exact | refused | mean runs |",
         "|---|---:|---|---:|---|---:|---:|---:|---:|---|---|---:|---:|"]
    for r in judge_reps(reps, crude):
        L.append(f"| {r['level']} | {r['crude_k']} | {r['crude_rate']:.3g} [{r['crude_low']:.3g}, {r['crude_high']:.3g}] | "
                 f"{r['mean']:.3g} | {'yes' if r['inside'] else 'NO'} | {r['z']:+.2f} | {r['observed_cov']:.3f} | "
                 f"{r['stated_cov']:.3f} | "
                 f"{r['ratio']:.2f} | {'yes' if r['within_25'] else 'NO'} | [{r['chi2_band'][0]:.2f}, "
                 f"{r['chi2_band'][1]:.2f}] | {r['refused']} | {r['mean_runs']:.0f} |")
    if replay:
        L += ["", f"Replay (seed 7, batches of 500, 1500 runs): rows bitwise on 1 and 2 ranks: "
                  f"{replay['rows_bitwise']['1 vs 2 ranks']}; killed with SIGKILL in its second batch "
                  f"({replay['kill']}) and resumed, against uninterrupted: rows bitwise "
                  f"{replay['rows_bitwise']['killed+resumed vs uninterrupted']}, estimates equal "
                  f"{replay['estimates_equal']}."]
    return L


def _reps_folders() -> list:
    """The repetitions' work folders (``python bench/rare_site.py reps``), when this tree has them."""
    return sorted((WORK / "reps").glob("seed_*"))


def split_lines(crude: dict) -> list:
    """The repetitions' rows split by stage against the crude rate: the pilot's alone (a fixed design), the
    first production batch's alone (strata without two rows there from the pilot), all -- a check that the
    production rows' weights carry no bias of their own."""
    from pycolfrag.rare.estimate import estimate
    from pycolfrag.rare.evaluator import read_columns, read_plan
    from pycolfrag.rare.proposal import Design
    from pycolfrag.rare.strata import build_strata
    st = build_strata(load_site(BENCH_SITE))
    parts = {"pilot alone": [], "batch 1 alone": [], "all": []}
    if not _reps_folders():   # the repetitions' rows are not in this tree
        return ["", f"(The repetitions' rows by stage need the repetitions' folders, {WORK / 'reps'}: run "
                    "`python bench/rare_site.py reps` first.)"]
    for f in sorted((WORK / "reps").glob("seed_*")):
        cols = [read_columns(p)[0] for p in sorted(f.glob("batch_*.h5"))]
        d = Design.from_dict(read_plan(f / "batch_001.plan.json")[0]["design"])
        keep = np.array([np.sum(cols[1]["stratum"] == h) >= 2 for h in range(len(st))])
        both = estimate(cols[1], st, d, QUANTITIES, keep=keep).levels, estimate(cols[0], st, d, QUANTITIES,
                                                                                 keep=~keep).levels
        allc = {k: np.concatenate([c[k] for c in cols]) for k in cols[0]}
        parts["pilot alone"].append([estimate(cols[0], st, d, QUANTITIES).levels[q.label].rate for q in QUANTITIES])
        parts["batch 1 alone"].append([both[0][q.label].rate + both[1][q.label].rate for q in QUANTITIES])
        parts["all"].append([estimate(allc, st, d, QUANTITIES, pieces=True).levels[q.label].rate for q in QUANTITIES])
    L = ["", "The repetitions' rows by stage, mean / crude rate (difference in standard errors):", "",
         "| rows | " + " | ".join(q.label for q in QUANTITIES) + " |", "|---|" + "---:|" * len(QUANTITIES)]
    for name, rows in parts.items():
        a = np.array(rows)
        cells = []
        for j, q in enumerate(QUANTITIES):
            c = crude["levels"][q.label]
            se = math.hypot(c["rate"] / math.sqrt(max(c["k"], 1)), a[:, j].std(ddof=1) / math.sqrt(len(a)))
            cells.append(f"{a[:, j].mean() / c['rate']:.3f} ({(a[:, j].mean() - c['rate']) / se:+.1f})")
        L.append(f"| {name} | " + " | ".join(cells) + " |")
    return L


def _replace_block(path: Path, name: str, lines: list) -> None:
    text = path.read_text()
    begin, end = f"<!-- {name}:begin -->", f"<!-- {name}:end -->"
    head, rest = text.split(begin, 1)
    tail = rest.split(end, 1)[1]
    path.write_text(head + begin + "\nWritten by `python bench/rare_site.py summary --write-docs`.\n\n"
                    + "\n".join(lines) + "\n" + end + tail)


def write_docs() -> None:
    """The blocks of docs/rare_events.md and docs/risk.md from the stored summaries (no number typed by hand)."""
    crude, reps, replay, target = pooled_crude(), _load("reps"), _load("replay"), _load("target")
    docs = ROOT / "docs"
    if crude and reps and _reps_folders():
        _replace_block(docs / "rare_events.md", "rare-verification", verification_lines(crude, reps, replay)
                       + split_lines(crude) + ["", _made_by(crude=_load("crude"), crude_seed2=_load("crude_seed2"), reps=reps,
                                                                 replay=replay)])
    elif crude and reps:   # the docs' table by stage needs the repetitions' rows: keep the block as it is
        print(f"kept the verification block of docs/rare_events.md: no repetitions' folders in {WORK / 'reps'}")
    if target:
        lines = target_table(target, _load("crude_example"))
        _replace_block(docs / "rare_events.md", "rare-example", lines)
        _replace_block(docs / "risk.md", "rare-efficiency", lines)


def pooled_crude() -> dict | None:
    """crude.json with every further reference (crude_seed*.json, other seeds) pooled in: k and N summed per level."""
    parts = [x for x in [_load("crude")] + [json.loads(p.read_text()) for p in sorted(SUMMARY.glob("crude_seed*.json"))]
             if x]
    if not parts:
        return None
    out = dict(parts[0], events=sum(x["events"] for x in parts), failed=sum(x["failed"] for x in parts),
               seed=[x["seed"] for x in parts], levels={})
    out["wall_s_per_event"] = sum(x["wall_s_per_event"] * x["events"] for x in parts) / out["events"]
    total = parts[0]["total_rate_per_yr"]
    for lab in parts[0]["levels"]:
        k, N = sum(x["levels"][lab]["k"] for x in parts), sum(x["levels"][lab]["N"] for x in parts)
        lo, hi = (float(stats.beta.ppf(c, k + 0.5, N - k + 0.5)) for c in (0.05, 0.95))
        out["levels"][lab] = {"k": k, "N": N, "p": k / N, "p_low": lo, "p_high": hi, "rate": total * k / N,
                              "rate_low": total * lo, "rate_high": total * hi}
    return out


def summary() -> str:
    L = ["# bench/rare_site.py summary", ""]
    crude, reps, replay = pooled_crude(), _load("reps"), _load("replay")
    if crude and reps:
        L += verification_lines(crude, reps, replay) + [""]
    target = _load("target")
    if target:
        L += target_table(target, _load("crude_example")) + [""]
    return "\n".join(L)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("stage", choices=("crude", "reps", "replay", "target", "crude-example", "summary"))
    ap.add_argument("--events", type=int, default=None, help="crude events (crude: 1e5, crude-example: 2000)")
    ap.add_argument("--reps", type=int, default=20)
    ap.add_argument("--target-cov", type=float, default=0.2)
    ap.add_argument("--max-runs", type=int, default=20000)
    ap.add_argument("--batch", type=int, default=1000, help="runs per batch of the repetitions")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--name", default="crude", help="crude: the reference's name (its folder and summary); every "
                                                    "crude_*.json but crude_example is pooled with crude.json")
    ap.add_argument("--write-docs", action="store_true", help="summary: write the blocks of docs/rare_events.md and "
                                                               "docs/risk.md from the stored results")
    a = ap.parse_args(argv)
    comm = get_comm("auto") if a.stage in ("crude", "reps", "crude-example") else None
    t0 = time.perf_counter()
    if a.stage == "crude":
        res = run_crude(comm, BENCH_SITE, BENCH_COLUMN, a.events or 100000, a.seed, a.name)
    elif a.stage == "crude-example":
        res = run_crude(comm, EXAMPLE_SITE, None, a.events or 2000, a.seed, "crude_example", batch=1000)
    elif a.stage == "reps":
        res = run_reps(comm, a.reps, a.target_cov, a.max_runs, a.batch)
    elif a.stage == "replay":
        res = run_replay(1500, 500)
    elif a.stage == "target":
        res = run_target(a.max_runs)
    else:
        text = summary()
        (SUMMARY / "summary.md").write_text(text)
        print(text)
        if a.write_docs:
            write_docs()
        return 0
    if res is not None:
        res["bench_wall_s"] = time.perf_counter() - t0
        print(f"wrote {_save(a.name if a.stage == 'crude' else a.stage.replace('-', '_'), res)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
