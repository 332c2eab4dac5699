"""Site risk, above the rare-event estimator (:mod:`pycolfrag.rare`) and the analysis
(:mod:`pycolfrag.analysis`): the command ``pycolfrag risk`` (:mod:`.site_risk`), the grid route's
computation (:mod:`.grid_route`: fragility x hazard, with its cells, fits, weights, branches, uncertainty,
report and figures), the rare-event route's runner (:mod:`.simulate`, ``--simulate``) and its reports
(:mod:`.rare_route`, :mod:`.rare_like`, :mod:`.rare_figures`), logic trees over the model and site choices
(:mod:`.logic_tree`, :mod:`.tree_apply`, :mod:`.tree_stats`; on the grid route :mod:`.tree_grid`, on the
rare route :mod:`.tree_rare`, :mod:`.tree_rare_run`), and sequences of mainshocks at a site
(:mod:`.sequences`)."""
