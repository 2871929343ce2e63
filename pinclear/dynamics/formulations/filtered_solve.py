"""The filtered solve of the singular-passage formulation (pinclear.dynamics.formulations.manifold):
x = g(S) r with g(s) = s / (s^2 + mu^4), from a shifted complex factor of S + i mu^2 I per group of
rows, or from a short series on a pivoted Cholesky factor when the shifts are small (numba).
"""
from __future__ import annotations

from pinclear.core.dense import WIDE, _axpy4, lower_solve, mirrored_lower_solve
from pinclear.core.jit import njit


@njit(cache=True, inline="always")
def group_shifts(S, mu, grp, gcnt, gsum):
    """gsum[g] = mu^2 times the mean of diag(S) over unit group g's closure rows (the first
    len(grp) rows; shifted_factor's Lam), at least 1e-30 of the mean over all of them."""
    mc = grp.shape[0]
    gsum[:] = 0.0
    tr = 0.0
    for i in range(mc):
        gsum[grp[i]] += S[i, i]
        tr += S[i, i]
    floor = max(1e-30 * tr / max(mc, 1), 1e-300)     # a group whose rows are all zero here
    for g in range(gsum.shape[0]):
        gsum[g] = mu * mu * max(gsum[g] / gcnt[g], floor)


@njit(cache=True)
def row_shifts(S, mu, grp, gcnt, gsum, dsh):
    """dsh = diag(mu^2 Lam): each closure row's group shift (group_shifts), 0 on the drive rows."""
    group_shifts(S, mu, grp, gcnt, gsum)
    for i in range(S.shape[0]):
        dsh[i] = gsum[grp[i]] if i < grp.shape[0] else 0.0


#: series_filtered gives up when a term is above this fraction of the one before (then it would
#: need more than SERIES_TERMS terms to reach rounding) or after SERIES_TERMS terms
SERIES_RATIO = 1e-2
SERIES_TERMS = 8


@njit(cache=True)
def series_filtered(Lc, pc, dsh, r, w, t, u, y):
    """w = g(S) r = Re[(S + i D)^-1 r], D = diag(dsh), from S's pivoted Cholesky factor (Lc, pc:
    pinclear.core.dense.chol_pivoted) instead of the complex factor of S + i D (shifted_factor);
    t, u, y: work of len m. With (S + i D)(x + i z) = r, z = -S^-1 D x and
        x = S^-1 r - T x = sum_k (-T)^k S^-1 r,   T = S^-1 D S^-1 D,
    which converges where the spectral radius rho^2 of T is below 1: far from a flat
    configuration, where D = mu^2 Lam is far below S's smallest eigenvalue (A02 N = 40:
    rho = 2e-4 .. 1e-2 at 90 % of its states, 3 terms to rounding). Two Cholesky solves (2 m^2)
    per term against the factor's m^3 / 6 complex products: a few terms cost a fraction of
    shifted_factor and its solve (benchmarks/kernel_choices.md). Terms are added
    until one is below eps of w (max norms): w is then g(S) r to rounding, as the factor's (both
    ~ eps cond(S)). False when a term is above
    SERIES_RATIO of the one before or SERIES_TERMS pass (near flat; w is then not g(S) r and the
    caller takes the factor)."""
    m = r.shape[0]
    _chol_solve_rows(Lc, pc, r, y, w)        # S^-1 r
    prev = 0.0
    for i in range(m):
        t[i] = w[i]
        prev = max(prev, abs(w[i]))
    for _ in range(SERIES_TERMS):
        for i in range(m):
            u[i] = dsh[i] * t[i]
        _chol_solve_rows(Lc, pc, u, y, u)
        for i in range(m):
            u[i] *= dsh[i]
        _chol_solve_rows(Lc, pc, u, y, t)
        tn = wn = 0.0
        for i in range(m):
            t[i] = -t[i]
            w[i] += t[i]
            tn = max(tn, abs(t[i]))
            wn = max(wn, abs(w[i]))
        if tn <= 1.1102230246251565e-16 * wn:
            return True
        if not tn <= SERIES_RATIO * prev:
            return False
        prev = tn
    return False


@njit(cache=True, inline="always")
def _chol_solve_rows(L, piv, r, y, x):
    """x = S^-1 r from chol_pivoted's factor, as pinclear.core.dense.chol_solve_pivoted but with
    L^-T applied row by row (y[k] -= L[i, k] y[i], contiguous and free of a chain of additions)
    instead of down L's columns: the same products, summed in another order (rounding apart,
    the same x); the series takes 1 + 2 per term of these solves."""
    m = L.shape[0]
    for i in range(m):
        y[i] = r[piv[i]]
    i = m - 1
    if m >= WIDE:
        mirrored_lower_solve(L, y)       # the same bits along the factor's mirror (chol_pivoted)
        while i >= 3:                    # four rows per pass, the same order (i descending)
            y0 = y[i] / L[i, i]
            y[i - 1] -= L[i, i - 1] * y0
            y1 = y[i - 1] / L[i - 1, i - 1]
            y[i - 2] = (y[i - 2] - L[i, i - 2] * y0) - L[i - 1, i - 2] * y1
            y2 = y[i - 2] / L[i - 2, i - 2]
            y[i - 3] = ((y[i - 3] - L[i, i - 3] * y0) - L[i - 1, i - 3] * y1) - L[i - 2, i - 3] * y2
            y3 = y[i - 3] / L[i - 3, i - 3]
            y[i], y[i - 1], y[i - 2], y[i - 3] = y0, y1, y2, y3
            _axpy4(y[:i - 3], L[i, :i - 3], L[i - 1, :i - 3], L[i - 2, :i - 3], L[i - 3, :i - 3], y0, y1, y2, y3)
            i -= 4
    else:
        lower_solve(L, m, y)
    while i >= 0:
        yi = y[i] / L[i, i]
        y[i] = yi
        for k in range(i):
            y[k] -= L[i, k] * yi
        i -= 1
    for i in range(m):
        x[piv[i]] = y[i]


@njit(cache=True)
def shifted_factor(S, mu, grp, gcnt, gsum, Fr, Fi):
    """The filter g(S) = Re[(S + i mu^2 Lam)^-1] (docs/singular_passages.md, "The filter"). Lam
    is diagonal: on a closure row (the first len(grp)), the mean of diag(S) over the row's unit
    group (``grp``: a closure's length rows, its angle rows; ``gcnt`` rows each; ``gsum`` work);
    on a drive row (the rest), 0. Why:
    * none on the drives: eliminating their rows first is exact, so g is the filter of the
      closures' own system with the driven joints locked (the Schur complement C), and the drive
      rows hold exactly (on a row with Lam_ii = 0 the real part of (S + i mu^2 Lam) z = r is
      (S w)_i = r_i). One shift mu^2 mean(diag S) on every row would take the spread a drive
      adds to S for a flat closure: accelerations off by 5 % on the nine-bar linkage at regular
      configurations (4.1e-5 with the shifts per row);
    * per group: Lam = D^-2 makes g(S) = D g1(D S D) D with g1 on the scaled eigenvalues, so
      B^T g(S) r does not change when a group's rows change unit (angles against lengths in mm,
      a heavy platform): 3-UPRU+UP's angle rows have 5000 times the diagonal of its length rows,
      and one shift for both filtered its regular configuration (accelerations off by 94 %;
      3.5e-4 now). Not per row: a row can vanish at flat (A02's y rows), and a per-row scale
      then hides the flat passage from the filter (A02 N = 2 crank acceleration off by 1.7e-3 at
      1e-4 rad from flat, measured); a group's mean does not vanish. A fixed-per-group D keeps
      the discarded part along B^T n (n: S's vanishing direction), as the isotropic shift does.
    On the scaled eigenvalues g1(s) = s / (s^2 + mu^4): 1/s where s >> mu^2 (the exact inverse),
    s / mu^4 below: on the normal part only, whose round-off it would otherwise amplify near
    flat; the price is a relative error (mu^2 / s)^2 where s is not far above mu^2 (4-UPS-UPR:
    3.6e-2 on its accelerations, s from 0.9 to 18 mu^2 over its first 0.3 s).
    Factors the complex symmetric S + i mu^2 Lam = L D L^T in place (L unit lower in Fr/Fi's
    strict lower triangle, D on the diagonal; real parts in Fr, imaginary in Fi). No pivoting,
    and no pivot vanishes: x^H (S + i mu^2 Lam) x has real part x^H S x >= 0 and imaginary part
    mu^2 x^H Lam x >= 0, both zero only for x on the drive rows with E^T x = 0 (E's rows: unit
    vectors of distinct joints), i.e. x = 0, and the same holds for every leading block. About
    m^3 / 6 complex products, against an eigensolver's ~9 m^3 and its workspace allocations
    (30 us at m = 20)."""
    m, mc = S.shape[0], grp.shape[0]
    group_shifts(S, mu, grp, gcnt, gsum)
    # row j's L[j, k] D[k] (k < j) once, then each entry below costs one complex product per k;
    # kept in the (unused) strict upper triangle, column j: no work array to allocate. Complex
    # numbers as (real, imaginary) pairs, two rows i at a time (independent sums the processor
    # overlaps) and 1 / d once per column: 1.4-2.4x faster at 16 rows (three runs) than
    # complex() products and one division per entry (the same operations otherwise)
    for j in range(m):
        dr, di = S[j, j], (gsum[grp[j]] if j < mc else 0.0)
        for k in range(j):
            lr, li = Fr[j, k], Fi[j, k]
            er, ei = Fr[k, k], Fi[k, k]
            wr, wi = lr * er - li * ei, lr * ei + li * er
            Fr[k, j], Fi[k, j] = wr, wi
            dr -= lr * wr - li * wi
            di -= lr * wi + li * wr
        Fr[j, j], Fi[j, j] = dr, di
        n2 = dr * dr + di * di
        ir, ii = dr / n2, -di / n2
        i = j + 1
        while i + 1 < m:
            ar, ai, br, bi = S[i, j], 0.0, S[i + 1, j], 0.0
            for k in range(j):
                wr, wi = Fr[k, j], Fi[k, j]
                xr, xi, yr, yi = Fr[i, k], Fi[i, k], Fr[i + 1, k], Fi[i + 1, k]
                ar -= xr * wr - xi * wi
                ai -= xr * wi + xi * wr
                br -= yr * wr - yi * wi
                bi -= yr * wi + yi * wr
            Fr[i, j], Fi[i, j] = ar * ir - ai * ii, ar * ii + ai * ir
            Fr[i + 1, j], Fi[i + 1, j] = br * ir - bi * ii, br * ii + bi * ir
            i += 2
        if i < m:
            ar, ai = S[i, j], 0.0
            for k in range(j):
                wr, wi = Fr[k, j], Fi[k, j]
                xr, xi = Fr[i, k], Fi[i, k]
                ar -= xr * wr - xi * wi
                ai -= xr * wi + xi * wr
            Fr[i, j], Fi[i, j] = ar * ir - ai * ii, ar * ii + ai * ir


@njit(cache=True)
def filtered_solve_ws(Fr, Fi, r, w, yr, yi):
    """w = g(S) r = Re[(S + i mu^2 I)^-1 r] from shifted_factor's L D L^T, with the complex work
    vector in (yr, yi) (real and imaginary parts), so nothing is allocated."""
    m = r.shape[0]
    for i in range(m):
        s = complex(r[i], 0.0)
        for k in range(i):
            s -= complex(Fr[i, k], Fi[i, k]) * complex(yr[k], yi[k])
        yr[i], yi[i] = s.real, s.imag
    for i in range(m):
        y = complex(yr[i], yi[i]) / complex(Fr[i, i], Fi[i, i])
        yr[i], yi[i] = y.real, y.imag
    for i in range(m - 1, -1, -1):
        s = complex(yr[i], yi[i])
        for k in range(i + 1, m):
            s -= complex(Fr[k, i], Fi[k, i]) * complex(yr[k], yi[k])
        yr[i], yi[i] = s.real, s.imag
        w[i] = s.real
