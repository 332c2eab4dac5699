#!/usr/bin/env python3
"""The grid with runs in SIMD lanes against a baseline tree (e.g. main), timed in the same session
(never a test).

Runs the reduced default grid (all 35 scenarios x ``--samples`` samples, the default grid's rows for
those samples) through each tree's ``scripts/run_grid.py`` on 2 MPI ranks, alternately round by round so
that both see the same machine load, and this tree on 1 rank too. Reports per command the wall time of
the driver's session (the file's ``wall_s_last_session``), the CPU seconds of all its processes
(``getrusage`` of the children: Python start-up and imports included), the ratio to the baseline, the
1 -> 2 rank speed-up, the full grid (3500 runs) extrapolated from the session times, and whether the
rows are bitwise the baseline's (``pycolfrag.analysis.compare``).

    .venv/bin/python bench/grid_batch.py --baseline /tmp/main [--samples 4] [--rounds 2] [--chunk-max 8 32]

The baseline checkout needs its C extension built in place (``python setup.py build_ext --inplace``);
it runs with ``PYTHONPATH`` pointing at it.
"""
from __future__ import annotations

import argparse
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "bench"))

from grid_speed import _env  # noqa: E402


def run(tree: Path, n_ranks: int, args: list[str]) -> tuple[float, float, float]:
    """(command wall s, session s, CPU s of every process) of one run_grid.py command of a tree."""
    env = _env()
    env["PYTHONPATH"] = os.pathsep.join([str(tree), env.get("PYTHONPATH", "")])
    script = tree / "scripts" / "run_grid.py"
    cmd = [sys.executable, str(script), *args] if n_ranks == 1 else \
        ["mpirun", "--allow-run-as-root", "-n", str(n_ranks), sys.executable, "-m", "mpi4py", str(script), *args]
    r0 = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    p = subprocess.run(cmd, capture_output=True, text=True, env=env, cwd=tree)
    t = time.perf_counter() - t0
    r1 = resource.getrusage(resource.RUSAGE_CHILDREN)
    if p.returncode != 0:
        raise SystemExit(f"{' '.join(cmd)} failed ({p.returncode}):\n{p.stdout}\n{p.stderr}")
    import h5py
    out = Path(args[args.index("--out") + 1])
    with h5py.File(out, "r") as f:
        session = float(f.attrs["wall_s_last_session"])
    cpu = (r1.ru_utime - r0.ru_utime) + (r1.ru_stime - r0.ru_stime)
    return t, session, cpu


def same_rows(a: Path, b: Path) -> bool:
    p = subprocess.run([sys.executable, "-m", "pycolfrag.analysis.compare", str(a), str(b)], capture_output=True, text=True,
                       cwd=ROOT)
    return "bitwise identical" in p.stdout


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--baseline", type=Path, required=True, help="checkout of the baseline commit, built in place")
    ap.add_argument("--samples", type=int, default=4, help="samples per scenario (default 4: 140 runs)")
    ap.add_argument("--rounds", type=int, default=2, help="alternating rounds (best session of each is reported)")
    ap.add_argument("--chunk-max", type=int, nargs="*", default=[32], help="chunk sizes of this tree to time")
    a = ap.parse_args(argv)
    work = Path(tempfile.mkdtemp(prefix="grid_batch_"))
    n_runs = 35 * a.samples
    common = ["--samples", str(a.samples), "--no-figures", "--no-progress", "--overwrite"]
    cases = [("baseline, 2 ranks", a.baseline.resolve(), 2, [])]
    cases += [(f"this tree, 2 ranks, chunk {c}", ROOT, 2, ["--chunk-max", str(c)]) for c in a.chunk_max]
    cases += [("baseline, 1 rank", a.baseline.resolve(), 1, [])]
    cases += [(f"this tree, 1 rank, chunk {c}", ROOT, 1, ["--chunk-max", str(c)]) for c in a.chunk_max[-1:]]
    best: dict = {}
    for _ in range(a.rounds):
        for i, (name, tree, n, extra) in enumerate(cases):
            out = work / f"case{i}.h5"
            t, s, cpu = run(tree, n, [*common, *extra, "--out", str(out)])
            if name not in best or s < best[name][1]:
                best[name] = (t, s, cpu, out)
    base = best[cases[0][0]]
    print(f"reduced default grid: 35 scenarios x {a.samples} samples = {n_runs} runs; best of {a.rounds} "
          f"alternating rounds; baseline {a.baseline}")
    print(f"{'case':<32} {'command s':>10} {'session s':>10} {'CPU s':>8} {'session/base':>13} "
          f"{'full grid est. s':>17}  rows = baseline")
    for name, _, _, _ in cases:
        t, s, cpu, out = best[name]
        print(f"{name:<32} {t:10.2f} {s:10.2f} {cpu:8.2f} {s / base[1]:13.2f} {s * 3500 / n_runs:17.0f}  "
              f"{'yes' if name == cases[0][0] or same_rows(base[3], out) else 'NO'}")
    one = best[cases[-1][0]][1]
    two = best[f"this tree, 2 ranks, chunk {a.chunk_max[-1]}"][1]
    print(f"1 -> 2 rank speed-up of this tree (chunk {a.chunk_max[-1]}): {one / two:.2f}")
    print(f"(result files in {work})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
