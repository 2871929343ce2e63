"""Benchmark mechanisms of the multibody community (issue 12, item 1), held to their published
criteria against references that do not come from pinclear's formulations:

* IFToMM A02 "N-four-bar" (N = 1, 2, 10): energy conserved, loop closed, parallelogram branch
  kept through the flat singular position; the crank angle against the branch's own 1-dof
  pendulum (closed-form inertia and gravity, integrated by SciPy at rtol 1e-13).
* IFToMM A04 Bricard: mobility 1 where Grübler's count gives 0, one redundant row in every
  configuration; energy conserved; the exact singular configuration of the rows ``lagrange``
  keeps (found by hand, closing to round-off).
* Flores et al.'s slider-crank: ideal piston position against x = r cos th + sqrt(l^2 - r^2
  sin^2 th); with the 0.5 mm piston-pin clearance the journal stays in its bearing.

Energies are computed here from Pinocchio's kinetic and potential energy at the returned
states; drifts are relative to the largest kinetic energy of the run (the energy that moves).
"""
from __future__ import annotations

import math
import warnings

import numpy as np
import pinocchio as pin
import pytest
from scipy.interpolate import CubicHermiteSpline
from scipy.optimize import brentq

import pinclear
from pinclear.mechanisms import benchmarks as B
from pinclear.model import kinematics
from tests.helpers import (
    a02_branch,
    a02_cranks,
    energy_drift,
    energy_drift_samples,
    flat_passages,
)


def _simulate(mech, t_end, **kw):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)      # a failed run warns; tests read status
        return pinclear.simulate(mech, t_end, **kw)


def _idx(mech, joint):
    return mech.model.joints[mech.model.getJointId(joint)].idx_q


@pytest.mark.parametrize("n", B.A02_SIZES)
def test_a02_model_matches_the_specification(n):
    """2N+1 bars of 1 kg; the published start: cranks at 45 deg, B0 moving at +1 m/s along x,
    and the energy of the branch pendulum (I = (N+1)/3 + N, V = ((N+1)/2 + N) g sin th)."""
    mech = pinclear.load(B.a02_name(n))
    model, data = mech.model, mech.model.createData()
    assert model.nv == 2 * n + 1 and len(mech.closures) == n
    assert sum(model.inertias[j].mass for j in range(1, model.njoints)) == pytest.approx(2 * n + 1, rel=1e-12)
    q0, v0 = mech.q0, mech.v0
    assert np.abs(kinematics.closure_residual(mech, mech.workspace(), q0)).max() < 1e-14
    pin.forwardKinematics(model, data, q0, v0)
    jid = model.getJointId("crank0_joint")
    vj = data.v[jid]                                     # crank 0's twist in its own frame
    vB0 = data.oMi[jid].rotation @ (vj.linear + np.cross(vj.angular, [B.A02_L, 0.0, 0.0]))
    assert vB0[0] == pytest.approx(1.0, abs=1e-12)
    # on the crank circle B0 moves along the tangent (-sin th, cos th): vy = -vx at 45 deg
    assert vB0 == pytest.approx([1.0, -1.0, 0.0], abs=1e-12)
    E0 = pin.computeKineticEnergy(model, data, q0, v0) + pin.computePotentialEnergy(model, data, q0)
    assert E0 == pytest.approx(B.a02_branch_energy(n, B.A02_THETA0, B.a02_initial_rate()), rel=1e-12)


@pytest.fixture(scope="module")
def a02_runs():
    runs = {}
    for n in (1, 2):
        mech = pinclear.load(B.a02_name(n))
        runs[n] = (mech, _simulate(mech, 10.0, method="proximal", integrator="DOP853", rtol=1e-10, dt_out=0.01))
    return runs


@pytest.mark.parametrize("n, drift_tol, away_tol, ref_tol", [(1, 1e-4, 1e-7, 1e-4), (2, 2e-6, 1e-6, 5e-5)])
def test_a02_proximal_keeps_energy_closure_and_branch(a02_runs, n, drift_tol, away_tol, ref_tol):
    """10 s, DOP853, proximal (default rho 1e-4): 14 flat passages. Convergence study (this
    machine; drift relative to max kinetic energy; crank-angle error against the branch pendulum):

        N = 1   rtol 1e-8: drift 4.9e-5, error 9.0e-5   1e-9: 7.8e-8, 1.4e-7   1e-10: 1.7e-8, 2.2e-7
        N = 2   rtol 1e-8: drift 3.6e-7, error 1.1e-5   1e-9: 5.4e-7, 2.5e-5   1e-10: 4.7e-7, 2.1e-5
                rtol 1e-11: 4.0e-7, 1.8e-5

    closure <= 1e-12 and branch spread <= 2.3e-9 throughout. For N = 2 the error stops falling
    with rtol: it is the regularisation's, not the integrator's (at rtol 1e-10: rho 1e-3 gives
    drift 4.4e-6, 1e-4 4.7e-7, 1e-6 3.2e-8).

    Rounding spread (2026-11-25): q0 moved by k 4e-16, k = 0..7, with the proximal iterations
    by triangular substitutions and by the explicit inverse (pinclear.core.regularised.proximal_inverse),
    16 runs per N. N = 2: drift 4.1e-7..7.5e-7, 4.1e-7..4.9e-7 away from flat (|sin th| > 0.3),
    error 1.5e-5..2.3e-5. N = 1: away from flat 1.7e-9..8.0e-9 in every run, but in 5 of the 16
    runs (2 with substitutions, 3 with the inverse) a step that lands near a flat configuration
    leaves a transient of 5.3e-7..2.6e-5 that the next 0.05 s undo (energy back within 1e-8),
    and a crank-angle error of 8.3e-7..4.7e-5 (the others 2.7e-8..2.2e-7): which runs do is
    the rounding's, not the kernel's. The single-run bounds this test had (drift 1e-6, error
    1e-6 at N = 1) failed 2 of the 8 runs of each kernel. Bounds, 2x-12x the spread: N = 1
    drift 1e-4, away 1e-7, error 1e-4; N = 2 drift 2e-6, away 1e-6, error 5e-5; closure 1e-8,
    branch 1e-6."""
    mech, traj = a02_runs[n]
    assert traj.status == "success" and traj.t[-1] == pytest.approx(10.0)
    th = a02_cranks(mech, n, traj)
    ref = a02_branch(n, traj.t)
    assert flat_passages(th[:, 0]) == flat_passages(ref.y[0]) >= 10
    drift = energy_drift_samples(mech, traj)
    assert drift.max() < drift_tol
    assert drift[np.abs(np.sin(th[:, 0])) > 0.3].max() < away_tol
    assert traj.residual.max() < 1e-8
    # parallelogram branch: every crank parallel to the first (the anti-parallelogram differs by O(1))
    assert np.abs(th - th[:, :1]).max() < 1e-6
    np.testing.assert_allclose(th[:, 0], ref.y[0], rtol=0, atol=ref_tol)


@pytest.fixture(scope="module")
def a02_10():
    return pinclear.load(B.a02_name(10))


def test_a02_n10_assembles_on_the_branch_and_reports_mobility(a02_10):
    """Generic configuration: mobility 1, no redundant row (Grübler's planar count: 3 (2N+1) -
    2 (3N+1) = 1). Flat configuration: the spec's 'degrees of freedom increase from 1 to N+1':
    rank falls by N, and N rows are named redundant."""
    mech, n = a02_10, 10
    mob = kinematics.mobility(mech, mech.q0)
    assert (mob["mobility"], mob["rank"], mob["rows"], mob["redundant_rows"]) == (1, 2 * n, 2 * n, [])
    flat = kinematics.mobility(mech, np.zeros(mech.model.nq))
    assert flat["mobility"] == n + 1 and flat["rank"] == n
    assert len(flat["redundant_rows"]) == n
    assert set(flat["redundant_rows"]) <= {f"B{k}.{a}" for k in range(1, n + 1) for a in "uv"}
    # assembly from a scrambled guess lands on the parallelogram branch (cranks parallel)
    rng = np.random.default_rng(12)
    guess = mech.q0 + rng.uniform(-0.05, 0.05, mech.model.nq)
    q = kinematics.assemble(mech, guess, with_drives=False)
    assert np.abs(kinematics.closure_residual(mech, mech.workspace(), q)).max() < 1e-12
    th = q[[_idx(mech, f"crank{k}_joint") for k in range(n + 1)]]
    assert np.abs(th - th[0]).max() < 1e-10


def test_a02_n10_short_run_through_a_flat_passage(a02_10):
    """0.5 s includes the first flat passage (t ~ 0.44 s). Measured (rtol 1e-10): drift 9.7e-9,
    closure 4e-12, branch 4.8e-10, error against the pendulum 1.2e-8."""
    mech, n = a02_10, 10
    traj = _simulate(mech, 0.5, method="proximal", integrator="DOP853", rtol=1e-10, dt_out=0.005)
    assert traj.status == "success"
    th = a02_cranks(mech, n, traj)
    assert th[0, 0] > 0 > th[-1, 0]
    assert energy_drift(mech, traj) < 1e-7
    assert traj.residual.max() < 1e-10
    assert np.abs(th - th[:, :1]).max() < 1e-8
    np.testing.assert_allclose(th[:, 0], a02_branch(n, traj.t).y[0], rtol=0, atol=1e-7)


# ============================================================================ A04 Bricard
@pytest.fixture(scope="module")
def bricard():
    return pinclear.load("a04_bricard")


@pytest.fixture(scope="module")
def bricard_proximal(bricard):
    return _simulate(bricard, 10.0, method="proximal", integrator="DOP853", rtol=1e-10, dt_out=0.01)


#: where the rows lagrange keeps (all but J5.z) lose rank: theta_J0 = theta_J2 = theta_J4 = pi/2,
#: theta_J1 = theta_J3 = -pi/6 (found by hand; it closes the loop to round-off)
BRICARD_SWITCH = np.array([math.pi / 2, -math.pi / 6, math.pi / 2, -math.pi / 6, math.pi / 2])
BRICARD_SWITCH.setflags(write=False)


def test_bricard_mobility_one_with_one_redundant_row(bricard):
    """Grübler (spatial): 6 (6 - 1) - 5 x 6 = 0; Bricard's axes give mobility 1, so one of the
    cut joint's 5 rows depends on the others."""
    grubler = 6 * (6 - 1) - 5 * 6
    mob = kinematics.mobility(bricard, bricard.q0)
    assert grubler == 0
    assert (mob["mobility"], mob["rank"], mob["rows"]) == (1, 4, 5)
    # which of the tied rows J5.x, J5.z, J5.rx is named is the QR pivot's choice
    assert len(mob["redundant_rows"]) == 1 and mob["redundant_rows"][0] in ("J5.x", "J5.z", "J5.rx")


def test_bricard_proximal_conserves_energy_with_a_redundant_row_everywhere(bricard, bricard_proximal):
    """10 s from rest, DOP853 rtol 1e-10, proximal (redundant rows kept): measured drift 1.3e-11
    (2.4e-9 at rtol 1e-8), closure 1e-12, 1.3 s CPU. Along the motion the full Jacobian keeps
    rank 4 of 5 (singular values 4 >= 1.17, 5th <= 4e-13), and the loop's kinematics make
    alternate joint angles equal (J0 = J2 = J4, J1 = J3), a property of this Bricard linkage
    that the integration does not impose."""
    traj = bricard_proximal
    assert traj.status == "success" and traj.t[-1] == pytest.approx(10.0)
    assert energy_drift(bricard, traj) < 1e-9
    assert traj.residual.max() < 1e-10
    assert np.ptp(traj.q[:, 0]) > 3.0                           # it swings through a half turn
    q = traj.q
    assert np.abs(q[:, [2, 4]] - q[:, [0, 0]]).max() < 1e-8
    assert np.abs(q[:, 3] - q[:, 1]).max() < 1e-8
    ws = bricard.workspace()
    for qi in q[::25]:
        sv = np.linalg.svd(kinematics.jacobian(bricard, ws, qi), compute_uv=False)
        assert sv[3] > 0.5 and sv[4] < 1e-9
        assert kinematics.mobility(bricard, qi, ws)["mobility"] == 1


def test_bricard_lagrange_chooses_its_rows_again_when_the_dropped_one_is_needed(bricard, bricard_proximal):
    """``lagrange`` drops J5.z, found redundant at t0 (a tie among J5.x, J5.z, J5.rx there). The
    four rows it keeps lose rank at BRICARD_SWITCH, reached at t* ~ 1.2479 s, where J5.z is the
    row that no longer depends on the others. A drop set fixed at t0 cannot pass t*; lagrange
    chooses the independent rows again when its Schur pivots fall to 1 % of their start, and so
    runs issue 12's 10 s with energy drift <= 1e-8 (measured 9e-12 at rtol 1e-10, 0.8 s CPU)."""
    ws = bricard.workspace()
    assert np.abs(kinematics.closure_residual(bricard, ws, BRICARD_SWITCH)).max() < 1e-14
    J = kinematics.jacobian(bricard, ws, BRICARD_SWITCH)
    names = bricard.compiled.row_names
    kept = [i for i, nm in enumerate(names) if nm != "J5.z"]
    assert np.linalg.svd(J[kept], compute_uv=False)[-1] < 1e-12
    assert np.linalg.svd(J, compute_uv=False)[3] > 1.0          # the full set is regular there
    # when the motion reaches it, from the proximal run (the other formulation)
    ref = bricard_proximal
    spline = CubicHermiteSpline(ref.t, ref.q[:, 0], ref.v[:, 0])
    t_star = brentq(lambda t: spline(t) - math.pi / 2, 1.0, 1.4, xtol=1e-13)

    run = _simulate(bricard, 10.0, method="lagrange", integrator="DOP853", rtol=1e-10, dt_out=0.01)
    assert run.stats["redundant_rows"] == ["J5.z"], "the QR pivot now drops another row: revisit this test"
    assert run.status == "success"
    assert energy_drift(bricard, run) < 1e-8
    assert run.residual.max() < 1e-9
    first = run.stats["row_changes"][0]
    assert t_star - 0.2 < first["t"] < t_star and first["dropped"] != ["J5.z"]
    # the same motion as proximal, which keeps every row (the two agree to their tolerances)
    np.testing.assert_allclose(run.q, ref.q, rtol=0, atol=1e-6)


# ============================================================================ slider-crank
@pytest.fixture(scope="module")
def slider_crank():
    return pinclear.load("slider_crank_clearance")


def test_ideal_slider_crank_follows_the_closed_form(slider_crank):
    """Two crank turns at 5000 rpm (lagrange, rtol 1e-10; measured 6.4e-11 m, 1.9e-9 m at
    rtol 1e-8)."""
    mech = slider_crank
    assert not any(f.kind == "planar_revolute" for f in mech.forces)      # clearance off by default
    w = B.crank_rate()
    assert w == pytest.approx(5000 * 2 * math.pi / 60)
    t_end = 2 * 2 * math.pi / w
    traj = _simulate(mech, t_end, method="lagrange", integrator="DOP853", rtol=1e-10, dt_out=t_end / 400)
    assert traj.status == "success"
    th = traj.q[:, _idx(mech, "crank_joint")]
    np.testing.assert_allclose(th, w * traj.t, rtol=0, atol=1e-9)
    assert th[-1] == pytest.approx(4 * math.pi)
    x = traj.q[:, _idx(mech, "slider_joint")]
    r, l = B.SC["r"], B.SC["l"]
    np.testing.assert_allclose(x, r * np.cos(th) + np.sqrt(l * l - r * r * np.sin(th) ** 2), rtol=0, atol=1e-8)
    assert x.max() == pytest.approx(r + l, abs=1e-8) and x.min() == pytest.approx(l - r, abs=1e-6)


def test_piston_pin_clearance_journal_stays_in_its_bearing(slider_crank):
    """One crank turn at 5000 rpm with the 0.5 mm clearance (LN law, ce 0.9, steel, rtol 1e-8):
    measured: ~30 impacts, largest penetration 5.7e-5 m, eccentricity <= 5.57e-4 m, 3.3 s CPU."""
    mech = pinclear.load("slider_crank_clearance", clearances=["P"])
    el = next(f for f in mech.forces if f.name == "P")
    assert el.is_clearance and el.kind == "planar_revolute" and el.c == pytest.approx(5e-4)
    assert not any(c.name == "P" for c in mech.closures)
    t_end = 2 * math.pi / B.crank_rate()
    traj = _simulate(mech, t_end, integrator="DOP853", rtol=1e-8, dt_out=t_end / 400, max_cpu=60)
    assert traj.status == "success", traj.message
    ecc = np.linalg.norm(traj.outputs["P.eccentricity"][:, :2], axis=1)
    pen = traj.outputs["P.penetration"]
    on = traj.outputs["P.contact"] > 0
    assert on.any() and (~on).any()                      # free flight and contact both occur
    assert ecc.max() < el.c + 1e-4
    assert pen.max() < 1e-4
    # the contact law's geometry: eccentricity = clearance + penetration while in contact
    np.testing.assert_allclose(ecc[on], el.c + pen[on], rtol=1e-9)
    assert np.all(ecc[~on] <= el.c * (1 + 1e-12))
    th = traj.q[:, _idx(mech, "crank_joint")]
    np.testing.assert_allclose(th, B.crank_rate() * traj.t, rtol=0, atol=1e-7)
