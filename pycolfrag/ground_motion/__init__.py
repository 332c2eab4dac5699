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

from typing import NamedTuple

import numpy as np

from pycolfrag.core.errors import ParameterError
from pycolfrag.core.validate import float_array, positive_float
from pycolfrag.ground_motion import (
    baker_2007,
    mavroeidis_papageorgiou_2003,
    pulse_shape,
    registry,
    rupakhety_2011,
    shahi_baker_2014,
)
from pycolfrag.ground_motion.mavroeidis_papageorgiou_2003 import _int_seed as _seed
from pycolfrag.ground_motion.record import Record

__all__ = ["Record", "stochastic", "synthesize", "sample_pulse_parameters", "NormalsLayout", "normals_layout",
           "draw_normals", "read_at2",
           "atkinson_silva_2000", "mavroeidis_papageorgiou_2003", "rupakhety_2011", "baker_2007", "shahi_baker_2014",
           "pulse_shape", "registry", "combine", "plots", "PULSE_STREAM"]

def sample_pulse_parameters(Mw, dist_km, n, seed, vp_scale=1.0, tp_model=registry.DEFAULT_TP_MODEL,
                            shape=registry.DEFAULT_PULSE_SHAPE, amplitude=True, vp_model=""):
    """A sample of ``n`` pulses of the shape named ``shape`` (a key of :data:`registry.PULSE_SHAPES`;
    default the paper's, whose Latin hypercube :func:`mavroeidis_papageorgiou_2003.sample_parameters`
    describes with the returned keys) for the scenario (Mw, dist_km km), the pulse period from the
    relation named ``tp_model`` (a key of :data:`registry.TP_MODELS`), the median Vp from the pulse-amplitude
    relation named ``vp_model`` (a key of :data:`registry.VP_MODELS`; empty: Eq. (6)): the names looked up here, the
    sampling in the shape's module, so a model need not import the registry that lists it.
    ``amplitude=False`` leaves out derived values that cost a search per sample (mp03: ``A_cm_s``);
    the rest keep their bits (a grid's rows need only the shape's ``INPUTS``)."""
    model = registry.pulse_shape_of(shape)
    return model.sample_parameters(Mw, dist_km, n, seed, vp_scale, registry.tp_model_of(tp_model),
                                   amplitude=amplitude, vp_model=registry.vp_model_of(vp_model))


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
        from pycolfrag.ground_motion.at2 import read_at2  # loads C on first use (see above)
        return read_at2
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def _scenario(Mw, dist_km):
    from pycolfrag.ground_motion import atkinson_silva_2000 as as00  # loads C: the package must import without it
    as00.check_scenario(Mw, dist_km)
    return rupakhety_2011.check_scenario(Mw, dist_km)


def stochastic(Mw, dist_km, seed=None, dt=0.005, normals=None) -> Record:
    """High-frequency record only (Boore's stochastic method, Atkinson & Silva 2000).

    Parameters
    ----------
    Mw : float, moment magnitude
    dist_km : float, distance, km
    seed : int (>= 0), noise seed; or None when ``normals`` are given
    dt : float, s
    normals : array_like or None, instead of ``seed``: the white noise itself
        (``normals_layout(Mw, dist_km, dt, shape="none").noise`` standard normals;
        :func:`atkinson_silva_2000.simulate`). ``normals=draw_normals(Mw, dist_km, seed)`` gives
        bitwise the record of ``seed``.

    Returns
    -------
    Record with ``meta``: ``Mw``, ``dist_km``, ``seed`` (None when made from normals), ``dt_s``,
    ``generator`` and the generator's details prefixed ``hf_`` (``hf_duration_s``,
    ``hf_window_start_s``, ``hf_nfft``).
    """
    from pycolfrag.ground_motion import atkinson_silva_2000 as as00  # loads C: the package must import without it
    from pycolfrag.ground_motion.synthesis import _generator_meta, _stochastic_meta  # as00 (above)
    dt = positive_float(dt, "dt")
    seed = None if seed is None else _seed(seed)
    acc, info = as00.simulate(Mw, dist_km, seed, dt=dt, normals=normals)
    return Record(acc, dt, meta=_stochastic_meta(float(Mw), float(dist_km), seed, dt, _generator_meta(info)))


class NormalsLayout(NamedTuple):
    """How many standard normals a synthetic record is made from: ``pulse`` quantiles (the shape's
    ``NORMALS``; 0 for the stochastic record alone) then ``noise`` white-noise samples."""

    pulse: int
    noise: int

    @property
    def size(self) -> int:
        """The length of ``normals``: ``pulse + noise``."""
        return self.pulse + self.noise


def normals_layout(Mw, dist_km, dt=0.005, shape=registry.DEFAULT_PULSE_SHAPE) -> NormalsLayout:
    """The :class:`NormalsLayout` of the records of a scenario: for :func:`synthesize` with the pulse
    shape ``shape`` (``synthesize(normals=z)`` takes ``z[:pulse]`` as the pulse's quantiles and
    ``z[pulse:]`` as the noise), or, with ``shape="none"``, for :func:`stochastic` (noise only). The
    noise count is ``floor(2 T_gm / dt) + 1`` (about 2 400 at Mw 6.25, 10 km, dt 0.005 s)."""
    from pycolfrag.ground_motion import atkinson_silva_2000 as as00  # loads C: the package must import without it
    n_pulse = 0 if shape == registry.NO_PULSE else len(registry.pulse_shape_of(shape).NORMALS)
    return NormalsLayout(n_pulse, as00.n_normals(Mw, dist_km, dt))


def draw_normals(Mw, dist_km, seed, dt=0.005):
    """The white-noise normals the seed ``seed`` draws for the scenario's high-frequency record
    (:func:`atkinson_silva_2000.draw_normals`): ``stochastic(Mw, dist_km, normals=draw_normals(Mw,
    dist_km, seed))`` is ``stochastic(Mw, dist_km, seed)`` bit for bit, and ``synthesize(Mw, dist_km,
    pulse=row, normals=draw_normals(Mw, dist_km, seed))`` is ``synthesize(Mw, dist_km, seed, pulse=row)``."""
    from pycolfrag.ground_motion import atkinson_silva_2000 as as00  # loads C: the package must import without it
    return as00.draw_normals(Mw, dist_km, seed, dt)


def _split_normals(normals, model, pulse, n_noise):
    """(pulse quantiles or None, noise) of ``normals``: the shape's ``NORMALS`` first unless a pulse
    row is given, then the ``n_noise`` white-noise normals; ParameterError for another length."""
    z = float_array(normals, "normals")
    n_pulse = 0 if pulse is not None else len(model.NORMALS)
    if z.size != n_pulse + n_noise:
        what = (f"the pulse row is given, so only the {n_noise} white-noise normals" if pulse is not None else
                f"{n_pulse} pulse quantiles ({', '.join(model.NORMALS)}) then {n_noise} white-noise normals")
        raise ParameterError(f"normals has {z.size} values; synthesize takes {n_pulse + n_noise} here: {what}")
    return (None if pulse is not None else z[:n_pulse]), z[n_pulse:]


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


def _checked_row(synth, seed, pulse) -> tuple:
    """(seed, pulse inputs, where they come from) of a record of the prepared scenario ``synth``
    (:mod:`pycolfrag.ground_motion.synthesis`) as its ``record`` takes them, checked as :func:`synthesize`
    checks them (its messages): ``seed`` an integer in [0, 2**64), ``pulse`` a dict with the shape's
    ``INPUTS`` in their ranges, or None for synthesize's draw from the seed (without a pulse: no inputs)."""
    from pycolfrag.ground_motion import atkinson_silva_2000 as as00  # loads C: the package must import without it
    seed = as00._check_seed(_seed(seed))
    if synth.model is None:
        return seed, None, "none"
    inputs = _pulse_row(synth.Mw, synth.dist_km, seed, synth.vp_scale, pulse, synth.model)
    return seed, inputs, "seed" if pulse is None else "argument"


def _pulse_and_noise(Mw, dist_km, dt, vp_scale, pulse, model, normals):
    """(the pulse row or None, where it comes from, the white-noise normals or None): a row given, a
    seeded draw (``pulse`` None, no normals), or the pulse and noise parts of ``normals``."""
    if normals is None:
        return pulse, ("seed" if pulse is None else "argument"), None
    from pycolfrag.ground_motion import atkinson_silva_2000 as as00  # loads C: the package must import without it
    z_pulse, noise = _split_normals(normals, model, pulse, as00.n_normals(Mw, dist_km, dt))
    if z_pulse is None:
        return pulse, "argument", noise
    return model.parameters_from_normals(Mw, dist_km, z_pulse, vp_scale), "normals", noise


def synthesize(Mw, dist_km, seed=None, dt=0.005, vp_scale=1.0, pulse=None, match_polarity=True,
               shape=registry.DEFAULT_PULSE_SHAPE, normals=None) -> Record:
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
    Mw : float; dist_km : float, km; seed : int (>= 0), or None when ``normals`` are given
    dt : float, s; vp_scale : float (> 0), multiplies the Eq. (6) mean Vp; pulse : dict or None
    match_polarity : bool, flip the HF record's sign to match the pulse (default True); shape : str
    normals : array_like or None, instead of ``seed`` (layout: :func:`normals_layout`): the pulse's
        quantiles (the shape's ``NORMALS``, mapped by its ``parameters_from_normals``), then the white
        noise of step 1 (with a ``pulse`` row, the noise alone). The record is a pure function of them;
        ``normals=draw_normals(Mw, dist_km, seed)`` with a pulse row gives bitwise the seed's record.

    Returns
    -------
    Record
        ``acc`` m/s^2; ``meta`` with ``Mw``, ``dist_km``, ``seed``, ``vp_scale``, the shape's
        ``PARAMETERS`` (for "mp03": ``Vp_cm_s``, ``fp_hz``, ``nu_rad``, ``gamma``, ``t0_s``, ``Tp_s``,
        ``A_cm_s``, ``Ap_g``: peak |acc| of the sampled pulse alone, g), ``pulse_shape``,
        ``pulse_seeded_from`` ("seed", "argument" or "normals"; ``seed`` is None with normals),
        ``t_peak_s``, ``pad_before_s``, ``pad_after_s``, ``generator``, ``hf_*``; ``components``:
        ``"hf"`` (step 1, padded), ``"pulse"`` and ``"hf_modified"`` (step 5), all on the record's
        time axis. Same arguments give the same record, bit for bit, in any process.
    """
    from pycolfrag.ground_motion import atkinson_silva_2000 as as00  # loads C: the package must import without it
    from pycolfrag.ground_motion import synthesis  # loads C: the package must import without it
    model = registry.pulse_shape_of(shape)
    Mw_f, dist_f = _scenario(Mw, dist_km)
    dt = positive_float(dt, "dt")
    as00._exactly_one(seed, normals)
    seed = None if seed is None else _seed(seed)
    rupakhety_2011.mean_vp_cm_s(Mw_f, dist_f, vp_scale)   # ParameterError naming a bad vp_scale
    vp_scale_f = float(vp_scale)
    pulse, source, noise = _pulse_and_noise(Mw_f, dist_f, dt, vp_scale_f, pulse, model, normals)
    prepared = model.prepare(*_pulse_row(Mw_f, dist_f, seed, vp_scale_f, pulse, model))
    hf, info = as00.simulate(Mw_f, dist_f, seed, dt=dt, normals=noise)             # step 1
    return synthesis.near_fault(Mw_f, dist_f, seed, dt, vp_scale_f, model, prepared, hf,    # steps 2-6
                                synthesis._generator_meta(info), match_polarity=match_polarity, source=source)
