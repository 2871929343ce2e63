"""Paper 004 4-UPS/UPR motion simulator, ideal joints: forward dynamics under the drive laws.

    python examples/four_ups_upr_ideal.py [--law high|low] [--limbs on|off] [--t-end T] [--out DIR] [--quick]

The four UPS prismatic joints follow the analytic IK of the coupled motion (alpha, beta, dx, dz).
A full period of either law crosses two singular configurations of the Table 1 layout (high law:
t = 1.0891 s and 1.1874 s; low law: 5x later), where the prescribed motion needs unbounded drive
forces; the default window (1.0 s high, 5.0 s low) stops before them. Asking for more shows the
core's rank-loss report at the crossing. Writes DIR/four_ups_upr_ideal_<law>.png (platform
coordinates, drive forces, condition number of the actuation map); DIR is created if missing.
``--quick``: a smoke run (0.2 s simulated).
"""
from __future__ import annotations

import argparse
import warnings
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pinocchio as pin  # noqa: E402

import pinclear  # noqa: E402
from pinclear.dynamics import screw  # noqa: E402
from pinclear.mechanisms import four_ups_upr as mod  # noqa: E402
from pinclear.core.models import model_path  # noqa: E402


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--law", default="high", choices=["low", "high"])
    ap.add_argument("--limbs", default="on", choices=["on", "off"])
    ap.add_argument("--t-end", type=float, default=None, help="default 1.0 s (high) / 5.0 s (low)")
    ap.add_argument("--rtol", type=float, default=1e-8)
    ap.add_argument("--out", default=".")
    ap.add_argument("--quick", action="store_true", help="smoke run: 0.2 s simulated")
    args = ap.parse_args(argv)
    Path(args.out).mkdir(parents=True, exist_ok=True)     # a new folder is created, before the run
    t_end = args.t_end or (0.2 if args.quick else 1.0 if args.law == "high" else 5.0)

    mech = mod.load(model_path("four_ups_upr"), law=args.law, limbs=args.limbs == "on")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        tr = pinclear.simulate(mech, t_end, rtol=args.rtol, dt_out=t_end / 400)
    cpu = tr.stats["cpu_s"]      # the run's CPU, kernel compilation excluded (stats["compile_s"])
    s = tr.summary()
    te = s.get("tracking_error", {})
    print(f"{mech}: status {tr.status} ({tr.message}); mobility {s.get('mobility')}; max closure residual "
          f"{s['max_closure_residual']:.2e}; tracking {te.get('platform_position', float('nan')):.2e} m / "
          f"{te.get('platform_rotation', float('nan')):.2e} rad; CPU {cpu:.2f} s ({cpu / max(tr.t[-1], 1e-9):.2f} s/s)")
    mon = screw.monitor(mech, tr, threshold=1e3)
    print(f"condition number of the actuation map along the run: max {mon['cond'].max():.3g}; "
          f"intervals above 1e3: {mon['intervals']}")

    data = mech.model.createData()
    coords = []
    for q in tr.q:
        pin.framesForwardKinematics(mech.model, data, q)
        coords.append(mod.pose_to_coordinates(data.oMf[mech.platform_frame]))
    coords = np.array(coords)
    fig, ax = plt.subplots(3, 1, figsize=(8, 9), sharex=True)
    for k, lab in enumerate(["alpha [rad]", "beta [rad]", "dx [m]", "dz [m]"]):
        ax[0].plot(tr.t, coords[:, k], label=lab)
    ax[0].legend(fontsize=8)
    ax[0].set_title(f"4-UPS/UPR, {args.law} law, limbs {args.limbs}")
    for name, f in tr.drive_forces().items():
        ax[1].plot(tr.t, f, label=name)
    ax[1].set_ylabel("drive force [N]")
    ax[1].legend(fontsize=8)
    ax[2].semilogy(mon["t"], mon["cond"])
    ax[2].set_ylabel("cond(G_p^q)")
    ax[2].set_xlabel("t [s]")
    fig.tight_layout()
    out = Path(args.out) / f"four_ups_upr_ideal_{args.law}.png"
    fig.savefig(out, dpi=100)
    print(f"wrote {out}")
    return 0 if tr.status == "success" else 1


if __name__ == "__main__":
    raise SystemExit(main())
