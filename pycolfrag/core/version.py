"""The package's version, and when the package began to load: a leaf module (it imports nothing of
pycolfrag), the first one ``import pycolfrag`` runs."""
import time as _time

__version__ = "0.1.0"

#: When this package began to load (wall s since the epoch, process CPU s): where a grid rank's
#: imports begin in its timeline (pycolfrag.grid.timeline).
IMPORT_STARTED = (_time.time(), _time.process_time())
