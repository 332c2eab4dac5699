"""The event-based site simulation with real runs: the grid's guarantees for its batches.

A site of four strata (tests/data/site_rare_tiny.toml) and the two-drum verification column
(bench/data/column_two_drums.toml) with records cut to 8 s: a run takes about 10 ms. Expected numbers
are not physics here but identities -- the same rows bit for bit (analysis.compare), the same estimate
-- between 1 and 2 MPI ranks, an interrupted and an uninterrupted run, a run extended and one asked for
the larger budget at once; and the refusals, each with its message.
"""
from __future__ import annotations

import json
import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from pycolfrag import grid
from pycolfrag.analysis.compare import compare_results
from pycolfrag.risk import site_risk as risk
from pycolfrag.structure.column import Column

ROOT = Path(__file__).resolve().parents[1]
SITE = ROOT / "tests" / "data" / "site_rare_tiny.toml"
COLUMN = ROOT / "bench" / "data" / "column_two_drums.toml"
#: --pilot 5: the pilot these tests' run counts were written for (by default the tiny site's 4 strata would get 15
#: runs each, the pilot sized per site: SiteSettings.pilot_for)
BASE = [str(SITE), "--column", str(COLUMN), "--max-record-s", "8", "--seed", "5", "--pilot", "5", "--no-progress",
        "--no-figures"]
ARGS = BASE + ["--batch", "20"]


def _env():
    env = {k: v for k, v in os.environ.items()
           if not (k.startswith("PMIX_") or k.startswith("OMPI_")) or k.startswith("OMPI_ALLOW_RUN_AS_ROOT")}
    env.update(OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1", OMP_NUM_THREADS="1",
               OPENBLAS_NUM_THREADS="1")
    return env


def _cmd(args, ranks=1, command="risk"):
    """The ``pycolfrag COMMAND`` line of ``args``, on ``ranks`` MPI ranks (mpirun) when more than one (also the
    sequences command's tests)."""
    py = [sys.executable, "-m", "pycolfrag", command]
    if ranks == 1:
        return py + args
    return ["timeout", "-k", "10", "240", "mpirun", "--allow-run-as-root", "-n", str(ranks), sys.executable, "-m",
            "mpi4py", "-m", "pycolfrag", command] + args


def _run(args, ranks=1, command="risk", env=None):
    if ranks > 1 and shutil.which("mpirun") is None:
        pytest.skip("mpirun not installed (make system)")
    return subprocess.run(_cmd(args, ranks, command), capture_output=True, text=True, env=env or _env(), cwd=ROOT,
                          timeout=300)


def _levels(out: Path) -> dict:
    return json.loads((out / "risk.json").read_text())["levels"]


def _same_rows(a: Path, b: Path):
    names = sorted(p.name for p in a.glob("batch_*.h5"))
    assert names and names == sorted(p.name for p in b.glob("batch_*.h5"))
    for n in names:
        c = compare_results(a / n, b / n)
        assert c.identical, f"{n}: {c.summary()}"


@pytest.fixture(scope="module")
def one_rank(tmp_path_factory):
    out = tmp_path_factory.mktemp("rare") / "one"
    p = _run(ARGS + ["--max-runs", "60", "--simulate", str(out)])
    assert p.returncode in (0, 6), p.stdout + p.stderr     # 6: the budget ended before every level converged
    return out, p


@pytest.mark.mpi
def test_one_and_two_ranks_write_the_same_rows_and_estimate(one_rank, tmp_path):
    out1, p1 = one_rank
    p2 = _run(ARGS + ["--max-runs", "60", "--simulate", str(tmp_path / "two")], ranks=2)
    assert p2.returncode == p1.returncode, p2.stdout + p2.stderr
    _same_rows(out1, tmp_path / "two")
    assert _levels(out1) == _levels(tmp_path / "two")
    assert "site simulation: batch 2 done, 60 runs" in p1.stdout and "site simulation: batch 2 done" in p2.stdout


def test_kill_9_mid_batch_then_resume_gives_the_uninterrupted_estimate(tmp_path):
    args = BASE + ["--batch", "300", "--max-runs", "320"]
    ref = _run(args + ["--simulate", str(tmp_path / "ref")])
    assert ref.returncode in (0, 6), ref.stdout + ref.stderr
    out = tmp_path / "killed"
    proc = subprocess.Popen(_cmd(args + ["--simulate", str(out)]), stdout=subprocess.DEVNULL,
                            stderr=subprocess.DEVNULL, env=_env(), cwd=ROOT, start_new_session=True)
    journal = out / "batch_001.h5.journal"
    t0 = time.time()
    while proc.poll() is None and time.time() - t0 < 120:
        if journal.exists() and journal.read_text().count("\n") > 20:
            break
        time.sleep(0.05)
    assert proc.poll() is None, "the run ended before it could be killed"
    os.killpg(proc.pid, signal.SIGKILL)
    proc.wait()
    done = journal.read_text().count("\n") - 1
    assert 20 <= done < 300                          # killed in the middle of its second batch
    assert not (out / "risk.json").exists()
    again = _run(args + ["--simulate", str(out)])
    assert again.returncode == ref.returncode, again.stdout + again.stderr
    assert "resuming" in again.stdout
    _same_rows(tmp_path / "ref", out)
    assert _levels(tmp_path / "ref") == _levels(out)


def test_a_batch_is_sized_by_the_budget_and_a_larger_budget_goes_on_after_it(one_rank, tmp_path):
    """A batch is never larger than the budget left: with batches of 20 and a budget of 50 the third batch is
    planned (and its file made) for 10 runs, not 20 cut to 10. A larger budget then reads the three batches
    back unchanged and plans the rest after them; the first two are those of a run asked for 60 at once."""
    out1, _ = one_rank
    out = tmp_path / "ext"
    first = _run(ARGS + ["--max-runs", "50", "--simulate", str(out)])
    assert first.returncode == 6 and "batch 2 done, 50 runs" in first.stdout
    plan = json.loads((out / "batch_002.plan.json").read_text())
    assert len(plan["inputs"]) == 10 and sum(n for _, n in plan["purpose"]["counts"]) == 10
    before = {p.name: p.read_bytes() for p in out.glob("batch_*")}
    second = _run(ARGS + ["--max-runs", "60", "--simulate", str(out)])
    assert second.returncode in (0, 6), second.stdout + second.stderr
    assert "batch 3 done, 60 runs" in second.stdout
    assert all((out / name).read_bytes() == data for name, data in before.items())   # read back, not rerun
    assert len(json.loads((out / "batch_003.plan.json").read_text())["inputs"]) == 10
    for n in ("batch_000.h5", "batch_001.h5"):
        c = compare_results(out1 / n, out / n)
        assert c.identical, f"{n}: {c.summary()}"


def test_a_resume_with_another_site_or_settings_is_refused(one_rank, tmp_path):
    out = tmp_path / "copy"
    shutil.copytree(one_rank[0], out)
    site = tmp_path / "site.toml"
    site.write_text(SITE.read_text().replace("rate = 0.01", "rate = 0.02"))
    p = _run([str(site)] + ARGS[1:] + ["--max-runs", "60", "--simulate", str(out)])
    assert p.returncode == 2 and "another site or with other settings" in p.stdout and "  - site:" in p.stdout
    p = _run(ARGS + ["--max-runs", "60", "--defensive", "0.5", "--simulate", str(out)])
    # the differing key itself (the table was once cut at 120 characters, before it)
    assert p.returncode == 2 and "  - settings: defensive: file has " in p.stdout, p.stdout
    assert "this run asks for 0.5" in p.stdout
    p = _run(ARGS + ["--max-runs", "60", "--column", str(ROOT / "examples" / "column_parthenon.toml"),
                     "--simulate", str(out)])
    assert p.returncode == 2 and "batch of another simulation" in p.stdout and "column:" in p.stdout
    _same_rows(one_rank[0], out)                     # nothing was written by the refused runs


def test_a_resume_by_other_code_is_refused_unless_allowed(one_rank, tmp_path, monkeypatch, capsys):
    out = tmp_path / "code"
    shutil.copytree(one_rank[0], out)
    monkeypatch.setattr(grid.events, "code_digest", lambda opts: "0" * 64)
    assert risk.main(ARGS + ["--max-runs", "60", "--simulate", str(out)]) == 2
    assert "computed by another build of pycolfrag" in capsys.readouterr().out
    assert risk.main(ARGS + ["--max-runs", "60", "--allow-code-change", "--simulate", str(out)]) in (0, 6)
    assert _levels(one_rank[0]) == _levels(out)


@pytest.mark.parametrize("extra, message", [
    (["--target-cov", "0"], "target CoV must be in (0, 1)"),
    (["--target-cov", "1"], "target CoV must be in (0, 1)"),
    (["--max-runs", "19"], "--max-runs 19 is below one pilot: 20 runs (5 in each of the site's 4 strata)"),
    (["--defensive", "0"], "the weights degenerate"),
])
def test_bad_settings_are_refused_before_any_run(tmp_path, capsys, extra, message):
    out = tmp_path / "bad"
    assert risk.main(ARGS + extra + ["--simulate", str(out)]) == 2
    assert message in capsys.readouterr().out
    assert not list(out.glob("*.h5")) if out.exists() else True


def test_a_site_the_models_never_reach_is_refused(tmp_path, capsys):
    site = tmp_path / "far.toml"
    site.write_text(SITE.read_text().replace("mw = 6.5", "mw = 8.5"))
    assert risk.main([str(site)] + ARGS[1:] + ["--simulate", str(tmp_path / "far")]) == 2
    out = capsys.readouterr().out
    assert "no event of the site's sources lies where the ground-motion models apply" in out and "'one': 1 of" in out


def test_an_event_with_a_grid_rows_inputs_is_that_row():
    """The event kind computes the grid's row: the inputs of row 3 of a grid (its noise seed and pulse) give
    every field of that row bit for bit."""
    col = Column.from_file(COLUMN).to_dict()
    gs = grid.GridSpec(mw=(6.5,), dist_km=(7.5,), samples=4, seed=9, column=col, max_record_s=4.0)
    ctx = gs.context()
    want = grid.run_sample(ctx, 3)
    inp = {"mw": 6.5, "dist_km": 7.5, "hf_seed": ctx.hf_seed(0, 3),
           "pulse": {k: v for k, v in ctx.pulse(0, 3).items() if k in ("Vp_cm_s", "fp_hz", "nu_rad", "gamma")}}
    es = grid.EventBatchSpec(inputs=(inp,), column=col, max_record_s=4.0)
    got = grid.run_event(es.context(), 0)
    same = [k for k in want if k not in ("row", "scenario", "sample", "wall_s")]
    assert len(same) > 20
    for k in same:
        a, b = got[k], want[k]
        assert (a == b) if isinstance(b, str) else np.asarray(a).tobytes() == np.asarray(b).tobytes(), k
    assert got["pulse"] == 1 and got["stage"] == 0


@pytest.mark.mpi
def test_a_stale_build_is_refused_on_every_rank(tmp_path):
    """A checkout whose csrc/ holds an edit of a header its library was not rebuilt from:
    the simulation is refused before any run, in one line, on 1 and on 2 ranks (the workers, inside
    their first batch, stop with rank 0 instead of waiting for it or printing a traceback)."""
    if shutil.which("mpirun") is None:
        pytest.skip("mpirun not installed (make system)")
    stale = tmp_path / "stale"
    shutil.copytree(ROOT / "pycolfrag", stale / "pycolfrag", ignore=shutil.ignore_patterns("__pycache__"))
    shutil.copytree(ROOT / "csrc", stale / "csrc")
    law = stale / "csrc" / "connector_law.h"
    law.write_text(law.read_text() + "/* edited, not rebuilt */\n")
    env = dict(_env(), PYTHONPATH=str(stale))
    for ranks in (1, 2):
        out = tmp_path / f"sim{ranks}"
        p = subprocess.run(_cmd(ARGS + ["--max-runs", "60", "--simulate", str(out)], ranks), capture_output=True,
                           text=True, env=env, cwd=stale, timeout=300)
        assert p.returncode == 2, p.stdout + p.stderr
        assert "stale build: the loaded C library" in p.stdout and "Traceback" not in p.stderr, p.stdout + p.stderr
        assert not list(out.glob("batch_*.h5"))
