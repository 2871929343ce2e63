"""pinclear's implicit integrator ROS34PW2 (pinclear.dynamics.stepping.rosenbrock).

Reference values: the IVP Test Set of Mazzia & Magherini (Bari; problems VDPOL and ROBER,
reference solutions computed with RADAU in quadruple precision), SciPy's DOP853 at rtol 1e-13
on the same right-hand side for the order study, and pinclear's DOP853 at rtol 1e-11 for the
mechanisms; never the method's own output. Order measurements take constant steps (max_step
with a tolerance the steps always pass), so they measure the method, not its step control.
"""
from __future__ import annotations

import warnings

import numpy as np
import pinocchio as pin
import pytest
from numba import carray, cfunc
from scipy.integrate import solve_ivp

import pinclear
from pinclear.core.call import CALLBACK, ptr_f8
from pinclear.dynamics.stepping import INTEGRATORS
from pinclear.dynamics.stepping import chunk as C
from pinclear.dynamics.stepping import rosenbrock as R
from pinclear.dynamics.stepping import rosenbrock_peers
from pinclear.dynamics.stepping.checks import reset_monitor
from pinclear.dynamics.stepping.run import STALL_STEPS
from pinclear.dynamics.stepping.state import (
    ATOL,
    BAD,
    H_ABS,
    H_STALL,
    MAX_STEP,
    NJAC,
    REJECTS,
    RTOL,
    STEPS,
    T_BAD,
    T_BOUND,
    T,
    new_steps,
)
from pinclear.dynamics.stepping.system import ode_system
from tests.stiff_odes import ROBER_REF, VDPOL_REF, rober, vdpol


# ----------------------------------------------------------------------------- ODEs without a mechanism
# Each right-hand side is a C callback of the stage signature reading x from the head of one
# buffer and writing its rates after it (the System's x and a are views of that buffer): the
# state layout x = [c, v, z] with nc leading components whose rate is the next nc (dc/dt = v).
@cfunc(CALLBACK)
def _forced(ctx, t):
    """c' = v, v' = -sin c - 0.3 v + 0.5 cos 2t + 0.2 z^2, z' = -2 z + c v: smooth, nonlinear,
    non-autonomous (a W-method needs no df/dt)."""
    b = carray(ptr_f8(ctx), (5,))
    c, v, z = b[0], b[1], b[2]
    b[3] = -np.sin(c) - 0.3 * v + 0.5 * np.cos(2.0 * t) + 0.2 * z * z
    b[4] = -2.0 * z + c * v
    return np.inf


def _forced_py(t, y):
    c, v, z = y
    return [v, -np.sin(c) - 0.3 * v + 0.5 * np.cos(2.0 * t) + 0.2 * z * z, -2.0 * z + c * v]


@cfunc(CALLBACK)
def _sqrt_decay(ctx, t):
    """y' = -sqrt(y): y = (1 - t/2)^2 from y(0) = 1; a state below zero evaluates to NaN."""
    b = carray(ptr_f8(ctx), (2,))
    b[1] = -np.sqrt(b[0])
    return np.inf


@cfunc(CALLBACK)
def _nan_after(ctx, t):
    """y' = -y until t = 0.5, NaN after: no step can pass t = 0.5."""
    b = carray(ptr_f8(ctx), (2,))
    b[1] = -b[0] if t <= 0.5 else np.nan
    return np.inf


class Ode:
    """A System around one of the callbacks above: n states, the first nc with dc/dt = v."""

    def __init__(self, stage, n, nc):
        self.n, self.nc = n, nc
        self.sys, self.buf = ode_system(stage.address, n, nc)

    def steps(self, y0, t1, rtol, atol, coeffs=R.ROS34PW2_COEFFS, h=None, **policy):
        """A started step state (Steps, Tableau) from y0 at t = 0 to t1; ``h``: constant steps
        (a hair longer, so that round-off in t leaves no sliver of a last step: the last one is
        cut to end at t1)."""
        if h is not None:
            h *= 1.0 + 1e-12
        tab = R.rosenbrock_tableau(coeffs)
        st = new_steps(self.n, 0, [t1], len(coeffs["b"]) + 2, 0, C.SEARCH_STATE, STALL_STEPS)
        st.r[T_BOUND], st.r[MAX_STEP], st.r[H_STALL], st.r[RTOL] = t1, np.inf if h is None else h, 0.0, rtol
        st.V[ATOL] = atol
        reset_monitor(st.r)
        st = R.prepare(st, self.n, self.nc, **policy)
        assert C.start(self.sys, tab, st, 0.0, np.asarray(y0, float), -1.0 if h is None else h, -1) == C.QUIET
        return st, tab

    def finish(self, st, tab):
        while True:
            code = C.advance(self.sys, tab, st, 100000)
            if code == C.FINISHED:
                return st.samples[-1].copy()
            assert code == C.QUIET, code

    def solve(self, y0, t1, rtol, atol, **kw):
        self.sys.count[0] = 0
        st, tab = self.steps(y0, t1, rtol, atol, **kw)
        return self.finish(st, tab), st


@pytest.fixture(scope="module")
def forced():
    y0, t1 = [1.0, 0.0, 0.5], 2.0
    ref = solve_ivp(_forced_py, (0.0, t1), y0, method="DOP853", rtol=1e-13, atol=1e-14).y[:, -1]
    return Ode(_forced, 3, 1), y0, t1, ref


#: constant steps: the error test always passes with these tolerances (the steps are max_step)
LOOSE = dict(rtol=1e3, atol=1e3)


def _orders(ode, y0, t1, ref, ns=(40, 80, 160, 320), coeffs=R.ROS34PW2_COEFFS, perturb=None, **policy):
    """Observed orders log2(e(h) / e(h/2)) of constant-step runs; ``perturb``: a matrix added to
    the Jacobian made at the start, which is then kept for the whole run."""
    errs = []
    for n in ns:
        st, tab = ode.steps(y0, t1, coeffs=coeffs, h=t1 / n, **LOOSE, **policy)
        if perturb is not None:
            W, r0, m = st.W, R.meta_rows(ode.n), ode.n - ode.nc
            assert R.jacobian(ode.sys, st, 0.0, r0, m, ode.nc) == 0
            W[r0:r0 + m] += perturb
            flat = W.reshape(-1)
            flat[R.J_STATE], flat[R.LU_H] = R.FRESH, 0.0
        y = ode.finish(st, tab)
        assert st.i[STEPS] == n
        errs.append(np.abs(y - ref).max())
    errs = np.array(errs)
    return np.log2(errs[:-1] / errs[1:])


def test_order_three_with_the_exact_jacobian(forced):
    """A Jacobian made at every step: the measured order is 3 (the last halvings within 0.15)."""
    ode, y0, t1, ref = forced
    p = _orders(ode, y0, t1, ref, max_age=1)
    assert np.all(np.abs(p[-2:] - 3.0) < 0.15), p


def test_jacobian_time_column_is_df_dt(forced):
    """The time column the secant test reads is df/dt: for the forced oscillator only the v row
    depends on t, d/dt (0.5 cos 2t) = -sin 2t, to the forward difference's error with
    h = sqrt(eps) t = 4.5e-9 s: truncation h |f_tt| / 2 <= 4e-9 plus rounding, a few ulps of
    the row's terms (<= 0.5) over h, <= 5e-8."""
    ode, y0, _, _ = forced
    st, tab = ode.steps(y0, 2.0, rtol=1e-6, atol=1e-9, time_column=True)
    t = 0.3
    assert C.start(ode.sys, tab, st, t, np.asarray(y0, float), 0.01, -1) == C.QUIET
    r0, m = R.meta_rows(ode.n), ode.n - ode.nc
    assert R.jacobian(ode.sys, st, t, r0, m, ode.nc) == 0
    ft = st.W[r0 + 2 * m + 2, :m]
    np.testing.assert_allclose(ft, [-np.sin(2 * t), 0.0], atol=1e-7)


def test_w_method_keeps_order_three_with_a_stale_or_wrong_jacobian(forced):
    """The W-method property: the Jacobian of the initial state kept for the whole run, or that
    Jacobian plus a matrix as large as itself, and still order 3. The same perturbation takes
    ROS3PW (order 3 only with the exact Jacobian) down to order 2: the test tells them apart."""
    ode, y0, t1, ref = forced
    frozen = dict(max_age=np.inf, secant=np.inf)
    p = _orders(ode, y0, t1, ref, **frozen)
    assert np.all(np.abs(p[-2:] - 3.0) < 0.15), p
    P = np.random.default_rng(7).normal(size=(2, 3))
    p = _orders(ode, y0, t1, ref, perturb=P, **frozen)
    assert np.all(np.abs(p[-2:] - 3.0) < 0.15), p
    p = _orders(ode, y0, t1, ref, coeffs=rosenbrock_peers.ROS3PW_COEFFS, perturb=P, **frozen)
    assert np.all(np.abs(p[-2:] - 2.0) < 0.25), p


def test_jacobian_evaluations_are_counted(forced):
    """Every difference quotient is an evaluation of the right-hand side and counted as one; the
    Jacobians in Steps.i[NJAC]: N constant steps with a Jacobian each cost 1 (f at the start) +
    N (3 stages + f at the new point + 3 columns), one more per Jacobian with the time column."""
    ode, y0, t1, _ = forced
    ode.sys.count[0] = 0
    n = 25
    st, tab = ode.steps(y0, t1, h=t1 / n, max_age=1, **LOOSE)
    ode.finish(st, tab)
    assert st.i[STEPS] == n and st.i[NJAC] == n
    assert ode.sys.count[0] == 1 + n * (3 + 1 + 3)
    ode.sys.count[0] = 0
    st, tab = ode.steps(y0, t1, h=t1 / n, max_age=1, time_column=True, **LOOSE)
    ode.finish(st, tab)
    assert ode.sys.count[0] == 1 + n * (3 + 1 + 3 + 1)


def test_bad_evaluation_rejects_the_attempt():
    """A first step of 1.9 s sends the second stage below zero (y + 2 u_1 with u_1 ~ -0.58): its
    NaN rejects the attempt like a large error, the step shrinks and the run reaches
    y(1.9) = (1 - 0.95)^2 within 10 rtol max|y| (the local errors were made at y ~ 1)."""
    ode = Ode(_sqrt_decay, 1, 0)
    ode.sys.count[0] = 0
    st, tab = ode.steps([1.0], 1.9, 1e-8, 1e-10)
    st.r[H_ABS] = 1.9
    y = ode.finish(st, tab)
    assert st.i[REJECTS] >= 1 and st.r[T_BAD] > 0.0
    assert abs(y[0] - 0.0025) < 10 * 1e-8


def test_bad_evaluations_without_end_stop_the_run():
    """Every evaluation past t = 0.5 bad: each shrinks the step by 5 (as rk_step), the steps creep
    up to the wall until one would be below 10 ulp of t; the chunk ends with STEP_TOO_SMALL
    there, with a bad evaluation recorded past the wall (the run reports the Python path's
    error at it) and the state still on y = exp(-t)."""
    ode = Ode(_nan_after, 1, 0)
    st, tab = ode.steps([1.0], 1.0, 1e-6, 1e-8)
    while True:
        code = C.advance(ode.sys, tab, st, 1000)
        if code != C.QUIET:
            break
    assert code == C.STEP_TOO_SMALL
    assert st.i[BAD] >= 1
    assert st.r[T] <= 0.5 < st.r[T_BAD] and 0.5 - st.r[T] < 1e-9
    assert abs(st.V[0, 0] - np.exp(-st.r[T])) < 1e-5


@pytest.mark.parametrize("rtol", [1e-5, 1e-7])
def test_van_der_pol_test_set(rtol):
    """VDPOL at t = 2 (eps = 1e-6: stiffness 1e6): each component within 10 rtol of the Test
    Set's value (the error test keeps each step's error below rtol |y| + atol; VDPOL's
    solution contracts onto its limit cycle, so the global error stays of that size), in a
    few thousand steps where an explicit method needs ~1e6."""
    ode = Ode(vdpol, 2, 1)
    y, st = ode.solve([2.0, 0.0], 2.0, rtol, rtol)
    err = np.abs(y - VDPOL_REF) / (rtol * np.abs(VDPOL_REF) + rtol)
    assert np.all(err < 10.0), (err, y)
    assert st.i[STEPS] < 20000


@pytest.mark.parametrize("rtol", [1e-4, 1e-6])
def test_robertson_test_set(rtol):
    """ROBER at t = 1e11 with the Test Set's scaling of the absolute tolerances (y2 ~ 1e-5 .. 1e-13):
    each component within 10 (rtol |y| + atol) of the reference, in a few thousand steps."""
    ode = Ode(rober, 3, 0)
    atol = np.array([1e-6, 1e-12, 1e-6]) * rtol
    y, st = ode.solve([1.0, 0.0, 0.0], 1e11, rtol, atol)
    err = np.abs(y - ROBER_REF) / (rtol * np.abs(ROBER_REF) + atol)
    assert np.all(err < 10.0), (err, y)
    assert st.i[STEPS] < 5000


# ----------------------------------------------------------------------------- mechanisms
def _quiet(mech, t_end, **kw):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        return pinclear.simulate(mech, t_end, **kw)


@pytest.fixture(scope="module")
def pendulum_a():
    """clr_planar_pendulum with clearance A over 0.03 s (six impacts; its 11th, near t = 0.044 s,
    grazes and makes later times sensitive to 1e-8 changes, so the comparison stops before)."""
    mech = pinclear.load("clr_planar_pendulum", clearances=["A"])
    t_eval = np.linspace(0.0, 0.03, 61)
    ref = _quiet(mech, 0.03, integrator="DOP853", rtol=1e-11, t_eval=t_eval)
    assert ref.status == "success"
    return mech, t_eval, ref


@pytest.mark.parametrize("rtol", [1e-6, 1e-8])
def test_clearance_pendulum_energy_and_agreement(pendulum_a, rtol):
    """Energy audit passed; configurations within rtol (the coordinates are at most 0.5: the
    error control's own scale) of DOP853 at 1e-11 and velocities no further from it than RK45's
    at the same rtol (the velocity jumps at each impact, so its error is set by the impact times)."""
    mech, t_eval, ref = pendulum_a
    tr = _quiet(mech, 0.03, integrator="ROS34PW2", rtol=rtol, t_eval=t_eval)
    rk = _quiet(mech, 0.03, integrator="RK45", rtol=rtol, t_eval=t_eval)
    assert tr.status == "success" and tr.stats["jacobians"] > 0
    assert tr.summary()["energy_balance"]["ok"]
    assert np.abs(tr.q - ref.q).max() < rtol
    assert np.abs(tr.v - ref.v).max() <= np.abs(rk.v - ref.v).max()


def test_clearance_events_as_rk45(pendulum_a):
    """The same impacts as RK45 and as the reference, each located within 1e-6 s of the
    reference's (an impact time is off by about the position error over the approach speed,
    here ~1e-8 m over ~0.03 m/s, RK45's within 3e-6 s)."""
    mech, t_eval, ref = pendulum_a
    tr = _quiet(mech, 0.03, integrator="ROS34PW2", rtol=1e-6, t_eval=t_eval)
    rk = _quiet(mech, 0.03, integrator="RK45", rtol=1e-6, t_eval=t_eval)
    ev = [(e["element"], e["event"]) for e in tr.stats["events"]]
    assert ev == [(e["element"], e["event"]) for e in rk.stats["events"]]
    assert ev == [(e["element"], e["event"]) for e in ref.stats["events"]] and len(ev) == 7
    dt = np.abs(np.array([e["t"] for e in tr.stats["events"]]) - [e["t"] for e in ref.stats["events"]])
    assert dt.max() < 1e-6, dt


def test_loops_take_the_same_steps(pendulum_a):
    """loop='python' (the plug-ins' Python methods) and the compiled stages: the same steps,
    evaluations, Jacobians and events with ROS34PW2, the same trajectory to round-off."""
    mech, t_eval, _ = pendulum_a
    a = _quiet(mech, 0.012, integrator="ROS34PW2", rtol=1e-6, t_eval=t_eval[:25])
    b = _quiet(mech, 0.012, integrator="ROS34PW2", rtol=1e-6, t_eval=t_eval[:25], loop="python")
    assert b.stats["loop"].startswith("python") and a.stats["loop"] == "compiled"
    for k in ("steps", "rhs_evals", "jacobians", "lu_decompositions"):
        assert a.stats[k] == b.stats[k], k
    assert [e["t"] for e in a.stats["events"]] == pytest.approx([e["t"] for e in b.stats["events"]], abs=1e-12)
    np.testing.assert_allclose(a.q, b.q, atol=1e-12)


def test_nine_bar_clearance_energy_and_agreement():
    """nine_bar with clearance A (drives, closures, a revolute clearance): energy audit passed and
    within 10 rtol of DOP853 at 1e-11 over 0.02 s."""
    mech = pinclear.load("nine_bar", clearances=["A"])
    t_eval = np.linspace(0.0, 0.02, 21)
    ref = _quiet(mech, 0.02, integrator="DOP853", rtol=1e-11, t_eval=t_eval)
    tr = _quiet(mech, 0.02, integrator="ROS34PW2", rtol=1e-7, t_eval=t_eval)
    assert tr.status == "success" and ref.status == "success"
    assert tr.summary()["energy_balance"]["ok"]
    assert np.abs(tr.q - ref.q).max() < 10 * 1e-7


def test_projection_formulation(four_bar):
    """A formulation that projects after each step (the state the method continues from is
    changed under it): agreement with DOP853 at 1e-11 within 10 rtol, and converging with rtol."""
    t_eval = np.linspace(0.0, 1.0, 11)
    ref = _quiet(four_bar, 1.0, method="projection", integrator="DOP853", rtol=1e-11, t_eval=t_eval)
    errs = []
    for rtol in (1e-6, 1e-8):
        tr = _quiet(four_bar, 1.0, method="projection", integrator="ROS34PW2", rtol=rtol, t_eval=t_eval)
        assert tr.status == "success"
        errs.append(np.abs(tr.q - ref.q).max())
        assert errs[-1] < 30 * rtol
    assert errs[0] / errs[1] > 30


def test_non_euclidean_chart():
    """A torque-free body on a spherical joint (configurations in a chart: every row of the
    Jacobian differenced): kinetic energy constant to 10 rtol and the motion within 10 rtol of
    DOP853 at 1e-11."""
    model = pin.Model()
    inertia = pin.Inertia(2.0, np.zeros(3), np.diag([0.02, 0.05, 0.09]))
    jid = model.addJoint(0, pin.JointModelSpherical(), pin.SE3.Identity(), "ball")
    model.appendBodyToJoint(jid, inertia, pin.SE3.Identity())
    model.gravity.linear[:] = 0.0
    mech = pinclear.Mechanism(model, "ball_body", [], [], [])
    assert not mech.euclidean
    kw = dict(method="lagrange", q0=pin.neutral(model), v0=np.array([0.05, 4.0, 0.08]), dt_out=0.1)
    ref = _quiet(mech, 1.0, integrator="DOP853", rtol=1e-11, **kw)
    tr = _quiet(mech, 1.0, integrator="ROS34PW2", rtol=1e-7, **kw)
    assert tr.status == "success"
    data = model.createData()
    T = np.array([pin.computeKineticEnergy(model, data, q, v) for q, v in zip(tr.q, tr.v)])
    assert np.abs(T - T[0]).max() / T[0] < 10 * 1e-7
    assert np.abs(tr.v - ref.v).max() < 10 * 1e-7 * np.abs(ref.v).max()


def test_registered():
    assert isinstance(INTEGRATORS["ROS34PW2"], R.Rosenbrock)
    assert INTEGRATORS["ROS34PW2"].corrects_state


def test_manifold_jacobians_as_the_projection_formulations_on_a_driven_clearance_scene():
    """nine_bar with clearance A (a driven crank) and ROS34PW2: the manifold formulation, which
    projects every evaluation onto the drive's row Phi(q, t) = 0, reuses its Jacobians as the
    projection formulation does (the same motion; the secant test with df/dt). Without the time
    column the secant test found nearly every Jacobian stale: 1 867 Jacobians in 2 423 steps
    where the projection formulation made 231 in 2 457."""
    mech = pinclear.load("nine_bar", clearances=["A"])
    runs = {m: _quiet(mech, 0.02, method=m, integrator="ROS34PW2", rtol=1e-7) for m in ("projection", "manifold")}
    assert all(tr.status == "success" for tr in runs.values())
    jp, jm = runs["projection"].stats["jacobians"], runs["manifold"].stats["jacobians"]
    assert jm <= 2 * jp, (jm, jp)
    assert runs["manifold"].stats["rhs_evals"] <= 2 * runs["projection"].stats["rhs_evals"]
