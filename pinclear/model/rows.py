"""Compiled closure and drive rows: residuals, Jacobian rows and their bias from the frame
kinematics, one loop over rows (numba). The primitives are documented in pinclear.model.closures.
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np

from pinclear.core.jit import njit
from pinclear.model.coupling import coupling_positions, coupling_velocities
from pinclear.model.frames import _cross, frame_positions, frame_velocities

# primitive codes of CompiledClosures.table
POINT, PLANE, DOT, PERP, DIST, COUPLE = 0, 1, 2, 3, 4, 5


class Rows(NamedTuple):
    """The buffers of a workspace's frame kinematics and constraint rows, one structured argument
    of every kernel that evaluates the rows (built once per workspace by
    pinclear.model.kinematics.row_buffers; every array stays valid for the workspace's life)."""
    Hj: np.ndarray       # (joints, 4, 4) placements of the frames' parent joints
    jidx: np.ndarray     # (F,) each frame's parent joint, an index into Hj
    jMf: np.ndarray      # (F, 4, 4) constant frame offsets
    H: np.ndarray        # (F, 4, 4) frame placements
    fcols: np.ndarray    # (F, nv) the dofs that move each frame, ascending (nfcols of them)
    nfcols: np.ndarray
    J: np.ndarray        # (6, nv) Pinocchio's joint Jacobian, WORLD (data.J)
    dJ: np.ndarray       # (6, nv) its time derivative (data.dJ)
    table: np.ndarray    # closure primitives (pinclear.model.closures.CompiledClosures)
    E: np.ndarray
    L: np.ndarray
    iq: np.ndarray       # drives' q and v indices
    iv: np.ndarray
    Jv: np.ndarray       # (F, 3, nv) frame Jacobians, origin velocity and angular
    Jw: np.ndarray
    V: np.ndarray        # (F, 3) origin velocities, angular velocities, zero-ddq accelerations
    W: np.ndarray
    A: np.ndarray
    Al: np.ndarray
    phi: np.ndarray      # (m,) residuals, closures then drives
    Jc: np.ndarray       # (m, nv) constraint Jacobian
    bias: np.ndarray     # (m,) dJ v
    dphi: np.ndarray     # (m,) J v + Phi_t
    gamma: np.ndarray    # (m,) the right-hand side of J a = gamma
    cols: np.ndarray     # (m, nv) each row's support: the dofs that can move it, ascending
    ncols: np.ndarray    # (m,) how many of cols' entries are used (pinclear.model.kinematics.row_support)


@njit(cache=True, inline="always")
def closure_positions(table, E, L, H, Jv, Jw, phi, Jc, dphi):
    """Residual and Jacobian of every closure primitive (see pinclear.model.closures), J v = 0 (the
    rows at rest). table rows: (code, i1, i2, row0, a, b); E (n, 2, 3) plane bases; L lengths.
    The rows' loops run over every dof, contiguous: within 20 % of a walk of each row's support
    either way (benchmarks/kernel_choices.md)."""
    nv = Jc.shape[1]
    for p in range(table.shape[0]):
        code, i1, i2, r = table[p, 0], table[p, 1], table[p, 2], table[p, 3]
        if code == POINT:
            for i in range(3):
                phi[r + i] = H[i1, i, 3] - H[i2, i, 3]
                dphi[r + i] = 0.0
                for k in range(nv):
                    Jc[r + i, k] = Jv[i1, i, k] - Jv[i2, i, k]
        elif code == PLANE:
            for j in range(2):
                s = 0.0
                for i in range(3):
                    s += E[p, j, i] * (H[i1, i, 3] - H[i2, i, 3])
                phi[r + j], dphi[r + j] = s, 0.0
                for k in range(nv):
                    acc = 0.0
                    for i in range(3):
                        acc += E[p, j, i] * (Jv[i1, i, k] - Jv[i2, i, k])
                    Jc[r + j, k] = acc
        elif code == DOT:
            a, b = table[p, 4], table[p, 5]
            u0, u1, u2 = H[i1, 0, a], H[i1, 1, a], H[i1, 2, a]
            x0, x1, x2 = H[i2, 0, b], H[i2, 1, b], H[i2, 2, b]
            c0, c1, c2 = _cross(u0, u1, u2, x0, x1, x2)
            phi[r] = u0 * x0 + u1 * x1 + u2 * x2
            dphi[r] = 0.0
            for k in range(nv):
                Jc[r, k] = (c0 * (Jw[i1, 0, k] - Jw[i2, 0, k]) + c1 * (Jw[i1, 1, k] - Jw[i2, 1, k])
                            + c2 * (Jw[i1, 2, k] - Jw[i2, 2, k]))
        elif code == PERP:
            a = table[p, 4]
            u0, u1, u2 = H[i1, 0, a], H[i1, 1, a], H[i1, 2, a]
            d0, d1, d2 = H[i2, 0, 3] - H[i1, 0, 3], H[i2, 1, 3] - H[i1, 1, 3], H[i2, 2, 3] - H[i1, 2, 3]
            c0, c1, c2 = _cross(u0, u1, u2, d0, d1, d2)
            phi[r] = u0 * d0 + u1 * d1 + u2 * d2
            dphi[r] = 0.0
            for k in range(nv):
                Jc[r, k] = (u0 * (Jv[i2, 0, k] - Jv[i1, 0, k]) + u1 * (Jv[i2, 1, k] - Jv[i1, 1, k])
                            + u2 * (Jv[i2, 2, k] - Jv[i1, 2, k])
                            + c0 * Jw[i1, 0, k] + c1 * Jw[i1, 1, k] + c2 * Jw[i1, 2, k])
        elif code == DIST:
            d0, d1, d2 = H[i1, 0, 3] - H[i2, 0, 3], H[i1, 1, 3] - H[i2, 1, 3], H[i1, 2, 3] - H[i2, 2, 3]
            nd = np.sqrt(d0 * d0 + d1 * d1 + d2 * d2)
            n0, n1, n2 = d0 / nd, d1 / nd, d2 / nd
            phi[r] = nd - L[p]
            dphi[r] = 0.0
            for k in range(nv):
                Jc[r, k] = (n0 * (Jv[i1, 0, k] - Jv[i2, 0, k]) + n1 * (Jv[i1, 1, k] - Jv[i2, 1, k])
                            + n2 * (Jv[i1, 2, k] - Jv[i2, 2, k]))


@njit(cache=True, inline="always")
def closure_velocities(table, E, H, V, W, A, Al, dphi, bias):
    """J v and the bias (dJ v) of every closure primitive, after closure_positions at the same
    configuration and frame_velocities."""
    for p in range(table.shape[0]):
        code, i1, i2, r = table[p, 0], table[p, 1], table[p, 2], table[p, 3]
        if code == POINT:
            for i in range(3):
                dphi[r + i] = V[i1, i] - V[i2, i]
                bias[r + i] = A[i1, i] - A[i2, i]
        elif code == PLANE:
            for j in range(2):
                ds = sb = 0.0
                for i in range(3):
                    e = E[p, j, i]
                    ds += e * (V[i1, i] - V[i2, i])
                    sb += e * (A[i1, i] - A[i2, i])
                dphi[r + j], bias[r + j] = ds, sb
        elif code == DOT:
            a, b = table[p, 4], table[p, 5]
            u0, u1, u2 = H[i1, 0, a], H[i1, 1, a], H[i1, 2, a]
            x0, x1, x2 = H[i2, 0, b], H[i2, 1, b], H[i2, 2, b]
            c0, c1, c2 = _cross(u0, u1, u2, x0, x1, x2)
            dw0, dw1, dw2 = W[i1, 0] - W[i2, 0], W[i1, 1] - W[i2, 1], W[i1, 2] - W[i2, 2]
            dphi[r] = c0 * dw0 + c1 * dw1 + c2 * dw2
            du0, du1, du2 = _cross(W[i1, 0], W[i1, 1], W[i1, 2], u0, u1, u2)
            dx0, dx1, dx2 = _cross(W[i2, 0], W[i2, 1], W[i2, 2], x0, x1, x2)
            p0, p1, p2 = _cross(du0, du1, du2, x0, x1, x2)
            q0, q1, q2 = _cross(u0, u1, u2, dx0, dx1, dx2)
            bias[r] = (c0 * (Al[i1, 0] - Al[i2, 0]) + c1 * (Al[i1, 1] - Al[i2, 1]) + c2 * (Al[i1, 2] - Al[i2, 2])
                       + (p0 + q0) * dw0 + (p1 + q1) * dw1 + (p2 + q2) * dw2)
        elif code == PERP:
            a = table[p, 4]
            u0, u1, u2 = H[i1, 0, a], H[i1, 1, a], H[i1, 2, a]
            d0, d1, d2 = H[i2, 0, 3] - H[i1, 0, 3], H[i2, 1, 3] - H[i1, 1, 3], H[i2, 2, 3] - H[i1, 2, 3]
            e0, e1, e2 = V[i2, 0] - V[i1, 0], V[i2, 1] - V[i1, 1], V[i2, 2] - V[i1, 2]
            c0, c1, c2 = _cross(u0, u1, u2, d0, d1, d2)
            w0, w1, w2 = W[i1, 0], W[i1, 1], W[i1, 2]
            dphi[r] = u0 * e0 + u1 * e1 + u2 * e2 + c0 * w0 + c1 * w1 + c2 * w2
            du0, du1, du2 = _cross(w0, w1, w2, u0, u1, u2)
            f0, f1, f2 = _cross(du0, du1, du2, d0, d1, d2)
            g0, g1, g2 = _cross(u0, u1, u2, e0, e1, e2)
            bias[r] = (u0 * (A[i2, 0] - A[i1, 0]) + u1 * (A[i2, 1] - A[i1, 1]) + u2 * (A[i2, 2] - A[i1, 2])
                       + c0 * Al[i1, 0] + c1 * Al[i1, 1] + c2 * Al[i1, 2]
                       + du0 * e0 + du1 * e1 + du2 * e2 + (f0 + g0) * w0 + (f1 + g1) * w1 + (f2 + g2) * w2)
        elif code == DIST:
            d0, d1, d2 = H[i1, 0, 3] - H[i2, 0, 3], H[i1, 1, 3] - H[i2, 1, 3], H[i1, 2, 3] - H[i2, 2, 3]
            e0, e1, e2 = V[i1, 0] - V[i2, 0], V[i1, 1] - V[i2, 1], V[i1, 2] - V[i2, 2]
            nd = np.sqrt(d0 * d0 + d1 * d1 + d2 * d2)
            n0, n1, n2 = d0 / nd, d1 / nd, d2 / nd
            ndd = n0 * e0 + n1 * e1 + n2 * e2
            dphi[r] = ndd
            bias[r] = (n0 * (A[i1, 0] - A[i2, 0]) + n1 * (A[i1, 1] - A[i2, 1]) + n2 * (A[i1, 2] - A[i2, 2])
                       + (e0 * e0 + e1 * e1 + e2 * e2 - ndd * ndd) / nd)


@njit(cache=True, inline="always")
def constraint_rows_all(R, alpha, beta, q, v, fdrv):
    """Frame kinematics, closure rows, drive rows (q[iq] - f(t)) and the Baumgarte-stabilised
    right-hand side gamma = -bias - 2 alpha dPhi - beta^2 Phi, in one call (R: Rows): the position
    level, then the velocity level."""
    constraint_rows_positions(R, q, v, fdrv)
    constraint_rows_velocities(R, alpha, beta, v, fdrv)


@njit(cache=True, inline="always")
def constraint_rows_positions(R, q, v, fdrv):
    """The position level of constraint_rows_all: frame placements and Jacobians, every row's
    Phi and J, and J v + Phi_t at rest (the drives' v - f'(t) with ``v``, the zero vector in the
    projections' iterations; zero for closures); bias and gamma are left as they were."""
    frame_positions(R.Hj, R.jidx, R.jMf, R.H, R.fcols, R.nfcols, R.J, R.Jv, R.Jw)
    closure_positions(R.table, R.E, R.L, R.H, R.Jv, R.Jw, R.phi, R.Jc, R.dphi)
    coupling_positions(R.table, R.E, q, R.phi, R.Jc, R.dphi, COUPLE)
    phi, dphi, iq, iv = R.phi, R.dphi, R.iq, R.iv
    mc = phi.shape[0] - iq.shape[0]
    for k in range(iq.shape[0]):
        r = mc + k
        phi[r] = q[iq[k]] - fdrv[0, k]
        dphi[r] = v[iv[k]] - fdrv[1, k]


@njit(cache=True, inline="always")
def constraint_rows_velocities(R, alpha, beta, v, fdrv):
    """The velocity level of constraint_rows_all at the configuration of the last
    constraint_rows_positions call: frame velocities and zero-ddq accelerations from the passes'
    J and dJ, every row's J v + Phi_t, bias and gamma (Phi and J kept)."""
    frame_velocities(R.H, R.fcols, R.nfcols, R.J, R.dJ, v, R.V, R.W, R.A, R.Al)
    closure_velocities(R.table, R.E, R.H, R.V, R.W, R.A, R.Al, R.dphi, R.bias)
    coupling_velocities(R.table, R.E, v, R.dphi, R.bias, COUPLE)
    phi, dphi, bias, gamma, iv = R.phi, R.dphi, R.bias, R.gamma, R.iv
    mc = phi.shape[0] - iv.shape[0]
    for k in range(iv.shape[0]):
        r = mc + k
        dphi[r] = v[iv[k]] - fdrv[1, k]
        bias[r] = -fdrv[2, k]
    for r in range(phi.shape[0]):
        gamma[r] = -bias[r] - 2.0 * alpha * dphi[r] - beta * beta * phi[r]
