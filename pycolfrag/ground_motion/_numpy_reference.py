"""Plain NumPy twin of the C stochastic generator (tests and benchmark only).

Written from ``pycolfrag/data/as00.json`` independently of ``csrc/stochastic.c``:
the coefficients are read from the JSON's formula strings (so this twin and the C
constants can be compared: the test requires the two target spectra to agree to
1e-10), the noise comes from ``numpy.random.default_rng(seed)`` (so records differ
from the C ones sample by sample; only their statistics agree) and the transforms
from ``numpy.fft``. Same recipe and the same choices as the C code (docs/stochastic.md):
window length 2 T_gm, padding max(10 s, 0.5/fa) each side, power-of-two length,
RMS over 0 < k < nfft/2, output from 1 s before the window to 3 s after it.
"""
from __future__ import annotations

import functools
import json
import math
import re
from importlib import resources

import numpy as np

_JSON = json.loads(resources.files("pycolfrag").joinpath("data/as00.json").read_text("utf-8"))
_NUM = r"[-+]?\d+(?:\.\d*)?(?:[eE][-+]?\d+)?"

PRE_S = 1.0     # kept before the window start, s
TAIL_S = 3.0    # kept after the window end, s
PAD_MIN_S = 10.0  # minimum zero padding each side, s


def _linear_in_m(text: str) -> tuple[float, float]:
    """'2.181 - 0.496*M' -> (2.181, -0.496)."""
    m = re.fullmatch(rf"\s*({_NUM})\s*([-+])\s*({_NUM})\s*\*\s*M\s*", text)
    if not m:
        raise ValueError(f"cannot parse {text!r}")
    return float(m.group(1)), float(m.group(3)) * (1 if m.group(2) == "+" else -1)


def _grab(pattern: str, text: str) -> list[float]:
    m = re.search(pattern, text)
    if not m:
        raise ValueError(f"{pattern!r} not found in {text!r}")
    return [float(g) for g in m.groups()]


def _coefficients(js: dict) -> dict:
    c = {}
    c["m0"] = _grab(rf"10\^\(({_NUM})\*M \+ ({_NUM})\)", js["moment"])
    src = js["source_spectrum"]
    c["fa"] = _linear_in_m(src["log10_fa"])
    c["fb"] = _linear_in_m(src["log10_fb"])
    c["eps"] = _linear_in_m(src["log10_eps"])
    k = js["constant"]
    c["C"] = k["radiation_R"] * k["partition_V"] * k["free_surface_F"] / (
        4.0 * math.pi * k["rho"] * k["beta"] ** 3 * k["R0_km"]) * 1e-20
    c["h"] = _linear_in_m(js["distance"].split("log10 h =")[1])
    c["r_cross"], _, c["g_exp"] = _grab(rf"R < ({_NUM}) km; \(1/({_NUM})\)\*\(\d+/R\)\^({_NUM})", js["geometric_spreading"])
    c["q0"], c["q_eta"], c["cq"] = _grab(rf"Q\(f\) = ({_NUM})\*f\^({_NUM}), cQ = ({_NUM})", js["anelastic"])
    c["kappa"], c["fmax"] = _grab(rf"kappa = ({_NUM}) s, fmax = ({_NUM})", js["diminution"])
    c["fmax_pow"] = _grab(rf"\(f/fmax\)\^({_NUM})", js["diminution"])[0]
    site = js["site_amplification_BJ97_generic_rock"]
    c["site_f"] = np.asarray(site["f_hz"], float)
    c["site_ln_amp"] = np.log(np.asarray(site["amp"], float))
    c["dur_src"], c["dur_path"] = _grab(rf"T_gm = ({_NUM})/fa \+ ({_NUM})\*R", js["duration"])
    w = js["window"]
    c["win_eps"], c["win_eta"] = float(w["eps"]), float(w["eta"])
    c["t_eta_factor"] = _grab(rf"({_NUM})\*T_gm", w["t_eta"])[0]
    return c


COEF = _coefficients(_JSON)


def source_path(Mw: float, dist_km: float) -> dict:
    """M0 (dyne-cm), fa, fb (Hz), eps, h, R (km), G(R), T_gm (s)."""
    c = COEF
    m0 = 10.0 ** (c["m0"][0] * Mw + c["m0"][1])
    fa = 10.0 ** (c["fa"][0] + c["fa"][1] * Mw)
    fb = 10.0 ** (c["fb"][0] + c["fb"][1] * Mw)
    eps = 10.0 ** (c["eps"][0] + c["eps"][1] * Mw)
    h = 10.0 ** (c["h"][0] + c["h"][1] * Mw)
    r = math.hypot(dist_km, h)
    g = 1.0 / r if r < c["r_cross"] else (1.0 / c["r_cross"]) * (c["r_cross"] / r) ** c["g_exp"]
    tgm = c["dur_src"] / fa + c["dur_path"] * r
    return dict(m0=m0, fa=fa, fb=fb, eps=eps, h=h, r=r, g=g, tgm=tgm)


def fourier_amplitude(f_hz, Mw: float, dist_km: float) -> np.ndarray:
    """Target acceleration FAS, m/s (as00.json's cm/s / 100); A(0) = 0."""
    c = COEF
    sp = source_path(Mw, dist_km)
    f = np.asarray(f_hz, dtype=float)
    out = np.zeros_like(f)
    pos = f > 0
    fp = f[pos]
    shape = (1 - sp["eps"]) / (1 + (fp / sp["fa"]) ** 2) + sp["eps"] / (1 + (fp / sp["fb"]) ** 2)
    q = c["q0"] * fp ** c["q_eta"]
    anelastic = np.exp(-np.pi * fp * sp["r"] / (q * c["cq"]))
    site = np.exp(np.interp(fp, c["site_f"], c["site_ln_amp"]))  # constant outside the table
    dimin = np.exp(-np.pi * c["kappa"] * fp) / np.sqrt(1 + (fp / c["fmax"]) ** c["fmax_pow"])
    out[pos] = c["C"] * sp["m0"] * shape * sp["g"] * anelastic * site * dimin * (2 * np.pi * fp) ** 2 / 100.0
    return out


def duration_s(Mw: float, dist_km: float) -> float:
    return source_path(Mw, dist_km)["tgm"]


def window(t, t_eta: float) -> np.ndarray:
    """Saragoni-Hart window of as00.json."""
    e, n = COEF["win_eps"], COEF["win_eta"]
    b = -e * np.log(n) / (1 + e * (np.log(e) - 1))
    cc = b / e
    a = (np.e / e) ** b
    x = np.asarray(t, float) / t_eta
    with np.errstate(divide="ignore", invalid="ignore"):
        w = a * np.where(x > 0, x, 0.0) ** b * np.exp(-cc * x)
    return np.where(x > 0, w, 0.0)


@functools.lru_cache(maxsize=16)
def _layout(Mw: float, dist_km: float, dt: float):
    sp = source_path(Mw, dist_km)
    t_eta = COEF["t_eta_factor"] * sp["tgm"]
    n_w = int(math.floor(t_eta / dt)) + 1
    n_pad = int(math.ceil(max(PAD_MIN_S, 0.5 / sp["fa"], PRE_S, TAIL_S) / dt))
    nfft = 1 << int(math.ceil(math.log2(2 * n_pad + n_w)))
    w = window(np.arange(n_w) * dt, t_eta)
    filt = fourier_amplitude(np.fft.rfftfreq(nfft, dt), Mw, dist_km) / dt
    n_pre, n_post = int(round(PRE_S / dt)), int(round(TAIL_S / dt))
    return sp, t_eta, n_w, n_pad, nfft, w, filt, n_pre, n_post


def simulate(Mw: float, dist_km: float, seed: int, dt: float = 0.005):
    """One record (m/s^2) by the SMSIM recipe in NumPy; returns (acc, info)."""
    sp, t_eta, n_w, n_pad, nfft, w, filt, n_pre, n_post = _layout(float(Mw), float(dist_km), float(dt))
    x = np.zeros(nfft)
    x[n_pad:n_pad + n_w] = np.random.default_rng(seed).standard_normal(n_w) * w
    z = np.fft.rfft(x)
    rms = np.sqrt(np.mean(np.abs(z[1:-1]) ** 2))
    acc = np.fft.irfft(z * (filt / rms), nfft)
    out = acc[n_pad - n_pre:n_pad + n_w + n_post].copy()
    info = {"duration_s": sp["tgm"], "window_s": t_eta, "window_start_s": n_pre * dt, "nfft": nfft,
            "generator": "NumPy reference twin (tests/benchmark)"}
    return out, info
