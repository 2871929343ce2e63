"""The proximal method's iteration count fitted to the start's conditioning
(pinclear.dynamics.formulations.proximal.Proximal.fit_start): k proximal iterations leave the fraction
(rho / (s + rho))^k of the constraint force along an eigen-direction s of J M^-1 J^T unapplied, so a
fixed k = 30 silently under-held mechanisms whose independent rows are nearly dependent."""
import warnings

import numpy as np
import pytest

import pinclear
from pinclear import simulate

T_END, RTOL = 0.5, 1e-10


@pytest.fixture(scope="module")
def three_upru_up():
    mech = pinclear.load("three_upru_up")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        ref = simulate(mech, T_END, method="manifold", rtol=RTOL, dt_out=T_END / 10)
    assert ref.status == "success", ref.message
    return mech, ref


def test_proximal_agrees_with_manifold_on_nearly_dependent_rows(three_upru_up):
    """three_upru_up's smallest independent eigenvalue of J M^-1 J^T is 0.046 rho: 30 iterations
    leave 26 % of the constraint force along it. With the fitted count, proximal ends where the
    manifold method (an independent formulation: exact projection, no regularisation) ends, to a
    bound of 1e-7 m/s on the velocities (two rtol-1e-10 runs over 0.5 s: their global errors are
    orders below it); the count before the fit was off by 4.6e-4."""
    mech, ref = three_upru_up
    tr = simulate(mech, T_END, method="proximal", rtol=RTOL, dt_out=T_END / 10)
    assert tr.status == "success", tr.message
    assert np.abs(tr.v - ref.v).max() < 1e-7
    assert np.abs(tr.q - ref.q).max() < 1e-9


def test_a_fixed_count_too_small_is_a_warning_and_is_wrong(three_upru_up):
    """max_iter given by the user is kept; when the start needs more and the user opted out of the
    failure (unapplied="record"; the default fails the run: test_proximal_unapplied.py), a
    RuntimeWarning names the rows, the fraction of force left and the count rtol needs; the motion
    then is off by far more than the integration error (the reason for the fit)."""
    mech, ref = three_upru_up
    with pytest.warns(RuntimeWarning, match=r"30 proximal iterations leave 0\.2\d+ of the constraint force unapplied "
                      r"\(rtol 1e-10 needs \d+ iterations\); raise max_iter"):
        tr = simulate(mech, T_END, method="proximal", max_iter=30, rtol=RTOL, dt_out=T_END / 10, unapplied="record")
    assert np.abs(tr.v - ref.v).max() > 1e-5


def test_well_conditioned_mechanisms_keep_thirty_iterations():
    """four_ups_upu (smallest eigenvalue 16 rho) needs no more than the former count: its
    iterations, and so its results, are unchanged."""
    from pinclear.dynamics import formulations
    from pinclear.model import kinematics

    mech = pinclear.load("four_ups_upu")
    form = formulations.get("proximal")(mech)
    J = kinematics.jacobian(mech, form.ws, mech.q0, 0.0, with_drives=True)
    _, indep, _ = kinematics.rank_analysis(J, mech.row_names())
    form.fit_start(0.0, mech.q0, J, indep, 1e-12)
    assert form.opts["max_iter"] == 30
    assert form.start_filter[0] > 10 and form.start_filter[1] < 1e-12
