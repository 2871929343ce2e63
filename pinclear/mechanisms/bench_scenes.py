"""The bundled scenes' settings for the benchmarks (pinclear.studies.bench): simulated windows of
the stability atlas, the joints that stay parallel on a scene's branch of parallel cranks, the
references computed by a path independent of the simulation where a scene has one (a closed form
or a reduced model), and the scenes the restitution and output benchmarks run. The benchmarks
are generic; what they know about a bundled mechanism lives here, by its name.
"""
from __future__ import annotations

import math
import re

import numpy as np
import pinocchio as pin
from scipy.integrate import solve_ivp

#: bundled mechanisms imported from other packages' robot files (``pinclear import``): the
#: benchmarks that sweep "every scene" (``bench runs``, ``bench atlas``) leave them out unless
#: named, since Cassie's five variants are robots, not clearance studies, and cost the quick atlas
#: ~7 CPU min on their own; benchmarks/bench_cassie.py measures them
IMPORTED_ROBOTS = ("cassie", "cassie_reduced", "cassie_simple", "cassie_v2", "cassie_wo_gearbox_spring")


def catalogue() -> list[str]:
    """The bundled mechanisms the whole-catalogue benchmarks run by default."""
    from pinclear.core.models import available

    return [n for n in available() if n not in IMPORTED_ROBOTS]


#: rigid scenes: simulated seconds (full atlas); the parallelogram and A02 scenes pass their flat
#: configuration at least twice in it
ATLAS_T_END = {"parallelogram": 1.0, "a02_nfourbar_1": 3.0, "a02_nfourbar_2": 3.0, "a02_nfourbar_10": 2.0,
               # python drive laws (inverse kinematics per evaluation): ~10x the cost of a sines law
               "four_ups_upr": 0.5,
               # 5000 rpm: 4 crank revolutions
               "slider_crank_clearance": 0.05,
               # the Test Set's interval: beta turns 2.5 revolutions and reaches ~1100 rad/s in it
               "squeezer": 0.03}
#: clearance scenes cost 1-70 CPU s per simulated s (benchmarks/bench_runs.md, RK45 rtol 1e-6):
#: windows sized so that one RK45 rtol-1e-6 cell costs about 0.3 s
ATLAS_T_END_CLEARANCE = {"clr_hinge+R": 0.04, "clr_pendulum+S": 0.05, "clr_planar_pendulum+A": 0.05,
                         "clr_slider+P": 0.015, "four_ups_upu+S2": 0.2, "nine_bar+A": 0.1, "nine_bar+B": 0.1,
                         "slider_crank_clearance+P": 0.01, "three_upru_up+P_UP": 0.005}
ATLAS_QUICK_T_END = {"parallelogram": 0.5, "a02_nfourbar_1": 1.0, "a02_nfourbar_2": 1.0, "a02_nfourbar_10": 1.0,
                     "squeezer": 0.03}

#: the restitution benchmark's two central impacts: (scene, clearance, mass of the moving body
#: [kg], velocity direction (q-space), clearance gap), by what they test
IMPACTS = {"ball in a socket (spherical, clr_ball)": ("clr_ball", "S", 6, 0),
           "journal in a bearing (planar revolute, clr_planar_pendulum)": ("clr_planar_pendulum", "A", 3, 1)}

#: the output benchmark's runs: (bundled name, active clearances, method): a clearance run with many
#: outputs and a singular rigid run (benchmarks/bench_outputs.md)
OUTPUT_CASES = (("four_ups_upu", ("S2",), "lagrange"), ("a02_nfourbar_2", (), "manifold"))


def branch_joints(mech):
    """Joints that stay parallel on the parallelogram branch (cranks), or None for other scenes.

    parallelogram: crank and rocker; IFToMM A02: crank0..crankN."""
    names = [mech.model.names[j] for j in range(1, mech.model.njoints)]
    cranks = sorted((n for n in names if re.fullmatch(r"crank\d+_joint", n)), key=lambda n: int(n[5:-6]))
    if len(cranks) >= 2:
        return cranks
    if "crank_joint" in names and "rocker_joint" in names and mech.name.startswith("parallelogram"):
        return ["crank_joint", "rocker_joint"]
    return None


def _a02_reference(mech, n, t_end):
    """IFToMM A02 on its parallelogram branch is a 1-dof pendulum with closed-form inertia and
    gravity (pinclear.mechanisms.benchmarks.a02_branch_rhs), integrated by SciPy at rtol 1e-13."""
    from pinclear.mechanisms import benchmarks as B

    sol = solve_ivp(B.a02_branch_rhs(n), (0.0, t_end), [B.A02_THETA0, B.a02_initial_rate()], method="DOP853",
                    rtol=1e-13, atol=1e-14, t_eval=[t_end])
    qd, _ = B.a02_branch_state(n, sol.y[0, -1], sol.y[1, -1])
    q = np.zeros(mech.model.nq)
    for name, val in qd.items():
        q[mech.model.joints[mech.model.getJointId(name)].idx_q] = val
    return q, "analytic: 1-dof branch pendulum, I = (N+1)/3 + N, V = ((N+1)/2 + N) g sin th (SciPy DOP853, rtol 1e-13)"


def _parallelogram_branch(mech, t_end, **kw):
    """The parallelogram branch q = (th, -th, th) as a 1-dof system: kinetic energy I(th) th'^2 / 2
    with I = u^T M u, u = (1, -1, 1), generalized gravity u^T g (Pinocchio's M and g only, no
    closure or multiplier), integrated by SciPy at rtol 1e-12."""
    model, data = mech.model, mech.model.createData()
    u = np.array([1.0, -1.0, 1.0])

    def inertia(th):
        M = pin.crba(model, data, th * u)           # upper triangle only: symmetrise
        M = np.triu(M) + np.triu(M, 1).T
        return u @ M @ u

    def f(t, y):
        th, thd = y
        dI = (inertia(th + 1e-6) - inertia(th - 1e-6)) / 2e-6
        G = u @ pin.computeGeneralizedGravity(model, data, th * u)
        return [thd, (-G - 0.5 * dI * thd * thd) / inertia(th)]

    return solve_ivp(f, (0.0, t_end), [float(mech.q0[0]), float(mech.v0[0])], method="DOP853", rtol=1e-12,
                     atol=1e-14, **kw), u


def _parallelogram_reference(mech, t_end):
    sol, u = _parallelogram_branch(mech, t_end, t_eval=[t_end])
    return sol.y[0, -1] * u, "1-dof reduction on the parallelogram branch (Pinocchio M and g, SciPy DOP853, rtol 1e-12)"


def parallelogram_flat_times(mech, t_end):
    """Times at which the parallelogram passes its flat (singular) configuration, th = 0 mod pi,
    from the 1-dof branch motion (the same reduction as the reference)."""
    sol, _ = _parallelogram_branch(mech, t_end, events=lambda t, y: math.sin(y[0]))
    return sol.t_events[0]


def reference(mech, label, t_end):
    """(q at t_end, description) of scene ``label`` from its own independent path, or None when the
    scene has none (the atlas then uses a tight run of another formulation)."""
    m = re.fullmatch(r"a02_nfourbar_(\d+)", label)
    if m:
        return _a02_reference(mech, int(m.group(1)), t_end)
    if label == "parallelogram":
        return _parallelogram_reference(mech, t_end)
    return None
