"""Cost of a wear update against the periods it simulates (issue 44: update <= periods + 10 %).

    PYTHONPATH=$PWD python benchmarks/bench_wear.py [socket]

Runs the iterative scheme (pinclear.analysis.wear_life.wear_run) on the nine-bar with clearance A worn, one
crank period per block (``socket``: the 4UPS-UPU with its spherical S2 worn on 72 x 144 nodes, one
2 s period per block at the paper-000 study's output step of 1e-3 s), and prints per block the CPU of the block's simulation (its samples'
outputs included) and of the update (energy audit, Archard quadrature over the samples, reshape:
a new joint and mechanism), and their ratio, measured in this one process.
"""
import sys

import numpy as np

import pinclear
from pinclear.analysis.wear_life import WearSettings, wear_run

if sys.argv[1:] == ["socket"]:
    mech = pinclear.load("four_ups_upu", clearances=["S2"], overrides={
        "S2.mu": 0.1, "S2.wear": {"k": 1e-5, "hardness": 2e9, "nodes": 72}})
    name, s = "S2", WearSettings(cycles=1e5, period=2.0, updates=6, transient_periods=1, dt_out=1e-3)
else:
    mech = pinclear.load("nine_bar", clearances=["A"], overrides={"A.wear": {"k": 1e-5, "hardness": 2e9}})
    name, s = "A", WearSettings(cycles=1e5, period=1.0, updates=6, transient_periods=1, dt_out=1e-4)
pinclear.simulate(mech, 0.05, dt_out=1e-3)          # kernels compiled outside the measurement
res = wear_run(mech, name, s)
h = res["history"]
sim, upd = np.array(h["cpu_sim"]), np.array(h["cpu_update"])
for k, (a, b) in enumerate(zip(sim, upd)):
    print(f"block {k + 1}: simulate {a:.3f} s, update {b:.4f} s, update / simulate {b / a:.3f}")
print(f"total: update / simulate = {upd.sum() / sim.sum():.3f} (issue 44 asks <= 0.10)")
