"""A batch's runs: how many in each stratum, in what order, and each run's inputs.

A run is named by (stage s, stratum h, index j); everything random about it comes from its own stream,
``SeedSequence(seed, spawn_key=(STREAM_SITE, s, h, j))``: the first word seeds the library's
xoshiro256** generator, whose :data:`N_NORMALS` standard normals place the event (Mw, R in their bins,
the mixture's component, the four pulse normals), the second is the seed of the record's
high-frequency noise. Uniforms are Phi of normals by the library's own CDF, and the inverse CDFs use the
library's exp and log (:mod:`pycolfrag.site.models`), so a run's inputs are the same bits on every CPU,
rank count and order of work. The pulse parameters are the pulse shape's own map of its standard
normals (z_vp, z_fp, z_nu, z_gamma) (``parameters_from_normals`` of the pulse-shape interface: the
inverse CDFs of the distributions the grid samples by Latin hypercube, the one map subset simulation
moves in too).

The order of a batch interleaves its strata (each stratum's rows at evenly spaced places), so that any
prefix of it -- a batch cut by the run budget -- is spread over the strata in proportion.
"""
from __future__ import annotations

import numpy as np

from pycolfrag.ground_motion.registry import pulse_shape_of, tp_model_of, vp_model_of
from pycolfrag.rare.strata import phi

__all__ = ["STREAM_SITE", "N_NORMALS", "event_streams", "event_normals", "interleave", "PulseMap", "event_input",
           "plan_inputs"]

#: Stream identifier of the site simulation's runs (the grid's streams are 1, Latin hypercube, and 2, noise).
STREAM_SITE = 3
#: Normals per run: Mw, R, the mixture's component, z_vp, z_fp, z_nu, z_gamma, one spare.
N_NORMALS = 8


def event_streams(seed: int, stage: int, stratum: int, index: int) -> tuple[int, int]:
    """(the event generator's seed, the record's noise seed) of run (stage, stratum, index): two 64-bit
    words of ``SeedSequence(seed, spawn_key=(STREAM_SITE, stage, stratum, index))``."""
    ss = np.random.SeedSequence(int(seed), spawn_key=(STREAM_SITE, int(stage), int(stratum), int(index)))
    a, b = ss.generate_state(2, dtype=np.uint64)
    return int(a), int(b)


def event_normals(rng_seed: int, n: int = N_NORMALS) -> np.ndarray:
    """``n`` standard normals of the library's generator (xoshiro256**, polar method) seeded with ``rng_seed``."""
    from pycolfrag.core.ffi import ffi, lib, ptr  # loads C on first use: reading this module needs no C library
    rng = ffi.new("cf_rng *")
    lib.cf_rng_seed(rng, int(rng_seed))
    out = np.empty(n)
    lib.cf_rng_normals(rng, ptr(out), n)
    return out


def interleave(new: dict, start: dict) -> list[tuple[int, int]]:
    """The runs (h, j) of a batch: ``new[h]`` runs of stratum h, indices ``start[h]`` onwards, each
    stratum's runs at the evenly spaced places (t + 1/2) / new[h] of the batch, ties by stratum."""
    keyed = [((t + 0.5) / k, h, start.get(h, 0) + t) for h, k in sorted(new.items()) for t in range(k)]
    keyed.sort()
    return [(h, j) for _, h, j in keyed]


class PulseMap:
    """The pulse shape's inputs from its standard normals (vp_scale, the pulse-period relation and the
    pulse-amplitude relation as the run's record settings say; ``vp_model`` empty: Eq. (6)):
    ``parameters_from_normals`` of the pulse-shape interface."""

    def __init__(self, shape: str, vp_scale: float, tp_model: str, vp_model: str = ""):
        self.module = pulse_shape_of(shape)
        self.vp_scale, self.tp_model = float(vp_scale), tp_model_of(tp_model)
        self.vp_model = vp_model_of(vp_model)

    def __call__(self, mw: float, r_km: float, z4) -> dict:
        row = self.module.parameters_from_normals(mw, r_km, z4, self.vp_scale, self.tp_model, self.vp_model)
        return {p.meta_key: float(row[p.meta_key]) for p in self.module.INPUTS}


def event_input(strata, seed: int, stage: int, h: int, j: int, mixture, pulse_map: PulseMap) -> dict:
    """The inputs of run (stage, h, j) (:class:`pycolfrag.grid.EventBatchSpec`'s), its tags included:
    identity, the normals, the occurrence weight, the sampling weight under ``mixture`` (the proposal of
    its stage) and the stratum's rate."""
    rng_seed, hf_seed = event_streams(seed, stage, h, j)
    x = event_normals(rng_seed)
    st = strata[h]
    mw, r = strata.place(h, x[0], x[1])
    occ = strata.occurrence_weight(h, r)
    tags = {"stage": int(stage), "stratum": int(h), "index": int(j), "source": int(st.source),
            "z_mw": float(x[0]) if st.mw[0] != st.mw[1] else None,
            "z_dist": float(x[1]) if st.r_km[0] != st.r_km[1] else None,
            "occurrence_weight": occ, "stratum_rate_per_yr": st.rate}
    pulse = None
    if st.pulse:
        k = mixture.component(phi(x[2]))
        mu = mixture.shift(k)
        z = (float(x[3]) + mu[0], float(x[4]) + mu[1], float(x[5]), float(x[6]))
        pulse = pulse_map(mw, r, z)
        tags.update(component=k, z_vp=z[0], z_fp=z[1], z_nu=z[2], z_gamma=z[3],
                    weight=occ * float(mixture.ratio(np.array([z[:2]]))[0]))
    else:
        tags.update(weight=occ)
    return {"mw": float(mw), "dist_km": float(r), "hf_seed": hf_seed, "pulse": pulse,
            "tags": {k: v for k, v in tags.items() if v is not None}}


def plan_inputs(strata, seed: int, stage: int, runs, mixture, pulse_map: PulseMap) -> list[dict]:
    """The inputs of the runs ``runs`` ((h, j) pairs, in the batch's order) of one stage."""
    return [event_input(strata, seed, stage, h, j, mixture, pulse_map) for h, j in runs]
