"""Paper 000 4UPS-UPU with the spherical clearance at S2 (c = 0.5 mm, mu = 0.1) against the ideal run.

    python examples/four_ups_upu_clearance.py [--out DIR] [--t-end 4] [--rtol 1e-6] [--integrator RK45]
                                              [--quick] [--set S2.mu=0.05 ...]

Writes DIR/four_ups_upu_clearance.png: platform displacement, velocity and acceleration with and
without clearance, the S2 contact and friction forces and the ball-centre position in the socket frame; prints impacts, peak force and CPU per simulated second.
"""
from __future__ import annotations

import argparse
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from pinclear.model.kinematics import frame_motion  # noqa: E402
from pinclear.mechanisms import clearance_scenes as scenes  # noqa: E402
from pinclear.io.sidecar import parse_assignments  # noqa: E402


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default=".")
    ap.add_argument("--t-end", type=float, default=None, help="simulated time, s (default 4 = two periods)")
    ap.add_argument("--rtol", type=float, default=1e-6)
    ap.add_argument("--integrator", default="RK45")
    ap.add_argument("--max-cpu", type=float, default=None, help="stop the clearance run after this many CPU s")
    ap.add_argument("--quick", action="store_true", help="smoke run: 0.05 s simulated")
    ap.add_argument("--set", action="append", default=[], metavar="S2.KEY=VALUE", help="override a clearance key")
    a = ap.parse_args(argv)
    Path(a.out).mkdir(parents=True, exist_ok=True)
    overrides = parse_assignments(a.set, "--set")
    t_end = a.t_end or (0.05 if a.quick else None)          # None: the scene's own duration
    res = scenes.run("four_ups_upu_S2", t_end=t_end, rtol=a.rtol, integrator=a.integrator, overrides=overrides,
                     max_cpu=a.max_cpu)
    print(scenes.summary(res))
    tr, tri, mech = res["clearance"], res["ideal"], res["mech"]
    p = frame_motion(mech.model, [mech.platform_frame], tr.q).p[:, 0]
    pi = frame_motion(res["mech_ideal"].model, [res["mech_ideal"].platform_frame], tri.q).p[:, 0]
    fig, ax = plt.subplots(3, 2, figsize=(11, 9))
    for k, lab in enumerate("XYZ"):
        ax[0, 0].plot(tri.t, pi[:, k] * 1e3, "k--", lw=0.8)
        ax[0, 0].plot(tr.t, p[:, k] * 1e3, label=lab)
        vi, v = np.gradient(pi[:, k], tri.t), np.gradient(p[:, k], tr.t)
        ax[1, 0].plot(tri.t, vi, "k--", lw=0.8)
        ax[1, 0].plot(tr.t, v, label=lab)
        ax[2, 0].plot(tr.t, np.gradient(v, tr.t), label=lab, lw=0.6)
        ax[2, 0].plot(tri.t, np.gradient(vi, tri.t), "k--", lw=0.8)
    ax[0, 0].set_ylabel("platform position, mm")
    ax[1, 0].set_ylabel("velocity, m/s")
    ax[2, 0].set_ylabel("acceleration, m/s^2")
    ax[2, 0].set_xlabel("t, s")
    ax[0, 0].legend(title="dashed: ideal")
    ax[0, 1].plot(tr.t, tr.outputs["S2.fn"])
    ax[0, 1].set_ylabel("S2 normal force, N")
    ax[1, 1].plot(tr.t, np.linalg.norm(tr.outputs["S2.friction_force"], axis=1))
    ax[1, 1].set_ylabel("S2 friction force, N")
    e = tr.outputs["S2.eccentricity"] * 1e3
    for k, lab in enumerate("xyz"):
        ax[2, 1].plot(tr.t, e[:, k], lw=0.7, label=lab)
    ax[2, 1].axhline(mech.forces[-1].c * 1e3, color="k", ls=":", lw=0.8)
    ax[2, 1].axhline(-mech.forces[-1].c * 1e3, color="k", ls=":", lw=0.8)
    ax[2, 1].set_ylabel("ball centre in socket frame, mm")
    ax[2, 1].set_xlabel("t, s")
    ax[2, 1].legend(title="dotted: +-c")
    fig.tight_layout()
    out = Path(a.out) / "four_ups_upu_clearance.png"
    fig.savefig(out, dpi=110)
    print(f"wrote {out}")
    return 0 if tr.status == "success" else 1


if __name__ == "__main__":
    raise SystemExit(main())
