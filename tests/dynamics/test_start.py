"""The start state of a run (pinclear.model.kinematics.start_state, simulate(start=...), --start):
a clearance run starts by default where the papers start, from the ideal mechanism's assembled
state and velocity (journal centred, no relative velocity at the clearance)."""
from __future__ import annotations

import json

import numpy as np
import pinocchio as pin
import pytest

import pinclear
from pinclear.core.errors import InputError
from pinclear.model import kinematics
from tests.helpers import URDF_DIR

NINE = URDF_DIR / "nine_bar.yaml"
#: assemble()'s tolerance on the closure residual (m): the centring error the start may keep
TOL_ASSEMBLY = 1e-10


@pytest.fixture(scope="module")
def nine_a():
    return pinclear.load(NINE, clearances=["A"])


@pytest.fixture(scope="module")
def nine_ideal():
    return pinclear.load(NINE)


def _journal_relative(mech, q, v):
    """Offset and relative velocity of the journal centre to the bearing centre of clearance A,
    from Pinocchio's frame kinematics of the closure's two frames (not from the contact code)."""
    cl = mech.replaced_closures["A"]
    fm = kinematics.frame_motion(mech.model, [cl.f1, cl.f2], q, v)
    return fm.p[0, 1] - fm.p[0, 0], fm.v[0, 1] - fm.v[0, 0]


def test_ideal_start_centred_and_at_rest_relative(nine_a):
    q, v = kinematics.start_state(nine_a, "ideal", nine_a.q0, nine_a.v0)
    e, de = _journal_relative(nine_a, q, v)
    c = 0.5e-3                                   # the sidecar's clearance
    assert np.linalg.norm(e[:2]) < TOL_ASSEMBLY  # centred: penetration -c, far from contact
    assert np.linalg.norm(e[:2]) - c < -0.99 * c
    # the crank tip moves at ~0.63 m/s; the journal moves with it to the assembly's precision
    assert np.linalg.norm(de[:2]) < 1e-8
    # the least-energy start at the same q leaves the journal a relative velocity of the crank tip's order
    v_le = kinematics.consistent_velocity(nine_a, q, nine_a.v0)
    assert np.linalg.norm(_journal_relative(nine_a, q, v_le)[1][:2]) > 1e-2


def test_ideal_start_velocity_is_the_ideal_mechanisms(nine_a, nine_ideal):
    """Independent checks: (1) the ideal mechanism's velocity solved from its own constraint
    Jacobian (closures + drive rows, J v = drive speeds: mobility 2, two drives, unique);
    (2) the central difference of the ideal assemblies at t = -h and +h (error O(h^2))."""
    q, v = kinematics.start_state(nine_a, "ideal", nine_a.q0, nine_a.v0)
    J = kinematics.jacobian(nine_ideal, nine_ideal.workspace(), q, 0.0, with_drives=True)
    assert np.linalg.matrix_rank(J) == nine_ideal.nv
    rhs = np.zeros(J.shape[0])
    rhs[-2:] = [2 * np.pi, -2 * np.pi]           # the drives' speeds (sidecar: omega1 = 2 pi, omega4 = -2 pi)
    v_ref = np.linalg.lstsq(J, rhs, rcond=None)[0]
    assert np.allclose(v, v_ref, rtol=0, atol=1e-9 * np.abs(v_ref).max())
    h = 1e-5
    qp = kinematics.assemble(nine_ideal, q, t=h, tol=1e-14)
    qm = kinematics.assemble(nine_ideal, q, t=-h, tol=1e-14)
    v_fd = pin.difference(nine_ideal.model, qm, qp) / (2 * h)
    # O(h^2 |dddq|): |dddq| ~ omega^3 * |q| scale ~ 250/s^3 -> 2.5e-8; with the 1e-14 assembly /2h: 1e-9
    assert np.allclose(v, v_fd, rtol=0, atol=1e-6)


def test_first_impact_much_smaller_from_ideal_start(nine_a, sim):
    """The least-energy start gives the journal the crank tip's relative speed: a start-up
    impact of ~10 kN within a millisecond; from the ideal start the first impact comes from the
    dynamics alone (~1 kN at ~12 ms on this scene)."""
    peaks = {}
    for start in ("ideal", "least-energy"):
        tr = sim(nine_a, 0.02, start=start, dt_out=1e-5)
        assert tr.status == "success", tr.message
        fn = np.asarray(tr.outputs["A.fn"])
        assert fn[0] == 0.0 or start == "least-energy"
        peaks[start] = fn.max()
    assert peaks["ideal"] < 0.25 * peaks["least-energy"]


def test_rest_refused_with_moving_drives(nine_a):
    with pytest.raises(InputError, match="crank1_drive.*moves"):
        kinematics.start_state(nine_a, "rest", nine_a.q0)


def test_rest_start_on_undriven_mechanism():
    mech = pinclear.load(URDF_DIR / "clr_planar_pendulum.yaml")
    q, v = kinematics.start_state(mech, "rest", mech.q0, np.ones(mech.nv))
    assert np.all(v == 0.0)
    assert np.abs(kinematics.closure_residual(mech, mech.workspace(), q)).max() < TOL_ASSEMBLY


def test_unknown_start_names_choices(nine_a):
    with pytest.raises(InputError, match="least-energy"):
        pinclear.simulate(nine_a, 0.01, start="centred")


def test_state_start_keeps_given_state(nine_a, tmp_path, sim):
    """start='state' assembles onto the clearance mechanism's own constraints only: an
    off-centre journal stays off centre (the ideal start would centre it)."""
    q, v = kinematics.start_state(nine_a, "ideal", nine_a.q0, nine_a.v0)
    v_le = kinematics.consistent_velocity(nine_a, q, nine_a.v0)      # the journal moves in its bearing
    ws = nine_a.workspace()
    J = kinematics.jacobian(nine_a, ws, q, 0.0, with_drives=True)
    null = np.linalg.svd(J)[2][np.linalg.matrix_rank(J):]
    # a step along the free direction sized to put the journal at a quarter of the clearance (the
    # offset is linear in a small step; the fitted linkage's lever ratio sets its scale)
    e_unit = np.linalg.norm(_journal_relative(nine_a, pin.integrate(nine_a.model, q, 1e-5 * null[0]), v)[0][:2]) / 1e-5
    q_off = pin.integrate(nine_a.model, q, 0.25 * nine_a.clearances[0].c / e_unit * null[0])
    e_off = np.linalg.norm(_journal_relative(nine_a, q_off, v)[0][:2])
    assert 1e-5 < e_off < 0.5e-3                       # inside the clearance, off centre
    np.savez(tmp_path / "s.npz", q=q_off, v=v)
    qs, vs = _read(tmp_path / "s.npz", nine_a)
    tr = sim(nine_a, 1e-4, start="state", q0=qs, v0=vs)
    assert np.isclose(np.linalg.norm(_journal_relative(nine_a, tr.q[0], tr.v[0])[0][:2]), e_off, rtol=1e-6)
    tr = sim(nine_a, 1e-4, q0=qs, v0=vs)                # given q0: the state start by default
    assert np.isclose(np.linalg.norm(_journal_relative(nine_a, tr.q[0], tr.v[0])[0][:2]), e_off, rtol=1e-6)
    tr = sim(nine_a, 1e-4, q0=qs, v0=vs, start="ideal")  # the ideal start centres it
    assert np.linalg.norm(_journal_relative(nine_a, tr.q[0], tr.v[0])[0][:2]) < TOL_ASSEMBLY
    tr = sim(nine_a, 1e-4)                               # no q0, v0: the ideal start by default
    assert np.linalg.norm(_journal_relative(nine_a, tr.q[0], tr.v[0])[0][:2]) < TOL_ASSEMBLY
    assert np.linalg.norm(_journal_relative(nine_a, tr.q[0], tr.v[0])[1][:2]) < 1e-8
    # v0 alone is a state too: the journal keeps the relative velocity it is given
    tr = sim(nine_a, 1e-4, v0=v_le)
    assert np.linalg.norm(_journal_relative(nine_a, tr.q[0], tr.v[0])[1][:2]) > 1e-2


def _read(path, mech):
    from pinclear.dynamics.simulate import read_state

    return read_state(path, mech)


def test_read_state_refuses_trajectory_shape(nine_a, tmp_path):
    np.savez(tmp_path / "t.npz", q=np.zeros((5, nine_a.nq)), v=np.zeros((5, nine_a.nv)))
    with pytest.raises(InputError, match="one state"):
        _read(tmp_path / "t.npz", nine_a)
    (tmp_path / "s.json").write_text(json.dumps({"q": [0.0] * nine_a.nq}))
    with pytest.raises(InputError, match="no 'v'"):
        _read(tmp_path / "s.json", nine_a)
