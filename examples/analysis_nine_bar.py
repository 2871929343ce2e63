"""Paper 002 (nine-bar, clearances at A and B): bifurcation diagrams against the clearance size
and against the driving speed, with phase portraits and Poincaré maps at chosen values.

    python examples/analysis_nine_bar.py clearance [--values 0.01e-3:1e-3:25] [--cycles 100]
    python examples/analysis_nine_bar.py speed     [--values 3.1416:9.4248:21]
    python examples/analysis_nine_bar.py clearance --quick          # 3 values, 10 cycles

Paper settings (sec. 4): friction coefficient 0.3 at both joints; clearance study at
w1 = -w4 = 2 pi rad/s, sizes 0.01-1 mm (portraits at 0.01 and 0.8 mm); speed study at 0.1 mm,
w = pi..3 pi (portraits at 2 pi and 3 pi); 100 cycles. The ordinate is the rate of the
eccentricity (journal centre relative to the bearing centre, bearing axes): the relative
velocity the paper plots. Each run simulates transient + cycles crank periods; with the paper's
100 cycles a full sweep is long: --max-cpu bounds each run, --workers spreads them over cores.

Needs the clearance entries A and B in urdf/nine_bar.yaml (bundled); the script says so if
they are missing. Writes PNG figures and bifurcation_<study>.npz to --out, prints a table of
the motion per value and joint (period-k / quasi-periodic / chaotic, with the 0-1 test K;
"unresolved" when no period shows and fewer than 40 cycles were recorded).
"""
import argparse
import math
import sys
from pathlib import Path

import numpy as np
import yaml

from pinclear import analysis as an
from pinclear.analysis.classify import classify_state

ROOT = Path(__file__).resolve().parents[1]
SIDECAR = ROOT / "urdf" / "nine_bar.yaml"
JOINTS = ("A", "B")
SIGNALS = ["A.eccentricity[0]", "A.eccentricity[1]", "B.eccentricity[0]", "B.eccentricity[1]"]
SPEED = {"drives[crank1_drive].law.coeffs[1]": 1.0, "drives[crank4_drive].law.coeffs[1]": -1.0}


def crank_period(w):
    """The mechanism repeats after one crank turn: T = 2 pi / w."""
    return 2 * math.pi / abs(w)


def parse_values(text):
    """'a:b:n' (n values from a to b) or a comma-separated list."""
    if ":" in text:
        a, b, n = text.split(":")
        return list(np.linspace(float(a), float(b), int(n)))
    return [float(v) for v in text.split(",")]


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("study", choices=["clearance", "speed"])
    ap.add_argument("--values", help="'a:b:n' or a comma list (m for clearance, rad/s for speed)")
    ap.add_argument("--cycles", type=int, default=100, help="recorded crank periods (paper: 100)")
    ap.add_argument("--transient", type=int, default=20, help="periods dropped before recording")
    ap.add_argument("--mu", type=float, default=0.3, help="friction coefficient at A and B (paper: 0.3)")
    ap.add_argument("--quick", action="store_true", help="3 values, 10 cycles, 5 transient: a smoke run")
    ap.add_argument("--workers", type=int, default=None)
    ap.add_argument("--method", default="lagrange")
    ap.add_argument("--integrator", default="RK45")
    ap.add_argument("--rtol", type=float, default=1e-6)
    ap.add_argument("--max-cpu", type=float, default=None, help="CPU seconds per run before it is stopped")
    ap.add_argument("--out", default="analysis_nine_bar")
    args = ap.parse_args(argv)

    sidecar = yaml.safe_load(SIDECAR.read_text())
    have = {c.get("name") for c in sidecar.get("clearances") or []}
    missing = [j for j in JOINTS if j not in have]
    if missing:
        print(f"analysis_nine_bar: {SIDECAR} has no clearance entries {missing} "
              "nothing to analyse", file=sys.stderr)
        return 2

    fixed = {f"{j}.mu": args.mu for j in JOINTS}
    if args.study == "clearance":
        values = parse_values(args.values) if args.values else list(np.linspace(0.01e-3, 1e-3, 25))
        parameter = {f"{j}.clearance": 1.0 for j in JOINTS}
        period, portraits_at, label = crank_period(2 * math.pi), (0.01e-3, 0.8e-3), "clearance c [m]"
    else:
        values = parse_values(args.values) if args.values else list(np.linspace(math.pi, 3 * math.pi, 21))
        parameter = SPEED
        fixed.update({f"{j}.clearance": 0.1e-3 for j in JOINTS})
        period, portraits_at, label = crank_period, (2 * math.pi, 3 * math.pi), "driving speed w [rad/s]"
    if args.quick:
        values, args.cycles, args.transient = [values[0], values[len(values) // 2], values[-1]], 10, 5
    # the portrait values are simulated with the sweep (added if absent)
    values = sorted(set(values) | set(portraits_at)) if not args.quick else values

    sim = dict(method=args.method, integrator=args.integrator, rtol=args.rtol)
    if args.max_cpu:
        sim["max_cpu"] = args.max_cpu
    res = an.bifurcation(SIDECAR, parameter, values, period=period, signal=SIGNALS, cycles=args.cycles,
                         transient=args.transient, per_period=40, keep_portrait=True, sim_options=sim,
                         load_options=dict(clearances=list(JOINTS), overrides=fixed),
                         max_workers=args.workers, progress=True)

    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    for sig in SIGNALS:
        tag = sig.replace("[", "").replace("]", "").replace(".", "_")
        an.plot_bifurcation(res, signal=sig, label=label, path=out / f"bifurcation_{args.study}_{tag}.png")
        for r in res.runs:
            if r.value in portraits_at and r.ok:
                t, x, xd = r.portraits[sig]
                an.plot_phase_portrait(x, xd, section=r.sections[sig], label=sig,
                                       path=out / f"phase_{args.study}_{r.value:.6g}_{tag}.png")
    res.save(out / f"bifurcation_{args.study}.npz")
    # one classification per joint from both eccentricity components, the "same point" tolerance
    # derived from the run's rtol and steps per period (classify.integration_rtol)
    periods = args.transient + args.cycles
    print(f"{'value':>12} {'status':8} " + " ".join(f"{'joint ' + j:>40}" for j in JOINTS))
    for r in res.runs:
        kinds = []
        for j in JOINTS:
            secs = [r.sections.get(s) for s in SIGNALS if s.startswith(j + ".")]
            if not r.stats.get("steps"):
                kinds.append("no run")
                continue
            c = classify_state(secs, sim_rtol=args.rtol, steps_per_period=r.stats["steps"] / periods)
            kinds.append(c.kind + (f" K={c.K:.2f}" if c.K is not None else ""))
        print(f"{r.value:12.6g} {r.status:8} " + " ".join(f"{k:>40}" for k in kinds)
              + ("" if r.ok else f"  ({r.message})"))
    print(f"figures and bifurcation_{args.study}.npz in {out}/")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
