"""The force elements in the stepping engine (ForceElement contract 10): every element type's
compiled kernel against its Python methods, against independent evaluations of the same physics,
and whole runs through the compiled stages against runs through the Python methods.

Bounds. A compiled stage and the element's Python ``add_force`` call the same kernel on the same
memory (the stage rebuilds views of the buffers from their addresses), so they agree bit for bit.
The clearance joints' law-by-law Python evaluation (``_compute``: the laws' vectorised methods,
NumPy projections) runs the same formulas in another order on the same geometry (Pinocchio's
frame placements are set to the kernel's): each quantity is a chain of a few dozen operations of
condition near one, so they agree to a few hundred ulps; 1e-12 of each quantity's scale leaves a
factor > 10 on that. Independent references (Pinocchio's frame Jacobians, the time laws' Python
formulas) differ by the round-off of their own chains, bounded the same way.
"""
from __future__ import annotations

import ast
import math
import warnings
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest
import yaml

import pinclear
from pinclear.core.stage import T, bind
from pinclear.model import kinematics, native
from pinclear.model import timelaws as TL
from pinclear.model.forces import JointForce
from tests.helpers import ROOT, write_sidecar

EPS = np.finfo(float).eps
LUGRE = {"type": "lugre", "mu_s": 0.3, "mu_c": 0.2, "vs": 1e-3, "s0": 1e4, "s1": 10.0, "s2": 0.01}
FRICTION = {
    "none": {"type": "none"},
    "coulomb": {"type": "coulomb", "mu": 0.3},
    "modified_coulomb": {"type": "modified_coulomb", "mu": 0.2, "v0": 1e-4, "v1": 1e-2},
    "stick_slip": {"type": "stick_slip", "mu_s": 0.5, "mu_d": 0.2, "Vs": 1e-3, "Vd": 1e-2},
    "lugre": LUGRE,
}
# every joint type with its normal laws: the power laws, the line law (journals, prismatic line
# contacts) and the plane law (prismatic faces, paper003's defaults for line_law and plane_law)
JOINTS = ([("clr_pendulum", "S", {"S.normal_law": law})
           for law in ("hertz", "lankarani_nikravesh", "flores", "hunt_crossley", "gonthier")]
          + [("clr_planar_pendulum", "A", {"A.normal_law": law}) for law in ("lankarani_nikravesh", "line")]
          + [("clr_hinge", "R", {"R.normal_law": law}) for law in ("flores", "line")]
          + [("clr_slider", "P", {"P.normal_law": law}) for law in ("lankarani_nikravesh", "gonthier")]
          + [("clr_slider", "P", {"P.model": "paper003", "P.point_law": law})
             for law in ("lankarani_nikravesh", "hunt_crossley")])


def _id(joint):
    scene, _, ov = joint
    return scene + "-" + "-".join(str(v) for v in ov.values())


def four_bar_spring_torque(folder, motor_law=None):
    """The bundled four-bar with a damped spring from a ground point to the coupler's middle, a
    constant torque on the crank and a sines torque on the rocker (sidecar in ``folder``)."""
    doc = yaml.safe_load((ROOT / "urdf" / "four_bar.yaml").read_text())
    doc["forces"] = [
        {"name": "spring", "type": "spring_damper", "frame1": {"parent": "ground", "xyz": [0.15, 0.35, 0.0]},
         "frame2": {"parent": "coupler", "xyz": [0.175, 0.0, 0.0]}, "k": 40.0, "c": 0.5, "free_length": 0.1},
        {"name": "motor", "type": "joint_force", "joint": "crank_joint",
         "law": motor_law or {"type": "constant", "value": 0.02}},
        {"name": "shaker", "type": "joint_force", "joint": "rocker_joint",
         "law": {"type": "sines", "offset": -0.01, "terms": [{"amp": 0.02, "omega": 9.0, "kind": "cos"}]}},
    ]
    return pinclear.load(write_sidecar(folder, doc))


def _states(mech, el, count, seed):
    """Random (q, v, z) around the scene's initial guess: positions moved by 5e-5 .. 2e-3 (m or
    rad) per coordinate, so some states are out of contact, some graze and some touch deeply;
    onset speeds 1e-4 .. 1 m/s; bristle deflections of a few micrometres."""
    rng = np.random.default_rng(seed)
    for i in range(count):
        spread = (5e-5, 2e-4, 2e-3)[i % 3]
        q = pin.integrate(mech.model, mech.q0, rng.normal(size=mech.nv) * spread)
        z = np.r_[10 ** rng.uniform(-4, 0, el.nc), 0.0, rng.normal(size=el.nfs) * 3e-6]
        yield q, rng.normal(size=mech.nv), z


def _point_jacobian(mech, ws, fid, p):
    """Linear velocity rows (3, nv) of the material point p (world) of frame fid's body: the
    WORLD joint Jacobian's columns of the joints moving it, v = v_o + w x p."""
    J = np.zeros((3, mech.nv))
    idx = kinematics.supporting_dofs(mech.model, fid)
    Jv, Jw = ws.J6[:3, idx], ws.J6[3:, idx]
    skew = np.array([[0.0, -p[2], p[1]], [p[2], 0.0, -p[0]], [-p[1], p[0], 0.0]])
    J[:, idx] = Jv - skew @ Jw
    return J


# ------------------------------------------------------------------ (a) kernels against Python methods
@pytest.mark.parametrize("joint", JOINTS, ids=[_id(j) for j in JOINTS])
def test_clearance_kernels_equal_the_python_methods(joint):
    """For every friction law: the compiled force and event stages against add_force and
    event_values (bitwise), record() after the evaluation against the law-by-law Python path,
    and the generalized force against one assembled from that path's contact forces with
    NumPy point Jacobians."""
    scene, name, ov = joint
    for fname, fr in FRICTION.items():
        mech = pinclear.load(scene, clearances=[name], overrides={**ov, f"{name}.friction_law": fr})
        i = [f.name for f in mech.forces].index(name)
        el, ws = mech.forces[i], mech.workspace()
        d, nc = ws.force_data[i], el.nc
        made = el.force_kernel(mech, ws, d, ws.z_views[i], ws.zdot_views[i])
        g = np.zeros(nc)
        ev = el.event_kernel(mech, ws, d, g)
        assert made is not None and ev is not None, fname                  # every law is compiled
        force, events = bind(*made), bind(*ev)
        touching = 0
        for q, v, z in _states(mech, el, 12, seed=len(fname)):
            ws.q[:], ws.v[:], ws.z_views[i][:] = q, v, z
            kinematics.update(mech, ws, ws.q, ws.v)
            ws.tau[:], ws.zdot[:] = 0.0, np.nan
            force(0.0)
            tau_c, zdot_c = ws.tau.copy(), ws.zdot_views[i].copy()
            M, delta_c = d.M.copy(), d.delta.copy()
            # the Python method: the same kernel called directly on the caller's buffers
            tau, zdot = np.zeros(mech.nv), np.full(el.nz, np.nan)
            el.add_force(mech, ws, d, 0.0, q, v, z, tau, zdot)
            assert np.array_equal(tau, tau_c) and np.array_equal(zdot, zdot_c), fname
            pot, loss, rec = el.record(mech, ws, d, 0.0, q, v, z, True)
            assert loss == zdot_c[nc] and el.power_loss(mech, ws, d, 0.0, q, v, z) == zdot_c[nc]
            g[:] = np.nan
            events(0.0)
            assert np.array_equal(g, el.event_values(mech, ws, d, 0.0, q, v, z))
            # the law-by-law Python path at the kernel's placements (event_values emptied d's cache)
            ws.data.oMf[el.f1], ws.data.oMf[el.f2] = pin.SE3(M[0]), pin.SE3(M[1])
            py = el.outputs(mech, ws, d, 0.0, q, v, z)
            assert np.array_equal(d.delta, delta_c)                   # the same geometry
            # force scale: the clipped damping leaves Fn = 0 with an elastic part that still dissipates
            F = max(np.abs(d.F2).max(), np.abs(d.Fel).max())
            vt = np.abs(d.vt).max() if d.moving else 0.0
            tau_ref = np.zeros(mech.nv)
            for k in range(nc):
                tau_ref += (_point_jacobian(mech, ws, el.f2, d.p2[k]) - _point_jacobian(mech, ws, el.f1, d.p1[k])).T \
                    @ d.F2[k]
            lever = 1.0 + np.abs(d.p2).max()
            np.testing.assert_allclose(tau_c, tau_ref, rtol=0, atol=1e-12 * F * lever + 1e-300, err_msg=fname)
            assert abs(zdot_c[nc] - d.loss) <= 1e-12 * F * (vt + np.abs(d.dd).max()) + 1e-300, fname
            np.testing.assert_allclose(zdot_c[nc + 1:], d.dzf, rtol=0,
                                       atol=1e-12 * max(vt, np.abs(d.dzf).max(initial=0.0)) + 1e-300, err_msg=fname)
            assert np.all(zdot_c[:nc] == 0.0)
            for key, val in py.items():
                np.testing.assert_allclose(rec[key], val, rtol=1e-12, atol=1e-12 * max(F, 1.0),
                                           err_msg=f"{fname} {key}")
            assert pot == pytest.approx(el.potential(mech, ws, d, q), rel=1e-12, abs=1e-300)
            touching += bool(np.any(g > 0))
            if fname == "lugre" and np.any(g > 0):
                assert np.abs(zdot_c[nc + 1:]).max() > 0            # the bristles move in contact
        assert touching >= 4, fname


def test_spring_kernel_equals_its_python_methods_and_pinocchio(tmp_path):
    """The spring-damper's stage against add_force (bitwise), and force, potential, power loss
    and outputs against the same physics from Pinocchio's frame placements and frame Jacobians
    (LOCAL_WORLD_ALIGNED), at random configurations and velocities (the spring's formula needs
    no closed loop)."""
    mech = four_bar_spring_torque(tmp_path)
    i = [f.name for f in mech.forces].index("spring")
    el, ws = mech.forces[i], mech.workspace()
    d = ws.force_data[i]
    assert el.kinematic_frames == (el.f1, el.f2)
    stage = bind(*el.force_kernel(mech, ws, d, ws.z_views[i], ws.zdot_views[i]))
    model, data = mech.model, mech.model.createData()
    rng = np.random.default_rng(11)
    for _ in range(20):
        q, v = rng.uniform(-np.pi, np.pi, mech.nq), rng.normal(size=mech.nv) * 3.0
        ws.q[:], ws.v[:] = q, v
        kinematics.update(mech, ws, ws.q, ws.v)
        ws.tau[:] = 0.0
        stage(0.0)
        tau = np.zeros(mech.nv)
        el.add_force(mech, ws, d, 0.0, q, v, np.zeros(0), tau, np.zeros(0))
        assert np.array_equal(tau, ws.tau)
        pin.computeJointJacobians(model, data, q)
        pin.updateFramePlacements(model, data)
        p1, p2 = data.oMf[el.f1].translation, data.oMf[el.f2].translation
        L = np.linalg.norm(p1 - p2)
        e = (p1 - p2) / L
        J = (pin.getFrameJacobian(model, data, el.f1, pin.LOCAL_WORLD_ALIGNED)[:3]
             - pin.getFrameJacobian(model, data, el.f2, pin.LOCAL_WORLD_ALIGNED)[:3])
        Ldot = e @ J @ v
        f = el.k * (L - el.L0) + el.c * Ldot
        ref = -f * J.T @ e
        scale = (abs(el.k * (L - el.L0)) + abs(el.c * Ldot)) * (1.0 + np.abs(J).max())
        np.testing.assert_allclose(tau, ref, rtol=0, atol=1e-13 * scale)
        assert el.potential(mech, ws, d, q) == pytest.approx(0.5 * el.k * (L - el.L0) ** 2, rel=1e-12)
        assert el.power_loss(mech, ws, d, 0.0, q, v, None) == pytest.approx(el.c * Ldot ** 2, rel=1e-12,
                                                                             abs=1e-13 * scale * abs(Ldot))
        out = el.outputs(mech, ws, d, 0.0, q, v, None)
        assert out["length"] == pytest.approx(L, rel=1e-13)
        assert out["force"] == pytest.approx(f, abs=1e-13 * scale)
        pot, loss, rec = el.record(mech, ws, d, 0.0, q, v, None, True)
        assert pot == el.potential(mech, ws, d, q) and loss == el.power_loss(mech, ws, d, 0.0, q, v, None)
        assert float(rec["force"]) == float(out["force"])


@pytest.mark.parametrize("law", [
    {"type": "constant", "value": -0.7},
    {"type": "sines", "offset": 0.1, "terms": [{"amp": 0.3, "omega": 7.0, "phase": 0.2}, {"amp": -1.1, "omega": 2.0,
                                                                                          "kind": "cos"}]},
    {"type": "polynomial", "coeffs": [0.5, -1.0, 0.25, 2.0]},
], ids=["constant", "sines", "polynomial"])
def test_joint_force_kernel_equals_its_python_methods_and_the_law(tmp_path, law):
    """The joint force's stage at time t (bound to the evaluation time) against add_force
    (bitwise) and against the law's Python formula (TimeLaw.eval): they differ by the round-off
    of a few sums of terms, < 8 eps of the sum of the terms' magnitudes."""
    mech = four_bar_spring_torque(tmp_path, motor_law=law)
    i = [f.name for f in mech.forces].index("motor")
    el, ws = mech.forces[i], mech.workspace()
    d = ws.force_data[i]
    kernel, args = el.force_kernel(mech, ws, d, ws.z_views[i], ws.zdot_views[i])
    assert T in args
    stage = bind(kernel, args)
    size = sum(abs(x) for x in np.ravel(TL.law_table([el.law], [0]).P))
    rng = np.random.default_rng(5)
    for t in rng.uniform(-2.0, 3.0, 25):
        ws.tau[:] = 0.0
        stage(t)
        tau = np.zeros(mech.nv)
        el.add_force(mech, ws, d, t, ws.q, ws.v, np.zeros(0), tau, np.zeros(0))
        assert np.array_equal(tau, ws.tau)
        ref = el.law.eval(t)[0]
        bound = 8 * EPS * size * max(1.0, abs(t)) ** 3
        assert abs(tau[el.idx_v] - ref) <= bound and np.count_nonzero(tau) <= 1
        v = rng.normal(size=mech.nv)
        loss = el.power_loss(mech, ws, d, t, ws.q, v, None)
        assert loss == pytest.approx(-ref * v[el.idx_v], abs=bound * abs(v).max())
        assert float(el.outputs(mech, ws, d, t, ws.q, v, None)["force"]) == tau[el.idx_v]


def test_a_python_law_keeps_its_python_stage(tmp_path):
    """A joint force following a Python function has no compiled form: its force_kernel is None
    and a run evaluates it through a Python stage (named in stats['loop']), taking the steps a
    run through the Python methods takes."""
    mech = four_bar_spring_torque(tmp_path)
    i = [f.name for f in mech.forces].index("motor")
    motor = mech.forces[i]
    pulse = JointForce("motor", motor.idx_v, TL.Callable(lambda t: (0.02 * math.cos(3.0 * t), 0.0, 0.0)))
    forces = list(mech.forces)
    forces[i] = pulse
    mech = mech.replace(forces=forces)
    ws = mech.workspace()
    assert pulse.force_kernel(mech, ws, ws.force_data[i], ws.z_views[i], ws.zdot_views[i]) is None
    fast, slow = _pair(mech, 0.5)
    assert fast.stats["loop"] == "compiled; python stages: force motor (JointForce.add_force)"
    _same_run(fast, slow)


# ------------------------------------------------------------------ (b) compiled runs against Python runs
def _pair(mech, t_end, **kw):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        fast = pinclear.simulate(mech, t_end, rtol=1e-6, dt_out=t_end / 50, **kw)
        slow = pinclear.simulate(mech, t_end, rtol=1e-6, dt_out=t_end / 50, loop="python", **kw)
    return fast, slow


def _same_run(fast, slow):
    """Same steps, evaluations and events (located on identical steps: equal times) and the same
    states: both loops run the same step logic on evaluations of the same arithmetic, so nothing
    but zero is expected; 1e-12 of the state's scale admits Pinocchio's passes called through
    its C++ API and through its Python bindings being differently built copies of one code."""
    assert slow.stats["loop"].startswith("python")
    assert fast.status == slow.status == "success"
    assert fast.stats["steps"] == slow.stats["steps"]
    assert fast.stats["rhs_evals"] == slow.stats["rhs_evals"]
    ef, es = fast.stats["events"], slow.stats["events"]
    assert [(e["element"], e["event"], e["t"]) for e in ef] == [(e["element"], e["event"], e["t"]) for e in es]
    for a, b in ((fast.q, slow.q), (fast.v, slow.v), (fast.z, slow.z)):
        np.testing.assert_allclose(a, b, rtol=0, atol=1e-12 * max(1.0, np.abs(b).max(initial=0.0)))


# the slider falls onto its guide's face from rest along a symmetry axis: with no slip friction
# would never act; sliding along the guide (z) and turning about it, it does
SLIDING = [0.0, 0.0, 0.05, 0.0, 0.0, 0.5]
# (label, scene, clearance, overrides, simulate arguments): each joint type and contact model,
# friction laws, LuGre on each geometry family
RUNS = [("ball", "clr_ball", "S", {}, dict(v0=[0.02, 0.01, 0.0, 0.0, 0.0, 3.0])),
        ("spherical", "clr_pendulum", "S", {}, {}),
        ("planar_revolute-modified_coulomb", "clr_planar_pendulum", "A",
         {"A.friction_law": FRICTION["modified_coulomb"]}, {}),
        ("revolute-coulomb", "clr_hinge", "R", {"R.friction_law": FRICTION["coulomb"]}, {}),
        ("prismatic-energy", "clr_slider", "P", {}, {}),
        ("prismatic-paper003-stick_slip", "clr_slider", "P",
         {"P.model": "paper003", "P.friction_law": FRICTION["stick_slip"]}, dict(v0=SLIDING)),
        ("spherical-lugre", "clr_pendulum", "S", {"S.friction_law": LUGRE}, {}),
        ("revolute-lugre", "clr_hinge", "R", {"R.friction_law": LUGRE}, {}),
        ("prismatic-energy-lugre", "clr_slider", "P", {"P.friction_law": LUGRE}, dict(v0=SLIDING))]


@pytest.mark.slow
@pytest.mark.skipif(not native.available(), reason=f"compiled passes unavailable: {native.reason}")
@pytest.mark.parametrize("scene, name, ov, kw", [r[1:] for r in RUNS], ids=[r[0] for r in RUNS])
def test_clearance_runs_are_compiled_and_take_the_python_steps(scene, name, ov, kw):
    mech = pinclear.load(scene, clearances=[name], overrides=ov)
    fast, slow = _pair(mech, 0.05, **kw)
    assert fast.stats["loop"] == "compiled", fast.stats["loop"]
    assert len(fast.stats["events"]) > 0                         # the run meets its contacts
    _same_run(fast, slow)
    if ov.get(f"{name}.friction_law") == LUGRE:
        assert np.abs(fast.z[:, mech.forces[-1].nc + 1:]).max() > 0      # the bristles were loaded


@pytest.mark.skipif(not native.available(), reason=f"compiled passes unavailable: {native.reason}")
def test_spring_torque_run_is_compiled_takes_the_python_steps_and_closes_its_energy(tmp_path):
    """The four-bar with a damped spring and two applied torques: no Python stage, the Python
    run's steps, and the energy audit closes (the spring's potential and power loss, the torques'
    power) with the spring's energy and the applied work each larger than its bound."""
    mech = four_bar_spring_torque(tmp_path)
    fast, slow = _pair(mech, 1.0)
    assert fast.stats["loop"] == "compiled", fast.stats["loop"]
    _same_run(fast, slow)
    b = fast.summary()["energy_balance"]
    assert b["ok"], b
    terms = b["terms"]
    # each term is beyond the audit's bound: leaving one out would fail it
    assert min(abs(terms["elastic"]), abs(terms["work_applied"])) > b["bound"] * b["scale"], b
    # the spring's outputs are its length and tension at the samples
    f = fast.outputs["spring.force"]
    L = fast.outputs["spring.length"]
    assert np.all(L > 0) and np.ptp(f) > 0


# ------------------------------------------------------------------ the old binder is gone from the elements
def test_force_elements_do_not_use_the_old_binder():
    """forces.py and pinclear/contact bind their kernels through the stepping engine's stages
    only (pinclear._bind is being retired)."""
    files = [ROOT / "pinclear" / "model" / "forces.py", *sorted((ROOT / "pinclear" / "contact").glob("*.py"))]
    for path in files:
        for node in ast.walk(ast.parse(Path(path).read_text())):
            if isinstance(node, ast.ImportFrom):
                names = [node.module or ""] + [a.name for a in node.names]
            elif isinstance(node, ast.Import):
                names = [a.name for a in node.names]
            else:
                continue
            assert not any(n == "_bind" or n.endswith("._bind") for n in names), (path, names)
