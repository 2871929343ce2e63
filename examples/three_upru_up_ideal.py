"""Paper 003 3-UPRU+UP polishing robot with ideal joints: one turn of the circle, drive forces.

    python examples/three_upru_up_ideal.py [--out DIR] [--rtol 1e-8] [--t-end 25.13] [--quick]

``--quick``: a smoke run (1.0 s simulated). DIR is created if missing.

Law (paper 003, sec. 4): the platform centre runs a circle of r = 0.2 m at 0.05 m/s
(centre and height reconstructed, see the sidecar's parameter table); the UP branch fixes the
orientation. Writes DIR/three_upru_up_ideal.png (platform position and tilt, slide in the UP
guide, the three drive forces) and prints the closure residual, tracking error and CPU time.
"""
from __future__ import annotations

import argparse
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pinocchio as pin  # noqa: E402

import pinclear  # noqa: E402
from pinclear.mechanisms import three_upru_up as mod  # noqa: E402



def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default=".", help="output directory (default: current)")
    ap.add_argument("--rtol", type=float, default=1e-8)
    ap.add_argument("--t-end", type=float, default=mod.PERIOD, help="simulated time, s (one turn = 25.13 s)")
    ap.add_argument("--quick", action="store_true", help="smoke run: 1.0 s simulated")
    args = ap.parse_args(argv)
    Path(args.out).mkdir(parents=True, exist_ok=True)     # a new folder is created, before the run
    if args.quick:
        args.t_end = min(args.t_end, 1.0)

    mech = pinclear.load("three_upru_up")
    tr = pinclear.simulate(mech, args.t_end, rtol=args.rtol, dt_out=0.05)
    cpu = tr.stats["cpu_s"]      # the run's CPU, kernel compilation excluded (stats["compile_s"])
    te = tr.tracking_error()
    print(f"status {tr.status}; max closure residual {np.max(tr.residual):.3e}; platform tracking error "
          f"{te['platform_position']:.3e} m / {te['platform_rotation']:.3e} rad; "
          f"CPU {cpu:.2f} s for {args.t_end:g} s simulated ({cpu / args.t_end:.3f} s per s)")

    data = mech.model.createData()
    pos, tilt = [], []
    for q in tr.q:
        pin.framesForwardKinematics(mech.model, data, q)
        M = data.oMf[mech.platform_frame]
        pos.append(M.translation.copy())
        tilt.append(np.degrees(np.arccos(np.clip(M.rotation[2, 2], -1, 1))))
    pos = np.array(pos)
    fig, ax = plt.subplots(4, 1, figsize=(7, 10), sharex=True)
    for k, lab in enumerate("XY"):
        ax[0].plot(tr.t, pos[:, k], label=lab)
    ax[0].plot(tr.t, pos[:, 2] - mod.Z0, label="Z - Z0")
    ax[0].set_ylabel("platform centre (m)")
    ax[0].legend()
    ax[1].plot(tr.t, tilt)
    ax[1].set_ylabel("tilt of the UP axis (deg)")
    ax[2].plot(tr.t, np.linalg.norm(pos, axis=1) * 1e3)
    ax[2].set_ylabel("slide |S0 M0| (mm)")
    for i in mod.LIMBS:
        ax[3].plot(tr.t, tr.lam[f"drive{i}"], label=f"limb {i}")
    ax[3].set_ylabel("drive force (N)")
    ax[3].set_xlabel("t (s)")
    ax[3].legend()
    fig.suptitle("3-UPRU+UP (paper 003), ideal joints, gravity -z")
    fig.tight_layout()
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    fig.savefig(out / "three_upru_up_ideal.png", dpi=120)
    print(f"wrote {out / 'three_upru_up_ideal.png'}")
    return 0 if tr.status == "success" else 1


if __name__ == "__main__":
    raise SystemExit(main())
