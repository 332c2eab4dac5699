"""Column geometry (pycolfrag/structure/column.py): mass properties, the default scene, file formats, bad input.

Where the expected numbers come from:
- frustum volume and centroid: closed forms for a regular n-gon frustum (the cross-section area is
  k r(z)^2 with k = (n/2) sin(2 pi/n) and r linear in z), written out again here;
- the Parthenon column: the paper's default scene, copied into pycolfrag/data/column_parthenon.json
  (shaft 9.38 m in 12 drums of 1.65-1.28 m diameter, capital, total 10.08 m, 10 sides,
  2700 kg/m^3); its mass and centre of mass are recomputed here independently by Simpson's rule
  over the height of each piece (exact: the area is quadratic and z * area cubic in z);
- the column description we started from also gave a mass (about 44800 kg) and centre-of-mass
  height (about 4.87 m): rounded figures for a slightly different idealisation (labelled "approx");
  our exact 10-gon values are 44297 kg and 4.812 m, 1.1 % and 1.2 % below them, so they are checked to 2 %.
"""
import json
import math

import numpy as np
import pytest

import pycolfrag as pcf
from pycolfrag import Block, Column, JointProperties, ParameterError, Segment


def k_ngon(n):
    """Area of the regular n-gon of unit circumradius."""
    return 0.5 * n * math.sin(2.0 * math.pi / n)


def simpson_piece(h, r0, r1, n, z0):
    """Volume and first moment (about z = 0) of an n-gon frustum from z0 to z0 + h, by Simpson's rule."""
    area = [k_ngon(n) * r ** 2 for r in (r0, 0.5 * (r0 + r1), r1)]
    z = [z0, z0 + 0.5 * h, z0 + h]
    vol = h / 6.0 * (area[0] + 4 * area[1] + area[2])
    mom = h / 6.0 * (z[0] * area[0] + 4 * z[1] * area[1] + z[2] * area[2])
    return vol, mom


# ---------------------------------------------------------------- mass properties vs closed forms
@pytest.mark.parametrize("n", [3, 4, 6, 10, 32])
@pytest.mark.parametrize("r0,r1", [(0.8, 0.8), (0.825, 0.64), (0.3, 0.9)])
def test_frustum_volume_and_centroid(n, r0, r1):
    h = 0.78
    s = Segment(h, r0, r1, n)
    vol = k_ngon(n) * h * (r0 ** 2 + r0 * r1 + r1 ** 2) / 3.0
    zc = h * (r0 ** 2 + 2 * r0 * r1 + 3 * r1 ** 2) / (4.0 * (r0 ** 2 + r0 * r1 + r1 ** 2))
    assert s.volume == pytest.approx(vol, rel=1e-13)
    assert s.centroid_height == pytest.approx(zc, rel=1e-13)


def test_prism_centroid_is_mid_height_and_cone_limit():
    assert Segment(2.0, 0.5, 0.5, 8).centroid_height == pytest.approx(1.0, rel=1e-14)
    # almost a pyramid (top radius -> 0): centroid at h/4, volume k r^2 h / 3
    s = Segment(1.2, 0.5, 1e-9, 6)
    assert s.centroid_height == pytest.approx(0.3, rel=1e-6)
    assert s.volume == pytest.approx(k_ngon(6) * 0.25 * 1.2 / 3, rel=1e-6)


def test_many_sides_approach_the_circle():
    # 64 sides is the most the solver takes (CF_SOLVER_MAX_SIDES); the n-gon's area is
    # (n/2) sin(2 pi/n) r^2 = pi r^2 (1 - (2 pi/n)^2/6 + ...): 1.6e-3 below the circle at n = 64
    s = Segment(1.0, 0.5, 0.5, 64)
    assert s.volume == pytest.approx(math.pi * 0.25 * (1 - (2 * math.pi / 64) ** 2 / 6), rel=1e-5)
    assert s.volume < math.pi * 0.25


def test_block_of_two_segments():
    a, b = Segment(0.4, 0.64, 0.83, 10), Segment(0.3, 1.2, 1.2, 4, math.pi / 4)
    blk = Block((a, b))
    assert blk.height == pytest.approx(0.7)
    assert blk.volume == pytest.approx(a.volume + b.volume)
    zc = (a.volume * a.centroid_height + b.volume * (0.4 + 0.15)) / (a.volume + b.volume)
    assert blk.centroid_height == pytest.approx(zc, rel=1e-13)


# ---------------------------------------------------------------- the default scene
def test_parthenon_geometry():
    col = Column.parthenon()
    assert col.n_blocks == 13 and col.n_joints == 13
    assert col.height == pytest.approx(10.08, abs=1e-12)
    assert col.base_diameter == pytest.approx(1.65, abs=1e-12)
    shaft = col.blocks[:12]
    assert sum(b.height for b in shaft) == pytest.approx(9.38, abs=1e-12)
    assert all(b.height == pytest.approx(9.38 / 12) for b in shaft)
    assert all(s.n_sides == 10 and s.phase_rad == 0.0 for b in shaft for s in b.segments)
    assert 2 * shaft[-1].top.r_top == pytest.approx(1.28, abs=1e-12)
    # joint i is under block i; diameters taper linearly from 1.65 to 1.28 over the 9.38 m shaft
    for i, (z, dj) in enumerate(zip(col.joint_heights, col.joint_diameters)):
        assert z == pytest.approx(i * 9.38 / 12, abs=1e-12)
        assert dj == pytest.approx(1.65 + (1.28 - 1.65) * min(i, 12) / 12, abs=1e-12)
    cap = col.blocks[12]
    assert len(cap.segments) == 2 and cap.height == pytest.approx(0.70)
    # capital's bottom face sits on the shaft's top: same polygon, no step at the joint
    assert cap.bottom.r_bottom == pytest.approx(shaft[-1].top.r_top) and cap.bottom.n_sides == 10
    # abacus: square of side 1.73 with sides along x and y (inradius = side / 2)
    ab = cap.top
    assert ab.n_sides == 4 and ab.r_bottom * math.cos(math.pi / 4) == pytest.approx(1.73 / 2)
    assert ab.phase_rad == pytest.approx(math.pi / 4)
    assert col.density == 2700.0
    j = col.joints
    assert (j.kn, j.ks, j.friction_deg, j.cohesion, j.tensile_strength) == (1e9, 1e9, 37.0, 0.0, 0.0)
    assert j.mu == pytest.approx(0.7536, abs=1e-4)


def test_parthenon_mass_and_centre_of_mass_independently():
    vol, mom, z = 0.0, 0.0, 0.0
    for _ in range(12):  # drums: circumradius linear over the shaft height
        h = 9.38 / 12
        r0 = 0.5 * (1.65 - 0.37 * z / 9.38)
        r1 = 0.5 * (1.65 - 0.37 * (z + h) / 9.38)
        v, m = simpson_piece(h, r0, r1, 10, z)
        vol, mom, z = vol + v, mom + m, z + h
    v, m = simpson_piece(0.40, 0.64, 0.83, 10, z)  # echinus
    vol, mom, z = vol + v, mom + m, z + 0.40
    v = 1.73 ** 2 * 0.30  # abacus
    vol, mom = vol + v, mom + v * (z + 0.15)
    mass, zc = 2700.0 * vol, mom / vol

    col = Column.parthenon()
    assert col.mass == pytest.approx(mass, rel=1e-12)
    assert col.com_height == pytest.approx(zc, rel=1e-12)
    assert sum(col.block_masses) == pytest.approx(col.mass, rel=1e-15)
    # the reference file's rounded figures (a slightly different idealisation): 1.1 % and 1.2 % off
    assert col.mass == pytest.approx(44800, rel=0.02)
    assert col.com_height == pytest.approx(4.87, rel=0.02)


def test_parthenon_overrides():
    col = Column.parthenon(density=2500.0, n_sides=16, phase_deg=18.0, joints=JointProperties(kn=1e10, ks=1e10))
    assert col.density == 2500.0 and col.joints.kn == 1e10
    assert all(b.bottom.n_sides == 16 for b in col.blocks)  # the echinus follows the shaft
    assert col.blocks[0].bottom.phase_rad == pytest.approx(math.radians(18.0))
    assert col.blocks[-1].top.n_sides == 4  # the abacus stays square
    with pytest.raises(ParameterError, match="kn"):
        Column.parthenon(kn=1e10)


def test_with_joints():
    col = Column.parthenon()
    stiff = col.with_joints(kn=1e11, ks=1e11)
    assert stiff.joints.kn == 1e11 and stiff.joints.friction_deg == 37.0 and col.joints.kn == 1e9
    assert stiff.mass == col.mass
    with pytest.raises(ParameterError, match="-5"):
        col.with_joints(kn=-5.0)


# ---------------------------------------------------------------- other constructors
def test_single_block_square():
    col = Column.single_block(0.4, 2.0)
    (blk,) = col.blocks
    s = blk.segments[0]
    assert s.n_sides == 4 and s.r_bottom == s.r_top
    inradius = s.r_bottom * math.cos(math.pi / 4)
    assert inradius == pytest.approx(0.2, rel=1e-14)  # width / 2: Housner's half-width b
    assert s.phase_rad == pytest.approx(math.pi / 4)  # faces normal to x and y
    assert blk.volume == pytest.approx(0.4 * 0.4 * 2.0, rel=1e-14)
    assert col.com_height == pytest.approx(1.0, rel=1e-14)
    assert col.mass == pytest.approx(2700 * 0.32, rel=1e-14)
    vtx = Column.single_block(0.4, 2.0, flat_side_along_x=False).blocks[0].segments[0]
    assert vtx.phase_rad == 0.0 and vtx.r_bottom == pytest.approx(s.r_bottom)


def test_single_block_hexagon_width_across_flats():
    s = Column.single_block(1.0, 3.0, n_sides=6).blocks[0].segments[0]
    assert s.r_bottom * math.cos(math.pi / 6) == pytest.approx(0.5, rel=1e-14)


def test_from_drums_taper_and_capital():
    cap = Column.doric_capital(0.2, 0.8, 1.0, 0.1, 1.1, n_sides=8)
    col = Column.from_drums([0.5, 1.0, 0.5], 1.0, 0.8, n_sides=8, capital=cap, name="mine")
    assert col.n_blocks == 4 and col.name == "mine"
    assert [2 * b.bottom.r_bottom for b in col.blocks[:3]] == pytest.approx([1.0, 0.95, 0.85])
    assert 2 * col.blocks[2].top.r_top == pytest.approx(0.8)
    assert col.height == pytest.approx(2.3)
    same = Column.from_drums([1.0, 1.0], 1.0)  # no taper, no capital
    assert same.n_blocks == 2 and same.blocks[1].top.r_top == 0.5


# ---------------------------------------------------------------- files and round trips
def test_dict_round_trip_is_lossless():
    col = Column.parthenon()
    d = col.to_dict()
    back = Column.from_dict(json.loads(json.dumps(d)))
    assert back.to_dict() == d
    assert back.mass == col.mass and back.com_height == col.com_height
    for a, b in zip(col.blocks, back.blocks):
        assert a.segments == b.segments and a.name == b.name
    assert json.loads(col.to_json()) == d


def test_json_file_shorthand(tmp_path):
    from importlib import resources
    src = resources.files("pycolfrag").joinpath("data/column_parthenon.json").read_text()
    p = tmp_path / "col.json"
    p.write_text(src)
    assert Column.from_file(p).to_dict() == Column.parthenon().to_dict()
    assert Column.from_file(str(p)).n_blocks == 13


def test_json_file_blocks_form(tmp_path):
    p = tmp_path / "col.json"
    p.write_text(json.dumps(Column.parthenon().to_dict()))
    assert Column.from_file(p).to_dict() == Column.parthenon().to_dict()


TOML_SHORTHAND = """
name = "three drums"
density = 2600.0
n_sides = 12

[shaft]
drum_heights = [0.6, 0.6, 0.6]
diameter_bottom = 0.9
diameter_top = 0.8

[capital]
echinus_height = 0.2
echinus_diameter_bottom = 0.8
echinus_diameter_top = 1.0
abacus_height = 0.15
abacus_side = 1.05

[joints]
kn = 2e9
ks = 1e9
friction_angle_deg = 35.0
"""

TOML_BLOCKS = """
name = "two blocks"
density = 2400.0

[joints]
kn = 5e9
ks = 5e9
friction_angle_deg = 30.0

[[blocks]]
name = "base"
[[blocks.segments]]
height = 1.0
diameter_bottom = 1.0
diameter_top = 0.9
n_sides = 8

[[blocks]]
name = "top"
[[blocks.segments]]
height = 0.5
diameter_bottom = 0.9
n_sides = 8
phase_deg = 22.5
"""


def test_toml_shorthand(tmp_path):
    p = tmp_path / "col.toml"
    p.write_text(TOML_SHORTHAND)
    col = Column.from_file(p)
    assert col.name == "three drums" and col.density == 2600.0 and col.n_blocks == 4
    assert col.height == pytest.approx(2.15)
    assert col.base_diameter == pytest.approx(0.9)
    assert col.blocks[0].bottom.n_sides == 12 and col.blocks[-1].top.n_sides == 4
    assert (col.joints.kn, col.joints.ks, col.joints.friction_deg) == (2e9, 1e9, 35.0)
    # TOML -> Column -> dict -> JSON file -> Column is lossless
    q = tmp_path / "col.json"
    q.write_text(json.dumps(col.to_dict()))
    assert Column.from_file(q).to_dict() == col.to_dict()


def test_toml_blocks_form(tmp_path):
    p = tmp_path / "col.TOML"  # suffix is case-insensitive
    p.write_text(TOML_BLOCKS)
    col = Column.from_file(p)
    assert [b.name for b in col.blocks] == ["base", "top"]
    top = col.blocks[1].segments[0]
    assert top.r_top == top.r_bottom == pytest.approx(0.45)  # diameter_top defaults to diameter_bottom
    assert top.phase_rad == pytest.approx(math.radians(22.5))
    assert col.joints.friction_deg == 30.0 and col.density == 2400.0


def test_examples_load():
    import pathlib
    ex = pathlib.Path(__file__).resolve().parent.parent / "examples"
    files = sorted(ex.glob("column_*.json")) + sorted(ex.glob("column_*.toml"))
    if not files:
        pytest.skip("no examples directory")
    for f in files:
        col = Column.from_file(f)
        assert col.n_blocks >= 1 and col.mass > 0, f
    par = ex / "column_parthenon.toml"
    if par.exists():
        assert Column.from_file(par).to_dict() == Column.parthenon().to_dict()


# ---------------------------------------------------------------- bad input
def drum(**kw):
    d = {"height": 1.0, "diameter_bottom": 1.0}
    d.update(kw)
    return {"blocks": [{"segments": [d]}]}


@pytest.mark.parametrize("height", [0.0, -1.0, float("nan"), float("inf"), "tall"])
def test_bad_segment_height(height):
    with pytest.raises(ParameterError, match=r"height.*" + (repr(height) if isinstance(height, str) else "")):
        Column.from_dict(drum(height=height))
    if not isinstance(height, str):
        with pytest.raises(ParameterError, match=str(height)):
            Segment(height, 0.5, 0.5)


@pytest.mark.parametrize("key,value", [("diameter_bottom", 0.0), ("diameter_bottom", -2.0),
                                       ("diameter_top", float("nan")), ("diameter_top", -0.1)])
def test_bad_diameters(key, value):
    with pytest.raises(ParameterError, match=r"radius.*" + str(0.5 * value).replace("-", "-")):
        Column.from_dict(drum(**{key: value}))


@pytest.mark.parametrize("n", [2, 0, -4, 3.7, "ten", True])
def test_bad_n_sides(n):
    with pytest.raises(ParameterError, match=r"n_sides.*" + repr(n).replace(".", r"\.")):
        Column.from_dict(drum(n_sides=n))
    with pytest.raises(ParameterError, match="n_sides"):
        Column.from_dict({"shaft": {"drum_heights": [1.0], "diameter_bottom": 1.0}, "n_sides": n})


def test_bad_n_sides_constructors():
    with pytest.raises(ParameterError, match="n_sides.*2"):
        Segment(1.0, 0.5, 0.5, 2)
    with pytest.raises(ParameterError, match="n_sides.*2"):
        Column.single_block(1.0, 1.0, n_sides=2)


@pytest.mark.parametrize("friction", [90.0, 95.0, 0.0, -10.0, float("nan"), "steep", None])
def test_bad_friction(friction):
    with pytest.raises(ParameterError, match=r"friction.*" + repr(friction)):
        JointProperties(friction_deg=friction)
    with pytest.raises(ParameterError, match="friction"):
        Column.from_dict(dict(drum(), joints={"friction_angle_deg": friction}))


@pytest.mark.parametrize("key", ["cohesion", "tensile_strength"])
def test_nonzero_cohesion_refused(key):
    with pytest.raises(ParameterError, match=f"{key}.*100000"):
        JointProperties(**{key: 1e5})
    with pytest.raises(ParameterError, match=key):
        Column.from_dict(dict(drum(), joints={key: 1e5}))


@pytest.mark.parametrize("key,value", [("kn", 0.0), ("kn", -1e9), ("ks", float("nan")), ("ks", "stiff")])
def test_bad_stiffness(key, value):
    with pytest.raises(ParameterError, match=key + r".*" + repr(value).replace("-", "-")):
        JointProperties(**{key: value})


def test_unknown_joint_keys():
    with pytest.raises(ParameterError, match="frction"):
        Column.from_dict(dict(drum(), joints={"frction": 30.0}))
    with pytest.raises(ParameterError, match="joints must be a mapping"):
        Column.from_dict(dict(drum(), joints=[1e9]))


def test_unknown_keys_elsewhere_are_refused():
    # a typo must not silently fall back to a default (e.g. 2700 kg/m^3 for "densty")
    with pytest.raises(ParameterError, match="densty"):
        Column.from_dict(dict(drum(), densty=2500.0))
    with pytest.raises(ParameterError, match="hieght"):
        Column.from_dict(drum(hieght=2.0))
    with pytest.raises(ParameterError, match="diamter_top"):
        Column.from_dict({"shaft": {"drum_heights": [1.0], "diameter_bottom": 1.0, "diamter_top": 0.8}})
    with pytest.raises(ParameterError, match="abacus_width"):
        Column.from_dict({"shaft": {"drum_heights": [1.0], "diameter_bottom": 1.0},
                          "capital": {"echinus_height": 0.2, "echinus_diameter_bottom": 1.0,
                                      "echinus_diameter_top": 1.2, "abacus_height": 0.1, "abacus_width": 1.3}})
    with pytest.raises(ParameterError, match="both"):
        Column.from_dict(dict(drum(), shaft={"drum_heights": [1.0], "diameter_bottom": 1.0}))


@pytest.mark.parametrize("d,word", [
    ({}, "shaft"),
    ({"shaft": {"diameter_bottom": 1.0}}, "drum_heights"),
    ({"shaft": {"drum_heights": [1.0]}}, "diameter_bottom"),
    ({"shaft": {"drum_heights": [], "diameter_bottom": 1.0}}, "empty"),
    ({"shaft": {"drum_heights": [1.0], "diameter_bottom": 1.0}, "capital": {"echinus_height": 0.2}},
     "echinus_diameter_bottom"),
    ({"blocks": [{"segments": [{"height": 1.0}]}]}, "diameter_bottom"),
    ({"blocks": [{"name": "x"}]}, "segments"),
    ({"blocks": []}, "at least one block"),
    ({"blocks": "drums"}, "list"),
    ({"shaft": [1.0, 1.0]}, "shaft must be a mapping"),
])
def test_missing_or_malformed_keys(d, word):
    with pytest.raises(ParameterError, match=word):
        Column.from_dict(d)


def test_bad_top_level_values():
    with pytest.raises(ParameterError, match="density.*-2700"):
        Column.from_dict(dict(drum(), density=-2700.0))
    with pytest.raises(ParameterError, match="ten"):
        Column.from_dict({"shaft": {"drum_heights": [1.0], "diameter_bottom": 1.0}, "phase_deg": "ten"})
    with pytest.raises(ParameterError, match="drum_heights.*-0.5"):
        Column.from_dict({"shaft": {"drum_heights": [1.0, -0.5], "diameter_bottom": 1.0}})
    with pytest.raises(ParameterError, match="abacus_side.*wide"):
        Column.from_dict({"shaft": {"drum_heights": [1.0], "diameter_bottom": 1.0},
                          "capital": {"echinus_height": 0.2, "echinus_diameter_bottom": 1.0,
                                      "echinus_diameter_top": 1.2, "abacus_height": 0.1, "abacus_side": "wide"}})
    with pytest.raises(ParameterError, match="mapping"):
        Column.from_dict([1, 2, 3])


def test_bad_python_objects():
    with pytest.raises(ParameterError, match="at least one block"):
        Column([])
    with pytest.raises(ParameterError, match="Block"):
        Column([Segment(1.0, 0.5, 0.5)])
    with pytest.raises(ParameterError, match="no segments"):
        Block(())
    with pytest.raises(ParameterError, match="JointProperties"):
        Column([Block((Segment(1.0, 0.5, 0.5),))], joints={"kn": 1e9})
    with pytest.raises(ParameterError, match="width.*0"):
        Column.single_block(0.0, 1.0)
    with pytest.raises(ParameterError, match="height.*nan"):
        Column.single_block(1.0, float("nan"))
    with pytest.raises(ParameterError, match="drum_heights"):
        Column.from_drums([], 1.0)


def test_toml_nan_height(tmp_path):
    p = tmp_path / "c.toml"
    p.write_text("[shaft]\ndrum_heights = [1.0, nan]\ndiameter_bottom = 1.0\n")
    with pytest.raises(ParameterError, match=r"drum_heights\[1\].*nan"):
        Column.from_file(p)


@pytest.mark.parametrize("name,content,needle", [
    ("bad.json", "{\"shaft\": {", "cannot parse column file .*bad.json"),
    ("bad.toml", "[shaft\ndrum_heights = 1", "cannot parse column file .*bad.toml"),
    ("bin.json", b"\xff\xfe\x00\x81garbage", r"column file .*bin.json is not UTF-8 text \(byte 0 is 0xff\)"),
])
def test_unreadable_file(tmp_path, name, content, needle):
    p = tmp_path / name
    (p.write_bytes if isinstance(content, bytes) else p.write_text)(content)
    with pytest.raises(ParameterError, match=needle):
        Column.from_file(p)


def test_missing_file(tmp_path):
    with pytest.raises(FileNotFoundError, match="nope.json"):
        Column.from_file(tmp_path / "nope.json")


def test_errors_are_value_errors():
    assert issubclass(ParameterError, ValueError) and issubclass(ParameterError, pcf.PycolfragError)
    with pytest.raises(ValueError):
        Segment(-1.0, 0.5, 0.5)


def test_joint_overrides_round_trip_and_validation(tmp_path):
    """Per-joint properties: kept by to_dict/from_dict and a JSON file, absent from the default
    layout (so results signatures of uniform columns do not change), refused when malformed."""
    import json
    base = pcf.JointProperties(kn=2e9, ks=2e9, friction_deg=45.0)
    col = pcf.Column.parthenon()
    assert "joint_overrides" not in col.to_dict()
    c2 = pcf.Column(col.blocks, density=col.density, joints=col.joints, joint_overrides={0: base})
    assert c2.joint(0) == base and c2.joint(1) == col.joints
    d = c2.to_dict()
    assert d["joint_overrides"] == {"0": base.to_dict()}
    assert pcf.Column.from_dict(d).to_dict() == d
    p = tmp_path / "c.json"
    p.write_text(json.dumps(d))
    assert pcf.Column.from_file(p).joint(0) == base
    assert c2.with_joints(kn=5e9).joint(0) == base          # --kn changes the default, not the override
    for bad in ({13: base}, {-1: base}, {"0": base}, {0: {"kn": 1e9}}, [base]):
        with pytest.raises(pcf.ParameterError, match="joint"):
            pcf.Column(col.blocks, joint_overrides=bad)
    with pytest.raises(pcf.ParameterError, match="joint_overrides"):
        pcf.Column.from_dict({**d, "joint_overrides": {"zero": base.to_dict()}})
    with pytest.raises(pcf.ParameterError):
        pcf.Column.from_dict({**d, "joint_overrides": {"0": {"kn": -1.0}}})


def test_joint_overrides_reach_the_solver():
    """A uniform column and the same column with an override equal to the default give the same
    bits; an override of the base friction changes the response (the solver takes it): a 1.2 g
    pulse of 0.3 s slides a 1 m x 0.5 m block on a mu = 0.75 base by about (A - mu g) A t^2 /
    (2 mu g) = 0.3 m (Newmark) and cannot slide it on a mu = 1.73 (60 deg) base; it rocks only
    above b / h = 2 g."""
    t = np.arange(0, 2.0, 0.005)
    acc = np.where(t <= 0.3, 1.2 * 9.81, 0.0)
    col = pcf.Column.single_block(1.0, 0.5)
    same = pcf.Column(col.blocks, joints=col.joints, joint_overrides={0: col.joints})
    a, b = pcf.simulate(col, acc, 0.005), pcf.simulate(same, acc, 0.005)
    assert a.u_top == b.u_top and a.u_d == b.u_d
    rough = pcf.Column(col.blocks, joints=col.joints, joint_overrides={0: pcf.JointProperties(friction_deg=60.0)})
    c = pcf.simulate(rough, acc, 0.005)
    assert a.u_d > 0.05 and c.u_d < 0.2 * a.u_d   # 0.5 g slides a mu 0.75 base, not a mu 1.73 one


def test_partial_joint_override_keeps_the_columns_joints():
    """In a file, an override names only what differs: joint 0 of this column keeps ks = 3e9 and
    30 deg from [joints] (before: the library defaults 1e9 and 37 deg came back silently)."""
    d = pcf.Column.parthenon().to_dict()
    d["joints"] = {"kn": 2e9, "ks": 3e9, "friction_angle_deg": 30.0}
    d["joint_overrides"] = {"0": {"kn": 5e8}}
    j0 = pcf.Column.from_dict(d).joint(0)
    assert (j0.kn, j0.ks, j0.friction_deg) == (5e8, 3e9, 30.0)
    with pytest.raises(pcf.ParameterError, match="joint_overrides.0"):
        pcf.Column.from_dict({**d, "joint_overrides": {"0": 5e8}})
