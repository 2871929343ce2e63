"""Spherical clearance joint (paper 000) in small test mechanisms, against physics references:
Hertz static deflection, the 1-DOF impact of the same law, energy conservation/balance and
convergence to the ideal joint."""
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest

import pinclear
from pinclear.contact import restitution_1dof
from pinclear.errors import ContactSetupError

URDF = Path(__file__).resolve().parents[1] / "urdf"
BALL, PEND = URDF / "clr_ball.yaml", URDF / "clr_pendulum.yaml"


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

    mech = pinclear.load(URDF / "clr_slider.yaml")
    with pytest.raises(ContactSetupError, match=r"a spherical clearance cannot replace the prismatic closure 'P'"):
        contact.build({"name": "P", "type": "spherical", "closure": "P", "clearance": 1e-4}, mech, "x.yaml")
    with pytest.raises(ContactSetupError, match=r"clearances.P.closure: no closure named 'Q'"):
        contact.build({"name": "P", "type": "prismatic", "closure": "Q", "clearance": 1e-4}, mech, "x.yaml")
    with pytest.raises(ContactSetupError, match=r"clearances.P.section: must be > 0"):
        contact.build({"name": "P", "type": "prismatic", "closure": "P", "clearance": 1e-4, "section": [0.05, -1]},
                      mech, "x.yaml")
