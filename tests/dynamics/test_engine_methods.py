"""The compiled formulations (lagrange, projection, proximal, manifold) under the stepping
engine's contract (Formulation contract 7/8): the compiled loop and the Python loop run the same
kernels on the same buffers, so they must take the same steps; and the compiled projections
against independent NumPy evaluations of the same equations.

Why the loops can be compared exactly: in ``loop="python"`` the formulation's Python methods
(accelerations, project) call the very stages the compiled run calls, on the same workspace
buffers. What differs is only what surrounds them: Pinocchio's passes through the Python
bindings (the same library functions, bit-identical: tests/model/test_native_build.py), the drive
values from DriveRows.values (bit-identical to the compiled laws: tests/core/test_compiled.py), and
for clearance scenes the force elements' Python path and event values (equal to the compiled
kernels to rounding, 1e-15: tests/core/test_compiled.py). Equal steps, evaluations and events are
therefore asserted exactly; states to 1e-12 of their scale, the room an event time moved by a
rounding-level difference of an event value leaves (|dg/dt| >= 1e-3 m/s at the impacts of these
scenes: 1e-15 m of g moves the event by <= 1e-12 s).
"""
from __future__ import annotations

import os
import subprocess
import sys
import warnings

import numpy as np
import pinocchio as pin
import pytest

import pinclear
from pinclear.dynamics import formulations
from pinclear.dynamics.formulations.proximal import proximal_multipliers
from pinclear.model import kinematics

METHODS = ("lagrange", "projection", "proximal", "manifold")

#: (scene, clearances, t_end, what it exercises)
SCENES = [
    ("four_bar", None, 0.5),                 # one ideal closure (planar), free motion under gravity
    ("a04_bricard", None, 0.5),              # a redundant closure row (dropped by lagrange, projection)
    ("nine_bar", None, 0.5),                 # drives (compiled sine laws) and ideal closures
    ("four_ups_upu", None, 0.3),             # drives from a compiled inverse kinematics, 17 dof
    ("nine_bar", ["A"], 0.1),                # a revolute clearance: impacts, events, internal states
    ("parallelogram", None, 1.0),            # a flat (singular) passage at t ~ 0.3 s
]


def _run(mech, method, t_end, loop):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        return pinclear.simulate(mech, t_end, method=method, rtol=1e-6, dt_out=t_end / 50, loop=loop)


@pytest.fixture(scope="module")
def mechs():
    return {}


@pytest.mark.parametrize("method", METHODS)
@pytest.mark.parametrize("scene, clearances, t_end", SCENES, ids=[s[0] + ("+" + s[1][0] if s[1] else "")
                                                                  for s in SCENES])
def test_compiled_and_python_loops_take_the_same_steps(mechs, scene, clearances, t_end, method):
    key = (scene, tuple(clearances or ()))
    if key not in mechs:
        mechs[key] = pinclear.load(scene, clearances=clearances)
    mech = mechs[key]
    fast = _run(mech, method, t_end, "auto")
    slow = _run(mech, method, t_end, "python")
    # every stage of the compiled run is compiled (no Python stage at all)
    assert fast.stats["loop"] == "compiled", fast.stats["loop"]
    assert slow.stats["loop"].startswith("python")
    assert (fast.status, fast.message) == (slow.status, slow.message)
    if scene == "parallelogram":
        # lagrange and projection stop at the rank loss of the flat configuration; the two
        # singular-passage methods are meant to pass it
        assert fast.status == ("success" if method in ("proximal", "manifold") else "failed")
    else:
        assert fast.status == "success"
    for k in ("steps", "rhs_evals", "restarts"):
        assert fast.stats[k] == slow.stats[k], k
    assert [(e["t"], e["element"], e["event"]) for e in fast.stats["events"]] == \
           [(e["t"], e["element"], e["event"]) for e in slow.stats["events"]]
    if clearances:
        assert len(fast.stats["events"]) > 0
    assert np.array_equal(fast.t, slow.t)
    for a, b in ((fast.q, slow.q), (fast.v, slow.v), (fast.z, slow.z)):
        scale = max(1.0, np.abs(b).max()) if b.size else 1.0
        np.testing.assert_allclose(a, b, rtol=0, atol=1e-12 * scale)
    if fast.status == "success" and method != "lagrange":
        # the projecting methods keep every sample on the manifold (their tolerance 1e-12,
        # plus the rounding of the rows at the projected state)
        assert np.abs(fast.residual).max() < 1e-10


# ------------------------------------------------------------------ the projections
def _reference_projection(mech, rows, t, q, v, tol, max_iter, solve):
    """project_to_manifold of the NumPy era: Gauss-Newton on Phi = 0 with steps
    -J^T solve(J J^T, Phi) (pin.integrate), then v - M^-1 J^T solve(J M^-1 J^T, J v + Phi_t),
    with Pinocchio's dense mass matrix."""
    ws = mech.workspace()
    q = np.array(q, float)
    for _ in range(max_iter):
        kinematics.update_positions(mech, ws, q)
        kinematics.constraint_rows(mech, ws, t, q, ws.zero_v)
        phi = ws.phi[rows]
        if np.linalg.norm(phi, np.inf) < tol:
            break
        J = ws.J[rows]
        q = pin.integrate(mech.model, q, -J.T @ solve(J @ J.T, phi))
    kinematics.update(mech, ws, q, v)
    kinematics.constraint_rows(mech, ws, t, q, v)
    J = ws.J[rows]
    M = pin.crba(mech.model, mech.model.createData(), q)
    M = np.triu(M) + np.triu(M, 1).T
    MiJt = np.linalg.solve(M, J.T)
    return q, v - MiJt @ solve(J @ MiJt, ws.dphi[rows]), J, M


def _lstsq(A, b):
    return np.linalg.lstsq(A, b, rcond=1e-12)[0]


def _off_manifold(mech, seed, size, t=0.0):
    """A state consistent at time ``t`` (the drives' rows depend on it) moved off the manifold by
    ``size`` in q and v (random directions)."""
    rng = np.random.default_rng(seed)
    q = kinematics.assemble(mech, pin.integrate(mech.model, mech.q0, 0.05 * rng.standard_normal(mech.nv)), t=t)
    v = kinematics.consistent_velocity(mech, q, rng.standard_normal(mech.nv), t=t)
    return q + size * rng.standard_normal(mech.nv), v + size * rng.standard_normal(mech.nv)


@pytest.mark.parametrize("method", ["projection", "proximal"])
@pytest.mark.parametrize("scene", ["four_bar", "nine_bar", "a04_bricard", "four_ups_upu"])
def test_projection_equals_the_numpy_projection(scene, method):
    """The compiled projection (Gauss-Newton with minimum-norm steps, mass-metric velocity
    projection; proximal: both through its filter) against the NumPy-era implementation at
    states 1e-6 off the manifold, on the formulation's rows (projection drops bricard's
    redundant row; proximal keeps it). Both stop once |Phi|_inf < tol = 1e-12, so the positions
    differ by at most what one more step would move them, ||J^+|| tol over J's nonzero singular
    values (plus rounding, eps cond(J) |q| per step), times 10 for the iterations. The
    velocities then differ through J and M at those positions (|d v1 / dq| ~ |v| per unit of q
    on these scenes: 1e-10 |v|) and through the solves' rounding (eps cond(S) |v|, cond(S) <=
    1e4 here: 2e-12 |v|): bound 1e-9 |v|. The landing point itself is checked without a
    reference: |Phi| < tol and |J v + Phi_t| at rounding."""
    mech = pinclear.load(scene)
    form = formulations.get(method)(mech)
    J0 = kinematics.jacobian(mech, form.ws, mech.q0, 0.0, with_drives=True)
    _, indep, _ = kinematics.rank_analysis(J0, mech.row_names())
    form.use_rows(indep)
    rows = np.asarray(form.rows if method == "projection" else np.arange(mech.m))
    if method == "proximal":
        k = form.opts["max_iter"]

        def solve(A, b):
            return proximal_multipliers(A, b, form.opts["rho"] * np.trace(A) / len(A), k)
    else:
        solve = _lstsq
    for seed in range(3):
        t = 0.13 * seed
        q, v = _off_manifold(mech, seed, 1e-6, t)
        q1, v1 = form.project(t, q.copy(), v.copy())
        q_ref, v_ref, J, M = _reference_projection(mech, rows, t, q, v, form.opts["tol"], form.opts["max_iter"], solve)
        sv = np.linalg.svd(J, compute_uv=False)
        sv = sv[sv > 1e-10 * sv[0]]                  # a redundant row's zero does not enter J^+
        bound_q = 10 * (form.opts["tol"] / sv[-1] + np.finfo(float).eps * sv[0] / sv[-1] * max(1.0, np.abs(q).max()))
        np.testing.assert_allclose(q1, q_ref, rtol=0, atol=bound_q)
        np.testing.assert_allclose(v1, v_ref, rtol=0, atol=1e-9 * max(1.0, np.abs(v_ref).max()))
        ws = mech.workspace()
        kinematics.update(mech, ws, q1, v1)
        kinematics.constraint_rows(mech, ws, t, q1, v1)
        assert np.abs(ws.phi[rows]).max() < form.opts["tol"]
        assert np.abs(ws.dphi[rows]).max() < 1e-12 * max(1.0, np.abs(v1).max())


def test_projection_moves_velocities_in_the_mass_metric():
    """The velocity projection is the point of {J v + Phi_t = 0} nearest to v in the kinetic
    metric: v1 - v lies in range(M^-1 J^T) (so M (v1 - v) is orthogonal to null(J)), the
    characterisation of the metric projection, checked with an SVD null space (clr_hinge: five
    rows on six dof, a body of spread inertia whose metric is far from the identity)."""
    mech = pinclear.load("clr_hinge")
    form = formulations.get("projection")(mech)
    q, v = _off_manifold(mech, 5, 0.0)
    v = v + 0.3 * np.random.default_rng(5).standard_normal(mech.nv)       # far off the velocity constraint
    q1, v1 = form.project(0.2, q, v)
    ws = mech.workspace()
    J = kinematics.jacobian(mech, ws, q1, 0.2, with_drives=True)
    M = pin.crba(mech.model, mech.model.createData(), q1)
    M = np.triu(M) + np.triu(M, 1).T
    _, s, Vt = np.linalg.svd(J)
    null = Vt[int(np.sum(s > 1e-10 * s[0])):]
    assert null.shape[0] == mech.nv - np.linalg.matrix_rank(J) > 0
    assert np.abs(null @ M @ (v1 - v)).max() < 1e-12 * np.abs(M @ (v1 - v)).max()


@pytest.mark.slow
def test_proximal_iterations_equal_the_extended_precision_iterations():
    """pinclear.core.regularised.proximal_filter (one Cholesky of S + rho I and its inverse, then k
    matrix-vector products) against the definition evaluated with 50 digits (mpmath): k solves
    (S + rho I) lam_{i+1} = r + rho lam_i from zero, on spectra from well conditioned to
    singular (eigenvalues 1e-14 .. 10, and exactly redundant rows). Error bound: the inverse's
    forward error, and so each iteration's, is at most ~ m eps cond(S + rho I) <= m eps (1 + 1 /
    rho_rel) relative (rho_rel = 1e-4, the default), and the iteration does not amplify it (its
    factor rho / (s + rho) <= 1): at most 1.9e-11 over these spectra (m = 20; the same to two
    digits with the former triangular substitutions, 2026-11-25), asserted 1e-10 relative to
    the largest multiplier."""
    mp = pytest.importorskip("mpmath")
    from pinclear.core.regularised import proximal_filter

    mp.mp.dps = 50
    rng = np.random.default_rng(11)
    k, rho_rel = 30, 1e-4
    for m in (2, 5, 12, 20):
        for kind in range(3):
            Q, _ = np.linalg.qr(rng.standard_normal((m, m)))
            s = 10 ** rng.uniform(-2, 1, m) if kind == 0 else 10 ** rng.uniform(-14, 1, m)
            if kind == 2:
                s[: max(1, m // 4)] = 0.0
            S = (Q * s) @ Q.T
            S = 0.5 * (S + S.T)
            r = rng.standard_normal(m)
            rho = rho_rel * np.trace(S) / m
            A = mp.matrix(S.tolist()) + mp.mpf(rho) * mp.eye(m)
            lam_mp = mp.matrix([0] * m)
            for _ in range(k):
                lam_mp = mp.lu_solve(A, mp.matrix(r.tolist()) + mp.mpf(rho) * lam_mp)
            ref = np.array([float(x) for x in lam_mp])
            out = np.zeros(m)
            proximal_filter(S, r, rho, k, np.zeros((m, m)), np.zeros(m), out)
            assert np.abs(out - ref).max() <= 1e-10 * np.abs(ref).max(), (m, kind)
            # and the NumPy closed form is the same function (its eigenvectors carry ~eps / gap)
            np.testing.assert_allclose(proximal_multipliers(S, r, rho, k), ref, rtol=0,
                                       atol=1e-7 * np.abs(ref).max())


@pytest.mark.slow
def test_without_the_extension_the_compiled_run_is_the_same():
    """PINCLEAR_NATIVE=0: the projections call Pinocchio's passes through a C callback running
    the Python bindings (pinclear.model.native.passes_for), the evaluation's passes run as a Python
    stage; the library functions are the same, so the run equals the one with the extension."""
    code = ("import warnings, numpy as np, pinclear\n"
            "warnings.simplefilter('ignore')\n"
            "m = pinclear.load('nine_bar')\n"
            "tr = pinclear.simulate(m, 0.2, method='{method}', rtol=1e-6, dt_out=0.01)\n"
            "print(tr.status, tr.stats['steps'], tr.stats['rhs_evals'])\n"
            "print(repr(tr.q[-1].tolist())); print(repr(tr.v[-1].tolist()))\n")
    mech = pinclear.load("nine_bar")
    for method in ("projection", "manifold"):
        env = dict(os.environ, PINCLEAR_NATIVE="0")
        out = subprocess.run([sys.executable, "-c", code.format(method=method)], env=env, capture_output=True,
                             text=True, timeout=600, check=True).stdout.splitlines()
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            ref = pinclear.simulate(mech, 0.2, method=method, rtol=1e-6, dt_out=0.01)
        assert out[0] == f"{ref.status} {ref.stats['steps']} {ref.stats['rhs_evals']}"
        assert np.array_equal(np.array(eval(out[1])), ref.q[-1])
        assert np.array_equal(np.array(eval(out[2])), ref.v[-1])


def test_monitors():
    """Contract 8: lagrange and projection watch the pivots of their Schur complement (rank
    floor 1 / RANK_COND; reselection only when rows were dropped); proximal and manifold pass
    singular configurations by design and only reject failed evaluations (negative codes)."""
    from pinclear.dynamics.formulations.base import RANK_COND
    from pinclear.dynamics.formulations.lagrange import RESELECT_DIP

    bricard = pinclear.load("a04_bricard")
    for name in ("lagrange", "projection"):
        form = formulations.get(name)(bricard)
        assert form.monitor() == (1.0 / RANK_COND, -np.inf)
        J = kinematics.jacobian(bricard, form.ws, bricard.q0, 0.0, with_drives=True)
        form.use_rows(kinematics.rank_analysis(J, bricard.row_names())[1])
        assert len(form.rows) < bricard.m and form.monitor() == (1.0 / RANK_COND, RESELECT_DIP)
    for name in ("proximal", "manifold"):
        assert formulations.get(name)(bricard).monitor() == (0.0, -np.inf)
