#!/usr/bin/env python3
"""Time and peak memory of reading a large OpenQuake hazard-curve CSV (never a test).

Writes a synthetic file of about ``--mb`` MB (``--levels`` poe columns, OpenQuake's current header
with ``custom_site_id``, poes decreasing along each row) to a temporary folder, then reads it with
:func:`pycolfrag.analysis.openquake.read_hazard_curves` in a fresh process and prints the wall time and
the process's peak resident memory (``ru_maxrss``; the interpreter and numpy/scipy imports alone are
included, printed as ``baseline``).

    .venv/bin/python bench/hazard_csv_read.py [--mb 100] [--levels 20]
"""
from __future__ import annotations

import argparse
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

_CHILD = r"""
import resource, sys, time
from pycolfrag.analysis import openquake as oq
base = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
t0 = time.perf_counter()
hc = oq.read_hazard_curves(sys.argv[1])
dt = time.perf_counter() - t0
peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
print(f"{len(hc.lon)} sites x {hc.imls.size} levels: {dt:.2f} s, peak RSS {peak / 1024:.0f} MB "
      f"(baseline after imports {base / 1024:.0f} MB), poes sum {hc.poes.sum():.6g}")
"""


def write_file(path: Path, mb: float, levels: int, seed: int = 0) -> int:
    """A hazard-curve CSV of about ``mb`` MB; returns its number of sites."""
    rng = np.random.default_rng(seed)
    imls = np.geomspace(0.005, 3.0, levels)
    head = ('#,,,,,"generated_by=\'OpenQuake engine 3.16\', start_date=\'2026-01-01\', checksum=1, '
            "kind='mean', investigation_time=50.0, imt='PGA'\"\n"
            "custom_site_id,lon,lat,depth," + ",".join(f"poe-{x:g}" for x in imls) + "\n")
    n_written, n_sites, limit = 0, 0, int(mb * 1e6)
    with open(path, "w") as f:
        f.write(head)
        while n_written < limit:
            n = 10000
            lon, lat = rng.uniform(-10, 30, n), rng.uniform(35, 45, n)
            scale = rng.uniform(0.02, 0.5, n)[:, None]
            poes = -np.expm1(-50 * 0.05 * (imls[None, :] / scale) ** -2.5 / 50)
            poes = np.minimum(poes, 0.999999)
            lines = [f"s{n_sites + i},{lon[i]:.5f},{lat[i]:.5f},0.0," + ",".join(f"{p:.6E}" for p in poes[i])
                     for i in range(n)]
            block = "\n".join(lines) + "\n"
            f.write(block)
            n_written += len(block)
            n_sites += n
    return n_sites


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--mb", type=float, default=100.0)
    ap.add_argument("--levels", type=int, default=20)
    a = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "hazard_curve-mean-PGA.csv"
        n = write_file(path, a.mb, a.levels)
        print(f"{path.stat().st_size / 1e6:.1f} MB, {n} sites")
        subprocess.run([sys.executable, "-c", _CHILD, str(path)], check=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
