"""Time per inverse-dynamics evaluation: screw method (paper 004) vs Pinocchio Lagrangian, same process.

Both start from the same inputs at each instant: the tree configuration q (analytic IK) and the
platform motion (twist and acceleration for the screw method; the drive rates and accelerations
of the same law for the Lagrangian one), and both return the four drive forces.

* screw:     one computeJointJacobians + batched numpy (limb inverses, Lie brackets, Newton-Euler
             wrenches of all bodies, virtual work) + a 6x6 solve;
* lagrange:  closure + drive Jacobian J and its bias (computeJointJacobiansTimeVariation), solve
             J v = rhs and J a = gamma (16x16), pin.rnea, solve J^T lam = tau.

Run: python benchmarks/bench_screw.py [--n 2000] [--law high|low]
"""
from __future__ import annotations

import argparse
import time

import numpy as np
import pinocchio as pin

from pinclear.model import kinematics
from pinclear.dynamics import screw
from pinclear.mechanisms import four_ups_upr as m
from pinclear.core.models import model_path


def _lagrange_eval(mech, ws, t, q):
    """Drive forces from Pinocchio's RNEA with loop-closure Jacobians and drive multipliers."""
    model, data = mech.model, ws.data
    kinematics.update_positions(mech, ws, q)
    kinematics.constraint_rows(mech, ws, t, q, ws.zero_v)
    v = np.linalg.solve(ws.J, -ws.dphi)              # at v = 0, dphi = Phi_t
    # same q: the placements stay, only the Jacobian's time variation changes with v
    pin.computeJointJacobiansTimeVariation(model, data, q, v)
    kinematics.constraint_rows(mech, ws, t, q, v)
    a = np.linalg.solve(ws.J, ws.gamma)
    tau = pin.rnea(model, data, q, v, a)
    return np.linalg.solve(ws.J.T, tau)[mech.m_closures:]


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=2000, help="evaluations per method")
    ap.add_argument("--law", default="high", choices=["low", "high"])
    args = ap.parse_args(argv)
    mech = m.load(model_path("four_ups_upr"), law=args.law)
    system = screw.screw_system(mech)
    ws = mech.workspace()
    T = m.PERIODS[args.law]
    ts = np.linspace(0.0, 0.8 * T, args.n)          # a well-conditioned stretch of the law
    inputs = []
    for t in ts:
        M, V, A = m.platform_motion(t, args.law)
        inputs.append((t, m.tree_configuration(mech.model, M), V, A))
    # agreement first (the benchmark compares like with like)
    err = 0.0
    for t, q, V, A in inputs[:: max(1, args.n // 50)]:
        a = system.inverse_dynamics(q, V, A)[0][:4]
        b = _lagrange_eval(mech, ws, t, q)
        err = max(err, float(np.abs(a - b).max() / np.abs(b).max()))

    def run(fn):
        best = np.inf
        for _ in range(3):
            c0 = time.perf_counter()
            for item in inputs:
                fn(*item)
            best = min(best, (time.perf_counter() - c0) / len(inputs))
        return best

    t_screw = run(lambda t, q, V, A: system.inverse_dynamics(q, V, A))
    t_lag = run(lambda t, q, V, A: _lagrange_eval(mech, ws, t, q))
    t_G = run(lambda t, q, V, A: system.influence_coefficients(q))
    t_ik = run(lambda t, q, V, A: m.tree_configuration(mech.model, m.platform_pose(t, args.law)))
    print(f"4-UPS/UPR, law {args.law}, {args.n} instants, max relative difference {err:.1e}")
    print(f"  screw (Newton-Euler + virtual work)   {t_screw * 1e6:8.1f} us / evaluation")
    print(f"  Pinocchio Lagrangian (rnea + J^T lam) {t_lag * 1e6:8.1f} us / evaluation")
    print(f"  ratio screw / Lagrangian              {t_screw / t_lag:8.2f}")
    print(f"  (G and H influence coefficients       {t_G * 1e6:8.1f} us; analytic IK {t_ik * 1e6:.1f} us)")
    return {"screw_us": t_screw * 1e6, "lagrange_us": t_lag * 1e6, "ratio": t_screw / t_lag, "max_rel_diff": err}


if __name__ == "__main__":
    main()
