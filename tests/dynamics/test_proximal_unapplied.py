"""A proximal run whose given max_iter leaves a row's constraint force unapplied beyond rtol ends
failed (FailureKind.UNAPPLIED), samples kept; ``unapplied="record"`` keeps its status and records
the shortfall (issue 53, item 7).

k proximal iterations leave the fraction (rho / (s + rho))^k of the force along an eigen-direction
s of J M^-1 J^T (pinclear.dynamics.formulations.proximal): the fraction, not a residual, says
whether the loops are held, since the projection after every step keeps the residual small while
the loops flex."""
from __future__ import annotations

import warnings

import numpy as np
import pinocchio as pin
import pytest

import pinclear
from pinclear.core.errors import InputError
from pinclear.core.failures import FailureKind


@pytest.fixture(scope="module")
def four_bar():
    return pinclear.load("four_bar")


def _smallest_fraction(mech, k):
    """(rho / (s + rho))^k for the smallest eigenvalue of S = J M^-1 J^T at the assembled start
    (the independent reference of the filter's closed form: Pinocchio's M, the rows' Jacobian)."""
    from pinclear.dynamics import formulations
    from pinclear.model import kinematics

    form = formulations.get("proximal")(mech)
    q = kinematics.assemble(mech, mech.q0)
    J = kinematics.jacobian(mech, form.ws, q, 0.0, with_drives=True)
    M = pin.crba(mech.model, mech.model.createData(), q)
    M = np.triu(M) + np.triu(M, 1).T
    S = J @ np.linalg.solve(M, J.T)
    rank = np.linalg.matrix_rank(J)
    s = np.linalg.eigvalsh(S)[-rank:]
    rho = 1e-4 * np.mean(np.diag(S))
    return float((rho / (s[0] + rho)) ** k)


def test_too_few_iterations_end_the_run_failed_with_its_samples(four_bar):
    """One iteration leaves rho / (s + rho) of the force (about 1e-3 on the four-bar), far above
    rtol = 1e-6: failed, named, samples kept to the end."""
    left = _smallest_fraction(four_bar, 1)
    assert left > 1e-6
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        tr = pinclear.simulate(four_bar, 0.02, method="proximal", max_iter=1, rtol=1e-6, dt_out=0.01)
    assert tr.status == "failed"
    assert tr.failure.kind == FailureKind.UNAPPLIED and tr.failure.t == 0.0
    assert "constraint force unapplied" in tr.message and "max_iter" in tr.message
    rec = tr.stats["unapplied_force"]
    assert rec["max_iter"] == 1 and rec["force_left"] == pytest.approx(left, rel=1e-6)
    assert len(tr.t) == 3 and tr.t[-1] == pytest.approx(0.02)


def test_the_explicit_opt_out_keeps_the_status_and_records_the_shortfall(four_bar):
    with pytest.warns(RuntimeWarning, match="constraint force unapplied"):
        tr = pinclear.simulate(four_bar, 0.02, method="proximal", max_iter=1, rtol=1e-6, dt_out=0.01,
                               unapplied="record")
    assert tr.status == "success", tr.message
    assert tr.stats["unapplied_force"]["force_left"] > 1e-6


def test_enough_iterations_leave_nothing_to_record(four_bar):
    """The count rtol needs, k >= log(rtol) / log(rho / (s + rho)), passes and records nothing."""
    k = 1
    while _smallest_fraction(four_bar, k) > 1e-6:
        k += 1
    tr = pinclear.simulate(four_bar, 0.02, method="proximal", max_iter=k, rtol=1e-6, dt_out=0.01)
    assert tr.status == "success", tr.message
    assert "unapplied_force" not in tr.stats


@pytest.mark.parametrize("bad", ["warn", "", None, 1, True])
def test_the_option_takes_its_two_values_only(four_bar, bad):
    with pytest.raises(InputError, match="unapplied"):
        pinclear.simulate(four_bar, 0.02, method="proximal", unapplied=bad)


@pytest.mark.slow
def test_cassie_at_fifty_iterations_fails_instead_of_flexing():
    """The audit's case: max_iter = 50, rtol = 1e-6 reported success while the knee-shin joints
    moved 1e-3 rad (manifold: 1e-10)."""
    mech = pinclear.load("cassie")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        tr = pinclear.simulate(mech, 0.05, method="proximal", max_iter=50, rtol=1e-6)
    assert tr.status == "failed", tr.message
    assert tr.failure.kind == FailureKind.UNAPPLIED
    assert tr.stats["unapplied_force"]["force_left"] > 1e-6
    assert len(tr.t) > 1 and tr.t[-1] == pytest.approx(0.05)
