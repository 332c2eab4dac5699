"""``python -m pycolfrag COMMAND ...``: the ``pycolfrag`` command (:mod:`pycolfrag.commands`)."""
import sys

from .commands import main

if __name__ == "__main__":
    sys.exit(main())
