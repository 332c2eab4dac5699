"""Site risk, above the rare-event estimator (:mod:`pycolfrag.rare`) and the analysis
(:mod:`pycolfrag.analysis`): the grid route (:mod:`.site_risk`, ``pycolfrag risk``: fragility x hazard,
with its cells, fits, weights, branches, uncertainty, report and figures), the rare-event route's runner
(:mod:`.simulate`, ``--simulate``) and its reports (:mod:`.rare_route`, :mod:`.rare_like`,
:mod:`.rare_figures`)."""
