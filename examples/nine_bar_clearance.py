"""Paper 002 nine-bar with revolute clearances at A, B or both (0.5 mm) against the ideal run.

    python examples/nine_bar_clearance.py [--joints A|B|AB] [--out DIR] [--t-end 1] [--rtol 1e-6]
                                          [--integrator RK45] [--quick] [--set A.mu=0.3 ...]

Writes DIR/nine_bar_clearance_<joints>.png: slider 9 displacement, velocity and acceleration with
and without clearance (paper 002 Figs. 5-7), the impact force (Fig. 8) and the journal-centre
trajectory in each bearing (Fig. 9); prints impacts, peak force and CPU per simulated second.
"""
from __future__ import annotations

import argparse
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from pinclear.mechanisms import clearance_scenes as scenes  # noqa: E402
from pinclear.io.sidecar import parse_assignments  # noqa: E402

SLIDER_JOINT = "guide"          # slider 9 in its fixed guide (urdf/nine_bar.urdf)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--joints", choices=["A", "B", "AB"], default="AB")
    ap.add_argument("--out", default=".")
    ap.add_argument("--t-end", type=float, default=None)
    ap.add_argument("--rtol", type=float, default=1e-6)
    ap.add_argument("--integrator", default="RK45")
    ap.add_argument("--max-cpu", type=float, default=None, help="stop the clearance run after this many CPU s")
    ap.add_argument("--quick", action="store_true", help="smoke run: 0.05 s simulated")
    ap.add_argument("--set", action="append", default=[], metavar="A.KEY=VALUE")
    a = ap.parse_args(argv)
    Path(a.out).mkdir(parents=True, exist_ok=True)
    overrides = parse_assignments(a.set, "--set")
    t_end = a.t_end or (0.05 if a.quick else None)          # None: the scene's own duration
    res = scenes.run(f"nine_bar_{a.joints}", t_end=t_end, rtol=a.rtol, integrator=a.integrator, overrides=overrides,
                     max_cpu=a.max_cpu)
    print(scenes.summary(res))
    tr, tri, mech = res["clearance"], res["ideal"], res["mech"]
    j = mech.model.joints[mech.model.getJointId(SLIDER_JOINT)]
    fig, ax = plt.subplots(3, 2, figsize=(11, 9))
    for row, (arr, arri, lab) in enumerate([(tr.q[:, j.idx_q], tri.q[:, j.idx_q], "slider 9 position, m"),
                                            (tr.v[:, j.idx_v], tri.v[:, j.idx_v], "velocity, m/s"),
                                            (tr.a[:, j.idx_v], tri.a[:, j.idx_v], "acceleration, m/s^2")]):
        ax[row, 0].plot(tr.t, arr, lw=0.7, label=f"clearance {a.joints}")
        ax[row, 0].plot(tri.t, arri, "k--", lw=0.8, label="ideal")
        ax[row, 0].set_ylabel(lab)
    ax[0, 0].legend()
    ax[2, 0].set_xlabel("t, s")
    names = list(a.joints)
    for n in names:
        ax[0, 1].plot(tr.t, tr.outputs[f"{n}.fn"], lw=0.7, label=n)
        e = tr.outputs[f"{n}.eccentricity"] * 1e3
        ax[1 + (n == "B" and len(names) == 2), 1].plot(e[:, 0], e[:, 1], lw=0.6, label=n)
    ax[0, 1].set_ylabel("impact force, N")
    ax[0, 1].legend()
    th = np.linspace(0, 2 * np.pi, 200)
    for k, n in enumerate(names):
        axk = ax[1 + k, 1]
        c = next(f for f in mech.forces if f.name == n).c * 1e3
        axk.plot(c * np.cos(th), c * np.sin(th), "k:", lw=0.8)
        axk.set_aspect("equal")
        axk.set_title(f"journal centre in bearing {n}, mm", fontsize=9)
    if len(names) == 1:
        ax[2, 1].axis("off")
    fig.tight_layout()
    out = Path(a.out) / f"nine_bar_clearance_{a.joints}.png"
    fig.savefig(out, dpi=110)
    print(f"wrote {out}")
    return 0 if tr.status == "success" else 1


if __name__ == "__main__":
    raise SystemExit(main())
