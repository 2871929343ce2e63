"""Cost of the worn contact (least distance on the worn profile) against the new bearing's
(issue 56 item 1: worn <= 2x unworn), measured in this one process.

    PYTHONPATH=$PWD python benchmarks/bench_worn_contact.py

The test journal (tests/data/wear_journal.yaml: a 1 kg disk spinning at 20 rad/s in a bearing of
c = 0.1 mm under gravity) three ways: the plain clearance (no ``wear:``: the circle kernel), the
worn joint at zero wear, and the worn joint with a conforming pocket of 0.8 c over the bottom
(w = (c + h) cos x - c, h = 0.8 c: the profile a journal wears). Per contact evaluation: the
compiled geometry kernel called through channels.channel_geometry on 2000 journal positions
around the bottom (the Python call's overhead is in both columns). Per run: pinclear.simulate of
T = 0.5 s (DOP853, rtol 1e-10, the same start; the fastest of 3), CPU per run and per right-hand-side
evaluation. The geometry column includes the Python call's overhead (the same in every row).
"""
import math
import time
from pathlib import Path

import numpy as np

import pinclear
from pinclear.contact import channels

JOURNAL = Path(__file__).parents[1] / "tests" / "data" / "wear_journal.yaml"
T = 0.5                                                           # simulated time per run, s


def geometry(joint, pts):
    M1, M2 = np.eye(4), np.eye(4)
    sc, de, n, p1, p2 = np.zeros((4, 3)), np.zeros(1), np.zeros((1, 3)), np.zeros((1, 3)), np.zeros((1, 3))
    code, gpar = joint.geometry_code, joint._geo.gpar
    t0 = time.process_time()
    for e in pts:
        M2[:2, 3] = e
        channels.channel_geometry(code, gpar, M1, M2, sc, de, n, p1, p2)
    return (time.process_time() - t0) / len(pts)


def main():
    plain = pinclear.load(JOURNAL, clearances=["A"], overrides={"A.wear": None})
    mech = pinclear.load(JOURNAL, clearances=["A"])
    joint = mech.forces[-1]
    c, th = joint.c, joint.wear.angles()
    x = (th + 0.5 * math.pi + math.pi) % (2 * math.pi) - math.pi
    h = 0.8 * c
    pocket = np.maximum((c + h) * np.cos(x) - c, 0.0)
    cases = {"plain (no wear key)": plain,
             "worn joint, zero wear": mech,
             "worn joint, 0.8 c pocket": mech.replace(forces=list(mech.forces[:-1]) + [joint.with_depth(pocket)])}
    law = joint.law
    delta = (9.81 / law.K) ** (1.0 / law.n)
    rng = np.random.default_rng(1)
    ang = -0.5 * math.pi + rng.uniform(-0.5, 0.5, 2000)
    rows = []
    for label, m in cases.items():
        j = m.forces[-1]
        depth = getattr(j, "depth", np.zeros(1)).max()
        r = c + depth + rng.uniform(-0.5, 1.0, 2000) * delta
        pts = np.stack([r * np.cos(ang), r * np.sin(ang)], 1)
        geometry(j, pts[:50])                                    # compiled outside the measurement
        g = min(geometry(j, pts) for _ in range(3))
        q0 = np.array([0.0, -(c + depth + delta), 0.0])
        pinclear.simulate(m, 0.002, integrator="DOP853", rtol=1e-10, q0=q0, v0=np.array([0.0, 0.0, 20.0]),
                          assemble=False, dt_out=1e-4)
        run = math.inf
        for _ in range(3):                                        # the fastest of 3: the machine is shared
            t0 = time.process_time()
            tr = pinclear.simulate(m, T, integrator="DOP853", rtol=1e-10, q0=q0, v0=np.array([0.0, 0.0, 20.0]),
                                   assemble=False, dt_out=1e-3)
            run = min(run, time.process_time() - t0)
        nfev = tr.stats["rhs_evals"]
        rows.append((label, g, run, nfev, tr.status))
    base = rows[0]
    print(f"| case | geometry call [us] | x plain | run {T:g} s [s] | x plain | rhs evaluations | run / rhs [us] | status |")
    print("|---|---|---|---|---|---|---|---|")
    for label, g, run, nfev, st in rows:
        per = f"{1e6 * run / nfev:.1f}" if nfev else "-"
        print(f"| {label} | {1e6 * g:.2f} | {g / base[1]:.2f} | {run:.3f} | {run / base[2]:.2f} | {nfev} | {per} | {st} |")


if __name__ == "__main__":
    main()
