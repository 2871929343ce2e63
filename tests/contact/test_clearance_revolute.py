"""Revolute clearance joints: planar journal in bearing (paper 002) and the spatial radial
clearance, against Hertz statics, the 1-DOF impact, energy balance and the ideal hinge."""
import numpy as np
import pinocchio as pin
import pytest

import pinclear
from pinclear.contact import restitution_1dof
from pinclear.core.errors import ContactSetupError
from pinclear.core.models import model_path
from tests.helpers import clearance_states

PLANAR, HINGE = model_path("clr_planar_pendulum"), model_path("clr_hinge")


def test_journal_settles_at_hertz_deflection():
    mech = pinclear.load(PLANAR, clearances=["A"])
    law = mech.forces[-1].law
    q0 = np.array([0.0, -1e-4, 0.0])           # rod hanging along -y, journal on the bearing bottom
    tr = pinclear.simulate(mech, 0.02, integrator="Radau", rtol=1e-8, q0=q0, v0=np.zeros(3), assemble=False)
    assert tr.status == "success"
    ref = (9.81 / law.K) ** (2.0 / 3.0)
    assert tr.outputs["A.penetration"][-1] == pytest.approx(ref, rel=1e-2)
    assert tr.outputs["A.eccentricity"][-1] == pytest.approx([0, -(1e-4 + ref), 0], rel=1e-3, abs=1e-12)


def test_journal_impact_restitution_equals_1dof_reference():
    mech = pinclear.load(PLANAR, clearances=["A"], overrides={"A.normal_law": "flores", "A.ce": 0.5})
    mech.model.gravity = pin.Motion.Zero()
    # moving along the rod (through its centre of mass): the contact force has no moment arm
    v0 = np.array([0.0, -0.3, 0.0])
    tr = pinclear.simulate(mech, 0.8e-3, integrator="DOP853", rtol=1e-10, q0=np.zeros(3), v0=v0,
                           assemble=False, dt_out=1e-5)
    assert tr.status == "success"
    assert len(tr.stats["events"]) == 1
    assert tr.v[-1, 1] / 0.3 == pytest.approx(restitution_1dof(mech.forces[-1].law), abs=1e-4)
    assert abs(tr.v[-1, 2]) < 1e-12


@pytest.mark.parametrize("fr", [
    {"type": "modified_coulomb", "mu": 0.2, "v0": 1e-4, "v1": 1e-3},
    # LuGre: its bristle state is integrated with q, v; the balance counts the friction work
    {"type": "lugre", "mu_s": 0.3, "mu_c": 0.2, "vs": 1e-3, "s0": 1e4, "s1": 10.0},
])
def test_friction_and_damping_power_balance_the_energy_lost(fr):
    mech = pinclear.load(PLANAR, clearances=["A"], overrides={"A.friction_law": fr, "A.clearance": 2e-4,
                                                              "A.stiffness": 1e9})
    tr = pinclear.simulate(mech, 0.02, integrator="DOP853", rtol=1e-10, q0=np.array([0, 0, 0.5]),
                           v0=np.array([0.3, 0.0, -2.0]), assemble=False, dt_out=1e-4, max_step=2e-5)
    assert tr.status == "success"
    tot = tr.energy()["total"]
    diss = tr.outputs["A.dissipated"]
    assert diss[-1] > 1e-3
    assert np.max(np.abs(tot + diss - tot[0])) / abs(tot[0]) < 1e-6
    assert np.abs(tr.outputs["A.friction_force"]).max() > 0.5


def test_spatial_hinge_ends_share_the_static_load():
    mech = pinclear.load(HINGE, clearances=["R"])
    law = mech.forces[-1].law
    q0 = np.zeros(6)
    q0[2] = -1e-4
    tr = pinclear.simulate(mech, 0.02, integrator="Radau", rtol=1e-8, q0=q0, v0=np.zeros(6), assemble=False)
    assert tr.status == "success"
    # two journal ends, each carrying half the weight: W/2 = K delta^1.5
    assert tr.outputs["R.penetration"][-1] == pytest.approx((9.81 / 2 / law.K) ** (2 / 3), rel=1e-2)
    assert tr.outputs["R.normal_force"][-1] == pytest.approx([0, 0, 9.81], rel=1e-3, abs=1e-6)


def _tip(mech, q):
    data = mech.model.createData()
    out = []
    for qi in q:
        pin.forwardKinematics(mech.model, data, qi)
        out.append(data.oMi[-1].act(np.array([0.0, 0.0, -0.5])))
    return np.array(out)


def test_spatial_hinge_converges_to_the_ideal_revolute():
    ideal = pinclear.load(HINGE)
    tri = pinclear.simulate(ideal, 0.15, rtol=1e-9, dt_out=1e-3)
    ref = _tip(ideal, tri.q)
    errs = []
    for c in (1e-3, 3e-4, 1e-4):
        mech = pinclear.load(HINGE, clearances=["R"], overrides={"R.clearance": c, "R.stiffness": 1e9, "R.ce": 0.5})
        tr = pinclear.simulate(mech, 0.15, rtol=1e-7, dt_out=1e-3, q0=tri.q[0], v0=tri.v[0], assemble=False)
        assert tr.status == "success"
        errs.append(np.abs(_tip(mech, tr.q) - ref).max())
    assert errs[0] > errs[1] > errs[2]
    assert errs[2] < 2e-4


def test_bad_revolute_input():
    with pytest.raises(ContactSetupError, match=r"bearing radius 0.005 m must exceed the journal radius 0.01 m"):
        pinclear.load(PLANAR, clearances=["A"], overrides={"A.bearing_radius": 0.005})
    with pytest.raises(ContactSetupError, match=r"clearances.A.clearance: must be > 0"):
        pinclear.load(PLANAR, clearances=["A"], overrides={"A.clearance": 0})
    with pytest.raises(ContactSetupError, match=r"clearances.A.friction_law.mu_s: required for friction law stick_slip"):
        pinclear.load(PLANAR, clearances=["A"], overrides={"A.friction_law": "stick_slip"})
    with pytest.raises(ContactSetupError, match=r"clearances.R.axial_clearance: must be > 0"):
        pinclear.load(HINGE, clearances=["R"], overrides={"R.axial_clearance": -1e-4})


def test_nine_bar_scene_journal_stays_in_its_bearing():
    from pinclear.mechanisms import clearance_scenes

    res = clearance_scenes.run("nine_bar_AB", t_end=0.05, ideal=False)
    tr = res["clearance"]
    assert tr.status == "success"
    for name in ("A", "B"):
        el = next(f for f in res["mech"].forces if f.name == name)
        e = np.linalg.norm(tr.outputs[f"{name}.eccentricity"][:, :2], axis=1)
        pen = tr.outputs[f"{name}.penetration"]
        # radial eccentricity = clearance + penetration whenever in contact (paper 002 eq. 6)
        on = tr.outputs[f"{name}.contact"] > 0
        assert on.any()
        assert e[on] == pytest.approx(el.c + pen[on], rel=1e-9)
        assert np.all(e[~on] <= el.c)
        # printed stiffness of paper 002 eq. 8: 4/3 E* sqrt(R1 R2 / (R1 + R2))
        Es = 207e9 / (2 * (1 - 0.3 ** 2))
        assert el.law.K == pytest.approx(4 / 3 * Es * np.sqrt(0.0105 * 0.01 / 0.0205), rel=1e-12)


def test_journal_with_line_law_settles_at_paper_003_eq6_deflection():
    mech = pinclear.load(PLANAR, clearances=["A"], overrides={"A.normal_law": "line"})
    law = mech.forces[-1].law
    tr = pinclear.simulate(mech, 0.02, integrator="Radau", rtol=1e-8, q0=np.array([0.0, -1e-4, 0.0]),
                           v0=np.zeros(3), assemble=False)
    assert tr.status == "success"
    # eq. 6 with P = W, l = journal length, R = conformal radius R1 R2 / c, written out here
    Es = 207e9 / (2 * (1 - 0.3 ** 2))
    R, l, W = 0.0101 * 0.01 / 1e-4, 0.02, 9.81
    ref = W / (np.pi * Es * l) * (1 - np.log(W * R / (np.pi * Es * l ** 3)))
    assert law.R == pytest.approx(R)
    assert tr.outputs["A.penetration"][-1] == pytest.approx(ref, rel=1e-2)


# ------------------------------------------------------------ the element against plain NumPy
def _reference_journal(mech, el, q, v, z, mu, v_eps):
    """Generalized force and dissipated power of a journal in its bearing, written out from paper
    002 eqs. 1-10 (spatial: both journal ends on the cylinder, the centre against the thrust
    faces) with Pinocchio's frame Jacobians, Lankarani-Nikravesh and regularised Coulomb."""
    model = mech.model
    data = model.createData()
    pin.computeJointJacobians(model, data, q)
    pin.updateFramePlacements(model, data)
    M1, M2 = data.oMf[el.f1], data.oMf[el.f2]
    J1 = pin.getFrameJacobian(model, data, el.f1, pin.LOCAL_WORLD_ALIGNED)
    J2 = pin.getFrameJacobian(model, data, el.f2, pin.LOCAL_WORLD_ALIGNED)
    s, a, j = M1.translation, M1.rotation[:, 2], M2.translation
    channels = []                                          # (delta, n, p1, p2)
    ends = [j + h * M2.rotation[:, 2] for h in (0.5 * el.L, -0.5 * el.L)] if el.spatial else [j]
    for p in ends:
        u = (p - s) @ a
        e = p - s - u * a
        n = e / np.linalg.norm(e)
        channels.append((np.linalg.norm(e) - el.c, n, s + u * a + el.R1 * n, p + el.R2 * n))
    if el.spatial:
        u = (j - s) @ a
        channels += [(u - el.ca, a, j, j), (-u - el.ca, -a, j, j)]
    chi = 0.75 * (1 - el.law.ce ** 2)
    tau, loss = np.zeros(mech.nv), 0.0
    for k, (delta, n, p1, p2) in enumerate(channels):
        if delta <= 0:
            continue
        vel = [J[:3] @ v + np.cross(J[3:] @ v, p - M.translation) for J, M, p in ((J1, M1, p1), (J2, M2, p2))]
        dv = vel[1] - vel[0]
        dd = n @ dv
        vt = dv - dd * n
        Fel = el.law.K * delta ** el.law.n
        Fn = max(Fel * (1 + chi * dd / max(z[k], el.v_impact_min)), 0.0)
        sl = np.linalg.norm(vt)
        Ft = -mu * sl / np.sqrt(sl ** 2 + v_eps ** 2) * Fn * vt / sl if sl > 0 else np.zeros(3)
        F = Ft - Fn * n                                    # on the journal, at p2; reaction at p1
        for J, M, p, sign in ((J2, M2, p2, 1.0), (J1, M1, p1, -1.0)):
            tau += sign * (J[:3].T @ F + J[3:].T @ np.cross(p - M.translation, F))
        loss += (Fn - Fel) * dd - Ft @ vt
    return tau, loss, sum(c[0] > 0 for c in channels)


@pytest.mark.parametrize("scene, name", [("clr_planar_pendulum", "A"), ("clr_hinge", "R"), ("nine_bar", "A")])
def test_journal_force_equals_plain_numpy_evaluation(scene, name):
    """The compiled right-hand-side path of the revolute clearances (planar, spatial, and one whose
    bearing moves) against an independent evaluation at random states, to 1e-12."""
    mu, v_eps = 0.3, 1e-4
    mech = pinclear.load(scene, clearances=[name], overrides={f"{name}.friction_law":
                                                             {"type": "coulomb", "mu": mu, "v_eps": v_eps}})
    el = next(f for f in mech.forces if f.name == name)
    i = mech.forces.index(el)
    mu = el.friction.mu         # a joint-level ``mu`` (nine_bar's A) sets the law's coefficient
    ws = mech.workspace()
    touching = 0
    for q, v, z in clearance_states(mech, el, 40, seed=7, spread=3e-3):
        pinclear.model.kinematics.update(mech, ws, q, v)
        tau, zdot = np.zeros(mech.nv), np.zeros(el.nz)
        el.add_force(mech, ws, ws.force_data[i], 0.0, q, v, z, tau, zdot)
        ref_tau, ref_loss, on = _reference_journal(mech, el, q, v, z, mu, v_eps)
        touching += on > 0
        scale = max(np.abs(ref_tau).max(), 1.0)
        np.testing.assert_allclose(tau, ref_tau, rtol=0, atol=1e-12 * scale)
        assert zdot[el.nc] == pytest.approx(ref_loss, rel=1e-11, abs=1e-12 * scale * np.abs(v).max())
    assert touching >= 10


def test_a_trial_step_into_stiff_contact_is_rejected_not_fatal():
    """DOP853's first trial steps on the nine-bar with clearance A overflow inside the compiled
    KKT kernel (division by a zero pivot). The kernel must hand back inf/nan (NumPy semantics) so
    the step is rejected and retried smaller; it once raised ZeroDivisionError and ended the run
    at t = 0. The run then meets RK45 at the same tolerance: the same contact events (the first
    at 0.48 ms) within 1e-5 s, and q at 2 ms within 1e-5 rad, ten times the rtol both bound
    each step's local error by (impacts amplify differences later, so the check stops early)."""
    import warnings

    mech = pinclear.load("nine_bar", clearances=["A"])
    runs = {}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        for integ in ("DOP853", "RK45"):
            # the least-energy start: its start-up impact is the stiff contact the first trial steps meet
            runs[integ] = pinclear.simulate(mech, 0.02, integrator=integ, rtol=1e-6, t_eval=[0.0, 0.002, 0.02],
                                            start="least-energy")
    a, b = runs["DOP853"], runs["RK45"]
    assert a.status == "success" and a.t[-1] == pytest.approx(0.02), a.message
    assert b.status == "success", b.message
    ta = [e["t"] for e in a.stats["events"][:4]]
    tb = [e["t"] for e in b.stats["events"][:4]]
    assert len(ta) == 4 and np.allclose(ta, tb, rtol=0, atol=1e-5)
    assert np.abs(a.q[1] - b.q[1]).max() < 1e-5
