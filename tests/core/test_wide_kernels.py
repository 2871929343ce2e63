"""The dense kernels' wide loops (pinclear.core.dense.WIDE rows and more: A02 at IFToMM's size,
benchmarks/bench_a02_scale.md) against their row-wise loops, which the small scenes keep. The
claim is that nothing changes but the memory order: each entry sees the same operations in the
same order, so the two give the same bits, pivot order and rank decision included. Checked on
A02 with N = 20 loops (40 rows, 41 dofs) at configurations off the manifold and near its flat
configuration (where the pivoted Cholesky factors stop at their gates and the QRs take over),
and on random matrices. The solutions are also checked against NumPy (the second method) to
the factorizations' error bounds (Higham, Accuracy and Stability of Numerical Algorithms, 2nd
ed., thm. 10.3-10.4), with a factor 10 for the constants those theorems leave out."""
from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

import pinclear
from pinclear.core import dense, tree_solve
from pinclear.dynamics import formulations
from pinclear.dynamics.formulations import manifold as manifold_mod
from pinclear.dynamics.formulations.projection import GRAM_GATE, minus_jt_times
from pinclear.mechanisms import benchmarks as B
from pinclear.model import kinematics, rows

EPS = np.finfo(float).eps
N = 20                      # 2 N = 40 rows >= WIDE


@pytest.fixture(scope="module")
def a02_wide(tmp_path_factory):
    folder = tmp_path_factory.mktemp("a02_wide")
    B.write_a02(N, folder)
    mech = pinclear.load(folder / f"{B.a02_name(N)}.yaml")
    assert mech.m == 2 * N >= dense.WIDE and mech.nv >= dense.WIDE
    return mech


def _states(mech):
    """(q, v): three off the manifold (random joint angles), three at 1e-3 .. 1e-7 rad from the
    flat configuration (B.a02_branch_state)."""
    model = mech.model
    rng = np.random.default_rng(11)
    out = []
    for _ in range(3):
        out.append((pin.integrate(model, pin.neutral(model), 0.3 * rng.standard_normal(model.nv)),
                    rng.standard_normal(model.nv)))
    for eps in (1e-3, 1e-5, 1e-7):
        qd, vd = B.a02_branch_state(N, eps, 3.0)
        q, v = np.zeros(model.nq), np.zeros(model.nv)
        for name in qd:
            jnt = model.joints[model.getJointId(name)]
            q[jnt.idx_q], v[jnt.idx_v] = qd[name], vd[name]
        out.append((q, v))
    return out


def _rows(mech, form, q, v):
    """The row buffers, M and the tree's parents at (q, v)."""
    ws = form.ws
    kinematics.update(mech, ws, q, v)
    form.drive_values(0.0)
    R = form.row_buffers
    rows.constraint_rows_all(R, 0.0, 0.0, q, v, ws.drive_data.f)
    return R, ws.data.M.copy(), ws.parent


def _factor(fn, G, gate):
    m = G.shape[0]
    L, piv, d = np.zeros((m, m)), np.zeros(m, dtype=np.int64), np.zeros(m)
    return fn(G, piv, L, d, gate), L, piv, d


def _assert_same_factor(G, gate):
    """_chol_pivoted_wide and _chol_pivoted_rows: the same ratio (0.0 where both stop at the
    gate), pivots, diagonal work and lower triangle; the wide one's upper triangle is L^T. When
    they do not stop, chol_solve_pivoted's wide solves (read from the mirror) give the row-wise
    solves' bits. Returns the ratio."""
    a = _factor(dense._chol_pivoted_wide, G, gate)
    b = _factor(dense._chol_pivoted_rows, G, gate)
    assert a[0] == b[0]
    assert np.array_equal(a[2], b[2]) and np.array_equal(a[3], b[3])
    if a[0] == 0.0:
        return 0.0
    La, Lb, piv = a[1], b[1], a[2]
    assert np.array_equal(np.tril(La), np.tril(Lb))
    assert np.array_equal(np.triu(La), np.tril(La).T)
    m = G.shape[0]
    r = np.random.default_rng(m).standard_normal(m)
    x = np.zeros(m)
    dense.chol_solve_pivoted(La, piv, r, np.zeros(m), x)       # wide: m >= WIDE
    y = r[piv].copy()
    dense.lower_solve(Lb, m, y)
    dense.lower_t_solve(Lb, m, y)
    ref = np.zeros(m)
    ref[piv] = y
    assert np.array_equal(x, ref)
    return a[0]


def test_wide_kernels_equal_the_row_kernels_bit_for_bit_on_a02(a02_wide):
    """At every state: L^T L = M by ltl_factor's chain loop equals its walk; Y = J L^-1 and
    S = Y Y^T (schur_complement, scaled_rows) equal the row-wise scaled rows and _gram; J J^T
    (gram_rows, wide) equals _gram's, over all rows and over every other row last first (the
    other loop order); the pivoted Cholesky factors of S and J J^T at the production gates equal
    the row-wise ones (near flat both stop: the rank decision is the same), and B^T w, -J^T w by
    runs of columns equal the loop over each row's support (a Python loop: the same IEEE
    operations)."""
    mech = a02_wide
    form = formulations.get("manifold")(mech)
    nv, m = mech.nv, mech.m
    gate = manifold_mod.chol_gate(form.opts["tangent"])
    stops = 0
    for q, v in _states(mech):
        R, M, parent = _rows(mech, form, q, v)
        La, Lb = np.zeros((nv, nv)), np.zeros((nv, nv))
        assert tree_solve._ltl_factor(M, parent, La, True) and tree_solve._ltl_factor(M, parent, Lb, False)
        assert np.array_equal(La, Lb)
        assert np.abs(La.T @ La - np.triu(M) - np.triu(M, 1).T).max() <= 10 * nv * EPS * np.abs(M).max()
        rows = np.arange(m, dtype=np.int64)
        Y, S = np.full((m, nv), np.nan), np.zeros((m, m))
        tree_solve.schur_complement(La, parent, R.Jc, rows, R.cols, R.ncols, Y, S)
        Y2, S2 = np.full((m, nv), np.nan), np.zeros((m, m))
        tree_solve._scaled_rows_narrow(La, parent, R.Jc, rows, Y2)
        dense._gram(Y2, rows, R.cols, R.ncols, S2, False)
        assert np.array_equal(Y, Y2) and np.array_equal(S, S2)
        Y3 = np.full((m, nv), np.nan)
        tree_solve.scaled_rows(La, parent, R.Jc, rows, Y3)
        assert np.array_equal(Y, Y3)
        for sel in (rows, rows[::-1].copy()):
            G, G2 = np.zeros((m, m)), np.zeros((m, m))
            dense.gram_rows(R.Jc, sel, R.cols, R.ncols, G)
            dense._gram(R.Jc, sel, R.cols, R.ncols, G2, True)
            assert np.array_equal(G, G2)
        stops += _assert_same_factor(S, gate) == 0.0
        stops += _assert_same_factor(G, GRAM_GATE) == 0.0
        w = np.random.default_rng(3).standard_normal(m)
        x, ref = np.zeros(nv), np.zeros(nv)
        manifold_mod._bt_times(Y, R, w, x)
        dq, ref2 = np.zeros(nv), np.zeros(nv)
        minus_jt_times(R.Jc, rows, R.cols, R.ncols, w, dq)
        for j in range(m):
            for k in R.cols[j, :R.ncols[j]]:
                ref[k] += Y[j, k] * w[j]
                ref2[k] -= R.Jc[j, k] * w[j]
        assert np.array_equal(x, ref) and np.array_equal(dq, ref2)
    assert stops >= 2          # near flat the gates are met (S's at 1e-5 and 1e-7 rad at least)


def _spread(m, n, seed):
    """An (m, n) matrix whose rows' norms spread over 10^-2 .. 10^2."""
    rng = np.random.default_rng(seed)
    return rng.standard_normal((m, n)) * 10.0 ** rng.uniform(-2, 2, (m, 1))


@pytest.mark.parametrize("m", [dense.WIDE, 40, 80])
def test_wide_pivoted_cholesky_equals_the_row_one_and_solves_as_numpy(m):
    """Random Gram matrices, full rank and of rank m - 3 (three rows combinations of others):
    the wide factor equals the row-wise one bit for bit, stopping at the same pivot below a gate
    of 1e-8; its solve agrees with NumPy's LU solve to m eps cond(G)."""
    A = _spread(m, m + 1, seed=m)
    G = np.zeros((m, m))
    dense.gram_rows(A, np.arange(m, dtype=np.int64), np.tile(np.arange(m + 1, dtype=np.int64), (m, 1)),
                np.full(m, m + 1, dtype=np.int64), G)
    assert np.abs(G - A @ A.T).max() <= 10 * m * EPS * (np.abs(A) @ np.abs(A).T).max()
    assert _assert_same_factor(G, 0.0) > 0.0
    ratio, L, piv, _ = _factor(dense.chol_pivoted, G, 0.0)
    r = np.random.default_rng(1).standard_normal(m)
    x = np.zeros(m)
    dense.chol_solve_pivoted(L, piv, r, np.zeros(m), x)
    ref = np.linalg.solve(G, r)
    assert np.abs(x - ref).max() <= 10 * m * EPS * np.linalg.cond(G) * np.abs(ref).max()
    D = A.copy()
    D[-3:] = np.random.default_rng(2).standard_normal((3, m - 3)) @ D[:m - 3]
    Gd = D @ D.T
    Gd = 0.5 * (Gd + Gd.T)
    assert _assert_same_factor(Gd, 1e-8) == 0.0       # rank m - 3: stops below the gate
    assert _factor(dense.chol_pivoted, Gd, 1e-8)[0] == 0.0
