"""Plots of one run (:mod:`.response`: top displacement, joints, energy, snapshots, animation), their
shared style (:mod:`.base`) and scenes (:mod:`.scene`). matplotlib is imported here, never by the
layers below."""
from pycolfrag.plots.response import *  # noqa: F401,F403
from pycolfrag.plots.response import __all__  # noqa: F401
