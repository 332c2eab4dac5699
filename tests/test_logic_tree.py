"""Logic trees over the model and site choices (pycolfrag/risk/logic_tree.py, tree_apply.py; docs/logic_tree.md).

Expected numbers are products of the weights written in each test (exact in binary where the weights are
dyadic, else to the float sum's round-off, 1e-15), and counts of end branches are products of the sets'
sizes. A refusal is checked by the value its message must name.
"""
import copy
import math
import tomllib
from pathlib import Path

import numpy as np
import pytest
from scipy import stats

from pycolfrag.core.errors import ParameterError
from pycolfrag.risk import logic_tree as lt
from pycolfrag.risk import tree_apply as ta
from pycolfrag.site.sources import load_site

ROOT = Path(__file__).resolve().parents[1]
SITE = tomllib.loads((ROOT / "examples" / "site_athens.toml").read_text())


def bset(choice, *pairs, **kw):
    return {"choice": choice, "branches": [{"value": v, "weight": w} for v, w in pairs], **kw}


EXAMPLE = {"branch_sets": [
    bset("vp_scale", (1.0, 0.6), (2.0, 0.4)),
    bset("b", (0.9, 0.5), (1.1, 0.5), sources=["Attica background"]),
    bset("contact", ("vertex", 0.5), ({"contact": "perimeter", "points_per_edge": 4}, 0.5)),
    bset("pulse_model", ({"model": "shahi_baker_2014", "mechanism": "non-strike-slip", "s_km": 5.0,
                          "angle_deg": 30.0}, 0.75),
         ({"model": "shahi_baker_earlier", "mechanism": "non-strike-slip", "s_km": 5.0, "angle_deg": 30.0}, 0.25)),
]}


# --------------------------------------------------------------------------- form and enumeration

def test_full_enumeration_has_the_product_weights_and_knows_what_changes_the_runs():
    """2 x 2 x 2 x 2 = 16 end branches; each weight the product of its alternatives' weights (0.6 x 0.5 x 0.5
    x 0.75 = 0.1125 for the first); they sum to 1 to round-off. Two sets change the runs (vp_scale,
    contact): 4 distinct run settings, each shared by the 4 end branches of the site-only sets."""
    t = lt.tree_from_dict(EXAMPLE)
    ends = t.end_branches()
    assert t.n_paths == len(ends) == 16
    assert ends[0].weight == pytest.approx(0.6 * 0.5 * 0.5 * 0.75, rel=1e-15)
    assert ends[0].path == ("vp_scale=1 / b=0.9 / contact=vertex / pulse_model=model=shahi_baker_2014,"
                            "mechanism=non-strike-slip,s_km=5,angle_deg=30")
    assert math.fsum(e.weight for e in ends) == pytest.approx(1.0, abs=1e-15)
    assert not t.site_only and all(e.changes_runs for e in ends)
    groups = t.run_groups()
    assert len(groups) == 4 and all(len(v) == 4 for v in groups.values())
    assert {s.name: s.scope for s in t.branch_sets} == {"vp_scale": "runs", "b": "site", "contact": "runs",
                                                         "pulse_model": "site"}
    site_only = lt.tree_from_dict({"branch_sets": EXAMPLE["branch_sets"][1::2]})
    assert site_only.site_only and len(site_only.run_groups()) == 1
    assert not any(e.changes_runs for e in site_only.end_branches())


@pytest.mark.parametrize("off, ok", [(5e-10, True), (2e-9, False), (-2e-9, False)])
def test_weights_must_sum_to_one_within_1e_9(off, ok):
    tree = {"branch_sets": [bset("vp_scale", (1.0, 0.5), (2.0, 0.5 + off))]}
    if ok:
        lt.tree_from_dict(tree)
    else:
        with pytest.raises(ParameterError, match=r"sum to 1\.00000000[0-9]*|sum to 0\.99999999"):
            lt.tree_from_dict(tree)


@pytest.mark.parametrize("tree, match", [
    ({"branch_sets": [bset("vp_scale", (1.0, 1.0))], "colour": 1}, "unknown key.*'colour'"),
    ({"branch_sets": [{**bset("vp_scale", (1.0, 1.0)), "weights": 1}]}, "unknown key.*'weights'"),
    ({"branch_sets": [{"choice": "vp_scale", "branches": [{"value": 1.0, "weight": 1.0, "wieght": 1}]}]},
     "unknown key.*'wieght'"),
    ({"branch_sets": [bset("vs30", (1.0, 1.0))]}, "got 'vs30'"),
    ({"branch_sets": [bset("dt_factor", (0.4, 0.5), (0.8, 0.5))]}, "'dt_factor' is a numerical setting"),
    ({"branch_sets": [bset("record_dt", (0.01, 1.0))]}, "'record_dt' is a numerical setting"),
    ({"branch_sets": [bset("damping_alpha", (0.0, 1.0))]}, "got 'damping_alpha' \\(a solver setting"),
    ({"branch_sets": [bset("vp_scale", (1.0, 0.5), (1, 0.5))]}, r"value = 1 repeats branch 0"),
    ({"branch_sets": [bset("contact", ({"contact": "perimeter", "points_per_edge": 4}, 0.5),
                           ({"points_per_edge": 4.0, "contact": "perimeter"}, 0.5))]}, "repeats branch 0"),
    ({"branch_sets": [{"choice": "vp_scale", "branches": [{"value": 1.0, "weight": 0.5, "name": "a"},
                                                          {"value": 2.0, "weight": 0.5, "name": "a"}]}]},
     "'a' names an earlier branch"),
    ({"branch_sets": [bset("vp_scale", (1.0, 1.0)), bset("vp_scale", (2.0, 1.0))]}, "names an earlier branch set"),
    ({"branch_sets": [bset("rate", (0.01, 1.0), sources=["a"]), bset("rate_factor", (2.0, 1.0), name="f")]},
     "both change 'rate'"),
    ({"branch_sets": [bset("vp_scale", (1.0, 1.5), (2.0, -0.5))]}, r"weight must be in \(0, 1\], got 1.5"),
    ({"branch_sets": [bset("vp_scale", (1.0, 0.0), (2.0, 1.0))]}, r"weight must be in \(0, 1\], got 0"),
    ({"branch_sets": [bset("vp_scale", ("1", 1.0))]}, "value must be a finite number, got '1'"),
    ({"branch_sets": [bset("vp_scale", (1.0, 1.0), sources=["a"])]}, "'vp_scale' is not a choice of the sources"),
    ({"branch_sets": []}, "at least one"),
    ({"branch_sets": [bset("vp_scale", (1.0, 1.0))], "samples": -1}, r"samples must be an integer.*got -1"),
    ({"branch_sets": [bset("vp_scale", (1.0, 1.0))], "seed": 1.5}, r"seed must be an integer >= 0, got 1.5"),
])
def test_bad_trees_are_refused_naming_the_value(tree, match):
    with pytest.raises(ParameterError, match=match):
        lt.tree_from_dict(tree, "tree.toml")


def test_sets_on_different_sources_do_not_conflict():
    t = lt.tree_from_dict({"branch_sets": [bset("rate", (0.01, 1.0), sources=["a"]),
                                           bset("rate_factor", (2.0, 1.0), sources=["b"], name="f")]})
    assert len(t.end_branches()) == 1


THREE_BY_FOUR = [bset(c, *[(v, 0.25) for v in (0.5, 1.0, 1.5, 2.0)], name=c) for c in ("a", "b", "c")]


def test_more_than_64_end_branches_need_samples():
    """4 x 4 x 4 = 64 are enumerated; a fourth set of 2 makes 128, refused with the advice."""
    sets = [{**s, "choice": "vp_scale" if k == 0 else ("joint_kn" if k == 1 else "joint_ks")}
            for k, s in enumerate(THREE_BY_FOUR)]
    assert len(lt.tree_from_dict({"branch_sets": sets}).end_branches()) == 64
    more = sets + [bset("joint_friction_deg", (30.0, 0.5), (37.0, 0.5))]
    with pytest.raises(ParameterError, match=r"128 end branches \(4 x 4 x 4 x 2\).*samples = N"):
        lt.tree_from_dict({"branch_sets": more})
    assert len(lt.tree_from_dict({"branch_sets": more, "samples": 5}).end_branches()) == 5


def test_sampled_branches_have_equal_weights_and_follow_the_set_weights():
    """OpenQuake's number_of_logic_tree_samples: N end branches of weight 1/N, each set's alternative drawn
    with its weight. Over 4000 samples the count of vp_scale = 2 (weight 0.3) is binomial(4000, 0.3): its
    two-sided 0.999 band is asserted; the same seed gives the same paths, another seed others."""
    tree = {"samples": 4000, "seed": 7, "branch_sets": [bset("vp_scale", (1.0, 0.7), (2.0, 0.3)),
                                                        bset("tp_model", ("rupakhety_2011", 0.5), ("baker_2007", 0.5))]}
    ends = lt.tree_from_dict(tree).end_branches()
    assert len(ends) == 4000 and {e.weight for e in ends} == {1 / 4000}
    k = sum(e.branches[0].value == 2.0 for e in ends)
    lo, hi = stats.binom.interval(0.999, 4000, 0.3)
    assert lo <= k <= hi
    assert [e.index for e in lt.tree_from_dict(tree).end_branches()] == [e.index for e in ends]
    other = lt.tree_from_dict({**tree, "seed": 8}).end_branches()
    assert [e.index for e in other] != [e.index for e in ends]


# --------------------------------------------------------------------------- files

def test_tree_reads_from_its_own_file_and_from_the_site_file(tmp_path):
    own = tmp_path / "tree.toml"
    own.write_text('samples = 0\n[[branch_sets]]\nchoice = "vp_scale"\n'
                   'branches = [{value = 1.0, weight = 0.6}, {value = 2.0, weight = 0.4}]\n')
    assert [b.value for b in lt.load_tree(own).branch_sets[0].branches] == [1.0, 2.0]
    site = tmp_path / "site.toml"
    site.write_text((ROOT / "examples" / "site_athens.toml").read_text()
                    + '\n[logic_tree]\n[[logic_tree.branch_sets]]\nchoice = "b"\n'
                      'branches = [{value = 0.9, weight = 0.5}, {value = 1.1, weight = 0.5}]\n')
    assert lt.load_tree(site).branch_sets[0].choice.name == "b"
    assert len(load_site(site).sources) == 2                     # the site loader reads the same file
    with pytest.raises(ParameterError, match="without a \\[logic_tree\\] table"):
        lt.load_tree(ROOT / "examples" / "site_athens.toml")
    bad = tmp_path / "bad.toml"
    bad.write_text("[[branch_sets]\n")
    with pytest.raises(ParameterError, match="not valid TOML"):
        lt.load_tree(bad)


# --------------------------------------------------------------------------- against the models

def test_site_branches_are_applied_and_read_by_the_site_loader():
    tree = lt.tree_from_dict({"branch_sets": [
        bset("rate_factor", (0.5, 0.5), (2.0, 0.5), sources=["Fili fault"]),
        bset("m_max", (6.6, 0.5), (7.0, 0.5)),
        bset("pulse_model", ({"probability": 0.2}, 1.0))]})
    checked = ta.check_tree(tree, SITE, "site.toml")
    last = checked.sites[-1]                                         # factor 2, m_max 7.0
    fili, bg = last.sources
    assert fili.rate == 2.0 * 0.001 and bg.rate == 0.03
    assert bg.magnitude.m_max == 7.0 and bg.magnitude.b == 1.0
    assert fili.pulse.p == 0.2 and bg.pulse.p == 0.2
    assert SITE["sources"][0]["rate"] == 0.001                      # the site's table is left as it was
    assert all(m == ta.ModelSettings() for m in checked.models)


@pytest.mark.parametrize("sets, match", [
    ([bset("b", (0.9, 0.5), (6.0, 0.5))], r"branch 'b=6'.*b must be in \(0, 5\], got 6"),
    ([bset("m_max", (5.0, 0.5), (7.0, 0.5))], r"branch 'm_max=5'.*m_max = 5 must be > m_min = 5.5"),
    ([bset("b", (0.9, 1.0), sources=["Fili fault"])], r"applies to Gutenberg-Richter sources; \['Fili fault'\]"),
    ([bset("rate", (0.01, 1.0), sources=["Fili", "Attica background"])], r"\['Fili'\] are not sources of the site"),
    ([bset("rate", (0.01, 1.0))], "an absolute rate for every one of the site's 2 sources"),
    ([bset("pulse_model", ({"model": "shahi_baker_2015"}, 1.0))], r"pulse_model=model=shahi_baker_2015.*got 'shahi"),
    ([bset("vp_scale", (1.0, 0.5), (-1.0, 0.5))], r"branch 'vp_scale=-1'.*vp_scale.*-1"),
    ([bset("tp_model", ("rupakhety_2011", 0.5), ("somerville_1999", 0.5))], "unknown pulse-period model 'somerville_1999'"),
    ([bset("contact", ("hertz", 1.0))], "'hertz'"),
    ([bset("contact", ({"contact": "vertex", "points_per_edge": 4}, 1.0))],
     "points_per_edge = 4 belongs to the contact model.*perimeter, not to 'vertex'"),
    ([bset("contact", ({"contact": "perimeter", "points_per_edge": 100}, 1.0))], "points_per_edge.*100"),
    ([bset("joint_friction_deg", (37.0, 0.5), (95.0, 0.5))], r"friction angle must be in \(0, 90\).*95"),
    ([bset("joint_kn", (1e9, 0.5), (-1e9, 0.5))], r"kn.*-1e\+?0?9|kn.*-1000000000"),
    ([bset("connectors", ([], 0.5), ([{"law": "bronze"}], 0.5))], "bronze"),
    ([bset("connectors", ([{"law": "titanium", "count": 3, "radius": 5.0}], 1.0))], "connectors"),
])
def test_branches_the_models_refuse_are_named_before_any_run(sets, match):
    tree = lt.tree_from_dict({"branch_sets": sets})
    with pytest.raises(ParameterError, match=match):
        ta.check_tree(tree, SITE, "site.toml")


def test_run_branches_set_the_model_they_name():
    tree = lt.tree_from_dict({"branch_sets": [
        bset("vp_scale", (2.0, 1.0)), bset("tp_model", ("baker_2007", 1.0)),
        bset("contact", ({"contact": "perimeter", "points_per_edge": 4}, 1.0)),
        bset("joint_kn", (1e10, 1.0)), bset("joint_friction_deg", (30.0, 1.0)),
        bset("connectors", ([{"law": "titanium", "joints": [1, 2]}], 1.0))]})
    (m,) = ta.check_tree(tree, SITE).models
    col, opts = ta.check_model(m)
    assert (m.vp_scale, m.tp_model, opts.contact, opts.points_per_edge) == (2.0, "baker_2007", "perimeter", 4)
    assert (col.joints.kn, col.joints.ks, col.joints.friction_deg) == (1e10, 1e9, 30.0)
    assert [c.joints for c in col.connectors] == [(1, 2)]
    base = copy.deepcopy(m)
    free = lt.tree_from_dict({"branch_sets": [bset("connectors", ([], 1.0))]}).end_branches()[0]
    assert "connectors" not in ta.model_of(free, base).column_dict()


def test_the_probe_runs_the_grid_check_of_each_run_setting_once(monkeypatch):
    """With probe, each distinct run setting is checked by the grid's own check, once: 2 vp_scale x 2 contact
    = 4 settings for 8 end branches (the b set changes only the site)."""
    import pycolfrag.grid.probes as probes
    calls = []
    monkeypatch.setattr(probes, "check_solver_options", lambda col, opts, dt: calls.append((opts.contact, dt)))
    tree = lt.tree_from_dict({"branch_sets": EXAMPLE["branch_sets"][:3]})
    ta.check_tree(tree, SITE, probe=True, record_dt_s=0.01)
    assert sorted(calls) == [("perimeter", 0.01)] * 2 + [("vertex", 0.01)] * 2


def test_sampling_rule_is_the_inverse_cdf_of_the_weights():
    """A set of weights (0.2, 0.3, 0.5): a uniform u picks the first alternative whose cumulative weight
    exceeds u (OpenQuake's rule); checked on the tree's own uniforms (PCG64 of the seed)."""
    tree = lt.tree_from_dict({"samples": 50, "seed": 11, "branch_sets": [bset("vp_scale", (1.0, 0.2), (2.0, 0.3),
                                                                              (3.0, 0.5))]})
    u = np.random.Generator(np.random.PCG64(11)).random((50, 1))[:, 0]
    expected = np.where(u < 0.2, 0, np.where(u < 0.5, 1, 2))
    assert [e.index[0] for e in tree.end_branches()] == expected.tolist()


def test_the_example_tree_reads_and_passes_the_checks_against_the_example_site():
    """examples/logic_tree_athens_site.toml: 2 x 3 x 3 x 3 = 54 end branches, all site choices (no new runs),
    every branch's site accepted by the site loader."""
    tree = lt.load_tree(ROOT / "examples" / "logic_tree_athens_site.toml")
    checked = ta.check_tree(tree, SITE, "site_athens.toml")
    assert tree.site_only and len(checked.ends) == 54
    assert math.fsum(e.weight for e in checked.ends) == pytest.approx(1.0, abs=1e-14)
    assert {s.sources[1].magnitude.m_max for s in checked.sites} == {6.6, 6.8, 7.0}


def test_the_bray_rodriguez_marek_tree_is_the_default_tree_but_for_the_amplitudes_alternative():
    """examples/logic_tree_brm.toml (docs/logic_tree.md, "How much the answer rests on the amplitude's
    alternative"): the default tree's sets and weights, the amplitude's alternative Bray & Rodriguez-Marek (2004)
    instead of 2 x Eq. (6) -- so that the comparison of the two answers is that of the alternative alone."""
    default = lt.load_tree(ROOT / "examples" / "logic_tree_default.toml")
    brm = lt.load_tree(ROOT / "examples" / "logic_tree_brm.toml")
    assert [s.choice.name for s in default.branch_sets] == ["vp_scale", "contact", "pulse_model"]
    assert [(b.value, b.weight) for b in default.branch_sets[0].branches] == [(1.0, 0.6), (2.0, 0.4)]
    assert [(b.value, b.weight) for b in brm.branch_sets[0].branches] == [("rupakhety_2011", 0.6),
                                                                         ("bray_rodriguez_marek_2004", 0.4)]
    assert brm.branch_sets[1:] == default.branch_sets[1:]


def test_the_probe_refuses_a_column_that_collapses_under_gravity():
    """kn = 1e5 Pa/m passes the joints' own check (> 0) but the parthenon column falls under gravity alone:
    the grid's check (a few solver steps, well under a second) refuses it, naming the branch, before any run."""
    tree = lt.tree_from_dict({"branch_sets": [bset("joint_kn", (1e9, 0.5), (1e5, 0.5))]})
    ta.check_tree(tree, SITE)
    with pytest.raises(ParameterError, match=r"branch 'joint_kn=100000'.*collapses under gravity alone"):
        ta.check_tree(tree, SITE, probe=True)
