"""Where the full `reproduce 000` and `reproduce 002` studies spend their CPU, before and after
issue 40's study-level savings, measured side by side in one session (benchmarks/bench_reproduce.md).

The full studies take hours, so their CPU is estimated: each kind of run the study makes (an
ordinary bifurcation value, a Lyapunov check at the study's tolerance and at a tenth of it, a
response run) is timed on both trees at two lengths (CPU = a + b x periods: the per-run fixed
cost and the cost per period), alternating the trees, and the study's composition (read off its
settings: paper000.SETTINGS, paper002._settings) multiplies it out.

    python benchmarks/bench_reproduce.py measure --base /tmp/base85904b6 [--repeat 2] > kinds.json
    python benchmarks/bench_reproduce.py estimate kinds.json        # the table of the .md
    python benchmarks/bench_reproduce.py compare A/report.json B/report.json   # results identical?

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
    from pinclear.models import model_path

    if paper == "000":
        from pinclear.reproduce import paper000 as P

        s = P._settings(False, None)
        return (str(model_path("four_ups_upu")), "S2.mu", 0.01, P.T,
                dict(signal=P.SIGNALS, per_period=s["per_period"], keep_portrait=True,
                     load_options={"clearances": ["S2"], "overrides": {}}))
    from pinclear.reproduce import paper002 as P

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
        from pinclear.sidecar import load

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


def composition(paper, limit_values=None):
    """[(row label, runs, periods per run, kind or 'lyap:<kinds>')] of the full study."""
    if paper == "000":
        from pinclear.reproduce import paper000 as P

        s = P._settings(False, None)
        per = s["transient"] + s["cycles"]
        nl = limit_values if limit_values is not None else 3 * s["lyapunov_limit"]
        lengths = [max(1, round(f * s["cycles"])) for f in (0.25, 0.5)]
        return s, [("bifurcation mu", len(s["mu_values"]), per, "000 ordinary"),
                   ("bifurcation clearance", len(s["clearance_values"]), per, "000 ordinary"),
                   ("sensitivity variants", len(P.SENS_VARIANTS), per, "000 ordinary"),
                   ("sensitivity rtol 1e-10", 1, per, "000 ordinary rtol/100"),
                   ("Lyapunov checks at rtol", nl, (s["transient"], lengths), "lyap:000 ordinary|000 lyapunov loop"),
                   ("Lyapunov checks at rtol/10", nl, (s["transient"], lengths),
                    "lyap:000 ordinary rtol/10|000 lyapunov loop rtol/10")]
    from pinclear.reproduce import paper002 as P

    s = P._settings(False)
    per = s["transient cycles"] + s["cycles"]
    nl = limit_values if limit_values is not None else 2 * s["lyapunov limit"]
    lengths = [max(1, round(f * s["cycles"])) for f in (0.25, 0.5)]
    n_c = len({round(v * 1e-3, 9) for v in s["clearances [mm]"]} | set(P.PAPER_CHAOS))
    n_w = len({float(v) * math.pi for v in s["speeds [pi rad/s]"]} | {2 * math.pi, 3 * math.pi})
    # the speed study's periods are 2 pi / w: in units of the clearance study's 1 s period
    w_period = sum(2 / v for v in s["speeds [pi rad/s]"]) / len(s["speeds [pi rad/s]"])
    return s, [("bifurcation clearance", n_c, per, "002 ordinary"),
               ("bifurcation speed (mean period %.3g s)" % w_period, n_w, per * w_period, "002 ordinary"),
               ("long run 0.01 mm", 1, max(20, s["transient cycles"]) + s["long cycles"], "002 ordinary"),
               ("Lyapunov checks at rtol", nl, (s["transient cycles"], lengths),
                "lyap:002 ordinary|002 lyapunov loop"),
               ("Lyapunov checks at rtol/10", nl, (s["transient cycles"], lengths),
                "lyap:002 ordinary rtol/10|002 lyapunov loop rtol/10")]


def estimate(fits, paper, limit_values=None):
    """Rows (label, runs, periods, before per run, after per run, before total, after total)."""
    _, comp = composition(paper, limit_values)
    rows = []
    for label, count, per, kind in comp:
        if kind.startswith("lyap:"):
            o, l = kind[5:].split("|")
            tr, lengths = per
            b = lyap_cost((fits[o]["before"], fits[l]["before"]), tr, lengths, after=False)
            a = lyap_cost((fits[o]["after"], fits[l]["after"]), tr, lengths, after=True)
            per_text = f"{tr}+{'/'.join(map(str, lengths))}"
        else:
            (ba, bb), (aa, ab) = fits[kind]["before"], fits[kind]["after"]
            b, a = ba + bb * per, aa + ab * per
            per_text = f"{per:.4g}"
        rows.append((label, count, per_text, b, a, count * b, count * a))
    return rows


def print_estimate(data, limits=None):
    fits = {k: {t: fit(v[t]) for t in ("before", "after")} for k, v in data["kinds"].items()}
    print("| kind | before: fixed s + s/period | after | after/before per period |")
    print("|---|---|---|---|")
    for k, f in fits.items():
        (ba, bb), (aa, ab) = f["before"], f["after"]
        print(f"| {k} | {ba:.2f} + {bb:.3f} | {aa:.2f} + {ab:.3f} | {ab / bb:.2f} |")
    for paper in ("000", "002"):
        for nl in ([None] + list(limits or [])):
            rows = estimate(fits, paper, nl)
            tb, ta = sum(r[5] for r in rows), sum(r[6] for r in rows)
            print(f"\nfull {paper}" + ("" if nl is None else f", {nl} Lyapunov-checked values") +
                  f": before {tb:.0f} s, after {ta:.0f} s CPU (after/before {ta / tb:.2f}; response runs not included)")
            print("| runs | count | periods | CPU per run before [s] | after [s] | total before [s] | after [s] |")
            print("|---|---|---|---|---|---|---|")
            for r in rows:
                print(f"| {r[0]} | {r[1]} | {r[2]} | {r[3]:.1f} | {r[4]:.1f} | {r[5]:.0f} | {r[6]:.0f} |")


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


def compare(fa, fb):
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
    e.add_argument("kinds_json")
    e.add_argument("--limits", default="", help="also estimate with these numbers of Lyapunov-checked values")
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
    k = sub.add_parser("_kind")
    k.add_argument("name")
    k.add_argument("periods", type=int)
    y = sub.add_parser("_lyap")
    for name, typ in (("paper", str), ("value", float), ("transient", int), ("lengths", str), ("rtol", float)):
        y.add_argument(name, type=typ)
    args = ap.parse_args(argv)
    if args.cmd == "_kind":
        print(json.dumps(run_kind(args.name, args.periods)))
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
        print_estimate(json.load(open(args.kinds_json)), [int(x) for x in args.limits.split(",") if x])
    else:
        return 1 if compare(args.a, args.b) else 0
    return 0


if __name__ == "__main__":
    sys.exit(main())
