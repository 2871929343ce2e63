"""The worn socket's contact models on paper 000's S2 (4UPS-UPU, c = 0.5 mm, R = 20 mm), worn
as the committed study left it (docs/study/paper000/profile.csv: 1e5 periods, 36 x 72 nodes, an
11 um pocket), 2 s of RK45 (rtol 1e-6, the study's) from the wear life's settled start and from
the centred start (a landing in the pocket), against the new joint, in one process:

    PYTHONPATH=$PWD python benchmarks/bench_worn_foundation.py [T_END]

Prints per run: status, CPU, steps, right-hand sides, CPU per right-hand side, both as ratios to
the new joint's run from the same start, and the largest turn of the contact normal between two
1 ms samples. Results: benchmarks/worn_contact.md.
"""
import sys
import time
from pathlib import Path

import numpy as np

from pinclear import load
from pinclear.analysis.wear_life import WearSettings, read_profile, settled_start
from pinclear.core.models import model_path
from pinclear.dynamics.simulate import simulate
from pinclear.studies import wear_paper000 as study

PROFILE = Path(__file__).parents[1] / "docs" / "study" / "paper000" / "profile.csv"


def _mech(contact):
    return load(model_path("four_ups_upu"), clearances=["S2"],
                overrides={"S2.mu": study.MU, "S2.wear": {**study.WEAR_S2, "nodes": 36, "contact": contact}})


def _run(contact, depth, start, t_end):
    mech = _mech(contact)
    j = mech.forces[-1]
    worn = mech.replace(forces=list(mech.forces[:-1]) + [j.with_depth(depth)])
    kw = {} if start is None else {"q0": start[0], "v0": start[1]}
    t0 = time.process_time()
    tr = simulate(worn, t_end, t_eval=np.arange(0.0, t_end + 1e-12, 1e-3), integrator="RK45",
                  min_mean_step=1e-6, max_cpu=300.0, **kw)
    cpu = time.process_time() - t0
    f = tr.outputs["S2.normal_force"]
    fn = np.linalg.norm(f, axis=1)
    n = f / np.maximum(fn, 1e-300)[:, None]
    on = (fn[1:] > 0) & (fn[:-1] > 0)
    turn = np.degrees(np.arccos(np.clip(np.sum(n[1:] * n[:-1], 1), -1, 1)))[on]
    return {"status": tr.status, "t": float(tr.t[-1]), "cpu": cpu, "steps": tr.stats.get("steps"),
            "rhs": tr.stats.get("rhs_evals"), "turn": float(turn.max()) if len(turn) else 0.0}


def main(t_end=2.0):
    depth = read_profile(PROFILE)["S2"]
    ws = WearSettings(cycles=1e5, period=study.T, updates=16, block_periods=1, transient_periods=2, rtol=1e-6,
                      dt_out=1e-3)
    q, v, _ = settled_start(_mech("foundation"), ws, None)
    print("| start | case | status (reached t [s]) | CPU [s] | x new | steps | right-hand sides | CPU per rhs [us] "
          "| x new | largest normal turn per 1 ms [deg] |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    for label, start in (("settled", (q, v)), ("centred", None)):
        base = None
        for case, contact, d in (("new joint", "foundation", 0.0 * depth), ("worn, foundation", "foundation", depth),
                                 ("worn, least distance", "least_distance", depth)):
            r = _run(contact, d, start, t_end)
            per = r["cpu"] / max(r["rhs"], 1)
            base = base or (r["cpu"], per)
            print(f"| {label} | {case} | {r['status']} ({r['t']:.3f}) | {r['cpu']:.2f} | {r['cpu'] / base[0]:.2f} | "
                  f"{r['steps']} | {r['rhs']} | {1e6 * per:.1f} | {per / base[1]:.2f} | {r['turn']:.2f} |", flush=True)


if __name__ == "__main__":
    main(*(float(a) for a in sys.argv[1:2]))
