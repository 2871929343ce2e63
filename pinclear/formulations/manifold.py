"""Singular-passage formulation ("manifold"): the right-hand side is evaluated at the stage
state projected onto the constraint manifold (docs/singular_passages.md, "The manifold
formulation"). At every evaluation, from the stage state (q, v):

1. q1 = P(q): Gauss-Newton on Phi(q, t) = 0 with minimum-norm steps -J^+ Phi (Householder QR of
   J^T with column pivoting), moved with pin.integrate; always at least one step, so q1 is the
   same function of q whatever the stage's residual; more only while |Phi| > ``tol``;
2. v1 = v - M^-1 J^T g(S) (J v + Phi_t) at q1, with S = J M^-1 J^T = B B^T (B = J L^-1,
   M = L^T L tree-sparse, pinclear._kernels.ltl_factor) and the filter g(s) = s / (s^2 + mu^4)
   (mu^2 relative to mean(diag S)): S^-1 where s >> mu^2, nothing along the directions that
   vanish at a flat configuration;
3. a = L^-1 ((I - Q Q^T) y + B^T g(S) gamma), y = L^-T (tau - nle), gamma = -(dJ v1) v1 at
   (q1, v1), Q an orthonormal basis of range(B^T) (the same pivoted QR, truncated at pivots
   below ``rcond_v``). Where g(S) = S^-1 this is the exact a = L^-1 (y + B^+ (gamma - B y)).
4. near flat (smallest kept pivot below ``tangent`` times the largest), range(Q) is made
   orthogonal to x = L v1 first: exact arithmetic has x orthogonal to range(B^T) already, so
   this only replaces round-off (below).

Why (the study is in the doc): near a flat configuration one singular value sigma of B falls
like the crank angle eps. At a stage state d off the manifold the exact multipliers turn the
O(d) inconsistency of gamma - B y into an acceleration error ~ d / eps. At the projected state
that inconsistency is gone; what is left is round-off: Phi is known to ~1e-16, so q1 only to
1e-16 / sigma along the vanishing direction, the tangent there to 1e-16 / sigma^2, and the
exact velocity-squared term B^+ gamma to 1e-16 / sigma^3, which collapses the step size at
rtol 1e-10. Hence the split in 3: the reaction to the applied forces (Q Q^T y, a projector) is
exact at any eps and is what keeps the motion on its branch; the tangential acceleration
u^T M a = u^T (tau - nle) does not depend on the filter at all (u^T J^T = 0); only the
velocity-squared part and, at the stages, the velocity projection are filtered, which bounds
their round-off. That leaves the direction of the vanishing normal itself, known only to
1e-16 / sigma^2 at q1, so (I - Q Q^T) y leaked up to 1e-4 of gravity into the tangent near flat
and collapsed the step size on A02 N = 10 (docs/singular_passages.md). The velocity carries the
branch (it is O(1) away from the other branch's tangent, the position is not): step 4 takes the
tangential equation x^T L a = x^T y from it. After every accepted step the state is projected
with the exact velocity projection (``project``)."""
from __future__ import annotations

import numpy as np
import pinocchio as pin

from .. import kinematics
from .._bind import DYN, bind
from .._jit import njit
from .._kernels import constraint_rows_all, ltl_factor, ltl_solve, ltl_solve_t, schur_complement
from ..errors import InputError
from .base import Formulation


class Manifold(Formulation):
    name = "manifold"
    options = {"tol": 1e-12, "max_iter": 10, "rcond": 1e-13, "rcond_v": 1e-8, "mu": 1e-2, "tangent": 1e-3}
    supports_projection = True
    # accelerations() leaves the pass of the projected state in ws.data, not the one of (q, v)
    fills_workspace = False

    def __init__(self, mech, **options):
        super().__init__(mech, **options)
        for key in ("tol", "rcond", "rcond_v", "mu"):
            if not (np.isfinite(self.opts[key]) and self.opts[key] > 0):
                raise InputError(f"method 'manifold': option {key!r} must be a positive number, "
                                 f"got {self.opts[key]!r}", key=key)
        if not (np.isfinite(self.opts["tangent"]) and 0.0 <= self.opts["tangent"] < 1.0):
            raise InputError(f"method 'manifold': option 'tangent' must be a number in [0, 1) (a relative pivot; "
                             f"0: off), got {self.opts['tangent']!r}", key="tangent")
        nv, m = mech.nv, mech.m
        ws = self.ws
        if int(self.opts["max_iter"]) != self.opts["max_iter"] or self.opts["max_iter"] < 1:
            raise InputError(f"method 'manifold': option 'max_iter' must be an integer >= 1, "
                             f"got {self.opts['max_iter']!r}", key="max_iter")
        self.opts["max_iter"] = int(self.opts["max_iter"])      # 10.0 is accepted: range() needs the int
        # buffers: L (M = L^T L), Y = B, S = B B^T and the factor of S + i mu^2 I (Fr, Fi), the QR of
        # B^T (Qr, piv, hb, rank kk) and of J^T for the Gauss-Newton step (Qg, pg, hg)
        self._b = {"L": np.zeros((nv, nv)), "Y": np.zeros((m, nv)), "S": np.zeros((m, m)), "Fr": np.zeros((m, m)),
                   "Fi": np.zeros((m, m)), "Qr": np.zeros((nv, m)), "piv": np.zeros(m, dtype=np.int64),
                   "hb": np.zeros(m), "kk": np.zeros(1, dtype=np.int64), "rows": np.arange(m, dtype=np.int64),
                   "Qg": np.zeros((nv, m)), "pg": np.zeros(m, dtype=np.int64), "hg": np.zeros(m),
                   "dq": np.zeros(nv), "v1": np.zeros(nv), "a": np.zeros(nv)}
        self._rows = kinematics.static_args(mech, ws) + (0.0, 0.0)     # no Baumgarte terms
        o, M, b = self.opts, ws.data.M, self._b
        # kernels bound once to their persistent buffers (pinclear._bind): only q, v, t's drive
        # values (and whether the velocity projection is the exact one) change per call
        self._gn = bind(gauss_newton_step, self._rows + (DYN, ws.zero_v, DYN, float(o["rcond"]), b["Qg"], b["pg"],
                                                          b["hg"], b["dq"]))
        self._vp = bind(velocity_projection, self._rows + (DYN, DYN, DYN, M, ws.parent, b["rows"], float(o["mu"]),
                                                           float(o["rcond_v"]), b["L"], b["Y"], b["S"], b["Fr"], b["Fi"],
                                                           b["Qr"], b["piv"], b["hb"], b["kk"], DYN, b["v1"]))
        self._acc = bind(projected_accelerations, self._rows + (DYN, DYN, DYN, ws.tau, ws.data.nle, ws.parent, b["L"],
                                                               b["Y"], b["Fr"], b["Fi"], b["Qr"], b["piv"], b["hb"],
                                                               b["kk"], float(o["tangent"]), ws.lam, b["a"]))
        self._values = mech.driverows.values
        # stages: filtered velocity projection (see the module doc); after steps: exact
        self._stage_exact = 0
        self._nonfinite = False

    def finite(self, a):
        return not self._nonfinite

    # -------------------------------------------------------------- the projection P
    def _positions(self, q):
        """Joint placements and Jacobians at q (all the constraint rows read)."""
        ws = self.ws
        pin.computeJointJacobians(self.mech.model, ws.data, q)
        ws.fk.load_placements(ws.data, q)

    def _project(self, t, q, v, exact):
        """(q1, v1) = P(q, v): at least one minimum-norm Gauss-Newton step (more while |Phi| >
        tol), then the mass-metric velocity projection at q1. Leaves M = L^T L, B = J L^-1 and
        B^T's pivoted QR at q1 in the buffers."""
        mech, ws, b, o = self.mech, self.ws, self._b, self.opts
        fdrv = self._values(t, ws.drive_data)
        self._positions(q)
        for _ in range(o["max_iter"]):
            self._gn(q, fdrv)
            q = pin.integrate(mech.model, q, b["dq"])
            self._positions(q)
            pin.crba(mech.model, ws.data, q)
            res = self._vp(q, v, fdrv, exact)
            if res <= o["tol"]:
                break
        if res == -1.0:
            raise np.linalg.LinAlgError(f"{mech.name}: the mass matrix is not positive definite at "
                                        f"t = {t:.9g} s (check the URDF inertias)")
        return q, b["v1"].copy(), fdrv

    def project(self, t, q, v):
        if self.mech.m == 0:
            return q, v
        return self._project(t, q, v, 1)[:2]

    # -------------------------------------------------------------- right-hand side
    def accelerations(self, t, q, v, z):
        mech, ws, b = self.mech, self.ws, self._b
        if mech.m == 0:
            self.applied(t, q, v, z)
            M = ws.data.M
            a = np.linalg.solve(np.triu(M) + np.triu(M, 1).T, ws.tau - ws.data.nle)
            self._nonfinite = not np.isfinite(a.sum())
            return a
        q1, v1, fdrv = self._project(t, q, v, self._stage_exact)
        # the dynamics pass at the projected state; _project left M and its factor at q1
        self.applied(t, q1, v1, z, mass=False)
        code = self._acc(q1, v1, fdrv)
        self._nonfinite = code == -2.0
        return b["a"].copy()


@njit(cache=True)
def qr_pivoted(A, piv, beta, rcond):
    """In place Householder QR with column pivoting, A P = Q R (A is (n, m)): R in the upper
    triangle, the reflectors' vectors below it (unit first entry implied) with factors beta.
    Stops at the first pivot below rcond times the first: returns the rank k kept. A
    rank-revealing factorization of A's columns (not of A A^T), so a pivot ~ eps divides
    round-off once, not twice; and without truncation the solves below do not depend on the
    pivot order."""
    n, m = A.shape
    for j in range(m):
        piv[j] = j
    r00 = 0.0
    for j in range(min(n, m)):
        best, bn = j, -1.0
        for c in range(j, m):
            s = 0.0
            for i in range(j, n):
                s += A[i, c] * A[i, c]
            if s > bn:
                best, bn = c, s
        if best != j:
            for i in range(n):
                A[i, j], A[i, best] = A[i, best], A[i, j]
            piv[j], piv[best] = piv[best], piv[j]
        norm = np.sqrt(bn)
        if j == 0:
            r00 = norm
        if norm <= rcond * r00 or norm == 0.0:
            return j
        alpha = -norm if A[j, j] >= 0.0 else norm
        v0 = A[j, j] - alpha
        for i in range(j + 1, n):
            A[i, j] /= v0
        beta[j] = -v0 / alpha                 # H = I - beta u u^T, u = (1, A[j+1:, j])
        A[j, j] = alpha
        for c in range(j + 1, m):
            s = A[j, c]
            for i in range(j + 1, n):
                s += A[i, j] * A[i, c]
            s *= beta[j]
            A[j, c] -= s
            for i in range(j + 1, n):
                A[i, c] -= s * A[i, j]
    return min(n, m)


@njit(cache=True)
def min_norm_solve(A, piv, beta, k, r, x, lam):
    """From qr_pivoted of A = B^T: x = B^+ r (minimum norm; r's rows beyond the rank dropped)
    and, when lam has entries, lam = (B B^T)^+ r with B^T lam = x."""
    z = np.zeros(k)
    for j in range(k):                       # R^T z = P^T r
        s = r[piv[j]]
        for i in range(j):
            s -= A[i, j] * z[i]
        z[j] = s / A[j, j]
    x[:] = 0.0
    for j in range(k):
        x[j] = z[j]
    _apply_q(A, beta, k, x)                  # x = Q (z, 0)
    if lam.shape[0] > 0:
        lam[:] = 0.0
        for j in range(k - 1, -1, -1):       # R lam_p = z
            s = z[j]
            for i in range(j + 1, k):
                s -= A[j, i] * lam[piv[i]]
            lam[piv[j]] = s / A[j, j]


@njit(cache=True)
def gauss_newton_step(Hj, jidx, jMf, H, mask, J, dJ, table, E, L, iq, iv, Jv, Jw, V, W, A, Al, phi, Jc, bias,
                      dphi, gamma, alpha, beta, q, zero_v, fdrv, rcond, Qr, piv, hb, dq):
    """dq = -J^+ Phi at q (minimum norm): one Gauss-Newton step."""
    constraint_rows_all(Hj, jidx, jMf, H, mask, J, dJ, table, E, L, iq, iv, Jv, Jw, V, W, A, Al, phi, Jc, bias,
                        dphi, gamma, alpha, beta, q, zero_v, fdrv)
    m, nv = Jc.shape
    for r in range(m):
        for c in range(nv):
            Qr[c, r] = Jc[r, c]
    k = qr_pivoted(Qr, piv, hb, rcond)
    min_norm_solve(Qr, piv, hb, k, phi, dq, np.zeros(0))
    for i in range(nv):
        dq[i] = -dq[i]


@njit(cache=True)
def shifted_factor(S, mu, Fr, Fi):
    """The filter g(S) = S (S^2 + mu^4)^-1 (mu^2 relative to mean(diag S)) without an
    eigendecomposition: for symmetric S, g(S) r = Re[(S + i mu^2 I)^-1 r], since
    1 / (s + i mu^2) = (s - i mu^2) / (s^2 + mu^4) on every eigenvalue. g is 1/s where
    s >> mu^2 (the exact inverse), s / mu^4 below: used only on the normal (range of B^T) part of
    the state, whose round-off it would otherwise amplify. Factors the complex symmetric
    S + i mu^2 I = L D L^T in place (L unit lower in Fr/Fi's strict lower triangle, D on the
    diagonal; real parts in Fr, imaginary in Fi). No pivoting: the imaginary part is positive
    definite, so no pivot vanishes, and where s >> mu^2 (where accuracy matters) the matrix is
    the SPD S up to a small shift. About m^3 / 6 complex operations, against an eigensolver's
    ~9 m^3 and its workspace allocations (30 us at m = 20)."""
    m = S.shape[0]
    tr = 0.0
    for i in range(m):
        tr += S[i, i]
    mu2 = mu * mu * max(tr / max(m, 1), 1e-300)
    for j in range(m):
        d = complex(S[j, j], mu2)
        for k in range(j):
            l = complex(Fr[j, k], Fi[j, k])
            d -= l * l * complex(Fr[k, k], Fi[k, k])
        Fr[j, j], Fi[j, j] = d.real, d.imag
        for i in range(j + 1, m):
            s = complex(S[i, j], 0.0)
            for k in range(j):
                s -= complex(Fr[i, k], Fi[i, k]) * complex(Fr[j, k], Fi[j, k]) * complex(Fr[k, k], Fi[k, k])
            s /= d
            Fr[i, j], Fi[i, j] = s.real, s.imag


@njit(cache=True)
def filtered_solve(Fr, Fi, r, w):
    """w = g(S) r = Re[(S + i mu^2 I)^-1 r] from shifted_factor's L D L^T."""
    m = r.shape[0]
    y = np.empty(m, dtype=np.complex128)
    for i in range(m):
        s = complex(r[i], 0.0)
        for k in range(i):
            s -= complex(Fr[i, k], Fi[i, k]) * y[k]
        y[i] = s
    for i in range(m):
        y[i] /= complex(Fr[i, i], Fi[i, i])
    for i in range(m - 1, -1, -1):
        s = y[i]
        for k in range(i + 1, m):
            s -= complex(Fr[k, i], Fi[k, i]) * y[k]
        y[i] = s
        w[i] = s.real


@njit(cache=True)
def _filtered_normal(Y, Fr, Fi, r, x):
    """x = B^T g(S) r (B = Y): the normal correction."""
    w = np.empty(Y.shape[0])
    filtered_solve(Fr, Fi, r, w)
    _bt_times(Y, w, x)


@njit(cache=True)
def _bt_times(Y, w, x):
    """x = B^T w (B = Y)."""
    m, nv = Y.shape
    x[:] = 0.0
    for j in range(m):
        for k in range(nv):
            x[k] += Y[j, k] * w[j]


@njit(cache=True)
def _project_out_rows(Qr, piv, hb, k, x):
    """x <- (I - Q Q^T) x: removes from x its part in the range of B^T (pivoted QR of B^T in
    Qr). A projector, computed without dividing by B's singular values."""
    _apply_qt(Qr, hb, k, x)
    for j in range(k):
        x[j] = 0.0
    _apply_q(Qr, hb, k, x)


@njit(cache=True)
def _reflect(Qr, hb, j, x):
    """x <- H_j x, H_j = I - hb[j] u u^T with u = (1, Qr[j+1:, j]) below row j."""
    n = Qr.shape[0]
    s = x[j]
    for i in range(j + 1, n):
        s += Qr[i, j] * x[i]
    s *= hb[j]
    x[j] -= s
    for i in range(j + 1, n):
        x[i] -= s * Qr[i, j]


@njit(cache=True)
def _apply_qt(Qr, hb, k, x):
    """x <- Q^T x for the first k reflectors of qr_pivoted (applied in order)."""
    for j in range(k):
        _reflect(Qr, hb, j, x)


@njit(cache=True)
def _apply_q(Qr, hb, k, x):
    """x <- Q x (the reflectors in reverse order)."""
    for j in range(k - 1, -1, -1):
        _reflect(Qr, hb, j, x)


@njit(cache=True)
def _lv(Lm, parent, v, x):
    """x = L v for M = L^T L, L upper-triangular in the tree pattern: (L v)_k sums over k and its
    ancestors."""
    for c in range(v.shape[0]):
        s = Lm[c, c] * v[c]
        i = parent[c]
        while i >= 0:
            s += Lm[c, i] * v[i]
            i = parent[i]
        x[c] = s


@njit(cache=True)
def _unit_lv(Lm, parent, v, x):
    """x = L v / |L v| (the velocity in the coordinates where B = J L^-1 lives); False if v = 0."""
    _lv(Lm, parent, v, x)
    n = 0.0
    for c in range(x.shape[0]):
        n += x[c] * x[c]
    if not n > 0.0:
        return False
    n = np.sqrt(n)
    for c in range(x.shape[0]):
        x[c] /= n
    return True


@njit(cache=True)
def velocity_projection(Hj, jidx, jMf, H, mask, J, dJ, table, E, L, iq, iv, Jv, Jw, V, W, A, Al, phi, Jc, bias,
                        dphi, gamma, alpha, beta, q, v, fdrv, M, parent, rows, mu, rcond, Lm, Y, S, Fr, Fi, Qr, piv,
                        hb, kk, exact, v1):
    """At q (placements, Jacobians and M there): M = L^T L, B = J L^-1 (in Y), the pivoted QR
    of B^T and the factor of S + i mu^2 I (shifted_factor; kept for projected_accelerations), and
    the mass-metric projection v1 = L^-1 ((I - Q Q^T) L v - B^T g(S) Phi_t) onto
    J v1 + Phi_t = 0. Returns |Phi|_inf at q, or -1 if M is not PD; kk[0] = rank kept."""
    constraint_rows_all(Hj, jidx, jMf, H, mask, J, dJ, table, E, L, iq, iv, Jv, Jw, V, W, A, Al, phi, Jc, bias,
                        dphi, gamma, alpha, beta, q, v, fdrv)
    if not ltl_factor(M, parent, Lm):
        return -1.0
    m, nv = Jc.shape
    schur_complement(Lm, parent, Jc, rows, Y, S)
    shifted_factor(S, mu, Fr, Fi)
    for r in range(m):
        for c in range(nv):
            Qr[c, r] = Y[r, c]
    k = qr_pivoted(Qr, piv, hb, rcond)
    kk[0] = k
    pt = np.empty(m)
    if exact:
        _lv(Lm, parent, v, v1)               # x = L v
        _project_out_rows(Qr, piv, hb, k, v1)
        # Phi_t = dphi - J v: the rheonomic rows' own rates (zero for closures)
        for r in range(m):
            s = dphi[r]
            for c in range(nv):
                s -= Jc[r, c] * v[c]
            pt[r] = s
    else:
        for r in range(m):
            pt[r] = dphi[r]
        for c in range(nv):
            v1[c] = v[c]
    corr = np.empty(nv)
    _filtered_normal(Y, Fr, Fi, pt, corr)
    if exact:
        for c in range(nv):
            v1[c] -= corr[c]
        ltl_solve(Lm, parent, v1)
    else:
        ltl_solve(Lm, parent, corr)
        for c in range(nv):
            v1[c] -= corr[c]
    res = 0.0
    for r in range(phi.shape[0]):
        res = max(res, abs(phi[r]))
    return res


@njit(cache=True)
def projected_accelerations(Hj, jidx, jMf, H, mask, J, dJ, table, E, L, iq, iv, Jv, Jw, V, W, A, Al, phi, Jc,
                            bias, dphi, gamma, alpha, beta, q, v, fdrv, tau, nle, parent, Lm, Y, Fr, Fi, Qr, piv, hb,
                            kk, wtan, lam, a):
    """Accelerations at a state on the manifold (pass at (q, v) done; L, B = Y, B^T's QR and the
    factor of S + i mu^2 I from velocity_projection at q):
        y = L^-T (tau - nle),   a = L^-1 ((I - Q Q^T) y + B^T g(S) gamma).
    Exact where g(S) = S^-1: then B^T S^-1 (gamma - B y) = B^T g gamma - Q Q^T y. The applied
    forces' part of the constraint reaction (Q Q^T y) is a projector, exact at any distance
    from the flat configuration; only the velocity-squared part gamma is filtered, the one
    whose round-off grows like 1/s^(3/2) near it. Multipliers: lam = g(S) gamma - S^+ B y."""
    constraint_rows_all(Hj, jidx, jMf, H, mask, J, dJ, table, E, L, iq, iv, Jv, Jw, V, W, A, Al, phi, Jc,
                        bias, dphi, gamma, alpha, beta, q, v, fdrv)
    m, nv = Y.shape
    for c in range(nv):
        a[c] = tau[c] - nle[c]
    ltl_solve_t(Lm, parent, a)                 # y
    # multipliers of the same split: B^T lam = B^T g(S) gamma - Q Q^T y, i.e.
    # lam = g(S) gamma - (B B^T)^+ B y (the second by the QR of B^T, no normal equations)
    r = np.empty(m)
    for rr in range(m):
        s = 0.0
        for c in range(nv):
            s -= Y[rr, c] * a[c]
        r[rr] = s
    xs = np.empty(nv)
    min_norm_solve(Qr, piv, hb, kk[0], r, xs, lam)
    w = np.empty(m)                            # g(S) gamma
    filtered_solve(Fr, Fi, gamma, w)
    for rr in range(m):
        lam[rr] += w[rr]
    k = kk[0]
    along = k > 0 and abs(Qr[k - 1, k - 1]) < wtan * abs(Qr[0, 0])    # near flat only
    if along:
        xt = np.empty(nv)
        along = _unit_lv(Lm, parent, v, xt)
    if along:
        xy = 0.0                               # x^T y before y's normal part is removed
        for c in range(nv):
            xy += xt[c] * a[c]
        wt = xt.copy()
        _project_out_rows(Qr, piv, hb, k, wt)  # w = (I - Q Q^T) x
        ww = 0.0
        for c in range(nv):
            ww += wt[c] * wt[c]
        along = ww > 0.5                       # x mostly tangent (else the velocity is not a guide)
    _project_out_rows(Qr, piv, hb, k, a)
    if along:
        # range(Q) made orthogonal to x: z - w (w^T z) / |w|^2 + x (x^T y). A no-op in exact
        # arithmetic, where x is orthogonal to range(B^T); near flat it replaces the round-off
        # of the vanishing normal along the velocity (~1e-16 / sigma^2) by x^T y exactly
        wz = 0.0
        for c in range(nv):
            wz += wt[c] * a[c]
        wz /= ww
        for c in range(nv):
            a[c] += xy * xt[c] - wz * wt[c]
    corr = np.empty(nv)
    _bt_times(Y, w, corr)                      # B^T g(S) gamma, g(S) gamma from the multipliers
    for c in range(nv):
        a[c] += corr[c]
    ltl_solve(Lm, parent, a)
    t = 0.0
    for c in range(nv):
        t += a[c]
    return 1.0 if np.isfinite(t) else -2.0
