"""The squeezer as a researcher would script it with Pinocchio and SciPy, without pinclear's
engine: the baseline of benchmarks/bench_squeezer.py.

    python benchmarks/plain_script.py [--rtol 1e-10] [--method DOP853]

Model: urdf/squeezer.urdf, parameters and the Test Set's published start from
pinclear.mechanisms.squeezer (numbers only). Per evaluation: one ``computeAllTerms`` (mass
matrix, bias forces, joint Jacobians, and the joint accelerations at zero ddq, which are what
``getFrameClassicalAcceleration`` turns into J-dot v), frame Jacobians of the three pins and of
the spring point, then the KKT system ``[[M, J^T], [J, 0]] [a; -lam] = [tau - b; gamma]`` by
``numpy.linalg.solve``. Closure drift: Baumgarte, gamma = -J-dot v - 2 alpha J v - beta^2 Phi,
with alpha = beta = 5 1/s, pinclear's ``lagrange`` defaults (the squeezer sidecar sets none: the
Test Set's problem has no stabilisation). Over the 0.03 s run these gains act on a time scale of
0.2 s, so they change no result at the tolerances measured; they only keep drift bounded.
Integration: ``scipy.integrate.solve_ivp`` (DOP853 or RK45), atol = rtol / 100 as pinclear's.
"""
from __future__ import annotations

import time

import numpy as np
import pinocchio as pin
from scipy.integrate import solve_ivp

from pinclear.mechanisms import squeezer as S
from pinclear.core.models import model_path

ALPHA = BETA = 5.0          # Baumgarte gains [1/s]
LWA = pin.ReferenceFrame.LOCAL_WORLD_ALIGNED


def build():
    """Model, data, frame ids (pin of body 2, pins of bodies 3, 4, 6, spring point D) and q0."""
    model = pin.buildModelFromUrdf(str(model_path("squeezer.urdf")))
    pts = S.body_points()

    def frame(name, body, xy):
        parent = model.getFrameId(body)
        place = model.frames[parent].placement * pin.SE3(np.eye(3), np.array([xy[0], xy[1], 0.0]))
        return model.addFrame(pin.Frame(name, model.frames[parent].parentJoint, parent, place,
                                        pin.FrameType.OP_FRAME))
    e2 = frame("E2", "body2", pts["E2"])
    ek = [frame(f"E{k}", f"body{k}", pts[f"E{k}"]) for k in (3, 4, 6)]
    fd = frame("D", "body3", pts["D3"])
    return model, model.createData(), e2, ek, fd, S.q_from_angles(model, S.ANGLES0)


def make_rhs(model, data, e2, ek, fd):
    nv, P = model.nv, S.P
    C = np.array([P["xc"], P["yc"], 0.0])
    i_beta = model.joints[model.getJointId("beta")].idx_v
    K = np.zeros((nv + 6, nv + 6))
    rhs_vec = np.zeros(nv + 6)
    iu = np.triu_indices(nv, 1)

    def point(fid):
        """Planar position, Jacobian rows and J-dot v of a frame's origin (world axes)."""
        return (data.oMf[fid].translation[:2], pin.getFrameJacobian(model, data, fid, LWA)[:2],
                pin.getFrameClassicalAcceleration(model, data, fid, LWA).linear[:2])

    def rhs(t, x):
        q, v = x[:nv], x[nv:]
        pin.computeAllTerms(model, data, q, v)
        pin.updateFramePlacements(model, data)
        p0, J0, a0 = point(e2)
        rows = [point(f) for f in ek]
        phi = np.concatenate([p0 - p for p, _, _ in rows])
        J = np.vstack([J0 - Jk for _, Jk, _ in rows])
        jdv = np.concatenate([a0 - a for _, _, a in rows])
        # spring from D (body 3) to the fixed point C: tension k (L - l0) along D - C
        d = data.oMf[fd].translation - C
        L = np.sqrt(d @ d)
        tau = -(P["c0"] * (L - P["l0"]) / L) * (pin.getFrameJacobian(model, data, fd, LWA)[:3].T @ d)
        tau[i_beta] += P["mom"]
        M = data.M
        M[iu[1], iu[0]] = M[iu]                 # computeAllTerms fills the upper triangle only
        K[:nv, :nv], K[:nv, nv:], K[nv:, :nv] = M, J.T, J
        rhs_vec[:nv] = tau - data.nle
        rhs_vec[nv:] = -jdv - 2.0 * ALPHA * (J @ v) - BETA * BETA * phi
        return np.concatenate([v, np.linalg.solve(K, rhs_vec)[:nv]])
    return rhs


def run(rtol, t_end=S.T_REF, method="DOP853"):
    """(q at t_end in Pinocchio's layout, CPU seconds of solve_ivp alone, evaluations)."""
    model, data, e2, ek, fd, q0 = build()
    rhs = make_rhs(model, data, e2, ek, fd)
    x0 = np.concatenate([q0, np.zeros(model.nv)])
    c0 = time.process_time()
    sol = solve_ivp(rhs, (0.0, t_end), x0, method=method, rtol=rtol, atol=rtol * 1e-2, t_eval=[t_end])
    cpu = time.process_time() - c0
    if sol.status != 0:
        raise RuntimeError(f"plain script: solve_ivp failed at rtol {rtol:g}: {sol.message}")
    return sol.y[:model.nv, -1].copy(), cpu, sol.nfev


if __name__ == "__main__":
    import argparse

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rtol", type=float, default=1e-10)
    ap.add_argument("--method", default="DOP853", choices=["RK45", "DOP853"])
    args = ap.parse_args()
    q, cpu, nfev = run(args.rtol, method=args.method)
    model = build()[0]
    err = np.abs(S.angles_from_q(model, q) - np.array([S.ANGLES_REF[a] for a in S.ANGLES])).max()
    print(f"{args.method} rtol {args.rtol:g}: max angle error at {S.T_REF} s {err:.3e} rad, "
          f"{cpu * 1e3:.1f} ms CPU, {nfev} evaluations")
