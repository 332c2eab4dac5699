"""What a site risk hands to people: :class:`SiteRisk`, its Markdown section, ``risk.json``, the figures
and the command's summary lines -- each carrying every mark of the computation (pulse-only,
incomplete files, Eq. (4) fits that failed or are degenerate, unpaired cells)."""
from __future__ import annotations

import os
import tempfile
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from pycolfrag.analysis.codes import summarize
from pycolfrag.core import report_json
from pycolfrag.core.errors import OutputError, ParameterError
from pycolfrag.risk import figures as risk_figures
from pycolfrag.risk.fit import EQ4_FIT_ALPHA, Degeneracy
from pycolfrag.risk.uncertainty import UNCERTAINTY_METHODS

__all__ = ["SiteRisk", "report_section", "write_outputs", "check_outdir", "print_summary", "level_marks"]


@dataclass
class SiteRisk:
    """Everything :func:`pycolfrag.risk.site_risk.site_risk` computes; ``to_json`` gives the numbers."""

    site: object
    files: dict
    branches: tuple
    estimator: str
    uncertainty: str
    confidence: float
    n_draws: int
    mws: np.ndarray
    ds: np.ndarray
    quantities: tuple
    rate: dict                 # label -> (lambda, low, high), 1/yr
    prob: dict                 # years -> label -> (P, low, high)
    source_rate: dict          # source name -> label -> lambda
    deagg: dict                # label -> (n_mw, n_dist) fractions of lambda
    outside: list              # OutsideReport per source
    weights: dict              # branch -> W (n_mw, n_dist)
    pulse_share: dict          # source name -> rate-weighted mean p_pulse
    unpaired_cells: int = 0    # cells whose two branches could not be drawn jointly
    curves: dict = field(default_factory=dict)   # edp -> dict(x, rate, low, high)
    misfit: str = "fallback"
    checks: dict = field(default_factory=dict)   # label -> fits, fallback, degenerate, w_max, unpaired
    degeneracy: Degeneracy = field(default_factory=Degeneracy)
    incomplete: list = field(default_factory=list)   # notes of the incomplete files
    identity: dict = field(default_factory=dict)     # branch -> seed, code identity

    @property
    def pulse_only(self) -> bool:
        """True when the pulse branch was used alone (p_pulse = 1 for every source)."""
        return self.branches == ("pulse",)

    def section(self, figures: dict | None = None, heading: str = "##") -> str:
        """This risk's section of a report (:func:`report_section`): how the results file's report
        (:func:`pycolfrag.analysis.report.write_report`, a layer below) includes it without importing this one."""
        return report_section(self, figures, heading)

    def to_json(self) -> dict:
        checks = {k: {"eq4_fit": [f.as_dict() for f in v["fits"]], "eq4_fit_failed_cells": _failed(v),
                      "fallback_cells": v["fallback"], "degenerate_cells": v["degenerate"],
                      "w_max_per_year": v["w_max"], "marks": level_marks(self, k)}
                  for k, v in self.checks.items()}
        return {"site": self.site.name, "site_file": self.site.path, "files": self.files,
                "branches": list(self.branches), "pulse_only": self.pulse_only,
                "incomplete": self.incomplete, "identity": self.identity,
                "rates_are_lower_bounds": not_computed_share(self) > 0, "not_computed_share": not_computed_share(self),
                "estimator": self.estimator, "uncertainty": self.uncertainty, "eq4_misfit": self.misfit,
                "eq4_fit_alpha": EQ4_FIT_ALPHA, "confidence": self.confidence, "n_draws": self.n_draws,
                "interpolation": "bilinear in (Mw, ln R) on the probability",
                "grid": {"mw": self.mws.tolist(), "dist_km": self.ds.tolist()},
                "rate_per_year": {k: list(v) for k, v in self.rate.items()},
                "probability": {f"{t:g}": {k: list(v) for k, v in d.items()} for t, d in self.prob.items()},
                "source_rate_per_year": self.source_rate,
                "pulse_models": {s.name: s.pulse.describe() for s in self.site.sources},
                "pulse_share": self.pulse_share, "unpaired_cells": self.unpaired_cells,
                "outside": [o.as_dict() for o in self.outside], "checks": checks,
                "degenerate_eq4": self.degeneracy.as_dict(),
                "deaggregation": {k: v.tolist() for k, v in self.deagg.items()},
                "curves": {k: {kk: np.asarray(vv).tolist() for kk, vv in v.items()} for k, v in self.curves.items()}}


def _failed(check) -> int:
    return int(sum(np.sum(f.failed) for f in check["fits"]))


def level_marks(risk: SiteRisk, label: str) -> list:
    """The marks a level's numbers carry, as short texts (empty: none)."""
    c = risk.checks.get(label, {})
    marks = []
    if c.get("degenerate"):
        marks.append(f"Eq. (4) not an estimate in {c['degenerate']} cell(s)")
    failed = _failed(c) if c.get("fits") else 0
    if risk.estimator == "eq4" and failed:
        marks.append(f"Eq. (4) failed its fit test in {failed} cell(s): "
                     + ("empirical ratio there" if risk.misfit == "fallback" else "kept (warn)"))
    if risk.incomplete:
        marks.append("INCOMPLETE results")
    share = not_computed_share(risk)
    if share > 0:
        marks.append(f"LOWER BOUND ({100 * share:.3g} % of the rate on scenarios not computed yet, counted as 0)")
    return marks


def not_computed_share(risk: SiteRisk) -> float:
    """The share of the site's rate on scenarios of the grid asked for that an incomplete file has no rows
    for yet (:class:`~pycolfrag.risk.weights.OutsideReport`'s ``not_computed``): counted as 0, so
    every rate is a lower bound when it is > 0."""
    total = sum(o.rate for o in risk.outside)
    return sum(o.rate * o.not_computed for o in risk.outside) / total if total > 0 else 0.0


def _ge(risk: SiteRisk) -> str:
    """">= " before a rate that is a lower bound (:func:`not_computed_share`), else ""."""
    return ">= " if not_computed_share(risk) > 0 else ""


def _e(x):
    return "0" if x == 0 else f"{x:.2e}"


def _p(x):
    return f"{x:.3f}" if x >= 0.001 or x == 0 else f"{x:.1e}"


def _not_computed_line(risk: SiteRisk) -> str:
    share = not_computed_share(risk)
    if share <= 0:
        return ""
    return (f" (the scenarios with rows so far; {100 * share:.3g} % of the site's rate falls on scenarios of the grid "
            "asked for that are not computed yet, counted as 0: every rate is a LOWER BOUND)")


def _header(risk: SiteRisk) -> list:
    s = risk.site
    pct = f"{100 * risk.confidence:g} %"
    L = []
    if risk.incomplete:
        L += ["**INCOMPLETE RESULTS (asked for explicitly): " + "; ".join(risk.incomplete)
              + ". The rates rest on the rows there are, not on the grid asked for.**", ""]
    if risk.pulse_only:
        L += ["**PULSE-ONLY: every motion is taken to carry a velocity pulse (asked for explicitly). "
              "Near-fault practice mixes pulse and no-pulse motions; this answer overstates the risk.**", ""]
    method = UNCERTAINTY_METHODS[risk.uncertainty]
    est = ("share of the cell's runs that exceeded (empirical ratio, Eq. (1) counted)" if risk.estimator == "empirical"
           else f"Eq. (4); cells failing its fit test at {EQ4_FIT_ALPHA:g} (cell or magnitude row): "
           + ("empirical ratio" if risk.misfit == "fallback" else "Eq. (4) kept and marked"))
    ident = "; ".join(f"{b}: seed {v['seed']}, code {v['code']}" + (
        f" (the first of {len(v['codes'])}, below)" if len(v.get("codes") or []) > 1 else "")
        for b, v in risk.identity.items())
    L += [f"- site file: `{s.path}`",
          *[f"- {b} branch: `{p}`" for b, p in risk.files.items()],
          f"- branches' identity: {ident}" + (" (same seed and code: checked)" if len(risk.branches) > 1 else ""),
          *[f"- **{b} branch: {line}**" for b, line in _several_codes(risk)],
          f"- cell probability: {est}; collapse: Eq. (3); interpolation: bilinear in (Mw, ln R) on the "
          f"probability; grid Mw {risk.mws[0]:g}-{risk.mws[-1]:g}, R {risk.ds[0]:g}-{risk.ds[-1]:g} km"
          + _not_computed_line(risk),
          f"- intervals: two-sided {pct}, `{method.name}`: {method.description}; {risk.n_draws} draws of every "
          "grid cell, cells drawn independently" + ("" if len(risk.branches) == 1 else
          ", a cell's pulse and no-pulse rows paired by sample (same seeds) and drawn together"
          + (f" ({risk.unpaired_cells} cells without pairs drawn branch by branch)" if risk.unpaired_cells
             else "")) + "; P in T years = 1 - exp(-lambda T) (Poisson)",
          f"- part of the sources outside the grid: treated as `{s.outside}` (table below)"]
    L += [f"- Eq. (4) not an estimate: {line}" for line in risk.degeneracy.lines()]
    return L + [""]


def _level_table(risk: SiteRisk) -> list:
    pct = f"{100 * risk.confidence:g} %"
    L = [f"| level | lambda (1/yr) [{pct}] | return period (yr) | "
         + " | ".join(f"P in {t:g} yr [{pct}]" for t in sorted(risk.prob)) + " | largest contribution | marks |",
         "|---|---|---:|" + "---|" * len(risk.prob) + "---|---|"]
    for q in risk.quantities:
        lam, lo, hi = risk.rate[q.label]
        d = risk.deagg[q.label]
        if lam > 0:
            i, j = np.unravel_index(np.argmax(d), d.shape)
            top = f"Mw {risk.mws[i]:g}, R {risk.ds[j]:g} km ({100 * d[i, j]:.0f} %)"
        else:
            top = "-"
        cells = [f"{_ge(risk)}{_p(v[0])} [{_p(v[1])}, {_p(v[2])}]" for v in (risk.prob[t][q.label] for t in sorted(risk.prob))]
        name = q.label if q.level is None else f"{q.label} ({q.name})"
        ge = _ge(risk)
        period = "inf" if lam == 0 else ("<= " if ge else "") + f"{1 / lam:.3g}"
        L.append(f"| {name} | {ge}{_e(lam)} [{_e(lo)}, {_e(hi)}] | {period} | "
                 + " | ".join(cells) + f" | {top} | {'; '.join(level_marks(risk, q.label)) or '-'} |")
    return L


def _fit_lines(risk: SiteRisk) -> list:
    L = ["", f"Eq. (4) against the counts (exact binomial test per cell, Poisson-binomial per magnitude row; "
             f"failed below {EQ4_FIT_ALPHA:g}):", ""]
    for label, c in risk.checks.items():
        for f in c["fits"]:
            rows = f.worst_rows(risk.mws)
            L.append(f"- {label}, {f.branch}: {int(np.sum(f.failed))} of {f.failed.size} cells failed"
                     + (f" ({rows})" if rows else ""))
    return L


def report_section(risk: SiteRisk, figures: dict | None = None, heading: str = "##") -> str:
    """The risk as a Markdown section: rates and probabilities with intervals and marks, sources, range,
    the fit of Eq. (4), figures (``figures`` maps a caption to a relative PNG path)."""
    s = risk.site
    L = [f"{heading} Site risk: {s.name}", ""]
    if s.description:
        L += [s.description, ""]
    L += _header(risk) + _level_table(risk)
    L += ["", "Sources (rate of each level per year; p_pulse is the rate-weighted mean over the source's events):", "",
          "| source | model | pulse | mean p_pulse | " + " | ".join(q.label for q in risk.quantities) + " |",
          "|---|---|---|---:|" + "---:|" * len(risk.quantities)]
    for src in s.sources:
        L.append(f"| {src.name} | {src.describe()} | {src.pulse.describe()} | {risk.pulse_share[src.name]:.3f} | "
                 + " | ".join(_e(risk.source_rate[src.name][q.label]) for q in risk.quantities) + " |")
    prov = {getattr(getattr(src.pulse, "module", None), "PROVENANCE", None) for src in s.sources} - {None}
    L += [f"- pulse-occurrence model provenance: {p}" for p in sorted(prov)]
    L += ["", "Part of each source outside the simulated range (fractions of its rate; a point outside in "
              "both Mw and R counts in both columns):", "",
          "| source | Mw below | Mw above | R below | R above | outside (any) | treated as |",
          "|---|---:|---:|---:|---:|---:|---|"]
    for o in risk.outside:
        L.append(f"| {o.source} | {o.mw_below:.3f} | {o.mw_above:.3f} | {o.r_below:.3f} | {o.r_above:.3f} | "
                 f"{o.outside:.3f} | {o.treatment} |")
    if not_computed_share(risk) > 0:
        L += ["", "Part of each source on scenarios not computed yet (inside the grid asked for; counted as 0, "
                  "so every rate above is a lower bound): "
              + ", ".join(f"{o.source} {o.not_computed:.3f}" for o in risk.outside)]
    L += _fit_lines(risk)
    if figures:
        L += [""]
        for caption, rel in figures.items():
            L += [f"![{caption}]({rel})", ""]
    return "\n".join(L) + "\n"


def check_outdir(outdir) -> Path:
    """Refuse, before any work, an output folder that cannot be one: a file in its place (or above it),
    or one that cannot be written. Nothing is created here."""
    if isinstance(outdir, str) and not outdir:
        raise ParameterError(f"output folder {outdir!r} is an empty path (it would write into the current "
                             "directory): give a folder")
    p = Path(outdir)
    probe = p
    while not probe.exists():
        if probe.parent == probe:
            break
        probe = probe.parent
    if not probe.is_dir():
        raise OutputError(f"output folder {p}: {probe} is a file, not a folder")
    if not os.access(probe, os.W_OK | os.X_OK):
        raise OutputError(f"output folder {p}: {probe} cannot be written (permission denied)")
    return p


def _umask() -> int:
    """The process's umask, read from /proc/self/status (Linux): setting it and setting it back, the only
    portable way, would race with another thread creating a file meanwhile; there, 022 is assumed."""
    try:
        with open("/proc/self/status", encoding="ascii") as fh:
            for line in fh:
                if line.startswith("Umask:"):
                    return int(line.split()[1], 8)
    except (OSError, ValueError, IndexError):
        pass
    return 0o022


def _write_text(path: Path, text: str) -> None:
    """Write through a temporary file in the same folder and rename it into place, so that a full disk
    leaves the old file (or none), never half of one."""
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", dir=path.parent)
    try:
        # mkstemp makes the file 0600; the outputs get the mode any new file gets (0666 less the umask)
        os.fchmod(fd, 0o666 & ~_umask())
        with os.fdopen(fd, "w", encoding="utf-8") as fh:
            fh.write(text)
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise


def write_outputs(risk: SiteRisk, outdir, *, figures=True) -> dict:
    """Write ``risk.md``, ``risk.json`` and (with matplotlib) the figures into ``outdir``; return the paths.
    A folder that cannot be made or written, or a full disk, raises :class:`~pycolfrag.core.errors.OutputError`."""
    outdir = check_outdir(outdir)
    try:
        outdir.mkdir(parents=True, exist_ok=True)
        paths, figs = {}, {}
        if figures:
            for stem, path in risk_figures.make_all(risk, outdir).items():
                figs[risk_figures.CAPTIONS[stem]] = Path(path).name
                paths[stem] = str(path)
        md, js = outdir / "risk.md", outdir / "risk.json"
        _write_text(md, "# pycolfrag site risk\n\n" + report_section(risk, figs))
        _write_text(js, report_json.dumps(risk.to_json(), indent=1))
    except OSError as exc:
        raise OutputError(f"cannot write the risk outputs into {outdir}: {exc.strerror or exc}") from None
    paths.update(markdown=str(md), json=str(js))
    return paths


def _several_codes(risk: SiteRisk) -> list:
    """(branch, line naming every code and its rows) of the branches whose rows more than one code wrote
    (resumed with ``--allow-code-change``; the identity's ``code`` is the first's)."""
    lines = [(b, summarize(v.get("codes"))) for b, v in risk.identity.items()]
    return [(b, line) for b, line in lines if line]


def print_summary(risk: SiteRisk, years: float) -> None:
    """The command's lines: marks first, then every level's lambda and P in ``years`` with its marks."""
    for b, line in _several_codes(risk):
        print(f"{b} branch: {line}")
    for note in risk.incomplete:
        print(f"INCOMPLETE results (asked for explicitly): {note}")
    if risk.pulse_only:
        print("PULSE-ONLY risk (asked for explicitly): it overstates the risk of a site")
    for o in risk.outside:
        if o.not_computed > 0:
            print(f"{o.source}: {100 * o.not_computed:.1f} % of its rate falls on scenarios of the grid asked for "
                  "that are not computed yet: counted as 0, every rate below is a LOWER BOUND")
        if o.outside > 0:
            print(f"{o.source}: {100 * o.outside:.1f} % of its rate lies outside the simulated range (Mw below "
                  f"{100 * o.mw_below:.1f} %, above {100 * o.mw_above:.1f} %; R below {100 * o.r_below:.1f} %, above "
                  f"{100 * o.r_above:.1f} %), treated as {o.treatment!r}")
    for q in risk.quantities:
        lam, lo, hi = risk.rate[q.label]
        p = risk.prob[years][q.label]
        marks = level_marks(risk, q.label)
        print(f"{q.label:>14}: lambda {_ge(risk)}{_e(lam)} [{_e(lo)}, {_e(hi)}] /yr, P{years:g} {_ge(risk)}{_p(p[0])} "
              f"[{_p(p[1])}, {_p(p[2])}]" + (f"  ({'; '.join(marks)})" if marks else ""))
