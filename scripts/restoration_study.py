"""The restoration study of docs/restoration.md: the default column free, with titanium dowels, with
wooden dowels, and in a two-column portal with an epistyle, on one reduced grid with and without
pulses, their fragility and their risk at the example site, side by side with intervals.

    python scripts/restoration_study.py grids results/restoration     # the grids (resumable), a few CPU-minutes each
    python scripts/restoration_study.py write results/restoration     # risk, fits, figures; prints the docs block
    python scripts/restoration_study.py write results/restoration --docs docs/restoration.md   # replaces the block

Every number of the block between ``<!-- restoration:begin -->`` and ``<!-- restoration:end -->`` of
docs/restoration.md comes from the files this writes; none is typed by hand. The fragility figure goes to
docs/figures/restoration_fragility.png. The grid route's rates are tabled, not drawn: its intervals overlap; the
alternatives' rates and their paired differences, each with its own interval, are the rare-event route's on the
same events (``make restoration-rare``: pycolfrag/risk/restoration_rare.py, docs/restoration.md's second block).
"""
from __future__ import annotations

import argparse
import json
import subprocess
import sys
import warnings
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
#: The variants: folder -> (label, the grid's model option).
VARIANTS = {
    "free": ("free column", ["--column", str(ROOT / "examples/column_parthenon.toml")]),
    "titanium": ("titanium dowels", ["--column", str(ROOT / "examples/column_parthenon_titanium.toml")]),
    "wood": ("wooden dowels", ["--column", str(ROOT / "examples/column_parthenon_wood.toml")]),
    "portal": ("2-column portal", ["--scene", str(ROOT / "examples/portal_2.toml")]),
}
#: The reduced grid: the example risk's (Makefile RISK_GRID) with 30 samples: 5 Mw x 4 R x 30 = 600
#: runs per branch, 1200 per variant (pulse and no-pulse branches, paired seeds).
GRID = ["--mw", "5.5", "6", "6.5", "7", "7.5", "--dist", "5", "10", "15", "20", "--samples", "30",
        "--no-figures", "--no-progress"]
SITE = ROOT / "examples/site_athens.toml"
BEGIN, END = "<!-- restoration:begin -->", "<!-- restoration:end -->"


def grids(folder: Path) -> None:
    """Every variant's two grids, one after the other (a rerun resumes them)."""
    for v, (_, model) in VARIANTS.items():
        out = folder / v
        out.mkdir(parents=True, exist_ok=True)
        for branch, extra in (("pulse", []), ("nopulse", ["--pulse", "none"])):
            cmd = [sys.executable, str(ROOT / "scripts/run_grid.py"), *GRID, *model, *extra, "--out",
                   str(out / f"{branch}.h5")]
            print(" ".join(cmd[1:]), flush=True)
            subprocess.run(cmd, check=True)


# ---- the analysis ------------------------------------------------------------------------------

#: The levels of the study: the paper's Tables III and IV and collapse (a portal's includes unseating).
LEVELS = ("u_top > 0.15", "u_top > 0.35", "u_top > 1", "u_d > 0.005", "u_d > 0.01", "u_d > 0.02", "collapse")
#: The fragility curves fitted on PGV (both branches' runs pooled): level label -> (edp, threshold).
CURVES = {"u_top > 0.15": ("u_top", 0.15), "u_top > 0.35": ("u_top", 0.35), "u_d > 0.005": ("u_d", 0.005),
          "collapse": (None, None)}


def _runs(folder: Path, v: str) -> dict:
    """Both branches' successful runs of a variant, pooled (numpy arrays by field)."""
    from pycolfrag.analysis.completeness import check_complete
    from pycolfrag.analysis.data import read_results
    from pycolfrag.structure.kinds import model_from_dict
    out: dict = {}
    for branch in ("pulse", "nopulse"):
        path = folder / v / f"{branch}.h5"
        d = read_results(path)
        check_complete(d, False, "the restoration study", path)
        model = model_from_dict(json.loads(d.attrs["column"]))
        # the first block of a scene's epistyles (after every column's): a collapse there is an unseating
        out.setdefault("first_beam", []).append(np.full(len(d["mw"]), model.column.n_blocks * model.n_columns
                                                        if hasattr(model, "n_columns") else model.n_blocks + 1))
        for k in ("mw", "dist_km", "pgv_cm_s", "pga_g", "u_top", "u_d", "collapsed", "collapse_block",
                  "dowel_shear_kn", "dowel_slip_mm", "dowels_yielded", "dowels_broken", "epistyle_slip_mm", "epistyle_unseat"):
            out.setdefault(k, []).append(np.asarray(d[k]))
    return {k: np.concatenate(v) for k, v in out.items()}


def _fit(r: dict, level: str):
    from pycolfrag.analysis import fragility as fr
    from pycolfrag.core.errors import ParameterError
    edp, thr = CURVES[level]
    coll = r["collapsed"].astype(bool)
    e = np.zeros(coll.size) if edp is None else np.where(coll, np.nan, r[edp])
    groups = np.round(r["mw"] * 100).astype(int) * 1000 + np.round(r["dist_km"]).astype(int)
    # collapse alone: an EDP of 0 against a threshold no run reaches
    # (a variant whose runs never reach a level has no curve: the fit refuses, the table says so)
    try:
        return fr.fit_lognormal_fragility(r["pgv_cm_s"], e, coll, 1e300 if edp is None else thr, groups=groups,
                                          n_boot=200, rng=0, band_im=np.geomspace(5.0, 500.0, 60))
    except ParameterError as exc:   # the fit's refusal, e.g. no run reached the level
        return str(exc)


def _risk(folder: Path, v: str) -> dict:
    out = folder / v / "risk"
    if not (out / "risk.json").exists():
        subprocess.run([sys.executable, "-m", "pycolfrag.risk.site_risk", str(SITE), str(folder / v / "pulse.h5"),
                        str(out), "--no-pulse", str(folder / v / "nopulse.h5"), "--no-figures"], check=True)
    return json.loads((out / "risk.json").read_text())


def _e(x):
    return "0" if x == 0 else f"{x:.2e}"


def _p(x):
    return f"{x:.3f}" if x >= 0.001 or x == 0 else f"{x:.1e}"


def _fig_fragility(fits: dict, path: Path) -> None:
    from matplotlib.figure import Figure
    fig = Figure(figsize=(11, 8))
    im = np.geomspace(5.0, 500.0, 60)
    for k, level in enumerate(CURVES):
        ax = fig.add_subplot(2, 2, k + 1)
        for j, v in enumerate(VARIANTS):
            f = fits[v][level]
            if isinstance(f, str):   # no run reached the level: no curve
                continue
            ax.semilogx(im, f(im), color=f"C{j}", label=f"{VARIANTS[v][0]} (median {f.median:.0f} cm/s)")
            if f.band_low is not None:
                ax.fill_between(f.band_im, f.band_low, f.band_high, color=f"C{j}", alpha=0.15)
        ax.set_xlabel("PGV (cm/s)")
        ax.set_ylabel("P(exceedance | PGV) (-)")
        ax.set_title(level)
        ax.set_ylim(-0.02, 1.02)
        ax.grid(alpha=0.3, which="both")
        ax.legend(fontsize=7)
    fig.suptitle("Restoration choices: lognormal fragility on PGV (90 % bootstrap bands)")
    fig.tight_layout()
    fig.savefig(path, dpi=110)


#: Where the rates' comparison is: the grid route's intervals above overlap (they are not drawn).
RISK_NOTE = ("The grid route's rates above, each alternative on its own with intervals that overlap, are not drawn: "
             "the alternatives' rates and their paired differences on the same events, each with its own interval, are "
             "the next block's (`make restoration-rare`).")
FRAGILITY_CAPTION = ("*Lognormal fragility on PGV (cm/s) of each level, per variant, with its 90 % bootstrap band "
                     "(both branches' runs pooled).*")
def write(folder: Path, figures: Path) -> str:
    """Fits, risks and figures of the four variants; returns the docs block (Markdown)."""
    runs = {v: _runs(folder, v) for v in VARIANTS}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        fits = {v: {lv: _fit(runs[v], lv) for lv in CURVES} for v in VARIANTS}
    risks = {v: _risk(folder, v) for v in VARIANTS}
    figures.mkdir(parents=True, exist_ok=True)
    _fig_fragility(fits, figures / "restoration_fragility.png")
    names = [VARIANTS[v][0] for v in VARIANTS]
    n = {v: runs[v]["mw"].size for v in VARIANTS}
    L = [f"Grid: Mw 5.5, 6, 6.5, 7, 7.5 x R 5, 10, 15, 20 km x 30 samples, with and without pulses (paired "
         f"seeds): {n['free']} runs per variant; site `examples/site_athens.toml`; written by "
         "`python scripts/restoration_study.py write results/restoration --docs docs/restoration.md`.", "",
         "**Fragility on PGV** (both branches pooled; maximum-likelihood lognormal, median PGV in cm/s with its "
         "90 % bootstrap interval, resampled within scenarios; beta):", "",
         "| level | " + " | ".join(names) + " |", "|---|" + "---|" * len(names)]
    for lv in CURVES:
        cells = []
        for v in VARIANTS:
            f = fits[v][lv]
            if isinstance(f, str):
                cells.append(f"no fit: {f}")
                continue
            lo, hi = f.median_ci
            mark = f" ({f.degenerate})" if f.degenerate else ""
            cells.append(f"{f.median:.0f} [{lo:.0f}, {hi:.0f}], beta {f.beta:.2f}{mark}")
        L.append(f"| {lv} | " + " | ".join(cells) + " |")
    L += ["", "**Risk at the example site** (annual rate lambda and probability in 50 years, each with its "
          "90 % interval, Fay-Feuer gamma, the site's default method):", "",
          "| level | " + " | ".join(names) + " |", "|---|" + "---|" * len(names)]
    for lv in LEVELS:
        cells = []
        for v in VARIANTS:
            lam, lo, hi = risks[v]["rate_per_year"][lv]
            p = risks[v]["probability"]["50"][lv]
            cells.append(f"{_e(lam)} [{_e(lo)}, {_e(hi)}]; P50 {_p(p[0])} [{_p(p[1])}, {_p(p[2])}]")
        L.append(f"| {lv} | " + " | ".join(cells) + " |")
    L += ["", "**What the runs did** (all runs of the variant):", "",
          "| | " + " | ".join(names) + " |", "|---|" + "---|" * len(names)]
    rows = {"collapsed": lambda r: f"{int(r['collapsed'].sum())} of {r['mw'].size}",
            "mean u_top (standing)": lambda r: f"{np.mean(r['u_top'][~r['collapsed'].astype(bool)]):.3f}",
            "mean u_d (standing)": lambda r: f"{np.nanmean(r['u_d'][~r['collapsed'].astype(bool)]):.4f}",
            "runs with a dowel yielded": lambda r: "-" if np.isnan(r["dowels_yielded"]).all()
            else f"{int((r['dowels_yielded'] > 0).sum())}",
            "runs with a dowel broken": lambda r: "-" if np.isnan(r["dowels_broken"]).all()
            else f"{int((r['dowels_broken'] > 0).sum())}",
            "mean peak dowel shear (kN)": lambda r: "-" if np.isnan(r["dowel_shear_kn"]).all()
            else f"{np.mean(r['dowel_shear_kn']):.1f}",
            "mean peak dowel slip (mm)": lambda r: "-" if np.isnan(r["dowel_slip_mm"]).all()
            else f"{np.mean(r['dowel_slip_mm']):.2f}",
            "mean peak epistyle slip (mm)": lambda r: "-" if np.isnan(r["epistyle_slip_mm"]).all()
            else f"{np.mean(r['epistyle_slip_mm']):.1f}",
            "epistyle unseated": lambda r: "-" if np.isnan(r["epistyle_unseat"]).all()
            else f"{int(((r['collapse_block'] >= r['first_beam']) & r['collapsed'].astype(bool)).sum())}"}
    for label, fn in rows.items():
        L.append(f"| {label} | " + " | ".join(fn(runs[v]) for v in VARIANTS) + " |")
    L += ["", "![fragility](figures/restoration_fragility.png)", "", FRAGILITY_CAPTION, "", RISK_NOTE]
    return "\n".join(L)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("what", choices=("grids", "write"))
    p.add_argument("folder", type=Path, help="the study's folder")
    p.add_argument("--docs", type=Path, default=None, help="replace the block of this page (docs/restoration.md)")
    p.add_argument("--figures", type=Path, default=ROOT / "docs" / "figures")
    a = p.parse_args(argv)
    if a.what == "grids":
        grids(a.folder)
        return 0
    block = write(a.folder, a.figures)
    if a.docs is None:
        print(block)
    else:
        text = a.docs.read_text(encoding="utf-8")
        i, j = text.index(BEGIN), text.index(END)
        a.docs.write_text(text[:i + len(BEGIN)] + "\n" + block + "\n" + text[j:], encoding="utf-8")
        print(f"wrote the block of {a.docs}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
