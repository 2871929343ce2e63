"""Dask scaling of a sweep: 8 points of clr_pendulum+S on a LocalCluster with 1, then 2
single-threaded worker processes (same process, same points), and the results compared.

    python benchmarks/bench_sweep.py [--quick]
"""
from __future__ import annotations

import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from distributed import Client, LocalCluster

import pinclear
from pinclear.dynamics.trajectory import Trajectory

QUICK = "--quick" in sys.argv
VARY = {"S.mu": [0.0, 0.1, 0.2, 0.3], "S.clearance": [1e-4, 2e-4]}
LOAD = {"clearances": ["S"], "overrides": {"S.friction_law": "coulomb", "S.mu": 0.1}}
T_END = 0.02 if QUICK else 0.1


def run(n_workers, out):
    with LocalCluster(n_workers=n_workers, threads_per_worker=1, processes=True, dashboard_address=None,
                      host="127.0.0.1") as cluster, Client(cluster) as client:
        # warm the workers (imports, compiled kernels from the cache) outside the timing
        client.run(lambda: __import__("pinclear").simulate(__import__("pinclear").load("clr_pendulum"), 1e-3))
        t0 = time.perf_counter()
        res = pinclear.sweep("clr_pendulum", VARY, T_END, out, sim_options={"rtol": 1e-6}, load_options=LOAD,
                             executor=client.get_executor(), progress=None)
        return time.perf_counter() - t0, res


if __name__ == "__main__":
    with tempfile.TemporaryDirectory() as tmp:
        w1, r1 = run(1, Path(tmp) / "one")
        w2, r2 = run(2, Path(tmp) / "two")
        same = all(np.array_equal(Trajectory.load(a.file).q, Trajectory.load(b.file).q)
                   for a, b in zip(r1.points, r2.points))
    print(f"sweep of {len(r1.points)} points x {T_END} s: 1 worker {w1:.2f} s wall, 2 workers {w2:.2f} s wall, "
          f"speed-up {w1 / w2:.2f}x; results bit-identical: {same}")
