"""Chipped joints missing a sector (docs/sequences.md, "As-built geometry: chipped joints"; the column file's
block key ``bottom_missing_sector = [start, end]``, docs/column_format.md): a block's bottom face bears nowhere
in the wedge of the angles [start, end) about its centre, in every contact model.

The closed forms, Housner's block (0.4 m square, half-width b = 0.2 m, 2 m tall: h_c = 1 m) on the ground:

* A, the sector [-60, 60) deg missing (120 deg, bisected by +x): what is left reaches along +x only to the
  corners where the wedge's edges leave the face, (b / tan 60, +-b) = (b / sqrt 3, +-b): pushed towards +x
  (the ground accelerating towards -x) the block lifts about the line through them, lever arm b / sqrt 3 =
  0.11547 m from its centre of mass (on its axis), at g (b / sqrt 3) / h_c; towards -x it still has its whole
  edge, at g b / h_c (Housner's).
* B, the half [-90, 90) missing and the block missing the part that would stand over it (0.08 m^3 centred at
  x = 0.15 m: its centre of mass at x = -0.08 * 0.15 / 0.24 = -0.05 m): the face's edge towards +x is the
  diameter, x = 0, lever arm 0.05 m: it lifts at g 0.05 / h_c towards +x and at g 0.15 / h_c towards -x.

The method is tests/test_as_built.py's quasi-static ramp and hold (2 s ramp, 6 s hold, planar), stiff joints
(kn = ks = 1e11 Pa/m): the block stands at 0.99x and overturns at 1.01x, so the tolerance is 1 % (the ramp's
resolution of the threshold is finer: measured by bisection, 12 halvings, the thresholds are vertex and
perimeter A 0.99810 (near) and 0.99963 (far), B 0.99644 and 0.99976 of the closed forms).

The exact model integrates a linear pressure over the compressed part of the face, so at lift-off the
resultant sits inside the edge by its soft-joint shift. Towards a whole edge (A far, B both ways: B's edge,
the diameter, is as long as the face's) it is the aligned face's 7.76 mm (tests/test_as_built.py) or a little
less for B's lighter block (measured: A far 0.96086, B 0.86724 and 0.95327 of the closed forms: 7.8, 6.6 and 7.0
mm); the test holds B between the closed form less that shift and the closed form. Towards A's corners the
face bears near the line of lift only on two slivers (of area sqrt 3 d^2 within d of it, not the 0.4 d of a
whole edge), so the shift is longer and shrinks slowly as the joints stiffen: measured 0.81313, 0.89258,
0.93945 of the closed form at kn = 1e11, 1e12, 1e13 Pa/m (21.6, 12.4, 7.0 mm). The test holds it at 1e13
between the closed form less 10 mm and the closed form.
"""
import math

import numpy as np
import pytest

import pycolfrag as pcf
from pycolfrag.core.errors import ParameterError
from pycolfrag.structure import as_built
from pycolfrag.structure.column import Block, Column

G = 9.81
JOINTS = pcf.JointProperties(kn=1e11, ks=1e11)
B, H_C = 0.2, 1.0
EXACT_SHIFT = B * (1.0 - 0.96124)       # the exact model's soft-joint shift towards a whole edge (m; test_as_built.py)
NEAR_A = B / math.sqrt(3.0)             # A's lever arm towards the missing sector, m


def block(sector=(), annulus=(0.0, 0.0), missing_part=(), joints=JOINTS):
    one = Column.single_block(2 * B, 2 * H_C, joints=joints)
    return Column((Block(one.blocks[0].segments, "block", bottom_annulus=annulus, missing_part=missing_part,
                         bottom_missing_sector=sector),), joints=joints)


def half_block():
    return block((-90.0, 90.0), missing_part=(0.08, 0.15, 0.0, 1.0))


def ramp_and_hold(col, level_g, contact, t_ramp=2.0, t_hold=6.0, dt=0.01):
    t = np.arange(0.0, t_ramp + t_hold, dt)
    return pcf.simulate(col, level_g * G * np.minimum(t / t_ramp, 1.0), dt, tail_s=0.0, planar=True, contact=contact)


def stands_then_overturns(col, sign, stands, overturns, contact):
    """Stands under sign * stands g, overturns (the block) under sign * overturns g."""
    assert not ramp_and_hold(col, sign * stands, contact).collapsed, (contact, sign, stands)
    r = ramp_and_hold(col, sign * overturns, contact)
    assert r.collapsed and r.collapse_block == 0, (contact, sign, overturns)


@pytest.mark.parametrize("contact", ["vertex", "perimeter", "exact"])
def test_block_missing_a_sector_lifts_about_the_corners_that_bound_what_is_left(contact):
    """A (module docstring): towards the missing sector (sign -1) at g (b / sqrt 3) / h_c, away from it at
    Housner's g b / h_c. Without the sector the first would be g b / h_c too (caught at 1.01x)."""
    col = block((-60.0, 60.0))
    shift = EXACT_SHIFT if contact == "exact" else 0.0
    stands_then_overturns(col, 1.0, 0.99 * (B - shift) / H_C, 1.01 * (B - shift) / H_C, contact)
    if contact == "exact":
        stiff = pcf.JointProperties(kn=1e13, ks=1e13)
        stands_then_overturns(block((-60.0, 60.0), joints=stiff), -1.0, 0.99 * (NEAR_A - 0.010) / H_C,
                              1.01 * NEAR_A / H_C, contact)
    else:
        stands_then_overturns(col, -1.0, 0.99 * NEAR_A / H_C, 1.01 * NEAR_A / H_C, contact)


@pytest.mark.parametrize("contact", ["vertex", "perimeter", "exact"])
def test_block_missing_half_its_face_lifts_about_the_diameter(contact):
    """B (module docstring): about the diameter (sign -1) at g 0.05 / h_c, about the far edge at g 0.15 / h_c;
    the exact model between the closed form less the aligned soft-joint shift and the closed form."""
    col = half_block()
    for sign, lever in ((-1.0, 0.05), (1.0, 0.15)):
        low = lever - (EXACT_SHIFT if contact == "exact" else 0.0)
        stands_then_overturns(col, sign, 0.99 * low / H_C, 1.01 * lever / H_C, contact)


def test_what_bears_and_its_support():
    """as_built.bearing: A's outline is the square less the wedge, its area b^2 (2 + 1 / sqrt 3) (the square's
    4 b^2 less the wedge's b^2 (2 - 1 / sqrt 3), integrated by hand); its support (convex hull) reaches
    b / sqrt 3 along +x. With an annulus (inner half-width b / 2) the hole's share, a quarter, goes too."""
    col = block((-60.0, 60.0))
    out = as_built.bearing(col, 0)
    assert as_built.area(out) == pytest.approx(B * B * (2.0 + 1.0 / math.sqrt(3.0)), rel=1e-12)
    assert max(x for x, _ in as_built.support(col, 0)) == pytest.approx(NEAR_A, rel=1e-12)
    ring = block((-60.0, 60.0), annulus=(0.5 * B * math.sqrt(2.0), 0.0))
    assert as_built.area(as_built.bearing(ring, 0)) == pytest.approx(0.75 * B * B * (2.0 + 1.0 / math.sqrt(3.0)),
                                                                    rel=1e-12)
    assert as_built.bearing(block(), 0) == []


@pytest.mark.parametrize("contact", ["vertex", "perimeter", "exact"])
def test_sector_with_an_annulus_stands_and_batch_runs_it_alike(contact):
    """An annulus missing a sector (both keys): the block stands at rest and under a weak motion, and the
    batch's lanes give the single run's bits."""
    col = block((-20.0, 30.0), annulus=(0.05 * math.sqrt(2.0), 0.0))
    t = np.arange(0.0, 2.0, 0.01)
    recs = [(a * G * np.sin(2 * np.pi * t), 0.01, 0.5 * a * G * np.cos(2 * np.pi * t), None) for a in (0.0, 0.05)]
    batch = pcf.simulate_batch(col, recs, tail_s=0.5, contact=contact)
    for (ax, dt, ay, _), rb in zip(recs, batch):
        r = pcf.simulate(col, ax, dt, acc_y=ay, tail_s=0.5, contact=contact)
        assert not r.collapsed
        assert (r.u_top, r.u_d, r.n_steps) == (rb.u_top, rb.u_d, rb.n_steps)


def test_bad_sectors_are_refused_by_name():
    seg = Column.single_block(2 * B, 2 * H_C).blocks[0].segments
    for bad, what in (((math.nan, 10.0), "must be finite"), ((0.0, math.inf), "must be finite"),
                      ((30.0, 30.0), r"\[30, 30\) deg is empty"), ((10.0, 370.0), r"\[10, 370\) deg is the whole face"),
                      ((-180.0, 180.0), "is the whole face"), ((10.0,), "must be two angles"), ("10", "must be two angles"),
                      (("10", 20.0), "bottom_missing_sector")):
        with pytest.raises(ParameterError, match=what):
            Block(seg, bottom_missing_sector=bad)
    # half or more of the face gone from under a centre of mass on the axis: it cannot stand
    with pytest.raises(ParameterError, match=r"joint 0: the centre of mass of blocks\[0:\] lies at \(0, 0\) m"):
        block((-90.0, 90.0))
    # an annulus and a sector that leave a sliver with (next to) no area
    with pytest.raises(ParameterError, match="has no area: a reduced face with no area"):
        block((0.0, 359.9999999999), annulus=(0.2, 0.0))
    # a sector on a joint whose faces are offset against each other
    sq = Column.single_block(0.4, 1.0).blocks[0].segments
    with pytest.raises(ParameterError, match="bottom_missing_sector\\) is for a joint whose faces are aligned"):
        Column((Block(sq, "a"), Block(sq, "b", offset=(0.05, 0.0), bottom_missing_sector=(0.0, 30.0))))


def test_sector_file_key_round_trips_and_is_written_only_when_given():
    col = block((-60.0, 60.0))
    d = col.to_dict()
    assert d["blocks"][0]["bottom_missing_sector"] == [-60.0, 60.0]
    assert Column.from_dict(d).to_json() == col.to_json()
    assert "bottom_missing_sector" not in block().to_json()
    d["blocks"][0]["bottom_missing_sector"] = [45.0, 45.0]
    with pytest.raises(ParameterError, match="is empty"):
        Column.from_dict(d)
