"""Where the full `reproduce 000` and `reproduce 002` studies spend their CPU, before and after
issue 40's study-level savings, measured side by side in one session (benchmarks/bench_reproduce.md).

The full studies take hours, so their CPU is estimated: each kind of run the study makes (an
ordinary bifurcation value, a Lyapunov check at the study's tolerance and at a tenth of it, a
response run) is timed on both trees at two lengths (CPU = a + b x periods: the per-run fixed
cost and the cost per period), alternating the trees, and the study's composition (read off its
settings: paper000.SETTINGS, paper002._settings) multiplies it out.

    python benchmarks/bench_reproduce.py measure --base /tmp/base85904b6 [--repeat 2] > kinds.json
    python benchmarks/bench_reproduce.py parts --paper 000 > parts000.json   # (and 002) the analysis + load
    python benchmarks/bench_reproduce.py estimate kinds.json --parts parts000.json parts002.json   # the .md's tables
    python benchmarks/bench_reproduce.py compare A B   # two report folders: results identical?

``measure`` runs each kind in a fresh process per tree (PYTHONPATH = that tree; this file only
uses APIs both trees have, and runs a Lyapunov check the way each tree's study does). The
Lyapunov model (reproduce.chaos): before, each (value, tolerance) pair ran, for each of the two
lengths, an ordinary run and a Benettin loop over transient + length periods; after, one loop over
transient + the longer length gives both exponents.
"""
from __future__ import annotations

import argparse
import json
import math
import os
import subprocess
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))

# ----------------------------------------------------------------------------- one kind, one tree
#: (paper, kind) -> what a run of that kind is; "rtol" None: the study's default
KINDS = {
    "000 ordinary": dict(paper="000", what="ordinary", rtol=1e-8),
    "000 ordinary rtol/10": dict(paper="000", what="ordinary", rtol=1e-9),
    "000 ordinary rtol/100": dict(paper="000", what="ordinary", rtol=1e-10),
    "000 lyapunov loop": dict(paper="000", what="loop", rtol=1e-8),
    "000 lyapunov loop rtol/10": dict(paper="000", what="loop", rtol=1e-9),
    "002 ordinary": dict(paper="002", what="ordinary", rtol=1e-6),
    "002 ordinary rtol/10": dict(paper="002", what="ordinary", rtol=1e-7),
    "002 lyapunov loop": dict(paper="002", what="loop", rtol=1e-6),
    "002 lyapunov loop rtol/10": dict(paper="002", what="loop", rtol=1e-7),
}


def _setup(paper):
    """(model path, parameter, value, period, common bifurcation options) of a representative run:
    000 at mu 0.01 (the chaotic end), 002 at the 0.8 mm clearance (the paper's chaotic value)."""
    from pinclear.core.models import model_path

    if paper == "000":
        from pinclear.studies.reproduce import paper000 as P

        s = P._settings(False, None)
        return (str(model_path("four_ups_upu")), "S2.mu", 0.01, P.T,
                dict(signal=P.SIGNALS, per_period=s["per_period"], keep_portrait=True,
                     load_options={"clearances": ["S2"], "overrides": {}}))
    from pinclear.studies.reproduce import paper002 as P

    return (str(model_path("nine_bar")), {f"{j}.clearance": 1.0 for j in P.JOINTS}, 8e-4, 1.0,
            dict(signal=P.SIGNALS, per_period=100, keep_portrait=True,
                 load_options={"clearances": list(P.JOINTS), "overrides": {f"{j}.mu": 0.3 for j in P.JOINTS}}))


def run_kind(name, periods, transient=2):
    """CPU seconds (this process) of one run of kind ``name`` over ``periods`` periods
    (transient included), after a one-period warm-up run (kernels loaded)."""
    import warnings

    from pinclear import analysis

    warnings.simplefilter("ignore")
    k = KINDS[name]
    path, par, value, T, common = _setup(k["paper"])
    sim = {"rtol": k["rtol"]}
    if k["paper"] == "002":
        sim.update(method="lagrange", integrator="RK45")
    analysis.bifurcation(path, par, [value], period=T, cycles=1, transient=0, executor="serial", sim_options=sim,
                         **common)
    c0 = time.process_time()
    if k["what"] == "ordinary":
        r = analysis.bifurcation(path, par, [value], period=T, cycles=periods - transient, transient=transient,
                                 executor="serial", sim_options=sim, **common)
        ok = r.runs[0].ok
    else:
        from pinclear.analysis.lyapunov import mechanism_lyapunov
        from pinclear.io.sidecar import load

        ov = dict(common["load_options"]["overrides"])
        for key in (par if isinstance(par, dict) else {par: 1.0}):
            ov[key] = value
        mech = load(path, clearances=common["load_options"]["clearances"], overrides=ov)
        res = mechanism_lyapunov(mech, periods * T, renorm=T / 4, transient=transient * T, **sim)
        ok = math.isfinite(res.exponent)
    return {"cpu_s": time.process_time() - c0, "periods": periods, "ok": bool(ok)}


def lyapunov_exponents(paper, value, transient, lengths, rtol):
    """{length: exponent} of one Lyapunov check the way this tree's study runs it: one
    bifurcation run with lyapunov_at where the tree has it, else one lyapunov=True run per length."""
    import inspect
    import warnings

    from pinclear import analysis

    warnings.simplefilter("ignore")
    path, par, _, T, common = _setup(paper)
    common = dict(common, keep_portrait=False)
    sim = {"rtol": rtol} if paper == "000" else {"rtol": rtol, "method": "lagrange", "integrator": "RK45"}
    c0 = time.process_time()
    if "lyapunov_at" in inspect.signature(analysis.bifurcation).parameters:
        r = analysis.bifurcation(path, par, [value], period=T, cycles=max(lengths), transient=transient,
                                 executor="serial", sim_options=sim, lyapunov=True, lyapunov_at=lengths, **common)
        got = {n: r.runs[0].stats["lyapunov_at"][n] for n in lengths}
    else:
        got = {}
        for n in lengths:
            r = analysis.bifurcation(path, par, [value], period=T, cycles=n, transient=transient, executor="serial",
                                     sim_options=sim, lyapunov=True, **common)
            got[n] = r.runs[0].stats.get("lyapunov")
    return {"exponents": got, "cpu_s": time.process_time() - c0}


def parts(paper, cycles, repeat):
    """In one process (the branch), the parts of an ordinary bifurcation run that the savings
    touch, old way and new way alternately on the same trajectory: the analysis (before: each
    signal resolved by poincare() and again for its portrait, each frame pass on its own; after:
    sweep._sections) and the variant's load (before: the YAML parsed and example-robot-data's
    file list read on every load; after: cached). The integration between them is common code,
    timed once (trajectory cpu_s). Returns medians and minima in CPU seconds."""
    import statistics
    import warnings

    from pinclear.core import models
    from pinclear.io import sidecar
    from pinclear.analysis import poincare, series, diagrams as sweep
    from pinclear.dynamics.simulate import simulate

    warnings.simplefilter("ignore")
    path, par, value, T, common = _setup(paper)
    sim = {"rtol": 1e-8} if paper == "000" else {"rtol": 1e-6, "method": "lagrange", "integrator": "RK45"}
    overrides = sweep._parameter_overrides(path, par, common["load_options"])
    load_kw = common["load_options"]
    tr_n = 2
    mech = sweep._load_variant(path, overrides, value, load_kw)
    t_eval = sweep.section_times(T, tr_n + cycles, 0.0, 0.0, common["per_period"])
    c0 = time.process_time()
    traj = simulate(mech, float(t_eval[-1]), t_eval=t_eval, **sim)
    integ = time.process_time() - c0
    job = dict(signals=common["signal"], period=T, phase=0.0, transient=tr_n, t0=0.0, keep_portrait=True)

    def old_analysis():
        for sig in job["signals"]:
            poincare(traj, T, sig, skip_transient=tr_n, mech=mech)
            series(traj, sig, mech)

    def new_analysis():
        sweep._sections(job, traj, mech)

    def old_load():
        sidecar._PARSED.clear()
        models.example_robot_data_dir.cache_clear()
        sweep._load_variant(path, overrides, value, load_kw)

    def new_load():
        sweep._load_variant(path, overrides, value, load_kw)

    got = {k: [] for k in ("analysis before", "analysis after", "load before", "load after")}
    for _ in range(repeat):
        for key, f in (("analysis before", old_analysis), ("analysis after", new_analysis),
                       ("load before", old_load), ("load after", new_load)):
            c0 = time.process_time()
            f()
            got[key].append(time.process_time() - c0)
    per = tr_n + cycles
    out = {"paper": paper, "periods": per, "samples": len(traj.t), "integration_s": integ,
           "integration_per_period": integ / per}
    for k, v in got.items():
        out[k] = {"median": statistics.median(v), "min": min(v)}
    for k in ("analysis", "load"):
        out[f"{k} after/before (medians)"] = out[f"{k} after"]["median"] / out[f"{k} before"]["median"]
        out[f"{k} after/before (minima)"] = out[f"{k} after"]["min"] / out[f"{k} before"]["min"]
    return out


def _child(tree, name, periods):
    env = dict(os.environ, PYTHONPATH=tree)
    out = subprocess.run([sys.executable, __file__, "_kind", name, str(periods)], env=env, cwd=tree,
                         capture_output=True, text=True, check=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


def measure(base, branch, kinds, lengths, repeat):
    """{kind: {tree: [(periods, cpu_s), ...]}}: each kind at each length on both trees,
    alternating base and branch, ``repeat`` times."""
    got = {}
    for name in kinds:
        got[name] = {"before": [], "after": []}
        for _ in range(repeat):
            for n in lengths:
                for label, tree in (("before", base), ("after", branch)):
                    r = _child(tree, name, n)
                    got[name][label].append((n, r["cpu_s"]))
                    print(f"{name:28s} {label:6s} {n:3d} periods: {r['cpu_s']:7.2f} s", file=sys.stderr, flush=True)
    return got


def fit(points):
    """(fixed s, s per period) of cpu = a + b periods: the least-squares line through the
    per-length minima (the least disturbed runs on a shared machine)."""
    by = {}
    for n, c in points:
        by[n] = min(c, by.get(n, math.inf))
    ns = sorted(by)
    if len(ns) == 1:
        return 0.0, by[ns[0]] / ns[0]
    mx, my = sum(ns) / len(ns), sum(by[n] for n in ns) / len(ns)
    b = sum((n - mx) * (by[n] - my) for n in ns) / sum((n - mx) ** 2 for n in ns)
    return my - b * mx, b


# ----------------------------------------------------------------------------- the estimate
def lyap_cost(kind_fit, tr, lengths, after):
    """CPU of one (value, tolerance) Lyapunov check: before, per length an ordinary run and a
    loop over tr + length periods; after, one loop over tr + the longest."""
    (oa, ob), (la, lb) = kind_fit
    if after:
        return la + lb * (tr + max(lengths))
    return sum(oa + ob * (tr + n) + la + lb * (tr + n) for n in lengths)


def composition(paper, limit_values=None, quick=False):
    """[(row label, runs before, runs after, periods per run, kind)] of the study, read off its
    settings; kind 'lyap:<ordinary kind>|<loop kind>' is a Lyapunov check (periods: (transient,
    lengths)); 'same:<kind>' a run whose code the savings leave alone (costed alike both times).
    limit_values: the number of values given the Lyapunov check (default: every diagram's limit;
    a quick study has none, its 10 cycles leave its non-periodic runs 'unresolved')."""
    if paper == "000":
        from pinclear.studies.reproduce import paper000 as P

        s = P._settings(quick, None)
        per = s["transient"] + s["cycles"]
        nl = limit_values if limit_values is not None else (0 if quick else 3 * s["lyapunov_limit"])
        lengths = [max(1, round(f * s["cycles"])) for f in (0.25, 0.5)]
        n_mu, n_c = len(s["mu_values"]), len(s["clearance_values"])
        # paper000.study_point: the clearance study's run at the sidecar's 0.5 mm is the mu study's 0.1
        dup_c = sum(1 for c in s["clearance_values"] if c == 5e-4) if 0.1 in s["mu_values"] else 0
        return [("response runs (mu x K form)", 6, 6, s["force_periods"], "same:000 ordinary"),
                ("bifurcation mu", n_mu, n_mu, per, "000 ordinary"),
                ("bifurcation clearance", n_c, n_c - dup_c, per, "000 ordinary"),
                ("sensitivity variants (baseline = mu 0.01 run)", len(P.SENS_VARIANTS),
                 len(P.SENS_VARIANTS) - (P.SENS_MU in s["mu_values"]), per, "000 ordinary"),
                ("sensitivity rtol 1e-10", 1, 1, per, "000 ordinary rtol/100"),
                ("Lyapunov checks at rtol", nl, nl, (s["transient"], lengths), "lyap:000 ordinary|000 lyapunov loop"),
                ("Lyapunov checks at rtol/10", nl, nl, (s["transient"], lengths),
                 "lyap:000 ordinary rtol/10|000 lyapunov loop rtol/10")]
    from pinclear.studies.reproduce import paper002 as P

    s = P._settings(quick)
    per = s["transient cycles"] + s["cycles"]
    nl = limit_values if limit_values is not None else (0 if quick else 2 * s["lyapunov limit"])
    lengths = [max(1, round(f * s["cycles"])) for f in (0.25, 0.5)]
    n_c = len({round(v * 1e-3, 9) for v in s["clearances [mm]"]} | set(P.PAPER_CHAOS))
    n_w = len({float(v) * math.pi for v in s["speeds [pi rad/s]"]} | {2 * math.pi, 3 * math.pi})
    # the speed study's periods are 2 pi / w: in units of the clearance study's 1 s period
    w_period = sum(2 / v for v in s["speeds [pi rad/s]"]) / len(s["speeds [pi rad/s]"])
    return [("bifurcation clearance", n_c, n_c, per, "002 ordinary"),
            ("bifurcation speed (mean period %.3g s)" % w_period, n_w, n_w, per * w_period, "002 ordinary"),
            ("long run 0.01 mm", 1, 1, max(20, s["transient cycles"]) + s["long cycles"], "002 ordinary"),
            ("Lyapunov checks at rtol", nl, nl, (s["transient cycles"], lengths), "lyap:002 ordinary|002 lyapunov loop"),
            ("Lyapunov checks at rtol/10", nl, nl, (s["transient cycles"], lengths),
             "lyap:002 ordinary rtol/10|002 lyapunov loop rtol/10")]


def estimate(fits, paper, limit_values=None, quick=False):
    """Rows (label, runs before, runs after, periods, before per run, after per run, before
    total, after total)."""
    rows = []
    for label, nb, na, per, kind in composition(paper, limit_values, quick):
        if kind.startswith("lyap:"):
            o, l = kind[5:].split("|")
            tr, lengths = per
            # the loop is the same code on both trees: its cost from both trees' runs together
            loop = fit(fits[l]["points"])
            b = lyap_cost((fits[o]["before"], loop), tr, lengths, after=False)
            a = lyap_cost((fits[o]["after"], loop), tr, lengths, after=True)
            per_text = f"{tr}+{'/'.join(map(str, lengths))}"
        elif kind.startswith("same:"):
            fa, fb = fits[kind[5:]]["before"]
            b = a = fa + fb * per
            per_text = f"{per:.4g}"
        else:
            (ba, bb), (aa, ab) = fits[kind]["before"], fits[kind]["after"]
            b, a = ba + bb * per, aa + ab * per
            per_text = f"{per:.4g}"
        rows.append((label, nb, na, per_text, b, a, nb * b, na * a))
    return rows


def difference_fits(data, part_files):
    """{kind: {before, after, points}} where an ordinary run's cost is the integration (the same
    code on both trees) plus the analysis and the load, whose old-way and new-way costs ``parts``
    measured in one process (far less noise than two trees' whole runs): the before line is
    fitted through the base tree's runs and the branch's runs with the measured savings added
    back, the after line is that line minus the savings. The Lyapunov loop is the same code on
    both trees: one line through both trees' runs."""
    parts_ = {}
    for f in part_files:
        p = json.load(open(f))
        parts_[p["paper"]] = ((p["analysis before"]["median"] - p["analysis after"]["median"]) / p["periods"],
                              p["load before"]["median"] - p["load after"]["median"])
    fits = {}
    for k, v in data["kinds"].items():
        paper, what = KINDS[k]["paper"], KINDS[k]["what"]
        if what == "ordinary" and paper in parts_:
            da, dl = parts_[paper]
            a, b = fit(v["before"] + [(n, c + da * n + dl) for n, c in v["after"]])
            fits[k] = {"before": (a, b), "after": (a - dl, b - da)}
        elif what == "loop":
            line = fit(v["before"] + v["after"])
            fits[k] = {"before": line, "after": line}
        else:
            fits[k] = {"before": fit(v["before"]), "after": fit(v["after"])}
        fits[k]["points"] = v["before"] + v["after"]
    return fits, parts_


def print_estimate(data, limits=None, part_files=()):
    if part_files:
        fits, parts_ = difference_fits(data, part_files)
        for paper, (da, dl) in parts_.items():
            print(f"{paper}: the savings measured in one process: analysis {da:.4f} s per period, load {dl:.3f} s per run")
    else:
        fits = {k: {"before": fit(v["before"]), "after": fit(v["after"]), "points": v["before"] + v["after"]}
                for k, v in data["kinds"].items()}
    print("| kind | before: fixed s + s/period | after | after/before per period |")
    print("|---|---|---|---|")
    for k, f in fits.items():
        (ba, bb), (aa, ab) = f["before"], f["after"]
        print(f"| {k} | {ba:.2f} + {bb:.3f} | {aa:.2f} + {ab:.3f} | {ab / bb:.2f} |")
    for paper in ("000", "002"):
        for quick, nl in [(True, None), (False, None)] + [(False, n) for n in (limits or [])]:
            rows = estimate(fits, paper, nl, quick)
            tb, ta = sum(r[6] for r in rows), sum(r[7] for r in rows)
            what = f"{'quick' if quick else 'full'} {paper}" + ("" if nl is None else f", {nl} Lyapunov-checked values")
            print(f"\n{what}: before {tb:.0f} s, after {ta:.0f} s CPU of its runs (after/before {ta / tb:.2f})")
            print("| runs | count before | after | periods | CPU per run before [s] | after [s] | total before [s] "
                  "| after [s] |")
            print("|---|---|---|---|---|---|---|---|")
            for r in rows:
                print(f"| {r[0]} | {r[1]} | {r[2]} | {r[3]} | {r[4]:.1f} | {r[5]:.1f} | {r[6]:.0f} | {r[7]:.0f} |")


# ----------------------------------------------------------------------------- results identical?
SKIP = ("cpu", "wall", "time [s]", "pid")


def _skipped(key):
    k = str(key).lower()
    return any(s in k for s in SKIP)


def differences(a, b, path=""):
    """[(path, a, b)] of the fields of two reports that differ, CPU / wall / pid fields left out
    (table columns named so included)."""
    out = []
    if isinstance(a, dict) and isinstance(b, dict):
        cols = a.get("columns") if isinstance(a.get("columns"), list) else None
        for k in sorted(set(a) | set(b), key=str):
            if _skipped(k):
                continue
            if k == "rows" and cols and isinstance(a.get(k), list) and isinstance(b.get(k), list):
                keep = [i for i, c in enumerate(cols) if not _skipped(c)]
                ra = [[r[i] for i in keep] if isinstance(r, list) else r for r in a[k]]
                rb = [[r[i] for i in keep] if isinstance(r, list) else r for r in b[k]]
                out += differences(ra, rb, f"{path}.rows")
                continue
            out += differences(a.get(k), b.get(k), f"{path}.{k}")
        return out
    if isinstance(a, list) and isinstance(b, list) and len(a) == len(b):
        for i, (x, y) in enumerate(zip(a, b)):
            out += differences(x, y, f"{path}[{i}]")
        return out
    if isinstance(a, str) and isinstance(b, str) and _skipped(path):
        return out
    same = a == b or (isinstance(a, float) and isinstance(b, float) and math.isnan(a) and math.isnan(b))
    return [] if same else [(path, a, b)]


def compare_arrays(da, db):
    """Names of the arrays of the two report folders' .npz files (the diagrams' Poincaré samples
    and portraits) that are not equal bit for bit, or that one folder lacks."""
    import glob

    import numpy as np

    bad = []
    for fa in sorted(glob.glob(os.path.join(da, "*.npz"))):
        fb = os.path.join(db, os.path.basename(fa))
        if not os.path.exists(fb):
            bad.append(f"{os.path.basename(fa)} missing")
            continue
        a, b = np.load(fa), np.load(fb)
        names = sorted(set(a.files) | set(b.files))
        bad += [f"{os.path.basename(fa)}:{k}" for k in names if k != "meta" and (
            k not in a.files or k not in b.files or not np.array_equal(a[k], b[k]))]
        print(f"{os.path.basename(fa)}: {len(names) - 1} arrays compared")
    return bad


def compare(fa, fb):
    if os.path.isdir(fa):
        bad = compare_arrays(fa, fb)
        print(f"{len(bad)} array(s) not bit-for-bit equal" + (": " + ", ".join(bad[:20]) if bad else ""))
        return len(bad) + compare(os.path.join(fa, "report.json"), os.path.join(fb, "report.json"))
    a, b = json.load(open(fa)), json.load(open(fb))
    diff = differences(a, b)
    for p, x, y in diff:
        rel = ""
        if isinstance(x, (int, float)) and isinstance(y, (int, float)) and not isinstance(x, bool):
            rel = f"  (relative {abs(x - y) / max(abs(x), abs(y), 1e-300):.2g})"
        print(f"{p}: {str(x)[:160]!r} != {str(y)[:160]!r}{rel}")
    print(f"{len(diff)} differing field(s) between {fa} and {fb} (CPU, wall time and pid fields left out)")
    return len(diff)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    sub = ap.add_subparsers(dest="cmd", required=True)
    m = sub.add_parser("measure")
    m.add_argument("--base", required=True, help="the baseline tree (PYTHONPATH of the 'before' runs)")
    m.add_argument("--branch", default=os.path.dirname(HERE))
    m.add_argument("--kinds", default=",".join(KINDS))
    m.add_argument("--lengths", default="4,8", help="periods per run (transient 2 included)")
    m.add_argument("--repeat", type=int, default=1)
    e = sub.add_parser("estimate")
    e.add_argument("kinds_json", nargs="+", help="outputs of `measure` (their runs pooled)")
    e.add_argument("--limits", default="", help="also estimate with these numbers of Lyapunov-checked values")
    e.add_argument("--parts", nargs="*", default=[], help="JSON files of `parts` (000, 002): the difference model")
    c = sub.add_parser("compare")
    c.add_argument("a")
    c.add_argument("b")
    q = sub.add_parser("lyapunov", help="one Lyapunov check on both trees: the exponents and the CPU")
    q.add_argument("--base", required=True)
    q.add_argument("--branch", default=os.path.dirname(HERE))
    q.add_argument("--paper", default="000")
    q.add_argument("--value", type=float, default=0.01)
    q.add_argument("--transient", type=int, default=2)
    q.add_argument("--lengths", default="2,4")
    q.add_argument("--rtol", type=float, default=1e-8)
    pa = sub.add_parser("parts", help="the analysis and load of one run, old way and new way, in one process")
    pa.add_argument("--paper", default="000")
    pa.add_argument("--cycles", type=int, default=8)
    pa.add_argument("--repeat", type=int, default=5)
    k = sub.add_parser("_kind")
    k.add_argument("name")
    k.add_argument("periods", type=int)
    y = sub.add_parser("_lyap")
    for name, typ in (("paper", str), ("value", float), ("transient", int), ("lengths", str), ("rtol", float)):
        y.add_argument(name, type=typ)
    args = ap.parse_args(argv)
    if args.cmd == "_kind":
        print(json.dumps(run_kind(args.name, args.periods)))
    elif args.cmd == "parts":
        print(json.dumps(parts(args.paper, args.cycles, args.repeat), indent=1))
    elif args.cmd == "_lyap":
        print(json.dumps(lyapunov_exponents(args.paper, args.value, args.transient, json.loads(args.lengths),
                                            args.rtol)))
    elif args.cmd == "lyapunov":
        lengths = [int(x) for x in args.lengths.split(",")]
        res = {}
        for label, tree in (("before", args.base), ("after", args.branch)):
            out = subprocess.run([sys.executable, __file__, "_lyap", args.paper, str(args.value), str(args.transient),
                                  json.dumps(lengths), str(args.rtol)], env=dict(os.environ, PYTHONPATH=tree),
                                 cwd=tree, capture_output=True, text=True, check=True)
            res[label] = json.loads(out.stdout.strip().splitlines()[-1])
            print(f"{label}: exponents {res[label]['exponents']} 1/s, CPU {res[label]['cpu_s']:.2f} s")
        b, a = res["before"]["exponents"], res["after"]["exponents"]
        print("after/before CPU", round(res["after"]["cpu_s"] / res["before"]["cpu_s"], 3), "; exponents",
              "bitwise equal" if b == a else "differ: " + ", ".join(f"{n}: {abs(a[n] - b[n]):.3g}" for n in b))
    elif args.cmd == "measure":
        got = measure(args.base, args.branch, args.kinds.split(","), [int(x) for x in args.lengths.split(",")],
                      args.repeat)
        print(json.dumps({"base": args.base, "branch": args.branch, "kinds": got}, indent=1))
    elif args.cmd == "estimate":
        data = {"kinds": {}}
        for f in args.kinds_json:
            for k, v in json.load(open(f))["kinds"].items():
                got = data["kinds"].setdefault(k, {"before": [], "after": []})
                got["before"] += v["before"]
                got["after"] += v["after"]
        print_estimate(data, [int(x) for x in args.limits.split(",") if x], args.parts)
    else:
        return 1 if compare(args.a, args.b) else 0
    return 0


if __name__ == "__main__":
    sys.exit(main())
