"""Tree-sparse factorisation of the mass matrix (M = L^T L over the kinematic tree, Featherstone's
LTL) and the constraint solves built on it: scaled rows L^-T J^T, the Schur complement
J M^-1 J^T and the KKT solve (numba).
"""
from __future__ import annotations

import numpy as np

from pinclear.core.dense import WIDE, _axpy, _gram, _gram_wide, lower_solve, lower_t_solve
from pinclear.core.jit import njit


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
    walk of the tree for all rows: a walk per row over its support alone is no faster and often
    slower (benchmarks/kernel_choices.md). At dof k only the rows from the first to
    the last whose Y[r, k] is non-zero are updated: the others would subtract exact zeros (no bit
    changes). Y is zero outside the rows' supports (pinclear.model.kinematics.row_support), so on
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
