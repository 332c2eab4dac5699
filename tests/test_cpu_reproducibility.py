"""Same numbers on other CPUs: synthetic records, their sampled pulse parameters and their
intensity measures are bitwise identical whatever CPU features numpy and glibc may use.

How the other machines are emulated (each in a fresh subprocess, because both libraries pick
their code paths once, at start-up):

* ``NPY_DISABLE_CPU_FEATURES``: numpy's dispatched loops (exp, log, power, sin, cos, ...) fall
  back to the baseline (SSE-level) code, as on a CPU without AVX2/AVX-512. numpy refuses to
  start if a named feature is unknown or absent on the machine, so the mask is built from the
  features this machine's numpy reports as found beyond its baseline (``X86_V3``, ``X86_V4``,
  ``AVX512_*``): on an AMD EPYC without AVX-512 it is just ``X86_V3``, on an Intel Xeon with
  AVX-512 it also names ``X86_V4 AVX512_ICL ...``.
* ``GLIBC_TUNABLES=glibc.cpu.hwcaps=-AVX2_Usable,-FMA_Usable,-AVX2,-FMA,-AVX512F``: glibc's libm
  uses its SSE2 variants of exp, log, pow, sin, cos instead of the FMA/AVX2 ones (which differ
  in the last bit), as on a CPU without FMA.

The expected values are those of the plain run on the same machine; the property tested is
equality, so the tolerance is zero (bit patterns compared through the raw bytes). On main at
c9942c1, before the library carried its own transcendental functions, the records differed
under both masks (see docs/reproducibility.md for the counts).

The column response (``pcf.simulate``) is compared too (the solver's set-up uses the library's
own cos/sin since it stopped calling libm), and so are the rows of a small grid run through
``scripts/run_grid.py``: every dataset of ``/samples`` and ``/spectra`` but the wall time.
"""
from __future__ import annotations

import json
import os
import subprocess
import sys

import numpy as np
import pytest

# (Mw, dist_km, seed): the paper's corners and centre; records are short (3-5 k samples).
RECORDS = [(6.5, 10.0, 1), (7.5, 5.0, 2), (5.5, 20.0, 3), (7.0, 15.0, 99)]
# LHS samples of the pulse parameters (the grid's draw): (Mw, dist_km, n, seed).
PULSE_SAMPLES = [(7.5, 5.0, 40, 12345), (6.0, 20.0, 40, 7)]

_CHILD = r"""
import sys, json
import numpy as np
import pycolfrag as pcf
from pycolfrag.ground_motion import sample_pulse_parameters
records, samples, out, with_sim = json.loads(sys.argv[1]), json.loads(sys.argv[2]), sys.argv[3], sys.argv[4] == "1"
arrays = {}
for mw, r, seed in records:
    rec = pcf.ground_motion.synthesize(mw, r, seed=seed)
    key = f"rec_{mw}_{r}_{seed}"
    arrays[key + "/acc"] = rec.acc
    for name in ("hf", "pulse"):
        arrays[key + "/" + name] = rec.components[name]
    arrays[key + "/pulse_params"] = np.array([rec.meta[k] for k in
        ("Vp_cm_s", "fp_hz", "nu_rad", "gamma", "A_cm_s", "t0_s", "Tp_s", "Ap_g")])
    ims = pcf.intensity.measures(rec.acc, rec.dt)
    for k, v in ims.items():
        arrays[key + "/im_" + k] = np.atleast_1d(np.asarray(v, dtype=float))
    if with_sim and seed == 1:
        res = pcf.simulate(pcf.Column.parthenon(), rec.acc, rec.dt)
        arrays["sim/response"] = np.array([res.u_top, res.u_d, res.max_top_disp, res.t_end, res.dt,
                                           res.dt_crit, float(res.n_steps), float(res.collapsed)])
        arrays["sim/residual_dislocation"] = np.asarray(res.residual_dislocation, dtype=float)
from pycolfrag.ground_motion.sampling import latin_hypercube
arrays["lhs_uniforms"] = latin_hypercube(4, 40, 12345)   # the grid's LHS (scipy's qmc.LatinHypercube numbers)
for mw, r, n, seed in samples:
    for k, v in sample_pulse_parameters(mw, r, n, seed).items():
        arrays[f"lhs_{mw}_{r}_{n}_{seed}/{k}"] = np.asarray(v, dtype=float)
np.savez(out, **arrays)
"""


def _numpy_mask():
    """NPY_DISABLE_CPU_FEATURES value masking every SIMD group this machine's numpy found
    beyond its baseline (never a feature it lacks: numpy would refuse to start)."""
    code = ("import json\n"
            "try:\n"
            "    from numpy._core import _multiarray_umath as m\n"
            "except ImportError:  # numpy < 2\n"
            "    from numpy.core import _multiarray_umath as m\n"
            "__cpu_baseline__, __cpu_dispatch__, __cpu_features__ = m.__cpu_baseline__, m.__cpu_dispatch__, m.__cpu_features__\n"
            "print(json.dumps([f for f in __cpu_dispatch__ if __cpu_features__.get(f) and f not in __cpu_baseline__]))")
    found = json.loads(subprocess.run([sys.executable, "-c", code], check=True, capture_output=True,
                                      text=True).stdout)
    return " ".join(found)


GLIBC_MASK = "glibc.cpu.hwcaps=-AVX2_Usable,-FMA_Usable,-AVX2,-FMA,-AVX512F"


def _run(tmp_path, name, extra_env, with_sim=True):
    env = {k: v for k, v in os.environ.items() if k not in ("NPY_DISABLE_CPU_FEATURES", "GLIBC_TUNABLES")}
    env.update(extra_env)
    out = tmp_path / f"{name}.npz"
    proc = subprocess.run([sys.executable, "-c", _CHILD, json.dumps(RECORDS), json.dumps(PULSE_SAMPLES),
                           str(out), "1" if with_sim else "0"], env=env, capture_output=True, text=True,
                          timeout=600)
    assert proc.returncode == 0, proc.stderr[-3000:]
    with np.load(out) as z:
        return {k: z[k] for k in z.files}


def _differences(plain, other, prefix_filter):
    """{array name: number of elements whose bit patterns differ}, for names passing the filter."""
    assert set(plain) == set(other)
    diff = {}
    for k in sorted(plain):
        if not prefix_filter(k):
            continue
        a, b = plain[k], other[k]
        assert a.shape == b.shape, k
        n = int(np.count_nonzero(a.view(np.uint64) != b.view(np.uint64)))
        if n:
            diff[k] = n
    return diff


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("cpu")
    mask = _numpy_mask()
    out = {"plain": _run(tmp, "plain", {})}
    if mask:
        out["numpy"] = _run(tmp, "numpy", {"NPY_DISABLE_CPU_FEATURES": mask})
    out["glibc"] = _run(tmp, "glibc", {"GLIBC_TUNABLES": GLIBC_MASK})
    return out


def _not_sim(k):
    return not k.startswith("sim/")


def test_numpy_mask_is_not_empty_on_x86_64():
    """The emulation means something only if this machine has dispatch targets to mask."""
    if os.uname().machine != "x86_64":
        pytest.skip("numpy's x86 dispatch groups exist only on x86-64")
    with open("/proc/cpuinfo") as fh:
        flags = fh.read()
    if " avx2" not in flags or " fma" not in flags:
        pytest.skip("this CPU has no AVX2/FMA: it is itself the older machine")
    assert "X86_V3" in _numpy_mask().split()


@pytest.mark.parametrize("emulation", ["numpy", "glibc"])
def test_records_pulses_and_ims_bitwise_equal(runs, emulation):
    if emulation not in runs:
        pytest.skip("numpy found no SIMD group beyond its baseline on this machine")
    diff = _differences(runs["plain"], runs[emulation], _not_sim)
    total = sum(v.size for k, v in runs["plain"].items() if _not_sim(k))
    assert not diff, f"{sum(diff.values())} of {total} values differ under {emulation}: {diff}"


@pytest.mark.parametrize("emulation", ["numpy", "glibc"])
def test_column_response_bitwise_equal(runs, emulation):
    if emulation not in runs:
        pytest.skip("numpy found no SIMD group beyond its baseline on this machine")
    diff = _differences(runs["plain"], runs[emulation], lambda k: k.startswith("sim/"))
    assert not diff, f"the column response differs under {emulation}: {diff}"


def _grid_rows(tmp_path, name, extra_env):
    """A small grid (Mw 7.5 and 6.0 at 5 km, 3 samples each, seed 99) in a child process."""
    import h5py
    env = {k: v for k, v in os.environ.items() if k not in ("NPY_DISABLE_CPU_FEATURES", "GLIBC_TUNABLES")}
    env.update(extra_env)
    out = tmp_path / f"grid_{name}.h5"
    root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    proc = subprocess.run([sys.executable, os.path.join(root, "scripts", "run_grid.py"), "--mw", "6.0", "7.5",
                           "--dist", "5", "--samples", "3", "--seed", "99", "--no-figures", "--no-progress",
                           "--out", str(out)], env=env, capture_output=True, text=True, timeout=900)
    assert proc.returncode == 0, proc.stdout[-2000:] + proc.stderr[-2000:]
    rows = {}
    with h5py.File(out, "r") as f:
        for group in ("samples", "spectra"):
            for k, v in f[group].items():
                if k != "wall_s" and v.dtype.kind == "f":
                    rows[f"{group}/{k}"] = v[()]
                elif k != "wall_s" and v.dtype.kind in "iub":
                    rows[f"{group}/{k}"] = v[()].astype(np.float64)
    return rows


def test_grid_rows_bitwise_equal_under_every_emulation(tmp_path):
    """End to end: the same grid rows on a machine without AVX2/AVX-512 in numpy's dispatch
    and without glibc's FMA/AVX2 libm variants (bit patterns compared, tolerance zero)."""
    plain = _grid_rows(tmp_path, "plain", {})
    assert np.isfinite(plain["samples/u_top"]).all() and plain["samples/u_top"].size == 6
    mask = _numpy_mask()
    emulations = {"glibc": {"GLIBC_TUNABLES": GLIBC_MASK}}
    if mask:
        emulations["numpy"] = {"NPY_DISABLE_CPU_FEATURES": mask}
    for name, env in emulations.items():
        other = _grid_rows(tmp_path, name, env)
        diff = _differences(plain, other, lambda k: True)
        assert not diff, f"grid rows differ under {name}: {diff}"


_LIBM_TRANSCENDENTALS = {"sin", "cos", "tan", "sincos", "exp", "exp2", "expm1", "log", "log2", "log10", "log1p",
                         "pow", "atan", "atan2", "asin", "acos", "sinh", "cosh", "tanh", "erf", "erfc", "cbrt",
                         "hypot"}


def test_library_imports_no_libm_transcendental():
    """The emulations above only see a libm call whose result differs between glibc's variants
    for the arguments used (the default column's cos/sin of multiples of pi/10 happen to agree),
    so the rule itself is checked statically: the extension must not import any libm
    transcendental function (sqrt, floor, fabs, ... are correctly rounded or exact and allowed).
    Fails, e.g., when make_face calls libm's cos instead of cf_math_cos."""
    import shutil

    import pycolfrag._libcolfrag as ext
    if shutil.which("nm") is None:
        pytest.skip("nm (binutils) not installed")
    out = subprocess.run(["nm", "-D", "--undefined-only", ext.__file__], capture_output=True, text=True,
                         check=True).stdout
    imported = {line.split()[-1].split("@")[0] for line in out.splitlines() if line.strip()}
    bad = sorted(imported & {n for f in _LIBM_TRANSCENDENTALS for n in (f, f + "f", f + "l")})
    assert not bad, f"the C library calls libm's {bad}: use csrc/cf_math.h (docs/reproducibility.md)"
