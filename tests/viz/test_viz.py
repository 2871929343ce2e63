"""Viewer scenes, animation keyframes and the standalone HTML (issue 5).

Reference values come from the kinematics itself, not from the viewer: a closed loop's two
closure frames coincide in space, a driven crank turns at its law's rate, the journal's
eccentricity is the distance between the bearing and journal frames.
"""
from __future__ import annotations

import glob
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest
import yaml

import pinclear
from pinclear.cli.view import view_main
from pinclear.model import kinematics
from pinclear.viz import animate, build_scene, export_html, resample
from pinclear.viz.html import find_chromium, screenshot
from pinclear.viz.scene import MechanismScene, clearance_frames

ROOT = Path(__file__).resolve().parents[2]
URDF = ROOT / "urdf"
SIDECARS = sorted(glob.glob(str(URDF / "*.yaml")))
POINT_CLOSURES = {"spherical", "revolute", "universal", "weld"}   # p1 = p2 when assembled


def _matrix(rec, path):
    node = rec.nodes.get(path)
    return np.asarray(node.transform.matrix) if node is not None and node.transform is not None else np.eye(4)


def world_matrix(scene: MechanismScene, path: str) -> np.ndarray:
    """Compose the recorded transforms along a node path, as three.js does."""
    parts = path.strip("/").split("/")
    T = np.eye(4)
    for k in range(1, len(parts) + 1):
        T = T @ _matrix(scene.recorder, "/" + "/".join(parts[:k]))
    return T


def display_to_world(scene: MechanismScene) -> np.ndarray:
    """Inverse of the root's display transform (centring + gravity-up rotation)."""
    return np.linalg.inv(_matrix(scene.recorder, f"/meshcat/{scene.root.path.entries[-1]}"))


def _clearance_names(path):
    sc = yaml.safe_load(Path(path).read_text()) or {}
    return [c["name"] for c in (sc.get("clearances") or [])]


def _assembled(mech):
    try:
        return kinematics.assemble(mech, mech.q0)
    except pinclear.PinclearError:
        return None


# ----------------------------------------------------------------------------- scene tree
@pytest.mark.slow
@pytest.mark.parametrize("sidecar", SIDECARS, ids=[Path(s).stem for s in SIDECARS])
def test_scene_has_one_node_per_body_and_closure_frames_meet(sidecar):
    mech = pinclear.load(sidecar)
    q = _assembled(mech)
    scene = build_scene(mech, q=q if q is not None else mech.q0)
    model = mech.model
    paths = set(scene.paths())
    bodies = scene.body_nodes()
    assert len(bodies) == model.njoints == len(set(bodies))
    for j, b in enumerate(bodies):
        assert b in paths
        # every moving body is drawn by at least one object below its node
        if j > 0:
            assert any(p.startswith(b + "/") and scene.recorder.nodes[p].object is not None for p in paths), b
        # the node's pose is the joint's world pose (display transform removed)
        data = model.createData()
        pin.forwardKinematics(model, data, scene.q)
        Tw = display_to_world(scene) @ world_matrix(scene, b)
        np.testing.assert_allclose(Tw, data.oMi[j].homogeneous, atol=1e-9)
    # no clearance active: no clearance overlays
    assert not [p for p in paths if "/overlays/clearance/" in p]
    if q is None:
        return
    # an assembled loop closes on screen too: the two frames of a point closure coincide
    for c in mech.closures:
        if c.type in POINT_CLOSURES:
            T1 = world_matrix(scene, [p for p in paths if p.endswith(f"/closure_{c.name}_f1")][0])
            T2 = world_matrix(scene, [p for p in paths if p.endswith(f"/closure_{c.name}_f2")][0])
            assert np.linalg.norm(T1[:3, 3] - T2[:3, 3]) < 1e-8 * max(1.0, scene.size), c.name


CLEARANCE_CASES = [(s, n) for s in SIDECARS for n in _clearance_names(s)]


@pytest.mark.parametrize("sidecar,name", CLEARANCE_CASES,
                         ids=[f"{Path(s).stem}-{n}" for s, n in CLEARANCE_CASES])
def test_active_clearance_has_overlay_nodes_with_stated_magnification(sidecar, name):
    mech = pinclear.load(sidecar, clearances=[name])
    scene = build_scene(mech, q=mech.q0, ecc_scale=250.0)
    paths = set(scene.paths())
    base = f"/meshcat/pinclear/overlays/clearance/{name}"
    for part in ("eccentricity", "normal_force", "friction_force"):
        assert f"{base}/{part}" in paths
        assert scene.recorder.nodes[f"{base}/{part}/shaft"].object is not None
    # the replaced closure's frames stay on screen
    assert any(p.endswith(f"/closure_{name}_f1") for p in paths)
    # move the joint off-centre: the eccentricity arrow is 250 x (journal - bearing)
    el = [e for e in scene.clearances if e.name == name][0]
    f1, f2 = clearance_frames(el)
    q = pin.integrate(mech.model, mech.q0, 0.05 * np.ones(mech.model.nv))
    scene.set_configuration(q)
    data = mech.model.createData()
    pin.framesForwardKinematics(mech.model, data, q)
    e = data.oMf[f2].translation - data.oMf[f1].translation
    if el.kind == "prismatic":        # only the play across the guide, not the travel along it
        z1 = data.oMf[f1].rotation[:, 2]
        e = e - np.dot(e, z1) * z1
    A = np.asarray(scene.recorder.nodes[f"{base}/eccentricity"].transform.matrix)
    np.testing.assert_allclose(A[:3, 1], 250.0 * e, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(A[:3, 3], data.oMf[f1].translation, atol=1e-12)
    assert scene.info["ecc_scale"] == 250.0


# ----------------------------------------------------------------------------- animation
@pytest.fixture(scope="module")
def nine_bar_run():
    mech = pinclear.load(URDF / "nine_bar.yaml")
    return mech, pinclear.simulate(mech, 0.5, dt_out=0.001)


def test_resample_follows_the_drive_law_at_playback_rate(nine_bar_run):
    mech, traj = nine_bar_run
    fps, slow = 24.0, 3.0
    tf, qf, nearest, fps_eff = resample(mech.model, traj.t, traj.q, fps=fps, slowdown=slow)
    assert fps_eff == pytest.approx(fps)
    assert len(tf) == int(0.5 * slow * fps) + 1
    np.testing.assert_allclose(tf, np.arange(len(tf)) / (fps * slow), atol=1e-12)
    # crank 1 is driven: theta1 = theta10 + 2 pi t (paper 002), exactly, at every frame time
    d = mech.drives[0]
    j = mech.model.getJointId(d.joint)
    iq = mech.model.joints[j].idx_q
    law = np.array([d.law.eval(t)[0] for t in tf])
    np.testing.assert_allclose(qf[:, iq], law, atol=1e-7)
    assert np.all(np.abs(traj.t[nearest] - tf) <= 0.5 * np.diff(traj.t).max() + 1e-12)
    # default playback: real time, or the smallest round factor that plays short runs >= 5 s
    from pinclear.viz.animate import auto_slowdown
    for dur in (0.01, 0.05, 0.3, 1.0, 2.0, 4.9):
        s = auto_slowdown(dur)
        mant = s / 10 ** np.floor(np.log10(s))
        assert s * dur >= 5.0 and min(abs(mant - m) for m in (1, 2, 5)) < 1e-9
        smaller = s / (2.5 if mant == 5 else 2.0)
        assert smaller * dur < 5.0
    assert auto_slowdown(5.0) == auto_slowdown(60.0) == 1.0
    # capped: long runs stay light
    tf2, *_ = resample(mech.model, traj.t, traj.q, fps=fps, slowdown=100.0, max_frames=50)
    assert len(tf2) == 50 and tf2[-1] == pytest.approx(traj.t[-1])


def test_animation_keyframes_rotate_the_crank_at_its_rate(nine_bar_run):
    mech, traj = nine_bar_run
    scene = MechanismScene(mech, traj.q[0])
    info = animate(scene, traj, fps=30.0, slowdown=2.0)
    anim = scene.recorder.animation.animation
    d = mech.drives[0]
    j = mech.model.getJointId(d.joint)
    clip = anim.clips[scene.root[scene.body_paths[j]].path]
    quat = np.array(clip.tracks["quaternion"].values)        # x, y, z, w
    frames = np.array(clip.tracks["quaternion"].frames)
    t = info["t0"] + frames / (clip.fps * info["slowdown"])
    # the crank's world orientation: rotation about the joint axis by the law's angle
    R0 = mech.model.jointPlacements[j].rotation
    for k in (0, len(t) // 3, len(t) - 1):
        ang = d.law.eval(t[k])[0]
        R = R0 @ pin.utils.rotate("z", ang)
        qk = quat[k]
        Rk = pin.Quaternion(qk[3], qk[0], qk[1], qk[2]).toRotationMatrix()
        np.testing.assert_allclose(Rk, R, atol=1e-6)


# ----------------------------------------------------------------------------- HTML / Chromium
def _coloured(png):
    from PIL import Image

    im = np.asarray(Image.open(png).convert("RGB"), float) / 255.0
    mx, mn = im.max(axis=2), im.min(axis=2)
    sat = (mx - mn) / np.maximum(mx, 1e-9)
    # the bodies' pastel colours (saturation BODY_SATURATION = 0.32, shading moves it little);
    # background, ground (0.09) and UI are grey
    return (sat > 0.18) & (mx > 0.25)


def test_html_is_offline_and_names_its_scene(nine_bar_run, tmp_path):
    mech, traj = nine_bar_run
    scene = build_scene(mech, traj, slowdown=2.0)
    html = export_html(scene, tmp_path / "run.html").read_text()
    assert "<script src" not in html and "<link" not in html
    assert "https://" not in html and "http://" not in html.replace("http://www.w3.org/1999/xhtml", "")
    assert "MeshCat.Viewer" in html and "nine_bar" in html


@pytest.mark.skipif(find_chromium() is None, reason="chromium not installed (apt-get install chromium)")
def test_html_renders_and_bodies_move_in_headless_chromium(nine_bar_run, tmp_path):
    mech, traj = nine_bar_run
    scene = build_scene(mech, traj, slowdown=2.0)
    html = export_html(scene, tmp_path / "run.html")
    size = (640, 480)
    a = _coloured(screenshot(html, tmp_path / "a.png", t=0.0, size=size))
    a2 = _coloured(screenshot(html, tmp_path / "a2.png", t=0.0, size=size))
    b = _coloured(screenshot(html, tmp_path / "b.png", t=0.25, size=size))
    npx = size[0] * size[1]
    # not blank: the mechanism covers a visible part of the picture
    assert 0.002 * npx < a.sum() < 0.5 * npx
    # rendering is deterministic: the same time gives the same picture ...
    assert (a ^ a2).sum() <= 0.002 * npx
    # ... and a quarter period later (the cranks turned by pi/2) the bodies have moved
    assert (a ^ b).sum() > 0.1 * a.sum()
    ya, xa = np.nonzero(a)
    yb, xb = np.nonzero(b)
    assert np.hypot(xa.mean() - xb.mean(), ya.mean() - yb.mean()) > 2.0 or (a ^ b).sum() > 0.3 * a.sum()
    # the page seeks simulated time, not playback time: at t = 0.25 s it shows the stored
    # configuration of t = 0.25 s (a static page of that configuration, same camera)
    k = int(np.argmin(np.abs(traj.t - 0.25)))
    still = MechanismScene(mech, traj.q[0])
    still.set_configuration(traj.q[k])
    c = _coloured(screenshot(export_html(still, tmp_path / "still.html"), tmp_path / "c.png", size=size))
    assert (b ^ c).sum() < 0.1 * (a ^ b).sum()


# ----------------------------------------------------------------------------- CLI
def test_view_cli_writes_html_for_yaml_and_npz(nine_bar_run, tmp_path, capsys):
    mech, traj = nine_bar_run
    out = tmp_path / "static.html"
    assert view_main([str(URDF / "nine_bar.yaml"), "--html", str(out)]) == 0
    assert out.stat().st_size > 100_000                 # viewer bundle inlined
    npz = traj.save(tmp_path / "run.npz")
    out2 = tmp_path / "anim.html"
    assert view_main([str(npz), "--html", str(out2), "--slowdown", "4"]) == 0
    text = capsys.readouterr().out
    assert "nine_bar: 9 bodies" in text and "slowdown 4" in text
    assert '"slowdown": 4.0' in out2.read_text()


def test_view_cli_bad_input_names_the_file(tmp_path, capsys):
    missing = tmp_path / "nope.yaml"
    assert view_main([str(missing), "--html", str(tmp_path / "x.html")]) == 2
    err = capsys.readouterr().err
    assert err.startswith("pinclear: error:") and "nope.yaml" in err
    assert view_main([str(URDF / "nine_bar.yaml"), "--clearance", "NOPE", "--html", str(tmp_path / "y.html")]) == 2
    assert "NOPE" in capsys.readouterr().err


def test_nothing_blocks_or_opens_a_browser(monkeypatch, tmp_path):
    import webbrowser

    opened = []
    monkeypatch.setattr(webbrowser, "open", lambda *a, **k: opened.append(a))
    mech = pinclear.load(URDF / "nine_bar.yaml")
    scene = pinclear.viz.show(mech, html=tmp_path / "s.html")
    assert scene.live is None and (tmp_path / "s.html").exists() and not opened


def test_live_viewer_server_holds_the_whole_scene(nine_bar_run):
    mech, traj = nine_bar_run
    scene = pinclear.viz.show(mech, traj, slowdown=2.0)       # starts a meshcat server, returns
    try:
        assert scene.live.url().startswith("http://127.0.0.1:")
        html = scene.live.static_html()
        # meshcat's server re-emits every node it keeps as one command: all of ours arrived
        assert html.count("fetch(\"data:application/octet-binary;base64,") == len(scene.recorder.packed())
    finally:
        scene.close()


def test_urdf_visuals_and_automatic_primitives_have_the_model_sizes():
    mech = pinclear.load(URDF / "nine_bar.yaml")
    L1 = [p["value"] for p in mech.parameters if p["name"] == "L1"][0]     # crank O1-A, 0.1 m
    crank = "/meshcat/pinclear/bodies/crank1"
    # URDF visual: the crank's <box size="0.1 0.025 0.01"/> is drawn as that box
    scene = build_scene(mech, q=mech.q0)
    boxes = [scene.recorder.nodes[p].object.object.geometry for p in scene.paths()
             if p.startswith(crank + "/urdf")]
    assert len(boxes) == 1 and np.allclose(boxes[0].lengths, [L1, 0.025, 0.01])
    # automatic primitives: a rod from the crank pivot to the closure frame at A, L1 long
    scene = build_scene(mech, q=mech.q0, use_urdf_visuals=False)
    rods = [scene.recorder.nodes[p].object.object.geometry for p in scene.paths()
            if p.startswith(crank + "/rod")]
    assert len(rods) == 1 and rods[0].height == pytest.approx(L1, rel=1e-12)


def test_impacts_shorter_than_a_frame_still_show_at_their_peak():
    from pinclear.viz.animate import peak_samples

    t = np.arange(0, 1.0 + 1e-12, 1e-3)
    mag = np.zeros_like(t)
    hit = 53                                   # a 1 ms impact at t = 0.053 s
    mag[hit] = 800.0
    tf = np.arange(0, 31) / 30.0               # 30 frames per second
    nearest = np.clip(np.searchsorted(t, tf), 0, len(t) - 1)
    idx = peak_samples(t, tf, mag, nearest)
    k = int(np.argmin(np.abs(tf - t[hit])))    # the frame whose window holds the impact
    assert idx[k] == hit and mag[nearest].max() == 0.0
    assert np.all(idx[np.arange(len(tf)) != k] == nearest[np.arange(len(tf)) != k])
