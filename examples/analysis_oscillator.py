"""Phase portrait, Poincaré map and bifurcation diagram of a driven linear oscillator, checked
against its transfer function (the model of tests/analysis/test_analysis.py).

    python examples/analysis_oscillator.py [--out DIR] [--workers N] [--quick]

``--quick``: a smoke run (4 frequencies, 2 workers). DIR is created if missing.

The sweep runs over the driving frequency w (the period follows: T = 2 pi / w); every run is
period-1 and its Poincaré point is the steady state (-X sin phi, X w cos phi) with
X = F0 / |k - m w^2 + i c w|, phi = arg(k - m w^2 + i c w). The script prints the largest
deviation from that closed form and writes three PNG figures.
"""
import argparse
from pathlib import Path

import numpy as np

import pinclear
from pinclear import analysis as an

HERE = Path(__file__).resolve().parent
SIDECAR = HERE.parent / "tests" / "data" / "analysis_oscillator.yaml"
M, K, C, F0 = 2.0, 50.0, 8.0, 3.0


def steady(w):
    H = complex(K - M * w * w, C * w)
    return -F0 / abs(H) * np.sin(np.angle(H)), F0 / abs(H) * w * np.cos(np.angle(H))


def period_of(w):
    return 2 * np.pi / w


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default="analysis_out", help="directory for the figures")
    ap.add_argument("--workers", type=int, default=None, help="worker processes (default: all cores)")
    ap.add_argument("--quick", action="store_true", help="smoke run: 4 frequencies, 2 workers")
    args = ap.parse_args(argv)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)

    # one run at w = 4 rad/s: output exactly on the section, 32 samples per period for the portrait
    w = 4.0
    T = period_of(w)
    mech = pinclear.load(SIDECAR)
    te = an.section_times(T, 12, per_period=32)
    traj = pinclear.simulate(mech, te[-1], t_eval=te, integrator="DOP853", rtol=1e-10)
    sec = an.poincare(traj, T, "slide", skip_transient=6)
    x0, v0 = steady(w)
    print(f"w = {w}: Poincaré points {len(sec)}, |x - x_ss| <= {np.max(np.abs(sec.x - x0)):.2e} m, "
          f"|v - v_ss| <= {np.max(np.abs(sec.xdot - v0)):.2e} m/s, {an.classify(sec).kind}")
    an.plot_phase_portrait(traj, "slide", section=sec, t_min=6 * T, path=out / "oscillator_phase.png")
    an.plot_poincare(sec, path=out / "oscillator_poincare.png")

    # bifurcation diagram over the driving frequency (through resonance at sqrt(k/m) = 5 rad/s)
    ws = np.linspace(2.0, 8.0, 4 if args.quick else 13)
    res = an.bifurcation(SIDECAR, "forces[push].law.terms[0].omega", ws, period=period_of, signal="slide",
                         cycles=10, transient=20, sim_options=dict(integrator="DOP853", rtol=1e-10),
                         max_workers=2 if args.quick else args.workers, progress=True)
    worst = 0.0
    for r in res.runs:
        xs, vs = steady(r.value)
        amp = abs(F0 / complex(K - M * r.value**2, C * r.value)) * r.value      # velocity amplitude X w
        worst = max(worst, np.max(np.abs(r.section.xdot - vs)) / amp)
        print(f"  w = {r.value:5.2f}  {r.status:8s} {r.classification.kind:10s} xdot = {r.section.xdot[-1]: .6f} "
              f"(closed form {vs: .6f})")
    print(f"largest deviation of the section velocity from the closed form: {worst:.2e} of X w")
    an.plot_bifurcation(res, path=out / "oscillator_bifurcation.png", label="driving frequency w [rad/s]")
    print(f"figures in {out}/")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
