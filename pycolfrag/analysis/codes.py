"""Which code wrote a results file's rows: every code, and how many rows each.

A file resumed with ``--allow-code-change`` holds rows of more than one build; its root attributes
``version``, ``git_revision`` and ``code_digest`` stay those of the first (the file is opened with its own
code marks, :func:`pycolfrag.grid.signing.resume_signature`), and every code that wrote rows is in the root
attribute ``code_digests``: its digest, its build (version, result hash), when it began and how many rows
were done before it (:func:`pycolfrag.grid.signing.code_entry`). The rows of entry i are therefore the rows
done before entry i + 1 less those done before entry i; the last entry's, the finished rows less those
done before it. A reader that showed the root attributes alone named the first code for every row.
"""
from __future__ import annotations

import json

__all__ = ["code_history", "code_lines", "code_summary", "summarize"]


def _text(v):
    return v.decode() if isinstance(v, bytes) else v


def code_history(attrs, n_done: int) -> list:
    """The codes that wrote the rows, in order: dicts with ``code_digest``, ``version``, ``result_hash``,
    ``started`` and ``rows`` (the rows it wrote, failed ones included). [] when the file records no history
    (files begun before it existed, or written by other code)."""
    raw = attrs.get("code_digests")
    if raw is None:
        return []
    try:
        entries = json.loads(_text(raw))
    except (TypeError, ValueError):
        return []
    if not isinstance(entries, list) or not all(isinstance(e, dict) for e in entries):
        return []
    out = []
    for i, e in enumerate(entries):
        before = int(e.get("rows_done_before") or 0)
        upto = int(n_done) if i + 1 == len(entries) else int(entries[i + 1].get("rows_done_before") or 0)
        build = e.get("build") if isinstance(e.get("build"), dict) else {}
        out.append({"code_digest": e.get("code_digest"), "version": build.get("version"),
                    "result_hash": build.get("result_hash"), "started": e.get("started"),
                    "rows": max(upto - before, 0)})
    return out


def _one(c: dict) -> str:
    digest = c["code_digest"] or "not recorded"
    return (f"code `{digest[:12]}` (version {c['version'] or '?'}, result hash {c['result_hash'] or '?'}, from "
            f"{c['started'] or '?'}): {c['rows']} rows")


def code_summary(attrs, n_done: int) -> str | None:
    """One line naming every code with its rows when more than one wrote the file, else None."""
    return summarize(code_history(attrs, n_done))


def summarize(hist) -> str | None:
    """The line of :func:`code_summary` from a :func:`code_history` (None for fewer than two codes)."""
    hist = list(hist or [])
    if len(hist) < 2:
        return None
    return (f"{len(hist)} codes wrote the rows (resumed with --allow-code-change): "
            + "; ".join(_one(c) for c in hist))


def code_lines(attrs, n_done: int) -> list:
    """Markdown list items of :func:`code_summary` (none for a file of one code)."""
    line = code_summary(attrs, n_done)
    return [] if line is None else [f"- **{line}**"]
