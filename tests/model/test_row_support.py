"""The supports (pinclear.model.kinematics.row_support, FrameKinematics.fcols): the frame Jacobians
and the Gram and Schur matrices (J J^T, J M^-1 J^T) walk only the dofs that can move each frame
and each row. The claim is that nothing is lost: outside a row's support J and J L^-1 are exact
zeros, so the dense kernels (every dof in every row's support, as before the supports existed)
and the sparse ones produce the same numbers bit for bit, at configurations off the manifold and
random velocities, where no entry vanishes by accident. The frames' supports are the dofs whose
Pinocchio joint Jacobian moves them."""
from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

import pinclear
from pinclear.core.dense import gram_rows
from pinclear.core.tree_solve import ltl_factor, schur_complement
from pinclear.dynamics import formulations
from pinclear.model import kinematics
from pinclear.model.rows import constraint_rows_all


def _dense(R, nv):
    """The rows' supports made every dof (the frames keep theirs: a frame's Jacobian column of a
    dof that does not move it is zero by definition, not by sparsity)."""
    m = R.cols.shape[0]
    return R._replace(cols=np.tile(np.arange(nv, dtype=np.int64), (m, 1)), ncols=np.full(m, nv, dtype=np.int64))


def _rows_and_schur(mech, form, R, q, v, t):
    """Phi, J, J v, bias, gamma, Y = J L^-1, S = Y Y^T and J J^T (every other row, last first) at
    (t, q, v) from the buffers R, the row buffers and frame Jacobians first reset to what a fresh
    workspace holds."""
    ws = form.ws
    ws.J[:mech.compiled.m] = 0.0
    ws.fk.Jv[:] = 0.0
    ws.fk.Jw[:] = 0.0
    kinematics.update(mech, ws, q, v)
    form.drive_values(t)
    constraint_rows_all(R, 0.3, 0.7, q, v, ws.drive_data.f)
    m = R.Jc.shape[0]
    rows = np.arange(m, dtype=np.int64)
    Lm, Y, S = np.zeros((mech.nv, mech.nv)), np.full((m, mech.nv), np.nan), np.zeros((m, m))
    assert ltl_factor(ws.data.M, ws.parent, Lm)
    schur_complement(Lm, ws.parent, R.Jc, rows, R.cols, R.ncols, Y, S)
    # J J^T over every other row, last first (the Gram kernel's other loop order: the supports
    # then shrink along the selected rows)
    sel = rows[::-2].copy()
    G = np.zeros((sel.size, sel.size))
    gram_rows(R.Jc, sel, R.cols, R.ncols, G)
    return [a.copy() for a in (R.phi, R.Jc, R.dphi, R.bias, R.gamma, Y, S, G)]


@pytest.mark.parametrize("name", ["a02_nfourbar_10", "three_upru_up", "four_ups_upu", "nine_bar", "four_bar"])
def test_sparse_rows_equal_the_dense_rows_bit_for_bit(name):
    mech = pinclear.load(name)
    form = formulations.get("lagrange")(mech)
    R = form.row_buffers
    nv = mech.nv
    support = np.zeros(R.Jc.shape, dtype=bool)
    for r in range(R.Jc.shape[0]):
        support[r, R.cols[r, :R.ncols[r]]] = True
    assert support.sum() < support.size or nv <= 3      # the larger scenes are sparse at all
    rng = np.random.default_rng(3)
    q0 = pin.neutral(mech.model)
    for k in range(4):
        q = pin.integrate(mech.model, q0, 0.2 * rng.standard_normal(nv))   # off the manifold
        v, t = rng.standard_normal(nv), 0.1 * k
        dense = _rows_and_schur(mech, form, _dense(R, nv), q, v, t)
        sparse = _rows_and_schur(mech, form, R, q, v, t)
        for a, b in zip(dense, sparse):
            assert np.array_equal(a, b)
        J, Y = dense[1], dense[5]
        # the support holds every entry the dense kernels make non-zero, in J and in J L^-1
        # (closed under the tree's parents: L^-T fills only ancestors)
        assert np.all(J[~support] == 0.0) and np.all(Y[~support] == 0.0)
        assert np.count_nonzero(J[support]) > 0.5 * support.sum()


def test_row_support_is_the_ancestor_closure_of_the_frames_and_drive_dofs():
    """Drive rows are moved by their own dof; the support adds that dof's ancestors (what J L^-1
    fills), and every support is closed under the tree's parent dof. A frame's dofs are those
    whose Pinocchio joint Jacobian moves it (pin.getFrameJacobian's non-zero columns)."""
    mech = pinclear.load("four_ups_upu")
    form = formulations.get("lagrange")(mech)
    R, parent = form.row_buffers, form.ws.parent
    mc = mech.compiled.m
    model, data = mech.model, mech.model.createData()
    q = pin.integrate(model, pin.neutral(model), 0.3 * np.random.default_rng(0).standard_normal(mech.nv))
    pin.computeJointJacobians(model, data, q)
    for f, fid in enumerate(form.ws.fk.fids):
        Jf = pin.getFrameJacobian(model, data, fid, pin.LOCAL_WORLD_ALIGNED)
        moving = np.flatnonzero(np.abs(Jf).max(axis=0) > 0.0)
        assert list(R.fcols[f, :R.nfcols[f]]) == list(moving)
    for r in range(R.cols.shape[0]):
        sup = set(R.cols[r, :R.ncols[r]].tolist())
        assert list(R.cols[r, :R.ncols[r]]) == sorted(sup)
        assert all(parent[k] < 0 or parent[k] in sup for k in sup)
        if r >= mc:
            iv = int(mech.driverows.iv[r - mc])
            chain, i = [], iv
            while i >= 0:
                chain.append(i)
                i = parent[i]
            assert sup == set(chain)
