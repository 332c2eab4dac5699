"""Rare-event estimation of site risk (docs/rare_events.md): precise rates of rare damage levels and
collapse from far fewer runs than crude Monte Carlo. This file is a map; it imports nothing.

The stratified event-based site estimator (``pycolfrag risk SITE.toml --simulate OUTDIR``):

* :mod:`~pycolfrag.rare.strata` -- the strata of a site's events (source x Mw bin x R bin x pulse
  occurrence) with exact rates by quadrature, where the ground-motion models apply;
* :mod:`~pycolfrag.rare.proposal` -- the defensive mixture of the pulse quantiles (importance sampling),
  its balance-heuristic weights and the cross-entropy step that places it;
* :mod:`~pycolfrag.rare.plans` -- a batch's runs: which strata, and each run's inputs from its random
  stream (a pure function of the seed, its stage, stratum and index);
* :mod:`~pycolfrag.rare.estimate` -- the estimator, its variance, intervals and weight diagnostics;
* :mod:`~pycolfrag.rare.allocation` -- the minimax-CoV Neyman allocation of a batch, steered by a model
  that never enters the estimate;
* :mod:`~pycolfrag.rare.evaluator` -- running batches of explicit inputs through the grid's scheduler
  (``evaluate(name, inputs, purpose) -> rows``), the interface other algorithms run their runs through;
* :mod:`~pycolfrag.rare.driver` -- the site simulation: pilot, cross-entropy step, batches, the
  stopping rule, resume;
* :mod:`~pycolfrag.risk.simulate` -- its command line (``--simulate``; the report is
  :mod:`pycolfrag.risk.rare_route`).

The record-to-record tail within a scenario:

* :mod:`~pycolfrag.rare.subset` -- subset simulation of a rare response within one scenario, in the
  space of the standard normals a record is made from; it runs through an ``evaluate(batch) -> rows``
  interface (serial, processes, or MPI ranks: :mod:`~pycolfrag.rare.subset_mpi`); its stated CoV with the
  correlation between levels: :mod:`~pycolfrag.rare.subset_cov`; its command line:
  :mod:`pycolfrag.cli.subset` (``pycolfrag subset``).
"""
