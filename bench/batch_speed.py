#!/usr/bin/env python3
"""Runs in SIMD lanes against one run at a time, timed in the same run (never a test).

Synthesises ``--samples`` records of the default grid (rows spread evenly over its 35
scenarios, the grid's own seeds and pulse parameters), writes them for
bench/batch_profile.c, builds that driver with the flags of csrc/flags.mk against this tree
(and, with ``--baseline``, against a baseline checkout, e.g. main, for its single-run path),
and runs, alternately round by round so that every mode sees the same machine load:

* ``single``      every record alone with ``cf_solver_run`` (this tree; and the baseline's);
* ``batch=W``     ``cf_solver_batch_run`` at each width W the CPU runs (1, 2, 4, 8).

Reports the best CPU time per run-step of each (thread CPU time: on a shared machine it leaves
out the time others held the core), the ratio to the baseline's (else this tree's) single runs,
and whether the result hashes agree (bitwise the same EDPs, residuals, steps, statuses).

    .venv/bin/python bench/batch_speed.py [--samples 64] [--rounds 3] [--baseline /tmp/main] [--define CF_FORCE_AVX2]

``--define CF_FORCE_AVX2`` builds both trees as on a CPU without AVX-512 (the widest lanes 4: the batch, the
point runners and the joints' lane functions), which is how an AVX2 CPU is measured on an AVX-512 one.
"""
from __future__ import annotations

import argparse
import re
import struct
import subprocess
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "bench"))

from solver_compare import _cpu_model, cflags  # noqa: E402


def build(tree: Path, out: Path, batch: bool, defines=()) -> None:
    srcs = [str(p) for p in sorted((tree / "csrc").glob("*.c"))]
    cmd = ["gcc", *cflags(), *([] if batch else ["-DNO_BATCH"]), *[f"-D{d}" for d in defines], f"-I{tree / 'csrc'}",
           "-o", str(out),
           str(ROOT / "bench" / "batch_profile.c"), *srcs, "-lm"]
    subprocess.run(cmd, check=True)


def write_records(path: Path, n: int) -> tuple[list[int], float]:
    """n rows of the default grid, spread over its scenarios; returns the rows and the mean record length (s)."""
    from pycolfrag import ground_motion
    from pycolfrag.grid import GridSpec
    spec = GridSpec()
    ctx = spec.context()
    rows = sorted({int(r) for r in np.linspace(0, spec.n_rows - 1, n).round()})
    recs = []
    for row in rows:
        sc, k, mw, dist = ctx.locate(row)
        rec = ground_motion.synthesize(mw, dist, ctx.hf_seed(sc, k), dt=spec.record_dt_s, vp_scale=spec.vp_scale,
                                       pulse=ctx.pulse(sc, k))
        recs.append((rec.acc, rec.dt))
    write_record_file(path, recs)
    return rows, float(np.mean([acc.size * dt for acc, dt in recs]))


def write_record_file(path: Path, recs) -> None:
    """The records file of bench/batch_profile.c: their count, then each record's n, dt and n accelerations."""
    with open(path, "wb") as f:
        f.write(struct.pack("i", len(recs)))
        for acc, dt in recs:
            acc = np.ascontiguousarray(acc, dtype=np.float64)
            f.write(struct.pack("i", acc.size) + struct.pack("d", float(dt)) + acc.tobytes())


def run(exe: Path, records: Path, mode: str, case: list[str]) -> tuple[float, int, int, str, int]:
    p = subprocess.run([str(exe), str(records), mode, *case], capture_output=True, text=True, check=True)
    m = re.search(r"runs (\d+) steps (\d+) cpu ([0-9.]+) us/run-step [0-9.]+ width (\d+) hash ([0-9a-f]+)", p.stdout)
    if not m:
        raise SystemExit(f"unexpected output of {exe}: {p.stdout}{p.stderr}")
    return float(m.group(3)), int(m.group(2)), int(m.group(1)), m.group(5), int(m.group(4))


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--samples", type=int, default=64, help="grid rows in the batch (default 64)")
    ap.add_argument("--rounds", type=int, default=3, help="alternating rounds (best of all is reported)")
    ap.add_argument("--baseline", type=Path, help="checkout of a baseline commit (its single-run path)")
    ap.add_argument("--widths", type=int, nargs="*", default=[1, 2, 4, 8], help="batch widths to time")
    ap.add_argument("--define", nargs="*", default=[], metavar="MACRO",
                    help="preprocessor macros for both builds, e.g. CF_FORCE_AVX2 (an AVX2 CPU)")
    ap.add_argument("--case", nargs="*", default=[], help="solver options of bench/batch_profile.c "
                    "(perimeterN, exact, planar, mono, sleep; default: the grid's)")
    args = ap.parse_args(argv)
    bdir = ROOT / "build"
    bdir.mkdir(exist_ok=True)
    records = bdir / "batch_records.bin"
    rows, mean_s = write_records(records, args.samples)
    exe_n = bdir / "batch_profile_new"
    build(ROOT, exe_n, True, args.define)
    modes = [("this tree, one run at a time", exe_n, "single")]
    if args.baseline is not None:
        exe_b = bdir / "batch_profile_baseline"
        build(args.baseline.resolve(), exe_b, False, args.define)
        modes.insert(0, ("baseline, one run at a time", exe_b, "single"))
    modes += [(f"this tree, batch of width {w}", exe_n, f"batch={w}") for w in args.widths]
    rev = lambda t: subprocess.run(["git", "-C", str(t), "rev-parse", "--short", "HEAD"], capture_output=True,
                                   text=True).stdout.strip() or "?"
    print(f"this tree ({rev(ROOT)})" + (f" vs baseline {args.baseline} ({rev(args.baseline)})" if args.baseline
                                         else "") + f", {_cpu_model()}")
    print(f"{len(rows)} default-grid rows (every {rows[1] - rows[0] if len(rows) > 1 else 0}th, mean record "
          f"{mean_s:.1f} s), options {' '.join(args.case) or 'of the grid'} (else vertex, dt_factor 0.8, early "
          "exit); best thread CPU time over "
          f"{args.rounds} alternating rounds" + (f"; built with {' '.join('-D' + d for d in args.define)}"
                                                    if args.define else ""))
    best, info = {}, {}
    for _ in range(args.rounds):
        for name, exe, mode in modes:
            try:
                cpu, steps, nruns, h, w = run(exe, records, mode, args.case)
            except subprocess.CalledProcessError as exc:   # a width this CPU does not run
                info[name] = None
                print(f"  {name}: {exc.stderr.strip()}", file=sys.stderr)
                continue
            best[name] = min(best.get(name, float("inf")), cpu)
            info[name] = (steps, h)
    ref_name = modes[0][0]
    ref = best[ref_name] / info[ref_name][0]
    print(f"{'mode':<34} {'steps':>9} {'CPU s':>8} {'us/run-step':>12} {'vs ' + ref_name.split(',')[0]:>16}  same bits")
    for name, _, _ in modes:
        if info.get(name) is None:
            continue
        steps, h = info[name]
        per = best[name] / steps
        print(f"{name:<34} {steps:>9d} {best[name]:>8.3f} {1e6 * per:>12.3f} {per / ref:>15.2f}x  "
              f"{'yes' if h == info[ref_name][1] else 'NO'}")


if __name__ == "__main__":
    main()
