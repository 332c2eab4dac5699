"""Why a grid scaled as it did: the timeline of every rank, read from a results file (``/timeline``).

    pycolfrag timeline RESULTS.h5 [--session K] [--plot timeline.png] [--json summary.json]
    python -m pycolfrag.analysis.timeline RESULTS.h5 ...            # the same

For each session of the file (a resumed run has one per job), it prints where the rank-seconds went
-- computing rows, start-up (launch, imports, MPI, checks, signature, file), waiting for the first
chunk, waiting between chunks (rank 0 late), idle after a rank's last chunk (the tail), rank 0's
serving, idling and writing -- the utilisation (rows computed per rank-second, from the launch and from
each rank's end of start-up), the rows that ran in narrow SIMD batches, and the CPU time per second
of wall time while computing (below 1: a shared or oversubscribed core). ``--plot`` draws the Gantt
chart. The intervals and their kinds are :data:`pycolfrag.results.timeline.KINDS`
(docs/results_format.md); the grid records them (:mod:`pycolfrag.grid.timeline`).
"""
from __future__ import annotations

import argparse
import json
import sys
from collections import defaultdict
from typing import Sequence

import numpy as np

from pycolfrag.core.help import HelpFormatter
from pycolfrag.results.timeline import read_timeline

__all__ = ["CAUSES", "summarise", "format_summary", "plot", "main"]

_START_UP = ("launch", "imports", "mpi_init", "checks", "identity", "gather", "open", "release")

#: The causes rank-seconds are put under, in the order they are printed.
CAUSES = {
    "computing": "computing rows (chunks)",
    "start_up": "start-up: launch, imports, MPI, checks, signature, gather, file (kinds " + ", ".join(_START_UP) + ")",
    "launch_late": "start-up: the launcher started this rank after the first",
    "first_chunk": "waiting for the first chunk",
    "between": "waiting between chunks (rank 0 late)",
    "tail": "idle after the rank's last chunk (the tail of the run)",
    "serving": "rank 0 answering requests and journalling rows",
    "idle": "rank 0 with nothing to answer or compute",
    "writing": "rank 0 writing the HDF5 file (flushes, final write)",
    "other": "not recorded (Python between intervals)",
}


def _kind_names(session) -> np.ndarray:
    kinds = session["kinds"]
    return np.array([kinds[k] if k < len(kinds) else f"kind{k}" for k in session["rows"]["kind"]])


def summarise(session: dict) -> dict:
    """Rank-seconds by cause (:data:`CAUSES`) and per rank, utilisation, chunks and batch widths of one
    session as :func:`pycolfrag.results.timeline.read_timeline` returns it."""
    rows, kinds, attrs = session["rows"], _kind_names(session), session["attrs"]
    n_ranks = int(attrs.get("n_ranks", int(rows["rank"].max()) + 1 if len(rows) else 1))
    lanes = int(attrs.get("lanes", 1))
    t_start = float(rows["t0"].min()) if len(rows) else 0.0
    t_end = float(rows["t1"].max()) if len(rows) else 0.0
    job = t_end - t_start
    per_rank = []
    for r in range(n_ranks):
        m = (rows["rank"] == r) & (kinds != "drain")
        per_rank.append(_rank_causes(rows[m], kinds[m], t_start, t_end))
    total = defaultdict(float)
    for pr in per_rank:
        for k, v in pr["causes"].items():
            total[k] += v
    chunks = rows[kinds == "chunk"]
    wall = chunks["t1"] - chunks["t0"]
    narrow = chunks["width"] < lanes
    ready = sum(t_end - pr["ready"] for pr in per_rank if pr["ready"] is not None)
    return {
        "attrs": attrs, "n_ranks": n_ranks, "lanes": lanes, "job_s": job, "session_s": t_end,
        "causes": {k: total.get(k, 0.0) for k in CAUSES}, "ranks": per_rank,
        "utilisation_job": total["computing"] / (n_ranks * job) if job > 0 else float("nan"),
        "utilisation_ready": total["computing"] / ready if ready > 0 else float("nan"),
        "chunks": int(len(chunks)), "rows": int(chunks["n_rows"].sum()),
        "narrow_rows": int(chunks["n_rows"][narrow].sum()), "narrow_chunks": int(narrow.sum()),
        "cpu_per_wall": float(np.nansum(chunks["cpu_s"]) / wall.sum()) if wall.sum() > 0 else float("nan"),
        "drain_s": float(sum(rows["t1"][kinds == "drain"] - rows["t0"][kinds == "drain"])),
        "crc_ok": bool(session.get("crc_ok", True)),
    }


def _rank_causes(rows, kinds, t_start: float, t_end: float) -> dict:
    """One rank's seconds by cause, from the job's start to its end."""
    c = defaultdict(float)
    if not len(rows):
        c["other"] = t_end - t_start
        return {"causes": dict(c), "ready": None, "chunks": 0, "rows": 0, "cpu_s": 0.0, "chunk_s": 0.0}
    order = np.argsort(rows["t0"], kind="stable")
    rows, kinds = rows[order], kinds[order]
    dur = rows["t1"] - rows["t0"]
    is_chunk = kinds == "chunk"
    first = rows["t0"][is_chunk].min() if is_chunk.any() else np.inf
    last = rows["t1"][is_chunk].max() if is_chunk.any() else -np.inf
    c["launch_late"] = float(rows["t0"][0] - t_start)
    for k, t0, d in zip(kinds, rows["t0"], dur):
        if k in _START_UP:
            c["start_up"] += d
        elif k == "chunk":
            c["computing"] += d
        elif k == "wait":
            c["first_chunk" if t0 < first else "tail" if t0 >= last else "between"] += d
        elif k == "serve":
            c["serving"] += d
        elif k == "idle":
            c["first_chunk" if t0 < first and np.isfinite(first) else "idle"] += d
        elif k in ("flush", "finish"):
            c["writing"] += d
    c["tail"] += float(t_end - rows["t1"].max())
    c["other"] = float((t_end - t_start) - sum(c.values()))
    ends = rows["t1"][np.isin(kinds, _START_UP)]
    return {"causes": dict(c), "ready": float(ends.max()) if len(ends) else None, "chunks": int(is_chunk.sum()),
            "rows": int(rows["n_rows"][is_chunk].sum()), "cpu_s": float(np.nansum(rows["cpu_s"][is_chunk])),
            "chunk_s": float(dur[is_chunk].sum())}


def format_summary(name: str, s: dict) -> str:
    """The printed summary of one session (:func:`summarise`)."""
    a, n = s["attrs"], s["n_ranks"]
    hosts = sorted(set(a.get("hosts", []) or []))
    lines = [f"{name}: {n} rank(s) on {', '.join(hosts) or '?'} ({a.get('launcher') or 'no launcher'}; "
             f"{a.get('cpu', '?')}; {a.get('mpi') or 'no MPI'}), lanes {s['lanes']}, chunk max {a.get('chunk_max', '?')}, "
             f"started {a.get('started', '?')}"]
    if not s["crc_ok"]:
        lines.append("  WARNING: this timeline fails its CRC-32 (changed after it was written): read it with care")
    lines.append(f"  job {s['job_s']:.2f} s (first rank's launch to rank 0's final write), session {s['session_s']:.2f} s; "
                 f"{s['rows']} rows in {s['chunks']} chunks")
    lines.append(f"  utilisation (computing / rank-seconds): {100 * s['utilisation_job']:.1f} % of the job, "
                 f"{100 * s['utilisation_ready']:.1f} % after each rank's start-up")
    total = n * s["job_s"]
    lines.append(f"  rank-seconds by cause ({total:.2f} in all):")
    for k, text in CAUSES.items():
        v = s["causes"][k]
        if abs(v) >= 5e-4 or k == "computing":
            lines.append(f"    {v:9.3f} s {100 * v / total if total else 0:6.1f} %  {text}")
    lines.append(f"  rows in narrow batches (width < {s['lanes']} lanes): {s['narrow_rows']} of {s['rows']} "
                 f"({s['narrow_chunks']} chunks); CPU per wall second while computing {s['cpu_per_wall']:.2f}")
    if s["drain_s"]:
        lines.append(f"  drained after a SIGTERM for {s['drain_s']:.2f} s")
    lines.append("  rank  start-up  computing  first chunk  between   tail  serving  writing  chunks  rows")
    for r, pr in enumerate(s["ranks"]):
        c = pr["causes"]
        lines.append(f"  {r:4d} {c.get('start_up', 0) + c.get('launch_late', 0):9.2f} {c.get('computing', 0):10.2f} "
                     f"{c.get('first_chunk', 0):12.2f} {c.get('between', 0):8.2f} {c.get('tail', 0):6.2f} "
                     f"{c.get('serving', 0) + c.get('idle', 0):8.2f} {c.get('writing', 0):8.2f} {pr['chunks']:7d} "
                     f"{pr['rows']:5d}")
    return "\n".join(lines)


#: Colours of the Gantt chart by kind.
_COLOURS = {"launch": "#dddddd", "imports": "#bbbbbb", "mpi_init": "#999999", "checks": "#777777",
            "identity": "#aa77cc", "gather": "#dddd88", "open": "#cc77aa", "release": "#ffcc66",
            "chunk": "#4477aa", "wait": "#ee6677", "serve": "#66ccee", "idle": "#eeeeee", "flush": "#228833",
            "finish": "#117733"}


def plot(name: str, session: dict, s: dict, path) -> None:
    """A Gantt chart of one session: one bar per rank, coloured by what it did; a drain is hatched."""
    import matplotlib  # here: only when a plot is asked for
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    rows, kinds = session["rows"], _kind_names(session)
    fig, ax = plt.subplots(figsize=(11, 1.8 + 0.35 * s["n_ranks"]))
    for kind, colour in _COLOURS.items():
        m = kinds == kind
        if m.any():
            ax.barh(rows["rank"][m], rows["t1"][m] - rows["t0"][m], left=rows["t0"][m], color=colour, height=0.6,
                    edgecolor="white" if kind == "chunk" else None, linewidth=0.3, label=kind)
    m = kinds == "drain"
    if m.any():
        ax.barh(rows["rank"][m], rows["t1"][m] - rows["t0"][m], left=rows["t0"][m], fill=False, hatch="//",
                height=0.8, label="drain")
    ax.set_yticks(range(s["n_ranks"]))
    ax.invert_yaxis()
    ax.set_ylabel("rank")
    ax.set_xlabel("s from the session's start (rank 0's clock)")
    ax.set_title(f"{name}: {s['n_ranks']} ranks, job {s['job_s']:.1f} s, computing {100 * s['utilisation_job']:.0f} % "
                 "of rank-time", fontsize=9)
    fig.legend(ncol=8, fontsize=7, loc="lower center")
    fig.tight_layout(rect=(0, 0.1, 1, 1))
    try:
        fig.savefig(path, dpi=110)
    finally:
        plt.close(fig)


def build_parser(prog: str = "pycolfrag timeline") -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog=prog, formatter_class=HelpFormatter,
                                description="Utilisation and idle time by cause of every rank of a grid run, "
                                            "from the timeline stored in its results file (docs/grid.md).")
    p.add_argument("results", help="results file of a grid (pycolfrag grid)")
    p.add_argument("--session", type=int, default=None,
                   help="only this session (0 = the first, -1 = the last; default: all)")
    p.add_argument("--plot", default=None, metavar="PNG",
                   help="draw the Gantt chart (with several sessions: one file each, _<k> before the suffix)")
    p.add_argument("--json", default=None, metavar="FILE", help="write the summaries as JSON")
    return p


def main(argv: Sequence[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    try:
        sessions = read_timeline(args.results)
    except (OSError, KeyError, ValueError) as exc:   # ValueError: ResultsFileError (a FIFO, a bad n_ranks, kinds)
        print(f"timeline: cannot read {args.results}: {exc}", file=sys.stderr)
        return 2
    if args.session is not None:
        names = list(sessions)
        k = args.session + len(names) if args.session < 0 else args.session
        sessions = {names[k]: sessions[names[k]]} if 0 <= k < len(names) else {}
    if not sessions:
        print(f"timeline: {args.results} holds no timeline" + (f" of session {args.session}" if args.session is not None
              else " (written before timelines were stored, or by other code)"), file=sys.stderr)
        return 2
    out = {}
    for name, sess in sessions.items():
        s = summarise(sess)
        print(format_summary(name, s))
        out[name] = {k: v for k, v in s.items() if k != "attrs"}
        if args.plot:
            path = args.plot if len(sessions) == 1 else _numbered(args.plot, name)
            try:
                plot(name, sess, s, path)
            except (OSError, ValueError) as exc:   # ValueError: a suffix matplotlib cannot write
                print(f"timeline: cannot write --plot {path}: {getattr(exc, 'strerror', None) or exc}",
                      file=sys.stderr)
                return 2
            print(f"  plot: {path}")
    if args.json:
        try:
            with open(args.json, "w") as fh:
                json.dump(out, fh, indent=1, default=float)
        except OSError as exc:
            print(f"timeline: cannot write --json {args.json}: {exc.strerror or exc}", file=sys.stderr)
            return 2
    return 0


def _numbered(path: str, name: str) -> str:
    stem, dot, suffix = path.rpartition(".")
    k = name.rsplit("_", 1)[-1]
    return f"{stem}_{k}.{suffix}" if dot else f"{path}_{k}"


if __name__ == "__main__":
    sys.exit(main())
