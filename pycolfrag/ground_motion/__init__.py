"""Ground motions: synthetic near-fault records (paper steps 1-6), natural records, Record.

Quick start (one near-fault record, Mw 6.5 at 10 km, and its debug plots)::

    import pycolfrag as pcf
    rec = pcf.ground_motion.synthesize(6.5, 10.0, seed=1)
    pcf.ground_motion.plots.plot_components(rec).savefig("record.png")

Modules, one per published model (docs/ground_motion.md):

* :mod:`.atkinson_silva_2000` -- high-frequency part, Boore's stochastic method (C generator);
* :mod:`.mavroeidis_papageorgiou_2003` -- the velocity pulse (Eq. 5) and its LHS sampling: pulse shape "mp03";
* :mod:`.pulse_shape` -- the interface every pulse shape offers (``registry.PULSE_SHAPES``);
* :mod:`.rupakhety_2011` -- mean pulse amplitude and frequency (Eqs. 6-7);
* :mod:`.baker_2007` -- an alternative pulse-period relation (``--tp-model baker_2007``);
* :mod:`.shahi_baker_2014` -- the probability that a near-fault motion carries a pulse;
  :mod:`.shahi_baker_earlier` -- the earlier model of the same form, its epistemic alternative;
* :mod:`.registry` -- the models that declare their parameters (``PARAMETERS``) and what is built
  from them (the pulse shapes, the pulse fields of a sample row, the ``--tp-model`` choices);
* :mod:`.combine` -- Fourier-amplitude combination (steps 3-6);
* :mod:`.at2` -- PEER NGA ``.AT2`` files; :mod:`.record` -- :class:`Record`; :mod:`.plots`.
"""
from __future__ import annotations

import math

import numpy as np

from .._validate import positive_float
from ..errors import ParameterError
from . import baker_2007, mavroeidis_papageorgiou_2003, pulse_shape, record, registry, rupakhety_2011, shahi_baker_2014
from .mavroeidis_papageorgiou_2003 import _int_seed as _seed
from .record import Record

__all__ = ["Record", "stochastic", "synthesize", "sample_pulse_parameters", "read_at2",
           "atkinson_silva_2000", "mavroeidis_papageorgiou_2003", "rupakhety_2011", "baker_2007", "shahi_baker_2014",
           "pulse_shape", "registry", "combine", "plots", "PULSE_STREAM"]

def sample_pulse_parameters(Mw, dist_km, n, seed, vp_scale=1.0, tp_model=registry.DEFAULT_TP_MODEL,
                            shape=registry.DEFAULT_PULSE_SHAPE, amplitude=True):
    """A sample of ``n`` pulses of the shape named ``shape`` (a key of :data:`registry.PULSE_SHAPES`;
    default the paper's, whose Latin hypercube :func:`mavroeidis_papageorgiou_2003.sample_parameters`
    describes with the returned keys) for the scenario (Mw, dist_km km), the pulse period from the
    relation named ``tp_model`` (a key of :data:`registry.TP_MODELS`): the names looked up here, the
    sampling in the shape's module, so a model need not import the registry that lists it.
    ``amplitude=False`` leaves out derived values that cost a search per sample (mp03: ``A_cm_s``);
    the rest keep their bits (a grid's rows need only the shape's ``INPUTS``)."""
    model = registry.pulse_shape_of(shape)
    return model.sample_parameters(Mw, dist_km, n, seed, vp_scale, registry.tp_model_of(tp_model),
                                   amplitude=amplitude)


#: Second word of the SeedSequence that seeds the pulse draw of ``synthesize(pulse=None)``:
#: ``SeedSequence([seed, PULSE_STREAM])``, so the pulse stream never equals the HF noise stream.
PULSE_STREAM = 0x70756C73  # "puls"


def __getattr__(name):
    # The stochastic model, the combination, the plots and the AT2 reader load on first use: they load
    # the C library at import, and this package's declarations (registry) must be readable without it.
    if name in ("atkinson_silva_2000", "combine", "plots", "at2"):
        import importlib  # only on this path
        return importlib.import_module(f"{__name__}.{name}")
    if name == "read_at2":
        from .at2 import read_at2  # loads C on first use (see above)
        return read_at2
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def _scenario(Mw, dist_km):
    from . import atkinson_silva_2000 as as00  # loads C: the package must import without it
    as00.check_scenario(Mw, dist_km)
    return rupakhety_2011.check_scenario(Mw, dist_km)


def stochastic(Mw, dist_km, seed, dt=0.005) -> Record:
    """High-frequency record only (Boore's stochastic method, Atkinson & Silva 2000).

    Parameters
    ----------
    Mw : float, moment magnitude
    dist_km : float, distance, km
    seed : int (>= 0), noise seed
    dt : float, s

    Returns
    -------
    Record with ``meta``: ``Mw``, ``dist_km``, ``seed``, ``dt_s``, ``generator`` and the
    generator's details prefixed ``hf_`` (``hf_duration_s``, ``hf_window_start_s``, ``hf_nfft``).
    """
    from . import atkinson_silva_2000 as as00  # loads C: the package must import without it
    dt = positive_float(dt, "dt")
    seed = _seed(seed)
    acc, info = as00.simulate(Mw, dist_km, seed, dt=dt)
    meta = {**_keyed(record.PARAMETERS, (float(Mw), float(dist_km), seed, dt)), "kind": "stochastic"}
    meta.update(_generator_meta(info))
    return Record(acc, dt, meta=meta)


def _keyed(parameters, values) -> dict:
    """``{meta key: value}`` of declared parameters, in their order."""
    return {p.meta_key: v for p, v in zip(parameters, values, strict=True)}


def _generator_meta(info):
    out = {"generator": info.get("generator", "atkinson_silva_2000")}
    for k, v in info.items():
        if k != "generator":
            out[f"hf_{k}"] = v
    return out


def _pulse_row(Mw, dist_km, seed, vp_scale, pulse, shape):
    """The pulse inputs (the declared ``INPUTS`` of the shape's module: Vp_cm_s, fp_hz, nu_rad, gamma of
    the paper's) from the given row, or one draw seeded from ``seed``."""
    if pulse is None:
        ss = np.random.SeedSequence([seed, PULSE_STREAM])
        row = sample_pulse_parameters(Mw, dist_km, 1, int(ss.generate_state(1)[0]), vp_scale=vp_scale,
                                      shape=shape.SHAPE)
        pulse = {k: v[0] for k, v in row.items()}
    if not hasattr(pulse, "get"):
        raise ParameterError(f"pulse must be a dict of pulse parameters, got {type(pulse).__name__}")
    inputs = shape.INPUTS
    for p in inputs:
        if p.meta_key not in pulse:
            raise ParameterError(f"pulse is missing {p.meta_key!r} (needs {', '.join(q.meta_key for q in inputs)})")
    return tuple(p.check(pulse[p.meta_key], f"pulse[{p.meta_key!r}]", error=ParameterError) for p in inputs)


def _place(prepared, hf, dt, t_peak):
    """The pulse's epoch t0 that puts its velocity peak at t_peak (s), the HF record padded with whole
    samples of zeros where the pulse's support reaches past it, and the times counted from the first
    sample: (hf, t0, t_peak, n_pre, n_post)."""
    t0 = t_peak - prepared.peak_offset_s
    n_pre = max(0, int(math.ceil((prepared.before_s - t0) / dt - 1e-9)))
    t_last = (hf.size - 1) * dt
    n_post = max(0, int(math.ceil((t0 + prepared.after_s - t_last) / dt - 1e-9)))
    if n_pre or n_post:
        hf = np.concatenate([np.zeros(n_pre), hf, np.zeros(n_post)])
    return hf, t0 + n_pre * dt, t_peak + n_pre * dt, n_pre, n_post


def synthesize(Mw, dist_km, seed, dt=0.005, vp_scale=1.0, pulse=None, match_polarity=True,
               shape=registry.DEFAULT_PULSE_SHAPE) -> Record:
    """A near-fault record: stochastic HF part plus a velocity pulse (the paper's steps 1-6).

    1. HF record: :func:`atkinson_silva_2000.simulate` with ``seed``.
    2. Pulse: of the shape named ``shape`` (a key of :data:`registry.PULSE_SHAPES`; default the
       paper's Mavroeidis-Papageorgiou pulse, "mp03"), from ``pulse`` (a row of
       :func:`sample_pulse_parameters` of that shape; only its ``INPUTS`` are read -- for "mp03"
       ``Vp_cm_s``, ``fp_hz``, ``nu_rad``, ``gamma``, while ``A_cm_s`` and ``Tp_s`` are recomputed --
       and ``vp_scale`` is assumed already applied to that row and is only recorded), or, when
       ``pulse`` is None, one draw from the scenario distributions with
       ``sample_pulse_parameters(Mw, dist_km, 1, s, vp_scale, shape=shape)``, ``s`` the first 32-bit
       word of ``numpy.random.SeedSequence([seed, PULSE_STREAM])``. The shape's ``prepare`` gives the
       pulse (for "mp03": the envelope amplitude A makes the pulse's peak |V| equal Vp). The pulse
       is placed so its velocity peak falls on the time of the HF record's peak |velocity|
       (trapezoidal velocity): ``t0_s`` is its epoch. If the pulse's support starts before the
       record or ends after it, the record is padded with zeros there (whole samples), so the whole
       pulse is inside; times are then counted from the first padded sample (``pad_before_s``,
       ``pad_after_s`` in ``meta``).
       Polarity (our choice; the paper aligns times only): with ``match_polarity`` the HF record
       is multiplied by -1 when its peak velocity and the pulse's have opposite signs. The
       stochastic record's sign is arbitrary (symmetric Gaussian noise: -HF is as likely as HF),
       so this leaves both parts' distributions unchanged, and the pulse then adds to the HF
       velocity peak instead of cancelling it: over 200 records (5 scenarios x 40 seeds) the
       combined peak velocity was >= the pulse's in every case, against 0.71 of it at worst
       without (docs/ground_motion.md). ``meta["hf_polarity"]`` is +1 or -1.
    3-6. :func:`combine.combine` (FAS subtraction clipped at 0, HF phase, plus the pulse).

    Parameters
    ----------
    Mw : float; dist_km : float, km; seed : int (>= 0)
    dt : float, s; vp_scale : float (> 0), multiplies the Eq. (6) mean Vp
    pulse : dict or None
    match_polarity : bool, flip the HF record's sign to match the pulse (default True)
    shape : str, the pulse shape (default "mp03")

    Returns
    -------
    Record
        ``acc`` m/s^2; ``meta`` with ``Mw``, ``dist_km``, ``seed``, ``vp_scale``, the shape's
        ``PARAMETERS`` (for "mp03": ``Vp_cm_s``, ``fp_hz``, ``nu_rad``, ``gamma``, ``t0_s``, ``Tp_s``,
        ``A_cm_s``, ``Ap_g``: peak |acc| of the sampled pulse alone, g), ``pulse_shape``,
        ``t_peak_s``, ``pad_before_s``, ``pad_after_s``, ``generator``, ``hf_*``; ``components``:
        ``"hf"`` (step 1, padded), ``"pulse"`` and ``"hf_modified"`` (step 5), all on the record's
        time axis. Same arguments give the same record, bit for bit, in any process.
    """
    from . import atkinson_silva_2000 as as00  # loads C: the package must import without it
    from .combine import combine  # loads C: the package must import without it
    from ..intensity import integrate  # loads C: the package must import without it

    model = registry.pulse_shape_of(shape)
    Mw_f, dist_f = _scenario(Mw, dist_km)
    dt = positive_float(dt, "dt")
    seed = _seed(seed)
    rupakhety_2011.mean_vp_cm_s(Mw_f, dist_f, vp_scale)   # ParameterError naming a bad vp_scale
    vp_scale_f = float(vp_scale)
    prepared = model.prepare(*_pulse_row(Mw_f, dist_f, seed, vp_scale_f, pulse, model))

    hf, info = as00.simulate(Mw_f, dist_f, seed, dt=dt)                            # step 1
    vel_hf = integrate(hf, dt)[0]
    k_peak = int(np.argmax(np.abs(vel_hf)))
    t_peak = k_peak * dt

    polarity = 1.0                                                                  # step 2
    if match_polarity and prepared.peak_sign * vel_hf[k_peak] < 0:
        polarity = -1.0
        hf = -hf
    hf, t0, t_peak, n_pre, n_post = _place(prepared, hf, dt, t_peak)
    pulse_acc = prepared.acceleration(np.arange(hf.size) * dt, t0)                 # m/s^2

    acc = combine(hf, pulse_acc)                                                    # steps 3-6
    meta = {**_keyed(record.PARAMETERS, (Mw_f, dist_f, seed, dt)), "kind": "near-fault", "vp_scale": vp_scale_f,
            **_keyed(model.PARAMETERS, prepared.meta(t0, pulse_acc)), "pulse_shape": model.SHAPE,
            "t_peak_s": t_peak, "pad_before_s": n_pre * dt, "pad_after_s": n_post * dt,
            "hf_polarity": int(polarity), "pulse_seeded_from": "seed" if pulse is None else "argument"}
    meta.update(_generator_meta(info))
    return Record(acc, dt, meta=meta,
                  components={"hf": hf, "pulse": pulse_acc, "hf_modified": acc - pulse_acc})
