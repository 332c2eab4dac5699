#!/usr/bin/env python3
"""How much can sleeping joints and tree-order sums save on the default grid? A ceiling, measured (never a test).

The targets of docs/performance.md "Speed, third edition: the ceiling" -- the full default grid >= 1.9x faster and the
single run >= 1.5x -- were to come from two changes of results at round-off: sleeping joints (a joint whose points all
stick is advanced by its linear law, its points skipped) and sums in a fixed tree order (the face sums off their
point-order chain). This bench measures what either can give
at most, on the grid's own rows (``pycolfrag grid`` with no options: its 35 scenarios, samples FIRST.. of each, the
records and solver options a full grid runs):

* **closed**: the share of joint-time (history every 2 ms) in which no vertex of the joint's upper face is open
  (``History.joint_opening`` = 0). A joint can sleep only with every point of both faces in contact, so this is an
  upper bound of the joint-steps sleeping can take, whatever its criterion (estimated from the 2 ms samples).
* **asleep**: the joint-steps the solver's own sleeping (option ``sleep``, margin 0.5) took, single runs, counted
  by the C driver bench/batch_profile.c (``single sleep``: every row alone, the grid's options), and the CPU
  time of the rows with and without it (the same binary, alternately, the best of the rounds).
* **all lanes closed**: the grid runs its rows in SIMD lanes, 8 side by side (docs/performance.md, "Runs in lanes");
  a joint's points can be skipped only when every running lane sleeps on it (a sleeping lane is masked, not
  removed). Approximated by the share of joint-time in which the joint is closed in all 8 rows of one scenario at
  once, started together at t = 0 and cut to the group's shortest. The grid's lanes are staggered (longest record
  first, a lane refilled as its run ends, chunks by cost), so their quiet phases coincide less than these aligned
  ones: the approximation errs high, as a ceiling may.
* the **ceiling** of a speed-up: 1 / (1 - p x s), s the share of joint-steps whose point work could be skipped and
  p the share of a step that is point work -- 0.52 in a single run, a generous value (perf, docs/performance.md
  "Profile of one step": the runner with the full law 47-53 %; the same page finds the point work about a third of
  a vertex step where every joint sleeps) and 0.80 in an 8-lane batch (perf, "The AVX2 path": ``run_w8`` 80 %, the
  joints' lanes 12 %). A sleeping step that cost nothing would reach it; the per-joint work, the bodies and the
  monitor remain.
* ``--tree-sums``: the face sums of the single run's point runner accumulated as whole vectors (one vector add per
  block, reduced once per face) instead of lane by lane in point order, for its blocks of easy points (a block with
  a hard point keeps point order) -- the cheapest order for them, so what a tree order can save there. The patch (bench/patches/vector_sums.diff) is applied to a copy of
  this tree; both builds are timed alternately, on the sine of bench/solver_speed.py (bench/solver_profile.c) and
  on the grid rows above one at a time (bench/batch_profile.c). In the batch each lane is its own run and adds its
  points one after the other; bench/patches/batch_pair_sums.diff gives every lane two sums (even and odd points,
  joined at the face's end), which halves that chain -- one tree order, not a bound -- timed at 8 lanes on the same
  rows.

    nice -n 10 .venv/bin/python bench/speed_ceiling.py [--samples 8] [--first 0] [--tree-sums] [--rounds 3]
    nice -n 10 .venv/bin/python bench/speed_ceiling.py --sums-only --samples 2 --rounds 12

Writes bench/results/speed_ceiling.json (the sleeping measures) and, with the sum orders, speed_ceiling_sums.json
(unless --no-write); ``--sums-only`` times the sum orders alone on the rows' records.
"""
from __future__ import annotations

import argparse
import datetime
import json
import re
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
HERE = ROOT / "bench"
sys.path.insert(0, str(HERE))

#: share of a step that is point work, generous values: single run (perf, docs/performance.md "Profile of one step":
#: the runner with the full law 47-53 %) and an 8-lane batch (perf, docs/performance.md "The AVX2 path": run_w8 80 %)
POINT_SHARE = {"single": 0.52, "batch": 0.80}
LANES = 8
#: runs of the short sine case per round (0.1 s each: this many keep its best time steady on a shared VM)
SINE_REPEAT = 5
HISTORY_DT = 0.002


def _in_turn(items: list, r: int) -> list:
    """The builds or settings timed in round r: in their order, reversed every other round (none always follows
    the same one on a shared machine)."""
    return items if r % 2 == 0 else items[::-1]


def ceiling(point_share: float, skipped: float) -> float:
    """The speed-up if the skipped share of joint-steps cost no point work and nothing else changed."""
    return 1.0 / (1.0 - point_share * skipped)


def _records(path: Path, rows) -> Path:
    from batch_speed import write_record_file
    write_record_file(path, [(acc, dt) for acc, dt, _ in rows])
    return path


def _single(exe: Path, records: Path, *flags: str) -> dict:
    """bench/batch_profile.c, every record alone: CPU s, steps, joint-steps asleep and all joint-steps."""
    out = subprocess.run([str(exe), str(records), "single", *flags], capture_output=True, text=True,
                         check=True).stdout
    m = re.search(r"steps (\d+) cpu ([0-9.]+) .* slept (\d+) of (\d+) joint-steps", out)
    if not m:
        raise SystemExit(f"unexpected output of {exe}: {out}")
    return {"steps": int(m.group(1)), "cpu_s": float(m.group(2)), "slept": int(m.group(3)),
            "joint_steps": int(m.group(4))}


def measure_rows(rows: list, work: Path, rounds: int) -> dict:
    """The sleeping measures of the rows ((acc, dt, label) of the default grid), per magnitude."""
    import pycolfrag as pcf
    from batch_speed import build
    col = pcf.Column.parthenon()
    exe = work / "batch_profile"
    build(ROOT, exe, batch=True)
    by_mw: dict = {}
    for row in rows:
        by_mw.setdefault(row[2].split()[0], []).append(row)
    per_mw: dict = {}
    groups = []
    for mw, mine in by_mw.items():
        rec = _records(work / f"{mw}.bin", mine)
        on, off = _single(exe, rec, "sleep"), _single(exe, rec)
        for r in range(rounds - 1):   # the best CPU of the rounds (the counts are the same every round)
            for flags, best in _in_turn([((), off), (("sleep",), on)], r):
                best["cpu_s"] = min(best["cpu_s"], _single(exe, rec, *flags)["cpu_s"])
        d = per_mw[mw] = {"rows": len(mine), "steps": off["steps"], "samples": 0, "closed": 0, "slept": on["slept"],
                          "joint_steps": on["joint_steps"], "cpu_off": off["cpu_s"], "cpu_on": on["cpu_s"]}
        for acc, dt, label in mine:
            closed = pcf.simulate(col, acc, dt, history=True, history_dt=HISTORY_DT).history.joint_opening <= 0.0
            d["samples"] += closed.size; d["closed"] += int(closed.sum())
            scen = label.rsplit(" sample", 1)[0]
            if not groups or groups[-1][0] != scen or len(groups[-1][1]) == LANES:
                groups.append((scen, []))
            groups[-1][1].append(closed)
    all_closed = all_samples = 0
    for _, g in groups:
        if len(g) < LANES:
            continue
        n = min(c.shape[0] for c in g)
        together = np.logical_and.reduce([c[:n] for c in g])
        all_closed += int(together.sum()); all_samples += together.size
    return {"per_mw": per_mw, "lane_groups": sum(len(g) == LANES for _, g in groups),
            "all_lanes_closed": all_closed / all_samples if all_samples else float("nan")}


def tree_sums(work: Path, rounds: int) -> list:
    """Each patch of bench/patches against this tree, alternately (best CPU of the rounds): the single run's runner
    with vector sums on the sine of bench/solver_speed.py (bench/solver_profile.c) and on the grid rows above one at
    a time; the batch with two sums per lane (even and odd points) on the same rows at 8 lanes (batch_profile.c)."""
    import batch_speed
    import solver_compare
    exe = {}
    for key, patch in (("base", None), ("vector", "vector_sums.diff"), ("pairs", "batch_pair_sums.diff")):
        tree = ROOT
        if patch:
            tree = work / key
            for part in ("csrc", "bench", "tests/c"):   # this tree as it is, then the patch
                shutil.copytree(ROOT / part, tree / part, ignore=shutil.ignore_patterns("results", "__pycache__"))
            subprocess.run(["git", "apply", str(HERE / "patches" / patch)], cwd=tree, check=True)
        solver_compare.build(tree, work / f"sine_{key}")
        batch_speed.build(tree, work / f"grid_{key}", batch=True)
        exe[key] = (work / f"sine_{key}", work / f"grid_{key}")
    cases = {"sine": ("vector", "single run, sine 0.25 g 20 s (bench/solver_speed.py), vector sums"),
             "grid": ("vector", "single runs, the grid rows above, vector sums"),
             "batch": ("pairs", "8-lane batch, the grid rows above, two sums per lane")}
    best = {(case, key): float("inf") for case in cases for key in exe}
    for r in range(rounds):
        for key, (sine, grid) in _in_turn(list(exe.items()), r):
            if key != "pairs":
                sec, _, steps = solver_compare.run(sine, ["vertex"], SINE_REPEAT)
                best["sine", key] = min(best["sine", key], 1e6 * sec / steps)
                cpu, steps, *_ = batch_speed.run(grid, work / "all.bin", "single", [])
                best["grid", key] = min(best["grid", key], 1e6 * cpu / steps)
            if key != "vector":
                cpu, steps, *_ = batch_speed.run(grid, work / "all.bin", "batch=8", [])
                best["batch", key] = min(best["batch", key], 1e6 * cpu / steps)
    return [{"case": name, "base_us": best[case, "base"], "patched_us": best[case, key],
             "speedup": best[case, "base"] / best[case, key]} for case, (key, name) in cases.items()]


def _report_rows(res: dict, cpu: str) -> dict:
    """Print the sleeping measures and their ceilings; their JSON."""
    per = res["per_mw"]
    print(f"{'Mw':6} {'rows':>5} {'steps':>9} {'closed':>7} {'asleep':>7} {'sleep on/off CPU':>17}")
    tot = {k: sum(d[k] for d in per.values()) for k in ("steps", "samples", "closed", "slept", "joint_steps",
                                                          "cpu_off", "cpu_on")}
    for mw, d in per.items():
        print(f"{mw:6} {d['rows']:5d} {d['steps']:9d} {d['closed'] / d['samples']:7.3f} "
              f"{d['slept'] / d['joint_steps']:7.3f} {d['cpu_on'] / d['cpu_off']:17.3f}")
    closed, asleep = tot["closed"] / tot["samples"], tot["slept"] / tot["joint_steps"]
    print(f"{'all':6} {sum(d['rows'] for d in per.values()):5d} {tot['steps']:9d} {closed:7.3f} {asleep:7.3f} "
          f"{tot['cpu_on'] / tot['cpu_off']:17.3f}")
    lanes = res["all_lanes_closed"]
    print(f"joint-time closed in all {LANES} lanes of a group at once: {lanes:.4f} ({res['lane_groups']} groups)")
    ceil = {"single, every closed joint-step free": ceiling(POINT_SHARE["single"], closed),
            "single, the solver's sleeping, free": ceiling(POINT_SHARE["single"], asleep),
            "batch, every closed (run, joint) free (lanes compacted)": ceiling(POINT_SHARE["batch"], closed),
            "batch, joints closed in all lanes free": ceiling(POINT_SHARE["batch"], lanes)}
    print("ceilings of sleeping (1 / (1 - p s)):")
    for k, v in ceil.items():
        print(f"  {k:58} {v:.2f}x")
    return {"cpu": cpu, "point_share": POINT_SHARE, "per_mw": per, "closed": closed, "asleep": asleep,
            "all_lanes_closed": lanes, "lane_groups": res["lane_groups"], "ceilings": ceil}


def _report_sums(sums: list, cpu: str) -> dict:
    print("sum orders against point order (best CPU us per run-step):")
    for r in sums:
        print(f"  {r['case']:66} {r['base_us']:7.3f} -> {r['patched_us']:7.3f}  {r['speedup']:.2f}x")
    return {"cpu": cpu, "tree_sums": sums}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--samples", type=int, default=8, help="grid samples per scenario (default %(default)s)")
    ap.add_argument("--first", type=int, default=0, help="from sample K of each scenario (default 0)")
    ap.add_argument("--tree-sums", action="store_true", help="also time two sum orders against point order")
    ap.add_argument("--sums-only", action="store_true", help="only the sum orders, on the rows' records")
    ap.add_argument("--rounds", type=int, default=3,
                    help="alternating rounds of every timing, the best CPU kept (default %(default)s)")
    ap.add_argument("--no-write", action="store_true")
    a = ap.parse_args(argv)
    if a.samples < 1 or a.rounds < 1:
        ap.error(f"--samples and --rounds must be >= 1, got {a.samples} and {a.rounds}")
    if a.samples < LANES and not a.sums_only:
        ap.error(f"--samples must be >= {LANES} (one lane group per scenario), got {a.samples}")
    from equivalence import _git, _stale, grid_inputs
    if not a.sums_only and _stale(ROOT):
        ap.error("the built extension is not this tree's csrc/: run make build (the histories come from it)")
    from pycolfrag.grid.schedule import cpu_model
    cpu = cpu_model()
    with tempfile.TemporaryDirectory() as tmp:
        work = Path(tmp)
        rows = grid_inputs(a.samples, a.first)
        _records(work / "all.bin", rows)
        res = None if a.sums_only else measure_rows(rows, work, a.rounds)
        sums = tree_sums(work, a.rounds) if a.tree_sums or a.sums_only else None
    utc = f"{datetime.datetime.now(datetime.timezone.utc):%Y-%m-%d %H:%M}"
    print(f"# {cpu}, {utc} UTC; default grid, {a.samples} samples per scenario from {a.first}")
    out = {}
    if res is not None:
        out["speed_ceiling.json"] = _report_rows(res, cpu)
    if sums is not None:
        out["speed_ceiling_sums.json"] = _report_sums(sums, cpu)
    stamp = {"utc": utc, "samples": a.samples,
             "first": a.first, "rounds": a.rounds, "commit": _git("rev-parse", "--short", "HEAD"),
             "dirty": bool(_git("status", "--porcelain", "--", "csrc", "bench", ":(exclude)bench/results"))}
    for name, data in out.items():
        if not a.no_write:
            data.update(stamp)
            (HERE / "results" / name).write_text(json.dumps(data, indent=1) + "\n")
            print(f"wrote bench/results/{name}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
