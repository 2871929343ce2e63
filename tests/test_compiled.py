"""Compiled kernels against plain NumPy evaluations of the same equations (issue 10: one
implementation per law, or a test that shows two equal), at random states."""
from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

import pinclear
from pinclear import formulations, kinematics
from pinclear.formulations.proximal import proximal_multipliers


def _random_consistent_state(mech, seed):
    rng = np.random.default_rng(seed)
    q = kinematics.assemble(mech, pin.integrate(mech.model, mech.q0, 0.05 * rng.standard_normal(mech.nv)))
    v = kinematics.consistent_velocity(mech, q, rng.standard_normal(mech.nv))
    return q, v


@pytest.mark.parametrize("name", ["four_bar", "nine_bar", "four_ups_upu", "three_upru_up", "parallelogram"])
def test_proximal_kernel_equals_numpy(name):
    """a = M^-1 (f + J^T lam), lam = filter(J M^-1 J^T)(gamma - J M^-1 f), evaluated with dense
    NumPy/SciPy linear algebra from Pinocchio's M and the constraint rows."""
    mech = pinclear.load(name)
    form = formulations.get("proximal")(mech)
    ws = mech.workspace()
    for seed in range(3):
        q, v = _random_consistent_state(mech, seed)
        t = 0.1 * seed
        z = np.zeros(mech.nz)
        a = form.accelerations(t, q, v, z)
        lam = form.ws.lam.copy()
        kinematics.update(mech, ws, q, v)
        kinematics.constraint_rows(mech, ws, t, q, v, (form.opts["alpha"], form.opts["beta"]))
        M = pin.crba(mech.model, pin.Model.createData(mech.model), q)
        M = np.triu(M) + np.triu(M, 1).T
        f = -pin.nonLinearEffects(mech.model, mech.model.createData(), q, v)
        J, g = ws.J, ws.gamma
        Mi = np.linalg.inv(M)
        S = J @ Mi @ J.T
        rho = form.opts["rho"] * np.trace(S) / len(S)
        lam_ref = proximal_multipliers(S, g - J @ Mi @ f, rho, form.opts["max_iter"])
        a_ref = Mi @ (f + J.T @ lam_ref)
        # rounding bound of the chain: solves with M (condition kappa_M), then the filter, whose
        # gain spread is at most min(cond(S), k / rho_rel); 100 covers the accumulation over the
        # O(nv) terms of each product
        k_f = min(np.linalg.cond(S), form.opts["max_iter"] / form.opts["rho"])
        tol = 100 * np.linalg.cond(M) * k_f * np.finfo(float).eps
        np.testing.assert_allclose(a, a_ref, rtol=0, atol=tol * max(1.0, np.abs(a_ref).max()))
        np.testing.assert_allclose(lam, lam_ref, rtol=0, atol=tol * max(1.0, np.abs(lam_ref).max()))


def test_proximal_filter_is_k_proximal_iterations():
    """The closed form equals k explicit iterations (S + rho I) lam_{i+1} = r + rho lam_i."""
    rng = np.random.default_rng(7)
    B = rng.standard_normal((6, 4))
    S = B @ B.T                                  # rank 4 of 6: two redundant directions
    r = rng.standard_normal(6)
    rho, k = 1e-2, 30
    lam = np.zeros(6)
    for _ in range(k):
        lam = np.linalg.solve(S + rho * np.eye(6), r + rho * lam)
    np.testing.assert_allclose(proximal_multipliers(S, r, rho, k), lam, rtol=1e-9, atol=1e-12)
