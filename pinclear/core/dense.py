"""Compiled kernels of the right-hand side (numba).

Why: after Pinocchio's tree algorithms (a few microseconds), the closure rows and the KKT solve
are ~40 small numpy calls whose per-call overhead dominated the four-bar right-hand side
(~100 us vs ~5 us for pin.constraintDynamics). These loops over closure *rows* (not bodies)
do the same arithmetic in one compiled call each. The maths is documented in
pinclear.model.closures and pinclear.model.kinematics.FrameKinematics.
"""
from __future__ import annotations

import numpy as np

from pinclear.core.jit import njit


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
    one dot product after another), which the processor overlaps, where one chain at a time
    waited on every addition (benchmarks/kernel_choices.md)."""
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
    one coupler deeper) cost half with the earlier's (benchmarks/kernel_choices.md). Four sums
    that share the support at a time: independent chains of additions the processor overlaps."""
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
