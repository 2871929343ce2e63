"""Paper 002 nine-bar with ideal joints: one crank period, slider 9 motion and crank torques.

    python examples/nine_bar_ideal.py [--out DIR] [--rtol 1e-8] [--quick]

``--quick``: a smoke run (0.1 s simulated). DIR is created if missing.

Writes DIR/nine_bar_ideal.png (slider 9 displacement, velocity, acceleration; torques of the
two crank drives) and prints the closure residual, the crank tracking error and the CPU time.
"""
from __future__ import annotations

import argparse
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

import pinclear  # noqa: E402
from pinclear.mechanisms import nine_bar as nb  # noqa: E402



def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default=".", help="output directory (default: current)")
    ap.add_argument("--rtol", type=float, default=1e-8)
    ap.add_argument("--t-end", type=float, default=1.0, help="simulated time, s (one period = 1 s)")
    ap.add_argument("--quick", action="store_true", help="smoke run: 0.1 s simulated")
    args = ap.parse_args(argv)
    Path(args.out).mkdir(parents=True, exist_ok=True)     # a new folder is created, before the run
    if args.quick:
        args.t_end = min(args.t_end, 0.1)

    mech = pinclear.load("nine_bar")
    tr = pinclear.simulate(mech, args.t_end, rtol=args.rtol, dt_out=0.002)
    cpu = tr.stats["cpu_s"]      # the run's CPU, kernel compilation excluded (stats["compile_s"])

    model = mech.model
    idx = {j: model.joints[model.getJointId(j)].idx_q for j in ("O1", "O4", "guide")}
    th1 = nb.OMEGA1 * tr.t + nb.THETA1_0
    th4 = nb.OMEGA4 * tr.t + nb.THETA4_0
    track = max(np.max(np.abs(tr.q[:, idx["O1"]] - th1)), np.max(np.abs(tr.q[:, idx["O4"]] - th4)))
    print(f"status {tr.status}; max closure residual {np.max(tr.residual):.3e}; "
          f"crank tracking error {track:.3e} rad; CPU {cpu:.2f} s for {args.t_end:g} s simulated")

    ig = idx["guide"]
    fig, ax = plt.subplots(4, 1, figsize=(7, 9), sharex=True)
    ax[0].plot(tr.t, tr.q[:, ig] * 1e3)
    ax[0].set_ylabel("x9 (mm)")
    ax[1].plot(tr.t, tr.v[:, ig])
    ax[1].set_ylabel("v9 (m/s)")
    ax[2].plot(tr.t, tr.a[:, ig])
    ax[2].set_ylabel("a9 (m/s$^2$)")
    for name, label in (("crank1_drive", "crank 1"), ("crank4_drive", "crank 4")):
        ax[3].plot(tr.t, tr.lam[name], label=label)
    ax[3].set_ylabel("drive torque (N m)")
    ax[3].set_xlabel("t (s)")
    ax[3].legend()
    fig.suptitle("Nine-bar (paper 002), ideal joints, gravity -y")
    fig.tight_layout()
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    png = out / "nine_bar_ideal.png"
    fig.savefig(png, dpi=110)
    print(f"wrote {png}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
