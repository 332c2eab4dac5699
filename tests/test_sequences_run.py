"""Sequences at a site as a command (pycolfrag/risk/sequences_run.py; docs/sequences.md, "Running it"): the
journal holds exactly the sequences :func:`pycolfrag.risk.sequences.run_site_sequences` computes in one
process (the reference: the same function call for call, so equality is exact, NaN included), a stopped
run resumes to the same sequences (SIGTERM: exit 75; a torn last line dropped), a larger ``--n`` adds
sequences, a journal of other settings or another site is refused by name, a held folder is refused
(exit 5), and two MPI ranks give the one-rank sequences."""
from __future__ import annotations

import dataclasses
import json
import signal
import subprocess
import time
from pathlib import Path

import pytest

from pycolfrag.results.lock import RunLock
from pycolfrag.risk import sequences as sq
from pycolfrag.risk import sequences_run as sr
from pycolfrag.risk.aftershocks import AFTERSHOCK_MODELS
from pycolfrag.site.sources import load_site
from pycolfrag.solver.sequence import Restoration
from pycolfrag.structure.column import Column
from test_rare_site_plumbing import _cmd as plumbing_cmd
from test_rare_site_plumbing import _env as plumbing_env
from test_rare_site_plumbing import _run as plumbing_run

ROOT = Path(__file__).resolve().parents[1]
COLUMN = ROOT / "bench" / "data" / "column_two_drums.toml"   # the rare route's cheap verification column
SITE = """name = "sequences test"
outside = "zero"
[pulse]
probability = 0.5
[[sources]]
name = "near"
rate = 0.2
magnitude = {type = "characteristic", mw = 6.5}
distance = {type = "uniform", min_km = 5.0, max_km = 10.0}
[[sources]]
name = "far"
rate = 0.1
magnitude = {type = "characteristic", mw = 5.5}
distance = {type = "uniform", min_km = 20.0, max_km = 40.0}
"""
# short records keep the runs cheap (changes the numbers, not the bookkeeping under test)
ARGS = ["--column", str(COLUMN), "--years", "10", "--seed", "3", "--max-record-s", "4", "--no-progress"]


def _env():
    """The rare route's tests' environment for mpirun as root (test_rare_site_plumbing), with this checkout."""
    return {**plumbing_env(), "PYTHONPATH": str(ROOT)}


def _cmd(args, ranks=1):
    return plumbing_cmd(args, ranks, "sequences")


def _run(args, ranks=1):
    return plumbing_run(args, ranks, "sequences", _env())


def _stopped(args, journal: Path, lines: int):
    """The command started, sent SIGTERM once ``journal`` has ``lines`` lines: (the process, its output)."""
    proc = subprocess.Popen(_cmd(args), stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, env=_env(),
                            cwd=ROOT)
    t0 = time.time()
    while proc.poll() is None and time.time() - t0 < 120:
        if journal.exists() and journal.read_text().count("\n") >= lines:
            break
        time.sleep(0.01)
    assert proc.poll() is None, "the run ended before it could be stopped"
    proc.send_signal(signal.SIGTERM)
    return proc, proc.communicate(timeout=120)[0]


def _journal(out: Path) -> dict:
    """The journal's sequences by index, as their JSON lines without the wall time."""
    lines = (out / sr.JOURNAL).read_text().splitlines()[1:]
    return {d["sequence"]: json.dumps({k: v for k, v in d.items() if k != "seconds"})
            for d in map(json.loads, lines)}


@pytest.fixture(scope="module")
def site_file(tmp_path_factory):
    p = tmp_path_factory.mktemp("seq") / "site.toml"
    p.write_text(SITE)
    return p


@pytest.fixture(scope="module")
def reference(site_file):
    """Six sequences run in this process by run_site_sequences, as journal lines."""
    st = sq.SequenceSettings(years=10.0, n_sequences=6, seed=3, restoration=Restoration(u_d=0.005), max_record_s=4.0)
    run = sq.run_site_sequences(load_site(site_file), Column.from_file(COLUMN), st)
    return {o.sequence: json.dumps({k: v for k, v in sr.outcome_to_dict(o, 0.0).items() if k != "seconds"})
            for o in run["outcomes"]}


def test_the_journal_is_the_in_process_run_and_a_larger_n_adds_sequences(site_file, reference, tmp_path):
    out = tmp_path / "out"
    p = _run([str(site_file), str(out), "--n", "3"] + ARGS)
    assert p.returncode == 0, p.stdout + p.stderr
    assert _journal(out) == {s: reference[s] for s in range(3)}
    p = _run([str(site_file), str(out), "--n", "6"] + ARGS)
    assert p.returncode == 0, p.stdout + p.stderr
    assert _journal(out) == reference
    sm = json.loads((out / "summary.json").read_text())
    assert sm["n_sequences"] == 6 and "P(collapse within 10 yr)" in (out / "summary.md").read_text()


def test_a_torn_last_line_is_dropped_and_rerun(site_file, reference, tmp_path):
    out = tmp_path / "out"
    assert _run([str(site_file), str(out), "--n", "6"] + ARGS).returncode == 0
    text = (out / sr.JOURNAL).read_text()
    last = text.rstrip("\n").rpartition("\n")[2]
    (out / sr.JOURNAL).write_text(text[:len(text) - len(last) - 1] + last[:len(last) // 2])   # cut mid-line
    p = _run([str(site_file), str(out), "--n", "6"] + ARGS)
    assert p.returncode == 0 and "cut short" in p.stdout, p.stdout + p.stderr
    assert _journal(out) == reference


@pytest.mark.parametrize("begun, change, named", [
    ([], ["--seed", "4"], "seed"), ([], ["--years", "11"], "years"), ([], ["--restore-u-d", "0.01"], "u_d"),
    # another aftershock model: its parameters are the identity's (dataclasses.asdict of the model), so a journal
    # begun with rj1989 (the bare flag) is refused with Page et al.'s SZ-GENERIC, naming the fields that differ
    (["--aftershocks"], ["--aftershocks", "page2016-sz-generic"], "aftershocks.a")])
def test_a_journal_of_other_settings_is_refused_by_name(site_file, tmp_path, begun, change, named):
    out = tmp_path / "out"
    assert _run([str(site_file), str(out), "--n", "1"] + ARGS + begun).returncode == 0
    before = (out / sr.JOURNAL).read_bytes()
    args = ARGS + begun
    i = args.index(change[0]) if change[0] in args else None
    args = args[:i] + args[i + 2:] + change if i is not None else args + change
    p = _run([str(site_file), str(out), "--n", "2"] + args)
    assert p.returncode == 2 and "another run" in p.stdout and named in p.stdout, p.stdout + p.stderr
    assert (out / sr.JOURNAL).read_bytes() == before


def test_a_journal_of_another_site_file_is_refused(site_file, tmp_path):
    out = tmp_path / "out"
    assert _run([str(site_file), str(out), "--n", "1"] + ARGS).returncode == 0
    other = tmp_path / "other.toml"
    other.write_text(SITE.replace("rate = 0.2", "rate = 0.3"))
    p = _run([str(other), str(out), "--n", "1"] + ARGS)
    assert p.returncode == 2 and "site_sha256" in p.stdout, p.stdout + p.stderr


def test_a_folder_held_by_a_running_run_is_refused(site_file, tmp_path):
    out = tmp_path / "out"
    out.mkdir()
    lock = RunLock.acquire(out / sr.JOURNAL, log=lambda s: None)
    try:
        p = _run([str(site_file), str(out), "--n", "1"] + ARGS)
    finally:
        lock.release()
    assert p.returncode == 5 and "another run" in p.stdout, p.stdout + p.stderr


def test_bad_arguments_are_refused_by_name(site_file, tmp_path):
    p = _run([str(site_file), str(tmp_path / "o"), "--n", "0"] + ARGS)
    assert p.returncode == 2 and "n_sequences" in p.stdout and "0" in p.stdout
    p = _run([str(tmp_path / "absent.toml"), str(tmp_path / "o")] + ARGS)
    assert p.returncode == 2 and "absent.toml" in p.stdout
    p = _run([str(site_file), str(tmp_path / "o")] + ARGS + ["--aftershocks", "page2016-greece"])
    assert p.returncode == 2 and "'page2016-greece'" in p.stdout and "page2016-sz-generic" in p.stdout, p.stdout


@pytest.mark.parametrize("words, model", [([], "rj1989"), (["page2016-sz-generic"], "page2016-sz-generic")])
def test_aftershocks_before_the_site_file_leave_it_the_site(site_file, tmp_path, words, model):
    """``--aftershocks SITE OUT``: the site file is the site, with rj1989 (it was read as the model and refused), and
    ``--aftershocks page2016-sz-generic SITE OUT`` keeps that model: the journal's identity holds its parameters."""
    out = tmp_path / "out"
    p = _run(["--aftershocks", *words, str(site_file), str(out), "--n", "1"] + ARGS)
    assert p.returncode == 0, p.stdout + p.stderr
    head = json.loads((out / sr.JOURNAL).open().readline())["identity"]
    assert head["settings"]["aftershocks"] == json.loads(json.dumps(dataclasses.asdict(AFTERSHOCK_MODELS[model])))


def test_sigterm_stops_after_the_running_sequence_and_the_rerun_completes(site_file, tmp_path):
    """SIGTERM once two sequences are in the journal: exit 75 with every finished sequence kept; the rerun
    gives the journal of an uninterrupted run."""
    out, whole = tmp_path / "stopped", tmp_path / "whole"
    args = ["--n", "30"] + ARGS
    proc, text = _stopped([str(site_file), str(out)] + args, out / sr.JOURNAL, 3)
    assert proc.returncode == 75 and "rerun the same command" in text, text
    assert not (out / "summary.json").exists()
    kept = _journal(out)
    assert 2 <= len(kept) < 30
    assert _run([str(site_file), str(out)] + args).returncode == 0
    assert _run([str(site_file), str(whole)] + args).returncode == 0
    assert _journal(out) == _journal(whole)


@pytest.mark.mpi
def test_two_mpi_ranks_give_the_one_rank_sequences(site_file, reference, tmp_path):
    p = _run([str(site_file), str(tmp_path / "two"), "--n", "6"] + ARGS, ranks=2)
    assert p.returncode == 0, p.stdout + p.stderr
    assert _journal(tmp_path / "two") == reference
    assert json.loads((tmp_path / "two" / "summary.json").read_text())["n_sequences"] == 6


# --------------------------------------------------------------------------- --rare: the strongest event's rows

RARE = ["--rare", "--target", "u_d > 0.005", "--target-cov", "0.01", "--pilot", "2", "--batch", "16",
        "--max-rows", "48"]


def test_the_rare_options_not_given_are_the_settings_defaults():
    """Only the --rare options given reach RareSequenceSettings; the others are its fields' defaults (their one text),
    which the help states."""
    from pycolfrag.risk import sequences_rare as R
    st = sq.SequenceSettings()
    args = sr.parser().parse_args(["site.toml", "out", "--rare"])
    assert sr.rare_settings(args, st) == R.RareSequenceSettings(sequences=st)
    args = sr.parser().parse_args(["site.toml", "out", "--rare", "--pilot", "3", "--ways", "accumulated, intact"])
    assert sr.rare_settings(args, st) == R.RareSequenceSettings(sequences=st, pilot=3, ways=("accumulated", "intact"))
    text = " ".join(sr.parser().format_help().split())
    assert "the row budget (default: 20000)" in text and "(default: accumulated,intact,restored)" in text, text


def _rows(out: Path) -> list:
    """The rows of a rare journal in order, without their wall times."""
    lines = (out / "rows.jsonl").read_text().splitlines()[1:]
    return [json.dumps({k: v for k, v in d.items() if k != "seconds"}) for d in map(json.loads, lines)]


def _rare_run(site_file, aftershocks=None) -> dict:
    """The rare estimator run in this process with the command's settings (``aftershocks``: --aftershocks's)."""
    from pycolfrag.risk import sequences_rare as rare
    st = sq.SequenceSettings(years=10.0, n_sequences=1000, seed=3, restoration=Restoration(u_d=0.005),
                             max_record_s=4.0, aftershocks=aftershocks)
    rs = rare.RareSequenceSettings(sequences=st, target="u_d > 0.005", target_cov=0.01, pilot=2, batch=16,
                                   max_rows=48)
    return rare.simulate_sequences(load_site(site_file), Column.from_file(COLUMN), rs)


@pytest.fixture(scope="module")
def rare_reference(site_file):
    """The rare estimator's rows (without their wall times) and estimate, run in this process."""
    run = _rare_run(site_file)
    return [json.dumps({k: v for k, v in r.items() if k != "seconds"}) for r in run["rows"]], run["estimate"]


def test_rare_rows_are_those_of_the_ways_run_apart(site_file, rare_reference, monkeypatch):
    """The runs the ways share (docs/sequences.md, "Runs shared between the ways") change no row but its count of
    runs made: the estimator with every way's every event run (``sq._SHARE = False``) gives the same rows bit for
    bit (JSON lines), its runs those made here plus those shared, and the same estimate."""
    monkeypatch.setattr(sq, "_SHARE", False)
    apart = _rare_run(site_file)
    rows = [json.loads(r) for r in rare_reference[0]]
    assert sum(r["shared"] for r in rows) > 0 and any(r["restorations"] for r in rows)
    assert [r["runs"] for r in apart["rows"]] == [r["runs"] + r["shared"] for r in rows]
    assert all(r["shared"] == 0 for r in apart["rows"])

    def bare(r: dict) -> str:
        return json.dumps({k: v for k, v in r.items() if k not in ("seconds", "runs", "shared")})
    assert [bare(r) for r in apart["rows"]] == [bare(r) for r in rows]
    assert json.dumps(apart["estimate"]) == json.dumps(rare_reference[1])


def test_rare_rows_are_the_in_process_estimators(site_file, rare_reference, tmp_path):
    out = tmp_path / "rare"
    p = _run([str(site_file), str(out)] + ARGS + RARE)
    assert p.returncode == 6 and "row budget" in p.stdout, p.stdout + p.stderr   # CoV 0.01 is out of 48 rows' reach
    assert _rows(out) == rare_reference[0]
    est = json.loads((out / "rare_summary.json").read_text())["estimate"]
    assert est["accumulated"]["u_d > 0.005"]["p"] == rare_reference[1]["accumulated"]["u_d > 0.005"]["p"]
    assert "importance sampling on the strongest event" in (out / "rare_summary.md").read_text()


def test_a_rare_run_its_budget_stopped_goes_on_under_a_larger_one(site_file, rare_reference, tmp_path):
    """A budget of the pilot and whole batches (16 + 16 rows: exit 6, "the rows so far are kept") resumes under a
    larger one (48) and gives the rows of the run begun with 48, bit for bit; a budget that cut its last batch (16 +
    a batch of 20 of 24) is part of the journal's identity: a larger one is refused naming it (another budget
    would place other rows), and the stop says to begin another folder."""
    out = tmp_path / "grown"
    p = _run([str(site_file), str(out)] + ARGS + RARE + ["--max-rows", "32"])
    assert p.returncode == 6 and "the rows so far are kept" in p.stdout, p.stdout + p.stderr
    assert _rows(out) == rare_reference[0][:32]
    p = _run([str(site_file), str(out)] + ARGS + RARE)
    assert p.returncode == 6, p.stdout + p.stderr
    assert _rows(out) == rare_reference[0]
    cut = tmp_path / "cut"
    p = _run([str(site_file), str(cut)] + ARGS + RARE + ["--batch", "24", "--max-rows", "36"])
    assert p.returncode == 6 and "its last batch was cut" in p.stdout, p.stdout + p.stderr
    assert len(_rows(cut)) == 36
    p = _run([str(site_file), str(cut)] + ARGS + RARE + ["--batch", "24", "--max-rows", "64"])
    assert p.returncode == 2 and "max_rows: 36 in the journal" in p.stdout + p.stderr, p.stdout + p.stderr


def test_rare_sigterm_then_resume_gives_the_uninterrupted_rows(site_file, rare_reference, tmp_path):
    out = tmp_path / "stopped"
    proc, text = _stopped([str(site_file), str(out)] + ARGS + RARE, out / "rows.jsonl", 9)
    assert proc.returncode == 75, text
    assert not (out / "rare_summary.json").exists()
    p = _run([str(site_file), str(out)] + ARGS + RARE)
    assert p.returncode == 6 and "row budget" in p.stdout, p.stdout + p.stderr   # CoV 0.01 is out of 48 rows' reach
    assert _rows(out) == rare_reference[0]


def test_rare_with_aftershocks_sigterm_then_resume_gives_the_uninterrupted_rows(site_file, rare_reference, tmp_path):
    """``--rare --aftershocks`` (docs/sequences.md, "Aftershocks in the rare sequences"): stopped by SIGTERM (exit 75)
    and rerun, the journal holds the rows the estimator makes in this process, whose sequences hold more events
    than without aftershocks."""
    from pycolfrag.risk.aftershocks import REASENBERG_JONES_1989
    run = _rare_run(site_file, REASENBERG_JONES_1989)
    want = [json.dumps({k: v for k, v in r.items() if k != "seconds"}) for r in run["rows"]]
    out = tmp_path / "stopped"
    proc, text = _stopped([str(site_file), str(out)] + ARGS + RARE + ["--aftershocks"], out / "rows.jsonl", 9)
    assert proc.returncode == 75, text
    p = _run([str(site_file), str(out)] + ARGS + RARE + ["--aftershocks"])
    assert p.returncode == 6 and "row budget" in p.stdout, p.stdout + p.stderr
    assert _rows(out) == want
    ran = [json.loads(r) for r in want]
    without = [json.loads(r) for r in rare_reference[0]]
    pilot = [[(r["h"], r["j"], r["strongest"]) for r in rows if r["stage"] == 0] for rows in (ran, without)]
    assert pilot[0] == pilot[1]   # the pilot's rows are the same events, ranked alike (the mainshocks alone)
    assert sum(r["events"] for r in ran) > sum(r["events"] for r in without)


def test_rare_ways_and_tail_share_are_the_in_process_estimators_and_part_of_the_identity(site_file, tmp_path):
    """``--ways accumulated --tail-share 0.5``: the journal holds the rows the estimator makes in this process with
    those settings (the accumulated way alone in each row, half the tails run); a journal begun with them is refused
    with another share; the settings are refused by name out of range (without --rare: the test below)."""
    from pycolfrag.risk import sequences_rare as rare
    st = sq.SequenceSettings(years=10.0, n_sequences=1000, seed=3, restoration=Restoration(u_d=0.005),
                             max_record_s=4.0)
    rs = rare.RareSequenceSettings(sequences=st, target="u_d > 0.005", target_cov=0.01, pilot=2, batch=16,
                                   max_rows=32, ways=("accumulated",), tail_share=0.5)
    run = rare.simulate_sequences(load_site(site_file), Column.from_file(COLUMN), rs)
    want = [json.dumps({k: v for k, v in r.items() if k != "seconds"}) for r in run["rows"]]
    assert all(set(r["hits"]) == {"accumulated"} for r in run["rows"])
    ran = [r for r in run["rows"] if r["strongest"]]
    assert {r["tail_weight"] for r in ran} == {0.0, 2.0}
    out = tmp_path / "acc"
    mine = ["--ways", "accumulated", "--tail-share", "0.5", "--max-rows", "32"]
    p = _run([str(site_file), str(out)] + ARGS + RARE + mine)
    assert p.returncode == 6, p.stdout + p.stderr
    assert _rows(out) == want
    assert "P(within 10 yr): accumulated" in (out / "rare_summary.md").read_text()
    p = _run([str(site_file), str(out)] + ARGS + RARE + mine[:-4] + ["--tail-share", "0.25", "--max-rows", "32"])
    assert p.returncode == 2 and "tail_share" in p.stdout, p.stdout + p.stderr
    p = _run([str(site_file), str(out)] + ARGS + RARE + ["--tail-share", "0.5", "--max-rows", "32"])   # all ways
    assert p.returncode == 2 and "ways" in p.stdout, p.stdout + p.stderr
    for bad, named in ((["--ways", "intact"], "ways"), (["--tail-share", "0"], "tail_share")):
        p = _run([str(site_file), str(tmp_path / "bad")] + ARGS + RARE + bad)
        assert p.returncode == 2 and named in p.stdout, p.stdout + p.stderr


def _rare_group():
    """The parser's importance-sampling group: the group that holds ``--rare``, read from argparse itself so that an
    option added to it is a case below without being listed here."""
    return next(g for g in sr.parser()._action_groups if any(a.dest == "rare" for a in g._group_actions))


# a valid value of each (a refusal for the value would hide the one for the missing --rare)
_RARE_VALUES = {"target": ["collapse"], "target_cov": ["0.2"], "pilot": ["5"], "batch": ["200"], "max_rows": ["100"],
                "ways": ["accumulated"], "tail_share": ["0.5"], "shift": ["1.0", "0.5"]}
_GROUP_ACTIONS = [a for a in _rare_group()._group_actions if a.dest != "rare"]


def test_every_rare_only_option_is_none_in_the_parser_and_has_a_case():
    """"Given" is "not None" for the refusal, and the cases below cover the whole group."""
    assert all(a.default is None for a in _GROUP_ACTIONS)
    assert sorted(a.dest for a in _GROUP_ACTIONS) == sorted(_RARE_VALUES)


@pytest.mark.parametrize("options", [[a.option_strings[0]] for a in _GROUP_ACTIONS] + [["--pilot", "--shift"]],
                         ids=lambda o: ",".join(o))
def test_the_rare_options_are_refused_by_name_without_rare(site_file, tmp_path, options):
    """Each option of the importance-sampling group but ``--rare`` itself, given without ``--rare``, is refused with
    exit 2 naming it (the crude sequences read none of them: passed over in silence it would look like an effect),
    before the crude run starts (no journal); several given are all named."""
    dest = {a.option_strings[0]: a.dest for a in _GROUP_ACTIONS}
    out = tmp_path / "crude"
    p = _run([str(site_file), str(out)] + ARGS + [w for o in options for w in [o] + _RARE_VALUES[dest[o]]])
    assert p.returncode == 2, p.stdout + p.stderr
    assert all(o in p.stdout for o in options) and "--rare" in p.stdout, p.stdout + p.stderr
    assert not (out / sr.JOURNAL).exists()


def test_a_rare_journal_begun_without_aftershocks_is_refused_with_them(site_file, tmp_path):
    out = tmp_path / "rare"
    assert _run([str(site_file), str(out)] + ARGS + RARE + ["--max-rows", "16"]).returncode == 6   # the pilot
    before = (out / "rows.jsonl").read_bytes()
    p = _run([str(site_file), str(out)] + ARGS + RARE + ["--max-rows", "16", "--aftershocks"])
    assert p.returncode == 2 and "another run" in p.stdout and "aftershocks" in p.stdout, p.stdout + p.stderr
    assert (out / "rows.jsonl").read_bytes() == before


@pytest.mark.mpi
def test_rare_two_mpi_ranks_give_the_one_rank_rows(site_file, rare_reference, tmp_path):
    p = _run([str(site_file), str(tmp_path / "two")] + ARGS + RARE, ranks=2)
    assert p.returncode == 6, p.stdout + p.stderr
    assert _rows(tmp_path / "two") == rare_reference[0]


def test_the_journal_identity_holds_the_code(monkeypatch):
    """The identity carries the grid's code digest (Python sources, C library, solver options): a change of a
    Python source alone changes it, so a journal begun by other code is refused like one of other settings
    (before, only the version and the C library's digest were held: an edited Python model resumed)."""
    from pycolfrag.grid import signing
    from pycolfrag.risk.sequences import SequenceSettings
    from pycolfrag.risk.sequences_journal import identity
    from pycolfrag.solver.options import SolverOptions
    from pycolfrag.structure.column import Column
    site = ROOT / "examples" / "site_athens.toml"
    st = SequenceSettings(years=10.0)
    before = identity(site, Column.parthenon(), st)
    assert before["code_digest"] == signing.code_digest(SolverOptions())     # st's solver options: the defaults
    files = signing.code_files()
    monkeypatch.setattr(signing, "_CODE", {})
    monkeypatch.setattr(signing, "code_files", lambda: files + [("extra.py", site)])
    after = identity(site, Column.parthenon(), st)
    assert after["code_digest"] != before["code_digest"] and after["settings"] == before["settings"]
