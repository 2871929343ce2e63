"""Build the planar 3-RRR parallel manipulator of docs/tutorial.md with pinclear.io.builder and write
urdf/rrr3.urdf + urdf/rrr3.yaml (the bundled copies are this script's output).

    python examples/rrr3_build.py [--out DIR] [--quick]

Tree: three limbs (proximal link driven at its base pivot A_i, distal link at the elbow B_i); the
platform hangs from limb 1 at P1; P2 and P3 close the other two loops (cut joints, so they can
take clearances: P2 has a 0.2 mm one, inactive until --clearance P2). --quick: the same (the
build takes a second); prints the mobility and the actuation.
"""
from __future__ import annotations

import argparse
import math

from pinclear.io.builder import Builder, plate, rod, sines

RB, RP, L1, L2 = 0.30, 0.08, 0.20, 0.20          # base and platform radii, link lengths [m]
M_LINK, M_PLATFORM = 0.3, 1.0                     # [kg]
AMP, OMEGA = 0.2, 2 * math.pi                     # drive amplitude [rad] and speed [rad/s]: 1 Hz


def build() -> Builder:
    b = Builder("rrr3", gravity=(0, 0, -9.81), description="planar 3-RRR, platform on limb 1, cut joints P2, P3")
    a = [math.pi / 2 + 2 * math.pi * i / 3 for i in range(3)]     # the limbs' directions
    c1 = (round(RP * math.cos(a[0]), 15), round(RP * math.sin(a[0]), 15))      # P1 on the platform (cos 90 deg = 0)
    b.body("platform", M_PLATFORM, com=(-c1[0], -c1[1], 0), inertia=plate(M_PLATFORM, RP))
    b.platform("platform", xyz=(-c1[0], -c1[1], 0))                # its centre, for the platform figure
    for i in range(3):
        k, u = i + 1, (-math.cos(a[i]), -math.sin(a[i]))         # u: base pivot -> platform point
        h = math.sqrt(L1 ** 2 - ((RB - RP) / 2) ** 2)            # the elbow's offset (elbows left)
        bx, by = RB * math.cos(a[i]) + (RB - RP) / 2 * u[0] - h * u[1], RB * math.sin(a[i]) + (RB - RP) / 2 * u[1] + h * u[0]
        th1 = math.atan2(by - RB * math.sin(a[i]), bx - RB * math.cos(a[i]))
        th2 = math.remainder(math.atan2(RP * math.sin(a[i]) - by, RP * math.cos(a[i]) - bx) - th1, 2 * math.pi)
        b.body(f"prox{k}", M_LINK, com=(L1 / 2, 0, 0), inertia=rod(M_LINK, L1))
        b.body(f"dist{k}", M_LINK, com=(L2 / 2, 0, 0), inertia=rod(M_LINK, L2))
        b.joint(f"A{k}", "revolute", "ground", f"prox{k}", xyz=(RB * math.cos(a[i]), RB * math.sin(a[i]), 0), q=th1)
        b.joint(f"B{k}", "revolute", f"prox{k}", f"dist{k}", xyz=(L1, 0, 0), q=th2)
        b.drive(f"A{k}", sines(th1, AMP, OMEGA, phase=2 * math.pi * i / 3))
        if k == 1:
            b.joint("P1", "revolute", "dist1", "platform", xyz=(L2, 0, 0), q=-(th1 + th2))
        else:
            ck = (RP * math.cos(a[i]) - c1[0], RP * math.sin(a[i]) - c1[1], 0)
            b.closure(f"P{k}", "planar_point", (f"dist{k}", (L2, 0, 0)), ("platform", ck))
    b.clearance("P2", clearance=2e-4, radius=5e-3, length=1e-2, material="steel", normal_law="lankarani_nikravesh",
                ce=0.9, mu=0.05, friction_law={"type": "modified_coulomb", "v0": 1e-4, "v1": 1e-3})
    return b


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default="urdf", help="folder for rrr3.urdf and rrr3.yaml (default: urdf)")
    ap.add_argument("--quick", action="store_true", help="the same (the build is quick)")
    a = ap.parse_args(argv)
    from pinclear.model import kinematics

    mech = build().write(a.out, head="# Written by examples/rrr3_build.py (pinclear.builder); edit that script.\n")
    mob = kinematics.mobility(mech, kinematics.assemble(mech))
    print(f"wrote {a.out}/rrr3.urdf and {a.out}/rrr3.yaml: mobility {mob['mobility']}, {len(mech.drives)} drives, "
          f"closure rows {mob['rows']} (rank {mob['rank']})")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
