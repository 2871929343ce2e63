"""A02 at IFToMM's size (issue 40, item 4): N = 40 four-bar loops over 20 s, manifold + DOP853,
CPU and the error of B0 (crank 0's tip) against the parallelogram branch's closed form (a
1-dof pendulum, pinclear.mechanisms.benchmarks.a02_branch_rhs, integrated at rtol 1e-13).

    python benchmarks/bench_a02_scale.py [RTOLS] [REPEAT]        (defaults: 1e-6 and 2)

Prints one JSON line per run: cpu_s (the integration), cpu_total (the whole simulate(): the
integration, the outputs of its 501 samples, set-up), evaluations, steps, samples and B0's largest
error. A 0.05 s run first loads the compiled kernels, so every timed run is warm. To compare with
another commit in the same session, run this file with PYTHONPATH pointing at that commit's tree
(git archive) in turn, alternating; benchmarks/bench_a02_scale.md has the commands and a result."""
import json
import sys
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np
import pinocchio as pin
from scipy.integrate import solve_ivp

import pinclear
from pinclear.mechanisms import benchmarks as B

N, T_END = 40, 20.0


def b0_positions(mech, q):
    """B0 = crank 0's tip (x, y) at each configuration."""
    data = mech.model.createData()
    jid = mech.model.getJointId("crank0_joint")
    tip = np.array([B.A02_L, 0.0, 0.0])
    out = []
    for qk in q:
        pin.forwardKinematics(mech.model, data, qk)
        out.append(data.oMi[jid].act(tip)[:2])
    return np.array(out)


def main(rtols=(1e-6,), repeat=2):
    warnings.simplefilter("ignore")
    folder = Path(tempfile.mkdtemp(prefix="a02_scale_"))
    B.write_a02(N, folder)
    mech = pinclear.load(folder / f"{B.a02_name(N)}.yaml")
    ref = solve_ivp(B.a02_branch_rhs(N), (0.0, T_END), [B.A02_THETA0, B.a02_initial_rate()], method="DOP853",
                    rtol=1e-13, atol=1e-13, dense_output=True)
    pinclear.simulate(mech, 0.05, method="manifold", integrator="DOP853", rtol=rtols[0])   # warm
    for rtol in rtols:
        for _ in range(repeat):
            c0 = time.process_time()
            tr = pinclear.simulate(mech, T_END, method="manifold", integrator="DOP853", rtol=rtol)
            total = time.process_time() - c0
            th = ref.sol(tr.t)[0]
            exact = np.c_[B.A02_L * np.cos(th), B.A02_L * np.sin(th)]
            print(json.dumps({"rtol": rtol, "status": tr.status, "cpu_s": round(tr.stats["cpu_s"], 4),
                              "cpu_total": round(total, 4), "evals": tr.stats["rhs_evals"],
                              "steps": tr.stats["steps"], "samples": len(tr.t),
                              "B0_err": float(np.abs(b0_positions(mech, tr.q) - exact).max())}), flush=True)


if __name__ == "__main__":
    main(tuple(float(x) for x in sys.argv[1].split(",")) if len(sys.argv) > 1 else (1e-6,),
         int(sys.argv[2]) if len(sys.argv) > 2 else 2)
