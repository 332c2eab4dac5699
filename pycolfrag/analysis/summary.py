"""Summary tables of a results file: what a grid prints when it ends and what the record report lists.

One row per group -- a synthetic grid's scenarios, a record suite's records or scale factors -- with
the done, failed and collapsed runs, the mean EDPs of the successful runs that did not collapse, and
the summed wall time of the runs; :func:`failure_lines` groups the failed rows by their message.
"""
from __future__ import annotations

import math

import numpy as np

from pycolfrag.analysis.data import as_results
from pycolfrag.core.errors import ParameterError

__all__ = ["summary_table", "failure_lines", "format_table"]


def _group_stats(s: dict, idx) -> dict:
    ok = s["status"][idx] == 0
    nc = ok & ~s["collapsed"][idx]
    return {"done": int(len(idx)), "failed": int((~ok).sum()), "collapses": int(s["collapsed"][idx][ok].sum()),
            "mean_u_top": float(np.mean(s["u_top"][idx][nc])) if nc.any() else math.nan,
            "mean_u_d": float(np.mean(s["u_d"][idx][nc])) if nc.any() else math.nan,
            "cpu_s": float(np.nansum(s["wall_s"][idx]))}


def summary_table(results, by: str | None = None) -> list[dict]:
    """The closing table of a results file, one dict per group: the done, failed and collapsed
    rows, mean u_top and u_d of the non-collapsed successful runs, and the summed sample wall time
    (CPU-seconds over ranks).

    Groups: a synthetic grid's scenarios (``mw``, ``dist_km``); a record suite's records
    (``by="record"``: ``record_id``, ``event``, ``mw``, ``rrup_km``) or scale factors (``by="scale"``;
    the default when the file holds several scales). ``results``: a path or a loaded :class:`Results`."""
    res = as_results(results)
    s = res.samples
    if res.attrs.get("layout") != "records":
        table = []
        for d in res.scenario_table():
            table.append({"mw": d["mw"], "dist_km": d["dist_km"], **_group_stats(s, d["index"])})
        return table
    scales = np.unique(s["scale"][np.isfinite(s["scale"])])
    by = by or ("scale" if len(scales) > 1 else "record")
    table = []
    if by == "scale":
        for f in scales:
            table.append({"scale": float(f), **_group_stats(s, np.flatnonzero(s["scale"] == f))})
        return table
    if by != "record":
        raise ParameterError(f"by must be 'record' or 'scale', got {by!r}")
    for k in np.unique(s["record"]):
        idx = np.flatnonzero(s["record"] == k)
        i0 = idx[0]
        table.append({"record_id": str(s["record_id"][i0]), "event": str(s["event"][i0]),
                      "mw": float(s["mw"][i0]), "rrup_km": float(s["rrup_km"][i0]), **_group_stats(s, idx)})
    return table


def failure_lines(results, limit: int = 10) -> list[str]:
    """Why rows failed, for the closing summary: one line per distinct message (most rows first, at most
    ``limit``), with the number of rows and the rows' names (record id and component of a record
    suite; Mw/R of a synthetic grid). ``results``: a path or a loaded :class:`Results`."""
    res = as_results(results)
    s = res.samples
    bad = np.flatnonzero(s["status"] > 0)
    groups: dict = {}
    for i in bad:
        if res.attrs.get("layout") == "records":
            name = f"{s['record_id'][i]} {s['component'][i]}" + (f" x{s['scale'][i]:g}" if s["scale"][i] != 1 else "")
        else:
            name = f"Mw {s['mw'][i]:g} R {s['dist_km'][i]:g} #{s['sample'][i]}"
        groups.setdefault(str(s["message"][i]) or "(no message)", []).append(name)
    lines = []
    for msg, names in sorted(groups.items(), key=lambda kv: -len(kv[1]))[:limit]:
        shown = ", ".join(names[:4]) + (f", ... ({len(names) - 4} more)" if len(names) > 4 else "")
        lines.append(f"  {len(names)} failed [{shown}]: {msg}")
    if len(groups) > limit:
        lines.append(f"  ... and {len(groups) - limit} other message(s): pycolfrag.analysis.data.load(...).samples['message']")
    return lines


def format_table(table: list[dict]) -> str:
    """The closing summary table printed by rank 0: one line per scenario of a synthetic grid, per
    record or per scale factor of a record suite (:func:`summary_table`)."""
    tail = (f"{'done':>5} {'failed':>6} {'collapses':>9} {'mean u_top*':>11} {'mean u_d*':>10} {'cpu s':>8}")

    def stats(t):
        return (f"{t['done']:5d} {t['failed']:6d} {t['collapses']:9d} {t['mean_u_top']:11.4g} "
                f"{t['mean_u_d']:10.4g} {t['cpu_s']:8.1f}")

    if table and "record_id" in table[0]:
        lines = [f"{'record':<12} {'event':<24} {'Mw':>4} {'Rrup km':>7} " + tail]
        for t in table:
            lines.append(f"{t['record_id'][:12]:<12} {t['event'][:24]:<24} {t['mw']:4.1f} {t['rrup_km']:7.1f} "
                         + stats(t))
    elif table and "scale" in table[0]:
        lines = [f"{'scale':>6} " + tail]
        for t in table:
            lines.append(f"{t['scale']:6.3g} " + stats(t))
    else:
        lines = [f"{'Mw':>4} {'R km':>5} " + tail]
        for t in table:
            lines.append(f"{t['mw']:4.1f} {t['dist_km']:5.1f} " + stats(t))
    lines.append("* means over successful runs without collapse; cpu s = summed sample wall times")
    return "\n".join(lines)
