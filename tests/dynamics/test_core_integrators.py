"""Integrators on the four-bar: every SciPy method agrees with a tight DOP853 reference to its
tolerance, and the fixed-step RK4 converges at fourth order (error ratio 16 per halving of h)."""
from __future__ import annotations

import numpy as np
import pytest


@pytest.fixture(scope="module")
def reference(four_bar, sim):
    t_eval = np.linspace(0.0, 1.0, 11)
    ref = sim(four_bar, 1.0, method="lagrange", integrator="DOP853", rtol=1e-12, t_eval=t_eval,
              alpha=0.0, beta=0.0)
    assert ref.status == "success"
    return ref


def test_rk4_fourth_order(four_bar, sim, reference):
    errs = []
    for h in (4e-3, 2e-3, 1e-3):
        tr = sim(four_bar, 1.0, method="lagrange", integrator="RK4", h=h, t_eval=reference.t,
                 alpha=0.0, beta=0.0)
        assert tr.status == "success"
        assert tr.stats["steps"] == pytest.approx(1.0 / h, abs=1)
        errs.append(np.abs(tr.q[-1] - reference.q[-1]).max())
    ratios = np.array(errs[:-1]) / np.array(errs[1:])
    assert np.all((ratios > 12) & (ratios < 20)), (errs, ratios)


@pytest.mark.parametrize("integrator, t_end, rtol, tol", [
    ("RK45", 1.0, 1e-8, 1e-6),
    ("DOP853", 1.0, 1e-8, 1e-6),
    ("LSODA", 1.0, 1e-8, 1e-5),
    ("BDF", 1.0, 1e-8, 1e-5),
    ("Radau", 0.3, 1e-6, 1e-5),       # implicit with a finite-difference Jacobian: kept short
])
def test_scipy_integrators_agree(four_bar, sim, reference, integrator, t_end, rtol, tol):
    n = int(round(t_end * 10)) + 1
    tr = sim(four_bar, reference.t[n - 1], method="lagrange", integrator=integrator, rtol=rtol,
             t_eval=reference.t[:n])
    assert tr.status == "success"
    assert tr.meta["integrator"] == integrator
    np.testing.assert_allclose(tr.t, reference.t[:n])
    np.testing.assert_allclose(tr.q, reference.q[:n], atol=tol)
