"""Compiled kernels of the right-hand side (numba).

Why: after Pinocchio's tree algorithms (a few microseconds), the closure rows and the KKT solve
are ~40 small numpy calls whose per-call overhead dominated the four-bar right-hand side
(~100 us vs ~5 us for pin.constraintDynamics). These loops over closure *rows* (not bodies)
do the same arithmetic in one compiled call each. The maths is documented in
pinclear.closures and pinclear.kinematics.FrameKinematics.
"""
from __future__ import annotations

import numpy as np

try:
    from numba import njit
except ImportError:  # pragma: no cover - numba is a declared dependency; keep importable
    def njit(*args, **kwargs):
        if args and callable(args[0]):
            return args[0]
        return lambda f: f

# primitive codes of CompiledClosures.table
POINT, PLANE, DOT, PERP, DIST = 0, 1, 2, 3, 4


@njit(cache=True, fastmath=False)
def _cross(a0, a1, a2, b0, b1, b2):
    return a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0


@njit(cache=True)
def frame_kinematics(H, mask, J, dJ, v, Jv, Jw, V, W, A, Al):
    """Frame Jacobians (origin velocity, angular; world axes), velocities and zero-ddq
    classical accelerations of every frame in H (F, 4, 4) from the tree's WORLD J, dJ."""
    F = H.shape[0]
    nv = J.shape[1]
    for f in range(F):
        px, py, pz = H[f, 0, 3], H[f, 1, 3], H[f, 2, 3]
        vo0 = vo1 = vo2 = w0 = w1 = w2 = 0.0
        ao0 = ao1 = ao2 = al0 = al1 = al2 = 0.0
        for k in range(nv):
            if mask[f, k] == 0.0:
                for i in range(3):
                    Jv[f, i, k] = 0.0
                    Jw[f, i, k] = 0.0
                continue
            jx, jy, jz = J[3, k], J[4, k], J[5, k]
            cx, cy, cz = _cross(jx, jy, jz, px, py, pz)
            Jw[f, 0, k], Jw[f, 1, k], Jw[f, 2, k] = jx, jy, jz
            Jv[f, 0, k], Jv[f, 1, k], Jv[f, 2, k] = J[0, k] + cx, J[1, k] + cy, J[2, k] + cz
            vk = v[k]
            vo0 += J[0, k] * vk
            vo1 += J[1, k] * vk
            vo2 += J[2, k] * vk
            w0 += jx * vk
            w1 += jy * vk
            w2 += jz * vk
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
def closure_rows(table, E, L, H, Jv, Jw, V, W, A, Al, phi, Jc, bias, dphi):
    """Residual, Jacobian, bias and J v of every closure primitive (see pinclear.closures).

    table rows: (code, i1, i2, row0, a, b); E (n, 2, 3) plane bases; L (n,) lengths."""
    nv = Jc.shape[1]
    for p in range(table.shape[0]):
        code, i1, i2, r = table[p, 0], table[p, 1], table[p, 2], table[p, 3]
        if code == POINT:
            for i in range(3):
                phi[r + i] = H[i1, i, 3] - H[i2, i, 3]
                dphi[r + i] = V[i1, i] - V[i2, i]
                bias[r + i] = A[i1, i] - A[i2, i]
                for k in range(nv):
                    Jc[r + i, k] = Jv[i1, i, k] - Jv[i2, i, k]
        elif code == PLANE:
            for j in range(2):
                s = ds = sb = 0.0
                for i in range(3):
                    e = E[p, j, i]
                    s += e * (H[i1, i, 3] - H[i2, i, 3])
                    ds += e * (V[i1, i] - V[i2, i])
                    sb += e * (A[i1, i] - A[i2, i])
                phi[r + j], dphi[r + j], bias[r + j] = s, ds, sb
                for k in range(nv):
                    acc = 0.0
                    for i in range(3):
                        acc += E[p, j, i] * (Jv[i1, i, k] - Jv[i2, i, k])
                    Jc[r + j, k] = acc
        elif code == DOT:
            # u fixed in body 1, w fixed in body 2: d(u.w)/dt = (u x w).(w1 - w2)
            a, b = table[p, 4], table[p, 5]
            u0, u1, u2 = H[i1, 0, a], H[i1, 1, a], H[i1, 2, a]
            x0, x1, x2 = H[i2, 0, b], H[i2, 1, b], H[i2, 2, b]
            c0, c1, c2 = _cross(u0, u1, u2, x0, x1, x2)
            dw0, dw1, dw2 = W[i1, 0] - W[i2, 0], W[i1, 1] - W[i2, 1], W[i1, 2] - W[i2, 2]
            phi[r] = u0 * x0 + u1 * x1 + u2 * x2
            dphi[r] = c0 * dw0 + c1 * dw1 + c2 * dw2
            du0, du1, du2 = _cross(W[i1, 0], W[i1, 1], W[i1, 2], u0, u1, u2)
            dx0, dx1, dx2 = _cross(W[i2, 0], W[i2, 1], W[i2, 2], x0, x1, x2)
            p0, p1, p2 = _cross(du0, du1, du2, x0, x1, x2)
            q0, q1, q2 = _cross(u0, u1, u2, dx0, dx1, dx2)
            bias[r] = (c0 * (Al[i1, 0] - Al[i2, 0]) + c1 * (Al[i1, 1] - Al[i2, 1]) + c2 * (Al[i1, 2] - Al[i2, 2])
                       + (p0 + q0) * dw0 + (p1 + q1) * dw1 + (p2 + q2) * dw2)
            for k in range(nv):
                Jc[r, k] = (c0 * (Jw[i1, 0, k] - Jw[i2, 0, k]) + c1 * (Jw[i1, 1, k] - Jw[i2, 1, k])
                            + c2 * (Jw[i1, 2, k] - Jw[i2, 2, k]))
        elif code == PERP:
            # u fixed in body 1, d = p2 - p1: d(u.d)/dt = u.(v2 - v1) + (u x d).w1
            a = table[p, 4]
            u0, u1, u2 = H[i1, 0, a], H[i1, 1, a], H[i1, 2, a]
            d0, d1, d2 = H[i2, 0, 3] - H[i1, 0, 3], H[i2, 1, 3] - H[i1, 1, 3], H[i2, 2, 3] - H[i1, 2, 3]
            e0, e1, e2 = V[i2, 0] - V[i1, 0], V[i2, 1] - V[i1, 1], V[i2, 2] - V[i1, 2]
            c0, c1, c2 = _cross(u0, u1, u2, d0, d1, d2)
            w0, w1, w2 = W[i1, 0], W[i1, 1], W[i1, 2]
            phi[r] = u0 * d0 + u1 * d1 + u2 * d2
            dphi[r] = u0 * e0 + u1 * e1 + u2 * e2 + c0 * w0 + c1 * w1 + c2 * w2
            du0, du1, du2 = _cross(w0, w1, w2, u0, u1, u2)
            f0, f1, f2 = _cross(du0, du1, du2, d0, d1, d2)
            g0, g1, g2 = _cross(u0, u1, u2, e0, e1, e2)
            bias[r] = (u0 * (A[i2, 0] - A[i1, 0]) + u1 * (A[i2, 1] - A[i1, 1]) + u2 * (A[i2, 2] - A[i1, 2])
                       + c0 * Al[i1, 0] + c1 * Al[i1, 1] + c2 * Al[i1, 2]
                       + du0 * e0 + du1 * e1 + du2 * e2 + (f0 + g0) * w0 + (f1 + g1) * w1 + (f2 + g2) * w2)
            for k in range(nv):
                Jc[r, k] = (u0 * (Jv[i2, 0, k] - Jv[i1, 0, k]) + u1 * (Jv[i2, 1, k] - Jv[i1, 1, k])
                            + u2 * (Jv[i2, 2, k] - Jv[i1, 2, k])
                            + c0 * Jw[i1, 0, k] + c1 * Jw[i1, 1, k] + c2 * Jw[i1, 2, k])
        else:  # DIST: |p1 - p2| = L
            d0, d1, d2 = H[i1, 0, 3] - H[i2, 0, 3], H[i1, 1, 3] - H[i2, 1, 3], H[i1, 2, 3] - H[i2, 2, 3]
            e0, e1, e2 = V[i1, 0] - V[i2, 0], V[i1, 1] - V[i2, 1], V[i1, 2] - V[i2, 2]
            nd = np.sqrt(d0 * d0 + d1 * d1 + d2 * d2)
            n0, n1, n2 = d0 / nd, d1 / nd, d2 / nd
            ndd = n0 * e0 + n1 * e1 + n2 * e2
            phi[r] = nd - L[p]
            dphi[r] = ndd
            bias[r] = (n0 * (A[i1, 0] - A[i2, 0]) + n1 * (A[i1, 1] - A[i2, 1]) + n2 * (A[i1, 2] - A[i2, 2])
                       + (e0 * e0 + e1 * e1 + e2 * e2 - ndd * ndd) / nd)
            for k in range(nv):
                Jc[r, k] = (n0 * (Jv[i1, 0, k] - Jv[i2, 0, k]) + n1 * (Jv[i1, 1, k] - Jv[i2, 1, k])
                            + n2 * (Jv[i1, 2, k] - Jv[i2, 2, k]))


@njit(cache=True)
def _chol_upper(M, L):
    """L L^T = M reading M's upper triangle (what crba fills). Returns min/max pivot ratio."""
    n = M.shape[0]
    pmin, pmax = np.inf, 0.0
    for j in range(n):
        s = M[j, j]
        for k in range(j):
            s -= L[j, k] * L[j, k]
        if s <= 0.0:
            return 0.0
        d = np.sqrt(s)
        L[j, j] = d
        pmin, pmax = min(pmin, s), max(pmax, s)
        for i in range(j + 1, n):
            s2 = M[j, i]          # upper triangle
            for k in range(j):
                s2 -= L[i, k] * L[j, k]
            L[i, j] = s2 / d
    return pmin / pmax


@njit(cache=True)
def _chol_solve(L, B):
    """Solve L L^T X = B in place (B: (n,) or (n, m) as 2-D)."""
    n = L.shape[0]
    m = B.shape[1]
    for c in range(m):
        for i in range(n):
            s = B[i, c]
            for k in range(i):
                s -= L[i, k] * B[k, c]
            B[i, c] = s / L[i, i]
        for i in range(n - 1, -1, -1):
            s = B[i, c]
            for k in range(i + 1, n):
                s -= L[k, i] * B[k, c]
            B[i, c] = s / L[i, i]


@njit(cache=True)
def kkt_solve(M, f, J, gamma, rows, Lm, X, S, Ls, a, lam):
    """Schur-complement solve of  M a - J^T lam = f,  J a = gamma  over the selected rows.

    Work arrays: Lm (nv, nv), X (nv, 1 + m), S, Ls (m, m). Returns the smallest/largest pivot
    ratio of S's Cholesky (0 when S is not positive definite): the caller's rank test."""
    nv = M.shape[0]
    m = rows.shape[0]
    if _chol_upper(M, Lm) == 0.0:
        return -1.0
    # X = M^-1 [f, J^T]
    for i in range(nv):
        X[i, 0] = f[i]
        for c in range(m):
            X[i, 1 + c] = J[rows[c], i]
    _chol_solve(Lm, X[:, : 1 + m])
    for i in range(nv):
        a[i] = X[i, 0]
    if m == 0:
        return 1.0
    # S = J M^-1 J^T (upper), r = gamma - J a_free
    for r in range(m):
        for c in range(r, m):
            s = 0.0
            for k in range(nv):
                s += J[rows[r], k] * X[k, 1 + c]
            S[r, c] = s
    ratio = _chol_upper(S[:m, :m], Ls[:m, :m])
    if ratio == 0.0:
        return 0.0
    R = np.empty((m, 1))
    for r in range(m):
        s = gamma[rows[r]]
        for k in range(nv):
            s -= J[rows[r], k] * a[k]
        R[r, 0] = s
    _chol_solve(Ls[:m, :m], R)
    for r in range(m):
        lam[r] = R[r, 0]
    for i in range(nv):
        s = a[i]
        for c in range(m):
            s += X[i, 1 + c] * R[c, 0]
        a[i] = s
    return ratio
