"""The worn bearing in the meshcat view (issue 44): the profile drawn is R_b + scale x depth at the
wear nodes' angles, in the bearing frame, placed where the kinematics puts that frame; the
command `pinclear view MECH --wear OUT` draws a wear run's profile and states the scale."""
from __future__ import annotations

import math

import numpy as np
import pinocchio as pin
import pytest

import pinclear
from pinclear.analysis.wear_life import (
    _history_keys,
    _tables,
    read_profile,
    with_profile,
    worn_joint,
)
from pinclear.cli.view import view_main
from pinclear.viz.html import legend
from pinclear.viz.scene import MechanismScene, clearance_frames

WEAR = "A.wear={k: 1.0e-5, hardness: 2.0e+9, nodes: 180}"


def _worn_nine_bar():
    mech = pinclear.load("nine_bar", clearances=["A"],
                         overrides={"A.wear": {"k": 1e-5, "hardness": 2e9, "nodes": 180}})
    i, joint = worn_joint(mech, "A")
    th = joint.wear.angles()
    # a 6 um pocket centred at 60 deg, 10 deg wide, and a uniform 0.5 um
    rel = (th - math.radians(60) + math.pi) % (2 * math.pi) - math.pi
    depth = 0.5e-6 + 6e-6 * np.exp(-0.5 * (rel / math.radians(10)) ** 2)
    return with_profile(mech, {"A": depth}), depth


def _node(scene, suffix):
    hits = [p for p in scene.paths() if p.endswith(suffix)]
    assert len(hits) == 1, hits
    return hits[0]


def _world(scene, path):
    # compose the recorded transforms along the path (as three.js does), root's display transform undone
    parts = path.strip("/").split("/")
    T = np.eye(4)
    for k in range(1, len(parts) + 1):
        node = scene.recorder.nodes.get("/" + "/".join(parts[:k]))
        if node is not None and node.transform is not None:
            T = T @ np.asarray(node.transform.matrix)
    root = np.asarray(scene.recorder.nodes[f"/meshcat/{scene.root.path.entries[-1]}"].transform.matrix)
    return np.linalg.inv(root) @ T


def test_worn_profile_vertices_are_radius_plus_scaled_depth_in_the_bearing_frame():
    mech, depth = _worn_nine_bar()
    joint = worn_joint(mech, "A")[1]
    scene = MechanismScene(mech)
    scale = scene.info["wear_scale"]
    # the default scale: the 1-2-5 factor drawing the deepest wear at most a quarter of R_b
    assert scale * depth.max() <= 0.25 * joint.R1 * (1 + 1e-12)
    assert scale * depth.max() > 0.25 * joint.R1 / 2.5
    path = _node(scene, "/worn_A/profile")
    pts = np.asarray(scene.recorder.nodes[path].object.object.geometry.position, float).T
    assert pts.shape == (joint.wear.nodes + 1, 3) and np.array_equal(pts[0], pts[-1])   # a closed loop
    pts = pts[:-1]
    # float32 vertices: each coordinate within a few ulps of R_b
    ulp = 4 * np.finfo(np.float32).eps * joint.R1
    r, th = np.hypot(pts[:, 0], pts[:, 1]), np.arctan2(pts[:, 1], pts[:, 0])
    assert np.max(np.abs(r - (joint.R1 + scale * depth))) <= 2 * ulp
    assert np.max(np.abs(np.angle(np.exp(1j * (th - joint.wear.angles()))))) <= 2 * ulp / joint.R1
    assert np.all(pts[:, 2] == 0.0)
    # the deepest vertex is the pocket's centre, 60 deg from the bearing frame's x
    assert math.degrees(th[np.argmax(r)]) == pytest.approx(60.0, abs=360 / joint.wear.nodes)
    new = np.asarray(scene.recorder.nodes[_node(scene, "/worn_A/new")].object.object.geometry.position, float).T
    assert np.max(np.abs(np.hypot(new[:, 0], new[:, 1]) - joint.R1)) <= 2 * ulp
    # the loop's frame is the bearing frame where the kinematics puts it
    data = mech.model.createData()
    pin.framesForwardKinematics(mech.model, data, scene.q)
    oMf = data.oMf[clearance_frames(joint)[0]].homogeneous
    assert np.allclose(_world(scene, path), oMf, atol=1e-9)
    assert "worn bearing depth &times;" in legend({**scene.info, "clearances": ["A"]})


def test_stated_wear_scale_is_the_one_drawn():
    mech, depth = _worn_nine_bar()
    joint = worn_joint(mech, "A")[1]
    scene = MechanismScene(mech, wear_scale=100.0)
    pts = np.asarray(scene.recorder.nodes[_node(scene, "/worn_A/profile")].object.object.geometry.position,
                     float).T[:-1]
    r = np.hypot(pts[:, 0], pts[:, 1])
    assert scene.info["wear_scale"] == 100.0
    assert np.max(np.abs(r - (joint.R1 + 100.0 * depth))) <= 8 * np.finfo(np.float32).eps * joint.R1


def test_new_bearing_draws_no_worn_profile():
    mech = pinclear.load("nine_bar", clearances=["A"], overrides={"A.wear": {"k": 1e-5, "hardness": 2e9}})
    scene = MechanismScene(mech)
    assert "wear_scale" not in scene.info and not [p for p in scene.paths() if "/worn_" in p]


def test_view_command_draws_a_wear_runs_profile(tmp_path, capsys):
    mech, depth = _worn_nine_bar()
    wm = worn_joint(mech, "A")[1].wear
    _tables(tmp_path, {"A": wm}, {"A": depth}, {k: [] for k in _history_keys(["A"])})
    # profile.csv holds 9 significant digits
    assert np.allclose(read_profile(tmp_path)["A"], depth, rtol=1e-8, atol=0)
    html = tmp_path / "v.html"
    rc = view_main(["nine_bar", "--clearance", "A", "--set", WEAR, "--wear", str(tmp_path), "--wear-scale", "200",
                    "--html", str(html)])
    out = capsys.readouterr()
    assert rc == 0, out.err
    assert "worn bearings A (6.5 um deep): depth x200" in out.out
    assert "worn bearing depth &times;200" in html.read_text()
    # the profile names a joint the mechanism was not loaded with: one line naming it
    rc = view_main(["nine_bar", "--clearance", "B", "--wear", str(tmp_path), "--html", str(html)])
    err = capsys.readouterr().err
    assert rc == 2 and "'A'" in err and err.count("\n") == 1

