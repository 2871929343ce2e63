"""Compiled kernels of the right-hand side (numba).

Why: after Pinocchio's tree algorithms (a few microseconds), the closure rows and the KKT solve
are ~40 small numpy calls whose per-call overhead dominated the four-bar right-hand side
(~100 us vs ~5 us for pin.constraintDynamics). These loops over closure *rows* (not bodies)
do the same arithmetic in one compiled call each. The maths is documented in
pinclear.closures and pinclear.kinematics.FrameKinematics.
"""
from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from pinclear._jit import njit
from pinclear.coupling import coupling_positions, coupling_velocities

# primitive codes of CompiledClosures.table
POINT, PLANE, DOT, PERP, DIST, COUPLE = 0, 1, 2, 3, 4, 5


class Rows(NamedTuple):
    """The buffers of a workspace's frame kinematics and constraint rows, one structured argument
    of every kernel that evaluates the rows (built once per workspace by
    pinclear.kinematics.row_buffers; every array stays valid for the workspace's life)."""
    Hj: np.ndarray       # (joints, 4, 4) placements of the frames' parent joints
    jidx: np.ndarray     # (F,) each frame's parent joint, an index into Hj
    jMf: np.ndarray      # (F, 4, 4) constant frame offsets
    H: np.ndarray        # (F, 4, 4) frame placements
    fcols: np.ndarray    # (F, nv) the dofs that move each frame, ascending (nfcols of them)
    nfcols: np.ndarray
    J: np.ndarray        # (6, nv) Pinocchio's joint Jacobian, WORLD (data.J)
    dJ: np.ndarray       # (6, nv) its time derivative (data.dJ)
    table: np.ndarray    # closure primitives (pinclear.closures.CompiledClosures)
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
    ncols: np.ndarray    # (m,) how many of cols' entries are used (pinclear.kinematics.row_support)


class Solve(NamedTuple):
    """The buffers of a constraint solve (lagrange, projection, proximal): the state and drive
    values it reads, Pinocchio's M and nle, the applied forces, the rows solved for, work arrays
    and the outputs (a, and lam over ``rows``)."""
    q: np.ndarray
    v: np.ndarray
    fdrv: np.ndarray     # (3, nd) drive law values and derivatives at t
    M: np.ndarray        # data.M (upper triangle)
    parent: np.ndarray   # parent dof (-1 at roots)
    tau: np.ndarray      # applied generalized forces
    nle: np.ndarray      # data.nle
    rows: np.ndarray     # (k,) the rows solved for
    Lm: np.ndarray       # (nv, nv) M = L^T L
    Y: np.ndarray        # (m, nv) L^-T J^T, row-wise
    S: np.ndarray        # (m, m) J M^-1 J^T
    Ls: np.ndarray       # (m, m) Cholesky of S (lagrange) or of S + rho I (proximal)
    d: np.ndarray        # (m,) reciprocal pivots of the proximal factor
    r: np.ndarray        # (m,) work
    a: np.ndarray        # (nv,) accelerations
    lam: np.ndarray      # (k,) multipliers of ``rows``


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


@njit(cache=True, inline="always")
def closure_positions(table, E, L, H, Jv, Jw, phi, Jc, dphi):
    """Residual and Jacobian of every closure primitive (see pinclear.closures), J v = 0 (the
    rows at rest). table rows: (code, i1, i2, row0, a, b); E (n, 2, 3) plane bases; L lengths.
    The rows' loops run over every dof, contiguous (measured 2026-11-27, all the rows at one
    state: 0.57 us on 3-UPRU+UP, against 0.69 for a walk of each row's support, half the dofs;
    on A02 N = 10, a third of the dofs, the walk took 1.4 us against 1.6)."""
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


@njit(cache=True)
def _chol_dense(S, L):
    """Dense Cholesky S = L L^T (lower). Returns the smallest/largest pivot ratio (0 if not PD)."""
    n = S.shape[0]
    pmin, pmax = np.inf, 0.0
    for j in range(n):
        s = S[j, j]
        for k in range(j):
            s -= L[j, k] * L[j, k]
        if s <= 0.0:
            return 0.0
        d = np.sqrt(s)
        L[j, j] = d
        pmin, pmax = min(pmin, s), max(pmax, s)
        for i in range(j + 1, n):
            s2 = S[i, j]
            for k in range(j):
                s2 -= L[i, k] * L[j, k]
            L[i, j] = s2 / d
    return pmin / pmax


@njit(cache=True)
def ltl_factor(M, parent, L):
    """Featherstone's LTL factorisation M = L^T L of a joint-space inertia matrix, with no fill-in
    outside the tree's ancestor pattern (RBDA, sec. 6.5). ``parent`` is Pinocchio's
    data.parents_fromRow (parent dof, -1 at a root); M's upper triangle is read (crba fills it).
    L[k, i] is non-zero only for i an ancestor dof of k. Returns False if M is not PD.
    From WIDE dofs a dof whose ancestors are the dofs just below it (a chain numbered down to its
    root, as A02's couplers) updates each ancestor's row along contiguous memory
    (_ltl_chain_update, the same bits)."""
    return _ltl_factor(M, parent, L, M.shape[0] >= WIDE)


@njit(cache=True)
def _ltl_factor(M, parent, L, wide):
    """ltl_factor; ``wide``: chains along contiguous rows."""
    n = M.shape[0]
    for k in range(n):
        L[k, k] = M[k, k]
        i = parent[k]
        while i >= 0:
            L[k, i] = M[i, k]
            i = parent[i]
    for k in range(n - 1, -1, -1):
        if L[k, k] <= 0.0:
            return False
        d = np.sqrt(L[k, k])
        L[k, k] = d
        i = parent[k]
        while i >= 0:
            L[k, i] /= d
            i = parent[i]
        if wide:
            root = k             # k's ancestors are k - 1, ..., root while they are contiguous
            while root > 0 and parent[root] == root - 1:
                root -= 1
            if root < k and parent[root] < 0:
                _ltl_chain_update(L, k, root)
                continue
        i = parent[k]
        while i >= 0:
            j = i
            while j >= 0:
                L[i, j] -= L[k, i] * L[k, j]
                j = parent[j]
            i = parent[i]
    return True


@njit(cache=True, inline="always")
def _ltl_chain_update(L, k, root):
    """ltl_factor's update from dof k when its ancestors are k - 1, ..., root: for each ancestor
    i, L[i, j] -= L[k, i] L[k, j] for j = i, ..., root, each entry once, as the walk does (the
    same operations: the same bits), along row i (_axpy)."""
    for i in range(k - 1, root - 1, -1):
        _axpy(L[i, root:i + 1], L[k, root:i + 1], L[k, i])


@njit(cache=True)
def ltl_solve_t(L, parent, b):
    """In place b <- L^-T b (back substitution along the tree, leaves first)."""
    for k in range(L.shape[0] - 1, -1, -1):
        b[k] /= L[k, k]
        yk = b[k]
        i = parent[k]
        while i >= 0:
            b[i] -= L[k, i] * yk
            i = parent[i]


@njit(cache=True)
def ltl_solve(L, parent, y):
    """In place y <- L^-1 y (forward substitution, roots first)."""
    for k in range(L.shape[0]):
        s = y[k]
        i = parent[k]
        while i >= 0:
            s -= L[k, i] * y[i]
            i = parent[i]
        y[k] = s / L[k, k]


@njit(cache=True)
def scaled_rows(Lm, parent, J, rows, Y):
    """Y[r] = L^-T J[rows[r]] (row-wise: Y = B = J L^-1 over the selected rows), M = L^T L.
    ltl_solve_t on every row at once: each row sees the same operations in the same order. One
    walk of the tree for all rows: a walk per row over its support alone took 0.94x (A02 N = 10)
    to 1.48x (3-UPRU+UP) its time, measured 2026-11-27. At dof k only the rows from the first to
    the last whose Y[r, k] is non-zero are updated: the others would subtract exact zeros (no bit
    changes). Y is zero outside the rows' supports (pinclear.kinematics.row_support), so on
    A02 N = 40, whose rows reach one coupler deeper each, that is a third of the products (30 us
    against 43-63 at 80 rows); the scan for the range reads a column's ends, nothing is allocated."""
    if rows.shape[0] >= WIDE:
        _transposed_back(_scaled_rows_wide(Lm, parent, J, rows), Y)
        return
    _scaled_rows_narrow(Lm, parent, J, rows, Y)


@njit(cache=True)
def _scaled_rows_narrow(Lm, parent, J, rows, Y):
    """scaled_rows below WIDE rows, on Y itself."""
    nv = Lm.shape[0]
    m = rows.shape[0]
    for r in range(m):
        for k in range(nv):
            Y[r, k] = J[rows[r], k]
    for k in range(nv - 1, -1, -1):
        a, b = 0, m
        while a < b and Y[a, k] == 0.0:
            a += 1
        while b > a and Y[b - 1, k] == 0.0:
            b -= 1
        d = Lm[k, k]
        for r in range(a, b):
            Y[r, k] /= d
        i = parent[k]
        while i >= 0:
            lki = Lm[k, i]
            for r in range(a, b):
                Y[r, i] -= lki * Y[r, k]
            i = parent[i]


@njit(cache=True)
def _scaled_rows_wide(Lm, parent, J, rows):
    """scaled_rows from WIDE rows, the same bits: the same operations on Y^T (allocated, (nv, m)),
    where a dof's updates run along contiguous rows (vector instructions). Returns Y^T."""
    nv, m = Lm.shape[0], rows.shape[0]
    Yt = np.empty((nv, m))
    for r in range(m):
        jr = rows[r]
        for k in range(nv):
            Yt[k, r] = J[jr, k]
    for k in range(nv - 1, -1, -1):
        yk = Yt[k]
        a, b = 0, m
        while a < b and yk[a] == 0.0:
            a += 1
        while b > a and yk[b - 1] == 0.0:
            b -= 1
        seg = yk[a:b]
        d = Lm[k, k]
        for r in range(b - a):
            seg[r] /= d
        i = parent[k]
        while i >= 0:
            _axpy(Yt[i, a:b], seg, Lm[k, i])
            i = parent[i]
    return Yt


@njit(cache=True)
def _transposed_back(Yt, Y):
    """Y = Yt^T."""
    for r in range(Y.shape[0]):
        for k in range(Y.shape[1]):
            Y[r, k] = Yt[k, r]


@njit(cache=True)
def schur_complement(Lm, parent, J, rows, cols, ncols, Y, S):
    """Y[r] = L^-T J[rows[r]] (row-wise) and S = Y Y^T = J M^-1 J^T over the selected rows, for
    M = L^T L factorised by ltl_factor (S by _gram), both over the rows' supports. From WIDE
    rows both along Y^T (_scaled_rows_wide, _gram_wide), the same bits."""
    if rows.shape[0] >= WIDE:
        Yt = _scaled_rows_wide(Lm, parent, J, rows)
        _transposed_back(Yt, Y)
        _gram_wide(Yt, rows, cols, ncols, S)
        return
    scaled_rows(Lm, parent, J, rows, Y)
    _gram(Y, rows, cols, ncols, S, False)


@njit(cache=True)
def kkt_solve(M, parent, f, J, gamma, rows, cols, ncols, Lm, Y, S, Ls, a, lam):
    """Solve  M a - J^T lam = f,  J a = gamma  over the selected rows by the Schur complement,
    with M = L^T L (tree-sparse):  Y = L^-T J^T,  S = Y^T Y,  y_f = L^-T f,
    lam = S^-1 (gamma - Y^T y_f),  a = L^-1 (y_f + Y lam).

    Work arrays: Lm (nv, nv), Y (m, nv) holding Y^T row-wise, S, Ls (m, m). Returns the
    smallest/largest pivot ratio of S's Cholesky (0 when S is singular: the caller's rank test;
    -1 when M is not positive definite)."""
    nv = M.shape[0]
    m = rows.shape[0]
    if not ltl_factor(M, parent, Lm):
        return -1.0
    for i in range(nv):
        a[i] = f[i]
    ltl_solve_t(Lm, parent, a)                 # a = y_f
    if m == 0:
        ltl_solve(Lm, parent, a)
        return 1.0
    schur_complement(Lm, parent, J, rows, cols, ncols, Y, S)
    ratio = _chol_dense(S[:m, :m], Ls[:m, :m])
    if ratio == 0.0:
        return 0.0
    # lam = S^-1 (gamma - Y^T y_f) by two triangular solves with Ls
    for r in range(m):
        s = gamma[rows[r]]
        for k in range(nv):
            s -= Y[r, k] * a[k]
        lam[r] = s
    lower_solve(Ls, m, lam)
    lower_t_solve(Ls, m, lam)
    for r in range(m):
        lr = lam[r]
        for k in range(nv):
            a[k] += Y[r, k] * lr
    ltl_solve(Lm, parent, a)
    return ratio


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


@njit(cache=True)
def _finite_code(a, code):
    """code, or -2 (NONFINITE) when a is not finite."""
    s = 0.0
    for i in range(a.shape[0]):
        s += a[i]
    return code if np.isfinite(s) else -2.0


@njit(cache=True, inline="always")
def lagrange_accel(R, K, alpha, beta):
    """Constraint rows + KKT solve of M a - J^T lam = tau - nle, J a = gamma over K.rows (R: Rows,
    K: Solve). Returns the pivot ratio of S's Cholesky (0: rank loss), -1 when M is not positive
    definite, -2 when the accelerations are not finite."""
    constraint_rows_all(R, alpha, beta, K.q, K.v, K.fdrv)
    a = K.a
    for i in range(a.shape[0]):
        a[i] = K.tau[i] - K.nle[i]
    ratio = kkt_solve(K.M, K.parent, a, R.Jc, R.gamma, K.rows, R.cols, R.ncols, K.Lm, K.Y, K.S, K.Ls, a,
                      K.lam)
    return _finite_code(a, ratio)


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


@njit(cache=True)
def proximal_factor(S, rho, F, d):
    """Cholesky S + rho I = F F^T (F lower; its upper triangle is left as it was) and the
    reciprocal pivots d. S is positive semi-definite and rho > 0, so every pivot is at least rho:
    the factor exists at any configuration."""
    m = S.shape[0]
    for j in range(m):
        s = S[j, j] + rho
        for p in range(j):
            s -= F[j, p] * F[j, p]
        dj = 1.0 / math.sqrt(s)
        d[j] = dj
        # four rows at a time: independent sums, each in its own order (as schur_complement)
        i = j + 1
        while i + 3 < m:
            s0, s1, s2, s3 = S[i, j], S[i + 1, j], S[i + 2, j], S[i + 3, j]
            for p in range(j):
                fjp = F[j, p]
                s0 -= F[i, p] * fjp
                s1 -= F[i + 1, p] * fjp
                s2 -= F[i + 2, p] * fjp
                s3 -= F[i + 3, p] * fjp
            F[i, j], F[i + 1, j], F[i + 2, j], F[i + 3, j] = s0 * dj, s1 * dj, s2 * dj, s3 * dj
            i += 4
        while i < m:
            s0 = S[i, j]
            for p in range(j):
                s0 -= F[i, p] * F[j, p]
            F[i, j] = s0 * dj
            i += 1


@njit(cache=True)
def proximal_inverse(F, d):
    """(S + rho I)^-1 in place of proximal_factor's F F^T = S + rho I (d: its reciprocal
    pivots), symmetric and full: G = F^-1 into F's lower triangle, then G^T G into its upper
    triangle and diagonal, mirrored. m^3 / 2 flops once, so that each proximal iteration is one
    dense matrix-vector product (m^2, each entry's sum along a contiguous row in order, which
    vectorises) instead of two triangular substitutions, whose entries wait on each other:
    2.0x faster at m = 5, 1.7x at m = 13 (pinclear._kernels.proximal_iterations). S + rho I is
    well conditioned (cond <= 1 + 1 / rho_rel), so the explicit inverse costs no accuracy:
    against 50-digit iterations the filter's error is the same to two digits (1.9e-11 relative
    at m = 20, tests/test_engine_methods.py)."""
    m = d.shape[0]
    for j in range(m):                       # G = F^-1, column by column (G[i, i] = d[i])
        F[j, j] = d[j]
        for i in range(j + 1, m):
            s = 0.0
            for p in range(j, i):
                s += F[i, p] * F[p, j]
            F[i, j] = -s * d[i]
    for i in range(m):                       # (G^T G)[i, j], j >= i: row i reads G's rows p >= i
        for j in range(i + 1, m):
            s = 0.0
            for p in range(j, m):
                s += F[p, i] * F[p, j]
            F[i, j] = s
        s = 0.0
        for p in range(i, m):
            s += F[p, i] * F[p, i]
        F[i, i] = s
    for i in range(m):
        for j in range(i):
            F[i, j] = F[j, i]


@njit(cache=True)
def proximal_iterations(A, rho, k, r, lam, y):
    """lam after k proximal iterations lam_{i+1} = A (r + rho lam_i) from lam_0 = 0, A = (S + rho
    I)^-1 (proximal_inverse; y: work of m). The same function of S as the closed form V diag((1 -
    (rho / (s + rho))^k) / s) V^T r over S's eigenpairs
    (pinclear.formulations.proximal.proximal_multipliers), at m^3 / 2 + k m^2 flops against an
    eigensolver's ~9 m^3 and its allocations; and closer to it in rounding: the iterations
    contract (factor rho / (s + rho) <= 1 per step), while the eigenvectors of S's nearly equal
    eigenvalues are determined only to eps over their gap (measured against a 50-digit
    evaluation, m = 2..20: 2e-11 relative against 2e-8 for eigh). The product runs column-wise
    (an axpy along a contiguous row of the symmetric A)."""
    m = r.shape[0]
    for i in range(m):
        lam[i] = 0.0
    for _ in range(k):
        for i in range(m):
            y[i] = r[i] + rho * lam[i]
            lam[i] = 0.0
        for p in range(m):
            yp = y[p]
            for i in range(m):
                lam[i] += A[p, i] * yp


@njit(cache=True)
def proximal_filter(S, r, rho, k, F, d, out):
    """out = k proximal iterations on S lam = r from zero (proximal_factor, then its inverse in F
    and the iterations; d ends as work)."""
    proximal_factor(S, rho, F, d)
    proximal_inverse(F, d)
    proximal_iterations(F, rho, k, r, out, d)


@njit(cache=True)
def relative_rho(S, rho_rel):
    """rho = rho_rel times the mean diagonal of S (the proximal parameter's scale)."""
    m = S.shape[0]
    trace = 0.0
    for i in range(m):
        trace += S[i, i]
    return rho_rel * max(trace / max(m, 1), 1e-300)


@njit(cache=True, inline="always")
def proximal_accel(R, K, alpha, beta, rho_rel, k):
    """Constraint rows + the proximal solve over K.rows (every row) (R: Rows, K: Solve): M = L^T L,
    Y = L^-T J^T, S = Y^T Y = J M^-1 J^T, lam = filter(S) (gamma - J M^-1 f),
    a = M^-1 (f + J^T lam), f = tau - nle. Returns 1, -1 when M is not positive definite, -2
    when the result is not finite."""
    constraint_rows_all(R, alpha, beta, K.q, K.v, K.fdrv)
    a, Y, rows = K.a, K.Y, K.rows
    nv, m = a.shape[0], rows.shape[0]
    if not ltl_factor(K.M, K.parent, K.Lm):
        return -1.0
    for i in range(nv):
        a[i] = K.tau[i] - K.nle[i]
    ltl_solve_t(K.Lm, K.parent, a)                 # a = y_f = L^-T f
    if m > 0:
        schur_complement(K.Lm, K.parent, R.Jc, rows, R.cols, R.ncols, Y, K.S)
        r = K.r
        for i in range(m):
            s = R.gamma[rows[i]]
            for c in range(nv):
                s -= Y[i, c] * a[c]
            r[i] = s                             # gamma - J M^-1 f
        proximal_filter(K.S, r, relative_rho(K.S, rho_rel), k, K.Ls, K.d, K.lam)
        for i in range(m):
            li = K.lam[i]
            for c in range(nv):
                a[c] += Y[i, c] * li
    ltl_solve(K.Lm, K.parent, a)
    return _finite_code(a, 1.0)


# ------------------------------------------------------------------ minimum-norm solves
# The QR below factorises B^T (nv x m) for a B stored row-wise as an (m, nv) array A (B = J or
# J L^-1): B^T's columns are A's rows, so every inner loop runs along a contiguous row.
@njit(cache=True)
def qr_pivoted(A, piv, beta, rcond):
    """In place Householder QR with column pivoting of X = A^T (A is (m, n), X's columns are A's
    rows): X P = Q R. R[i, j] (i <= j) is left in A[j, i], the reflectors' vectors beyond the
    diagonal (unit first entry implied) in A[j, j+1:], with factors beta. Stops at the first
    pivot below rcond times the first: returns the rank k kept. A rank-revealing factorization
    of X's columns (not of X^T X), so a pivot ~ eps divides round-off once, not twice; and
    without truncation the solves below do not depend on the pivot order (Golub & Van Loan,
    Matrix Computations, 4th ed., sec. 5.4.2).

    The column norms run two columns at a time and each reflector meets four at a time: their
    sums are independent chains of additions, each kept in its own order (the same numbers as
    one dot product after another), which the processor overlaps: 1.5x faster at 16 x 16, where
    one chain at a time waited on every addition."""
    m, n = A.shape
    for j in range(m):
        piv[j] = j
    r00 = 0.0
    for j in range(min(n, m)):
        best, bn = j, -1.0
        c = j
        while c + 1 < m:
            s0 = 0.0
            s1 = 0.0
            for i in range(j, n):
                a0 = A[c, i]
                a1 = A[c + 1, i]
                s0 += a0 * a0
                s1 += a1 * a1
            if s0 > bn:
                best, bn = c, s0
            if s1 > bn:
                best, bn = c + 1, s1
            c += 2
        if c < m:
            s0 = 0.0
            for i in range(j, n):
                s0 += A[c, i] * A[c, i]
            if s0 > bn:
                best, bn = c, s0
        if best != j:
            for i in range(n):
                A[j, i], A[best, i] = A[best, i], A[j, i]
            piv[j], piv[best] = piv[best], piv[j]
        norm = np.sqrt(bn)
        if j == 0:
            r00 = norm
        if norm <= rcond * r00 or norm == 0.0:
            return j
        alpha = -norm if A[j, j] >= 0.0 else norm
        v0 = A[j, j] - alpha
        for i in range(j + 1, n):
            A[j, i] /= v0
        bj = -v0 / alpha
        beta[j] = bj
        A[j, j] = alpha
        c = j + 1
        while c + 3 < m:
            s0 = A[c, j]
            s1 = A[c + 1, j]
            s2 = A[c + 2, j]
            s3 = A[c + 3, j]
            for i in range(j + 1, n):
                aji = A[j, i]
                s0 += aji * A[c, i]
                s1 += aji * A[c + 1, i]
                s2 += aji * A[c + 2, i]
                s3 += aji * A[c + 3, i]
            s0 *= bj
            s1 *= bj
            s2 *= bj
            s3 *= bj
            A[c, j] -= s0
            A[c + 1, j] -= s1
            A[c + 2, j] -= s2
            A[c + 3, j] -= s3
            for i in range(j + 1, n):
                aji = A[j, i]
                A[c, i] -= s0 * aji
                A[c + 1, i] -= s1 * aji
                A[c + 2, i] -= s2 * aji
                A[c + 3, i] -= s3 * aji
            c += 4
        while c < m:
            s0 = A[c, j]
            for i in range(j + 1, n):
                s0 += A[j, i] * A[c, i]
            s0 *= bj
            A[c, j] -= s0
            for i in range(j + 1, n):
                A[c, i] -= s0 * A[j, i]
            c += 1
    return min(n, m)


@njit(cache=True)
def reflect(Qr, hb, j, x):
    """x <- H_j x, H_j = I - hb[j] u u^T with u = (1, Qr[j, j+1:]) from index j on."""
    n = Qr.shape[1]
    s = x[j]
    for i in range(j + 1, n):
        s += Qr[j, i] * x[i]
    s *= hb[j]
    x[j] -= s
    for i in range(j + 1, n):
        x[i] -= s * Qr[j, i]


@njit(cache=True)
def apply_qt(Qr, hb, k, x):
    """x <- Q^T x for the first k reflectors of qr_pivoted (applied in order)."""
    for j in range(k):
        reflect(Qr, hb, j, x)


@njit(cache=True)
def apply_q(Qr, hb, k, x):
    """x <- Q x (the reflectors in reverse order)."""
    for j in range(k - 1, -1, -1):
        reflect(Qr, hb, j, x)


@njit(cache=True)
def project_out(Qr, hb, k, x):
    """x <- (I - Q Q^T) x: removes from x its part in the range of the factorised columns (the
    first k of qr_pivoted). A projector, computed without dividing by singular values."""
    apply_qt(Qr, hb, k, x)
    for j in range(k):
        x[j] = 0.0
    apply_q(Qr, hb, k, x)


@njit(cache=True)
def _r_transpose_solve(A, piv, k, r, x):
    """x[:k] = z from R^T z = P^T r (qr_pivoted's R), x[k:] = 0."""
    for j in range(k):
        s = r[piv[j]]
        for i in range(j):
            s -= A[j, i] * x[i]
        x[j] = s / A[j, j]
    for j in range(k, x.shape[0]):
        x[j] = 0.0


@njit(cache=True)
def min_norm_x(A, piv, beta, k, r, x):
    """x = B^+ r as min_norm_solve, without the multipliers (nothing allocated)."""
    _r_transpose_solve(A, piv, k, r, x)
    apply_q(A, beta, k, x)                   # x = Q (z, 0)


@njit(cache=True)
def min_norm_solve(A, piv, beta, k, r, x, lam):
    """From qr_pivoted of B^T (A holding B row-wise): x = B^+ r (minimum norm; r's rows beyond
    the rank dropped) and, when lam has entries, lam = (B B^T)^+ r with B^T lam = x."""
    # z lives in x[:k] (no allocation); lam is solved from it before Q is applied
    _r_transpose_solve(A, piv, k, r, x)
    if lam.shape[0] > 0:
        lam[:] = 0.0
        for j in range(k - 1, -1, -1):       # R lam_p = z
            s = x[j]
            for i in range(j + 1, k):
                s -= A[i, j] * lam[piv[i]]
            lam[piv[j]] = s / A[j, j]
    apply_q(A, beta, k, x)                   # x = Q (z, 0)


# ------------------------------------------------------------------ Cholesky with diagonal pivoting
# Where the rows are far from rank loss, the solves above take the Gram matrix's Cholesky factor
# instead of the pivoted QR: G = A A^T costs m^2 n / 2 products and its factor m^3 / 6, against
# the QR's 2 m^2 n - 2 m^3 / 3 (and S = B B^T is formed anyway by schur_complement). Diagonal
# pivoting picks the largest remaining diagonal of the Schur complement: in exact arithmetic the
# pivot order and R^T of qr_pivoted (Golub & Van Loan, sec. 5.4.2 and 4.2.8), computed from G,
# so a pivot carries G's round-off eps |G| instead of A's: the callers take it only while every
# pivot of G stays above a gate (their relative accuracy is then eps / gate, Higham, Accuracy
# and Stability of Numerical Algorithms, 2nd ed., thm. 10.4 / sec. 20.4) and use the QR below it.
@njit(cache=True)
def gram_rows(A, rows, cols, ncols, G):
    """G = A[rows] A[rows]^T (both triangles), as schur_complement's S."""
    m = rows.shape[0]
    if m < WIDE:
        _gram(A, rows, cols, ncols, G, True)
        return
    At = np.empty((A.shape[1], m))
    for c in range(m):
        rc = rows[c]
        for k in range(A.shape[1]):
            At[k, c] = A[rc, k]
    _gram_wide(At, rows, cols, ncols, G)


@njit(cache=True)
def _gram_wide(At, rows, cols, ncols, G):
    """_gram from WIDE rows on At = A'^T, the same bits: G[r, c] for the c of one line summed
    together along At's rows (acc[c] += A'[r, k] A'[c, k] over the line's support, k ascending,
    from zero: _gram_line's sums, as vector instructions)."""
    m = rows.shape[0]
    later = earlier = 0
    for r in range(m):
        later += (r + 1) * ncols[rows[r]]
        earlier += (m - r) * ncols[rows[r]]
    acc = np.empty(m)
    for r in range(m):
        lo, hi = (0, r + 1) if later <= earlier else (r, m)
        seg = acc[lo:hi]
        seg[:] = 0.0
        sr = rows[r]
        ns = ncols[sr]
        kk = 0
        while kk + 4 <= ns:                # four support entries per pass, added in order
            k0, k1, k2, k3 = cols[sr, kk], cols[sr, kk + 1], cols[sr, kk + 2], cols[sr, kk + 3]
            _axpy_plus4(seg, At[k0, lo:hi], At[k1, lo:hi], At[k2, lo:hi], At[k3, lo:hi],
                        At[k0, r], At[k1, r], At[k2, r], At[k3, r])
            kk += 4
        while kk < ns:
            k = cols[sr, kk]
            _axpy_plus(seg, At[k, lo:hi], At[k, r])
            kk += 1
        if later <= earlier:           # G[r, :r + 1], mirrored below
            for c in range(r + 1):
                G[r, c] = seg[c]
        else:                          # G[r:, r] kept in G[r, r:], mirrored below
            for c in range(m - r):
                G[r, r + c] = seg[c]
    if later <= earlier:
        for r in range(m):
            for c in range(r):
                G[c, r] = G[r, c]
    else:
        for r in range(m):
            for c in range(r):
                G[r, c] = G[c, r]


@njit(cache=True, inline="always")
def _axpy_plus4(y, a, b, c, e, ca, cb, cc, ce):
    """y <- (((y + a ca) + b cb) + c cc) + e ce: four _axpy_plus in that order, one pass."""
    for i in range(y.shape[0]):
        y[i] = (((y[i] + a[i] * ca) + b[i] * cb) + c[i] * cc) + e[i] * ce


@njit(cache=True, inline="always")
def _axpy_plus(y, x, a):
    """y += x a (views from index 0, as _axpy)."""
    for i in range(y.shape[0]):
        y[i] += x[i] * a


@njit(cache=True, inline="always")
def support_runs_add(x, a, cols_r, n, w):
    """x[k] += a[k] w for k in one row's support cols_r[:n] (ascending): the same operation on
    each x[k] as a loop over the support, done run by run of consecutive columns as _axpy_plus
    (vector instructions; A02's rows are two runs, a chain prefix and a crank). x[k] - a[k] w
    is this with -w (IEEE subtraction is the addition of the negation: the same bits)."""
    kk = 0
    while kk < n:
        lo = cols_r[kk]
        e = kk + 1
        while e < n and cols_r[e] == cols_r[e - 1] + 1:
            e += 1
        hi = cols_r[e - 1] + 1
        _axpy_plus(x[lo:hi], a[lo:hi], w)
        kk = e


@njit(cache=True, inline="always")
def _gram(A, rows, cols, ncols, G, indirect):
    """G = A' A'^T (both triangles) with A' = A[rows] (``indirect``) or A's first len(rows) rows,
    A' row r zero outside cols[rows[r]][:ncols[rows[r]]] (ascending). Each G[r, c] (c <= r) sums
    over one of the two rows' supports in order from zero: the products skipped are exact zeros
    and the others come in the dense sum's order, so either support gives the same bits. Which:
    the later row's (r) for every c, or the earlier row's (c) for every r, whichever needs fewer
    products in all (an O(m) count): supports that grow along the rows (A02's chain, each loop
    one coupler deeper) cost half with the earlier's (80 rows: 22 us against 53, 2026-11-27). Four sums that
    share the support at a time: independent chains of additions the processor overlaps (30% less
    than one at a time at 16 rows)."""
    m = rows.shape[0]
    later = earlier = 0
    for r in range(m):
        later += (r + 1) * ncols[rows[r]]
        earlier += (m - r) * ncols[rows[r]]
    if later <= earlier:
        for r in range(m):
            _gram_line(A, rows, cols, ncols, G, indirect, r, 0, r + 1, False)
    else:
        for c in range(m):
            _gram_line(A, rows, cols, ncols, G, indirect, c, c, m, True)
    for r in range(m):
        for c in range(r):
            G[c, r] = G[r, c]


@njit(cache=True, inline="always")
def _gram_line(A, rows, cols, ncols, G, indirect, r, lo, hi, column):
    """G[r, c] for c in [lo, hi) over row r's support (``column``: G[c, r], the same sums)."""
    ar = rows[r] if indirect else r
    sr = rows[r]
    ns = ncols[sr]
    c = lo
    while c + 4 <= hi:
        if indirect:
            c0, c1, c2, c3 = rows[c], rows[c + 1], rows[c + 2], rows[c + 3]
        else:
            c0, c1, c2, c3 = c, c + 1, c + 2, c + 3
        s0 = s1 = s2 = s3 = 0.0
        for kk in range(ns):
            k = cols[sr, kk]
            x = A[ar, k]
            s0 += x * A[c0, k]
            s1 += x * A[c1, k]
            s2 += x * A[c2, k]
            s3 += x * A[c3, k]
        if column:
            G[c, r], G[c + 1, r], G[c + 2, r], G[c + 3, r] = s0, s1, s2, s3
        else:
            G[r, c], G[r, c + 1], G[r, c + 2], G[r, c + 3] = s0, s1, s2, s3
        c += 4
    while c < hi:
        cc = rows[c] if indirect else c
        s0 = 0.0
        for kk in range(ns):
            k = cols[sr, kk]
            s0 += A[ar, k] * A[cc, k]
        if column:
            G[c, r] = s0
        else:
            G[r, c] = s0
        c += 1


#: rows from which the dense kernels below (chol_pivoted, its solve, _gram, scaled_rows) run their
#: loops along contiguous memory, which the compiler turns into vector instructions (A02 N = 40's
#: 80 rows, benchmarks/bench_a02_scale.md). Each entry sees the same operations in the same order
#: on both sides of it: the same bits; below it the loops stay as they were, which is faster on a
#: few rows (no transposed copies, no allocation)
WIDE = 32


@njit(cache=True)
def chol_pivoted(G, piv, L, d, gate):
    """P^T G P = L L^T with diagonal pivoting (L lower in L, piv the order, d work), stopping
    at the first pivot below ``gate`` times the first: returns the ratio of the smallest pivot to
    the first (pivots of G, the squares of qr_pivoted's |R_jj|), or 0.0 when it stopped (the
    caller then takes the QR). G is read, not written. From WIDE rows L's strict upper triangle
    holds L^T as well (_chol_pivoted_wide; chol_solve_pivoted reads it); below, it is not written."""
    if G.shape[0] >= WIDE:
        return _chol_pivoted_wide(G, piv, L, d, gate)
    return _chol_pivoted_rows(G, piv, L, d, gate)


@njit(cache=True, inline="always")
def _pivots_start(G, piv, d):
    """piv = 0, 1, ..., d = diag(G); returns G's size."""
    for i in range(G.shape[0]):
        piv[i] = i
        d[i] = G[i, i]
    return G.shape[0]


@njit(cache=True, inline="always")
def _next_pivot(piv, d, j, gate, first):
    """Pivot step j of chol_pivoted: the largest remaining d[i] (i >= j, the first of equal
    ones) moved to position j of piv and d. Returns (where it came from, or -1 when it is not
    above ``gate`` times the first pivot; the first pivot, set at j = 0)."""
    p = j
    for i in range(j + 1, d.shape[0]):
        if d[i] > d[p]:
            p = i
    if p != j:
        piv[j], piv[p] = piv[p], piv[j]
        d[j], d[p] = d[p], d[j]
    if j == 0:
        first = d[0]
    return (p if d[j] > gate * first else -1), first


@njit(cache=True, inline="always")
def _chol_pivoted_rows(G, piv, L, d, gate):
    """chol_pivoted below WIDE rows: L[i, j] as a sum along rows i and j of L."""
    m = _pivots_start(G, piv, d)
    first, low = 0.0, np.inf
    for j in range(m):
        p, first = _next_pivot(piv, d, j, gate, first)
        if p < 0:
            return 0.0
        for k in range(j if p != j else 0):     # rows j and p of L
            L[j, k], L[p, k] = L[p, k], L[j, k]
        dj = d[j]
        low = min(low, dj)
        ljj = np.sqrt(dj)
        L[j, j] = ljj
        pj = piv[j]
        i = j + 1
        while i + 3 < m:                    # four rows at a time: independent sums, each in order
            s0, s1, s2, s3 = G[piv[i], pj], G[piv[i + 1], pj], G[piv[i + 2], pj], G[piv[i + 3], pj]
            for k in range(j):
                ljk = L[j, k]
                s0 -= L[i, k] * ljk
                s1 -= L[i + 1, k] * ljk
                s2 -= L[i + 2, k] * ljk
                s3 -= L[i + 3, k] * ljk
            s0 /= ljj
            s1 /= ljj
            s2 /= ljj
            s3 /= ljj
            L[i, j], L[i + 1, j], L[i + 2, j], L[i + 3, j] = s0, s1, s2, s3
            d[i] -= s0 * s0
            d[i + 1] -= s1 * s1
            d[i + 2] -= s2 * s2
            d[i + 3] -= s3 * s3
            i += 4
        while i < m:
            s0 = G[piv[i], pj]
            for k in range(j):
                s0 -= L[i, k] * L[j, k]
            s0 /= ljj
            L[i, j] = s0
            d[i] -= s0 * s0
            i += 1
    return low / first if m else 1.0


@njit(cache=True)
def chol_solve_pivoted(L, piv, r, y, x):
    """x = G^-1 r from chol_pivoted's factor (y: work of len m; x may be r). From WIDE rows
    both solves read L^T from the factor's upper triangle (contiguous rows), in the same order:
    the same bits."""
    m = L.shape[0]
    for i in range(m):
        y[i] = r[piv[i]]
    if m >= WIDE:
        mirrored_lower_solve(L, y)
        for i in range(m - 1, -1, -1):     # lower_t_solve with L[k, i] read as L[i, k]
            s = y[i]
            for k in range(i + 1, m):
                s -= L[i, k] * y[k]
            y[i] = s / L[i, i]
    else:
        lower_solve(L, m, y)
        lower_t_solve(L, m, y)
    for i in range(m):
        x[piv[i]] = y[i]


@njit(cache=True, inline="always")
def mirrored_lower_solve(L, y):
    """y <- L^-1 y as lower_solve (the same products subtracted from each y[i] in the same
    order, k ascending), column by column: after y[k] is final, y[k+1:] -= L[k+1:, k] y[k] with
    that column read from the upper triangle (row k, contiguous; _chol_pivoted_wide's mirror)."""
    m = y.shape[0]
    k = 0
    while k + 4 <= m:      # four columns per pass: y[k..k+3] first, then the rest in one _axpy4
        y0 = y[k] / L[k, k]
        y[k + 1] -= L[k, k + 1] * y0
        y1 = y[k + 1] / L[k + 1, k + 1]
        y[k + 2] = (y[k + 2] - L[k, k + 2] * y0) - L[k + 1, k + 2] * y1
        y2 = y[k + 2] / L[k + 2, k + 2]
        y[k + 3] = ((y[k + 3] - L[k, k + 3] * y0) - L[k + 1, k + 3] * y1) - L[k + 2, k + 3] * y2
        y3 = y[k + 3] / L[k + 3, k + 3]
        y[k], y[k + 1], y[k + 2], y[k + 3] = y0, y1, y2, y3
        _axpy4(y[k + 4:], L[k, k + 4:], L[k + 1, k + 4:], L[k + 2, k + 4:], L[k + 3, k + 4:], y0, y1, y2, y3)
        k += 4
    while k < m:
        yk = y[k] / L[k, k]
        y[k] = yk
        _axpy(y[k + 1:], L[k, k + 1:], yk)
        k += 1


@njit(cache=True, inline="always")
def _axpy(y, x, a):
    """y -= x a (views from index 0: the loop the compiler vectorizes; a range starting
    elsewhere keeps numba's negative-index test, which it does not)."""
    for i in range(y.shape[0]):
        y[i] -= x[i] * a


@njit(cache=True)
def _chol_pivoted_wide(G, piv, L, d, gate):
    """chol_pivoted from WIDE rows, the same bits: column j of L in pivot order is built in
    row j of the upper triangle (U = L^T, U[k, i] = L[i, k]) as
        U[j, i] = (G[piv[i], piv[j]] - sum_k U[k, i] U[k, j]) / U[j, j],   k = 0, 1, ..., j - 1
    in that order, as chol_pivoted sums L[i, k] L[j, k], but as axpys along U's rows, four k at
    a time (contiguous: vector instructions, 0.77-0.90x the row-wise sums' time at 80 rows). A pivot
    swap exchanges columns j and p of U's first j rows. The lower triangle is copied from U at
    the end. w: row j's sums (not L's own row, so the compiler needs no aliasing test)."""
    m = _pivots_start(G, piv, d)
    w = np.empty(m)
    first, low = 0.0, np.inf
    for j in range(m):
        p, first = _next_pivot(piv, d, j, gate, first)
        if p < 0:
            return 0.0
        for k in range(j if p != j else 0):     # columns j and p of U's first j rows
            L[k, j], L[k, p] = L[k, p], L[k, j]
        low = min(low, d[j])
        ljj = L[j, j] = np.sqrt(d[j])
        for i in range(j + 1, m):               # G's column piv[j] in pivot order
            w[i] = G[piv[i], piv[j]]
        wj = w[j + 1:]
        k = 0
        while k + 4 <= j:
            _axpy4(wj, L[k, j + 1:], L[k + 1, j + 1:], L[k + 2, j + 1:], L[k + 3, j + 1:],
                   L[k, j], L[k + 1, j], L[k + 2, j], L[k + 3, j])
            k += 4
        while k < j:
            _axpy(wj, L[k, j + 1:], L[k, j])
            k += 1
        uj, dv = L[j, j + 1:], d[j + 1:]
        for i in range(m - j - 1):
            s = wj[i] / ljj
            uj[i] = s
            dv[i] -= s * s
    for j in range(m):
        for i in range(j + 1, m):
            L[i, j] = L[j, i]
    return low / first


@njit(cache=True, inline="always")
def _axpy4(y, a, b, c, e, ca, cb, cc, ce):
    """y <- (((y - a ca) - b cb) - c cc) - e ce: four axpys in that order, one pass."""
    for i in range(y.shape[0]):
        y[i] = (((y[i] - a[i] * ca) - b[i] * cb) - c[i] * cc) - e[i] * ce


@njit(cache=True, inline="always")
def lower_solve(L, m, y):
    """y[:m] <- L^-1 y[:m], L lower triangular (its leading m x m block)."""
    for i in range(m):
        s = y[i]
        for k in range(i):
            s -= L[i, k] * y[k]
        y[i] = s / L[i, i]


@njit(cache=True, inline="always")
def lower_t_solve(L, m, y):
    """y[:m] <- L^-T y[:m]."""
    for i in range(m - 1, -1, -1):
        s = y[i]
        for k in range(i + 1, m):
            s -= L[k, i] * y[k]
        y[i] = s / L[i, i]
