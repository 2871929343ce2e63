"""4-UPS/UPR model of paper 004: tree, closures, mobility, coupled motion, IK, drives, statics."""
from __future__ import annotations

import math
import warnings

import numpy as np
import pinocchio as pin
import pytest

import pinclear
from pinclear.core.errors import InputError, ModelFileError
from pinclear.core.models import model_path, models_dir
from pinclear.dynamics import screw
from pinclear.mechanisms import four_ups_upr as m
from pinclear.model import kinematics
from tests.helpers import kkt_singular_time
from tests.model_files import assert_same_urdf

SIDECAR = model_path("four_ups_upr")
GENERIC = (0.12, -0.09, 0.04, 0.07)      # (alpha, beta, dx, dz) away from the home pose


@pytest.fixture(scope="module")
def mech():
    return m.load(SIDECAR, law="high")


def _state(mech, t, ws):
    """Tree (q, v, a) along the drive laws from Pinocchio alone: analytic IK for q, then the
    closure + drive Jacobian for v and a (J v = -Phi_t, J a = gamma)."""
    M = m.platform_pose(t, mech.options["law"])
    q = m.tree_configuration(mech.model, M, mech.options["layout"])
    v = kinematics.consistent_velocity(mech, q, t=t, ws=ws)
    kinematics.update(mech, ws, q, v)
    kinematics.constraint_rows(mech, ws, t, q, v)
    return q, v, np.linalg.solve(ws.J, ws.gamma)


def test_generated_files_are_current():
    # by value: structure and strings exactly, numbers within the bound of tests/model_files.py (the
    # last bits of the generator's trigonometry and products depend on the build)
    assert_same_urdf(m.urdf_text("f"), models_dir() / "four_ups_upr.urdf",
                     "urdf/four_ups_upr.urdf (stale? run write_urdf)")


def test_tree_sizes_mobility_and_parameters(mech):
    assert (mech.nq, mech.nv) == (16, 16)
    assert [c.type for c in mech.closures] == ["spherical"] * 4 and mech.m_closures == 12
    q = m.tree_configuration(mech.model, m.coupled_pose(*GENERIC))
    mob = kinematics.mobility(mech, q)
    assert mob["mobility"] == 4 and mob["redundant_rows"] == [] and mob["rank"] == 12
    # every parameter documented with a source; reconstructed rod lengths follow from I = m L^2 / 12
    prm = {p["name"]: p for p in mech.parameters}
    assert all(p["source"] for p in mech.parameters)
    assert prm["L_ups_swing"]["source"].startswith("reconstructed")
    assert prm["L_ups_swing"]["value"] == pytest.approx(math.sqrt(12 * 0.064 / 6.71), abs=1e-4)
    Y = mech.model.inertias[mech.model.getJointId("ups1_u2")]
    assert Y.mass == pytest.approx(6.71) and Y.lever[2] == pytest.approx(m.L_UPS_SWING / 2)
    assert np.allclose(np.diag(Y.inertia), [0.064, 0.064, 0.002])
    P = mech.model.inertias[mech.model.getJointId("upr_r")]
    assert P.mass == pytest.approx(53.45) and np.allclose(np.diag(P.inertia), [1.41, 4.41, 2.82])


def test_assembly_residual_and_ik_round_trip(mech):
    ws = mech.workspace()
    for x in [(0, 0, 0, 0), GENERIC, (-0.18, 0.15, -0.08, 0.15)]:
        M = m.coupled_pose(*x)
        q = m.tree_configuration(mech.model, M)
        assert np.abs(kinematics.closure_residual(mech, ws, q)).max() < 1e-12
        ell = m.limb_kinematics(M)[0]
        # forward position analysis of the closed chain by Pinocchio: assemble with the drive
        # rows at the IK lengths from a perturbed guess, then read the platform pose
        fixed = mech.replace(drives=[d.__class__(d.name, d.joint, d.idx_q, d.idx_v,
                                                 pinclear.model.timelaws.Constant(ell[k]))
                                     for k, d in enumerate(mech.drives)])
        q1 = kinematics.assemble(fixed, q + 0.02, ws=fixed.workspace())
        data = mech.model.createData()
        pin.framesForwardKinematics(mech.model, data, q1)
        Mp = data.oMf[mech.platform_frame]
        assert np.abs(pin.log6(Mp.actInv(M)).np).max() < 1e-9
        # and the analytic FK of the module
        assert np.abs(m.forward_kinematics(ell, guess=np.asarray(x) + 0.01) - np.asarray(x)).max() < 1e-9


def test_coupled_twist_and_acceleration_by_finite_differences():
    x = np.array(GENERIC)
    xd, xdd = np.array([0.7, -0.4, 0.3, 0.5]), np.array([2.0, 1.0, -1.5, 0.8])
    V, A = m.coupled_accel(x, xd, xdd)
    h = 1e-5

    def pose(s):
        return m.coupled_pose(*(x + s * xd + 0.5 * s * s * xdd))

    # world twist by the group difference (an independent route: no omega formula)
    Vfd = screw.from_motion(pin.log6(pose(h) * pose(-h).inverse())) / (2 * h)
    assert np.abs(Vfd - V).max() < 1e-8
    Vp = m.coupled_twist(x + h * xd + 0.5 * h * h * xdd, xd + h * xdd)
    Vm = m.coupled_twist(x - h * xd + 0.5 * h * h * xdd, xd - h * xdd)
    assert np.abs((Vp - Vm) / (2 * h) - A).max() < 1e-7
    # the coupling itself: p' = R p (eq. 3), so the platform origin is R [dx, 0, H + dz]
    M = pose(0.0)
    assert np.allclose(M.rotation.T @ M.translation, [x[2], 0.0, m.H0 + x[3]])


def test_converters_match_pinocchio_frame_quantities(mech):
    t = 0.37
    ws = mech.workspace()
    q, v, a = _state(mech, t, ws)
    M, V, A = m.platform_motion(t, "high")
    data = mech.model.createData()
    pin.forwardKinematics(mech.model, data, q, v, a)
    pin.updateFramePlacements(mech.model, data)
    fid = mech.platform_frame
    for ref in (pin.WORLD, pin.LOCAL_WORLD_ALIGNED, pin.LOCAL):
        mv = pin.getFrameVelocity(mech.model, data, fid, ref)
        assert np.abs(m.twist_to_pin(V, M, ref).np - mv.np).max() < 1e-9
        assert np.abs(m.twist_from_pin(mv, M, ref) - V).max() < 1e-9
        ma = pin.getFrameAcceleration(mech.model, data, fid, ref)
        assert np.abs(m.accel_to_pin(A, V, M, ref).np - ma.np).max() < 1e-8
        assert np.abs(m.accel_from_pin(ma, V, M, ref) - A).max() < 1e-8
    mc = pin.getFrameClassicalAcceleration(mech.model, data, fid, pin.LOCAL_WORLD_ALIGNED)
    assert np.abs(m.accel_to_pin(A, V, M, "LOCAL_WORLD_ALIGNED", classical=True).np - mc.np).max() < 1e-8
    assert np.abs(m.accel_from_pin(mc, V, M, "LOCAL_WORLD_ALIGNED", classical=True) - A).max() < 1e-8


def test_limb_law_derivatives():
    for law in ("low", "high"):
        t, h = 0.81, 1e-5
        for k in (1, 2, 3, 4):
            y, yd, ydd = m.limb_law(t, k, law)
            yp, ydp, _ = m.limb_law(t + h, k, law)
            ym, ydm, _ = m.limb_law(t - h, k, law)
            assert (yp - ym) / (2 * h) == pytest.approx(yd, abs=1e-7 * max(1, abs(yd)))
            assert (ydp - ydm) / (2 * h) == pytest.approx(ydd, abs=1e-6 * max(1, abs(ydd)))


def test_static_drive_forces_equal_gravity_load_by_virtual_work(mech):
    """Platform held still under gravity: drive multipliers (Pinocchio rnea + J^T lam) equal
    dU/dl, the derivative of the potential energy along the forward kinematics."""
    x0 = np.array(GENERIC)
    M = m.coupled_pose(*x0)
    q = m.tree_configuration(mech.model, M)
    zero = np.zeros(mech.nv)
    lam = screw.lagrange_inverse_dynamics(mech, q, zero, zero)
    model, data = mech.model, mech.model.createData()
    ell0 = m.limb_kinematics(M)[0]

    def potential(ell):
        x = m.forward_kinematics(ell, guess=x0)
        qq = m.tree_configuration(model, m.coupled_pose(*x))
        return pin.computePotentialEnergy(model, data, qq)

    h = 1e-5
    dU = np.array([(potential(ell0 + h * e) - potential(ell0 - h * e)) / (2 * h) for e in np.eye(4)])
    # the actuators hold the load: their force equals the potential's gradient
    assert np.abs(lam - dU).max() < 1e-6 * np.abs(dU).max()
    assert np.abs(dU).max() > 50.0      # a real load (about the platform weight over four limbs)


def test_simulation_high_law_tracks_and_forces_match_screw(mech):
    """Forward dynamics under the drives over [0, 1] s of the high-speed law. The law's period is
    1.2566 s, but at t = 1.08906 s it crosses a singular configuration (see the last test)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        tr = pinclear.simulate(mech, 1.0, rtol=1e-8, dt_out=1.0 / 50)
    assert tr.status == "success"
    s = tr.summary()
    assert s["mobility"] == 4
    assert s["max_closure_residual"] < 1e-8
    assert s["tracking_error"]["platform_position"] < 1e-6
    assert s["tracking_error"]["platform_rotation"] < 1e-6
    # actuator forces by name agree with the screw method (an independent formulation)
    res = screw.inverse_dynamics(mech, "high", tr.t, limbs=True)
    lam = np.column_stack([tr.lam[f"P{k}"] for k in range(1, 5)])
    assert res.cond.max() < 200
    assert np.abs(lam - res.tau).max() < 1e-5 * np.abs(res.tau).max()
    # the condition monitor on the simulated configurations sees what the prescribed motion has
    mon = screw.monitor(mech, tr, threshold=1e3)
    assert mon["intervals"] == [] and np.allclose(mon["cond"], res.cond, rtol=1e-5)


def test_options_limbs_layout_law_and_errors():
    base = m.load(SIDECAR, law="low", limbs=False, layout="c")
    assert base.options == {"law": "low", "limbs": False, "layout": "c"}
    assert base.drives[0].law.eval(0.3) == pytest.approx(m.limb_law(0.3, 1, "low", "c"))
    model = base.model
    f = model.frames[model.getFrameId("platform_b2")]
    assert np.allclose(f.placement.translation, m.LAYOUTS["c"][1])
    Y = model.inertias[model.getJointId("ups3_p")]
    assert Y.mass == pytest.approx(m.LIMB_RESIDUE * m.M_UPS_ROD)
    assert model.inertias[model.getJointId("upr_r")].mass == pytest.approx(m.M_PLATFORM)
    # limbs off keeps the mass matrix positive definite (the Schur-complement formulations need it)
    q = m.tree_configuration(model, m.coupled_pose(*GENERIC), "c")
    assert np.linalg.eigvalsh(pin.crba(model, model.createData(), q)).min() > 0
    with pytest.raises(ModelFileError, match="layout"):
        pinclear.load(SIDECAR, options={"layout": "g"})
    # the plain sidecar follows the law option through its "$law" drive-law arguments
    low = pinclear.load(SIDECAR, options={"law": "low"})
    assert low.drives[2].law.eval(0.7) == pytest.approx(m.limb_law(0.7, 3, "low", "f"))
    assert np.allclose(low.platform_motion(0.7).translation, m.platform_pose(0.7, "low").translation)
    plain = pinclear.load(SIDECAR, options={"limbs": False})
    assert plain.model.inertias[plain.model.getJointId("ups1_p")].mass == pytest.approx(m.LIMB_RESIDUE * m.M_UPS_ROD)
    with pytest.raises(ModelFileError, match="valid"):
        pinclear.load(SIDECAR, options={"speed": "fast"})
    with pytest.raises(InputError, match="low, high"):
        m.limb_law(0.0, 1, "medium")
    with pytest.raises(InputError, match="1..4"):
        m.limb_law(0.0, 5)


def test_forward_run_reports_the_singular_crossing_of_the_high_law(mech):
    """Where the high-speed law crosses a singular configuration (located independently from the
    constraint Jacobian at the IK configurations, and by the screw monitor), the core's forward
    run stops with a rank-loss report at the same instant instead of returning wrong forces."""
    t0 = 1.08
    q0 = m.tree_configuration(mech.model, m.platform_pose(t0, "high"))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        tr = pinclear.simulate(mech, 1.2, t0=t0, q0=q0, rtol=1e-8, max_cpu=40)
    assert tr.status == "failed"
    rl = tr.stats["rank_loss"]
    assert rl["rank"] == 15 and rl["rows"] == 16
    assert rl["t"] == pytest.approx(kkt_singular_time(mech, 1.07, 1.11), abs=1e-5)
    res = screw.inverse_dynamics(mech, "high", np.linspace(1.085, 1.093, 17), limbs=False, gravity=False)
    assert res.crossings[0][0] == pytest.approx(rl["t"], abs=1e-5)


def test_compiled_limb_lengths_equal_the_pose_written_out():
    """The drives' compiled inverse kinematics against the platform pose built with NumPy
    rotations (paper 004 eq. 3: p' = R(x, alpha) R(y', beta) [dx, 0, H + dz]): l_i = |p' + R b_i - a_i|;
    its rates are checked by central differences in test_limb_law_derivatives."""
    rng = np.random.default_rng(4)
    for law in ("low", "high"):
        for layout in ("a", "f"):
            for t in rng.uniform(0.0, 6.0, 20):
                x = m.motion_law(t, law)[0]
                pose = m.coupled_pose(*x)
                b = pose.translation + m.LAYOUTS[layout] @ pose.rotation.T
                ref = np.linalg.norm(b - m.BASE_POINTS, axis=1)
                np.testing.assert_allclose(m.limb_lengths(t, law, layout)[0], ref, rtol=1e-13, atol=0)
