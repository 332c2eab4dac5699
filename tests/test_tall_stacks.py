"""Tall stacks: the stability limit from 100 moving bodies on comes from the band path
(csrc/solver_band.c, O(n b^2)) instead of the dense Householder path (O(n^3): 800 drums took
114 s of set-up before; 0.14 s now, measured on this machine kind -- timings live in the notes,
not in asserts).

Reference: for a stack of identical drums the largest eigenvalue of the stack's stiffness over
mass grows smoothly and monotonically with the number of drums (adding a body adds modes; the
stiffest ones are local and converge), so dt_crit(n) decreases smoothly. The switch from the
dense (99 bodies) to the band path (100 bodies) must not show in that sequence: the step across
it equals its neighbours' steps to 5 % (measured 2.47e-6 and 2.45e-6 relative, against 2.54e-6
from 98 to 99, all dense or all band on either side). A wrong band entry or storage offset makes
a jump far larger than that (a dropped coupling of one body changes dt_crit by percent)."""
import numpy as np
import pytest

import pycolfrag as pcf


def dt_crit(n_drums):
    col = pcf.Column.from_drums([0.5] * n_drums, 1.0, 1.0)
    return pcf.simulate(col, np.zeros(2), 0.01, tail_s=0.0).dt_crit


def test_band_path_continues_the_dense_path():
    d = {n: dt_crit(n) for n in (98, 99, 100, 101)}
    assert d[98] > d[99] > d[100] > d[101]
    steps = [d[98] - d[99], d[99] - d[100], d[100] - d[101]]
    assert steps[1] == pytest.approx(steps[0], rel=0.05) and steps[1] == pytest.approx(steps[2], rel=0.05)


def test_800_drums_set_up_and_run():
    """The case that took 114 s before: 800 drums on a 2-sample record (a few steps) set up and run."""
    col = pcf.Column.from_drums([0.5] * 800, 1.0, 1.0)
    r = pcf.simulate(col, np.zeros(2), 0.01, tail_s=0.005)
    assert not r.collapsed and np.isfinite(r.dt_crit) and r.dt_crit == pytest.approx(dt_crit(150), rel=1e-4)
