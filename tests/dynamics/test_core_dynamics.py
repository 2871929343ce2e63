"""Forward dynamics without loops, on non-Euclidean trees, with force elements, and Pinocchio's
own constrained dynamics.

References: pin.aba (open chains), conservation laws of a torque-free rigid body (kinetic
energy, world angular momentum, centroidal momentum), the energy balance of a spring-damper
(lost energy = integral of the dissipated power), and the Lagrange KKT solve vs Pinocchio's
proximal constraintDynamics on a mechanism both can express.
"""
from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest
from scipy.integrate import trapezoid

import pinclear
from pinclear.dynamics import formulations
from pinclear.model import kinematics
from pinclear.model.forces import JointForce, SpringDamper
from pinclear.model.timelaws import Constant
from tests.helpers import DATA, URDF_DIR


# ---------------------------------------------------------------------------- 1. no closures
def test_open_chain_equals_aba(double_pendulum_urdf):
    """Every formulation reduces to M^-1 (tau - b) without closures: equal to pin.aba to 1e-10,
    with the joint torques applied through joint_force elements."""
    base = pinclear.load(double_pendulum_urdf)
    model = base.model
    assert base.m == 0 and model.nv == 2
    data = model.createData()
    rng = np.random.default_rng(7)
    for trial in range(3):
        q = pin.integrate(model, pin.neutral(model), rng.uniform(-np.pi, np.pi, model.nv))
        v = 3.0 * rng.standard_normal(model.nv)
        tau = 2.0 * rng.standard_normal(model.nv)
        names = [n for n in model.names[1:]]
        forces = [JointForce(f"tau_{n}", model.joints[model.getJointId(n)].idx_v, Constant(tau[k]))
                  for k, n in enumerate(names)]
        mech = base.replace(forces=forces)
        ref = pin.aba(model, data, q, v, tau)
        assert np.abs(ref).max() > 1.0            # a non-trivial state
        for name, Form in formulations.METHODS.items():
            form = Form(mech)
            a = form.accelerations(0.3, q, v, np.zeros(0))
            np.testing.assert_allclose(a, ref, rtol=0, atol=1e-10, err_msg=f"{name}, trial {trial}")


def test_open_chain_simulation_matches_aba_integration(double_pendulum_urdf, sim):
    """A short free swing: pinclear.simulate equals scipy's DOP853 on pin.aba directly."""
    from scipy.integrate import solve_ivp

    mech = pinclear.load(double_pendulum_urdf)
    model = mech.model
    data = model.createData()
    q0, v0 = np.array([0.7, -0.4]), np.array([0.5, 1.0])

    def f(t, x):
        return np.r_[x[2:], pin.aba(model, data, x[:2], x[2:], np.zeros(2))]

    t_eval = np.linspace(0, 1.0, 11)
    ref = solve_ivp(f, (0, 1.0), np.r_[q0, v0], method="DOP853", rtol=1e-13, atol=1e-15, t_eval=t_eval)
    traj = sim(mech, 1.0, method="lagrange", integrator="DOP853", rtol=1e-12, t_eval=t_eval, q0=q0, v0=v0)
    assert traj.status == "success"
    np.testing.assert_allclose(traj.q, ref.y[:2].T, atol=1e-8)
    np.testing.assert_allclose(traj.v, ref.y[2:].T, atol=1e-7)


# ---------------------------------------------------------------------------- 12. Lie-group trees
def _rigid_body_model(joint):
    model = pin.Model()
    inertia = pin.Inertia(2.0, np.array([0.0, 0.0, 0.0]) if isinstance(joint, pin.JointModelSpherical)
                          else np.array([0.05, -0.02, 0.03]),
                          np.diag([0.02, 0.05, 0.09]) + 0.004 * np.array([[0, 1, 0], [1, 0, 0], [0, 0, 0]]))
    jid = model.addJoint(0, joint, pin.SE3.Identity(), "body_joint")
    model.appendBodyToJoint(jid, inertia, pin.SE3.Identity())
    model.addBodyFrame("body", jid, pin.SE3.Identity(), 0)
    model.gravity.linear[:] = 0.0
    return model


_BODY_RUNS: dict = {}


def _tumbling_body(joint, sim):
    """Euler's torque-free body spun close to its intermediate principal axis (it tumbles),
    on a spherical joint (COM at the pivot) or a free-flyer (COM off the joint origin)."""
    if joint not in _BODY_RUNS:
        jm = pin.JointModelSpherical() if joint == "spherical" else pin.JointModelFreeFlyer()
        model = _rigid_body_model(jm)
        mech = pinclear.Mechanism(model, f"body_{joint}", [], [], [])
        w0 = np.array([0.05, 4.0, 0.08])
        v0 = w0 if joint == "spherical" else np.r_[0.3, -0.1, 0.2, w0]
        traj = sim(mech, 4.0, method="lagrange", integrator="DOP853", rtol=1e-11, q0=pin.neutral(model),
                   v0=v0, dt_out=0.02)
        _BODY_RUNS[joint] = (mech, traj, v0)
    return _BODY_RUNS[joint]


@pytest.mark.parametrize("joint", ["spherical", "freeflyer"])
def test_torque_free_body_energy_and_unit_quaternion(joint, sim):
    """Kinetic energy is a constant of the torque-free motion; the quaternion stays unit; the
    body does tumble (the spin about the intermediate axis changes sign); the chart integration
    re-anchored along the way."""
    mech, traj, v0 = _tumbling_body(joint, sim)
    assert not mech.euclidean
    assert traj.status == "success"
    assert traj.stats["restarts"] > 5
    model, data = mech.model, mech.model.createData()
    T = np.array([pin.computeKineticEnergy(model, data, q, v) for q, v in zip(traj.q, traj.v)])
    assert np.abs(T - T[0]).max() / T[0] < 1e-8
    assert np.abs(np.linalg.norm(traj.q[:, -4:], axis=1) - 1.0).max() < 1e-12
    np.testing.assert_allclose(traj.v[0], v0, atol=1e-12)
    wy = traj.v[:, -2]
    assert wy.min() < 0.0 < wy.max()


@pytest.mark.parametrize("joint", ["spherical", "freeflyer"])
def test_torque_free_body_world_momentum(joint, sim):
    """World angular momentum (centroidal momentum for the free flyer: linear and angular) is a
    constant of the motion, and the first sample is the initial configuration."""
    mech, traj, v0 = _tumbling_body(joint, sim)
    model, data = mech.model, mech.model.createData()
    np.testing.assert_allclose(traj.q[0], pin.neutral(model), atol=1e-12)
    H = []
    for q, v in zip(traj.q, traj.v):
        h = pin.computeCentroidalMomentum(model, data, q, v)
        H.append(np.r_[h.linear, h.angular])
    H = np.array(H)
    assert np.abs(H - H[0]).max() / np.linalg.norm(H[0]) < 1e-8


# ---------------------------------------------------------------------------- 8. force elements
@pytest.fixture(scope="module")
def spring_bar():
    return pinclear.load(DATA / "core_four_bar_spring.yaml")


def test_spring_keeps_total_energy(spring_bar, sim):
    mech = spring_bar
    assert len(mech.forces) == 1 and mech.forces[0].k > 0 and mech.conservative
    traj = sim(mech, 3.0, method="lagrange", integrator="DOP853", rtol=1e-10)
    assert traj.status == "success"
    E = traj.energy()
    spring = E["spring"]
    # the spring works: its energy swings by a good fraction of the kinetic energy
    assert np.ptp(spring) > 0.2 * np.max(E["kinetic"])
    # spring potential recomputed here from the frame positions
    data = mech.model.createData()
    f = mech.forces[0]
    L = []
    for q in traj.q:
        pin.framesForwardKinematics(mech.model, data, q)
        L.append(np.linalg.norm(data.oMf[f.f1].translation - data.oMf[f.f2].translation))
    np.testing.assert_allclose(spring, 0.5 * f.k * (np.array(L) - f.L0) ** 2, rtol=1e-12, atol=1e-15)
    total = E["kinetic"] + E["potential"] + spring
    assert np.abs(total - total[0]).max() / np.max(E["kinetic"]) < 1e-7
    assert traj.summary()["energy_drift_rel"] < 1e-7


def test_damper_energy_loss_equals_dissipated_work(spring_bar, sim):
    f = spring_bar.forces[0]
    damped = SpringDamper("damped", spring_bar.model, f.f1, f.f2, f.k, c=0.8, free_length=f.L0)
    mech = spring_bar.replace(forces=[damped])
    assert not mech.conservative
    traj = sim(mech, 2.0, method="lagrange", integrator="DOP853", rtol=1e-10, dt_out=1e-3)
    assert traj.status == "success"
    E = traj.energy()
    total = E["kinetic"] + E["potential"] + E["spring"]
    lost = total[0] - total[-1]
    assert lost > 0.2 * E["kinetic"][0]          # it damps visibly
    P = traj.energies["dissipated_power"]
    assert P.min() >= 0.0
    # independent value of the dissipated power from the relative velocity of the frames
    data = mech.model.createData()
    Pref = []
    for q, v in zip(traj.q, traj.v):
        pin.forwardKinematics(mech.model, data, q, v)
        pin.updateFramePlacements(mech.model, data)
        d = data.oMf[f.f1].translation - data.oMf[f.f2].translation
        dv = (pin.getFrameVelocity(mech.model, data, f.f1, pin.LOCAL_WORLD_ALIGNED).linear
              - pin.getFrameVelocity(mech.model, data, f.f2, pin.LOCAL_WORLD_ALIGNED).linear)
        Pref.append(0.8 * (d @ dv / np.linalg.norm(d)) ** 2)
    np.testing.assert_allclose(P, Pref, rtol=1e-9, atol=1e-12)
    work = trapezoid(P, traj.t)
    assert abs(lost - work) / lost < 1e-4
    # and the loss accumulates as the integral does, not just at the end
    mid = len(traj.t) // 2
    assert abs((total[0] - total[mid]) - trapezoid(P[: mid + 1], traj.t[: mid + 1])) / lost < 1e-4


# ---------------------------------------------------------------------------- 13. pinocchio CD
def test_pinocchio_formulation_equals_lagrange_on_spherical_closures():
    mech = pinclear.load(URDF_DIR / "four_ups_upu.yaml")
    assert {c.type for c in mech.closures} == {"spherical"} and len(mech.drives) == 5
    t = 0.37
    q = kinematics.assemble(mech, mech.q0, t=t)
    rng = np.random.default_rng(3)
    v = kinematics.consistent_velocity(mech, q, rng.standard_normal(mech.nv), t=t)
    ws = mech.workspace()
    kinematics.update(mech, ws, q, v)
    kinematics.constraint_rows(mech, ws, t, q, v)
    assert np.abs(ws.dphi).max() < 1e-9          # consistent: Baumgarte terms vanish
    lag = formulations.get("lagrange")(mech)
    pcd = formulations.get("pinocchio")(mech)
    a_l = lag.accelerations(t, q, v, np.zeros(0))
    a_p = pcd.accelerations(t, q, v, np.zeros(0))
    assert np.abs(a_l).max() > 0.1
    np.testing.assert_allclose(a_p, a_l, rtol=0, atol=1e-8 * max(1.0, np.abs(a_l).max()))
    # the drive forces (the multipliers of the drive rows) agree too
    md = mech.m_closures
    np.testing.assert_allclose(pcd.ws.lam[md:], lag.ws.lam[md:], rtol=1e-7, atol=1e-7)
    # J a + (dJ/dt) v = 0 for the closures and the drives' second derivatives are met
    kinematics.constraint_rows(mech, ws, t, q, v)
    np.testing.assert_allclose(ws.J @ a_p, ws.gamma, atol=1e-7)


def test_pinocchio_formulation_refuses_other_closures(four_bar):
    with pytest.raises(pinclear.InputError, match="planar_point"):
        formulations.get("pinocchio")(four_bar)


@pytest.fixture(scope="module")
def upu_runs(sim):
    mech = pinclear.load(URDF_DIR / "four_ups_upu.yaml")
    return mech, {m: sim(mech, 0.2, method=m, integrator="DOP853", rtol=1e-9, dt_out=0.02)
                  for m in ("lagrange", "pinocchio")}


def test_pinocchio_and_lagrange_drive_forces_along_a_run(upu_runs):
    """Along the prescribed platform motion the five drive forces (hundreds of newtons) of the
    two formulations agree to 1e-7 relative."""
    mech, runs = upu_runs
    for r in runs.values():
        assert r.status == "success" and r.residual.max() < 1e-9
    for d in mech.drives:
        ref = runs["lagrange"].lam[d.name]
        np.testing.assert_allclose(runs["pinocchio"].lam[d.name], ref, rtol=0, atol=1e-7 * np.abs(ref).max())


def test_pinocchio_closure_multipliers_in_world_axes(upu_runs):
    mech, runs = upu_runs
    for c in mech.closures:
        for ax in "xyz":
            ref = runs["lagrange"].lam[f"{c.name}.{ax}"]
            np.testing.assert_allclose(runs["pinocchio"].lam[f"{c.name}.{ax}"], ref, atol=1e-6 * (1 + np.abs(ref).max()))


def test_pinocchio_method_records_energies_and_residuals_of_its_own_states():
    """The 'pinocchio' method solves on Pinocchio's own data; the samples' energies must still
    be those of the returned states (they were read from a workspace the method never updated:
    kinetic energy 0). Reference: Pinocchio's energies recomputed at the returned states."""
    mech = pinclear.load("clr_pendulum")
    tr = pinclear.simulate(mech, 0.5, method="pinocchio", rtol=1e-8, dt_out=0.05)
    assert tr.status == "success"
    model, data = mech.model, mech.model.createData()
    T = [pin.computeKineticEnergy(model, data, q, v) for q, v in zip(tr.q, tr.v)]
    V = [pin.computePotentialEnergy(model, data, q) for q in tr.q]
    E = tr.energy()
    assert max(T) > 0.1                                   # it swings: the check is not vacuous
    np.testing.assert_allclose(E["kinetic"], T, rtol=1e-12, atol=1e-14)
    np.testing.assert_allclose(E["potential"], V, rtol=1e-12, atol=1e-14)
