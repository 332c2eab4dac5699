#!/usr/bin/env python3
"""Solver speed of this tree against a baseline tree, timed in the same run (never a test).

Builds bench/solver_profile.c twice with the flags of csrc/flags.mk -- against this
tree's csrc/ and against the baseline's -- and runs the two binaries alternately, case by
case and round by round, so that both see the same machine load. Reports for each case
the best CPU time per step over all rounds (CPU time of the thread: on a shared machine
it leaves out the time others held the core), the ratio baseline / new, and whether
the result hashes agree (bitwise the same u_top, u_d, energy error, residuals).

    .venv/bin/python bench/solver_compare.py --baseline /tmp/base [--rounds 5] [--repeat 3]

--baseline is a checkout of the baseline commit (e.g. `git worktree add /tmp/base c9942c1`).
"""
from __future__ import annotations

import argparse
import re
import shlex
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
CASES = [
    ("vertex (default)", ["vertex"]),
    ("vertex, dt_factor 0.5", ["vertex", "dtf=0.5"]),
    ("perimeter, 2 pts/edge", ["perimeter2"]),
    ("exact", ["exact"]),
    ("vertex, planar", ["vertex", "planar"]),
    ("vertex, monolithic", ["vertex", "mono"]),
    ("vertex, sleeping", ["vertex", "sleep"]),
    ("perimeter 2, sleeping", ["perimeter2", "sleep"]),
]


def cflags() -> list[str]:
    out = subprocess.run(["make", "-s", "-f", "csrc/flags.mk", "-f", "-", "print-cflags"], cwd=ROOT, text=True,
                         input="print-cflags: ; @echo $(CFLAGS)\n", capture_output=True, check=True).stdout
    return shlex.split(out)


def build(tree: Path, out: Path) -> None:
    srcs = [str(p) for p in sorted((tree / "csrc").glob("*.c"))]
    cmd = ["gcc", *cflags(), "-g", f"-I{tree / 'csrc'}", "-o", str(out), str(tree / "bench" / "solver_profile.c"),
           *srcs, "-lm"]
    subprocess.run(cmd, check=True)


def run(exe: Path, args: list[str], repeat: int) -> tuple[float, str, int]:
    p = subprocess.run([str(exe), *args, f"repeat={repeat}"], capture_output=True, text=True, check=True)
    # the CPU microseconds per step (printed to 1 ns; the seconds are printed to 0.1 ms only)
    m = re.search(r"steps (\d+) .*\(cpu ([0-9.]+)\) .*hash ([0-9a-f]+)", p.stdout)
    if not m:
        raise SystemExit(f"unexpected output of {exe}: {p.stdout}{p.stderr}")
    return float(m.group(2)) * 1e-6 * int(m.group(1)), m.group(3), int(m.group(1))


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--baseline", type=Path, required=True, help="checkout of the baseline commit")
    ap.add_argument("--rounds", type=int, default=5, help="alternating rounds (best of all is reported)")
    ap.add_argument("--repeat", type=int, default=3, help="runs per binary per round")
    ap.add_argument("--cases", nargs="*", help="case names to run (default: all)")
    args = ap.parse_args(argv)
    bdir = ROOT / "build"
    bdir.mkdir(exist_ok=True)
    exe_b, exe_n = bdir / "solver_profile_baseline", bdir / "solver_profile_new"
    build(args.baseline.resolve(), exe_b)
    build(ROOT, exe_n)
    rev = lambda t: subprocess.run(["git", "-C", str(t), "rev-parse", "--short", "HEAD"], capture_output=True,
                                   text=True).stdout.strip() or "?"
    cpu = _cpu_model()
    print(f"baseline {args.baseline} ({rev(args.baseline)}) vs this tree ({rev(ROOT)}), {cpu}")
    print(f"best CPU time per step over {args.rounds} alternating rounds x {args.repeat} runs; default column, "
          "0.25 g 2 Hz sine for 3 s, 20 s simulated, early exit off")
    print(f"{'case':<24} {'steps':>6} {'base us/step':>13} {'new us/step':>12} {'speed-up':>9}  same bits")
    for name, cargs in CASES:
        if args.cases and name not in args.cases:
            continue
        best = {"b": float("inf"), "n": float("inf")}
        hashes = {}
        for _ in range(args.rounds):
            for key, exe in (("b", exe_b), ("n", exe_n)):
                t, h, steps = run(exe, cargs, args.repeat)
                best[key] = min(best[key], t)
                hashes[key] = h
        print(f"{name:<24} {steps:>6d} {1e6 * best['b'] / steps:>13.3f} {1e6 * best['n'] / steps:>12.3f} "
              f"{best['b'] / best['n']:>8.2f}x  {'yes' if hashes['b'] == hashes['n'] else 'NO'}")
        sys.stdout.flush()


def _cpu_model():
    try:
        for line in open("/proc/cpuinfo", encoding="utf-8"):
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return "unknown CPU"


if __name__ == "__main__":
    main()
