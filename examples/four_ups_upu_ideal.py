"""Paper 000 4UPS-UPU platform with ideal joints: one period of the platform law, actuator forces.

    python examples/four_ups_upu_ideal.py [--out DIR] [--rtol 1e-8] [--t-end 2] [--quick]

``--quick``: a smoke run (0.2 s simulated). DIR is created if missing.

Law (paper 000, sec. 4): X = 1.1 m, Y = 0.05 sin(pi t), Z = 0.05 cos(pi t), beta = gamma = 0,
limb lengths from the analytic inverse kinematics. Writes DIR/four_ups_upu_ideal.png
(platform position and rotation, the five prismatic drive forces) and prints the closure
residual, the tracking error and the CPU time.
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
from pinclear.mechanisms import four_ups_upu as mod  # noqa: E402



def platform_samples(mech, tr):
    """Platform position (N, 3) and rotation vector (N, 3) at every sample."""
    data = mech.model.createData()
    pos, rot = [], []
    for q in tr.q:
        pin.framesForwardKinematics(mech.model, data, q)
        M = data.oMf[mech.platform_frame]
        pos.append(M.translation.copy())
        rot.append(pin.log3(M.rotation))
    return np.array(pos), np.array(rot)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default=".", help="output directory (default: current)")
    ap.add_argument("--rtol", type=float, default=1e-8)
    ap.add_argument("--t-end", type=float, default=mod.PERIOD, help="simulated time, s (one period = 2 s)")
    ap.add_argument("--quick", action="store_true", help="smoke run: 0.2 s simulated")
    args = ap.parse_args(argv)
    Path(args.out).mkdir(parents=True, exist_ok=True)     # a new folder is created, before the run
    if args.quick:
        args.t_end = min(args.t_end, 0.2)

    mech = pinclear.load("four_ups_upu")
    tr = pinclear.simulate(mech, args.t_end, rtol=args.rtol, dt_out=0.005)
    cpu = tr.stats["cpu_s"]      # the run's CPU, kernel compilation excluded (stats["compile_s"])
    te = tr.tracking_error()
    print(f"status {tr.status}; max closure residual {np.max(tr.residual):.3e}; platform tracking error "
          f"{te['platform_position']:.3e} m / {te['platform_rotation']:.3e} rad; "
          f"CPU {cpu:.2f} s for {args.t_end:g} s simulated ({cpu / args.t_end:.3f} s per s)")

    pos, rot = platform_samples(mech, tr)
    fig, ax = plt.subplots(3, 1, figsize=(7, 9), sharex=True)
    for k, lab in enumerate("XYZ"):
        ax[0].plot(tr.t, (pos[:, k] - (mod.X0 if k == 0 else 0.0)) * 1e3, label=lab + (" - 1.1 m" if k == 0 else ""))
    ax[0].set_ylabel("platform position (mm)")
    ax[0].legend()
    for k, lab in enumerate(("about X (alpha)", "about Y (gamma)", "about Z (beta)")):
        ax[1].plot(tr.t, rot[:, k], label=lab)
    ax[1].set_ylabel("platform rotation (rad)")
    ax[1].legend()
    for i in mod.LIMBS:
        ax[2].plot(tr.t, tr.lam[f"drive{i}"], label=f"limb {i}" + (" (UPU)" if i == 1 else ""))
    ax[2].set_ylabel("drive force (N)")
    ax[2].set_xlabel("t (s)")
    ax[2].legend(ncol=3)
    fig.suptitle("4UPS-UPU (paper 000), ideal joints, gravity -X")
    fig.tight_layout()
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    fig.savefig(out / "four_ups_upu_ideal.png", dpi=120)
    print(f"wrote {out / 'four_ups_upu_ideal.png'}")
    return 0 if tr.status == "success" else 1


if __name__ == "__main__":
    raise SystemExit(main())
