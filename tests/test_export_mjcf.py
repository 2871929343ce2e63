"""pinclear export --mjcf: every bundled mechanism round-trips (export, import) to the same model,
and MuJoCo runs the exported file with first accelerations equal to pinclear's within MuJoCo's
constraint softness."""
from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

import pinclear
from pinclear import kinematics
from pinclear.export_mjcf import export_mjcf
from pinclear.importers import import_file
from pinclear.models import available


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


PASSIVE = [n for n in available() if n in ("four_bar", "four_bar_revolute", "a02_nfourbar_1", "a02_nfourbar_2",
                                           "a04_bricard", "parallelogram")]


@pytest.mark.parametrize("name", PASSIVE)
def test_mujoco_runs_the_export_and_agrees_at_rest(name, tmp_path):
    """At an assembled configuration at rest, MuJoCo's qacc equals pinclear's accelerations within
    MuJoCo's softness: the impedance d = 0.9999 adds R = (1 - d)/d diag(A) to the constraint
    problem, a relative change of 1e-4 of the constraint forces; 1e-3 of the largest
    acceleration is asserted. (At rest MuJoCo's missing dJ/dt v term is zero.)"""
    mujoco = pytest.importorskip("mujoco")
    mech = pinclear.load(name)
    q = kinematics.assemble(mech, mech.q0)
    xml, notes = export_mjcf(mech)
    assert not notes
    m = mujoco.MjModel.from_xml_string(xml)
    d = mujoco.MjData(m)
    for j in range(1, mech.model.njoints):
        jm = mech.model.joints[j]
        assert jm.nq == 1, "a 1-dof tree"
        jid = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, mech.model.names[j])
        d.qpos[m.jnt_qposadr[jid]] = q[jm.idx_q]
    mujoco.mj_forward(m, d)
    from pinclear.formulations import METHODS

    form = METHODS["lagrange"](mech)
    form.use_rows(kinematics.mobility(mech, q)["independent"])
    a = form.accelerations(0.0, q, np.zeros(mech.nv), np.zeros(mech.nz))
    a_mj = np.array([d.qacc[m.jnt_dofadr[mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, mech.model.names[j])]]
                     for j in range(1, mech.model.njoints)])
    a_pc = np.array([a[mech.model.joints[j].idx_v] for j in range(1, mech.model.njoints)])
    assert np.abs(a_mj - a_pc).max() <= 1e-3 * np.abs(a_pc).max()
