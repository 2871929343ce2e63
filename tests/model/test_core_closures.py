"""Closure types on a spatial two-branch tree (tests/data/core_two_branch.*).

References, all independent of pinclear's compiled kernels:
- residuals recomputed here from Pinocchio's frame placements and the closure definitions;
- Jacobians against central finite differences of the residual along pin.integrate;
- acceleration bias against finite differences of J(q(s)) v along q(s) = integrate(q, s v),
  a motion of zero joint acceleration, so J a + bias = d2 Phi/dt2 is checked at a = 0 and,
  the rows being affine in a, everywhere;
- each closure alone, assembled: the relative motions left free by the null space of its
  Jacobian are exactly those of the ideal joint (no more, no less).
"""
from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

import pinclear
from pinclear.model import kinematics
from pinclear.model.closures import Closure
from tests.helpers import DATA

ROWS = {"spherical": 3, "revolute": 5, "universal": 4, "prismatic": 5, "cylindrical": 4, "weld": 6,
        "planar_point": 2, "distance": 1}
TYPE_OF = {"S": "spherical", "R": "revolute", "U": "universal", "P": "prismatic", "C": "cylindrical",
           "W": "weld", "PP": "planar_point", "D": "distance"}


@pytest.fixture(scope="module")
def tree():
    return pinclear.load(DATA / "core_two_branch.yaml")


def _spherical_root(mech):
    """The same tree hanging from a spherical joint instead of the fixed ground (quaternion
    coordinates: nq = nv + 1 + 1), with the closures' frames copied onto it."""
    urdf = DATA / "core_two_branch.urdf"
    model = pin.buildModelFromUrdf(str(urdf), pin.JointModelSpherical())
    model.gravity.linear = mech.model.gravity.linear
    closures = []
    for c in mech.closures:
        ids = []
        for fid, fname in ((c.f1, c.frame1), (c.f2, c.frame2)):
            fr = mech.model.frames[fid]
            joint = mech.model.names[fr.parentJoint]
            jid = model.getJointId(joint)
            ids.append(model.addFrame(pin.Frame(fname, jid, fr.placement, pin.FrameType.OP_FRAME)))
        closures.append(Closure(c.name, c.type, c.frame1, c.frame2, ids[0], ids[1], normal=c.normal,
                                length=c.length))
    return pinclear.Mechanism(model, "core_two_branch_spherical_root", closures, [], [])


def _subset(mech, names):
    return mech.replace(closures=[c for c in mech.closures if c.name in names])


def _phi(mech, ws, q):
    return kinematics.closure_residual(mech, ws, q)


def _J(mech, ws, q):
    return kinematics.jacobian(mech, ws, q)


def _random_state(model, seed):
    """A reproducible configuration on the manifold (pin.randomConfiguration draws from
    Pinocchio's own unseeded generator) and a velocity."""
    rng = np.random.default_rng(seed)
    q = pin.integrate(model, pin.neutral(model), rng.uniform(-1.0, 1.0, model.nv))
    return q, rng.standard_normal(model.nv)


# ---------------------------------------------------------------------------- row counts
def test_row_counts_and_names(tree):
    assert [c.nrows for c in tree.closures] == [ROWS[TYPE_OF[c.name]] for c in tree.closures]
    assert tree.m_closures == sum(ROWS.values()) == 30
    names = tree.row_names()
    assert len(names) == 30 and len(set(names)) == 30
    for c in tree.closures:
        assert c.type == TYPE_OF[c.name]
        assert all(n.startswith(c.name + ".") for n in c.row_names())


# ---------------------------------------------------------------------------- residuals
def _independent_phi(model, c, oMf):
    """Closure residual from its definition (pinclear.model.closures docstring table)."""
    M1, M2 = oMf[c.f1], oMf[c.f2]
    p1, p2, R1, R2 = M1.translation, M2.translation, M1.rotation, M2.rotation
    x1, y1, z1 = R1.T
    x2, y2, z2 = R2.T
    d = p2 - p1
    return {
        "spherical": p1 - p2,
        "revolute": np.r_[p1 - p2, x1 @ z2, y1 @ z2],
        "universal": np.r_[p1 - p2, z1 @ z2],
        "prismatic": np.r_[x1 @ y2, y1 @ z2, z1 @ x2, x1 @ d, y1 @ d],
        "cylindrical": np.r_[x1 @ z2, y1 @ z2, x1 @ d, y1 @ d],
        "weld": np.r_[p1 - p2, x1 @ y2, y1 @ z2, z1 @ x2],
        "distance": np.r_[np.linalg.norm(p1 - p2) - c.length],
    }.get(c.type)


@pytest.mark.parametrize("seed", [0, 1])
def test_residual_matches_definition(tree, seed):
    model = tree.model
    q, _ = _random_state(model, seed)
    data = model.createData()
    pin.framesForwardKinematics(model, data, q)
    phi = _phi(tree, tree.workspace(), q)
    row = 0
    for c in tree.closures:
        got = phi[row:row + c.nrows]
        row += c.nrows
        if c.type == "planar_point":
            # basis-free: E^T (p1 - p2) has the norm of the in-plane part of p1 - p2
            n = c.normal / np.linalg.norm(c.normal)
            dp = data.oMf[c.f1].translation - data.oMf[c.f2].translation
            assert np.linalg.norm(got) == pytest.approx(np.linalg.norm(dp - (dp @ n) * n), rel=1e-12)
        else:
            np.testing.assert_allclose(got, _independent_phi(model, c, data.oMf), rtol=0, atol=1e-13,
                                       err_msg=c.name)
    # the residual is not trivially small: a wrong row would show
    assert np.linalg.norm(phi) > 0.1


# ---------------------------------------------------------------------------- Jacobian
@pytest.mark.parametrize("root", ["fixed", "spherical"])
@pytest.mark.parametrize("name", list(TYPE_OF))
def test_jacobian_matches_finite_differences(tree, name, root):
    mech = _subset(tree, {name})
    if root == "spherical":
        mech = _subset(_spherical_root(tree), {name})
    model, ws = mech.model, mech.workspace()
    for seed in (3, 4):
        q, _ = _random_state(model, seed)
        J = _J(mech, ws, q)
        assert J.shape == (ROWS[TYPE_OF[name]], model.nv)
        eps = 1e-6
        Jfd = np.zeros_like(J)
        for k in range(model.nv):
            e = np.zeros(model.nv)
            e[k] = eps
            Jfd[:, k] = (_phi(mech, ws, pin.integrate(model, q, e))
                         - _phi(mech, ws, pin.integrate(model, q, -e))) / (2 * eps)
        scale = max(np.abs(Jfd).max(), 1.0)
        np.testing.assert_allclose(J, Jfd, rtol=0, atol=1e-6 * scale, err_msg=f"{name} ({root} root)")
        assert np.abs(J).max() > 1e-2          # not a structurally empty Jacobian


@pytest.mark.parametrize("root", ["fixed", "spherical"])
@pytest.mark.parametrize("name", list(TYPE_OF))
def test_bias_matches_finite_differences(tree, name, root):
    """bias = d/ds [J(q(s)) v] at s = 0 along q(s) = integrate(q, s v) (zero joint acceleration),
    and J v = dPhi/ds: the acceleration-level rows are exact second time derivatives of Phi."""
    mech = _subset(tree, {name})
    if root == "spherical":
        mech = _subset(_spherical_root(tree), {name})
    model, ws = mech.model, mech.workspace()
    m = mech.m_closures
    for seed in (5, 6):
        q, v = _random_state(model, seed)
        kinematics.update(mech, ws, q, v)
        kinematics.constraint_rows(mech, ws, 0.0, q, v)
        bias, dphi = ws.bias[:m].copy(), ws.dphi[:m].copy()
        J = ws.J[:m].copy()
        np.testing.assert_allclose(dphi, J @ v, rtol=0, atol=1e-12)
        h = 1e-5
        qp, qm = pin.integrate(model, q, h * v), pin.integrate(model, q, -h * v)
        jv_fd = (_J(mech, ws, qp) @ v - _J(mech, ws, qm) @ v) / (2 * h)
        dphi_fd = (_phi(mech, ws, qp) - _phi(mech, ws, qm)) / (2 * h)
        d2phi_fd = (_phi(mech, ws, qp) - 2 * _phi(mech, ws, q) + _phi(mech, ws, qm)) / h**2
        scale = max(np.abs(jv_fd).max(), 1.0)
        np.testing.assert_allclose(bias, jv_fd, rtol=0, atol=1e-6 * scale, err_msg=f"{name} ({root})")
        np.testing.assert_allclose(dphi, dphi_fd, rtol=0, atol=1e-7 * max(np.abs(dphi).max(), 1.0))
        # second difference of Phi itself: coarser (roundoff / h^2), an independent route
        np.testing.assert_allclose(bias, d2phi_fd, rtol=0, atol=1e-4 * scale)
        assert np.abs(bias).max() > 1e-3


# ---------------------------------------------------------------------------- joint semantics
def _allowed_motion_violation(model, data, c):
    """How far the relative motion of the two closure frames (velocities in ``data``) is from
    the motions the ideal joint allows (0 when allowed)."""
    V1 = pin.getFrameVelocity(model, data, c.f1, pin.LOCAL_WORLD_ALIGNED)
    V2 = pin.getFrameVelocity(model, data, c.f2, pin.LOCAL_WORLD_ALIGNED)
    M1, M2 = data.oMf[c.f1], data.oMf[c.f2]
    z1, z2 = M1.rotation[:, 2], M2.rotation[:, 2]
    d = M2.translation - M1.translation
    w_rel = V1.angular - V2.angular
    v_rel = V1.linear - V2.linear
    # origin 2 seen from body 1: v2 - v1 - w1 x d
    slide = V2.linear - V1.linear - np.cross(V1.angular, d)
    n = c.normal / np.linalg.norm(c.normal)
    return {
        "spherical": np.linalg.norm(v_rel),
        "revolute": np.linalg.norm(v_rel) + np.linalg.norm(np.cross(w_rel, z1)),
        "universal": np.linalg.norm(v_rel) + abs(w_rel @ np.cross(z1, z2)),
        "prismatic": np.linalg.norm(w_rel) + np.linalg.norm(np.cross(slide, z1)),
        "cylindrical": np.linalg.norm(np.cross(w_rel, z1)) + np.linalg.norm(np.cross(slide, z1)),
        "weld": np.linalg.norm(w_rel) + np.linalg.norm(v_rel),
        "planar_point": np.linalg.norm(np.cross(v_rel, n)),
        "distance": abs(v_rel @ (M1.translation - M2.translation)),
    }[c.type]


def _forbidden_motion(model, data, c):
    """Size of the relative twist of the two frames: nonzero for some null-space motion unless
    the joint locks everything (weld)."""
    V1 = pin.getFrameVelocity(model, data, c.f1, pin.LOCAL_WORLD_ALIGNED)
    V2 = pin.getFrameVelocity(model, data, c.f2, pin.LOCAL_WORLD_ALIGNED)
    return np.linalg.norm(V1.angular - V2.angular) + np.linalg.norm(V1.linear - V2.linear)


def _joint_offset(ctype, rng):
    """A relative placement of frame 2 w.r.t. frame 1 (in frame 1 axes) that the ideal joint
    allows, away from the identity; for planar_point/distance the offset is built in world."""
    th, s = rng.uniform(0.3, 1.2), rng.uniform(0.05, 0.2)
    Rz = pin.utils.rotate("z", th)
    return {
        "spherical": pin.SE3(pin.exp3(rng.standard_normal(3)), np.zeros(3)),
        "revolute": pin.SE3(Rz, np.zeros(3)),
        "universal": pin.SE3(Rz @ pin.utils.rotate("x", np.pi / 2) @ pin.utils.rotate("z", th), np.zeros(3)),
        "prismatic": pin.SE3(np.eye(3), np.array([0.0, 0.0, s])),
        "cylindrical": pin.SE3(Rz, np.array([0.0, 0.0, s])),
        "weld": pin.SE3.Identity(),
    }.get(ctype)


@pytest.mark.parametrize("name", list(TYPE_OF))
def test_closure_leaves_exactly_the_joint_freedoms(tree, name):
    """Place frame 2 so that the closure holds at a random configuration (the ideal joint's pose
    with a nonzero joint displacement): Phi = 0 there, the rows are independent (mobility =
    6 - rows) and every velocity in the Jacobian's null space moves the two frames only as the
    ideal joint allows; the joint's own freedoms are not locked."""
    import copy

    c0 = next(c for c in tree.closures if c.name == name)
    model = copy.deepcopy(tree.model)
    rng = np.random.default_rng(11)
    q, _ = _random_state(model, 12)
    # a loop through all six joints (A3 to B3), so that the relative twist spans all of se(3)
    ja, jb = model.getJointId("a3"), model.getJointId("b3")
    f1 = model.addFrame(pin.Frame("placed1", ja, pin.SE3(pin.exp3(np.array([0.2, -0.4, 0.3])),
                                                         np.array([0.05, 0.1, -0.02])), pin.FrameType.OP_FRAME))
    data = model.createData()          # after addFrame: a Data sized for fewer frames would overflow
    pin.framesForwardKinematics(model, data, q)
    M1 = data.oMf[f1]
    off = _joint_offset(c0.type, rng)
    if off is not None:
        M2 = M1 * off
    else:
        u = c0.normal / np.linalg.norm(c0.normal) if c0.type == "planar_point" else rng.standard_normal(3)
        u = u / np.linalg.norm(u)
        dist = 0.17 if c0.type == "planar_point" else c0.length
        M2 = pin.SE3(pin.exp3(rng.standard_normal(3)), M1.translation + dist * u)
    f2 = model.addFrame(pin.Frame("placed2", jb, data.oMi[jb].inverse() * M2, pin.FrameType.OP_FRAME))
    c = Closure(c0.name, c0.type, "placed1", "placed2", f1, f2, normal=c0.normal, length=c0.length)
    mech = pinclear.Mechanism(model, "placed", [c], [], [])
    ws = mech.workspace()
    assert np.abs(_phi(mech, ws, q)).max() < 1e-12
    mob = kinematics.mobility(mech, q)
    assert mob["rank"] == ROWS[TYPE_OF[name]]
    assert mob["mobility"] == model.nv - ROWS[TYPE_OF[name]]
    assert mob["redundant_rows"] == []
    J = _J(mech, ws, q)
    null = np.linalg.svd(J)[2][mob["rank"]:]
    data = model.createData()
    moved = 0.0
    for k in range(len(null)):
        pin.forwardKinematics(model, data, q, null[k])
        pin.updateFramePlacements(model, data)
        assert _allowed_motion_violation(model, data, c) < 1e-9, f"{name}: null-space motion {k}"
        moved = max(moved, _forbidden_motion(model, data, c))
    if TYPE_OF[name] != "weld":
        assert moved > 1e-3           # the joint's own freedoms are not locked
