"""Paper 003 3-UPRU+UP polishing robot: model files, kinematics, mobility, dynamics.

References are independent of the code under test: the circle law itself (round trip
through a Newton solve of the closed chain), Pinocchio's frame Jacobians (limb rates),
paper 003's Table 2, the energy balance, and virtual work on the closed-loop manifold
(static drive forces = dV/dL by finite differences of the potential energy).
"""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest
import yaml
from scipy.integrate import cumulative_simpson

import pinclear
from pinclear.mechanisms import three_upru_up as mod
from pinclear.model import kinematics
from pinclear.model.drives import Drive
from pinclear.model.timelaws import Constant
from tests.model_files import assert_same_data, assert_same_urdf

ROOT = Path(__file__).resolve().parents[2]
SIDECAR = ROOT / "urdf" / "three_upru_up.yaml"
URDF = ROOT / "urdf" / "three_upru_up.urdf"


@pytest.fixture(scope="module")
def mech():
    return pinclear.load(SIDECAR)


def _platform_error(M, Mref):
    return float(np.max(np.abs(pin.log6(Mref.actInv(M)).vector)))


# ----------------------------------------------------------------------------- files and parameters
def test_committed_files_match_generator():
    # by value: structure and strings exactly, numbers within the bound of tests/model_files.py (the
    # last bits of the generator's trigonometry and products depend on the build)
    assert_same_urdf(mod.urdf_text(), URDF, "urdf/three_upru_up.urdf (stale? run write_urdf)")
    sc = yaml.safe_load(SIDECAR.read_text())
    # the table's masses are computed, then rounded to 6 decimals
    assert_same_data(mod.parameters(), sc["parameters"], "parameters", rounded=True)
    assert {c["name"]: c["type"] for c in sc["closures"]} == {"U6": "universal", "U7": "universal",
                                                               "P_UP": "prismatic"}
    for p in sc["parameters"]:
        assert p["source"].startswith(("paper 003", "reconstructed:")), p


def test_table2_masses_and_inertias(mech):
    """Paper 003 Table 2 values reach the model: limb bodies (inertia about their centre of
    mass, limb axis = smallest moment), platform + UP branch + the 118.5 kg external load."""
    model = mech.model

    def body(link):
        return model.inertias[model.frames[model.getFrameId(link)].parentJoint]

    for i in mod.LIMBS:
        for link, m, J in (("cyl", 70.8, (14.264, 14.598, 0.203)), ("rod", 29.85, (5.94, 5.94, 0.02)),
                           ("rot", 1.3, (0.004, 0.004, 0.004))):
            I = body(f"{link}{i}")
            assert I.mass == pytest.approx(m)
            assert sorted(np.linalg.eigvalsh(I.inertia)) == pytest.approx(sorted(J), abs=1e-12)
            assert I.inertia[2, 2] == pytest.approx(J[2])          # z = limb axis in the zero pose
    P = body("moving_platform")
    assert P.mass == pytest.approx(138.239 + 118.5)
    # load as a point mass at M0 = the platform's centre of mass: inertia about it unchanged
    assert np.diag(P.inertia) == pytest.approx([35.509, 35.478, 1.452], abs=1e-12)
    assert P.lever == pytest.approx(-mod.platform_point(1))
    # guide rail: aluminium box section 0.40 x 0.10 x 0.08, wall 0.01
    assert body("guide_rail").mass == pytest.approx(2700 * 0.40 * (0.10 * 0.08 - 0.08 * 0.06))
    q = kinematics.assemble(mech, mech.q0)
    assert np.linalg.eigvalsh(pin.crba(model, model.createData(), q)).min() > 0


# ----------------------------------------------------------------------------- kinematics
def test_circle_law():
    T = 2 * math.pi * 0.2 / 0.05
    assert mod.PERIOD == pytest.approx(T)
    for t in np.linspace(0, T, 9):
        p, v, _ = mod.platform_position(t)
        assert np.hypot(p[0] - mod.XC, p[1] - mod.YC) == pytest.approx(0.2)
        assert p[2] == mod.Z0
        assert np.linalg.norm(v) == pytest.approx(0.05)
        M = mod.platform_pose(t)
        # UP branch: the platform axis passes through the base centre; no spin about it
        assert M.rotation[:, 2] == pytest.approx(p / np.linalg.norm(p), abs=1e-14)
        assert M.rotation[0, 1] == pytest.approx(0.0, abs=1e-15)     # R = Rx(a) Ry(b): x0 stays in xz


@pytest.mark.parametrize("t", [1.0, 6.3, 11.0, 17.5, 24.0])
def test_ik_round_trip(t):
    model = mod._model(str(URDF))
    guess = mod.config_vector(model, mod.ik_configuration(0.0))
    q, M = mod.forward_kinematics(mod.limb_lengths(t)[0], guess=guess, model=model)
    assert _platform_error(M, mod.platform_pose(t)) < 1e-9


@pytest.mark.parametrize("t", [0.4, 9.1, 20.2])
def test_limb_rates_match_closed_chain_velocity(t):
    """Exact jets vs Pinocchio: moving the closed chain with the platform twist of the law
    (omega from finite differences of the orientation, to 1e-9) gives the IK limb rates."""
    model = mod._model(str(URDF))
    ch = mod.chain(model)
    q = mod.config_vector(model, mod.ik_configuration(t))
    _, J = ch.residual_jacobian(q)
    Jp = pin.getFrameJacobian(model, ch.data, model.getFrameId("platform"), pin.LOCAL_WORLD_ALIGNED)
    h = 1e-4
    Rm, Rp = mod.platform_pose(t - h).rotation, mod.platform_pose(t + h).rotation
    w = pin.log3(Rp @ Rm.T) / (2 * h)
    twist = np.concatenate([mod.platform_position(t)[1], w])
    A = np.vstack([J, Jp])
    b = np.concatenate([np.zeros(J.shape[0]), twist])
    v = np.linalg.lstsq(A, b, rcond=None)[0]
    assert np.abs(A @ v - b).max() < 1e-8
    L, Ld, Ldd = mod.limb_lengths(t)
    iv = [model.joints[model.getJointId(f"P{i}")].idx_v for i in mod.LIMBS]
    assert v[iv] == pytest.approx(Ld, abs=1e-9)
    fd = (mod.limb_lengths(t + h)[1] - mod.limb_lengths(t - h)[1]) / (2 * h)
    assert Ldd == pytest.approx(fd, abs=1e-10)
    assert mod.limb_law(t, 2) == (L[1], Ld[1], Ldd[1])


# ----------------------------------------------------------------------------- mobility, assembly
def test_mobility_at_generic_configuration(mech):
    L = mod.limb_lengths(5.0)[0] + np.array([0.021, -0.013, 0.008])
    q, _ = mod.forward_kinematics(L, model=mech.model)
    mob = kinematics.mobility(mech, q)
    assert mob["mobility"] == 3
    assert mob["rank"] == mob["rows"] == 13
    assert mob["redundant_rows"] == []
    J = kinematics.jacobian(mech, mech.workspace(), q, with_drives=True)
    s = np.linalg.svd(J, compute_uv=False)
    assert J.shape == (16, 16) and s[0] / s[-1] < 1e3


def test_not_singular_along_the_circle(mech):
    ws = mech.workspace()
    model = mech.model
    for t in np.linspace(0, mod.PERIOD, 13):
        q = mod.config_vector(model, mod.ik_configuration(t))
        J = kinematics.jacobian(mech, ws, q, t=t, with_drives=True)
        s = np.linalg.svd(J, compute_uv=False)
        assert s[0] / s[-1] < 100, t


def test_up_branch_leaves_two_tilts_and_the_slide(mech):
    """The platform twists the closures allow (at M0) are: slide along the UP axis and tilts
    about axes through the base centre; no spin about the axis (paper 003: 3 DoF)."""
    q = kinematics.assemble(mech, mech.q0)
    ws = mech.workspace()
    J = kinematics.jacobian(mech, ws, q)
    N = np.linalg.svd(J)[2][np.linalg.matrix_rank(J):].T
    data = mech.model.createData()
    pin.computeJointJacobians(mech.model, data, q)
    pin.updateFramePlacements(mech.model, data)
    T = pin.getFrameJacobian(mech.model, data, mech.platform_frame, pin.LOCAL_WORLD_ALIGNED) @ N
    U, s, _ = np.linalg.svd(T, full_matrices=False)
    B = U[:, s > 1e-9 * s[0]]
    assert B.shape[1] == 3

    def inside(tw):
        return np.linalg.norm(tw - B @ (B.T @ tw)) < 1e-9 * np.linalg.norm(tw)

    p = mod.platform_pose(0.0).translation
    n = p / np.linalg.norm(p)
    assert inside(np.concatenate([n, np.zeros(3)]))                     # slide
    for w in (np.array([1.0, 0, 0]), np.cross(n, [1.0, 0, 0])):          # tilts about the base centre
        assert inside(np.concatenate([np.cross(w, p), w]))
    assert not inside(np.concatenate([np.zeros(3), n]))                 # spin about the axis


def test_assembled_residual(mech):
    q = kinematics.assemble(mech, mech.q0)
    ws = mech.workspace()
    assert np.abs(kinematics.closure_residual(mech, ws, q, with_drives=True)).max() < 1e-10
    pin.framesForwardKinematics(mech.model, ws.data, q)
    assert _platform_error(ws.data.oMf[mech.platform_frame], mod.platform_pose(0.0)) < 1e-10
    r, _ = mod.chain(mech.model).residual_jacobian(q, mod.limb_lengths(0.0)[0])
    assert np.abs(r).max() < 1e-10


# ----------------------------------------------------------------------------- dynamics
@pytest.fixture(scope="module")
def period(mech):
    return pinclear.simulate(mech, mod.PERIOD, rtol=1e-8, dt_out=0.05)


def test_one_period_tracks_the_circle(period):
    tr = period
    assert tr.status == "success", tr.message
    assert tr.t[-1] == pytest.approx(mod.PERIOD)
    assert np.max(tr.residual) < 1e-8
    te = tr.tracking_error()
    assert te["platform_position"] < 1e-6 and te["platform_rotation"] < 1e-6
    # the slider really slides in the UP guide (what the clearance study needs)
    model = period.mech.model
    data = model.createData()
    s = []
    for q in tr.q[::20]:
        pin.framesForwardKinematics(model, data, q)
        s.append(np.linalg.norm(data.oMf[model.getFrameId("platform")].translation))
    assert max(s) - min(s) > 0.02


def test_drive_power_equals_energy_rate(period, mech):
    tr = period
    Ld = np.array([mod.limb_lengths(t)[1] for t in tr.t])
    P = sum(tr.lam[f"drive{i}"] * Ld[:, k] for k, i in enumerate(mod.LIMBS))
    data = mech.model.createData()
    E = np.array([pin.computeKineticEnergy(mech.model, data, q, v) + pin.computePotentialEnergy(mech.model, data, q)
                  for q, v in zip(tr.q, tr.v)])
    W = cumulative_simpson(P, x=tr.t, initial=0.0)
    scale = np.max(np.abs(E - E[0]))
    assert scale > 0.1                   # Z is constant: only the limbs tilt against gravity
    assert np.max(np.abs(W - (E - E[0]))) < 1e-5 * scale


def test_static_drive_forces_balance_gravity_by_virtual_work(mech):
    """Platform held still at the pose of t = 7 s: drive multipliers = dV/dL_i along the
    closed-loop manifold (central differences over forward-kinematics solutions)."""
    L0 = mod.limb_lengths(7.0)[0]
    q0, _ = mod.forward_kinematics(L0, model=mech.model)
    drives = [Drive(d.name, d.joint, d.idx_q, d.idx_v, Constant(float(L0[k]))) for k, d in enumerate(mech.drives)]
    still = mech.replace(drives=drives, q0=q0, v0=np.zeros(mech.nv))
    tr = pinclear.simulate(still, 0.2, rtol=1e-10, dt_out=0.05)
    assert tr.status == "success", tr.message
    assert np.abs(tr.v).max() < 1e-8
    data = mech.model.createData()

    def V(L):
        q, _ = mod.forward_kinematics(L, guess=q0, model=mech.model)
        return pin.computePotentialEnergy(mech.model, data, q)

    h = 1e-5
    dV = np.array([(V(L0 + h * e) - V(L0 - h * e)) / (2 * h) for e in np.eye(3)])
    lam = np.array([tr.lam[f"drive{i}"] for i in mod.LIMBS])
    assert np.abs(dV).max() > 500.0
    for k in range(lam.shape[1]):
        assert lam[:, k] == pytest.approx(dV, abs=1e-5 * np.abs(dV).max())
    assert dV.sum() > 0                  # lengthening the limbs lifts the platform
