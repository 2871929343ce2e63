"""The MuJoCo peer (benchmarks/peers/mujoco_peer.py): the translation of pinclear's mechanisms to
MuJoCo is checked against physics and against Pinocchio, an independent implementation of the same
kinematics and dynamics.

Bounds come from the convergence study of benchmarks/peers/run_peers.py (peers.md): MuJoCo's RK4
with solref = (2h, 1) converges at order 2 (its constraint acceleration omits dJ/dt v, and with a
time constant proportional to h the resulting violation ~ tc^2 dJ/dt v is O(h^2)). On four_bar over
0.5 s: error 1.06e-6 at h = 1e-3 and 2.2e-7 at h = 5e-4, i.e. C h^2 with C ~ 0.9-1.1."""
from __future__ import annotations

import sys
import warnings
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest

mujoco = pytest.importorskip("mujoco")

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "benchmarks" / "peers"))

import mujoco_peer as mp  # noqa: E402

import pinclear  # noqa: E402
from pinclear.core.errors import InputError  # noqa: E402
from pinclear.model.mechanism import Mechanism  # noqa: E402


@pytest.fixture(autouse=True)
def _in_a_temporary_folder(tmp_path, monkeypatch):
    """MuJoCo writes MUJOCO_LOG.TXT into the working folder when it warns: keep it out of the clone."""
    monkeypatch.chdir(tmp_path)


def _load(name):
    return pinclear.load(ROOT / "urdf" / f"{name}.yaml")


@pytest.fixture(scope="module")
def four_bar_ref():
    mech = _load("four_bar")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        ref = pinclear.simulate(mech, 0.5, method="projection", integrator="DOP853", rtol=1e-12, atol=1e-14,
                                t_eval=[0.0, 0.5])
    assert ref.status == "success"
    return mech, ref


def test_four_bar_converges_to_pinclear_reference(four_bar_ref):
    """q(0.5 s) of MuJoCo approaches pinclear's tight reference at second order: twice the
    study's constant at h = 1e-3, and halving h must divide the error by more than 3 (order > 1.58)."""
    mech, ref = four_bar_ref
    errs = []
    for h in (1e-3, 5e-4):
        q, v, n, _ = mp.MujocoScene(mech, h).run(0.5)
        assert n == round(0.5 / h)
        errs.append(float(np.max(np.abs(pin.difference(mech.model, ref.q[-1], q)))))
    assert errs[0] < 2.2 * 1e-3 ** 2, errs          # 2 x (C ~ 1.1) h^2
    assert errs[1] < errs[0] / 3, errs


def test_four_bar_conserves_energy_and_closure(four_bar_ref):
    """No drive, no damping: the mechanical energy (Pinocchio's, on the mapped state) is constant.
    MuJoCo's soft constraints dissipate O(h^2): below 1e-6 relative at h = 5e-4 over 0.5 s (study:
    3.6e-8 absolute on |E| ~ 0.1 J), falling with h; the closure residual ~ tc^2 |dJ/dt v| stays
    below 1e-8 m at h = 5e-4 (study: 4.5e-10 at t_end, 1.8e-7 max at h = 1e-3)."""
    mech, _ = four_bar_ref
    changes = []
    for h in (1e-3, 5e-4):
        sc = mp.MujocoScene(mech, h)
        E0 = mp.energy(mech.model, sc.q0, sc.v0)
        worst = [0.0]
        q, v, _, _ = sc.run(0.5, samples=50, monitor=lambda t, q, v: worst.__setitem__(
            0, max(worst[0], mp.closure_residual(mech, q))))
        changes.append(abs(mp.energy(mech.model, q, v) - E0) / abs(E0))
    assert changes[1] < 1e-6 and changes[1] < changes[0] / 3, changes
    assert worst[0] < 1e-7 * (5e-4 / 1e-3) ** 2 * 4, worst


def test_q_layout_matches_pinocchio_kinematics_four_ups_upu():
    """At configurations away from q0, MuJoCo's bodies and closure sites (from the mapped qpos)
    sit where Pinocchio puts the joints and frames: joint order, axes and placements agree; the
    map is a bijection on q and v."""
    mech = _load("four_ups_upu")
    sc = mp.MujocoScene(mech, 1e-3)
    model, data = mech.model, mech.model.createData()
    rng = np.random.default_rng(3)
    for _ in range(3):
        q = mech.q0 + 0.2 * rng.standard_normal(model.nq)
        v = rng.standard_normal(model.nv)
        sc.qmap.to_mujoco(q, v, sc.d.qpos, sc.d.qvel)
        mujoco.mj_kinematics(sc.m, sc.d)
        pin.framesForwardKinematics(model, data, q)
        for j in range(1, model.njoints):
            # the body a joint moves (named after its link: pinclear.io.export_mjcf)
            bid = sc.m.jnt_bodyid[mujoco.mj_name2id(sc.m, mujoco.mjtObj.mjOBJ_JOINT, model.names[j])]
            assert np.allclose(sc.d.xpos[bid], data.oMi[j].translation, atol=1e-12)
            assert np.allclose(sc.d.xmat[bid].reshape(3, 3), data.oMi[j].rotation, atol=1e-12)
        for c in mech.closures:
            for fid in (c.f1, c.f2):
                sid = [i for i in range(sc.m.nsite)
                       if mujoco.mj_id2name(sc.m, mujoco.mjtObj.mjOBJ_SITE, i).endswith("_" + model.frames[fid].name)]
                assert sid
                assert np.allclose(sc.d.site_xpos[sid[0]], data.oMf[fid].translation, atol=1e-12)
        q2, v2 = sc.qmap.to_pinocchio(sc.d.qpos, sc.d.qvel)
        assert np.array_equal(q2, q) and np.array_equal(v2, v)


def _free_ball_mech():
    """A free-flying body carrying a ball-jointed body carrying a hinged one (no closures)."""
    model = pin.Model()
    rng = np.random.default_rng(7)

    def inertia():
        # a box (a physical inertia: principal moments obey the triangle inequality), turned
        m, (a, b, c) = 1.0 + rng.random(), 0.1 + 0.3 * rng.random(3)
        d = m / 12 * np.array([b * b + c * c, a * a + c * c, a * a + b * b])
        R = pin.exp3(rng.standard_normal(3))
        return pin.Inertia(m, rng.standard_normal(3) * 0.1, R @ np.diag(d) @ R.T)
    j1 = model.addJoint(0, pin.JointModelFreeFlyer(), pin.SE3.Identity(), "free")
    model.appendBodyToJoint(j1, inertia(), pin.SE3.Identity())
    j2 = model.addJoint(j1, pin.JointModelSpherical(), pin.SE3(pin.rpy.rpyToMatrix(0.3, -0.2, 0.5), np.array([0.2, 0.1, -0.3])), "ball")
    model.appendBodyToJoint(j2, inertia(), pin.SE3.Identity())
    j3 = model.addJoint(j2, pin.JointModelRevoluteUnaligned(np.array([0.6, 0.0, 0.8])),
                        pin.SE3(pin.rpy.rpyToMatrix(-0.4, 0.1, 0.2), np.array([0.0, 0.3, 0.1])), "hinge")
    model.appendBodyToJoint(j3, inertia(), pin.SE3.Identity())
    model.gravity.linear = np.array([0.0, 0.0, -9.81])
    return Mechanism(model, "free_ball", [], [], [])


def test_quaternion_mapping_against_pinocchio():
    """Free and ball joints: Pinocchio's (x, y, z, w) quaternions and body-frame free-flyer
    velocity map to MuJoCo's (w, x, y, z) and world-frame linear velocity; then MuJoCo's poses
    equal Pinocchio's, its kinetic energy (MuJoCo's mass matrix from the translated inertias) equals Pinocchio's, and its generalized gravity force equals Pinocchio's."""
    mech = _free_ball_mech()
    model, data = mech.model, mech.model.createData()
    sc = mp.MujocoScene(mech, 1e-3, q0=pin.neutral(model), v0=np.zeros(model.nv))
    rng = np.random.default_rng(11)
    for _ in range(4):
        q = pin.randomConfiguration(model, -np.ones(model.nq), np.ones(model.nq))
        v = rng.standard_normal(model.nv)
        sc.qmap.to_mujoco(q, v, sc.d.qpos, sc.d.qvel)
        mujoco.mj_forward(sc.m, sc.d)
        pin.forwardKinematics(model, data, q, v)
        for j in range(1, model.njoints):
            # the body a joint moves (named after its link: pinclear.io.export_mjcf)
            bid = sc.m.jnt_bodyid[mujoco.mj_name2id(sc.m, mujoco.mjtObj.mjOBJ_JOINT, model.names[j])]
            assert np.allclose(sc.d.xpos[bid], data.oMi[j].translation, atol=1e-12)
            assert np.allclose(sc.d.xmat[bid].reshape(3, 3), data.oMi[j].rotation, atol=1e-12)
        mujoco.mj_energyVel(sc.m, sc.d)          # 1/2 qvel^T M qvel with MuJoCo's mass matrix
        ke_mj = sc.d.energy[1]
        ke_pin = pin.computeKineticEnergy(model, data, q, v)
        assert ke_mj == pytest.approx(ke_pin, rel=1e-10)
        # generalized gravity: MuJoCo's bias at zero velocity, mapped to Pinocchio's v layout
        sc.d.qvel[:] = 0.0
        mujoco.mj_forward(sc.m, sc.d)
        g_pin = pin.computeGeneralizedGravity(model, data, q)
        # power of gravity along a random velocity is layout-independent
        w = rng.standard_normal(model.nv)
        qpos_tmp, qvel_w = np.zeros(sc.m.nq), np.zeros(sc.m.nv)
        sc.qmap.to_mujoco(q, w, qpos_tmp, qvel_w)
        assert qvel_w @ sc.d.qfrc_bias == pytest.approx(w @ g_pin, rel=1e-10, abs=1e-12)
        q2, v2 = sc.qmap.to_pinocchio(*_mapped(sc, q, v))
        assert np.allclose(pin.difference(model, q, q2), 0.0, atol=1e-14)
        assert np.allclose(v2, v, atol=1e-13)


def _mapped(sc, q, v):
    qpos, qvel = np.zeros(sc.m.nq), np.zeros(sc.m.nv)
    sc.qmap.to_mujoco(q, v, qpos, qvel)
    return qpos, qvel


def test_driven_limbs_follow_their_laws_four_ups_upu():
    """The 4UPS-UPU's five prismatic drives follow the inverse-kinematics laws: the joint
    equality on the clock with the lag compensation keeps |q_P - f(t)| below 1.5e-7 at h = 1e-3
    (study: 1.0e-7 at h = 1e-3, 4.1e-7 at 2e-3; 9x larger without the compensation), the four
    spherical closures hold and q(0.2 s) agrees with pinclear's reference to the study's
    second-order bound."""
    mech = _load("four_ups_upu")
    T, h = 0.2, 1e-3
    sc = mp.MujocoScene(mech, h)
    iq = [d.idx_q for d in mech.drives]
    dd = mech.driverows.create_data()
    worst = {"drive": 0.0, "closure": 0.0}

    def monitor(t, q, v):
        worst["drive"] = max(worst["drive"], float(np.max(np.abs(q[iq] - mech.driverows.values(t, dd)[0]))))
        worst["closure"] = max(worst["closure"], mp.closure_residual(mech, q))
    q, v, n, _ = sc.run(T, samples=int(round(T / h)), monitor=monitor)
    assert worst["drive"] < 1.5e-7, worst
    assert worst["closure"] < 5e-8, worst
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        ref = pinclear.simulate(mech, T, method="projection", integrator="DOP853", rtol=1e-12, atol=1e-14,
                                t_eval=[0.0, T])
    err = float(np.max(np.abs(pin.difference(mech.model, ref.q[-1], q))))
    assert err < 2 * 1.8 * h ** 2, err          # study over 0.5 s: 1.82e-6 at h = 1e-3


def test_peer_interface_and_bad_input(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)         # MuJoCo's default handler would log into the cwd
    peer = mp.make_peer()
    assert peer.name == "mujoco" and {"four_bar", "a02_nfourbar_2", "four_ups_upu"} <= peer.scenes
    assert all(a > b for a, b in zip(peer.tols, peer.tols[1:]))
    r = peer.run(str(ROOT / "urdf" / "four_bar.yaml"), 0.1, 1e-3)
    assert r["status"] == "success" and r["q_final"].shape == (3,) and r["steps"] == 100
    assert r["energy_drift"] < 1e-5 and r["max_residual"] < 1e-6
    with pytest.raises(InputError, match="time step"):
        peer.run(str(ROOT / "urdf" / "four_bar.yaml"), 0.1, -1.0)
    with pytest.raises(InputError, match="integrator"):
        mp.MujocoScene(_load("four_bar"), 1e-3, integrator="RK45")
    assert mp.make_peer("implicitfast").name == "mujoco_implicitfast"
    # MuJoCo resets a blown-up state by itself and goes on: the scene must notice
    sc = mp.MujocoScene(_load("four_bar"), 1e-3)
    assert not sc.unstable()
    sc.d.qvel[:] = 1e12                      # above MuJoCo's mjMAXVAL
    sc.run(0.01)
    assert sc.unstable() and "unstable" in sc.warnings[0]
    assert not (tmp_path / "MUJOCO_LOG.TXT").exists()      # warnings collected, not logged
    # a closure type MuJoCo has no equality for is refused, naming the valid ones
    res = peer.run(str(ROOT / "urdf" / "three_upru_up.yaml"), 0.01, 1e-3)
    assert res["status"] == "failed" and "supported" in res["message"]
