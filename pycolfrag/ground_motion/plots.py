"""Debug plots of ground-motion records: histories, Fourier amplitude against the AS00 target,
response spectra, and the HF / pulse / sum panels of the paper's Fig. 5.

Every function takes a :class:`~pycolfrag.ground_motion.Record` (or an m/s^2 array with ``dt``
in s) and returns a matplotlib ``Figure`` built with the object-oriented API (no pyplot state,
nothing shown; works under the Agg backend). Units on the axes: time s, acceleration g,
velocity cm/s, displacement cm, Fourier amplitude m/s, periods s.

    import pycolfrag as pcf
    from pycolfrag.ground_motion import plots
    rec = pcf.ground_motion.synthesize(6.5, 10.0, seed=1)
    plots.plot_components(rec).savefig("fig5.png")
"""
from __future__ import annotations

import numpy as np
from matplotlib.figure import Figure

from pycolfrag.core.errors import ParameterError
from pycolfrag.ground_motion.intensity import G, integrate, response_spectrum
from pycolfrag.ground_motion.record import Record

__all__ = ["plot_record", "plot_fourier", "plot_spectra", "plot_components", "fourier_amplitude"]

_PERIODS = np.geomspace(0.05, 10.0, 80)


def _rec(rec, dt=None):
    if isinstance(rec, Record):
        return rec
    if dt is None:
        raise ParameterError("pass a Record, or an acceleration array (m/s^2) with dt (s)")
    return Record(rec, dt)


def fourier_amplitude(acc, dt):
    """One-sided Fourier amplitude |FFT(acc)| dt of a record (m/s for acc in m/s^2), without
    padding. Returns ``(f_hz, amplitude)`` without the DC term."""
    a = np.asarray(acc, dtype=float)
    amp = np.abs(np.fft.rfft(a)) * dt
    f = np.fft.rfftfreq(a.size, dt)
    return f[1:], amp[1:]


def _smooth(f, amp, n_bands=60):
    """RMS of ``amp`` in log-spaced bands (for a readable single-record FAS)."""
    edges = np.geomspace(f[0], f[-1], n_bands + 1)
    fc, out = [], []
    for lo, hi in zip(edges[:-1], edges[1:]):
        k = (f >= lo) & (f < hi)
        if k.any():
            fc.append(np.sqrt(lo * hi))
            out.append(np.sqrt(np.mean(amp[k] ** 2)))
    return np.array(fc), np.array(out)


def plot_record(rec, dt=None):
    """Acceleration (g), velocity (cm/s) and displacement (cm) histories (trapezoidal, from rest)."""
    r = _rec(rec, dt)
    vel, disp = integrate(r.acc, r.dt)
    fig = Figure(figsize=(8.0, 6.5), layout="constrained")
    axes = [fig.add_subplot(3, 1, i + 1) for i in range(3)]
    for a in axes[1:]:
        a.sharex(axes[0])
    t = r.time
    for a, y, lab, c in zip(axes, (r.acc / G, 100 * vel, 100 * disp),
                            ("acceleration (g)", "velocity (cm/s)", "displacement (cm)"), ("0.3", "C0", "C1")):
        a.plot(t, y, color=c, lw=0.8)
        a.set_ylabel(lab)
        k = int(np.argmax(np.abs(y)))
        a.plot(t[k], y[k], "o", ms=4, color="C3")
        a.annotate(f"{abs(y[k]):.3g}", (t[k], y[k]), textcoords="offset points", xytext=(4, 4), fontsize=8)
    axes[-1].set_xlabel("time (s)")
    axes[0].set_title(_title(r))
    return fig


def _title(r):
    m = r.meta
    if "Mw" in m and "dist_km" in m:
        s = f"Mw {m['Mw']:g}, R {m['dist_km']:g} km, seed {m.get('seed', '?')}"
        if "Vp_cm_s" in m:
            s += f"; pulse Vp {m['Vp_cm_s']:.3g} cm/s, Tp {1 / m['fp_hz']:.3g} s, gamma {m['gamma']:.3g}"
        return s
    return str(m.get("title", "record"))


def plot_fourier(rec, target=True, dt=None):
    """Fourier amplitude of the record (raw and band-smoothed) against the Atkinson & Silva
    (2000) target of its scenario (when ``target`` and the record's meta has ``Mw`` and
    ``dist_km``). For a combined record the pulse's part (``components["pulse"]``) is shown too;
    near fp the record follows the pulse, not the target."""
    r = _rec(rec, dt)
    f, amp = fourier_amplitude(r.acc, r.dt)
    fig = Figure(figsize=(7.0, 4.5), layout="constrained")
    ax = fig.add_subplot(1, 1, 1)
    ax.loglog(f, amp, color="0.75", lw=0.6, label="record")
    fs, ams = _smooth(f, amp)
    ax.loglog(fs, ams, color="k", lw=1.4, label="record, band RMS")
    if "pulse" in r.components:
        fp_, ap = fourier_amplitude(r.components["pulse"], r.dt)
        ax.loglog(fp_, ap, color="C1", lw=1.0, label="pulse")
    if target and "Mw" in r.meta and "dist_km" in r.meta:
        from pycolfrag.ground_motion import atkinson_silva_2000 as as00  # loads C, only for the target curve
        ax.loglog(f, as00.fourier_amplitude(f, r.meta["Mw"], r.meta["dist_km"]), "C0--", lw=1.4,
                  label="AS00 target")
    ax.set_xlim(max(f[0], 0.05), f[-1])
    positive = amp[amp > 0]
    if positive.size:
        ax.set_ylim(positive.max() * 1e-5, positive.max() * 3)
    ax.set_xlabel("frequency (Hz)")
    ax.set_ylabel("Fourier amplitude (m/s)")
    ax.set_title(_title(r))
    ax.legend(fontsize=8)
    return fig


def plot_spectra(rec, periods=None, damping=0.05, dt=None):
    """Pseudo-spectral acceleration (g) and relative velocity spectrum (cm/s) against period."""
    r = _rec(rec, dt)
    p = _PERIODS if periods is None else np.asarray(periods, dtype=float)
    s = response_spectrum(r.acc, r.dt, p, damping)
    fig = Figure(figsize=(8.0, 3.8), layout="constrained")
    a1, a2 = fig.add_subplot(1, 2, 1), fig.add_subplot(1, 2, 2)
    a1.semilogx(p, s["psa_m_s2"] / G, color="k")
    a2.semilogx(p, 100 * s["sv_m_s"], color="k")
    a1.set_ylabel(f"SA ({100 * damping:g} %, g)")
    a2.set_ylabel(f"SV ({100 * damping:g} %, cm/s)")
    for a in (a1, a2):
        a.set_xlabel("period (s)")
        a.grid(True, which="both", alpha=0.3)
    if "fp_hz" in r.meta:
        for a in (a1, a2):
            a.axvline(1 / r.meta["fp_hz"], color="C1", ls=":", lw=1, label="Tp = 1/fp")
        a2.legend(fontsize=8)
    fig.suptitle(_title(r), fontsize=9)
    return fig


def plot_components(rec, periods=None, damping=0.05):
    """The paper's Fig. 5 for a combined record: HF part, pulse, sum (acceleration row, velocity
    row) and their SA / SV spectra (last column)."""
    if not isinstance(rec, Record) or "hf" not in rec.components or "pulse" not in rec.components:
        raise ParameterError("plot_components needs a Record from synthesize() (components 'hf' and 'pulse')")
    p = _PERIODS if periods is None else np.asarray(periods, dtype=float)
    parts = [("high frequency", rec.components["hf"], "C0"), ("pulse", rec.components["pulse"], "C1"),
             ("combined", rec.acc, "k")]
    fig = Figure(figsize=(13.0, 5.5), layout="constrained")
    gs = fig.add_gridspec(2, 4)
    t = rec.time
    first = None
    for j, (name, acc, c) in enumerate(parts):
        aa = fig.add_subplot(gs[0, j], sharex=first)
        first = first or aa
        av = fig.add_subplot(gs[1, j], sharex=first)
        aa.plot(t, acc / G, color=c, lw=0.7)
        av.plot(t, 100 * integrate(acc, rec.dt)[0], color=c, lw=0.9)
        aa.set_title(name)
        av.set_xlabel("time (s)")
        if j == 0:
            aa.set_ylabel("acceleration (g)")
            av.set_ylabel("velocity (cm/s)")
    sa_ax, sv_ax = fig.add_subplot(gs[0, 3]), fig.add_subplot(gs[1, 3])
    for name, acc, c in parts:
        s = response_spectrum(acc, rec.dt, p, damping)
        sa_ax.semilogx(p, s["psa_m_s2"] / G, color=c, label=name)
        sv_ax.semilogx(p, 100 * s["sv_m_s"], color=c, label=name)
    sa_ax.set_ylabel(f"SA ({100 * damping:g} %, g)")
    sv_ax.set_ylabel(f"SV ({100 * damping:g} %, cm/s)")
    sv_ax.set_xlabel("period (s)")
    sa_ax.legend(fontsize=7)
    fig.suptitle(_title(rec), fontsize=10)
    return fig
