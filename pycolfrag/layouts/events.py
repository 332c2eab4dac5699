"""The rare route's row (root attribute ``layout = "events"``): one run of the stratified site simulation
(:mod:`pycolfrag.rare`), computed as a batch of events with explicit inputs
(:class:`pycolfrag.grid.EventBatchSpec`).

Owned by the rare side: its identity fields are what :mod:`pycolfrag.rare.plans` tags a run with (stage,
stratum, index, the standard normals it was drawn from, its weights) and what
:mod:`pycolfrag.rare.estimate` reads back; a change of the algorithm's tags is a change of this file. It
lives here, below the estimator, so that every reader of results files (:mod:`pycolfrag.analysis`, the
resume of :mod:`pycolfrag.results`) knows the layout without importing the estimator or the grid. The
inputs are the synthetic row's (:data:`pycolfrag.layouts.synthetic.INPUTS`): the run itself is one.
"""
from __future__ import annotations

import math

from pycolfrag.ground_motion import record as _gm_record
from pycolfrag.layouts.kind import RowKind, declared_fields
from pycolfrag.layouts.synthetic import INPUTS

__all__ = ["KIND"]

KIND = RowKind(
    name="events",
    identity={
        # identity of the run in the algorithm that asked for it
        "stage": ("i4", -1, "stage of the algorithm that asked for the run (site simulation: 0 the pilot, "
                            "1, 2, ... the production batches)"),
        "stratum": ("i4", -1, "stratum of the site's events (source x Mw bin x R bin x pulse occurrence)"),
        "index": ("i4", -1, "index of the run within its stage and stratum"),
        "source": ("i4", -1, "index of the site source (order of the site file)"),
        "pulse": ("u1", 0, "1: the motion carries a velocity pulse; 0: the stochastic record alone"),
        "component": ("i4", -1, "component of the pulse-parameter mixture that drew the run (0 the site's own "
                                "density, c >= 1 a shifted one; -1 no pulse)"),
        "hf_seed": ("u8", 0, "seed of the high-frequency noise of the record"),
        # the standard normals the event was drawn from (Phi of each is a CDF fraction)
        "z_mw": ("f8", math.nan, "standard normal whose Phi places Mw in its bin (NaN: one magnitude)"),
        "z_dist": ("f8", math.nan, "standard normal whose Phi places R in its bin (NaN: one distance)"),
        "z_vp": ("f8", math.nan, "standard normal quantile of the pulse amplitude Vp (NaN: no pulse)"),
        "z_fp": ("f8", math.nan, "standard normal quantile of the pulse frequency fp (NaN: no pulse)"),
        "z_nu": ("f8", math.nan, "standard normal whose Phi places the pulse phase nu (NaN: no pulse)"),
        "z_gamma": ("f8", math.nan, "standard normal whose Phi places the pulse's gamma (NaN: no pulse)"),
        # what the run stands for
        "weight": ("f8", math.nan, "sampling weight under the proposal that drew the run: the site's density of "
                                   "its pulse normals over the proposal's, times its pulse-occurrence weight, -"),
        "occurrence_weight": ("f8", math.nan, "pulse-occurrence weight: p(R) / the bin's mean p (pulse), (1 - p(R)) "
                                              "/ (1 - mean p) (no pulse), -"),
        "stratum_rate_per_yr": ("f8", math.nan, "annual rate of the run's stratum, 1/yr"),
        **declared_fields(_gm_record.PARAMETERS),        # mw, dist_km
    },
    inputs=INPUTS,
    named_by=("stage",),          # an event row is named by its stage (and stratum, index) in its algorithm
    owner="pycolfrag.rare (through pycolfrag.grid.EventBatchSpec)",
)
