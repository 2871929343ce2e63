"""Spherical clearance joint (paper 000) in small test mechanisms, against physics references:
Hertz static deflection, the 1-DOF impact of the same law, energy conservation/balance and
convergence to the ideal joint."""
import numpy as np
import pinocchio as pin
import pytest

import pinclear
from pinclear.contact import restitution_1dof
from pinclear.core.errors import ContactSetupError
from pinclear.core.models import model_path
from pinclear.model import kinematics

BALL, PEND = model_path("clr_ball"), model_path("clr_pendulum")


def energy_error(tr, name):
    """max |E(t) + E_dissipated(t) - E(0)| / E(0) (mechanical energy incl. contact potential)."""
    tot = tr.energy()["total"]
    diss = tr.outputs[f"{name}.dissipated"]
    return np.max(np.abs(tot + diss - tot[0])) / abs(tot[0])


def test_ball_settles_at_hertz_deflection():
    mech = pinclear.load(PEND, clearances=["S"])
    law = mech.forces[-1].law
    q0 = np.zeros(6)
    q0[2] = -1e-4                      # rod hanging, ball touching the bottom of the socket
    tr = pinclear.simulate(mech, 0.02, integrator="Radau", rtol=1e-8, q0=q0, v0=np.zeros(6), assemble=False)
    assert tr.status == "success"
    W = 1.0 * 9.81                     # rod weight carried by the ball
    ref = (W / law.K) ** (2.0 / 3.0)   # Hertz: W = K delta^1.5
    assert tr.outputs["S.penetration"][-1] == pytest.approx(ref, rel=1e-2)
    assert tr.outputs["S.normal_force"][-1] == pytest.approx([0, 0, W], rel=1e-3, abs=1e-6)
    # the ball sits straight below the socket centre, in the socket frame
    assert tr.outputs["S.eccentricity"][-1] == pytest.approx([0, 0, -(1e-4 + ref)], rel=1e-3)


@pytest.mark.parametrize("law,ce", [("lankarani_nikravesh", 0.6), ("flores", 0.3), ("gonthier", 0.9)])
def test_single_impact_restitution_equals_1dof_reference(law, ce):
    mech = pinclear.load(BALL, clearances=["S"], overrides={"S.normal_law": law, "S.ce": ce})
    el = mech.forces[-1]
    v0 = np.zeros(6)
    v0[0] = 0.2
    # free flight c/v = 0.5 ms, one impact, then back towards the far wall (reached after 1.5 ms)
    tr = pinclear.simulate(mech, 1.2e-3, integrator="DOP853", rtol=1e-10, q0=np.zeros(6), v0=v0,
                           assemble=False, dt_out=1e-5)
    assert tr.status == "success"
    assert [e["event"] for e in tr.stats["events"]] == ["S.c0"]
    assert tr.stats["events"][0]["t"] == pytest.approx(1e-4 / 0.2, rel=1e-9)
    e_joint = -tr.v[-1, 0] / 0.2
    assert e_joint == pytest.approx(restitution_1dof(el.law), abs=1e-4)
    assert np.abs(tr.v[-1, 1:]).max() < 1e-12            # a central impact stays 1-DOF
    # the dissipated-energy state equals the kinetic energy lost
    assert tr.outputs["S.dissipated"][-1] == pytest.approx(0.5 * 2.0 * (0.2 ** 2 - tr.v[-1, 0] ** 2), rel=1e-6)


def test_frictionless_undamped_contact_conserves_energy_over_many_impacts():
    mech = pinclear.load(BALL, clearances=["S"], overrides={"S.normal_law": "hertz", "S.clearance": 2e-4})
    v0 = np.array([0.5, 0.3, -0.2, 3.0, -2.0, 1.0])
    # max_step: a restart after an impact must not try the free-flight step inside the contact
    tr = pinclear.simulate(mech, 0.015, integrator="DOP853", rtol=1e-11, q0=np.zeros(6), v0=v0,
                           assemble=False, dt_out=1e-4, max_step=2e-5)
    assert tr.status == "success"
    assert len(tr.stats["events"]) >= 15
    assert tr.outputs["S.dissipated"][-1] == 0.0
    assert energy_error(tr, "S") < 1e-6


def test_energy_lost_equals_integrated_friction_and_damping_power():
    fr = {"type": "modified_coulomb", "mu": 0.3, "v0": 1e-4, "v1": 1e-3}
    mech = pinclear.load(BALL, clearances=["S"], overrides={"S.friction_law": fr, "S.clearance": 2e-4})
    v0 = np.array([0.5, 0.3, -0.2, 3.0, -2.0, 1.0])
    tr = pinclear.simulate(mech, 0.006, integrator="DOP853", rtol=1e-10, q0=np.zeros(6), v0=v0,
                           assemble=False, dt_out=1e-4, max_step=2e-5)
    assert tr.status == "success"
    E0 = tr.energy()["total"][0]
    assert tr.outputs["S.dissipated"][-1] > 0.3 * E0          # friction and damping did real work
    assert np.abs(tr.outputs["S.friction_force"]).max() > 1.0
    assert energy_error(tr, "S") < 1e-6


def _tip(mech, q):
    data = mech.model.createData()
    fid = mech.frame_id("ball_centre")
    out = []
    for qi in q:
        pin.framesForwardKinematics(mech.model, data, qi)
        out.append(data.oMf[fid].act(np.array([0.0, 0.0, -0.5])))
    return np.array(out)


def test_converges_to_ideal_joint_as_clearance_shrinks():
    ideal = pinclear.load(PEND)
    T = 0.15
    tri = pinclear.simulate(ideal, T, rtol=1e-9, dt_out=1e-3)
    tip_i = _tip(ideal, tri.q)
    errs = []
    for c in (1e-3, 3e-4, 1e-4):
        mech = pinclear.load(PEND, clearances=["S"], overrides={"S.clearance": c, "S.stiffness": 1e9, "S.ce": 0.5})
        tr = pinclear.simulate(mech, T, rtol=1e-7, dt_out=1e-3, q0=tri.q[0], v0=tri.v[0], assemble=False)
        assert tr.status == "success"
        errs.append(np.abs(_tip(mech, tr.q) - tip_i).max())
    assert errs[0] > errs[1] > errs[2]
    # the rod tip error is of the order of the clearance itself (the ball rattles within c)
    assert errs[2] < 2e-4


def test_bad_input_is_rejected_before_integration():
    with pytest.raises(ContactSetupError, match=r"clr_ball.yaml: clearances.S.clearance: must be > 0"):
        pinclear.load(BALL, clearances=["S"], overrides={"S.clearance": -1e-4})
    with pytest.raises(ContactSetupError, match=r"clearances.S.ce: .*outside \(0, 1\]"):
        pinclear.load(BALL, clearances=["S"], overrides={"S.ce": 1.5})
    with pytest.raises(ContactSetupError, match=r"socket radius 0.01 m must exceed the ball radius 0.02"):
        pinclear.load(BALL, clearances=["S"], overrides={"S.socket_radius": 0.01})
    with pytest.raises(ContactSetupError, match=r"clearances.S.normal_law.type.*valid: flores, gonthier"):
        pinclear.load(BALL, clearances=["S"], overrides={"S.normal_law": "elastic"})
    with pytest.raises(ContactSetupError, match=r"clearances.S.radius_ball: unknown key \(valid: .*socket_radius"):
        pinclear.load(BALL, clearances=["S"], overrides={"S.radius_ball": 0.01})
    with pytest.raises(ContactSetupError, match=r"clearances.S.stiffness: invalid value 'concave'"):
        pinclear.load(BALL, clearances=["S"], overrides={"S.stiffness": "concave"})
    mech = pinclear.load(BALL, clearances=["S"])
    q0 = np.zeros(6)
    q0[0] = 1e-4 + 5e-5                # 50 um into the socket wall
    with pytest.raises(ContactSetupError, match=r"initial pose penetrates 5.000e-05 m"):
        pinclear.simulate(mech, 1e-3, q0=q0, v0=np.zeros(6), assemble=False)


def test_clearance_type_must_match_the_closure_it_replaces():
    from pinclear import contact

    mech = pinclear.load(model_path("clr_slider"))
    with pytest.raises(ContactSetupError, match=r"a spherical clearance cannot replace the prismatic closure 'P'"):
        contact.build({"name": "P", "type": "spherical", "closure": "P", "clearance": 1e-4}, mech, "x.yaml")
    with pytest.raises(ContactSetupError, match=r"clearances.P.closure: no closure named 'Q'"):
        contact.build({"name": "P", "type": "prismatic", "closure": "Q", "clearance": 1e-4}, mech, "x.yaml")
    with pytest.raises(ContactSetupError, match=r"clearances.P.section: must be > 0"):
        contact.build({"name": "P", "type": "prismatic", "closure": "P", "clearance": 1e-4, "section": [0.05, -1]},
                      mech, "x.yaml")


# ------------------------------------------------------------ the element against plain NumPy
def _reference_ball(mech, el, q, v, z, law, friction):
    """Generalized force, dissipated power and bristle rates of the ball in its world-fixed
    socket, written out from paper 000 eqs. 3-19 with Pinocchio's frame Jacobian (no kernel)."""
    model = mech.model
    data = model.createData()
    fid = mech.frame_id("ball_centre")
    pin.computeJointJacobians(model, data, q)
    pin.updateFramePlacements(model, data)
    J = pin.getFrameJacobian(model, data, fid, pin.LOCAL_WORLD_ALIGNED)
    o = data.oMf[fid].translation
    e = o - data.oMf[mech.frame_id("socket")].translation
    n = e / np.linalg.norm(e)
    delta = np.linalg.norm(e) - el.c
    p2 = o + el.R2 * n                                   # contact point on the ball
    vp = J[:3] @ v + np.cross(J[3:] @ v, p2 - o)
    dd = n @ vp
    vt = vp - dd * n
    dd0 = max(z[0], el.v_impact_min)
    Fn, Fel = (x[0] for x in law.force_and_elastic(np.array([delta]), np.array([dd]), np.array([dd0])))
    dz = np.zeros(0)
    if friction.nstate:
        zs = z[2:] - (z[2:] @ n) * n
        s = np.linalg.norm(vt)
        g = friction.mu_c + (friction.mu_s - friction.mu_c) * np.exp(-(s / friction.vs) ** 2)
        dz = vt - friction.s0 * s / g * zs
        Ft = -Fn * (friction.s0 * zs + friction.s1 * dz + friction.s2 * vt)
        Ft -= (Ft @ n) * n
    else:
        s = np.linalg.norm(vt)
        Ft = -friction.coefficient(np.array([s]))[0] * Fn * vt / s if s > 0 else np.zeros(3)
    F = Ft - Fn * n
    tau = J[:3].T @ F + J[3:].T @ np.cross(p2 - o, F)
    return tau, (Fn - Fel) * dd - Ft @ vt, dz


@pytest.mark.parametrize("normal", ["hertz", "lankarani_nikravesh", "flores", "hunt_crossley", "gonthier"])
@pytest.mark.parametrize("fr", [{"type": "none"}, {"type": "coulomb", "mu": 0.3},
                                {"type": "modified_coulomb", "mu": 0.2, "v0": 1e-4, "v1": 1e-2},
                                {"type": "stick_slip", "mu_s": 0.5, "mu_d": 0.2, "Vs": 1e-3, "Vd": 1e-2},
                                {"type": "lugre", "mu_s": 0.3, "mu_c": 0.2, "vs": 1e-3, "s0": 1e4, "s1": 10.0}])
def test_ball_force_equals_plain_numpy_evaluation(normal, fr):
    """The compiled channel loop (power laws, memoryless friction and LuGre) against an
    independent evaluation, at random states in contact."""
    mech = pinclear.load(BALL, clearances=["S"], overrides={"S.normal_law": normal, "S.friction_law": fr})
    el = mech.forces[-1]
    ws = mech.workspace()
    d = ws.force_data[-1]
    rng = np.random.default_rng(2024)
    pushing = 0
    for _ in range(20):
        q = rng.uniform(-1.0, 1.0, 6)
        u = rng.normal(size=3)
        gap = 10 ** rng.uniform(-8, -5.5)
        q[:3] = u / np.linalg.norm(u) * (el.c + gap)     # in contact, delta = gap
        v = rng.normal(size=6) * np.r_[0.1, 0.1, 0.1, 5.0, 5.0, 5.0]
        z = np.r_[10 ** rng.uniform(-4, 0), 0.0, rng.normal(size=el.nz - 2) * 1e-6]
        kinematics.update(mech, ws, q, v)
        tau, zdot = np.zeros(6), np.zeros(el.nz)
        el.add_force(mech, ws, d, 0.0, q, v, z, tau, zdot)
        ref_tau, ref_loss, ref_dz = _reference_ball(mech, el, q, v, z, el.law, el.friction)
        scale = np.abs(ref_tau).max()
        pushing += scale > 0                             # else separating fast: the law clipped to 0
        # the penetration delta = |e| - c is a difference of numbers of size c: the kernel's |e|
        # (its own loop) and NumPy's (a BLAS dot, whose summation order and FMA use depend on the
        # OpenBLAS kernel picked at run time) differ by up to ~4 ulp of |e|, so delta by
        # 4 eps |e|, and Fn ~ delta^n, with every force proportional to it, by n 4 eps |e| / delta
        # relatively: 1.3e-11 at delta = 1e-8 m (c = 1e-4 m). Measured with OPENBLAS_CORETYPE=
        # Prescott: 1.9e-12 in the LuGre cases, whose draws reach the small gaps; 1e-12 covers the
        # rest of the chain (Jacobians, cross products)
        rel = 1e-12 + el.law.n * 4 * np.finfo(float).eps * (el.c + gap) / gap
        np.testing.assert_allclose(tau, ref_tau, rtol=0, atol=rel * scale)
        assert zdot[1] == pytest.approx(ref_loss, rel=rel, abs=rel * scale * np.abs(v).max())
        assert zdot[2:].shape == ref_dz.shape
        if ref_dz.size:
            np.testing.assert_allclose(zdot[2:], ref_dz, rtol=0, atol=1e-12 * np.abs(ref_dz).max())
        assert el.power_loss(mech, ws, d, 0.0, q, v, z) == zdot[1]
    assert pushing >= 5
    # every law declares a compiled form, so the joint's force is one compiled call (contract 10)
    assert el.law.kernel_params() is not None and el.friction.kernel_params() is not None
    assert el.force_kernel(mech, ws, d, ws.z_views[-1], ws.zdot_views[-1]) is not None


def test_two_data_objects_of_one_element_do_not_interfere():
    """Element data is per workspace: evaluating workspace a at another state between two
    evaluations of workspace b at the same state changes nothing in b's answers."""
    mech = pinclear.load(BALL, clearances=["S"], overrides={"S.friction_law": {"type": "coulomb", "mu": 0.3}})
    el = mech.forces[-1]
    wa, wb = mech.workspace(), mech.workspace()
    da, db = wa.force_data[-1], wb.force_data[-1]
    assert da is not db
    qa, qb = np.array([1.05e-4, 0, 0, 0.1, 0.2, 0.3]), np.array([0, -1.02e-4, 0, -0.3, 0.1, 0.0])
    va, vb = np.array([0.2, 0.1, 0, 1, 2, 3]), np.array([0.1, -0.3, 0.2, 0, 1, 0])
    z = np.array([0.1, 0.0])

    def force(ws, d, q, v):
        kinematics.update(mech, ws, q, v)
        tau = np.zeros(6)
        el.add_force(mech, ws, d, 0.0, q, v, z, tau, np.zeros(el.nz))
        return tau, el.outputs(mech, ws, d, 0.0, q, v, z)["fn"]
    ref_b = force(wb, db, qb, vb)
    ref_a = force(wa, da, qa, va)
    assert ref_a[1] > 0 and ref_b[1] > 0 and not np.allclose(ref_a[0], ref_b[0])
    for _ in range(3):
        got_b = force(wb, db, qb, vb)
        got_a = force(wa, da, qa, va)
        assert np.array_equal(got_b[0], ref_b[0]) and got_b[1] == ref_b[1]
        assert np.array_equal(got_a[0], ref_a[0]) and got_a[1] == ref_a[1]
    with pytest.raises(AttributeError, match="immutable"):
        el.c = 1e-3


def test_two_workspaces_in_two_threads_give_bit_identical_runs():
    """One clearance mechanism, two runs at once in two threads (each simulate owns its
    workspace): impacts, friction and outputs are bit-identical to each other and to a serial run."""
    from concurrent.futures import ThreadPoolExecutor

    fr = {"type": "modified_coulomb", "mu": 0.3, "v0": 1e-4, "v1": 1e-3}
    mech = pinclear.load(BALL, clearances=["S"], overrides={"S.friction_law": fr, "S.clearance": 2e-4})
    v0 = np.array([0.5, 0.3, -0.2, 3.0, -2.0, 1.0])

    def run(_):
        return pinclear.simulate(mech, 3e-3, integrator="DOP853", rtol=1e-9, q0=np.zeros(6), v0=v0,
                                 assemble=False, dt_out=1e-4, max_step=2e-5)
    serial = run(0)
    assert serial.status == "success" and len(serial.stats["events"]) >= 3
    with ThreadPoolExecutor(2) as ex:
        runs = list(ex.map(run, range(2)))
    for tr in runs:
        assert tr.status == "success"
        assert [e["t"] for e in tr.stats["events"]] == [e["t"] for e in serial.stats["events"]]
        for a, b in ((tr.t, serial.t), (tr.q, serial.q), (tr.v, serial.v), (tr.a, serial.a)):
            assert np.array_equal(a, b)
        assert set(tr.outputs) == set(serial.outputs)
        for k in serial.outputs:
            assert np.array_equal(tr.outputs[k], serial.outputs[k]), k


def test_a_trial_stage_on_a_singular_configuration_is_rejected_not_fatal():
    """4UPS-UPU with the S2 clearance, DOP853 at rtol 1e-4: a too-long trial step through an
    impact lands a stage on a configuration where the constraint Jacobian loses rank. The motion
    never goes there (the tight run below passes the same time), so the step must be rejected
    and retried, not the run ended ('lost rank at t = 0.0158 s' before). The loose run then
    follows the tight one to its tolerance: q within rtol = 1e-4 (measured 2.2e-6) and the
    loop closed within atol = 1e-6 (measured 5.7e-11)."""
    import warnings

    mech = pinclear.load("four_ups_upu", clearances=["S2"])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        loose = pinclear.simulate(mech, 0.2, integrator="DOP853", rtol=1e-4, atol=1e-6, t_eval=[0.0, 0.2])
        tight = pinclear.simulate(mech, 0.2, integrator="DOP853", rtol=1e-8, t_eval=[0.0, 0.2])
    assert loose.status == "success" and loose.t[-1] == pytest.approx(0.2), loose.message
    assert tight.status == "success", tight.message
    assert loose.residual.max() < 1e-6
    assert np.abs(pin.difference(mech.model, tight.q[-1], loose.q[-1])).max() < 1e-4
