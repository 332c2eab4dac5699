"""``python -m pycolfrag COMMAND ...``: the ``pycolfrag`` command (:mod:`pycolfrag.cli.main`)."""
import sys

from pycolfrag.cli.main import main

if __name__ == "__main__":
    sys.exit(main())
