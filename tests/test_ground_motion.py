"""Synthetic near-fault records (pycolfrag.ground_motion.synthesize, paper steps 1-6), Record,
stochastic(), the debug plots, and an orientation check against NGA-West2 (BSSA14, pygmm)."""
import hashlib
import math
import os
import subprocess
import sys

import matplotlib
import numpy as np
import pytest

matplotlib.use("Agg")

import pycolfrag as pcf  # noqa: E402
from pycolfrag.core.errors import ModelRangeError, ParameterError, PycolfragError  # noqa: E402
from pycolfrag.ground_motion import Record, sample_pulse_parameters, stochastic, synthesize  # noqa: E402
from pycolfrag.ground_motion import mavroeidis_papageorgiou_2003 as mp  # noqa: E402
from pycolfrag.ground_motion import rupakhety_2011 as r11  # noqa: E402
from pycolfrag.ground_motion.combine import combine  # noqa: E402
from pycolfrag.ground_motion.intensity import G, integrate  # noqa: E402

META_KEYS = ("Mw", "dist_km", "seed", "vp_scale", "Vp_cm_s", "fp_hz", "nu_rad", "gamma", "t0_s",
             "A_cm_s", "Ap_g", "Tp_s")   # docs/architecture.md, "Records"


def _digest(rec):
    h = hashlib.sha256(rec.acc.tobytes())
    for k in META_KEYS:
        h.update(repr(rec.meta[k]).encode())
    return h.hexdigest()


# ---------------------------------------------------------------- determinism
def test_same_arguments_same_record_in_process_and_subprocess():
    a = synthesize(6.5, 10.0, 42)
    b = synthesize(6.5, 10.0, 42)
    assert np.array_equal(a.acc, b.acc) and a.meta == b.meta
    code = ("import hashlib, pycolfrag.ground_motion as gm\n"
            "r = gm.synthesize(6.5, 10.0, 42)\n"
            "h = hashlib.sha256(r.acc.tobytes())\n"
            f"[h.update(repr(r.meta[k]).encode()) for k in {META_KEYS!r}]\n"
            "print(h.hexdigest())\n")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120, check=True)
    assert out.stdout.strip() == _digest(a)


def test_different_seeds_differ():
    a, b = synthesize(6.5, 10.0, 1), synthesize(6.5, 10.0, 2)
    assert a.meta["Vp_cm_s"] != b.meta["Vp_cm_s"]
    n = min(a.n, b.n)
    assert not np.allclose(a.acc[:n], b.acc[:n])
    # the same pulse row with two noise seeds: the HF parts differ, the pulse parameters not
    row = {k: v[3] for k, v in sample_pulse_parameters(6.5, 10.0, 10, 5).items()}
    c, d = synthesize(6.5, 10.0, 1, pulse=row), synthesize(6.5, 10.0, 2, pulse=row)
    assert c.meta["Vp_cm_s"] == d.meta["Vp_cm_s"] == row["Vp_cm_s"]
    assert not np.allclose(c.components["hf"][:n], d.components["hf"][:n])


# ---------------------------------------------------------------- contents
def test_meta_and_components():
    rec = synthesize(7.0, 7.5, 11)
    for k in META_KEYS:
        assert k in rec.meta and rec.meta[k] is not None
    m = rec.meta
    assert m["Mw"] == 7.0 and m["dist_km"] == 7.5 and m["seed"] == 11 and m["vp_scale"] == 1.0
    assert m["Tp_s"] == pytest.approx(1 / m["fp_hz"], rel=1e-15)
    assert m["A_cm_s"] == pytest.approx(mp.envelope_amplitude(m["Vp_cm_s"], m["fp_hz"], m["nu_rad"], m["gamma"]))
    hf, pulse = rec.components["hf"], rec.components["pulse"]
    assert hf.shape == pulse.shape == rec.acc.shape
    assert m["Ap_g"] == pytest.approx(np.abs(pulse).max() / G, rel=1e-15)
    # the record is exactly steps 3-6 applied to the stored parts
    np.testing.assert_array_equal(rec.acc, combine(hf, pulse))
    # the stored pulse is the closed form (C) on the record's time axis
    np.testing.assert_array_equal(pulse, mp.acceleration(rec.time, m["A_cm_s"] / 100, m["fp_hz"],
                                                         m["nu_rad"], m["gamma"], m["t0_s"]))
    # generator details are kept
    assert "generator" in m and "hf_duration_s" in m


def test_pulse_row_is_used_and_a_recomputed():
    table = sample_pulse_parameters(6.0, 12.5, 20, 77, vp_scale=1.3)
    row = {k: float(table[k][7]) for k in ("Vp_cm_s", "fp_hz", "nu_rad", "gamma")}   # no A, no Tp
    rec = synthesize(6.0, 12.5, 5, vp_scale=1.3, pulse=row)
    for k in row:
        assert rec.meta[k] == row[k]
    assert rec.meta["A_cm_s"] == pytest.approx(table["A_cm_s"][7], rel=1e-12)
    assert rec.meta["vp_scale"] == 1.3


def test_velocity_peaks_are_aligned():
    # step 2: the pulse's velocity peak coincides with the HF record's velocity peak (to one sample)
    for seed in range(5):
        rec = synthesize(6.5, 10.0, seed)
        v_hf = integrate(rec.components["hf"], rec.dt)[0]
        t_hf = np.argmax(np.abs(v_hf)) * rec.dt
        m = rec.meta
        t_pulse = mp.peak_velocity_time(m["fp_hz"], m["nu_rad"], m["gamma"], m["t0_s"])
        assert abs(t_pulse - t_hf) <= rec.dt * (1 + 1e-9)
        assert m["t_peak_s"] == pytest.approx(t_hf, abs=1e-12)


def test_padding_keeps_the_whole_pulse():
    # a long pulse (Tp = 10 s, gamma 3: 30 s of support) around the peak of a short Mw 5.5 record
    row = {"Vp_cm_s": 30.0, "fp_hz": 0.1, "nu_rad": 0.2, "gamma": 3.0}
    rec = synthesize(5.5, 20.0, 3, pulse=row)
    short = stochastic(5.5, 20.0, 3)
    m = rec.meta
    ts, te = mp.support(m["fp_hz"], m["gamma"], m["t0_s"])
    assert m["pad_before_s"] > 0 and m["pad_after_s"] > 0
    assert ts >= -1e-9 and te <= rec.duration + 1e-9
    n_pre = round(m["pad_before_s"] / rec.dt)
    assert rec.n == short.n + n_pre + round(m["pad_after_s"] / rec.dt)
    np.testing.assert_array_equal(np.abs(rec.components["hf"][n_pre:n_pre + short.n]), np.abs(short.acc))
    # the whole pulse is inside: its velocity (trapezoid of the closed-form acceleration) returns
    # to the closed-form residual at the end; sampled peak within 0.1 % of Vp (dt = 0.005 s vs 10 s)
    v_p = integrate(rec.components["pulse"], rec.dt)[0]
    assert np.abs(v_p).max() == pytest.approx(row["Vp_cm_s"] / 100, rel=1e-3)
    assert abs(v_p[-1]) < 1e-4


SCENARIOS = ((6.5, 10.0), (7.5, 5.0), (5.5, 20.0), (6.0, 15.0), (5.5, 5.0))


def test_combined_velocity_shows_the_pulse():
    # The combined record's peak velocity is at least the pulse's (the pulse shows). Measured over these
    # 40 records: min ratio 1.002, median 1.18 (with the HF polarity matched to the pulse; without,
    # min 0.71 -- see docs/ground_motion.md).
    for mw, r in SCENARIOS:
        for seed in range(8):
            rec = synthesize(mw, r, seed)
            v_c = np.abs(rec.velocity()).max()
            v_p = np.abs(integrate(rec.components["pulse"], rec.dt)[0]).max()
            assert v_c >= v_p, (mw, r, seed, v_c / v_p)


def test_combined_fourier_amplitude_follows_the_larger_part():
    # Steps 3-6 give |C| = |max(|H| - |P|, 0) e^{i phase H} + P| per frequency, so where the pulse
    # dominates C = P, and where HF dominates by 4x, |C| >= |H| - 2|P| >= |H|/2; the only other
    # change is the trimming of the inverse FFT to n samples. Band RMS over 10 log bands 0.2-20 Hz,
    # FFT grid of combine (power of two >= 2n). Measured on these 40 records: pulse-dominated bands
    # 0.99-1.04, HF-dominated 0.71-1.00, all bands <= 1.22.
    edges = np.geomspace(0.2, 20.0, 11)
    n_p = n_h = 0
    for mw, r in SCENARIOS[:4]:
        for seed in range(10):
            rec = synthesize(mw, r, seed)
            nfft = 1 << int(math.ceil(math.log2(2 * rec.n)))
            f = np.fft.rfftfreq(nfft, rec.dt)
            C, H, P = (np.abs(np.fft.rfft(x, nfft)) for x in (rec.acc, rec.components["hf"], rec.components["pulse"]))
            for lo, hi in zip(edges[:-1], edges[1:]):
                k = (f >= lo) & (f < hi)
                c, h, p = (math.sqrt(np.mean(x[k] ** 2)) for x in (C, H, P))
                assert c <= 1.3 * max(h, p)
                if p >= 2 * h:
                    n_p += 1
                    assert 0.9 <= c / p <= 1.1
                elif h >= 4 * p:
                    n_h += 1
                    assert 0.5 <= c / h <= 1.05
    assert n_p > 50 and n_h > 100       # both regimes were exercised


def test_medians_against_bssa14():
    # Orientation, not calibration: medians over 30 records at Mw 6.5, 10 km against NGA-West2 BSSA14
    # (pygmm, Rjb = 10 km, Vs30 760 m/s, strike-slip). Site difference: AS00 uses the Boore-Joyner
    # (1997) generic-rock amplification (Vs30 about 620 m/s), a little softer than 760, so our PGA is
    # expected somewhat above BSSA14; nothing is tuned to it.
    # * The HF (stochastic) records are what a GMPE describes: PGA and PGV within a factor 1.6.
    #   Measured: PGA ratio 1.44, PGV ratio 1.00.
    # * The combined records add a forward-directivity pulse whose median Vp (Rupakhety Eq. 6) is
    #   38.4 cm/s, 2.3x BSSA14's PGV (16.7 cm/s) by construction of the published models, so their
    #   PGV is compared with Eq. 6 instead (within 1.6; measured 1.24). Measured combined/BSSA14:
    #   PGA 1.79, PGV 2.85 (reported in docs/ground_motion.md, not asserted).
    pygmm = pytest.importorskip("pygmm")
    scen = pygmm.Scenario(mag=6.5, dist_jb=10.0, v_s30=760.0, mechanism="SS")
    bssa = pygmm.BooreStewartSeyhanAtkinson2014(scen)
    hf = np.array([[m["pga_g"], m["pgv_cm_s"]] for m in (stochastic(6.5, 10.0, s).measures() for s in range(30))])
    nf = np.array([[m["pga_g"], m["pgv_cm_s"]] for m in (synthesize(6.5, 10.0, s).measures() for s in range(30))])
    med_hf, med_nf = np.exp(np.log(hf).mean(0)), np.exp(np.log(nf).mean(0))
    assert 1 / 1.6 <= med_hf[0] / bssa.pga <= 1.6
    assert 1 / 1.6 <= med_hf[1] / bssa.pgv <= 1.6
    assert 1 / 1.6 <= med_nf[1] / r11.mean_vp_cm_s(6.5, 10.0) <= 1.6
    assert med_nf[1] > med_hf[1]


# ---------------------------------------------------------------- stochastic(), Record
def test_stochastic_record():
    rec = stochastic(6.0, 10.0, 9)
    assert isinstance(rec, Record) and rec.dt == 0.005
    assert rec.meta["Mw"] == 6.0 and rec.meta["seed"] == 9 and "generator" in rec.meta
    assert np.array_equal(rec.acc, stochastic(6.0, 10.0, 9).acc)
    assert not rec.components


def test_record_basics():
    acc = np.sin(np.linspace(0, 10, 501))
    rec = Record(acc.astype(np.float32), 0.02, meta={"a": 1})
    assert rec.acc.dtype == np.float64 and rec.n == 501
    assert rec.duration == pytest.approx(10.0) and rec.time[-1] == pytest.approx(10.0)
    v, d = integrate(rec.acc, rec.dt)
    np.testing.assert_array_equal(rec.velocity(), v)
    np.testing.assert_array_equal(rec.displacement(), d)
    assert rec.measures()["pga_g"] == pytest.approx(np.abs(rec.acc).max() / G)
    assert "Record(" in repr(rec)
    acc[0] = 5.0
    assert rec.acc[0] != 5.0   # a copy


@pytest.mark.parametrize("args, word", [
    (([0.0, np.nan], 0.01), "nan"),
    (([[0.0, 1.0]], 0.01), "acc"),
    (([0.0, 1.0], 0.0), "0.0"),
    (([0.0, 1.0], -1.0), "-1.0"),
    (([0.0, 1.0], float("inf")), "inf"),
])
def test_record_bad_input(args, word):
    with pytest.raises(ParameterError, match=word):
        Record(*args)
    with pytest.raises(ParameterError, match="components"):
        Record([0.0, 1.0], 0.01, components={"hf": [1.0]})


@pytest.mark.parametrize("kwargs, word", [
    ({"Mw": 9.0}, "Mw = 9"),
    ({"Mw": 3.0}, "Mw = 3"),
    ({"Mw": float("nan")}, "nan"),
    ({"Mw": "big"}, "big"),
    ({"dist_km": -5.0}, "dist_km = -5"),
    ({"dist_km": 500.0}, "dist_km = 500"),
    ({"dist_km": float("inf")}, "inf"),
    ({"dt": 0.0}, "0.0"),
    ({"dt": -0.005}, "-0.005"),
    ({"dt": float("nan")}, "nan"),
    ({"seed": -1}, "-1"),
    ({"seed": 2.5}, "2.5"),
    ({"vp_scale": 0.0}, "0.0"),
    ({"vp_scale": float("nan")}, "nan"),
    ({"pulse": {"Vp_cm_s": 30.0, "fp_hz": 0.5, "nu_rad": 0.0}}, "gamma"),
    ({"pulse": {"Vp_cm_s": -30.0, "fp_hz": 0.5, "nu_rad": 0.0, "gamma": 2.0}}, "-30.0"),
    ({"pulse": {"Vp_cm_s": 30.0, "fp_hz": float("nan"), "nu_rad": 0.0, "gamma": 2.0}}, "nan"),
])
def test_synthesize_bad_input(kwargs, word):
    args = {"Mw": 6.5, "dist_km": 10.0, "seed": 1, "dt": 0.005, "vp_scale": 1.0, "pulse": None}
    args.update(kwargs)
    with pytest.raises(ValueError) as ei:
        synthesize(args.pop("Mw"), args.pop("dist_km"), args.pop("seed"), **args)
    assert isinstance(ei.value, PycolfragError)
    assert word in str(ei.value)


def test_out_of_range_is_model_range_error():
    with pytest.raises(ModelRangeError):
        synthesize(8.5, 10.0, 1)
    with pytest.raises(ModelRangeError):
        stochastic(6.5, 0.0, 1)


# ---------------------------------------------------------------- plots
def test_plots_return_figures():
    from matplotlib.figure import Figure

    from pycolfrag.ground_motion import plots
    rec = synthesize(6.5, 10.0, 2)
    for fig in (plots.plot_record(rec), plots.plot_fourier(rec), plots.plot_spectra(rec, [0.2, 1.0, 3.0]),
                plots.plot_components(rec), plots.plot_record(rec.acc, dt=rec.dt),
                plots.plot_fourier(stochastic(6.5, 10.0, 2))):
        assert isinstance(fig, Figure) and fig.axes
        fig.canvas.draw() if hasattr(fig.canvas, "draw") else None
    with pytest.raises(ParameterError):
        plots.plot_components(stochastic(6.5, 10.0, 2))
    with pytest.raises(ParameterError):
        plots.plot_record(rec.acc)


def test_public_names():
    gm = pcf.ground_motion
    for name in ("Record", "stochastic", "synthesize", "sample_pulse_parameters", "read_at2",
                 "atkinson_silva_2000", "mavroeidis_papageorgiou_2003", "rupakhety_2011", "combine", "plots"):
        assert hasattr(gm, name)
    ims = pcf.intensity.measures(synthesize(6.5, 10.0, 1).acc, 0.005)
    assert ims["sa_g"].shape == (5,)


def test_readme_three_line_example(tmp_path):
    """docs/ground_motion.md's three-line example, in a fresh interpreter (so no
    earlier test has imported the plots submodule for it): it must write the figure."""
    code = ("import pycolfrag as pcf\n"
            "rec = pcf.ground_motion.synthesize(6.5, 10.0, seed=1)\n"
            "pcf.ground_motion.plots.plot_components(rec).savefig('record.png')\n")
    env = dict(os.environ, MPLBACKEND="Agg")
    p = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, env=env, capture_output=True, text=True)
    assert p.returncode == 0, p.stderr
    assert (tmp_path / "record.png").stat().st_size > 10_000
