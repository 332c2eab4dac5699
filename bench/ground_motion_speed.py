#!/usr/bin/env python3
"""Speed of the ground-motion generator: ms per record, C vs the NumPy twin.

    .venv/bin/python bench/ground_motion_speed.py            # 200 repetitions per row
    .venv/bin/python bench/ground_motion_speed.py --n 1000

Rows (median over --n calls, after one warm-up call; dt = 0.005 s):
* C generator, ``atkinson_silva_2000.simulate`` (Python call, scenario cached: noise, window,
  2 FFTs) and the same on a new scenario each call ("cold": also the target spectrum, window and
  FFT plan); the C kernel alone (``cf_stochastic_run`` through cffi, no Python wrapper);
* NumPy twin (``_numpy_reference.simulate``, its layout and spectrum cached the same way) and cold;
* one FFT of the padded length: own radix-2 (C) vs ``numpy.fft.rfft``;
* ``combine`` (steps 3-6) on the record, and -- if ``pycolfrag.ground_motion.intensity.measures`` exists --
  the intensity measures at 5 periods.
The machine may be shared with other jobs: the table is what this run saw. Never a test.
"""
from __future__ import annotations

import argparse
import platform
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from pycolfrag.core.ffi import ffi, lib, ptr  # noqa: E402
from pycolfrag.ground_motion import _numpy_reference as npref  # noqa: E402
from pycolfrag.ground_motion import atkinson_silva_2000 as as00  # noqa: E402
from pycolfrag.ground_motion.combine import combine  # noqa: E402

DT = 0.005
PERIODS = (0.2, 0.5, 1.0, 2.0, 3.0)


def cpu_model() -> str:
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or "unknown"


def median_ms(fn, n: int) -> float:
    fn(0)
    times = []
    for i in range(n):
        t = time.perf_counter()
        fn(i)
        times.append(time.perf_counter() - t)
    return 1e3 * float(np.median(times))


def rows_for(mw: float, d: float, n: int):
    acc, info = as00.simulate(mw, d, 0, DT)
    nfft = info["nfft"]
    rows = []
    c_ms = median_ms(lambda i: as00.simulate(mw, d, i, DT), n)
    rows.append(("C generator, `simulate` (scenario cached)", c_ms))
    # the kernel alone
    gen = as00._generator(mw, d, DT)
    out = np.empty(info["n_window"] + int(round((info["pre_s"] + info["tail_s"]) / DT)))
    assert out.size == acc.size
    p = ptr(out)
    rows.append(("C kernel `cf_stochastic_run` only", median_ms(lambda i: lib.cf_stochastic_run(gen.ptr, i, p, out.size), n)))
    # cold: a new scenario every call (distance nudged so the cache never hits)
    rows.append(("C generator, new scenario each call",
                 median_ms(lambda i: as00.simulate(mw, d + 1e-9 * (i + 1), i, DT), max(20, n // 5))))
    np_ms = median_ms(lambda i: npref.simulate(mw, d, i, DT), n)
    rows.append(("NumPy twin (layout and spectrum cached)", np_ms))
    rows.append(("NumPy twin, new scenario each call",
                 median_ms(lambda i: npref.simulate(mw, d + 1e-9 * (i + 1), i, DT), max(20, n // 5))))
    # one FFT of the padded length
    pl = ffi.new("cf_fft_plan **")
    assert lib.cf_fft_plan_create(nfft, pl) == 0
    plan = ffi.gc(pl[0], lib.cf_fft_plan_free)
    x = np.random.default_rng(0).standard_normal(nfft)
    spec = np.empty(nfft + 2)
    px, ps = ptr(x), ptr(spec)
    rows.append((f"FFT n = {nfft}: own radix-2 (C)", median_ms(lambda i: lib.cf_fft_forward(plan, px, ps), n)))
    rows.append((f"FFT n = {nfft}: numpy.fft.rfft", median_ms(lambda i: np.fft.rfft(x), n)))
    pulse = np.zeros_like(acc)
    pulse[acc.size // 3: acc.size // 3 + 400] = np.sin(np.linspace(0, 4 * np.pi, 400))
    rows.append(("`combine` (steps 3-6)", median_ms(lambda i: combine(acc, pulse), n)))
    try:
        from pycolfrag.ground_motion.intensity import measures
    except ImportError:
        measures = None
    if measures is not None:
        rows.append(("IMs at 5 periods (`pycolfrag.ground_motion.intensity.measures`)",
                     median_ms(lambda i: measures(acc, DT, periods=PERIODS), n)))
    return rows, info, acc.size, c_ms, np_ms


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=200, help="calls per row (median)")
    args = ap.parse_args()
    print(f"machine: {cpu_model()}, {platform.system()} {platform.machine()}, "
          f"Python {platform.python_version()}, numpy {np.__version__}\n")
    for mw, d in ((6.5, 10.0), (7.5, 5.0)):
        rows, info, n_out, c_ms, np_ms = rows_for(mw, d, args.n)
        print(f"### Mw {mw}, {d:g} km, dt {DT} s: {n_out} samples returned, nfft {info['nfft']}\n")
        print("| what | ms (median) |")
        print("|---|---|")
        for name, ms in rows:
            print(f"| {name} | {ms:.3f} |")
        print(f"\nC / NumPy per record: {c_ms / np_ms:.2f}\n")


if __name__ == "__main__":
    main()
