"""The top layer: the ``pycolfrag`` command (:mod:`.main`), the grid command with its analysis after
the run (:mod:`.grid`), and the commands that were scripts of the checkout (:mod:`.figures`,
:mod:`.validation`, :mod:`.record_checks`) or a package's ``__main__`` (:mod:`.openquake`). Nothing
imports this package."""
