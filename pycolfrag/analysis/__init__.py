"""Analysis of results files: everything that reads what a grid wrote.

* :mod:`~pycolfrag.analysis.data` -- every reader of a results file (``load``, ``read_results``, ``read_table``);
* :mod:`~pycolfrag.analysis.summary` -- the summary tables a grid prints when it ends;
* :mod:`~pycolfrag.analysis.fragility` -- the statistics: Eqs. (1)-(4), surfaces, stripes, fits (numpy/scipy only);
* :mod:`~pycolfrag.analysis.outputs` -- fragility output formats, one writer each in one registry;
* :mod:`~pycolfrag.analysis.figures`, :mod:`~pycolfrag.analysis.report`, :mod:`~pycolfrag.analysis.validation`
  -- the paper's figures, the markdown report, docs/validation.md;
* :mod:`~pycolfrag.analysis.record_report`, :mod:`~pycolfrag.analysis.record_figures` -- record suites;
* :mod:`~pycolfrag.analysis.openquake` -- OpenQuake hazard curves in and fragility models out (site risk itself,
  which reads these, is the layer above: :mod:`pycolfrag.risk`);
* :mod:`~pycolfrag.analysis.compare` -- two results files, row by row.

No module here imports the grid driver, the rare-event estimator or the site risk, and the statistics (``fragility``, ``summary``, ``data``) import
no C binding (tests/test_analysis_package.py). ``import pycolfrag`` loads ``fragility`` (the public
``pcf.fragility``) and nothing else of this package.
"""
