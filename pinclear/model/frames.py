"""Compiled frame kinematics: joint placements and Jacobians of a tree, and the placements,
Jacobians, velocities and zero-ddq accelerations of every closure frame at once (numba).

Why compiled: after Pinocchio's tree algorithms (a few microseconds), these loops over frames
replace ~40 small numpy calls whose per-call overhead dominated a small right-hand side. The
maths: pinclear.model.kinematics.FrameKinematics.
"""
from __future__ import annotations

import numpy as np

from pinclear.core.jit import njit


@njit(cache=True, fastmath=False)
def _cross(a0, a1, a2, b0, b1, b2):
    return a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0


@njit(cache=True, inline="always")
def frame_positions(Hj, jidx, jMf, H, fcols, nfcols, J, Jv, Jw):
    """Frame placements H[f] = Hj[jidx[f]] jMf[f] (parent-joint placement times the constant
    frame offset) and frame Jacobians (origin velocity, angular; world axes) from the tree's WORLD
    J on the dofs supporting each frame (fcols[f, :nfcols[f]]; the other entries of Jv and Jw are
    structural zeros, zero since their buffers were made)."""
    F = H.shape[0]
    for f in range(F):
        j = jidx[f]
        for r in range(3):
            for c in range(4):
                s = Hj[j, r, 3] if c == 3 else 0.0
                for i in range(3):
                    s += Hj[j, r, i] * jMf[f, i, c]
                H[f, r, c] = s
    for f in range(F):
        px, py, pz = H[f, 0, 3], H[f, 1, 3], H[f, 2, 3]
        for kk in range(nfcols[f]):
            k = fcols[f, kk]
            jx, jy, jz = J[3, k], J[4, k], J[5, k]
            cx, cy, cz = _cross(jx, jy, jz, px, py, pz)
            Jw[f, 0, k], Jw[f, 1, k], Jw[f, 2, k] = jx, jy, jz
            Jv[f, 0, k], Jv[f, 1, k], Jv[f, 2, k] = J[0, k] + cx, J[1, k] + cy, J[2, k] + cz


@njit(cache=True, inline="always")
def frame_velocities(H, fcols, nfcols, J, dJ, v, V, W, A, Al):
    """Velocities and zero-ddq classical accelerations of every frame (after frame_positions):
    v_o + w x p and a_o + alpha x p + w x v_p with (v_o; w) = J v, (a_o; alpha) = dJ v over the
    dofs supporting the frame."""
    F = H.shape[0]
    for f in range(F):
        px, py, pz = H[f, 0, 3], H[f, 1, 3], H[f, 2, 3]
        vo0 = vo1 = vo2 = w0 = w1 = w2 = 0.0
        ao0 = ao1 = ao2 = al0 = al1 = al2 = 0.0
        for kk in range(nfcols[f]):
            k = fcols[f, kk]
            vk = v[k]
            vo0 += J[0, k] * vk
            vo1 += J[1, k] * vk
            vo2 += J[2, k] * vk
            w0 += J[3, k] * vk
            w1 += J[4, k] * vk
            w2 += J[5, k] * vk
            ao0 += dJ[0, k] * vk
            ao1 += dJ[1, k] * vk
            ao2 += dJ[2, k] * vk
            al0 += dJ[3, k] * vk
            al1 += dJ[4, k] * vk
            al2 += dJ[5, k] * vk
        c0, c1, c2 = _cross(w0, w1, w2, px, py, pz)
        vp0, vp1, vp2 = vo0 + c0, vo1 + c1, vo2 + c2
        V[f, 0], V[f, 1], V[f, 2] = vp0, vp1, vp2
        W[f, 0], W[f, 1], W[f, 2] = w0, w1, w2
        d0, d1, d2 = _cross(al0, al1, al2, px, py, pz)
        e0, e1, e2 = _cross(w0, w1, w2, vp0, vp1, vp2)
        A[f, 0], A[f, 1], A[f, 2] = ao0 + d0 + e0, ao1 + d1 + e1, ao2 + d2 + e2
        Al[f, 0], Al[f, 1], Al[f, 2] = al0, al1, al2


@njit(cache=True)
def frame_kinematics(Hj, jidx, jMf, H, fcols, nfcols, J, dJ, v, Jv, Jw, V, W, A, Al):
    """Frame placements H[f] = Hj[jidx[f]] jMf[f] (parent-joint placement times the constant
    frame offset), then frame Jacobians (origin velocity, angular; world axes), velocities and
    zero-ddq classical accelerations of every frame from the tree's WORLD J, dJ."""
    frame_positions(Hj, jidx, jMf, H, fcols, nfcols, J, Jv, Jw)
    frame_velocities(H, fcols, nfcols, J, dJ, v, V, W, A, Al)


# joint kinds of the compiled placement chain (1-dof joints only)
J_REVOLUTE, J_PRISMATIC = 0, 1


@njit(cache=True)
def joint_placements(parent, jP, kind, axis, iq, q, O, want, Hj):
    """World placements of every joint of a tree of 1-dof joints, O[j] = O[parent[j]] jP[j]
    X_j(q), with X_j a rotation about (revolute) or a translation along (prismatic) the unit
    ``axis[j]`` by q[iq[j]] (Rodrigues); then Hj[k] = O[want[k]]. Replaces one Python access to
    data.oMi per joint, which cost more than Pinocchio's whole forward pass."""
    # placements are affine (last row 0 0 0 1): only the 3 x 4 top rows are multiplied, in the
    # order of the 4 x 4 products (the zero terms dropped change no bit)
    for j in range(parent.shape[0]):
        O[j, 3, 0] = O[j, 3, 1] = O[j, 3, 2] = 0.0
        O[j, 3, 3] = 1.0
    for i in range(3):
        for c2 in range(4):
            O[0, i, c2] = 1.0 if i == c2 else 0.0
    # X and T (below) live in scalars, row by row: np.empty in compiled code allocates on every call
    for j in range(1, parent.shape[0]):
        qj = q[iq[j]]
        ax, ay, az = axis[j, 0], axis[j, 1], axis[j, 2]
        p = parent[j]
        revolute = kind[j] == J_REVOLUTE
        x00 = x01 = x02 = x10 = x11 = x12 = x20 = x21 = x22 = 0.0
        dx = dy = dz = 0.0
        if revolute:
            c, s = np.cos(qj), np.sin(qj)
            C = 1.0 - c
            x00, x01, x02 = c + ax * ax * C, ax * ay * C - az * s, ax * az * C + ay * s
            x10, x11, x12 = ay * ax * C + az * s, c + ay * ay * C, ay * az * C - ax * s
            x20, x21, x22 = az * ax * C - ay * s, az * ay * C + ax * s, c + az * az * C
        else:
            dx, dy, dz = ax * qj, ay * qj, az * qj
        for r in range(3):                     # row r of T = O[parent] jP, then of O[j] = T X
            o0, o1, o2 = O[p, r, 0], O[p, r, 1], O[p, r, 2]
            t0 = 0.0 + o0 * jP[j, 0, 0] + o1 * jP[j, 1, 0] + o2 * jP[j, 2, 0]
            t1 = 0.0 + o0 * jP[j, 0, 1] + o1 * jP[j, 1, 1] + o2 * jP[j, 2, 1]
            t2 = 0.0 + o0 * jP[j, 0, 2] + o1 * jP[j, 1, 2] + o2 * jP[j, 2, 2]
            t3 = 0.0 + o0 * jP[j, 0, 3] + o1 * jP[j, 1, 3] + o2 * jP[j, 2, 3] + O[p, r, 3]
            if revolute:                       # rotation about the axis
                O[j, r, 0] = 0.0 + t0 * x00 + t1 * x10 + t2 * x20
                O[j, r, 1] = 0.0 + t0 * x01 + t1 * x11 + t2 * x21
                O[j, r, 2] = 0.0 + t0 * x02 + t1 * x12 + t2 * x22
                O[j, r, 3] = t3
            else:                              # translation along the axis
                O[j, r, 0], O[j, r, 1], O[j, r, 2] = t0, t1, t2
                O[j, r, 3] = 0.0 + t0 * dx + t1 * dy + t2 * dz + t3
    for k in range(want.shape[0]):
        Hj[k, :, :] = O[want[k]]


@njit(cache=True)
def joint_placements_jacobians(parent, jP, kind, axis, iq, q, O, want, Hj, J):
    """joint_placements, then the tree's WORLD joint Jacobian J (6, nv; linear rows first, the
    velocity of the body point at the world origin, as Pinocchio's computeJointJacobians) from
    the placements: joint j's column is its motion axis carried to the world, a = R_j axis[j],
    with (p_j x a; a) for a revolute joint through p_j and (a; 0) for a prismatic one. For the
    projections' Gauss-Newton iterates, which need placements and J and nothing else of
    Pinocchio's position pass (a 1-dof tree has q and v indices equal: q[iq[j]] moves column
    iq[j])."""
    joint_placements(parent, jP, kind, axis, iq, q, O, want, Hj)
    for j in range(1, parent.shape[0]):
        ax, ay, az = axis[j, 0], axis[j, 1], axis[j, 2]
        a0 = O[j, 0, 0] * ax + O[j, 0, 1] * ay + O[j, 0, 2] * az
        a1 = O[j, 1, 0] * ax + O[j, 1, 1] * ay + O[j, 1, 2] * az
        a2 = O[j, 2, 0] * ax + O[j, 2, 1] * ay + O[j, 2, 2] * az
        k = iq[j]
        if kind[j] == J_REVOLUTE:
            c0, c1, c2 = _cross(O[j, 0, 3], O[j, 1, 3], O[j, 2, 3], a0, a1, a2)
            J[0, k], J[1, k], J[2, k], J[3, k], J[4, k], J[5, k] = c0, c1, c2, a0, a1, a2
        else:
            J[0, k], J[1, k], J[2, k], J[3, k], J[4, k], J[5, k] = a0, a1, a2, 0.0, 0.0, 0.0
