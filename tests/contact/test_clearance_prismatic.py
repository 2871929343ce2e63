"""Prismatic clearance joint (paper 003): the 15 contact modes of its Table 1, each produced by a
slider pose built for it, the force law of each contact kind, and the static plane contact."""
import numpy as np
import pytest
from scipy.optimize import linprog

import pinclear
from pinclear.contact.prismatic import MODE_NAMES, classify
from pinclear.core.models import model_path
from pinclear.model import kinematics
from tests.helpers import clearance_states

SLIDER = model_path("clr_slider")
A_, B_, L_, C_ = 0.05, 0.05, 0.1, 1e-4          # section, length and clearance of clr_slider.yaml


def channel(s1, s2, s3, face):
    """Channel of corner (s1 a/2, s2 b/2, s3 L/2) against its x face (top/bottom) or y face (side)."""
    k = 4 * (s1 > 0) + 2 * (s2 > 0) + (s3 > 0)
    return 2 * k + (face == "y")


# Which corners touch which faces, per mode (corner signs s1 s2 s3; x: top/bottom face, y: side face)
P, M = 1, -1
MODES = {
    1: [(M, M, M, "x")],
    2: [(M, M, M, "x"), (M, P, M, "y")],
    3: [(M, M, M, "x"), (M, P, M, "y"), (P, M, P, "y")],
    4: [(M, M, M, "x"), (M, P, M, "y"), (P, M, P, "y"), (P, P, P, "x")],
    5: [(M, M, M, "x"), (M, M, M, "y"), (M, P, M, "x")],
    6: [(M, M, M, "x"), (M, M, M, "y"), (M, M, P, "x"), (M, P, P, "y"), (P, M, M, "y")],
    7: [(M, M, M, "x"), (M, M, M, "y"), (M, P, M, "x"), (P, M, P, "x")],
    8: [(M, M, M, "x"), (M, M, P, "x")],
    9: [(M, M, M, "x"), (M, M, M, "y"), (M, M, P, "x"), (P, M, M, "y")],
    10: [(M, M, M, "x"), (M, M, M, "y"), (M, M, P, "x"), (M, P, P, "y"), (P, M, M, "y"), (P, P, P, "y")],
    11: [(M, M, M, "x"), (M, M, M, "y"), (M, M, P, "x"), (M, P, P, "y"), (P, M, M, "y"), (P, P, M, "x"),
         (P, P, P, "x"), (P, P, P, "y")],
    12: [(M, M, M, "x"), (M, M, M, "y"), (M, M, P, "x"), (M, M, P, "y"), (M, P, M, "x"), (M, P, P, "x")],
    13: [(M, M, M, "x"), (M, M, M, "y"), (M, M, P, "x"), (M, M, P, "y"), (M, P, M, "x"), (M, P, P, "x"),
         (P, P, M, "y"), (P, P, P, "y")],
    14: [(M, M, M, "x"), (M, M, P, "x"), (M, P, M, "x"), (M, P, P, "x")],
    15: [(M, M, M, "x"), (M, M, M, "y"), (M, M, P, "x"), (M, M, P, "y"), (M, P, M, "x"), (M, P, P, "x"),
         (P, M, M, "y"), (P, M, P, "y")],
}


def build_pose(touch, depth=2e-5):
    """Slider coordinates (px, py, pz, rx, ry, rz) putting exactly the ``touch`` channels ``depth``
    into their faces and every other corner at least ``depth`` clear: a linear program on the
    small-rotation corner positions r = t + C + theta x C (written out here, independently of
    the element's geometry)."""
    rows = []
    for k in range(8):
        s = np.array([1 if k & 4 else -1, 1 if k & 2 else -1, 1 if k & 1 else -1])
        C = s * np.array([A_ / 2, B_ / 2, L_ / 2])
        # x = (t1, t2, th_x, th_y, th_z); penetration = A x - c
        rows.append(s[0] * np.array([1, 0, 0, C[2], -C[1]]))
        rows.append(s[1] * np.array([0, 1, -C[2], 0, C[0]]))
    A = np.array(rows)
    tset = set(touch)
    A_ub, b_ub = [], []
    for i in range(16):
        if i in tset:                      # A x - c >= depth
            A_ub.append(-A[i]), b_ub.append(-C_ - depth)
        else:                              # A x - c <= -depth
            A_ub.append(A[i]), b_ub.append(C_ - depth)
    # smallest rotations that do it (keeps the neglected second-order terms ~ theta^2 L tiny)
    cost = np.r_[0, 0, 1, 1, 1, 1, 1, 1]
    A2 = np.hstack([np.array(A_ub), np.zeros((16, 3))])
    absrows = []
    for j in range(3):                     # |theta_j| <= u_j
        r1 = np.zeros(8); r1[2 + j], r1[5 + j] = 1, -1
        r2 = np.zeros(8); r2[2 + j], r2[5 + j] = -1, -1
        absrows += [r1, r2]
    res = linprog(cost, A_ub=np.vstack([A2, absrows]), b_ub=np.r_[b_ub, np.zeros(6)],
                  bounds=[(-3 * C_, 3 * C_)] * 2 + [(-0.03, 0.03)] * 3 + [(0, None)] * 3)
    assert res.status == 0, "no rigid slider pose has this contact set"
    x = res.x
    return np.array([x[0], x[1], 0.0, x[2], x[3], x[4]])


@pytest.fixture(scope="module")
def slider():
    mech = pinclear.load(SLIDER, clearances=["P"])
    ws = mech.workspace()
    return mech, mech.forces[-1], ws, ws.force_data[-1]


@pytest.fixture(scope="module")
def slider003():
    """The slider with paper 003's per-mode laws (``model: paper003``)."""
    mech = pinclear.load(SLIDER, clearances=["P"], overrides={"P.model": "paper003"})
    ws = mech.workspace()
    return mech, mech.forces[-1], ws, ws.force_data[-1]


def penetrations(mech, el, ws, d, q):
    """Per-channel penetration at pose q (the event values are the channels' penetrations)."""
    kinematics.update(mech, ws, q, np.zeros(6))
    return el.event_values(mech, ws, d, 0.0, q, np.zeros(6), np.zeros(el.nz))


@pytest.mark.parametrize("mode", sorted(MODES))
def test_each_contact_mode_is_produced_and_classified(slider, mode):
    mech, el, ws, d = slider
    touch = [channel(*c) for c in MODES[mode]]
    q = build_pose(touch)
    delta = penetrations(mech, el, ws, d, q)
    out = el.outputs(mech, ws, d, 0.0, q, np.zeros(6), np.zeros(el.nz))
    touched = set(np.flatnonzero(delta > 0).tolist())
    assert touched == set(touch)
    assert int(out["mode"]) == mode, MODE_NAMES[mode]
    assert classify(delta > 0)[0] == mode
    # the mode is part of the workspace's data, not of the (shared, immutable) element
    assert d.mode == mode and not hasattr(el, "mode")


def test_free_slider_is_mode_zero(slider):
    mech, el, ws, d = slider
    q = np.array([3e-5, -2e-5, 0.01, 1e-4, -1e-4, 2e-4])
    delta = penetrations(mech, el, ws, d, q)
    assert classify(delta > 0)[0] == 0
    assert delta.max() < 0
    assert int(el.outputs(mech, ws, d, 0.0, q, np.zeros(6), np.zeros(el.nz))["mode"]) == 0


def test_force_laws_per_contact_kind(slider003):
    """model: paper003 applies paper 003's law of each contact kind (sec. 2.2)."""
    mech, el, ws, dat = slider003
    v = np.zeros(6)
    z = np.zeros(el.nz)
    d = 3e-6
    # plane: the slider pressed flat onto the bottom face: F = E A d / l, paper 003 eq. 4
    q = np.array([-(C_ + d), 0, 0, 0, 0, 0])
    kinematics.update(mech, ws, q, v)
    out = el.outputs(mech, ws, dat, 0.0, q, v, z)
    assert out["normal_force"] == pytest.approx([200e9 * (L_ * B_) * d / A_, 0, 0], rel=1e-9)
    assert int(out["mode"]) == 14
    # single point: corner of radius r on a flat, Lankarani-Nikravesh with Hertz K = 4/3 E* sqrt(r)
    q = build_pose([channel(M, M, M, "x")], depth=d)
    dk = penetrations(mech, el, ws, dat, q)[channel(M, M, M, "x")]
    Es = 1.0 / (2 * (1 - 0.3 ** 2) / 200e9)
    out = el.outputs(mech, ws, dat, 0.0, q, v, z)
    assert out["fn"] == pytest.approx(4 / 3 * Es * np.sqrt(1e-3) * dk ** 1.5, rel=1e-9)


def test_slider_settles_on_its_face_at_the_plane_law_deflection():
    mech = pinclear.load(SLIDER, clearances=["P"])
    q0 = np.array([-C_, 0, 0, 0, 0, 0])        # resting on the bottom face, gravity along -x
    tr = pinclear.simulate(mech, 4e-3, integrator="Radau", rtol=1e-8, q0=q0, v0=np.zeros(6), assemble=False,
                           dt_out=1e-4)
    assert tr.status == "success"
    W = 2.0 * 9.81
    ref = W * A_ / (200e9 * L_ * B_)           # E A delta / l = W
    assert tr.outputs["P.penetration"][-1] == pytest.approx(ref, rel=1e-2)
    assert tr.outputs["P.mode"][-1] == 14
    assert tr.outputs["P.normal_force"][-1] == pytest.approx([W, 0, 0], rel=1e-2)


@pytest.mark.parametrize("model", ["energy", "paper003"])
@pytest.mark.parametrize("scene, name, friction", [("clr_slider", "P", None),
                                                   ("clr_slider", "P", {"type": "coulomb", "mu": 0.2}),
                                                   ("three_upru_up", "P_UP", None)])
def test_compiled_slider_equals_the_python_path(scene, name, friction, model):
    """The prismatic joint's one compiled call (corner geometry, mode classification, the
    foundation's corner loads (energy) or each face's point/line/plane law (paper003), friction,
    wrenches) against its Python path (Pinocchio's frame placements, ``classify`` and the law
    objects face by face, or the foundation called on the Python geometry) at random poses in
    contact.

    Tolerance: the two paths round the corner coordinates differently, by ~eps |r| with |r| up to
    0.3 m, so a penetration of ~1 um differs by ~3e-11 relative and the forces as much."""
    ov = {f"{name}.model": model}
    if friction:
        ov[f"{name}.friction_law"] = friction
    mech = pinclear.load(scene, clearances=[name], overrides=ov)
    i = [f.name for f in mech.forces].index(name)
    el = mech.forces[i]
    fast, slow = mech.workspace(), mech.workspace()
    d = fast.force_data[i]
    assert el.force_kernel(mech, fast, d, fast.z_views[i], fast.zdot_views[i]) is not None
    assert el.event_level == "placements"
    modes = set()
    for q, v, z in clearance_states(mech, el, 200, seed=5, spread=1e-3):
        kinematics.update(mech, fast, q, v)
        kinematics.update(mech, slow, q, v)
        tau, zdot = np.zeros(mech.nv), np.zeros(el.nz)
        el.add_force(mech, fast, fast.force_data[i], 0.0, q, v, z, tau, zdot)
        pot, loss, rec = el.record(mech, fast, fast.force_data[i], 0.0, q, v, z, True)
        ds = slow.force_data[i]
        py = el.outputs(mech, slow, ds, 0.0, q, v, z)          # Python path (_eval)
        modes.add(ds.mode)
        assert rec["mode"] == ds.mode and np.array_equal(rec["kinds"], py["kinds"])
        scale = max(float(py["fn"]), 1.0)
        for k, val in py.items():
            np.testing.assert_allclose(rec[k], val, rtol=1e-10, atol=1e-10 * scale, err_msg=k)
        assert pot == pytest.approx(el.potential(mech, slow, ds, q), rel=1e-10, abs=1e-15)
        assert loss == pytest.approx(el.power_loss(mech, slow, ds, 0.0, q, v, z), rel=1e-10, abs=1e-10 * scale)
        np.testing.assert_allclose(el.event_values(mech, fast, fast.force_data[i], 0.0, q, v, z), ds.delta,
                                   rtol=0, atol=el.event_snap)      # event values snap |delta| < 1e-13
    assert len(modes) >= 4            # lines, planes, their mixes and free flight are all visited


def test_model_key_is_validated_with_file_key_and_choices():
    from pinclear.core.errors import ContactSetupError
    with pytest.raises(ContactSetupError) as e:
        pinclear.load(SLIDER, clearances=["P"], overrides={"P.model": "paper_003"})
    msg = str(e.value)
    assert "clr_slider.yaml" in msg and "clearances.P.model" in msg and "energy, mode_laws" in msg
    with pytest.raises(ContactSetupError) as e:
        pinclear.load(SLIDER, clearances=["P"], overrides={"P.normal_law": "line"})
    assert "clearances.P.normal_law" in str(e.value) and "lankarani_nikravesh" in str(e.value)
    el = pinclear.load(SLIDER, clearances=["P"]).forces[-1]
    assert el.contact_model == "energy" and {d for _, d in el.events} == {1}       # onsets only
    el = pinclear.load(SLIDER, clearances=["P"], overrides={"P.model": "paper003"}).forces[-1]
    assert el.contact_model == "mode_laws" and {d for _, d in el.events} == {0}    # the old name: an alias
