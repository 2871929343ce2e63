"""Paper 000 (4UPS-UPU, spherical clearance at S2): bifurcation diagrams against the friction
coefficient and against the clearance size, for the platform and for the clearance joint, with
phase portraits and Poincaré maps at the paper's chosen values.

    python examples/analysis_four_ups_upu.py mu        [--values 0.01:0.20:20] [--cycles 100]
    python examples/analysis_four_ups_upu.py clearance [--values 0.05e-3:0.9e-3:18]
    python examples/analysis_four_ups_upu.py mu --quick          # 3 values, 10 cycles

Paper settings (sec. 4): platform Y = 0.05 sin(pi t), Z = 0.05 cos(pi t), so one period is
2 s; friction study at c = 0.5 mm (the size of its ADAMS check), mu 0.01..0.20, portraits at
mu = 0.01, 0.05, 0.10; clearance study at mu = 0.1, c in (0, 0.9] mm, portraits at 0.30, 0.42
and 0.67 mm. Ordinates: platform velocity along world x, y, z ("platform.x" ... , the paper's
three axis directions; X is normal to the fixed platform) and the relative velocity of ball
and socket centres, the rate of the eccentricity in the socket frame ("S2.eccentricity[k]").
The paper's cycle count is not given; 100 as in paper 002. A full sweep is long (every run
simulates transient + cycles periods of 2 s): --max-cpu bounds each run, --workers spreads them.

Needs the clearance entry S2 in urdf/four_ups_upu.yaml (bundled); the script says so if it is
missing. Writes PNG figures and bifurcation_<study>.npz to --out and prints the motion per
value (period-k / quasi-periodic / chaotic, with the 0-1 test K).
"""
import argparse
import sys
from pathlib import Path

import numpy as np
import yaml

from pinclear import analysis as an

ROOT = Path(__file__).resolve().parents[1]
SIDECAR = ROOT / "urdf" / "four_ups_upu.yaml"
PERIOD = 2.0                       # s: Y = 0.05 sin(pi t), Z = 0.05 cos(pi t)
PLATFORM = ["platform.x", "platform.y", "platform.z"]
CLEARANCE = ["S2.eccentricity[0]", "S2.eccentricity[1]", "S2.eccentricity[2]"]


def parse_values(text):
    """'a:b:n' (n values from a to b) or a comma-separated list."""
    if ":" in text:
        a, b, n = text.split(":")
        return list(np.linspace(float(a), float(b), int(n)))
    return [float(v) for v in text.split(",")]


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("study", choices=["mu", "clearance"])
    ap.add_argument("--values", help="'a:b:n' or a comma list (mu, or clearance in m)")
    ap.add_argument("--cycles", type=int, default=100, help="recorded periods of 2 s")
    ap.add_argument("--transient", type=int, default=10, help="periods dropped before recording")
    ap.add_argument("--quick", action="store_true", help="3 values, 10 cycles, 3 transient: a smoke run")
    ap.add_argument("--workers", type=int, default=None)
    ap.add_argument("--method", default="lagrange")
    ap.add_argument("--integrator", default="RK45")
    ap.add_argument("--rtol", type=float, default=1e-6)
    ap.add_argument("--max-cpu", type=float, default=None, help="CPU seconds per run before it is stopped")
    ap.add_argument("--out", default="analysis_four_ups_upu")
    args = ap.parse_args(argv)

    sidecar = yaml.safe_load(SIDECAR.read_text())
    if "S2" not in {c.get("name") for c in sidecar.get("clearances") or []}:
        print(f"analysis_four_ups_upu: {SIDECAR} has no clearance entry S2; "
              "nothing to analyse", file=sys.stderr)
        return 2

    if args.study == "mu":
        values = parse_values(args.values) if args.values else list(np.linspace(0.01, 0.20, 20))
        parameter, fixed = "S2.mu", {"S2.clearance": 0.5e-3}
        portraits_at, label = (0.01, 0.05, 0.10), "friction coefficient mu"
    else:
        values = parse_values(args.values) if args.values else list(np.linspace(0.05e-3, 0.9e-3, 18))
        parameter, fixed = "S2.clearance", {"S2.mu": 0.1}
        portraits_at, label = (0.30e-3, 0.42e-3, 0.67e-3), "clearance c [m]"
    if args.quick:
        values, args.cycles, args.transient = [values[0], values[len(values) // 2], values[-1]], 10, 3
    else:
        values = sorted(set(values) | set(portraits_at))

    sim = dict(method=args.method, integrator=args.integrator, rtol=args.rtol)
    if args.max_cpu:
        sim["max_cpu"] = args.max_cpu
    signals = PLATFORM + CLEARANCE
    res = an.bifurcation(SIDECAR, parameter, values, period=PERIOD, signal=signals, cycles=args.cycles,
                         transient=args.transient, per_period=40, keep_portrait=True, sim_options=sim,
                         load_options=dict(clearances=["S2"], overrides=fixed),
                         max_workers=args.workers, progress=True)

    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    for sig in signals:
        tag = sig.replace("[", "").replace("]", "").replace(".", "_")
        an.plot_bifurcation(res, signal=sig, label=label, path=out / f"bifurcation_{args.study}_{tag}.png")
        for r in res.runs:
            if r.value in portraits_at and r.ok:
                t, x, xd = r.portraits[sig]
                an.plot_phase_portrait(x, xd, section=r.sections[sig], label=sig,
                                       path=out / f"phase_{args.study}_{r.value:.6g}_{tag}.png")
    res.save(out / f"bifurcation_{args.study}.npz")
    print(f"{'value':>12} {'status':8} " + " ".join(f"{s:>20}" for s in signals))
    for r in res.runs:
        kinds = []
        for s in signals:
            c = r.classifications[s]
            kinds.append(c.kind + (f" K={c.K:.2f}" if c.K is not None else ""))
        print(f"{r.value:12.6g} {r.status:8} " + " ".join(f"{k:>20}" for k in kinds)
              + ("" if r.ok else f"  ({r.message})"))
    print(f"figures and bifurcation_{args.study}.npz in {out}/")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
