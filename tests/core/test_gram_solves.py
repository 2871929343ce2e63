"""The Cholesky solves that replace the pivoted QR away from rank loss (pinclear.core.dense:
gram_rows, chol_pivoted, chol_solve_pivoted; projection.min_norm_step_gram; the manifold's
velocity projection and accelerations).

References are independent of the kernels: SciPy's pivoted QR (LAPACK dgeqp3) for the pivot
order and the pivots, NumPy's solve and SVD pseudo-inverse for the solutions, and the kernels'
own QR path for the manifold (the same formulas through another factorization). Bounds are the
factorizations' error bounds (Higham, Accuracy and Stability of Numerical Algorithms, 2nd ed.,
thm. 10.3-10.4: a Cholesky solve of G is accurate to ~m eps cond(G), and G = J J^T squares
J's condition), with a factor 10 for the constants those theorems leave out."""
from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest
import scipy.linalg

import pinclear
from pinclear.core.dense import chol_pivoted, chol_solve_pivoted, gram_rows
from pinclear.dynamics import formulations
from pinclear.dynamics.formulations import manifold as manifold_mod
from pinclear.dynamics.formulations.projection import (
    GRAM_GATE,
    min_norm_step,
    min_norm_step_gram,
)
from pinclear.model import kinematics

EPS = np.finfo(float).eps


def _rows(m, n, seed, spread=2.0):
    """An (m, n) matrix whose rows' norms spread over 10^-spread .. 10^spread (lengths in m
    against angles), well conditioned after row scaling."""
    rng = np.random.default_rng(seed)
    return rng.standard_normal((m, n)) * 10.0 ** rng.uniform(-spread, spread, (m, 1))


def _dense(m, n):
    """Every row's support is every column (pinclear.model.kinematics.row_support's dense case)."""
    return np.tile(np.arange(n, dtype=np.int64), (m, 1)), np.full(m, n, dtype=np.int64)


def _factor(G, gate=0.0):
    m = G.shape[0]
    L, piv, d = np.zeros((m, m)), np.zeros(m, dtype=np.int64), np.zeros(m)
    return chol_pivoted(G, piv, L, d, gate), L, piv


@pytest.mark.parametrize("m,n", [(1, 3), (2, 3), (5, 8), (16, 16), (20, 21), (40, 41)])
def test_pivoted_cholesky_of_the_gram_matrix_is_the_pivoted_qr_of_the_rows(m, n):
    """G = A A^T by gram_rows equals NumPy's product; chol_pivoted picks the pivots of the pivoted
    QR of A^T (SciPy, LAPACK dgeqp3) and its pivots are R's diagonal squared; P^T G P = L L^T to
    Cholesky's backward error; the returned ratio is the smallest pivot over the first."""
    A = _rows(m, n, seed=m)
    G = np.zeros((m, m))
    gram_rows(A, np.arange(m, dtype=np.int64), *_dense(m, n), G)
    assert np.abs(G - A @ A.T).max() <= 10 * n * EPS * np.abs(A).max(axis=1) @ np.abs(A).max(axis=1)
    ratio, L, piv = _factor(G)
    _, R, P = scipy.linalg.qr(A.T, mode="economic", pivoting=True)
    assert list(piv) == list(P)
    r2 = np.diag(R) ** 2
    cond = np.linalg.cond(A) ** 2
    assert np.allclose(np.diag(L) ** 2, r2, rtol=10 * m * EPS * cond, atol=0.0)
    assert ratio == pytest.approx(r2.min() / r2[0], rel=10 * m * EPS * cond)
    Gp = G[np.ix_(piv, piv)]
    L = np.tril(L)                                  # from WIDE rows the upper triangle holds L^T
    assert np.abs(L @ L.T - Gp).max() <= 10 * (m + 1) * EPS * (np.abs(L) @ np.abs(L).T).max()
    assert np.all(np.diff(np.diag(L)) <= 0.0)       # the largest remaining pivot first


@pytest.mark.parametrize("m", [1, 4, 16, 20, 40])
def test_pivoted_cholesky_solve(m):
    """x = G^-1 r against NumPy's LU solve, to the Cholesky solve's forward error."""
    A = _rows(m, m + 1, seed=10 + m)
    G = A @ A.T
    _, L, piv = _factor(G)
    r = np.random.default_rng(m).standard_normal(m)
    x = np.zeros(m)
    chol_solve_pivoted(L, piv, r, np.zeros(m), x)
    ref = np.linalg.solve(G, r)
    assert np.abs(x - ref).max() <= 10 * m * EPS * np.linalg.cond(G) * np.abs(ref).max()
    chol_solve_pivoted(L, piv, r, np.zeros(m), r)       # in place: x may be r
    assert np.array_equal(r, x)


def test_pivoted_cholesky_stops_below_the_gate():
    """A repeated row (a redundant constraint) or a nearly repeated one (a flat configuration)
    leaves a pivot far below the gate: the factorization stops and says so (0.0), so the caller
    takes the QR; above the gate it returns the ratio."""
    A = _rows(6, 8, seed=3, spread=0.0)
    A[4] = A[1]
    assert _factor(A @ A.T, gate=1e-8)[0] == 0.0
    A[4] = A[1] + 1e-6 * np.random.default_rng(0).standard_normal(8)   # a pivot ~ (1e-6)^2 of the first
    assert _factor(A @ A.T, gate=1e-8)[0] == 0.0
    _, R, _p = scipy.linalg.qr(A.T, mode="economic", pivoting=True)
    low = (R[-1, -1] / R[0, 0]) ** 2
    assert 1e-14 < low < 1e-10
    # G's round-off eps |G| on a pivot of 1e-12 |G|: a relative error ~ 1e-4
    assert _factor(A @ A.T, gate=1e-14)[0] == pytest.approx(low, rel=1e-3)


@pytest.mark.parametrize("redundant", [False, True])
def test_gram_step_is_the_minimum_norm_step(redundant):
    """min_norm_step_gram's dq = -J^+ Phi (NumPy's SVD pseudo-inverse) to eps cond(J)^2 |dq|
    where J has full row rank; with a redundant row it is exactly the pivoted QR's step
    (min_norm_step, which drops the row)."""
    m, nv = 7, 9
    J = _rows(m, nv, seed=7)
    if redundant:
        J[5] = 2.0 * J[2]
    phi = np.random.default_rng(1).standard_normal(m) * 1e-6
    rows = np.arange(m, dtype=np.int64)
    w = [np.zeros((m, m)), np.zeros((m, m)), np.zeros(m, dtype=np.int64), np.zeros(m), np.zeros(m)]
    qr = [np.zeros((m, nv)), np.zeros(m, dtype=np.int64), np.zeros(m), np.zeros(m)]
    dq, dq_qr = np.zeros(nv), np.zeros(nv)
    min_norm_step_gram(J, phi, rows, *_dense(m, nv), *w, *qr, 1e-8, dq)
    min_norm_step(J, phi, rows, *[x.copy() for x in qr], 1e-8, dq_qr)
    if redundant:
        assert np.array_equal(dq, dq_qr)
        return
    ref = -np.linalg.pinv(J) @ phi
    assert np.abs(dq - ref).max() <= 10 * m * EPS * np.linalg.cond(J) ** 2 * np.abs(ref).max()
    assert GRAM_GATE < 1.0 / np.linalg.cond(J) ** 2      # the Cholesky path was the one taken


def _manifold_form(mech, tr):
    """A manifold formulation with the rows simulate chooses at the run's first sample."""
    form = formulations.get("manifold")(mech)
    J = kinematics.jacobian(mech, form.ws, tr.q[0], float(tr.t[0]), with_drives=True)
    form.use_rows(kinematics.rank_analysis(J, mech.row_names())[1])
    return form


def _off_manifold(mech, tr, k, d):
    """(t, q, v) of sample k moved d off the manifold in a random direction (seeded by k)."""
    rng = np.random.default_rng(k)
    r = rng.standard_normal(mech.nv)
    q = pin.integrate(mech.model, tr.q[k], d * r / np.linalg.norm(r))
    return float(tr.t[k]), q, tr.v[k] + d * rng.standard_normal(mech.nv)


@pytest.mark.parametrize("name", ["four_bar", "nine_bar", "three_upru_up", "four_ups_upr"])
def test_manifold_cholesky_path_agrees_with_its_qr_path(name, monkeypatch):
    """The manifold's evaluation with S's Cholesky factor (far from flat: the default gate) and
    with B^T's pivoted QR (gate above every pivot) at states of a run moved 1e-6 off the
    manifold: the projected state and the accelerations agree to ~m eps cond(S) (the Cholesky
    solve's bound; the QR's is smaller), and so does the exact projection after steps."""
    mech = pinclear.load(name)
    tr = pinclear.simulate(mech, 0.02, method="projection", rtol=1e-9, dt_out=0.01)
    out = {}
    for path, gate in (("chol", None), ("qr", 2.0)):
        if gate is not None:
            monkeypatch.setattr(manifold_mod, "chol_gate", lambda tangent: gate)
        form = _manifold_form(mech, tr)
        res = []
        for k in range(len(tr.t)):
            t, q, v = _off_manifold(mech, tr, k, 1e-6)
            a = form.accelerations(t, q, v, tr.z[k])
            used = int(form._W.chol[0])
            S = form._W.S.copy()
            q1, v1 = form.ws.q.copy(), form.ws.v.copy()
            qp, vp = form.project(t, q, v)
            res.append((a, q1, v1, qp, vp, used, S))
        out[path] = res
    for (a, q1, v1, qp, vp, used, S), (a2, q2, v2, qp2, vp2, used2, _) in zip(out["chol"], out["qr"]):
        assert (used, used2) == (1, 0)
        m = S.shape[0]
        tol = 10 * m * EPS * np.linalg.cond(S)
        assert np.array_equal(q1, q2)                          # the step's own solve does not change
        assert np.abs(v1 - v2).max() <= tol * np.abs(v1).max()
        assert np.abs(a - a2).max() <= tol * np.abs(a).max()
        assert np.abs(qp - qp2).max() <= tol * np.abs(qp).max()
        assert np.abs(vp - vp2).max() <= tol * np.abs(vp).max()


@pytest.mark.parametrize("name", ["four_bar", "nine_bar", "three_upru_up", "a02_nfourbar_2"])
def test_exact_projection_after_the_stage_at_the_same_state_is_bit_identical(name):
    """The exact projection of the state the step logic evaluated last (an FSAL step's accepted
    state) takes its first Gauss-Newton step, rows and factors from that evaluation's stage
    projection (manifold.same_state) instead of computing them again: the result must be the
    very bits a formulation that never evaluated there computes, and a state that differs in
    one velocity component must not take the shortcut."""
    mech = pinclear.load(name)
    tr = pinclear.simulate(mech, 0.02, method="manifold", rtol=1e-6, dt_out=0.01)
    hits = 0
    for k in range(len(tr.t)):
        t, q, v = _off_manifold(mech, tr, k, 1e-7)
        fresh, used = _manifold_form(mech, tr), _manifold_form(mech, tr)
        used.accelerations(t, q, v, tr.z[k])
        assert used._W.last[0] == 1
        qr, vr = fresh.project(t, q, v)
        qs, vs = used.project(t, q, v)
        hits += used._W.last[0] == 2          # the exact projection took the stage's numbers
        assert np.array_equal(qs, qr) and np.array_equal(vs, vr)
        assert int(used.ws.gn_steps[0]) == int(fresh.ws.gn_steps[0])
        # another velocity: the full computation (its result again equal to a fresh one's)
        used.accelerations(t, q, v, tr.z[k])
        v2 = v.copy()
        v2[0] += 1e-9
        assert np.array_equal(used.project(t, q, v2)[1], fresh.project(t, q, v2)[1])
        assert used._W.last[0] == 0
    assert hits == len(tr.t)
