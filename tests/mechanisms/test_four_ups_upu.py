"""Paper 000 4UPS-UPU platform: model files, inverse/forward kinematics, mobility, dynamics.

References are independent of the code under test: the platform law itself (round trip
through a Newton solve of the closed chain), Pinocchio's frame Jacobians (limb rates),
density x volume (masses), the energy balance (drive power = d(kinetic + potential)/dt),
and virtual work on the closed-loop manifold (static drive forces = dV/dL by finite
differences of the potential energy over forward-kinematics solutions).
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
from pinclear.mechanisms import four_ups_upu as mod
from pinclear.model import kinematics
from pinclear.model.drives import Drive
from pinclear.model.timelaws import Constant
from tests.model_files import assert_same_data, assert_same_urdf

ROOT = Path(__file__).resolve().parents[2]
SIDECAR = ROOT / "urdf" / "four_ups_upu.yaml"
URDF = ROOT / "urdf" / "four_ups_upu.urdf"


@pytest.fixture(scope="module")
def mech():
    return pinclear.load(SIDECAR)


def _platform_error(M, Mref):
    return float(np.max(np.abs(pin.log6(Mref.actInv(M)).vector)))


# ----------------------------------------------------------------------------- files and parameters
def test_committed_files_match_generator():
    # by value: structure and strings exactly, numbers within the bound of tests/model_files.py (the
    # last bits of the generator's trigonometry and products depend on the build)
    assert_same_urdf(mod.urdf_text(), URDF, "urdf/four_ups_upu.urdf (stale? run write_urdf)")
    sc = yaml.safe_load(SIDECAR.read_text())
    # the table's masses are computed, then rounded to 6 decimals
    assert_same_data(mod.parameters(), sc["parameters"], "parameters", rounded=True)
    assert [c["name"] for c in sc["closures"]] == ["S2", "S3", "S4", "S5"]
    assert all(c["type"] == "spherical" for c in sc["closures"])
    for p in sc["parameters"]:
        assert p["source"].startswith(("paper 000", "reconstructed:")), p
    # paper 000, sec. 3.1: every rod's x axis points "downward along the rod", from the fixed
    # platform (X = 0) to the moving one (X = 1.1 m): gravity points from the first to the second
    g = np.asarray(sc["gravity"], float)
    assert np.linalg.norm(g) == pytest.approx(9.81) and g @ np.array([mod.X0, 0.0, 0.0]) == pytest.approx(9.81 * mod.X0)
    assert sc["baumgarte"] == {"alpha": 5.0, "beta": 5.0}            # eq. 31: zeta = xi = 5


def test_masses_from_dimensions(mech):
    model = mech.model
    tube = 7850 * math.pi / 4 * (0.070**2 - 0.050**2) * 0.60
    rod = 7850 * math.pi / 4 * 0.035**2 * 0.70
    disc = 2700 * math.pi * 0.25**2 * 0.03
    pins = 2 * 7850 * math.pi / 4 * 0.025**2 * 0.08

    def mass(link):
        return model.inertias[model.frames[model.getFrameId(link)].parentJoint].mass

    assert mass("rod3_lower") == pytest.approx(tube, rel=1e-12)
    assert mass("rod3_upper") == pytest.approx(rod, rel=1e-12)
    assert mass("moving_platform") == pytest.approx(disc, rel=1e-12)
    assert mass("cross4_base") == pytest.approx(pins, rel=1e-12)
    # no massless body in the tree, and a positive definite mass matrix
    assert min(I.mass for I in list(model.inertias)[1:]) > 0.1
    q = kinematics.assemble(mech, mech.q0)
    assert np.linalg.eigvalsh(pin.crba(model, model.createData(), q)).min() > 0


def test_geometry_from_paper():
    # paper 000 sec. 3.1: radii 0.65 / 0.71 / 0.202, U1 halfway between U2 and U3
    for i in (2, 3, 4, 5):
        assert np.linalg.norm(mod.base_point(i)) == pytest.approx(0.65)
        assert np.linalg.norm(mod.platform_point(i)) == pytest.approx(0.202)
    a1 = mod.base_point(1)
    assert np.linalg.norm(a1) == pytest.approx(0.71)
    bis = mod.base_point(2) / 0.65 + mod.base_point(3) / 0.65
    assert np.cross(a1, bis) == pytest.approx(np.zeros(3), abs=1e-15)
    assert a1 @ bis > 0
    # platform joints evenly spaced (72 deg)
    ang = sorted(math.atan2(mod.platform_point(i)[2], mod.platform_point(i)[1]) % (2 * math.pi) for i in mod.LIMBS)
    assert np.diff(ang + [ang[0] + 2 * math.pi]) == pytest.approx(np.full(5, 2 * math.pi / 5))


# ----------------------------------------------------------------------------- inverse / forward kinematics
@pytest.mark.parametrize("t", [0.1, 0.5, 0.93, 1.4, 1.77])
def test_ik_round_trip(t):
    model = mod._model(str(URDF))
    guess = mod.config_vector(model, mod.ik_configuration(0.0))
    L = mod.limb_lengths(t)[0]
    q, M = mod.forward_kinematics(L, guess=guess, model=model)
    assert _platform_error(M, mod.platform_pose(t)) < 1e-9
    # the law really is X = 1.1, Y = 0.05 sin(pi t), Z = 0.05 cos(pi t), no rotation
    assert M.translation == pytest.approx([1.1, 0.05 * math.sin(math.pi * t), 0.05 * math.cos(math.pi * t)], abs=1e-9)
    assert np.abs(M.rotation - np.eye(3)).max() < 1e-9


@pytest.mark.parametrize("t", [0.2, 0.71, 1.3])
def test_limb_rates_match_closed_chain_velocity(t):
    """dL/dt from the analytic IK = prismatic joint rates of the closed chain moving the
    platform with the law's velocity (Pinocchio frame Jacobians, least squares)."""
    model = mod._model(str(URDF))
    ch = mod.chain(model)
    q = mod.config_vector(model, mod.ik_configuration(t))
    _, J = ch.residual_jacobian(q)
    data = ch.data
    Jp = pin.getFrameJacobian(model, data, model.getFrameId("platform"), pin.LOCAL_WORLD_ALIGNED)
    _, pd, pdd = mod.platform_position(t)
    A = np.vstack([J, Jp])
    v = np.linalg.lstsq(A, np.concatenate([np.zeros(J.shape[0]), pd, np.zeros(3)]), rcond=None)[0]
    assert np.abs(A @ v - np.concatenate([np.zeros(J.shape[0]), pd, np.zeros(3)])).max() < 1e-12
    L, Ld, Ldd = mod.limb_lengths(t)
    iv = [model.joints[model.getJointId(f"P{i}")].idx_v for i in mod.LIMBS]
    assert v[iv] == pytest.approx(Ld, abs=1e-12)
    h = 1e-4
    fd = (mod.limb_lengths(t + h)[1] - mod.limb_lengths(t - h)[1]) / (2 * h)
    assert Ldd == pytest.approx(fd, abs=1e-8)
    assert mod.limb_law(t, 3) == (L[2], Ld[2], Ldd[2])


# ----------------------------------------------------------------------------- mobility, assembly
def test_mobility_at_generic_configuration(mech):
    L = mod.limb_lengths(0.3)[0] + np.array([0.011, -0.017, 0.013, 0.004, -0.009])
    q, _ = mod.forward_kinematics(L, model=mech.model)
    mob = kinematics.mobility(mech, q)
    assert mob["mobility"] == 5
    assert mob["rank"] == mob["rows"] == 12
    assert mob["redundant_rows"] == []
    # the five drives then fix the mechanism, far from a singularity
    J = kinematics.jacobian(mech, mech.workspace(), q, with_drives=True)
    s = np.linalg.svd(J, compute_uv=False)
    assert J.shape == (17, 17) and s[0] / s[-1] < 1e3


def test_not_singular_along_the_law(mech):
    ws = mech.workspace()
    for t in np.linspace(0, mod.PERIOD, 9):
        q = mod.config_vector(mech.model, mod.ik_configuration(t))
        J = kinematics.jacobian(mech, ws, q, t=t, with_drives=True)
        s = np.linalg.svd(J, compute_uv=False)
        assert s[0] / s[-1] < 200, t


def test_upu_limb_constrains_rotation_about_the_normal(mech):
    """Paper 000: the platform keeps 5 freedoms (X, Y, Z, beta, gamma); the UPU limb's one
    constraint is a couple normal to its four U axes, close to the fixed platform's normal X,
    so alpha is the dependent coordinate. Checked on the platform twists the closures allow."""
    q = kinematics.assemble(mech, mech.q0)
    model, data = mech.model, mech.model.createData()
    J = kinematics.jacobian(mech, mech.workspace(), q)
    N = np.linalg.svd(J)[2][np.linalg.matrix_rank(J):].T             # closure null space (17, 5)
    pin.computeJointJacobians(model, data, q)
    pin.updateFramePlacements(model, data)
    T = pin.getFrameJacobian(model, data, mech.platform_frame, pin.LOCAL_WORLD_ALIGNED) @ N
    U, s, _ = np.linalg.svd(T)
    assert np.sum(s > 1e-9 * s[0]) == 5
    wrench = U[:, 5]                                                  # reciprocal to all allowed twists
    assert np.linalg.norm(wrench[:3]) < 1e-9                          # a pure couple
    c = wrench[3:]
    axes = []
    for jn in ("U1_1", "U1_2", "U1_3", "U1_4"):
        jid = model.getJointId(jn)
        Jj = pin.getJointJacobian(model, data, jid, pin.LOCAL_WORLD_ALIGNED)
        axes.append(Jj[3:, model.joints[jid].idx_v])
    assert np.abs(np.array(axes) @ c).max() < 1e-9                   # normal to the four U axes
    assert abs(c[0]) > 0.9                                            # mostly about X: alpha
    for e in np.eye(6)[:3]:                                           # translations stay free
        assert abs(e @ wrench) < 1e-12


def test_assembled_residual(mech):
    q = kinematics.assemble(mech, mech.q0)
    ws = mech.workspace()
    assert np.abs(kinematics.closure_residual(mech, ws, q, with_drives=True)).max() < 1e-10
    pin.framesForwardKinematics(mech.model, ws.data, q)
    assert _platform_error(ws.data.oMf[mech.platform_frame], mod.platform_pose(0.0)) < 1e-10
    # core closures agree with the module's independent closure equations
    r, _ = mod.chain(mech.model).residual_jacobian(q, mod.limb_lengths(0.0)[0])
    assert np.abs(r).max() < 1e-10


# ----------------------------------------------------------------------------- dynamics
@pytest.fixture(scope="module")
def period(mech):
    return pinclear.simulate(mech, mod.PERIOD, rtol=1e-8, dt_out=0.01)


def test_one_period_tracks_the_law(period):
    tr = period
    assert tr.status == "success", tr.message
    assert tr.t[-1] == pytest.approx(mod.PERIOD)
    assert np.max(tr.residual) < 1e-8
    te = tr.tracking_error()
    assert te["platform_position"] < 1e-6 and te["platform_rotation"] < 1e-6
    assert set(tr.drive_forces()) == {f"drive{i}" for i in mod.LIMBS}


def test_drive_power_equals_energy_rate(period, mech):
    """Ideal closures do no work: the drives' power sum lam_i dL_i/dt integrates to the
    change of kinetic + potential energy (computed by Pinocchio from the samples)."""
    tr = period
    Ld = np.array([mod.limb_lengths(t)[1] for t in tr.t])
    P = sum(tr.lam[f"drive{i}"] * Ld[:, k] for k, i in enumerate(mod.LIMBS))
    data = mech.model.createData()
    E = np.array([pin.computeKineticEnergy(mech.model, data, q, v) + pin.computePotentialEnergy(mech.model, data, q)
                  for q, v in zip(tr.q, tr.v)])
    W = cumulative_simpson(P, x=tr.t, initial=0.0)
    scale = np.max(np.abs(E - E[0]))
    assert scale > 0.1                                    # limbs swing against gravity, platform moves
    err = np.max(np.abs(W - (E - E[0])))
    print("energy balance error", err, "of", scale)
    assert err < 1e-5 * scale


def test_static_drive_forces_balance_gravity_by_virtual_work(mech):
    """Platform held still at the pose of t = 0.4: the drive multipliers equal dV/dL_i, the
    derivative of the potential energy along the closed-loop manifold (central differences
    over forward-kinematics solutions: virtual work of the ideal closures is zero)."""
    L0 = mod.limb_lengths(0.4)[0]
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
    dV = np.array([(V(L0 + h * e) - V(L0 - h * e)) / (2 * h) for e in np.eye(5)])
    lam = np.array([tr.lam[f"drive{i}"] for i in mod.LIMBS])          # (5, samples)
    assert np.abs(dV).max() > 50.0                                    # a real load
    for k in range(lam.shape[1]):
        assert lam[:, k] == pytest.approx(dV, abs=1e-5 * np.abs(dV).max())
    # sign: gravity is +X (paper 000, sec. 3.1), the platform hangs below the fixed platform, so
    # lengthening the limbs lowers it and every body on them: V falls, the drives pull (dV/dL < 0)
    assert dV.sum() < 0
