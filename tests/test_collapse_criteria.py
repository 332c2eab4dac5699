"""Collapse criteria measured against the block that moves as well as the face that carries it.

Case (reproduced from a hostile-input review): a 1 m tall, 1 cm wide square block on a 1 m
wide drum. Its static rocking threshold is g tan(alpha) with tan(alpha) = b / h_cg =
0.005 / 0.5 = 0.01, i.e. 0.01 g (rigid-block statics; Housner 1963); a constant 0.05 g for 1 s
exceeds it fivefold for far longer than the block's tipping time, so the block must overturn.
Before the fix overturning was measured only against the lower face's radius (0.5 m): the
needle tipped past 170 degrees and lay on the drum with collapsed=False and u_d = 21."""
import math

import numpy as np
import pytest

import pycolfrag as pcf
from pycolfrag.structure.column import Block, Column, Segment


@pytest.fixture(scope="module")
def needle_on_drum():
    lower = Block((Segment(0.5, 0.5, 0.5, n_sides=10),), name="drum")
    r = 0.005 * math.sqrt(2.0)   # a 1 cm wide square: circumradius b sqrt(2)
    upper = Block((Segment(1.0, r, r, n_sides=4, phase_rad=math.pi / 4),), name="needle")
    return Column([lower, upper])


def test_narrow_block_on_wide_drum_overturns(needle_on_drum):
    t = np.arange(0, 3.0, 0.005)
    acc = 0.05 * 9.81 * (t < 1.0)
    r = pcf.simulate(needle_on_drum, acc, 0.005)
    assert r.collapsed and r.collapse_block == 1 and r.collapse_reason == "overturning"
    # the criterion fires at a centre-of-mass offset of two circumradii (about twice the
    # slenderness angle): within the first half second of a fivefold overload
    assert 0.0 < r.collapse_time < 0.5
    assert math.isnan(r.u_d)


def test_narrow_block_below_its_threshold_stands(needle_on_drum):
    """Below the soft-joint uplift level the needle stands (guards against a criterion that
    fires on the narrow block's own small radius by mistake, and against the joint losing the
    drum's half of its area: the drum's vertices all lie outside the needle's 1 cm face).

    Reference (quasi-static, vertex springs of the whole joint area A = 1e-4 m^2 at +-b):
    rocking stiffness kn A b^2 = 2.5 N m/rad against the overturning gravity moment W h = 1.33
    N m/rad; the pre-compression W / (kn A) is used up (uplift) at
    a / g = (b / h) (1 - W h / (kn A b^2)) = 0.01 x 0.47 = 0.0047 g. A suddenly applied
    constant acceleration doubles the peak response of an undamped oscillator, so a step stands
    below about 0.0023 g: 0.002 g must stand. With half the area (the drum's share lost) the
    rocking stiffness 1.25 N m/rad is below W h: the needle fell at any acceleration."""
    t = np.arange(0, 2.0, 0.005)
    r = pcf.simulate(needle_on_drum, 0.002 * 9.81 * (t < 1.0), 0.005)
    assert not r.collapsed and r.u_top < 0.01
