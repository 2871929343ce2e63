"""The worn planar kernel's own cost: channels.channel_geometry called from a compiled loop (no
Python call per evaluation, unlike bench_worn_contact.py's geometry column, where about 1 us of
call overhead is in every row), on bench_worn_contact.py's cases and positions (2000 near the
bottom, x 50 passes; the fastest of 3), in one process:

    PYTHONPATH=$PWD python benchmarks/bench_worn_kernel.py
"""
import math
import time
from pathlib import Path

import numpy as np

import pinclear
from pinclear.contact import channels
from pinclear.core.jit import njit

JOURNAL = Path(__file__).parents[1] / "tests" / "data" / "wear_journal.yaml"
PASSES = 50


@njit
def _loop(code, gpar, P):
    M1, M2 = np.eye(4), np.eye(4)
    sc, de = np.zeros((4, 3)), np.zeros(1)
    n, p1, p2 = np.zeros((1, 3)), np.zeros((1, 3)), np.zeros((1, 3))
    acc = 0.0
    for _ in range(PASSES):
        for k in range(P.shape[0]):
            M2[0, 3], M2[1, 3] = P[k, 0], P[k, 1]
            channels.channel_geometry(code, gpar, M1, M2, sc, de, n, p1, p2)
            acc += de[0]
    return acc


def _timed(joint, P):
    best = math.inf
    for _ in range(3):
        t0 = time.process_time()
        _loop(joint.geometry_code, joint._geo.gpar, P)
        best = min(best, time.process_time() - t0)
    return best / (PASSES * len(P))


def main():
    plain = pinclear.load(JOURNAL, clearances=["A"], overrides={"A.wear": None}).forces[-1]
    joint = pinclear.load(JOURNAL, clearances=["A"]).forces[-1]
    c, th = joint.c, joint.wear.angles()
    x = (th + 0.5 * math.pi + math.pi) % (2 * math.pi) - math.pi
    pocket = joint.with_depth(np.maximum(1.8 * c * np.cos(x) - c, 0.0))    # bench_worn_contact's 0.8 c pocket
    delta = (9.81 / joint.law.K) ** (1.0 / joint.law.n)
    rng = np.random.default_rng(1)
    ang = -0.5 * math.pi + rng.uniform(-0.5, 0.5, 2000)
    rows = []
    for label, j in (("plain (no wear key)", plain), ("worn joint, zero wear", joint), ("worn joint, 0.8 c pocket", pocket)):
        r = c + getattr(j, "depth", np.zeros(1)).max() + rng.uniform(-0.5, 1.0, 2000) * delta
        P = np.stack([r * np.cos(ang), r * np.sin(ang)], 1)
        _loop(j.geometry_code, j._geo.gpar, P[:10])                       # compiled outside the measurement
        rows.append((label, _timed(j, P)))
    print("| case | kernel call [ns] | x plain |")
    print("|---|---|---|")
    for label, t in rows:
        print(f"| {label} | {1e9 * t:.0f} | {t / rows[0][1]:.2f} |")


if __name__ == "__main__":
    main()
