"""Compiled kernels against plain NumPy evaluations of the same equations (issue 10: one
implementation per law, or a test that shows two equal), at random states."""
from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

import pinclear
from pinclear.dynamics import formulations
from pinclear.dynamics.formulations.proximal import proximal_multipliers
from pinclear.model import kinematics
from tests.helpers import clearance_states


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


# ------------------------------------------------------------------ drive laws
def test_compiled_time_laws_equal_their_python_eval():
    """Constant, sines and polynomial laws filled by one compiled call equal each law's own
    ``eval`` (the formulas written in Python) bit for bit, at random times."""
    from pinclear.model import timelaws as T
    from pinclear.model.drives import Drive, DriveRows

    laws = [T.Constant(0.3), T.Sines(0.1, [{"amp": 0.2, "omega": 3.0, "phase": 0.4},
                                           {"amp": -1.1, "omega": 7.0, "kind": "cos"}]),
            T.Polynomial([1.0, -2.0, 0.5, 0.25]), T.Polynomial([2.0]), T.Polynomial([1.0, 3.0]),
            T.Sines(0.0, [])]
    rows = DriveRows([Drive(f"d{i}", "j", i, i, law) for i, law in enumerate(laws)], len(laws))
    assert rows.law_table is not None and not rows.single        # all compiled
    d = rows.create_data()
    for t in np.random.default_rng(0).uniform(-5.0, 5.0, 200):
        np.testing.assert_array_equal(rows.values(t, d), np.array([law.eval(t) for law in laws]).T)
    # and the sines' derivatives are the derivatives (central differences, error O(h^2))
    h = 1e-5
    for t in (0.3, 1.7):
        (y0, _, _), (y1, yd1, ydd1), (y2, _, _) = (laws[1].eval(t + s) for s in (-h, 0.0, h))
        assert (y2 - y0) / (2 * h) == pytest.approx(yd1, abs=1e-8)
        assert (y2 - 2 * y1 + y0) / h ** 2 == pytest.approx(ydd1, abs=1e-4)


@pytest.mark.parametrize("name", ["four_ups_upu", "three_upru_up", "four_ups_upr"])
def test_ik_drive_laws_written_in_place_have_consistent_derivatives(name):
    """The seed mechanisms' inverse kinematics fills the drive values in place (one compiled call
    per time, the direct path taken). Its analytic rates and accelerations equal central
    differences of the lengths and rates it fills (h = 1e-5 s: truncation h^2/6 |d3L/dt3| and
    rounding eps |L| / h, both below the bounds). The lengths themselves are checked against
    each module's own geometry in test_four_ups_upu, test_three_upru_up and test_four_ups_upr."""
    mech = pinclear.load(name)
    law = mech.drives[0].law
    assert law.filler() is not None and mech.driverows.groups[0][3] is not None   # the direct, in-place path
    d = mech.driverows.create_data()
    h = 1e-5
    for t in np.random.default_rng(1).uniform(0.1, 4.0, 20):
        f = mech.driverows.values(t, d).copy()
        fp = mech.driverows.values(t + h, d).copy()
        fm = mech.driverows.values(t - h, d).copy()
        np.testing.assert_allclose(f[1], (fp[0] - fm[0]) / (2 * h), rtol=0, atol=1e-7 * max(1.0, np.abs(f[1]).max()))
        np.testing.assert_allclose(f[2], (fp[1] - fm[1]) / (2 * h), rtol=0, atol=1e-6 * max(1.0, np.abs(f[2]).max()))


def test_brent_search_compiled_and_python_take_the_same_points():
    """The singular-passage search (pinclear.core.dense.brent_start/brent_next, reverse
    communication) is driven from compiled code in the compiled loop and from Python in the
    Python loop: on random smooth functions both drivers return the same point after the same
    evaluations, and the point is the minimiser: SciPy's bounded Brent's where it found the same
    basin, the analytic one of a parabola to the flat band around it."""
    import math

    from numba import njit
    from scipy.optimize import minimize_scalar

    from pinclear.dynamics.stepping.roots import BRENT_STATE, brent_next, brent_start

    @njit
    def wavy(x, p):
        return (x - p[0]) ** 2 + p[1] * math.cos(p[2] * x)

    @njit
    def search_compiled(p, a, b, xatol):
        st = np.empty(BRENT_STATE)
        x, n = brent_start(a, b, xatol, st), 0
        while True:
            fx = wavy(x, p)
            n += 1
            x, done = brent_next(st, fx, 500)
            if done:
                return x, n

    def search_python(f, a, b, xatol):
        st = np.empty(BRENT_STATE)
        x, n, done = brent_start.py_func(a, b, xatol, st), 0, False
        while not done:
            fx = f(x)
            n += 1
            x, done = brent_next.py_func(st, fx, 500)
        return x, n

    rng = np.random.default_rng(3)
    same_basin = 0
    for _ in range(50):
        p = (rng.uniform(-1, 2), rng.uniform(0, 0.3), rng.uniform(1, 8))
        xc, nc = search_compiled(p, -1.0, 2.0, 1e-12)
        xp, n_p = search_python(lambda x: wavy.py_func(x, p), -1.0, 2.0, 1e-12)
        assert (xc, nc) == (xp, n_p)
        ref = minimize_scalar(lambda x: wavy.py_func(x, p), bounds=(-1, 2), method="bounded",
                              options={"xatol": 1e-12})
        if abs(ref.x - xc) < 1e-3:       # both are local searches
            same_basin += 1
            assert abs(xc - ref.x) < 1e-7
    assert same_basin > 40
    # a parabola: within the flat band where 3 (x - c)^2 is below eps of f (|x - c| < 1e-8)
    for c in (-0.7, 0.0, 0.4, 1.9):
        x, n = search_python(lambda x: 3.0 * (x - c) ** 2 + 1.0, -1.0, 2.0, 1e-13)
        assert abs(x - c) < 2e-8 * max(1.0, abs(c)) and n < 100
    # it gives up after maxiter points
    st = np.empty(BRENT_STATE)
    x, n, done = brent_start(0.0, 1.0, 0.0, st), 0, False
    while not done:
        x, done = brent_next(st, math.sin(50 * x), 7)
        n += 1
    assert n == 7


# ------------------------------------------------------------------ fused clearance path
def _clearance_scene(scene, name):
    """(mech, element, its z slice, a workspace, the element's data there) with clearance ``name``."""
    mech = pinclear.load(scene, clearances=[name])
    i = [f.name for f in mech.forces].index(name)
    ws = mech.workspace()
    return mech, mech.forces[i], mech.z_slices[i], ws, ws.force_data[i]


@pytest.mark.parametrize("scene, name", [("clr_ball", "S"), ("nine_bar", "A"), ("clr_hinge", "R")])
def test_fused_clearance_events_and_records_equal_the_python_path(scene, name):
    """The compiled right-hand-side path of a clearance joint (placements from the joint chain)
    leaves the same penetrations, forces and outputs as the element's Python path (Pinocchio's
    frame placements, law by law), at random states."""
    mech, el, sl, ws, d = _clearance_scene(scene, name)
    assert el.event_level == "placements" and el.kinematic_frames == (el.f1, el.f2)
    seen_contact = 0
    for q, v, z in clearance_states(mech, el, 30, seed=3, spread=2e-3):
        kinematics.update(mech, ws, q, v)
        tau, zdot = np.zeros(mech.nv), np.zeros(el.nz)
        el.add_force(mech, ws, d, 0.0, q, v, z, tau, zdot)
        pot, loss, rec = el.record(mech, ws, d, 0.0, q, v, z, True)
        ev = el.event_values(mech, ws, d, 0.0, q, v, z)
        # the Python path, from Pinocchio's data.oMf
        py = el.outputs(mech, ws, d, 0.0, q, v, z)
        seen_contact += py["contact"] > 0
        scale = max(float(py["fn"]), 1.0)
        for k, val in py.items():
            tol = 1e-12 * (scale if k.endswith("force") or k == "fn" else 1.0)
            np.testing.assert_allclose(rec[k], val, rtol=1e-12, atol=tol, err_msg=k)
        assert pot == pytest.approx(el.potential(mech, ws, d, q), rel=1e-12, abs=1e-15)
        assert loss == pytest.approx(el.power_loss(mech, ws, d, 0.0, q, v, z), rel=1e-11, abs=1e-12 * scale)
        np.testing.assert_allclose(ev, d.delta, rtol=0, atol=1e-15)
    assert seen_contact >= 5


# ------------------------------------------------------------------ bound kernels
@pytest.mark.parametrize("name,clearance", [("four_ups_upu", "S2"), ("nine_bar", "A"), ("parallelogram", None)])
def test_bound_kernels_equal_the_direct_calls(name, clearance):
    """pinclear.core.stage.bind passes a kernel's buffers (NamedTuples of them: Rows, Solve)
    as addresses rebuilt into views inside compiled code. The formulation's solve stage and a
    direct call of its kernel on the same buffers run the same arithmetic on the same memory, so
    every output buffer must be bitwise equal, at random states and times; a wrong address,
    shape or layout (Pinocchio's M and J are column-major) would give different numbers or
    garbage."""
    from pinclear.dynamics.formulations.base import Solve
    from pinclear.dynamics.formulations.lagrange import lagrange_accel
    from pinclear.dynamics.formulations.proximal import proximal_accel

    mech = pinclear.load(name, clearances=[clearance] if clearance else None)
    nv, m = mech.nv, mech.m
    for method, kernel in (("lagrange", lagrange_accel), ("proximal", proximal_accel)):
        form = formulations.get(method)(mech)
        ws = form.ws
        stage = form.compiled().solve[0]
        o = form.opts
        extra = (float(o["alpha"]), float(o["beta"])) + ((float(o["rho"]), o["max_iter"]) if method == "proximal" else ())
        K = Solve(ws.q, ws.v, ws.drive_data.f, ws.data.M, ws.parent, ws.tau, ws.data.nle, np.arange(m),
                  np.zeros((nv, nv)), np.zeros((m, nv)), np.zeros((m, m)), np.zeros((m, m)), np.zeros(m), np.zeros(m),
                  np.zeros(nv), np.zeros(m))
        for seed in range(3):
            q, v = _random_consistent_state(mech, seed)
            t = 0.37 * seed
            ws.load_state(q, v, np.zeros(mech.nz))
            form.applied(t, ws.q, ws.v, ws.z)
            mech.driverows.values(t, ws.drive_data)
            r1 = kernel(form.row_buffers, K, *extra)
            first = [x.copy() for x in (K.a, K.lam, ws.J, ws.gamma, ws.phi)]
            for x in (ws.a, ws.lam, ws.gamma, ws.phi):     # J's drive rows are constant inputs
                x[...] = np.nan
            r2 = stage(t)
            assert r1 == r2
            for a, b in zip(first, (ws.a, ws.lam, ws.J, ws.gamma, ws.phi)):
                assert np.array_equal(a, b)


@pytest.mark.parametrize("scene, name", [("four_ups_upu", "S2"), ("clr_hinge", "R"), ("clr_slider", "P")])
def test_clearance_force_stages_equal_the_direct_calls(scene, name):
    """Inside a run a clearance joint's force is its force_kernel bound as a stage to the
    workspace's own tau and zdot (pinclear.core.stage); add_force calls the same kernel
    directly on the caller's buffers. Both must leave bitwise equal forces, state rates and
    channel quantities (spherical, revolute and prismatic kernels): a wrong address, shape or
    layout in the stage would give other numbers or garbage."""
    from pinclear.core.stage import bind

    mech, el, sl, ws, d = _clearance_scene(scene, name)
    i = list(mech.forces).index(el)
    stage = bind(*el.force_kernel(mech, ws, d, ws.z_views[i], ws.zdot_views[i]))
    seen_contact = 0
    for q, v, z in clearance_states(mech, el, 20, seed=5, spread=2e-3):
        ws.q[:], ws.v[:], ws.z[sl] = q, v, z
        kinematics.update(mech, ws, ws.q, ws.v)
        tau, zdot = np.zeros(mech.nv), np.zeros(el.nz)
        el.add_force(mech, ws, d, 0.0, q, v, z, tau, zdot)         # direct: not the workspace's buffers
        direct = [x.copy() for x in (tau, zdot, d.Fn, d.F2, d.delta)]
        ws.tau[:] = 0.0
        ws.zdot[:] = np.nan
        d.Fn[:] = d.F2[:] = d.delta[:] = np.nan
        stage(0.0)
        for a, b in zip(direct, (ws.tau, ws.zdot[sl], d.Fn, d.F2, d.delta)):
            assert np.array_equal(a, b)
        seen_contact += bool((d.delta > 0).any())
    assert seen_contact >= 3


@pytest.mark.parametrize("name", ["four_bar", "nine_bar", "four_ups_upu", "three_upru_up", "squeezer",
                                  "clr_slider", "a04_bricard"])
def test_joint_jacobians_from_the_placements_equal_pinocchios(name):
    """The projections' iterates take the WORLD joint Jacobian of a 1-dof tree from the compiled
    placements (pinclear.model.frames.joint_placements_jacobians) instead of Pinocchio's
    computeJointJacobians: both, at random configurations (revolute and prismatic joints,
    serial and branched trees), agree to rounding (a column is a unit axis and a point's cross
    product with it, so 1e-12 of the placements' scale)."""
    from pinclear.model.frames import joint_placements_jacobians

    mech = pinclear.load(name)
    model, data = mech.model, mech.model.createData()
    chain = kinematics.joint_chain(model)
    assert chain is not None
    n = model.njoints
    O, Hj, J = np.zeros((n, 4, 4)), np.zeros((n, 4, 4)), np.full((6, model.nv), np.nan)
    rng = np.random.default_rng(7)
    for _ in range(10):
        q = pin.integrate(model, mech.q0, rng.uniform(-1.5, 1.5, model.nv))
        pin.computeJointJacobians(model, data, q)
        joint_placements_jacobians(*chain, q, O, np.arange(n, dtype=np.int64), Hj, J)
        scale = 1.0 + max(np.abs(data.oMi[j].translation).max() for j in range(n))
        assert np.abs(J - data.J).max() <= 1e-12 * scale
        for j in range(n):
            assert np.abs(Hj[j] - data.oMi[j].homogeneous).max() <= 1e-12 * scale
