"""The rare sequences (:mod:`pycolfrag.risk.sequences_rare`) in a folder, on MPI ranks, resumable:
``pycolfrag sequences SITE.toml OUT --rare`` (docs/sequences.md, "Rare sequences").

Every rank takes the estimator's decisions itself from the same rows: a batch's rows are dealt to the
ranks by their place in the batch (place k to rank k mod N) in chunks of a few per rank, each chunk's rows
then shared by every rank (``allgather``), so the rows, the allocation and the estimate do not depend on the
number of ranks. Rank 0 writes ``OUT/rows.jsonl``: its identity line (the crude sequences' identity and the
rare settings) and each chunk's rows once they are done (synced), so a
stopped run loses at most a chunk and the same command resumes with the uninterrupted run's rows and
decisions. SIGTERM ends every rank at the next chunk (exit 75).
"""
from __future__ import annotations

import signal
from pathlib import Path

from pycolfrag.core.errors import PycolfragError
from pycolfrag.grid.serve import EXIT_DRAINED
from pycolfrag.rare.plans import PulseMap
from pycolfrag.rare.strata import build_strata
from pycolfrag.risk import sequences_rare as rare
from pycolfrag.risk.sequences_journal import EXIT_ARGS, EXIT_OK, abort_others, identity, open_journal
from pycolfrag.site.sources import load_site

__all__ = ["ROWS", "CHUNK_PER_RANK", "run_rare_folder"]

#: The journal of the rare sequences in the output folder.
ROWS = "rows.jsonl"
#: Rows per rank in a chunk (the most a stopped run loses per rank).
CHUNK_PER_RANK = 4


class _Stopped(Exception):
    pass


def _lor():
    from mpi4py import MPI  # only under MPI (a comm was given)
    return MPI.LOR


def run_rare_folder(site_path, model, rs: rare.RareSequenceSettings, folder, comm=None, log=print):
    """Run (or resume) the rare sequences into ``folder`` on every rank of ``comm``: ``(exit code, run)``, the
    run (:func:`pycolfrag.risk.sequences_rare.simulate_sequences`'s) on rank 0 when it ended at its target
    or its budget, else None."""
    rank, size = (comm.Get_rank(), comm.Get_size()) if comm is not None else (0, 1)
    folder = Path(folder)
    site = load_site(site_path)
    try:
        strata = build_strata(site)   # the site simulation's check, every rank alike
    except PycolfragError as exc:
        log(f"sequences: {exc}")
        return EXIT_ARGS, None
    ident = {**identity(site_path, model, rs.sequences), "rare": rare.journal_settings(rs, len(strata))}
    lock = journal = error = None
    entries: list = []
    if rank == 0:
        lock, entries, journal, error = open_journal(folder / ROWS, ident, log)
        entries = entries or []
    if comm is not None:
        error, entries = comm.bcast((error, entries), root=0)
    if error is not None:
        log(f"sequences: {error[1]}")
        return error[0], None
    done = entries
    pulse_map = PulseMap(rs.sequences.pulse_shape, rs.sequences.vp_scale, rs.sequences.tp_model)
    asked = [False]
    old = signal.signal(signal.SIGTERM, lambda signum, frame: asked.__setitem__(0, True))

    def evaluate(todo: list, mixture, stage: int) -> list:
        out = []
        step = CHUNK_PER_RANK * size
        for c in range(0, len(todo), step):
            stop = comm.allreduce(asked[0], op=_lor()) if comm is not None else asked[0]
            if stop:
                raise _Stopped()
            chunk = todo[c:c + step]
            try:   # a failure on one rank (a run, the journal) ends every rank: the others would wait for it
                mine = [rare.run_row(site, strata, model, rs, h, j, pulse_map, mixture, stage, b)
                        for k, (h, j, b) in enumerate(chunk) if k % size == rank]
                parts = comm.allgather(mine) if comm is not None else [mine]
                rows = [parts[k % size][k // size] for k in range(len(chunk))]
                if journal is not None:
                    journal.add_rows(rows)
            except BaseException as exc:
                abort_others(exc, comm, log)
                raise
            out += rows
        return out

    try:
        run = rare.simulate_sequences(site, model, rs, evaluate=evaluate, done=done, log=log)
    except PycolfragError as exc:   # a refusal every rank meets alike (the site's strata): exit 2
        log(f"sequences: {exc}")
        return EXIT_ARGS, None
    except _Stopped:
        log(f"sequences: stopped; every finished row is in {folder / ROWS}: rerun the same command to run the "
            f"rest (exit {EXIT_DRAINED})")
        return EXIT_DRAINED, None
    finally:
        signal.signal(signal.SIGTERM, old)
        if journal is not None:
            journal.close()
        if lock is not None:
            lock.release()
    return EXIT_OK, (run if rank == 0 else None)
