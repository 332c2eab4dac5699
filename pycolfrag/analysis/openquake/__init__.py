"""OpenQuake interchange and the IM route of site risk: hazard curves in, IM-based fragility out, and
OpenQuake's ``classical_damage`` convolution of the two (docs/risk.md, "IM route and OpenQuake").

Three pieces, none of which needs OpenQuake installed:

* :func:`read_hazard_curves` -- an OpenQuake hazard-curve CSV (``hazard_curve-mean-PGA_*.csv``):
  one metadata comment line (the current ``#,,,,"generated_by=..., investigation_time=50.0,
  imt='PGA'"`` or the older ``# ..., investigation_time=50.0, imt="PGA"``), a header
  ``[custom_site_id,]lon,lat[,depth],poe-<IML>,...`` and one row per site. The values are probabilities
  of exceedance in the investigation time T, not rates: the annual rate is ``-ln(1 - poe) / T`` (Poisson).
* :class:`ContinuousFragility`, :class:`DiscreteFragility`, :class:`FragilityModel` -- fragility
  functions with OpenQuake's semantics (``minIML``/``maxIML`` clipping, ``noDamageLimit``), built
  from pycolfrag's maximum-likelihood lognormal fits (:func:`fragility_from_results`) and written /
  read as NRML 0.5 ``fragilityModel`` (:func:`write_nrml`, :func:`read_nrml`). OpenQuake's
  continuous ``mean`` and ``stddev`` are the mean and standard deviation of the capacity IML itself,
  not a median and a log-dispersion: ``mean = median exp(beta^2 / 2)``,
  ``stddev = mean sqrt(exp(beta^2) - 1)`` (:meth:`ContinuousFragility.from_lognormal`).
* :func:`classical_damage` -- OpenQuake's classical damage algorithm: annual exceedance rates of
  the hazard levels; the rate of occurrence attributed to level i is the difference of the rates at
  the midpoints around it, ``(rate[i-1] - rate[i+1]) / 2`` (half differences at both ends: the rate
  above the highest level is not counted); the annual rate of exceeding a limit state is the sum of
  those rates times the fragility at each level; its probability in the risk investigation time
  ``T_r`` is ``1 - exp(-rate T_r)``; the damage-state probabilities are the differences of
  consecutive limit-state probabilities.

Command line::

    pycolfrag openquake export results/grid.h5 column_fragility.xml --im pga_g
    pycolfrag openquake damage hazard_curve-mean-PGA.csv column_fragility.xml --risk-time 50

Units are OpenQuake's: PGA and SA in g, PGV in cm/s (pycolfrag's ``pga_g``, ``sa_g``, ``pgv_cm_s``).
"""
from __future__ import annotations

from pycolfrag.analysis.openquake.damage import DiscretisationWarning, HazardRangeWarning, classical_damage, fine_rates
from pycolfrag.analysis.openquake.export import fragility_from_results
from pycolfrag.analysis.openquake.functions import (
           CROSSING_TOL,
           MIN_IML,
           ContinuousFragility,
           DiscreteFragility,
           FragilityModel,
)
from pycolfrag.analysis.openquake.hazard import (
           HazardCurves,
           annual_rates,
           im_of_imt,
           imt_of,
           occurrence_rates,
           read_hazard_curves,
)
from pycolfrag.analysis.openquake.nrml import read_nrml
from pycolfrag.analysis.outputs import NRML_NS, write_nrml

__all__ = ["NRML_NS", "MIN_IML", "HazardCurves", "read_hazard_curves", "imt_of", "im_of_imt", "annual_rates",
           "occurrence_rates", "ContinuousFragility", "DiscreteFragility", "FragilityModel",
           "classical_damage", "fine_rates", "HazardRangeWarning", "DiscretisationWarning", "CROSSING_TOL", "fragility_from_results", "write_nrml", "read_nrml"]
