"""pinclear export --mjcf: every bundled mechanism round-trips (export, import) to the same model,
and MuJoCo runs the exported file with first accelerations equal to pinclear's within MuJoCo's
constraint softness."""
from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

import pinclear
from pinclear.core.models import available
from pinclear.io.export_mjcf import export_mjcf
from pinclear.io.importers import import_file
from pinclear.model import kinematics


@pytest.fixture(autouse=True)
def _in_a_temporary_folder(tmp_path, monkeypatch):
    """MuJoCo writes MUJOCO_LOG.TXT into the working folder when it warns: keep it out of the clone."""
    monkeypatch.chdir(tmp_path)


def _q_in(b, a, qa):
    """a's configuration qa laid out for b (joints matched by name)."""
    qb = np.zeros(b.model.nq)
    for j in range(1, a.model.njoints):
        A, B = a.model.joints[j], b.model.joints[b.model.getJointId(a.model.names[j])]
        qb[B.idx_q:B.idx_q + B.nq] = qa[A.idx_q:A.idx_q + A.nq]
    return qb


@pytest.mark.parametrize("name", available())
def test_round_trip_gives_the_same_model(name, tmp_path):
    """Masses, inertias, joint placements at random configurations and every closure row agree
    to 1e-12 after export and import (the closures MuJoCo cannot express come back from the
    pinclear annotation)."""
    a = pinclear.load(name)
    xml, _ = export_mjcf(a)
    (tmp_path / f"{name}.xml").write_text(xml)
    import_file(tmp_path / f"{name}.xml", tmp_path / "out")
    b = pinclear.load(tmp_path / "out" / f"{name}.yaml")
    assert sorted(a.model.names) == sorted(b.model.names)
    assert [c.type for c in a.closures] == [c.type for c in b.closures]
    da, db = a.model.createData(), b.model.createData()
    rng = np.random.default_rng(3)
    for _ in range(3):
        qa = pin.randomConfiguration(a.model, -np.ones(a.nq), np.ones(a.nq))
        qa = pin.integrate(a.model, qa, 0.1 * rng.standard_normal(a.nv))
        qb = _q_in(b, a, qa)
        pin.forwardKinematics(a.model, da, qa)
        pin.forwardKinematics(b.model, db, qb)
        for j in range(1, a.model.njoints):
            jb = b.model.getJointId(a.model.names[j])
            assert np.abs(da.oMi[j].homogeneous - db.oMi[jb].homogeneous).max() < 1e-12
            Ia, Ib = a.model.inertias[j], b.model.inertias[jb]
            assert abs(Ia.mass - Ib.mass) < 1e-12
            assert np.abs(Ia.lever - Ib.lever).max() < 1e-12 and np.abs(Ia.inertia - Ib.inertia).max() < 1e-12
        pa = kinematics.closure_residual(a, a.workspace(), qa)
        pb = kinematics.closure_residual(b, b.workspace(), qb)
        assert np.abs(pa - pb).max() < 1e-12


#: passive mechanisms whose every closure MuJoCo expresses; the clearance scenes' massless links
#: are merged into their child body (pinclear.io.export_mjcf._tree_xml); clr_ball's gravity is zero,
#: so it is tilted here to load the socket
PASSIVE = {n: [0.0, -9.81, 0.0] if n == "clr_ball" else None for n in available()
           if n in ("four_bar", "four_bar_revolute", "a02_nfourbar_1", "a02_nfourbar_2", "a04_bricard",
                    "parallelogram", "clr_ball", "clr_pendulum", "clr_hinge", "clr_planar_pendulum")}


def _dofs(m, mech):
    """MuJoCo's dof address of each of pinclear's joints (1-dof trees), in pinclear's joint order."""
    import mujoco

    out = []
    for j in range(1, mech.model.njoints):
        assert mech.model.joints[j].nq == 1, "a 1-dof tree"
        out.append(m.jnt_dofadr[mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, mech.model.names[j])])
    return np.array(out)


def _mujoco_at(mech, q, v=None):
    """(MjModel, MjData after mj_forward at (q, v), dof addresses) of the exported mechanism."""
    import mujoco

    xml, notes = export_mjcf(mech)
    assert not [n for n in notes if "mass" in n]
    m = mujoco.MjModel.from_xml_string(xml)
    d = mujoco.MjData(m)
    dofs = _dofs(m, mech)
    iv = np.array([mech.model.joints[j].idx_v for j in range(1, mech.model.njoints)])
    d.qpos[dofs] = q[iv]          # 1-dof joints: qpos and qvel share the dof addresses
    d.qvel[dofs] = (np.zeros(mech.nv) if v is None else v)[iv]
    mujoco.mj_forward(m, d)
    return m, d, dofs, iv


@pytest.mark.parametrize("name", [n for n in available() if n.startswith("clr_") or n in ("four_ups_upu", "rrr3")])
def test_mujoco_mass_matrix_and_bias_equal_pinocchio(name):
    """The exported tree is the same multibody: MuJoCo's joint-space mass matrix (mj_fullM) and
    bias forces (qfrc_bias = C v + g) equal Pinocchio's crba and nle at random (q, v), to 1e-11
    of their largest entry (two exact recursions in double precision). For the clearance scenes
    this is the proof that merging their massless links into the ball's body leaves the dynamics
    unchanged (MuJoCo refused them before: 'mass and inertia of moving bodies must be larger than
    mjMINVAL')."""
    mujoco = pytest.importorskip("mujoco")
    mech = pinclear.load(name)
    rng = np.random.default_rng(7)
    data = mech.model.createData()
    for _ in range(3):
        q = pin.integrate(mech.model, mech.q0, 0.3 * rng.standard_normal(mech.nv))
        v = rng.standard_normal(mech.nv)
        m, d, dofs, iv = _mujoco_at(mech, q, v)
        if name.startswith("clr_") and name != "clr_planar_pendulum":
            assert m.nbody == 2                    # world + the ball: five massless links merged
        M = np.zeros((m.nv, m.nv))
        mujoco.mj_fullM(m, d, M)
        Mp = pin.crba(mech.model, data, q)
        Mp = np.triu(Mp) + np.triu(Mp, 1).T
        Mp = Mp[np.ix_(iv, iv)]
        Mm = M[np.ix_(dofs, dofs)]
        assert np.abs(Mm - Mp).max() <= 1e-11 * np.abs(Mp).max()
        b = pin.nonLinearEffects(mech.model, data, q, v)[iv]
        assert np.abs(d.qfrc_bias[dofs] - b).max() <= 1e-11 * max(np.abs(b).max(), 1.0)


@pytest.mark.parametrize("name", PASSIVE)
def test_mujoco_runs_the_export_and_agrees_at_rest(name, tmp_path):
    """At an assembled configuration at rest, MuJoCo's qacc equals pinclear's accelerations within
    MuJoCo's softness: the impedance d = 0.9999 adds R = (1 - d)/d diag(A) to the constraint
    problem, a relative change of 1e-4 of the constraint forces, which move the accelerations by
    at most 1e-4 of the change the constraints make (|a - a_free|, a_free: Pinocchio's ABA without
    them); 1e-3 of max(|a|, |a_free|) is asserted. (At rest MuJoCo's missing dJ/dt v term is
    zero.)"""
    pytest.importorskip("mujoco")
    mech = pinclear.load(name, overrides={"gravity": PASSIVE[name]} if PASSIVE[name] else None)
    q = kinematics.assemble(mech, mech.q0)
    m, d, dofs, iv = _mujoco_at(mech, q)
    from pinclear.dynamics.formulations import METHODS

    form = METHODS["lagrange"](mech)
    form.use_rows(kinematics.mobility(mech, q)["independent"])
    a_pc = form.accelerations(0.0, q, np.zeros(mech.nv), np.zeros(mech.nz))[iv]
    a_free = pin.aba(mech.model, mech.model.createData(), q, np.zeros(mech.nv), np.zeros(mech.nv))[iv]
    assert np.abs(a_free).max() > 1.0                          # gravity loads the constraints
    assert np.abs(d.qacc[dofs] - a_pc).max() <= 1e-3 * max(np.abs(a_pc).max(), np.abs(a_free).max())


def _mujoco_run(mech, q0, v0, t_end, h):
    """MuJoCo's q(t_end) (pinclear's joint order) of the export at step h from (q0, v0); every
    drive's servo gets ctrl = f + 2 tc f' at the step's midpoint (the export's note)."""
    import mujoco

    xml, _ = export_mjcf(mech, h)
    m = mujoco.MjModel.from_xml_string(xml)
    d = mujoco.MjData(m)
    dofs = _dofs(m, mech)
    iv = np.array([mech.model.joints[j].idx_v for j in range(1, mech.model.njoints)])
    d.qpos[dofs], d.qvel[dofs] = q0[iv], v0[iv]
    act = [mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_ACTUATOR, f"drive_{x.name}") for x in mech.drives]
    dd = mech.driverows.create_data()
    for k in range(int(round(t_end / h))):
        if act:
            f = mech.driverows.values((k + 0.5) * h, dd)
            d.ctrl[act] = f[0] + 2 * (2 * h) * f[1]           # tc = 2 h (export_mjcf)
        mujoco.mj_step(m, d)
    assert not d.warning[mujoco.mjtWarning.mjWARN_BADQACC].number
    return d.qpos[dofs].copy(), iv


@pytest.mark.parametrize("name, h", [("clr_pendulum", 1e-3), ("clr_hinge", 1e-3), ("clr_planar_pendulum", 1e-3),
                                     ("rrr3", 1e-3), ("four_ups_upu", 5e-4)])
def test_mujoco_run_converges_to_pinclear_at_second_order(name, h):
    """A 0.1 s run of the export in MuJoCo (RK4) at steps h and h/2 against pinclear's run.

    Expected order 2: MuJoCo's closures are soft with time constant tc = 2 h, and their violation
    (forced by the dJ/dt v term MuJoCo's constraint rows leave out, and by the impedance's 1e-4
    leak) settles at O(tc^2); the drives' servos track f with an O(tc^2) error once fed ctrl =
    f + 2 tc f' (pinclear.io.export_mjcf._drives_xml); RK4's own O(h^4) is below both. Asserted:
    e(h) / e(h/2) within 2^(2 +- 0.3), and the Richardson extrapolation q(h/2) + (q(h/2) - q(h))/3
    nearer pinclear's q than a quarter of e(h/2) (MuJoCo converges to pinclear's motion, not to
    another). pinclear's own error (rtol 1e-11 against 1e-12) is checked to be below 1% of e(h/2)."""
    pytest.importorskip("mujoco")
    mech = pinclear.load(name)
    ws = mech.workspace()
    q0 = kinematics.assemble(mech, mech.q0, ws=ws)
    v0 = kinematics.consistent_velocity(mech, q0, mech.v0, ws=ws)
    T = 0.1
    ref = {rtol: pinclear.simulate(mech, T, q0=q0, v0=v0, rtol=rtol, t_eval=np.array([0.0, T])).q[-1]
           for rtol in (1e-11, 1e-12)}
    a, iv = _mujoco_run(mech, q0, v0, T, h)
    b, _ = _mujoco_run(mech, q0, v0, T, h / 2)
    r = ref[1e-12][iv]
    e1, e2 = np.abs(a - r).max(), np.abs(b - r).max()
    assert np.abs(ref[1e-11] - ref[1e-12]).max() < 0.01 * e2
    assert np.abs(r - q0[iv]).max() > 100 * e2                   # it moved far more than the errors
    assert 2 ** 1.7 < e1 / e2 < 2 ** 2.3
    assert np.abs(b + (b - a) / 3 - r).max() < 0.25 * e2


OFFSET_CHAIN = """<?xml version="1.0"?>
<robot name="offset_chain">
  <link name="world"/>
  <joint name="a" type="revolute"><parent link="world"/><child link="l1"/>
    <origin xyz="0.1 -0.2 0.3" rpy="0.3 -0.5 0.7"/><axis xyz="0.6 0 0.8"/>
    <limit lower="-10" upper="10" effort="1" velocity="1"/></joint>
  <link name="l1"/>
  <joint name="b" type="prismatic"><parent link="l1"/><child link="l2"/><origin xyz="0.2 0.1 -0.1" rpy="-0.4 0.2 1.1"/>
    <axis xyz="0 1 0"/><limit lower="-10" upper="10" effort="1" velocity="1"/></joint>
  <link name="l2"/>
  <joint name="c" type="revolute"><parent link="l2"/><child link="body"/>
    <origin xyz="-0.3 0.05 0.2" rpy="0.9 0.1 -0.6"/><axis xyz="0 0 1"/>
    <limit lower="-10" upper="10" effort="1" velocity="1"/></joint>
  <link name="body"><inertial><origin xyz="0.1 0.02 -0.03" rpy="0.2 0.3 0.4"/><mass value="1.5"/>
    <inertia ixx="0.02" ixy="0.001" ixz="-0.002" iyy="0.03" iyz="0.0015" izz="0.025"/></inertial></link>
  <joint name="d" type="revolute"><parent link="body"/><child link="tip"/><origin xyz="0.4 0 0" rpy="0 0.3 0"/>
    <axis xyz="0 1 0"/><limit lower="-10" upper="10" effort="1" velocity="1"/></joint>
  <link name="tip"><inertial><origin xyz="0.2 0 0" rpy="0 0 0"/><mass value="0.5"/>
    <inertia ixx="0.001" ixy="0" ixz="0" iyy="0.007" iyz="0" izz="0.007"/></inertial></link>
</robot>
"""


def test_massless_links_off_their_child_merge_exactly(tmp_path):
    """Two massless links with general placements (rotated and shifted joint frames, an unaligned
    axis, a slide between two hinges) merge into the massive body below them: MuJoCo's M and bias
    equal Pinocchio's at random (q, v), the massive bodies sit where Pinocchio puts them, and the
    round trip (the import splits the three-joint body into named massless links again) gives
    the same massive-body placements, masses and inertias."""
    mujoco = pytest.importorskip("mujoco")
    (tmp_path / "offset_chain.urdf").write_text(OFFSET_CHAIN)
    (tmp_path / "offset_chain.yaml").write_text("name: offset_chain\nurdf: offset_chain.urdf\n"
                                               "gravity: [0.3, -9.81, 0.5]\n")
    mech = pinclear.load(tmp_path / "offset_chain.yaml")
    xml, notes = export_mjcf(mech)
    assert not notes and 'data="l1"' in xml and 'data="l2"' in xml
    rng = np.random.default_rng(11)
    data = mech.model.createData()
    for _ in range(3):
        q = rng.uniform(-1, 1, mech.nq)
        v = rng.standard_normal(mech.nv)
        m, d, dofs, iv = _mujoco_at(mech, q, v)
        assert m.nbody == 3                                   # world, body (a, b, c), tip
        M = np.zeros((m.nv, m.nv))
        mujoco.mj_fullM(m, d, M)
        Mp = pin.crba(mech.model, data, q)
        Mp = (np.triu(Mp) + np.triu(Mp, 1).T)[np.ix_(iv, iv)]
        assert np.abs(M[np.ix_(dofs, dofs)] - Mp).max() <= 1e-11 * np.abs(Mp).max()
        b = pin.nonLinearEffects(mech.model, data, q, v)[iv]
        assert np.abs(d.qfrc_bias[dofs] - b).max() <= 1e-11 * np.abs(b).max()
        pin.forwardKinematics(mech.model, data, q)
        for name in ("body", "tip"):
            j = mech.model.frames[mech.model.getFrameId(name)].parentJoint
            X = data.oMi[j]
            bid = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, name)
            assert np.abs(d.xpos[bid] - X.translation).max() < 1e-12
            assert np.abs(d.xmat[bid].reshape(3, 3) - X.rotation).max() < 1e-12
    (tmp_path / "x.xml").write_text(xml)
    import_file(tmp_path / "x.xml", tmp_path / "out")
    back = pinclear.load(tmp_path / "out" / "offset_chain.yaml")
    assert sorted(back.model.names) == sorted(mech.model.names)
    assert {f.name for f in back.model.frames} >= {"l1", "l2", "body", "tip"}
    q = rng.uniform(-1, 1, mech.nq)
    db = back.model.createData()
    pin.forwardKinematics(mech.model, data, q)
    pin.forwardKinematics(back.model, db, _q_in(back, mech, q))
    for name in ("c", "d"):
        ja, jb = mech.model.getJointId(name), back.model.getJointId(name)
        assert np.abs(data.oMi[ja].homogeneous - db.oMi[jb].homogeneous).max() < 1e-12
        Ia, Ib = mech.model.inertias[ja], back.model.inertias[jb]
        assert abs(Ia.mass - Ib.mass) < 1e-12 and np.abs(Ia.inertia - Ib.inertia).max() < 1e-12
