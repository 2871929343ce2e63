"""Paper 003 3-UPRU+UP with the prismatic clearance of the UP branch (0.1 mm, eq. 3 friction)
against the ideal run.

    python examples/three_upru_up_clearance.py [--out DIR] [--t-end 0.3] [--rtol 1e-6]
                                               [--integrator RK45] [--quick] [--set P_UP.clearance=2e-4 ...]

Writes DIR/three_upru_up_clearance.png: platform position deviation from the ideal run
(paper 003 Figs. 9-10), contact and friction forces (Fig. 11), and the contact mode of Table 1
over time; prints impacts, peak force and CPU per simulated second. Expect minutes of CPU: the
light guide rail rattles on a near-rigid plane contact (E A / l ~ 1.5e10 N/m).
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
from pinclear.contact.prismatic import MODE_NAMES  # noqa: E402


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default=".")
    ap.add_argument("--t-end", type=float, default=None)
    ap.add_argument("--rtol", type=float, default=1e-6)
    ap.add_argument("--integrator", default="RK45")
    ap.add_argument("--max-cpu", type=float, default=None, help="stop the clearance run after this many CPU s")
    ap.add_argument("--quick", action="store_true", help="smoke run: 0.005 s simulated")
    ap.add_argument("--set", action="append", default=[], metavar="P_UP.KEY=VALUE")
    a = ap.parse_args(argv)
    Path(a.out).mkdir(parents=True, exist_ok=True)
    overrides = parse_assignments(a.set, "--set")
    t_end = a.t_end or (0.005 if a.quick else None)          # None: the scene's own duration
    res = scenes.run("three_upru_up_P", t_end=t_end, rtol=a.rtol, integrator=a.integrator, overrides=overrides,
                     max_cpu=a.max_cpu)
    print(scenes.summary(res))
    tr, tri, mech = res["clearance"], res["ideal"], res["mech"]
    p = frame_motion(mech.model, [mech.platform_frame], tr.q).p[:, 0]
    pi = frame_motion(res["mech_ideal"].model, [res["mech_ideal"].platform_frame], tri.q[: len(tr.t)]).p[:, 0]
    modes = tr.outputs["P_UP.mode"].astype(int)
    used = sorted(set(modes))
    print("contact modes seen (paper 003 Table 1):", ", ".join(f"{m} {MODE_NAMES[m]}" for m in used))
    fig, ax = plt.subplots(2, 2, figsize=(11, 7))
    for k, lab in enumerate("XYZ"):
        ax[0, 0].plot(tr.t, (p[:, k] - pi[:, k]) * 1e3, lw=0.7, label=lab)
    ax[0, 0].set_ylabel("platform position - ideal, mm")
    ax[0, 0].legend()
    ax[0, 1].plot(tr.t, tr.outputs["P_UP.fn"], lw=0.7, label="normal")
    ax[0, 1].plot(tr.t, np.linalg.norm(tr.outputs["P_UP.friction_force"], axis=1), lw=0.7, label="friction")
    ax[0, 1].set_ylabel("contact force, N")
    ax[0, 1].legend()
    ax[1, 0].step(tr.t, modes, where="post", lw=0.7)
    ax[1, 0].set_ylabel("contact mode (Table 1; 0 free, 16 other)")
    ax[1, 0].set_xlabel("t, s")
    ax[0, 0].set_xlabel("t, s")
    ax[0, 1].set_xlabel("t, s")
    e = tr.outputs["P_UP.eccentricity"] * 1e3
    ax[1, 1].plot(e[:, 0], e[:, 1], lw=0.6)
    ax[1, 1].set_xlabel("slider centre x in guide, mm")
    ax[1, 1].set_ylabel("y, mm")
    # a square window around the path, equal scales: an aspect-equal panel sized by a path that is
    # long in one direction and short in the other is squashed to a strip
    lim = 1.15 * max(float(np.abs(e[:, :2]).max()), 1e-6)
    ax[1, 1].set_xlim(-lim, lim)
    ax[1, 1].set_ylim(-lim, lim)
    ax[1, 1].set_aspect("equal", adjustable="box")
    ax[1, 1].ticklabel_format(useOffset=False)
    fig.tight_layout()
    out = Path(a.out) / "three_upru_up_clearance.png"
    fig.savefig(out, dpi=110)
    print(f"wrote {out}")
    return 0 if tr.status == "success" else 1


if __name__ == "__main__":
    raise SystemExit(main())
