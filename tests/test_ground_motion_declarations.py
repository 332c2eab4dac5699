"""The ground-motion models' declarations (PARAMETERS, pycolfrag.ground_motion.registry): their ranges
against what the modules cite, the range checks reading them, and the one spelling of each pulse field
shared by the record's meta, the sample row, the /samples layout and the docs."""
from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np
import pytest

from pycolfrag import results as R
from pycolfrag.core.errors import ModelRangeError, ParameterError
from pycolfrag.ground_motion import atkinson_silva_2000 as as00
from pycolfrag.ground_motion import baker_2007 as b07
from pycolfrag.ground_motion import mavroeidis_papageorgiou_2003 as mp
from pycolfrag.ground_motion import record, registry, synthesize
from pycolfrag.ground_motion import rupakhety_2011 as r11
from pycolfrag.ground_motion import shahi_baker_2014 as sb14
from pycolfrag.solver import sample

DOCS = Path(__file__).resolve().parent.parent / "docs"


def _param(module, name):
    return next(p for p in module.PARAMETERS if p.name == name)


# --- ranges against the published or cited ranges --------------------------------------------------

def test_as00_ranges_are_the_cited_ones():
    """The module docstring cites 4.0 <= Mw <= 8.0 and 0 < dist_km <= 200 (the project's adopted AS00
    limits) and the generator's dt in [1e-4, 0.02] s; the declaration is read from the C generator, so
    this also checks that C and the documented limits agree."""
    assert _param(as00, "Mw").range == (4.0, 8.0)
    r = _param(as00, "R")
    assert r.range == (0.0, 200.0) and r.low_open
    assert _param(as00, "dt").range == (1e-4, 0.02)


def test_pulse_period_ranges_cover_the_papers_grid():
    """Rupakhety et al. (2011) as used by the paper: its module says the range is a validity guard
    5-8 around the paper's grid (Mw 5.5-7.5, R 5-20 km) and 0-60 km near-fault distances; Baker (2007)
    replaces Eq. (7) on the same scenarios, so it takes the same magnitudes (the same declaration)."""
    assert _param(r11, "Mw").range == (5.0, 8.0) == r11.MW_RANGE
    assert _param(r11, "R").range == (0.0, 60.0) == r11.DIST_RANGE_KM
    assert r11.MW_RANGE[0] <= 5.5 and 7.5 <= r11.MW_RANGE[1]
    assert b07.PARAMETERS[0] is _param(r11, "Mw")


def test_mp03_ranges_hold_the_sampled_values():
    """The paper samples gamma ~ N(1.8, 0.4) truncated at 1 and nu ~ U[-pi/2, pi/2]: every sampled value
    is accepted by the declared ranges (gamma > 0, any nu), and Vp, fp, A, Tp are > 0."""
    g, nu = _param(mp, "gamma"), _param(mp, "nu")
    assert g.range[0] < mp.GAMMA_MIN and g.low_open
    assert nu.range[0] <= mp.NU_RANGE_RAD[0] and mp.NU_RANGE_RAD[1] <= nu.range[1]
    rows = mp.sample_parameters(6.5, 10.0, 20, 3)
    for p in mp.PARAMETERS:
        if p.meta_key in rows:
            for v in rows[p.meta_key]:
                p.check(v, error=ParameterError)


def test_shahi_baker_angle_range_is_the_papers():
    """The directivity angle theta (phi) of Shahi & Baker (2014) is in [0, 90] degrees (module
    docstring, after Somerville et al. 1997); distances are >= 0."""
    assert [p.range for p in sb14.PARAMETERS] == [(0.0, math.inf), (0.0, math.inf), (0.0, 90.0)]


# --- the range checks read the declarations ------------------------------------------------------

def test_range_checks_use_the_declared_bounds():
    """The bounds of the declarations, not other numbers: inside and on a bound accepted, just outside
    refused with an error naming the value (and the range)."""
    lo, hi = r11.MW_RANGE
    assert r11.check_scenario(hi, 10.0) == (hi, 10.0)
    with pytest.raises(ModelRangeError, match=r"Mw = 8\.01 is outside the pulse model's range \(5\.0, 8\.0\)"):
        r11.check_scenario(8.01, 10.0)
    with pytest.raises(ModelRangeError, match=r"dist_km = 60\.5 is outside .* km"):
        r11.check_scenario(6.0, 60.5)
    with pytest.raises(ModelRangeError, match="Mw = 4.9"):
        b07.log10_fp_mean(4.9)
    assert b07.log10_fp_mean(lo) == pytest.approx(-(b07.C0 + b07.C1 * lo) / math.log(10.0), rel=1e-15)
    with pytest.raises(ParameterError, match="vp_scale must be > 0, got 0"):
        r11.mean_vp_cm_s(6.5, 10.0, 0.0)
    assert sb14.pulse_probability(5.0, 10.0, 90.0) > 0
    with pytest.raises(ParameterError, match=r"angle_deg must be in \[0, 90\] deg"):
        sb14.pulse_probability(5.0, 10.0, 90.5)
    row = {"Vp_cm_s": 30.0, "fp_hz": 0.5, "nu_rad": 0.1, "gamma": -1.0}
    with pytest.raises(ParameterError, match=r"pulse\['gamma'\] must be > 0, got -1\.0"):
        synthesize(6.5, 10.0, 1, pulse=row)
    with pytest.raises(ParameterError, match=r"pulse is missing 'fp_hz' \(needs Vp_cm_s, fp_hz, nu_rad, gamma\)"):
        synthesize(6.5, 10.0, 1, pulse={"Vp_cm_s": 30.0})


# --- one spelling: meta key <-> row field <-> layout <-> docs -------------------------------------

def test_record_meta_row_and_layout_agree():
    """A synthesized record carries every declared meta key; its sample row carries every declared pulse
    field with the value of that key; the /samples layout has each field with the declared description.
    A key spelled differently in synthesize, sample or results fails here."""
    rec = synthesize(6.5, 10.0, seed=4)
    for p in (*record.PARAMETERS, *mp.PARAMETERS):
        assert p.meta_key in rec.meta, p.meta_key
    out, acc, dt = sample._synthetic_record(6.5, 10.0, 4, None, 0.005, 1.0, None)
    assert acc is not None and out["status"] == 0
    for p in registry.PULSE_FIELDS:
        assert out[p.row_field] == float(rec.meta[p.meta_key]), p.row_field
        assert np.isfinite(out[p.row_field])
    assert out["tp_s"] == 1.0 / out["fp_hz"]               # Tp = 1/fp (Eq. 5's period)
    for p in (*registry.PULSE_FIELDS, *(q for q in record.PARAMETERS if q.row_field)):
        assert R.SAMPLE_FIELDS[p.row_field] == ("f8", R.SAMPLE_FIELDS["pga_g"][1], p.field_description)
    # the row's pulse fields are exactly the layout's between the status fields and record_s
    keys = list(R.SAMPLE_FIELDS)
    assert keys[keys.index("message") + 1:keys.index("record_s")] == [p.row_field for p in registry.PULSE_FIELDS]


def test_layout_pulse_fields_are_the_documented_ones():
    """docs/results_format.md (written by hand before the declarations) lists the pulse fields in this
    order with these meanings: the declarations reproduce both (the text of each dataset's
    ``description`` attribute is unchanged)."""
    text = (DOCS / "results_format.md").read_text()
    doc = dict(re.findall(r"^\| `(\w+)` \| \w+ \| [^|]+ \| ([^|]+) \|$", text[:text.index("## `/spectra`")], re.M))
    fields = [p.row_field for p in registry.PULSE_FIELDS]
    assert fields == ["vp_cm_s", "fp_hz", "nu_rad", "gamma", "t0_s", "tp_s", "a_cm_s", "ap_g"]
    for p in (*registry.PULSE_FIELDS, *(q for q in record.PARAMETERS if q.row_field)):
        assert doc[p.row_field].strip().startswith(p.field_description), p.row_field


def test_tp_model_choices_are_the_declared_pulse_period_models():
    """The paper's Eq. (7) (the default) and Baker (2007) are the declared pulse-period relations, and the
    grid offers exactly the declared ones."""
    assert {"rupakhety_2011", "baker_2007"} <= set(registry.TP_MODELS)
    assert registry.DEFAULT_TP_MODEL == "rupakhety_2011" and all(
        m.KIND == "pulse_period" for m in registry.TP_MODELS.values())
    from pycolfrag import grid
    action = next(a for a in grid.build_parser()._actions if "--tp-model" in a.option_strings)
    assert list(action.choices) == sorted(registry.TP_MODELS)
    with pytest.raises(ParameterError, match="unknown pulse-period model 'x'"):
        registry.tp_model_of("x")


def test_declared_names_are_unique():
    """A row field belongs to one model, except that pulse shapes share the fields they have in common
    (the meaning, meta key and unit the same: a row of either shape fills the same /samples column)."""
    fields = [p.row_field for m in registry.MODELS.values() if m.KIND != "pulse" for p in m.PARAMETERS
              if p.row_field]
    fields += [p.row_field for p in registry.PULSE_FIELDS]
    assert len(fields) == len(set(fields))
    for m in registry.PULSE_SHAPES.values():
        for p in m.PARAMETERS:
            if p.row_field:
                q = next(f for f in registry.PULSE_FIELDS if f.row_field == p.row_field)
                assert (q.meta_key, q.unit, q.field_description) == (p.meta_key, p.unit, p.field_description)
    for m in registry.MODELS.values():
        assert m.KIND in registry.KINDS and registry.MODELS[m.NAME] is m
    # every listed module kept its entry (the registry refuses to import with two models of one NAME)
    assert len(registry.MODELS) == len(registry._LISTED)


def test_docs_tables_are_the_declarations():
    """docs/ground_motion.md prints registry.docs_section() between its markers."""
    text = (DOCS / "ground_motion.md").read_text()
    block = text[text.index("<!-- declarations:begin -->\n") + len("<!-- declarations:begin -->\n"):
                 text.index("<!-- declarations:end -->")]
    assert block == registry.docs_section()
