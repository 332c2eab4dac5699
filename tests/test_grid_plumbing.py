"""The default per-sample function, in process, with the physics replaced by stand-ins.

Checks that :func:`pycolfrag.grid.run_sample` passes the right seeds and pulse parameters to the
ground-motion model and files every record/IM/EDP value in the documented field, whatever the
solver and generator compute; the real physics is exercised by tests/test_grid.py.
"""
import json
import math
from types import SimpleNamespace

import numpy as np
import pytest

import pycolfrag as pcf
from pycolfrag import grid
from pycolfrag import results as R
from pycolfrag.analysis.data import load
from pycolfrag.analysis.summary import format_table, summary_table
from pycolfrag.cli import grid as cli


@pytest.fixture
def fake_physics(monkeypatch):
    grid.build_identity()  # the build's result hash comes from the real physics (computed once per process)
    calls = {"lhs": [], "synth": []}

    def sample_pulse_parameters(Mw, dist_km, n, seed, vp_scale=1.0, tp_model="rupakhety_2011", shape="mp03",
                                amplitude=True, vp_model=""):
        calls["lhs"].append((Mw, dist_km, n, seed, vp_scale))
        calls.setdefault("tp_model", []).append(tp_model)
        calls.setdefault("vp_model", []).append(vp_model)
        rng = np.random.default_rng(seed)
        return {"Vp_cm_s": 30 + 10 * rng.random(n), "fp_hz": 0.5 + rng.random(n), "nu_rad": rng.random(n),
                "gamma": 2 + rng.random(n), "t0_s": 5 + rng.random(n)}

    def synthesize(Mw, dist_km, seed, dt=0.005, vp_scale=1.0, pulse=None, shape="mp03"):
        calls["synth"].append((Mw, dist_km, seed, dt, vp_scale, dict(pulse)))
        acc = np.random.default_rng(seed).normal(size=2001)
        # the keys the real synthesize derives (Tp = 1/fp, A, Ap): the row copies every declared key
        meta = dict(pulse, A_cm_s=12.0, Ap_g=0.3, Tp_s=1.0 / pulse["fp_hz"], Mw=Mw, dist_km=dist_km)
        return pcf.ground_motion.Record(acc, dt, meta)

    def stochastic(Mw, dist_km, seed, dt=0.005):
        calls.setdefault("stochastic", []).append((Mw, dist_km, seed, dt))
        return pcf.ground_motion.Record(0.5 * np.random.default_rng(seed).normal(size=1501), dt,
                                        {"Mw": Mw, "dist_km": dist_km})

    def measures(acc, dt, periods=(0.2, 0.5, 1.0, 2.0, 3.0), damping=0.05):
        p = np.asarray(periods)
        return {"pga_g": float(np.abs(acc).max() / 9.81), "pgv_cm_s": 11.0, "pgd_cm": 3.0, "arias_m_s": 0.2,
                "d5_95_s": 7.0, "sa_g": p * 2, "sv_cm_s": p * 3, "periods_s": p}

    def record_measures(record, spectral):
        return measures(record.acc, record.dt, spectral.periods_s, spectral.damping)

    def simulate(col, acc_x, dt=None, options=None, **opts):
        if isinstance(acc_x, pcf.ground_motion.Record):   # a run's motion: its acc and dt
            acc_x, dt = acc_x.acc, acc_x.dt
        opts = {**(options.to_dict() if options is not None else {}), **opts}
        if opts.get("unstable_tolerance", 0.5) < 1e-6:   # the real solver would stop such runs as unstable
            raise pcf.SolverError("instability at t = 1.2 s")
        big = float(np.abs(acc_x).max()) > 3.5
        # a Response of a run without dowels or epistyles: their EDPs NaN, as the real one's
        return SimpleNamespace(**pcf.solver.scene_setup.EDP_DEFAULTS, u_top=0.01 * len(acc_x) * dt, u_d=0.002, collapsed=big,
                               collapse_block=4 if big else -1, collapse_time=2.5 if big else None,
                               n_steps=len(acc_x) * 10, t_end=len(acc_x) * dt, energy_error=1e-6, options=opts)

    class Scenario:   # the grid's rows make their records through a scenario prepared once (ground_motion.synthesis)
        def __init__(self, Mw, dist_km, dt=0.005, vp_scale=1.0, shape="mp03"):
            self.Mw, self.dist_km, self.dt, self.vp_scale, self.model = Mw, dist_km, dt, vp_scale, shape

        def record(self, seed, inputs, *, components=True, source="argument"):
            if self.model is None:
                return stochastic(self.Mw, self.dist_km, seed, self.dt)
            return synthesize(self.Mw, self.dist_km, seed, self.dt, self.vp_scale, inputs, self.model)

    class PreparedBatch:   # the grid's chunks run on the column set up once
        def __init__(self, col, options):
            self.col, self.options = col, options

        def run(self, records):
            return pcf.solver.run.simulate_batch(self.col, records, options=self.options, errors="return")

    monkeypatch.setattr(pcf.ground_motion, "sample_pulse_parameters", sample_pulse_parameters, raising=False)
    monkeypatch.setattr(pcf.ground_motion, "synthesize", synthesize, raising=False)
    monkeypatch.setattr(pcf.ground_motion, "stochastic", stochastic, raising=False)
    monkeypatch.setattr(pcf.ground_motion.synthesis, "prepare", Scenario)
    monkeypatch.setattr(pcf.ground_motion, "_checked_row", lambda synth, seed, pulse: (seed, dict(pulse), "argument"))
    monkeypatch.setattr(pcf.solver.prepared_batch, "PreparedBatch", PreparedBatch)
    monkeypatch.setattr(pcf.intensity, "measures", measures, raising=False)
    monkeypatch.setattr(pcf.intensity, "record_measures", record_measures, raising=False)
    def simulate_batch(col, records, history=False, options=None, *, width=None, errors="raise", **opts):
        calls.setdefault("batch", []).append(len(records))
        out = []
        for r in records:
            try:
                out.append(simulate(col, r, options=options, **opts))
            except Exception as exc:
                if errors == "raise":
                    raise
                out.append(exc)
        return out

    monkeypatch.setattr(pcf.solver.run, "simulate", simulate)
    monkeypatch.setattr(pcf.solver.run, "simulate_batch", simulate_batch)  # the grid's chunks run through it
    return calls


def test_run_sample_files_every_value(fake_physics):
    spec = grid.GridSpec(mw=(6.0, 7.0), dist_km=(10.0,), samples=4, seed=3, periods_s=(0.5, 1.0),
                         max_record_s=5.0, vp_scale=1.1)
    ctx = grid.SampleContext(spec)
    out = grid.run_sample(ctx, 6)  # scenario 1 (Mw 7, R 10), sample 2
    assert out["status"] == 0, out["message"]
    assert (out["scenario"], out["sample"], out["mw"], out["dist_km"]) == (1, 2, 7.0, 10.0)
    mw, dist, n, lhs_seed, vps = fake_physics["lhs"][0]
    assert (mw, dist, n, vps) == (7.0, 10.0, 4, 1.1) and lhs_seed == ctx.lhs_seed(1)
    _, _, hf_seed, dt, vps, pulse = fake_physics["synth"][0]
    assert hf_seed == ctx.hf_seed(1, 2) and dt == 0.005 and vps == 1.1
    table = grid.SampleContext(spec).pulse(1, 2)
    assert pulse == table and out["vp_cm_s"] == pulse["Vp_cm_s"] and out["fp_hz"] == pulse["fp_hz"]
    assert out["tp_s"] == 1.0 / pulse["fp_hz"] and out["a_cm_s"] == 12.0 and out["ap_g"] == 0.3
    assert out["record_s"] == pytest.approx(1001 * 0.005)  # cut to max_record_s (+1 sample)
    assert out["pgv_cm_s"] == 11.0 and list(out["sa_g"]) == [1.0, 2.0] and list(out["sv_cm_s"]) == [1.5, 3.0]
    assert out["u_top"] == pytest.approx(0.01 * 1001 * 0.005) and out["n_steps"] == 10010
    assert out["wall_s"] > 0


def test_no_pulse_row_is_the_stochastic_record_of_the_same_seed(fake_physics):
    """``pulse="none"``: the row's record is the stochastic record alone with the high-frequency seed of
    the same row of the pulse grid (so the two grids pair row by row), no pulse is drawn, the pulse
    fields stay NaN; a Tp model reaches the pulse sampling."""
    spec = grid.GridSpec(mw=(6.0, 7.0), dist_km=(10.0,), samples=4, seed=3, periods_s=(0.5, 1.0), pulse="none")
    ctx = grid.SampleContext(spec)
    out = grid.run_sample(ctx, 6)
    assert out["status"] == 0, out["message"]
    assert fake_physics["stochastic"] == [(7.0, 10.0, ctx.hf_seed(1, 2), 0.005)]
    assert fake_physics["lhs"] == [] and fake_physics["synth"] == []
    assert ctx.hf_seed(1, 2) == grid.SampleContext(grid.GridSpec(mw=(6.0, 7.0), dist_km=(10.0,), samples=4,
                                                                  seed=3)).hf_seed(1, 2)
    for k in ("vp_cm_s", "fp_hz", "nu_rad", "gamma", "t0_s", "tp_s", "a_cm_s", "ap_g"):
        assert math.isnan(out.get(k, math.nan)), k
    assert out["record_s"] == pytest.approx(1501 * 0.005) and out["u_top"] == pytest.approx(0.01 * 1501 * 0.005)
    baker = grid.GridSpec(mw=(6.0,), dist_km=(10.0,), samples=2, seed=3, tp_model="baker_2007")
    grid.run_sample(grid.SampleContext(baker), 0)
    assert fake_physics["tp_model"] == ["baker_2007"] and fake_physics["vp_model"] == [""]
    brm = grid.GridSpec(mw=(6.0,), dist_km=(10.0,), samples=2, seed=3, vp_model="bray_rodriguez_marek_2004")
    grid.run_sample(grid.SampleContext(brm), 0)      # the pulse-amplitude relation reaches the rows' pulses
    assert fake_physics["vp_model"] == ["", "bray_rodriguez_marek_2004"]


@pytest.mark.parametrize("kw, words", [
    ({"pulse": "half"}, "'half'"),
    ({"tp_model": "somerville"}, "'somerville'"),
    ({"pulse": "none", "tp_model": "baker_2007"}, "'baker_2007'"),
    ({"pulse": "none", "vp_scale": 2.0}, "2.0"),
    ({"vp_model": "somerville"}, "unknown pulse-amplitude model 'somerville'"),
    ({"pulse": "none", "vp_model": "bray_rodriguez_marek_2004"}, "'bray_rodriguez_marek_2004'"),
])
def test_pulse_options_are_checked(kw, words):
    with pytest.raises(pcf.ParameterError, match=words):
        grid.GridSpec(mw=(6.0,), dist_km=(10.0,), samples=2, **kw)


def test_pulse_choices_enter_signature_and_attributes():
    """The default grid keeps the signature it had before the pulse options (old files resume); the
    no-pulse and Baker grids differ from it and from each other; the file attributes always say which."""
    base = dict(mw=(6.0,), dist_km=(10.0,), samples=2, seed=1)
    d, n, b = (grid.GridSpec(**base, **kw) for kw in ({}, {"pulse": "none"}, {"tp_model": "baker_2007"}))
    assert "pulse" not in d.signature() and "tp_model" not in d.signature()
    assert n.signature()["pulse"] == "none" and b.signature()["tp_model"] == "baker_2007"
    assert len({json.dumps(s.signature(), sort_keys=True) for s in (d, n, b)}) == 3
    assert (d.file_attrs()["pulse"], d.file_attrs()["tp_model"]) == ("mp03", "rupakhety_2011")
    assert (n.file_attrs()["pulse"], n.file_attrs()["tp_model"]) == ("none", "")
    assert "no pulse" in n.describe() and "baker_2007" in b.describe()
    # vp_model: Eq. (6), however named, is the default's signature and attributes (no key); another relation is
    # a key of its own beside tp_model, in the signature and the attributes
    e6, v = (grid.GridSpec(**base, vp_model=x) for x in ("rupakhety_2011", "bray_rodriguez_marek_2004"))
    assert e6.vp_model == "" and e6.signature() == d.signature() and e6.file_attrs() == d.file_attrs()
    assert "vp_model" not in d.signature() and "vp_model" not in d.file_attrs()
    assert (v.signature()["vp_model"], v.file_attrs()["vp_model"], v.signature().get("tp_model")) == (
        "bray_rodriguez_marek_2004", "bray_rodriguez_marek_2004", None)
    assert "bray_rodriguez_marek_2004" in v.describe()


def test_streams_do_not_depend_on_order_or_process(fake_physics):
    spec = grid.GridSpec(mw=(6.0, 7.0), dist_km=(5.0, 10.0), samples=3, seed=11, periods_s=(1.0,))
    a = [grid.run_sample(grid.SampleContext(spec), r) for r in range(spec.n_rows)]
    ctx = grid.SampleContext(spec)
    b = {r: grid.run_sample(ctx, r) for r in reversed(spec.order(range(spec.n_rows)))}
    for r in range(spec.n_rows):
        for k, v in a[r].items():
            if k != "wall_s":
                assert np.array_equal(v, b[r][k], equal_nan=isinstance(v, float)), (r, k)
    # a sub-grid reproduces the rows of the full grid (streams keyed by Mw and R values)
    sub = grid.GridSpec(mw=(7.0,), dist_km=(10.0,), samples=3, seed=11, periods_s=(1.0,))
    s = grid.run_sample(grid.SampleContext(sub), 1)
    assert s["u_top"] == a[3 * 3 + 1]["u_top"] and s["pga_g"] == a[10]["pga_g"]


def test_solver_failure_becomes_status_3_and_run_goes_on(fake_physics, tmp_path):
    spec = grid.GridSpec(mw=(6.0,), dist_km=(10.0,), samples=2, seed=1, periods_s=(1.0,),
                         solver_options={"unstable_tolerance": 1e-9})
    summary = grid.run_grid(spec, tmp_path / "g.h5", progress=False, log=lambda s: None)
    assert summary.computed == 2 and summary.failed == 2
    r = load(tmp_path / "g.h5")
    assert (r.samples["status"] == R.STATUS_SOLVER_FAILED).all()
    assert r.samples["message"][0] == "SolverError: instability at t = 1.2 s"
    assert np.isfinite(r.samples["pga_g"]).all() and np.isnan(r.samples["u_top"]).all()


def test_in_process_run_writes_summary_and_collapse_fields(fake_physics, tmp_path):
    spec = grid.GridSpec(mw=(6.0, 7.5), dist_km=(5.0,), samples=3, seed=2, periods_s=(0.5, 1.0))
    summary = grid.run_grid(spec, tmp_path / "g.h5", progress=False, log=lambda s: None)
    assert summary.n_ranks == 1 and summary.computed == 6
    table = summary_table(summary.path)
    assert len(table) == 2
    r = load(tmp_path / "g.h5")
    c = r.samples["collapsed"]
    assert (r.samples["collapse_block"][c] == 4).all() and (r.samples["collapse_block"][~c] == -1).all()
    assert np.isnan(r.samples["collapse_time_s"][~c]).all()
    text = format_table(table)
    assert "collapses" in text and "7.5" in text
    assert sum(t["collapses"] for t in table) == int(c.sum())
    assert math.isclose(table[0]["cpu_s"], float(r.samples["wall_s"][:3].sum()))


def test_report_links_figures_from_a_custom_figures_dir(tmp_path, monkeypatch):
    # --figures-dir and --report in different folders: the report must link the PNGs where
    # make_all wrote them (it used to look in <report folder>/figures and found none)
    import functools

    from pycolfrag.analysis import figures
    from pycolfrag.analysis import report as rep
    from test_figures import write_results

    h5 = write_results(tmp_path / "grid.h5", mws=(6.5, 7.5), dists=(5.0,), n=10, n_failed=0)

    def fake_make_all(results_path, out_dir, **kw):  # the figures themselves are tested in test_figures
        (tmp_path / "figs").mkdir(exist_ok=True)
        (tmp_path / "figs" / "fig07_ud_vs_utop.png").write_bytes(b"\x89PNG")

    monkeypatch.setattr(figures, "make_all", fake_make_all)
    monkeypatch.setattr(rep, "write_report", functools.partial(rep.write_report, n_boot=20))  # speed only
    report = tmp_path / "rep" / "report.md"
    assert cli.make_outputs(h5, tmp_path / "figs", report, log=lambda s: None)
    assert "![fig07_ud_vs_utop](../figs/fig07_ud_vs_utop.png)" in report.read_text()


def test_no_pulse_row_with_the_real_generator():
    """Real physics, record cut to 3 s: the no-pulse row's PGA and PGV are those of
    ground_motion.stochastic with the row's seed (bit for bit); the row carries no pulse field (the
    results file fills them with NaN)."""
    spec = grid.GridSpec(mw=(7.0,), dist_km=(5.0,), samples=2, seed=5, periods_s=(1.0,), max_record_s=3.0,
                         pulse="none")
    ctx = grid.SampleContext(spec)
    row = grid.run_sample(ctx, 1)
    assert row["status"] == 0, row["message"]
    rec = pcf.ground_motion.stochastic(7.0, 5.0, ctx.hf_seed(0, 1))
    acc = rec.acc[: int(round(3.0 / rec.dt)) + 1]
    ims = pcf.intensity.measures(acc, rec.dt, periods=(1.0,))
    assert (row["pga_g"], row["pgv_cm_s"]) == (ims["pga_g"], ims["pgv_cm_s"])
    assert "vp_cm_s" not in row and "tp_s" not in row and row["record_s"] == pytest.approx(len(acc) * rec.dt)
