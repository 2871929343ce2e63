"""Model economy (pinclear.analysis.economy, `pinclear info --along`): redundant rows by name, planarity
and the planar model's size, and each body's influence on the drive forces.

References: hand counts of rows and freedoms (Grübler, planar and spatial), Bricard's known
single redundant constraint, the slider-crank's closed-form kinematics with the power balance
(drive power = rate of the body's energy), and paper 004's screw method (an independent inverse
dynamics) for the 4-UPS/UPR limbs."""
from __future__ import annotations

import json
import warnings

import numpy as np
import pinocchio as pin
import pytest

import pinclear
from pinclear.analysis import economy
from pinclear.cli.commands import main
from pinclear.core.errors import InputError
from pinclear.core.models import model_path
from pinclear.dynamics import screw
from pinclear.mechanisms import four_ups_upr as upr
from pinclear.model import kinematics

# slider-crank_clearance: crank r at constant speed w (5000 rpm), rod l, slider mass, crank com
R, L, W = 0.05, 0.12, 523.5987755982989
M_SLIDER, M_CRANK, RC_CRANK, G = 0.14, 0.3, 0.025, 9.81


@pytest.fixture(scope="module")
def crank_run():
    """One crank revolution, tight tolerance: the drive errors below scale with rtol (measured
    max |error| / peak: 2e-8 at rtol 1e-8, 2e-10 at rtol 1e-10)."""
    mech = pinclear.load("slider_crank_clearance")
    T = 2 * np.pi / W
    tr = pinclear.simulate(mech, T, rtol=1e-10, t_eval=np.linspace(0.0, T, 201))
    assert tr.status == "success"
    return mech, tr


# --------------------------------------------------------------------------- redundancy
def test_bricard_one_redundant_row_named_everywhere():
    """Bricard's 6R loop: Grübler 6(6-1) - 5*6 = 0, yet mobility 1: exactly one closure row is
    redundant, at the assembly and along the motion."""
    mech = pinclear.load("a04_bricard")
    q = kinematics.assemble(mech)
    red = economy.redundant_rows(mech, q)
    assert len(red) == 1
    r = red[0]
    assert r["closure"] == "J5" and r["type"] == "revolute"
    assert r["name"].startswith("a04_bricard closure 'J5' (revolute) ")
    assert r["axis"] in r["name"] and ("rotation" in r["axis"] or "translation" in r["axis"])
    # the named row really depends on the others: dropping it keeps the rank
    J = kinematics.jacobian(mech, mech.workspace(), q)
    k = mech.compiled.row_names.index(r["row"])
    rank = np.linalg.matrix_rank(J)
    # the loop is cut at J5: a 5-dof tree, a 5-row revolute closure (Grübler 5 - 5 = 0), rank 4
    assert J.shape == (5, 5) and rank == 4 and mech.nv - rank == 1
    assert np.linalg.matrix_rank(np.delete(J, k, axis=0)) == rank
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        tr = pinclear.simulate(mech, 0.6, rtol=1e-8, dt_out=0.2)
    assert tr.status == "success"
    moved = np.abs(tr.q[-1] - tr.q[0]).max()
    assert moved > 0.05                                  # it really moved under gravity
    ws = mech.workspace()
    for qk in tr.q[1:]:
        # off the manifold by the run's drift the dependency is blurred: the raw rank is full
        assert kinematics.mobility(mech, qk, ws)["rank"] == 5
        assert len(economy.redundant_rows(mech, qk, ws)) == 1
    along = economy.redundant_rows_along(mech, tr, ws=ws)
    assert len(along) == 1 and along[0]["count"] == 1


def test_four_bar_revolute_three_redundant_rows_named():
    """A planar four-bar closed by a spatial revolute (5 rows) needs 2: the other 3 are redundant
    and are the out-of-plane ones (translation along the axis z, rotations about x and y)."""
    mech = pinclear.load("four_bar_revolute")
    red = economy.redundant_rows(mech)
    assert len(red) == 3 and {r["closure"] for r in red} == {"B"}
    axes = {r["axis"] for r in red}
    assert axes == {"translation along world z", "rotation about frame1's x axis", "rotation about frame1's y axis"}
    assert economy.redundant_rows(pinclear.load("four_bar")) == []


# --------------------------------------------------------------------------- planarity
def test_four_bar_is_planar_and_planar_model_matches_hand_count():
    """four_bar: already planar (2-row planar_point closure, 3 z-revolutes): saves nothing.
    four_bar_revolute: the same linkage with a 5-row revolute closure: a planar model needs 2
    rows (saves 3), the same 3 freedoms, mobility 3*(4-1) - 2*4 = 1 (Grübler, planar)."""
    for name, rows, saved in (("four_bar", 2, 0), ("four_bar_revolute", 5, 3)):
        mech = pinclear.load(name)
        p = economy.planarity(mech)
        assert p["planar"] and p["deviation"] < 1e-12
        assert abs(abs(p["normal"][2]) - 1.0) < 1e-12
        pm = p["planar_model"]
        assert (pm["rows"], pm["planar_rows"], pm["saved_rows"]) == (rows, 2, saved)
        assert (pm["nv"], pm["planar_nv"], pm["saved_dofs"]) == (3, 3, 0)
        assert pm["planar_mobility"] == 1 and pm["planar_redundant_rows"] == 0


def test_planar_motion_of_a_spatial_tree_saves_rows_and_freedoms(tmp_path):
    """The four-bar built as an RUSR chain: the coupler hangs on a universal joint (z, then y)
    and closes on the rocker with a spherical joint (3 rows). The spherical's z row forbids the
    y rotation, so it moves in the x-y plane. Hand count of the planar model: the y joint
    disappears (4 -> 3 freedoms), the spherical becomes a 2-row pin (3 -> 2 rows); mobility
    4 - 3 = 3 - 2 = 1 both ways."""
    src = (model_path("four_bar").parent / "four_bar.urdf").read_text()
    cross = ('<link name="cross"><inertial><origin xyz="0 0 0"/><mass value="0.01"/>'
             '<inertia ixx="1e-6" ixy="0" ixz="0" iyy="1e-6" iyz="0" izz="1e-6"/></inertial></link>\n'
             '  <joint name="coupler_y" type="revolute"><parent link="cross"/><child link="coupler"/>'
             '<origin xyz="0 0 0" rpy="0 0 0"/><axis xyz="0 1 0"/>'
             '<limit lower="-1e9" upper="1e9" effort="1e9" velocity="1e9"/></joint>\n  <link name="ground"/>')
    urdf = src.replace('<link name="ground"/>', cross, 1)
    urdf = urdf.replace('<parent link="crank"/><child link="coupler"/>', '<parent link="crank"/><child link="cross"/>')
    (tmp_path / "rusr.urdf").write_text(urdf)
    (tmp_path / "rusr.yaml").write_text(
        "name: rusr\nurdf: rusr.urdf\ngravity: [0.0, -9.81, 0.0]\n"
        "initial: {q: {crank_joint: 0.5, coupler_joint: 0.9, coupler_y: 0.0, rocker_joint: 1.9}}\n"
        "closures:\n  - {name: B, type: spherical, frame1: {parent: coupler, xyz: [0.35, 0, 0]},"
        " frame2: {parent: rocker, xyz: [0.30, 0, 0]}}\n")
    mech = pinclear.load(tmp_path / "rusr.yaml")
    assert mech.nv == 4 and mech.m_closures == 3
    p = economy.planarity(mech)
    assert p["planar"] and p["deviation"] < 1e-12
    pm = p["planar_model"]
    assert (pm["nv"], pm["planar_nv"], pm["saved_dofs"]) == (4, 3, 1)
    assert (pm["rows"], pm["planar_rows"], pm["saved_rows"]) == (3, 2, 1)
    assert {j["joint"]: j["planar_nv"] for j in pm["joints"]}["coupler_y"] == 0
    assert pm["planar_mobility"] == kinematics.mobility(mech, kinematics.assemble(mech))["mobility"] == 1
    # the same tree closed by a 1-row distance constraint moves out of the plane (mobility 3)
    (tmp_path / "rusr_d.yaml").write_text(
        (tmp_path / "rusr.yaml").read_text().replace("type: spherical", "type: distance, length: 0.0001")
        .replace("xyz: [0.30, 0, 0]", "xyz: [0.30, 0, 0.0001]"))
    spatial = pinclear.load(tmp_path / "rusr_d.yaml")
    ps = economy.planarity(spatial)
    assert not ps["planar"] and ps["deviation"] > 0.01 and "planar_model" not in ps


def test_spatial_seed_mechanisms_are_not_planar_along_their_run():
    mech = pinclear.load("four_ups_upu")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        tr = pinclear.simulate(mech, 0.2, rtol=1e-8, dt_out=0.05)
    p = economy.planarity(mech, tr)
    # the platform's law moves it along X and swings Y, Z: a good fraction out of any plane
    assert not p["assembled"]["planar"] and not p["along_run"]["planar"] and not p["planar"]
    assert p["along_run"]["deviation"] > 0.05 and "planar_model" not in p


def test_planar_along_run_of_a_planar_linkage():
    mech = pinclear.load("four_bar")
    tr = pinclear.simulate(mech, 0.3, rtol=1e-8, dt_out=0.01)
    p = economy.planarity(mech, tr)
    assert p["along_run"]["planar"] and p["along_run"]["deviation"] < 1e-12 and p["planar"]
    assert p["along_run"]["samples"] == len(tr.t)


# --------------------------------------------------------------------------- inertia influence
def _slider_kinematics(t):
    """x(theta) = r cos(theta) + sqrt(l^2 - r^2 sin^2(theta)) and its first two theta-derivatives."""
    th = W * t
    s, c = np.sin(th), np.cos(th)
    root = np.sqrt(L**2 - R**2 * s**2)
    x1 = -R * s - R**2 * s * c / root
    x2 = -R * c - R**2 * np.cos(2 * th) / root - R**4 * s**2 * c**2 / root**3
    return th, x1, x2


def test_slider_inertia_changes_crank_torque_by_power_balance(crank_run):
    """Constant crank speed w: the drive's power lam w equals the rate of every body's energy, so
    the slider's share of the torque is m x_dot x_ddot / w = m w^2 x'(theta) x''(theta) (its
    weight is carried by the guide: no gravity term)."""
    mech, tr = crank_run
    th, x1, x2 = _slider_kinematics(tr.t)
    ref = M_SLIDER * W**2 * x1 * x2
    d = economy.drive_force_change(mech, tr, [mech.model.getJointId("slider_joint")])[:, 0]
    assert np.abs(ref).max() > 50.0
    assert np.abs(d - ref).max() < 1e-8 * np.abs(ref).max()
    rep = economy.inertia_influence(mech, tr)
    slider = next(b for b in rep["bodies"] if b["joint"] == "slider_joint")
    peak = np.abs(tr.lam["crank_drive"]).max()
    assert slider["max_rel_change"] == pytest.approx(np.abs(ref).max() / peak, rel=1e-7)
    assert slider["body"] == "slider" and slider["mass"] == M_SLIDER


def test_uniformly_rotating_crank_changes_the_torque_by_its_weight_only(crank_run):
    """The crank turns at constant speed about a fixed axis: its inertia adds no torque about
    the axis, its weight adds m g r_c cos(theta). Without gravity its influence is zero while
    the rod and slider still load the drive by ~70 N m."""
    mech, tr = crank_run
    jc = mech.model.getJointId("crank_joint")
    th = W * tr.t
    d = economy.drive_force_change(mech, tr, [jc])[:, 0]
    ref = M_CRANK * G * RC_CRANK * np.cos(th)
    assert np.abs(d - ref).max() < 1e-10 * M_CRANK * G * RC_CRANK
    rep = economy.inertia_influence(mech, tr, threshold=0.01)
    drop = {b["joint"]: b["error"] for b in rep["droppable"]}
    assert list(drop) == ["crank_joint"]
    assert drop["crank_joint"] == pytest.approx(M_CRANK * G * RC_CRANK / np.abs(tr.lam["crank_drive"]).max(),
                                                rel=1e-8)
    # the same run without gravity (the motion is prescribed: q, v, a do not change)
    model0 = mech.model.copy()
    model0.gravity = pin.Motion.Zero()
    mech0 = mech.replace(model=model0)
    d0 = economy.drive_force_change(mech0, tr, [jc])[:, 0]
    dr = economy.drive_force_change(mech0, tr, [mech.model.getJointId("rod_joint")])[:, 0]
    assert np.abs(dr).max() > 50.0
    assert np.abs(d0).max() < 1e-12 * np.abs(dr).max()


def test_body_changes_add_up_to_the_run_multiplier(crank_run):
    """rnea is linear in the inertia and the slider-crank has no applied force besides gravity on
    the bodies: removing every body removes the whole drive torque, so the per-body changes sum
    to the forward-dynamics multiplier of the run (an independent route: the KKT solve)."""
    mech, tr = crank_run
    total = sum(economy.drive_force_change(mech, tr, [j])[:, 0] for j in range(1, mech.model.njoints))
    lam = tr.lam["crank_drive"]
    assert np.abs(total - lam).max() < 1e-9 * np.abs(lam).max()


def test_limb_inertia_matches_screw_method_limbs_on_minus_off():
    """4-UPS/UPR (paper 004): zeroing every limb body changes the drive forces by what the screw
    method (paper 004 eq. 26, an independent inverse dynamics) gives with limbs on minus off;
    the simulation's tolerance bounds the agreement (as in test_four_ups_upr: 1e-5 of the peak)."""
    mech = upr.load(model_path("four_ups_upr"), law="high")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        tr = pinclear.simulate(mech, 0.4, rtol=1e-8, dt_out=1.0 / 50)
    assert tr.status == "success"
    jids = [mech.model.getJointId(j) for j in upr.LIMB_BODY_JOINTS]
    d = economy.drive_force_change(mech, tr, jids)
    on = screw.inverse_dynamics(mech, "high", tr.t, limbs=True).tau
    off = screw.inverse_dynamics(mech, "high", tr.t, limbs=False).tau
    ref = on - off
    assert np.abs(ref).max() > 0.05 * np.abs(on).max()          # the limbs carry a real share
    assert np.abs(d - ref).max() < 1e-5 * np.abs(on).max()
    rep = economy.inertia_influence(mech, tr, threshold=0.01)
    platform = next(b for b in rep["bodies"] if b["joint"] == "upr_r")
    assert platform["max_rel_change"] > 0.5                      # the platform is never droppable
    assert all(b["error"] < 0.01 for b in rep["droppable"])
    kept = {b["joint"] for b in rep["bodies"] if b["max_rel_change"] >= 0.01}
    assert kept | {b["joint"] for b in rep["droppable"]} == {b["joint"] for b in rep["bodies"]}


def test_influence_not_applicable_without_prescribed_motion_and_bad_threshold(crank_run):
    mech, tr = crank_run
    with pytest.raises(InputError, match="threshold"):
        economy.inertia_influence(mech, tr, threshold=0.0)
    free = pinclear.load("four_bar")
    trf = pinclear.simulate(free, 0.05, rtol=1e-8, dt_out=0.01)
    rep = economy.inertia_influence(free, trf)
    assert not rep["applicable"] and "no drives" in rep["reason"]
    released = mech.replace(drives=[])
    rep = economy.inertia_influence(released, tr)
    assert not rep["applicable"]


# --------------------------------------------------------------------------- command line
def test_cli_info_along_reports_economy(capsys):
    rc = main(["info", "slider_crank_clearance", "--along", "0.012", "--threshold", "0.01", "--json"])
    assert rc == 0
    info = json.loads(capsys.readouterr().out)
    eco = info["economy"]
    assert eco["run"]["status"] == "success"
    assert eco["planarity"]["planar"] and eco["planarity"]["planar_model"]["saved_rows"] == 0
    assert [b["joint"] for b in eco["inertia_influence"]["droppable"]] == ["crank_joint"]
    assert info["redundant_rows_named"] == []
    rc = main(["info", "a04_bricard", "--json"])
    info = json.loads(capsys.readouterr().out)
    assert len(info["redundant_rows_named"]) == 1 and "'J5'" in info["redundant_rows_named"][0]
    assert "run" not in info["economy"] and "inertia_influence" not in info["economy"]


def _pendulum(tmp_path, axes):
    """A rod hanging from revolute joints about ``axes`` in turn at the origin (a U joint for two)."""
    links = ['<link name="ground"/>']
    joints = []
    parent = "ground"
    for k, ax in enumerate(axes):
        child = f"b{k}"
        mass = '<mass value="1.0"/>' if k == len(axes) - 1 else '<mass value="0.01"/>'
        links.append(f'<link name="{child}"><inertial><origin xyz="0 0 -0.5"/>{mass}'
                     '<inertia ixx="0.01" ixy="0" ixz="0" iyy="0.01" iyz="0" izz="0.001"/></inertial></link>')
        joints.append(f'<joint name="j{k}" type="revolute"><parent link="{parent}"/><child link="{child}"/>'
                      f'<origin xyz="0 0 0"/><axis xyz="{ax}"/>'
                      '<limit lower="-1e9" upper="1e9" effort="1e9" velocity="1e9"/></joint>')
        parent = child
    (tmp_path / "p.urdf").write_text('<robot name="p">' + "".join(links + joints) + "</robot>")
    (tmp_path / "p.yaml").write_text("name: p\nurdf: p.urdf\ngravity: [0.0, 0.0, -9.81]\n")
    return pinclear.load(tmp_path / "p.yaml")


def test_rotation_alone_decides_the_plane(tmp_path):
    """A pendulum swinging about x: its pivot point does not move, only the rotation tells the
    plane (normal x). Hung on a U joint (x then y) it swings out of any plane."""
    p = economy.planarity(_pendulum(tmp_path, ["1 0 0"]))
    assert p["planar"] and abs(abs(p["normal"][0]) - 1.0) < 1e-12
    assert p["planar_model"]["planar_nv"] == 1 and p["planar_model"]["saved_dofs"] == 0
    u = economy.planarity(_pendulum(tmp_path, ["1 0 0", "0 1 0"]))
    assert not u["planar"] and u["deviation"] > 0.1
