"""Compiled kernels against plain NumPy evaluations of the same equations (issue 10: one
implementation per law, or a test that shows two equal), at random states."""
from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

import pinclear
from conftest import clearance_states
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


# ------------------------------------------------------------------ drive laws
def test_compiled_time_laws_equal_their_python_eval():
    """Constant, sines and polynomial laws filled by one compiled call equal each law's own
    ``eval`` (the formulas written in Python) bit for bit, at random times."""
    from pinclear import timelaws as T
    from pinclear.drives import Drive, DriveRows

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


# ------------------------------------------------------------------ integrator
def test_compiled_rk45_takes_scipys_steps():
    """The RK45 integrator (compiled step arithmetic) against SciPy's RK45 on a damped
    oscillator: the same accepted times and states to rounding, and the closed form to rtol."""
    from scipy.integrate import RK45

    from pinclear.integrators import CompiledRK45

    w, zeta = 3.0, 0.1
    wd = w * np.sqrt(1 - zeta ** 2)

    def f(t, y):
        return np.array([y[1], -2 * zeta * w * y[1] - w * w * y[0]])

    runs = []
    for cls in (RK45, CompiledRK45):
        s = cls(f, 0.0, np.array([1.0, 0.0]), 10.0, rtol=1e-8, atol=1e-10)
        ts, ys = [], []
        while s.status == "running":
            s.step()
            ts.append(s.t)
            ys.append(s.y.copy())
        runs.append((np.array(ts), np.array(ys), s))
    (t1, y1, s1), (t2, y2, s2) = runs
    # The error estimate sum_j E_j K_j cancels to ~rtol of its terms, so the two summation orders
    # (BLAS vs a plain loop) give error norms that differ by ~eps/rtol relative and step sizes
    # that differ as much: the same steps, times within 1e-7 relative, and states that differ by
    # far less than the error both runs are allowed (rtol).
    assert len(t1) == len(t2) > 50
    np.testing.assert_allclose(t2, t1, rtol=1e-7, atol=0)
    np.testing.assert_allclose(y2, y1, rtol=0, atol=1e-8)
    exact = np.exp(-zeta * w * t2) * (np.cos(wd * t2) + zeta * w / wd * np.sin(wd * t2))
    assert np.max(np.abs(y2[:, 0] - exact)) < 1e-6
    # its dense output is SciPy's interpolant: over the same step from the same state, equal
    s3 = CompiledRK45(f, s1.t_old, s1.y_old.copy(), 10.0, rtol=1e-8, atol=1e-10, first_step=s1.h_previous)
    s3.step()
    assert s3.t == s1.t
    tm = 0.5 * (s1.t_old + s1.t)
    np.testing.assert_allclose(s3.dense_output()(tm), s1.dense_output()(tm), rtol=0, atol=1e-12)


def test_compiled_rk45_starts_as_scipys_rk45():
    """Its own start (no SciPy validation and wrappers: paid after every impact) carries every
    attribute SciPy's RK45 sets, so SciPy's step(), dense_output() and step_size work on it,
    and chooses SciPy's initial step bit for bit (a chattering contact's later impacts depend on
    it), with SciPy's count of evaluations."""
    from scipy.integrate import RK45

    from pinclear.integrators import CompiledRK45

    rng = np.random.default_rng(7)
    A = rng.normal(size=(6, 6))

    def f(t, y):
        return A @ y + np.sin(t)

    for k in range(20):
        y0 = rng.normal(size=6) * 10.0 ** rng.uniform(-3, 3)
        rtol, t_bound = 10.0 ** rng.uniform(-10, -3), rng.uniform(1e-3, 10)
        ours = CompiledRK45(f, 0.0, y0, t_bound, rtol=rtol, atol=rtol * 1e-2)
        ref = RK45(f, 0.0, y0, t_bound, rtol=rtol, atol=rtol * 1e-2)
        assert set(vars(ref)) <= set(vars(ours)) | set(dir(ours))
        assert ours.h_abs == ref.h_abs and ours.nfev == ref.nfev == 2
        assert ours.step_size is None and ours.status == "running"
    # max_step and first_step as SciPy takes them
    assert (CompiledRK45(f, 0.0, y0, 1.0, rtol=1e-6, atol=1e-8, max_step=1e-5).h_abs
            == RK45(f, 0.0, y0, 1.0, rtol=1e-6, atol=1e-8, max_step=1e-5).h_abs)
    s = CompiledRK45(f, 0.0, y0, 1.0, rtol=1e-6, atol=1e-8, first_step=2e-3)
    assert s.h_abs == 2e-3 and s.nfev == 1
    s.step()
    assert 0.0 < s.t <= 2e-3                              # the first step tries first_step
    with pytest.raises(ValueError, match="finite"):
        CompiledRK45(f, 0.0, np.array([1.0, np.nan]), 1.0, rtol=1e-6, atol=1e-8)


def test_brent_search_compiled_and_python_take_the_same_points():
    """The singular-passage search (pinclear._kernels.brent_start/brent_next, reverse
    communication) is driven from compiled code in the compiled loop and from Python in the
    Python loop: on random smooth functions both drivers return the same point after the same
    evaluations, and the point is the minimiser: SciPy's bounded Brent's where it found the same
    basin, the analytic one of a parabola to the flat band around it."""
    import math

    from numba import njit
    from scipy.optimize import minimize_scalar

    from pinclear.stepping.roots import BRENT_STATE, brent_next, brent_start

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
    """pinclear._bind passes a kernel's buffers as addresses rebuilt into views inside compiled
    code. Bound and direct calls run the same arithmetic on the same memory, so every output
    buffer must be bitwise equal, at random states and times; a wrong address, shape or layout
    (Pinocchio's M and J are column-major) would give different numbers or garbage."""
    from pinclear._bind import DYN, bind
    from pinclear._kernels import lagrange_accel, proximal_accel

    mech = pinclear.load(name, clearances=[clearance] if clearance else None)
    for method, kernel in (("lagrange", lagrange_accel), ("proximal", proximal_accel)):
        form = formulations.get(method)(mech)
        ws = form.ws
        q0, v0 = _random_consistent_state(mech, 9)
        form.accelerations(0.0, q0, v0, np.zeros(mech.nz))    # binds the kernel's buffers
        bound = bind(kernel, form._args + (DYN, DYN, DYN))
        assert hasattr(bound, "bound")                       # really bound, not the fallback
        out = [ws.lam, ws.J, ws.gamma, ws.phi, form._buf["a"]]
        for seed in range(3):
            q, v = _random_consistent_state(mech, seed)
            t = 0.37 * seed
            form.applied(t, q, v, np.zeros(mech.nz))
            f = mech.driverows.values(t, ws.drive_data)
            r1 = kernel(*form._args, q, v, f)
            first = [x.copy() for x in out]
            for x in (ws.lam, ws.gamma, ws.phi, form._buf["a"]):   # J's drive rows are constant inputs
                x[...] = np.nan
            r2 = bound(q, v, f)
            assert r1 == r2
            for a, b in zip(first, out):
                assert np.array_equal(a, b)


def test_bound_kernel_falls_back_on_a_strided_view_and_lives_in_the_user_cache():
    """A buffer that is not contiguous cannot be rebuilt from an address and a shape: bind then
    calls the kernel directly (same result). Generated wrappers are written to the user cache
    folder, never inside the installed package."""
    from pinclear import _bind
    from pinclear._jit import cache_dir
    from pinclear._kernels import proximal_filter

    rng = np.random.default_rng(3)
    B = rng.standard_normal((4, 4))
    S = B @ B.T
    r = rng.standard_normal(4)
    ref = np.zeros(4)
    proximal_filter(S, r, 1e-3, 5.0, ref)
    out = np.zeros(4)
    bound = _bind.bind(proximal_filter, (S, _bind.DYN, 1e-3, 5.0, out))
    bound(r)
    assert hasattr(bound, "bound") and np.array_equal(out, ref)
    big = np.zeros(8)
    strided = big[::2]                                       # a view with stride 2: not bindable
    direct = _bind.bind(proximal_filter, (S, _bind.DYN, 1e-3, 5.0, strided))
    assert not hasattr(direct, "bound")
    direct(r)
    assert np.array_equal(strided, ref) and np.all(big[1::2] == 0.0)
    import sys
    from pathlib import Path
    files = [Path(m.__file__).resolve() for k, m in sys.modules.items() if k.startswith("pinclear_bound_")]
    assert files and all(cache_dir().resolve() in f.parents for f in files)
    assert not any(Path(pinclear.__file__).resolve().parent in f.parents for f in files)


@pytest.mark.parametrize("scene, name", [("four_ups_upu", "S2"), ("clr_hinge", "R"), ("clr_slider", "P")])
def test_clearance_force_stages_equal_the_direct_calls(scene, name):
    """Inside a run a clearance joint's force is its force_kernel bound as a stage to the
    workspace's own tau and zdot (pinclear.stepping.stage); add_force calls the same kernel
    directly on the caller's buffers. Both must leave bitwise equal forces, state rates and
    channel quantities (spherical, revolute and prismatic kernels): a wrong address, shape or
    layout in the stage would give other numbers or garbage."""
    from pinclear.stepping.stage import bind

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
