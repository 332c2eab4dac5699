"""The target of rare sequences (docs/sequences.md, "Rare sequences"): P(collapse within 50 years) with
accumulation at the example site and its CoV, the accumulated u_d's exceedance of Table IV's levels, and the
runs against those of the single-event rare route at the same CoV.

    mpirun -n 2 python -m mpi4py -m pycolfrag sequences examples/site_athens.toml results/sequences_rare \\
        --rare --target collapse --target-cov 0.2 --pilot 5 --batch 200          # resumable
    python bench/sequences_rare.py results/sequences_rare --site examples/site_athens.toml \\
        --single results/risk/rare/risk.json [--json bench/results/sequences_rare.json]

The folder's journal (``rows.jsonl``) is read, so a run stopped before its target (SIGTERM, exit 75) is stated as
far as it went: its estimate as the run would state it after those rows (``estimate_rows``: the design its
decisions placed, the rare route's floors), and the runs the target would take at the same cost per unit of
variance (runs x (CoV / target)^2: a CoV falls as one over the square root of the runs) -- an extrapolation,
said as such. ``--single``: the rare route's ``risk.json`` of the same site and column (``make risk-rare``); without
it, ``--single-runs`` and ``--single-cov`` (default: its v5 run, docs/risk.md). The single-event runs at a CoV c are
its runs x (its CoV / c)^2.
"""
from __future__ import annotations

import argparse
import json
import math
import platform
import sys
from pathlib import Path

from pycolfrag.core.errors import PycolfragError
from pycolfrag.rare.proposal import Mixture
from pycolfrag.risk import sequences_rare as rare
from pycolfrag.risk.aftershocks import Aftershocks
from pycolfrag.risk.sequences import SequenceSettings
from pycolfrag.risk.sequences_journal import read_lines
from pycolfrag.site.sources import load_site


def _journal(folder: Path, site_path: str) -> tuple:
    """(the rare settings, the rows) of a folder's journal; its identity gives the settings (years, seed, rare)."""
    head = json.loads((folder / "rows.jsonl").open().readline())["identity"]
    st, r = head["settings"], head["rare"]
    if r.get("algorithm") != rare.ALGORITHM:
        raise PycolfragError(f"{folder}: rows of another algorithm ({r.get('algorithm')!r})")
    rs = rare.RareSequenceSettings(
        sequences=SequenceSettings(years=st["years"], seed=st["seed"], aftershocks=None if st.get("aftershocks") is None
                                   else Aftershocks(**st["aftershocks"])), target=r["target"], target_cov=r["target_cov"],
        pilot=r["pilot"], batch=r["batch"], pilot_mixture=Mixture.from_dict(r["pilot_mixture"]),
        max_rows=r["max_rows"] if isinstance(r["max_rows"], int) else 10 ** 9,   # "whole batches": any budget
        mixture=None if r["mixture"] is None else Mixture.from_dict(r["mixture"]), ways=tuple(r["ways"]),
        tail_share=r["tail_share"])
    return rs, read_lines(folder / "rows.jsonl", head, lambda s: None)


def _interval(p: float, cov: float, z: float = 1.6449) -> tuple:
    """The 90 % interval the rare route states (log-normal: p exp(+-z sqrt(ln(1 + CoV^2))))."""
    if not (p > 0 and math.isfinite(cov)):
        return 0.0, math.inf
    half = z * math.sqrt(math.log1p(cov * cov))
    return p * math.exp(-half), p * math.exp(half)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("folder", help="the output folder of pycolfrag sequences --rare (rows.jsonl)")
    p.add_argument("--site", default="examples/site_athens.toml", help="the site file the folder was run on")
    p.add_argument("--single", default=None, help="the rare route's risk.json of the same site and column")
    p.add_argument("--single-runs", type=float, default=6430, help="without --single: its runs (v5: 6430)")
    p.add_argument("--single-cov", type=float, default=0.138, help="without --single: its collapse CoV (v5: 0.138)")
    p.add_argument("--json", default=None, help="write the numbers here too")
    args = p.parse_args(argv)
    rs, rows = _journal(Path(args.folder), args.site)
    run = rare.estimate_rows(load_site(args.site), rs, rows)
    est, years, target = run["estimate"], rs.sequences.years, rs.target
    print(f"rare sequences: {len(rows)} rows over {len(run['strata'])} strata "
          f"({sum(r['strongest'] for r in rows)} with the row's event the strongest), {run['runs']} event runs "
          f"({run['shared']} more shared between the ways), {run['seconds']:.0f} s of runs ({platform.processor() or platform.machine()}); horizon {years:g} years"
          + (f", with aftershocks ({rs.sequences.aftershocks})" if rs.sequences.aftershocks is not None else ""))
    for note in run["design"].notes:
        print(f"  production proposal: {note}")
    others = rs.ways[1:]
    print(f"\n| quantity | P within {years:g} yr: accumulated [CoV; sample-variance CoV] | its 90 % interval | "
          + "".join(f"{w} [CoV] | " for w in others) + "hits | of them after x | P from them | P on strata of < 20 "
          "rows |\n|---|---|---|" + "---|" * (len(others) + 4))
    for q, a in est["accumulated"].items():
        cells = "".join(f"{est[w][q]['p']:.3g} [{est[w][q]['cov']:.2f}] | " for w in others)
        lo, hi = _interval(a["p"], a["cov"])
        print(f"| {q} | {a['p']:.3g} [{a['cov']:.2f}; {a['cov_sample']:.2f}] | [{lo:.3g}, {hi:.3g}] | {cells}"
              f"{a['hits']} | {a['late_hits']} | {a['p_late']:.3g} | {a['p_on_few_rows']:.2g} |")
    if args.single:
        single = json.loads(Path(args.single).read_text())
        s_runs, s_cov = single["runs"], single["levels"]["collapse"]["cov"]
    else:
        s_runs, s_cov = args.single_runs, args.single_cov
    cov = est["accumulated"][target]["cov"]
    s_at = s_runs * (s_cov / rs.target_cov) ** 2
    need = run["runs"] * (cov / rs.target_cov) ** 2
    print(f"\nsingle event (rare route): collapse CoV {s_cov:.3f} from {s_runs:.0f} runs: {s_at:.0f} runs at CoV "
          f"{rs.target_cov:g}, the target's budget 2x = {2 * s_at:.0f} runs")
    met = cov <= rs.target_cov and run["runs"] <= 2 * s_at
    reached = (f"reached CoV {rs.target_cov:g}: measured {run['runs'] / s_at:.2f}x the single event's runs at CoV "
               f"{rs.target_cov:g} (target <= 2x: {'met' if met else 'NOT met'}); at exactly {rs.target_cov:g} by "
               f"1/sqrt(runs) {need:.0f} runs ({need / s_at:.2f}x)")
    print(f"sequences: {target} CoV {cov:.3f} from {run['runs']} runs; "
          + (reached if cov <= rs.target_cov else f"extrapolated by 1/sqrt(runs): {need:.0f} runs at CoV "
             f"{rs.target_cov:g} ({need / s_at:.2f}x the single event's; target <= 2x) -- NOT measured, the run stopped "
             f"at CoV {cov:.3f}"))
    if args.json:
        Path(args.json).write_text(json.dumps({
            "rows": len(rows), "runs": run["runs"], "shared": run["shared"], "seconds": run["seconds"], "design": run["design"].as_dict(),
            "ways": list(rs.ways), "tail_share": rs.tail_share,
            "tails_run": rare.tails_run(rows),
            "estimate": est, "single": {"runs": s_runs, "cov": s_cov, "runs_at_target": s_at},
            "runs_at_target_extrapolated": need, "target_met": met}, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
