"""Paper 004's screw-theory inverse dynamics of the 4-UPS/UPR simulator: the three cases of its
sec. 4.2, the printed influence coefficients, the hinge layouts of its Fig. 2.

    python examples/four_ups_upr_inverse_dynamics.py [--out DIR] [--n 2001] [--quick]

Gravity off, as in the paper's example. Prints, per case, the peak drive force over the full
period and over the stretches the condition monitor finds well conditioned, next to the paper's
peaks (85 N, 2080 N, 2560 N); the singular crossings found on the way; G_q^p at the initial
configuration next to the printed one; the rank and lost motion of each layout. Writes
DIR/four_ups_upr_inverse_dynamics.png.
"""
from __future__ import annotations

import argparse
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from pinclear import screw  # noqa: E402
from pinclear.mechanisms import four_ups_upr as mod  # noqa: E402
from pinclear.models import model_path  # noqa: E402

SIDECAR = model_path("four_ups_upr")
PAPER = {"low speed, platform only": 85.0, "high speed, platform only": 2080.0, "high speed, with limbs": 2560.0}
PAPER_G = np.array([[0.8237, 0.8237, -0.8673, -0.8673, 0.0, 0.4628],
                    [-7.7204, 7.7204, -6.5346, 6.5346, 0.9231, 0.0],
                    [0, 0, 0, 0, 1.0, 0],
                    [4.6366, -4.6366, 4.8741, -4.8741, -0.6544, 0.0],
                    [0, 0, 0, 0, 0, 0.38],
                    [0.3066, 0.3066, 0.3229, 0.3229, 0.0, 0.0]])


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default=".")
    ap.add_argument("--n", type=int, default=2001, help="samples per period")
    ap.add_argument("--quick", action="store_true", help="smoke run: 201 samples per period")
    args = ap.parse_args(argv)
    if args.quick:
        args.n = 201
    mech = mod.load(SIDECAR)
    system = screw.screw_system(mech)
    np.set_printoptions(precision=4, suppress=True, linewidth=120)

    G, _ = system.influence_coefficients(mech.q0)
    print("G_q^p at the initial configuration (columns: P1..P4, virtual 1, virtual 2):")
    print(G)
    print("printed in paper 004, sec. 4.1:")
    print(PAPER_G)
    rel = np.abs(G[:, :4] - PAPER_G[:, :4]).max(axis=0) / np.abs(PAPER_G[:, :4]).max(axis=0)
    print(f"actuated columns: max deviation {100 * rel.max():.2f} % of the column norm\n")

    cases = [("low speed, platform only", "low", False), ("high speed, platform only", "high", False),
             ("high speed, with limbs", "high", True)]
    fig, axes = plt.subplots(len(cases), 1, figsize=(8, 9))
    for ax, (label, law, limbs) in zip(axes, cases):
        t = np.linspace(0.0, mod.PERIODS[law], args.n)
        res = screw.inverse_dynamics(mech, law, t, limbs=limbs, gravity=False, system=system)
        s = res.summary()
        well = np.abs(res.tau[res.cond < 20]).max()
        print(f"{label:28s} peak over the period {s['peak_abs_all']:10.1f} N | outside ill-conditioned "
              f"intervals {s['peak_abs_outside_intervals']:8.1f} N | where cond < 20 {well:7.1f} N | "
              f"paper {PAPER[label]:6.0f} N")
        for tc, c in res.crossings:
            print(f"    singular crossing at t = {tc:.6f} s (cond {c:.2e})")
        for i, n in enumerate(res.drive_names):
            ax.plot(t, res.tau[:, i], label=n)
        ok = res.outside_intervals()
        lim = 1.5 * np.abs(res.tau[ok]).max()
        ax.set_ylim(-lim, lim)
        for a, b, _ in res.intervals:
            ax.axvspan(a, b, color="r", alpha=0.15)
        ax.set_title(label, fontsize=9)
        ax.set_ylabel("force [N]")
    axes[0].legend(fontsize=8, ncol=4)
    axes[-1].set_xlabel("t [s]")
    fig.tight_layout()
    out = Path(args.out) / "four_ups_upr_inverse_dynamics.png"
    fig.savefig(out, dpi=100)

    print("\nhinge layouts of Fig. 2 at the initial configuration:")
    for lay in "abcdef":
        m2 = mod.load(SIDECAR, layout=lay)
        sg = screw.singularity(m2, m2.q0)
        print(f"  ({lay}) rank {sg['rank']} cond {sg['cond']:.3g}  lost motion {sg['lost_motion']}")
    print(f"wrote {out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
